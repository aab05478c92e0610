"""The 3D scene of a real viewer on a real live session: its nodes, the painted URDF, and
that every node follows the session while a browser (a raw websocket client speaking viser's
protocol, tests/web/viewer_client.py) watches."""

from __future__ import annotations

import json
from functools import partial
from types import SimpleNamespace

import numpy as np
import pytest
import viser.transforms as tf
import yourdfpy

from tests.web.support import free_port, wait_for
from tests.web.viewer.support import caught_up, connect
from tests.web.viewer.test_browser_scene import project
from tests.web.viser_client import ViserClient
from twin.assets import asset_path
from twin.mechanisms.urdf import joint_configuration
from twin.sim.live import LiveSession
from twin.spatial import matrix_to_wxyz, pose_to_transform
from twin.web.access import Access
from twin.web.viewer import (
    FOV,
    PAINT_METALLIC,
    ClientPanel,
    Viewer,
    framed_points,
    margin_colours,
    mechanism_points,
    mm,
    mount_transform,
    painted_urdf,
    start_viewer,
    trail_label,
    trail_magnification,
)
from twin.web.viewer.cameras import VIEWS
from twin.web.viewer.frame_state import read_frame


def test_scene_has_its_nodes(viewer: Viewer) -> None:
    """Sea, vessel, base with URDF and legs, transition piece, trail: all added at start."""
    scene = viewer.server.scene
    for name in ("/ocean", "/vessel/hull", "/vessel/pedestal", "/base", "/base/legs",
                 "/base/robot/visual/leg1_cross/leg1_barrel/leg1_rod", "/target/transition_piece",
                 "/target/access_platform", "/target/tower", "/target/held_tip", "/trail",
                 "/trail_label"):  # fmt: skip
        assert scene.get_handle_by_name(name) is not None, name
    assert viewer.port == viewer.server.get_port()


def glb_materials(glb: bytes) -> list[dict]:
    """The materials of a GLB file (its JSON chunk: length at bytes 12-16, JSON from 20)."""
    length = int.from_bytes(glb[12:16], "little")
    return json.loads(glb[20 : 20 + length]).get("materials", [])


@pytest.mark.parametrize("name", ["hybrid", "upu3up", "upr4"])
def test_urdf_parts_reach_the_browser_painted_not_as_bare_metal(name: str) -> None:
    """Each URDF mesh, exported as viser sends it (GLB), carries a material of its link's
    `<color>` in linear light (IEC 61966-2-1), which shown in sRGB is that colour again, and
    mostly diffuse.
    Without one (as yourdfpy loads them: vertex colours only) three.js draws glTF's default
    material, full metal, black wherever no environment map lights it ("light" graphics)."""
    path = asset_path("urdf", f"{name}.urdf")
    plain = yourdfpy.URDF.load(path, load_meshes=True, build_scene_graph=True,
                               filename_handler=partial(yourdfpy.filename_handler_magic,
                                                        dir=path.parent))  # fmt: skip
    for mesh in plain.scene.geometry.values():
        assert glb_materials(mesh.export(file_type="glb")) == []
    urdf = painted_urdf(path)
    assert urdf.scene.geometry.keys() == plain.scene.geometry.keys()
    for key, mesh in urdf.scene.geometry.items():
        (material,) = glb_materials(mesh.export(file_type="glb"))
        pbr = material["pbrMetallicRoughness"]
        assert pbr["metallicFactor"] == PAINT_METALLIC <= 0.5
        linear = np.array(pbr["baseColorFactor"])
        srgb = plain.scene.geometry[key].visual.main_color / 255.0
        want = np.where(srgb <= 0.04045, srgb / 12.92, ((srgb + 0.055) / 1.055) ** 2.4)
        # trimesh keeps a material's colour in 8 bits: half a step of rounding
        np.testing.assert_allclose(linear[:3], want[:3], rtol=0, atol=0.5 / 255, err_msg=key)
        assert linear[3] == srgb[3]
        assert np.all(linear[:3] <= srgb[:3]) and np.any(linear[:3] < srgb[:3] - 0.05)


