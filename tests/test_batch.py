"""`twin.batch.LaneBatch`: a lane function over a broadcast batch, compiled and interpreted."""

from __future__ import annotations

import numpy as np
import pytest

from twin.batch import LaneBatch
from twin.mechanisms import HybridBoardingSystem
from twin.planners.allocation_step import REACHABLE_RANGE
from twin.planners.limits import VELOCITY_LIMIT

H = HybridBoardingSystem()


def _scaled_sum(
    x: np.ndarray, y: np.ndarray, factor: float, out: np.ndarray, total: np.ndarray
) -> None:
    """out (N, n) = factor·x + y, total (N,) = Σ out: a toy loop with a per-lane float."""
    for k in range(x.shape[0]):
        s = 0.0
        for j in range(x.shape[1]):
            out[k, j] = factor * x[k, j] + y[k]
            s += out[k, j]
        total[k] = s


SCALED_SUM = LaneBatch(_scaled_sum, cores=(1, 0))


@pytest.mark.parametrize("plain", [False, True])
def test_leading_axes_broadcast_and_come_back(plain: bool, rng: np.random.Generator) -> None:
    """x (2, 1, 4, n) with y (3, 4): the lanes are the broadcast (2, 3, 4); each output comes
    back with those axes before its core; a single lane gives numpy floats, as ufuncs do."""
    x, y = rng.normal(size=(2, 1, 4, 5)), rng.normal(size=(3, 4))
    out, total = SCALED_SUM([x, y], [2.5], [(5,), ()], plain=plain)
    expect = 2.5 * x + y[..., None]
    assert out.shape == (2, 3, 4, 5) and total.shape == (2, 3, 4)
    np.testing.assert_allclose(out, expect, rtol=0, atol=1e-15)
    np.testing.assert_allclose(total, expect.sum(-1), rtol=0, atol=1e-12)
    one, one_total = SCALED_SUM([x[0, 0, 0], y[0, 0]], [2.5], [(5,), ()], plain=plain)
    assert one.shape == (5,) and isinstance(one_total, np.floating)
    empty, _ = SCALED_SUM([np.zeros((0, 5)), 1.0], [2.5], [(5,), ()], plain=plain)
    assert empty.shape == (0, 5)


def test_an_input_without_its_core_axes_is_refused() -> None:
    """An input with fewer axes than its core signature raises ValueError saying so."""
    with pytest.raises(ValueError, match="fewer axes than its core"):
        SCALED_SUM([1.0, 1.0], [2.5], [(1,), ()])


def test_interpreted_loop_gives_the_compiled_numbers(rng: np.random.Generator) -> None:
    """The plain-Python fallback runs the same lane functions: the same numbers (to rounding
    of the compiled code's contracted multiply-adds) on the engine's lanes."""
    state = H.stewart.legs(H.working_state[:6] + rng.normal(scale=0.05, size=(20, 6)))
    limits = [H.stewart.leg_min, H.stewart.leg_max]
    batched = [state.vectors, state.lengths]
    compiled = REACHABLE_RANGE(batched, limits, [(3,)])[0]
    plain = REACHABLE_RANGE(batched, limits, [(3,)], plain=True)[0]
    np.testing.assert_allclose(plain, compiled, rtol=0, atol=1e-12)
    v, maximum = rng.normal(size=(20, 9)), np.full(9, 0.3)
    compiled_v = VELOCITY_LIMIT([v, maximum], [], [(9,), ()])
    plain_v = VELOCITY_LIMIT([v, maximum], [], [(9,), ()], plain=True)
    for a, b in zip(compiled_v, plain_v, strict=True):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-15)
