"""Each planner's rated sea: the Hs at which its operability falls below 50 % (issue 38 item 8).

python scripts/rated_sea.py [--planners pi mtmp qp] [--tp 6 8 10 12] [--headings 180 90]
                            [--seeds 3] [--steps 6] [--hs-max 8] [--scheduler in-process]
                            [--out docs/workability/rated_sea.json]

For each planner, relative heading (180° head seas, 90° beam seas from starboard,
docs/workability.md "Conventions") and peak period Tp, the operability p(Hs) of a one-row record
is measured by direct runs (`run_workability`, method "direct", `--seeds` sea seeds, the spec's
default criterion: no joint or leg limit violated and tip error ≤ the threshold) and the Hs where
p crosses `OPERABLE_LEVEL` is found by bisection (interval halving) on [0.25, `--hs-max`] m:
`--steps` halvings leave a bracket of (hs_max − 0.25)/2^steps m; the midpoint is reported.
Bisection assumes p falls with Hs; a p that is not monotone gives one of its crossings.
Not part of the tests; prints the table docs/workability.md quotes.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from pathlib import Path

import numpy as np

from twin.runs.executor import Executor
from twin.runs.workability import OPERABLE_LEVEL, WorkabilitySpec, run_workability
from twin.site import SiteRecord

HS_LOW = 0.25  # [m] the cell grid's smallest Hs: a sea below it is not rated


def rated_hs(
    operability: Callable[[np.ndarray], np.ndarray],
    low: float,
    high: float,
    steps: int,
    n: int,
    level: float = OPERABLE_LEVEL,
) -> tuple[np.ndarray, np.ndarray]:
    """Bisect `n` operability curves at once for the Hs [m] where each falls below `level`.

    `operability(hs)` takes (n,) Hs [m] and returns (n,) operability in [0, 1], curve i at
    hs[i]. Returns (rated Hs [m], status): status 0 a crossing inside [low, high] (the final
    bracket's midpoint), −1 below `level` already at `low` (rated `low`), +1 still at or above
    `level` at `high` (rated `high`: a lower bound).
    """
    if not low < high or steps < 0 or n < 1:
        raise ValueError(f"rated_hs: need low < high, steps ≥ 0, n ≥ 1; got {low}, {high}, "
                         f"{steps}, {n}")  # fmt: skip
    lo, hi = np.full(n, float(low)), np.full(n, float(high))
    status = np.zeros(n, dtype=int)
    status[np.asarray(operability(lo)) < level] = -1
    status[(status == 0) & (np.asarray(operability(hi)) >= level)] = 1
    open_ = status == 0
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        ok = np.asarray(operability(mid)) >= level
        lo = np.where(open_ & ok, mid, lo)
        hi = np.where(open_ & ~ok, mid, hi)
    rated = np.where(status == 0, 0.5 * (lo + hi), np.where(status < 0, low, high))
    return rated, status


def operability_of(
    planner: str, heading: float, tps: np.ndarray, args: argparse.Namespace, executor: Executor
) -> Callable[[np.ndarray], np.ndarray]:
    """p(Hs) of `planner` at a fixed relative heading [deg]: curve i at Tp `tps[i]` [s]."""

    def operability(hs: np.ndarray) -> np.ndarray:
        spec = WorkabilitySpec(planners=[planner], seeds=args.seeds, method="direct",
                               heading={"kind": "fixed", "headings": [heading]},
                               window_hours=[1.0])  # fmt: skip
        record = SiteRecord(hs=np.asarray(hs, float), tp=np.asarray(tps, float), kind="scatter",
                            source="rated sea")  # fmt: skip
        rows = run_workability(spec, record, executor=executor, data_dir=args.data_dir).rows
        return rows["probability"].to_numpy()

    return operability


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--planners", nargs="+", default=["pi", "mtmp", "qp"])
    parser.add_argument("--tp", type=float, nargs="+", default=[6.0, 8.0, 10.0, 12.0])
    parser.add_argument("--headings", type=float, nargs="+", default=[180.0, 90.0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--steps", type=int, default=6)
    parser.add_argument("--hs-max", type=float, default=8.0)
    parser.add_argument("--data-dir", type=Path, default=Path("/tmp/twin-cells"))
    parser.add_argument("--scheduler", default="in-process")
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--out", type=Path, default=Path("docs/workability/rated_sea.json"))
    args = parser.parse_args()
    tps = np.asarray(args.tp)
    table: dict = {"seeds": args.seeds, "steps": args.steps, "hs_range": [HS_LOW, args.hs_max],
                   "level": OPERABLE_LEVEL, "tp": args.tp, "rated": {}}  # fmt: skip
    with Executor.start(args.scheduler, n_workers=args.workers) as executor:
        for planner in args.planners:
            for heading in args.headings:
                curve = operability_of(planner, heading, tps, args, executor)
                rated, status = rated_hs(curve, HS_LOW, args.hs_max, args.steps, tps.size)
                table["rated"][f"{planner} {heading:g}"] = {
                    "hs": [round(float(v), 3) for v in rated],
                    "status": status.tolist(),
                }
                print(planner, heading, table["rated"][f"{planner} {heading:g}"], flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(table, indent=2) + "\n")


if __name__ == "__main__":
    main()
