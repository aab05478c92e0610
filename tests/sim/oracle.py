"""Independent statements the engine's tests check its output against (issue 29 item 5).

Nothing here steps a simulation: the engine (`twin.sim.engine`, its kernels in
`twin/sim/kernels`) is the one statement of a step, and its tests judge what it wrote. What is
kept here is what must not share the package's code, stated from the papers and from scipy:

- `held_target`, `pack_target`: the held target of one sample and its kernel row (seed 000
  §5.1; the rotation's logarithm by `scipy.spatial.transform.Rotation`, not `twin.spatial`);
- `rotation`, `integrate`, `step_twist`: the platform's body twist integrated on SE(3) by the
  matrix exponential (`scipy.linalg.expm`) and read back from two states (`logm`);
- `leg_lengths`, `limit_excess`: seed 000 eq (5) from Table 1's hinges, and the distance past
  Table 6's joint limits and Table 1's stroke;
- `Guard`: what the joint-limit guard's outcome must satisfy: a shortened step stays within
  the limits, the full step would have left them, the step is the longest that fits to the
  resolution measured from the outcomes; nothing is taken from the package's bisection.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import expm, logm
from scipy.spatial.transform import Rotation

from twin.mechanisms.hybrid import HybridBoardingSystem
from twin.planners import TipTarget
from twin.sim.base_motion import BaseSamples
from twin.sim.faults import Fault

# ------------------------------------------------------------------------------------ targets


def held_target(held: np.ndarray, base: BaseSamples, k: int, dt: float) -> TipTarget:
    """Desired pose in B at sample k and its mean twist to sample k + 1, for the inertial pose
    `held` (4, 4); the twist is [ᴮṗ; ᴮω] in B [m/s, rad/s] (seed 000 §5.1, docs/planners.md:
    ᴮT_d = ᴵT_B⁻¹ ᴵT*, and the rate that carries it to the next sample over dt)."""
    T0 = np.linalg.solve(base.transform[k], held)
    T1 = np.linalg.solve(base.transform[k + 1], held)
    v = (T1[:3, 3] - T0[:3, 3]) / dt
    R = T1[:3, :3] @ T0[:3, :3].T
    finite = np.all(np.isfinite(R))  # a failed base sample: a NaN target (a planner fault)
    w = Rotation.from_matrix(R).as_rotvec() / dt if finite else np.full(3, np.nan)
    return TipTarget(transform=T0, twist=np.r_[v, w])


def pack_target(target: TipTarget) -> np.ndarray:
    """A `TipTarget` as the kernels' (18,) row, as twin/sim/target.py states it: ᴮR_d
    row-major, ᴮp_d, then the twist [ᴮṗ; ᴮω]."""
    return np.r_[target.transform[:3, :3].ravel(), target.transform[:3, 3], target.twist]


# -------------------------------------------------------------------- the hybrid's kinematics


def rotation(rpy: np.ndarray) -> np.ndarray:
    """ᴮR_P = Rz(yaw) Ry(pitch) Rx(roll) (seed 000 eq (3)) of `rpy` (3,) [rad]: (3, 3)."""
    return Rotation.from_euler("ZYX", np.asarray(rpy)[::-1]).as_matrix()


def _transform(x: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = rotation(x[3:6]), x[:3]
    return T


def _hat(twist: np.ndarray) -> np.ndarray:
    """The 4 × 4 matrix of a twist [v; ω] (se(3))."""
    (vx, vy, vz), (wx, wy, wz) = twist[:3], twist[3:]
    return np.array([[0, -wz, wy, vx], [wz, 0, -wx, vy], [-wy, wx, 0, vz], [0, 0, 0, 0.0]])


def integrate(x: np.ndarray, v: np.ndarray, dt: float) -> np.ndarray:
    """xi (9,) after the virtual-joint velocity v (9,) held for dt [s]: ᴮT_P ← ᴮT_P exp(V̂ dt)
    with V = [ᴾṖ; ω_P] the platform's body twist (seed 000 eq (24): the Jacobian's columns
    0-5), by `scipy.linalg.expm`; the gangway joints add q̇ dt."""
    T = _transform(x) @ expm(_hat(np.asarray(v[:6]) * dt))
    rpy = Rotation.from_matrix(T[:3, :3]).as_euler("ZYX")[::-1]
    return np.r_[T[:3, 3], rpy, x[6:] + np.asarray(v[6:]) * dt]


def step_twist(x: np.ndarray, x_next: np.ndarray, dt: float) -> np.ndarray:
    """The velocity (9,) that `integrate` carries x to x_next with over dt, read from the two
    states (`scipy.linalg.logm` of ᴮT_P⁻¹ ᴮT_P'), for rotations by less than π."""
    relative = np.linalg.solve(_transform(x), _transform(x_next))
    M = np.real(logm(relative))
    twist = np.r_[M[:3, 3], M[2, 1], M[0, 2], M[1, 0]]
    return np.r_[twist, x_next[6:] - x[6:]] / dt


def leg_lengths(mechanism: HybridBoardingSystem, x: np.ndarray) -> np.ndarray:
    """Leg lengths (6,) [m], seed 000 eq (5): |ᴮp_P + ᴮR_P ᴾp_i − ᴮb_i| with Table 1's hinges."""
    hinges = mechanism.layout
    tops = x[:3] + hinges.platform_hinges @ rotation(x[3:6]).T
    return np.linalg.norm(tops - hinges.base_hinges, axis=-1)


def limit_excess(mechanism: HybridBoardingSystem, x: np.ndarray) -> np.ndarray:
    """How far (15,) [m, rad] each joint is past Table 6's limits and each leg past Table 1's
    stroke; 0 inside."""
    legs, stewart = leg_lengths(mechanism, x), mechanism.stewart
    joints = np.maximum(mechanism.lower - x, 0) + np.maximum(x - mechanism.upper, 0)
    return np.r_[
        joints, np.maximum(stewart.leg_min - legs, 0) + np.maximum(legs - stewart.leg_max, 0)
    ]


# ------------------------------------------------------------------------------------ the guard


#: [m, rad] how far past what it was the guard may let a limit move in a step it allows (the
#: guard's rounding slack must be below this; the test's own rounding is ~1e-15)
FIT_TOL = 1e-9


def dyadic_exponent(s: float) -> int:
    """The least m with s·2^m an integer (s in [0, 1], a bisection's outcome)."""
    m = 0
    while s * 2.0**m != np.floor(s * 2.0**m):
        m += 1
    return m


class Guard:
    """The joint-limit guard's outcome judged on its own (seed 000's limits, the former
    `HybridRig.advance`'s contract): for the hybrid mechanism and control period dt [s]."""

    def __init__(self, mechanism: HybridBoardingSystem, dt: float) -> None:
        self.mechanism, self.dt = mechanism, dt

    def fits(self, x: np.ndarray, v: np.ndarray, s: float) -> bool:
        """Whether the step s·v from x carries no joint and no leg further past its limit than
        it already is (`FIT_TOL` allowed)."""
        now = limit_excess(self.mechanism, x)
        return bool(
            np.all(limit_excess(self.mechanism, integrate(x, s * v, self.dt)) <= now + FIT_TOL)
        )

    def check(
        self, x: np.ndarray, x_next: np.ndarray, s: float, bits: int | None, hold: bool,
        v: np.ndarray | None = None, resolution: float | None = None,
    ) -> None:  # fmt: skip
        """Assert one guarded step x → x_next (9,) with limit scale s and fault bits (None: not
        known per step; the caller checks the counts).

        The planner's velocity v (9,) if known, else read from the outcome (`step_twist` / s;
        not for s = 0). Non-finite v: held (x_next == x, s = 0, PLANNER). Else x_next is
        `integrate`(x, s·v); `record` mode (hold False): s = 1 and no JOINT_LIMIT; `hold`: s = 1
        or JOINT_LIMIT, a step that fits, and when shortened the full step does not fit, nor
        does s + `resolution` (the bisection's, measured from the outcomes: `resolution_of`).
        """
        if v is not None and not np.all(np.isfinite(v)):
            np.testing.assert_array_equal(x_next, x)
            assert s == 0.0
            assert bits is None or (bits & Fault.PLANNER and not bits & Fault.JOINT_LIMIT)
            return
        assert 0.0 <= s <= 1.0
        if bits is not None:
            assert not bits & Fault.PLANNER
            assert bool(bits & Fault.JOINT_LIMIT) == (s < 1.0)
        if not hold:
            assert s == 1.0
            if v is not None:
                np.testing.assert_allclose(x_next, integrate(x, v, self.dt), rtol=0, atol=1e-9)
            return
        if s == 0.0:  # stood on a limit: nothing moved (to the rpy round trip)
            np.testing.assert_allclose(x_next, x, rtol=0, atol=1e-12)
            if v is not None:
                assert not self.fits(x, v, 1.0)
            return
        if v is None:
            v = step_twist(x, x_next, self.dt) / s
        else:
            np.testing.assert_allclose(x_next, integrate(x, s * v, self.dt), rtol=0, atol=1e-9)
        assert self.fits(x, v, s)
        if s < 1.0:
            assert not self.fits(x, v, 1.0)
            if resolution is not None:
                assert not self.fits(x, v, s + resolution)


def resolution_of(scales: np.ndarray) -> float:
    """The bisection's resolution 2^-N measured from its outcomes: N the largest
    `dyadic_exponent` of the scales of the steps shortened but taken (0 < s < 1; each is then a
    multiple of 2^-N)."""
    shortened = [float(s) for s in np.ravel(scales) if 0.0 < s < 1.0]
    assert shortened, "no step was shortened and taken: nothing to measure the resolution from"
    return 2.0 ** -max(dyadic_exponent(s) for s in shortened)


# ---------------------------------------------------------------------------------- platforms


def assert_platform_steps(
    model: object, states: np.ndarray, legs: np.ndarray, held: np.ndarray | None = None,
    limited: np.ndarray | None = None,
) -> None:  # fmt: skip
    """A small platform's samples states (S + 1, 3) and actuator lengths legs (S + 1, n)
    [native] as the actuators and the rigid top allow (the former `PlatformRig.advance`'s
    contract): the lengths inside the stroke; the state after each step the least-squares fit
    of its lengths (the normal equations Jᵀ(l(x) − L) = 0 with J by central differences of
    `model.leg_lengths`; three legs for three DOF: l(x) = L). Per-step masks (S,): `held`
    steps (PLANNER, KINEMATICS) move nothing and fit nothing; `limited` (JOINT_LIMIT) steps
    end with a leg on a stroke end."""
    low, high = (np.asarray(b)[: legs.shape[1]] for b in model.stroke)  # type: ignore[attr-defined]
    assert np.all((legs >= low) & (legs <= high))
    held = np.zeros(len(states) - 1, dtype=bool) if held is None else held
    still = np.all(states[1:] == states[:-1], -1) & np.all(legs[1:] == legs[:-1], -1)
    assert np.all(still[held])
    lengths_of = model.leg_lengths  # type: ignore[attr-defined]
    h = 1e-6 * np.maximum(1.0, np.abs(states).max(axis=0))
    for x, lengths in zip(states[1:][~held], legs[1:][~held], strict=True):
        r = lengths_of(x) - lengths
        J = np.stack(
            [(lengths_of(x + e) - lengths_of(x - e)) / (2 * e.sum()) for e in np.diag(h)], -1
        )
        assert np.abs(J.T @ r).max() <= 1e-7 * np.abs(J).max() * max(1.0, np.abs(lengths).max())
        if legs.shape[1] == 3:
            assert np.abs(r).max() <= 1e-9 * max(1.0, np.abs(lengths).max())
    if limited is not None:
        on_end = np.any((legs[1:] == low) | (legs[1:] == high), -1)
        assert np.all(on_end[limited])
