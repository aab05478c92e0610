"""Upu3Up: seed 001 eqs (11)-(27), Tables 1-3 and the SPEC check value."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from twin.errors import ConvergenceError, TwinError, UnreachableError
from twin.mechanisms.legs import legs, universal_angles
from twin.mechanisms.upu3up import Upu3Up
from twin.spatial import pose_to_transform, rpy_to_matrix

UPU = Upu3Up()
L0, D = 1040.0, 990.0  # [mm] seed 001 eq (26)
DEG = np.pi / 180.0
# seed 001 eq (26), written out again here: ᴼB_i = ᴼ¹P_i [mm]
HINGES = np.array(
    [[np.sqrt(3) / 3 * D, 0, 0], [-np.sqrt(3) / 6 * D, D / 2, 0], [-np.sqrt(3) / 6 * D, -D / 2, 0]]
)
# seed 001 Table 1 with eq (27), R1 = R2 = 5°, D = 30 mm: (alpha, beta, z) as functions of t
TABLE_1 = {
    "P1": lambda s: (5 * DEG * s, 5 * DEG * s, 0 * s),
    "P2": lambda s: (0 * s, 5 * DEG * s, 30 * s),
    "P3": lambda s: (5 * DEG * s, 0 * s, 30 * s),
    "P4": lambda s: (5 * DEG * s, 5 * DEG * s, 30 * s),
}
# seed 001 Table 3 (ideal, eq (13)): (α, β, z) [deg, deg, mm] → (X_p, Y_p, Z_p, α_p, β_p)
TABLE_3 = [
    ((5, 5, 0), (90.6420, -90.2971, 1032.0962, 5.0, 5.0)),
    ((5, 0, 30), (0.0, -93.2566, 1065.9342, 5.0, 0.0)),
    ((0, 5, 30), (93.2566, 0.0, 1065.9342, 0.0, 5.0)),
    ((5, 5, 30), (93.2566, -92.9018, 1061.8684, 5.0, 5.0)),
]
# seed 001 Table 2 (the paper's Newton-Raphson results), same layout
TABLE_2 = [
    ((5, 5, 0), (90.6413, -90.3200, 1032.2488, 5.0000, 5.0000)),
    ((5, 0, 30), (0.0041, -93.2276, 1065.7433, 4.9993, 0.0006)),
    ((0, 5, 30), (93.2416, -0.0003, 1065.8653, -0.0002, 4.9995)),
    ((5, 5, 30), (93.2161, -92.8308, 1061.6206, 4.9974, 5.0180)),  # SPEC erratum 9: Y < 0
]


def random_states(rng: np.random.Generator, n: int) -> np.ndarray:
    """n states (n, 3) = (z [mm], alpha, beta [rad]) uniform inside `state_limits`."""
    low, high = UPU.state_limits
    return rng.uniform(low, high, size=(n, 3))


def reference_leg_lengths(z: float, alpha: float, beta: float) -> np.ndarray:
    """Eqs (16)-(18) for one state, with scipy's intrinsic X-Y Euler rotation (eq (11))."""
    R = Rotation.from_euler("XY", [alpha, beta]).as_matrix()
    centre = (L0 + z) * R[:, 2]  # eq (13)
    return np.linalg.norm(centre + HINGES @ R.T - HINGES, axis=1)  # ᴼB_i = ᴼ¹P_i


def test_ideal_pose_matches_spec_check_value() -> None:
    """(α, β, z) = (5°, 5°, 0) gives (90.6420, −90.2971, 1032.1000) mm (SPEC, eq (13))."""
    pose = UPU.ideal_pose(0.0, 5 * DEG, 5 * DEG)
    np.testing.assert_allclose(pose[:3], [90.6420, -90.2971, 1032.1000], atol=5e-5)
    np.testing.assert_allclose(pose[3:], [5 * DEG, 5 * DEG], atol=1e-15)


@pytest.mark.parametrize(("inputs", "expected"), TABLE_3)
def test_ideal_pose_matches_table_3(inputs: tuple, expected: tuple) -> None:
    """Table 3 from eq (13): X, Y and angles to print precision; Z to 0.01 mm, because every
    printed Z is 4-6 µm off eq (13) (SPEC calls the first one a rounding slip)."""
    alpha, beta, z = inputs
    pose = UPU.ideal_pose(z, alpha * DEG, beta * DEG)
    np.testing.assert_allclose(pose[:2], expected[:2], atol=5e-5)
    assert pose[2] == pytest.approx(expected[2], abs=1e-2)
    np.testing.assert_allclose(pose[3:] / DEG, expected[3:], atol=5e-5)


