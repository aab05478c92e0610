r"""Property-based fuzzing of the planners: one step of every registry planner (issue 8).

Random in-range `PlannerParameters`, random in-limit states (corners of the limits, where the
joint-limit weights nearly freeze a joint, included) and random targets near the held pose give
finite velocities and diagnostics within the rate limits; `weighted_pinv` stays bounded on
random near-singular matrices; bad input raises a ValueError that names the argument.

The bound on `weighted_pinv`. With D = diag(√w), J_W = J D = U S Vᵀ (singular values s_i ≥
σ_min) and λ² = (1 − (σ_min/ε)²) λ_max² when σ_min < ε, else 0,

    J_W⁺ = W⁻¹Jᵀ(J W⁻¹ Jᵀ + λ²I)⁻¹ = D V diag(s_i / (s_i² + λ²)) Uᵀ,

so ‖J_W⁺‖₂ ≤ √max(w) · max_i s_i/(s_i² + λ²) ≤ √max(w) · min(1/σ_min, 1/(2λ)) (the second
by s² + λ² ≥ 2sλ). If σ_min ≥ ε this is ≤ 1/ε. Otherwise 1/σ_min falls and 1/(2λ) rises with
σ_min, so their minimum is largest where they meet, σ_min² = 4λ_max²(1 − σ_min²/ε²); hence

    ‖J_W⁺‖₂ ≤ √max(w) · √(1/ε² + 1/(4 λ_max²))      for every J when λ_max > 0,

i.e. about √max(w) / (2 λ_max) for the default ε = 0.01, λ_max = 0.05 (10.2 √max(w)).
"""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from annotated_types import Ge, Gt, Le
from hypothesis import assume, given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from tests.figures import fuzz
from tests.mechanisms.test_fuzz_kinematics import hybrid_states, upr4_states, upu3up_states
from twin.mechanisms import HybridBoardingSystem, Upr4, Upu3Up
from twin.planners import (
    HYBRID_RATE_LIMITS,
    PLANNERS,
    PlannerParameters,
    PlatformModel,
    TipTarget,
    get_planner,
    weighted_pinv,
)
from twin.spatial import so3_exp

H = HybridBoardingSystem()
HYBRID_PLANNERS = sorted(n for n, s in PLANNERS.items() if "hybrid" in s.mechanisms)
PLATFORM_PLANNERS = sorted(n for n, s in PLANNERS.items() if "upr4" in s.mechanisms)
PLATFORMS = {"upu3up": (Upu3Up(), upu3up_states()), "upr4": (Upr4(), upr4_states())}


def finite(low: float, high: float, **kwargs: Any) -> st.SearchStrategy[float]:
    return st.floats(low, high, allow_nan=False, allow_infinity=False, **kwargs)


def field_range(name: str) -> tuple[float, float, bool]:
    """(low, high, low excluded) of a `PlannerParameters` field, from its pydantic bounds."""
    low, high, open_low = -np.inf, np.inf, False
    for bound in PlannerParameters.model_fields[name].metadata:
        if isinstance(bound, Ge):
            low = bound.ge
        elif isinstance(bound, Gt):
            low, open_low = bound.gt, True
        elif isinstance(bound, Le):
            high = bound.le
    return low, high, open_low


FIELDS = sorted(PlannerParameters.model_fields)


@st.composite
def parameters(draw: st.DrawFn) -> PlannerParameters:
    """Every field anywhere in its allowed range, bounds included."""
    values = {}
    for name in FIELDS:
        low, high, open_low = field_range(name)
        values[name] = draw(finite(low, high, exclude_min=open_low), label=name)
    return PlannerParameters(**values)


