"""When a joint or a leg counts as past its limit: one predicate per limit kind, one tolerance
each, called by everything that asks (the metrics kernel's flags and first bound, the
mechanisms' `within_limits` and `check_lengths`, the viewer's readout), so no two of them can
disagree about a sample within an ulp of a bound.

Each predicate answers which limit a value is past: −1.0 the lower, 1.0 the upper, 0.0 none.
"""

from __future__ import annotations

from twin.compiled import LaneUfunc, register_jitable

#: [m, rad] a virtual joint within this of its limit is on it (seed 000 Table 6's limits)
JOINT_TOL = 1e-9
#: [m] a leg counts as past its stroke beyond Table 1's millimetre precision: the geometry's
#: stowed legs, 2.57986 m, are Table 1's 2.58 m (seed 000 Table 1)
LEG_TOL = 5e-4


@register_jitable
def past_lane(value: float, lower: float, upper: float, tol: float) -> float:
    """Which limit value is past by more than tol: −1.0 lower, 1.0 upper, 0.0 neither (units
    of the value; a negative tol counts a value within |tol| of a limit as past it)."""
    if lower - value > tol:
        return -1.0
    if value - upper > tol:
        return 1.0
    return 0.0


@register_jitable
def joint_past_lane(x: float, lower: float, upper: float, touching: float) -> float:
    """Which Table 6 limit a virtual joint x [m | rad] is past (`past_lane`'s codes): by more
    than `JOINT_TOL`, or with touching ≠ 0 (`record` mode's violations) also on it to within
    `JOINT_TOL`."""
    return past_lane(x, lower, upper, -JOINT_TOL if touching != 0.0 else JOINT_TOL)


@register_jitable
def leg_past_lane(length: float, leg_min: float, leg_max: float) -> float:
    """Which end of its stroke a leg of length [m] is past by more than `LEG_TOL`
    (`past_lane`'s codes)."""
    return past_lane(length, leg_min, leg_max, LEG_TOL)


#: the predicates over broadcast arrays (the objects' and the readout's): the same functions
JOINT_PAST = LaneUfunc(joint_past_lane, 4)
LEG_PAST = LaneUfunc(leg_past_lane, 3)
