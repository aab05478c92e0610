r"""One-sided wave spectra S(ω) [m²·s/rad] and the cos-2s directional spreading D(θ) [1/rad].

Every spectrum is a numpy expression of `omega` (..., n) [rad/s]; its parameters broadcast
against `omega`, so a batch of sea states is `hs[:, None]`, `tp[:, None]` with `omega` (n,).
The frequency-domain forms convert to those in frequency f [Hz] by S(f) = 2π S(ω).
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import ArrayLike
from scipy.special import gammaln

from twin.errors import TwinError
from twin.sea.components import G

SpectrumName = Literal["jonswap", "pierson_moskowitz"]
SPECTRA: tuple[SpectrumName, ...] = ("jonswap", "pierson_moskowitz")

PM_ALPHA = 0.0081  # [-] Phillips constant, seed 001 eq (28) μ
PM_BETA = 0.74  # [-] seed 001 eq (28) ρ, with U the wind speed at 19.5 m (SPEC erratum 8)
JONSWAP_SIGMA_A = 0.07  # [-] peak width for ω ≤ ω_p (Hasselmann et al. 1973)
JONSWAP_SIGMA_B = 0.09  # [-] peak width for ω > ω_p (Hasselmann et al. 1973)
GAMMA_MAX = 10.0  # [-] upper bound accepted for γ; DNV-RP-C205 §3.5.5 uses 1 ≤ γ ≤ 7


def _checked(
    value: ArrayLike,
    name: str,
    unit: str,
    low: float = 0.0,
    high: float = np.inf,
    *,
    low_open: bool = False,
) -> np.ndarray:
    """`value` as a float64 array in [low, high] (or (low, high]), else a `TwinError`.

    The message names the argument and its allowed range, also for NaN and inf.
    """
    allowed = f"{'(' if low_open else '['}{low:g}, {high:g}] {unit}".rstrip()
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TwinError(f"{name} must be a number in {allowed}, got {value!r:.80}") from exc
    with np.errstate(invalid="ignore"):
        bad = ~np.isfinite(array) | (array < low) | (array > high) | (low_open & (array == low))
    if np.any(bad):
        raise TwinError(f"{name} must be finite and in {allowed}, got {array[bad].tolist()!r:.120}")
    return array


def _unit_pm_shape(omega: np.ndarray, omega_p: np.ndarray) -> np.ndarray:
    """PM shape with unit area, 5/ω_p · y⁵ exp(-5/4 y⁴), y = ω_p/ω [s/rad]; 0 at ω = 0."""
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        y = omega_p / omega
        shape = 5.0 / omega_p * y**5 * np.exp(-1.25 * y**4)
    return np.where(y < 1e3, shape, 0.0)  # exp(-1.25e12) is 0: avoids inf·0 as ω → 0


def pierson_moskowitz(omega: ArrayLike, hs: ArrayLike, tp: ArrayLike) -> np.ndarray:
    r"""Pierson–Moskowitz spectrum in (Hs, Tp) form.

    :math:`S(ω) = \frac{5}{16} H_s^2 ω_p^4 ω^{-5} \exp(-\frac{5}{4}(ω_p/ω)^4)`, ω_p = 2π/Tp
    (DNV-RP-C205 §3.5.5.1): seed 001 eq (28) with μ g² and ρ (g/U)⁴ rewritten through
    Hs and Tp, so 4·sqrt(m0) = Hs exactly.

    Args:
        omega: (..., n) [rad/s] angular frequencies, ≥ 0.
        hs: [m] significant wave height ≥ 0, broadcast against `omega`.
        tp: [s] peak period > 0, broadcast against `omega`.

    Returns:
        S(ω), broadcast shape of the inputs [m²·s/rad].

    Raises:
        TwinError: an argument is NaN/inf or out of its range.
    """
    omega = _checked(omega, "omega", "rad/s")
    hs = _checked(hs, "hs", "m")
    tp = _checked(tp, "tp", "s", low_open=True)
    return hs**2 / 16.0 * _unit_pm_shape(omega, 2.0 * np.pi / tp)


def pierson_moskowitz_wind(omega: ArrayLike, wind_speed: ArrayLike, *, g: float = G) -> np.ndarray:
    r"""Pierson–Moskowitz spectrum of a fully developed sea from the wind speed.

    :math:`S(ω) = 0.0081\, g^2 ω^{-5} \exp(-0.74 (g / (U ω))^4)`, seed 001 eq (28) as
    corrected by SPEC erratum 8 (the paper prints g²/(Uω)); U is the wind at 19.5 m.

    Args:
        omega: (..., n) [rad/s] angular frequencies, ≥ 0.
        wind_speed: [m/s] U at 19.5 m above the sea, > 0, broadcast against `omega`.
        g: [m/s²] gravity; seed 001 uses 9.8.

    Returns:
        S(ω), broadcast shape of the inputs [m²·s/rad].
    """
    omega = _checked(omega, "omega", "rad/s")
    u = _checked(wind_speed, "wind_speed", "m/s", low_open=True)
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        y = g / (u * omega)
        s = PM_ALPHA * g**2 / omega**5 * np.exp(-PM_BETA * y**4)  # seed 001 eq (28)
    return np.where(y < 1e3, s, 0.0)


def pm_sea_from_wind(wind_speed: ArrayLike, *, g: float = G) -> tuple[np.ndarray, np.ndarray]:
    r"""(Hs, Tp) of the fully developed sea whose PM spectrum `pierson_moskowitz_wind` gives.

    From the moments of seed 001 eq (28): :math:`m_0 = αU^4/(4βg^2)`, so
    :math:`H_s = 2\sqrt{α/β}\,U^2/g ≈ 0.209\,U^2/g`, and dS/dω = 0 at
    :math:`ω_p = (4β/5)^{1/4} g/U ≈ 0.877\,g/U`.

    Args:
        wind_speed: [m/s] U at 19.5 m, > 0.
        g: [m/s²] gravity.

    Returns:
        hs [m] and tp [s], each the shape of `wind_speed`.
    """
    u = _checked(wind_speed, "wind_speed", "m/s", low_open=True)
    hs = 2.0 * np.sqrt(PM_ALPHA / PM_BETA) * u**2 / g
    tp = 2.0 * np.pi * u / (g * (0.8 * PM_BETA) ** 0.25)
    return hs, tp


def fully_developed_tp(hs: ArrayLike, *, g: float = G) -> np.ndarray:
    r"""Tp [s] of the fully developed PM sea with significant wave height `hs` [m].

    Eliminates U between the two relations of `pm_sea_from_wind`:
    :math:`T_p = \frac{2π}{(4β/5)^{1/4}} \sqrt{\frac{H_s}{2g\sqrt{α/β}}} ≈ 5.0005\sqrt{H_s}`,
    just past the boundary DNV-RP-C205 §3.5.5.5 gives for γ = 1 (Tp/√Hs ≥ 5, `dnv_gamma`).
    """
    hs = _checked(hs, "hs", "m")
    u = np.sqrt(hs * g / (2.0 * np.sqrt(PM_ALPHA / PM_BETA)))
    return 2.0 * np.pi * u / (g * (0.8 * PM_BETA) ** 0.25)


#: [-] DNV-RP-C205 §3.5.5.5 bounds of Tp/√Hs [s/√m]: γ = 5 at or below the first, 1 at or
#: above the second, exp(5.75 − 1.15 Tp/√Hs) between (continuous at both ends to 0.06 %)
DNV_GAMMA_BOUNDS = (3.6, 5.0)


def dnv_gamma(hs: ArrayLike, tp: ArrayLike) -> np.ndarray:
    r"""JONSWAP peak enhancement γ from the sea's steepness, DNV-RP-C205 §3.5.5.5.

    :math:`γ = 5` for :math:`T_p/\sqrt{H_s} ≤ 3.6`, :math:`γ = \exp(5.75 − 1.15\,T_p/\sqrt{H_s})`
    for :math:`3.6 < T_p/\sqrt{H_s} < 5` and :math:`γ = 1` (Pierson–Moskowitz) for
    :math:`T_p/\sqrt{H_s} ≥ 5`, Tp in s and Hs in m. A fully developed sea
    (`fully_developed_tp`, Tp = 5.0005 √Hs, every WMO code of `sea_state_hs_tp`) gets γ = 1;
    a younger, steeper wind sea (shorter Tp at the same Hs) a higher peak, e.g. Hs 3.086 m at
    Tp 6.85 s (`seed004`'s sea) γ = 3.55. Hs = 0 has no steepness: γ = 1.

    Args:
        hs: [m] significant wave height ≥ 0.
        tp: [s] peak period > 0, broadcast against `hs`.

    Returns:
        γ [-] in [1, 5], the broadcast shape of `hs` and `tp`.
    """
    hs = _checked(hs, "hs", "m")
    tp = _checked(tp, "tp", "s", low_open=True)
    with np.errstate(divide="ignore"):
        ratio = tp / np.sqrt(hs)  # inf at Hs = 0: γ = 1
    low, high = DNV_GAMMA_BOUNDS
    middle = np.exp(5.75 - 1.15 * np.clip(ratio, low, high))
    return np.where(ratio <= low, 5.0, np.where(ratio >= high, 1.0, middle))


def _gauss_legendre(a: float, b: float, n: int) -> tuple[np.ndarray, np.ndarray]:
    nodes, weights = np.polynomial.legendre.leggauss(n)
    return (b - a) / 2.0 * nodes + (a + b) / 2.0, (b - a) / 2.0 * weights


# Quadrature for ∫₀¹ γ^r(x(u)) du, u = exp(-5/4 x⁻⁴): split at the peak u = e^{-5/4}, where
# σ switches from σ_a to σ_b, so each panel's integrand is smooth.
_U_PEAK = np.exp(-1.25)
_LOW_PANEL, _HIGH_PANEL = _gauss_legendre(0.0, _U_PEAK, 64), _gauss_legendre(_U_PEAK, 1.0, 64)
_U_NODES = np.concatenate([_LOW_PANEL[0], _HIGH_PANEL[0]])
_U_WEIGHTS = np.concatenate([_LOW_PANEL[1], _HIGH_PANEL[1]])
_X_NODES = (1.25 / -np.log(_U_NODES)) ** 0.25  # ω/ω_p at each node


def _peak_exponent(x: np.ndarray) -> np.ndarray:
    """r = exp(-(x - 1)² / (2σ²)), x = ω/ω_p, σ = σ_a below the peak, σ_b above."""
    sigma = np.where(x <= 1.0, JONSWAP_SIGMA_A, JONSWAP_SIGMA_B)
    return np.exp(-((x - 1.0) ** 2) / (2.0 * sigma**2))


def jonswap_normalisation(gamma: ArrayLike) -> np.ndarray:
    r"""A(γ) with ∫ A(γ) S_PM(ω) γ^r dω = Hs²/16: the exact factor, by quadrature.

    With u = exp(-5/4 (ω_p/ω)⁴) the unit PM shape becomes du, so
    :math:`1/A(γ) = \int_0^1 γ^{r(u)} du`, a bounded smooth integrand evaluated by 2×64-point
    Gauss–Legendre (error < 1e-12). DNV-RP-C205 §3.5.5.2 approximates it by Goda's
    1 - 0.287 ln γ, off by 0.24 % at γ = 3.3 and 1.8 % at γ = 7.

    Args:
        gamma: [-] peak enhancement factor, 1 ≤ γ ≤ 10; any shape.

    Returns:
        A(γ) [-], the shape of `gamma`.
    """
    gamma = _checked(gamma, "gamma", "", 1.0, GAMMA_MAX)
    integrand = gamma[..., None] ** _peak_exponent(_X_NODES)
    return 1.0 / np.sum(integrand * _U_WEIGHTS, axis=-1)


#: ∫₀¹ x(u)² du = √(5π/4) for the unit PM shape (x = ω/ω_p, u = exp(-5/4 x⁻⁴)): m2/(m0 ω_p²)
#: of Pierson–Moskowitz, so Tz/Tp = (5π/4)^(-1/4) = 0.7104 there
_PM_SECOND_MOMENT = np.sqrt(1.25 * np.pi)


def zero_crossing_ratio(gamma: ArrayLike) -> np.ndarray:
    r"""Tz/Tp of a JONSWAP sea, Tz = 2π √(m0/m2) (mean zero-up-crossing period).

    With u = exp(-5/4 (ω_p/ω)⁴) (as in `jonswap_normalisation`):
    :math:`m_2/(m_0 ω_p^2) = \int_0^1 x^2 γ^{r} du / \int_0^1 γ^{r} du`. The x² factor has an
    integrable singularity at u = 1 (ω → ∞), so the PM part √(5π/4) is taken exactly and only
    the smooth peak term x²(γ^r − 1) by the same quadrature. γ = 1 gives 0.7104; γ = 3.3 gives
    0.7776, beside DNV-RP-C205 §3.5.5.4's fitted 0.6673 + 0.05037γ − 0.006230γ² + 0.0003341γ³
    (0.7777).

    Args:
        gamma: [-] peak enhancement, 1 ≤ γ ≤ 10; any shape.

    Returns:
        Tz/Tp [-], the shape of `gamma`.
    """
    gamma = _checked(gamma, "gamma", "", 1.0, GAMMA_MAX)
    peak = gamma[..., None] ** _peak_exponent(_X_NODES)
    m0 = np.sum(peak * _U_WEIGHTS, axis=-1)
    m2 = _PM_SECOND_MOMENT + np.sum(_X_NODES**2 * (peak - 1.0) * _U_WEIGHTS, axis=-1)
    return np.sqrt(m0 / m2)


def tp_from_tz(hs: ArrayLike, tz: ArrayLike, gamma: ArrayLike | None = None) -> np.ndarray:
    r"""Peak period Tp [s] of the JONSWAP sea with significant height `hs` and mean
    zero-up-crossing period `tz`: Tp = Tz / `zero_crossing_ratio`(γ).

    With `gamma` None, γ is the scenario's default `dnv_gamma`(Hs, Tp), which depends on Tp
    itself; Tp·ratio(γ(Hs, Tp)) rises with Tp on γ's whole range, so the Tp that gives `tz`
    is found by bisection between Tz/ratio(5) and Tz/ratio(1) (60 halvings: to rounding).

    Args:
        hs: [m] significant wave height ≥ 0.
        tz: [s] mean zero-up-crossing period > 0, broadcast against `hs`.
        gamma: [-] a fixed peak enhancement, or None for DNV's γ of each sea.

    Returns:
        Tp [s], the broadcast shape of `hs` and `tz`.
    """
    hs = _checked(hs, "hs", "m")
    tz = _checked(tz, "tz", "s", low_open=True)
    hs, tz = np.broadcast_arrays(hs, tz)
    if gamma is not None:
        return tz / zero_crossing_ratio(np.broadcast_to(gamma, tz.shape))
    low, high = tz / zero_crossing_ratio(5.0), tz / zero_crossing_ratio(1.0)
    for _ in range(60):
        middle = 0.5 * (low + high)
        above = middle * zero_crossing_ratio(dnv_gamma(hs, middle)) > tz
        low, high = np.where(above, low, middle), np.where(above, middle, high)
    return 0.5 * (low + high)


def jonswap(
    omega: ArrayLike,
    hs: ArrayLike,
    tp: ArrayLike,
    gamma: ArrayLike = 3.3,
) -> np.ndarray:
    r"""JONSWAP spectrum (Hasselmann et al. 1973) normalised to the given Hs.

    :math:`S(ω) = A(γ)\, S_{PM}(ω; H_s, T_p)\, γ^{\exp(-(ω-ω_p)^2/(2σ^2ω_p^2))}`,
    σ = 0.07 for ω ≤ ω_p and 0.09 above (DNV-RP-C205 §3.5.5.2), with the exact A(γ) of
    `jonswap_normalisation` instead of Goda's approximation, so 4·sqrt(m0) = Hs for every γ.
    γ = 1 gives `pierson_moskowitz`.

    Args:
        omega: (..., n) [rad/s] angular frequencies, ≥ 0.
        hs: [m] significant wave height ≥ 0, broadcast against `omega`.
        tp: [s] peak period > 0, broadcast against `omega`.
        gamma: [-] peak enhancement, 1 ≤ γ ≤ 10, broadcast against `omega`.

    Returns:
        S(ω), broadcast shape of the inputs [m²·s/rad].
    """
    omega = _checked(omega, "omega", "rad/s")
    hs = _checked(hs, "hs", "m")
    tp = _checked(tp, "tp", "s", low_open=True)
    scale = jonswap_normalisation(gamma)
    omega_p = 2.0 * np.pi / tp
    enhancement = np.asarray(gamma, dtype=np.float64) ** _peak_exponent(omega / omega_p)
    return scale * hs**2 / 16.0 * _unit_pm_shape(omega, omega_p) * enhancement


def spectral_density(
    omega: ArrayLike,
    hs: ArrayLike,
    tp: ArrayLike,
    spectrum: str = "jonswap",
    *,
    gamma: ArrayLike = 3.3,
) -> np.ndarray:
    """S(ω) [m²·s/rad] of the spectrum named `spectrum` (one of `SPECTRA`).

    `gamma` is used by "jonswap" only.

    Raises:
        TwinError: unknown spectrum name, or an argument out of range.
    """
    if spectrum == "jonswap":
        return jonswap(omega, hs, tp, gamma)
    if spectrum == "pierson_moskowitz":
        return pierson_moskowitz(omega, hs, tp)
    raise TwinError(f"spectrum must be one of {list(SPECTRA)}, got {spectrum!r}")


def cos2s_spreading(theta: ArrayLike, mean_direction: ArrayLike, s: ArrayLike) -> np.ndarray:
    r"""cos-2s directional spreading (Longuet-Higgins, Cartwright & Smith 1963).

    :math:`D(θ) = \frac{Γ(s+1)}{2\sqrt{π}\,Γ(s+1/2)} \cos^{2s}\frac{θ - θ_m}{2}`, which
    integrates to 1 over any 2π interval. Its circular spread is
    σ = sqrt(2/(s+1)) [rad] (Kuik et al. 1988), the form wavespectra's `cartwright` uses.
    s = 0 is isotropic; s → ∞ is long-crested.

    Args:
        theta: (..., m) [rad] directions.
        mean_direction: [rad] θ_m, broadcast against `theta`.
        s: [-] spreading exponent ≥ 0, broadcast against `theta`.

    Returns:
        D(θ) [1/rad], broadcast shape of the inputs.
    """
    theta = _checked(theta, "theta", "rad", -np.inf)
    mean_direction = _checked(mean_direction, "mean_direction", "rad", -np.inf)
    s = _checked(s, "s", "")
    scale = np.exp(gammaln(s + 1.0) - gammaln(s + 0.5)) / (2.0 * np.sqrt(np.pi))
    # cos²(Δ/2) = (1 + cos Δ)/2 is 2π-periodic, so Δ needs no wrapping.
    return scale * ((1.0 + np.cos(theta - mean_direction)) / 2.0) ** s
