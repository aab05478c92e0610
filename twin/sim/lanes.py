"""A mechanism's lanes in the engine: its kernel, its constants, its planners packed, its record.

The engine (`twin.sim.engine.Simulation`) is the same for every mechanism: it samples the
base, builds the held targets, calls a compiled kernel over a chunk and keeps the history.
What differs — the state, the kernel, how a planner object becomes kernel rows, what is
recorded and judged — is one class per kind of mechanism here.

Planner objects (`twin.planners`) are built by the registry as always and packed into rows of
`prm` and `memory` (`twin.sim.kernels.layout`): the objects state the math and configure the
kernel, which runs it.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from twin.compiled import pick_runner
from twin.errors import TwinError
from twin.mechanisms import HybridBoardingSystem
from twin.planners import (
    HYBRID_RATE_LIMITS,
    PlatformModel,
    PlatformPlanner,
    TipTarget,
    get_planner,
)
from twin.planners.allocation_step import pack_allocation
from twin.planners.differential_step import pack_differential
from twin.planners.families import FAMILY_DIAGNOSTICS
from twin.planners.parameters import as_record, as_records
from twin.planners.qp_step import pack_qp
from twin.sim.kernels import layout
from twin.sim.metrics import (
    HybridReduction,
    PlatformReduction,
    Reduction,
    hybrid_metrics,
    hybrid_metrics_lanes,
    platform_metrics,
    platform_metrics_lanes,
)
from twin.sim.records import (
    hybrid_records,
    landing_frame,
    platform_records,
    record_arrays,
    record_views,
)
from twin.sim.scenario import Scenario
from twin.sim.scratch import scratch
from twin.sim.target import held_targets
from twin.spatial import pose_to_transform

#: the engines: "numba" (compiled), "python" (the same kernels interpreted, lane by lane: for
#: machines where numba cannot import; the same numbers), "auto" (numba when it imports)
ENGINES = ("auto", "numba", "python")


def numba_available() -> bool:
    """Whether the compiled engine can run (numba importable)."""
    try:
        import numba  # noqa: F401
    except ImportError:
        return False
    return True


def use_numba(engine: str) -> bool:
    """Whether `engine` compiles; a TwinError for an unknown or unavailable one."""
    if engine == "numpy":  # the name of the interpreted engine before there was one engine
        engine = "python"
    if engine not in ENGINES:
        raise TwinError(f"engine: unknown {engine!r}; allowed: {list(ENGINES)}")
    if engine == "numba" and not numba_available():
        raise TwinError("engine: 'numba' needs the numba package (pip install numba)")
    return engine == "numba" or (engine == "auto" and numba_available())


def runner(kind: str, compiled: bool, lanes: int) -> Any:
    """The chunk runner of `kind` ("hybrid" or "platform") for `lanes` lanes (`pick_runner`)."""
    from twin.sim.kernels import hybrid_runner, platform

    if kind == "hybrid":  # the qp family has a runner of its own (`HybridRunners`)
        return hybrid_runner.HybridRunners(
            pick_runner(hybrid_runner.compiled_hybrid, hybrid_runner.run_hybrid, compiled, lanes),
            pick_runner(
                hybrid_runner.compiled_hybrid_qp, hybrid_runner.run_hybrid_qp, compiled, lanes
            ),
        )
    return pick_runner(platform.compiled_platform, platform.run_platform, compiled, lanes)


def tip_target(row: np.ndarray) -> TipTarget:
    """A `TipTarget` from a packed target row (N_TARGET,) (`layout.TARGET`)."""
    target = as_record(np.ascontiguousarray(row), layout.TARGET)
    T = np.eye(4)
    T[:3, :3] = target.R_d.reshape(3, 3)
    T[:3, 3] = target.p_d
    return TipTarget(T, np.array(target.twist))


#: a lane's packed planner: its parameter row (`layout.ROW_SIZE`) and memory row (`N_MEMORY`)
Packed = tuple[np.ndarray, np.ndarray]


def _stateless(pack: Callable[[Any, bool], np.ndarray]) -> Callable[[Any, bool], Packed]:
    """A family's row packer as one that also gives the lane's (empty) planner memory."""
    return lambda planner, hold: (pack(planner, hold), np.zeros(layout.N_MEMORY))


#: (prm row, memory row) of a reset planner, by its family: how the hybrid kernel's lanes are
#: packed (`HybridLanes.pack`); a planner composed of existing parts needs only a registry line
HYBRID_PACKERS: dict[str, Callable[[Any, bool], Packed]] = {
    "differential": _stateless(pack_differential),
    "allocation": pack_allocation,
    "qp": _stateless(pack_qp),
}
#: the families the hybrid kernel runs
HYBRID_FAMILIES = tuple(HYBRID_PACKERS)


class HybridLanes:
    """The hybrid boarding system's lanes: state xi (9,) [m, rad] (seed 000 eq (14)).

    Args:
        mechanism: the hybrid system.
        x0: (N, 9) states at t = 0 (set-points such as MTMP's q̃2 stay at these, eq (40)).
        T_IB0: (N, 4, 4) the base at t = 0, where each lane's held tip pose ᴵT_E* is fixed.
    """

    kind = "hybrid"
    state_key = "xi"

    def __init__(
        self,
        mechanism: HybridBoardingSystem,
        x0: np.ndarray,
        T_IB0: np.ndarray,
        compiled: bool = True,
    ):
        from twin.sim.kernels.hybrid import hybrid_constants
        from twin.sim.kernels.records import compiled_records, run_hybrid_records

        self.mechanism = mechanism
        self.compiled = compiled
        self._records = pick_runner(compiled_records, run_hybrid_records, compiled, len(x0))
        self.x0 = np.array(x0, dtype=float)
        self.held = T_IB0 @ mechanism.end_effector(self.x0)
        self.landing, self.gangway0 = landing_frame(T_IB0, self.x0, mechanism)
        self.const = hybrid_constants(mechanism, HYBRID_RATE_LIMITS)
        self.n_diagnostics = layout.N_HYBRID_DIAGNOSTICS
        self.extra: np.ndarray | None = None  # the small platforms' actuator lengths
        # the chunk's arrays for legs, tip errors and scalars, and its targets and what the
        # kernel handed over (made by `run`, filled by `records`)
        self._recorded = record_arrays(len(self.x0), 0)
        self._handed: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self._xs = np.empty((len(self.x0), 0, 9))  # the chunk's states (`run`)
        self._rows: dict[tuple, np.ndarray] = {}  # packed differential planners (`pack`)

    def pack(
        self, lane: int, scenario: Scenario, x: np.ndarray, target: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Build the lane's planner from the registry, reset it at state x and target row
        (18,), and pack it: (prm row, memory row).

        The registry entry's family picks the packer (`HYBRID_PACKERS`). A differential
        planner keeps no state (its reset does nothing), so its row depends only on its name,
        knobs, hold mode and the lane's start x0: lanes alike (a batch of seeds) share one
        build, kept by this object (`_rows`)."""
        hold = scenario.joint_limits == "hold"
        knobs = scenario.parameters()
        key = (scenario.planner_name, knobs.model_dump_json(), hold, self.x0[lane].tobytes())
        if key in self._rows:
            return self._rows[key].copy(), np.zeros(layout.N_MEMORY)
        spec = get_planner(scenario.planner_name, "hybrid")
        packer = HYBRID_PACKERS.get(spec.family)
        planner = spec.build(self.mechanism, knobs, self.x0[lane])
        if packer is None or getattr(planner, "family", None) != spec.family:
            raise TwinError(f"planner {scenario.planner!r}: no hybrid kernel packs a "
                            f"{type(planner).__name__} of family {spec.family!r}")  # fmt: skip
        planner.reset(x, tip_target(target))
        row, memory = packer(planner, hold)
        if spec.family == "differential":  # stateless: lanes alike share the row
            self._rows[key] = row
            return row.copy(), memory
        return row, memory

    def run(
        self,
        run: Any,
        xs: np.ndarray,
        targets: np.ndarray,
        prm: np.ndarray,
        memory: np.ndarray,
        dt: float,
        diag: np.ndarray,
        faults: np.ndarray,
        first: int = 1,
    ) -> None:
        """Run the kernel `run` over a chunk (arrays as `twin.sim.kernels.layout` says; targets
        (N, B + 1, 18), the last row the chunk's end, `held_targets` with `end=True`): every
        lane, of every family (qp included: its QP is solved in the lane,
        `twin.planners.qp_step`), through `run` for the whole chunk, a differential lane handing
        over the tips and errors of samples first … B − 1
        (`twin.sim.kernels.hybrid_runner`). `records`, called next, records every lane's
        samples first … B."""
        from twin.sim.kernels.records import N_TIP

        N, S = xs.shape[:2]
        self._recorded = record_arrays(N, S)
        errors = self._recorded[1]  # the kernel hands differential lanes' errors over into it
        tips = scratch("tips", (N, S, N_TIP))  # dies with the chunk
        kinds = as_records(prm, layout.COMMON_PARAMETERS)["kind"]
        handed = np.where(kinds == layout.KIND_DIFFERENTIAL, S - 1, 0)
        run(xs, targets, prm, memory, self.const, dt, diag, faults, first, errors, tips)
        self._handed = (targets, handed, tips)
        self._xs = xs  # what `reduce` records

    def records(
        self, poses: np.ndarray, xs: np.ndarray, diag: np.ndarray, dt: float, first: int = 1
    ) -> dict:
        """Records (N, S − first, …) of the chunk `run` just stepped (`run_hybrid_records`, with
        its targets and what its differential lanes handed over): its states xs (N, S, 9) on
        base poses (N, S, 6) with the steps' diagnostics (N, S, N_HYBRID_DIAGNOSTICS), the start
        in row 0, samples first … S − 1 (first = 1: the start was recorded with the chunk
        before; 0: a run's first chunk recording its start too)."""
        from twin.sim.kernels.records import keep_records

        del dt  # Unused: nothing recorded is a rate.
        if self._handed is None:  # each chunk is recorded once, after `run`
            raise RuntimeError("HybridLanes.records: no chunk stepped since; call run first")
        targets, handed, tips = self._handed
        self._handed = None  # the scratch rows die with the chunk
        legs, errors, scalars = self._recorded
        self._records(targets, xs, first, handed, self.held, self.landing, self.gangway0,
                      self.const, legs, errors, scalars, tips, *keep_records(len(xs)))  # fmt: skip
        return self._with_state(poses, xs, diag, record_views(*self._recorded, first), first)

    def state_records(self, poses: np.ndarray, xs: np.ndarray, diag: np.ndarray) -> dict:
        """The records of the chunk `run` just stepped that are its own arrays (views, nothing
        computed): base poses, states and diagnostics of samples 1 … S − 1, (N, S − 1, …)."""
        return self._with_state(poses, xs, diag, {}, 1)

    def reduction(self, ends: np.ndarray, joint_limits: Sequence[str]) -> HybridReduction:
        """The lanes' running metrics for keep="metrics" (`HybridReduction`), lane n over its
        first ends[n] samples in its `joint_limits` mode."""
        return HybridReduction(self.mechanism, ends, joint_limits, self.compiled)

    def reduce(self, reduction: Reduction, t: np.ndarray, start: int) -> dict | None:
        """keep="metrics": samples 1 … S − 1 of the chunk `run` just stepped, each recorded and
        added to `reduction` at once (`run_hybrid_records` reducing), its records never kept.

        Args:
            reduction: the lanes' running metrics (`reduction`), samples up to `start` added.
            t: (S − 1,) the samples' times [s]; start: the index of sample 1 in the run.

        Returns:
            Sample S − 1's computed records (N, 1, …) (`record_views`' keys), or None where
            a state or record is not finite: then `reduction` holds part of the chunk (the
            caller puts back what it held before, as `Simulation` does), and `records` (still
            to be called) records the chunk, to be held as a series is.

        Raises:
            ValueError: samples that do not follow those already added.
        """
        if self._handed is None:  # each chunk is recorded once, after `run`
            raise RuntimeError("HybridLanes.reduce: no chunk stepped since; call run first")
        targets, handed, tips = self._handed
        xs, S = self._xs, len(t) + 1
        if np.any(reduction.seen != np.minimum(reduction.ends, start)):
            raise ValueError(f"reduction: samples from {start} on, after {reduction.seen}")
        # legs and scalars: one row each sample overwrites; the errors: the chunk's, where
        # the kernel handed its differential lanes' over (kept for `records` if one is not
        # finite)
        legs, _, scalars = record_arrays(len(xs), 1)
        errors = self._recorded[1]
        finite = np.ones(len(xs), dtype=bool)
        self._records(targets, xs, 1, handed, self.held, self.landing, self.gangway0,
                      self.const, legs, errors, scalars, tips, reduction.acc,
                      np.ascontiguousarray(t), reduction.hold,
                      np.clip(reduction.ends - start, 0, S - 1), finite)  # fmt: skip
        if not finite.all():
            return None
        self._handed = None  # the scratch rows die with the chunk
        return record_views(legs, errors[:, -1:], scalars, 0)

    def initial_records(self, poses: np.ndarray, x: np.ndarray) -> dict:
        """Records (N, 1, …) at t = 0 (diagnostics zero: the engine repeats the first step's)."""
        start = held_targets(self.held, poses, 1.0, self.compiled, end=True)  # no step: no dt
        out = hybrid_records(start, x[:, None], self.held, self.landing, self.gangway0,
                             self.const, self._records)  # fmt: skip
        del out["xi"]
        diag = np.zeros((len(x), 1, self.n_diagnostics))
        return self._with_state(poses, x[:, None], diag, out, 0)

    def _with_state(
        self, poses: np.ndarray, xs: np.ndarray, diag: np.ndarray, out: dict, first: int
    ) -> dict:
        """The records `out` with the samples' base poses, states and diagnostics from
        `first` on."""
        out = {"base_pose": poses[:, first:], "xi": xs[:, first:], **out}
        diagnostics = as_records(diag[:, first:], layout.HYBRID_DIAGNOSTICS)  # by name
        for name in ("weights", "null_space_share", "damping", "velocity_scale",
                     "position_share", "limit_scale", "qp_level", "qp_active"):
            out[name] = diagnostics[name]  # fmt: skip
        return out

    #: every hybrid family's diagnostics (a lane keeps its own planner's, `keys`)
    diagnostics = frozenset().union(*(FAMILY_DIAGNOSTICS[f] for f in HYBRID_FAMILIES))

    def keys(self, planner: str) -> set[str]:
        """The diagnostics a planner's lanes record: its registry entry's
        (`PlannerSpec.series_diagnostics`)."""
        return set(get_planner(planner, "hybrid").series_diagnostics)

    def metrics(
        self, series: dict[str, np.ndarray], lane: int, joint_limits: str = "record"
    ) -> dict:
        del lane  # Unused: every lane is the same machine.
        return hybrid_metrics(series, self.mechanism, joint_limits, self.compiled)

    def metrics_lanes(
        self, data: dict[str, np.ndarray], ends: np.ndarray, joint_limits: Sequence[str]
    ) -> list[dict]:
        """Every lane's `metrics` at once from its series as (N, C, ...) arrays (the history's,
        in place), lane n over its first ends[n] samples: one compiled pass over all lanes
        (`hybrid_metrics_lanes`)."""
        return hybrid_metrics_lanes(data, ends, self.mechanism, joint_limits, self.compiled)


class PlatformLanes:
    """The 3UPU_UP's or 4-UPR's lanes: state (z, α, β) (seed 001 / seed 002) and actuator
    lengths [native: mm for the Upu3Up, m for the Upr4].

    Args:
        mechanism: the Upu3Up or Upr4.
        x0: (N, 3) states at t = 0 (the Upr4 holds each lane's z, seed 002 §4).
        T_IB0: (N, 4, 4) the base at t = 0: each lane holds the top level at its inertial
            position then, with the base's heading.
    """

    kind = "platform"
    state_key = "state"

    def __init__(self, mechanism: Any, x0: np.ndarray, T_IB0: np.ndarray, compiled: bool = True):
        from twin.sim.kernels.platform import N_PLATFORM_DIAGNOSTICS, platform_constants

        self.compiled = compiled  # the metrics' runners (the records are numpy, lane by lane)
        self.mechanism = mechanism
        self.x0 = np.array(x0, dtype=float)
        self.models = [PlatformModel(mechanism, z_hold=float(z)) for z in self.x0[:, 0]]
        self.model = self.models[0]
        top = T_IB0 @ self.model.transform(self.x0)
        yaw = np.arctan2(T_IB0[:, 1, 0], T_IB0[:, 0, 0])
        zero = np.zeros(len(yaw))
        self.held = pose_to_transform(np.stack([*top[:, :3, 3].T, zero, zero, yaw], -1))
        self.const = platform_constants(self.model)
        self.n_diagnostics = N_PLATFORM_DIAGNOSTICS
        n = self.model.n_legs
        self.extra = np.zeros((len(self.x0), 4))
        self.extra[:, :n] = self.model.leg_lengths(self.x0)
        self._legs = self.extra[:, None]

    def pack(
        self, lane: int, scenario: Scenario, x: np.ndarray, target: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Build the lane's planner, reset it at its actuator lengths and target row (18,),
        and pack it: (prm row, memory row). It is built at the lane's start x0, so a rebuilt
        planner holds the Upr4 at the height it held from t = 0 (the recorded desired state)."""
        from twin.sim.kernels.platform import pack_platform

        del x  # Unused: the actuator lengths are the platform planner's state.
        spec = get_planner(scenario.planner_name, self.models[lane].name)
        planner = spec.build(self.mechanism, scenario.parameters(), self.x0[lane])
        if not isinstance(planner, PlatformPlanner):
            name = type(planner).__name__
            raise TwinError(f"planner {scenario.planner_name!r}: no kernel packs {name}")
        n = self.model.n_legs
        planner.reset(self.extra[lane, :n].copy(), tip_target(target))
        return pack_platform(planner, scenario.joint_limits == "hold")

    def run(
        self,
        run: Any,
        xs: np.ndarray,
        targets: np.ndarray,
        prm: np.ndarray,
        memory: np.ndarray,
        dt: float,
        diag: np.ndarray,
        faults: np.ndarray,
        first: int = 1,
    ) -> None:
        """Run the kernel `run` over a chunk (arrays as `twin.sim.kernels.layout` says); the
        states and actuator lengths are all `records` needs, so `first` changes nothing."""
        del first  # Unused: `records` computes the record from the states.
        legs = np.empty((xs.shape[0], xs.shape[1], 4))
        legs[:, 0] = self.extra
        run(xs, legs, targets, prm, memory, self.const, dt, diag, faults)
        self._legs = legs  # read by `records`

    def records(
        self, poses: np.ndarray, xs: np.ndarray, diag: np.ndarray, dt: float, first: int = 1
    ) -> dict:
        """Records (N, S − first, …) of the chunk just run (`run` keeps its actuator lengths):
        its states xs (N, S, 3) on base poses (N, S, 6) with the steps' diagnostics, the start
        in row 0, samples first … S − 1 (as `HybridLanes.records`; the start's rates are 0)."""
        from twin.sim.kernels.platform import PLATFORM_DIAGNOSTICS

        legs = self._legs[:, :, : self.model.n_legs]
        self.extra = self._legs[:, -1].copy()
        rates = np.zeros_like(legs)
        rates[:, 1:] = np.diff(legs, axis=1) / dt
        out = self._lanes(poses[:, first:], xs[:, first:], legs[:, first:], rates[:, first:])
        diagnostics = as_records(diag[:, first:], PLATFORM_DIAGNOSTICS)  # by name
        out["clipped"] = diagnostics["clipped"]
        out["saturated"] = diagnostics["saturated"]
        return out

    def initial_records(self, poses: np.ndarray, x: np.ndarray) -> dict:
        """Records (N, 1, …) at t = 0: the start, nothing moved yet."""
        legs = self.extra[:, None, : self.model.n_legs]
        out = self._lanes(poses, x[:, None], legs, np.zeros_like(legs))
        out["clipped"] = np.zeros((len(x), 1))
        out["saturated"] = np.zeros((len(x), 1))
        return out

    def _lanes(
        self, poses: np.ndarray, state: np.ndarray, legs: np.ndarray, rates: np.ndarray
    ) -> dict[str, np.ndarray]:
        """`platform_records` lane by lane (each lane's model holds its own z), stacked."""
        lanes = [
            platform_records(m, poses[i : i + 1], state[i : i + 1], legs[i : i + 1],
                             rates[i : i + 1], self.held[i : i + 1])
            for i, m in enumerate(self.models)
        ]  # fmt: skip
        return {key: np.concatenate([r[key] for r in lanes]) for key in lanes[0]}

    #: both laws record the same: no family's diagnostics to leave out
    diagnostics: frozenset[str] = frozenset()

    def keys(self, planner: str) -> set[str]:
        del planner  # Unused: both laws record the same.
        return set()

    def reduction(self, ends: np.ndarray, joint_limits: Sequence[str]) -> PlatformReduction:
        """The lanes' running metrics for keep="metrics" (`PlatformReduction`): each chunk is
        recorded, then reduced (these lanes have no `reduce`)."""
        return PlatformReduction(self.models, ends, joint_limits, self.compiled)

    def metrics(
        self, series: dict[str, np.ndarray], lane: int, joint_limits: str = "record"
    ) -> dict:
        return platform_metrics(series, self.models[lane], joint_limits, self.compiled)

    def metrics_lanes(
        self, data: dict[str, np.ndarray], ends: np.ndarray, joint_limits: Sequence[str]
    ) -> list[dict]:
        """Every lane's `metrics` from its series as (N, C, ...) arrays (the history's, in
        place), lane n over its first ends[n] samples: one compiled pass over all lanes
        (`platform_metrics_lanes`)."""
        return platform_metrics_lanes(data, ends, self.models, joint_limits, self.compiled)