def near(T: np.ndarray, offset: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    """T moved by `offset` [m] and turned by the rotation vector `rotation` [rad], in B."""
    out = np.array(T)
    out[:3, :3] = so3_exp(rotation) @ T[:3, :3]
    out[:3, 3] += offset
    return out


OFFSET = arrays(np.float64, 3, elements=finite(-0.1, 0.1))  # [m] target off the held pose
TURN = arrays(np.float64, 3, elements=finite(-0.05, 0.05))  # [rad]
TWIST = arrays(np.float64, 6, elements=finite(-1.0, 1.0))  # [m/s, rad/s]
DT = finite(0.005, 0.2)  # [s], Scenario.dt


def all_finite(values: dict) -> bool:
    return all(np.all(np.isfinite(np.asarray(v, dtype=float))) for v in values.values())


@fuzz(300)
@given(
    name=st.sampled_from(HYBRID_PLANNERS),
    p=parameters(),
    xi0=hybrid_states(),
    xi=hybrid_states(),
    offset=OFFSET,
    turn=TURN,
    twist=TWIST,
    dt=DT,
)
def test_hybrid_planner_step_is_finite_and_rate_limited(name, p, xi0, xi, offset, turn, twist, dt):
    """One step from any in-limit state towards a target near the held tip pose: finite
    velocity and diagnostics; PI/WPI/MTMP stay within the rate limits with λ ∈ [0, λ_max];
    qp within its rate box."""
    planner = PLANNERS[name].build(H, p, xi0)
    planner.reset(xi0, TipTarget(H.end_effector(xi0), np.zeros(6)))
    target = TipTarget(near(H.end_effector(xi), offset, turn), twist)
    out = planner.step(xi, target, dt)
    assert out.velocity.shape == (9,) and np.all(np.isfinite(out.velocity))
    assert all_finite(out.diagnostics)
    assert out.diagnostics["task_error"].shape == (6,)
    if name in ("pi", "wpi", "mtmp"):
        assert np.all(np.abs(out.velocity) <= HYBRID_RATE_LIMITS * (1 + 1e-12))
        assert 0.0 < out.diagnostics["velocity_scale"] <= 1.0
        assert 0.0 <= out.diagnostics["damping"] <= p.damping
        assert np.all(out.diagnostics["weights"] >= 0.0)
    elif name == "qp":  # the rate limits are a hard box, the level says what it met
        assert np.all(np.abs(out.velocity) <= HYBRID_RATE_LIMITS * (1 + 1e-9))
        assert out.diagnostics["qp_level"] in (0.0, 1.0, 2.0)
        assert 0 <= out.diagnostics["qp_active"] <= 24
    else:
        share = out.diagnostics["position_share"]
        assert np.all((share >= 0.0) & (share <= 1.0))


@fuzz(200)
@given(
    name=st.sampled_from(PLATFORM_PLANNERS),
    platform=st.sampled_from(sorted(PLATFORMS)),
    p=parameters(),
    data=st.data(),
    offset=OFFSET,
    turn=TURN,
    twist=TWIST,
    dt=DT,
)
def test_platform_planner_step_is_finite_and_speed_limited(
    name, platform, p, data, offset, turn, twist, dt
):
    """Two steps of the small platforms' servo from any in-limit state towards a target
    near the held top pose: finite rates within ±actuator_speed, finite diagnostics."""
    mechanism, states = PLATFORMS[platform]
    state0 = data.draw(states, label="state0")
    state = data.draw(states, label="state")
    planner = get_planner(name, platform).build(mechanism, p, state0)
    model = PlatformModel(mechanism, z_hold=float(state0[0]))
    held = model.transform(state0)
    legs = model.leg_lengths(state)
    planner.reset(legs, TipTarget(held, np.zeros(6)))
    for _ in range(2):  # the second step runs the PID's derivative and integral terms
        out = planner.step(legs, TipTarget(near(held, offset, turn), twist), dt)
        assert out.velocity.shape == (model.n_legs,) and np.all(np.isfinite(out.velocity))
        limit = p.actuator_speed / model.unit  # a subnormal limit is met to 1e-300 only
        assert np.all(np.abs(out.velocity) <= limit * (1 + 1e-9) + 1e-300)
        assert all_finite(out.diagnostics)
        legs = legs + out.velocity * dt


@st.composite
def near_singular(draw: st.DrawFn, rows: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(J (m, n), w (n,)): J = U diag(s) Vᵀ with random orthonormal U, V, largest singular
    value 0.01-1000 and the others any fraction of it, 0 and 1e-300 included; weights in
    [0, 100] (k_c ≤ 100 on the telescope), zeros and subnormals included."""
    m = rows if rows is not None else draw(st.integers(1, 6))
    n = draw(st.integers(m, 9))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    U = np.linalg.qr(rng.normal(size=(m, m)))[0]
    V = np.linalg.qr(rng.normal(size=(n, n)))[0][:, :m]
    fraction = st.sampled_from([0.0, 1e-300, 1e-12, 1e-6]) | finite(0.0, 1.0)
    s = draw(finite(1e-2, 1e3)) * np.r_[1.0, draw(arrays(np.float64, m - 1, elements=fraction))]
    w = draw(arrays(np.float64, n, elements=st.sampled_from([0.0, 1.0]) | finite(0.0, 100.0)))
    return U @ np.diag(s) @ V.T, w


@fuzz(400)
@given(
    Jw=near_singular(),
    epsilon=finite(1e-4, 1.0),
    damping_max=finite(1e-3, 1.0),
)
def test_weighted_pinv_is_bounded_on_near_singular_matrices(Jw, epsilon, damping_max) -> None:
    """‖J_W⁺‖₂ ≤ √max(w) · √(1/ε² + 1/(4λ_max²)) (module docstring), λ ∈ [0, λ_max], and
    J J_W⁺ = I wherever no damping was needed."""
    J, w = Jw
    pinv, damping = weighted_pinv(J, w, epsilon=epsilon, damping_max=damping_max)
    assert pinv.shape == J.T.shape and np.all(np.isfinite(pinv))
    assert 0.0 <= damping <= damping_max
    bound = np.sqrt(w.max()) * np.sqrt(1 / epsilon**2 + 1 / (4 * damping_max**2))
    assert np.linalg.norm(pinv, 2) <= bound * (1 + 1e-9) + 1e-12
    if damping == 0.0:  # σ_min(J_W) ≥ ε: a right inverse, up to cond(J_W) roundoff
        s = np.linalg.svd(J * np.sqrt(w), compute_uv=False)
        np.testing.assert_allclose(J @ pinv, np.eye(J.shape[0]), atol=1e-12 * s[0] / s[-1])


@fuzz(300)
@given(Jw=near_singular(rows=6), epsilon=finite(1e-4, 1.0))
def test_undamped_weighted_pinv_stays_finite_at_singularities(Jw, epsilon) -> None:
    """λ_max = 0 (PlannerParameters allows damping = 0) with a rank-deficient J_W, e.g. β = 0
    zeroing the six platform joints: still a finite matrix, no exception, and λ = 0. (Unless
    ‖J_W‖ is itself below ~1e-294: the undamped inverse is then beyond the float range.)"""
    J, w = Jw
    norm = np.linalg.norm(J * np.sqrt(w), 2)
    assume(norm == 0.0 or norm >= 1e-150)
    pinv, damping = weighted_pinv(J, w, epsilon=epsilon, damping_max=0.0)
    assert np.all(np.isfinite(pinv)) and damping == 0.0


def test_undamped_wpi_with_beta_zero_steps_finitely() -> None:
    """β = 0 gives the six platform joints zero weight, so J W⁻¹ Jᵀ has rank 3; with
    damping = 0 the WPI and MTMP steps must still be finite (was LinAlgError), and WPI then
    leaves the platform still."""
    xi = H.working_state
    target = TipTarget(near(H.end_effector(xi), np.r_[0.01, 0, 0], np.zeros(3)), np.zeros(6))
    for name in ("wpi", "mtmp"):
        for beta in (0.0, 1.0):
            p = PlannerParameters(beta=beta, damping=0.0)
            out = PLANNERS[name].build(H, p, xi).step(xi, target, 0.05)
            assert np.all(np.isfinite(out.velocity)) and np.abs(out.velocity).max() > 1e-3
            if name == "wpi" and beta == 0.0:
                np.testing.assert_array_equal(out.velocity[:6], 0.0)


NONFINITE = st.sampled_from([np.nan, np.inf, -np.inf])


@st.composite
def bad_fields(draw: st.DrawFn) -> tuple[str, float]:
    """(field, value) with the value NaN, inf or just outside the field's range."""
    name = draw(st.sampled_from(FIELDS), label="field")
    low, high, open_low = field_range(name)
    below = finite(-1e6, low) if open_low else finite(-1e6, float(np.nextafter(low, -np.inf)))
    above = finite(float(np.nextafter(high, np.inf)), 1e6)
    return name, draw(NONFINITE | below | above, label=name)


@fuzz(200)
@given(bad=bad_fields())
def test_out_of_range_parameters_raise_a_value_error_naming_the_field(bad) -> None:
    """pydantic's ValidationError is a ValueError; its message lists the field by name."""
    name, value = bad
    with pytest.raises(ValueError, match=rf"(?m)^{name}$"):
        PlannerParameters(**{name: value})


_XI = H.working_state
_PI = PLANNERS["pi"].build(H, PlannerParameters(), _XI)
_TARGET = TipTarget(H.end_effector(_XI), np.zeros(6))
_PID = get_planner("pid", "upr4").build(Upr4(), PlannerParameters(), Upr4().working_state)
_LEGS = Upr4().leg_lengths(*Upr4().working_state)


def _with(base: np.ndarray, index: int, value: float) -> np.ndarray:
    out = np.array(base, dtype=float)
    out[index] = value
    return out


# (name the message starts with, call with the bad value, bad values)
BAD_PLANNER: list[tuple[str, Callable[[Any], Any], st.SearchStrategy]] = [
    ("xi", lambda v: _PI.step(_with(_XI, 3, v), _TARGET, 0.05), NONFINITE),
    ("dt", lambda v: _PID.step(_LEGS, _TARGET, v), NONFINITE | finite(-1e3, 0.0)),
    ("state", lambda v: _PID.step(_with(_LEGS, 0, v), _TARGET, 0.05), NONFINITE),
    (
        "planner",
        lambda v: get_planner(v, "hybrid"),
        st.text(min_size=1).filter(lambda v: v not in PLANNERS),
    ),
    ("planner", lambda v: get_planner(v, "upr4"), st.sampled_from(HYBRID_PLANNERS)),
]


@fuzz(150)
@given(data=st.data())
def test_bad_planner_input_raises_a_value_error_naming_it(data: st.DataObject) -> None:
    """NaN or inf states, a non-positive dt, unknown or unsuitable planner names: a
    ValueError whose message starts with the argument's name."""
    name, call, bad = data.draw(st.sampled_from(BAD_PLANNER), label="argument")
    value = data.draw(bad, label=name)
    with pytest.raises(ValueError, match=rf"^{re.escape(name)}\b"):
        call(value)
