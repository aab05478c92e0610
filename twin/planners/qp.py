r"""The `qp` planner: each step a small quadratic program over the nine virtual-joint rates,
with the machine's limits as hard inequalities (beyond the papers; issue 15).

The papers' planners are weighted pseudo-inverses whose limits are soft: MTMP's joint-limit
weights (seed 000 eqs (35)-(37)) guard Table 6's virtual-joint box, not the legs, and nothing
stops a rate limit but a common scale. The field's task-based differential IK (mink, pink,
Drake's DifferentialInverseKinematics) solves each step as a QP with hard inequalities. Here,
with v = [ᴾṖ; ω_P; q̇1; q̇2; ḋ3] (the platform's body twist in P, then the gangway rates, as
every hybrid planner's velocity; `HybridBoardingSystem.integrate`):

    minimise   ½ w_o |J_o v − b_o|²  +  ½ w_s Σ_a |J_a v − b_a|²  +  ½ μ Σ_j v_j² / w_j
    subject to J_p v = b_p                                  (tip position, exactly)
               lower ≤ C v ≤ upper                           (legs, Table 6: velocity dampers)
               |v_j| ≤ v_j,max                               (HYBRID_RATE_LIMITS)

- b = ẋ_d + k_e e, the closed-loop demand of seed 000 eq (34) (e with SPEC erratum 6), J the
  task Jacobian of eq (24), split into its position rows (p) and orientation rows (o);
- the secondary terms a are MTMP's, at the lower weight w_s: q2 held at its start (eqs (39)-
  (40), SPEC erratum 5) and Algorithm 1's slew priority as a term that keeps the platform's
  yaw (`PlatformYawTask`), the slew joint taking the rest of the tip's yaw;
- μ Σ v_j² / w_j with w = `BetaSplit(β, l)` (eq (28)) picks among what is left and keeps the
  Hessian positive definite (the Levenberg-Marquardt damping of mink and pink);
- the inequalities are velocity dampers in mink's form: a coordinate s with limits
  [s_min, s_max] moves by at most a fraction `gain` of its remaining room in one step,
  gain (s_min + margin − s) / dt ≤ ṡ ≤ gain (s_max − margin − s) / dt, where ṡ is linear in v:
  the six leg rates l̇ = J_P [ᴮR_P ᴾṖ; ᴮR_P ω_P] (seed 000 eq (8)); the platform's pose
  coordinates, whose rates are ᴮR_P ᴾṖ and E(rpy)⁻¹ ᴮR_P ω_P (`twin.spatial.rpy_rate_matrix`:
  the pose is [x, y, z, roll, pitch, yaw] while the velocity is a body twist); the gangway's
  q1, q2, d3 (rates v_6, v_7, v_8). The margin is 1 mm plus a bound on a step's second-order
  part (the rows are linear, the legs and Euler angles are not: `LegStrokeLimit`,
  `JointLimit`), so a step within the rows never carries a coordinate past its limit.

When the limits leave no rates that meet the tip position exactly, the position becomes a term
of weight `position_weight` (level 1). When no rates meet every limit at all (a state outside
its limits that the rate limits cannot bring back in one step), the limit rows take slacks
s ≥ 0, lower − s ≤ C v ≤ upper + s, weighted `SLACK_WEIGHT` (level 2): the closest feasible
rates; the engine flags the step `Fault.INFEASIBLE`. The rate limits are never relaxed.

The matrices are written once, by the engine's qp lane (`twin.planners.qp_step`:
`qp_problem_lane`, `leg_rows_lane`, `joint_rows_lane`, `count_active_lane`); the objects here
say what they are, pack their knobs by name (`pack`), and run those lanes over a batch
(`QPPlanner.problem`, `QPPlanner.step`, the limits' `rows`, `count_active`; `twin.batch`).
`solve_levels` solves the matrices, by default with `solve_levels_lane`: the three levels over
the compiled dual active-set method of Goldfarb and Idnani (`twin.planners.active_set`), the
very function the engine's qp lanes run. DAQP, ProxQP and quadprog stay selectable on the
object for comparison (docs/decisions.md, "The qp planner's solver" and "The qp planner in
the compiled lane").
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import ClassVar, NamedTuple

import daqp
import numpy as np

from twin.errors import TwinError
from twin.mechanisms.hybrid import HYBRID_CONSTANTS, N_HYBRID_CONSTANTS, HybridBoardingSystem
from twin.planners.active_set import INF
from twin.planners.families import QP_PARAMETERS
from twin.planners.lane_rows import HYBRID_DIAGNOSTICS, N_HYBRID_DIAGNOSTICS
from twin.planners.parameters import (
    KIND_QP,
    as_records,
    pack_part,
    parameter_record,
    parameter_row,
    refuse,
)
from twin.planners.qp_levels import N_POSITION, SLACK_WEIGHT, levels_work, solve_levels_lane
from twin.planners.qp_step import COUNT_ACTIVE, LIMIT_ROWS, N_QP_ROWS, QP_PROBLEM, QP_STEP
from twin.planners.target import PlannerOutput, TipTarget
from twin.planners.tasks import JointPostureTask, PlatformYawTask, TipPoseTask, target_rows
from twin.planners.weights import BetaSplit
from twin.validation import as_array

#: solvers `solve_levels` can call: the compiled Goldfarb-Idnani method the engine runs
#: (`twin.planners.active_set`), DAQP directly, or a library through qpsolvers (for comparison)
SOLVERS = ("active_set", "daqp", "proxqp", "quadprog")
def pack_damper(limit: LegStrokeLimit | JointLimit, record: np.record, name: str) -> None:
    """Write a velocity-damper limit's gain and margin into the `QP_PARAMETERS` record's
    `<name>_gain`, `<name>_margin`.

    Raises:
        TwinError: the record has this limit already, a gain outside (0, 1], a margin that is
            negative or not finite, or a rate box other than the record's (`RateLimit.pack`
            writes it first).
    """
    if record[f"{name}_gain"] > 0.0:
        raise refuse(f"a second {type(limit).__name__} ({limit!r:.80})")
    if not (0 < limit.gain <= 1 and np.isfinite(limit.margin) and limit.margin >= 0):
        raise refuse(f"the limit {limit!r:.80} (gain in (0, 1], margin ≥ 0)")
    if not np.array_equal(np.broadcast_to(limit.rate, (9,)), record["rate"]):
        raise refuse(f"the limit {limit!r:.80} on another rate box than the QP's")
    record[f"{name}_gain"], record[f"{name}_margin"] = limit.gain, limit.margin


class Rows(NamedTuple):
    """Linear rows of a limit: lower ≤ C v ≤ upper, C (m, 9), lower and upper (m,)."""

    C: np.ndarray
    lower: np.ndarray
    upper: np.ndarray


def checked_dt(dt: float) -> float:
    """dt [s] as a float, or TwinError unless finite and > 0 (the dampers divide by it)."""
    value = float(dt)
    if not (math.isfinite(value) and value > 0):
        raise TwinError(f"qp planner: dt must be finite and > 0 [s], got {dt!r}")
    return value


def lane_rows(
    limit: LegStrokeLimit | JointLimit, xi: np.ndarray, dt: float, const: np.ndarray,
    legs: bool,
) -> Rows:  # fmt: skip
    """A limit's rows by the qp lane's own (`twin.planners.qp_step.LIMIT_ROWS`: `leg_rows_lane`
    when `legs`, else `joint_rows_lane`), cut from where the lane writes them in its A and
    bounds: the limit packed by name (`pack`) with its rate box (`RateLimit.pack`), const the
    `HYBRID_CONSTANTS` the rows read. xi (..., 9) gives C (..., m, 9), lower, upper (..., m).

    Raises:
        TwinError: xi not (..., 9) or not finite, dt not > 0, or a limit `pack` refuses.
    """
    xi, dt = as_array(xi, "xi", (9,)), checked_dt(dt)
    row = parameter_row(KIND_QP, False)
    record = parameter_record(row, QP_PARAMETERS)
    RateLimit(limit.rate).pack(record)
    limit.pack(record)
    A, lower, upper = LIMIT_ROWS(
        [xi], [row, const, dt, legs], [(N_QP_ROWS, 9), (9 + N_QP_ROWS,), (9 + N_QP_ROWS,)]
    )
    first, stop = (N_POSITION, 9) if legs else (9, N_QP_ROWS)  # the lane's row layout
    return Rows(A[..., first:stop, :], lower[..., 9 + first : 9 + stop],
                upper[..., 9 + first : 9 + stop])  # fmt: skip


@dataclass(frozen=True)
class LegStrokeLimit:
    r"""The six legs inside Table 1's stroke [l_min, l_max], as velocity dampers on
    l̇ = J_P [ᴮR_P ᴾṖ; ᴮR_P ω_P] (seed 000 eq (8); `StewartPlatform.jacobian` takes the
    platform's velocities in B, the planner's are in P).

    The legs are not linear in the step, so the stroke's ends are kept further than `margin`
    by a bound on the step's second-order part (θ, s, e_rot, e_trans of the rate box:
    `twin.planners.qp_step.step_bounds_lane`): a leg vector
    L = ᴮR_P ᴾP_i + ᴮp_P − ᴮB_i moves by ΔL = ᴮR_P[(exp([θ]×) − I) ᴾP_i + V(θ) ᴾṖ dt], whose
    part beyond the rows' linear one is at most e_rot |ᴾP_i| + e_trans s. A length only loses
    that much against its linear prediction (|L + ΔL| ≥ u·(L + ΔL)), and gains at most that
    plus |ΔL|² / (2 l_min) (|L + ΔL| ≤ l + u·ΔL + |ΔL|² / (2l)), with |ΔL| ≤ θ |ᴾP_i| +
    (1 + e_trans) s. So a step inside the box and the rows never carries a leg past its stroke.
    The rows are the qp lane's (`twin.planners.qp_step.leg_rows_lane`).

    Attributes:
        mechanism: the hybrid system.
        rate: (9,) [m/s, rad/s] the rate box the QP keeps (`RateLimit.maximum`).
        gain: [-] fraction of the room to a limit a leg may close in one step, in (0, 1].
        margin: [m] kept from the stroke's ends besides the second-order bound.
    """

    mechanism: HybridBoardingSystem
    rate: np.ndarray
    gain: float = 0.5
    margin: float = 1e-3

    def pack(self, record: np.record) -> None:
        """Write the gain and margin into a `QP_PARAMETERS` record's `leg_*` (`pack_damper`;
        the lane reads the stroke and hinges from the hybrid constants)."""
        pack_damper(self, record, "leg")

    def on(self, mechanism: HybridBoardingSystem) -> bool:
        """Whether these are `mechanism`'s legs and stroke (what the lane reads, from its
        hybrid constants)."""
        return bool(np.array_equal(self.mechanism.pack(np.ones(9)), mechanism.pack(np.ones(9))))

    def rows(self, xi: np.ndarray, dt: float) -> Rows:
        """(C (6, 9), lower (6,), upper (6,)) [m/s] at the state xi (9,) for a step of dt [s]
        (xi (..., 9): those leading axes too), by the qp lane's `leg_rows_lane` (`lane_rows`).

        Raises:
            TwinError: xi not (..., 9) or not finite, dt not > 0, a gain outside (0, 1], a
                margin < 0 or a rate box not finite and > 0.
        """
        const = self.mechanism.pack(np.full(9, np.inf))  # the rows read the legs' data only
        return lane_rows(self, xi, dt, const, True)


@dataclass(frozen=True)
class JointLimit:
    r"""The nine virtual joints inside Table 6 (absolute, SPEC erratum 3), as velocity dampers
    on their coordinate rates: the platform's position ẋ = ᴮR_P ᴾṖ, its roll-pitch-yaw rates
    E(rpy)⁻¹ ᴮR_P ω_P (`twin.spatial.rpy_rate_matrix`), the gangway's q̇1, q̇2, ḋ3.

    Besides `margin`, the limits are kept further by the step's second-order part
    (`twin.planners.qp_step.step_bounds_lane` of the rate box): e_trans s on the platform's
    position (its step is ᴮR_P V(θ) ᴾṖ dt); θ² on its roll, pitch and yaw, a bound of their
    second-order part over Table 6's box (|pitch| ≤ 30°: at most 0.45 θ² there,
    tests/planners/test_qp.py); none on the gangway joints, which integrate linearly. The rows
    are the qp lane's (`twin.planners.qp_step.joint_rows_lane`).

    Attributes:
        lower, upper: (9,) [m, rad] the limits.
        rate: (9,) [m/s, rad/s] the rate box the QP keeps (`RateLimit.maximum`).
        gain: [-] fraction of the room to a limit a joint may close in one step, in (0, 1].
        margin: [m | rad] kept from the limits besides the second-order bound.
    """

    lower: np.ndarray
    upper: np.ndarray
    rate: np.ndarray
    gain: float = 0.5
    margin: float = 1e-3

    def pack(self, record: np.record) -> None:
        """Write the gain and margin into a `QP_PARAMETERS` record's `joint_*` (`pack_damper`;
        the lane reads the limits from the hybrid constants)."""
        pack_damper(self, record, "joint")

    def on(self, mechanism: HybridBoardingSystem) -> bool:
        """Whether these are `mechanism`'s Table 6 limits (what the lane reads, from its hybrid
        constants)."""
        return bool(
            np.array_equal(self.lower, mechanism.lower)
            and np.array_equal(self.upper, mechanism.upper)
        )

    def rows(self, xi: np.ndarray, dt: float) -> Rows:
        """(C (9, 9), lower (9,), upper (9,)) [m/s, rad/s] at the state xi (9,) for a step of
        dt [s] (xi (..., 9): those leading axes too), by the qp lane's `joint_rows_lane`
        (`lane_rows`) on constants holding these limits.

        Raises:
            TwinError: as `LegStrokeLimit.rows`, or limits that are not finite.
        """
        const = np.zeros(N_HYBRID_CONSTANTS)
        c = const.view(HYBRID_CONSTANTS)[0]  # the rows read the limits only
        c["lower"] = as_array(self.lower, "JointLimit lower", (9,))
        c["upper"] = as_array(self.upper, "JointLimit upper", (9,))
        return lane_rows(self, xi, dt, const, False)


@dataclass(frozen=True)
class RateLimit:
    """|v_j| ≤ maximum_j: the box of joint rates (`HYBRID_RATE_LIMITS`), never relaxed.

    Attributes:
        maximum: (9,) [m/s, rad/s].
    """

    maximum: np.ndarray

    def pack(self, record: np.record) -> None:
        """Write the box into a `QP_PARAMETERS` record's `rate`.

        Raises:
            TwinError: a maximum that is not finite and > 0 (the lane divides by none, but a
                box of zero width leaves no rates).
        """
        rate = np.broadcast_to(np.asarray(self.maximum, dtype=float), (9,))
        if not np.all(rate > 0) or not np.all(np.isfinite(rate)):
            raise refuse(f"the rate limits {rate.tolist()!r:.120} (finite and > 0)")
        record["rate"] = rate


class QPProblem(NamedTuple):
    """One step's QP (module doc), in the layout DAQP takes (the first 9 bounds bound v):

        min ½ vᵀ H v + fᵀ v   s.t.   lower ≤ [v; A v] ≤ upper

    H (9, 9) and f (9,) hold every term but the position; A (3 + m, 9) is the position rows
    J_p (3) then the limit rows C (m); lower and upper (9 + 3 + m,) are the rate box (9), b_p
    twice (the position an equality) and the limits' bounds (m). `position_weight` is the
    position's weight when it turns into a term (level 1)."""

    H: np.ndarray
    f: np.ndarray
    A: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    position_weight: float


