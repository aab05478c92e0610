"""Engine before/after check: dump every planner's series and metrics, then compare two dumps.

A refactor of the engine (issue 41) must leave its numbers unchanged. `dump OUT.pkl` runs every
planner of every mechanism (2 seeds, joint limits `record` and `hold`, WMO 5, 20 s) and pickles
each run's series and metrics; `compare BEFORE.pkl AFTER.pkl` prints the worst absolute
difference over every series value and float metric, lists any other metric that differs, and
exits 1 when the worst difference exceeds `--tol` (1e-12 by default).

    python scripts/engine_dump.py dump /tmp/before.pkl     # on the old commit
    python scripts/engine_dump.py dump /tmp/after.pkl      # on the new one
    python scripts/engine_dump.py compare /tmp/before.pkl /tmp/after.pkl
"""

from __future__ import annotations

import argparse
import pickle
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np


def scenarios() -> list[dict[str, Any]]:
    """Every planner of every mechanism, seeds 0 and 1, both joint-limit modes, WMO 5, 20 s."""
    from twin.planners.registry import PLANNERS

    out = []
    for mechanism in ("hybrid", "upu3up", "upr4"):
        for name in sorted(n for n, p in PLANNERS.items() if mechanism in p.mechanisms):
            for seed in (0, 1):
                for joint_limits in ("record", "hold"):
                    out.append({"mechanism": mechanism, "planner": name, "seed": seed,
                                "sea_state": 5.0, "duration": 20.0,
                                "joint_limits": joint_limits})
    return out


def dump(path: Path) -> None:
    """Run `scenarios()` and pickle (scenario, series, metrics) per run to `path`."""
    from twin.sim import simulate_many

    chosen = scenarios()
    runs = simulate_many(chosen)
    out = [(s, {k: np.asarray(v) for k, v in r.series.items()}, r.metrics)
           for s, r in zip(chosen, runs, strict=True)]
    path.write_bytes(pickle.dumps(out))
    n_series = sum(len(series) for _, series, _ in out)
    print(f"{len(out)} runs, {n_series} series, "
          f"{sum(v.size for _, ser, _ in out for v in ser.values())} values -> {path}")


def leaves(value: Any, prefix: str = "") -> Iterator[tuple[str, Any]]:
    """(path, leaf) of a nested dict/list of metrics."""
    if isinstance(value, dict):
        for key, item in value.items():
            yield from leaves(item, f"{prefix}/{key}")
    elif isinstance(value, list | tuple):
        for i, item in enumerate(value):
            yield from leaves(item, f"{prefix}/{i}")
    else:
        yield prefix, value


def compare(before: Path, after: Path, tol: float) -> int:
    """Print the worst difference of two dumps; 0 when within `tol` and nothing else differs."""
    a = pickle.loads(before.read_bytes())
    b = pickle.loads(after.read_bytes())
    if [s for s, _, _ in a] != [s for s, _, _ in b]:
        print("the dumps hold different scenarios")
        return 1
    worst, other = 0.0, 0
    for (scenario, series_a, metrics_a), (_, series_b, metrics_b) in zip(a, b, strict=True):
        if series_a.keys() != series_b.keys():
            print("series differ in names:", scenario["planner"],
                  sorted(series_a.keys() ^ series_b.keys()))
            other += 1
        for key in series_a.keys() & series_b.keys():
            x, y = series_a[key], series_b[key]
            if x.shape != y.shape:
                print("shape differs", scenario["planner"], key, x.shape, y.shape)
                other += 1
            elif x.size and np.issubdtype(x.dtype, np.number):
                same_nan = np.isnan(x) == np.isnan(y)
                other += int(not same_nan.all())
                worst = max(worst, float(np.nanmax(np.abs(x - y), initial=0.0)))
        la, lb = dict(leaves(metrics_a)), dict(leaves(metrics_b))
        for key, value in la.items():
            new = lb.get(key)
            if isinstance(value, float) and isinstance(new, float):
                if not (np.isnan(value) and np.isnan(new)):
                    worst = max(worst, abs(value - new))
            elif value != new:
                print("differs", scenario["mechanism"], scenario["planner"], key, value, new)
                other += 1
    print(f"{len(a)} runs; worst absolute difference {worst:.3g}; {other} other differences")
    return 0 if worst <= tol and other == 0 else 1


def main(argv: list[str] | None = None) -> int:
    """Command line: `dump OUT` or `compare BEFORE AFTER [--tol]`."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    d = sub.add_parser("dump", help="run the scenarios and pickle their results")
    d.add_argument("out", type=Path)
    c = sub.add_parser("compare", help="compare two dumps")
    c.add_argument("before", type=Path)
    c.add_argument("after", type=Path)
    c.add_argument("--tol", type=float, default=1e-12)
    args = parser.parse_args(argv)
    if args.command == "dump":
        dump(args.out)
        return 0
    return compare(args.before, args.after, args.tol)


if __name__ == "__main__":
    sys.exit(main())
