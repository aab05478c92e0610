"""The statistical part of docs/reproduction.md: every claim over held-out sea seeds.

Imported by scripts/reproduce.py (it sits beside it). Runs, through the one engine's lanes
(`twin.runs.claims`, `simulate_many`):

1. every claim of seeds 000, 004, 001 and 002 on `REPORT_SEEDS` (50-149, held out from the
   calibration's seeds 0-49), judged by `twin.runs.claims`'s rules;
2. the sensitivity of each number to `n_components` and dt (on the first 50 report seeds);
3. the most likely causes of the unfitted mismatches, one cause at a time: each variant of
   the `seed000` sea has its own Hs refitted so PI's leg maximum is Table 7's again (on
   calibration seeds `CAUSE_FIT_SEEDS`), then PI, WPI and MTMP run on report seeds;
4. seed 001's ocean-wave coupling (P5-P8) and seed 002's efficiency against dt with the
   measured limb rates.

`write_claims_json` writes docs/reproduction/claims.json. Run as a script, it writes
docs/reproduction/stability.json: every claim over seeds 50-1049 and its ten blocks of 100 in
both sea models (`stability`), the verdicts the report states and
tests/test_reproduction_claims.py holds the engine to (~3 minutes on two cores, cached per
block in `STABILITY_CACHE`).
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from twin.mechanisms import Upu3Up
from twin.planners import PlannerParameters
from twin.runs.claims import (
    BLOCK,
    BLOCKS,
    RESAMPLES,
    SEED001_DT,
    SEED001_P8,
    SEED002_ETA,
    STABILITY_SEEDS,
    TABLE7,
    Outcome,
    block_verdict,
    block_verdicts,
    claim_values,
    claims,
    column,
    evaluate,
    preset_runs,
    seed002_runs,
    seed002_values,
    stable_verdict,
)
from twin.sea.presets import (
    SEED001_DURATION,
    SEED001_TRAJECTORIES,
    seed001_signals,
    seed001_trajectory,
)
from twin.sea.spectra import dnv_gamma
from twin.sim import PAPER_PRESETS
from twin.sim.presets import CALIBRATION_SEEDS, REPORT_SEEDS

#: sensitivity runs: label → changes to the presets
SENSITIVITY = {
    "100 comp.": {"n_components": 100},
    "400 comp.": {"n_components": 400},
    "dt 25 ms": {"dt": 0.025},
}
SENSITIVITY_SEEDS = REPORT_SEEDS[:50]
#: one cause at a time: label → changes to the `seed000` sea (Hs then refitted)
CAUSES = {
    "as calibrated (JONSWAP γ 3.3, long-crested, Tp 6.85 s, 225°), Hs refitted": {},
    "γ = 1 (Pierson–Moskowitz)": {"gamma": 1.0},
    "short-crested, cos-2s s = 10": {"spreading": 10.0},
    "Tp 9 s (λ 126 m, not ≈ the 70.5 m hull)": {"tp": 9.0},
    "heading 195° (waves from 15° off the port bow)": {"heading": 195.0},
}
#: seeds of the causes' comparison: Hs is refitted on the same seeds the columns are read on,
#: so every row has PI's leg maximum at 4.243 m exactly (a counterfactual, not a prediction)
CAUSE_SEEDS = REPORT_SEEDS[:50]
#: [m] how closely a cause's Hs refit meets PI's 4.243 m
CAUSE_TOLERANCE = 2e-3
#: [s] seed 002 control periods tabulated
SEED002_TABLE_DTS = (0.005, 0.01, 0.02, 0.05)


def fmt(x: float, digits: int) -> str:
    return "—" if x is None or not np.isfinite(x) else f"{x:.{digits}f}"


def digits_of(unit: str) -> int:
    return {"m": 3, "°": 2, "%": 1, "mm": 1}.get(unit, 2)


def table(header: list[str], rows: list[list[Any]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + " --- |" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


def bold(verdict: str) -> str:
    return f"**{verdict}**" if verdict in ("matched", "reproduced") else verdict


# ---------------------------------------------------------------------------------------------
# Runs
# ---------------------------------------------------------------------------------------------


def secant_hs(changes: dict[str, Any], target: float = TABLE7["pi"]["legs"][0]) -> float:
    """[m] Hs of the `seed000` sea with `changes` at which PI's mean leg maximum over
    `CAUSE_SEEDS` is `target` [m] (secant on Hs, from the preset's Hs and 1.2 times it)."""

    def miss(hs: float) -> float:
        rows = preset_runs("seed000", ["pi"], CAUSE_SEEDS, {**changes, "hs": hs})["pi"]
        return float(np.mean(column(rows, "legs_max"))) - target

    a = float(PAPER_PRESETS["seed000"].hs)
    b = 1.2 * a
    fa, fb = miss(a), miss(b)
    for _ in range(12):
        if abs(fb) <= CAUSE_TOLERANCE:
            return b
        a, fa, b = b, fb, max(0.05, b - fb * (b - a) / (fb - fa))
        fb = miss(b)
    return b  # close enough for a cause's comparison; the table prints PI's mean beside it


def cause_rows() -> list[dict[str, Any]]:
    """Per cause: its refitted Hs and the unfitted columns' means over `CAUSE_SEEDS`."""
    out = []
    for label, changes in CAUSES.items():
        hs = secant_hs(changes)
        runs = preset_runs("seed000", ("pi", "wpi", "mtmp"), CAUSE_SEEDS, {**changes, "hs": hs})
        mean = {
            (p, k): float(np.mean(column(runs[p], k)))
            for p in runs
            for k in ("legs_max", "legs_min", "q1_max", "q1_min", "q2_max", "q2_min")
        }
        wpi_inside = float(np.mean(column(runs["wpi"], "leg_violations") == 0))
        mtmp_inside = float(np.mean(column(runs["mtmp"], "violations") == 0))
        q2_up = float(np.mean(column(runs["pi"], "q2_max") > np.abs(column(runs["pi"], "q2_min"))))
        out.append(
            {"label": label, "hs": hs, "mean": mean, "wpi_inside": wpi_inside,
             "mtmp_inside": mtmp_inside, "pi_q2_up": q2_up}
        )  # fmt: skip
    return out


def seed001_all(seeds: range) -> dict[str, np.ndarray]:
    """Trajectory → (seeds, 3) coupled-displacement maxima |Xc|, |Yc|, |Zc| [mm] over 500 s."""
    t = np.arange(0.0, SEED001_DURATION + SEED001_DT / 2, SEED001_DT)
    platform = Upu3Up()
    signals = [seed001_signals(t, s) for s in seeds]  # one sea per seed, for all four
    return {
        name: np.array(
            [
                np.abs(platform.coupled_displacement(*seed001_trajectory(one, name))).max(axis=0)
                for one in signals
            ]
        )
        for name in SEED001_TRAJECTORIES
    }


def run_all() -> dict[str, Any]:
    """Everything the claims sections print."""
    outcomes = evaluate(REPORT_SEEDS)
    sensitivity = {
        label: evaluate(SENSITIVITY_SEEDS, changes, with_seed001=False)
        for label, changes in SENSITIVITY.items()
    }
    return {
        "outcomes": outcomes,
        "sensitivity": sensitivity,
        "causes": cause_rows(),
        "seed001": seed001_all(REPORT_SEEDS),
        "seed002": seed002_runs(SEED002_TABLE_DTS),
    }


def write_claims_json(outcomes: dict[str, Outcome], path: Path) -> None:
    """The claims' statistics over the report seeds (the verdicts that stand are
    `STABILITY_JSON`'s, over 1,000 seeds)."""
    data = {
        "seeds": [REPORT_SEEDS.start, REPORT_SEEDS.stop - 1],
        "claims": {key: o.summary() for key, o in outcomes.items()},
    }
    path.write_text(json.dumps(data, indent=1, ensure_ascii=False) + "\n")


# ---------------------------------------------------------------------------------------------
# Sections
# ---------------------------------------------------------------------------------------------


def sensitivity_cell(key: str, data: dict[str, Any]) -> str:
    """Means of a number on `SENSITIVITY_SEEDS` as preset / each sensitivity change."""
    o = data["outcomes"][key]
    d = digits_of(o.claim.unit)
    base = float(np.mean(o.values[: len(SENSITIVITY_SEEDS)]))
    parts = [fmt(base, d)]
    for label in SENSITIVITY:
        other = data["sensitivity"][label].get(key)
        parts.append(fmt(other.mean, d) if other is not None else "—")
    return " / ".join(parts)


def number_row(o: Outcome, data: dict[str, Any]) -> list[str]:
    d = digits_of(o.claim.unit)
    sens = (
        sensitivity_cell(o.claim.key, data)
        if o.claim.key in data["sensitivity"]["dt 25 ms"]
        else "—"
    )
    return [
        o.claim.source,
        o.claim.text + (f" [{o.claim.unit}]" if o.claim.unit else ""),
        fmt(o.claim.paper, d),
        f"{fmt(o.mean, d)} ({fmt(o.low, d)} … {fmt(o.high, d)})",
        f"{fmt(o.ci[0], d)} … {fmt(o.ci[1], d)}",
        sens,
        bold(o.verdict),
    ]


def share_row(o: Outcome) -> list[str]:
    k = round(o.mean * o.values.size)
    return [
        o.claim.source,
        o.claim.text,
        f"{k}/{o.values.size} = {100 * o.mean:.0f} %",
        f"{100 * o.ci[0]:.0f} … {100 * o.ci[1]:.0f} %",
        bold(o.verdict),
    ]


def headline(outcomes: dict[str, Outcome]) -> str:
    """The unfitted columns in words, from the outcomes (no number typed by hand)."""

    def num(key: str, d: int = 3) -> str:
        o = outcomes[key]
        return f"{o.mean:.{d}f} ({o.low:.{d}f} … {o.high:.{d}f}; paper {o.claim.paper:.{d}f})"

    def share(key: str) -> str:
        o = outcomes[key]
        return f"{100 * o.mean:.0f} % of seeds (CI {100 * o.ci[0]:.0f} … {100 * o.ci[1]:.0f} %)"

    def verdict(*keys: str) -> str:
        return ", ".join(outcomes[k].verdict for k in keys)

    def than(*keys: str) -> str:
        """ "further than" / "less far than" the paper's, if every key agrees."""
        wider = {abs(outcomes[k].mean) > abs(outcomes[k].claim.paper) for k in keys}
        return (
            "mixed against"
            if len(wider) > 1
            else ("further than" if wider.pop() else "less far than")
        )

    return "\n".join([
        f"- **Leg minima** (PI, WPI): {num('seed000.pi.legs_min')}, "
        f"{num('seed000.wpi.legs_min')} m: the paper's lie inside our range but near its top "
        f"({verdict('seed000.pi.legs_min', 'seed000.wpi.legs_min')}); PI's shortest leg stays "
        f"above the stroke on only {share('seed000.pi.legs_min_inside')} and WPI's legs stay "
        f"inside the stroke on {share('seed000.wpi.inside_stroke')}, where the paper's WPI "
        "stays inside" + (": **our WPI leaves the stroke on most seeds.**"
                          if outcomes["seed000.wpi.inside_stroke"].mean < 0.5 else "."),
        f"- **q1** (slew): PI {num('seed000.pi.q1_max', 2)}°, MTMP min "
        f"{num('seed000.mtmp.q1_min', 2)}°: our slew moves "
        f"{than('seed000.pi.q1_max', 'seed000.mtmp.q1_min')} the paper's "
        f"({verdict('seed000.pi.q1_max', 'seed000.mtmp.q1_min')}).",
        f"- **q2** (luff): PI max {num('seed000.pi.q2_max', 1)}°, WPI max "
        f"{num('seed000.wpi.q2_max', 1)}°, MTMP max {num('seed000.mtmp.q2_max', 2)}°: ours swing "
        + than("seed000.pi.q2_max", "seed000.wpi.q2_max", "seed000.mtmp.q2_max")
        + " the paper's ("
        + verdict("seed000.pi.q2_max", "seed000.wpi.q2_max", "seed000.mtmp.q2_max") + ").",
        f"- **d3** (telescope): PI min {num('seed000.pi.d3_min')} m, WPI min "
        f"{num('seed000.wpi.d3_min')} m, MTMP {num('seed000.mtmp.d3_max')} m max "
        f"({verdict('seed000.pi.d3_min', 'seed000.wpi.d3_min', 'seed000.mtmp.d3_max')}).",
        f"- **MTMP's margins**: inside every limit on {share('seed000.mtmp.inside')} "
        f"(the paper: inside), legs max {num('seed000.mtmp.legs_max')} m against the 4.18 m "
        "stroke.",
        f"- **DWA against the conventional methods** (seed 004): DWA inside every limit on "
        f"{share('seed004.dwa.inside')}; its largest abs θe below method 2's by "
        f"{num('seed004.dwa.theta_reduction', 1)} % and φe by "
        f"{num('seed004.dwa.phi_reduction', 1)} % "
        f"({verdict('seed004.dwa.theta_reduction', 'seed004.dwa.phi_reduction')}).",
    ])  # fmt: skip


def section_claims(data: dict[str, Any]) -> str:
    """The summary: unfitted numbers first, then qualitative claims, seed 002, fitted last."""
    outcomes: dict[str, Outcome] = data["outcomes"]
    numbers = [o for o in outcomes.values() if o.claim.kind == "number"]
    unfitted = [o for o in numbers if o.claim.fitted is None]
    fitted = [o for o in numbers if o.claim.fitted is not None]
    shares = [o for o in outcomes.values() if o.claim.kind == "share"]
    fixed = [o for o in outcomes.values() if o.claim.kind == "deterministic"]
    n = len(REPORT_SEEDS)
    count = {v: sum(o.verdict == v for o in unfitted) for v in
             ("matched", "reproduced", "not reproduced")}  # fmt: skip
    missed = [o.claim.text for o in unfitted if o.verdict == "not reproduced"]
    number_header = [
        "paper", "claim", "paper's value", f"ours: mean (10 … 90 %), {n} seeds",
        "95 % bootstrap CI of the mean",
        "mean as preset / " + " / ".join(SENSITIVITY) + " (50 seeds)", "verdict",
    ]  # fmt: skip
    share_header = ["paper", "claim", "holds on (seeds)", "95 % Wilson interval", "verdict"]
    fixed_rows = []
    for o in fixed:
        ours = (
            "holds"
            if o.claim.paper is None and o.mean > 0.5
            else ("does not hold" if o.claim.paper is None else f"{o.mean:.2f} %")
        )
        fixed_rows.append([o.claim.source, o.claim.text, fmt(o.claim.paper, 2), ours,
                           bold(o.verdict)])  # fmt: skip
    return f"""## The first block in detail, with sensitivities

The verdicts that stand are the section above's (1,000 seeds, ten blocks). This section shows
one block, **{n} sea seeds ({REPORT_SEEDS.start}–{REPORT_SEEDS.stop - 1})**, judged by the same
rules, with each number's sensitivity to the sea's discretisation and dt; its verdicts are
that block's (a seed-dependent claim can go either way here). The rules (`twin.runs.claims`):

- a paper's number is **matched** when the 95 % bootstrap CI of our mean contains it,
  **reproduced** when it lies within our 10–90 % band of per-seed values (a comparison claim
  also needs the paper's sign on 90 % of seeds), else **not reproduced**;
- a qualitative claim, which the paper's single run shows holding, is **reproduced** when it
  holds on most seeds (the lower end of the 95 % Wilson interval of the share above 50 %),
  **not reproduced** when its upper end is below 50 %, else **undecided**;
- seed 002's regular waves are deterministic (one record): a number is reproduced within
  1 percentage point.

The sensitivity column gives the mean on the first 50 report seeds as the preset runs it
(200 components, dt 50 ms) and with 100 or 400 components or dt = 25 ms: a verdict that a
column change would flip is fragile.

### Numbers no knob was fitted to

Of {len(unfitted)} unfitted numbers, {count["matched"]} are matched, {count["reproduced"]}
reproduced and **{count["not reproduced"]} not reproduced**: {"; ".join(missed) or "none"}.
The most likely causes are measured below ("What the mismatches come from"). In words:

{headline(outcomes)}

{table(number_header, [number_row(o, data) for o in unfitted])}

### Qualitative claims

{table(share_header, [share_row(o) for o in shares])}

### Seed 002 (regular waves, deterministic)

{table(["paper", "claim", "paper's value", "ours", "verdict"], fixed_rows)}

### Numbers a knob was fitted to (agreement by construction)

These are what the calibration fitted (Hs to PI's leg maximum, the heading chosen by WPI's;
seed 004's Hs to method 1's). On held-out seeds they show how well a fit on 50 seeds carries
over, not that the twin predicts them.

{table(number_header, [number_row(o, data) for o in fitted])}
"""


def section_causes(data: dict[str, Any]) -> str:
    """The unfitted columns under one changed cause at a time."""
    rows = []
    paper = [
        "paper (Table 7)", "—",
        f"{TABLE7['pi']['legs'][1]:.3f} / {TABLE7['wpi']['legs'][1]:.3f}",
        f"{TABLE7['wpi']['legs'][0]:.3f}",
        f"{TABLE7['pi']['q2'][0]:.1f} / {TABLE7['wpi']['q2'][0]:.1f} / "
        f"{TABLE7['mtmp']['q2'][0]:.2f}",
        f"{TABLE7['pi']['q1'][0]:.2f} / {TABLE7['mtmp']['q1'][1]:.2f}",
        "inside", "inside", "up",
    ]  # fmt: skip
    rows.append(paper)
    for c in data["causes"]:
        m = c["mean"]
        rows.append([
            c["label"], f"{c['hs']:.3f} (PI legs max {m[('pi', 'legs_max')]:.3f})",
            f"{m[('pi', 'legs_min')]:.3f} / {m[('wpi', 'legs_min')]:.3f}",
            f"{m[('wpi', 'legs_max')]:.3f}",
            f"{m[('pi', 'q2_max')]:.1f} / {m[('wpi', 'q2_max')]:.1f} / {m[('mtmp', 'q2_max')]:.2f}",
            f"{m[('pi', 'q1_max')]:.2f} / {m[('mtmp', 'q1_min')]:.2f}",
            f"{100 * c['wpi_inside']:.0f} %", f"{100 * c['mtmp_inside']:.0f} %",
            f"{100 * c['pi_q2_up']:.0f} %",
        ])  # fmt: skip
    header = [
        "sea (one change from `seed000`)", "Hs refitted [m]", "legs min PI / WPI [m]",
        "WPI legs max [m]", "q2 max PI / WPI / MTMP [°]", "q1 max PI / q1 min MTMP [°]",
        "WPI inside the stroke", "MTMP inside all limits", "PI q2 drifts up",
    ]  # fmt: skip
    return f"""### What the mismatches come from (one cause at a time)

Each row changes one thing in `seed000`'s sea and refits Hs so PI's mean leg maximum over
report seeds {CAUSE_SEEDS.start}–{CAUSE_SEEDS.stop - 1} is Table 7's 4.243 m again (secant,
to {CAUSE_TOLERANCE * 1e3:g} mm; fitted on the same seeds it is read on, so every row holds
the fitted number fixed and compares the others), then runs PI, WPI and MTMP there (means). A
cause explains a mismatch when changing it moves the column towards the paper's value.

{table(header, rows)}

{causes_reading(data)}
"""


def causes_reading(data: dict[str, Any]) -> str:
    """Which single change moves each unfitted column furthest towards the paper's value."""
    causes = data["causes"]
    base = causes[0]["mean"]
    columns = [
        ("PI's leg minimum", ("pi", "legs_min"), TABLE7["pi"]["legs"][1], "m", 3),
        ("WPI's leg minimum", ("wpi", "legs_min"), TABLE7["wpi"]["legs"][1], "m", 3),
        ("PI's q2 maximum", ("pi", "q2_max"), TABLE7["pi"]["q2"][0], "°", 1),
        ("WPI's q2 maximum", ("wpi", "q2_max"), TABLE7["wpi"]["q2"][0], "°", 1),
        ("MTMP's q2 maximum", ("mtmp", "q2_max"), TABLE7["mtmp"]["q2"][0], "°", 2),
        ("PI's q1 maximum", ("pi", "q1_max"), TABLE7["pi"]["q1"][0], "°", 2),
        ("MTMP's q1 minimum", ("mtmp", "q1_min"), TABLE7["mtmp"]["q1"][1], "°", 2),
    ]
    lines = []
    for name, key, target, unit, d in columns:
        gap = abs(base[key] - target)
        best = min(causes[1:], key=lambda c: abs(c["mean"][key] - target))
        moved = gap - abs(best["mean"][key] - target)
        share = 100 * moved / gap if gap > 0 else 0.0
        spread = [c["mean"][key] for c in causes]
        if share < 5.0:  # under 5 % of the gap: no change explains it
            lines.append(
                f"- {name}: {base[key]:.{d}f} {unit} against the paper's {target:.{d}f}; no "
                f"single change moves it closer (range {min(spread):.{d}f} … "
                f"{max(spread):.{d}f} over the rows)."
            )
        else:
            lines.append(
                f"- {name}: {base[key]:.{d}f} {unit} against the paper's {target:.{d}f}; "
                f"{best['label'].split(' (')[0]} moves it to {best['mean'][key]:.{d}f}, closing "
                f"{share:.0f} % of the gap."
            )
    return (
        "Measured, per column (the largest single-change effect):\n\n"
        + "\n".join(lines)
        + "\n\nA change that closes little of a gap leaves it unexplained by the sea's shape: "
        "what stays is then the planner, the vessel (our SOV's RAOs, not the papers' unnamed "
        "ship) or the unpublished trajectory itself. Seed 000 does not publish its trajectory, "
        "so the causes can be narrowed, not proven."
    )


def section_holes(data: dict[str, Any]) -> str:
    """Seed 001's P5-P8 in its sea; seed 002's η against dt with the measured limb rates."""
    n = len(REPORT_SEEDS)
    rows = []
    for name, peaks in data["seed001"].items():
        inputs = [
            k for k, on in zip(("z", "α", "β"), SEED001_TRAJECTORIES[name], strict=True) if on
        ]
        cells = [name, ", ".join(inputs)]
        for i in range(3):
            x = peaks[:, i]
            lo, hi = np.percentile(x, [5, 95])
            cells.append(f"{x.mean():.1f} ({lo:.1f} … {hi:.1f})")
        rows.append(cells)
    rows.append(["P8, paper (Fig. 12)", "z, α, β", *(f"{SEED001_P8[a]:.1f}" for a in "xyz")])
    p8 = data["seed001"]["P8"]
    ranks = ", ".join(
        f"{axis.upper()}c {100 * np.mean(p8[:, i] < SEED001_P8[axis]):.0f} %"
        for i, axis in enumerate("xyz")
    )
    eta = data["seed002"]
    limit = PlannerParameters().actuator_speed
    falls = eta[("state1", 0.005)][0] > eta[("state2", 0.005)][0] > eta[("state3", 0.005)][0]
    eta_rows = []
    for state, value in SEED002_ETA.items():
        eta_rows.append([state, f"{value:.2f}",
                         *(f"{eta[(state, dt)][0]:.2f} ({1e3 * eta[(state, dt)][1]:.1f})"
                           for dt in SEED002_TABLE_DTS)])  # fmt: skip
    rates = [eta[k][1] for k in eta]
    eta_header = ["wave state", "paper η [%]"] + [
        f"ours η [%] (peak limb rate [mm/s]), dt = {dt * 1e3:g} ms" for dt in SEED002_TABLE_DTS
    ]
    return f"""### Seed 001: the ocean-wave coupling of P5–P8

Seed 001 §IV.D.2 feeds its level-4 PM sea (`twin.sea.presets`, 500 s) to the 3UPU_UP as
Table 4's trajectories and prints the coupled-displacement maxima of the last one only (P8,
Fig. 12). Ours over {n} seeds of the sea's phases ({REPORT_SEEDS.start}–
{REPORT_SEEDS.stop - 1}), max |Xc|, |Yc|, |Zc| over the record [mm], mean (5 … 95 %):

{table(["trajectory", "inputs", "max abs Xc [mm]", "max abs Yc [mm]", "max abs Zc [mm]"], rows)}

The paper's P8 maxima sit at these percentiles of ours: {ranks}; the verdicts are in the
claims table above. Zc = (l + z)(cos α cos β − 1) (eq 15) depends on the
slope extremes α, β, which one 500 s record samples sparsely, hence the wide range.

### Seed 002: efficiency against the control period, with measured limb rates

η of the PID on the 4-UPR in Table 2's regular waves (deterministic records, 30 s), by control
period; in brackets the peak commanded limb rate [mm/s] as measured. The presets run at
dt = 5 ms (kp·dt = 0.6); the scenario default is 50 ms:

{table(eta_header, eta_rows)}

The paper's 98.23 % at state 1 needs a short control period: η is {eta[("state1", 0.005)][0]:.2f} %
at 5 ms and {eta[("state1", 0.05)][0]:.2f} % at the default 50 ms. Peak limb rates reach
{1e3 * max(rates):.1f} mm/s against the {1e3 * limit:g} mm/s actuator limit
({
        "never reached: the loop's lag, not its actuators, limits η"
        if max(rates) < limit
        else "reached"
    }), and η {"falls" if falls else "does not fall"} from wave state 1 to 3
at 5 ms (the paper's falls).
"""


def section_calibration() -> str:
    """What was fitted, with which knobs, on which seeds — stated once."""
    s000, s004 = PAPER_PRESETS["seed000"], PAPER_PRESETS["seed004"]
    return f"""## What was fitted

Seeds 000 and 004 publish what their unpublished random trajectories did to the legs, not the
trajectories, so the presets' seas are fitted (`python scripts/calibrate_presets.py`, on sea
seeds {CALIBRATION_SEEDS.start}–{CALIBRATION_SEEDS.stop - 1}; every number in this report is
on the held-out seeds {REPORT_SEEDS.start}–{REPORT_SEEDS.stop - 1}):

- **Fixed, not fitted:** the SOV and the hybrid mount, JONSWAP γ = {s000.gamma:g}, 200
  components, long-crested, Tp = {s000.tp} s (WMO sea state 4's), 200 s at dt = 50 ms.
- **Seed 000: two knobs fit two numbers.** At each heading from 185° to 230° (step 5°), Hs is
  fitted so PI's mean leg maximum is Table 7's 4.243 m; then, of the headings where PI's q2
  drifts up as in Table 7, the heading whose WPI mean leg maximum is nearest Table 7's
  4.102 m is kept: {s000.heading:g}° (waves from {s000.heading - 180:g}° off the port bow),
  Hs = {s000.hs} m (WPI's mean leg maximum falls steadily with the heading at PI's fitted
  Hs, from 4.222 m at 185° to 4.101 m at 225° and 4.097 m at 230°, in the calibration's
  printout). PI's and WPI's leg maxima are therefore **fitted**, not predictions.
- **Seed 004: one knob fits one number.** At that heading, Hs = {s004.hs} m so conventional
  method 1's mean leg maximum is seed 004's 4.71 m (**fitted**).

Everything else (leg minima, q1, q2 and d3 ranges, MTMP's and DWA's margins, DWA against the
conventional methods, seed 001 and 002) is unfitted.
"""


# ---------------------------------------------------------------------------------------------
# Verdicts over 1,000 seeds, in blocks, in both seas (python scripts/reproduce_claims.py)
# ---------------------------------------------------------------------------------------------

#: the two sea models of every claim: the papers' presets, and the scenario defaults
#: (800 components, DNV's γ for Hs and Tp) on the same Hs, Tp, heading and seeds
SEAS = {"presets": {}, "defaults": {"gamma": None, "n_components": 800}}
#: where `stability_values` keeps each block's values (a crash loses one block)
STABILITY_CACHE = Path("/tmp/twin_claims_blocks")
#: the repository's copy, whatever folder scripts/reproduce.py writes its report to
STABILITY_JSON = Path(__file__).resolve().parents[1] / "docs" / "reproduction" / "stability.json"
#: [%] how close (relative) a seed's P8 maxima must come to the paper's to count as "near"
P8_NEAR = 5.0


def stability_values(seeds: range, sea: str, cache: Path = STABILITY_CACHE) -> dict:
    """Claim key → per-seed values over `seeds` in `sea` (`SEAS`), computed block by block
    (`BLOCK` seeds) and cached as .npz; seed 001's claims (own sea) only under the presets,
    seed 002's deterministic claims run once."""
    cache.mkdir(parents=True, exist_ok=True)
    parts: list[dict[str, np.ndarray]] = []
    for start in range(seeds.start, seeds.stop, BLOCK):
        path = cache / f"{sea}_{start}.npz"
        if not path.exists():
            values = claim_values(range(start, start + BLOCK), SEAS[sea] or None,
                                  with_seed001=sea == "presets")  # fmt: skip
            np.savez(path, **values)  # type: ignore[arg-type]  # numpy's stub: **kwds as arrays
            print(f"{sea} seeds {start}-{start + BLOCK - 1}", flush=True)
        with np.load(path) as data:
            parts.append({k: data[k] for k in data.files if not k.startswith("seed002")})
    values = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    return values | seed002_values(seed002_runs())


def stability(seeds: range = STABILITY_SEEDS) -> dict[str, Any]:
    """Every claim judged over `seeds` in both seas with its block split (`stable_verdict`),
    seed 001's P8 joint count, and the block tests/test_reproduction_claims.py runs."""
    out: dict[str, Any] = {"seeds": [seeds.start, seeds.stop - 1], "seas": {}}
    presets_values: dict[str, np.ndarray] = {}
    for sea in SEAS:
        values = stability_values(seeds, sea)
        presets_values = presets_values or values
        rows = {}
        for c in claims():
            if c.key in values:
                outcome, split = stable_verdict(c, values[c.key])
                rows[c.key] = outcome.summary() | {
                    "split": split,
                    "blocks": block_verdicts(c, values[c.key]),
                }
        out["seas"][sea] = rows
    out["test_block"] = test_block(out["seas"]["presets"], seeds)
    x, z = presets_values["seed001.p8.xc_max"], presets_values["seed001.p8.zc_max"]
    near = (np.abs(x / SEED001_P8["x"] - 1) <= P8_NEAR / 100) & (
        np.abs(z / SEED001_P8["z"] - 1) <= P8_NEAR / 100
    )
    out["p8"] = {"near_both": int(near.sum()), "n": int(x.size),
                 "implied_l_plus_z": float(np.median(x**2 / z))}  # fmt: skip
    return out


def test_block(rows: dict[str, Any], seeds: range) -> list[int]:
    """[first, last] seed of the first block on which every stable claim gives its stated
    verdict (the block tests/test_reproduction_claims.py recomputes)."""
    stable = {k: r for k, r in rows.items() if r["verdict"] != "seed-dependent"}
    for i in range(BLOCKS):
        if all(r["blocks"][i] == block_verdict(r["verdict"]) for r in stable.values()):
            start = seeds.start + i * BLOCK
            return [start, start + BLOCK - 1]
    raise RuntimeError("no block gives every stable verdict")


def split_text(split: dict[str, int]) -> str:
    """ "NR in 4 of 10": the blocks against the majority's verdict."""
    short = {"reproduced": "R", "not reproduced": "NR", "undecided": "U"}
    parts = sorted(split.items(), key=lambda kv: kv[1])
    return ", ".join(f"{short[v]} in {k} of {BLOCKS}" for v, k in parts[:-1]) or (
        f"all {BLOCKS} blocks"
    )


def stability_cell(row: dict[str, Any] | None) -> str:
    """One sea's column of a claim: verdict, block split, mean (10 … 90 %), paper's
    percentile, the bootstrap CI."""
    if row is None:
        return "— (own sea)"
    d = digits_of(row["unit"])
    if row["kind"] == "share":
        lo, hi = (100 * v for v in row["ci"])
        body = f"holds on {100 * row['mean']:.1f} % (CI {lo:.1f} … {hi:.1f})"
    elif row["kind"] == "deterministic":
        body = (
            f"{row['mean']:.2f}"
            if row["paper"] is not None
            else ("holds" if row["mean"] > 0.5 else "does not hold")
        )
    else:
        body = (
            f"{fmt(row['mean'], d)} ({fmt(row['low'], d)} … {fmt(row['high'], d)}), "
            f"paper at P{row['percentile']:.0f}, CI {fmt(row['ci'][0], d)} … "
            f"{fmt(row['ci'][1], d)}"
        )
        if "same_sign" in row:
            body += f", paper's sign on {100 * row['same_sign']:.1f} %"
    split = split_text(row["split"])
    if row["verdict"] == "seed-dependent":
        split += f"; {100 * row['agreement']:.0f} % of {RESAMPLES} random blocks agree"
    return f"{bold(row['verdict'])} ({split}): {body}"


def sea_cause(key: str, a: dict[str, Any], b: dict[str, Any]) -> str:
    """One line on why the two seas' verdicts differ: the spectrum's shape, and the measured
    shift of the claim from the presets to the defaults."""
    cause = "spectrum's shape (γ 3.3 → 1, same Hs, Tp): "
    if a["kind"] == "share":
        return cause + f"holds on {100 * a['mean']:.1f} → {100 * b['mean']:.1f} % of seeds"
    d = digits_of(a["unit"])
    return cause + (
        f"mean {fmt(a['mean'], d)} → {fmt(b['mean'], d)} {a['unit']}, the paper's "
        f"percentile P{a['percentile']:.0f} → P{b['percentile']:.0f}"
    )


def sea_gamma(scenario: Any) -> float:
    """[-] DNV's γ at a scenario's Hs [m] and Tp [s] (what the scenario default would use)."""
    return float(dnv_gamma(float(scenario.hs), float(scenario.tp)))


def section_stability(data: dict[str, Any]) -> str:
    """The report's lead: the verdict rule, the counts over 1,000 seeds, and every claim in
    both seas with its block split (from `STABILITY_JSON`)."""
    first, last = data["seeds"]
    presets, defaults = data["seas"]["presets"], data["seas"]["defaults"]
    kinds = ("matched", "reproduced", "not reproduced", "seed-dependent")
    count = {v: sum(r["verdict"] == v for r in presets.values()) for v in kinds}
    count_d = {v: sum(r["verdict"] == v for r in defaults.values()) for v in kinds}
    rows = []
    for key, a in presets.items():
        b = defaults.get(key)
        differ = b is not None and a["verdict"] != b["verdict"]
        rows.append([a["source"], a["text"] + (f" [{a['unit']}]" if a["unit"] else "")
                     + (f" (**fitted**: {a['fitted']})" if a["fitted"] else ""),
                     fmt(a["paper"], digits_of(a["unit"])) if a["paper"] is not None else "—",
                     stability_cell(a), stability_cell(b),
                     sea_cause(key, a, b) if differ else ""])  # fmt: skip
    seed_dependent = [r["text"] for r in presets.values() if r["verdict"] == "seed-dependent"]
    block = data["test_block"]
    return f"""## Verdicts over {last - first + 1} seeds

**The rule** (`twin.runs.claims`). Every claim is evaluated on sea seeds {first}–{last}
(held out: the calibration used seeds {CALIBRATION_SEEDS.start}–{CALIBRATION_SEEDS.stop - 1})
and on each of the ten blocks of 100 seeds in them.

- **A number** is **reproduced** when the paper's value lies within our 10–90 % band (its
  percentile in our per-seed distribution between 10 and 90), and **matched** when, besides,
  the 95 % bootstrap CI of our mean over the {last - first + 1} seeds contains it; a
  **comparison** claim (DWA below method 2 by 30.8 % / 34.8 %) must also have the paper's
  sign on at least 90 % of seeds. Otherwise **not reproduced**.
- **A qualitative claim** (the paper's one run shows it holding) is reproduced when it holds on
  most seeds (the 95 % Wilson interval of the share above 50 %), not reproduced when below,
  else undecided. Seed 002's regular waves are one deterministic record: within 1 point.
- **Stability:** a verdict is stated only if at least 9 of the 10 blocks give it (matched
  counts as reproduced in a block) and so do 99 % of {RESAMPLES} random blocks of 100 of the
  seeds (a verdict near a band's edge, which a new block could flip, is not stated); otherwise
  the claim is **seed-dependent** and the split is shown ("NR in 4 of 10": four blocks say not
  reproduced).

**Counts, papers' presets:** {count["matched"]} matched, {count["reproduced"]} reproduced,
{count["not reproduced"]} not reproduced, {count["seed-dependent"]} seed-dependent (of
{len(presets)} claims). **Scenario defaults** (800 components, DNV γ): {count_d["matched"]}
matched, {count_d["reproduced"]} reproduced, {count_d["not reproduced"]} not reproduced,
{count_d["seed-dependent"]} seed-dependent (of {len(defaults)}; seed 001 has its own sea).
Seed-dependent on the presets: {"; ".join(seed_dependent) or "none"}.

Every stable verdict holds on seeds {block[0]}–{block[1]}, the block
tests/test_reproduction_claims.py recomputes. Computed by `python scripts/reproduce_claims.py`
({data.get("seconds", 0)} s from its block cache; about 3 minutes from nothing, two cores) into
`reproduction/stability.json`, which this report reads.

The scenario defaults differ from the presets in the spectrum only: DNV's γ at the presets'
Hs and Tp is {sea_gamma(PAPER_PRESETS["seed000"]):g}
(Tp/√Hs ≥ 5: Pierson–Moskowitz, a broader spectrum than the calibrated γ 3.3) on 800
components instead of 200. The last column gives the measured shift where the verdicts differ.

{
        table(
            [
                "paper",
                "claim",
                "paper's value",
                "papers' presets",
                "scenario defaults",
                "why the seas differ",
            ],
            rows,
        )
    }

{p8_finding(data)}

{eta_trend(presets)}
"""


def p8_finding(data: dict[str, Any]) -> str:
    """Seed 001's P8 maxima cannot hold together: eq 15's arithmetic."""
    platform = Upu3Up()
    length = float(platform.l)  # [mm]
    implied = SEED001_P8["x"] ** 2 / SEED001_P8["z"]
    p8 = data["p8"]
    return f"""### Finding: seed 001's three P8 maxima are inconsistent

With α = β = a(t) (P8), eq 15 gives Zc = (l + z)(cos² a − 1) ≈ −(l + z)·a² and
Xc ≈ (l + z)·a, so |Zc| ≈ |Xc|²/(l + z). The paper's |Xc| = {SEED001_P8["x"]:.1f} mm and
|Zc| = {SEED001_P8["z"]:.1f} mm imply l + z = {SEED001_P8["x"]:.1f}²/{SEED001_P8["z"]:.1f} =
{implied:.0f} mm, but l = {length:.0f} mm; ours give a median |Xc|²/|Zc| of
{p8["implied_l_plus_z"]:.0f} mm. Of {p8["n"]} seeds, {p8["near_both"]} come within
{P8_NEAR:g} % of both the paper's |Xc| and |Zc|: the paper's Xc sits in our low tail and its
Zc in our high tail, so neither verdict above says the three numbers were reproduced together.
"""


def eta_trend(rows: dict[str, Any]) -> str:
    """Seed 002's η over states 1-3: the verdict and what our loop does instead."""
    runs = seed002_runs((0.005,))
    eta = [runs[(s, 0.005)][0] for s in SEED002_ETA]
    rates = [1e3 * runs[(s, 0.005)][1] for s in SEED002_ETA]
    return f"""### The η trend over seed 002's wave states 1–3

The paper's η falls {" → ".join(f"{v:.2f}" for v in SEED002_ETA.values())} %; ours (dt 5 ms)
is {" → ".join(f"{v:.2f}" for v in eta)} %: **{rows["seed002.eta_falls"]["verdict"]}**. State 1's
η is **fitted** (kp from the paper's 98.23 %, dt 5 ms chosen for it), so only states 2–3 and
the trend test the model. Measured cause: our velocity loop is linear and never saturates
(peak limb rates {", ".join(f"{r:.1f}" for r in rates)} mm/s, far below the actuators' limit),
so η depends only on each wave component's frequency (lag ≈ ω/kp), not its amplitude; states
2 and 3 add 5 s and 7 s components, tracked better than state 1's 3 s wave, so η stays flat.
The paper's fall needs an amplitude-dependent loss its Gazebo effort loop has and ours does
not model.
"""


def main() -> None:
    """Write `STABILITY_JSON` (docs/reproduction/stability.json), which scripts/reproduce.py
    turns into the report's verdicts."""
    started = time.perf_counter()
    data = stability()
    data["seconds"] = round(time.perf_counter() - started)
    STABILITY_JSON.write_text(json.dumps(data, indent=1, ensure_ascii=False) + "\n")
    print(f"wrote {STABILITY_JSON} in {data['seconds']} s")


if __name__ == "__main__":
    main()
