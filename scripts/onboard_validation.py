"""Validate the wave buoy analogy (`twin.motion.estimate`) on motion of known seas; write the table
docs/onboard.md quotes.

python scripts/onboard_validation.py [--out docs/onboard] [--window 1200] [--rate 10]
                                     [--headings 12] [--seed 0]

For each sea (Hs 0.5-4 m, Tp 5-14 s, `SEAS`), each relative heading (every 360/--headings
degrees) and each sensor set (all six motions; heave-roll-pitch alone), a --window-long motion
log of the SOV is made with the twin's own sea and vessel (`twin.sea.wave_components`, JONSWAP
γ 3.3, long-crested, 800 components as a Scenario's; `twin.vessel.vessel_motion` at zero
speed), sampled at --rate with white sensor noise and a constant bias (`NOISE`, `BIAS`), and
estimated. Errors: Hs and Tp relative, the direction on the circle; for heave-roll-pitch alone
also modulo the port/starboard mirror (β ↔ −β). Beside it netsse's spectral-residual method
(Brodtkorb et al. 2018, `netsse.analys.sawb.specres`, long-crested, amplitude of the same Welch
cross-spectra and |RAO| of the same table) on the heave-roll-pitch set: Hs, Tp
(`spec1d_to_params`) and its direction folded to 0-180° (netsse decides port/starboard and
head/following by sign tests in its own phase convention, so only |β| is compared).

Writes validation.csv (every case) and summary.json to --out; prints the markdown table.
Not part of the tests.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import types
from pathlib import Path

import numpy as np
import pandas as pd

from twin.motion.estimate import EstimateRefused, cross_spectra, estimate_sea
from twin.sea.synthesis import wave_components
from twin.vessel import DOFS, interpolate_raos, load_raos, vessel_motion

# netsse's tools module imports geopy for great-circle distances, which the spectral-residual
# method never calls; geopy is not a dependency of the twin, so an empty stand-in lets it import
sys.modules.setdefault("geopy", types.ModuleType("geopy"))
sys.modules["geopy"].distance = None  # type: ignore[attr-defined]
from netsse.analys.sawb import specres  # noqa: E402
from netsse.analys.spec import spec1d_to_params  # noqa: E402

#: (Hs [m], Tp [s]): calm to rough, short wind sea to long swell
SEAS = [(0.5, 5.0), (0.5, 14.0), (1.0, 6.0), (1.5, 8.0), (2.0, 10.0), (2.5, 11.0),
        (3.0, 12.0), (4.0, 14.0)]  # fmt: skip
#: white sensor noise per motion [m, m, m, rad, rad, rad]: an MRU's stated accuracy
NOISE = np.array([0.02, 0.02, 0.02, np.radians(0.01), np.radians(0.01), np.radians(0.02)])
#: constant sensor bias per motion [m, m, m, rad, rad, rad] (the yaw: a compass heading offset)
BIAS = np.array([0.1, -0.05, 0.05, np.radians(0.3), np.radians(-0.2), np.radians(40.0)])
SETS = {"6-DOF": (), "heave-roll-pitch": ("surge", "sway", "yaw")}
#: the table's pass criteria (issue 40 item 5)
HS_TOL, TP_TOL, DIR_TOL = 0.15, 0.10, 20.0
HRP = [DOFS.index(n) for n in ("heave", "roll", "pitch")]


def log(hs: float, tp: float, beta: float, seed: int, args: argparse.Namespace) -> tuple:
    """(t, motion) of the SOV in a long-crested sea, noise and bias added."""
    sea = wave_components(hs, tp, heading=np.radians(beta), seed=seed, n_components=800)
    t = np.arange(0.0, args.window, 1.0 / args.rate)
    motion = vessel_motion(sea, RAOS, t)
    rng = np.random.default_rng(seed + 7919)
    return t, motion + NOISE * rng.standard_normal(motion.shape) + BIAS


def on_circle(a: float, b: float) -> float:
    """|a − b| on the circle [deg], 0-180."""
    return float(abs((a - b + 180.0) % 360.0 - 180.0))


def netsse_estimate(t: np.ndarray, motion: np.ndarray) -> tuple[float, float, float]:
    """(Hs, Tp, |β|) by netsse's spectral-residual method on heave, roll, pitch."""
    spectra = cross_spectra(t, motion, np.array(HRP))
    p = spectra.phi
    rxy = np.stack([p[:, 0, 0], p[:, 1, 1], p[:, 2, 2], p[:, 0, 1], p[:, 0, 2], p[:, 1, 2]], 1)
    beta = np.arange(0.0, 181.0, 5.0)
    H = interpolate_raos(RAOS, spectra.omega[:, None], np.radians(beta)[None, :])
    trf = np.concatenate([np.abs(H[..., DOFS.index(n)]) for n in ("heave", "roll", "pitch")], 1)
    s_wave, beta_est, _ = specres(rxy, trf, spectra.omega, beta)
    params = spec1d_to_params(np.maximum(s_wave, 0.0), spectra.omega, unit_freq="rad/s")
    return float(params[1]), float(params[2]), float(abs(beta_est))


