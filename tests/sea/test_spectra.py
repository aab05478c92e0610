"""Spectra: seed 001 eq (28) (SPEC erratum 8), DNV-RP-C205 PM/JONSWAP, cos-2s; wavespectra peer."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import minimize_scalar
from wavespectra.construct.direction import cartwright
from wavespectra.construct.frequency import jonswap as ws_jonswap
from wavespectra.construct.frequency import pierson_moskowitz as ws_pierson_moskowitz

from twin.errors import TwinError
from twin.sea import G
from twin.sea.spectra import (
    cos2s_spreading,
    dnv_gamma,
    jonswap,
    jonswap_normalisation,
    pierson_moskowitz,
    pierson_moskowitz_wind,
    pm_sea_from_wind,
    spectral_density,
    tp_from_tz,
    zero_crossing_ratio,
)

HS, TP = 2.5, 9.0  # [m], [s]
GAMMAS = [1.0, 2.0, 3.3, 5.0, 7.0, 10.0]
SPECTRA = [
    pytest.param(lambda w: pierson_moskowitz(w, HS, TP), id="pierson_moskowitz"),
    *(pytest.param(lambda w, g=g: jonswap(w, HS, TP, g), id=f"jonswap-{g}") for g in GAMMAS),
]


def _m0(spectrum, omega_p: float) -> float:
    """∫₀^∞ S dω by adaptive quadrature, split at the peak and at 10 ω_p."""
    head = quad(spectrum, 0.0, omega_p, limit=200)[0]
    body = quad(spectrum, omega_p, 10 * omega_p, limit=200)[0]
    return head + body + quad(spectrum, 10 * omega_p, np.inf, limit=200)[0]


@pytest.mark.parametrize("spectrum", SPECTRA)
def test_m0_gives_hs(spectrum) -> None:
    """4·sqrt(m0) = Hs (brief asks 1 %; the exact normalisation holds to 1e-6)."""
    m0 = _m0(spectrum, 2 * np.pi / TP)
    assert m0 == pytest.approx(HS**2 / 16, rel=1e-6)


@pytest.mark.parametrize("spectrum", SPECTRA)
def test_peak_at_two_pi_over_tp(spectrum) -> None:
    """S(ω) peaks at ω_p = 2π/Tp."""
    omega_p = 2 * np.pi / TP
    bounds = (0.5 * omega_p, 2 * omega_p)
    found = minimize_scalar(lambda w: -spectrum(w), bounds=bounds, options={"xatol": 1e-10})
    assert found.x == pytest.approx(omega_p, rel=1e-5)


@pytest.mark.parametrize("wind_speed", [5.0, 12.0, 25.0])
def test_wind_form_hs_and_peak(wind_speed: float) -> None:
    """Fully developed PM: Hs ≈ 0.21 U²/g and ω_p ≈ 0.877 g/U (standard relations)."""
    spectrum = lambda w: pierson_moskowitz_wind(w, wind_speed)  # noqa: E731
    omega_p = 0.877 * G / wind_speed
    hs = 4 * np.sqrt(_m0(spectrum, omega_p))
    assert hs == pytest.approx(0.21 * wind_speed**2 / G, rel=5e-3)  # 0.2092 exactly
    found = minimize_scalar(
        lambda w: -spectrum(w), bounds=(0.5 * omega_p, 2 * omega_p), method="bounded"
    )
    assert found.x == pytest.approx(omega_p, rel=1e-3)


@pytest.mark.parametrize("g", [G, 9.8])
def test_hs_tp_form_equals_wind_form(g: float) -> None:
    """PM(Hs, Tp) with (Hs, Tp) of a fully developed sea is seed 001 eq (28) for that U."""
    omega = np.linspace(0.05, 4.0, 400)
    hs, tp = pm_sea_from_wind(12.0, g=g)
    with np.errstate(under="ignore"):
        expected = 0.0081 * g**2 / omega**5 * np.exp(-0.74 * (g / (12.0 * omega)) ** 4)
    np.testing.assert_allclose(pierson_moskowitz_wind(omega, 12.0, g=g), expected, rtol=1e-13)
    np.testing.assert_allclose(pierson_moskowitz(omega, hs, tp), expected, rtol=1e-12)


def test_jonswap_gamma_one_is_pierson_moskowitz() -> None:
    """JONSWAP with gamma 1 equals Pierson-Moskowitz at every frequency."""
    omega = np.linspace(0.0, 5.0, 501)
    np.testing.assert_allclose(jonswap(omega, HS, TP, 1.0), pierson_moskowitz(omega, HS, TP))


@pytest.mark.parametrize("gamma", GAMMAS)
def test_jonswap_normalisation_matches_adaptive_quadrature(gamma: float) -> None:
    """A(γ) = 1 / ∫ γ^r S_PM/m0 dω, computed independently by scipy's quad in ω/ω_p."""

    def shape(x: float) -> float:
        sigma = 0.07 if x <= 1 else 0.09
        return 5 * x**-5 * np.exp(-1.25 * x**-4) * gamma ** np.exp(-((x - 1) ** 2) / (2 * sigma**2))

    integral = quad(shape, 0.05, 1.0, limit=200)[0] + quad(shape, 1.0, np.inf, limit=200)[0]
    assert jonswap_normalisation(gamma) == pytest.approx(1 / integral, rel=1e-9)


