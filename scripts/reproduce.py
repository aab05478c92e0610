"""Reproduce the papers' tables with the twin; write docs/reproduction.md and its PNG plots.

python scripts/reproduce.py [--seeds 5] [--out docs] [--processes 2]   (needs the `docs` extra)

Runs the reference scenarios (hybrid system on the SOV, WMO sea state 4, JONSWAP, one heading
for every planner, 200 s at dt = 0.05 s, seeds 0 … n−1), seed 004's own set-up (platform
raised 1.1 m, 50 s), seed 002's regular-wave states on the 4-UPR, and the kinematic tables of
seeds 001 and 002; then writes the report beside the papers' numbers. Not part of the tests.
"""

from __future__ import annotations

import argparse
import datetime
import multiprocessing
import time
from collections.abc import Callable, Sequence
from itertools import pairwise
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")  # files only, no display
import matplotlib.pyplot as plt
import numpy as np
from tqdm import tqdm

from twin.mechanisms import HybridBoardingSystem, Upr4, Upu3Up
from twin.planners import PLANNERS, PlannerParameters
from twin.sim import Scenario, simulate
from twin.sim.metrics import SETTLE
from twin.spatial import invert_transform, pose_to_transform, se3_log

# ---------------------------------------------------------------------------------------------
# Scenarios
# ---------------------------------------------------------------------------------------------

#: [deg] the one wave heading of every hybrid run (150° bow-quartering; see `HEADING_NOTE`).
HEADING = 150.0
#: [deg] the alternative measured for MTMP only, to justify the choice.
HEADING_ALT = 180.0
REFERENCE: dict[str, Any] = {
    "mechanism": "hybrid",
    "sea_state": 4,
    "spectrum": "jonswap",
    "heading": HEADING,
    "duration": 200.0,  # seed 000 §5.3: 200 s at 0.05 s
    "dt": 0.05,
}
#: Seed 004 §4: platform raised 1.1 m from its lowest state (z = 1.525 + 1.1 m), gangway
#: perpendicular to the bow, horizontal, extended 3.5 m; a 50 s base trajectory.
SEED004_STATE = [0.0, 0.0, 2.625, 0.0, 0.0, 0.0, 0.0, 0.0, 13.052]
SEED004 = {**REFERENCE, "duration": 50.0, "initial_state": SEED004_STATE}
HYBRID_PLANNERS = ("pi", "wpi", "mtmp", "dwa", "conv1", "conv2")
DIFFERENTIAL = ("pi", "wpi", "mtmp")
ALLOCATION = ("conv1", "conv2", "dwa")
PLATFORM_PLANNERS = ("pid", "ik")
WAVE_STATES = ("state1", "state2", "state3")
#: [s] seed 002 §5: "All the tests were conducted over 30 s".
UPR4_DURATION = 30.0
#: seed whose time series are plotted
PLOT_SEED = 0

# ---------------------------------------------------------------------------------------------
# The papers' numbers
# ---------------------------------------------------------------------------------------------

#: Seed 000 Table 3 (PI) and Table 4 (WPI, β = 0.7): PṖx,y,z [cm/s], w_px,y,z [°/s],
#: q̇1, q̇2 [°/s], ḋ3 [cm/s].
TABLE3 = np.array(
    [
        [-6.34, -8.89, -5.43, 2.80, -3.36, 0.45, 0.45, -1.31, -2.93],
        [-7.37, -11.09, -6.28, 2.86, -3.45, 0.46, 0.46, -1.18, -3.40],
        [-8.30, -13.19, -7.18, 2.91, -3.26, 0.47, 0.47, -1.04, -3.82],
    ]
)
TABLE4 = np.array(
    [
        [-6.39, -8.90, -5.48, 2.80, -3.66, 0.63, 0.27, -1.34, -2.72],
        [-7.44, -11.10, -6.32, 2.86, -3.48, 0.64, 0.28, -1.21, -3.17],
        [-8.39, -13.21, -7.22, 2.90, -3.29, 0.65, 0.28, -1.07, -3.57],
    ]
)
VELOCITY_COLUMNS = ("PṖx", "PṖy", "PṖz", "w_px", "w_py", "w_pz", "q̇1", "q̇2", "ḋ3")
#: table units per SI unit: cm/s for m/s, °/s for rad/s
VELOCITY_SCALE = np.array([100, 100, 100, *([np.degrees(1.0)] * 5), 100])
#: Seed 000 Table 7: q1, q2 [°], d3 [m], legs [m]; (max, min) per method.
TABLE7 = {
    "pi": {
        "q1": (0.63, -0.73), "q2": (14.93, -2.11), "d3": (13.075, 12.403), "legs": (4.243, 2.616)
    },
    "wpi": {
        "q1": (0.31, -0.42), "q2": (8.11, -2.44), "d3": (13.068, 12.729), "legs": (4.102, 2.707)
    },
    "mtmp": {
        "q1": (1.04, -1.25), "q2": (0.54, -0.47), "d3": (13.238, 12.876), "legs": (3.953, 2.729)
    },
}  # fmt: skip
#: Seed 004 §4: leg max [m], manipulability min, φe and θe maxima [°] (None: not printed).
SEED004_PAPER = {
    "conv1": {"legs_max": 4.71, "manip": 27.78, "phi": 0.0, "theta": 0.0},
    "conv2": {"legs_max": None, "manip": 44.51, "phi": -4.25, "theta": -4.35},
    "dwa": {"legs_max": None, "manip": 39.73, "phi": -2.94, "theta": -2.84},
}
#: Seed 001 Table 3 (eq 13) and Table 2 (Newton-Raphson): (α, β [°], z [mm]) →
#: (X_p, Y_p, Z_p [mm], α_p, β_p [°]).
SEED001_INPUTS = [(5.0, 5.0, 0.0), (5.0, 0.0, 30.0), (0.0, 5.0, 30.0), (5.0, 5.0, 30.0)]
SEED001_TABLE3 = np.array(
    [
        [90.6420, -90.2971, 1032.0962, 5.0000, 5.0000],
        [0.0000, -93.2566, 1065.9342, 5.0000, 0.0000],
        [93.2566, 0.0000, 1065.9342, 0.0000, 5.0000],
        [93.2566, -92.9018, 1061.8684, 5.0000, 5.0000],
    ]
)
SEED001_TABLE2 = np.array(
    [
        [90.6413, -90.3200, 1032.2488, 5.0000, 5.0000],
        [0.0041, -93.2276, 1065.7433, 4.9993, 0.0006],
        [93.2416, -0.0003, 1065.8653, -0.0002, 4.9995],
        [93.2161, 92.8308, 1061.6206, 4.9974, 5.0180],
    ]
)
#: Seed 001 §IV.D: maximum coupled displacement [mm] of trajectories P1-P4.
SEED001_COUPLED = {"P1": 7.9594, "P2": 4.0471, "P3": 4.1346, "P4": 8.1706}
#: Seed 002 Table 2: η [%] per wave state.
SEED002_ETA = {"state1": 98.23, "state2": 97.16, "state3": 94.84}
SEED002_WAVES = {
    "state1": "0.2 m, 3 s, [1,1]",
    "state2": "0.2; 0.3 m, 5; 3 s, [1,0]; [0,1]",
    "state3": "0.2; 0.3; 0.4 m, 7; 5; 3 s, [1,0]; [0,1]; [1,1]",
}

# ---------------------------------------------------------------------------------------------
# Workers (run in the pool; each returns plain data)
# ---------------------------------------------------------------------------------------------

Job = tuple[str, str, int]  # (variant, planner, seed or wave state index)


def joint_velocities(xi: np.ndarray, dt: float) -> np.ndarray:
    """Virtual-joint velocities (N − 1, 9) that carried xi[k] to xi[k + 1].

    The platform pose moves on SE(3) by exp of its body twist (`HybridBoardingSystem.integrate`),
    so log(T_k⁻¹ T_k+1)/dt recovers the applied [ᴾṖ; ω_P] exactly; the gangway joints are
    plain differences.
    """
    T = pose_to_transform(xi[:, :6])
    twist = se3_log(invert_transform(T[:-1]) @ T[1:]) / dt
    return np.concatenate([twist, np.diff(xi[:, 6:], axis=0) / dt], axis=1)


