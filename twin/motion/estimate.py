r"""Sea state from measured vessel motion: the wave buoy analogy.

A vessel responds to the sea linearly through its RAOs (`twin.vessel.rao`), so the
cross-spectra of its six motions are the wave spectrum seen through them (Huss & Olander 1994;
Nielsen 2006, 2017):

.. math:: Φ_{ij}(ω) = \int H_i(ω, β)\, \overline{H_j(ω, β)}\, S(ω)\, D(β)\, dβ

with H the complex RAO of motion i at wave direction β (the direction the waves travel
towards, counter-clockwise from the bow: `Scenario.heading`), S the wave spectrum and D the
directional spreading. `estimate_sea` measures Φ by Welch's averaged, Hann-windowed
periodograms (Welch 1967; `scipy.signal.csd`, the window's linear trend removed so a sensor's
bias and slow drift drop out) and fits a parametric sea to it: the sea layer's JONSWAP
(`twin.sea.spectra.jonswap`, DNV-RP-C205 §3.5.5.2) times its cos-2s spreading
(`twin.sea.spectra.cos2s_spreading`), parameters Hs, Tp, mean direction β and spreading s, by
weighted least squares (`scipy.optimize.least_squares`) over the auto-spectra and the real and
imaginary parts of the cross-spectra, started from several directions (the cost has a local
minimum near the mirror and the reciprocal direction of the truth).

Weights: each residual is divided by the standard error of its Welch estimate,
σ_ij = sqrt((Φ_ii + ε_i)(Φ_jj + ε_j) / K), K the number of independent segments (Bendat &
Piersol 2010 §9.2) and ε_i a floor of `NOISE_FLOOR_SHARE` of the channel's peak, so the motions'
different units (m, rad) weigh alike and no band is weighed by its noise alone. With residuals
in standard errors, (JᵀJ)⁻¹ of the fit's Jacobian is the parameters' covariance; it is scaled by
the reduced χ² when that exceeds 1 (the model does not explain the data to Welch's precision),
and its square roots are the 1-σ uncertainties reported.

Stated assumptions and limits:

- **Zero forward speed.** The frequency measured is taken as the wave frequency (ω_e = ω): a
  walk-to-work vessel works on DP. Under way, ω_e = ω − kU cos β (`encounter_frequency`) maps
  up to three wave frequencies to one ω_e in following seas; this estimator does not solve it.
- **Port/starboard.** A mirrored sea (β → −β) gives the same heave and pitch and the same
  auto-spectra; only the sign of the roll cross-spectra (and sway's and yaw's) tells the sides
  apart. With heave, roll and pitch alone the roll phase is all there is, and when the mirror's
  fit is as good as the best one (cost within `MIRROR_TOLERANCE`) the estimate says it is
  ambiguous (`SeaEstimate.ambiguous`) and gives both directions; sway or yaw resolve it.
- **Refusals** (`EstimateRefused`, a `TwinError` with the reason): a window shorter than
  `MIN_WINDOW`; a sea too calm, every motion's standard deviation in the wave band below its
  noise floor (`NOISE_FLOOR`, an MRU's stated accuracy); a fit too poor, its relative misfit
  above `MAX_MISFIT` (motion the RAOs cannot explain: noise, a wrong vessel, a frozen channel).
- The motion is the vessel's centre of motion in the vessel frame (x bow, y port, z up), as
  `twin.vessel.vessel_motion` returns it; moving a sensor's motion there is the motion input's
  job (`twin.motion`).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any, Protocol

import numpy as np
from scipy.optimize import least_squares
from scipy.signal import csd, detrend, get_window
from threadpoolctl import threadpool_limits

from twin.errors import TwinError
from twin.sea.spectra import cos2s_spreading, jonswap
from twin.vessel.rao import DOFS, RaoTable, interpolate_raos

#: [s] shortest window estimated (Welch needs enough segments for a stable cross-spectrum)
MIN_WINDOW = 600.0
#: [s] the default window length (20 min, as onboard tools use)
DEFAULT_WINDOW = 1200.0
#: [s] Welch segment length: Δω = 2π/200 ≈ 0.031 rad/s, about 11 segments in 20 min
SEGMENT = 200.0
#: [rad/s] the band fitted: periods 3-25 s, where seas carry their energy
BAND = (0.25, 2.1)
#: noise floor per motion [m, m, m, rad, rad, rad]: a motion reference unit's stated accuracy
#: (heave 5 cm, surge and sway likewise, roll/pitch 0.02°, yaw 0.05°); a window whose every
#: motion varies less than this in the wave band is too calm to estimate
NOISE_FLOOR = np.array([0.05, 0.05, 0.05, np.radians(0.02), np.radians(0.02), np.radians(0.05)])
#: [-] each auto-spectrum's weighting floor as a share of its own peak
NOISE_FLOOR_SHARE = 0.02
#: [-] largest relative misfit ‖Φ_model − Φ‖ / ‖Φ‖ (normalised spectra) accepted
MAX_MISFIT = 0.6
#: [-] the mirror direction's cost within this factor of the best: port/starboard ambiguous
MIRROR_TOLERANCE = 1.25
#: [deg] wave directions the spreading integral sums over (and the search's directions)
DIRECTIONS = np.arange(0.0, 360.0, 2.0)
#: bounds of (Hs [m], Tp [s], σ_θ [deg]) in the fit: σ_θ 0° long-crested, 60° s ≈ 0.8
HS_BOUNDS, TP_BOUNDS, SPREAD_BOUNDS = (0.01, 20.0), (3.0, 25.0), (0.0, 60.0)
#: [deg] the direction grid's step: below it the spreading is not resolved (`_Model.weights`)
GRID_STEP = float(DIRECTIONS[1] - DIRECTIONS[0])
#: the motions needed at least: heave, roll, pitch (what every MRU gives)
REQUIRED = ("heave", "roll", "pitch")


class EstimateRefused(TwinError):
    """A window the estimator will not estimate: too short, too calm or too noisy (the
    message says which and the stated limit)."""


class MotionWindow(Protocol):
    """What `estimate_series` reads of a measured motion series (`twin.motion.series`)."""

    time: np.ndarray
    motion: np.ndarray


@dataclass(frozen=True)
class SeaEstimate:
    """The sea estimated from one window of motion.

    Attributes:
        hs: [m] significant wave height; hs_sd its 1-σ uncertainty.
        tp: [s] peak period; tp_sd its 1-σ uncertainty.
        direction: [deg, 0-360) mean direction the waves travel towards, counter-clockwise
            from the bow (`Scenario.heading`: 180 head seas); direction_sd [deg] 1-σ.
        spread: [deg] circular spread σ_θ of the cos-2s spreading (s = 2/σ_θ² − 1; 0°
            long-crested); spread_sd its 1-σ.
        gamma: [-] the JONSWAP peak enhancement assumed.
        mirror: [deg] the best direction on the other side (near −β): the port/starboard
            alternative.
        ambiguous: True when the mirror fits as well (within `MIRROR_TOLERANCE`): the side
            the waves come from is not known.
        misfit: [-] relative misfit of the fitted cross-spectra.
        chi2: [-] reduced χ² of the fit (≈ 1: the model explains the data to Welch's error).
        channels: the motions used.
        segments: [-] Welch segments averaged (independent-equivalent count K).
        start, end: [s] the window.
        notes: assumptions a reader should know.
    """

    hs: float
    hs_sd: float
    tp: float
    tp_sd: float
    direction: float
    direction_sd: float
    spread: float
    spread_sd: float
    gamma: float
    mirror: float
    ambiguous: bool
    misfit: float
    chi2: float
    channels: tuple[str, ...]
    segments: float
    start: float
    end: float
    notes: tuple[str, ...] = field(default_factory=tuple)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready (floats, lists)."""
        out = asdict(self)
        out["channels"], out["notes"] = list(self.channels), list(self.notes)
        return {k: (float(v) if isinstance(v, np.floating) else v) for k, v in out.items()}


@dataclass(frozen=True)
class CrossSpectra:
    """Welch cross-spectral matrix of the used motions over the fitted band.

    Attributes:
        omega: (F,) [rad/s]; phi: (F, C, C) complex one-sided Φ_ij [unit_i·unit_j·s/rad];
        channels: the C motions' indices in `DOFS`; segments: independent-equivalent K.
        dt: [s] sample period; nperseg: samples per segment.
    """

    omega: np.ndarray
    phi: np.ndarray
    channels: np.ndarray
    segments: float
    dt: float
    nperseg: int

    def smoothing(self) -> tuple[np.ndarray, np.ndarray]:
        """The expected Welch estimate as a matrix on a finer grid: (ω_fine (M,) [rad/s],
        K (F, M)) with E[Φ(ω_k)] = Σ_m K_km Φ(ω_fine_m). Welch 1967 eq (8): the expected
        periodogram of a windowed segment is the true spectrum convolved with the window's
        spectral window |W(ω)|² (here the Hann's), normalised to unit area; over ±4 bins, where
        the Hann's side lobes are under −50 dB, on a grid a quarter bin fine."""
        step = 2.0 * np.pi / (self.nperseg * self.dt)  # one Welch bin [rad/s]
        fine = np.arange(self.omega[0] - 4 * step, self.omega[-1] + 4.01 * step, step / 4)
        fine = fine[fine > 0]
        # |W|² at quarter-bin offsets: the window's FFT zero-padded to four times its length
        spectral = np.abs(np.fft.fft(get_window("hann", self.nperseg), 4 * self.nperseg)) ** 2
        quarters = np.rint((self.omega[:, None] - fine[None, :]) / (step / 4)).astype(int)
        kernel = np.where(np.abs(quarters) <= 16, spectral[quarters % spectral.size], 0.0)
        return fine, kernel / kernel.sum(axis=1, keepdims=True)


def cross_spectra(
    t: np.ndarray, motion: np.ndarray, channels: np.ndarray, segment: float = SEGMENT
) -> CrossSpectra:
    """Φ_ij(ω) of `motion[:, channels]` by Welch (Hann, 50 % overlap, the window's linear
    trend removed), as a
    density in ω: S(ω) = S(f)/2π (`twin.sea.spectra`'s convention).

    Args:
        t: (N,) [s] uniform times; motion: (N, 6) [m, rad]; channels: indices used.
        segment: [s] Welch segment length.
    """
    dt = float(np.median(np.diff(t)))
    fs = 1.0 / dt
    nperseg = min(round(segment * fs), t.size)
    # one linear trend off each whole channel (a sensor's bias and slow drift), not one per
    # segment and pair: the 36 pairs' per-segment fits cost 20 times the spectra themselves
    x = detrend(motion[:, channels].T, axis=-1, type="linear")  # (C, N)
    f, p = csd(x[:, None, :], x[None, :, :], fs=fs, nperseg=nperseg, detrend=False)
    omega = 2.0 * np.pi * f
    keep = (omega >= BAND[0]) & (omega <= BAND[1])
    # Hann at 50 % overlap: the segments' correlation leaves ≈ 0.95 K independent ones per
    # (Welch 1967 eq (22)); as the scaling, an estimate of the error, not exact
    n_seg = 1 + max(0, (t.size - nperseg) // (nperseg // 2))
    return CrossSpectra(omega[keep], np.moveaxis(p[..., keep], -1, 0) / (2.0 * np.pi),
                        np.asarray(channels), 0.95 * n_seg, dt, nperseg)  # fmt: skip


class _Model:
    """Φ_model(Hs, Tp, β, σ_θ) on the measured frequencies, and the weighted residuals.

    The sea's parameters x = (Hs [m], Tp [s], β [deg], σ_θ [deg]); σ_θ is the cos-2s
    spreading's circular spread, s = 2/σ_θ² − 1 (Kuik et al. 1988, as `cos2s_spreading`
    states), so one bounded parameter runs from long-crested (0°) to short-crested (60°).
    Below the direction grid's step (`GRID_STEP`) cos-2s is not resolved by the grid; there the
    weights blend linearly from cos-2s at σ_θ = `GRID_STEP` to the long-crested limit, a
    linear interpolation of the products between the two grid directions around β (without it
    the narrowest sea the model holds is 2° wide, and at head seas its roll, magnified by the
    roll resonance, is far above what a long-crested sea gives).
    """

    def __init__(self, spectra: CrossSpectra, raos: RaoTable, gamma: float) -> None:
        self.spectra, self.gamma, self.raos = spectra, gamma, raos
        n = spectra.phi.shape[1]
        self.upper, self.strict = np.triu_indices(n), np.triu_indices(n, 1)
        beta = np.radians(DIRECTIONS)
        # the model on a finer grid, then as Welch's estimate sees it (`smoothing`): a peak as
        # narrow as a bin (JONSWAP's at Tp 14 s, a lightly damped roll) is otherwise misfitted
        self.fine, self.kernel = spectra.smoothing()
        H = interpolate_raos(raos, self.fine[:, None], beta[None, :])[..., spectra.channels]
        i, j = self.upper
        # H_i H̄_j per direction, fine frequency and pair i ≤ j: (B, M·P), real and imaginary
        products = np.moveaxis(H[..., i] * np.conj(H[..., j]), 1, 0).reshape(beta.size, -1)
        self.products_re = np.ascontiguousarray(products.real)
        self.products_im = np.ascontiguousarray(products.imag)
        self.reweigh(spectra.phi)

    def reweigh(self, phi: np.ndarray) -> None:
        """Standard errors σ_ij from the cross-spectra `phi` (F, C, C) (module docstring): the
        measured ones first, then the fitted model's (a weight from the data itself favours
        the points that came out low, biasing Hs down)."""
        auto = np.real(np.einsum("fii->fi", phi))
        # the larger of a share of the channel's peak and its noise floor spread over the band
        noise = NOISE_FLOOR[self.spectra.channels] ** 2 / (BAND[1] - BAND[0])
        floor = np.maximum(NOISE_FLOOR_SHARE * auto.max(axis=0), noise)
        i, j = self.upper
        self.sigma = np.sqrt((auto + floor)[:, i] * (auto + floor)[:, j] / self.spectra.segments)
        self.measured = self._flatten(self.spectra.phi[:, i, j])

    def _flatten(self, pairs: np.ndarray) -> np.ndarray:
        """(F, P) pair spectra → Re of every pair and Im of the off-diagonal ones, each divided
        by its standard error, flat."""
        scaled = pairs / self.sigma
        off = self.upper[0] != self.upper[1]
        return np.concatenate([scaled.real.ravel(), scaled[:, off].imag.ravel()])

    @staticmethod
    def weights(beta: float, spread_deg: float) -> np.ndarray:
        """(B,) quadrature weights of the spreading D(θ) on `DIRECTIONS`, summing to 1 (class
        docstring): cos-2s, blended below `GRID_STEP` towards the two grid directions around
        β weighted linearly."""
        sigma = max(float(spread_deg), GRID_STEP)
        s = 2.0 / np.radians(sigma) ** 2 - 1.0
        spread = cos2s_spreading(np.radians(DIRECTIONS), np.radians(beta), s)
        spread = spread / spread.sum()  # the grid's quadrature, exactly normalised
        if spread_deg >= GRID_STEP:
            return spread
        gap = np.abs(np.mod(DIRECTIONS - beta + 180.0, 360.0) - 180.0)
        linear = np.maximum(0.0, 1.0 - gap / GRID_STEP)
        share = spread_deg / GRID_STEP
        return share * spread + (1.0 - share) * linear / linear.sum()

    def pairs(self, x: np.ndarray) -> np.ndarray:
        """(F, P) Φ_ij, i ≤ j, of the parametric sea x (class docstring)."""
        hs, tp, beta, spread_deg = x
        spectrum = jonswap(self.fine, hs, tp, self.gamma)
        spread = self.weights(beta, spread_deg)
        # Σ_β D(β) H_i H̄_j: two real matrix-vector products (BLAS), not a complex einsum
        shape = (self.fine.size, -1)
        directional = (spread @ self.products_re).reshape(shape) + 1j * (
            spread @ self.products_im).reshape(shape)  # fmt: skip
        return self.kernel @ (spectrum[:, None] * directional)

    def phi(self, x: np.ndarray) -> np.ndarray:
        """(F, C, C) Hermitian Φ of the parametric sea x."""
        n = self.spectra.phi.shape[1]
        out = np.zeros((self.spectra.omega.size, n, n), dtype=complex)
        out[:, self.upper[0], self.upper[1]] = self.pairs(x)
        return out + np.conj(np.swapaxes(np.triu(out, 1), 1, 2))

    def residuals(self, x: np.ndarray) -> np.ndarray:
        return self._flatten(self.pairs(x)) - self.measured

    def search(self, tp0: float) -> tuple[np.ndarray, np.ndarray]:
        """Long-crested seas on the grid of `DIRECTIONS` × Tp ∈ `tp0`·[0.6, 1.6]: the best
        (Hs, Tp) per direction and its cost, Hs² solved in closed form (the model is linear
        in it). Returns (B, 2) (Hs, Tp) and (B,) costs."""
        tps = np.clip(tp0 * np.geomspace(0.6, 1.6, 13), *TP_BOUNDS)
        shapes = jonswap(self.spectra.omega[None, :], 1.0, tps[:, None], self.gamma)  # (T, F)
        # at the Welch frequencies themselves, without the smoothing: a start, not the fit
        omega, beta = self.spectra.omega[:, None], np.radians(DIRECTIONS)[None, :]
        H = interpolate_raos(self.raos, omega, beta)[..., self.spectra.channels]
        i, j = self.upper
        per_direction = np.moveaxis(H[..., i] * np.conj(H[..., j]), 1, 0)  # (B, F, P)
        best = np.full((DIRECTIONS.size, 2), np.nan)
        cost = np.full(DIRECTIONS.size, np.inf)
        d = self.measured
        for k, shape in enumerate(shapes):
            m = per_direction * shape[None, :, None]
            scaled = m / self.sigma
            off = self.upper[0] != self.upper[1]
            re = scaled.real.reshape(DIRECTIONS.size, -1)
            flat = np.concatenate([re, scaled[..., off].imag.reshape(DIRECTIONS.size, -1)], 1)
            mm, md = np.sum(flat * flat, axis=1), flat @ d
            a = np.maximum(md / np.maximum(mm, 1e-300), 1e-8)  # Hs² ≥ 0
            c = 0.5 * np.sum((flat * a[:, None] - d) ** 2, axis=1)
            better = c < cost
            cost[better] = c[better]
            best[better] = np.stack([np.sqrt(a[better]), np.full(better.sum(), tps[k])], 1)
        return best, cost


def _usable(motion: np.ndarray) -> tuple[np.ndarray, list[str]]:
    """Indices of the motions with data (all finite) and notes; refuses without heave, roll
    and pitch."""
    finite = np.all(np.isfinite(motion), axis=0)
    missing = [name for name in REQUIRED if not finite[DOFS.index(name)]]
    if missing:
        raise EstimateRefused(
            f"motion: {missing} absent or with gaps in the window; the estimate needs "
            f"{list(REQUIRED)} (sway, yaw, surge optional)"
        )
    used = np.flatnonzero(finite)
    notes = []
    if not (finite[DOFS.index("sway")] or finite[DOFS.index("yaw")]):
        notes.append("heave, roll and pitch only: port and starboard are told apart by the roll "
                     "cross-spectra alone (see ambiguous)")  # fmt: skip
    return used, notes


def _check_window(t: np.ndarray, motion: np.ndarray) -> None:
    """Refuse a window that is too short, unevenly sampled or of the wrong shape."""
    if t.ndim != 1 or motion.shape != (t.size, 6):
        raise TwinError(f"time (N,) and motion (N, 6) expected, got {t.shape} and {motion.shape}")
    if t.size < 2 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise TwinError("time: finite and strictly increasing, at least two samples")
    steps = np.diff(t)
    span = float(t[-1] - t[0] + np.median(steps))  # N samples cover N steps
    if span < MIN_WINDOW - 1e-6:
        raise EstimateRefused(f"window: {span:.0f} s; at least {MIN_WINDOW:.0f} s (10 min) is "
                              "needed for a stable cross-spectrum")  # fmt: skip
    if np.ptp(steps) > 0.01 * np.median(steps):
        raise TwinError("time: uneven sampling; resample the series first (MotionSeries.resampled)")


def _too_calm(spectra: CrossSpectra) -> None:
    """Refuse when every motion's band standard deviation is under its `NOISE_FLOOR`."""
    dw = np.gradient(spectra.omega)
    auto = np.real(np.einsum("fii->fi", spectra.phi))
    std = np.sqrt(np.sum(auto * dw[:, None], axis=0))
    floor = NOISE_FLOOR[spectra.channels]
    if np.all(std < floor):
        levels = zip(spectra.channels, std, floor, strict=True)
        pairs = ", ".join(f"{DOFS[c]} {s:.3g} < {f:.3g}" for c, s, f in levels)
        raise EstimateRefused(f"sea too calm: every motion is below its noise floor ({pairs}; "
                              "m or rad, standard deviation in the wave band)")  # fmt: skip


def _first_guess(spectra: CrossSpectra) -> tuple[float, float]:
    """(Hs, Tp) to start from: the heave's band variance (heave RAO ≈ 1 in long waves) and
    the peak of the normalised sum of the auto-spectra."""
    auto = np.real(np.einsum("fii->fi", spectra.phi))
    heave = auto[:, list(spectra.channels).index(DOFS.index("heave"))]
    dw = np.gradient(spectra.omega)
    hs = float(np.clip(4.0 * np.sqrt(np.sum(heave * dw)), 0.1, 15.0))
    peak = spectra.omega[np.argmax(np.sum(auto / auto.max(axis=0), axis=1))]
    return hs, float(np.clip(2.0 * np.pi / peak, TP_BOUNDS[0] + 0.5, TP_BOUNDS[1] - 0.5))


def _side(beta: float) -> int:
    """0 for waves travelling to port (β in [0°, 180°]), 1 to starboard."""
    return int(np.mod(beta, 360.0) > 180.0)


def _fit(model: _Model, start: np.ndarray, side: int) -> Any:
    """One least-squares fit of x = (Hs, Tp, β, σ_θ) from `start`, β kept on `side`
    (`_side`: the two half-planes port and starboard, so the two fits are the two
    mirror-image answers)."""
    low = [HS_BOUNDS[0], TP_BOUNDS[0], 180.0 * side, SPREAD_BOUNDS[0]]
    high = [HS_BOUNDS[1], TP_BOUNDS[1], 180.0 * (side + 1), SPREAD_BOUNDS[1]]
    x0 = np.array(start, dtype=float)
    x0[2] = np.mod(x0[2], 360.0) if side or np.mod(x0[2], 360.0) <= 180.0 else 0.0
    x0 = np.clip(x0, np.add(low, 1e-6), np.subtract(high, 1e-6))
    return least_squares(model.residuals, x0, bounds=(low, high), x_scale=[1.0, 1.0, 10.0, 5.0],
                         max_nfev=100)  # fmt: skip


def _fit_both_sides(model: _Model, tp0: float) -> tuple[Any, Any]:
    """The best fit and the best fit on the other side (port or starboard), each started from
    the long-crested search's best direction on its side (`_Model.search`), σ_θ 10°."""
    guess, cost = model.search(tp0)
    sides = (DIRECTIONS > 180.0).astype(int)
    starts = [int(np.flatnonzero(sides == k)[np.argmin(cost[sides == k])]) for k in (0, 1)]
    fits = [_fit(model, np.r_[guess[k], DIRECTIONS[k], 10.0], side)
            for side, k in enumerate(starts)]  # fmt: skip
    best = 0 if fits[0].cost <= fits[1].cost else 1
    model.reweigh(model.phi(fits[best].x))  # the model's own standard errors (`reweigh`)
    fits = [_fit(model, f.x, side) for side, f in enumerate(fits)]
    return (fits[0], fits[1]) if fits[0].cost <= fits[1].cost else (fits[1], fits[0])


def estimate_sea(
    t: np.ndarray, motion: np.ndarray, raos: RaoTable, *, gamma: float = 3.3
) -> SeaEstimate:
    """The sea (Hs, Tp, mean direction, spreading and their uncertainty) of one window.

    Args:
        t: (N,) [s] uniform times, at least `MIN_WINDOW` long.
        motion: (N, 6) [m, rad] surge, sway, heave, roll, pitch, yaw of the centre of motion
            in the vessel frame; a column of NaN is an absent motion.
        raos: the vessel's RAO table (`twin.vessel.load_raos`).
        gamma: [-] JONSWAP peak enhancement assumed (3.3, the JONSWAP mean).

    Raises:
        EstimateRefused: too short, too calm or too poor a fit (module docstring).
        TwinError: malformed input.
    """
    t, motion = np.asarray(t, dtype=float), np.asarray(motion, dtype=float)
    _check_window(t, motion)
    used, notes = _usable(motion)
    spectra = cross_spectra(t, motion, used)
    _too_calm(spectra)
    model = _Model(spectra, raos, gamma)
    # small matrix-vector products: BLAS threads cost more than they share (measured 3× on 2
    # cores under load), and a server's other work keeps its cores
    with threadpool_limits(1, user_api="blas"):
        best, other = _fit_both_sides(model, _first_guess(spectra)[1])
    x = best.x.copy()
    x[2] = float(np.mod(x[2], 360.0))
    ambiguous = bool(other.cost <= MIRROR_TOLERANCE * best.cost)
    resid = best.fun
    dof = max(1, resid.size - x.size)
    chi2 = float(2.0 * best.cost / dof)
    sd = _uncertainty(best.jac, chi2)
    misfit = float(np.linalg.norm(resid) / max(float(np.linalg.norm(model.measured)), 1e-300))
    if misfit > MAX_MISFIT:
        raise EstimateRefused(f"motion too noisy for its RAOs: relative misfit {misfit:.2f}; at "
                              f"most {MAX_MISFIT:g} (noise, a frozen channel or another vessel's "
                              "RAOs)")  # fmt: skip
    notes.append("zero forward speed assumed (encounter frequency = wave frequency)")
    return SeaEstimate(
        hs=float(x[0]), hs_sd=sd[0], tp=float(x[1]), tp_sd=sd[1], direction=float(x[2]),
        direction_sd=sd[2], spread=float(x[3]), spread_sd=sd[3], gamma=gamma,
        mirror=float(np.mod(other.x[2], 360.0)),
        ambiguous=ambiguous, misfit=misfit, chi2=chi2,
        channels=tuple(DOFS[c] for c in used), segments=spectra.segments,
        start=float(t[0]), end=float(t[-1]), notes=tuple(notes),
    )  # fmt: skip


def _uncertainty(jac: np.ndarray, chi2: float) -> list[float]:
    """1-σ of each parameter: sqrt of diag (JᵀJ)⁻¹, scaled by the reduced χ² above 1
    (module docstring); inf where the Jacobian does not determine it."""
    cov = np.linalg.pinv(jac.T @ jac) * max(1.0, chi2)
    diag = np.diag(cov)
    return [float(np.sqrt(v)) if v > 0 and np.isfinite(v) else float("inf") for v in diag]


def estimate_series(series: MotionWindow, raos: RaoTable, *, gamma: float = 3.3) -> SeaEstimate:
    """`estimate_sea` of a motion series (an object with `time` and `motion`, as
    `twin.motion.series.MotionSeries`)."""
    return estimate_sea(series.time, series.motion, raos, gamma=gamma)


def window_starts(t0: float, t1: float, window: float = DEFAULT_WINDOW) -> np.ndarray:
    """[s] starts of the consecutive, non-overlapping windows of length `window` in [t0, t1]
    (a last, shorter part is dropped if under `MIN_WINDOW`, else kept as it is)."""
    if window < MIN_WINDOW:
        raise TwinError(f"window: {window:g} s; at least {MIN_WINDOW:g} s")
    starts = np.arange(t0, t1, window)
    return starts[t1 - starts >= MIN_WINDOW]
