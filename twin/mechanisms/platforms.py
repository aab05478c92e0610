r"""The small platforms (3UPU_UP, 4-UPR) one lane at a time: geometry, legs, forward kinematics.

The engine's kernel (`twin.sim.kernels.platform`) and the objects (`Upu3Up`, `Upr4`,
`twin.planners.platform_model.PlatformModel`) share these functions: each handles ONE state with
floats and small arrays and is compiled by numba into whatever calls it (`twin.compiled`), or
runs as plain Python without numba.

A mechanism travels as one record of `PLATFORM_GEOMETRY` (`PlatformModel.pack`), read by
name. Units are the mechanism's native ones: mm for the Upu3Up (seed 001), m for the Upr4
(seed 002); `unit` [m] converts. States are (z, α, β) or (z, roll, pitch) [native, rad, rad].
"""

from __future__ import annotations

from collections.abc import Callable
from functools import cache
from typing import NamedTuple

import numpy as np

from twin.batch import LaneBatch
from twin.compiled import compile_runner, register_jitable
from twin.mechanisms.legs import leg_arm_lane, leg_component, leg_twist_row_lane
from twin.mechanisms.newton import CONVERGED, NewtonResult, newton_loop
from twin.spatial import rpy_rate_entries, rpy_to_matrix_lane

#: [mm | rad] a Newton-Raphson solution on a state limit may land this far outside it.
STATE_SLACK = 1e-9
#: `Upu3Up.forward`'s defaults: [mm] residual tolerance and Newton-Raphson steps (seed 001
#: eq (22)); `PlatformModel.fit` and the engine's fit (`upu3up_forward`) use them.
FORWARD_TOL, FORWARD_MAX_ITER = 1e-10, 30
#: `PLATFORM_GEOMETRY["mechanism"]` of each mechanism
MECHANISM_UPU3UP, MECHANISM_UPR4 = 0, 1
#: most actuated limbs of a small platform (the Upr4's four)
MAX_LEGS = 4
#: [m | rad] Gauss-Newton step after which the Upr4's best-fit pose is taken as converged:
#: convergence is quadratic (linear with a tiny rate for slightly inconsistent lengths), so
#: the pose is then within ~1e-12 of the limit, and one Jacobian is saved per step.
FIT_TOL = 1e-8
FIT_MAX_ITER = 30


class NewtonWork(NamedTuple):
    """One lane's scratch for `platform_kinematics` and a Newton solve (numba passes it as one
    argument): R (3, 3), o (3,), residual (≥ n,) and J (≥ n, 3) [native], M (3, 4), step (3,)
    [native | rad]. `platform_newton` leaves the last evaluation's residual and step in it."""

    R: np.ndarray
    o: np.ndarray
    residual: np.ndarray
    J: np.ndarray
    M: np.ndarray
    step: np.ndarray


@register_jitable
def newton_work() -> NewtonWork:
    """Fresh `NewtonWork` for any small platform (`MAX_LEGS` rows)."""
    return NewtonWork(np.zeros((3, 3)), np.zeros(3), np.zeros(MAX_LEGS), np.zeros((MAX_LEGS, 3)),
                      np.zeros((3, 4)), np.zeros(3))  # fmt: skip


#: A small platform as the lanes read it (one record, `PlatformModel.pack`):
#: mechanism code (`MECHANISM_*`), actuated limbs n, [m] per native unit, the Upu3Up's l
#: [mm] (seed 001 eq (26); 0 for the Upr4), the actuators' stroke [native], the state limits
#: (3 + 3) [native, rad, rad], the Upu3Up's forward-kinematics envelope (3 + 3; ±inf for the
#: Upr4), base hinges ᴮB_i and platform hinges ᴾP_i (MAX_LEGS × 3 row-major each, native;
#: rows past n are 0).
PLATFORM_GEOMETRY = np.dtype(
    [
        ("mechanism", np.int64),
        ("n_legs", np.int64),
        ("unit", np.float64),
        ("l", np.float64),
        ("stroke_low", np.float64),
        ("stroke_high", np.float64),
        ("state_low", np.float64, (3,)),
        ("state_high", np.float64, (3,)),
        ("envelope_low", np.float64, (3,)),
        ("envelope_high", np.float64, (3,)),
        ("base_hinges", np.float64, (3 * MAX_LEGS,)),
        ("platform_hinges", np.float64, (3 * MAX_LEGS,)),
    ]
)