def velocity_claims(v: np.ndarray, beta: float) -> dict[str, float]:
    """Shares [%] of samples where seed 000 §4.1's overlap and reverse-compensation claims hold.

    Overlap (a): w_pz and q̇1 have the same sign; PI: equal; WPI: ratio β/(1 − β) (their
    J_task columns are equal, so a weighted minimum-norm solution splits by the weights).
    Reverse (b): sign(w_py) = sign(q̇2), i.e. the two turn the gangway tip opposite ways
    (positive w_py lowers the tip, positive q̇2 raises it, in our frames as in the paper's).
    Samples where either velocity is below 1e-9 rad/s count as "no sign".
    """
    v = v[SETTLE:]
    eps, rel = 1e-9, 1e-6
    w_pz, q1d, w_py, q2d = v[:, 5], v[:, 6], v[:, 4], v[:, 7]

    def share(mask: np.ndarray, of: np.ndarray) -> float:
        n = int(np.sum(of))
        return float(100 * np.sum(mask & of) / n) if n else float("nan")  # nan: no samples

    both = (np.abs(w_pz) > eps) & (np.abs(q1d) > eps)
    every = np.ones_like(both)

    def ratio_is(r: float) -> np.ndarray:
        return np.abs(w_pz - r * q1d) <= rel * np.maximum(np.abs(w_pz), np.abs(r * q1d)) + eps

    signed = (np.abs(w_py) > eps) & (np.abs(q2d) > eps)
    ratio = w_pz[both] / q1d[both]
    return {
        "overlap_sign": share(np.sign(w_pz) == np.sign(q1d), both),
        "ratio_1": share(ratio_is(1.0), every),
        "ratio_beta": share(ratio_is(beta / (1 - beta)), every),
        "w_pz_zero": share(np.abs(w_pz) <= 1e-6, every),
        "ratio_median": float(np.median(ratio)) if ratio.size else float("nan"),
        "reverse": share(np.sign(w_py) == np.sign(q2d), signed),
        "w_py_rms": float(np.degrees(np.sqrt(np.mean(w_py**2)))),
        "q2_rms": float(np.degrees(np.sqrt(np.mean(q2d**2)))),
        "samples": float(v.shape[0]),
    }


def run_job(job: Job) -> tuple[Job, dict[str, Any]]:
    """Run one scenario; return its metrics, claim shares and, for plots, a few series."""
    variant, planner, index = job
    if variant == "upr4":
        scenario = {
            "mechanism": "upr4",
            "planner": planner,
            "regular_waves": WAVE_STATES[index],
            "duration": UPR4_DURATION,
        }
    else:
        base = SEED004 if variant == "seed004" else REFERENCE
        heading = HEADING_ALT if variant == "alt" else HEADING
        scenario = {**base, "planner": planner, "seed": index, "heading": heading}
    result = simulate(scenario)
    out: dict[str, Any] = {"metrics": result.metrics}
    s = result.series
    if variant == "upr4":
        out["series"] = {k: s[k] for k in ("t", "alpha_top", "alpha_bottom", "state")}
        return job, out
    if planner in DIFFERENTIAL:
        v = joint_velocities(s["xi"], result.scenario.dt)
        out["claims"] = velocity_claims(v, result.scenario.beta)
    if variant == "ref" and index == PLOT_SEED:
        keep = ("t", "xi", "legs", "manipulability", "phi_e", "theta_e")
        out["series"] = {k: s[k] for k in keep}
        if planner in DIFFERENTIAL:
            out["series"]["velocity"] = v
    return job, out


# ---------------------------------------------------------------------------------------------
# Formatting
# ---------------------------------------------------------------------------------------------


def stats(values: Sequence[float], digits: int = 3, kind: str = "f") -> str:
    """'mean ± std' (sample std) of per-seed values; '—' if any is undefined (nan).

    `kind` is the format type: "f" fixed, "g" significant digits (for tiny errors).
    """
    x = np.asarray(values, dtype=float)
    if np.any(np.isnan(x)):
        return "—"
    std = x.std(ddof=1) if x.size > 1 else 0.0
    return f"{x.mean():.{digits}{kind}} ± {std:.{digits}{kind}}"


def spread(values: Sequence[float], digits: int = 3, kind: str = "f") -> str:
    """'min … max' of per-seed values."""
    x = np.asarray(values, dtype=float)
    return f"{x.min():.{digits}{kind}} … {x.max():.{digits}{kind}}"