def test_urdf_frames_follow_the_session(
    viewer: Viewer, session: LiveSession, browser: tuple[ViserClient, ClientPanel]
) -> None:
    """With a browser watching, after steps, every URDF joint frame equals yourdfpy's forward
    kinematics of `joint_configuration` of the newest state, and the base frame the base
    pose."""
    urdf = yourdfpy.URDF.load(asset_path("urdf", "hybrid.urdf"), load_meshes=False)
    parent = {j.child: j.parent for j in urdf.joint_map.values()}
    before = dict(viewer.scene.joint_values)
    for _ in range(2):  # the second pass exercises LiveUrdf's per-joint update
        session.step(20)
        assert wait_for(caught_up(viewer, session))
        record = session.latest()
        cfg = joint_configuration(session.mechanism, record["xi"])
        assert viewer.scene.joint_values == pytest.approx({k: float(v) for k, v in cfg.items()})
        urdf.update_cfg({k: float(v) for k, v in cfg.items()})
        for joint in urdf.joint_map.values():
            path, link = [], joint.child
            while link != urdf.base_link:
                path.append(link)
                link = parent[link]
            handle = viewer.server.scene.get_handle_by_name(
                "/base/robot/visual/" + "/".join(reversed(path))
            )
            T = urdf.get_transform(joint.child, joint.parent)
            np.testing.assert_allclose(handle.position, T[:3, 3], atol=1e-6)
            q = matrix_to_wxyz(T[:3, :3])
            assert min(np.abs(handle.wxyz - q).max(), np.abs(handle.wxyz + q).max()) < 1e-6
    assert viewer.scene.joint_values != before  # the session moved, so did the robot
    base = viewer.server.scene.get_handle_by_name("/base")
    np.testing.assert_allclose(base.position, record["base_pose"][:3], atol=1e-9)


def test_vessel_is_the_base_pose_without_the_mount(
    viewer: Viewer, session: LiveSession, browser: tuple[ViserClient, ClientPanel]
) -> None:
    """ᴵT_V · ᵛT_B = ᴵT_B: the hull moves with the base it carries."""
    session.step(10)
    assert wait_for(caught_up(viewer, session))
    vessel = viewer.server.scene.get_handle_by_name("/vessel")
    T_IV = np.eye(4)
    T_IV[:3, :3], T_IV[:3, 3] = tf.SO3(vessel.wxyz).as_matrix(), vessel.position
    T_IB = pose_to_transform(session.latest()["base_pose"])
    np.testing.assert_allclose(T_IV @ mount_transform("hybrid"), T_IB, atol=1e-9)


def test_sea_and_trail_animate(
    viewer: Viewer, session: LiveSession, browser: tuple[ViserClient, ClientPanel]
) -> None:
    """With a browser watching, the sea mesh's vertices and the trail move with simulated time
    (same nodes)."""
    ocean = viewer.server.scene.get_handle_by_name("/ocean")
    before, trail = np.array(ocean.vertices), np.array(viewer.scene.trail.handle.points)
    session.step(10)
    assert wait_for(caught_up(viewer, session))
    assert viewer.server.scene.get_handle_by_name("/ocean") is ocean
    assert np.abs(ocean.vertices - before).max() > 1e-3
    assert np.abs(viewer.scene.trail.handle.points - trail).max() > 0.0


def test_mechanism_switch_swaps_urdf_target_and_planners(
    viewer: Viewer, session: LiveSession, browser: tuple[ViserClient, ClientPanel]
) -> None:
    """Choosing the 4-UPR in the GUI restarts the session; the scene and the planner list
    follow, and the joints follow the new state."""
    client, panel = browser
    client.update(client.wait_widget("Mechanism"), value="upr4")
    assert wait_for(lambda: (session.scenario.mechanism, session.scenario.planner)
                    == ("upr4", "pid"))  # fmt: skip
    assert wait_for(lambda: viewer.scene.mechanism_name == "upr4")
    scene = viewer.server.scene
    assert scene.get_handle_by_name("/target/tower") is None
    for name in ("/target/body", "/target/held_pad", "/base/top/pad", "/vessel/float_port"):
        assert scene.get_handle_by_name(name) is not None, name
    assert wait_for(lambda: panel.inputs["planner"].options == ("pid", "ik"))
    assert wait_for(lambda: panel.inputs["planner"].value == "pid")
    assert wait_for(lambda: not panel.inputs["kp"].disabled and not panel.inputs["sigma"].visible)
    session.step(5)
    assert wait_for(caught_up(viewer, session))
    cfg = joint_configuration(session.mechanism, session.latest()["state"])
    assert viewer.scene.joint_values == pytest.approx({k: float(v) for k, v in cfg.items()})