@pytest.mark.parametrize("gamma", GAMMAS)
def test_zero_crossing_ratio_matches_adaptive_quadrature(gamma: float) -> None:
    """Tz/Tp = √(m0/m2) / ω_p·2π/… : m0 and m2 of the JONSWAP shape by scipy's quad in ω/ω_p."""

    def shape(x: float, k: int) -> float:
        sigma = 0.07 if x <= 1 else 0.09
        peak = gamma ** np.exp(-((x - 1) ** 2) / (2 * sigma**2))
        return x**k * 5 * x**-5 * np.exp(-1.25 * x**-4) * peak

    m0, m2 = (quad(shape, 0.05, 1.0, args=(k,), limit=200)[0]
              + quad(shape, 1.0, np.inf, args=(k,), limit=200)[0] for k in (0, 2))  # fmt: skip
    assert zero_crossing_ratio(gamma) == pytest.approx(np.sqrt(m0 / m2), rel=1e-9)


def test_zero_crossing_ratio_near_dnv_fit_and_tp_from_tz_inverts_it() -> None:
    """DNV-RP-C205 §3.5.5.4's fit Tz/Tp = 0.6673 + 0.05037γ − 0.006230γ² + 0.0003341γ³ is within
    0.3 % for 1 ≤ γ ≤ 7; Tp from Tz gives back Tz, with a fixed γ and with DNV's γ of each sea."""
    gamma = np.linspace(1.0, 7.0, 13)
    fit = 0.6673 + 0.05037 * gamma - 0.006230 * gamma**2 + 0.0003341 * gamma**3
    assert np.max(np.abs(zero_crossing_ratio(gamma) / fit - 1)) < 3e-3
    hs, tz = np.array([0.3, 1.0, 2.0, 4.0, 8.0]), np.array([2.5, 4.0, 5.0, 7.0, 9.0])
    assert tp_from_tz(hs, tz, 3.3) == pytest.approx(tz / zero_crossing_ratio(3.3), rel=1e-12)
    tp = tp_from_tz(hs, tz)
    assert tp * zero_crossing_ratio(dnv_gamma(hs, tp)) == pytest.approx(tz, rel=1e-12)
    assert np.all(tz / zero_crossing_ratio(5.0) < tp)
    assert np.all(tp <= tz / zero_crossing_ratio(1.0))


def test_jonswap_normalisation_near_goda() -> None:
    """Goda's 1 - 0.287 ln γ (DNV-RP-C205 §3.5.5.2) is within 2 % for 1 ≤ γ ≤ 7."""
    gamma = np.linspace(1.0, 7.0, 13)
    np.testing.assert_allclose(jonswap_normalisation(gamma), 1 - 0.287 * np.log(gamma), rtol=0.02)


def test_parameters_broadcast_against_omega() -> None:
    """A batch (3, 1) of sea states against omega (n,) gives (3, n), row i = sea i."""
    omega = np.linspace(0.1, 3.0, 50)
    hs = np.array([[1.0], [2.0], [3.0]])
    tp = np.array([[6.0], [8.0], [10.0]])
    gamma = np.array([[1.0], [3.3], [5.0]])
    batch = jonswap(omega, hs, tp, gamma)
    assert batch.shape == (3, 50)
    for i in range(3):
        np.testing.assert_allclose(batch[i], jonswap(omega, hs[i, 0], tp[i, 0], gamma[i, 0]))


def test_zero_frequency_is_zero_not_nan() -> None:
    """Every spectrum is exactly 0 (not NaN) at zero and near-zero frequency."""
    omega = np.array([0.0, 1e-300, 1e-3])
    for s in (
        pierson_moskowitz(omega, HS, TP),
        jonswap(omega, HS, TP),
        pierson_moskowitz_wind(omega, 10.0),
    ):
        np.testing.assert_array_equal(s, 0.0)