@register_jitable
def coupled_frame_lane(
    z: float, alpha: float, beta: float, l: float, R: np.ndarray, o: np.ndarray
) -> None:
    """The Upu3Up's ᴼT_O1 (`twin.mechanisms.upu3up.coupled_transform`): ᴼR_O1 = Rx(α)·Ry(β)
    (seed 001 eq (11)) into R (3, 3), ᴼO1 = (l + z) ᴼR_O1 e_z [mm] (eq (13)) into o (3,)."""
    ca, sa = np.cos(alpha), np.sin(alpha)
    cb, sb = np.cos(beta), np.sin(beta)
    R[0, 0], R[0, 1], R[0, 2] = cb, 0.0, sb
    R[1, 0], R[1, 1], R[1, 2] = sa * sb, ca, -sa * cb
    R[2, 0], R[2, 1], R[2, 2] = -ca * sb, sa, ca * cb
    r = l + z
    o[0], o[1], o[2] = r * R[0, 2], r * R[1, 2], r * R[2, 2]


@register_jitable
def upr4_frame_lane(z: float, roll: float, pitch: float, R: np.ndarray, o: np.ndarray) -> None:
    """The Upr4's ᴼT_p (`twin.mechanisms.upr4.platform_transform`): R = Ry(pitch)·Rx(roll)
    (seed 002 eq (15), the twin's Rz·Ry·Rx at yaw 0) into R (3, 3), P = (0, 0, z) [m]
    (eq (16)) into o (3,)."""
    rpy_to_matrix_lane(roll, pitch, 0.0, R)
    o[0], o[1], o[2] = 0.0, 0.0, z


@register_jitable
def platform_frame(state: np.ndarray, g: np.void, R: np.ndarray, o: np.ndarray) -> None:
    """ᴮT_P of a state (3,): its rotation into R (3, 3), its origin [native] into o (3,);
    `coupled_frame_lane` (seed 001 eqs (11), (13)) or `upr4_frame_lane` (seed 002 eqs
    (15)-(16)). g: a `PLATFORM_GEOMETRY` record."""
    if g["mechanism"] == MECHANISM_UPU3UP:
        coupled_frame_lane(state[0], state[1], state[2], g["l"], R, o)
    else:
        upr4_frame_lane(state[0], state[1], state[2], R, o)


@register_jitable
def platform_kinematics(
    state: np.ndarray,
    g: np.void,
    R: np.ndarray,
    o: np.ndarray,
    lengths: np.ndarray,
    J: np.ndarray,
    jacobian: bool,
) -> None:
    """Actuator lengths l_i [native] of a state (3,) into lengths (n,), and, if `jacobian`,
    ∂l/∂state into J (n, 3) [native/native, native/rad]; R (3, 3), o (3,) scratch.

    l_i = |ᴮR_P ᴾP_i + ᴮO_P − ᴮB_i| (`leg_component`; seed 001 eqs (16)-(18), seed 002 eqs
    (15)-(18)). The Jacobian is the leg twist rows [n_iᵀ, (ᴮR_P ᴾP_i × n_i)ᵀ]
    (`leg_twist_row_lane`) composed with the state-rate map: the Upu3Up's coupled twist
    (seed 001 eq (24): the top turns about O with ω = α̇ e_x + β̇ Rx(α) e_y), the Upr4's
    v = ż e_z, ω = E(roll, pitch, 0) (roll̇, pitcḣ, 0) (`twin.spatial.rpy_rate_entries`,
    `Upr4.jacobian`).
    """
    platform_frame(state, g, R, o)
    upu = g["mechanism"] == MECHANISM_UPU3UP
    ca, sa = np.cos(state[1]), np.sin(state[1])  # Upu3Up: Rx(α) e_y = (0, cos α, sin α)
    e00, e10, e20, e01, e11 = rpy_rate_entries(state[2], 0.0)  # Upr4: E(roll, pitch, 0)
    base, top = g["base_hinges"], g["platform_hinges"]
    for i in range(g["n_legs"]):
        v0 = leg_component(R, o, base, top, i, 0)
        v1 = leg_component(R, o, base, top, i, 1)
        v2 = leg_component(R, o, base, top, i, 2)
        length = np.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
        lengths[i] = length
        if not jacobian:
            continue
        a0, a1, a2 = leg_arm_lane(R, top, i)
        n0, n1, n2, m0, m1, m2 = leg_twist_row_lane(a0, a1, a2, v0, v1, v2, length)
        if upu:
            c0, c1, c2 = o[0], o[1], o[2]  # O1
            J[i, 0] = n0 * R[0, 2] + n1 * R[1, 2] + n2 * R[2, 2]
            J[i, 1] = n1 * -c2 + n2 * c1 + m0  # e_x × O1 = (0, −c2, c1)
            J[i, 2] = n0 * (ca * c2 - sa * c1) + n1 * (sa * c0) - n2 * (ca * c0) + m1 * ca + m2 * sa
        else:  # (arm × n_i)ᵀ E's roll and pitch columns
            J[i, 0] = n2
            J[i, 1] = m0 * e00 + m1 * e10 + m2 * e20
            J[i, 2] = m0 * e01 + m1 * e11