class QPSolution(NamedTuple):
    """Rates v (9,) (NaN if even level 2 failed) and the level solved (0: position exact,
    1: position weighted, 2: limits relaxed, the closest feasible rates)."""

    velocity: np.ndarray
    level: int


@dataclass
class QPPlanner:
    r"""Task-based differential IK with hard limits for the hybrid system (module doc).

    Attributes:
        tip: the tip pose task (gain k_e): its position rows an equality, its orientation rows
            a term of weight `orientation_weight`.
        orientation_weight: w_o [-].
        position_weight: [-] the position's weight when it cannot be met exactly (level 1).
        secondary: MTMP's secondary tasks (`JointPostureTask` on q2, `PlatformYawTask`).
        secondary_weight: w_s [-].
        split: `BetaSplit` w_j of the regularisation.
        damping: μ [-] of the regularisation.
        limits: the limit objects (`LegStrokeLimit`, `JointLimit`): rows of inequalities.
        rate_limit: the rate box.
        solver: a QP library of `SOLVERS`.
    """

    #: the kernel family it packs for (`twin.planners.families.FAMILY_DIAGNOSTICS`)
    family: ClassVar[str] = "qp"

    tip: TipPoseTask
    limits: tuple
    rate_limit: RateLimit
    orientation_weight: float = 1.0
    position_weight: float = 1e4
    secondary: tuple = ()
    secondary_weight: float = 0.1
    split: BetaSplit | None = None
    damping: float = 0.01
    solver: str = "active_set"

    def __post_init__(self) -> None:
        if self.solver not in SOLVERS:
            raise TwinError(f"QPPlanner solver: unknown {self.solver!r}; allowed: {SOLVERS}")

    def reset(self, xi: np.ndarray, target: TipTarget) -> None:
        """A velocity-level planner keeps no state between steps."""
        del xi, target  # Unused.

    def lane(self) -> tuple[np.ndarray, np.ndarray]:
        """(row, const): the planner as its lane reads it, whatever its solver (`pack(False)`;
        `hold` is the runner's guard's, not the QP's), and its mechanism's hybrid constants
        (`HybridBoardingSystem.pack`; the QP reads their Table 6, legs and gangway, its rate
        box is its row's).

        Raises:
            TwinError: a planner `pack` refuses (other than for its solver).
        """
        row = replace(self, solver=SOLVERS[0]).pack(False)  # a library solves the same QP
        return row, self.tip.mechanism.pack(np.full(9, np.inf))

    def problem(self, xi: np.ndarray, target: TipTarget, dt: float) -> QPProblem:
        """The step's QP at the state xi (9,) (module doc), assembled by the engine's own
        `twin.planners.qp_step.qp_problem_lane` (`QP_PROBLEM`; xi (..., 9) and a target
        broadcasting against it give arrays with those leading axes).

        Raises:
            TwinError: xi not (..., 9) or not finite, dt not finite and > 0, or a planner
                `pack` refuses (`lane`).
        """
        xi, dt = as_array(xi, "xi", (9,)), checked_dt(dt)
        row, const = self.lane()
        n = 9 + N_QP_ROWS
        H, f, A, lower, upper = QP_PROBLEM(
            [xi, target_rows(target)], [row, const, dt], [(9, 9), (9,), (N_QP_ROWS, 9), (n,), (n,)]
        )
        return QPProblem(H, f, A, lower, upper, self.position_weight)

    def pack(self, hold: bool) -> np.ndarray:
        """The planner as its lane's parameter row (`QP_PARAMETERS`): each part writes its own
        fields (`pack`: the tip task, the split, the posture task, the rate box, the limits),
        this its weights and the yaw term.

        Args:
            hold: the lane holds its joint limits (`Scenario.joint_limits == "hold"`).

        Raises:
            TwinError: a planner the lane would assemble wrongly: a part without `pack` or one
                it refuses; limits other than one `LegStrokeLimit` on the tip's system then one
                `JointLimit` on its Table 6 limits (`_pack_limits`); secondary tasks after a
                `PlatformYawTask` (each part's `pack` refuses a second of its kind); weights
                that are negative or not finite; a solver other than the compiled one; μ ≤ 0.
        """
        row = parameter_row(KIND_QP, hold)
        record = parameter_record(row, QP_PARAMETERS)
        record["split"], record["posture_index"] = 1.0, -1.0
        pack_part(self.tip, record, "primary task")
        record["orientation"], record["position"] = self.orientation_weight, self.position_weight
        record["secondary"], record["damping"] = self.secondary_weight, self.damping
        if self.split is not None:
            pack_part(self.split, record, "split")
        weights = np.r_[record["orientation"], record["position"], record["secondary"],
                        record["damping"], record["split"]]  # fmt: skip
        if not np.all(np.isfinite(weights) & (weights >= 0)):
            raise refuse(f"weights {weights.tolist()!r:.120} (finite and ≥ 0 only)")
        for task in self.secondary:
            if record["yaw"] > 0.0:  # the lane adds the posture term first, then the yaw's
                raise refuse(f"the secondary tasks {self.secondary!r:.120}")
            pack_part(task, record, "secondary task")
        self._pack_limits(record)
        if self.solver != SOLVERS[0]:  # a library is called from Python, not in a lane
            raise refuse(
                f"the solver {self.solver!r}: the engine solves with the compiled "
                f"{SOLVERS[0]!r} (`twin.planners.active_set`); the others only through "
                "QPPlanner.step"
            )
        if not self.damping > 0:
            raise refuse(f"the damping {self.damping!r} (> 0: the QP must be strictly convex)")
        record["solver"] = SOLVERS.index(self.solver)
        return row

    def _pack_limits(self, record: np.record) -> None:
        """The rate box and the limits into `record` (`QPPlanner.pack`), each by its own `pack`:
        the lane reads the legs and Table 6 from the hybrid constants of the tip's system, so
        each limit must be on those (its `on`), and it assembles the leg rows before the
        Table 6 rows (`problem`'s A), so the limits are listed in that order: the legs' limit
        first, then the joints' (each writes its own fields; `pack_damper` refuses a second)."""
        mechanism = self.tip.mechanism
        pack_part(self.rate_limit, record, "rate limit")
        for k, limit in enumerate(self.limits):
            pack_part(limit, record, "limit")
            on = getattr(limit, "on", None)
            if on is None or not on(mechanism):
                raise refuse(f"the limit {limit!r:.80}: not on the mechanism's own limits")
            if k == 0 and not record["leg_gain"] > 0.0:
                raise refuse(f"the limits {self.limits!r:.120}: the legs' limit first")
        if not (record["leg_gain"] > 0.0 and record["joint_gain"] > 0.0):
            raise refuse(
                f"the limits {self.limits!r:.120}: one LegStrokeLimit and one JointLimit on the "
                "mechanism's own limits"
            )

    def step(self, xi: np.ndarray, target: TipTarget, dt: float) -> PlannerOutput:
        """Joint rates (9,) for the state xi (9,): the QP's solution. With the compiled solver,
        the engine's own step (`twin.planners.qp_step.qp_velocity` through `QP_STEP`); with a
        library, `solve_levels` on `problem`.

        Returns:
            velocity (9,) [m/s, rad/s] (NaN when no level is solved) and the diagnostics
            `task_error` (6,) [m, rad] e in B, `qp_level` (0, 1, 2) and `qp_active` (limit rows
            and rate bounds at their bound, `count_active`).

        Raises:
            TwinError: as `problem`.
        """
        if self.solver != SOLVERS[0]:
            problem = self.problem(xi, target, dt)
            solution = solve_levels(problem, self.solver)
            velocity, level = solution.velocity, float(solution.level)
            active = float(count_active(problem, velocity))
        else:
            row, const = self.lane()
            velocity, diag = QP_STEP(
                [as_array(xi, "xi", (9,)), target_rows(target)], [row, const, checked_dt(dt)],
                [(9,), (N_HYBRID_DIAGNOSTICS,)],
            )  # fmt: skip
            named = as_records(diag, HYBRID_DIAGNOSTICS)  # by name
            level, active = float(named["qp_level"]), float(named["qp_active"])
        return PlannerOutput(
            velocity=velocity,
            diagnostics={
                "task_error": self.tip.error(xi, target),
                "qp_level": level,
                "qp_active": active,
            },
        )


