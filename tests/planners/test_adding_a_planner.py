"""docs/adding-a-planner.md, run: its example planner `wpi_limits`, built exactly as the doc
shows, registered in the registry for the test's duration (`monkeypatch.setitem` on
`PLANNERS`, undone afterwards) and simulated by the engine through the path every registered
planner takes (`Scenario.planner` → `get_planner` → `PlannerSpec.build` → `pack` → kernel)."""

from __future__ import annotations

import numpy as np
import pytest

from twin.errors import TwinError
from twin.mechanisms.hybrid import HybridBoardingSystem
from twin.planners.allocation import AllocationPlanner
from twin.planners.differential import DifferentialPlanner
from twin.planners.families import DIFFERENTIAL_PARAMETERS
from twin.planners.limits import VelocityLimit
from twin.planners.parameters import PlannerParameters
from twin.planners.registry import HYBRID_RATE_LIMITS, PLANNERS, PlannerSpec
from twin.planners.tasks import TipPoseTask
from twin.planners.weights import BetaSplit, JointLimitWeights, ProductWeights
from twin.sim import simulate


# --- as in docs/adding-a-planner.md, step 1 (twin/planners/registry.py) ----------------------
def _wpi_limits(
    h: HybridBoardingSystem, p: PlannerParameters, xi0: np.ndarray
) -> DifferentialPlanner:
    """WPI (seed 000 eqs (27)-(32)) with the joint-limit weights of eqs (35)-(36), k_c = 1."""
    del xi0  # Unused: no set-point is taken from the start state.
    weights = ProductWeights(
        (BetaSplit(p.beta, p.l), JointLimitWeights(h.lower, h.upper, np.ones(9)))
    )
    return DifferentialPlanner(
        TipPoseTask(h, gain=p.k_e),
        weights,
        velocity_limit=VelocityLimit(HYBRID_RATE_LIMITS),
        damping_max=p.damping,
    )


# --- as in docs/adding-a-planner.md, step 2 (the registry line) -------------------------------
WPI_LIMITS = PlannerSpec(
    "wpi_limits",
    "weighted pseudo-inverse with joint-limit weights",
    ("hybrid",),
    ("k_e", "beta", "l", "damping"),
    "seed 000 eqs (27)-(32), (35)-(36)",
    _wpi_limits,
    "differential",
)
# ---------------------------------------------------------------------------------------------

#: the doc's scenario: knobs away from their defaults, so a knob lost on the way shows
SCENARIO = {
    "planner": "wpi_limits",
    "sea_state": 5,
    "duration": 2.0,
    "beta": 0.6,
    "l": 2.0,
    "k_e": 20.0,
}


@pytest.fixture()
def built(monkeypatch: pytest.MonkeyPatch) -> list[DifferentialPlanner]:
    """Register `WPI_LIMITS` for one test; the planners the engine builds from it, in order."""
    planners: list[DifferentialPlanner] = []

    def build(h: HybridBoardingSystem, p: PlannerParameters, xi0: np.ndarray) -> object:
        planners.append(WPI_LIMITS.build(h, p, xi0))
        return planners[-1]

    spec = PlannerSpec(**{**WPI_LIMITS.__dict__, "build": build})
    monkeypatch.setitem(PLANNERS, spec.name, spec)
    return planners


def test_the_example_planner_runs_on_the_engine(built: list[DifferentialPlanner]) -> None:
    """2 s at sea state 5: the engine builds the planner from the registry with the scenario's
    knobs, its states stay finite, its first weights are the object's own to 1e-9 and it
    holds the tip far better than the base moves."""
    result = simulate(SCENARIO)
    assert len(built) >= 1
    planner = built[0]
    assert planner.tip.gain == SCENARIO["k_e"]
    series = result.series
    assert np.all(np.isfinite(series["xi"]))
    assert len(series["t"]) == round(SCENARIO["duration"] / 0.05) + 1
    # the kernel's diag(W⁻¹) on the first step is the object's at the start state
    np.testing.assert_allclose(
        series["weights"][1], planner.weights(series["xi"][0]), rtol=0, atol=1e-9
    )
    # compensation: once the start-up transient has passed (the lane starts at rest and its
    # rates are limited; ≈ 0.1 m for ≈ 1 s), the tip's position error [m] is a small share
    # of the base's excursion [m], which an uncompensated tip would follow
    settled = series["t"] >= 1.0
    tip = np.linalg.norm(series["tip_error"][settled, :3], axis=-1).max()
    base = series["base_pose"][:, :3] - series["base_pose"][0, :3]
    excursion = np.linalg.norm(base, axis=-1).max()
    assert excursion > 0.05  # the sea moves the base: the comparison means something
    assert tip < 0.01 * excursion


