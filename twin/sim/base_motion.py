"""The mechanism base's inertial motion for a scenario: sea → vessel RAOs → mount."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cache
from typing import Protocol

import numpy as np

from twin.errors import TwinError
from twin.sea.components import WaveComponents
from twin.sim.measured import MeasuredMotion
from twin.sim.scenario import Scenario
from twin.spatial import pose_to_transform
from twin.vessel import MOUNTS, Mount, RaoTable, load_raos
from twin.vessel.motion import response_amplitudes, superpose


@dataclass(frozen=True)
class BaseSamples:
    """Inertial base motion at a batch of times.

    Attributes:
        t: (N,) [s].
        pose: (N, 6) [m, rad] `[x, y, z, roll, pitch, yaw]`, z up, R = Rz·Ry·Rx.
        transform: (N, 4, 4) ᴵT_B.
    """

    t: np.ndarray
    pose: np.ndarray
    transform: np.ndarray


class BaseMotion:
    """Base motion of a mechanism on its vessel in a given sea.

    Args:
        components: the sea (inertial frame; the vessel's bow points along +x, so a wave
            direction is also its direction relative to the bow, π = head seas).
        mount: where the base sits on which vessel.
        vessel: RAO table name, overriding the mount's.
        speed: [m/s] forward speed.
        terms: (omega_e, amplitude), `response_amplitudes` of these components on this
            vessel at this speed when already computed (`many`); None computes them.
    """

    def __init__(
        self,
        components: WaveComponents,
        mount: Mount,
        vessel: str | None = None,
        speed: float = 0.0,
        terms: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> None:
        self.components = components
        self.mount = mount
        self.raos = raos_named(vessel or mount.vessel)
        self.speed = speed
        # the terms vessel_motion sums, interpolated from the RAO table once per sea
        if terms is None:
            terms = response_amplitudes(components, self.raos, 0.0, speed)
        self.omega_e, self.amplitude = terms
        #: most steps the engine may sample ahead (None: any; `Measured.horizon`)
        self.horizon: int | None = None

    @classmethod
    def of(cls, scenario: Scenario) -> BaseMotion:
        """The base motion of a scenario: its sea, its mechanism's mount, its vessel."""
        return cls.many([scenario])[0]

    @classmethod
    def many(cls, scenarios: Sequence[Scenario]) -> list[BaseMotion]:
        """`of` each scenario, the same numbers: the response terms of every lane on one
        vessel at one speed come from one `response_amplitudes` call over all their
        components (elementwise, so each lane's equal its own call's), where a call per lane
        would cost mostly its fixed overhead. A scenario whose `base_motion` is a stored log
        gets the log's motion instead (`MeasuredBase`), with a calm sea to draw."""
        measured = [s.base_motion is not None and s.base_motion.source == "log"
                    for s in scenarios]  # fmt: skip
        if any(measured):
            sea_lanes = [s for s, m in zip(scenarios, measured, strict=True) if not m]
            sea_motions = iter(cls.many(sea_lanes) if sea_lanes else [])
            return [MeasuredBase.of(s) if m else next(sea_motions)
                    for s, m in zip(scenarios, measured, strict=True)]  # fmt: skip
        seas = [s.components() for s in scenarios]
        mounts = [mount_for(s.mechanism) for s in scenarios]
        vessels = [s.vessel or m.vessel for s, m in zip(scenarios, mounts, strict=True)]
        groups: dict[tuple[str, float], list[int]] = {}
        for i, s in enumerate(scenarios):
            groups.setdefault((vessels[i], s.forward_speed), []).append(i)
        terms: list[tuple[np.ndarray, np.ndarray]] = [None] * len(scenarios)  # type: ignore[list-item]
        for (vessel, speed), lanes in groups.items():
            every = WaveComponents(*(np.concatenate([getattr(seas[i], field) for i in lanes])
                                     for field in ("omega", "amplitude", "phase", "direction")))
            omega_e, amplitude = response_amplitudes(every, raos_named(vessel), 0.0, speed)
            ends = np.cumsum([seas[i].omega.size for i in lanes])[:-1]
            for i, w, a in zip(lanes, np.split(omega_e, ends), np.split(amplitude, ends),
                               strict=True):  # fmt: skip
                terms[i] = (w, a)
        return [
            cls(sea, mount, vessel=vessel, speed=s.forward_speed, terms=t)
            for s, sea, mount, vessel, t in zip(scenarios, seas, mounts, vessels, terms,
                                                strict=True)
        ]  # fmt: skip

    def poses(self, t: np.ndarray) -> np.ndarray:
        """(N, 6) inertial base poses at times t (N,) [s] (`twin.vessel.vessel_motion`)."""
        t = np.asarray(t, dtype=float)
        if t.size > 2 and np.allclose(np.diff(t), t[1] - t[0], rtol=0.0, atol=1e-12):
            return self.uniform_poses([self], t[0], t[1] - t[0], t.size)[0]
        return self.mount.pose(superpose(t, self.omega_e, self.amplitude))

    @staticmethod
    def uniform_poses(
        motions: Sequence[BaseMotion],
        t0: float,
        dt: float,
        n: int,
        compiled: bool = True,
        first: int = 0,
    ) -> np.ndarray:
        """(N, n, 6) base poses [m, rad] of N base motions at t = t0 + k dt, k = first …
        first + n − 1, in one compiled pass over the lanes (`twin.sim.kernels.sea`: each
        vessel motion put on its mount). A sample's numbers depend on t0, dt and k alone, not
        on `first` or `n`: a run sampled in pieces gets the bits of one call. A non-finite
        response gives NaN poses, not an error.

        Args:
            motions: base motions; t0, dt: [s]; n: samples.
            compiled: run the numba-compiled function (else the same function interpreted).
            first: [-] the first sample's index k, ≥ 0.
        """
        if first < 0:
            raise TwinError(f"first: got {first}; allowed a sample index ≥ 0")
        if any(isinstance(m, MeasuredBase) for m in motions):
            return _mixed_poses(motions, t0, dt, n, compiled, first)
        from twin.compiled import pick_runner
        from twin.sim.kernels.sea import compiled_base_poses, run_base_poses

        # lanes with fewer components are padded with silent ones (zero response)
        K = max(m.omega_e.size for m in motions)
        omega_e = np.zeros((len(motions), K))
        response = np.zeros((len(motions), 6, K), dtype=complex)
        for lane, m in enumerate(motions):
            omega_e[lane, : m.omega_e.size] = m.omega_e
            response[lane, :, : m.omega_e.size] = m.amplitude.T
        lever_arm = np.array([m.mount.lever_arm for m in motions], dtype=float)
        yaw = np.array([m.mount.yaw for m in motions], dtype=float)
        out = np.empty((len(motions), n, 6))
        runner = pick_runner(compiled_base_poses, run_base_poses, compiled, len(motions))
        runner(omega_e, np.ascontiguousarray(response.real), np.ascontiguousarray(response.imag),
               lever_arm, yaw, float(t0), float(dt), int(first), out)  # fmt: skip
        return out

    def sample(self, t: np.ndarray) -> BaseSamples:
        """Poses and transforms at times t (N,) [s]."""
        t = np.asarray(t, dtype=float)
        poses = self.poses(t)
        return BaseSamples(t, poses, pose_to_transform(poses))


