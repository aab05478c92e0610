r"""The small platforms' step (Upu3Up, Upr4) as a compiled kernel: one lane, scalar code.

`run_platform` steps N lanes (one scenario each) through a chunk of B samples, each step
exactly what the former `PlatformRig.advance` did with `twin.planners.platform`'s
`PlatformPlanner` ("pid" or "ik" law) and `PlatformModel.fit`:

1. desired state from the target's top normal (`PlatformModel.desired_state`), clipped to the
   state limits, and its actuator lengths by inverse kinematics (seed 001 eqs (16)-(19), seed
   002 eqs (15)-(18)), clipped to the stroke (`PlatformPlanner.desired`);
2. the law: "ik" l̇ = (l_d(t + dt) − l) / dt with the target advanced by its twist
   (`advance_target`), "pid" kp e + ki ∫e + kd ė with e = l_d − l;
3. the speed-limit split `PlatformPlanner.limit` (tilt first, the largest heave share that
   fits) and the PID's conditional integration (anti-windup);
4. the rig's guard: a non-finite rate holds the platform (FAULT_PLANNER); the new lengths stop
   at the stroke (FAULT_JOINT_LIMIT where they were cut); forward kinematics warm-started at
   the previous state — the Upu3Up's Newton-Raphson on its hardware envelope (`Upu3Up.forward`,
   seed 001 eqs (20)-(24)), the Upr4's Gauss-Newton least-squares pose — and a failure there
   holds the platform (FAULT_KINEMATICS).

Every function handles ONE lane with floats and small numpy arrays, and is decorated with
numba's `register_jitable`; without numba they run as plain Python and give the same numbers
(tested to 1e-9 against the compiled form and against the planner objects stepped as the
rig stepped them). The objects in `twin.planners.platform` stay the readable statement of the
math and the tests' oracle.

Units: states (z, α, β) or (z, roll, pitch) and lengths are in the mechanism's native unit
(mm for the Upu3Up, m for the Upr4; `C_UNIT` [m] converts), angles in rad, actuator rates in
native/s; targets are in metres and the base frame B (`twin.sim.kernels.layout`).

Linear algebra differs from the oracle's LAPACK calls only by rounding: square systems by
Gaussian elimination with partial pivoting (failing, as `np.linalg.solve` raises, on an exactly
zero pivot), the Upr4's 4 × 3 least squares by the normal equations (J has full column rank
across the workspace; `np.linalg.lstsq`'s minimum-norm answer for a rank-deficient J is not
reproduced: such a step fails instead).
"""

from __future__ import annotations

from collections.abc import Callable
from functools import cache

import numpy as np

from twin.compiled import compile_runner, prange, register_jitable
from twin.mechanisms.upu3up import _STATE_SLACK, Upu3Up
from twin.planners.platform import (
    EFFORT_KD,
    EFFORT_KI,
    EFFORT_KP,
    FIT_MAX_ITER,
    FIT_TOL,
    PHYSICS_STEP,
    PlatformModel,
    PlatformPlanner,
)
from twin.sim.kernels.layout import (
    FAULT_JOINT_LIMIT,
    FAULT_KINEMATICS,
    FAULT_PLANNER,
    KIND_PLATFORM,
    N_MEMORY,
    N_PARAMETERS,
    P_FAMILY,
    P_HOLD,
    P_KIND,
    TARGET_P,
    TARGET_R,
    TARGET_V,
    TARGET_W,
)

#: Mechanism codes (const[C_MECHANISM]).
MECHANISM_UPU3UP, MECHANISM_UPR4 = 0, 1
#: Rows of `const` (`platform_constants`): mechanism code, actuators n, [m] per native unit,
#: stroke low/high [native], state limits low/high (3 + 3) [native, rad, rad], the Upu3Up's
#: forward-kinematics envelope low/high (3 + 3, ±inf for the Upr4), the Upu3Up's l [mm]
#: (seed 001 eq (26); 0 for the Upr4), base hinges ᴮB_i and platform hinges ᴾP_i (4 × 3
#: row-major each, native; the Upu3Up's fourth rows are 0, its UP limb not being actuated).
C_MECHANISM, C_N_LEGS, C_UNIT, C_STROKE_LOW, C_STROKE_HIGH = 0, 1, 2, 3, 4
C_STATE_LOW, C_STATE_HIGH, C_ENVELOPE_LOW, C_ENVELOPE_HIGH = 5, 8, 11, 14
C_L, C_BASE_HINGES, C_PLATFORM_HINGES = 17, 18, 30
N_PLATFORM_CONSTANTS = 42
MAX_LEGS = 4

