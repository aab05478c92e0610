"""The viser scene and GUI of a real viewer on a real live session, driven by raw websocket
clients speaking viser's protocol (tests/web/viser_client.py), as a script or a hostile page
would: no browser (test_browser.py has one)."""

from __future__ import annotations

import dataclasses
import http.client
import json
import socket
import time
from collections.abc import Callable, Iterator
from functools import partial
from types import SimpleNamespace

import numpy as np
import pytest
import viser.transforms as tf
import yourdfpy

from tests.figures import record
from tests.web.support import TOKEN, free_port, wait_for
from tests.web.test_browser_scene import project
from tests.web.viser_client import ViserClient
from twin.assets import asset_path
from twin.errors import TwinError
from twin.mechanisms.urdf import joint_configuration
from twin.planners import PlannerParameters
from twin.sim.kernels.layout import P_HOLD
from twin.sim.live import LiveSession
from twin.spatial import matrix_to_wxyz, pose_to_transform
from twin.web.access import Access
from twin.web.frame import read_frame
from twin.web.gui import (
    PLANNER_KNOBS,
    SWEEP_SETTINGS,
    ClientPanel,
    knob,
    limit_violations,
    mm,
    sweep_text,
)
from twin.web.scene import (
    AMBIENT,
    FOV,
    GRAPHICS,
    PAINT_METALLIC,
    RENDERER_PATH,
    TRAIL_MAGNIFICATION,
    VIEWS,
    Viewer,
    framed_points,
    margin_colours,
    mechanism_points,
    mount_transform,
    painted_urdf,
    start_viewer,
    trail_label,
)


@pytest.fixture
def session() -> Iterator[LiveSession]:
    """A paused session: the tests step it, the viewer's render loop only reads it."""
    live = LiveSession({"sea_state": 3})
    live.pause()
    yield live
    live.stop()


@pytest.fixture
def viewer(session: LiveSession) -> Iterator[Viewer]:
    handle = start_viewer(session, port=free_port())
    yield handle
    handle.stop()


def connect(viewer: Viewer, origin: str | None = None) -> tuple[ViserClient, ClientPanel]:
    """A raw client that announces itself, and the panel the viewer built for it."""
    before = set(viewer.gui.panels)
    client = ViserClient(viewer.port, origin=origin)
    client.hello()
    assert wait_for(lambda: set(viewer.gui.panels) - before, 10.0), "no panel was built"
    (client_id,) = set(viewer.gui.panels) - before
    client.wait_widget("Reset")  # the panel has reached the client
    return client, viewer.gui.panels[client_id]


@pytest.fixture
def browser(viewer: Viewer) -> Iterator[tuple[ViserClient, ClientPanel]]:
    client, panel = connect(viewer)
    yield client, panel
    client.close()


def caught_up(viewer: Viewer, session: LiveSession) -> Callable[[], bool]:
    """The scene shows the session's newest sample."""
    t = float(session.latest()["t"])
    return lambda: viewer.scene.last is not None and viewer.scene.last.t == t


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


@pytest.mark.parametrize("graphics", GRAPHICS)
def test_graphics_reach_a_browser(session: LiveSession, graphics: str) -> None:
    """A browser of a "light" viewer is told to drop the environment map and every shadow and
    gets the sky's ambient light; a "full" viewer sends viser's built-in map ("city") and
    the sun's shadows, and no ambient light. Both replace viser's overhead key light with a
    low sun (`configure_graphics`), and both ask the page for its WebGL renderer."""
    viewer = start_viewer(session, port=free_port(), graphics=graphics)
    try:
        with ViserClient(viewer.port) as client:
            client.hello()
            client.wait_widget("Reset")
            assert wait_for(lambda: any(m["type"] == "RunJavascriptMessage"
                                        for m in list(client.received)), 10.0)  # fmt: skip
            with client._lock:
                received = list(client.received)
    finally:
        viewer.stop()
    maps = [m for m in received if m["type"] == "EnvironmentMapMessage"]
    lights = [m for m in received if m["type"] == "EnableLightsMessage"]
    ambient = [m for m in received if m["type"] == "AmbientLightMessage"]
    sun = [m for m in received if m["type"] == "DirectionalLightMessage" and m["name"] == "/sun"]
    scripts = [m["source"] for m in received if m["type"] == "RunJavascriptMessage"]
    assert [(m["enabled"], m["cast_shadow"]) for m in lights] == [(False, False)]
    assert [m["name"] for m in ambient] == ["/sky_light"]
    (sun,) = sun
    (script,) = scripts
    assert RENDERER_PATH[1:] in script and "WEBGL_debug_renderer_info" in script
    if graphics == "light":
        assert [m["hdri_data"] for m in maps] == [None]
        assert ambient[0]["props"]["intensity"] == AMBIENT > 0
        assert sun["props"]["cast_shadow"] is False
    else:
        assert len(maps) == 1 and maps[0]["hdri_data"] is not None
        assert ambient[0]["props"]["intensity"] == 0.0
        assert sun["props"]["cast_shadow"] is True


