"""One reading of the live session per render frame (`read_frame` → `FrameState`), shared by
the scene, the cameras and the GUI: what each frame draws comes from one consistent reading."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from twin.sim.live import LiveSession
from twin.sim.registries import WaveComponents, joint_configuration, leg_joint_names
from twin.sim.scenario import Scenario
from twin.spatial import pose_to_transform

#: record key of the mechanism state, when not "state"
STATE_KEY = {"hybrid": "xi"}


@dataclass(frozen=True)
class FrameState:
    """One consistent reading of the live session and what scene and GUI derive from it.

    Attributes:
        version: the session's version when read (bumps on reset and restart).
        scenario: the session's scenario.
        mechanism: the session's mechanism object (only read).
        record: the newest record (`LiveSession.latest`).
        sea: the simulated sea.
        held: (4, 4) ᴵT*, the inertial pose the mechanism holds.
        playing: whether the session advances.
        speed: [-] simulated / wall time.
        cfg: URDF joint name → value [m | rad].
        transform_base: (4, 4) ᴵT_B, the base in the inertial frame.
        transform_platform: (4, 4) ᴮT_P, the platform in the base frame [m].
        leg_lengths: (n,) [m] hinge to hinge, every leg of the URDF.
        leg_min: (n,) [m] shortest leg lengths.
        leg_max: (n,) [m] longest leg lengths.
        landing: (3,) [m] the landing point in the inertial frame: the gangway tip (hybrid:
            ᴵT_B · ᴮT_E), else the platform top (the 3UPU_UP's cargo top, the 4-UPR's pad
            centre: ᴵT_B · ᴮT_P), the point whose held place is `held`'s origin.
        ghost: the comparison lane read the same way (its scenario has its own planner), or
            None.
        replay: the stored run shown instead of the simulation ({run_id, t, duration}), or
            None.
    """

    version: int
    scenario: Scenario
    mechanism: Any
    record: dict[str, np.ndarray]
    sea: WaveComponents
    held: np.ndarray
    playing: bool
    speed: float
    cfg: dict[str, float]
    transform_base: np.ndarray
    transform_platform: np.ndarray
    leg_lengths: np.ndarray
    leg_min: np.ndarray
    leg_max: np.ndarray
    landing: np.ndarray
    ghost: FrameState | None = None
    replay: dict[str, Any] | None = None

    @property
    def t(self) -> float:
        """[s] simulated time of the record."""
        return float(self.record["t"])

    @property
    def state(self) -> np.ndarray:
        """The mechanism's own state (xi for the hybrid system)."""
        return self.record[STATE_KEY.get(self.scenario.mechanism, "state")]

    @property
    def landing_offset(self) -> np.ndarray:
        """(3,) [m] where the landing point is minus where it is held, inertial: the tip
        error of every mechanism, as the viewer shows it (trail, readout, plots).

        The recorded `tip_error` is this for the hybrid system and the 3UPU_UP, but for the
        4-UPR it is the top's error against the state it can reach (its height held on the
        base, no surge or sway: `PlatformModel.desired_state`), which a pad drifting off its
        held pose with the vessel does not show.
        """
        return self.landing - self.held[:3, 3]

    @property
    def leg_margin(self) -> np.ndarray:
        """(n,) [-] distance to the nearer stroke end over half the stroke: 1 at mid-stroke,
        0 at a limit, negative beyond it."""
        half = 0.5 * (self.leg_max - self.leg_min)
        return np.minimum(self.leg_lengths - self.leg_min, self.leg_max - self.leg_lengths) / half


def read_frame(session: LiveSession) -> FrameState | None:
    """Read the session once for a frame (one consistent reading, `LiveSession.view`)."""
    view = session.view()
    scenario, record = view["scenario"], view["record"]
    ghost = None
    if view["compare"] is not None:
        other = scenario.model_copy(update={"planner": view["compare"]})
        ghost = _frame(view, other, view["compare_record"])
    return _frame(view, scenario, record, ghost)


def _frame(
    view: dict[str, Any], scenario: Scenario, record: dict[str, np.ndarray],
    ghost: FrameState | None = None,
) -> FrameState:  # fmt: skip
    mechanism = view["mechanism"]
    state = record[STATE_KEY.get(scenario.mechanism, "state")]
    cfg = {name: float(v) for name, v in joint_configuration(mechanism, state).items()}
    layout = mechanism.layout
    strokes = [leg_joint_names(i + 1)[2] for i in range(layout.n_legs)]
    transform_base = pose_to_transform(record["base_pose"])
    transform_platform = pose_to_transform(np.asarray(mechanism.platform_pose(state)))
    # the gangway tip of the hybrid system, else the platform top (`FrameState.landing`)
    top = mechanism.end_effector(state) if scenario.mechanism == "hybrid" else transform_platform
    return FrameState(
        version=view["version"],
        scenario=scenario,
        mechanism=mechanism,
        record=record,
        sea=view["sea"],
        held=view["held"],
        playing=view["playing"],
        speed=view["speed"],
        cfg=cfg,
        transform_base=transform_base,
        transform_platform=transform_platform,
        leg_lengths=np.array([cfg[name] for name in strokes]),
        leg_min=np.array(layout.length_min),
        leg_max=np.array(layout.length_max),
        landing=(transform_base @ top)[:3, 3],
        ghost=ghost,
        replay=view["replay"],
    )
