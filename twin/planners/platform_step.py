r"""The small platforms' step on one lane: the two control laws of seed 002 §5 (the PID
position loop, its proportional term sampled exactly, and the ideal ``ik`` servo with its
one-step preview), the speed limit that keeps the tilt's priority over the heave, the
effort-driven actuators' dynamics, and the target advanced by its twist. The engine's kernel
(`twin.sim.kernels.platform`) and the objects (`twin.planners.platform.PlatformPlanner`,
`twin.planners.platform_model.PlatformModel`) both run these lanes; they read the planner's
knobs and memory by name (`PLATFORM_PARAMETERS`, `PLATFORM_MEMORY`).

Units: lengths in the mechanism's own unit (mm for the Upu3Up, m for the Upr4); targets in m.
"""

from __future__ import annotations

import numpy as np

from twin.batch import LaneBatch
from twin.compiled import register_jitable
from twin.mechanisms.newton import least_squares_lane
from twin.mechanisms.platforms import (
    MAX_LEGS,
    MECHANISM_UPU3UP,
    NewtonWork,
    newton_work,
    platform_fit,
    platform_kinematics,
)
from twin.planners.gains import proportional_gain
from twin.planners.parameters import (
    family_dtype,
)
from twin.planners.tasks import advance_target_lane

LAWS = ("ik", "pid")
#: `PLATFORM_PARAMETERS["law"]` of each law
LAW_IK, LAW_PID = 0, 1
#: Seed 002 §5's effort PID, tuned in Gazebo: kp [N/m], ki [N/(m·s)], kd [N·s/m].
EFFORT_KP, EFFORT_KI, EFFORT_KD = 5000.0, 0.5, 10.0
#: [s] longest step of the actuator dynamics within a control period (Gazebo's default 1 ms
#: physics step, at which its controllers run too).
PHYSICS_STEP = 1e-3


@register_jitable
def physics_steps(dt: float) -> int:
    """Steps of the actuator dynamics in a control period dt [s]: the fewest of ≤ 1 ms."""
    return max(1, int(np.ceil(dt / PHYSICS_STEP - 1e-9)))


#: A platform planner's knobs as the engine's kernel reads them (`PlatformPlanner.pack`): the
#: law (`LAW_*`), kp [1/s], ki [1/s²], kd [-], the speed limit [native/s] (`speed_limit`), the
#: Upr4's held height z_hold [m] (NaN for the Upu3Up), the actuators' moving mass [kg] (0:
#: velocity-commanded; `actuate`) and their top speed [m/s] (`actuator_speed`).
PLATFORM_PARAMETERS = family_dtype(
    (
        ("law", 1),
        ("kp", 1),
        ("ki", 1),
        ("kd", 1),
        ("speed_limit", 1),
        ("z_hold", 1),
        ("mass", 1),
        ("speed", 1),
    )
)
#: A platform planner's state carried from step to step (`PlatformPlanner.pack_memory`): the
#: PID integral ∫e dt [native·s], the previous error e [native], whether there is one (1.0)
#: or the next derivative starts from zero (0.0), the effort-driven actuators' velocity
#: [native/s]; MAX_LEGS values each.
PLATFORM_MEMORY = np.dtype(
    [
        ("integral", np.float64, (MAX_LEGS,)),
        ("previous", np.float64, (MAX_LEGS,)),
        ("has_previous", np.float64),
        ("velocity", np.float64, (MAX_LEGS,)),
    ]
)
#: float64 values of a lane's memory row that `PLATFORM_MEMORY` covers
MEMORY_SIZE = PLATFORM_MEMORY.itemsize // 8


def memory_record(row: np.ndarray) -> np.void:
    """A lane's float memory row (≥ MEMORY_SIZE,) seen as one `PLATFORM_MEMORY` record:
    writing a field writes the row."""
    return row[:MEMORY_SIZE].view(PLATFORM_MEMORY)[0]


# One lane (floats and small arrays; compiled by numba into the engine's kernel and the
# objects' batch loops, `twin.compiled`; plain Python without numba): the control laws.