def test_unknown_graphics_are_refused_before_anything_starts(session: LiveSession) -> None:
    port = free_port()
    with pytest.raises(TwinError, match="graphics 'fancy' unknown; one of: full, light"):
        start_viewer(session, port=port, graphics="fancy")
    with socket.socket() as probe:  # the port was never bound
        probe.bind(("127.0.0.1", port))


def test_urdf_frames_follow_the_session(viewer: Viewer, session: LiveSession) -> None:
    """After steps, every URDF joint frame equals yourdfpy's forward kinematics of
    `joint_configuration` of the newest state, and the base frame the base pose."""
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


def test_vessel_is_the_base_pose_without_the_mount(viewer: Viewer, session: LiveSession) -> None:
    """ᴵT_V · ᵛT_B = ᴵT_B: the hull moves with the base it carries."""
    session.step(10)
    assert wait_for(caught_up(viewer, session))
    vessel = viewer.server.scene.get_handle_by_name("/vessel")
    T_IV = np.eye(4)
    T_IV[:3, :3], T_IV[:3, 3] = tf.SO3(vessel.wxyz).as_matrix(), vessel.position
    T_IB = pose_to_transform(session.latest()["base_pose"])
    np.testing.assert_allclose(T_IV @ mount_transform("hybrid"), T_IB, atol=1e-9)


def test_sea_and_trail_animate(viewer: Viewer, session: LiveSession) -> None:
    """The sea mesh's vertices and the trail move with simulated time (same nodes)."""
    ocean = viewer.server.scene.get_handle_by_name("/ocean")
    before, trail = np.array(ocean.vertices), np.array(viewer.scene.trail.handle.points)
    session.step(10)
    assert wait_for(caught_up(viewer, session))
    assert viewer.server.scene.get_handle_by_name("/ocean") is ocean
    assert np.abs(ocean.vertices - before).max() > 1e-3
    assert np.abs(viewer.scene.trail.handle.points - trail).max() > 0.0


def test_slider_patches_the_session(
    browser: tuple[ViserClient, ClientPanel], session: LiveSession
) -> None:
    """A browser's edit goes through `session.patch`, and the session's value is what shows."""
    client, _ = browser
    client.update(client.wait_widget("β"), value=0.3)
    assert wait_for(lambda: session.scenario.beta == 0.3)
    client.update(client.wait_widget("Sim speed ×"), value=2.0)
    assert wait_for(lambda: session.controls.speed == 2.0)
    client.update(client.wait_widget("Planner"), value="wpi")
    assert wait_for(lambda: session.scenario.planner == "wpi")


