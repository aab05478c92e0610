"""Calibrate the seas of PAPER_PRESETS["seed000"] and ["seed004"] to the papers' own severity.

python scripts/calibrate_presets.py [--seeds 50] [--headings 185 190 … 230] [--check]

Seeds 000 and 004 do not publish their base trajectories, only what they did to the legs, so
the sea is matched to those numbers (docs/reproduction.md, "Calibrated seas"):

1. Sea shape: the SOV, JONSWAP γ = 3.3, 200 components, long-crested, Tp = 6.85 s (WMO sea
   state 4's); the wave height Hs and the heading are calibrated, nothing else. Seeds:
   `CALIBRATION_SEEDS` (0-49) by default; docs/reproduction.md reports on the held-out
   `REPORT_SEEDS` (50-149).
2. Seed 000: for each candidate heading, Hs by the secant method such that PI's leg maximum
   (Table 7: 4.243 m), averaged over sea seeds 0 … n−1 (200 s, the first 10 samples left out
   as Table 7), is met to 0.5 mm. Of the headings where PI's q2 drifts up as Table 7's does
   (q2 max 14.93° against min −2.11°: mean q2 max > |mean q2 min|), the one whose WPI leg
   maximum is nearest Table 7's 4.102 m is taken. Two knobs (Hs, heading) fit two numbers
   (PI's and WPI's leg maxima): neither is a prediction.
3. Seed 004: at that heading, Hs such that conventional method 1's leg maximum (4.71 m),
   averaged over the same seeds (50 s from seed 004's raised start), is met to 0.5 mm: one
   knob, one number.

`--check` runs only the presets as they are and fails (exit 1) when a mean is more than 3 %
off its target. A run of 200 s takes some 30 ms; with 50 seeds, 10 headings and a few secant
steps each, a calibration took about 10 minutes on 2 shared cores.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from twin.sim import PAPER_PRESETS, Scenario, simulate_many
from twin.sim.presets import CALIBRATION_SEEDS

#: Seed 000 Table 7: leg maxima [m] of PI and WPI.
TABLE7_LEGS = {"pi": 4.243, "wpi": 4.102}
#: Seed 004 §4: conventional method 1's leg maximum [m].
SEED004_LEGS = 4.71
#: [m] how closely the secant meets a target
TOLERANCE = 5e-4
#: [-] the largest relative miss `--check` accepts
CHECK = 0.03
HEADINGS = tuple(float(h) for h in range(185, 235, 5))
#: [s] peak period of every calibrated sea: WMO sea state 4's (docs/sea.md)
TP = 6.85


@dataclass(frozen=True)
class Means:
    """Means over sea seeds of one planner's run: leg maximum [m], q2 max and min [deg]."""

    legs_max: float
    q2_max: float
    q2_min: float


def means(base: Scenario, planner: str, seeds: range, **sea: float) -> Means:
    """`base` with `planner`, Tp = `TP` and `sea` (hs, heading) over `seeds`: the means of
    their Table 7 extremes."""
    runs = simulate_many(
        base.model_copy(update={"planner": planner, "seed": s, "tp": TP, **sea}) for s in seeds
    )
    table = [r.metrics["table7"] for r in runs]
    return Means(*(float(np.mean([t[k] for t in table])) for k in ("legs_max", "q2_max", "q2_min")))


def secant(f: Callable[[float], float], a: float, b: float, tol: float = TOLERANCE) -> float:
    """x with |f(x)| ≤ tol from the two guesses a, b (f monotonic near the root)."""
    fa, fb = f(a), f(b)
    for _ in range(20):
        if abs(fb) <= tol:
            return b
        a, fa, b = b, fb, max(0.05, b - fb * (b - a) / (fb - fa))
        fb = f(b)
    raise RuntimeError(f"secant: no root within {tol} after 20 steps (last x = {b:.4f})")


def match_hs(base: Scenario, planner: str, target: float, seeds: range, heading: float) -> float:
    """[m] Hs at which `planner`'s mean leg maximum is `target` [m]."""

    def miss(hs: float) -> float:
        return means(base, planner, seeds, hs=hs, heading=heading).legs_max - target

    return secant(miss, 1.0, 1.6)


def calibrate(seeds: range, headings: tuple[float, ...]) -> tuple[float, float, float] | None:
    """(heading [deg], seed 000's Hs [m], seed 004's Hs [m]), printing what it tried; None
    when no heading drives PI's q2 up (the table is still printed)."""
    seed000 = PAPER_PRESETS["seed000"]
    print("Seed 000: Hs for PI's Table 7 leg maximum, per heading")
    print(" heading   Hs [m]   PI legs   WPI legs   PI q2 max / min [deg]")
    best: tuple[float, float, float] | None = None  # (WPI miss, heading, hs)
    for heading in headings:
        hs = match_hs(seed000, "pi", TABLE7_LEGS["pi"], seeds, heading)
        pi = means(seed000, "pi", seeds, hs=hs, heading=heading)
        wpi = means(seed000, "wpi", seeds, hs=hs, heading=heading)
        upward = pi.q2_max > abs(pi.q2_min)
        print(
            f" {heading:7.1f}  {hs:7.4f}  {pi.legs_max:8.4f}  {wpi.legs_max:9.4f}   "
            f"{pi.q2_max:6.2f} / {pi.q2_min:6.2f}{'' if upward else '  (q2 drifts down)'}"
        )
        miss = abs(wpi.legs_max - TABLE7_LEGS["wpi"])
        if upward and (best is None or miss < best[0]):
            best = (miss, heading, hs)
    if best is None:
        print("No heading drives PI's q2 up as Table 7 does; widen --headings.")
        return None
    _, heading, hs000 = best
    seed004 = PAPER_PRESETS["seed004"].model_copy(update={"heading": heading})
    hs004 = match_hs(seed004, "conv1", SEED004_LEGS, seeds, heading)
    print(f"Seed 004 at {heading:.1f}°: Hs {hs004:.4f} m for method 1's 4.71 m")
    return heading, hs000, hs004


def check(seeds: range) -> bool:
    """Whether the presets meet their targets within `CHECK`, printing the means."""
    cases = [
        ("seed000", "pi", TABLE7_LEGS["pi"]),
        ("seed000", "wpi", TABLE7_LEGS["wpi"]),
        ("seed004", "conv1", SEED004_LEGS),
    ]
    ok = True
    for preset, planner, target in cases:
        got = means(PAPER_PRESETS[preset], planner, seeds).legs_max
        miss = got / target - 1.0
        ok = ok and abs(miss) <= CHECK
        print(
            f"{preset} {planner:5s} legs max {got:.4f} m, target {target} m ({100 * miss:+.2f} %)"
        )
    return ok


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--seeds", type=int, default=len(CALIBRATION_SEEDS), help="sea seeds 0 … n−1"
    )
    parser.add_argument("--headings", type=float, nargs="+", default=HEADINGS, help="[deg]")
    parser.add_argument("--check", action="store_true", help="only check the presets")
    args = parser.parse_args()
    seeds = range(args.seeds)
    if args.check:
        sys.exit(0 if check(seeds) else 1)
    found = calibrate(seeds, tuple(args.headings))
    if found is None:
        sys.exit(1)
    heading, hs000, hs004 = found
    print(
        f"\nPAPER_PRESETS (twin/sim/presets.py): heading {heading:g}°, tp {TP} s;\n"
        f"  seed000 hs = {hs000:.3f} m, seed004 hs = {hs004:.3f} m"
    )


if __name__ == "__main__":
    main()