# ------------------------------------------------------------------------------------ solving


def solve_daqp(
    H: np.ndarray, f: np.ndarray, A: np.ndarray, upper: np.ndarray, lower: np.ndarray,
    n_equal: int,
) -> np.ndarray | None:  # fmt: skip
    """DAQP (Arnström et al. 2022, a dual active-set method in C) on
    min ½xᵀHx + fᵀx s.t. lower ≤ [x; A x] ≤ upper (the first len(x) entries bound x), the
    first `n_equal` rows of A equalities; the solution, or None when DAQP finds none."""
    sense = np.zeros(upper.size, dtype=np.intc)
    n = f.size
    sense[n : n + n_equal] = 5  # DAQP's "equality"
    x, _, exitflag, _ = daqp.solve(H, f, A, upper, lower, sense)
    return np.asarray(x) if exitflag > 0 else None


def solve_qpsolvers(
    H: np.ndarray, f: np.ndarray, A: np.ndarray, upper: np.ndarray, lower: np.ndarray,
    n_equal: int, solver: str,
) -> np.ndarray | None:  # fmt: skip
    """`solve_daqp`'s problem through qpsolvers with `solver` (one-sided G x ≤ h rows)."""
    import qpsolvers

    n = f.size
    E, rows = A[:n_equal], A[n_equal:]
    low, high = lower[n + n_equal :], upper[n + n_equal :]
    keep_high, keep_low = high < INF / 2, low > -INF / 2
    G = np.concatenate([rows[keep_high], -rows[keep_low]])
    h = np.concatenate([high[keep_high], -low[keep_low]])
    problem = qpsolvers.Problem(
        H, f, G if G.size else None, h if G.size else None,
        E if n_equal else None, upper[n : n + n_equal] if n_equal else None,
        lower[:n], np.minimum(upper[:n], INF),
    )  # fmt: skip
    solution = qpsolvers.solve_problem(problem, solver=solver)
    if not solution.found or solution.x is None or not np.all(np.isfinite(solution.x)):
        return None
    return np.asarray(solution.x)