@pytest.mark.parametrize("mechanism", ["hybrid", "upu3up", "upr4"])
def test_views_frame_the_mechanism_and_its_target(mechanism: str) -> None:
    """Projected through each preset camera onto a 1200 × 760 window (viser's 75° field of
    view): the close-up has the mechanism and its target in the window, left of the control
    panel's third, and the overview draws the mechanism ≥ 80 px, the 3UPU_UP's 1.3 m on its
    70 m ship too; the views differ."""
    session = LiveSession({"sea_state": 4, "mechanism": mechanism, "planner": None})
    session.pause()
    viewer = start_viewer(session, access=Access(), port=free_port(), graphics="light")
    try:
        session.step()
        fs = read_frame(session)
        assert fs is not None and fs.scenario.mechanism == mechanism
        poses = {view: viewer.scene.camera_pose(view, fs) for view in VIEWS}
    finally:
        viewer.stop()
        session.stop()
    assert len({tuple(np.round(p, 3)) for p, _ in poses.values()}) == len(VIEWS)
    width, height = 1200, 760
    for view, (position, look_at) in poses.items():
        assert np.all(np.isfinite(position)) and np.linalg.norm(position - look_at) > 1.0
        camera = SimpleNamespace(position=position, look_at=look_at, up_direction=(0, 0, 1),
                                 fov=FOV, aspect=width / height)  # fmt: skip
        if view == "close-up":
            shown = project(framed_points(fs), camera, width, height)
            assert np.all(shown >= 0) and np.all(shown[:, 1] <= height), shown
            assert np.all(shown[:, 0] <= 2 / 3 * width), shown  # clear of the panel
        if view == "overview":
            shown = project(mechanism_points(fs), camera, width, height)
            assert np.ptp(shown, axis=0).max() >= 80.0


def test_the_trail_magnification_fits_the_error_to_the_mechanism() -> None:
    """A power of ten from ×1 to ×10 000 that draws the largest deviation within half the
    mechanism's size: a tip held to 0.1 mm on a 2.65 m mechanism ×10 000, one 3 mm off ×100,
    one a metre off at true size; the label says what a millimetre draws as."""
    assert [trail_magnification(d, 2.65) for d in (0.0, 1e-4, 3e-3, 1.0)] == [
        1e4, 1e4, 100.0, 1.0]  # fmt: skip
    for d in (1e-5, 2e-3, 0.05, 0.4):
        assert trail_magnification(d, 2.65) * d <= 0.5 * 2.65
    assert trail_label(100.0) == "tip error ×100 (1 mm draws as 100 mm)"


def test_leg_colours_go_green_to_red() -> None:
    """Mid-stroke legs are green, legs at or beyond a limit red."""
    green, red, beyond = margin_colours(np.array([1.0, 0.0, -0.5]))
    assert green[1] > green[0] and red[0] > red[1] and np.array_equal(beyond, red)


@pytest.mark.parametrize("mechanism", ["hybrid", "upu3up", "upr4"])
def test_tip_error_is_where_the_landing_point_is_from_where_it_is_held(mechanism: str) -> None:
    """For every mechanism the trail, the readout and the plot show one quantity: the landing
    point's distance from its held place, the point the scene draws (the platform top's node,
    or the gangway tip); in mm, under a trail label that states its magnification. The 4-UPR
    pad drifts off its held pose by centimetres or more at sea state 4, and reads so, though
    the recorded tip error (against the level state it can reach) is under a micrometre."""
    session = LiveSession({"sea_state": 4, "mechanism": mechanism, "planner": None})
    session.pause()
    viewer = start_viewer(session, access=Access(), port=free_port(), graphics="light")
    client, _ = connect(viewer)  # the scene is drawn for a browser
    try:
        offsets = []
        for _ in range(6):
            session.step(40)
            assert wait_for(caught_up(viewer, session), 10.0)
            fs = viewer.scene.last
            assert fs is not None
            T_IB = pose_to_transform(fs.record["base_pose"])
            if mechanism == "hybrid":
                drawn = (T_IB @ fs.mechanism.end_effector(fs.state))[:3, 3]
                np.testing.assert_allclose(  # the record's e = x_d − x, in the base frame
                    fs.landing_offset, -T_IB[:3, :3] @ fs.record["tip_error"][:3], atol=1e-9
                )
            else:  # the top node's pose in the base node's, in the world
                base = tf.SE3.from_rotation_and_translation(
                    tf.SO3(viewer.scene.base.wxyz), viewer.scene.base.position
                )
                top = tf.SE3.from_rotation_and_translation(
                    tf.SO3(viewer.scene.top.wxyz), viewer.scene.top.position
                )
                drawn = (base @ top).translation()
            np.testing.assert_allclose(fs.landing_offset, drawn - fs.held[:3, 3], atol=1e-6)
            trail_end = viewer.scene.trail.handle.points[-1, 1]
            np.testing.assert_allclose(
                trail_end, fs.held[:3, 3] + viewer.scene.trail_scale * fs.landing_offset,
                atol=1e-4,
            )
            offsets.append(np.linalg.norm(fs.landing_offset))
            readout = viewer.gui._readout(fs)
            assert f"tip error now: {mm(offsets[-1])}" in readout
            assert " nm" not in readout.split("orientation")[0]
            assert viewer.scene.trail_label.text == trail_label(viewer.scene.trail_scale)
        if mechanism == "upr4":
            assert max(offsets) > 0.01  # [m] visibly off its held pose
            assert np.linalg.norm(fs.record["tip_error"][:3]) < 1e-6  # what it read before
    finally:
        client.close()
        viewer.stop()
        session.stop()
