"""The wave buoy analogy (`twin.motion.estimate`) on motion the twin's own sea and vessel make:
it recovers Hs, Tp and the direction (with sensor noise and bias, with heave-roll-pitch alone),
tells port from starboard, and refuses a window too short, too calm or too noisy."""

from __future__ import annotations

import numpy as np
import pytest

from twin.errors import TwinError
from twin.motion.estimate import (
    MIN_WINDOW,
    EstimateRefused,
    cross_spectra,
    estimate_sea,
    window_starts,
)
from twin.sea.synthesis import wave_components
from twin.vessel import DOFS, load_raos, vessel_motion

RAOS = load_raos("sov")
#: white sensor noise [m, m, m, rad, rad, rad] and a constant bias per motion
NOISE = np.array([0.02, 0.02, 0.02, np.radians(0.01), np.radians(0.01), np.radians(0.02)])
BIAS = np.array([0.1, 0.0, 0.05, np.radians(0.2), np.radians(-0.1), 0.3])


def measured(
    hs: float,
    tp: float,
    beta: float,
    *,
    seed: int = 0,
    duration: float = 900.0,
    rate: float = 2.0,
    noise: float = 1.0,
    absent: tuple[str, ...] = (),
) -> tuple:
    """(t, motion) of the SOV in a long-crested JONSWAP sea (β [deg]), noise and bias added;
    the `absent` motions NaN."""  # fmt: skip
    sea = wave_components(hs, tp, heading=np.radians(beta), seed=seed, n_components=300)
    t = np.arange(0.0, duration, 1.0 / rate)
    motion = vessel_motion(sea, RAOS, t)
    rng = np.random.default_rng(seed + 1)
    motion = motion + noise * NOISE * rng.standard_normal(motion.shape) + BIAS
    for name in absent:
        motion[:, DOFS.index(name)] = np.nan
    return t, motion


@pytest.mark.parametrize(("hs", "tp", "beta", "absent"), [
    (2.0, 8.0, 150.0, ()),
    (1.0, 11.0, 60.0, ("surge", "sway", "yaw")),
    (3.0, 6.0, 250.0, ("surge", "sway", "yaw")),
])  # fmt: skip
def test_recovers_the_sea(hs: float, tp: float, beta: float, absent: tuple[str, ...]) -> None:
    """Hs within 15 %, Tp within 10 % and the direction within 20° of the sea that made the
    motion, through noise and bias, with all six motions or heave-roll-pitch alone."""
    estimate = estimate_sea(*measured(hs, tp, beta, absent=absent), RAOS)
    assert abs(estimate.hs / hs - 1.0) < 0.15
    assert abs(estimate.tp / tp - 1.0) < 0.10
    assert abs((estimate.direction - beta + 180.0) % 360.0 - 180.0) < 20.0
    assert np.isfinite([estimate.hs_sd, estimate.tp_sd, estimate.direction_sd]).all()
    assert set(estimate.channels) == set(DOFS) - set(absent)


def test_port_and_starboard_apart() -> None:
    """Mirror seas (β and −β) give the same heave and pitch; the estimate still puts each on
    its own side from the roll cross-spectra, and names the other side's best as `mirror`."""
    port = estimate_sea(*measured(1.5, 9.0, 120.0, absent=("sway", "yaw")), RAOS)
    starboard = estimate_sea(*measured(1.5, 9.0, 240.0, absent=("sway", "yaw")), RAOS)
    assert 0.0 < port.direction < 180.0 < starboard.direction
    assert starboard.mirror <= 180.0 <= port.mirror


def test_uncertainty_shrinks_with_a_longer_window() -> None:
    """A window twice as long (more Welch segments) gives a smaller Hs uncertainty."""
    short = estimate_sea(*measured(2.0, 9.0, 180.0, duration=MIN_WINDOW + 10), RAOS)
    long = estimate_sea(*measured(2.0, 9.0, 180.0, duration=2 * MIN_WINDOW + 20), RAOS)
    assert long.segments > short.segments
    assert long.hs_sd < short.hs_sd


def test_refuses_a_short_window() -> None:
    """A window under 10 min is refused, saying the minimum."""
    with pytest.raises(EstimateRefused, match="at least 600 s"):
        estimate_sea(*measured(2.0, 8.0, 150.0, duration=MIN_WINDOW - 30), RAOS)


def test_refuses_a_calm_sea() -> None:
    """Motion below every channel's noise floor is refused as too calm."""
    with pytest.raises(EstimateRefused, match="too calm"):
        estimate_sea(*measured(0.02, 8.0, 150.0, noise=0.0), RAOS)


def test_refuses_noise_the_raos_cannot_explain() -> None:
    """White noise far above the wave response does not fit the vessel's RAOs: refused as
    too noisy, naming the misfit."""
    with pytest.raises(EstimateRefused, match="too noisy"):
        estimate_sea(*measured(0.5, 8.0, 150.0, noise=400.0), RAOS)


def test_refuses_without_roll() -> None:
    """Heave, roll and pitch are required: a log without roll is refused, naming it."""
    with pytest.raises(EstimateRefused, match="roll"):
        estimate_sea(*measured(2.0, 8.0, 150.0, absent=("roll",)), RAOS)


def test_refuses_uneven_times() -> None:
    """Unevenly sampled times are a TwinError asking for a resampled series."""
    t, motion = measured(2.0, 8.0, 150.0)
    t = t.copy()
    t[10] += 0.2
    with pytest.raises(TwinError, match="uneven"):
        estimate_sea(t, motion, RAOS)


def test_cross_spectra_integrate_to_the_variance() -> None:
    """Welch's auto-spectrum of a regular heave 0.5 cos(0.8 t) integrates to its variance
    0.125 m² over the band (the density in ω the fit relies on), and the cross-spectrum of
    heave with a copy a quarter period later is imaginary (the phase the fit reads)."""
    t = np.arange(0.0, 1200.0, 0.5)
    motion = np.zeros((t.size, 6))
    motion[:, 2] = 0.5 * np.cos(0.8 * t)
    motion[:, 3] = 0.5 * np.sin(0.8 * t)
    spectra = cross_spectra(t, motion, np.array([2, 3]))
    step = spectra.omega[1] - spectra.omega[0]
    assert np.sum(spectra.phi[:, 0, 0].real) * step == pytest.approx(0.125, rel=0.01)
    peak = np.argmax(spectra.phi[:, 0, 0].real)
    assert abs(spectra.phi[peak, 0, 1].real) < 1e-3 * abs(spectra.phi[peak, 0, 1].imag)


def test_window_starts() -> None:
    """Consecutive windows; a last part shorter than 10 min is dropped, a window under 10 min
    refused."""
    assert window_starts(0.0, 2900.0, 1200.0).tolist() == [0.0, 1200.0]
    assert window_starts(0.0, 3000.0, 1200.0).tolist() == [0.0, 1200.0, 2400.0]
    assert window_starts(0.0, 3000.0, 1000.0).tolist() == [0.0, 1000.0, 2000.0]
    with pytest.raises(TwinError):
        window_starts(0.0, 3000.0, 300.0)
