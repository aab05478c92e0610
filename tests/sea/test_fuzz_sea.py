"""Property-based fuzzing of the sea layer: spectra, sea states, synthesis (issue 8).

Every finite input inside the Scenario ranges (Hs 0-20 m, Tp 1-30 s, γ 1-10, s 1-100 or
long-crested, 8-2048 components) gives finite, bounded output; bad input raises a ValueError
that names the argument.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.integrate import quad

from tests.figures import fuzz
from twin.sea import (
    WMO_SEA_STATES,
    cos2s_spreading,
    elevation,
    evaluate_elevation,
    evaluate_slope,
    jonswap,
    jonswap_normalisation,
    pierson_moskowitz,
    pierson_moskowitz_wind,
    pm_sea_from_wind,
    sea_state_code,
    sea_state_hs_tp,
    wave_components,
)
from twin.sea.synthesis import OMEGA_BAND


def finite(low: float, high: float) -> st.SearchStrategy[float]:
    return st.floats(low, high, allow_nan=False, allow_infinity=False)


OMEGA = arrays(np.float64, st.integers(1, 32), elements=finite(0.0, 1e3))  # [rad/s], 0 included
HS, TP, GAMMA = finite(0.0, 20.0), finite(1.0, 30.0), finite(1.0, 10.0)  # Scenario ranges
SPREADING = st.none() | finite(1.0, 100.0)
HEADING = finite(-360.0, 360.0).map(np.deg2rad)  # [rad]
SPECTRUM = st.sampled_from(["jonswap", "pierson_moskowitz"])
NONFINITE = st.sampled_from([np.nan, np.inf, -np.inf])
NEGATIVE = st.floats(max_value=-np.finfo(float).smallest_subnormal, allow_infinity=False)


@fuzz(300)
@given(omega=OMEGA, hs=HS, tp=TP, gamma=GAMMA)
def test_spectra_are_finite_non_negative_and_bracketed(omega, hs, tp, gamma) -> None:
    """PM and JONSWAP are finite and ≥ 0, 0 at ω = 0, and A(γ) S_PM ≤ S_J ≤ A(γ) γ S_PM."""
    pm = pierson_moskowitz(omega, hs, tp)
    js = jonswap(omega, hs, tp, gamma)
    scale = jonswap_normalisation(gamma)
    for s in (pm, js):
        assert s.shape == omega.shape and np.all(np.isfinite(s)) and np.all(s >= 0.0)
        assert np.all(s[omega == 0.0] == 0.0)
    assert 0.0 < scale <= 1.0
    np.testing.assert_array_less(scale * pm * (1 - 1e-12) - 1e-300, js)  # γ^r ≥ 1
    np.testing.assert_array_less(js, scale * gamma * pm * (1 + 1e-12) + 1e-300)  # γ^r ≤ γ
    np.testing.assert_allclose(jonswap(omega, hs, tp, 1.0), pm, rtol=1e-12, atol=0)  # γ = 1


@fuzz(200)
@given(omega=OMEGA, wind_speed=finite(0.1, 60.0))
def test_wind_spectrum_is_the_pm_of_its_fully_developed_sea(omega, wind_speed) -> None:
    """S(ω; U) of seed 001 eq (28) is finite, ≥ 0 and the (Hs, Tp) PM of `pm_sea_from_wind`."""
    s = pierson_moskowitz_wind(omega, wind_speed)
    assert np.all(np.isfinite(s)) and np.all(s >= 0.0)
    hs, tp = pm_sea_from_wind(wind_speed)
    assert np.isfinite(hs) and np.isfinite(tp) and hs > 0 and tp > 0
    np.testing.assert_allclose(s, pierson_moskowitz(omega, hs, tp), rtol=1e-9, atol=1e-300)


@fuzz(200)
@given(mean_direction=finite(-1e3, 1e3), s=finite(0.0, 100.0))
def test_cos2s_spreading_is_a_finite_unit_density(mean_direction, s) -> None:
    """D(θ) is finite, ≥ 0, peaks at θ_m and integrates to 1 over any 2π interval."""
    theta = mean_direction + np.linspace(-np.pi, np.pi, 4097)
    density = cos2s_spreading(theta, mean_direction, s)
    assert np.all(np.isfinite(density)) and np.all(density >= 0.0)
    assert density[2048] == pytest.approx(density.max(), rel=1e-12)
    m = mean_direction
    integral, _ = quad(cos2s_spreading, m - np.pi, m + np.pi, args=(m, s), points=[m], limit=200)
    assert integral == pytest.approx(1.0, abs=1e-9)


@fuzz(300)
@given(codes=arrays(np.float64, 2, elements=finite(0.0, 9.0)))
def test_sea_state_hs_tp_is_finite_and_monotone(codes) -> None:
    """Fractional codes 0-9 give finite Hs ≥ 0, Tp > 0, both non-decreasing with the code,
    Hs between its neighbouring codes' values; integer codes map back by `sea_state_code`."""
    low, high = np.sort(codes)
    (hs_lo, hs_hi), (tp_lo, tp_hi) = sea_state_hs_tp([low, high])
    assert np.all(np.isfinite([hs_lo, hs_hi, tp_lo, tp_hi]))
    assert 0.0 <= hs_lo <= hs_hi and 0.0 < tp_lo <= tp_hi
    below, above = WMO_SEA_STATES[int(np.floor(low))], WMO_SEA_STATES[int(np.ceil(low))]
    assert below.hs <= hs_lo <= above.hs
    code = int(np.round(low))
    assert sea_state_code(sea_state_hs_tp(code)[0]) == code


