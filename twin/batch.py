"""A lane function over a batch of lanes: how the objects' vectorised API runs the kernels' math.

Each primitive is written once, as a lane function over one lane's floats and small arrays
(`twin.compiled`). An object that takes a batch (leading axes `...`) calls it through a
`LaneBatch`: a plain loop over the lanes, written next to the lane it calls,

    def _tip_batch(q, d1, a1, out):          # q (N, 3) batched, d1 and a1 fixed, out (N, 4, 4)
        for k in range(q.shape[0]):
            gangway_tip_lane(q[k, 0], q[k, 1], q[k, 2], d1, a1, out[k])

    TIP = LaneBatch(_tip_batch, cores=(1,))
    T = TIP([q], [d1, a1], [(4, 4)])[0]      # q (..., 3) → T (..., 4, 4)

`LaneBatch` broadcasts the batched inputs' leading axes against each other, flattens them to
one axis N (C-contiguous float64, so one compiled signature serves every call), allocates the
outputs (N, *core), runs the loop and gives the outputs back shaped (..., *core). The loop is
compiled by `twin.compiled.compile_runner` (serial, cached on disk under a name stamped with
the sources it reaches) lazily on the first call; without numba it runs as plain Python: the
same lane functions, interpreted.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import ArrayLike

from twin.compiled import _COMPILING, compile_runner


class LaneBatch:
    """A loop `loop(*batched, *fixed, *outputs)` over the lanes of a batch (module doc).

    Attributes:
        loop: the plain loop: batched inputs (N, *core) first, then the fixed arguments (the
            same for every lane), then the outputs (N, *core), written.
        cores: each batched input's number of core (per-lane) axes, in order.
    """

    def __init__(self, loop: Callable[..., None], cores: tuple[int, ...]) -> None:
        self.loop, self.cores = loop, cores
        self._compiled: Callable | None = None
        self.__doc__ = loop.__doc__

    def compiled(self) -> Callable:
        """The loop compiled (or loaded from numba's cache) on first use; the plain loop
        without numba."""
        if self._compiled is None:
            with _COMPILING:
                if self._compiled is None:  # another thread may have built it meanwhile
                    self._compiled = compile_runner(self.loop, False)
        return self._compiled

    def __call__(
        self,
        batched: Sequence[ArrayLike],
        fixed: Sequence[object],
        outputs: Sequence[tuple[int, ...]],
        *,
        plain: bool = False,
    ) -> list[np.ndarray]:
        """Run the loop over the broadcast batch.

        Args:
            batched: the per-lane inputs, each (..., *core) with len(core) = `cores[i]`; the
                leading axes broadcast against each other.
            fixed: the arguments every lane shares (floats, or float arrays passed as they are).
            outputs: each output's core shape per lane (() for one float per lane).
            plain: run the plain Python loop (the interpreted fallback), not the compiled one.

        Returns:
            The outputs, each (..., *core); a float output of a single lane (no leading axes)
            as a numpy float, as numpy's ufuncs give it.
        """
        arrays = [np.asarray(a, dtype=float) for a in batched]
        splits = [a.ndim - core for a, core in zip(arrays, self.cores, strict=True)]
        if min(splits, default=0) < 0:
            raise ValueError(f"{self.loop.__name__}: an input has fewer axes than its core")
        shape = np.broadcast_shapes(*(a.shape[:s] for a, s in zip(arrays, splits, strict=True)))
        n = int(np.prod(shape, dtype=np.int64))
        flat = [
            np.ascontiguousarray(np.broadcast_to(a, shape + a.shape[s:]).reshape(n, *a.shape[s:]))
            for a, s in zip(arrays, splits, strict=True)
        ]
        results = [np.empty((n, *core)) for core in outputs]
        loop = self.loop if plain else self.compiled()
        loop(*flat, *fixed, *results)
        shaped = [r.reshape(shape + r.shape[1:]) for r in results]
        return [r[()] if r.ndim == 0 else r for r in shaped]
