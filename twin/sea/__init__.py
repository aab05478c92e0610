"""Sea layer: wave spectra, sea states, time-domain synthesis and regular-wave presets."""

from __future__ import annotations

from twin.sea.components import G, WaveComponents

__all__ = ["G", "WaveComponents"]
