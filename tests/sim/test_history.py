"""The history ring: appends in chunks, reads oldest first, grows while nothing is dropped."""

from __future__ import annotations

import numpy as np
import pytest

from twin.sim.history import History


def chunk(start: int, n: int, lanes: int = 2) -> dict[str, np.ndarray]:
    """n samples numbered start … start + n − 1 for each lane (lane l adds 1000 l)."""
    k = start + np.arange(n)
    t = k[None, :] + 1000.0 * np.arange(lanes)[:, None]
    return {"t": t, "v": np.stack([t, -t], -1)}


@pytest.mark.parametrize("sizes", [(1, 3, 4), (5, 1, 1, 1, 7), (12,), (2, 2, 2, 2, 2, 2)])
def test_ring_keeps_the_newest_in_order(sizes: tuple[int, ...]) -> None:
    """Appended in chunks short and long, wrapping or not, a 5-sample ring keeps the newest
    samples oldest first, and its latest and newest rows are the last appended."""
    ring, total = History(5), 0
    for n in sizes:
        ring.append(chunk(total, n))
        total += n
    kept = np.arange(max(0, total - 5), total)
    assert len(ring) == kept.size and ring.complete == (total <= 5)
    np.testing.assert_array_equal(ring.series(1)["t"], kept + 1000.0)
    np.testing.assert_array_equal(ring.series(0)["v"][:, 1], -kept)
    assert ring.latest(1)["t"] == total - 1 + 1000.0
    np.testing.assert_array_equal(ring.newest()["t"], [total - 1, total - 1 + 1000.0])


def test_reserve_grows_an_unwrapped_history_and_refuses_a_wrapped_one() -> None:
    """reserve grows a history that has not wrapped and raises ValueError on one that dropped
    samples."""
    history = History(4)
    history.append(chunk(0, 3))
    history.reserve(10)
    history.append(chunk(3, 6))
    np.testing.assert_array_equal(history.series(0)["t"], np.arange(9))
    ring = History(2)
    ring.append(chunk(0, 3))
    with pytest.raises(ValueError, match="dropped"):
        ring.reserve(5)


def test_backfill_first_copies_the_first_steps_values_into_sample_zero() -> None:
    """backfill_first copies the first step's values of the named keys into sample 0, other keys
    left."""
    history = History(4)
    history.append({"t": np.zeros((1, 1)), "d": np.zeros((1, 1))})
    step = {"t": np.ones((1, 2)), "d": np.array([[7.0, 8.0]])}
    history.backfill_first(step, {"d"})
    history.append(step)
    np.testing.assert_array_equal(history.series(0)["d"], [7.0, 7.0, 8.0])
    np.testing.assert_array_equal(history.series(0)["t"], [0.0, 1.0, 1.0])


def test_adopt_makes_a_whole_runs_records_the_history_without_a_copy() -> None:
    """adopt takes a run's arrays without copying, copies once the run grows, and refuses a history
    past sample 0."""
    history = History(1)
    history.append(chunk(0, 1))
    run = chunk(0, 6)
    history.adopt(run)
    assert len(history) == 6 and history.complete
    view = history.series(1, copy=False)
    assert np.shares_memory(view["v"], run["v"])  # the run's own arrays: nothing copied
    np.testing.assert_array_equal(view["t"], np.arange(6) + 1000.0)
    history.reserve(8)  # a run that grows afterwards moves to arrays of its own
    history.append(chunk(6, 2))
    np.testing.assert_array_equal(history.series(0)["t"], np.arange(8))
    assert not np.shares_memory(history.data["v"], run["v"])
    with pytest.raises(ValueError, match="sample 0 alone"):
        history.adopt(chunk(0, 8))
