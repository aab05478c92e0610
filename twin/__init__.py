"""Digital twin of offshore wave-motion compensation systems.

Layers, each a subpackage, data flowing one way:
sea → vessel → mechanisms → planners → simulation → runs (executor, sweeps, workability,
claims) → web.
"""

from __future__ import annotations

__version__ = "0.1.0"
