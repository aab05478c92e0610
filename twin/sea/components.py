"""A sea as a finite sum of linear (Airy) wave components.

This is the one hand-off between the sea layer and the vessel layer: spectra, random-phase
synthesis and regular-wave presets all produce `WaveComponents`; the vessel layer maps each
component through its RAOs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from twin.errors import TwinError

G = 9.80665  # [m/s²] standard gravity


@dataclass(frozen=True)
class WaveComponents:
    """Deep-water waves, η(x, y, t) = Σ a_i cos(k_i (x cos μ_i + y sin μ_i) - ω_i t + ε_i).

    Attributes:
        omega: (k,) [rad/s] angular frequencies, > 0.
        amplitude: (k,) [m] amplitudes a_i ≥ 0.
        phase: (k,) [rad] phases ε_i.
        direction: (k,) [rad] direction each component travels *towards*, in the inertial
            frame (x east-ish, z up), measured from +x counter-clockwise.
    """

    omega: np.ndarray
    amplitude: np.ndarray
    phase: np.ndarray
    direction: np.ndarray

    def __post_init__(self) -> None:
        fields = (self.omega, self.amplitude, self.phase, self.direction)
        arrays = [np.asarray(a, dtype=float) for a in fields]
        shapes = {a.shape for a in arrays}
        if len(shapes) != 1 or arrays[0].ndim != 1:
            raise TwinError(f"WaveComponents arrays must share one 1-D shape, got {shapes}")
        for name, a in zip(("omega", "amplitude", "phase", "direction"), arrays, strict=True):
            if not np.all(np.isfinite(a)):
                raise TwinError(f"WaveComponents.{name} must be finite")
            object.__setattr__(self, name, a)
        if np.any(arrays[0] <= 0):
            raise TwinError("WaveComponents.omega must be > 0 rad/s")

    @property
    def wavenumber(self) -> np.ndarray:
        """(k,) [rad/m] deep-water dispersion k = ω²/g."""
        return self.omega**2 / G