#: Laws (prm[P_LAW]).
LAW_IK, LAW_PID = 0, 1
#: prm rows of the platform family: law, kp [1/s], ki [1/s²], kd [-], the speed limit
#: [native/s] (`PlatformPlanner.speed_limit`), the Upr4's held height z_hold [m], the
#: actuators' moving mass [kg] (0: velocity-commanded; `PlatformPlanner.actuate`) and
#: their top speed [m/s] (`actuator_speed`).
P_LAW, P_KP, P_KI, P_KD, P_SPEED_LIMIT, P_Z_HOLD, P_MASS, P_SPEED = (P_FAMILY + i for i in range(8))
#: memory rows: the PID integral ∫e dt (4) [native·s], the previous error e (4) [native],
#: whether there is one (1.0) or the next step starts its derivative from zero (0.0), the
#: effort-driven actuators' velocity (4) [native/s].
M_INTEGRAL, M_PREVIOUS, M_HAS_PREVIOUS, M_VELOCITY = 0, 4, 8, 9
#: diag rows (N, B + 1, N_PLATFORM_DIAGNOSTICS): 1.0 where the desired state or a desired length
#: was clipped to a limit, 1.0 where the speed limit bound (`PlatformPlanner.step`).
D_CLIPPED, D_SATURATED = 0, 1
N_PLATFORM_DIAGNOSTICS = 2

#: `Upu3Up.forward`'s defaults, which `PlatformModel.fit` uses: [mm] residual tolerance and
#: Newton-Raphson steps (seed 001 eq (22)).
FORWARD_TOL, FORWARD_MAX_ITER = 1e-10, 30


def platform_constants(model: PlatformModel) -> np.ndarray:
    """`const` (N_PLATFORM_CONSTANTS,) of a small platform (rows `C_*`), native units."""
    m = model.mechanism
    const = np.zeros(N_PLATFORM_CONSTANTS)
    upu = isinstance(m, Upu3Up)
    const[C_MECHANISM] = MECHANISM_UPU3UP if upu else MECHANISM_UPR4
    const[C_N_LEGS] = model.n_legs
    const[C_UNIT] = model.unit
    low, high = model.stroke
    const[C_STROKE_LOW], const[C_STROKE_HIGH] = low[0], high[0]
    low, high = m.state_limits
    const[C_STATE_LOW : C_STATE_LOW + 3], const[C_STATE_HIGH : C_STATE_HIGH + 3] = low, high
    if upu:
        envelope = model._envelope
        low, high = envelope.state_limits
        layout = m._layout_mm  # the hinges of seed 001 eq (26) [mm]
        const[C_L] = m.l
    else:
        low, high = np.full(3, -np.inf), np.full(3, np.inf)
        layout = m.layout  # seed 002 eqs (1)-(2) [m]
    const[C_ENVELOPE_LOW : C_ENVELOPE_LOW + 3] = low
    const[C_ENVELOPE_HIGH : C_ENVELOPE_HIGH + 3] = high
    n = model.n_legs
    const[C_BASE_HINGES : C_BASE_HINGES + 3 * n] = layout.base_hinges[:n].ravel()
    const[C_PLATFORM_HINGES : C_PLATFORM_HINGES + 3 * n] = layout.platform_hinges[:n].ravel()
    return const


def pack_platform(planner: PlatformPlanner, hold: bool) -> tuple[np.ndarray, np.ndarray]:
    """(prm (N_PARAMETERS,), memory (N_MEMORY,)) of a planner, after its `reset`.

    `hold` is recorded in prm[P_HOLD] but unused: the actuators' end stops always hold.
    """
    prm = np.zeros(N_PARAMETERS)
    prm[P_KIND] = KIND_PLATFORM
    prm[P_HOLD] = 1.0 if hold else 0.0
    prm[P_LAW] = LAW_PID if planner.law == "pid" else LAW_IK
    prm[P_KP], prm[P_KI], prm[P_KD] = planner.kp, planner.ki, planner.kd
    prm[P_SPEED_LIMIT] = planner.speed_limit
    z_hold = planner.model.z_hold
    prm[P_Z_HOLD] = np.nan if z_hold is None else float(z_hold)
    prm[P_MASS] = planner.actuator_mass if planner.dynamic else 0.0
    prm[P_SPEED] = planner.actuator_speed
    memory = np.zeros(N_MEMORY)
    n = planner.model.n_legs
    memory[M_INTEGRAL : M_INTEGRAL + n] = planner.integral
    memory[M_VELOCITY : M_VELOCITY + n] = planner.actuator_velocity
    previous = planner._previous_error
    if previous is not None:
        memory[M_PREVIOUS : M_PREVIOUS + n] = previous
        memory[M_HAS_PREVIOUS] = 1.0
    return prm, memory