@fuzz(200)
@given(
    hs=HS,
    tp=TP,
    spectrum=SPECTRUM,
    heading=HEADING,
    spreading=SPREADING,
    seed=st.integers(0, 2**32 - 1),
    n_components=st.integers(8, 64) | st.integers(8, 2048),
    gamma=GAMMA,
    t=arrays(np.float64, st.integers(1, 16), elements=finite(-1e4, 1e4)),
    x=finite(-1e3, 1e3),
    y=finite(-1e3, 1e3),
)
def test_wave_components_and_elevation_are_finite_and_bounded(
    hs, tp, spectrum, heading, spreading, seed, n_components, gamma, t, x, y
) -> None:
    """Components lie in the band with Σa²/2 within 1 % of Hs²/16; η and ∇η are finite
    and |η| ≤ Σ a_i at any time and place (seed 001 eqs (29)-(30))."""
    c = wave_components(hs, tp, spectrum, heading, spreading, seed, n_components, gamma=gamma)
    for a in (c.omega, c.amplitude, c.phase, c.direction):
        assert a.shape == (n_components,) and np.all(np.isfinite(a))
    band = np.array(OMEGA_BAND) * 2 * np.pi / tp
    assert np.all((c.omega >= band[0] * (1 - 1e-12)) & (c.omega <= band[1] * (1 + 1e-12)))
    assert np.all(c.amplitude >= 0.0)
    energy = np.sum(c.amplitude**2) / 2
    assert energy == pytest.approx(hs**2 / 16, rel=1e-2, abs=1e-12)
    eta = evaluate_elevation(c, t, x, y)
    grad = evaluate_slope(c, t, x, y)
    assert eta.shape == t.shape and grad.shape == (*t.shape, 2)
    assert np.all(np.isfinite(eta)) and np.all(np.isfinite(grad))
    assert np.all(np.abs(eta) <= np.sum(c.amplitude) * (1 + 1e-9) + 1e-12)
    sea = {"heading": heading, "spreading": spreading, "n_components": n_components}
    same = elevation(t, hs, tp, spectrum, seed, x=x, y=y, gamma=gamma, **sea)
    np.testing.assert_array_equal(same, eta)  # the same arguments give the same sea


def _wave(**kwargs: Any) -> Any:
    return wave_components(**{"hs": 2.0, "tp": 8.0, "n_components": 8, **kwargs})


# (name the message starts with, call with the bad value, bad values)
BAD_SEA: list[tuple[str, Callable[[Any], Any], st.SearchStrategy]] = [
    ("omega", lambda v: pierson_moskowitz([1.0, v], 2.0, 8.0), NONFINITE | NEGATIVE),
    ("hs", lambda v: pierson_moskowitz(1.0, v, 8.0), NONFINITE | NEGATIVE),
    ("tp", lambda v: jonswap(1.0, 2.0, v), NONFINITE | NEGATIVE | st.just(0.0)),
    ("gamma", lambda v: jonswap(1.0, 2.0, 8.0, v), NONFINITE | finite(-1e6, 1.0 - 1e-9)),
    ("gamma", lambda v: jonswap_normalisation(v), finite(10.0 + 1e-9, 1e6)),
    ("wind_speed", lambda v: pierson_moskowitz_wind(1.0, v), NONFINITE | NEGATIVE | st.just(0.0)),
    ("theta", lambda v: cos2s_spreading([0.0, v], 0.0, 2.0), NONFINITE),
    ("mean_direction", lambda v: cos2s_spreading(0.0, v, 2.0), NONFINITE),
    ("s", lambda v: cos2s_spreading(0.0, 0.0, v), NONFINITE | NEGATIVE),
    ("sea-state code", sea_state_hs_tp, NONFINITE | NEGATIVE | finite(9.0 + 1e-9, 1e6)),
    ("hs", lambda v: _wave(hs=v), NONFINITE | NEGATIVE),
    ("tp", lambda v: _wave(tp=v), NONFINITE | NEGATIVE | st.just(0.0)),
    ("heading", lambda v: _wave(heading=v), NONFINITE),
    ("spreading", lambda v: _wave(spreading=v), NONFINITE | NEGATIVE),
    ("gamma", lambda v: _wave(gamma=v), NONFINITE | finite(10.0 + 1e-9, 1e6)),
    ("n_components", lambda v: _wave(n_components=v), st.integers(-(2**40), 0) | finite(1, 9)),
    ("t", lambda v: elevation([0.0, v], 2.0, 8.0, n_components=8), NONFINITE),
    ("x", lambda v: elevation(0.0, 2.0, 8.0, n_components=8, x=v), NONFINITE),
    ("y", lambda v: elevation(0.0, 2.0, 8.0, n_components=8, y=v), NONFINITE),
]


@fuzz(200)
@given(data=st.data())
def test_bad_sea_input_raises_a_value_error_naming_it(data: st.DataObject) -> None:
    """NaN, inf or out-of-range input: a ValueError whose message starts with the argument."""
    name, call, bad = data.draw(st.sampled_from(BAD_SEA), label="argument")
    value = data.draw(bad, label=name)
    with pytest.raises(ValueError, match=rf"^{re.escape(name)} must"):
        call(value)
