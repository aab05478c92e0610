"""Draw docs/frames.png: the hybrid boarding system at its working state with its frames.

python scripts/plot_frames.py   (needs the `docs` extra: matplotlib)
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from twin.mechanisms import HybridBoardingSystem
from twin.spatial import pose_to_transform

OUT = Path(__file__).resolve().parents[1] / "docs" / "frames.png"


def axes(ax, T: np.ndarray, label: str, length: float = 1.5) -> None:
    """Draw a frame's x (red), y (green), z (blue) axes and its name."""
    for k, colour in enumerate(("tab:red", "tab:green", "tab:blue")):
        tip = T[:3, 3] + length * T[:3, k]
        ax.plot(*np.stack([T[:3, 3], tip]).T, color=colour, lw=2)
        ax.text(*tip, "xyz"[k], color=colour, fontsize=8)
    ax.text(*(T[:3, 3] + [0.2, 0.3, 0.3]), label, fontsize=10, weight="bold")


def main() -> None:
    hybrid = HybridBoardingSystem()
    xi = hybrid.working_state.copy()
    xi[7] = np.deg2rad(8)  # luff up a little so the tip frame stands apart
    T_P = pose_to_transform(xi[:6])
    links = hybrid.gangway.links(xi[6:])
    fig = plt.figure(figsize=(9, 6))
    ax = fig.add_subplot(projection="3d")
    base, top = (
        hybrid.layout.base_hinges,
        (T_P[:3, :3] @ hybrid.layout.platform_hinges.T).T + T_P[:3, 3],
    )
    for ring, colour in ((base, "grey"), (top, "tab:orange")):
        closed = np.vstack([ring, ring[:1]])
        ax.plot(*closed.T, color=colour)
    for b, p in zip(base, top, strict=True):
        ax.plot(*np.stack([b, p]).T, color="tab:blue", lw=3)
    chain = np.stack([T_P[:3, 3]] + [(T_P @ T)[:3, 3] for T in links])
    ax.plot(*chain.T, color="gold", lw=5)
    axes(ax, np.eye(4), "B (Stewart base = sensor origin)")
    axes(ax, T_P, "P (platform = gangway frame 0)")
    axes(ax, T_P @ links[0], "1 (slew)")
    axes(ax, T_P @ links[2], "E (tip = DH frame 3)")
    ax.set_xlabel("x_B [m] (starboard)")
    ax.set_ylabel("y_B [m] (bow)")
    ax.set_zlabel("z_B [m] (up)")
    ax.set_box_aspect((17, 6, 8))
    ax.set_xlim(-3, 14)
    ax.set_ylim(-3, 3)
    ax.set_zlim(0, 8)
    ax.view_init(elev=18, azim=-60)
    ax.set_title("Hybrid boarding system, working state (q2 = 8° for clarity)")
    fig.tight_layout()
    fig.savefig(OUT, dpi=120)
    print("wrote", OUT)


if __name__ == "__main__":
    main()