@register_jitable
def platform_frame(state: np.ndarray, const: np.ndarray, R: np.ndarray, o: np.ndarray) -> None:
    """ᴮT_P of a state (3,): its rotation into R (3, 3), its origin [native] into o (3,).

    Upu3Up: R = Rx(α)·Ry(β) (seed 001 eq (11)), O1 = (l + z) R e_z (eq (13)). Upr4:
    R = Ry(pitch)·Rx(roll), P = (0, 0, z) (seed 002 eqs (15)-(16)).
    """
    if const[C_MECHANISM] == MECHANISM_UPU3UP:
        ca, sa = np.cos(state[1]), np.sin(state[1])
        cb, sb = np.cos(state[2]), np.sin(state[2])
        R[0, 0], R[0, 1], R[0, 2] = cb, 0.0, sb
        R[1, 0], R[1, 1], R[1, 2] = sa * sb, ca, -sa * cb
        R[2, 0], R[2, 1], R[2, 2] = -ca * sb, sa, ca * cb
        r = const[C_L] + state[0]
        o[0], o[1], o[2] = r * R[0, 2], r * R[1, 2], r * R[2, 2]
    else:
        cf, sf = np.cos(state[1]), np.sin(state[1])
        ct, st = np.cos(state[2]), np.sin(state[2])
        R[0, 0], R[0, 1], R[0, 2] = ct, st * sf, st * cf
        R[1, 0], R[1, 1], R[1, 2] = 0.0, cf, -sf
        R[2, 0], R[2, 1], R[2, 2] = -st, ct * sf, ct * cf
        o[0], o[1], o[2] = 0.0, 0.0, state[0]


@register_jitable
def kinematics(
    state: np.ndarray,
    const: np.ndarray,
    R: np.ndarray,
    o: np.ndarray,
    lengths: np.ndarray,
    J: np.ndarray,
    jacobian: bool,
) -> None:
    """Actuator lengths l_i [native] of a state (3,) into lengths (n,), and, if `jacobian`,
    ∂l/∂state into J (n, 3) [native/native, native/rad]; R (3, 3), o (3,) scratch.

    l_i = |ᴮR_P ᴾP_i + ᴮO_P − ᴮB_i| (seed 001 eqs (16)-(18), seed 002 eqs (15)-(18)). The
    Jacobian is the leg twist rows [n_iᵀ, (ᴮR_P ᴾP_i × n_i)ᵀ] composed with the state-rate
    map: the Upu3Up's coupled twist (seed 001 eq (24), `coupled_twist_map`: the top turns
    about O with ω = α̇ e_x + β̇ Rx(α) e_y), the Upr4's v = ż e_z, ω = E(roll, pitch, 0)
    (roll̇, pitcḣ, 0) (`Upr4.jacobian`).
    """
    platform_frame(state, const, R, o)
    upu = const[C_MECHANISM] == MECHANISM_UPU3UP
    ca, sa = np.cos(state[1]), np.sin(state[1])  # Upu3Up: Rx(α) e_y = (0, cos α, sin α)
    ct, st = np.cos(state[2]), np.sin(state[2])  # Upr4: E's roll column (cos θ, 0, −sin θ)
    for i in range(int(const[C_N_LEGS])):
        b = C_BASE_HINGES + 3 * i
        p = C_PLATFORM_HINGES + 3 * i
        px, py, pz = const[p], const[p + 1], const[p + 2]
        a0 = R[0, 0] * px + R[0, 1] * py + R[0, 2] * pz  # arm ᴮR_P ᴾP_i
        a1 = R[1, 0] * px + R[1, 1] * py + R[1, 2] * pz
        a2 = R[2, 0] * px + R[2, 1] * py + R[2, 2] * pz
        v0, v1, v2 = a0 + o[0] - const[b], a1 + o[1] - const[b + 1], a2 + o[2] - const[b + 2]
        length = np.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
        lengths[i] = length
        if not jacobian:
            continue
        n0, n1, n2 = v0 / length, v1 / length, v2 / length
        m0, m1, m2 = a1 * n2 - a2 * n1, a2 * n0 - a0 * n2, a0 * n1 - a1 * n0  # arm × n_i
        if upu:
            c0, c1, c2 = o[0], o[1], o[2]  # O1
            J[i, 0] = n0 * R[0, 2] + n1 * R[1, 2] + n2 * R[2, 2]
            J[i, 1] = n1 * -c2 + n2 * c1 + m0  # e_x × O1 = (0, −c2, c1)
            J[i, 2] = n0 * (ca * c2 - sa * c1) + n1 * (sa * c0) - n2 * (ca * c0) + m1 * ca + m2 * sa
        else:
            J[i, 0] = n2
            J[i, 1] = m0 * ct - m2 * st
            J[i, 2] = m1


