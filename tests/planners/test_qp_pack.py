"""The qp planner's parameters are filled by name by each part's own `pack()` (issue 29 item 2):
no part is named in a whitelist, a part the qp lane cannot take refuses itself, and the row
the planner packs holds what its parts say."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import pytest

from twin.errors import TwinError
from twin.mechanisms import HybridBoardingSystem
from twin.planners import HYBRID_RATE_LIMITS
from twin.planners.families import DIFFERENTIAL_PARAMETERS, QP_PARAMETERS
from twin.planners.parameters import parameter_record
from twin.planners.qp import JointLimit, QPPlanner, qp_planner
from twin.planners.tasks import PlatformYawTask

H = HybridBoardingSystem()


def planner(**changes: object) -> QPPlanner:
    """The registry's qp planner on H with yaw_hold 0.7 (fields replaced by `changes`)."""
    built = qp_planner(
        H, k_e=25.0, w_orientation=1.0, w_secondary=0.1, limit_gain=0.5, beta=0.5, l=10.0,
        k_a2=1.0, yaw_hold=0.7, damping=0.01, q2_setpoint=0.2, rate_limit=HYBRID_RATE_LIMITS,
    )  # fmt: skip
    return replace(built, **changes)


def test_yaw_task_writes_its_term_by_name() -> None:
    """`PlatformYawTask.pack` turns the yaw term on with its yaw_hold; a second one, or one
    whose yaw_hold is not finite, is refused."""
    record = np.zeros(1, QP_PARAMETERS)[0]
    PlatformYawTask(yaw_hold=0.3).pack(record)
    assert record["yaw"] == 1.0 and record["yaw_hold"] == 0.3
    with pytest.raises(TwinError, match="more than one"):
        PlatformYawTask(yaw_hold=0.3).pack(record)
    with pytest.raises(TwinError, match="PlatformYawTask"):
        PlatformYawTask(yaw_hold=np.nan).pack(np.zeros(1, QP_PARAMETERS)[0])


def test_yaw_task_refuses_a_family_without_its_term() -> None:
    """The differential family has no yaw term: its record is refused, not half-written."""
    record = np.zeros(1, DIFFERENTIAL_PARAMETERS)[0]
    before = record.copy()
    with pytest.raises(TwinError, match="qp planner only"):
        PlatformYawTask().pack(record)
    assert record.tobytes() == before.tobytes()


def test_planner_row_holds_what_its_parts_pack() -> None:
    """The packed row's yaw and limit fields are the parts' own values."""
    qp = planner()
    p = parameter_record(qp.pack(hold=False), QP_PARAMETERS)
    assert p["yaw"] == 1.0 and p["yaw_hold"] == 0.7
    legs, joints = qp.limits
    assert (p["leg_gain"], p["leg_margin"]) == (legs.gain, legs.margin)
    assert (p["joint_gain"], p["joint_margin"]) == (joints.gain, joints.margin)
    np.testing.assert_array_equal(p["rate"], HYBRID_RATE_LIMITS)


@dataclass(frozen=True)
class WrappedJointLimit:
    """A Table 6 limit that is not a `JointLimit` (no subclass): what a whitelist would refuse."""

    inner: JointLimit

    def pack(self, record: np.void) -> None:
        self.inner.pack(record)

    def on(self, mechanism: HybridBoardingSystem) -> bool:
        return self.inner.on(mechanism)


def test_a_part_is_judged_by_its_pack_not_its_class() -> None:
    """A limit of another class that packs the same fields gives the same row; one without
    `pack`, or not on the mechanism's own limits, is refused."""
    qp = planner()
    legs, joints = qp.limits
    wrapped = planner(limits=(legs, WrappedJointLimit(joints)))
    np.testing.assert_array_equal(wrapped.pack(hold=True), qp.pack(hold=True))
    with pytest.raises(TwinError, match="no pack"):
        planner(limits=(legs, object())).pack(hold=True)
    shifted = JointLimit(H.lower - 0.1, H.upper, HYBRID_RATE_LIMITS)
    with pytest.raises(TwinError, match="own limits"):
        planner(limits=(legs, shifted)).pack(hold=True)
    with pytest.raises(TwinError, match="legs' limit first"):
        planner(limits=(joints, legs)).pack(hold=True)
