"""Draw docs/wave_directions.png: the wave-direction convention of `Scenario.heading`, top view.

python scripts/plot_wave_directions.py   (needs the `docs` extra)

The arrows are drawn from the code's own numbers, not by hand: each heading β goes through
`Scenario.components` (the direction the components travel towards) and the hull outline is
placed with the hybrid mount's lever arm (`twin.vessel.MOUNTS`), so the figure cannot drift
from what the engine computes.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only, no display
import matplotlib.pyplot as plt
import numpy as np

from twin.sim import Scenario
from twin.vessel import MOUNTS

#: [deg] headings drawn: the four cardinal ones and the two the papers' presets use
HEADINGS = {
    0.0: "0°: following seas",
    90.0: "90°: beam seas from starboard",
    150.0: "150°: from 30° off the starboard bow\n(seed000_ss4)",
    180.0: "180°: head seas",
    225.0: "225°: from 45° off the port bow\n(seed000, seed004)",
    270.0: "270°: beam seas from port",
}
LENGTH, BEAM = 70.5, 16.6  # [m] the SOV's hull (docs/vessel.md), for the outline only


def hull_outline() -> np.ndarray:
    """(n, 2) [m] a ship-shaped outline in the vessel frame (x bow, y port)."""
    half = BEAM / 2
    return np.array(
        [[-LENGTH / 2, -half], [LENGTH / 4, -half], [LENGTH / 2, 0.0], [LENGTH / 4, half],
         [-LENGTH / 2, half], [-LENGTH / 2, -half]]
    )  # fmt: skip


def main(out: Path = Path("docs/wave_directions.png")) -> None:
    fig, ax = plt.subplots(figsize=(8.0, 8.0))
    ax.fill(*hull_outline().T, color="0.85", edgecolor="0.3")
    ax.annotate("", xy=(22, 0), xytext=(0, 0), arrowprops={"arrowstyle": "->", "lw": 2})
    ax.annotate("", xy=(0, 22), xytext=(0, 0), arrowprops={"arrowstyle": "->", "lw": 2})
    ax.text(23, -3, "x (bow)", fontsize=11)
    ax.text(1.5, 23, "y (port)", fontsize=11)
    mount = MOUNTS["hybrid"].lever_arm
    ax.plot(mount[0], mount[1], "s", color="tab:red", ms=9)
    ax.text(mount[0] + 2, mount[1] - 4, "gangway base\n(starboard)", color="tab:red", fontsize=9)
    radius = 60.0
    for heading, label in HEADINGS.items():
        sea = Scenario(heading=heading, n_components=8, hs=1.0, tp=8.0).components()
        mu = float(sea.direction[0])  # the direction the code makes the waves travel towards
        towards = np.array([np.cos(mu), np.sin(mu)])
        start = -radius * towards  # the waves come from the opposite side
        end = start + 0.45 * radius * towards
        ax.annotate("", xy=end, xytext=start,
                    arrowprops={"arrowstyle": "-|>", "lw": 2, "color": "tab:blue"})  # fmt: skip
        # beside the arrow's tail, below it for the horizontal ones so the text misses it
        where = 1.12 * start + (np.array([0.0, -7.0]) if abs(towards[1]) < 0.1 else 0.0)
        ax.text(*where, label, ha="center", va="center", fontsize=9, color="tab:blue")
    arc = np.radians(np.linspace(0, 60, 30))
    ax.plot(30 * np.cos(arc), 30 * np.sin(arc), color="0.4", lw=1)
    ax.annotate("", xy=(30 * np.cos(arc[-1]), 30 * np.sin(arc[-1])),
                xytext=(30 * np.cos(arc[-3]), 30 * np.sin(arc[-3])),
                arrowprops={"arrowstyle": "->", "color": "0.4"})  # fmt: skip
    ax.text(31, 12, "heading β,\ncounter-clockwise", fontsize=9, color="0.3")
    ax.set_title(
        "Scenario.heading β: the direction the waves travel TOWARDS,\n"
        "counter-clockwise from the bow seen from above (arrows: waves arriving)",
        fontsize=11,
    )
    ax.set_aspect("equal")
    ax.set_xlim(-95, 95)
    ax.set_ylim(-95, 95)
    ax.set_xlabel("x [m] (bow)")
    ax.set_ylabel("y [m] (port)")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