def table(header: Sequence[str], rows: Sequence[Sequence[Any]]) -> str:
    """A Markdown table."""
    lines = ["| " + " | ".join(header) + " |", "|" + " --- |" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


def paper(value: float | None, digits: int = 3) -> str:
    """A paper's number, '—' where it prints none."""
    return "—" if value is None else f"{value:.{digits}f}"


def num(value: float, digits: int) -> str:
    """A number, '—' if undefined (nan)."""
    return "—" if np.isnan(value) else f"{value:.{digits}f}"


# ---------------------------------------------------------------------------------------------
# Plots
# ---------------------------------------------------------------------------------------------


def plot_legs(runs: dict, hybrid: HybridBoardingSystem, path: Path) -> None:
    """Stewart legs over time for PI, WPI, MTMP (one seed), with the Table 1 stroke."""
    fig, axes = plt.subplots(3, 1, figsize=(10, 8), sharex=True, sharey=True)
    for ax, planner in zip(axes, DIFFERENTIAL, strict=True):
        s = runs[("ref", planner, PLOT_SEED)]["series"]
        ax.plot(s["t"], s["legs"], lw=0.7)
        for limit in (hybrid.stewart.leg_min, hybrid.stewart.leg_max):
            ax.axhline(limit, color="k", ls="--", lw=1)
        ax.set_ylabel(f"{planner.upper()} legs [m]")
    axes[0].legend([f"l{i + 1}" for i in range(6)], ncol=6, fontsize=8, loc="upper left")
    axes[-1].set_xlabel("t [s]")
    fig.suptitle(f"Stewart legs, seed {PLOT_SEED}, stroke 2.58-4.18 m (dashed)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_gangway(runs: dict, hybrid: HybridBoardingSystem, path: Path) -> None:
    """q1, q2, d3 over time for PI, WPI, MTMP (one seed), with the Table 6 limits."""
    fig, axes = plt.subplots(3, 1, figsize=(10, 8), sharex=True)
    labels = ("q1 [°]", "q2 [°]", "d3 [m]")
    for j, (ax, label) in enumerate(zip(axes, labels, strict=True)):
        scale = 1.0 if j == 2 else np.degrees(1.0)
        for planner in DIFFERENTIAL:
            s = runs[("ref", planner, PLOT_SEED)]["series"]
            ax.plot(s["t"], s["xi"][:, 6 + j] * scale, lw=0.8, label=planner.upper())
        for limit in (hybrid.lower[6 + j], hybrid.upper[6 + j]):
            ax.axhline(limit * scale, color="k", ls="--", lw=1)
        ax.set_ylabel(label)
    axes[0].legend(fontsize=8)
    axes[-1].set_xlabel("t [s]")
    fig.suptitle(f"Gangway joints, seed {PLOT_SEED}; Table 6 limits dashed")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_allocation(runs: dict, path_manip: Path, path_attitude: Path) -> None:
    """Manipulability and end attitude angles φe, θe for conv1, conv2, DWA (one seed)."""
    fig, ax = plt.subplots(figsize=(10, 4))
    for planner in ALLOCATION:
        s = runs[("ref", planner, PLOT_SEED)]["series"]
        ax.plot(s["t"], s["manipulability"], lw=0.8, label=planner)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("manipulability √det(J Jᵀ)")
    ax.legend()
    ax.set_title(f"Stewart manipulability, seed {PLOT_SEED}")
    fig.tight_layout()
    fig.savefig(path_manip, dpi=110)
    plt.close(fig)
    fig, axes = plt.subplots(2, 1, figsize=(10, 6), sharex=True)
    for ax, key, label in zip(axes, ("phi_e", "theta_e"), ("φe [°]", "θe [°]"), strict=True):
        for planner in ALLOCATION:
            s = runs[("ref", planner, PLOT_SEED)]["series"]
            ax.plot(s["t"], np.degrees(s[key]), lw=0.8, label=planner)
        ax.set_ylabel(label)
    axes[0].legend()
    axes[-1].set_xlabel("t [s]")
    fig.suptitle(f"End attitude angles (change from t = 0), seed {PLOT_SEED}")
    fig.tight_layout()
    fig.savefig(path_attitude, dpi=110)
    plt.close(fig)


def plot_upr4_tilt(runs: dict, planners: Sequence[str], path: Path) -> None:
    """4-UPR top vs bottom tilt α for wave states 1-3."""
    fig, axes = plt.subplots(3, 1, figsize=(10, 8), sharex=True)
    for i, ax in enumerate(axes):
        s0 = runs[("upr4", planners[0], i)]["series"]
        ax.plot(s0["t"], np.degrees(s0["alpha_bottom"]), color="k", lw=1, label="α bottom (ASV)")
        for planner in planners:
            s = runs[("upr4", planner, i)]["series"]
            ax.plot(s["t"], np.degrees(s["alpha_top"]), lw=0.9, label=f"α top ({planner})")
        ax.set_ylabel(f"wave {WAVE_STATES[i]} [°]")
    axes[0].legend(fontsize=8, ncol=3)
    axes[-1].set_xlabel("t [s]")
    fig.suptitle("4-UPR: tilt of the base (ASV deck) and of the top platform")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_workspace(ws: Any, path: Path) -> None:
    """Feasible roll × pitch set at z = 0.5 m with eq (28)'s circle and Table 1's π/9."""
    fig, ax = plt.subplots(figsize=(5.5, 5))
    r, p = np.degrees(ws.roll), np.degrees(ws.pitch)
    ax.contourf(r, p, ws.feasible.T.astype(float), levels=[0.5, 1.5], colors=["tab:green"])
    phi = np.linspace(0, 2 * np.pi, 361)
    for radius, style, label in (
        (ws.circle_radius, "-", f"eq (28) circle, ours {np.degrees(ws.circle_radius):.2f}°"),
        (np.pi / 9, "--", "Table 1: π/9 = 20°"),
    ):
        rho = np.degrees(radius)
        ax.plot(rho * np.cos(phi), rho * np.sin(phi), "k", ls=style, lw=1, label=label)
    ax.set_xlim(-30, 30)
    ax.set_ylim(-30, 30)
    ax.set_aspect("equal")
    ax.set_xlabel("roll [°]")
    ax.set_ylabel("pitch [°]")
    ax.legend(fontsize=8, loc="upper right")
    ax.set_title(f"4-UPR workspace at z = {ws.z} m (green: feasible)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


# ---------------------------------------------------------------------------------------------
# Sections
# ---------------------------------------------------------------------------------------------


def metric(runs: dict, variant: str, planner: str, seeds: range, get: Callable) -> list[float]:
    """One metric per seed."""
    return [float(get(runs[(variant, planner, s)]["metrics"])) for s in seeds]


def section_summary(runs: dict, seeds: range, upr4_planners: Sequence[str]) -> str:
    """The papers' qualitative claims, one line each, with our verdict from the runs."""
    n = len(seeds)

    def seeds_with(planner: str, variant: str = "ref") -> int:
        return sum(runs[(variant, planner, s)]["metrics"]["violations"] > 0 for s in seeds)

    def claim(planner: str, key: str) -> float:
        return float(np.mean([runs[("ref", planner, s)]["claims"][key] for s in seeds]))

    def better(variant: str) -> tuple[int, int]:
        up = down = 0
        for s in seeds:
            m = {p: runs[(variant, p, s)]["metrics"] for p in ALLOCATION}
            up += m["dwa"]["manipulability_min"] > m["conv1"]["manipulability_min"]
            down += all(abs(m["dwa"][k]) < abs(m["conv2"][k]) for k in ("phi_e_max", "theta_e_max"))
        return up, down

    up, down = better("ref")
    up4, down4 = better("seed004")
    rows = [
        [
            "000 §5.3",
            "PI and WPI leave a Table 6 / leg limit",
            f"PI on {seeds_with('pi')}/{n} seeds, WPI on {seeds_with('wpi')}/{n}",
        ],
        [
            "000 §5.3",
            "MTMP stays inside all limits",
            f"on {n - seeds_with('mtmp')}/{n} seeds (at {HEADING_ALT:.0f}°: "
            f"{n - seeds_with('mtmp', 'alt')}/{n}); MTMP does not guard the leg stroke",
        ],
        [
            "000 Table 3",
            "PI overlap: w_pz = q̇1",
            f"on {claim('pi', 'ratio_1'):.1f} % of samples",
        ],
        [
            "000 Table 4",
            "WPI overlap: same sign, ratio β/(1 − β)",
            f"on {claim('wpi', 'ratio_beta'):.1f} % of samples",
        ],
        [
            "000 Tables 3–4",
            "reverse compensation: sign w_py = sign q̇2",
            f"PI {claim('pi', 'reverse'):.1f} %, WPI {claim('wpi', 'reverse'):.1f} % of samples",
        ],
        [
            "000 §6",
            "MTMP removes overlap / reverse compensation",
            f"overlap removed (w_pz = 0 on {claim('mtmp', 'w_pz_zero'):.1f} %); signs still "
            f"agree on {claim('mtmp', 'reverse'):.1f} % (q2 no longer drifts)",
        ],
        [
            "004 §4",
            "DWA raises the minimum manipulability against conv1",
            f"{up}/{n} seeds (seed 004 set-up: {up4}/{n})",
        ],
        [
            "004 §4",
            "DWA lowers the max abs φe and θe against conv2",
            f"{down}/{n} seeds (seed 004 set-up: {down4}/{n})",
        ],
    ]
    for planner in upr4_planners:
        etas = [runs[("upr4", planner, i)]["metrics"]["eta"] for i in range(len(WAVE_STATES))]
        falls = all(a > b for a, b in pairwise(etas))
        rows.append(
            [
                "002 Table 2",
                f"η falls from wave state 1 to 3 (`{planner}`)",
                ("yes: " if falls else "no: ") + " → ".join(f"{x:.2f}" for x in etas) + " %",
            ]
        )
    if not upr4_planners:
        rows.append(["002 Table 2", "η falls from wave state 1 to 3", "not yet run"])
    rows += [
        ["001 Table 3", "ideal pose from eq 13", "X, Y, angles exact; Z within 6 µm (paper slip)"],
        [
            "002 Table 1",
            "roll, pitch limits ±π/9 at z = 0.5 m",
            "on a 2° or 10° grid; exact ±20.705°",
        ],
    ]
    return f"""## Claims at a glance

{table(["paper", "claim", "ours"], rows)}
"""


def section_scenarios(runs: dict, seeds: range) -> str:
    """The reference scenario, the heading choice and its numbers."""
    scenario = Scenario(**{**REFERENCE, "planner": "mtmp"})
    hs, tp = scenario.sea()
    p = PlannerParameters()
    rows = []
    for variant, heading in (("ref", HEADING), ("alt", HEADING_ALT)):
        for s in seeds:
            m = runs[(variant, "mtmp", s)]["metrics"]
            rows.append(
                [
                    f"{heading:.0f}°",
                    s,
                    m["violations"],
                    f"{m['table7']['legs_max']:.3f}",
                    f"{m['table7']['legs_min']:.3f}",
                    f"{1e3 * m['tip_position_error_max']:.2f}",
                ]
            )
    bad = {
        v: sum(runs[(v, "mtmp", s)]["metrics"]["violations"] > 0 for s in seeds)
        for v in ("ref", "alt")
    }
    others = {
        planner: sum(runs[("ref", planner, s)]["metrics"]["violations"] for s in seeds)
        for planner in ("dwa", "conv2")
    }
    others_tip = 1e3 * max(
        runs[("ref", planner, s)]["metrics"]["tip_position_error_max"]
        for s in seeds
        for planner in ("dwa", "conv2")
    )
    setup = [
        [
            "vessel, mount",
            "`sov` (70.5 m walk-to-work SOV, RAOs `assets/vessels/sov.nc`), the hybrid system's "
            "default mount: midships, 5.5 m to starboard, Stewart base 10 m above the waterline, "
            "base x to starboard (the gangway at q1 = 0 is perpendicular to the bow, as in "
            "seed 004)",
        ],
        [
            "sea",
            f"WMO sea state 4 → Hs = {hs:.3f} m, Tp = {tp:.2f} s; JONSWAP γ = {scenario.gamma:g}, "
            f"long-crested, {scenario.n_components} components, random phases from `seed`",
        ],
        [
            "heading",
            f"{HEADING:.0f}° (waves 30° off the bow, bow-quartering), the same for every "
            "hybrid planner",
        ],
        [
            "time",
            f"{REFERENCE['duration']:.0f} s at dt = {REFERENCE['dt']} s (seed 000 §5.3); the "
            f"first {SETTLE} samples are left out of min/max (as seed 000)",
        ],
        [
            "seeds",
            f"{seeds.start} … {seeds.stop - 1}; tables give mean ± sample std and "
            "(min … max) over seeds",
        ],
        [
            "initial state",
            "Table 5 working state: platform z = 2.475 m, level; q1 = q2 = 0; d3 = 13.052 m",
        ],
        [
            "planner knobs",
            f"defaults: k_e = {p.k_e:g} 1/s, β = {p.beta:g}, l = {p.l:g}, k_c = {p.k_c:g}, "
            f"σ = {p.sigma:g}°, q̇1,max = {p.q1_rate_max:g}°/s, k_a2 = {p.k_a2:g} 1/s, "
            f"damping λ_max = {p.damping:g}",
        ],
    ]
    heading_header = [
        "heading",
        "seed",
        "MTMP violations [samples]",
        "legs max [m]",
        "legs min [m]",
        "tip error max [mm]",
    ]
    return f"""## Reference scenarios

The papers do not publish their input trajectories (seed 000 Fig. 8 and seed 004 Fig. 6 are
plots of a "randomly simulated" base motion; seed 002 names only its regular waves). We
therefore drive every planner with the same named sea, vessel and mount, not tuned per planner:

{table(["", ""], setup)}

**Heading.** 150° is the scenario default and the realistic W2W case: at 180° (head seas,
long-crested) the SOV has no roll, sway or yaw, which removes the motions a gangway finds
hardest. We measured MTMP at both over the seeds:

{table(heading_header, rows)}

At {HEADING:.0f}° MTMP leaves a leg limit on {bad["ref"]} of {len(seeds)} seeds, at
{HEADING_ALT:.0f}° on {bad["alt"]}. But the {HEADING:.0f}° sea is within what a planner can do: on
the same seeds DWA and conv2 hold every joint and leg inside its limits (total violations
{others["dwa"]} and {others["conv2"]} samples), with the tip position within
{others_tip:.2g} mm. So no seed "exceeds what any planner can do"; MTMP's violations are a
property of MTMP (its joint-limit weights guard the Table 6 virtual joints, not the leg
stroke; see Table 7), and we keep {HEADING:.0f}° for every planner.
"""


def section_tables34(runs: dict, seeds: range) -> str:
    """Seed 000 Tables 3 and 4: overlap and reverse compensation."""
    beta = PlannerParameters().beta
    pi = runs[("ref", "pi", PLOT_SEED)]["series"]
    wpi = runs[("ref", "wpi", PLOT_SEED)]["series"]
    ours_pi = pi["velocity"] * VELOCITY_SCALE
    ours_wpi = wpi["velocity"] * VELOCITY_SCALE
    # The moment most like the paper's: three consecutive PI samples nearest to Table 3's rows
    # (sum of squares in table units); WPI is shown at the same instants.
    windows = np.lib.stride_tricks.sliding_window_view(ours_pi[SETTLE:], (3, 9))[:, 0]
    k = SETTLE + int(np.argmin(np.sum((windows - TABLE3) ** 2, axis=(1, 2))))
    t = pi["t"][k : k + 3]

    def rows(values: np.ndarray, label: str) -> list[list[str]]:
        out = []
        for i, row in enumerate(values):
            ratio = row[5] / row[6] if row[6] != 0 else float("nan")
            same = "same" if np.sign(row[4]) == np.sign(row[7]) else "opposite"
            out.append([f"{label} {i + 1}", *(f"{x:.2f}" for x in row), f"{ratio:.3f}", same])
        return out

    header = ["row", *VELOCITY_COLUMNS, "w_pz/q̇1", "sign w_py vs q̇2"]
    body = (
        rows(TABLE3, "paper PI")
        + rows(ours_pi[k : k + 3], f"ours PI t={t[0]:.2f}+")
        + rows(TABLE4, "paper WPI")
        + rows(ours_wpi[k : k + 3], f"ours WPI t={t[0]:.2f}+")
    )
    share_rows = []
    for planner in DIFFERENTIAL:
        for s in seeds:
            c = runs[("ref", planner, s)]["claims"]
            share_rows.append(
                [
                    planner.upper(),
                    s,
                    num(c["overlap_sign"], 1),
                    num(c["ratio_1"], 1),
                    num(c["ratio_beta"], 1),
                    num(c["w_pz_zero"], 1),
                    num(c["ratio_median"], 3),
                    num(c["reverse"], 1),
                    num(c["w_py_rms"], 3),
                    num(c["q2_rms"], 3),
                ]
            )
    share_header = [
        "planner",
        "seed",
        "w_pz, q̇1 same sign",
        "w_pz = q̇1",
        "w_pz = β/(1−β)·q̇1",
        "w_pz = 0",
        "median w_pz/q̇1",
        "sign w_py = sign q̇2",
        "w_py RMS [°/s]",
        "q̇2 RMS [°/s]",
    ]
    summary = {
        planner: {
            key: stats([runs[("ref", planner, s)]["claims"][key] for s in seeds], 1)
            for key in ("overlap_sign", "ratio_1", "ratio_beta", "w_pz_zero", "reverse", "q2_rms")
        }
        for planner in DIFFERENTIAL
    }
    mtmp_share = float(np.mean([runs[("ref", "mtmp", s)]["claims"]["reverse"] for s in seeds]))
    if mtmp_share > 50:
        mtmp_reverse = (
            "MTMP does **not** remove it in the sign sense in our runs (w_py and q̇2 still share "
            "a sign on most samples); what its q2 task (eqs 39–40) does is hold q2 near its "
            "start, so q2 no longer drifts (Table 7)."
        )
    else:
        mtmp_reverse = "MTMP removes it: w_py and q̇2 share a sign on a minority of samples."
    return f"""### Tables 3 and 4 — virtual joint velocities of PI and WPI (β = {beta:g})

The paper prints three rows of velocities at an unnamed moment of its own trajectory, so the
values cannot be reproduced; its claims are qualitative: **(a) overlap** — PI gives
w_pz = q̇1 exactly, WPI the same sign with a different value (Table 4's ratio is
0.63/0.27 = 2.33 = β/(1 − β)); **(b) reverse compensation** — sign(w_py) = sign(q̇2), so the
platform's pitch and the luffing turn the gangway tip opposite ways. Below: the paper's rows
and ours at the three consecutive samples of seed {PLOT_SEED} nearest to Table 3 (sum of squared
differences in table units; velocities recovered from the recorded states,
`log(T_k⁻¹ T_k+1)/dt`, which is exactly what the integrator applied). Units: cm/s and °/s.

{table(header, body)}

Share of samples (after the first {SETTLE}) where each claim holds, per seed [%]. "Same sign"
counts samples where both w_pz and q̇1 are nonzero (> 1e-9 rad/s); ratios hold to 1e-6
relative; "w_pz = 0" means |w_pz| ≤ 1e-6 rad/s.

{table(share_header, share_rows)}

Across seeds: PI w_pz = q̇1 on {summary["pi"]["ratio_1"]} % of samples; WPI ratio β/(1 − β) on
{summary["wpi"]["ratio_beta"]} % (same sign {summary["wpi"]["overlap_sign"]} %); MTMP w_pz = 0 on
{summary["mtmp"]["w_pz_zero"]} %. sign(w_py) = sign(q̇2): PI {summary["pi"]["reverse"]} %, WPI
{summary["wpi"]["reverse"]} %, MTMP {summary["mtmp"]["reverse"]} %; RMS q̇2: PI
{summary["pi"]["q2_rms"]}, WPI {summary["wpi"]["q2_rms"]}, MTMP {summary["mtmp"]["q2_rms"]} °/s.

**Reading.** (a) Overlap is reproduced exactly, on every sample: J_task's columns for w_pz and
q̇1 are equal (the slew axis is the platform's z axis), so any (weighted) minimum-norm solution
splits their common rate by the weights, 1 : 1 for PI and β : (1 − β) for WPI. It is a
property of the solver, not of the trajectory. MTMP's Algorithm 1 hands the sum to the slew
joint, so w_pz = 0 while q1 is inside its flexible range: the overlap is removed, as the paper
claims. (b) Reverse compensation is reproduced too: with PI and WPI, w_py and q̇2 have the same
sign on nearly every sample, so the platform's pitch and the luffing fight each other over the
tip's height. {mtmp_reverse} The paper's claim that MTMP "solves" reverse compensation rests
on its Figs. 13–14, not on a velocity table.
"""


def section_table7(runs: dict, seeds: range, hybrid: HybridBoardingSystem) -> str:
    """Seed 000 Table 7 plus violations and drift."""
    quantities = [
        ("q1 max [°]", "q1", 0, lambda m: m["table7"]["q1_max"], 2),
        ("q1 min [°]", "q1", 1, lambda m: m["table7"]["q1_min"], 2),
        ("q2 max [°]", "q2", 0, lambda m: m["table7"]["q2_max"], 2),
        ("q2 min [°]", "q2", 1, lambda m: m["table7"]["q2_min"], 2),
        ("d3 max [m]", "d3", 0, lambda m: m["table7"]["d3_max"], 3),
        ("d3 min [m]", "d3", 1, lambda m: m["table7"]["d3_min"], 3),
        ("legs max [m]", "legs", 0, lambda m: m["table7"]["legs_max"], 3),
        ("legs min [m]", "legs", 1, lambda m: m["table7"]["legs_min"], 3),
    ]
    rows = []
    for label, key, i, get, digits in quantities:
        row = [label]
        for planner in DIFFERENTIAL:
            values = metric(runs, "ref", planner, seeds, get)
            row += [
                f"{TABLE7[planner][key][i]:.{digits}f}",
                f"{stats(values, digits)} ({spread(values, digits)})",
            ]
        rows.append(row)
    extra = [
        ("violations [samples of 4001]", lambda m: m["violations"], 0),
        ("leg violations [samples]", lambda m: m["leg_violations"], 0),
        ("joint violations [samples]", lambda m: m["joint_violations"], 0),
        ("drift q1 [°]", lambda m: m["joints"]["q1"]["drift"], 2),
        ("drift q2 [°]", lambda m: m["joints"]["q2"]["drift"], 2),
        ("drift d3 [m]", lambda m: m["joints"]["d3"]["drift"], 3),
        ("drift z [m]", lambda m: m["joints"]["z"]["drift"], 3),
        ("drift yaw [°]", lambda m: m["joints"]["yaw"]["drift"], 2),
        ("max abs leg drift [m]", lambda m: max(abs(d) for d in m["leg_drift"]), 3),
        ("leg margin [m] (< 0: outside)", lambda m: m["leg_margin"], 3),
    ]
    for label, get, digits in extra:
        row = [label]
        for planner in DIFFERENTIAL:
            values = metric(runs, "ref", planner, seeds, get)
            row += ["—", f"{stats(values, digits)} ({spread(values, digits)})"]
        rows.append(row)
    seeds_bad = {
        planner: sum(v > 0 for v in metric(runs, "ref", planner, seeds, lambda m: m["violations"]))
        for planner in DIFFERENTIAL
    }
    header = ["quantity"] + [f"{p.upper()} {w}" for p in DIFFERENTIAL for w in ("paper", "ours")]
    lo, hi = hybrid.lower, hybrid.upper

    def mean(planner: str, get: Callable) -> float:
        return float(np.mean(metric(runs, "ref", planner, seeds, get)))

    def drift_of(name: str) -> Callable:
        return lambda m: m["joints"][name]["drift"]

    mtmp_margin = min(metric(runs, "ref", "mtmp", seeds, lambda m: m["leg_margin"]))
    mtmp_yaw, mtmp_q1 = mean("mtmp", drift_of("yaw")), mean("mtmp", drift_of("q1"))
    mtmp_q1_max = max(metric(runs, "ref", "mtmp", seeds, lambda m: m["table7"]["q1_max"]))
    legs_max = {p: mean(p, lambda m: m["table7"]["legs_max"]) for p in DIFFERENTIAL}
    q2_drift = {p: mean(p, drift_of("q2")) for p in DIFFERENTIAL}
    d3_drift = {p: mean(p, drift_of("d3")) for p in DIFFERENTIAL}
    d3_min = {p: mean(p, lambda m: m["table7"]["d3_min"]) for p in DIFFERENTIAL}
    d3_max = {p: mean(p, lambda m: m["table7"]["d3_max"]) for p in DIFFERENTIAL}
    start_d3 = hybrid.working_state[8]
    top = np.r_[0.0, 0.0, hi[2], 0.0, 0.0, 0.0, hybrid.working_state[6:]]
    legs_top = float(hybrid.leg_lengths(top).max())
    rolled = hybrid.working_state.copy()
    rolled[3] = hi[3]
    legs_roll = float(hybrid.leg_lengths(rolled).min())
    reproduces = (
        f"The paper's ordering. PI and WPI leave the leg stroke on {seeds_bad['pi']} and "
        f"{seeds_bad['wpi']} of {len(seeds)} seeds (mean legs max {legs_max['pi']:.3f} and "
        f"{legs_max['wpi']:.3f} m; paper 4.243 and 4.102 m), WPI less than PI, and their joints "
        f"drift (§5.3 analysis 1): q2 by {q2_drift['pi']:+.1f}° (PI) and {q2_drift['wpi']:+.1f}° "
        f"(WPI), d3 by {d3_drift['pi']:+.3f} and {d3_drift['wpi']:+.3f} m, so their d3 range is "
        f"one-sided (min ≈ the start {start_d3:.3f} m). MTMP's q2 stays near its start "
        f"(drift {q2_drift['mtmp']:+.2f}°) and its d3 works both ways about the start, "
        f"{d3_min['mtmp']:.3f} … {d3_max['mtmp']:.3f} m (paper 12.876 … 13.238 m): "
        '"MTMP can take advantage of d3" (§5.3). MTMP\'s legs max '
        f"{legs_max['mtmp']:.3f} m (paper 3.953 m)."
    )
    return f"""### Table 7 — joint extremes over 200 s

Limits: q1, q2 ∈ [{np.degrees(lo[6]):.0f}°, {np.degrees(hi[6]):.0f}°], d3 ∈ [{lo[8]:.3f},
{hi[8]:.3f}] m (Table 6 about Table 5's working state, SPEC erratum 3), legs ∈
[{hybrid.stewart.leg_min:.2f}, {hybrid.stewart.leg_max:.2f}] m (Table 1). Ours: mean ± std
(min … max) over {len(seeds)} seeds; violations count samples with any joint or leg outside its
limit; drift is the least-squares trend over the run (slope × duration).

{table(header, rows)}

Seeds with any violation: PI {seeds_bad["pi"]}/{len(seeds)}, WPI {seeds_bad["wpi"]}/{len(seeds)},
MTMP {seeds_bad["mtmp"]}/{len(seeds)}.

![Stewart legs, PI / WPI / MTMP](reproduction/legs_pi_wpi_mtmp.png)

![Gangway joints, PI / WPI / MTMP](reproduction/gangway_joints.png)

**What reproduces.** {reproduces}

**What differs, and why.**
- *Magnitudes.* Our sea-state-4 base motion on the SOV is not the paper's random trajectory
  (unpublished; its Fig. 8 gives no numbers), so extremes differ in size and the direction of
  PI's and WPI's q2 drift (ours down, the paper's up) is the trajectory's. The SOV's roll and
  the mount 5.5 m off the centreline and 10 m up turn roll into heave and sway of the base,
  which the platform takes (β = 0.7).
- *MTMP and the legs.* MTMP's joint-limit weights (eqs 35–37) act on the nine virtual joints
  and their Table 6 box; the legs are not virtual joints. Table 6's box is larger than the
  legs' reachable set (level at z = {hi[2]:.3f} m the legs are already {legs_top:.3f} m; a
  30° roll at the working height needs {legs_roll:.3f} m), so MTMP can drive a leg out of its
  stroke while every virtual joint is far from its limit: here on
  {seeds_bad["mtmp"]}/{len(seeds)} seeds, by up to {-mtmp_margin:.3f} m. The paper's single
  trajectory did not show this.
- *q1 and yaw under MTMP.* Algorithm 1 gives the body yaw rate w_pz to the slew joint (w_pz = 0
  on every sample above), yet the platform's Euler yaw still turns through cycles of roll and
  pitch (rotations do not commute), and q1 turns back to hold the tip's heading: MTMP's yaw
  and q1 drift by {mtmp_yaw:+.2f}° and {mtmp_q1:+.2f}° (mean; sum {mtmp_yaw + mtmp_q1:+.3f}°),
  which is why our q1 range (max {mtmp_q1_max:.2f}°) is one-sided and wider than the paper's
  ±1.2°. (Had the paper integrated w_p as Euler-angle rates, its yaw could not drift this
  way.) It is far from ±30° in 200 s; a run long enough to reach the σ band would see
  Algorithm 1 hand the yaw back to the platform; no MTMP task holds the platform's yaw angle.
- *Our choices that shape the numbers* (docs/decisions.md, twin/planners): c_i = q_max − q_min
  in eq 35 (the paper's "constant factor"), σ = 5° and q̇1,max = 10°/s (not given), k_a2 = 1/s,
  damped least squares (λ_max = 0.05) and joint rate limits `HYBRID_RATE_LIMITS` (not in the
  paper), a one-step-predicted target twist, rotation-vector orientation error (SPEC erratum 6).
"""


def section_seed004(runs: dict, seeds: range) -> str:
    """Seed 004: conv1, conv2, DWA on the reference scenario and on seed 004's set-up."""
    get = {
        "legs_max": lambda m: m["table7"]["legs_max"],
        "manip": lambda m: m["manipulability_min"],
        "abs_phi": lambda m: abs(m["phi_e_max"]),
        "abs_theta": lambda m: abs(m["theta_e_max"]),
        "violations": lambda m: m["violations"],
    }
    header = [
        "method",
        "legs max paper [m]",
        "ours",
        "manip. min paper",
        "ours",
        "max abs φe paper [°]",
        "ours",
        "max abs θe paper [°]",
        "ours",
        "violations (seeds)",
    ]

    def block(variant: str) -> tuple[str, dict[str, dict[str, list[float]]]]:
        values: dict[str, dict[str, list[float]]] = {}
        rows = []
        for planner in ALLOCATION:
            v = {k: metric(runs, variant, planner, seeds, g) for k, g in get.items()}
            values[planner] = v
            ref = SEED004_PAPER[planner]
            bad = sum(x > 0 for x in v["violations"])
            rows.append(
                [
                    planner,
                    paper(ref["legs_max"], 2),
                    f"{stats(v['legs_max'])} ({spread(v['legs_max'])})",
                    paper(ref["manip"], 2),
                    f"{stats(v['manip'], 2)} ({spread(v['manip'], 2)})",
                    paper(abs(ref["phi"]), 2),
                    f"{stats(v['abs_phi'], 2)} ({spread(v['abs_phi'], 2)})",
                    paper(abs(ref["theta"]), 2),
                    f"{stats(v['abs_theta'], 2)} ({spread(v['abs_theta'], 2)})",
                    f"{stats(v['violations'], 0)} ({bad}/{len(seeds)})",
                ]
            )
        return table(header, rows), values

    ref_table, ref = block("ref")
    own_table, own = block("seed004")

    def claims(v: dict) -> str:
        n = len(seeds)
        dwa, conv1, conv2 = v["dwa"], v["conv1"], v["conv2"]
        manip = [100 * (d / c - 1) for d, c in zip(dwa["manip"], conv1["manip"], strict=True)]
        phi = [100 * (1 - d / c) for d, c in zip(dwa["abs_phi"], conv2["abs_phi"], strict=True)]
        theta = [
            100 * (1 - d / c) for d, c in zip(dwa["abs_theta"], conv2["abs_theta"], strict=True)
        ]
        up = sum(x > 0 for x in manip)
        down = sum(a > 0 and b > 0 for a, b in zip(phi, theta, strict=True))
        return (
            f"Claims: DWA's minimum manipulability is {stats(manip, 1)} % above conv1's (paper "
            f"+43 %), higher on {up}/{n} seeds; DWA lowers conv2's max |φe| by {stats(phi, 1)} % "
            f"and max |θe| by {stats(theta, 1)} % (paper 30.8 %, 34.8 %), both on {down}/{n} "
            "seeds."
        )

    conv1_legs = max(ref["conv1"]["legs_max"] + own["conv1"]["legs_max"])
    conv1_bad = sum(x > 0 for x in ref["conv1"]["violations"] + own["conv1"]["violations"])
    conv1_manip = min(ref["conv1"]["manip"] + own["conv1"]["manip"])
    conv2_own = float(np.mean(own["conv2"]["manip"]))
    hybrid = HybridBoardingSystem()
    manip_work = float(hybrid.manipulability(hybrid.working_state))
    manip_own = float(hybrid.manipulability(np.array(SEED004_STATE)))
    return f"""## Seed 004 — conventional methods 1, 2 and dynamic weight allocation

Seed 004 reports, for its 50 s trajectory: conv1's legs reach 4.71 m (> 4.18 m), minimum
manipulability 27.78 (conv1), 44.51 (conv2), 39.73 (DWA); end attitude maxima φe, θe
−4.25°, −4.35° (conv2), −2.94°, −2.84° (DWA); conv1's are 0 (the gangway does not move).
φe, θe are the deviations from t = 0 of the gangway's direction (luff pivot → tip) in the
inertial landing frame (seed 004 §3.1 a). Their sign depends on the wave phase (ours differ in
sign between seeds), so we compare magnitudes: the largest |φe|, |θe| over the run.

**Reference scenario** ({HEADING:.0f}°, 200 s, working state z = 2.475 m):

{ref_table}

{claims(ref)}

**Seed 004's own set-up**: platform raised 1.1 m (z = 2.625 m, manipulability
{manip_own:.2f} there, SPEC check value), 50 s, same sea, heading and seeds:

{own_table}

{claims(own)}

![Manipulability, conv1 / conv2 / DWA](reproduction/manipulability.png)

![End attitude angles, conv1 / conv2 / DWA](reproduction/end_attitude.png)

**What reproduces.** The three claims' directions: conv1 holds φe = θe = 0 (the platform alone
holds the tip) at the price of the lowest manipulability; conv2 keeps the platform's position,
so its manipulability barely moves (ours {conv2_own:.2f} at seed 004's height against the
paper's 44.51; the level pose there gives {manip_own:.2f}), but its end attitude deviations
are the largest; DWA lies between on both counts.

**What differs, and why.**
- *Trajectory.* Seed 004's 50 s 6-DOF trajectory is unpublished. Its conv1 legs reach 4.71 m,
  i.e. its platform had to travel further than ours: our conv1 legs reach at most
  {conv1_legs:.3f} m (violations on {conv1_bad} of {2 * len(seeds)} runs) and our conv1's
  minimum manipulability is {conv1_manip:.2f} at worst, not 27.78. With less platform travel, DWA's
  gain over conv1 is smaller than the paper's +43 %.
- *Working state.* Our reference runs start at Table 5's working state (z = 2.475 m, raised
  0.95 m, manipulability {manip_work:.2f}); seed 004 raised the platform 1.1 m
  ({manip_own:.2f}), hence the second table. DWA's ratios λ_p and w_i are taken against the
  mechanism's working state (`AllocationPlanner.reset`), not the start, so at z = 2.625 m λ_p
  starts at {manip_own / manip_work:.3f} and DWA gives the platform a little less position.
- *Tip orientation.* conv2 and DWA hold the tip's position but not its orientation (the gangway
  only positions the tip, and the platform does not undo the slew and luff rotations): the
  end attitude deviation is the tip orientation error of these methods (see Tip tracking).
- *Planner details we chose* (twin/planners/allocation.py): the reachable range Δx_p is found
  in closed form (seed 004's "space search"), the share [λ_p w_i]³ is clipped to [0, 1], and
  all three methods plan on a one-step prediction of the target.
"""


def section_seed001() -> str:
    """Seed 001: Table 3 (eq 13), Table 2 (Newton-Raphson), coupled-displacement maxima."""
    m = Upu3Up()
    a = np.radians([r[0] for r in SEED001_INPUTS])
    b = np.radians([r[1] for r in SEED001_INPUTS])
    z = np.array([r[2] for r in SEED001_INPUTS])
    ideal = m.ideal_pose(z, a, b)
    ideal[:, 3:] = np.degrees(ideal[:, 3:])
    state = m.forward(m.leg_lengths(z, a, b))
    nr = m.ideal_pose(state[:, 0], state[:, 1], state[:, 2])
    nr[:, 3:] = np.degrees(nr[:, 3:])

    def rows(ours: np.ndarray, theirs: np.ndarray) -> list[list[str]]:
        out = []
        for i, (alpha, beta, zz) in enumerate(SEED001_INPUTS):
            diff = ours[i] - theirs[i]
            out.append(
                [
                    f"({alpha:g}, {beta:g}, {zz:g})",
                    ", ".join(f"{x:.4f}" for x in theirs[i]),
                    ", ".join(f"{x:.4f}" for x in ours[i]),
                    ", ".join(f"{x:+.4f}" for x in diff),
                ]
            )
        return out

    header = ["(α, β, z) [°, °, mm]", "paper (X, Y, Z [mm], α, β [°])", "ours", "ours − paper"]
    # Eq (27): α = R1 sin t, β = R2 sin t, z = D sin t, R = 5°, D = 30 mm; Table 1's P1-P4.
    t = np.linspace(0.0, 2 * np.pi, 20001)
    sin, R, D = np.sin(t), np.radians(5.0), 30.0
    zero = np.zeros_like(t)
    trajectories = {
        "P1": (zero, R * sin, R * sin),
        "P2": (D * sin, zero, R * sin),
        "P3": (D * sin, R * sin, zero),
        "P4": (D * sin, R * sin, R * sin),
    }
    inputs = {"P1": "α, β; z = 0", "P2": "β, z", "P3": "α, z", "P4": "α, β, z"}
    coupled_rows = []
    for name, (zz, alpha, beta) in trajectories.items():
        d = np.abs(m.coupled_displacement(zz, alpha, beta)).max(axis=0)
        coupled_rows.append(
            [
                name,
                inputs[name],
                f"{SEED001_COUPLED[name]:.4f}",
                f"{d[2]:.4f}",
                f"{d[2] - SEED001_COUPLED[name]:+.4f}",
                f"{d[0]:.3f}",
                f"{d[1]:.3f}",
            ]
        )
    nr_err = np.abs(nr - ideal).max()
    coupled_header = [
        "trajectory",
        "inputs",
        "paper max Z_c [mm]",
        "ours max abs Z_c [mm]",
        "ours − paper",
        "ours max abs X_c [mm]",
        "ours max abs Y_c [mm]",
    ]
    return f"""## Seed 001 — 3UPU_UP coupled platform

Code: `twin.mechanisms.Upu3Up` (mm and rad, as the paper); decisions in
docs/mechanisms/upu3up.md.

### Table 3 — ideal pose from the coupling constraint (eq 13, `Upu3Up.ideal_pose`)

{table(header, rows(ideal, SEED001_TABLE3))}

X, Y and the angles match to print precision. Every printed Z is 4–6 µm off eq 13
(1032.0962 vs 1032.1000 etc.): a rounding slip in the paper (SPEC check value; eq 13 gives
Z = (l + z) cos α cos β exactly).

### Table 2 — pose by Newton-Raphson from the limb lengths (`Upu3Up.forward`)

Lengths from `leg_lengths` (eqs 16–18), then Newton-Raphson (eqs 20–24, residual ≤ 1e-10 mm)
and eq 13:

{table(header, rows(nr, SEED001_TABLE2))}

Our Newton-Raphson returns eq 13's pose to {nr_err:.1e} (mm, °), i.e. Table 3. The paper's
Table 2 scatters around it by up to 0.25 mm (Z of (5, 5, 30)) and 0.018° (β), more than the
"about 1e-2 mm and 1e-4°" its text claims, and row (5, 5, 30) prints Y = +92.83 mm where eq 13
and Table 3 give −92.90 (SPEC erratum 9, a sign slip). No Newton iterate from the initial pose
reproduces Table 2; it is presumably a stopped iteration (the paper stops at 1e-4).

### Coupled-displacement maxima (§IV.D, eq 15) over the sine inputs of eq 27

Inputs α = 5° sin t, β = 5° sin t, z = 30 mm sin t (Table 1's P1–P4), t over one period.
Max |Z_c| is the paper's quantity; |X_c|, |Y_c| (the large horizontal coupling) are shown too.

{table(coupled_header, coupled_rows)}

Eq 15 gives Z_c = (l + z)(cos α cos β − 1), which is symmetric in α and β, so P2 and P3 must
be equal; the paper's 4.0471 vs 4.1346 mm (and its up to 0.06 mm offsets) match its scattered
Newton-Raphson results of Table 2, not eq 15 itself.
"""


def section_seed002(runs: dict, planners: Sequence[str]) -> str:
    """Seed 002: Table 1 workspace, Table 2 efficacy η."""
    m = Upr4()
    fine = m.workspace(0.5)
    coarse = m.workspace(0.5, n_roll=19, n_pitch=19)  # 10° grid

    def roll_at_pitch(ws: Any, pitch_deg: float) -> float:
        j = int(np.argmin(np.abs(np.degrees(ws.pitch) - pitch_deg)))
        column = ws.feasible[:, j]
        return float(np.degrees(np.abs(ws.roll[column]).max())) if column.any() else float("nan")

    deg = np.degrees
    ws_rows = [
        [
            "roll",
            "−π/9 … π/9 (±20°)",
            f"{deg(coarse.roll_limits[0]):.0f}° … {deg(coarse.roll_limits[1]):.0f}°",
            f"{deg(fine.roll_limits[0]):.0f}° … {deg(fine.roll_limits[1]):.0f}°",
            f"±{deg(fine.roll_limits_exact[1]):.3f}°",
            fine.roll_binding[1],
        ],
        [
            "pitch",
            "−π/9 … π/9 (±20°)",
            f"{deg(coarse.pitch_limits[0]):.0f}° … {deg(coarse.pitch_limits[1]):.0f}°",
            f"{deg(fine.pitch_limits[0]):.0f}° … {deg(fine.pitch_limits[1]):.0f}°",
            f"±{deg(fine.pitch_limits_exact[1]):.3f}°",
            fine.pitch_binding[1],
        ],
        [
            "eq 28 circle radius",
            "π/9 (20°)",
            "—",
            "—",
            f"{deg(fine.circle_radius):.3f}° (min) … {deg(fine.circle_radius_max):.3f}° (max)",
            "collision",
        ],
        [
            "roll limit at pitch π/9",
            "0",
            f"{roll_at_pitch(coarse, 20.0):.0f}°",
            f"{roll_at_pitch(fine, 20.0):.0f}°",
            f"{deg(np.arccos(np.cos(fine.pitch_limits_exact[1]) / np.cos(np.pi / 9))):.2f}°",
            "collision",
        ],
    ]
    bindings = sorted(set(fine.binding[~fine.feasible].tolist()))
    ws_text = f"""### Table 1 — workspace at z = 0.5 m (`Upr4().workspace(0.5)`)

Sweep over ±π/2 in roll and pitch; "grid" limits are the last feasible grid point from level
(the paper's "verified limit"), "exact" the boundary by bisection.

{table(["quantity", "paper", "ours, 10° grid", "ours, 2° grid", "ours, exact", "binding"], ws_rows)}

Every infeasible point at z = 0.5 m is bound by: {", ".join(bindings)}. The exact limit is
asin(0.5/√2) = 20.705°, 0.7° beyond π/9: the paper reports the last point of a coarse sweep
(its "at pitch π/9 the roll limit is 0" holds on a 10° grid; on a fine grid roll reaches
about 5° there). Eq 3's "× 2" is read as √2, the pad's half-diagonal (docs/mechanisms/upr4.md):
only that gives π/9.

![4-UPR workspace](reproduction/upr4_workspace.png)
"""
    if not planners:
        return f"""## Seed 002 — 4-UPR UAV landing platform

{ws_text}
### Table 2 — efficacy η

**Not yet run**: no planner for the `upr4` mechanism was registered (`twin.planners.PLANNERS`)
when this report was generated. Rerun the script once `pid`/`ik` exist.
"""
    eta_rows = []
    for i, state in enumerate(WAVE_STATES):
        row = [state[-1], SEED002_WAVES[state], f"{SEED002_ETA[state]:.2f}"]
        for planner in planners:
            mm = runs[("upr4", planner, i)]["metrics"]
            row += [f"{mm['eta']:.2f}", f"{mm['eta_printed']:.2f}"]
        mm = runs[("upr4", planners[0], i)]["metrics"]
        row += [f"{mm['alpha_bottom_max']:.2f}"]
        row += [f"{runs[('upr4', p, i)]['metrics']['alpha_top_max']:.2g}" for p in planners]
        row += [str(sum(runs[("upr4", p, i)]["metrics"]["saturated"] for p in planners))]
        eta_rows.append(row)

    def eta_text(planner: str) -> str:
        if planner not in planners:
            return "not run"
        etas = [runs[("upr4", planner, i)]["metrics"]["eta"] for i in range(len(WAVE_STATES))]
        return " → ".join(f"{x:.2f}" for x in etas) + " %"

    saturated = sum(
        runs[("upr4", q, i)]["metrics"]["saturated"]
        for q in planners
        for i in range(len(WAVE_STATES))
    )
    ik_text = ""
    if "ik" in planners:
        top = max(runs[("upr4", "ik", i)]["metrics"]["alpha_top_max"] for i in range(3))
        ik_text = (
            f" With one-step preview (`ik`: {eta_text('ik')}) the top stays level to "
            f"{top:.1e}°: the lag, not the 0.1 m/s actuators, limits the PID at these waves."
        )
    header = ["state", "waves (amplitude, period, direction)", "paper η [%]"]
    for planner in planners:
        header += [f"{planner} η integral [%]", f"{planner} η as printed [%]"]
    header += ["max α bottom [°]"] + [f"max α top {p} [°]" for p in planners]
    header += ["samples at 0.1 m/s"]
    p = PlannerParameters()
    return f"""## Seed 002 — 4-UPR UAV landing platform

Code: `twin.mechanisms.Upr4`; decisions in docs/mechanisms/upr4.md.

{ws_text}
### Table 2 — efficacy η for wave states 1–3

The 4-UPR on the twin-float `asv` (its default mount), seed 002 Table 2's regular waves
(`regular_waves="state1"…"state3"`; directions relative to the bow; phases 0, so the runs do
not depend on the seed and are run once), {UPR4_DURATION:.0f} s each (as the paper), actuators
limited to {p.actuator_speed:g} m/s. η as printed is eq 29, the time mean of
(α_bottom − α_top)/α_bottom; the integral form is 1 − ∫|α_top| dt / ∫|α_bottom| dt (SPEC
erratum 11). `pid`: the paper's position loop on the limb lengths (kp = {p.kp:g} 1/s,
ki = {p.ki:g} 1/s², kd = {p.kd:g}); `ik`: an ideal position servo with one-step preview.

{table(header, eta_rows)}

![4-UPR top vs bottom tilt](reproduction/upr4_tilt.png)

**What differs, and why.**
- *Vessel.* The paper's ASV is a Gazebo VRX WAM-V with Gerstner waves; ours is a twin-float
  hull whose RAOs we computed (`assets/vessels/asv.nc`), so the base tilt for the same wave
  list differs, and with it η.
- *Controller.* The paper tunes an effort PID in Gazebo (kp = 5000, ki = 0.5, kd = 10); ours
  commands actuator velocity with those gains scaled to a velocity loop (kp = {p.kp:g} 1/s).
  A reactive position loop lags the base by about 1/kp, so the residual tilt is a fixed
  fraction of the base tilt at each wave frequency (ωτ ≈ {2 * np.pi / 3 / p.kp:.2f} for the
  3 s wave). All three states contain the 3 s wave, so our PID η changes little from state 1
  to 3 ({eta_text("pid")}), while the paper's falls (98.23 → 94.84 %).{ik_text}
  The actuator speed limit bound on {saturated} samples in all these runs.
- *η as printed* divides by α_bottom, which passes near zero; its mean is dominated by those
  samples and is not a robust measure (SPEC erratum 11). The integral form is the one to
  compare.
"""


def section_tracking(runs: dict, seeds: range) -> str:
    """Tip tracking of every hybrid planner on the reference scenario."""
    rows = []
    for planner in HYBRID_PLANNERS:
        get = {
            "pos_rms": lambda m: 1e3 * m["tip_position_error_rms"],
            "pos_max": lambda m: 1e3 * m["tip_position_error_max"],
            "rot_rms": lambda m: m["tip_orientation_error_rms"],
            "rot_max": lambda m: m["tip_orientation_error_max"],
            "faults": lambda m: m["faults"],
        }
        v = {k: metric(runs, "ref", planner, seeds, g) for k, g in get.items()}
        rows.append(
            [
                planner,
                stats(v["pos_rms"], 2, "g"),
                f"{stats(v['pos_max'], 2, 'g')} ({spread(v['pos_max'], 2, 'g')})",
                stats(v["rot_rms"], 2, "g"),
                f"{stats(v['rot_max'], 2, 'g')} ({spread(v['rot_max'], 2, 'g')})",
                f"{sum(v['faults']):.0f}",
            ]
        )
    header = [
        "planner",
        "tip pos. RMS [mm]",
        "tip pos. max [mm]",
        "tip rot. RMS [°]",
        "tip rot. max [°]",
        "faults",
    ]
    return f"""## Tip tracking (all hybrid planners, reference scenario)

Error of the gangway tip against its held inertial pose, after the first {SETTLE} samples.

{table(header, rows)}

PI, WPI and MTMP hold the whole tip pose (closed loop, k_e = 25 1/s, on a one-step-predicted
target); conv1 too (the platform alone, exact inverse kinematics). conv2 and DWA hold the
tip's position only: their orientation error is the end attitude deviation of seed 004 (φe, θe
above), by design of the methods.
"""


# ---------------------------------------------------------------------------------------------
# Main
# ---------------------------------------------------------------------------------------------


def platform_planners() -> list[str]:
    """The small-platform planners registered for the 4-UPR (another module may lack them)."""
    return [p for p in PLATFORM_PLANNERS if p in PLANNERS and "upr4" in PLANNERS[p].mechanisms]


def jobs(seeds: range, upr4_planners: Sequence[str]) -> list[Job]:
    """Every run, longest first so the two processes finish together."""
    out: list[Job] = [("ref", p, s) for s in seeds for p in HYBRID_PLANNERS]
    out += [("alt", "mtmp", s) for s in seeds]
    out += [("seed004", p, s) for s in seeds for p in ALLOCATION]
    out += [("upr4", p, i) for p in upr4_planners for i in range(len(WAVE_STATES))]
    return out


def main(n_seeds: int = 5, out: Path = Path("docs"), processes: int = 2) -> None:
    """Run everything and write `out`/reproduction.md and `out`/reproduction/*.png."""
    started = time.perf_counter()
    seeds = range(n_seeds)
    figures = out / "reproduction"
    figures.mkdir(parents=True, exist_ok=True)
    upr4_planners = platform_planners()
    todo = jobs(seeds, upr4_planners)
    runs: dict[Job, dict[str, Any]] = {}
    with multiprocessing.Pool(processes) as pool:
        for job, result in tqdm(
            pool.imap_unordered(run_job, todo), total=len(todo), unit="run", desc="scenarios"
        ):
            runs[job] = result

    hybrid = HybridBoardingSystem()
    plot_legs(runs, hybrid, figures / "legs_pi_wpi_mtmp.png")
    plot_gangway(runs, hybrid, figures / "gangway_joints.png")
    plot_allocation(runs, figures / "manipulability.png", figures / "end_attitude.png")
    plot_workspace(Upr4().workspace(0.5, n_roll=241, n_pitch=241), figures / "upr4_workspace.png")
    if upr4_planners:
        plot_upr4_tilt(runs, upr4_planners, figures / "upr4_tilt.png")

    elapsed = time.perf_counter() - started
    command = f"python scripts/reproduce.py --seeds {n_seeds} --out {out}"
    if processes != 2:
        command += f" --processes {processes}"
    header = f"""# Reproduction of the papers' results

> **Generated** by `{command}` on {datetime.date.today().isoformat()}
> ({len(todo)} simulations, {elapsed:.0f} s on {processes} processes). Do not edit by hand:
> change `scripts/reproduce.py` and rerun it. Plots are in `{figures.name}/`.

Each paper's numbers beside ours, with the differences explained. Papers: seed 000 (hybrid
system, PI / WPI / MTMP), seed 004 (DWA; summarised in SPEC.md), seed 001 (3UPU_UP), seed 002
(4-UPR); SPEC.md lists the errata we follow, docs/decisions.md and docs/mechanisms/*.md our
choices where the papers are silent.
"""
    text = "\n".join(
        [
            header,
            section_summary(runs, seeds, upr4_planners),
            section_scenarios(runs, seeds),
            "## Seed 000 — PI, WPI and MTMP on the hybrid system\n",
            section_tables34(runs, seeds),
            section_table7(runs, seeds, hybrid),
            section_seed004(runs, seeds),
            section_seed001(),
            section_seed002(runs, upr4_planners),
            section_tracking(runs, seeds),
        ]
    )
    (out / "reproduction.md").write_text(text)
    print(f"wrote {out / 'reproduction.md'} and {figures}/ in {elapsed:.0f} s")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5, help="sea seeds 0 … n−1 (≥ 2)")
    parser.add_argument("--out", type=Path, default=Path("docs"), help="output directory")
    parser.add_argument("--processes", type=int, default=2, help="worker processes")
    args = parser.parse_args()
    if args.seeds < 2:
        parser.error("--seeds must be at least 2 (the report gives a spread over seeds)")
    main(args.seeds, args.out, args.processes)
