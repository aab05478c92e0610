"""Each claim of docs/reproduction.md keeps its verdict: the engine is re-run on the claims and
judged by the report's rules (`twin.sim.claims`), and a verdict that moves fails naming its
claim.

The report judges every claim over sea seeds 50-149 (held out from the calibration's 0-49);
this test recomputes the first 40 of them (`TEST_SEEDS`, for its time: some 20-40 s on two
cores) and compares with the verdicts on those seeds that scripts/reproduce.py stored in
docs/reproduction/claims.json beside the report's own. A change that turns a claim from
"reproduced" to "not reproduced" therefore fails here until the report is regenerated and
says so.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from twin.sim.claims import TEST_SEEDS, claims, evaluate

CLAIMS_JSON = Path(__file__).resolve().parents[1] / "docs" / "reproduction" / "claims.json"


@pytest.fixture(scope="module")
def stored() -> dict:
    return json.loads(CLAIMS_JSON.read_text())


@pytest.fixture(scope="module")
def recomputed() -> dict:
    return evaluate(TEST_SEEDS)


def test_every_claim_is_in_the_report(stored: dict) -> None:
    """No claim of `twin.sim.claims` is missing from the stored table, on either seed set."""
    keys = {c.key for c in claims()}
    assert keys == set(stored["claims"]) == set(stored["test_verdicts"])
    assert stored["test_seeds"] == [TEST_SEEDS.start, TEST_SEEDS.stop - 1]


def test_claims_keep_their_verdicts(stored: dict, recomputed: dict) -> None:
    """The engine's verdict on `TEST_SEEDS` equals the stored one for every claim."""
    changed = {
        key: f"{stored['test_verdicts'][key]} -> {outcome.verdict}"
        for key, outcome in recomputed.items()
        if outcome.verdict != stored["test_verdicts"][key]
    }
    assert not changed, f"claims whose verdict changed (rerun scripts/reproduce.py): {changed}"


def test_fitted_numbers_are_flagged(stored: dict) -> None:
    """The three numbers a calibration knob was fitted to say so, and no other number does."""
    fitted = {key for key, c in stored["claims"].items() if c["fitted"]}
    assert fitted == {"seed000.pi.legs_max", "seed000.wpi.legs_max", "seed004.conv1.legs_max"}
