"""Build assets/site/north_sea_coastdat2_2014_scatter.csv from the shipped coastDat-2 year.

The hindcast gives Hs and the mean zero-up-crossing period Tz per hour; the scatter diagram is
Hs × Tp, Tp from Tz for the JONSWAP sea the twin runs (`twin.sea.tp_from_tz` with DNV's γ,
docs/decisions.md "A North Sea scatter diagram from coastDat-2"). Deterministic: running it again
writes the same file (tests/site/test_scatter.py checks the shipped one).

    python scripts/build_site_scatter.py
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from twin.assets import asset_path
from twin.sea import tp_from_tz
from twin.site.scatter import scatter_table

SOURCE = ("sources", "coastDat2_oneyear.csv")
TARGET = "north_sea_coastdat2_2014_scatter.csv"


def build(source: Path | None = None) -> pd.DataFrame:
    """The scatter table of the coastDat-2 year at `source` (default: the shipped file)."""
    series = pd.read_csv(source or asset_path("site", *SOURCE), sep=";")
    hs = series["Significant wave height(m)"].to_numpy()
    tz = series["Zero-up-crossing period(s)"].to_numpy()
    return scatter_table(hs, tp_from_tz(hs, tz))


def main() -> None:
    path = asset_path("site", TARGET)
    table = build()
    table.to_csv(path, index=False)
    print(f"{path}: {len(table)} classes, {int(table['count'].sum())} hours")


if __name__ == "__main__":
    main()
