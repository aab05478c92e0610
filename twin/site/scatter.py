"""A scatter diagram from a sea-state series: occurrences per (Hs, Tp) class.

The classes are the usual ones of published scatter diagrams, Hs in 0.5 m and Tp in 1 s steps
from 0; each class is named by its centre, and empty classes are left out. `read_scatter` reads
the table back (long form: `hs, tp, count`).

    table = scatter_table(hs, tp)          # DataFrame hs [m], tp [s], count
    table.to_csv("site_scatter.csv", index=False)
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike

from twin.errors import TwinError


def scatter_table(
    hs: ArrayLike, tp: ArrayLike, hs_step: float = 0.5, tp_step: float = 1.0
) -> pd.DataFrame:
    """Occurrences of each (Hs, Tp) class: the class [k·step, (k + 1)·step) is named by its
    centre (k + ½)·step.

    Args:
        hs: (n,) [m] significant wave heights ≥ 0.
        tp: (n,) [s] peak periods > 0.
        hs_step, tp_step: [m], [s] class widths > 0.

    Returns:
        Columns `hs` [m], `tp` [s] (class centres) and `count` (> 0), sorted by hs then tp.

    Raises:
        TwinError: different lengths, NaN, or values or steps out of range.
    """
    hs, tp = np.asarray(hs, dtype=float), np.asarray(tp, dtype=float)
    if hs.shape != tp.shape or hs.ndim != 1:
        raise TwinError(f"hs and tp: one value each per sea state, got shapes {hs.shape} and "
                        f"{tp.shape}")  # fmt: skip
    if not (np.all(hs >= 0.0) and np.all(tp > 0.0)):  # NaN fails both
        raise TwinError("hs ≥ 0 m and tp > 0 s on every sea state (no NaN)")
    if not (hs_step > 0.0 and tp_step > 0.0):
        raise TwinError(f"hs_step and tp_step > 0, got {hs_step} and {tp_step}")
    classes = pd.DataFrame({"hs": np.floor(hs / hs_step), "tp": np.floor(tp / tp_step)})
    counts = classes.value_counts().sort_index().reset_index(name="count")
    counts["hs"] = (counts["hs"] + 0.5) * hs_step
    counts["tp"] = (counts["tp"] + 0.5) * tp_step
    return counts[["hs", "tp", "count"]]
