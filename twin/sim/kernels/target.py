"""The held targets of a chunk, compiled: ᴮT_d = ᴵT_B⁻¹ ᴵT* and its mean twist to the next
sample, for every lane and sample (`twin.sim.target.held_targets` is the entry point; the
tests hold it to the one-sample statement of the same math, `held_target` in
tests/sim/oracle.py).

Per lane the base's rotation is built once per sample from its pose (seed 000 eq (3)); the
twist of sample k is [(ᴮp_d(k+1) − ᴮp_d(k)) / dt; log(ᴮR_d(k+1) ᴮR_d(k)ᵀ) / dt] in B.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import cache

import numpy as np

from twin.compiled import compile_runner, prange, register_borrowing
from twin.sim.kernels.layout import TARGET
from twin.spatial import rpy_to_matrix_lane, so3_log_lane


@register_borrowing
def desired_lane(pose: np.ndarray, held: np.ndarray, R_IB: np.ndarray, out: np.ndarray) -> None:
    """ᴮT_d = ᴵT_B⁻¹ ᴵT* at one sample: ᴮR_d row-major (9) then ᴮp_d [m] (3) into out (12,).

    Args:
        pose: (6,) ᴵT_B as [x, y, z, roll, pitch, yaw] [m, rad].
        held: (4, 4) ᴵT*.
        R_IB: (3, 3) scratch (ᴵR_B is written into it).
    """
    rpy_to_matrix_lane(pose[3], pose[4], pose[5], R_IB)
    for i in range(3):
        for j in range(3):
            out[3 * i + j] = (
                R_IB[0, i] * held[0, j] + R_IB[1, i] * held[1, j] + R_IB[2, i] * held[2, j]
            )
        out[9 + i] = (
            R_IB[0, i] * (held[0, 3] - pose[0])
            + R_IB[1, i] * (held[1, 3] - pose[1])
            + R_IB[2, i] * (held[2, 3] - pose[2])
        )


@register_borrowing
def held_targets_lane(
    poses: np.ndarray,
    held: np.ndarray,
    dt: float,
    out: np.ndarray,
    R_IB: np.ndarray,
    now: np.ndarray,
    nxt: np.ndarray,
    R_step: np.ndarray,
    w: np.ndarray,
) -> None:
    """One lane's held targets (`run_held_targets`): the loop is here, not in the runner,
    because a borrowing function takes its per-sample views without reference counting.

    Args:
        poses: (B + 1, 6) ᴵT_B [m, rad]; held: (4, 4) ᴵT*; dt: [s].
        out: (B, 18) or (B + 1, 18) written: with B + 1 rows, the last is sample B's desired
            pose, its twist NaN (the next sample's pose is not known).
        R_IB, R_step: (3, 3), now, nxt: (12,), w: (3,): scratch.
    """
    desired_lane(poses[0], held, R_IB, nxt)
    steps = poses.shape[0] - 1
    for k in range(steps):
        for i in range(12):
            now[i] = nxt[i]
        desired_lane(poses[k + 1], held, R_IB, nxt)
        for i in range(3):  # ᴮR_d(k+1) ᴮR_d(k)ᵀ
            for j in range(3):
                R_step[i, j] = (
                    nxt[3 * i] * now[3 * j]
                    + nxt[3 * i + 1] * now[3 * j + 1]
                    + nxt[3 * i + 2] * now[3 * j + 2]
                )
        so3_log_lane(R_step, w)
        row = out[k].view(TARGET)[0]  # the row by name
        R_d, p_d, twist = row.R_d, row.p_d, row.twist
        for i in range(9):
            R_d[i] = now[i]
        for i in range(3):
            p_d[i] = now[9 + i]
            twist[i] = (nxt[9 + i] - now[9 + i]) / dt  # ᴮṗ_d
            twist[3 + i] = w[i] / dt  # ᴮω_d
    if out.shape[0] > steps:  # the end: its desired pose, for what is recorded there
        row = out[steps].view(TARGET)[0]
        R_d, p_d, twist = row.R_d, row.p_d, row.twist
        for i in range(9):
            R_d[i] = nxt[i]
        for i in range(3):
            p_d[i] = nxt[9 + i]
        for i in range(6):
            twist[i] = math.nan


def run_held_targets(poses: np.ndarray, held: np.ndarray, dt: float, out: np.ndarray) -> None:
    """The held targets of N lanes over B samples.

    Args:
        poses: (N, B + 1, 6) ᴵT_B at samples k … k + B [m, rad].
        held: (N, 4, 4) ᴵT*.
        dt: [s] sample period.
        out: (N, B, 18) written, rows `twin.sim.kernels.layout.TARGET_*`; or (N, B + 1, 18),
            the last row sample k + B's desired pose (`held_targets_lane`).
    """
    for n in prange(poses.shape[0]):
        held_targets_lane(poses[n], held[n], dt, out[n], np.empty((3, 3)), np.empty(12),
                          np.empty(12), np.empty((3, 3)), np.empty(3))  # fmt: skip


@cache
def compiled_targets(parallel: bool) -> Callable:
    """`run_held_targets` compiled (`compile_runner`); the plain function without numba."""
    return compile_runner(
        run_held_targets,
        parallel,
        ("twin.sim.kernels.target", "twin.sim.kernels.hybrid", "twin.sim.kernels.layout"),
    )