@register_jitable
def solve3(M: np.ndarray, x: np.ndarray) -> bool:
    """Solve the 3 × 3 system of the augmented M (3, 4) = [A | b] into x (3,), destroying M.

    Gaussian elimination with partial pivoting; False (x untouched) on an exactly zero pivot,
    where `np.linalg.solve` raises LinAlgError.
    """
    for c in range(3):
        pivot = c
        for r in range(c + 1, 3):
            if abs(M[r, c]) > abs(M[pivot, c]):
                pivot = r
        if M[pivot, c] == 0.0:
            return False
        if pivot != c:
            for j in range(4):
                M[c, j], M[pivot, j] = M[pivot, j], M[c, j]
        for r in range(c + 1, 3):
            f = M[r, c] / M[c, c]
            for j in range(c, 4):
                M[r, j] = M[r, j] - f * M[c, j]
    x2 = M[2, 3] / M[2, 2]
    x1 = (M[1, 3] - M[1, 2] * x2) / M[1, 1]
    x0 = (M[0, 3] - M[0, 1] * x1 - M[0, 2] * x2) / M[0, 0]
    x[0], x[1], x[2] = x0, x1, x2
    return True


@register_jitable
def least_squares(J: np.ndarray, r: np.ndarray, n: int, M: np.ndarray, x: np.ndarray) -> bool:
    """x (3,) minimising |J x − r| for J (n, 3), r (n,): the solve itself for n = 3, the
    normal equations JᵀJ x = Jᵀr for n = 4 (`np.linalg.lstsq` to rounding); M (3, 4) scratch.
    False where the system is singular."""
    if n == 3:
        for i in range(3):
            for j in range(3):
                M[i, j] = J[i, j]
            M[i, 3] = r[i]
    else:
        for i in range(3):
            for j in range(3):
                s = 0.0
                for k in range(n):
                    s += J[k, i] * J[k, j]
                M[i, j] = s
            s = 0.0
            for k in range(n):
                s += J[k, i] * r[k]
            M[i, 3] = s
    return solve3(M, x)


