"""The live twin's 3D viewer in viser, one module per concern.

- `viewer`: `start_viewer` and `Viewer`, the render loop (it rests while no browser is
  connected);
- `scene`: the scene's nodes per mechanism and per frame (`TwinScene`, the tip-error `Trail`);
- `frame_state`: one reading of the live session per render frame (`read_frame` →
  `FrameState`), which the scene, the cameras and the GUI draw from;
- `meshes`: the static geometry (sea grid, vessel, targets); `urdf`: the painted mechanism
  (`LiveUrdf`); `cameras`: the camera presets; `graphics`: lights and WebGL renderer checks;
- `gui`: the control panel (`TwinGui`), with `panel` (one browser's controls, `ClientPanel`),
  `knobs` (widgets from pydantic fields), `plots`, `readout`, `replay` and `operability`;
- `handshake`: the Host and Origin checks of the viewer's port; `viser_adapter`: the only
  module that touches viser's private internals.

Re-exported here: what the rest of the twin (`twin.web.server`), its tests and benchmarks use.
"""

from twin.web.viewer.cameras import FOV, FRAMING, VIEWS, framed_points, mechanism_points
from twin.web.viewer.graphics import (
    AMBIENT,
    GRAPHICS,
    RENDERER_PATH,
    check_graphics,
    configure_graphics,
    software_renderer,
)
from twin.web.viewer.gui import TwinGui
from twin.web.viewer.knobs import PLANNER_KNOBS, knob
from twin.web.viewer.meshes import hull_parts, mount_transform
from twin.web.viewer.operability import SWEEP_SETTINGS, sweep_text
from twin.web.viewer.panel import ClientPanel
from twin.web.viewer.readout import fault_line, limit_line, limit_violations, mm, si
from twin.web.viewer.scene import (
    TwinScene,
    margin_colours,
    trail_label,
    trail_magnification,
)
from twin.web.viewer.urdf import PAINT_METALLIC, painted_urdf
from twin.web.viewer.viewer import FPS, Viewer, start_viewer

__all__ = [
    "AMBIENT",
    "FOV",
    "FPS",
    "FRAMING",
    "GRAPHICS",
    "PAINT_METALLIC",
    "PLANNER_KNOBS",
    "RENDERER_PATH",
    "SWEEP_SETTINGS",
    "VIEWS",
    "ClientPanel",
    "TwinGui",
    "TwinScene",
    "Viewer",
    "check_graphics",
    "configure_graphics",
    "fault_line",
    "framed_points",
    "hull_parts",
    "knob",
    "limit_line",
    "limit_violations",
    "margin_colours",
    "mechanism_points",
    "mm",
    "mount_transform",
    "painted_urdf",
    "si",
    "software_renderer",
    "start_viewer",
    "sweep_text",
    "trail_label",
    "trail_magnification",
]
