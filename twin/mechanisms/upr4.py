r"""The 4-UPR UAV landing platform of seed 002 (§§2-4): geometry, kinematics, limits, workspace.

Four limbs U-P-R: a universal joint at the base hinge b_i, an electric cylinder, a revolute
joint at the top hinge a_i (seed 002 §2.1). The state is `(z, roll, pitch)` [m, rad, rad].

Frames (docs/frames.md, docs/mechanisms/upr4.md): base O-xyz at the centre of the bottom
hinge square (seed 002 §2.1, "origin O (centre of the base platform)"), z up, x and y parallel
to the sides of the square, b_1 in the (+x, +y) quadrant (eq (1)); platform p at the centroid
of the top hinge square, parallel to O at the level pose (eq (2)).

Platform pose (eqs (15)-(16)): the centre is P = (0, 0, z) and R = Ry(pitch)·Rx(roll) with no
yaw, which is the twin's Rz(yaw)·Ry(pitch)·Rx(roll) at yaw = 0, so no angle conversion is
needed and there is no parasitic x, y or yaw. Eq (14)'s screw analysis backs this to first
order at the level pose; rigid R joints would allow finite tilts about the base diagonals only
(docs/mechanisms/upr4.md), and the paper's Gazebo model imposes the motion by a virtual chain.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike

from twin.batch import LaneBatch
from twin.errors import ConvergenceError, TwinError, UnreachableError
from twin.mechanisms import platforms
from twin.mechanisms.legs import LegLayout, LegState, legs
from twin.mechanisms.newton import check_tolerances, start
from twin.mechanisms.platforms import MECHANISM_UPR4, PLATFORM_GEOMETRY, upr4_frame_lane
from twin.validation import as_array, check_range

LIMIT_NAMES = ("stroke_min", "stroke_max", "u_joint", "collision")
# [m | rad] a Newton step this small with the residual still above tol means a least-squares
# stationary point: the four lengths are inconsistent, not a slow solver.
_STALL_STEP = 1e-12


def square(side: float) -> np.ndarray:
    """Corners (4, 3) [m] of a square of side `side` centred at the origin in z = 0.

    Order of seed 002 eqs (1)-(2): (+,+), (+,−), (−,−), (−,+).
    """
    half = side / 2.0
    return np.array(
        [[half, half, 0.0], [half, -half, 0.0], [-half, -half, 0.0], [-half, half, 0.0]]
    )


def platform_transform(z: np.ndarray, roll: np.ndarray, pitch: np.ndarray) -> np.ndarray:
    """ᴼT_p (..., 4, 4) [m]: P = (0, 0, z) (eq (16)), R = Ry(pitch)·Rx(roll) (eq (15)), by
    `platforms.upr4_frame_lane` lane by lane (`FRAME`); z, roll, pitch (...) [m, rad, rad]
    broadcast together."""
    return FRAME([z, roll, pitch], [], [(4, 4)])[0]


def _frame_batch(z: np.ndarray, roll: np.ndarray, pitch: np.ndarray, T: np.ndarray) -> None:
    """`upr4_frame_lane` over states z, roll, pitch (N,) into T (N, 4, 4)."""
    for k in range(z.shape[0]):
        upr4_frame_lane(z[k], roll[k], pitch[k], T[k, :3, :3], T[k, :3, 3])
        T[k, 3, 0], T[k, 3, 1], T[k, 3, 2], T[k, 3, 3] = 0.0, 0.0, 0.0, 1.0


#: the lane over a batch of states: what `platform_transform` calls
FRAME = LaneBatch(_frame_batch, cores=(0, 0, 0))


def joint_frames(base_hinges: np.ndarray, platform_hinges: np.ndarray, z0: float) -> np.ndarray:
    """U-joint frames J_i (4, 3, 3) [-], columns x_i, y_i, z_i in the base frame.

    z_i = s_i⁰, the limb direction at the home pose (level at z0): the paper's static link
    s_i⁰ (§5, Fig. 10) and its "(·)⁰" after eq (27). x_i = s_i⁰ × e_z, horizontal and
    tangential, the U joint's second axis and parallel to the R joint ($2 ∥ $4, eqs (4)-(7),
    eq (12)); y_i = z_i × x_i, whose horizontal part points along the base diagonal ("45
    degrees to the global Y-axis", below eq (26)).
    """
    s0 = platform_hinges + np.array([0.0, 0.0, z0]) - base_hinges
    s0 /= np.linalg.norm(s0, axis=-1, keepdims=True)
    x = np.cross(s0, np.array([0.0, 0.0, 1.0]))
    x /= np.linalg.norm(x, axis=-1, keepdims=True)
    return np.stack([x, np.cross(s0, x), s0], -1)


def u_joint_angles(frames: np.ndarray, units: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """U-joint (roll, pitch), each (..., 4) [rad], with s_i = J_i·Ry(pitch)·Rx(roll)·e_z.

    Pitch turns about the base-fixed y_i (first axis, $1 of eq (4)), roll about the moved x_i
    (second axis, $2 of eq (5)); both are zero at the home pose. In J_i coordinates
    s = (cos roll sin pitch, −sin roll, cos roll cos pitch).

    Args:
        frames: (4, 3, 3) J_i from `joint_frames`.
        units: (..., 4, 3) limb unit vectors s_i in the base frame (eq (20)).
    """
    local = (np.swapaxes(frames, -1, -2) @ units[..., None])[..., 0]  # J_iᵀ s_i
    roll = np.arcsin(np.clip(-local[..., 1], -1.0, 1.0))
    pitch = np.arctan2(local[..., 0], local[..., 2])
    return roll, pitch


@dataclass(frozen=True)
class JointAngles:
    """Passive joint angles of the four limbs, each (..., 4) [rad].

    Attributes:
        u_roll: U-joint roll about its second axis x_i, from the home pose (β_x, eq (24)).
        u_pitch: U-joint pitch about its first axis y_i, from the home pose (β_y, eq (26)).
        r: R-joint angle γ_i between the limb and the line from a_i to the platform centre,
            absolute as printed in eq (27).
    """

    u_roll: np.ndarray
    u_pitch: np.ndarray
    r: np.ndarray


@dataclass(frozen=True)
class Workspace:
    """Roll × pitch sweep at one height (seed 002 §4, Table 1, eq (28), Fig. 8b).

    Attributes:
        z: [m] platform height of the sweep.
        roll: (n_roll,) [rad] grid values.
        pitch: (n_pitch,) [rad] grid values.
        feasible: (n_roll, n_pitch) no limit violated.
        violated: LIMIT_NAMES → (n_roll, n_pitch) that limit violated.
        binding: (n_roll, n_pitch) name of the limit met first on the straight path in
            (roll, pitch) from the level platform to the point; "" where feasible.
        roll_limits: (2,) [rad] lowest and highest grid roll feasible at pitch 0, reached
            without crossing an infeasible grid point (Table 1's "verified limit").
        pitch_limits: (2,) [rad] the same for pitch at roll 0.
        roll_limits_exact: (2,) [rad] the boundary itself, by bisection along the roll axis.
        pitch_limits_exact: (2,) [rad] the same along the pitch axis.
        roll_binding: limit binding at (roll_limits_exact[0], roll_limits_exact[1]).
        pitch_binding: the same for pitch.
        ray_angles: (n_rays,) [rad] directions φ of rays (roll, pitch) = ρ (cos φ, sin φ).
        ray_radii: (n_rays,) [rad] boundary ρ along each ray, by bisection (capped at `sweep`).
        circle_radius: [rad] eq (28)'s radius: the largest circle √(roll² + pitch²) ≤ r about
            the level pose inside the feasible set, min of `ray_radii`.
        circle_radius_max: [rad] max of `ray_radii`; the set is a circle when both agree.
    """

    z: float
    roll: np.ndarray
    pitch: np.ndarray
    feasible: np.ndarray
    violated: dict[str, np.ndarray]
    binding: np.ndarray
    roll_limits: np.ndarray
    pitch_limits: np.ndarray
    roll_limits_exact: np.ndarray
    pitch_limits_exact: np.ndarray
    roll_binding: tuple[str, str]
    pitch_binding: tuple[str, str]
    ray_angles: np.ndarray
    ray_radii: np.ndarray
    circle_radius: float
    circle_radius_max: float


@dataclass(frozen=True)
class Upr4:
    r"""Seed 002's 4-UPR landing platform; lengths [m], angles [rad].

    Frames: base O at the centre of the bottom hinge square (z up, axes along the square's
    sides, b_1 = (b/2, b/2, 0), eq (1)); platform p at the centroid of the top hinge square,
    ᵖa_1 = (a/2, a/2, 0) (eq (2)). State `(z, roll, pitch)`: P = (0, 0, z),
    ᴼR_p = Ry(pitch)·Rx(roll) (eqs (15)-(16)) = the twin's Rz·Ry·Rx at yaw 0.

    Limits (`limits_violated`): limb stroke 0.7225 ≤ l_i ≤ 1.1225 m (SPEC erratum 10: the
    printed inequality is reversed); U-joint |roll|, |pitch| ≤ `u_joint_limit` about the home
    pose (SPEC erratum 10: printed as 30° and ±45°, default ±45°); collision (eq (3)) unless
    z > (pad_side/√2)·sin α, α the platform tilt, i.e. the pad's corner circle stays above the
    base plane (the printed "× 2" is √2 with the root lost, as in eqs (18) and (28); only √2
    gives Table 1's π/9, docs/mechanisms/upr4.md).

    Attributes:
        a: side of the top hinge square (eq (2)).
        b: side of the bottom hinge square (eq (1)).
        z0: home height; the U joints' zero is the limb direction there (eqs (23)-(27)).
        stroke_min: retracted limb length, hinge to hinge.
        stroke_max: extended limb length (0.4 m stroke).
        u_joint_limit: bound on each U-joint angle about the home pose.
        pad_side: side of the square landing pad (2 × 2 m², §2.1), for eq (3).
    """

    a: float = 0.2
    b: float = 1.25
    z0: float = 0.5
    stroke_min: float = 0.7225
    stroke_max: float = 1.1225
    u_joint_limit: float = float(np.pi / 4)
    pad_side: float = 2.0
    state_names: ClassVar[tuple[str, str, str]] = ("z", "roll", "pitch")
    layout: LegLayout = field(init=False, repr=False, compare=False)
    _frames: np.ndarray = field(init=False, repr=False, compare=False)
    _geometry: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        for name in ("a", "b", "z0", "stroke_min", "stroke_max", "u_joint_limit", "pad_side"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise TwinError(f"Upr4.{name} must be a positive finite number, got {value!r}")
        if self.a == self.b:
            raise TwinError(f"Upr4 needs a != b: with a = b = {self.a} m the limbs stand vertical")
        if not self.stroke_min < self.stroke_max:
            raise TwinError(
                f"Upr4 needs stroke_min < stroke_max, got {self.stroke_min} >= {self.stroke_max} m"
            )
        if self.u_joint_limit >= np.pi / 2:
            raise TwinError(f"Upr4.u_joint_limit must be below π/2 rad, got {self.u_joint_limit}")
        layout = LegLayout(
            base_hinges=square(self.b),  # seed 002 eq (1)
            platform_hinges=square(self.a),  # seed 002 eq (2)
            length_min=np.full(4, self.stroke_min),
            length_max=np.full(4, self.stroke_max),
        )
        home = np.hypot(np.hypot(*(layout.platform_hinges - layout.base_hinges)[0, :2]), self.z0)
        if not self.stroke_min <= home <= self.stroke_max:
            raise TwinError(
                f"Upr4 home pose (level, z0 = {self.z0} m) needs limbs of {home:.4f} m, outside "
                f"the stroke [{self.stroke_min}, {self.stroke_max}] m"
            )
        object.__setattr__(self, "layout", layout)
        frames = joint_frames(layout.base_hinges, layout.platform_hinges, self.z0)
        object.__setattr__(self, "_frames", frames)
        geometry = self.pack()
        geometry.setflags(write=False)
        object.__setattr__(self, "_geometry", geometry)

    def pack(self) -> np.ndarray:
        """The mechanism as its lanes read it (`twin.mechanisms.platforms`): a (1,) array of one
        `PLATFORM_GEOMETRY` record [m, rad]; no envelope (±inf)."""
        out = np.zeros(1, PLATFORM_GEOMETRY)
        g = out[0]
        g["mechanism"], g["n_legs"], g["unit"] = MECHANISM_UPR4, 4, 1.0
        g["stroke_low"], g["stroke_high"] = self.stroke_min, self.stroke_max
        g["state_low"], g["state_high"] = self.state_limits
        g["envelope_low"], g["envelope_high"] = -np.inf, np.inf
        g["base_hinges"][:] = self.layout.base_hinges.ravel()  # seed 002 eq (1)
        g["platform_hinges"][:] = self.layout.platform_hinges.ravel()  # seed 002 eq (2)
        return out

    @property
    def pad_radius(self) -> float:
        """[m] half-diagonal of the landing pad, the radius in eq (3)."""
        return self.pad_side / np.sqrt(2.0)

    @property
    def working_state(self) -> np.ndarray:
        """(3,) the home pose (z, roll, pitch) = (z0, 0, 0): level at the working height."""
        return np.array([self.z0, 0.0, 0.0])

    @property
    def state_limits(self) -> tuple[np.ndarray, np.ndarray]:
        """(low, high), each (3,) [m, rad, rad]: a box around every feasible `(z, roll, pitch)`.

        z ≤ z_max, the level height at full stroke: tilting only lengthens Σ l_i² (eq (18)),
        so no feasible state is higher. Eq (3) needs sin α < z / pad_radius, and
        |roll|, |pitch| ≤ α because cos α = cos roll · cos pitch.
        """
        reach = np.hypot(*(self.layout.platform_hinges - self.layout.base_hinges)[0, :2])
        z_max = np.sqrt(self.stroke_max**2 - reach**2)
        tilt = np.arcsin(min(1.0, z_max / self.pad_radius))
        return np.array([0.0, -tilt, -tilt]), np.array([z_max, tilt, tilt])

    def legs(self, z: ArrayLike, roll: ArrayLike, pitch: ArrayLike) -> LegState:
        """Limb vectors S_i = a_i − b_i, lengths, unit vectors s_i (eqs (17)-(20)), base frame."""
        z, roll, pitch = self._state(z, roll, pitch)
        return legs(self.layout, platform_transform(z, roll, pitch))

    def leg_lengths(
        self, z: ArrayLike, roll: ArrayLike, pitch: ArrayLike, *, check: bool = False
    ) -> np.ndarray:
        """Limb lengths l_i (..., 4) [m], hinge to hinge; seed 002 eqs (15)-(18).

        Args:
            z: (...) [m] height of the platform centre above the base plane.
            roll: (...) [rad] rotation about x (eq (15)'s θx).
            pitch: (...) [rad] rotation about y (eq (15)'s θy).
            check: raise UnreachableError if any limit of `limits_violated` is violated;
                without it the lengths are returned as they are (a planner counts violations).
        """
        if check:
            self.check(z, roll, pitch)
        z, roll, pitch = self._state(z, roll, pitch)
        return platforms.leg_lengths(self._geometry, np.stack([z, roll, pitch], -1))

    def jacobian(self, z: ArrayLike, roll: ArrayLike, pitch: ArrayLike) -> np.ndarray:
        """∂(l_1..l_4)/∂(z, roll, pitch) (..., 4, 3) [m/m, m/rad].

        The leg twist Jacobian (rows [s_iᵀ, (R ᵖa_i × s_i)ᵀ]) times the map from state rates to
        the platform twist: v_P = ż e_z, ω = E(roll, pitch, 0)·(roll̇, pitcḣ, 0)
        (`platforms.platform_kinematics`).
        """
        z, roll, pitch = self._state(z, roll, pitch)
        return platforms.jacobian(self._geometry, np.stack([z, roll, pitch], -1))

    def limb_velocities(
        self,
        z: ArrayLike,
        roll: ArrayLike,
        pitch: ArrayLike,
        z_dot: ArrayLike,
        roll_dot: ArrayLike,
        pitch_dot: ArrayLike,
    ) -> np.ndarray:
        """Sliding velocities l̇_i (..., 4) [m/s]; seed 002 eqs (21)-(22).

        Ṡ_i = ω × R ᵖa_i + Ṗ with the rotated offset R ᵖa_i (SPEC erratum 10; the print has
        a_i) and ω = E·(roll̇, pitcḣ, 0), the angular velocity of R = Ry·Rx: eq (21)'s θ̇ is
        exact only at pitch 0 (docs/mechanisms/upr4.md). l̇_i = s_i · Ṡ_i (eq (22)), which is
        the row i of ∂l/∂(z, roll, pitch) (`jacobian`, `platforms.platform_kinematics`, the
        engine's lane) times the state rates.

        Args:
            z, roll, pitch: (...) state [m, rad, rad].
            z_dot, roll_dot, pitch_dot: (...) its rates [m/s, rad/s, rad/s].
        """
        z, roll, pitch, z_dot, roll_dot, pitch_dot = self._broadcast(
            ("z", z),
            ("roll", roll),
            ("pitch", pitch),
            ("z_dot", z_dot),
            ("roll_dot", roll_dot),
            ("pitch_dot", pitch_dot),
        )
        J = platforms.jacobian(self._geometry, np.stack([z, roll, pitch], -1))
        rates = np.stack([z_dot, roll_dot, pitch_dot], -1)
        return (J @ rates[..., None])[..., 0]  # eqs (21)-(22)

    def joint_angles(self, z: ArrayLike, roll: ArrayLike, pitch: ArrayLike) -> JointAngles:
        """U-joint and R-joint angles of the four limbs; seed 002 eqs (23)-(27).

        The U-joint angles follow the paper's definition (limb frame = joint frame turned
        about its y then x axis, z along the limb, §2.1) about the home pose; see
        `u_joint_angles`. The R-joint angle is eq (27):
        γ_i = arccos((P − a_i)/|P − a_i| · s_i).
        """
        state = self.legs(z, roll, pitch)
        u_roll, u_pitch = u_joint_angles(self._frames, state.units)
        inward = -state.arms / np.linalg.norm(state.arms, axis=-1, keepdims=True)  # P − a_i
        r = np.arccos(np.clip(np.sum(inward * state.units, axis=-1), -1.0, 1.0))  # eq (27)
        return JointAngles(u_roll=u_roll, u_pitch=u_pitch, r=r)

    def limits_violated(
        self, z: ArrayLike, roll: ArrayLike, pitch: ArrayLike
    ) -> dict[str, np.ndarray]:
        """Which limits a state violates: LIMIT_NAMES → (...) bool.

        `stroke_min` / `stroke_max`: some l_i below / above the stroke; `u_joint`: some U-joint
        angle beyond ±u_joint_limit; `collision`: eq (3), z ≤ pad_radius · sin α with
        cos α = e_z · R e_z = cos roll · cos pitch.
        """
        z, roll, pitch = self._state(z, roll, pitch)
        state = legs(self.layout, platform_transform(z, roll, pitch))
        u_roll, u_pitch = u_joint_angles(self._frames, state.units)
        alpha = np.arccos(np.clip(np.cos(roll) * np.cos(pitch), -1.0, 1.0))  # eq (3)
        return {
            "stroke_min": np.any(state.lengths < self.stroke_min, axis=-1),
            "stroke_max": np.any(state.lengths > self.stroke_max, axis=-1),
            "u_joint": np.any(
                (np.abs(u_roll) > self.u_joint_limit) | (np.abs(u_pitch) > self.u_joint_limit),
                axis=-1,
            ),
            "collision": z <= self.pad_radius * np.sin(alpha),  # seed 002 eq (3)
        }

    def feasible(self, z: ArrayLike, roll: ArrayLike, pitch: ArrayLike) -> np.ndarray:
        """(...) bool: no limit of `limits_violated` is violated."""
        return ~np.any(np.stack(list(self.limits_violated(z, roll, pitch).values())), axis=0)

    def check(self, z: ArrayLike, roll: ArrayLike, pitch: ArrayLike) -> None:
        """Raise UnreachableError naming every violated limit and the first offending state."""
        violated = self.limits_violated(z, roll, pitch)
        names = [name for name in LIMIT_NAMES if np.any(violated[name])]
        if names:
            z, roll, pitch = self._state(z, roll, pitch)
            bad = np.any(np.stack([violated[n] for n in names]), axis=0)
            first = tuple(np.argwhere(bad)[0]) if bad.ndim else ()
            raise UnreachableError(
                f"Upr4 state (z, roll, pitch) = ({z[first]:.6g} m, {roll[first]:.6g} rad, "
                f"{pitch[first]:.6g} rad) violates {', '.join(names)} (stroke "
                f"[{self.stroke_min}, {self.stroke_max}] m, U joints ±{self.u_joint_limit:.6g} "
                f"rad, collision z > {self.pad_radius:.6g}·sin α, seed 002 eq (3))"
            )

    def forward(
        self,
        lengths: ArrayLike,
        guess: ArrayLike | None = None,
        *,
        tol: float = 1e-10,
        max_iter: int = 30,
    ) -> np.ndarray:
        """State `(z, roll, pitch)` (..., 3) [m, rad, rad] from limb lengths by Newton-Raphson.

        Four lengths, three unknowns: Gauss-Newton steps Δx = (JᵀJ)⁻¹Jᵀ(l(x) − L), exact
        Newton when the lengths come from a state. Lengths of no state (inconsistent) stall at
        a nonzero least-squares residual and raise UnreachableError.

        Args:
            lengths: (..., 4) [m] limb lengths, each within [stroke_min, stroke_max].
            guess: (..., 3) starting state, broadcast against the batch; default the home
                pose (z0, 0, 0).
            tol: [m | rad] stop when every limb's residual and the Newton step are at most
                this.
            max_iter: Newton steps before giving up.

        Raises:
            TwinError: bad shape, NaN or inf, a length outside the stroke, bad tol/max_iter.
            UnreachableError: the lengths fit no state (least-squares residual above tol).
            ConvergenceError: no convergence within max_iter steps, or a singular Jacobian.
        """
        lengths = as_array(lengths, "lengths", (4,))
        check_range(lengths, "lengths [m]", self.stroke_min, self.stroke_max)

        check_tolerances(tol, max_iter)
        x0 = start(guess, np.array([self.z0, 0.0, 0.0]), (*lengths.shape[:-1], 3))
        # A small residual alone is not enough: ∂l/∂roll is only ~0.06 m/rad (small top
        # square), so a 1e-10 m residual can hide a 2e-9 rad error; the step must be small too.
        # Gauss-Newton on l(x) − L: `platforms.platform_newton`, the engine's lane.
        result = platforms.forward(self._geometry, lengths, x0, tol, max_iter, tol)
        if result.converged:
            return result.x
        residual = result.residual
        unsolved = np.any(np.abs(residual) > tol, axis=-1)
        if (
            np.all(np.isfinite(residual))
            and np.any(unsolved)
            and np.all(np.abs(result.step[unsolved]) < _STALL_STEP)
        ):
            raise UnreachableError(
                f"Upr4.forward: lengths {np.round(lengths[unsolved], 6).tolist()!r:.160} m fit no "
                f"(z, roll, pitch) state: Newton-Raphson settled at a least-squares residual of "
                f"{result.worst:.3g} m > tol {tol:g} m (the four lengths are inconsistent)"
            )
        raise ConvergenceError(
            f"Upr4.forward did not converge: stopped after {result.iterations} Newton-Raphson "
            f"steps (max_iter={max_iter}) with worst limb residual {result.worst:.3g} m (tol "
            f"{tol:g} m); the lengths may fit no state, or give a closer `guess`"
        )

    def platform_pose(self, state: ArrayLike) -> np.ndarray:
        """Platform pose `[x, y, z, roll, pitch, yaw]` (..., 6) [m, rad] of p in O.

        `[0, 0, z, roll, pitch, 0]`: eq (16) puts the centre on the z axis with no yaw and
        eq (15)'s Ry(pitch)·Rx(roll) is Rz(0)·Ry(pitch)·Rx(roll), the twin's order.

        Args:
            state: (..., 3) `(z, roll, pitch)` [m, rad, rad].
        """
        state = as_array(state, "state", (3,))
        o = np.zeros(state.shape[:-1])
        return np.stack([o, o, state[..., 0], state[..., 1], state[..., 2], o], -1)

    def workspace(
        self,
        z: float | None = None,
        *,
        sweep: float = np.pi / 2,
        n_roll: int = 91,
        n_pitch: int = 91,
        n_rays: int = 72,
        path_samples: int = 16,
        ray_step: float = np.radians(0.25),
    ) -> Workspace:
        """Sweep roll × pitch at height z (seed 002 §4: Table 1, Fig. 8b, eq (28)).

        The grid spans [−sweep, sweep] on both axes (Table 1: ±π/2). A point's `binding`
        limit is the first one met on the straight path from the level pose, sampled at
        `path_samples` points. Exact single-axis limits and the rays for eq (28) march out in
        steps of `ray_step` to the first infeasible sample, then bisect to 1e-12 rad.

        Args:
            z: [m] platform height; default z0 (Table 1 uses 0.5 m).
            sweep: [rad] half-range of the sweep.
            n_roll, n_pitch: grid points per axis, odd (≥ 3) so that 0 is on the grid.
            n_rays: rays for the eq (28) circle, evenly spread over 2π.
            path_samples: samples on each point's path from level, for `binding`.
            ray_step: [rad] marching step along rays before bisection.
        """
        z = self.z0 if z is None else float(as_array(z, "z"))
        for name, n in (("n_roll", n_roll), ("n_pitch", n_pitch)):
            if n < 3 or n % 2 == 0:
                raise TwinError(
                    f"workspace {name} must be odd and at least 3 (0 on the grid), got {n}"
                )
        if not (
            0 < sweep <= np.pi / 2 and 0 < ray_step <= sweep and n_rays >= 1 and path_samples >= 1
        ):
            raise TwinError(
                "workspace needs 0 < sweep <= π/2, 0 < ray_step <= sweep, n_rays >= 1 and "
                f"path_samples >= 1, got {sweep}, {ray_step}, {n_rays}, {path_samples}"
            )
        if not self.feasible(z, 0.0, 0.0):  # rays and paths all start from the level pose
            names = [k for k, v in self.limits_violated(z, 0.0, 0.0).items() if v]
            raise UnreachableError(
                f"Upr4 level platform at z = {z} m is infeasible ({', '.join(names)}): "
                "no workspace at this height"
            )
        roll = np.linspace(-sweep, sweep, n_roll)
        pitch = np.linspace(-sweep, sweep, n_pitch)
        grid_roll, grid_pitch = np.meshgrid(roll, pitch, indexing="ij")
        violated = self.limits_violated(z, grid_roll, grid_pitch)
        feasible = ~np.any(np.stack(list(violated.values())), axis=0)

        t = np.arange(1, path_samples + 1)[:, None, None] / path_samples
        on_path = self.limits_violated(z, t * grid_roll, t * grid_pitch)
        first = np.stack(  # first path sample violating each limit; path_samples if none
            [np.where(v.any(0), v.argmax(0), path_samples) for v in on_path.values()]
        )
        binding = np.where(feasible, "", np.array(LIMIT_NAMES)[np.argmin(first, axis=0)])

        axes = np.array([[-1.0, 0.0], [1.0, 0.0], [0.0, -1.0], [0.0, 1.0]])
        ray_angles = np.arange(n_rays) * 2 * np.pi / n_rays
        rays = np.concatenate([axes, np.stack([np.cos(ray_angles), np.sin(ray_angles)], -1)])
        radii, ray_binding = self._boundary(z, rays, sweep, ray_step)
        return Workspace(
            z=z,
            roll=roll,
            pitch=pitch,
            feasible=feasible,
            violated=violated,
            binding=binding,
            roll_limits=_axis_limits(roll, feasible[:, n_pitch // 2]),
            pitch_limits=_axis_limits(pitch, feasible[n_roll // 2, :]),
            roll_limits_exact=np.array([-radii[0], radii[1]]),
            pitch_limits_exact=np.array([-radii[2], radii[3]]),
            roll_binding=(str(ray_binding[0]), str(ray_binding[1])),
            pitch_binding=(str(ray_binding[2]), str(ray_binding[3])),
            ray_angles=ray_angles,
            ray_radii=radii[4:],
            circle_radius=float(np.min(radii[4:])),
            circle_radius_max=float(np.max(radii[4:])),
        )

    def _boundary(
        self, z: float, rays: np.ndarray, sweep: float, step: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """Boundary radius (k,) [rad] and binding limit name (k,) along unit rays (k, 2) in
        (roll, pitch) from the level pose; radius `sweep` and "" if feasible all the way."""
        rho = np.append(np.arange(step, sweep, step), sweep)
        bad = ~self.feasible(z, rho[:, None] * rays[:, 0], rho[:, None] * rays[:, 1])  # (m, k)
        hit = bad.any(0)
        index = bad.argmax(0)
        lo = np.where(hit & (index > 0), rho[index - 1], 0.0)
        hi = np.where(hit, rho[index], sweep)
        for _ in range(60):  # bisection: each pass halves the bracket; 60 reach 1e-12 rad
            mid = (lo + hi) / 2
            out = ~self.feasible(z, mid * rays[:, 0], mid * rays[:, 1])
            lo, hi = np.where(out, lo, mid), np.where(out, mid, hi)
        violated = self.limits_violated(z, hi * rays[:, 0], hi * rays[:, 1])
        names = np.array(LIMIT_NAMES)[np.argmax(np.stack(list(violated.values())), axis=0)]
        return np.where(hit, lo, sweep), np.where(hit, names, "")

    def _state(
        self, z: ArrayLike, roll: ArrayLike, pitch: ArrayLike
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """z, roll, pitch as finite float arrays broadcast together, or TwinError."""
        z, roll, pitch = self._broadcast(("z", z), ("roll", roll), ("pitch", pitch))
        return z, roll, pitch

    @staticmethod
    def _broadcast(*named: tuple[str, ArrayLike]) -> tuple[np.ndarray, ...]:
        arrays = [as_array(value, name) for name, value in named]
        try:
            return tuple(np.broadcast_arrays(*arrays))
        except ValueError as exc:
            shapes = ", ".join(
                f"{name} {a.shape}" for (name, _), a in zip(named, arrays, strict=True)
            )
            raise TwinError(f"Upr4 state arguments must broadcast together, got {shapes}") from exc


def _axis_limits(values: np.ndarray, feasible: np.ndarray) -> np.ndarray:
    """(low, high) (2,) of the run of feasible grid `values` around the centre (value 0)."""
    centre = values.size // 2
    if not feasible[centre]:
        return np.array([np.nan, np.nan])
    blocked = ~feasible
    up = centre + (np.argmax(blocked[centre:]) if blocked[centre:].any() else values.size - centre)
    down = centre - (np.argmax(blocked[centre::-1]) if blocked[centre::-1].any() else centre + 1)
    return np.array([values[down + 1], values[up - 1]])
