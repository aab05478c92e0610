"""What the browsers render: the lights of each graphics mode, the sun's place, and the
detection of a browser that draws WebGL on the CPU (switched to "light" graphics).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from twin.errors import TwinError
from twin.sim.registries import WaveComponents
from twin.web.viewer.meshes import SKY

#: what the browsers render (`configure_graphics`): "full" lights the scene
#: with an environment map (image-based reflections) and casts the sun's shadows (three
#: cascaded shadow maps, each drawing the scene again); "light" drops both, for a browser
#: without a GPU (a remote desktop, a virtual machine: WebGL on the CPU), where the
#: environment map costs most of each frame. The server's `--graphics` is every browser's
#: start; each browser switches its own (View → Graphics), and one that reports a software
#: renderer is switched to "light" (`twin.web.viewer.Viewer.report_renderer`)
GRAPHICS = ("full", "light")

#: [-] the ambient light of "light" graphics, in place of the environment map: low enough
#: that the sun's shading of the wave slopes shows (at 1.2 it washed the sea flat)
AMBIENT = 0.6
#: the key light (`configure_graphics`): a low sun, 21° above the horizon where the waves
#: run to (`sun_azimuth`), where a wave slope of 5° changes the light it gets by ±20 %
#: (overhead: 0.4 %) and the sea's toon bands split the slopes facing the sun from those
#: facing away (`SEA_MATERIAL`)
SUN_ELEVATION = float(np.radians(21.0))
SUN_AZIMUTH = 0.0  # [rad] from +x towards +y, until a sea is drawn
SUN_INTENSITY = 2.6
SUN = (255, 244, 226)
#: [-] the fill light from above (viser's own key light was 3.0 from there)
OVERHEAD_INTENSITY = 0.8
#: lower-case words of a WebGL renderer string that mean software rendering
SOFTWARE_RENDERERS = ("swiftshader", "llvmpipe", "softpipe", "software", "basic render")
#: where a page reports its WebGL renderer (relative to the page, as its websocket is)
RENDERER_PATH = "/twin-renderer"
#: what the viewer runs in a browser once (viser's RunJavascriptMessage, as viser sends
#: plotly.js): read the WebGL renderer of a throw-away canvas and report it with the key
#: the server gave this browser alone; `__KEY__` and `__PATH__` are filled in (JSON)
DETECT_RENDERER_JS = """(() => {
  let name = "unknown";
  try {
    const gl = document.createElement("canvas").getContext("webgl");
    if (gl === null) {
      name = "no WebGL";
    } else {
      const info = gl.getExtension("WEBGL_debug_renderer_info");
      name = String(gl.getParameter(info ? info.UNMASKED_RENDERER_WEBGL : gl.RENDERER));
      const lose = gl.getExtension("WEBGL_lose_context");
      if (lose) lose.loseContext();
    }
  } catch (err) {
    name = "error: " + err;
  }
  const url = new URL(__PATH__.slice(1), window.location.href);
  url.searchParams.set("key", __KEY__);
  url.searchParams.set("renderer", name.slice(0, 200));
  fetch(url, { cache: "no-store" }).catch(() => {});
})();"""


def sun_azimuth(sea: WaveComponents) -> float:
    """[rad] the sun's azimuth from +x towards +y: where the drawn sea's waves run to (the
    amplitude-weighted mean of the components' directions), so their slopes face towards
    and away from it and its light tells them apart (`SEA_MATERIAL`)."""
    a = sea.amplitude
    return float(np.arctan2(np.sum(a * np.sin(sea.direction)), np.sum(a * np.cos(sea.direction))))


def sun_position(azimuth: float) -> np.ndarray:
    """(3,) [m] where the sun node stands: far away at `SUN_ELEVATION` and `azimuth` (a
    three.js directional light shines from its position towards the world origin)."""
    return 1000.0 * np.array([np.cos(azimuth) * np.cos(SUN_ELEVATION),
                              np.sin(azimuth) * np.cos(SUN_ELEVATION),
                              np.sin(SUN_ELEVATION)])  # fmt: skip


def configure_graphics(scene: Any, graphics: str, azimuth: float = 0.0) -> None:
    """Light a scene (the server's: every browser; a client's: that browser alone) for one
    of `GRAPHICS`.

    viser's default lights are replaced: its key light stands overhead, where a wave slope
    of a few degrees barely changes the light it gets. A low sun (`SUN_ELEVATION`) shades the
    wave slopes and the vessel's sides; a weaker light from above and, in "light", the
    sky's ambient light (in place of the environment map, at no cost per pixel) fill the
    rest. "full" adds the environment map (viser's built-in one, "city") and the sun's
    cascaded shadows. `azimuth` [rad]: the sun's (`sun_azimuth`).
    """
    full = graphics == "full"
    scene.configure_environment_map("city" if full else None)
    scene.configure_default_lights(enabled=False, cast_shadow=False)
    scene.add_light_directional(
        "/sun", color=SUN, intensity=SUN_INTENSITY, cast_shadow=full,
        position=tuple(sun_position(azimuth)),
    )  # fmt: skip
    scene.add_light_directional(
        "/overhead", intensity=OVERHEAD_INTENSITY, position=(-200.0, 0.0, 1000.0)
    )
    scene.add_light_ambient("/sky_light", color=SKY, intensity=0.0 if full else AMBIENT)


def software_renderer(renderer: str) -> bool:
    """Whether a WebGL renderer string (WEBGL_debug_renderer_info's) names a renderer that
    draws on the CPU: the names viser's own client warns about (SwiftShader, llvmpipe,
    softpipe, "software"), and Windows' "Microsoft Basic Render Driver"."""
    name = renderer.lower()
    return any(word in name for word in SOFTWARE_RENDERERS)


def check_graphics(graphics: str) -> None:
    """Raises TwinError (a ValueError) unless `graphics` is one of `GRAPHICS`."""
    if graphics not in GRAPHICS:
        raise TwinError(f"graphics {graphics!r} unknown; one of: {', '.join(GRAPHICS)}")
