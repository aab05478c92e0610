r"""The base's inertial pose at uniform samples for N lanes, compiled: the vessel motion
`vessel_motion` sums (`twin.vessel.motion`), Re Σ_j H_jd e^{−iω_j t} at t = t0 + k dt, put
on the mount (`base_pose`).

The samples go in blocks of `ANCHOR`: at a block's first sample each component's phasor
z_j = e^{−iω_j t} is an exact exponential, and within the block it advances by a table of
e^{−iω_j m dt} (m < ANCHOR, built once per call by repeated multiplication), so its rounding
error never grows past a few ulps (≤ 1e-14 m against the direct sum, tested). The innermost
loop runs along the block's samples, accumulating one component at a time: it vectorises
without reordering any sum, so the numbers are the same whichever machine code runs them (a
lane alone, among many, compiled in this process or loaded from numba's cache).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import cache

import numpy as np

from twin.sim.kernels.compile import compile_runner, prange, register_borrowing
from twin.sim.kernels.hybrid import rpy_to_matrix_lane

#: samples between exact phasors
ANCHOR = 64


@register_borrowing
def mount_lane(
    motion: np.ndarray, lever_arm: np.ndarray, yaw: float, R: np.ndarray, out: np.ndarray
) -> None:
    """`twin.vessel.motion.base_pose` of one sample: ᴵp_B = p_V + ᴵR_V r and ᴵR_B = ᴵR_V Rz(ψ),
    whose angles (`matrix_to_rpy`) need only its first column and its row 2.

    Args:
        motion: (6,) [m, rad] the vessel's motion; lever_arm: (3,) [m] r; yaw: [rad] ψ.
        R: (3, 3) scratch (ᴵR_V is written into it).
        out: (6,) written: the base pose [m, rad]; may be motion itself.
    """
    rpy_to_matrix_lane(motion[3], motion[4], motion[5], R)
    c, s = math.cos(yaw), math.sin(yaw)
    x0, x1 = R[0, 0] * c + R[0, 1] * s, R[1, 0] * c + R[1, 1] * s
    x2, y2 = R[2, 0] * c + R[2, 1] * s, R[2, 1] * c - R[2, 0] * s
    r0, r1, r2 = lever_arm[0], lever_arm[1], lever_arm[2]
    for i in range(3):  # the position first: the angles below are read from R, not motion
        out[i] = motion[i] + R[i, 0] * r0 + R[i, 1] * r1 + R[i, 2] * r2
    out[3] = math.atan2(y2, R[2, 2])
    out[4] = math.atan2(-x2, math.hypot(y2, R[2, 2]))
    out[5] = math.atan2(x1, x0)


def run_base_poses(
    omega_e: np.ndarray,
    response_re: np.ndarray,
    response_im: np.ndarray,
    lever_arm: np.ndarray,
    mount_yaw: np.ndarray,
    t0: float,
    dt: float,
    out: np.ndarray,
) -> None:
    """Base poses of N lanes at n uniform samples, lanes in parallel.

    Args:
        omega_e: (N, K) [rad/s] each lane's encounter frequencies.
        response_re, response_im: (N, 6, K) the complex responses H_jd [m, rad]
            (`response_amplitudes`), split and transposed so K is contiguous.
        lever_arm: (N, 3) [m], mount_yaw: (N,) [rad] each lane's mount (`Mount`).
        t0: [s] the first sample; dt: [s] the sample period.
        out: (N, n, 6) written: the base poses [x, y, z, roll, pitch, yaw] [m, rad].
    """
    K, n = omega_e.shape[1], out.shape[1]
    for lane in prange(omega_e.shape[0]):
        w, H_re, H_im = omega_e[lane], response_re[lane], response_im[lane]
        # the phasor's advance over m samples, e^{−iω_j m dt}, m < ANCHOR
        P_re, P_im = np.empty((K, ANCHOR)), np.empty((K, ANCHOR))
        for j in range(K):
            step_re, step_im = math.cos(w[j] * dt), -math.sin(w[j] * dt)
            re, im = 1.0, 0.0
            for m in range(ANCHOR):
                P_re[j, m], P_im[j, m] = re, im
                re, im = re * step_re - im * step_im, re * step_im + im * step_re
        block, R = np.empty((6, ANCHOR)), np.empty((3, 3))
        for k0 in range(0, n, ANCHOR):
            block[:] = 0.0
            for j in range(K):
                phase = w[j] * (t0 + k0 * dt)
                z_re, z_im = math.cos(phase), -math.sin(phase)  # exact at the block's start
                for d in range(6):
                    c_re = z_re * H_re[d, j] - z_im * H_im[d, j]
                    c_im = z_re * H_im[d, j] + z_im * H_re[d, j]
                    row = block[d]
                    for m in range(ANCHOR):  # along the samples: vectorised, no reordering
                        row[m] += c_re * P_re[j, m] - c_im * P_im[j, m]
            for m in range(min(ANCHOR, n - k0)):
                pose = out[lane, k0 + m]
                for d in range(6):
                    pose[d] = block[d, m]
                mount_lane(pose, lever_arm[lane], mount_yaw[lane], R, pose)


@cache
def compiled_base_poses(parallel: bool) -> Callable:
    """`run_base_poses` compiled (`compile_runner`); the plain function without numba."""
    return compile_runner(
        run_base_poses, parallel, ("twin.sim.kernels.sea", "twin.sim.kernels.hybrid")
    )
