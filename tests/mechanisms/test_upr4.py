"""Upr4: seed 002 eqs (1)-(3), (15)-(28), Table 1 and the limits of §2.1 (SPEC erratum 10)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from twin.errors import ConvergenceError, TwinError, UnreachableError
from twin.mechanisms.legs import legs
from twin.mechanisms.upr4 import FRAME, LIMIT_NAMES, Upr4, platform_transform
from twin.spatial import pose_to_transform, rpy_to_matrix

UPR = Upr4()
A, B, Z0 = 0.2, 1.25, 0.5  # [m] seed 002 §4
L_MIN, L_MAX = 0.7225, 1.1225  # [m] §2.1, SPEC erratum 10
DEG = np.pi / 180.0
# seed 002 eqs (1)-(2), written out again here [m]
BASE = np.array([[B, B, 0], [B, -B, 0], [-B, -B, 0], [-B, B, 0]]) / 2
TOP = np.array([[A, A, 0], [A, -A, 0], [-A, -A, 0], [-A, A, 0]]) / 2


def eq_15(roll: float, pitch: float) -> np.ndarray:
    """R = Ry·Rx exactly as printed in seed 002 eq (15)."""
    cx, sx, cy, sy = np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch)
    return np.array([[cy, sx * sy, sy * cx], [0, cx, -sx], [-sy, cy * sx, cy * cx]])


def reference_limbs(z: float, roll: float, pitch: float) -> np.ndarray:
    """S_i = a_i − b_i (4, 3) [m] for one state; eqs (16), (17), (19)."""
    return np.array([0.0, 0.0, z]) + TOP @ eq_15(roll, pitch).T - BASE


def reference_lengths(states: np.ndarray) -> np.ndarray:
    """Eq (18) for states (n, 3), one at a time."""
    return np.array([np.linalg.norm(reference_limbs(*s), axis=1) for s in states])


def random_feasible(rng: np.random.Generator, n: int) -> np.ndarray:
    """At least n states (k, 3) uniform in `state_limits`, keeping the feasible ones."""
    low, high = UPR.state_limits
    kept = np.empty((0, 3))
    while len(kept) < n:
        draw = rng.uniform(low, high, size=(6 * n, 3))
        kept = np.concatenate([kept, draw[UPR.feasible(*draw.T)]])
    return kept


def test_level_platform_at_z0_has_hand_computed_limbs() -> None:
    """Level at z0: every limb spans (b−a)/2 in x and y and z0 in z, √(2·0.525² + 0.5²) m."""
    expected = np.sqrt(2 * 0.525**2 + 0.5**2)  # 0.895126 m
    np.testing.assert_allclose(UPR.leg_lengths(Z0, 0.0, 0.0), [expected] * 4, rtol=0, atol=1e-15)
    assert expected == pytest.approx(0.8951257, abs=1e-7)


def test_leg_lengths_match_printed_equations(rng: np.random.Generator) -> None:
    """Eqs (15)-(18) with the printed rotation matrix, state by state."""
    states = rng.uniform([0.3, -0.5, -0.5], [0.8, 0.5, 0.5], size=(50, 3))
    np.testing.assert_allclose(
        UPR.leg_lengths(*states.T), reference_lengths(states), rtol=0, atol=1e-14
    )


def test_platform_pose_is_eq_16_and_closes_the_layout(rng: np.random.Generator) -> None:
    """Pose [0, 0, z, roll, pitch, 0]; our Rz·Ry·Rx equals eq (15); `legs` on `layout` gives
    the eq (18) lengths (the URDF generator's loop closure)."""
    states = rng.uniform([0.3, -0.5, -0.5], [0.8, 0.5, 0.5], size=(20, 3))
    pose = UPR.platform_pose(states)
    np.testing.assert_array_equal(pose[:, [0, 1, 5]], 0.0)
    np.testing.assert_array_equal(pose[:, 2:5], states)
    for p, s in zip(pose, states, strict=True):
        np.testing.assert_allclose(rpy_to_matrix(p[3:]), eq_15(s[1], s[2]), atol=1e-15)
    closed = legs(UPR.layout, pose_to_transform(pose)).lengths
    np.testing.assert_allclose(closed, reference_lengths(states), rtol=0, atol=1e-14)
    np.testing.assert_allclose(UPR.layout.base_hinges, BASE)
    np.testing.assert_allclose(UPR.layout.platform_hinges, TOP)


def test_platform_transform_is_eqs_15_16_over_a_batch(rng: np.random.Generator) -> None:
    """`platform_transform` (`upr4_frame_lane` lane by lane): eq (15)'s printed rotation, eq
    (16)'s origin (0, 0, z) and a homogeneous last row, for a (4, 5) batch broadcast from z
    (4, 1) against roll and pitch (4, 5), compiled and plain alike."""
    z = rng.uniform(0.3, 0.8, (4, 1))
    roll, pitch = rng.uniform(-0.5, 0.5, (2, 4, 5))
    T = platform_transform(z, roll, pitch)
    assert T.shape == (4, 5, 4, 4)
    np.testing.assert_array_equal(T, FRAME([z, roll, pitch], [], [(4, 4)], plain=True)[0])
    for index in np.ndindex(4, 5):
        want = np.eye(4)
        want[:3, :3] = eq_15(roll[index], pitch[index])
        want[2, 3] = z[index[0], 0]
        np.testing.assert_allclose(T[index], want, rtol=0, atol=1e-15)


@pytest.mark.parametrize("u_limit", [30 * DEG, 45 * DEG])  # SPEC erratum 10: both printed
def test_table_1_on_a_one_degree_grid(u_limit: float) -> None:
    """Table 1 at z = 0.5 m: roll and pitch each −π/9 to π/9 over the ±π/2 sweep, the
    collision of eq (3) binding; the exact boundary is asin(0.5/√2) = 20.70°."""
    upr = Upr4(u_joint_limit=u_limit)
    w = upr.workspace(0.5, n_roll=181, n_pitch=181, path_samples=1)
    np.testing.assert_allclose(w.roll_limits, [-np.pi / 9, np.pi / 9], rtol=0, atol=1e-12)
    np.testing.assert_allclose(w.pitch_limits, [-np.pi / 9, np.pi / 9], rtol=0, atol=1e-12)
    edge = np.arcsin(0.5 / np.sqrt(2.0))  # z = √2 sin α, √2 the pad's half-diagonal [m]
    np.testing.assert_allclose(w.roll_limits_exact, [-edge, edge], rtol=0, atol=1e-10)
    np.testing.assert_allclose(w.pitch_limits_exact, [-edge, edge], rtol=0, atol=1e-10)
    assert w.roll_binding == w.pitch_binding == ("collision", "collision")
    assert not w.violated["u_joint"].any() and not w.violated["stroke_min"].any()


def test_eq_28_circle_and_only_collision_binds_at_z0() -> None:
    """Eq (28): the feasible set is the circle √(roll² + pitch²) ≤ π/9 (to the paper's whole
    degrees), and at z = 0.5 m the collision is the only binding constraint (§4)."""
    w = UPR.workspace(0.5)
    assert np.pi / 9 <= w.circle_radius < np.pi / 9 + 1 * DEG
    assert w.circle_radius_max - w.circle_radius < 0.2 * DEG
    assert set(np.unique(w.binding[~w.feasible])) == {"collision"}
    radius = np.hypot(*np.meshgrid(w.roll, w.pitch, indexing="ij"))
    assert np.all(w.feasible[radius <= np.pi / 9])
    assert not np.any(w.feasible[radius > w.circle_radius_max])


def test_ten_degree_sweep_reproduces_the_pitch_example() -> None:
    """§4: "with a pitch of π/9 the roll limit is at 0" holds on a π/18 grid. On finer grids
    roll reaches arccos(cos 20.70° / cos 20°) = 5.47° there (docs/mechanisms/upr4.md)."""
    w = UPR.workspace(0.5, n_roll=19, n_pitch=19, path_samples=4)
    np.testing.assert_allclose(w.roll_limits, [-np.pi / 9, np.pi / 9], atol=1e-12)
    at_pitch = np.isclose(w.pitch, np.pi / 9)
    np.testing.assert_allclose(w.roll[w.feasible[:, at_pitch][:, 0]], [0.0], atol=1e-12)
    fine = UPR.workspace(0.5, n_roll=181, n_pitch=181, path_samples=1)
    roll = fine.roll[fine.feasible[:, np.isclose(fine.pitch, np.pi / 9)][:, 0]]
    expected = np.arccos(np.cos(np.arcsin(0.5 / np.sqrt(2))) / np.cos(np.pi / 9))
    assert np.max(roll) == pytest.approx(np.floor(expected / DEG) * DEG, abs=1e-12)


def test_printed_eq_3_factor_2_would_not_give_table_1() -> None:
    """Eq (3) read as z > 2 sin α (pad radius 2 m) caps the tilt at asin(0.25) = 14.48°, so
    the printed factor cannot be Table 1's; √2 (the 2 × 2 m² pad's half-diagonal) is."""
    w = Upr4(pad_side=2 * np.sqrt(2)).workspace(0.5, n_roll=181, n_pitch=181, path_samples=1)
    np.testing.assert_allclose(w.roll_limits, [-14 * DEG, 14 * DEG], atol=1e-12)


@pytest.mark.parametrize("z", [0.3, 0.4, 0.6, 0.7])
def test_limits_grow_with_height_while_collision_binds(z: float) -> None:
    """Fig. 8a: a higher platform tilts further, the limit following eq (3), asin(z/√2)."""
    w = UPR.workspace(z, n_roll=3, n_pitch=3)
    assert w.roll_binding == w.pitch_binding == ("collision", "collision")
    np.testing.assert_allclose(w.pitch_limits_exact[1], np.arcsin(z / np.sqrt(2)), atol=1e-10)


def test_stroke_binds_near_full_extension() -> None:
    """Fig. 8a's other side: at z = 0.8 m the longest limb reaches 1.1225 m first, and the
    limit falls below the one at z = 0.7 m."""
    w = UPR.workspace(0.8, n_roll=3, n_pitch=3)
    assert w.roll_binding == ("stroke_max", "stroke_max")
    edge = w.roll_limits_exact[1]
    assert edge < np.arcsin(0.7 / np.sqrt(2))
    longest = reference_lengths(np.array([[0.8, edge, 0.0]])).max()
    assert longest == pytest.approx(L_MAX, abs=1e-9)


def test_forward_inverts_inverse_kinematics(rng: np.random.Generator) -> None:
    """FK(IK(x)) = x to 1e-9 on ≥ 1000 feasible states, from the default home guess."""
    states = random_feasible(rng, 1000)
    assert len(states) >= 1000
    solved = UPR.forward(reference_lengths(states))
    np.testing.assert_allclose(solved, states, rtol=0, atol=1e-9)


def test_forward_from_nearby_guess_takes_few_steps(rng: np.random.Generator) -> None:
    """From a guess 1 cm / 0.01 rad off, three Newton steps settle to 1e-10."""
    states = random_feasible(rng, 200)
    guess = states + rng.uniform(-0.01, 0.01, states.shape)
    solved = UPR.forward(reference_lengths(states), guess, max_iter=3)
    np.testing.assert_allclose(solved, states, rtol=0, atol=1e-10)


def test_jacobian_equals_central_differences(rng: np.random.Generator) -> None:
    """∂l/∂(z, roll, pitch) equals central differences of eq (18)."""
    states = random_feasible(rng, 30)
    h = 1e-6  # [m | rad]
    expected = np.stack(
        [
            (reference_lengths(states + h * e) - reference_lengths(states - h * e)) / (2 * h)
            for e in np.eye(3)
        ],
        -1,
    )
    np.testing.assert_allclose(UPR.jacobian(*states.T), expected, rtol=0, atol=1e-9)


def test_limb_velocities_equal_differences_along_a_trajectory() -> None:
    """Eqs (21)-(22) (rotated offset, SPEC erratum 10) equal d/dt of eq (18) on a path that
    heaves, rolls and pitches at once."""
    t = np.linspace(0.0, 10.0, 201)
    w = np.array([1.3, 0.9, 1.7])  # [rad/s]
    amp, mean = np.array([0.1, 0.3, 0.3]), np.array([0.5, 0.0, 0.0])

    def path(t: np.ndarray) -> np.ndarray:
        return mean + amp * np.sin(w * t[:, None])

    h = 1e-6  # [s]
    expected = (reference_lengths(path(t + h)) - reference_lengths(path(t - h))) / (2 * h)
    rates = amp * w * np.cos(w * t[:, None])
    got = UPR.limb_velocities(*path(t).T, *rates.T)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-8)
    assert np.max(np.abs(expected)) > 0.05  # the check is not trivially zero