def case(hs: float, tp: float, beta: float, sensors: str, seed: int,
         args: argparse.Namespace) -> dict:  # fmt: skip
    """One estimate against its truth (and netsse's on heave-roll-pitch)."""
    t, motion = log(hs, tp, beta, seed, args)
    for name in SETS[sensors]:
        motion[:, DOFS.index(name)] = np.nan
    row: dict = {"hs": hs, "tp": tp, "beta": beta, "sensors": sensors}
    start = time.perf_counter()
    try:
        e = estimate_sea(t, motion, RAOS)
    except EstimateRefused as exc:
        return row | {"refused": str(exc)}
    row |= {"seconds": time.perf_counter() - start, "refused": "", "hs_est": e.hs,
            "hs_sd": e.hs_sd, "tp_est": e.tp, "tp_sd": e.tp_sd, "dir_est": e.direction,
            "dir_sd": e.direction_sd, "mirror": e.mirror, "ambiguous": e.ambiguous,
            "misfit": e.misfit, "hs_err": e.hs / hs - 1.0, "tp_err": e.tp / tp - 1.0,
            "dir_err": on_circle(e.direction, beta),
            "dir_err_mod_mirror": min(on_circle(e.direction, beta),
                                      on_circle(e.direction, -beta))}  # fmt: skip
    if sensors == "heave-roll-pitch":
        n_hs, n_tp, n_beta = netsse_estimate(t, motion)
        folded = on_circle(abs(on_circle(beta, 0.0)), 0.0)
        row |= {"netsse_hs": n_hs, "netsse_tp": n_tp, "netsse_abs_dir": n_beta,
                "netsse_hs_err": n_hs / hs - 1.0, "netsse_tp_err": n_tp / tp - 1.0,
                "netsse_dir_err": abs(n_beta - folded)}  # fmt: skip
    return row


def summary(table: pd.DataFrame) -> pd.DataFrame:
    """Per sea and sensor set: worst errors over the headings and the share passing all three."""
    done = table[table["refused"] == ""].copy()
    done["dir_used"] = np.where(done["sensors"] == "6-DOF", done["dir_err"],
                                done["dir_err_mod_mirror"])  # fmt: skip
    done["pass"] = ((done["hs_err"].abs() < HS_TOL) & (done["tp_err"].abs() < TP_TOL)
                    & (done["dir_used"] < DIR_TOL))  # fmt: skip
    groups = done.groupby(["sensors", "hs", "tp"], sort=False)
    out = groups.agg(cases=("pass", "size"), passed=("pass", "mean"),
                     hs_err=("hs_err", lambda v: v.abs().max()),
                     tp_err=("tp_err", lambda v: v.abs().max()),
                     dir_err=("dir_err", "max"), dir_err_mod_mirror=("dir_err_mod_mirror", "max"),
                     seconds=("seconds", "max"))  # fmt: skip
    refused = table[table["refused"] != ""].groupby(["sensors", "hs", "tp"]).size()
    out["refused"] = refused.reindex(out.index).fillna(0).astype(int)
    if "netsse_hs_err" in done:
        hrp = done.groupby(["sensors", "hs", "tp"], sort=False)
        out["netsse_hs_err"] = hrp["netsse_hs_err"].agg(lambda v: v.abs().max())
        out["netsse_tp_err"] = hrp["netsse_tp_err"].agg(lambda v: v.abs().max())
        out["netsse_dir_err"] = hrp["netsse_dir_err"].max()
    return out.reset_index()


def markdown(table: pd.DataFrame) -> str:
    """A markdown table of `table`, numbers to 3 significant digits (no tabulate needed)."""

    def cell(v: object) -> str:
        return f"{v:.3g}" if isinstance(v, float) else str(v)

    lines = ["| " + " | ".join(table.columns) + " |", "|" + " --- |" * len(table.columns)]
    lines += ["| " + " | ".join(cell(v) for v in row) + " |" for row in table.itertuples(False)]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("docs/onboard"))
    parser.add_argument("--window", type=float, default=1200.0, help="[s] log length")
    parser.add_argument("--rate", type=float, default=10.0, help="[Hz] sampling rate")
    parser.add_argument("--headings", type=int, default=12, help="relative headings")
    parser.add_argument("--seed", type=int, default=0, help="first sea seed")
    args = parser.parse_args()
    rows = []
    for k, (hs, tp) in enumerate(SEAS):
        for j, beta in enumerate(np.arange(0.0, 360.0, 360.0 / args.headings)):
            for sensors in SETS:
                rows.append(case(hs, tp, float(beta), sensors,
                                 args.seed + 100 * k + j, args))  # fmt: skip
        print(f"Hs {hs} m Tp {tp} s done", flush=True)
    table = pd.DataFrame(rows)
    args.out.mkdir(parents=True, exist_ok=True)
    table.to_csv(args.out / "validation.csv", index=False, float_format="%.5g")
    result = summary(table)
    (args.out / "summary.json").write_text(json.dumps(result.to_dict(orient="records"),
                                                      indent=1) + "\n")  # fmt: skip
    print(markdown(result))


RAOS = load_raos("sov")

if __name__ == "__main__":
    main()