# Peer: wavespectra works in f [Hz], S(ω) = S(f) / 2π, and takes Phillips' α or scales to hs
# numerically (sum over np.gradient(f) plus a tail term), so the α form is compared at machine
# precision and the hs form on a 0.0005 Hz grid to 0.02 .. 2 Hz, where its quadrature is < 1e-6.
FREQ = np.linspace(0.02, 2.0, 3961)  # [Hz]


def _alpha(hs: float, tp: float) -> float:
    """Phillips α of PM(hs, tp): 5/16 Hs² ω_p⁴ / g²."""
    return 5 / 16 * hs**2 * (2 * np.pi / tp) ** 4 / G**2


def _assert_relative(ours: np.ndarray, peer: np.ndarray, rtol: float) -> None:
    live = peer > 1e-12 * peer.max()  # both underflow to 0 far below the peak
    np.testing.assert_array_equal(ours[~live] < 1e-12 * peer.max(), True)
    np.testing.assert_allclose(ours[live], peer[live], rtol=rtol)


@pytest.mark.parametrize(("hs", "tp"), [(HS, TP), (0.5, 4.0), (12.0, 16.0)])
def test_pierson_moskowitz_equals_wavespectra(hs: float, tp: float) -> None:
    """Pierson-Moskowitz equals wavespectra's, to 1e-12 in its alpha form and 1e-6 in its Hs
    form."""
    ours = pierson_moskowitz(2 * np.pi * FREQ, hs, tp)
    alpha_form = ws_pierson_moskowitz(FREQ, 1 / tp, alpha=_alpha(hs, tp)).values / (2 * np.pi)
    hs_form = ws_pierson_moskowitz(FREQ, 1 / tp, hs=hs).values / (2 * np.pi)
    _assert_relative(ours, alpha_form, 1e-12)
    _assert_relative(ours, hs_form, 1e-6)


@pytest.mark.parametrize("gamma", [1.0, 2.0, 3.3, 5.0, 7.0])
def test_jonswap_equals_wavespectra(gamma: float) -> None:
    """JONSWAP equals wavespectra's for each gamma, to 1e-12 in its alpha form and 1e-6 in its Hs
    form."""
    ours = jonswap(2 * np.pi * FREQ, HS, TP, gamma)
    alpha = _alpha(HS, TP) * jonswap_normalisation(gamma)
    alpha_form = ws_jonswap(FREQ, 1 / TP, alpha=alpha, gamma=gamma).values / (2 * np.pi)
    hs_form = ws_jonswap(FREQ, 1 / TP, gamma=gamma, hs=HS).values / (2 * np.pi)
    _assert_relative(ours, alpha_form, 1e-12)
    _assert_relative(ours, hs_form, 1e-6)


def test_wind_form_equals_wavespectra() -> None:
    """seed 001 eq (28) is wavespectra's α-form PM with α = 0.0081, f_p = ω_p/2π."""
    u = 12.0
    _, tp = pm_sea_from_wind(u)
    peer = ws_pierson_moskowitz(FREQ, 1 / tp, alpha=0.0081).values / (2 * np.pi)
    _assert_relative(pierson_moskowitz_wind(2 * np.pi * FREQ, u), peer, 1e-12)


@pytest.mark.parametrize("spread_deg", [10.0, 30.0, 60.0])
def test_cos2s_equals_wavespectra_cartwright(spread_deg: float) -> None:
    """cartwright() is cos^2s(Δθ/2) normalised on its grid, per degree; s = 2/σ² - 1.

    Its normalisation is a sum over the 1° grid: exact to 1e-14 for smooth shapes, but the
    |cos(Δθ/2)|^2s kink at Δθ = π for s < 1 (σ = 60°) leaves it 6e-8 off the analytic one.
    """
    directions = np.arange(0.0, 360.0, 1.0)
    s = 2 / np.deg2rad(spread_deg) ** 2 - 1
    peer = cartwright(directions, 200.0, spread_deg).values * 180 / np.pi  # [1/deg] → [1/rad]
    ours = cos2s_spreading(np.deg2rad(directions), np.deg2rad(200.0), s)
    np.testing.assert_allclose(ours, peer, rtol=1e-6, atol=1e-12 * peer.max())