@pytest.mark.parametrize(("inputs", "expected"), TABLE_2)
def test_forward_matches_table_2(inputs: tuple, expected: tuple) -> None:
    """Eq (25) after Newton-Raphson on the eq (18) lengths is within Table 2's own scatter
    about Table 3 (up to 0.25 mm and 0.018°, not the ~1e-2 mm the paper's text states)."""
    alpha, beta, z = inputs
    state = UPU.forward(reference_leg_lengths(z, alpha * DEG, beta * DEG))
    pose = UPU.ideal_pose(*state)
    np.testing.assert_allclose(pose[:3], expected[:3], atol=0.3)
    np.testing.assert_allclose(pose[3:] / DEG, expected[3:], atol=0.02)


def test_leg_lengths_match_independent_closed_vector(rng: np.random.Generator) -> None:
    """Eqs (16)-(18) against a per-state loop with scipy's rotation."""
    states = random_states(rng, 50)
    expected = np.array([reference_leg_lengths(*s) for s in states])
    np.testing.assert_allclose(UPU.leg_lengths(*states.T), expected, atol=1e-9)


def test_initial_pose_has_all_limbs_at_l() -> None:
    """l is the length of each limb at the initial pose (eqs (19), (26))."""
    np.testing.assert_allclose(UPU.leg_lengths(0.0, 0.0, 0.0), [L0] * 3, atol=1e-12)


def test_single_dof_limb_motions_match_fig_7() -> None:
    """§IV.A: roll keeps limb 1 still and moves limbs 2, 3 oppositely; pitch moves limbs 2, 3
    together and limb 1 the other way with about twice their amplitude."""
    t = np.linspace(0.1, np.pi - 0.1, 50)
    roll = UPU.leg_lengths(0.0, 5 * DEG * np.sin(t), 0.0) - L0
    np.testing.assert_allclose(roll[:, 0], 0.0, atol=1e-9)
    assert np.all(roll[:, 1] * roll[:, 2] < 0)
    pitch = UPU.leg_lengths(0.0, 0.0, 5 * DEG * np.sin(t)) - L0
    np.testing.assert_allclose(pitch[:, 1], pitch[:, 2], atol=1e-9)
    np.testing.assert_allclose(pitch[:, 0] / pitch[:, 1], -2.0, rtol=0.05)


@pytest.mark.parametrize("trajectory", sorted(TABLE_1))
def test_forward_inverts_table_1_sine_signals(trajectory: str) -> None:
    """FK(IK(x)) = x to 1e-9 along each Table 1 trajectory of eq (27), t ∈ [0, 2π]."""
    alpha, beta, z = TABLE_1[trajectory](np.sin(np.linspace(0.0, 2 * np.pi, 361)))
    states = np.stack([z, alpha, beta], -1)
    lengths = np.array([reference_leg_lengths(*s) for s in states])
    np.testing.assert_allclose(UPU.forward(lengths), states, rtol=0, atol=1e-9)


def test_forward_inverts_random_workspace_states(rng: np.random.Generator) -> None:
    """FK(IK(x)) = x to 1e-9 on 2000 states inside `state_limits`, from the default guess."""
    states = random_states(rng, 2000)
    solved = UPU.forward(UPU.leg_lengths(*states.T))
    np.testing.assert_allclose(solved, states, rtol=0, atol=1e-9)


def test_forward_from_nearby_guess_takes_few_steps(rng: np.random.Generator) -> None:
    """From a guess 1 mm / 0.01 rad off, three Newton steps reach 1e-10 mm (eqs (22)-(24))."""
    states = random_states(rng, 200)
    lengths = UPU.leg_lengths(*states.T)
    guess = states + rng.uniform(-1, 1, states.shape) * [1.0, 0.01, 0.01]
    solved = UPU.forward(lengths, guess, max_iter=3)
    np.testing.assert_allclose(UPU.leg_lengths(*solved.T), lengths, rtol=0, atol=1e-10)


def test_forward_keeps_batch_shape(rng: np.random.Generator) -> None:
    """Lengths (2, 4, 3) give states (2, 4, 3); z, alpha, beta broadcast together."""
    states = random_states(rng, 8).reshape(2, 4, 3)
    assert UPU.forward(UPU.leg_lengths(*np.moveaxis(states, -1, 0))).shape == (2, 4, 3)
    assert UPU.leg_lengths(10.0, np.zeros(5), 0.0).shape == (5, 3)


