"""The scenario: one flat pydantic model shared by Python, REST, CLI and GUI.

A user writes `{"mechanism": "hybrid", "planner": "mtmp", "sea_state": 4, "beta": 0.7}`;
every unset field takes the papers' default (or ours, documented in the field).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from twin.errors import TwinError
from twin.mechanisms import MECHANISMS
from twin.planners import PlannerParameters, get_planner
from twin.sea.components import WaveComponents
from twin.sea.regular import REGULAR_PRESETS
from twin.sea.sea_states import sea_state_hs_tp
from twin.sea.spectra import SpectrumName, fully_developed_tp
from twin.sea.synthesis import wave_components
from twin.vessel.rao import available_raos

#: [s] longest run one scenario may ask for, and most samples (duration / dt).
MAX_DURATION = 3600.0
MAX_STEPS = 200_000

#: [s] peak periods a scenario may have
TP_RANGE = (1.0, 30.0)
#: Most values any mechanism's state has (the hybrid system's xi).
MAX_STATE_SIZE = 9

#: Planner a mechanism gets when the scenario names none.
DEFAULT_PLANNER = {"hybrid": "mtmp", "upu3up": "pid", "upr4": "pid"}


class MotionSource(BaseModel):
    """Where a run's base motion comes from: the synthesised sea through the vessel's RAOs
    (`sea`, the default) or a stored motion log (`log`: `twin.sim.measured`)."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    source: Literal["sea", "log"] = Field("sea", description="sea: sea → RAOs → mount; log: "
                                          "a stored motion log moved to the mount")  # fmt: skip
    log: str | None = Field(None, pattern=r"^[0-9a-f]{16}$",
                            description="the stored log's ID (POST /api/motion-logs)")  # fmt: skip
    offset: float = Field(0.0, ge=0.0, le=7 * 86_400.0,
                          description="[s] where in the log the run starts")  # fmt: skip

    @model_validator(mode="after")
    def _log_named(self) -> MotionSource:
        if (self.source == "log") != (self.log is not None):
            raise TwinError("base_motion: a log ID goes with source 'log', and only with it")
        return self


