"""Numerical faults of a running simulation: what went wrong at a step, and how it was held.

A twin that runs for hours meets a sea sample that is not a number, a planner that blows up
next to a singularity, forward kinematics that does not converge, a joint driven into its end
stop. None of these may stop the loop or reach a viewer as NaN. The simulation holds (keeps
the last good base pose, or the mechanism where it is), damps (the planners' damped least
squares) or clamps (a step shortened at a limit), and flags the sample with a `Fault`.
"""

from __future__ import annotations

from collections import Counter, deque
from collections.abc import Mapping
from dataclasses import dataclass
from enum import IntFlag

import numpy as np

from twin.errors import TwinError


class Fault(IntFlag):
    """What happened at a step; several may at once."""

    #: the base motion was not finite: the last finite base pose is held
    BASE_MOTION = 1
    #: the planner's velocity was not finite, or it raised: the mechanism is held
    PLANNER = 2
    #: forward kinematics did not converge (or left the workspace): the mechanism is held
    KINEMATICS = 4
    #: the step would have carried a joint or leg further past its limit: shortened at it
    JOINT_LIMIT = 8
    #: near-singular Jacobian: damped least squares engaged (the planner's `damping` > 0)
    SINGULAR = 16
    #: no rates met every limit (the `qp` planner): the closest feasible rates were taken
    INFEASIBLE = 32


#: faults that stop the mechanism for the step (counted by the `faults` metric)
HOLDS = Fault.BASE_MOTION | Fault.PLANNER | Fault.KINEMATICS


def flag_name(flag: Fault) -> str:
    """The lower-case name of one flag, e.g. 'base_motion' (the key of the fault counts);
    a TwinError for no flag (Fault(0) has no name) or several (`fault_names` splits them)."""
    if flag.name is None or "|" in flag.name:
        raise TwinError(f"not a single Fault flag: {flag!r}; allowed: one of {list(Fault)}")
    return flag.name.lower()


def fault_names(fault: Fault) -> list[str]:
    """Lower-case names of the flags set, e.g. ['base_motion', 'singular']."""
    return [flag_name(f) for f in Fault if f in fault]


