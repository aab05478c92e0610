"""`wave_components` with its per-sea-state work cached (bins, bin energies, the spreading CDF)
and its scalar checks in plain Python: the same bits as the plain computation for every seed,
cached arrays nobody can write through, and the same errors, every time."""

from __future__ import annotations

import re

import numpy as np
import pytest

from twin.errors import TwinError
from twin.sea.spectra import cos2s_spreading, spectral_density
from twin.sea.synthesis import OMEGA_BAND, frequency_bins, wave_components


def plain_components(
    hs: float,
    tp: float,
    spectrum: str = "jonswap",
    heading: float = 0.0,
    spreading: float | None = None,
    seed: int = 0,
    n: int = 256,
    gamma: float = 3.3,
    omega_range: tuple[float, float] | None = None,
    jitter: bool = True,
) -> tuple[np.ndarray, ...]:
    """The components as computed before any caching: (omega, amplitude, phase, direction)."""
    rng = np.random.default_rng(seed)
    band = tuple(r * 2.0 * np.pi / tp for r in OMEGA_BAND) if omega_range is None else omega_range
    edges = np.linspace(*np.asarray(band, dtype=float), n + 1)
    offset = rng.uniform(size=n) if jitter else np.full(n, 0.5)
    omega = edges[:-1] + offset * np.diff(edges)
    nodes, weights = np.polynomial.legendre.leggauss(8)
    width = np.diff(edges)[:, None]
    density = spectral_density(edges[:-1, None] + (nodes + 1.0) / 2.0 * width, hs, tp,
                               spectrum, gamma=gamma)  # fmt: skip
    amplitude = np.sqrt(2.0 * np.sum(density * weights * width / 2.0, axis=-1))
    phase = rng.uniform(0.0, 2.0 * np.pi, size=n)
    if spreading is None:
        direction = np.full(n, float(heading))
    else:
        grid = np.linspace(-np.pi, np.pi, 4097)
        d = cos2s_spreading(grid, 0.0, spreading)
        cdf = np.concatenate([[0.0], np.cumsum((d[1:] + d[:-1]) / 2 * np.diff(grid))])
        direction = heading + np.interp(rng.uniform(size=n), cdf / cdf[-1], grid)
    return omega, amplitude, phase, direction


CASES = [
    {"hs": 2.5, "tp": 9.0},
    {"hs": 2.5, "tp": 9.0, "spectrum": "pierson_moskowitz", "n": 64},
    {"hs": 4.1, "tp": 8.8, "heading": 2.6, "n": 200, "gamma": 1.0},
    {"hs": 1.0, "tp": 6.0, "spreading": 4.0, "heading": -1.0, "n": 61},
    {"hs": 0.0, "tp": 3.0, "n": 8, "gamma": 7},
    {"hs": 3.0, "tp": 12.0, "omega_range": (0.2, 2.0), "n": 33, "spreading": 0.5},
    {"hs": 2.0, "tp": 8.0, "jitter": False, "n": 50},
]


@pytest.mark.parametrize("case", CASES)
def test_bits_equal_the_plain_computation_for_every_seed(case: dict) -> None:
    """Seeds interleaved with other sea states, so hits and misses of every cache both occur."""
    other = {"hs": 1.7, "tp": 7.0, "spreading": 2.0, "n": 40}
    for seed in (0, 1, 2, 2**32 - 1, 1):
        for spec in (case, other):
            kwargs = {**spec, "seed": seed}
            n = kwargs.pop("n", 256)
            components = wave_components(**kwargs, n_components=n)
            got = (components.omega, components.amplitude, components.phase,
                   components.direction)  # fmt: skip
            for a, b in zip(got, plain_components(**kwargs, n=n), strict=True):
                assert a.tobytes() == b.tobytes()


def test_numpy_and_python_scalars_give_the_same_sea() -> None:
    """The plain-Python check of a float and `_checked`'s conversion of anything else agree."""
    as_floats = wave_components(2.0, 8.0, heading=0.5, spreading=3.0, seed=4)
    as_numpy = wave_components(np.array(2.0), np.float32(8.0), heading=np.array(0.5),
                               spreading=np.int64(3), seed=4, gamma=np.float64(3.3))  # fmt: skip
    for name in ("omega", "amplitude", "phase", "direction"):
        assert getattr(as_floats, name).tobytes() == getattr(as_numpy, name).tobytes()


def test_cached_arrays_cannot_be_corrupted() -> None:
    """What a caller gets is its own (writable); writing into it changes no later sea."""
    first = wave_components(2.0, 8.0, spreading=2.0, seed=1, n_components=20)
    first.amplitude[:] = -1.0
    first.omega[:] = 0.0
    _, edges = frequency_bins(20, (0.5, 2.0), seed=1)
    edges[:] = 0.0
    again = wave_components(2.0, 8.0, spreading=2.0, seed=1, n_components=20)
    plain = plain_components(2.0, 8.0, spreading=2.0, seed=1, n=20)
    assert again.amplitude.tobytes() == plain[1].tobytes()
    assert again.omega.tobytes() == plain[0].tobytes()
    np.testing.assert_array_equal(frequency_bins(20, (0.5, 2.0), seed=1)[1],
                                  np.linspace(0.5, 2.0, 21))  # fmt: skip


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"hs": -1.0}, "hs must be finite and in [0, inf] m, got [-1.0]"),
        ({"hs": float("nan")}, "hs must be finite and in [0, inf] m"),
        ({"tp": 0.0}, "tp must be finite and in (0, inf] s, got [0.0]"),
        ({"tp": "x"}, "tp must be a number in (0, inf] s"),
        ({"heading": float("inf")}, "heading must be finite and in [-inf, inf] rad"),
        ({"spreading": -2}, "spreading must be finite and in [0, inf], got [-2.0]"),
        ({"spectrum": "bretschneider"}, "spectrum must be one of"),
        ({"gamma": 20.0}, "gamma must be finite and in [1, 10]"),
        ({"omega_range": (2.0, 1.0)}, "omega_range must be (low, high) with low < high"),
        ({"omega_range": (0.0, 1.0)}, "omega_range must be finite and in (0, inf] rad/s"),
        ({"omega_range": (0.5, float("inf"))}, "omega_range must be finite and in (0, inf]"),
        ({"n_components": 0}, "n_components must be an integer ≥ 1"),
    ],
)
def test_errors_are_raised_every_time(kwargs: dict, message: str) -> None:
    """A bad argument raises its TwinError on the first call and again on the next (a failed
    computation leaves nothing in a cache)."""
    arguments = {"hs": 2.0, "tp": 8.0, **kwargs}
    for _ in range(2):
        with pytest.raises(TwinError, match=re.escape(message)):
            wave_components(**arguments)