@register_jitable
def fit(
    lengths: np.ndarray,
    guess: np.ndarray,
    const: np.ndarray,
    x: np.ndarray,
    R: np.ndarray,
    o: np.ndarray,
    residual: np.ndarray,
    J: np.ndarray,
    M: np.ndarray,
    step: np.ndarray,
) -> bool:
    """`PlatformModel.fit`: the state (3,) of actuator lengths (n,) [native] into x, warm-started
    at `guess` (3,); False where the oracle raises (x then undefined). R, o, residual, J, M,
    step: scratch.

    Upu3Up: `Upu3Up.forward` on the hardware envelope, Newton-Raphson on l(x) − L (seed 001
    eqs (20)-(24)) with `FORWARD_TOL`, `FORWARD_MAX_ITER`, failing on lengths outside the
    stroke, a non-finite residual, a singular J, no convergence, or a root outside the envelope
    (± `_STATE_SLACK`). Upr4: Gauss-Newton least squares on l(x) − L, stopping once every
    |step| ≤ FIT_TOL, failing on a non-finite step or after FIT_MAX_ITER steps.
    """
    n = int(const[C_N_LEGS])
    for j in range(3):
        x[j] = guess[j]
    if const[C_MECHANISM] == MECHANISM_UPU3UP:
        for i in range(n):  # check_range in Upu3Up.forward
            if not (const[C_STROKE_LOW] <= lengths[i] <= const[C_STROKE_HIGH]):
                return False
        converged = False
        for iteration in range(FORWARD_MAX_ITER + 1):  # twin.mechanisms.newton.newton
            kinematics(x, const, R, o, residual, J, True)
            small = True
            for i in range(n):
                residual[i] = residual[i] - lengths[i]
                if not np.isfinite(residual[i]):
                    return False
                small = small and abs(residual[i]) <= FORWARD_TOL
            if not least_squares(J, residual, n, M, step):
                return False
            for j in range(3):
                x[j] = x[j] - step[j]
            if small:
                converged = True
                break
            if iteration == FORWARD_MAX_ITER:
                break
        if not converged:
            return False
        for j in range(3):  # Upu3Up._check_state on the envelope
            if x[j] < const[C_ENVELOPE_LOW + j] - _STATE_SLACK:
                return False
            if x[j] > const[C_ENVELOPE_HIGH + j] + _STATE_SLACK:
                return False
        return True
    for _ in range(FIT_MAX_ITER):
        kinematics(x, const, R, o, residual, J, True)
        for i in range(n):
            residual[i] = residual[i] - lengths[i]
        if not least_squares(J, residual, n, M, step):
            return False
        done = True
        for j in range(3):
            if not np.isfinite(step[j]):
                return False
        for j in range(3):
            x[j] = x[j] - step[j]
            done = done and abs(step[j]) <= FIT_TOL
        if done:
            return True
    return False


@register_jitable
def desired(
    target: np.ndarray,
    prm: np.ndarray,
    const: np.ndarray,
    state: np.ndarray,
    lengths: np.ndarray,
    R: np.ndarray,
    o: np.ndarray,
    J: np.ndarray,
) -> bool:
    """`PlatformPlanner.desired`: for a target row (18,) (ᴮT_P,d, m), the desired state (3,)
    clipped to the state limits into `state`, its lengths (n,) clipped to the stroke into
    `lengths` [native]; returns whether anything was clipped. R, o, J scratch.

    From the top normal n = ᴮR_P,d e_z (`PlatformModel.desired_state`): Upu3Up β = asin n_x,
    α = atan2(−n_y, n_z) (seed 001 eq (11)), z = n·p_d / unit − l (eq (13)); Upr4
    roll = −asin n_y, pitch = atan2(n_x, n_z) (seed 002 eq (15)), z = z_hold.
    """
    r = TARGET_R
    nx, ny, nz = target[r + 2], target[r + 5], target[r + 8]  # third column of ᴮR_P,d
    norm = np.sqrt(nx * nx + ny * ny + nz * nz)
    nx, ny, nz = nx / norm, ny / norm, nz / norm
    if const[C_MECHANISM] == MECHANISM_UPU3UP:
        p = TARGET_P
        state[0] = (nx * target[p] + ny * target[p + 1] + nz * target[p + 2]) / const[
            C_UNIT
        ] - const[C_L]
        state[1] = np.arctan2(-ny, nz)
        state[2] = np.arcsin(min(max(nx, -1.0), 1.0))
    else:
        state[0] = prm[P_Z_HOLD]
        state[1] = -np.arcsin(min(max(ny, -1.0), 1.0))
        state[2] = np.arctan2(nx, nz)
    clipped = False
    for j in range(3):
        value = min(max(state[j], const[C_STATE_LOW + j]), const[C_STATE_HIGH + j])
        clipped = clipped or value != state[j]
        state[j] = value
    kinematics(state, const, R, o, lengths, J, False)
    low, high = const[C_STROKE_LOW], const[C_STROKE_HIGH]
    for i in range(int(const[C_N_LEGS])):
        value = min(max(lengths[i], low), high)
        clipped = clipped or value != lengths[i]
        lengths[i] = value
    return clipped


