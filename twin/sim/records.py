"""What a run records at each sample, computed for a whole chunk of samples at once.

The kernels step the state; everything recorded that does not feed back — leg lengths, the
tip's error against its held pose, attitude angles, manipulability — is computed here from
the states and base poses of a chunk, vectorised over lanes and time, each transform once.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from twin.mechanisms import HybridBoardingSystem
from twin.mechanisms.upu3up import Upu3Up
from twin.planners.parameters import as_records
from twin.planners.platform_model import PlatformModel
from twin.sim.target import tilt
from twin.spatial import invert_transform, pose_error, pose_to_transform


def landing_frame(T_IB: np.ndarray, xi: np.ndarray, mechanism: HybridBoardingSystem) -> tuple[
    np.ndarray, np.ndarray
]:
    """Seed 004's landing frame at t = 0: inertial, x along the horizontal gangway direction.

    Args:
        T_IB: (..., 4, 4) ᴵT_B at t = 0; xi: (..., 9) the state at t = 0.

    Returns:
        (L (..., 3, 3) rotating inertial vectors into it, the gangway vector g₀ (..., 3) in it).
    """
    g = gangway_direction(T_IB, xi, mechanism)
    heading = np.arctan2(g[..., 1], g[..., 0])
    c, s = np.cos(heading), np.sin(heading)
    L = np.zeros((*heading.shape, 3, 3))
    L[..., 0, 0], L[..., 0, 1], L[..., 1, 0], L[..., 1, 1], L[..., 2, 2] = c, s, -s, c, 1.0
    return L, (L @ g[..., None])[..., 0]


def gangway_direction(
    T_IB: np.ndarray, xi: np.ndarray, mechanism: HybridBoardingSystem
) -> np.ndarray:
    """Inertial vector (..., 3) [m] from the luff pivot (DH frame 2) to the tip: d3 along the
    tip's z axis (seed 000 Table 2), turned by ᴵR_B ᴮR_E."""
    R_IE = T_IB[..., :3, :3] @ mechanism.end_effector(xi)[..., :3, :3]
    return xi[..., 8:9] * R_IE[..., :, 2]


def record_arrays(N: int, S: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Uninitialised arrays for the hybrid records of N lanes × S samples, as the compiled
    record functions write them: legs (N, S, 6) [m], tip errors (N, S, 6) [m, rad] and the
    scalars (N, S, N_SCALARS) (`twin.sim.kernels.records`)."""
    from twin.sim.kernels.records import N_SCALARS

    return np.empty((N, S, 6)), np.empty((N, S, 6)), np.empty((N, S, N_SCALARS))


def record_views(
    legs: np.ndarray, errors: np.ndarray, scalars: np.ndarray, first: int
) -> dict[str, np.ndarray]:
    """The recorded keys of `record_arrays`' arrays from sample `first` on (views):
    legs, tip_error (tip pose error against ᴮT_d, [m, rad] in B), manipulability, phi_e,
    theta_e (seed 004 §3.1 a: the gangway's azimuth and elevation change since t = 0 [rad]),
    alpha_top (tilt of the tip's "up" axis from its held direction [rad]), alpha_bottom (the
    base's tilt [rad]), each (N, S − first, ...)."""
    from twin.sim.kernels.records import SCALARS

    named = as_records(scalars[:, first:], SCALARS)  # the scalars by name
    return {
        "legs": legs[:, first:],
        "tip_error": errors[:, first:],
        "manipulability": named["manipulability"],
        "phi_e": named["phi_e"],
        "theta_e": named["theta_e"],
        "alpha_top": named["alpha_top"],
        "alpha_bottom": named["alpha_bottom"],
    }


def hybrid_records(
    targets: np.ndarray,
    xi: np.ndarray,
    held: np.ndarray,
    landing: np.ndarray,
    gangway0: np.ndarray,
    const: np.ndarray,
    runner: Callable,
    first: int = 0,
) -> dict[str, np.ndarray]:
    """The hybrid system's record at samples first … S − 1 of N lanes, computed from their
    states alone by the compiled records runner (`twin.sim.kernels.records.run_hybrid_records`,
    no tip handed over by a kernel: a run's start, and the tests).

    Args:
        targets: (N, S, 18) each sample's target row (`held_targets`, with `end=True` for a
            chunk's end; ᴮR_d and ᴮp_d read).
        xi: (N, S, 9) virtual joints [m, rad].
        held: (N, 4, 4) ᴵT_E*, the held tip pose.
        landing, gangway0: (N, 3, 3) and (N, 3), `landing_frame` at t = 0.
        const: the hybrid constants (`twin.sim.kernels.hybrid.hybrid_constants`).
        runner: `compiled_records(...)` or the plain `run_hybrid_records`.
        first: the first sample recorded.

    Returns:
        xi and the keys of `record_views`, each (N, S − first, ...).
    """
    from twin.sim.kernels.records import N_TIP, keep_records

    N, S = xi.shape[:2]
    legs, errors, scalars = record_arrays(N, S)
    none = np.zeros(N, dtype=np.int64)  # no tip handed over: each computed here
    runner(np.ascontiguousarray(targets), np.ascontiguousarray(xi), first, none,
           np.ascontiguousarray(held), np.ascontiguousarray(landing),
           np.ascontiguousarray(gangway0), const, legs, errors, scalars,
           np.empty((N, 0, N_TIP)), *keep_records(N))  # fmt: skip
    return {"xi": xi[:, first:], **record_views(legs, errors, scalars, first)}


def platform_records(
    model: PlatformModel,
    poses: np.ndarray,
    state: np.ndarray,
    legs: np.ndarray,
    rates: np.ndarray,
    held: np.ndarray,
) -> dict[str, np.ndarray]:
    """A small platform's record at T samples of N lanes.

    Args:
        model: the platform.
        poses: (N, T, 6) inertial base poses [m, rad].
        state: (N, T, 3) platform states [native, rad, rad] (mm for the Upu3Up).
        legs: (N, T, n) actuator lengths [native].
        rates: (N, T, n) actuator rates over the step that ended at each sample [native/s].
        held: (N, 4, 4) ᴵT*, the held level top pose [m].

    Returns:
        base_pose, state, desired_state (the state whose top matches the held pose, unclipped),
        legs, leg_rates, tip_error (top pose error against the desired state's top [m, rad]),
        alpha_top, alpha_bottom (tilts from inertial z [rad]) and, for the Upu3Up,
        coupled_displacement (seed 001 eq (15) [mm]); each (N, T, ...).
    """
    T_IB = pose_to_transform(poses)
    T_BP = model.transform(state)
    desired = model.desired_state(invert_transform(T_IB) @ held[:, None])
    records = {
        "base_pose": poses,
        "state": state,
        "desired_state": desired,
        "legs": legs,
        "leg_rates": rates,
        "tip_error": pose_error(model.transform(desired), T_BP),
        "alpha_top": tilt(T_IB[..., :3, :3] @ T_BP[..., :3, :3]),
        "alpha_bottom": tilt(T_IB[..., :3, :3]),
    }
    if isinstance(model.mechanism, Upu3Up):
        records["coupled_displacement"] = model.mechanism.coupled_displacement(
            state[..., 0], state[..., 1], state[..., 2]
        )
    return records