@register_jitable
def desired_state_lane(
    R_d: np.ndarray, p_d: np.ndarray, z_hold: float, g: np.void, state: np.ndarray
) -> None:
    """`PlatformModel.desired_state` of ᴮT_P,d (R_d (9,) row-major, p_d (3,) [m]) into state
    (3,), not clipped; g: the `PLATFORM_GEOMETRY` record; z_hold [m] the Upr4's height.

    From the top normal n = ᴮR_P,d e_z: Upu3Up β = asin n_x, α = atan2(−n_y, n_z) (seed 001
    eq (11)), z = n·p_d / unit − l (eq (13)); Upr4 roll = −asin n_y, pitch = atan2(n_x, n_z)
    (seed 002 eq (15)), z = z_hold.
    """
    nx, ny, nz = R_d[2], R_d[5], R_d[8]  # third column of ᴮR_P,d
    norm = np.sqrt(nx * nx + ny * ny + nz * nz)
    nx, ny, nz = nx / norm, ny / norm, nz / norm
    if g["mechanism"] == MECHANISM_UPU3UP:
        along = nx * p_d[0] + ny * p_d[1] + nz * p_d[2]
        state[0] = along / g["unit"] - g["l"]  # seed 001 eq (13)
        state[1] = np.arctan2(-ny, nz)
        state[2] = np.arcsin(min(max(nx, -1.0), 1.0))
    else:
        state[0] = z_hold
        state[1] = -np.arcsin(min(max(ny, -1.0), 1.0))
        state[2] = np.arctan2(nx, nz)


@register_jitable
def desired_lane(
    R_d: np.ndarray,
    p_d: np.ndarray,
    z_hold: float,
    g: np.void,
    state: np.ndarray,
    lengths: np.ndarray,
    R: np.ndarray,
    o: np.ndarray,
    J: np.ndarray,
) -> bool:
    """`PlatformPlanner.desired` of ᴮT_P,d (R_d (9,) row-major, p_d (3,) [m]): the desired
    state (3,) clipped to the state limits into `state`, its lengths (n,) clipped to the
    stroke into `lengths` [native]; returns whether anything was clipped. g: the
    `PLATFORM_GEOMETRY` record; z_hold [m] the Upr4's height; R, o, J scratch.
    The state is `desired_state_lane`'s, its lengths `platform_kinematics`' (seed 001 eqs
    (16)-(18), seed 002 eqs (15)-(18)).
    """
    desired_state_lane(R_d, p_d, z_hold, g, state)
    clipped = False
    for j in range(3):
        value = min(max(state[j], g["state_low"][j]), g["state_high"][j])
        clipped = clipped or value != state[j]
        state[j] = value
    platform_kinematics(state, g, R, o, lengths, J, False)
    for i in range(g["n_legs"]):
        value = min(max(lengths[i], g["stroke_low"]), g["stroke_high"])
        clipped = clipped or value != lengths[i]
        lengths[i] = value
    return clipped