class Measured(Protocol):
    """A measured source of base poses: a stored log (`twin.sim.measured.MeasuredMotion`) or
    a live stream (`twin.sim.motion_live.StreamMotion`)."""

    mount: Mount
    #: most steps whose poses may be sampled ahead (None: any; a live stream: what arrived)
    horizon: int | None

    def poses(self, t: np.ndarray) -> np.ndarray:
        """(N, 6) [m, rad] the mount's base poses at run times t (N,) [s]."""
        ...


class MeasuredBase(BaseMotion):
    """A base motion from measured motion (a `Measured`: a stored log or a live stream): the
    same interface as the sea's, its poses the measured ones at the mount, its sea calm
    (nothing to draw but the hull's own motion)."""

    def __init__(self, measured: Measured) -> None:
        calm = WaveComponents(*(np.zeros(0) for _ in range(4)))
        super().__init__(calm, measured.mount, terms=(np.zeros(0), np.zeros((0, 6), complex)))
        self.measured = measured
        self.horizon = measured.horizon

    @classmethod
    def of(cls, scenario: Scenario) -> MeasuredBase:
        """The scenario's log on its mechanism's mount, from its offset for its duration."""
        source = scenario.base_motion
        assert source is not None and source.log is not None  # `many` picked it for that
        mount = mount_for(scenario.mechanism)
        return cls(MeasuredMotion(source.log, mount, source.offset, scenario.duration))

    def poses(self, t: np.ndarray) -> np.ndarray:
        """(N, 6) [m, rad] the measured base poses at times t (N,) [s]."""
        return self.measured.poses(np.asarray(t, dtype=float))


def _mixed_poses(motions: Sequence[BaseMotion], t0: float, dt: float, n: int, compiled: bool,
                 first: int) -> np.ndarray:  # fmt: skip
    """`BaseMotion.uniform_poses` of lanes some of which are measured: the sea's lanes in one
    compiled pass, the measured ones from their logs at the same times."""
    out = np.empty((len(motions), n, 6))
    t = t0 + (first + np.arange(n)) * dt
    sea = [i for i, m in enumerate(motions) if not isinstance(m, MeasuredBase)]
    if sea:
        out[sea] = BaseMotion.uniform_poses([motions[i] for i in sea], t0, dt, n, compiled, first)
    for i, m in enumerate(motions):
        if isinstance(m, MeasuredBase):
            out[i] = m.poses(t)
    return out


@cache
def raos_named(name: str) -> RaoTable:
    """An RAO table by shipped name or path, read once per process (a NetCDF read costs ms)."""
    return load_raos(name)


def mount_for(mechanism: str) -> Mount:
    """The mechanism's standard mount (twin.vessel.MOUNTS)."""
    return MOUNTS[mechanism]