class Scenario(PlannerParameters):
    """A run: mechanism, planner and its knobs, sea, vessel, time. Flat on purpose."""

    mechanism: Literal["hybrid", "upu3up", "upr4"] = Field(
        "hybrid", description="registry name (twin.mechanisms.MECHANISMS)"
    )
    planner: str | None = Field(
        None,
        description="pi, wpi, mtmp, dwa, conv1, conv2, qp (hybrid); pid, ik (upu3up, upr4); "
        "default mtmp for the hybrid system, pid for the small platforms",
    )
    sea_state: float = Field(4.0, ge=0.0, le=9.0, description="[-] WMO sea-state code 0-9")
    hs: float | None = Field(
        None, ge=0.0, le=20.0, description="[m] significant wave height; overrides sea_state"
    )
    tp: float | None = Field(
        None,
        ge=TP_RANGE[0],
        le=TP_RANGE[1],
        description="[s] peak period; overrides sea_state (default with hs: fully developed, "
        "kept within 1-30 s)",
    )
    heading: float = Field(
        150.0,
        ge=-360.0,
        le=360.0,
        description="[deg] direction the waves travel towards, counter-clockwise from the bow "
        "seen from above (vessel x bow, y port, z up; docs/frames.md): 180 = head seas (from "
        "ahead), 0 = following seas, 90 = beam seas from starboard (travelling to port), 270 = "
        "beam seas from port; the waves come from heading − 180°, e.g. 150 = from 30° off the "
        "starboard bow, 225 = from 45° off the port bow",
    )
    spectrum: SpectrumName = Field(
        "jonswap", description="wave spectrum (seed 001 eq 28); `pm` is short for pierson_moskowitz"
    )
    gamma: float | None = Field(
        None,
        ge=1.0,
        le=10.0,
        description="[-] JONSWAP peak enhancement γ; None: DNV-RP-C205 §3.5.5.5's rule from "
        "Tp/√Hs (5 at ≤ 3.6, exp(5.75 − 1.15 Tp/√Hs) between, 1 at ≥ 5: 1 for the WMO sea "
        "states' fully developed seas); 3.3 is the JONSWAP mean the papers' presets pin",
    )
    spreading: float | None = Field(
        None,
        ge=1.0,
        le=100.0,
        description="[-] cos-2s spreading exponent s; None: long-crested",
    )
    n_components: int = Field(
        800,
        ge=8,
        le=2048,
        description="[-] wave components, random frequencies inside equal bins; 800 so a live "
        "session's vessel motion does not repeat within hours (docs/sea.md); the papers' "
        "presets pin 200",
    )
    regular_waves: Literal["state1", "state2", "state3"] | None = Field(
        None,
        description="seed 002 Table 2 regular-wave state instead of a spectrum (directions "
        "relative to the bow; sea_state, hs, tp, heading are then unused)",
    )
    vessel: str | None = Field(
        None, description="RAO table name (assets/vessels); default: the mechanism's mount"
    )
    base_motion: MotionSource | None = Field(
        None,
        description='the base motion\'s source: null or {"source": "sea"} the synthesised sea '
        '(the sea fields above); {"source": "log", "log": ID, "offset": s} a stored motion log '
        "(the sea fields are then unused)",
    )
    forward_speed: float = Field(
        0.0, ge=0.0, le=10.0, description="[m/s] vessel forward speed (0: on DP)"
    )
    joint_limits: Literal["record", "hold"] = Field(
        "record",
        description="record: joints and legs may pass their limits and each such sample "
        "counts as a violation (the papers' kinematic studies); hold: a step that would carry "
        "one further past its limit is shortened to stop there, like an end stop (the live "
        "session's default)",
    )
    duration: float = Field(
        200.0, gt=0.0, le=MAX_DURATION, description="[s] simulated time (seed 000: 200 s)"
    )
    dt: float = Field(0.05, ge=0.005, le=0.2, description="[s] control period (seed 000: 0.05)")
    seed: int = Field(0, ge=0, le=2**32 - 1, description="random-phase seed of the sea")
    initial_state: list[float] | None = Field(
        None,
        max_length=MAX_STATE_SIZE,
        description="mechanism state at t = 0 within its state limits (hybrid: xi, 9 values "
        "[m, rad]; upu3up: z [mm], α, β [rad]; upr4: z [m], α, β [rad]); default: the working "
        "state",
    )

    @field_validator("spectrum", mode="before")
    @classmethod
    def _spectrum_alias(cls, value: object) -> object:
        return "pierson_moskowitz" if value == "pm" else value

    @model_validator(mode="after")
    def _consistent(self) -> Scenario:
        planner = DEFAULT_PLANNER[self.mechanism] if self.planner is None else self.planner
        get_planner(planner, self.mechanism)  # raises naming the allowed ones, "" included
        if self.planner is None:
            object.__setattr__(self, "planner", planner)
        steps = self.duration / self.dt
        if steps > MAX_STEPS:
            raise TwinError(
                f"duration / dt = {steps:.0f} steps; allowed at most {MAX_STEPS} "
                f"(e.g. duration ≤ {MAX_STEPS * self.dt:g} s at dt = {self.dt} s)"
            )
        if self.vessel is not None:
            known = available_raos()
            if self.vessel not in known and not Path(self.vessel).suffix == ".nc":
                raise TwinError(
                    f"vessel: unknown {self.vessel!r}; shipped RAO tables: {known}, or a path "
                    "to your own .nc file in the same layout (docs/vessel.md)"
                )
        if self.initial_state is not None:
            _check_state(self.mechanism, self.initial_state)
        return self

    @property
    def planner_name(self) -> str:
        """The planner's registry name: `planner`, which validation sets to the mechanism's
        default (`DEFAULT_PLANNER`) when none is given, so never None here."""
        return DEFAULT_PLANNER[self.mechanism] if self.planner is None else self.planner

    def parameters(self) -> PlannerParameters:
        """The planner knobs alone (a scenario is a `PlannerParameters` with more fields)."""
        return PlannerParameters(**self.model_dump(include=set(PlannerParameters.model_fields)))

    def components(self) -> WaveComponents:
        """The sea as wave components: seed 002's regular preset or a seeded spectrum."""
        if self.regular_waves is not None:
            return REGULAR_PRESETS[self.regular_waves]
        hs, tp = self.sea()
        return wave_components(
            hs, tp, self.spectrum, heading=np.deg2rad(self.heading), spreading=self.spreading,
            seed=self.seed, n_components=self.n_components, gamma=self.gamma,
        )  # fmt: skip

    def sea(self) -> tuple[float, float]:
        """(hs [m], tp [s]): hs/tp when given, else the WMO sea-state table."""
        hs_table, tp_table = (float(v) for v in sea_state_hs_tp(self.sea_state))
        hs = self.hs if self.hs is not None else hs_table
        if self.tp is not None:
            return hs, self.tp
        if self.hs is None:
            return hs, tp_table
        # below Hs ≈ 0.04 m a fully developed sea peaks under 1 s, outside the tp range
        return hs, float(np.clip(fully_developed_tp(hs), TP_RANGE[0], TP_RANGE[1]))


def check_one_sea(given: Mapping[str, Any]) -> None:
    """Refuse a request that sets the sea twice: `sea_state` (a WMO code) with `hs` or `tp`.

    `Scenario` lets `hs`/`tp` override `sea_state`, so a stored scenario carries both; a
    request (REST, the live session's PATCH) that writes both would silently lose one.

    Args:
        given: the fields as the request wrote them.

    Raises:
        TwinError: naming which to drop.
    """
    def number(name: str) -> bool:  # anything else gets its own error from its field
        value = given.get(name)
        return isinstance(value, int | float) and not isinstance(value, bool)

    both = [name for name in ("hs", "tp") if number(name)]
    if number("sea_state") and both:
        named = " and ".join(both)
        raise TwinError(
            f"sea_state: given together with {named}, which set the sea themselves; drop "
            f"sea_state to keep {named}, or drop {named} to use WMO sea state "
            f"{given['sea_state']}"
        )


def _check_state(mechanism: str, state: list[float]) -> None:
    """TwinError unless `state` has the mechanism's size and lies within its state limits."""
    model = MECHANISMS[mechanism]()
    n = model.working_state.size
    if len(state) != n:
        raise TwinError(f"initial_state: {mechanism} has {n} state values, got {len(state)}")
    low, high = model.state_limits
    x = np.asarray(state, dtype=float)
    bad = np.flatnonzero((x < low - 1e-9) | (x > high + 1e-9))
    if bad.size:
        i = int(bad[0])
        raise TwinError(
            f"initial_state[{i}] = {x[i]:g} is outside {mechanism}'s state limits; allowed "
            f"{low[i]:.6g} ≤ initial_state[{i}] ≤ {high[i]:.6g} (all limits: "
            f"{np.round(low, 4).tolist()} .. {np.round(high, 4).tolist()})"
        )
