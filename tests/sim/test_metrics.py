"""Metric functions: drift and seed 002's efficacy η."""

from __future__ import annotations

import numpy as np
import pytest

from twin.sim.metrics import drift, efficacy


def test_drift_of_a_ramp_is_its_rise_and_of_a_sine_nearly_zero() -> None:
    t = np.linspace(0, 100, 2001)
    ramp = np.stack([0.02 * t, np.sin(2 * np.pi * t / 7)], -1)
    d = drift(t, ramp)
    assert d[0] == pytest.approx(2.0)
    assert abs(d[1]) < 0.05


def test_efficacy_both_forms() -> None:
    """Seed 002 eq (29) and SPEC erratum 11: a top tilting half as much gives η = 50 %."""
    bottom = np.abs(np.sin(np.linspace(0.1, 10, 500))) + 0.01
    result = efficacy(0.5 * bottom, bottom)
    assert result["eta"] == pytest.approx(50.0)
    assert result["eta_printed"] == pytest.approx(50.0)
    perfect = efficacy(np.zeros_like(bottom), bottom)
    assert perfect["eta"] == pytest.approx(100.0)


def test_efficacy_printed_form_explodes_near_zero_tilt_but_stays_finite() -> None:
    """Dividing by α_bottom (erratum 11): tiny bottom tilt gives a huge, finite value."""
    bottom = np.array([1e-6, 0.1, 0.1])
    top = np.array([0.05, 0.05, 0.05])
    result = efficacy(top, bottom)
    assert result["eta_printed"] < -1e5 and np.isfinite(result["eta_printed"])
    assert efficacy(np.zeros(3), np.zeros(3)) == {"eta_printed": 0.0, "eta": 0.0}