def test_rest_patch_moves_the_widgets_without_feedback(
    viewer: Viewer,
    session: LiveSession,
    browser: tuple[ViserClient, ClientPanel],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A patch from elsewhere (REST) moves a browser's sliders and dropdowns within a few
    frames, and showing it sends nothing back to the session."""
    _, panel = browser
    calls: list[dict] = []
    patch = session.patch
    monkeypatch.setattr(session, "patch", lambda changes: calls.append(changes) or patch(changes))
    session.patch({"beta": 0.45, "sea_state": 5.0, "planner": "wpi", "speed": 4.0})
    inputs = panel.inputs
    assert wait_for(
        lambda: (inputs["beta"].value, inputs["sea_state"].value, inputs["planner"].value,
                 inputs["speed"].value) == (0.45, 5.0, "wpi", 4.0)
    )  # fmt: skip
    frames = viewer.frames
    assert wait_for(lambda: viewer.frames >= frames + 3)
    assert len(calls) == 1  # the GUI did not echo the values back
    assert inputs["k_c"].visible and inputs["k_c"].disabled  # WPI does not read k_c
    assert not inputs["sigma"].visible and not inputs["beta"].disabled


def test_bad_value_notifies_and_reverts(
    viewer: Viewer, session: LiveSession, browser: tuple[ViserClient, ClientPanel]
) -> None:
    """A value the session refuses changes nothing and the widget shows the value in force."""
    client, panel = browser
    client.update(client.wait_widget("β"), value=5.0)
    assert wait_for(lambda: "beta" in (viewer.gui.last_error or ""))
    assert session.scenario.beta == 0.7
    assert wait_for(lambda: panel.inputs["beta"].value == 0.7)
    assert wait_for(lambda: any("Not applied" in n for n in client.notifications()))


def test_buttons_drive_the_session(
    session: LiveSession, browser: tuple[ViserClient, ClientPanel]
) -> None:
    """Play, pause, step and reset call the session (sync callbacks run in viser's pool)."""
    client, _ = browser
    client.update(client.wait_widget("Step"), value=True)
    assert wait_for(lambda: float(session.latest()["t"]) == pytest.approx(0.05))
    client.update(client.wait_widget("Play"), value=True)
    assert wait_for(lambda: session.controls.playing)
    client.update(client.wait_widget("Pause"), value=True)
    assert wait_for(lambda: not session.controls.playing)
    version = session.version
    client.update(client.wait_widget("Reset"), value=True)
    assert wait_for(lambda: session.version == version + 1)


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


def test_render_loop_runs_at_30_fps(viewer: Viewer, session: LiveSession) -> None:
    """The loop counts its own frames: ≥ 25 in 1 s.

    It is paced to FPS = 40 and measured 39-40 frames/s on an idle 2-core machine with the
    session playing; 25 leaves room for a loaded test machine while still failing a loop
    that renders far below the 30 fps the issue asks for (e.g. one blocked on a client).
    """
    session.play()
    frames = viewer.frames
    time.sleep(1.0)
    assert viewer.frames - frames >= 25


@pytest.mark.parametrize("mechanism", ["hybrid", "upu3up", "upr4"])
def test_views_frame_the_mechanism_and_its_target(mechanism: str) -> None:
    """Projected through each preset camera onto a 1200 × 760 window (viser's 75° field of
    view): the close-up has the mechanism and its target in the window, left of the control
    panel's third, and the overview draws the mechanism ≥ 80 px, the 3UPU_UP's 1.3 m on its
    70 m ship too; the views differ."""
    session = LiveSession({"sea_state": 4, "mechanism": mechanism, "planner": None})
    session.pause()
    viewer = start_viewer(session, port=free_port(), graphics="light")
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


def test_limit_readout_names_the_violation(session: LiveSession) -> None:
    """A leg beyond its stroke and a state outside its limits are reported by name."""
    fs = read_frame(session)
    assert fs is not None and limit_violations(fs) == []
    lengths = fs.leg_lengths.copy()
    lengths[2] = fs.leg_max[2] + 0.1
    record = {**fs.record, "xi": np.r_[fs.state[:8], 99.0]}
    bad = dataclasses.replace(fs, leg_lengths=lengths, record=record)
    text = "; ".join(limit_violations(bad))
    assert "leg 3" in text and "d3" in text


def test_leg_colours_go_green_to_red() -> None:
    """Mid-stroke legs are green, legs at or beyond a limit red."""
    green, red, beyond = margin_colours(np.array([1.0, 0.0, -0.5]))
    assert green[1] > green[0] and red[0] > red[1] and np.array_equal(beyond, red)


def test_knob_ranges_come_from_the_fields() -> None:
    """Slider ranges and defaults are the pydantic constraints (a strict bound moves a step)."""
    beta = knob(PlannerParameters, "beta", "β")
    assert (beta.min, beta.max, beta.default, beta.slider) == (0.0, 1.0, 0.7, True)
    rate = knob(PlannerParameters, "q1_rate_max", "q̇1,max")  # 0 < q1_rate_max ≤ 45
    assert rate.min == pytest.approx(rate.step) and rate.max == 45.0
    assert {k.name for k in PLANNER_KNOBS} == set(PlannerParameters.model_fields)
    ki = next(k for k in PLANNER_KNOBS if k.name == "ki")
    assert not ki.slider  # 8e-4 is off a 0-200 slider's grid: a number box keeps it


def test_a_cross_origin_websocket_is_refused(viewer: Viewer, session: LiveSession) -> None:
    """A page from another origin (or under a DNS name of its own) cannot open the viewer's
    websocket: 403 at the handshake, so it reads nothing and sends nothing. The viewer's own
    origin, and a script without Origin, connect."""
    from websockets.exceptions import InvalidStatus

    before = (session.scenario, session.controls.model_dump(), session.version)
    refused = []
    for origin in ("http://evil.example", f"http://evil.example:{viewer.port}", "null",
                   f"https://127.0.0.1:{viewer.port}", "http://127.0.0.1:1"):  # fmt: skip
        with pytest.raises(InvalidStatus) as exc:
            ViserClient(viewer.port, origin=origin)
        refused.append(exc.value.response.status_code)
    assert refused == [403] * 5
    own = f"http://127.0.0.1:{viewer.port}"
    with pytest.raises(InvalidStatus) as exc:  # two Origins, even both its own, are none
        ViserClient(viewer.port, origin=[own, own])
    assert exc.value.response.status_code == 403
    assert (session.scenario, session.controls.model_dump(), session.version) == before
    for origin in (f"http://127.0.0.1:{viewer.port}", f"http://localhost:{viewer.port}", None):
        ViserClient(viewer.port, origin=origin).close()
    record("attack_cross_origin_websocket", origins_tried=len(refused), handshake=403,
           changed="nothing")  # fmt: skip


def get(port: int, path: str, host: str | None) -> tuple[int, str]:
    """`GET path` from the viewer's port with exactly this Host header (None: none at all), as
    a page under another DNS name (DNS rebinding) would send it: (status, body)."""
    connection = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
    try:
        connection.putrequest("GET", path, skip_host=True)
        if host is not None:
            connection.putheader("Host", host)
        connection.endheaders()
        response = connection.getresponse()
        return response.status, response.read().decode("utf-8", "replace")
    finally:
        connection.close()


def test_a_spoofed_host_is_refused_on_the_viewer_port(
    viewer: Viewer, session: LiveSession, caplog: pytest.LogCaptureFixture
) -> None:
    """The viewer's port passes the REST API's Host check: a websocket handshake or a page
    request whose Host is not one of the server's names (a DNS-rebinding page, whatever its
    Origin) or is missing gets 400 naming it, builds no panel and changes nothing. Its own
    names, with and without the port, are served."""
    from websockets.exceptions import InvalidStatus

    port = viewer.port
    before = (session.scenario, session.controls.model_dump(), session.version)
    panels = set(viewer.gui.panels)
    refused = []
    for host, origin in (("evil.example", None), (f"evil.example:{port}", None),
                         (f"evil.example:{port}", f"http://evil.example:{port}"),
                         (f"evil.example:{port}", f"http://127.0.0.1:{port}"),
                         (f"127.0.0.1.evil.example:{port}", None)):  # fmt: skip
        with caplog.at_level("WARNING", logger="twin.web.scene"):
            with pytest.raises(InvalidStatus) as exc:
                ViserClient(port, origin=origin, host=host)
        response = exc.value.response
        refused.append(response.status_code)
        assert repr(host) in response.body.decode() and "--allow-host" in response.body.decode()
    assert refused == [400] * 5
    assert sum("viewer: request for Host" in r.getMessage() for r in caplog.records) == 5
    time.sleep(0.3)  # a handshake that got through would have built a panel by now
    assert set(viewer.gui.panels) == panels
    assert (session.scenario, session.controls.model_dump(), session.version) == before
    # the page (and anything else on the port) alike; without a Host too
    pages = [get(port, path, host) for path in ("/", "/index.html", "/assets/index.js")
             for host in ("evil.example", f"evil.example:{port}", None)]  # fmt: skip
    assert [status for status, _ in pages] == [400] * 9
    assert "'evil.example'" in pages[0][1] and "None" in pages[2][1]
    assert all("<html" not in body for _, body in pages)
    for host in (f"127.0.0.1:{port}", f"localhost:{port}", "localhost", f"[::1]:{port}"):
        status, body = get(port, "/", host)
        assert (status, "<html" in body) == (200, True), host
    ViserClient(port, origin=f"http://127.0.0.1:{port}", host=f"127.0.0.1:{port}").close()
    ViserClient(port, host=f"localhost:{port}").close()
    record("attack_viewer_host_spoofing", handshakes_tried=len(refused), handshake=400,
           page_requests_tried=len(pages), page=400, changed="nothing")  # fmt: skip


def test_an_allowed_host_reaches_the_viewer(session: LiveSession) -> None:
    """A name given with `--allow-host` (`Access.for_server(allow_hosts=...)`) is served on
    the viewer's port, page and websocket; other names are still refused."""
    from websockets.exceptions import InvalidStatus

    port = free_port()
    access = Access.for_server("127.0.0.1", (port,), allow_hosts=("twin.example",))
    viewer = start_viewer(session, port=port, access=access)
    try:
        port = viewer.port
        status, body = get(port, "/", f"twin.example:{port}")
        assert (status, "<html" in body) == (200, True)
        assert get(port, "/", "TWIN.example")[0] == 200  # a host name is case-insensitive
        assert get(port, "/", f"evil.example:{port}")[0] == 400
        before = set(viewer.gui.panels)
        client = ViserClient(
            port, origin=f"http://twin.example:{port}", host=f"twin.example:{port}"
        )
        client.hello()
        assert wait_for(lambda: set(viewer.gui.panels) - before, 10.0), "no panel was built"
        client.close()
        with pytest.raises(InvalidStatus) as exc:
            ViserClient(port, host=f"evil.example:{port}")
        assert exc.value.response.status_code == 400
    finally:
        viewer.stop()


def test_a_locked_browsers_writes_change_nothing(session: LiveSession) -> None:
    """With a token, a browser that has not unlocked sees read-only controls. Whatever it
    sends - a value, a hostile property (`update_cb`, `removed`), another browser's widget id,
    a share-tunnel request - changes neither the session nor another browser's widgets. After
    a wrong token (rate-limited) and the right one, its edits apply."""
    from viser import _messages

    viewer = start_viewer(session, port=free_port(), access=Access(token=TOKEN, failure_burst=2))
    try:
        attacker, locked = connect(viewer)
        operator, panel = connect(viewer)
        assert viewer.gui.unlock(panel.client, TOKEN) is True
        assert all(h.disabled for h in locked.inputs.values())  # read-only for it
        assert not panel.inputs["beta"].disabled
        before = (session.scenario, session.controls.model_dump(), session.version)
        beta = attacker.wait_widget("β")
        attacker.update(beta, value=0.3)
        attacker.update(attacker.wait_widget("Pause"), value=True)
        attacker.update(attacker.wait_widget("Reset"), value=True)
        attacker.update(beta, update_cb=[])  # on shared handles: every browser's β dead
        attacker.update(attacker.wait_widget("Planner"), removed=True)
        attacker.update(operator.wait_widget("β"), value=0.1)  # the operator's widget id
        attacker.send(_messages.ShareUrlRequest())
        assert wait_for(lambda: "locked" in (viewer.gui.last_error or ""), 5.0)
        time.sleep(0.5)
        assert (session.scenario, session.controls.model_dump(), session.version) == before
        assert viewer.server._share_tunnel is None
        assert wait_for(lambda: locked.inputs["beta"].value == 0.7)  # undone, for it alone
        # the operator's controls still work
        operator.update(operator.wait_widget("β"), value=0.45)
        assert wait_for(lambda: session.scenario.beta == 0.45)
        operator.update(operator.wait_widget("Planner"), value="wpi")
        assert wait_for(lambda: session.scenario.planner == "wpi")
        # unlocking: wrong tokens are refused, then the same kind again rate-limited; the
        # right one never is, whatever others' failures from its address (issue 30)
        answers = [viewer.gui.unlock(locked.client, "a" * 16) for _ in range(3)]
        assert all(isinstance(a, str) for a in answers) and "too many" in answers[-1]
        assert viewer.gui.unlock(locked.client, TOKEN) is True
        assert not locked.inputs["speed"].disabled
        attacker.update(attacker.wait_widget("Sim speed ×"), value=2.0)  # its β it broke itself
        assert wait_for(lambda: session.controls.speed == 2.0)
        attacker.close()
        operator.close()
    finally:
        viewer.stop()
    record("attack_locked_widget_write", messages=7, changed="nothing",
           operator_controls="still apply")  # fmt: skip


def test_nan_base_motion_never_reaches_the_scene_and_the_readout_flags_it(
    nan_sea: Callable[[float, float], None],
) -> None:
    """A NaN sea window: every node the scene moves stays finite, and the panel says so."""
    nan_sea(0.22, 0.58)
    session = LiveSession({"sea_state": 3})
    session.pause()
    viewer = start_viewer(session, port=free_port())
    try:
        session.step(10)  # t = 0.5: inside the window
        assert wait_for(caught_up(viewer, session))
        scene = viewer.scene
        for node in (scene.vessel, scene.base, scene.top):
            assert np.all(np.isfinite(node.position)) and np.all(np.isfinite(node.wxyz))
        assert np.all(np.isfinite(scene.legs.points))
        assert wait_for(lambda: "⚠ Faults:** base motion" in viewer.gui.readout.content, 5.0)
    finally:
        viewer.stop()
        session.stop()


def test_joint_limits_dropdown_switches_hold_and_record(
    session: LiveSession, browser: tuple[ViserClient, ClientPanel]
) -> None:
    """The live session starts holding at the limits; the dropdown switches without a reset."""
    client, _ = browser
    assert session.scenario.joint_limits == "hold" and session._sim.prm[0, P_HOLD] == 1.0
    client.update(client.wait_widget("Joint limits"), value="record")
    assert wait_for(lambda: session.scenario.joint_limits == "record")
    assert session._sim.prm[0, P_HOLD] == 0.0 and session.version == 0


def test_readout_keeps_held_steps_limit_handling_and_violations_apart(
    session: LiveSession,
) -> None:
    """Steps shortened at a limit are not faults nor violations; a state held on its limit is
    within it (a tolerance of its range), one beyond it prints with the digits that show by how
    much; no quantity prints with an exponent."""
    from twin.web.gui import fault_line, limit_line, si

    faults = {"counts": {"base_motion": 0, "planner": 0, "kinematics": 0, "joint_limit": 107,
                         "singular": 3}, "held": 0, "events": [], "loop_errors": 0}  # fmt: skip
    assert fault_line(faults) == "**Faults:** none (no step held)"
    assert "stopped at a limit 107" in limit_line(faults, "hold")
    assert "damped near a singularity 3" in limit_line(faults, "hold")
    assert [si(2.5, "m"), si(0.0025, "m"), si(2.5e-6, "m"), si(1234.0, "m")] == [
        "2.50 m", "2.50 mm", "2.50 µm", "1.23 km"]  # fmt: skip

    session.patch({"mechanism": "upu3up", "planner": None})
    fs = read_frame(session)
    assert fs is not None
    high = fs.mechanism.state_limits[1][0]  # z [mm]
    on_limit = dataclasses.replace(fs, record={**fs.record, "state": np.r_[high, fs.state[1:]]})
    assert limit_violations(on_limit) == []
    beyond = dataclasses.replace(fs, record={**fs.record,
                                             "state": np.r_[high + 0.5, fs.state[1:]]})  # fmt: skip
    (line,) = limit_violations(beyond)
    assert line.startswith("z: ") and "mm >" in line and "e+" not in line
    assert f"{high + 0.5:.3f}" in line


def test_a_locked_browser_cannot_compare_replay_or_sweep(session: LiveSession, tmp_path) -> None:
    """With a token and a run store, a locked browser's new controls (Compare with, the
    replay's run, time and buttons, the sweep's settings and button) are read-only, and what
    it sends anyway changes nothing: no second lane, no replay, no sweep stored."""
    from twin.sim import Scenario, simulate
    from twin.web.jobs import SweepRunner
    from twin.web.store import RunStore

    with RunStore(tmp_path / "runs.sqlite") as store:
        scenario = Scenario(duration=1.0)
        run = store.create(scenario)
        store.finish(run.id, simulate(scenario))
        viewer = start_viewer(session, port=free_port(), access=Access(token=TOKEN),
                              store=store, sweeps=SweepRunner(store))  # fmt: skip
        try:
            attacker, locked = connect(viewer)
            assert wait_for(lambda: len(locked.settings["replay_run"].options) == 2, 10.0)
            handles = [locked.inputs["compare_planner"], *locked.settings.values(),
                       *(locked.buttons[b] for b in ("Watch in 3D", "Back to live", "Run sweep"))]
            assert all(h.disabled for h in handles)
            attacker.update(attacker.wait_widget("Compare with"), value="pi")
            attacker.update(attacker.wait_widget("Stored run"),
                            value=locked.settings["replay_run"].options[1])  # fmt: skip
            attacker.update(attacker.wait_widget("Watch in 3D"), value=True)
            attacker.update(attacker.wait_widget("Replay time [s]"), value=0.5)
            attacker.update(attacker.wait_widget("Run sweep"), value=True)
            assert wait_for(lambda: "locked" in (viewer.gui.last_error or ""), 5.0)
            time.sleep(0.5)
            assert session.compare_planner is None and session.replaying is None
            assert store.pending("sweeps") == 0 and viewer.gui.sweep_id is None
            assert wait_for(lambda: locked.inputs["compare_planner"].value == "none")
            # the sweep's grid settings: each edit refused (a notification each) and undone
            grid = {
                "Hs cells": ("sweep_hs_points", 9, 5),
                "Hs span [±%]": ("sweep_hs_span", 90.0, 50.0),
                "Tp cells": ("sweep_tp_points", 7, 3),
                "Tp span [± s]": ("sweep_tp_span", 5.0, 2.0),
            }
            for label, (name, sent, kept) in grid.items():
                refused = len(attacker.notifications())
                attacker.update(attacker.wait_widget(label), value=sent)
                assert wait_for(lambda n=refused: len(attacker.notifications()) > n, 5.0), label
                assert wait_for(lambda name=name, kept=kept: locked.settings[name].value == kept)
            attacker.close()
        finally:
            viewer.stop()


def test_the_sweep_grid_comes_from_the_panel(session: LiveSession, tmp_path) -> None:
    """A browser's Operability settings (Hs and Tp cells and spans, seeds, run length) are the
    grid of the sweep it starts, around the current sea, and it is told how many runs that
    is; a grid `spec_around` refuses (a hostile value past a slider's range) starts nothing and
    says why."""
    from twin.sim.sweep import SweepSpec
    from twin.web.jobs import SweepRunner
    from twin.web.store import RunStore

    with RunStore(tmp_path / "runs.sqlite") as store:
        # a runner never started: the sweep stays queued, its spec as the panel submitted it
        viewer = start_viewer(session, port=free_port(), store=store, sweeps=SweepRunner(store))
        try:
            client, panel = connect(viewer)
            assert {name: panel.settings[name].value for name in SWEEP_SETTINGS} == {
                "sweep_hs_points": 5, "sweep_hs_span": 50.0, "sweep_tp_points": 3,
                "sweep_tp_span": 2.0, "sweep_seeds": 2, "sweep_duration": 60.0,
            }  # fmt: skip
            # past the slider's range, as a script could send: refused by name, nothing stored
            client.update(client.wait_widget("Tp cells"), value=12)
            assert wait_for(lambda: panel.settings["sweep_tp_points"].value == 12)
            client.update(client.wait_widget("Run sweep"), value=True)
            assert wait_for(lambda: any("Sweep not started: tp_points: got 12" in n
                                        for n in client.notifications()), 5.0)  # fmt: skip
            assert store.pending("sweeps") == 0 and viewer.gui.sweep_id is None

            chosen = {"Hs cells": 7, "Hs span [±%]": 30.0, "Tp cells": 5, "Tp span [± s]": 1.0,
                      "Seeds per cell": 3, "Run length [s]": 20.0}  # fmt: skip
            for label, value in chosen.items():
                client.update(client.wait_widget(label), value=value)
            assert wait_for(lambda: [panel.settings[name].value for name in SWEEP_SETTINGS]
                            == list(chosen.values()))  # fmt: skip
            client.update(client.wait_widget("Run sweep"), value=True)
            assert wait_for(lambda: viewer.gui.sweep_id is not None, 10.0)
            sweep = store.get_sweep(viewer.gui.sweep_id)
            spec = SweepSpec(**sweep.spec)
            hs, tp = session.scenario.sea()
            assert (len(spec.hs), len(spec.tp), spec.seeds, spec.duration) == (7, 5, 3, 20.0)
            assert hs in spec.hs and tp in spec.tp  # the current sea is a cell
            assert (spec.hs[0], spec.hs[-1]) == pytest.approx((0.7 * hs, 1.3 * hs), rel=5e-3)
            assert (spec.tp[0], spec.tp[-1]) == pytest.approx((tp - 1.0, tp + 1.0), rel=5e-3)
            assert sweep.total == 7 * 5 * 3 and store.pending("sweeps") == 1
            assert wait_for(lambda: any("Hs 7 × Tp 5 cells × 3 seeds = 105 runs of 20 s" in n
                                        for n in client.notifications()), 5.0)  # fmt: skip
            client.close()
        finally:
            viewer.stop()


def test_the_panel_compares_planners_and_replays_a_stored_run(
    session: LiveSession, tmp_path
) -> None:
    """Compare with adds the ghost (a second URDF on the same base) and dashed plot lines;
    none removes it. A stored run chosen and watched replays; Back to live returns."""
    from twin.sim import Scenario, simulate
    from twin.web.store import RunStore

    with RunStore(tmp_path / "runs.sqlite") as store:
        scenario = Scenario(duration=2.0, planner="wpi")
        run = store.create(scenario)
        store.finish(run.id, simulate(scenario))
        viewer = start_viewer(session, port=free_port(), store=store)
        try:
            client, panel = connect(viewer)
            client.update(client.wait_widget("Compare with"), value="pi")
            assert wait_for(lambda: session.compare_planner == "pi")
            assert wait_for(lambda: viewer.scene.ghost is not None, 5.0)
            assert viewer.server.scene.get_handle_by_name("/ghost_label") is not None
            assert wait_for(lambda: any("· pi" in str(s.get("label"))
                                        for p in viewer.gui.plots for s in p.series), 5.0)
            session.step(3)
            assert wait_for(caught_up(viewer, session))
            ghost_cfg = joint_configuration(session.mechanism, session.latest(1)["xi"])
            assert viewer.scene.last.ghost.cfg == pytest.approx(
                {k: float(v) for k, v in ghost_cfg.items()})  # fmt: skip
            # the ghost draws its own tip-error trail, at the main trail's magnification
            scene = viewer.scene
            assert viewer.server.scene.get_handle_by_name("/ghost_trail") is not None
            before = np.array(scene.ghost_trail.handle.points)
            session.step(20)
            assert wait_for(caught_up(viewer, session))
            after = np.array(scene.ghost_trail.handle.points)
            assert np.abs(after - before).max() > 0.0
            newest = scene.last.held[:3, 3] + scene.trail_scale * scene._tip_deviation(
                scene.last.ghost)
            np.testing.assert_allclose(after[-1, 1], newest, atol=1e-9)
            assert np.abs(after[-1, 1] - np.array(scene.trail.handle.points)[-1, 1]).max() > 0.0
            client.update(client.wait_widget("Compare with"), value="none")
            assert wait_for(lambda: viewer.scene.ghost is None, 5.0)
            assert viewer.server.scene.get_handle_by_name("/ghost_trail") is None
            assert viewer.scene.ghost_trail is None

            assert wait_for(lambda: len(panel.settings["replay_run"].options) == 2, 10.0)
            choice = panel.settings["replay_run"].options[1]
            client.update(client.wait_widget("Stored run"), value=choice)
            assert wait_for(lambda: panel.settings["replay_run"].value == choice)
            client.update(client.wait_widget("Watch in 3D"), value=True)
            assert wait_for(lambda: (session.replaying or {}).get("run_id") == run.id)
            assert wait_for(lambda: session.scenario.planner == "wpi")
            assert wait_for(lambda: panel.settings["replay_t"].max == 2.0, 5.0)
            client.update(client.wait_widget("Back to live"), value=True)
            assert wait_for(lambda: session.replaying is None)
            client.close()
        finally:
            viewer.stop()


def _renderer_key(client: ViserClient) -> str:
    """The key the viewer gave this connection's page for its renderer report."""
    assert wait_for(lambda: any(m["type"] == "RunJavascriptMessage" for m in list(client.received)))
    with client._lock:
        (source,) = [m["source"] for m in client.received if m["type"] == "RunJavascriptMessage"]
    return json.loads(source.split('url.searchParams.set("key", ', 1)[1].split(")", 1)[0])


def _report(port: int, key: str, renderer: str) -> int:
    """GET the renderer report as the page's fetch does; the HTTP status."""
    from urllib.parse import urlencode

    connection = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
    connection.request("GET", f"{RENDERER_PATH}?{urlencode({'key': key, 'renderer': renderer})}")
    status = connection.getresponse().status
    connection.close()
    return status


def test_a_software_renderer_report_switches_that_browser_to_light_graphics(
    viewer: Viewer,
) -> None:
    """A page reporting SwiftShader with its own key is switched to light graphics (its
    dropdown, an environment map of none, a notification); a report with a made-up key, or
    another browser's GPU, changes nothing; the browser's own dropdown switches it back to
    full (viser's environment map again), and a locked browser may do that too."""
    first, first_panel = connect(viewer)
    second, second_panel = connect(viewer)
    try:
        assert first_panel.graphics.value == second_panel.graphics.value == "full"
        assert _report(viewer.port, "made-up", "SwiftShader") == 200
        assert _report(viewer.port, _renderer_key(second), "ANGLE (NVIDIA GeForce RTX)") == 200
        time.sleep(0.5)
        assert first_panel.graphics.value == second_panel.graphics.value == "full"

        maps = lambda c: [m for m in list(c.received) if m["type"] == "EnvironmentMapMessage"]  # noqa: E731
        before = len(maps(first))
        renderer = "ANGLE (Google, Vulkan 1.3.0 (SwiftShader Device (Subzero)), SwiftShader driver)"
        assert _report(viewer.port, _renderer_key(first), renderer) == 200
        assert wait_for(lambda: first_panel.graphics.value == "light", 10.0)
        assert viewer.renderers[first_panel.client.client_id] == renderer
        assert wait_for(lambda: len(maps(first)) > before)
        assert maps(first)[-1]["hdri_data"] is None
        assert wait_for(lambda: any("Light graphics" in n for n in first.notifications()))
        assert second_panel.graphics.value == "full"  # the other browser keeps its own
        assert not any("Light graphics" in n for n in second.notifications())

        # the way back, from the browser's own dropdown
        first.update(first.wait_widget("Graphics"), value="full")
        assert wait_for(lambda: maps(first)[-1]["hdri_data"] is not None)
    finally:
        first.close()
        second.close()


def test_a_locked_browser_switches_its_own_graphics(session: LiveSession) -> None:
    """Graphics change what one browser draws, nothing else: a browser locked by the token
    still switches them."""
    viewer = start_viewer(session, port=free_port(), access=Access(token=TOKEN))
    try:
        client, panel = connect(viewer)
        assert panel.locked
        client.update(client.wait_widget("Graphics"), value="light")
        assert wait_for(lambda: any(m["type"] == "EnvironmentMapMessage" and m["hdri_data"] is None
                                    for m in list(client.received)))  # fmt: skip
        assert panel.graphics.value == "light"
        client.close()
    finally:
        viewer.stop()


@pytest.mark.parametrize("mechanism", ["hybrid", "upu3up", "upr4"])
def test_tip_error_is_where_the_landing_point_is_from_where_it_is_held(mechanism: str) -> None:
    """For every mechanism the trail, the readout and the plot show one quantity: the landing
    point's distance from its held place, the point the scene draws (the platform top's node,
    or the gangway tip); in mm, under a trail label whose magnification stays put. The 4-UPR
    pad drifts off its held pose by centimetres or more at sea state 4, and reads so, though
    the recorded tip error (against the level state it can reach) is under a micrometre."""
    session = LiveSession({"sea_state": 4, "mechanism": mechanism, "planner": None})
    session.pause()
    viewer = start_viewer(session, port=free_port(), graphics="light")
    try:
        label = viewer.scene.trail_label.text
        assert label == trail_label(TRAIL_MAGNIFICATION[mechanism])
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
                trail_end, fs.held[:3, 3] + TRAIL_MAGNIFICATION[mechanism] * fs.landing_offset,
                atol=1e-4,
            )
            offsets.append(np.linalg.norm(fs.landing_offset))
            readout = viewer.gui._readout(fs)
            assert f"tip error now: {mm(offsets[-1])}" in readout
            assert " nm" not in readout.split("orientation")[0]
            assert viewer.scene.trail_label.text == label  # fixed
        if mechanism == "upr4":
            assert max(offsets) > 0.01  # [m] visibly off its held pose
            assert np.linalg.norm(fs.record["tip_error"][:3]) < 1e-6  # what it read before
    finally:
        viewer.stop()
        session.stop()


def test_changing_the_compare_planner_says_live_time_restarted(
    viewer: Viewer, session: LiveSession
) -> None:
    """A compare planner set (or dropped) restarts live time at 0; the readout says so."""
    session.step(20)
    assert wait_for(caught_up(viewer, session))
    assert "restarted" not in viewer.gui.readout.content
    session.patch({"compare_planner": "pi"})
    assert wait_for(lambda: "Live time restarted at t = 0" in viewer.gui.readout.content, 5.0)
    assert "compare planner is now pi" in viewer.gui.readout.content
    session.patch({"compare_planner": None})
    assert wait_for(lambda: "compare planner was removed" in viewer.gui.readout.content, 5.0)


def test_sweep_text_counts_rightly_and_explains_a_cell() -> None:
    """One seed, one run: singular; the sea to 0.1 m and 0.1 s; short link texts; and why a
    cell can differ from the live run."""
    one = sweep_text("0123456789ab", 1, 1, 60.0, (1.8765, 6.84717), "http://h/api/sweeps/x")
    assert "1 run, 1 seed per cell" in one and "1 seeds" not in one and "1 runs" not in one
    assert "Hs 1.9 m, Tp 6.8 s" in one and "6.84717" not in one
    assert "[sweep 01234567](http://h/api/sweeps/x)" in one
    assert "[heatmap PNG](http://h/api/sweeps/x/heatmap.png)" in one
    assert "can differ from the live run" in one
    many = sweep_text("0123456789ab", 30, 2, 60.0, (1.0, 6.0), "http://h/api/sweeps/x")
    assert "30 runs, 2 seeds per cell" in many