def test_jacobian_equals_central_differences(rng: np.random.Generator) -> None:
    """∂l/∂(z, α, β) (eq (24)) equals central differences of leg_lengths."""
    states = random_states(rng, 30)
    h = 1e-6  # [mm | rad]
    expected = np.stack(
        [
            (UPU.leg_lengths(*(states + h * e).T) - UPU.leg_lengths(*(states - h * e).T)) / (2 * h)
            for e in np.eye(3)
        ],
        -1,
    )
    np.testing.assert_allclose(UPU.jacobian(*states.T), expected, rtol=0, atol=1e-6)


def test_coupled_displacement_maxima_match_section_iv_d() -> None:
    """Largest |Z_c| (eq (15)) along P1-P4: the paper reports 7.9594, 4.0471, 4.1346 and
    8.1706 mm from its own NR runs; eq (15) gives 7.9004, 4.0715, 4.0715, 8.1278 mm."""
    s = np.sin(np.linspace(0.0, 2 * np.pi, 721))
    reported = {"P1": 7.9594, "P2": 4.0471, "P3": 4.1346, "P4": 8.1706}
    for name, signal in TABLE_1.items():
        alpha, beta, z = signal(s)
        displacement = UPU.coupled_displacement(z, alpha, beta)
        np.testing.assert_allclose(displacement[:, :2], UPU.ideal_pose(z, alpha, beta)[:, :2])
        assert np.max(np.abs(displacement[:, 2])) == pytest.approx(reported[name], abs=0.07)


def test_layout_is_eq_26_in_metres() -> None:
    """Three actuated UPU limbs on the eq (26) hinges and the passive UP limb from O to O1;
    length limits are the documented 620-1460 mm default."""
    layout = UPU.layout
    np.testing.assert_allclose(layout.length_min, 0.620)
    np.testing.assert_allclose(layout.length_max, 1.460)
    assert layout.n_legs == 4 and layout.actuated == (True, True, True, False)
    np.testing.assert_allclose(layout.base_hinges[:3], HINGES * 1e-3, atol=1e-15)
    np.testing.assert_allclose(layout.platform_hinges[:3], HINGES * 1e-3, atol=1e-15)
    np.testing.assert_allclose(layout.base_hinges[3], 0.0)
    np.testing.assert_allclose(layout.platform_hinges[3], 0.0)
    sides = np.diff(layout.base_hinges[:3], axis=0, append=layout.base_hinges[:1])
    np.testing.assert_allclose(np.linalg.norm(sides, axis=1), D * 1e-3)


def test_platform_pose_reproduces_leg_lengths(rng: np.random.Generator) -> None:
    """legs(layout, T(platform_pose(s))) in metres, × 1000, equals leg_lengths(s) in mm."""
    states = random_states(rng, 200)
    lengths = legs(UPU.layout, pose_to_transform(UPU.platform_pose(states))).lengths
    np.testing.assert_allclose(lengths[:, :3] * 1e3, UPU.leg_lengths(*states.T), rtol=0, atol=1e-9)


def test_platform_pose_is_eq_11_in_zyx_convention(rng: np.random.Generator) -> None:
    """Rz(yaw)Ry(pitch)Rx(roll) of platform_pose equals Rx(α)Ry(β) (eq (11)); the origin is
    eq (13)'s (X_p, Y_p, Z_p) in metres."""
    states = random_states(rng, 100)
    pose = UPU.platform_pose(states)
    expected = Rotation.from_euler("XY", states[:, 1:]).as_matrix()
    np.testing.assert_allclose(rpy_to_matrix(pose[:, 3:]), expected, atol=1e-14)
    np.testing.assert_allclose(pose[:, :3] * 1e3, UPU.ideal_pose(*states.T)[:, :3], atol=1e-10)


