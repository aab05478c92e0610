"""WMO sea-state code table 3700 and its representative fully developed seas."""

from __future__ import annotations

import numpy as np
import pytest

from twin.errors import TwinError
from twin.sea import G
from twin.sea.sea_states import WMO_SEA_STATES, sea_state_code, sea_state_hs_tp
from twin.sea.spectra import pierson_moskowitz, pierson_moskowitz_wind, pm_sea_from_wind

# WMO code table 3700 (WMO-No. 306): code → Hs range [m]
WMO_3700 = {
    0: (0.0, 0.0),
    1: (0.0, 0.1),
    2: (0.1, 0.5),
    3: (0.5, 1.25),
    4: (1.25, 2.5),
    5: (2.5, 4.0),
    6: (4.0, 6.0),
    7: (6.0, 9.0),
    8: (9.0, 14.0),
    9: (14.0, np.inf),
}


def test_table_matches_wmo_3700() -> None:
    """The sea-state table has codes 0-9 with WMO 3700's Hs bands, each typical Hs inside its
    band."""
    assert [s.code for s in WMO_SEA_STATES] == list(range(10))
    for state in WMO_SEA_STATES:
        assert (state.hs_min, state.hs_max) == WMO_3700[state.code]
        assert state.hs_min <= state.hs <= state.hs_max


def test_representative_hs_are_range_midpoints() -> None:
    """Middle of each range; code 9 closed at the 19 m WMO buoy record."""
    hs = [s.hs for s in WMO_SEA_STATES]
    np.testing.assert_allclose(hs, [0, 0.05, 0.3, 0.875, 1.875, 3.25, 5, 7.5, 11.5, 16.5])


@pytest.mark.parametrize("code", range(1, 10))
def test_representative_sea_is_fully_developed(code: int) -> None:
    """Its PM(Hs, Tp) is seed 001 eq (28) for the wind U that raises this Hs (0.2092 U²/g)."""
    state = WMO_SEA_STATES[code]
    wind = np.sqrt(state.hs * G / (2 * np.sqrt(0.0081 / 0.74)))
    omega = np.linspace(0.05, 30.0, 600)
    np.testing.assert_allclose(
        pierson_moskowitz(omega, state.hs, state.tp),
        pierson_moskowitz_wind(omega, wind),
        rtol=1e-10,
        atol=1e-14,
    )
    # DNV-RP-C205 §3.5.5.5: γ = 1 (PM) from Tp/sqrt(Hs) ≈ 5 on
    assert state.tp / np.sqrt(state.hs) == pytest.approx(5.0, rel=5e-3)


def test_integer_codes_give_table_values() -> None:
    """Integer codes give the table's Hs and Tp, with Tp increasing from code 1 up."""
    hs, tp = sea_state_hs_tp(np.arange(10))
    np.testing.assert_allclose(hs, [s.hs for s in WMO_SEA_STATES])
    np.testing.assert_allclose(tp, [s.tp for s in WMO_SEA_STATES])
    assert np.all(np.diff(tp[1:]) > 0)


def test_fractional_code_is_between_neighbours() -> None:
    """A slider at 4.5 lies halfway in Hs between codes 4 and 5, and is still fully developed."""
    hs, tp = sea_state_hs_tp(4.5)
    assert hs == pytest.approx((WMO_SEA_STATES[4].hs + WMO_SEA_STATES[5].hs) / 2)
    assert WMO_SEA_STATES[4].tp < tp < WMO_SEA_STATES[5].tp
    codes = np.linspace(0, 9, 91)
    hs_all, tp_all = sea_state_hs_tp(codes)
    assert np.all(np.diff(hs_all) > 0) and np.all(np.diff(tp_all) >= 0) and np.all(tp_all > 0)


def test_code_of_hs_inverts_the_table() -> None:
    """sea_state_code of each typical Hs is its code, and band edges fall into the right codes."""
    codes = sea_state_code([s.hs for s in WMO_SEA_STATES])
    np.testing.assert_array_equal(codes, np.arange(10))
    np.testing.assert_array_equal(sea_state_code([0.1, 0.5, 14.0, 14.01, 25.0]), [1, 2, 8, 9, 9])


def test_seed001_level_four_sea_is_wmo_code_5() -> None:
    """U = 12 m/s at 19.5 m (seed 001) raises Hs = 3.07 m: WMO 3700 calls that 'rough' (5)."""
    hs, _ = pm_sea_from_wind(12.0, g=9.8)
    assert float(hs) == pytest.approx(3.07, abs=0.01)
    assert sea_state_code(hs) == 5


@pytest.mark.parametrize("code", [-1, 9.5, 10, np.nan, np.inf])
def test_bad_code_names_range(code: float) -> None:
    """A code outside [0, 9] raises TwinError naming the range."""
    with pytest.raises(TwinError, match=r"sea-state code .*\[0, 9\]"):
        sea_state_hs_tp(code)