@register_jitable
def platform_newton(
    lengths: np.ndarray,
    g: np.void,
    tol: float,
    max_iter: int,
    step_tol: float,
    x: np.ndarray,
    w: NewtonWork,
) -> tuple[int, int]:
    """Newton-Raphson on l(x) − L from the start x (3,), in place (seed 001 eqs (20)-(24); the
    Upr4's four limbs a Gauss-Newton least-squares step): `newton_loop`, at most max_iter + 1
    evaluations of `platform_kinematics`, each followed by its step with tol [native] on the
    residual and step_tol [native | rad] on the step. Returns (the last step's outcome,
    `twin.mechanisms.newton.STEPPED` if max_iter ran out; the steps taken before it).

    lengths (n,) [native]; g: a `PLATFORM_GEOMETRY` record; w: scratch, its residual and step
    the last evaluation's; x: after the last step taken (the root where converged).
    """
    return newton_loop(platform_legs_lane, (g, w.R, w.o), lengths, g["n_legs"], tol, step_tol,
                       max_iter, x, w.residual, w.J, w.M, w.step)  # fmt: skip


@register_jitable
def platform_legs_lane(x: np.ndarray, data: tuple, lengths: np.ndarray, J: np.ndarray) -> None:
    """`platform_kinematics` with its Jacobian as `newton_loop` calls it: data = (g, R, o);
    the residual of seed 001 eq (20) is then taken in lengths."""
    g, R, o = data
    platform_kinematics(x, g, R, o, lengths, J, True)


@register_jitable
def upu3up_forward(lengths: np.ndarray, g: np.void, x: np.ndarray, w: NewtonWork) -> bool:
    """`Upu3Up.forward` on the geometry's envelope, from the start x (3,), in place:
    `platform_newton` with `FORWARD_TOL`, `FORWARD_MAX_ITER`; False where `forward` raises:
    lengths outside the stroke, a non-finite residual, a singular J, no convergence, or a
    root outside the envelope (± `STATE_SLACK`)."""
    n = g["n_legs"]
    for i in range(n):  # check_range in Upu3Up.forward
        if not (g["stroke_low"] <= lengths[i] <= g["stroke_high"]):
            return False
    outcome, _ = platform_newton(lengths, g, FORWARD_TOL, FORWARD_MAX_ITER, np.inf, x, w)
    if outcome != CONVERGED:
        return False
    for j in range(3):  # Upu3Up._check_state on the envelope
        if x[j] < g["envelope_low"][j] - STATE_SLACK:
            return False
        if x[j] > g["envelope_high"][j] + STATE_SLACK:
            return False
    return True


@register_jitable
def platform_fit(
    lengths: np.ndarray, guess: np.ndarray, g: np.void, x: np.ndarray, w: NewtonWork
) -> bool:
    """`PlatformModel.fit`: the state (3,) of actuator lengths (n,) [native] into x,
    warm-started at `guess` (3,); False where no state is found (x then undefined). w:
    scratch.

    Upu3Up: `upu3up_forward`. Upr4: four limbs for three DOFs, so the least-squares pose,
    Gauss-Newton on l(x) − L (`platform_newton` with no residual test), stopping once every
    |step| ≤ FIT_TOL, failing on a singular J, a non-finite residual or after FIT_MAX_ITER
    steps.
    """
    for j in range(3):
        x[j] = guess[j]
    if g["mechanism"] == MECHANISM_UPU3UP:
        return upu3up_forward(lengths, g, x, w)
    outcome, _ = platform_newton(lengths, g, np.inf, FIT_MAX_ITER - 1, FIT_TOL, x, w)
    return outcome == CONVERGED


# Batch loops: the objects' vectorised API over the same lane functions, compiled lazily on first
# use and cached on disk (`twin.compiled.compile_runner`; plain Python without numba).


def kinematics_lanes(
    states: np.ndarray, geometry: np.ndarray, lengths: np.ndarray, J: np.ndarray, jacobian: bool
) -> None:
    """`platform_kinematics` of states (N, 3) into lengths (N, ≥ n) and, if `jacobian`, J
    (N, ≥ n, 3); geometry (1,) `PLATFORM_GEOMETRY`."""
    R, o = np.zeros((3, 3)), np.zeros(3)
    for k in range(states.shape[0]):
        platform_kinematics(states[k], geometry[0], R, o, lengths[k], J[k], jacobian)


def fit_lanes(
    lengths: np.ndarray, guesses: np.ndarray, geometry: np.ndarray, x: np.ndarray, ok: np.ndarray
) -> None:
    """`platform_fit` of lengths (N, n) from guesses (N, 3) into x (N, 3), success into ok (N,)
    bool; geometry (1,) `PLATFORM_GEOMETRY`."""
    w = newton_work()
    for k in range(lengths.shape[0]):
        ok[k] = platform_fit(lengths[k], guesses[k], geometry[0], x[k], w)


