r"""The 3UPU_UP coupled 3-DOF platform of seed 001 (Hu, Li, Tang, IEEE Access 2020).

Three actuated UPU limbs, 120° apart, and a passive central UP limb whose U joint sits at the
base centre and whose prismatic joint is fixed normal to the platform (seed 001 §II.B). The
UP limb makes the platform a rigid body turning about the base centre O: its state is
`(z, alpha, beta)` and the other three coordinates follow from the coupling constraint
(eqs (11)-(13)).

Frames (docs/mechanisms/upu3up.md): base O-xyz at the centre of the base hinge triangle
(also the centre of the UP limb's U joint), z up; platform O1-x1y1z1 at the centre of the
platform hinge triangle, z1 along the platform normal, x1 towards limb 1. Both hinge
triangles lie in their frame's xy plane (eq (26)).

Units: mm and rad, like the paper, except `layout` and `platform_pose`, which feed the URDF
generator in m and rad.
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
from twin.mechanisms.platforms import (
    FORWARD_MAX_ITER,
    FORWARD_TOL,
    MECHANISM_UPU3UP,
    PLATFORM_GEOMETRY,
    STATE_SLACK,
    coupled_frame_lane,
)
from twin.spatial import transform_to_pose
from twin.validation import as_array, check_range


def coupled_transform(z: np.ndarray, alpha: np.ndarray, beta: np.ndarray, l: float) -> np.ndarray:
    """ᴼT_O1 (..., 4, 4) [mm]: ᴼR_O1 = Rx(α)·Ry(β) of eq (11), origin of eq (13), by
    `platforms.coupled_frame_lane` lane by lane.

    The platform centre lies on the UP limb, l + z from O along the platform normal:
    ᴼO1 = (l + z) ᴼR_O1 e_z, which is eq (13) written as a vector.

    Args:
        z: (...) [mm] UP-limb extension beyond the initial length l.
        alpha: (...) [rad] roll, about the base x axis (the UP U joint's first axis).
        beta: (...) [rad] pitch, about the once-rotated y axis (its second axis).
        l: [mm] limb length at the initial pose.
    """
    return COUPLED_FRAME([z, alpha, beta], [float(l)], [(4, 4)])[0]


def _coupled_batch(
    z: np.ndarray, alpha: np.ndarray, beta: np.ndarray, l: float, T: np.ndarray
) -> None:
    """`coupled_frame_lane` over states z, alpha, beta (N,) into T (N, 4, 4)."""
    for k in range(z.shape[0]):
        coupled_frame_lane(z[k], alpha[k], beta[k], l, T[k, :3, :3], T[k, :3, 3])
        T[k, 3, 0], T[k, 3, 1], T[k, 3, 2], T[k, 3, 3] = 0.0, 0.0, 0.0, 1.0


#: the lane over a batch of states: what `coupled_transform` calls
COUPLED_FRAME = LaneBatch(_coupled_batch, cores=(0, 0, 0))


@dataclass(frozen=True)
class Upu3Up:
    """Seed 001's 3UPU_UP platform: geometry of eq (26) and the limits we chose.

    The state is `(z, alpha, beta)` [mm, rad, rad]: z is the extension of the central UP
    limb beyond its initial length l, so |O O1| = l + z (eqs (8), (13)) — not the height of
    O1, which is Z_p = (l + z) cos α cos β. ᴼR_O1 = Rx(α)·Ry(β) (eq (11)), an X-Y order; the
    twin's Z-Y-X roll/pitch/yaw of the same rotation come from `platform_pose`.

    The paper gives no stroke or workspace. Defaults cover its own simulations: the sine
    tests (eq (27): 30 mm, 5°) and the Pierson–Moskowitz runs P5-P8 (Table 4: z = 0.05 A(t)
    reaches ±150 mm and the wave slope a(t) ±17.5° at U = 12 m/s), hence |z| ≤ 150 mm,
    |α|, |β| ≤ 20°, and the leg range that box needs, 1040 ± 420 mm
    (docs/mechanisms/upu3up.md).

    Attributes:
        l: [mm] UPU limb length at the initial pose, also |O O1| there (eq (26)).
        d: [mm] distance between neighbouring hinges of a triangle (eq (26)).
        leg_min: [mm] shortest UPU hinge-to-hinge length.
        leg_max: [mm] longest UPU hinge-to-hinge length.
        heave_limit: [mm] |z| bound of the workspace.
        tilt_limit: [rad] |α| and |β| bound of the workspace.
    """

    l: float = 1040.0
    d: float = 990.0
    leg_min: float = 620.0
    leg_max: float = 1460.0
    heave_limit: float = 150.0
    tilt_limit: float = float(np.radians(20.0))
    state_names: ClassVar[tuple[str, str, str]] = ("z", "alpha", "beta")
    _layout_mm: LegLayout = field(init=False, repr=False, compare=False)
    _geometry: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        for name in ("l", "d", "leg_min", "leg_max", "heave_limit", "tilt_limit"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise TwinError(f"Upu3Up.{name} must be a positive finite number, got {value!r}")
        if not self.leg_min < self.l < self.leg_max:
            raise TwinError(
                f"Upu3Up needs leg_min < l < leg_max [mm], got {self.leg_min} < {self.l} < "
                f"{self.leg_max}"
            )
        if self.heave_limit >= self.l:
            raise TwinError(f"Upu3Up.heave_limit must be below l = {self.l} mm (l + z > 0)")
        if self.tilt_limit >= np.pi / 2:
            raise TwinError(f"Upu3Up.tilt_limit must be below π/2 rad, got {self.tilt_limit}")
        r3, d = np.sqrt(3.0), self.d
        hinges = np.array(  # seed 001 eq (26): ᴼB_i = ᴼ¹P_i
            [[r3 / 3 * d, 0.0, 0.0], [-r3 / 6 * d, d / 2, 0.0], [-r3 / 6 * d, -d / 2, 0.0]]
        )
        centre = np.zeros((1, 3))  # the UP limb: U joint at O, prismatic ending at O1
        layout = LegLayout(
            base_hinges=np.concatenate([hinges, centre]),
            platform_hinges=np.concatenate([hinges, centre]),
            # The passive UP limb gets the actuators' range, wider than its l ± heave_limit.
            length_min=np.full(4, self.leg_min),
            length_max=np.full(4, self.leg_max),
            actuated=(True, True, True, False),
        )
        object.__setattr__(self, "_layout_mm", layout)
        geometry = self.pack()
        geometry.setflags(write=False)
        object.__setattr__(self, "_geometry", geometry)

    def pack(self) -> np.ndarray:
        """The mechanism as its lanes read it (`twin.mechanisms.platforms`): a (1,) array of one
        `PLATFORM_GEOMETRY` record [mm, rad]; its envelope is `state_limits`, where `forward`
        accepts a solution."""
        out = np.zeros(1, PLATFORM_GEOMETRY)
        g = out[0]
        g["mechanism"], g["n_legs"], g["unit"], g["l"] = MECHANISM_UPU3UP, 3, 1e-3, self.l
        g["stroke_low"], g["stroke_high"] = self.leg_min, self.leg_max
        g["state_low"], g["state_high"] = self.state_limits
        g["envelope_low"], g["envelope_high"] = self.state_limits
        g["base_hinges"][:9] = self._layout_mm.base_hinges[:3].ravel()  # seed 001 eq (26)
        g["platform_hinges"][:9] = self._layout_mm.platform_hinges[:3].ravel()
        return out

    @property
    def working_state(self) -> np.ndarray:
        """(3,) the initial pose (z, alpha, beta) = (0 mm, 0, 0): level, UP limb at length l."""
        return np.zeros(3)

    @property
    def state_limits(self) -> tuple[np.ndarray, np.ndarray]:
        """(low, high), each (3,) [mm, rad, rad], bounds of `(z, alpha, beta)`."""
        high = np.array([self.heave_limit, self.tilt_limit, self.tilt_limit])
        return -high, high

    @property
    def layout_mm(self) -> LegLayout:
        """Hinges and length limits [mm] (eq (26)): legs 0-2 the UPU limbs, leg 3 the UP limb."""
        return self._layout_mm

    @property
    def layout(self) -> LegLayout:
        """Hinges and length limits in metres, for the URDF generator.

        Legs 0-2 are the UPU limbs (actuated), leg 3 the passive UP limb from O to O1.
        """
        mm = self._layout_mm
        return LegLayout(
            base_hinges=mm.base_hinges * 1e-3,
            platform_hinges=mm.platform_hinges * 1e-3,
            length_min=mm.length_min * 1e-3,
            length_max=mm.length_max * 1e-3,
            actuated=mm.actuated,
        )

    def ideal_pose(self, z: ArrayLike, alpha: ArrayLike, beta: ArrayLike) -> np.ndarray:
        """P_2 = (X_p, Y_p, Z_p, α_p, β_p) (..., 5) [mm, mm, mm, rad, rad] of O1 in O-xyz.

        Seed 001 eqs (13)-(14); the coupling moves O1 but leaves the angles as commanded.
        The twin's full 6-component pose (yaw included) is `platform_pose`.
        """
        z, alpha, beta = self._state(z, alpha, beta)
        centre = coupled_transform(z, alpha, beta, self.l)[..., :3, 3]
        return np.concatenate([centre, alpha[..., None], beta[..., None]], -1)

    def coupled_displacement(self, z: ArrayLike, alpha: ArrayLike, beta: ArrayLike) -> np.ndarray:
        """D_c = (X_p, Y_p, Z_p − (l + z)) (..., 3) [mm], output minus input; eq (15)."""
        z, alpha, beta = self._state(z, alpha, beta)
        displacement = coupled_transform(z, alpha, beta, self.l)[..., :3, 3]
        displacement[..., 2] -= self.l + z  # seed 001 eq (15): the input moves O1 along z only
        return displacement

    def legs(self, z: ArrayLike, alpha: ArrayLike, beta: ArrayLike) -> LegState:
        """All four limbs [mm] in O-xyz: the UPU limbs 0-2 (eqs (16)-(18)), the UP limb 3."""
        z, alpha, beta = self._state(z, alpha, beta)
        return legs(self._layout_mm, coupled_transform(z, alpha, beta, self.l))

    def leg_lengths(
        self, z: ArrayLike, alpha: ArrayLike, beta: ArrayLike, *, check: bool = False
    ) -> np.ndarray:
        """UPU limb lengths l_1..l_3 (..., 3) [mm]; seed 001 eqs (16)-(18).

        Δl_i of eq (19) is this minus `l`. With `check`, a state outside `state_limits` or
        needing a length outside [leg_min, leg_max] raises UnreachableError; without, the
        lengths are returned as they are (a planner counts the violations).
        """
        z, alpha, beta = self._state(z, alpha, beta)
        lengths = platforms.leg_lengths(self._geometry, np.stack([z, alpha, beta], -1))
        if check:
            self._check_state(np.stack([z, alpha, beta], -1), "state", slack=0.0)
            bad = (lengths < self.leg_min) | (lengths > self.leg_max)
            if np.any(bad):
                raise UnreachableError(
                    f"state needs UPU limb lengths {np.round(lengths[bad], 4).tolist()!r:.120} "
                    f"mm, allowed [{self.leg_min}, {self.leg_max}] mm"
                )
        return lengths

    def jacobian(self, z: ArrayLike, alpha: ArrayLike, beta: ArrayLike) -> np.ndarray:
        """∂(l_1, l_2, l_3)/∂(z, α, β) (..., 3, 3) [mm/mm, mm/rad]; the matrix of eq (24).

        The leg twist Jacobian (rows [n_iᵀ, (ᴼR_O1 ᴼ¹P_i × n_i)ᵀ]) composed with the
        coupled twist map (ω = α̇ e_x + β̇ Rx(α) e_y, the top turning about O;
        `platforms.platform_kinematics`). Eq (24)
        is written for the squared residual of eq (20); its rows are these times 2 l_i.
        """
        z, alpha, beta = self._state(z, alpha, beta)
        return platforms.jacobian(self._geometry, np.stack([z, alpha, beta], -1))

    def forward(
        self,
        lengths: ArrayLike,
        guess: ArrayLike | None = None,
        *,
        tol: float = FORWARD_TOL,
        max_iter: int = FORWARD_MAX_ITER,
    ) -> np.ndarray:
        """State `(z, alpha, beta)` (..., 3) [mm, rad, rad] from UPU limb lengths by Newton-Raphson.

        Seed 001 eqs (20)-(24), iterated on the length residual l_i(x) − L_i rather than
        eq (20)'s squared one: same root, residual in mm. Pass the result to `ideal_pose`
        for eq (25)'s (X_p, Y_p, Z_p, α_p, β_p).

        Args:
            lengths: (..., 3) [mm] UPU limb lengths, each within [leg_min, leg_max].
            guess: (..., 3) starting state, broadcast against `lengths`; default the initial
                pose (0, 0, 0), whose first Newton step is the linearised solution.
            tol: [mm] stop when every limb's residual is at most this.
            max_iter: Newton steps before giving up.

        Raises:
            TwinError: bad shape, NaN or inf, or a length outside [leg_min, leg_max].
            ConvergenceError: the residual did not fall below `tol` in `max_iter` steps.
            UnreachableError: the lengths are met only outside `state_limits`.
        """
        lengths = as_array(lengths, "lengths", (3,))
        check_range(lengths, "lengths [mm]", self.leg_min, self.leg_max)
        check_tolerances(tol, max_iter)
        x0 = start(guess, np.zeros(3), lengths.shape)
        # seed 001 eqs (20)-(24): `platforms.platform_newton`, the engine's lane
        result = platforms.forward(self._geometry, lengths, x0, tol, max_iter, np.inf)
        if result.converged:
            self._check_state(result.x, "forward solution", slack=STATE_SLACK)
            return result.x
        raise ConvergenceError(
            f"Upu3Up.forward did not converge: stopped after {result.iterations} Newton-Raphson "
            f"steps (max_iter={max_iter}) with worst limb residual {result.worst:.3g} mm > tol "
            f"{tol:g} mm; the lengths may be unreachable, or give a closer `guess`"
        )

    def platform_pose(self, state: ArrayLike) -> np.ndarray:
        """Platform pose `[x, y, z, roll, pitch, yaw]` (..., 6) [m, rad] of O1 in O-xyz.

        R = Rz(yaw)·Ry(pitch)·Rx(roll) (the twin's convention) equals the paper's
        Rx(α)·Ry(β) (eq (11)), so roll = atan2(sin α, cos α cos β), pitch = asin(cos α sin β)
        and yaw = atan2(sin α sin β, cos β) ≠ 0 when both tilts are nonzero.

        Args:
            state: (..., 3) `(z, alpha, beta)` [mm, rad, rad].
        """
        state = as_array(state, "state", (3,))
        z, alpha, beta = state[..., 0], state[..., 1], state[..., 2]
        pose = transform_to_pose(coupled_transform(z, alpha, beta, self.l))
        pose[..., :3] *= 1e-3  # mm → m
        return pose

    def _state(
        self, z: ArrayLike, alpha: ArrayLike, beta: ArrayLike
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """z, alpha, beta as finite float arrays broadcast together, or TwinError."""
        arrays = [as_array(v, n) for v, n in ((z, "z"), (alpha, "alpha"), (beta, "beta"))]
        try:
            z, alpha, beta = np.broadcast_arrays(*arrays)
        except ValueError as exc:
            shapes = ", ".join(str(a.shape) for a in arrays)
            raise TwinError(f"z, alpha, beta must broadcast together, got shapes {shapes}") from exc
        return z, alpha, beta

    def _check_state(self, state: np.ndarray, name: str, slack: float) -> None:
        """UnreachableError unless `state` (..., 3) lies within `state_limits` (± slack)."""
        low, high = self.state_limits
        bad = np.any((state < low - slack) | (state > high + slack), axis=-1)
        if np.any(bad):
            shown = np.round(state[bad], 6).tolist()
            raise UnreachableError(
                f"{name} (z [mm], alpha [rad], beta [rad]) = {shown!r:.160} lies outside "
                f"state_limits |z| <= {self.heave_limit} mm, |alpha|, |beta| <= "
                f"{self.tilt_limit:.6g} rad"
            )