def test_the_example_planner_packs_the_doc_values() -> None:
    """`pack()` writes the family's record by name: β^l | (1 − β)^l, the limits with scale 1
    and joint-limit weights on, k_e, λ_max and the rate limit, as the doc lists."""
    h = HybridBoardingSystem()
    knobs = PlannerParameters(beta=0.6, l=2.0, k_e=20.0)
    planner = WPI_LIMITS.build(h, knobs, np.zeros(9))
    record = planner.pack(hold=False).view(DIFFERENTIAL_PARAMETERS)[0]
    np.testing.assert_allclose(record["split"], [0.36] * 6 + [0.16] * 3, rtol=1e-12)
    np.testing.assert_array_equal(record["scale"], np.ones(9))
    np.testing.assert_array_equal(record["lower"], h.lower)
    np.testing.assert_array_equal(record["upper"], h.upper)
    assert record["joint_limits"] == 1.0
    assert record["gain"] == 20.0
    assert record["damping"] == knobs.damping
    assert record["posture_index"] == -1.0  # no secondary task
    assert record["slew"] == 0.0  # no Algorithm 1
    assert record["rate_limited"] == 1.0
    np.testing.assert_array_equal(record["rate"], HYBRID_RATE_LIMITS)


# --- docs/adding-a-planner.md, "Another family's parts": an allocation planner ---------------
def _conv2_quiet(
    h: HybridBoardingSystem, p: PlannerParameters, xi0: np.ndarray
) -> AllocationPlanner:
    """Seed 004 §4 b's conventional method 2, registered again under its own name."""
    del p, xi0  # Unused: seed 004's methods have no knobs.
    return AllocationPlanner(h, "conv2")


#: its registry line: the allocation family, recording none of the family's diagnostics
CONV2_QUIET = PlannerSpec(
    "conv2_quiet", "conventional method 2, no diagnostics", ("hybrid",), (), "seed 004 §4 b",
    _conv2_quiet, "allocation", diagnostics=frozenset(),
)  # fmt: skip


def test_an_allocation_planner_with_its_own_diagnostics_needs_only_a_registry_line(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Registered by its line alone, the new planner runs on the engine's allocation lanes:
    its states equal conv2's on the same sea, and its series keep its own (empty) diagnostics,
    where conv2's keep the family's `position_share`."""
    monkeypatch.setitem(PLANNERS, CONV2_QUIET.name, CONV2_QUIET)
    sea = {"sea_state": 5, "duration": 2.0, "seed": 4}
    quiet = simulate({**sea, "planner": "conv2_quiet"})
    conv2 = simulate({**sea, "planner": "conv2"})
    np.testing.assert_array_equal(quiet.series["xi"], conv2.series["xi"])
    assert "position_share" in conv2.series and "position_share" not in quiet.series


def test_a_registry_line_names_a_known_family_and_only_its_diagnostics() -> None:
    """An unknown family, or diagnostics its family does not record, are refused with what is
    allowed."""
    with pytest.raises(TwinError, match="unknown family 'mystery'; allowed"):
        PlannerSpec("x", "x", ("hybrid",), (), "", _conv2_quiet, "mystery")
    with pytest.raises(TwinError, match="not its family's"):
        PlannerSpec("x", "x", ("hybrid",), (), "", _conv2_quiet, "allocation",
                    diagnostics=frozenset({"qp_level"}))  # fmt: skip


def test_every_registry_planner_is_of_its_entrys_family() -> None:
    """Each registered hybrid planner, built, says the family its registry line names (the
    engine packs it by that family)."""
    h = HybridBoardingSystem()
    for spec in PLANNERS.values():
        if "hybrid" in spec.mechanisms:
            planner = spec.build(h, PlannerParameters(), h.working_state)
            assert planner.family == spec.family, spec.name