@cache
def batch(loop: Callable[..., None]) -> Callable[..., None]:
    """A batch loop of this package compiled by numba (serial, lazily, cached on disk), or the
    loop itself without numba (`compile_runner`)."""
    return compile_runner(loop, False)


def leg_lengths(geometry: np.ndarray, states: np.ndarray) -> np.ndarray:
    """Actuator lengths (..., n) [native] of states (..., 3) (`platform_kinematics`)."""
    flat = np.ascontiguousarray(states, dtype=float).reshape(-1, 3)
    lengths, J = np.zeros((len(flat), MAX_LEGS)), np.zeros((len(flat), MAX_LEGS, 3))
    batch(kinematics_lanes)(flat, geometry, lengths, J, False)
    n = int(geometry[0]["n_legs"])
    return lengths[:, :n].reshape(*np.shape(states)[:-1], n)


def jacobian(geometry: np.ndarray, states: np.ndarray) -> np.ndarray:
    """∂l/∂state (..., n, 3) [native/native, native/rad] of states (..., 3)."""
    flat = np.ascontiguousarray(states, dtype=float).reshape(-1, 3)
    lengths, J = np.zeros((len(flat), MAX_LEGS)), np.zeros((len(flat), MAX_LEGS, 3))
    batch(kinematics_lanes)(flat, geometry, lengths, J, True)
    n = int(geometry[0]["n_legs"])
    return J[:, :n].reshape(*np.shape(states)[:-1], n, 3)


def fit(
    geometry: np.ndarray, lengths: np.ndarray, guesses: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(states (..., 3), found (...) bool) of actuator lengths (..., n) [native] warm-started at
    guesses (..., 3) (`platform_fit`); a state where not found is undefined."""
    n = int(geometry[0]["n_legs"])
    flat = np.ascontiguousarray(lengths, dtype=float).reshape(-1, n)
    start = np.ascontiguousarray(np.broadcast_to(guesses, (*np.shape(lengths)[:-1], 3)),
                                 dtype=float).reshape(-1, 3)  # fmt: skip
    x, ok = np.zeros((len(flat), 3)), np.zeros(len(flat), dtype=np.bool_)
    batch(fit_lanes)(flat, start, geometry, x, ok)
    batch_shape = np.shape(lengths)[:-1]
    return x.reshape(*batch_shape, 3), ok.reshape(batch_shape)


def _forward_batch(
    lengths: np.ndarray,
    guesses: np.ndarray,
    geometry: np.ndarray,
    tol: float,
    max_iter: int,
    step_tol: float,
    x: np.ndarray,
    residual: np.ndarray,
    step: np.ndarray,
    outcome: np.ndarray,
) -> None:
    """`platform_newton` of lengths (N, n) from guesses (N, 3) into x (N, 3), the last
    residual (N, MAX_LEGS) and step (N, 3), and (outcome, steps) (N, 2); geometry (1,)
    `PLATFORM_GEOMETRY`."""
    w = newton_work()
    for k in range(lengths.shape[0]):
        for j in range(3):
            x[k, j] = guesses[k, j]
        for i in range(MAX_LEGS):
            residual[k, i] = 0.0
        for j in range(3):
            step[k, j] = np.inf  # no step taken yet
        lane = NewtonWork(w.R, w.o, residual[k], w.J, w.M, step[k])
        result = platform_newton(lengths[k], geometry[0], tol, max_iter, step_tol, x[k], lane)
        outcome[k, 0], outcome[k, 1] = result[0], result[1]


#: the lane over a batch of lengths: what `Upu3Up.forward` and `Upr4.forward` call
FORWARD = LaneBatch(_forward_batch, cores=(1, 1))


def forward(
    geometry: np.ndarray,
    lengths: np.ndarray,
    guesses: np.ndarray,
    tol: float,
    max_iter: int,
    step_tol: float,
) -> NewtonResult:
    """`platform_newton` of actuator lengths (..., n) [native] from guesses (..., 3) (broadcast
    together), lane by lane, as a `NewtonResult` (residual (..., n)).

    Args:
        geometry: (1,) `PLATFORM_GEOMETRY`.
        tol: [native] every |l_i(x) − L_i| at most this; step_tol: [native | rad] every
            |Δ_j| too (inf: no test on the step).
        max_iter: Newton steps before giving up.
    """
    n = int(geometry[0]["n_legs"])
    x, residual, step, outcome = FORWARD(
        [lengths, guesses], [geometry, float(tol), int(max_iter), float(step_tol)],
        [(3,), (MAX_LEGS,), (3,), (2,)],
    )  # fmt: skip
    return NewtonResult.of(x, residual[..., :n], step, outcome)
