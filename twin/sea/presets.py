r"""Seed 001's level-4 sea and the platform inputs of its Table 4 (trajectories P5-P8).

Seed 001 §IV.C: Pierson–Moskowitz wind sea (eq (28), SPEC erratum 8) with U = 12 m/s at
19.5 m and g = 9.8 m/s², ω from 0.5 to 2.4 rad/s at Δω = 0.01 rad/s, 500 s. The components
sit on the paper's grid ω_i = 0.50, 0.51, …, 2.40 rad/s (191 bin centres, no jitter) with
A_i = sqrt(2 Δω S(ω_i)) (eq (29)) and seeded uniform phases. Equal spacing makes the record
periodic with 2π/Δω = 628.3 s (docs/sea.md), longer than the paper's 500 s, so one run never
repeats.

The sea is long-crested, travelling along +x: A(t) is the elevation η at the origin and a(t)
the slope ∂η/∂x there, amplitudes ω_i²/g · A_i (eq (30)), a quarter period after η. The slope
takes g from the synthesis (9.80665 m/s²), 0.07 % from the paper's 9.8.

Sea state: 4·sqrt(m0) of the components is 3.05 m (the band holds 98.6 % of the full
spectrum's m0, whose Hs is 0.2092 U²/g = 3.07 m), Tp = 8.77 s, i.e. WMO code 5 "rough"
although the paper calls it level four (docs/sea.md). No vessel: seed 001 feeds the wave
signals straight to the platform (§IV.D.2), scaled as Table 4 states.
"""

from __future__ import annotations

from types import MappingProxyType
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from twin.errors import TwinError
from twin.sea.components import WaveComponents
from twin.sea.spectra import pierson_moskowitz_wind
from twin.sea.synthesis import evaluate_surface, frequency_bins

SEED001_WIND_SPEED = 12.0  # [m/s] U at 19.5 m, seed 001 §IV.C
SEED001_G = 9.8  # [m/s²] seed 001 eq (28)
SEED001_OMEGA = (0.5, 2.4)  # [rad/s] first and last component, seed 001 §IV.C
SEED001_DOMEGA = 0.01  # [rad/s] Δω, seed 001 §IV.C
SEED001_DURATION = 500.0  # [s] seed 001 §IV.C, Fig. 9
SEED001_HEAVE_SCALE = 0.05  # [-] z = 0.05 A(t), seed 001 Table 4 and §IV.D.2


class Table4Row(NamedTuple):
    """Which platform inputs a trajectory drives; the others stay 0 (seed 001 Table 4).

    Attributes:
        z: heave z = 0.05 A(t).
        alpha: roll α = a(t).
        beta: pitch β = a(t).
    """

    z: bool
    alpha: bool
    beta: bool


#: Seed 001 Table 4: P5 (α, β), P6 (β, z), P7 (α, z), P8 (α, β, z), as Table 1's P1-P4.
SEED001_TRAJECTORIES: MappingProxyType[str, Table4Row] = MappingProxyType(
    {
        "P5": Table4Row(z=False, alpha=True, beta=True),
        "P6": Table4Row(z=True, alpha=False, beta=True),
        "P7": Table4Row(z=True, alpha=True, beta=False),
        "P8": Table4Row(z=True, alpha=True, beta=True),
    }
)


def table4_row(trajectory: str) -> Table4Row:
    """The inputs seed 001 Table 4's `trajectory` drives.

    Raises:
        TwinError: unknown trajectory, naming the known ones.
    """
    if trajectory not in SEED001_TRAJECTORIES:
        raise TwinError(
            f"trajectory must be one of {sorted(SEED001_TRAJECTORIES)} (seed 001 Table 4), "
            f"got {trajectory!r}"
        )
    return SEED001_TRAJECTORIES[trajectory]


def seed001_sea(seed: int | np.random.Generator | None = 0) -> WaveComponents:
    """Seed 001's level-4 sea: 191 components on ω_i = 0.50 … 2.40 rad/s, along +x.

    Args:
        seed: seed or Generator of the phases ε_i; the same seed gives the same sea.

    Returns:
        The components; amplitudes A_i = sqrt(2 Δω S(ω_i)) [m] (seed 001 eq (29)).
    """
    low, high = SEED001_OMEGA
    n = round((high - low) / SEED001_DOMEGA) + 1
    half = SEED001_DOMEGA / 2
    # bins centred on the paper's ω_i, so the centres are exactly 0.50, 0.51, ... rad/s
    omega, _ = frequency_bins(n, (low - half, high + half), jitter=False)
    density = pierson_moskowitz_wind(omega, SEED001_WIND_SPEED, g=SEED001_G)  # eq (28)
    amplitude = np.sqrt(2.0 * SEED001_DOMEGA * density)  # eq (29), point value as the paper
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    phase = rng.uniform(0.0, 2.0 * np.pi, size=n)
    return WaveComponents(omega, amplitude, phase, np.zeros(n))


def seed001_inputs(
    t: ArrayLike, seed: int | np.random.Generator | None = 0, trajectory: str = "P8"
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The 3UPU_UP inputs of one of seed 001 Table 4's trajectories at times `t`.

    z = 0.05 A(t), A in m, returned in mm (the 3UPU_UP's unit); α = β = a(t), the slope [m/m]
    read as an angle [rad] (seed 001 §IV.D.2: "the slope of wave surface is as the roll angle
    α and the pitch angle β"). Inputs the trajectory does not drive are 0.

    Args:
        t: [s] times, any shape (seed 001: 0 to `SEED001_DURATION`).
        seed: seed or Generator of the sea's phases (`seed001_sea`).
        trajectory: a key of `SEED001_TRAJECTORIES`.

    Returns:
        z [mm], alpha [rad], beta [rad], each the shape of `t`.

    Raises:
        TwinError: unknown trajectory, or non-finite t.
    """
    table4_row(trajectory)  # an unknown name fails before the sea is computed
    return seed001_trajectory(seed001_signals(t, seed), trajectory)


def seed001_signals(
    t: ArrayLike, seed: int | np.random.Generator | None = 0
) -> tuple[np.ndarray, np.ndarray]:
    """The two wave signals every seed 001 Table 4 trajectory is made of, at times `t`.

    Args:
        t: [s] times, any shape; seed: seed or Generator of the sea's phases (`seed001_sea`).

    Returns:
        z = 0.05 A(t) [mm] (Table 4, the 3UPU_UP's unit) and the slope a(t) [m/m] along the
        travel direction +x (eq (30)), each the shape of `t`.
    """
    heave, slope = evaluate_surface(seed001_sea(seed), t)  # one pass gives both
    return 1e3 * SEED001_HEAVE_SCALE * heave, slope[..., 0]


def seed001_trajectory(
    signals: tuple[np.ndarray, np.ndarray], trajectory: str = "P8"
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A Table 4 trajectory's inputs z [mm], α, β [rad] from the signals of `seed001_signals`
    (one sea serves all four trajectories); inputs it does not drive are 0.

    Raises:
        TwinError: unknown trajectory.
    """
    row = table4_row(trajectory)
    heave, slope = signals
    # own arrays: α and β share a(t), and a caller may edit one in place
    z, alpha, beta = (
        x.copy() if on else np.zeros_like(x)
        for x, on in zip((heave, slope, slope), row, strict=True)
    )
    return z, alpha, beta
