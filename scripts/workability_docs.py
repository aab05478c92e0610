"""Measure the shipped NDBC record's workability; write PNGs and measured.json to --out.

python scripts/workability_docs.py [--seeds 5] [--every 3] [--out /tmp/workability/docs_script]
                                   [--data-dir /tmp/twin-cells] [--workers 2]
                                   [--scheduler in-process|tcp://HOST:PORT]
                                   [--record 46097h2019_08.txt] [--compare-headings 150 180 210]
                                   [--compare-only]

1. Cells method (linear lookup, the default), every hybrid planner, on the whole record
   (`--record`, default NDBC 46097, August 2019, hourly), relative heading fixed at 150°
   (Scenario's default), then the best of 150/180/210°.
2. Cells (conservative and linear lookup) vs direct on a sample (every `--every`-th hour) for
   three planners at each of `--compare-headings` (fixed): workability of each, and the share
   of rows whose operable flag (probability ≥ 0.5) differs. `--compare-only` skips step 1 (the
   cells-vs-direct table of docs/workability.md on each record, at a reasonable cost). A scatter
   table is compared whole (`--every` samples time series only).

Not part of the tests; prints what docs/workability.md quotes.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from twin.assets import asset_path
from twin.runs.executor import Executor
from twin.runs.workability import WorkabilitySpec, run_workability
from twin.site import SiteRecord, read_record

ALL = ["pi", "wpi", "mtmp", "dwa", "conv1", "conv2", "qp"]
COMPARED = ["pi", "mtmp", "qp"]


def sample(record: SiteRecord, every: int) -> SiteRecord:
    """Every `every`-th row of a time series, its optional columns (None where absent) with it."""
    keep = np.arange(record.n)[::every]
    columns = {name: None if (value := getattr(record, name)) is None else value[keep]
               for name in ("time", "direction", "spreading", "heading", "weight")}  # fmt: skip
    return SiteRecord(hs=record.hs[keep], tp=record.tp[keep], kind=record.kind,
                      source=record.source + f", every {every}th row", skipped={},
                      **columns)  # fmt: skip


def compare_methods(
    part: SiteRecord, heading: float, args: argparse.Namespace, executor: Executor
) -> dict:
    """Cells (conservative and linear lookup) against direct runs on `part` at a fixed relative
    heading [deg]: workability of each, and per planner the rows whose operable flag differs."""
    compare: dict = {"rows": part.n, "heading": heading}
    variants = {"cells": {"method": "cells", "cell_lookup": "conservative"},
                "linear": {"method": "cells", "cell_lookup": "linear"},
                "direct": {"method": "direct"}}  # fmt: skip
    fixed = {"kind": "fixed", "headings": [heading]}
    rows = {}
    for name, fields in variants.items():
        spec = WorkabilitySpec(planners=COMPARED, seeds=args.seeds, heading=fixed, **fields)
        start = time.perf_counter()
        result = run_workability(spec, part, executor=executor, data_dir=args.data_dir,
                                 progress=True)  # fmt: skip
        took = time.perf_counter() - start
        compare[name] = {
            "workability": result.summary["workability"],
            "runs": result.runs,
            "seconds": took,
        }
        rows[name] = result.rows
    for planner in COMPARED:
        direct = rows["direct"][rows["direct"]["planner"] == planner]
        compare[planner] = {"workability_direct": compare["direct"]["workability"][planner]}
        for name in ("cells", "linear"):
            cells = rows[name][rows[name]["planner"] == planner]
            dp = cells["probability"].to_numpy() - direct["probability"].to_numpy()
            flips = cells["operable"].to_numpy() != direct["operable"].to_numpy()
            compare[planner][name] = {
                "workability": compare[name]["workability"][planner],
                "difference": compare[name]["workability"][planner]
                - compare["direct"]["workability"][planner],
                "rows_flipped": float(flips.mean()),
                "row_probability_mean_abs_difference": float(np.abs(dp).mean()),
                "rows_lower": float(np.mean(dp < 0)),
                "rows_higher": float(np.mean(dp > 0)),
            }  # fmt: skip
    return compare


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--every", type=int, default=3)
    parser.add_argument("--out", type=Path, default=Path("/tmp/workability/docs_script"))
    parser.add_argument("--data-dir", type=Path, default=Path("/tmp/twin-cells"))
    parser.add_argument("--workers", type=int, default=2)
    # in-process: one worker thread, for a busy machine where a local cluster fails to start
    parser.add_argument("--scheduler", default=None, help="default: a local cluster")
    parser.add_argument("--record", default="46097h2019_08.txt", help="a file in assets/site/")
    parser.add_argument(
        "--compare-headings",
        type=float,
        nargs="+",
        default=[150.0],
        help="relative headings [deg] of the cells-vs-direct comparison",
    )
    parser.add_argument("--compare-only", action="store_true", help="step 2 alone")
    args = parser.parse_args()
    record = read_record(asset_path("site", args.record))
    measured: dict = {"record": record.summary(), "seeds": args.seeds}
    args.out.mkdir(parents=True, exist_ok=True)
    with Executor.start(args.scheduler, n_workers=args.workers) as executor:
        common = {"seeds": args.seeds, "window_hours": [6.0, 12.0], "shift": None}
        for name, heading in (
            ()
            if args.compare_only
            else (
                ("fixed150", {"kind": "fixed", "headings": [150.0]}),
                ("best", {"kind": "best", "headings": [150.0, 180.0, 210.0]}),
            )
        ):
            spec = WorkabilitySpec(planners=ALL, heading=heading, **common)
            start = time.perf_counter()
            result = run_workability(spec, record, executor=executor, data_dir=args.data_dir,
                                     progress=True)  # fmt: skip
            took = time.perf_counter() - start
            print(f"{name}: {result.runs} runs ({result.new_runs} new) in {took:.1f} s")
            data = result.to_dict()
            measured[name] = {
                "workability": data["workability"],
                "threshold": {k: v["workability"] for k, v in data["threshold"].items()},
                "limiting": {k: v["limiting"] for k, v in data["planners"].items()},
                "windows": {k: {w: {x: s[x] for x in ("count", "length_mean", "wait_mean",
                                                      "wait_p50", "wait_p90")}
                                for w, s in v["windows"].items()}
                            for k, v in data["planners"].items()},
                "runs": result.runs, "new_runs": result.new_runs, "seconds": took,
            }  # fmt: skip
            if name == "best":
                measured[name]["headings_chosen"] = {
                    k: v.get("headings_chosen") for k, v in data["planners"].items()
                }
            for png, blob in result.pngs().items():
                (args.out / f"{name}_{png}").write_bytes(blob)
        part = record if record.kind == "scatter" else sample(record, args.every)
        for heading in args.compare_headings:
            key = "cells_vs_direct" + ("" if heading == 150.0 else f"_{heading:g}")
            measured[key] = compare_methods(part, heading, args, executor)
    (args.out / "measured.json").write_text(json.dumps(measured, indent=2) + "\n")
    print(json.dumps(measured, indent=2))


if __name__ == "__main__":
    main()