@pytest.mark.parametrize("s", [0.0, 0.5, 1.0, 10.0, 300.0])
def test_cos2s_integrates_to_one_and_peaks_at_mean(s: float) -> None:
    """The cos-2s spreading integrates to 1 over a circle and, when s > 0, peaks at the mean
    direction."""
    total = quad(lambda th: cos2s_spreading(th, 1.0, s), 1.0 - np.pi, 1.0 + np.pi, limit=200)[0]
    assert total == pytest.approx(1.0, rel=1e-9)
    theta = np.linspace(-np.pi, np.pi, 721)
    if s > 0:
        assert theta[np.argmax(cos2s_spreading(theta, 1.0, s))] == pytest.approx(1.0, abs=0.01)


@pytest.mark.parametrize(
    ("call", "field", "allowed"),
    [
        (lambda: pierson_moskowitz(1.0, -1.0, 8.0), "hs", "[0, inf] m"),
        (lambda: pierson_moskowitz(1.0, np.nan, 8.0), "hs", "[0, inf] m"),
        (lambda: jonswap(1.0, 2.0, 0.0), "tp", "(0, inf] s"),
        (lambda: jonswap(1.0, 2.0, -3.0), "tp", "(0, inf] s"),
        (lambda: jonswap(1.0, 2.0, np.inf), "tp", "(0, inf] s"),
        (lambda: jonswap([1.0, np.nan], 2.0, 8.0), "omega", "[0, inf] rad/s"),
        (lambda: jonswap(-1.0, 2.0, 8.0), "omega", "[0, inf] rad/s"),
        (lambda: jonswap(1.0, 2.0, 8.0, gamma=0.5), "gamma", "[1, 10]"),
        (lambda: pierson_moskowitz_wind(1.0, 0.0), "wind_speed", "(0, inf] m/s"),
        (lambda: pierson_moskowitz(1.0, "tall", 8.0), "hs", "[0, inf] m"),
        (lambda: cos2s_spreading(0.0, 0.0, -1.0), "s", "[0, inf]"),
        (lambda: spectral_density(1.0, 2.0, 8.0, "bretschneider"), "spectrum", "pierson_moskowitz"),
    ],
)
def test_bad_input_names_field_and_range(call, field: str, allowed: str) -> None:
    """Bad spectrum input raises a TwinError (a ValueError) naming the field and its allowed
    range."""
    with pytest.raises(TwinError) as error:
        call()
    assert field in str(error.value) and allowed in str(error.value)
    assert isinstance(error.value, ValueError)


@pytest.mark.parametrize(
    ("hs", "tp", "gamma"),
    [
        (1.0, 3.0, 5.0),  # Tp/√Hs = 3 ≤ 3.6: the steepest seas
        (1.0, 3.6, 5.0),  # on the lower bound
        (1.0, 4.0, np.exp(5.75 - 1.15 * 4.0)),  # between: 3.16
        (4.0, 9.0, np.exp(5.75 - 1.15 * 4.5)),  # Tp/√Hs = 4.5 with Hs ≠ 1: 1.77
        (1.0, 5.0, 1.0),  # on the upper bound
        (1.875, 6.85, 1.0),  # WMO sea state 4: fully developed, PM
        (0.0, 6.85, 1.0),  # a flat sea has no steepness
    ],
)
def test_dnv_gamma_follows_the_steepness_rule(hs: float, tp: float, gamma: float) -> None:
    """DNV-RP-C205 §3.5.5.5: γ = 5, exp(5.75 − 1.15 Tp/√Hs), 1 by Tp/√Hs (docs/references.md)."""
    assert dnv_gamma(hs, tp) == pytest.approx(gamma, rel=1e-12)


def test_dnv_gamma_falls_with_the_period_and_broadcasts() -> None:
    """Longer periods at one Hs are older seas with flatter peaks; arrays broadcast."""
    tp = np.linspace(2.0, 12.0, 51)
    gamma = dnv_gamma(2.0, tp)
    assert gamma.shape == tp.shape
    assert np.all(np.diff(gamma) <= 0) and gamma[0] == 5.0 and gamma[-1] == 1.0
    assert np.all((gamma >= 1.0) & (gamma <= 5.0))


@pytest.mark.parametrize(("hs", "tp"), [(-1.0, 6.0), (1.0, 0.0), (np.nan, 6.0)])
def test_dnv_gamma_rejects_bad_input(hs: float, tp: float) -> None:
    """A negative or NaN Hs, or a Tp ≤ 0, is a TwinError naming the argument."""
    with pytest.raises(TwinError, match=r"hs|tp"):
        dnv_gamma(hs, tp)