def solve_qp(
    H: np.ndarray, f: np.ndarray, A: np.ndarray, upper: np.ndarray, lower: np.ndarray,
    n_equal: int, solver: str = "daqp",
) -> np.ndarray | None:  # fmt: skip
    """`solve_daqp`'s problem with `solver` (`SOLVERS`); None when there is no solution."""
    if solver == "daqp":
        return solve_daqp(H, f, A, upper, lower, n_equal)
    return solve_qpsolvers(H, f, A, upper, lower, n_equal, solver)


def count_active(problem: QPProblem, v: np.ndarray) -> int:
    """Limit rows and rate bounds of a `QPPlanner.problem` at their bound at v (9,) (to
    `twin.planners.qp_step.ACTIVE_TOL`, relative to the bound's size): the engine's own count,
    `count_active_lane` (through `COUNT_ACTIVE`); 0 for a non-finite v."""
    if not np.all(np.isfinite(v)):
        return 0
    A, lower, upper = problem.A, problem.lower, problem.upper
    return int(COUNT_ACTIVE([v, A, lower, upper], [], [()])[0])


def solve_levels(problem: QPProblem, solver: str = "active_set") -> QPSolution:
    """The step's rates: level 0 (position an equality), else level 1 (position a term of
    `position_weight`), else level 2 (limit rows relaxed by slacks of weight `SLACK_WEIGHT`;
    the closest feasible rates); NaN rates if all three fail or the problem is not finite (a
    NaN target: the engine then holds the machine). The engine's solver, "active_set", is
    `solve_levels_lane` (the one the compiled lanes run); the others are libraries."""
    H, f, A, lower, upper, rho = problem
    if solver == "active_set":
        rates = np.empty(f.size)
        H0, f0, A0, lower0, upper0 = (
            np.ascontiguousarray(a, dtype=float) for a in (H, f, A, lower, upper)
        )
        work = levels_work(f.size, A.shape[0] - N_POSITION)
        level = solve_levels_lane(H0, f0, A0, lower0, upper0, float(rho), work, rates)
        return QPSolution(rates, level)
    n = f.size
    if not (np.all(np.isfinite(f)) and np.all(np.isfinite(lower)) and np.all(np.isfinite(upper))):
        return QPSolution(np.full(n, np.nan), 0)
    # level 0: the rate box, the position rows (equalities), the limit rows
    v = solve_qp(H, f, A, upper, lower, 3, solver)
    if v is not None:
        return QPSolution(v, 0)
    # level 1: the position a weighted term
    J_p, b_p = A[:3], upper[n : n + 3]
    H1 = H + rho * J_p.T @ J_p
    f1 = f - rho * J_p.T @ b_p
    C, low, high, rate = A[3:], lower[n + 3 :], upper[n + 3 :], upper[:n]
    v = solve_qp(H1, f1, C, np.r_[rate, high], np.r_[-rate, low], 0, solver)
    if v is not None:
        return QPSolution(v, 1)
    # level 2: z = [v; s], low − s ≤ C v ≤ high + s, s ≥ 0, cost + SLACK_WEIGHT |s|²
    m = C.shape[0]
    H2 = np.zeros((n + m, n + m))
    H2[:n, :n] = H1
    H2[n:, n:] = SLACK_WEIGHT * np.eye(m)
    A2 = np.block([[C, np.eye(m)], [C, -np.eye(m)]])
    upper2 = np.r_[rate, np.full(m, INF), np.full(m, INF), high]
    lower2 = np.r_[-rate, np.zeros(m), low, np.full(m, -INF)]
    z = solve_qp(H2, np.r_[f1, np.zeros(m)], A2, upper2, lower2, 0, solver)
    if z is not None:
        return QPSolution(z[:n], 2)
    return QPSolution(np.full(n, np.nan), 2)


def qp_planner(
    mechanism: HybridBoardingSystem,
    *,
    k_e: float,
    w_orientation: float,
    w_secondary: float,
    limit_gain: float,
    beta: float,
    l: float,
    k_a2: float,
    yaw_hold: float,
    damping: float,
    q2_setpoint: float,
    rate_limit: np.ndarray,
    solver: str = "active_set",
) -> QPPlanner:
    """The registry's `qp`: the tip task, MTMP's two secondary terms, the leg and Table 6
    dampers at `limit_gain`, the rate box."""
    rate = np.asarray(rate_limit, dtype=float)
    return QPPlanner(
        tip=TipPoseTask(mechanism, gain=k_e),
        limits=(
            LegStrokeLimit(mechanism, rate, gain=limit_gain),
            JointLimit(mechanism.lower, mechanism.upper, rate, gain=limit_gain),
        ),
        rate_limit=RateLimit(rate),
        orientation_weight=w_orientation,
        secondary=(
            JointPostureTask(index=7, setpoint=q2_setpoint, gain=k_a2),
            PlatformYawTask(yaw_hold=yaw_hold),
        ),
        secondary_weight=w_secondary,
        split=BetaSplit(beta, l),
        damping=damping,
        solver=solver,
    )
