"""Working state: leg lengths and gangway tip of the hybrid boarding system.

Prints seed 000 Table 5's active-compensation state as the twin computes it.
"""

from __future__ import annotations

import numpy as np

from twin.mechanisms import MECHANISMS


def main() -> None:
    hybrid = MECHANISMS["hybrid"]()
    xi = hybrid.working_state  # [x, y, z, roll, pitch, yaw, q1, q2, d3] [m, rad]
    print("legs [m]:", np.round(hybrid.leg_lengths(xi), 4))
    print("tip  [m]:", np.round(hybrid.end_effector(xi)[:3, 3], 3) + 0.0)
    print("manipulability:", round(float(hybrid.manipulability(xi)), 2))


if __name__ == "__main__":
    main()
