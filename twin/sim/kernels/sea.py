r"""The base's inertial pose at uniform samples for N lanes, compiled: the vessel motion
`vessel_motion` sums (`twin.vessel.motion`), Re Σ_j H_jd e^{−iω_j t} at t = t0 + k dt, put
on the mount (`base_pose`).

Phasors. The samples go in blocks of `BLOCK` and the blocks in spans of `SPAN` (1024 samples,
51.2 s at dt = 0.05 s), both counted from the sample k = 0 at t0, whatever sample a call starts
at (`first`): a sample's bits do not depend on how a run cuts its samples into calls, so a live
session sampling 256 steps at a time gets the numbers of a batch run sampling 8192 (a call
that starts mid-block computes the block's earlier samples and drops them). At a span's first
sample t_s each component's phasor e^{−iω_j t_s} is
an exact exponential (cos and sin of the rounded angle ω_j t_s); block b < SPAN of the span
starts from z_j = e^{−iω_j t_s} · Q_jb, Q_jb = e^{−iω_j b BLOCK dt}, and sample m < BLOCK of the
block is z_j · P_jm, P_jm = e^{−iω_j m dt}. Both tables are built once per lane by repeated
multiplication from an exact step (`advance_table`), so a phasor carries at most about
SPAN + BLOCK roundings, fewer than the rounding of the angle ω_j t_s costs once t_s is tens of
seconds: against a sum in extended precision the error is no larger than the dense sum's of
`vessel_motion` (tested; a few 1e-15 m over the first 200 s of a sea-state-5 motion, a few
1e-14 m at 10 min). cos and sin thus run once per component per span, not per block, where
they had been a fifth of the cost.

The sum. A block's start folds its phasors into the responses once, B_jd = z_j H_jd [m, rad],
and its six rows are then x_d[m] = Σ_j (Re B_jd Re P_jm − Im B_jd Im P_jm), the terms added
one by one in increasing j. The innermost loop runs along the block's samples and updates all
six rows for two components at a time (`add_components`): one load and store of a row serves
two components and one load of P_jm six rows, where each row was loaded and stored once per
component before (the loop was bound by those loads and stores). Each row's sum is still
((x + t_0) + t_1) + … exactly as written: it vectorises along the samples without reordering
any sum, and no fastmath flag lets LLVM reorder or fuse it, so the numbers are the same
whichever machine code runs them (a lane alone or among many, serial or parallel, compiled in
this process or loaded from numba's cache); the interpreted function gives them to the last
ulp of the `math` functions.

The mount (`mount_lane`) takes the cos and sin of the lane's constant mount yaw from its
caller, computed once per lane instead of per sample; its remaining cost is the cos, sin and
atan2 of the angles, three each per sample.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import cache

import numpy as np

from twin.compiled import compile_runner, prange, register_borrowing
from twin.spatial import rpy_of_entries, rpy_to_matrix_lane

#: samples per block: the span of the table P_jm = e^{−iω_j m dt}
BLOCK = 64
#: blocks per span: exact phasors every SPAN·BLOCK samples, the table Q_jb = e^{−iω_j b BLOCK dt}
SPAN = 16


@register_borrowing
def mount_lane(
    motion: np.ndarray,
    lever_arm: np.ndarray,
    cos_yaw: float,
    sin_yaw: float,
    R: np.ndarray,
    out: np.ndarray,
) -> None:
    """`twin.vessel.motion.base_pose` of one sample: ᴵp_B = p_V + ᴵR_V r and ᴵR_B = ᴵR_V Rz(ψ),
    whose angles (`matrix_to_rpy`) need only its first column and its row 2.

    Args:
        motion: (6,) [m, rad] the vessel's motion in the equilibrium frame.
        lever_arm: (3,) [m] r, the base origin in the vessel frame.
        cos_yaw, sin_yaw: [-] cos ψ and sin ψ of the mount yaw ψ (base x from the bow, about z).
        R: (3, 3) scratch (ᴵR_V is written into it).
        out: (6,) written: the base pose [m, rad] in the equilibrium frame; may be motion.
    """
    rpy_to_matrix_lane(motion[3], motion[4], motion[5], R)
    c, s = cos_yaw, sin_yaw
    x0, x1 = R[0, 0] * c + R[0, 1] * s, R[1, 0] * c + R[1, 1] * s
    x2, y2 = R[2, 0] * c + R[2, 1] * s, R[2, 1] * c - R[2, 0] * s
    r0, r1, r2 = lever_arm[0], lever_arm[1], lever_arm[2]
    for i in range(3):  # the position first: the angles below are read from R, not motion
        out[i] = motion[i] + R[i, 0] * r0 + R[i, 1] * r1 + R[i, 2] * r2
    out[3], out[4], out[5] = rpy_of_entries(x0, x1, x2, y2, R[2, 2])


@register_borrowing
def add_components(
    B_re: np.ndarray, B_im: np.ndarray, P_re: np.ndarray, P_im: np.ndarray, block: np.ndarray
) -> None:
    """block[d, m] += Σ_j Re(B_jd P_jm), the terms added one by one in increasing j.

    Args:
        B_re, B_im: (6, K) [m, rad] the responses times the block's first phasors.
        P_re, P_im: (K, BLOCK) [-] the phasors' advance e^{−iω_j m dt}.
        block: (6, BLOCK) [m, rad] the six rows, updated.
    """
    K = B_re.shape[1]
    pairs = K - K % 2
    for j in range(0, pairs, 2):
        # the 24 coefficients as named scalars: they stay in registers through the m loop
        a0, a1, a2 = B_re[0, j], B_re[1, j], B_re[2, j]
        a3, a4, a5 = B_re[3, j], B_re[4, j], B_re[5, j]
        b0, b1, b2 = B_im[0, j], B_im[1, j], B_im[2, j]
        b3, b4, b5 = B_im[3, j], B_im[4, j], B_im[5, j]
        e0, e1, e2 = B_re[0, j + 1], B_re[1, j + 1], B_re[2, j + 1]
        e3, e4, e5 = B_re[3, j + 1], B_re[4, j + 1], B_re[5, j + 1]
        f0, f1, f2 = B_im[0, j + 1], B_im[1, j + 1], B_im[2, j + 1]
        f3, f4, f5 = B_im[3, j + 1], B_im[4, j + 1], B_im[5, j + 1]
        for m in range(BLOCK):  # along the samples: vectorised, each row's sum in j order
            p, q = P_re[j, m], P_im[j, m]
            u, v = P_re[j + 1, m], P_im[j + 1, m]
            block[0, m] = (block[0, m] + (a0 * p - b0 * q)) + (e0 * u - f0 * v)
            block[1, m] = (block[1, m] + (a1 * p - b1 * q)) + (e1 * u - f1 * v)
            block[2, m] = (block[2, m] + (a2 * p - b2 * q)) + (e2 * u - f2 * v)
            block[3, m] = (block[3, m] + (a3 * p - b3 * q)) + (e3 * u - f3 * v)
            block[4, m] = (block[4, m] + (a4 * p - b4 * q)) + (e4 * u - f4 * v)
            block[5, m] = (block[5, m] + (a5 * p - b5 * q)) + (e5 * u - f5 * v)
    for j in range(pairs, K):  # the last component of an odd K
        for d in range(6):
            c_re, c_im = B_re[d, j], B_im[d, j]
            for m in range(BLOCK):
                block[d, m] += c_re * P_re[j, m] - c_im * P_im[j, m]


@register_borrowing
def advance_table(w: np.ndarray, step: float, T_re: np.ndarray, T_im: np.ndarray) -> None:
    """T_jm = e^{−iω_j m step} for m < T.shape[1], by repeated multiplication from the exact
    e^{−iω_j step}, so entry m carries about m roundings.

    Args:
        w: (K,) [rad/s] the frequencies; step: [s].
        T_re, T_im: (K, M) written.
    """
    for j in range(w.size):
        step_re, step_im = math.cos(w[j] * step), -math.sin(w[j] * step)
        re, im = 1.0, 0.0
        for m in range(T_re.shape[1]):
            T_re[j, m], T_im[j, m] = re, im
            re, im = re * step_re - im * step_im, re * step_im + im * step_re


def run_base_poses(
    omega_e: np.ndarray,
    response_re: np.ndarray,
    response_im: np.ndarray,
    lever_arm: np.ndarray,
    mount_yaw: np.ndarray,
    t0: float,
    dt: float,
    first: int,
    out: np.ndarray,
) -> None:
    """Base poses of N lanes at the n uniform samples t0 + k dt, k = first … first + n − 1,
    lanes in parallel.

    Args:
        omega_e: (N, K) [rad/s] each lane's encounter frequencies.
        response_re, response_im: (N, 6, K) the complex responses H_jd [m, rad]
            (`response_amplitudes`), split and transposed so K is contiguous.
        lever_arm: (N, 3) [m], mount_yaw: (N,) [rad] each lane's mount (`Mount`).
        t0: [s] the time of sample 0, from which blocks and spans count; dt: [s] the sample
            period; first: [-] the first sample wanted, ≥ 0.
        out: (N, n, 6) written: the base poses [x, y, z, roll, pitch, yaw] [m, rad] in the
            equilibrium frame.
    """
    K, n = omega_e.shape[1], out.shape[1]
    start = first - first % BLOCK  # the block holding the first sample
    for lane in prange(omega_e.shape[0]):
        w, H_re, H_im = omega_e[lane], response_re[lane], response_im[lane]
        P_re, P_im = np.empty((K, BLOCK)), np.empty((K, BLOCK))
        advance_table(w, dt, P_re, P_im)
        Q_re, Q_im = np.empty((K, SPAN)), np.empty((K, SPAN))
        advance_table(w, BLOCK * dt, Q_re, Q_im)
        E_re, E_im = np.empty(K), np.empty(K)
        B_re, B_im = np.empty((6, K)), np.empty((6, K))
        block, R = np.empty((6, BLOCK)), np.empty((3, 3))
        cos_yaw, sin_yaw = math.cos(mount_yaw[lane]), math.sin(mount_yaw[lane])
        for k0 in range(start, first + n, BLOCK):
            b = (k0 // BLOCK) % SPAN
            if b == 0 or k0 == start:  # the exact phasor at the start of the block's span
                span = k0 - b * BLOCK
                for j in range(K):
                    phase = w[j] * (t0 + span * dt)
                    E_re[j], E_im[j] = math.cos(phase), -math.sin(phase)
            for j in range(K):
                z_re = E_re[j] * Q_re[j, b] - E_im[j] * Q_im[j, b]
                z_im = E_re[j] * Q_im[j, b] + E_im[j] * Q_re[j, b]
                for d in range(6):
                    B_re[d, j] = z_re * H_re[d, j] - z_im * H_im[d, j]
                    B_im[d, j] = z_re * H_im[d, j] + z_im * H_re[d, j]
            block[:] = 0.0
            add_components(B_re, B_im, P_re, P_im, block)
            for m in range(max(0, first - k0), min(BLOCK, first + n - k0)):
                pose = out[lane, k0 + m - first]
                for d in range(6):
                    pose[d] = block[d, m]
                mount_lane(pose, lever_arm[lane], cos_yaw, sin_yaw, R, pose)


@cache
def compiled_base_poses(parallel: bool) -> Callable:
    """`run_base_poses` compiled (`compile_runner`); the plain function without numba."""
    return compile_runner(
        run_base_poses, parallel, ("twin.sim.kernels.sea", "twin.sim.kernels.hybrid")
    )