def test_limb_speed_of_a_level_roll_matches_the_hand_value() -> None:
    """Level at z0, pure roll rate ω: limbs slide at ±(a/2)·z0/l_0·ω (eq (22)); the 0.1 m/s
    cylinders then allow 1.79 rad/s (§5 quotes "up to 1.7 rad/s")."""
    per_rad = (A / 2) * Z0 / np.sqrt(2 * 0.525**2 + Z0**2)  # [m/rad] 0.05586
    got = UPR.limb_velocities(Z0, 0.0, 0.0, 0.0, 1.0, 0.0)
    np.testing.assert_allclose(got, [per_rad, -per_rad, -per_rad, per_rad], atol=1e-15)
    assert 0.1 / per_rad == pytest.approx(1.79, abs=0.005)


def joint_frame(i: int) -> np.ndarray:
    """U-joint frame of limb i: z along the home limb (level at z0), x = z × e_z horizontal."""
    z = reference_limbs(Z0, 0.0, 0.0)[i]
    z /= np.linalg.norm(z)
    x = np.cross(z, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    return np.stack([x, np.cross(z, x), z], -1)


def test_u_joint_angles_rebuild_the_limb_direction(rng: np.random.Generator) -> None:
    """Limb frame = joint frame · Ry(pitch) · Rx(roll), z along the limb (§2.1, eqs (4)-(5):
    first axis y, second x): its z axis is s_i of eq (20)."""
    states = random_feasible(rng, 40)
    angles = UPR.joint_angles(*states.T)
    for k, state in enumerate(states):
        limbs = reference_limbs(*state)
        for i in range(4):
            turn = Rotation.from_euler("YX", [angles.u_pitch[k, i], angles.u_roll[k, i]])
            rebuilt = joint_frame(i) @ turn.as_matrix() @ [0.0, 0.0, 1.0]
            np.testing.assert_allclose(rebuilt, limbs[i] / np.linalg.norm(limbs[i]), atol=1e-12)


def test_u_joints_are_at_zero_at_home_with_diagonal_axes() -> None:
    """At the home pose every U-joint angle is 0; the joint y axis is 45° to global Y in plan
    (text below eq (26)) and x is horizontal (eq (12))."""
    angles = UPR.joint_angles(Z0, 0.0, 0.0)
    np.testing.assert_allclose(angles.u_roll, 0.0, atol=1e-15)
    np.testing.assert_allclose(angles.u_pitch, 0.0, atol=1e-15)
    for i in range(4):
        x, y, _ = joint_frame(i).T
        assert x[2] == pytest.approx(0.0, abs=1e-15)
        plan = y[:2] / np.linalg.norm(y[:2])
        assert abs(plan[1]) == pytest.approx(np.cos(np.pi / 4), abs=1e-12)


def test_r_joint_angle_is_eq_27(rng: np.random.Generator) -> None:
    """γ_i = arccos((P − a_i)/|P − a_i| · s_i); at home arccos(((b−a)/√2) / l_0)."""
    home = UPR.joint_angles(Z0, 0.0, 0.0).r
    expected = np.arccos((B - A) / np.sqrt(2) / np.sqrt(2 * 0.525**2 + 0.25))  # 33.99°
    np.testing.assert_allclose(home, [expected] * 4, atol=1e-12)
    states = random_feasible(rng, 20)
    got = UPR.joint_angles(*states.T).r
    for k, (z, roll, pitch) in enumerate(states):
        a = np.array([0.0, 0.0, z]) + TOP @ eq_15(roll, pitch).T
        inward = (np.array([0.0, 0.0, z]) - a) / np.linalg.norm(a - [0.0, 0.0, z], axis=1)[:, None]
        s = (a - BASE) / np.linalg.norm(a - BASE, axis=1)[:, None]
        np.testing.assert_allclose(got[k], np.arccos(np.sum(inward * s, axis=1)), atol=1e-12)


def test_limit_flags_match_independent_checks(rng: np.random.Generator) -> None:
    """Stroke against eq (18), collision against eq (3) (α from R's z column), U joints
    against their angles; every flag is seen both set and clear."""
    # Tighter than the paper, so that every limit binds somewhere (see the next test).
    upr = Upr4(u_joint_limit=3 * DEG, stroke_min=0.8)
    states = rng.uniform([0.0, -0.7, -0.7], [0.9, 0.7, 0.7], size=(2000, 3))
    flags = upr.limits_violated(*states.T)
    lengths = reference_lengths(states)
    np.testing.assert_array_equal(flags["stroke_min"], lengths.min(1) < 0.8)
    np.testing.assert_array_equal(flags["stroke_max"], lengths.max(1) > L_MAX)
    alpha = np.array([np.arccos(eq_15(r, p)[2, 2]) for _, r, p in states])
    np.testing.assert_array_equal(flags["collision"], states[:, 0] <= np.sqrt(2) * np.sin(alpha))
    angles = upr.joint_angles(*states.T)
    worst = np.maximum(np.abs(angles.u_roll), np.abs(angles.u_pitch)).max(1)
    np.testing.assert_array_equal(flags["u_joint"], worst > 3 * DEG)
    for name in LIMIT_NAMES:
        assert flags[name].any() and not flags[name].all(), name
    feasible = upr.feasible(*states.T)
    np.testing.assert_array_equal(feasible, ~np.any([flags[n] for n in LIMIT_NAMES], axis=0))


def test_retracted_stroke_is_never_reached(rng: np.random.Generator) -> None:
    """In plan a limb spans at least |b_i| − |a_i| = (b − a)/√2 = 0.7425 m > 0.7225 m, so the
    paper's geometry never uses the last 2 cm of retraction."""
    states = rng.uniform([-0.5, -1.5, -1.5], [1.5, 1.5, 1.5], size=(5000, 3))
    assert reference_lengths(states).min() >= (B - A) / np.sqrt(2) - 1e-12
    assert not UPR.limits_violated(*states.T)["stroke_min"].any()


def test_state_limits_bound_the_workspace(rng: np.random.Generator) -> None:
    """No feasible state lies outside `state_limits`: z ≤ √(1.1225² − 0.7425²) (level, full
    stroke), tilts ≤ asin(z_max/√2)."""
    low, high = UPR.state_limits
    z_max = np.sqrt(L_MAX**2 - 2 * 0.525**2)
    np.testing.assert_allclose(high, [z_max, *[np.arcsin(z_max / np.sqrt(2))] * 2], atol=1e-12)
    np.testing.assert_allclose(low, [0.0, -high[1], -high[2]], atol=1e-15)
    wide = rng.uniform([-0.1, -1.0, -1.0], [1.2, 1.0, 1.0], size=(20000, 3))
    inside = UPR.feasible(*wide.T)
    assert inside.any()
    assert np.all((wide[inside] >= low) & (wide[inside] <= high))


def test_check_names_the_violated_limit() -> None:
    """check / leg_lengths(check=True) raise UnreachableError naming the limit; a feasible
    state passes."""
    UPR.check(0.5, 0.1, -0.1)
    with pytest.raises(UnreachableError, match="collision"):
        UPR.check([0.5, 0.5], [0.0, 0.4], 0.0)
    with pytest.raises(UnreachableError, match="stroke_max"):
        UPR.leg_lengths(0.9, 0.0, 0.0, check=True)


def test_batch_shapes_broadcast() -> None:
    """Arguments broadcast; outputs keep the batch axes."""
    assert UPR.leg_lengths(0.5, np.zeros((2, 3)), 0.0).shape == (2, 3, 4)
    assert UPR.jacobian(np.full(5, 0.5), 0.0, 0.1).shape == (5, 4, 3)
    assert UPR.limb_velocities(0.5, 0.0, 0.0, np.ones(7), 0.0, 0.0).shape == (7, 4)
    assert UPR.joint_angles(0.5, np.zeros(6), 0.0).r.shape == (6, 4)
    lengths = UPR.leg_lengths(0.5, 0.05 * np.ones((2, 2)), 0.0)
    assert UPR.forward(lengths).shape == (2, 2, 3)
    assert UPR.platform_pose(np.full((3, 3), 0.1)).shape == (3, 6)


@pytest.mark.parametrize(
    ("call", "error", "message"),
    [
        (lambda: UPR.leg_lengths(np.nan, 0.0, 0.0), TwinError, "finite"),
        (lambda: UPR.leg_lengths(np.zeros(3), 0.0, np.zeros(2)), TwinError, "broadcast"),
        (lambda: UPR.forward([0.9, 0.9, 0.9]), TwinError, r"shape \(\.\.\., 4\)"),
        (lambda: UPR.forward([0.9, 0.9, 0.9, 1.3]), TwinError, "out of range"),
        (lambda: UPR.forward([0.9, 0.9, 0.9, 0.91]), UnreachableError, "inconsistent"),
        (lambda: UPR.forward([0.9] * 4, guess=[0.5, 0.0]), TwinError, "guess"),
        (lambda: UPR.platform_pose([0.5, 0.0]), TwinError, "state"),
        (lambda: UPR.workspace(1.0), UnreachableError, "infeasible"),
        (lambda: UPR.workspace(0.5, n_roll=10), TwinError, "odd"),
        (lambda: Upr4(a=-0.2), TwinError, "positive"),
        (lambda: Upr4(u_joint_limit=2.0), TwinError, "u_joint_limit"),
        (lambda: Upr4(z0=2.0), TwinError, "stroke"),
    ],
)
def test_bad_input_raises_a_named_error(call, error: type, message: str) -> None:
    """Bad shapes, NaN, lengths outside the stroke or of no state raise TwinError subclasses
    whose message says what is wrong."""
    with pytest.raises(error, match=message):
        call()


def test_non_convergence_raises_instead_of_hanging() -> None:
    """Two Newton steps from a far guess are not enough: ConvergenceError, not a loop."""
    lengths = UPR.leg_lengths(0.6, 0.2, -0.1)
    with pytest.raises(ConvergenceError, match="did not converge"):
        UPR.forward(lengths, guess=[0.3, -0.3, 0.3], max_iter=2)
