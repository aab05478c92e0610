"""One predicate per limit kind (`twin.mechanisms.limits`): at ±1 ulp of every bound and
tolerance, the metrics' violation flags, their first bound and the objects' `within_limits`
agree, because they all call the same predicate."""

from __future__ import annotations

import numpy as np
import pytest

from twin.mechanisms.hybrid import HybridBoardingSystem
from twin.mechanisms.limits import JOINT_TOL, LEG_PAST, LEG_TOL, joint_past_lane, leg_past_lane
from twin.sim.lanes import numba_available
from twin.sim.metrics import hybrid_metrics

H = HybridBoardingSystem()
LEGS = H.leg_lengths(H.working_state)


def near(value: float, steps: int) -> float:
    """value moved by `steps` ulps (negative: down)."""
    out = value
    for _ in range(abs(steps)):
        out = float(np.nextafter(out, np.inf if steps > 0 else -np.inf))
    return out


def edges() -> list[tuple[str, int, float]]:
    """(kind, index, value) for values within a few ulps of every bound and of every bound
    moved by its tolerance: joints 0-8 and legs 0-5, both sides."""
    out = []
    for j in range(9):
        for bound in (H.lower[j], H.upper[j]):
            for centre in (bound - JOINT_TOL, bound, bound + JOINT_TOL):
                out += [("joint", j, near(centre, s)) for s in (-2, -1, 0, 1, 2)]
    for i in range(6):
        for bound in (H.stewart.leg_min, H.stewart.leg_max):
            for centre in (bound - LEG_TOL, bound + LEG_TOL):
                out += [("leg", i, near(centre, s)) for s in (-2, -1, 0, 1, 2)]
    return out


def one_sample_series(kind: str, index: int, value: float) -> dict[str, np.ndarray]:
    """A two-sample series at the working state whose second sample has one joint or one leg
    set to value (the legs recorded as given: the metrics read them, not the state)."""
    xi, legs = np.tile(H.working_state, (2, 1)), np.tile(LEGS, (2, 1))
    if kind == "joint":
        xi[1, index] = value
    else:
        legs[1, index] = value
    zeros = np.zeros(2)
    return {"t": np.array([0.0, 0.01]), "xi": xi, "legs": legs, "tip_error": np.zeros((2, 6)),
            "manipulability": zeros + 1.0, "phi_e": zeros, "theta_e": zeros,
            "alpha_top": zeros, "alpha_bottom": zeros}  # fmt: skip


@pytest.mark.parametrize("compiled", [False, True] if numba_available() else [False])
@pytest.mark.parametrize("mode", ["record", "hold"])
def test_the_flag_and_the_first_bound_agree_at_every_edge(compiled: bool, mode: str) -> None:
    """A sample counts as a violation exactly when the first bound names a limit, that limit is
    the one moved and its time the sample's, for values ±2 ulps around every bound and
    tolerance edge; the predicate decides both."""
    flagged = 0
    for kind, index, value in edges():
        m = hybrid_metrics(one_sample_series(kind, index, value), H, mode, compiled)
        if kind == "joint":
            side = joint_past_lane(value, H.lower[index], H.upper[index], float(mode == "record"))
        else:
            side = leg_past_lane(value, H.stewart.leg_min, H.stewart.leg_max)
        assert (m["violations"] == 1) == (side != 0.0), (kind, index, value)
        assert (m["first_bound"] is not None) == (side != 0.0), (kind, index, value)
        if side != 0.0:
            flagged += 1
            assert m["first_bound"]["t"] == 0.01
            name = "upper" if side > 0 else "lower"
            where = f"leg {index + 1}" if kind == "leg" else "joint"
            assert m["first_bound"]["limit"].startswith(where)
            assert m["first_bound"]["limit"].endswith(f"({name})")
    assert 0 < flagged < len(edges())  # both answers occur: the edges straddle the bounds


def test_within_limits_is_the_hold_modes_flag() -> None:
    """`HybridBoardingSystem.within_limits` is False exactly where hold mode counts a violation
    (joints past by more than JOINT_TOL, legs by more than LEG_TOL), at the joint edges."""
    for kind, index, value in edges():
        if kind != "joint":
            continue
        xi = H.working_state.copy()
        xi[index] = value
        side = joint_past_lane(value, H.lower[index], H.upper[index], 0.0)
        legs_ok = bool(np.all(LEG_PAST(H.leg_lengths(xi), H.stewart.leg_min,
                                       H.stewart.leg_max) == 0.0))  # fmt: skip
        assert bool(H.within_limits(xi)) == (side == 0.0 and legs_ok), (index, value)


def test_check_lengths_refuses_exactly_past_the_leg_tolerance() -> None:
    """`StewartPlatform.check_lengths` raises for a leg 1 ulp past leg_max + LEG_TOL and not
    for one 1 ulp inside it."""
    s = H.stewart
    edge = s.leg_max + LEG_TOL
    inside, outside = LEGS.copy(), LEGS.copy()
    inside[2], outside[2] = near(edge, -1), near(edge, 2)
    s.check_lengths(inside, "legs")
    with pytest.raises(ValueError, match="leg lengths"):
        s.check_lengths(outside, "legs")
