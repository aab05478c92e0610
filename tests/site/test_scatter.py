"""Scatter diagrams from a series: hand-counted classes, and the shipped North Sea diagram is the
one its build script makes from the shipped coastDat-2 year."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from tests.site.support import script_module
from twin.assets import asset_path
from twin.errors import TwinError
from twin.site import read_record
from twin.site.scatter import scatter_table


def test_classes_are_counted_by_their_centres() -> None:
    """A series is binned into 0.5 m × 1 s classes, each including its lower edge, and listed by
    class centre with its count."""
    hs = [0.1, 0.4, 0.5, 1.74, 0.2]
    tp = [5.2, 5.9, 5.0, 7.99, 6.0]
    table = scatter_table(hs, tp)
    # [0, 0.5) × [5, 6): 0.1/5.2 and 0.4/5.9; [0.5, 1) × [5, 6): 0.5/5.0 (a class includes its
    # lower edge); [1.5, 2) × [7, 8): 1.74/7.99; [0, 0.5) × [6, 7): 0.2/6.0
    assert table.to_dict("list") == {
        "hs": [0.25, 0.25, 0.75, 1.75], "tp": [5.5, 6.5, 5.5, 7.5], "count": [2, 1, 1, 1]
    }  # fmt: skip


@pytest.mark.parametrize(
    ("hs", "tp", "message"),
    [([1.0, np.nan], [5.0, 6.0], "no NaN"), ([1.0], [5.0, 6.0], "shapes"), ([1.0], [0.0], "tp")],
)
def test_bad_series_are_refused(hs: list[float], tp: list[float], message: str) -> None:
    """A series with NaN, mismatched shapes or a non-positive Tp is a TwinError saying which."""
    with pytest.raises(TwinError, match=message):
        scatter_table(hs, tp)


def test_the_shipped_north_sea_scatter_is_rebuilt_from_the_shipped_hindcast() -> None:
    """The shipped North Sea scatter is exactly what its script builds from the shipped
    coastDat2 hindcast: 8,760 hours, its top class the hindcast's largest Hs."""
    module = script_module("build_site_scatter")
    shipped = pd.read_csv(asset_path("site", "north_sea_coastdat2_2014_scatter.csv"))
    pd.testing.assert_frame_equal(module.build(), shipped)
    record = read_record(asset_path("site", "north_sea_coastdat2_2014_scatter.csv"))
    assert record.kind == "scatter" and record.weight is not None
    assert record.weight.sum() == 8760  # every hour of 2014
    hindcast = pd.read_csv(asset_path("site", "sources", "coastDat2_oneyear.csv"), sep=";")
    assert record.hs.max() == np.floor(hindcast.iloc[:, 2].max() / 0.5) * 0.5 + 0.25