@register_jitable
def advance_target(target: np.ndarray, dt: float, out: np.ndarray) -> None:
    """`twin.planners.platform.advance_target`: the target row (18,) moved by its twist over
    dt [s] into out (18,): R_d ← exp(ω dt) R_d (Rodrigues, `so3_exp`), p_d ← p_d + ṗ_d dt."""
    w0, w1, w2 = target[TARGET_W] * dt, target[TARGET_W + 1] * dt, target[TARGET_W + 2] * dt
    theta = np.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
    if theta < 1e-8:
        a, b = 1.0 - theta**2 / 6.0, 0.5 - theta**2 / 24.0
    else:
        a, b = np.sin(theta) / theta, (1.0 - np.cos(theta)) / theta**2
    # E = I + a K + b K², K = [w]×, K² = w wᵀ − θ² I
    k00, k11, k22 = -w2 * w2 - w1 * w1, -w2 * w2 - w0 * w0, -w1 * w1 - w0 * w0
    k01, k02, k12 = w1 * w0, w2 * w0, w2 * w1
    e00, e01, e02 = 1.0 + b * k00, -a * w2 + b * k01, a * w1 + b * k02
    e10, e11, e12 = a * w2 + b * k01, 1.0 + b * k11, -a * w0 + b * k12
    e20, e21, e22 = -a * w1 + b * k02, a * w0 + b * k12, 1.0 + b * k22
    r = TARGET_R
    for j in range(3):
        d0, d1, d2 = target[r + j], target[r + 3 + j], target[r + 6 + j]
        out[r + j] = e00 * d0 + e01 * d1 + e02 * d2
        out[r + 3 + j] = e10 * d0 + e11 * d1 + e12 * d2
        out[r + 6 + j] = e20 * d0 + e21 * d1 + e22 * d2
    for j in range(3):
        out[TARGET_P + j] = target[TARGET_P + j] + target[TARGET_V + j] * dt
        out[TARGET_V + j] = target[TARGET_V + j]
        out[TARGET_W + j] = target[TARGET_W + j]


@register_jitable
def limit(
    command: np.ndarray,
    lengths: np.ndarray,
    guess: np.ndarray,
    prm: np.ndarray,
    const: np.ndarray,
    velocity: np.ndarray,
    x: np.ndarray,
    R: np.ndarray,
    o: np.ndarray,
    residual: np.ndarray,
    J: np.ndarray,
    M: np.ndarray,
    rates: np.ndarray,
) -> bool:
    """`PlatformPlanner.limit`: rates (n,) [native/s] within ±the speed limit into `velocity`;
    returns whether the limit bound. The rest scratch.

    Beyond the limit, the command c is split at the pose of `lengths` (forward kinematics from
    `guess`, the desired state; `guess` itself where that fails) into tilt and heave parts,
    ṡ = J⁺ c, c = J ṡ_tilt + J ṡ_heave: the tilt part whole if it fits, scaled uniformly if
    not; the heave part the largest share σ ∈ [0, 1] that fits.
    """
    n = int(const[C_N_LEGS])
    speed = prm[P_SPEED_LIMIT]
    peak = 0.0
    for i in range(n):
        if not np.isfinite(command[i]):  # not reached with a finite target: pass it on
            peak = -1.0
            break
        peak = max(peak, abs(command[i]))
    if peak <= speed:
        for i in range(n):
            velocity[i] = command[i]
        return False
    if not fit(lengths, guess, const, x, R, o, residual, J, M, rates):
        for j in range(3):
            x[j] = guess[j]
    kinematics(x, const, R, o, residual, J, True)
    if not least_squares(J, command, n, M, rates):
        for j in range(3):
            rates[j] = np.nan
    tilt_peak = 0.0
    for i in range(n):
        tilt = J[i, 1] * rates[1] + J[i, 2] * rates[2]
        velocity[i] = tilt
        tilt_peak = max(tilt_peak, abs(tilt))
    if tilt_peak >= speed:
        scale = speed / tilt_peak
        for i in range(n):
            velocity[i] = velocity[i] * scale
        return True
    share = 1.0
    for i in range(n):
        heave = J[i, 0] * rates[0]
        if heave > 0:
            share = min(share, (speed - velocity[i]) / heave)
        elif heave < 0:
            share = min(share, (-speed - velocity[i]) / heave)
    share = min(1.0, max(0.0, share))
    for i in range(n):
        velocity[i] = velocity[i] + share * (J[i, 0] * rates[0])
    return True