def hold_invalid(pose: np.ndarray, last_good: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Base poses with every non-finite row replaced by the last finite one before it.

    Args:
        pose: (..., T, 6) [m, rad] base poses at T times (of N lanes, say; any row may hold
            NaN or inf).
        last_good: (..., 6) [m, rad] the finite pose to hold if the first rows are bad.

    Returns:
        (finite poses (..., T, 6), (..., T) bool: the rows replaced); the poses are `pose`
        itself when every row is finite, else a copy.
    """
    pose = np.asarray(pose, dtype=float)
    if np.isfinite(pose).all():  # the common case: no copy
        return pose, np.zeros(pose.shape[:-1], dtype=bool)
    pose = pose.copy()
    bad = ~np.all(np.isfinite(pose), axis=-1)
    held = np.asarray(last_good, dtype=float)
    for *lane, i in zip(*np.nonzero(bad), strict=True):  # C order: each lane's times in turn
        pose[(*lane, i)] = pose[(*lane, i - 1)] if i else held[tuple(lane)]
    return pose, bad


def hold_nonfinite(records: dict[str, np.ndarray], previous: dict[str, np.ndarray]) -> np.ndarray:
    """Replace, in place, every non-finite recorded value by the sample before's.

    Args:
        records: name → (N, m, ...) a chunk of m samples of N lanes (written in place).
        previous: name → (N, ...) the sample before the chunk; where it is not finite
            either, 0 is used.

    Returns:
        (N, m) bool: the samples where something was replaced.
    """
    N, m = next(iter(records.values())).shape[:2]
    rows = np.zeros((N, m), dtype=bool)
    owners: dict[int, bool] = {}  # id of an array the records view → all of it finite
    for key, values in records.items():
        # Most records are views of a few arrays (the kernel's states and diagnostics, the
        # record runner's outputs): one contiguous check of each array the views share clears
        # them all, where a check per strided view reads the same memory many times over.
        owner = values.base if isinstance(values.base, np.ndarray) else values
        if id(owner) not in owners:
            owners[id(owner)] = bool(np.isfinite(owner).all())
        if owners[id(owner)]:
            continue
        bad = ~np.isfinite(values)
        if not bad.any():  # a non-finite value outside this view
            continue
        touched = bad.reshape(N, m, -1).any(-1)
        rows |= touched
        for lane, j in zip(*np.nonzero(touched), strict=True):
            before = values[lane, j - 1] if j else previous[key][lane]
            fill = np.where(np.isfinite(before), before, 0.0)
            values[lane, j] = np.where(bad[lane, j], fill, values[lane, j])
    return rows


@dataclass(frozen=True)
class FaultEvent:
    """A run of faulty steps alike: first and last sample time [s], what, and the message of
    what raised (if anything did)."""

    start: float
    end: float
    kinds: tuple[str, ...]
    message: str = ""


class FaultLog:
    """Counts per kind over a run and the newest events (a bounded list).

    Args:
        keep: events kept.
    """

    def __init__(self, keep: int = 20) -> None:
        self.counts: Counter[str] = Counter({flag_name(f): 0 for f in Fault})
        self.events: deque[FaultEvent] = deque(maxlen=keep)
        self.holds = 0

    def add(self, t: float, fault: Fault, message: str = "") -> None:
        if not fault:
            return
        names = fault_names(fault)
        self.counts.update(names)
        if fault & HOLDS:
            self.holds += 1
        last = self.events[-1] if self.events else None
        if last is None or last.kinds != tuple(names) or message:
            self.events.append(FaultEvent(t, t, tuple(names), message))
        else:  # the same fault going on: one event, its end moved on
            self.events[-1] = FaultEvent(last.start, t, last.kinds, last.message)

    def add_chunk(self, t: np.ndarray, bits: np.ndarray) -> None:
        """`add` for a chunk of steps at once: times t (m,) [s] and fault bits (m,) int.

        The same counts and events as adding step by step (tested): counts by bit, and runs of
        equal faulty steps (steps without a fault between them do not break a run) become one
        event each; only the newest `keep` runs are built.
        """
        faulty = np.flatnonzero(bits)
        if faulty.size == 0:
            return
        t, bits = t[faulty], bits[faulty]
        for f in Fault:
            self.counts[flag_name(f)] += int(np.count_nonzero(bits & int(f)))
        self.holds += int(np.count_nonzero(bits & int(HOLDS)))
        starts = np.flatnonzero(np.r_[True, bits[1:] != bits[:-1]])
        ends = np.r_[starts[1:], bits.size] - 1
        keep = self.events.maxlen or len(starts)
        for first, last in zip(starts[-keep - 1 :], ends[-keep - 1 :], strict=True):
            kinds = tuple(fault_names(Fault(int(bits[first]))))
            previous = self.events[-1] if self.events else None
            if previous is not None and previous.kinds == kinds and not previous.message:
                self.events[-1] = FaultEvent(previous.start, float(t[last]), kinds)
            else:
                self.events.append(FaultEvent(float(t[first]), float(t[last]), kinds))

    def summary(self) -> dict[str, object]:
        """JSON-able: counts per kind, samples held, the newest events (newest last)."""
        return {
            "counts": dict(self.counts),
            "held": self.holds,
            "events": [
                {"start": e.start, "end": e.end, "kinds": list(e.kinds), "message": e.message}
                for e in self.events
            ],
        }


#: [m] a tip position error beyond which a run's tracking counts as diverged: two orders of
#: magnitude above a compensating run's (millimetres) and past any gangway's landing tolerance,
#: while a loop that has lost its target (an unstable gain, a limit it stays on, a planner that
#: cannot follow) goes on to decimetres and metres (docs/decisions.md, "Sampled loop gains")
TRACKING_DIVERGED = 0.25


def tracking_diverged(metrics: Mapping[str, object]) -> bool:
    """Whether a run's tracking diverged: its tip position error reached `TRACKING_DIVERGED`
    at some sample, whatever the cause (`metrics["tip_position_error_max"]` [m], every
    mechanism's metrics have it; a run without one, e.g. no samples, did not diverge)."""
    error = metrics.get("tip_position_error_max")
    return isinstance(error, float | int) and float(error) >= TRACKING_DIVERGED


def series_faults(series: dict[str, np.ndarray]) -> dict[str, int]:
    """Samples where a limit clamped the step or damping engaged, from a run's series."""
    limited = 0
    if "limit_scale" in series:
        limited = int(np.sum(series["limit_scale"] < 1.0))
    elif "clipped" in series:
        limited = int(np.sum(series["clipped"] > 0))
    damped = int(np.sum(series["damping"] > 0)) if "damping" in series else 0
    return {"joint_limit": limited, "singular": damped}
