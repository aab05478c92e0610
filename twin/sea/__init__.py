"""Sea layer: wave spectra, sea states, time-domain synthesis and regular-wave presets."""

from __future__ import annotations

from twin.sea.components import G, WaveComponents
from twin.sea.presets import SEED001_TRAJECTORIES, seed001_inputs, seed001_sea
from twin.sea.regular import REGULAR_PRESETS, regular_components
from twin.sea.sea_states import WMO_SEA_STATES, SeaState, sea_state_code, sea_state_hs_tp
from twin.sea.spectra import (
    SPECTRA,
    cos2s_spreading,
    dnv_gamma,
    fully_developed_tp,
    jonswap,
    jonswap_normalisation,
    pierson_moskowitz,
    pierson_moskowitz_wind,
    pm_sea_from_wind,
    spectral_density,
    tp_from_tz,
    zero_crossing_ratio,
)
from twin.sea.surface import gerstner_points, surface_heights
from twin.sea.synthesis import (
    WaveChunk,
    WaveStream,
    elevation,
    evaluate_elevation,
    evaluate_slope,
    evaluate_surface,
    frequency_bins,
    slope,
    wave_components,
)

__all__ = [
    "REGULAR_PRESETS",
    "SEED001_TRAJECTORIES",
    "SPECTRA",
    "WMO_SEA_STATES",
    "G",
    "SeaState",
    "WaveChunk",
    "WaveComponents",
    "WaveStream",
    "cos2s_spreading",
    "dnv_gamma",
    "elevation",
    "evaluate_elevation",
    "evaluate_slope",
    "evaluate_surface",
    "frequency_bins",
    "fully_developed_tp",
    "gerstner_points",
    "jonswap",
    "jonswap_normalisation",
    "pierson_moskowitz",
    "pierson_moskowitz_wind",
    "pm_sea_from_wind",
    "regular_components",
    "sea_state_code",
    "sea_state_hs_tp",
    "seed001_inputs",
    "seed001_sea",
    "slope",
    "spectral_density",
    "surface_heights",
    "tp_from_tz",
    "wave_components",
    "zero_crossing_ratio",
]