@register_jitable
def actuate(
    l_d: np.ndarray,
    legs: np.ndarray,
    prm: np.ndarray,
    memory: np.ndarray,
    const: np.ndarray,
    dt: float,
    rates: np.ndarray,
) -> bool:
    """`PlatformPlanner.actuate`: effort-driven actuators (mass prm[P_MASS] [kg] each) under
    seed 002's Gazebo PID over one control period, the desired lengths l_d (n,) held; the
    mean rates of their travel into `rates` (n,) [native/s]; returns whether the speed limit
    bound.
    The masses' velocity and the integral carry over in `memory` (M_VELOCITY, M_INTEGRAL).

    Per step h = dt / n_h (the fewest steps of ≤ PHYSICS_STEP): ∫e += e h; the spring and the
    damper implicitly, u⁺ = (m/h u + K_p e + K_i ∫e) / (m/h + K_d + h K_p); |u⁺| ≤ the top
    speed; x⁺ = x + h u⁺, stopped at the stroke's ends (u⁺ = 0 there); all in metres, the
    travel x − x₀ summed apart from the length x₀.
    """
    unit = const[C_UNIT]
    n_h = max(1, int(np.ceil(dt / PHYSICS_STEP - 1e-9)))
    h = dt / n_h
    inertia = prm[P_MASS] / h
    low, high = const[C_STROKE_LOW] * unit, const[C_STROKE_HIGH] * unit
    top = prm[P_SPEED]
    saturated = False
    for i in range(int(const[C_N_LEGS])):
        start = legs[i] * unit
        travel = 0.0
        u = memory[M_VELOCITY + i] * unit
        integral = memory[M_INTEGRAL + i] * unit
        goal = l_d[i] * unit
        for _ in range(n_h):
            e = goal - (start + travel)
            integral = integral + e * h
            u = (inertia * u + EFFORT_KP * e + EFFORT_KI * integral) / (
                inertia + EFFORT_KD + h * EFFORT_KP
            )
            if abs(u) > top:
                saturated = True
            u = min(max(u, -top), top)
            travel = travel + h * u
            x = start + travel
            if x < low:
                travel, u = low - start, 0.0
            elif x > high:
                travel, u = high - start, 0.0
        memory[M_VELOCITY + i] = u / unit
        memory[M_INTEGRAL + i] = integral / unit
        rates[i] = travel / unit / dt
    return saturated


@register_jitable
def step(
    x: np.ndarray,
    legs: np.ndarray,
    target: np.ndarray,
    prm: np.ndarray,
    memory: np.ndarray,
    const: np.ndarray,
    dt: float,
    x_out: np.ndarray,
    legs_out: np.ndarray,
    diag_out: np.ndarray,
    work: np.ndarray,
    R: np.ndarray,
    J: np.ndarray,
    M: np.ndarray,
) -> int:
    """One `PlatformRig.advance`: plan, guard, move the actuators one dt, fit the state.

    Args:
        x: (3,) state at sample k [native, rad, rad]; legs: (4,) its actuator lengths
            [native] (the first n used).
        target: (18,) the held target in B at sample k (`TARGET_*` rows).
        prm: (N_PARAMETERS,) the lane's knobs (`pack_platform`); memory: (N_MEMORY,) the PID's
            integral and previous error, updated.
        const: (N_PLATFORM_CONSTANTS,) `platform_constants`.
        dt: [s] control period.
        x_out, legs_out: (3,), (4,) written: sample k + 1 (sample k's on a hold).
        diag_out: (N_PLATFORM_DIAGNOSTICS,) written.
        work: (8, 18) scratch; R (3, 3), J (4, 3), M (3, 4) scratch.

    Returns:
        The step's fault bits (FAULT_PLANNER, FAULT_KINEMATICS, FAULT_JOINT_LIMIT).
    """
    n = int(const[C_N_LEGS])
    ahead, o, state_d, l_d, l_next = work[0], work[1], work[2], work[3], work[4]
    command, velocity, scratch = work[5], work[6], work[7]
    for j in range(4):
        legs_out[j] = legs[j]
    for j in range(3):
        x_out[j] = x[j]
    diag_out[D_CLIPPED] = 0.0
    diag_out[D_SATURATED] = 0.0

    # PlatformPlanner.step
    for j in range(18):
        if not np.isfinite(target[j]):
            return FAULT_PLANNER  # NaN rates: the rig holds, memory untouched
    clipped = desired(target, prm, const, state_d, l_d, R, o, J)
    pid = prm[P_LAW] == LAW_PID
    # scratch rows 0-2: fit state; rows 4-7: residual; 8-10: rates
    fit_x, residual, rates = scratch[0:3], scratch[4:8], scratch[8:11]
    saturated = False
    if pid and prm[P_MASS] > 0.0:  # effort-driven actuators (PlatformPlanner.actuate)
        saturated = actuate(l_d, legs, prm, memory, const, dt, velocity)
    elif pid:
        has_previous = memory[M_HAS_PREVIOUS] != 0.0
        kp = -np.expm1(-prm[P_KP] * dt) / dt  # proportional_gain: the loop sampled exactly
        ki, kd = prm[P_KI], prm[P_KD]
        for i in range(n):
            error = l_d[i] - legs[i]
            previous = memory[M_PREVIOUS + i] if has_previous else error
            command[i] = kp * error + ki * memory[M_INTEGRAL + i] + kd * (error - previous) / dt
    else:
        advance_target(target, dt, ahead)
        clipped = desired(ahead, prm, const, scratch, l_next, R, o, J) or clipped
        for i in range(n):
            command[i] = (l_next[i] - legs[i]) / dt  # reach l_d(t + dt) in one step
    if not (pid and prm[P_MASS] > 0.0):
        saturated = limit(
            command, legs, state_d, prm, const, velocity, fit_x, R, o, residual, J, M, rates
        )
    if pid and prm[P_MASS] <= 0.0:  # anti-windup by conditional integration
        for i in range(n):
            error = l_d[i] - legs[i]
            if not saturated:
                memory[M_INTEGRAL + i] = memory[M_INTEGRAL + i] + error * dt
            memory[M_PREVIOUS + i] = error
        memory[M_HAS_PREVIOUS] = 1.0
    diag_out[D_CLIPPED] = 1.0 if clipped else 0.0
    diag_out[D_SATURATED] = 1.0 if saturated else 0.0

    # PlatformRig.advance: guard, end stops, forward kinematics
    for i in range(n):
        if not np.isfinite(velocity[i]):
            return FAULT_PLANNER
    fault = 0
    low, high = const[C_STROKE_LOW], const[C_STROKE_HIGH]
    for i in range(n):
        moved = legs[i] + velocity[i] * dt
        lengths = min(max(moved, low), high)  # the actuators' end stops
        if lengths != moved:
            fault = FAULT_JOINT_LIMIT
        l_next[i] = lengths
    if not fit(l_next, x, const, fit_x, R, o, residual, J, M, rates):
        return fault | FAULT_KINEMATICS
    for j in range(3):
        if not np.isfinite(fit_x[j]):
            return fault | FAULT_KINEMATICS
    for j in range(3):
        x_out[j] = fit_x[j]
    for i in range(n):
        legs_out[i] = l_next[i]
    return fault