def test_up_limb_lies_along_platform_normal(rng: np.random.Generator) -> None:
    """The coupling constraint: the UP limb runs from O along the platform z axis, l + z
    long, and its U-joint angles are (α, β) (seed 001 §II.B)."""
    states = random_states(rng, 200)
    z, alpha, beta = states.T
    pose = UPU.platform_pose(states)
    up = legs(UPU.layout, pose_to_transform(pose))
    ca, sa, cb, sb = np.cos(alpha), np.sin(alpha), np.cos(beta), np.sin(beta)
    normal = np.stack([sb, -sa * cb, ca * cb], -1)  # third column of Rx(α)Ry(β)
    np.testing.assert_allclose(up.units[:, 3], normal, atol=1e-14)
    np.testing.assert_allclose(up.units[:, 3], rpy_to_matrix(pose[:, 3:])[:, :, 2], atol=1e-14)
    np.testing.assert_allclose(up.lengths[:, 3] * 1e3, L0 + z, atol=1e-10)
    np.testing.assert_allclose(UPU.legs(z, alpha, beta).units[:, 3], normal, atol=1e-14)  # mm API
    np.testing.assert_allclose(universal_angles(up.units[:, 3]), states[:, 1:], atol=1e-12)


def test_stroke_covers_state_limits() -> None:
    """Every state on a 9³ grid of `state_limits`, corners included, is reachable."""
    low, high = UPU.state_limits
    grid = np.stack(np.meshgrid(*np.linspace(low, high, 9).T, indexing="ij"), -1).reshape(-1, 3)
    lengths = UPU.leg_lengths(*grid.T, check=True)
    assert lengths.min() >= UPU.leg_min and lengths.max() <= UPU.leg_max


@pytest.mark.parametrize(
    ("lengths", "message"),
    [
        (np.full((4, 2), L0), r"lengths must have shape \(\.\.\., 3\)"),
        ([L0, np.nan, L0], "lengths must be finite"),
        ([L0, L0, 1500.0], r"lengths \[mm\] out of range.*allowed \[620, 1460\]"),
    ],
)
def test_forward_rejects_bad_lengths(lengths: object, message: str) -> None:
    """Wrong shape, NaN and lengths outside the stroke raise TwinError naming the problem."""
    with pytest.raises(TwinError, match=message):
        UPU.forward(lengths)


def test_forward_rejects_lengths_met_outside_workspace() -> None:
    """All legs at leg_min is z = −420 mm, outside |z| ≤ 150 mm: UnreachableError."""
    with pytest.raises(UnreachableError, match="outside state_limits"):
        UPU.forward([620.0, 620.0, 620.0])


def test_forward_raises_convergence_error() -> None:
    """Lengths no state meets, or too few steps, raise ConvergenceError instead of hanging."""
    with pytest.raises(ConvergenceError, match="did not converge"):
        UPU.forward([620.0, 1460.0, 1460.0])
    far = UPU.leg_lengths(140.0, 18 * DEG, -18 * DEG)
    with pytest.raises(ConvergenceError, match=r"max_iter=1\)"):
        UPU.forward(far, max_iter=1)


def test_forward_rejects_bad_guess() -> None:
    """A guess that is not (..., 3), or does not broadcast to the lengths, is a TwinError."""
    with pytest.raises(TwinError, match=r"guess must have shape"):
        UPU.forward([L0] * 3, guess=[0.0, 0.0])
    with pytest.raises(TwinError, match="does not broadcast"):
        UPU.forward([L0] * 3, guess=np.zeros((2, 3)))


def test_state_input_is_checked() -> None:
    """NaN, non-broadcasting and out-of-workspace states raise TwinError naming them."""
    with pytest.raises(TwinError, match="alpha must be finite"):
        UPU.leg_lengths(0.0, np.nan, 0.0)
    with pytest.raises(TwinError, match="must broadcast together"):
        UPU.ideal_pose(np.zeros(2), np.zeros(3), 0.0)
    with pytest.raises(UnreachableError, match="outside state_limits"):
        UPU.leg_lengths(200.0, 0.0, 0.0, check=True)
    with pytest.raises(UnreachableError, match=r"UPU limb lengths \[1140"):
        Upu3Up(leg_min=1000.0, leg_max=1100.0).leg_lengths(100.0, 0.0, 0.0, check=True)
    with pytest.raises(TwinError, match=r"state must have shape \(\.\.\., 3\)"):
        UPU.platform_pose([0.0, 0.0])


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [({"l": -1.0}, "Upu3Up.l must be a positive"), ({"leg_min": 1100.0}, "leg_min < l < leg_max"),
     ({"tilt_limit": 2.0}, "tilt_limit must be below"), ({"heave_limit": 1040.0}, "heave_limit")],
)
def test_bad_parameters_raise(kwargs: dict, message: str) -> None:
    """Parameters are validated on construction."""
    with pytest.raises(TwinError, match=message):
        Upu3Up(**kwargs)