@register_jitable
def limit_lane(
    command: np.ndarray,
    lengths: np.ndarray,
    guess: np.ndarray,
    speed: float,
    g: np.void,
    velocity: np.ndarray,
    x: np.ndarray,
    w: NewtonWork,
) -> bool:
    """`PlatformPlanner.limit`: rates (n,) [native/s] within ±speed [native/s] into
    `velocity`; returns whether the limit bound. x, w: scratch (w.step the split's rates).

    Beyond the limit, the command c is split at the pose of `lengths` (`platform_fit` from
    `guess`; `guess` itself where that fails) into tilt and heave parts, ṡ = J⁺ c,
    c = J ṡ_tilt + J ṡ_heave: the tilt part whole if it fits, scaled uniformly if not; the
    heave part the largest share σ ∈ [0, 1] that fits.
    """
    n = g["n_legs"]
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
    if not platform_fit(lengths, guess, g, x, w):
        for j in range(3):
            x[j] = guess[j]  # no pose from the encoders: split at the desired state instead
    R, J, M, rates = w.R, w.J, w.M, w.step
    platform_kinematics(x, g, R, w.o, w.residual, J, True)
    if not least_squares_lane(J, command, n, M, rates):
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
def actuate_lane(
    l_d: np.ndarray,
    legs: np.ndarray,
    mass: float,
    top: float,
    g: np.void,
    dt: float,
    integral: np.ndarray,
    actuator_velocity: np.ndarray,
    rates: np.ndarray,
) -> bool:
    """`PlatformPlanner.actuate`: effort-driven actuators (mass [kg] each, top speed [m/s])
    under seed 002's Gazebo PID over dt [s], the desired lengths l_d (n,) held; the mean rates
    of their travel into `rates` (n,) [native/s]; returns whether the speed limit bound.
    `integral` (n,) [native·s] and `actuator_velocity` (n,) [native/s] carry over, updated.

    Per step h = dt / n_h (`physics_steps`): ∫e += e h; the spring and the damper implicitly,
    u⁺ = (m/h u + K_p e + K_i ∫e) / (m/h + K_d + h K_p); |u⁺| ≤ top; x⁺ = x + h u⁺, stopped at
    the stroke's ends (u⁺ = 0 there); all in metres, the travel x − x₀ summed apart from x₀.
    """
    unit = g["unit"]
    n_h = physics_steps(dt)
    h = dt / n_h
    inertia = mass / h  # [kg/s]
    low, high = g["stroke_low"] * unit, g["stroke_high"] * unit
    saturated = False
    for i in range(g["n_legs"]):
        start = legs[i] * unit
        travel = 0.0
        u = actuator_velocity[i] * unit
        accumulated = integral[i] * unit
        goal = l_d[i] * unit
        for _ in range(n_h):
            e = goal - (start + travel)
            accumulated = accumulated + e * h
            u = (inertia * u + EFFORT_KP * e + EFFORT_KI * accumulated) / (
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
        actuator_velocity[i] = u / unit
        integral[i] = accumulated / unit
        rates[i] = travel / unit / dt
    return saturated


@register_jitable
def plan_lane(
    R_d: np.ndarray,
    p_d: np.ndarray,
    twist: np.ndarray,
    legs: np.ndarray,
    p: np.void,
    m: np.void,
    g: np.void,
    dt: float,
    velocity: np.ndarray,
    work: np.ndarray,
    R: np.ndarray,
    J: np.ndarray,
    M: np.ndarray,
) -> tuple[bool, bool]:
    """`PlatformPlanner.step` on a finite target (R_d (9,), p_d (3,) [m], twist (6,)) and
    actuator lengths legs (n,) [native]: rates (n,) [native/s] into `velocity`; returns
    (clipped, saturated). p, m, g: the `PLATFORM_PARAMETERS`, `PLATFORM_MEMORY` (updated) and
    `PLATFORM_GEOMETRY` records; work (8, 18), R (3, 3), J (4, 3), M (3, 4) scratch.

    "ik": l̇ = (l_d(t + dt) − l) / dt, the target advanced by its twist; "pid": kp e + ki ∫e
    + kd ė with e = l_d − l and the sampled kp (`proportional_gain`), or the effort-driven
    actuators (`actuate_lane`); then the speed limit (`limit_lane`) and the PID's
    conditional integration (anti-windup).
    """
    ahead, o, state_d, l_d, l_next = work[0], work[1], work[2], work[3], work[4]
    command, scratch = work[5], work[7]
    fit_x, residual, rates = scratch[0:3], scratch[4:8], scratch[8:11]
    n = g["n_legs"]
    clipped = desired_lane(R_d, p_d, p["z_hold"], g, state_d, l_d, R, o, J)
    pid = p["law"] == LAW_PID
    if pid and p["mass"] > 0.0:  # effort-driven actuators
        saturated = actuate_lane(l_d, legs, p["mass"], p["speed"], g, dt, m["integral"],
                                 m["velocity"], velocity)  # fmt: skip
        return clipped, saturated
    if pid:
        has_previous = m["has_previous"] != 0.0
        kp, ki, kd = proportional_gain(p["kp"], dt), p["ki"], p["kd"]
        for i in range(n):
            error = l_d[i] - legs[i]
            previous = m["previous"][i] if has_previous else error
            command[i] = kp * error + ki * m["integral"][i] + kd * (error - previous) / dt
    else:
        advance_target_lane(R_d, p_d, twist, dt, M, ahead[0:9].reshape((3, 3)), ahead[9:12])
        ahead_clipped = desired_lane(ahead[0:9], ahead[9:12], p["z_hold"], g, scratch, l_next,
                                     R, o, J)  # fmt: skip
        clipped = clipped or ahead_clipped
        for i in range(n):
            command[i] = (l_next[i] - legs[i]) / dt  # reach l_d(t + dt) in one step
    newton = NewtonWork(R, o, residual, J, M, rates)
    saturated = limit_lane(command, legs, state_d, p["speed_limit"], g, velocity, fit_x, newton)
    if pid:  # anti-windup by conditional integration: no integral while the limit binds
        for i in range(n):
            error = l_d[i] - legs[i]
            if not saturated:
                m["integral"][i] = m["integral"][i] + error * dt
            m["previous"][i] = error
        m["has_previous"] = 1.0
    return clipped, saturated


# Batch loops: the objects' API over the same lane functions, compiled lazily on first use and
# cached on disk (`twin.mechanisms.platforms.batch`; plain Python without numba).


def desired_lanes(
    rotations: np.ndarray,
    positions: np.ndarray,
    z_hold: float,
    geometry: np.ndarray,
    states: np.ndarray,
    lengths: np.ndarray,
    clipped: np.ndarray,
    clip: bool,
) -> None:
    """`desired_lane` (clip) or `desired_state_lane` of rotations (N, 9) and positions (N, 3)
    into states (N, 3), lengths (N, MAX_LEGS) and clipped (N,) bool."""
    R, o, J = np.zeros((3, 3)), np.zeros(3), np.zeros((MAX_LEGS, 3))
    for k in range(states.shape[0]):
        if clip:
            clipped[k] = desired_lane(rotations[k], positions[k], z_hold, geometry[0], states[k],
                                      lengths[k], R, o, J)  # fmt: skip
        else:
            desired_state_lane(rotations[k], positions[k], z_hold, geometry[0], states[k])


def plan_lanes(
    targets: np.ndarray,
    legs: np.ndarray,
    prm: np.ndarray,
    memory: np.ndarray,
    geometry: np.ndarray,
    dt: float,
    velocity: np.ndarray,
    work: np.ndarray,
    flags: np.ndarray,
) -> None:
    """`plan_lane` of targets (N, 18) (ᴮR_d row-major, ᴮp_d, twist) and lengths (N, n): rates
    into velocity (N, n), its scratch into work (N, 8, 18) (row 2 the desired state, row 3 the
    desired lengths), clipped + 2 saturated into flags (N,); prm (N,) and memory (N,) records."""
    R, J, M = np.zeros((3, 3)), np.zeros((MAX_LEGS, 3)), np.zeros((3, 4))
    for k in range(targets.shape[0]):
        target = targets[k]
        clipped, saturated = plan_lane(target[0:9], target[9:12], target[12:18], legs[k], prm[k],
                                       memory[k], geometry[0], dt, velocity[k], work[k], R, J,
                                       M)  # fmt: skip
        flags[k] = (1 if clipped else 0) + (2 if saturated else 0)


def limit_lanes(
    commands: np.ndarray,
    lengths: np.ndarray,
    guesses: np.ndarray,
    speed: float,
    geometry: np.ndarray,
    velocity: np.ndarray,
    bound: np.ndarray,
) -> None:
    """`limit_lane` of commands (N, n) at lengths (N, n) from guesses (N, 3) into velocity
    (N, n) and bound (N,) bool."""
    x, w = np.zeros(3), newton_work()
    for k in range(commands.shape[0]):
        bound[k] = limit_lane(commands[k], lengths[k], guesses[k], speed, geometry[0],
                              velocity[k], x, w)  # fmt: skip


def actuate_lanes(
    l_d: np.ndarray,
    legs: np.ndarray,
    mass: float,
    top: float,
    geometry: np.ndarray,
    dt: float,
    integral: np.ndarray,
    actuator_velocity: np.ndarray,
    rates: np.ndarray,
    saturated: np.ndarray,
) -> None:
    """`actuate_lane` of desired lengths l_d (N, n) from legs (N, n): integral and
    actuator_velocity (N, n) updated, rates (N, n) and saturated (N,) bool written."""
    for k in range(l_d.shape[0]):
        saturated[k] = actuate_lane(l_d[k], legs[k], mass, top, geometry[0], dt, integral[k],
                                    actuator_velocity[k], rates[k])  # fmt: skip


def _advance_batch(rows: np.ndarray, dt: float, T: np.ndarray) -> None:
    """`advance_target_lane` of target rows (N, 18) (`target_rows`) over dt [s] into T (N, 4, 4)."""
    E = np.zeros((3, 3))
    for k in range(rows.shape[0]):
        advance_target_lane(rows[k, 0:9], rows[k, 9:12], rows[k, 12:18], dt, E, T[k, :3, :3],
                            T[k, :3, 3])  # fmt: skip
        for i in range(3):
            T[k, 3, i] = 0.0
        T[k, 3, 3] = 1.0


#: the lane over a batch of targets: what `advance_target` calls
ADVANCE = LaneBatch(_advance_batch, cores=(1,))