def run_platform(
    xs: np.ndarray,
    legs: np.ndarray,
    targets: np.ndarray,
    prm: np.ndarray,
    memory: np.ndarray,
    const: np.ndarray,
    dt: float,
    diag: np.ndarray,
    faults: np.ndarray,
) -> None:
    """Step every lane through a chunk of samples, one lane per thread (numba's prange).

    Args:
        xs: (N, B + 1, 3) platform states [native, rad, rad]; row 0 the chunk's start, rows
            1 … B written.
        legs: (N, B + 1, 4) actuator lengths [native], the first n_legs used; rows as xs.
        targets: (N, B, 18) the held target in B at each step (`layout.TARGET_*`; a row B,
            the chunk's end, is not read).
        prm: (N, N_PARAMETERS) per lane (`pack_platform`).
        memory: (N, N_MEMORY) per lane, read and written (`M_*` rows).
        const: (N_PLATFORM_CONSTANTS,) the mechanism (`platform_constants`).
        dt: [s] control period.
        diag: (N, B + 1, N_PLATFORM_DIAGNOSTICS): rows 1 … B written (`D_*` rows; step k's in
            row k + 1).
        faults: (N, B) int64 written: fault bits of each step (`layout.FAULT_*`).
    """
    for n in prange(xs.shape[0]):
        work = np.zeros((8, 18))
        R, J, M = np.zeros((3, 3)), np.zeros((4, 3)), np.zeros((3, 4))
        for k in range(xs.shape[1] - 1):
            faults[n, k] = step(
                xs[n, k], legs[n, k], targets[n, k], prm[n], memory[n], const, dt,
                xs[n, k + 1], legs[n, k + 1], diag[n, k + 1], work, R, J, M,
            )  # fmt: skip


@cache
def compiled_platform(parallel: bool) -> Callable:
    """`run_platform` compiled by numba, parallel over lanes or serial, cached on disk
    (`compile_runner`); the plain `run_platform` without numba."""
    return compile_runner(
        run_platform, parallel, ("twin.sim.kernels.platform", "twin.sim.kernels.layout")
    )
