"""The compensation task: a body that holds its inertial pose while the base moves.

Seed 000 §5.1: the desired base-frame motion is the inverse of the measured base motion. With
the held pose ᴵT* fixed at t = 0, the desired pose in the base frame is ᴮT_d = ᴵT_B⁻¹ ᴵT*.

Both papers plan on a *predicted* base trajectory (seed 000 §5.1: the hydraulics' delay is
covered by predicting the sensor's motion; seed 004 §1: short-term wave-motion prediction).
We give the planner a one-step prediction: the twist is the mean rate that carries ᴮT_d(t_k)
to ᴮT_d(t_k+1) over dt, so a velocity held for one control period lands on the next target
(docs/planners.md).
"""

from __future__ import annotations

import numpy as np

from twin.sim.kernels.layout import N_TARGET
from twin.spatial import TILT


def tilt(R: np.ndarray, axis: int = 2) -> np.ndarray:
    """Angle [rad] between a body axis (column `axis` of R (..., 3, 3)) and inertial z up
    (`twin.spatial.tilt_lane`)."""
    return np.asarray(TILT(R[..., 0, axis], R[..., 1, axis], R[..., 2, axis]))


def held_targets(
    held: np.ndarray,
    poses: np.ndarray,
    dt: float,
    compiled: bool = True,
    out: np.ndarray | None = None,
    end: bool = False,
) -> np.ndarray:
    """ᴮT_d = ᴵT_B⁻¹ ᴵT* at each sample and its mean twist to the next, for a chunk of samples
    of N lanes at once, packed as the kernels read it (`twin.sim.kernels.target`, parallel over
    lanes when there are several). The tests hold it to the one-sample statement of the same
    math in numpy (`held_target` in tests/sim/oracle.py).

    Args:
        held: (N, 4, 4) ᴵT*, each lane's held inertial pose.
        poses: (N, B + 1, 6) the base ᴵT_B at samples k … k + B [m, rad].
        dt: [s] sample period.
        compiled: run the numba-compiled function (else the same function interpreted: the
            engine without numba).
        out: (N, B + end, 18) C-contiguous float64 to write into (e.g.
            `twin.sim.scratch.scratch`); None: a new array.
        end: add a row for sample k + B, its desired pose only (its twist NaN): what is
            recorded there (`twin.sim.kernels.records`).

    Returns:
        (N, B + end, 18): ᴮR_d row-major, ᴮp_d [m], twist [ᴮṗ; ᴮω] [m/s, rad/s] at samples
        k … k + B − 1 (+ end) (`twin.sim.kernels.layout.TARGET` rows).
    """
    from twin.compiled import pick_runner
    from twin.sim.kernels.target import compiled_targets, run_held_targets

    poses, held = np.ascontiguousarray(poses, dtype=float), np.ascontiguousarray(held, dtype=float)
    if out is None:
        out = np.empty((poses.shape[0], poses.shape[1] - 1 + end, N_TARGET))
    runner = pick_runner(compiled_targets, run_held_targets, compiled, len(poses))
    runner(poses, held, float(dt), out)
    return out
