"""How soon a long session's vessel motion repeats: effective components and envelope recurrence.

python scripts/sea_repeat.py   (prints; docs/sea.md "A long session's vessel motion" quotes it)

For WMO sea state 4 at heading 150° on the SOV, each DOF's response weights
w_i = |a_i H(ω_i)|² (`twin.vessel.motion.response_amplitudes`, the engine's own terms) give
the effective number of components (Σw)²/Σw² and the envelope autocorrelation
|Σ w_i e^{jω_i τ}| / Σ w_i, whose largest value over lags 10 Tp … 3 h says how closely the
motion's envelope comes back. Also times the superposition per sample for each n.
"""

from __future__ import annotations

import time

import numpy as np

from twin.sea.sea_states import sea_state_hs_tp
from twin.sea.synthesis import wave_components
from twin.sim.base_motion import raos_named
from twin.vessel.motion import response_amplitudes, superpose

DOFS = {"heave": 2, "roll": 3, "pitch": 4}


def main() -> None:
    raos = raos_named("sov")
    hs, tp = (float(v) for v in sea_state_hs_tp(4.0))
    tau = np.arange(10 * tp, 3 * 3600, 0.5)  # [s] lags
    for gamma in (3.3, 1.0):
        for n in (200, 400, 800):
            for name, dof in DOFS.items():
                effective, worst = [], []
                for seed in range(10):
                    sea = wave_components(hs, tp, "jonswap", np.radians(150), None, seed, n,
                                          gamma=gamma)  # fmt: skip
                    omega_e, amplitude = response_amplitudes(sea, raos)
                    w = np.abs(amplitude[:, dof]) ** 2
                    effective.append(w.sum() ** 2 / (w**2).sum())
                    worst.append((np.abs(np.exp(1j * np.outer(tau, omega_e)) @ w) / w.sum()).max())
                print(f"γ {gamma} n {n} {name}: effective {np.mean(effective):.1f}, max "
                      f"autocorrelation 10 Tp-3 h: mean {np.mean(worst):.2f}, "
                      f"worst {max(worst):.2f}")  # fmt: skip
    t = np.arange(4096) * 0.05
    for n in (200, 400, 800):
        omega_e, amplitude = response_amplitudes(wave_components(hs, tp, n_components=n), raos)
        start = time.perf_counter()
        for _ in range(5):
            superpose(t, omega_e, amplitude)
        print(f"superpose n {n}: {(time.perf_counter() - start) / 5 / t.size * 1e6:.1f} µs/sample")


if __name__ == "__main__":
    main()
