"""The verdict rules of twin.runs.claims: bootstrap CI of the mean, Wilson interval, which
verdict a paper's number or a share gets, and the block-stability rule (docs/reproduction.md,
"Verdicts over 1000 seeds")."""

from __future__ import annotations

import numpy as np
import pytest

from twin.runs.claims import BLOCK, BLOCKS, Claim, judge, mean_ci, stable_verdict, wilson

NUMBER = Claim("x", "test", "a number", 10.0)
SHARE = Claim("s", "test", "a claim", None, kind="share")


def test_mean_ci_is_a_bootstrap_that_covers() -> None:
    """The bootstrap CI holds the sample mean, is reproducible, and covers the true mean about
    95 % of the time (n = 50 normal samples)."""
    x = np.array([1.0, 2.0, 4.0, 7.0, 3.0])
    lo, hi = mean_ci(x)
    assert lo < x.mean() < hi and mean_ci(x) == (lo, hi)
    rng = np.random.default_rng(0)
    covered = [lo <= 0.0 <= hi for lo, hi in (mean_ci(rng.normal(size=50)) for _ in range(400))]
    assert 0.9 < np.mean(covered) < 0.98


def test_wilson_interval_at_the_ends_and_inside() -> None:
    """Wilson's interval stays in [0, 1], is not empty at 0/n and n/n, and holds k/n."""
    assert wilson(0, 100)[0] == pytest.approx(0.0, abs=1e-12) and 0.0 < wilson(0, 100)[1] < 0.05
    assert wilson(100, 100)[1] == pytest.approx(1.0) and 0.95 < wilson(100, 100)[0] < 1.0
    low, high = wilson(91, 100)
    assert low < 0.91 < high and high - low < 0.15


@pytest.mark.parametrize(
    ("values", "verdict"),
    [
        (np.linspace(9.0, 11.0, 101), "matched"),  # mean 10: the CI holds the paper's 10
        (np.linspace(9.5, 13.5, 101), "reproduced"),  # 10 at P12.5: in 10-90 %, not in the CI
        (np.linspace(9.8, 13.8, 101), "not reproduced"),  # 10 at P5: outside the band
        (np.linspace(11.0, 13.0, 101), "not reproduced"),  # 10 below every seed
    ],
)
def test_number_verdicts(values: np.ndarray, verdict: str) -> None:
    """matched: CI of the mean holds it; reproduced: the 10-90 % band does; else not."""
    assert judge(NUMBER, values).verdict == verdict


def test_a_comparison_needs_the_papers_sign_on_90_percent() -> None:
    """A comparison in the band but with the paper's sign on only 85 % of seeds is not
    reproduced; on 95 % it is."""
    claim = Claim("c", "test", "A below B by", 10.0, "%", comparison=True)
    mixed = np.r_[np.full(15, -1.0), np.linspace(2.0, 30.0, 85)]
    assert judge(claim, mixed).extra["same_sign"] == pytest.approx(0.85)
    assert judge(claim, mixed).verdict == "not reproduced"
    assert judge(claim, np.r_[np.full(5, -1.0), np.linspace(2.0, 30.0, 95)]).verdict in (
        "matched",
        "reproduced",
    )


def test_a_verdict_needs_nine_blocks_of_ten() -> None:
    """Eight agreeing blocks make a claim seed-dependent, with the split; nine state it."""
    good, bad = np.linspace(9.0, 11.0, BLOCK), np.linspace(11.0, 13.0, BLOCK)
    eight = np.concatenate([good] * 8 + [bad] * 2)
    outcome, split = stable_verdict(NUMBER, eight)
    assert outcome.verdict == "seed-dependent" and split == {"reproduced": 8, "not reproduced": 2}
    nine = np.concatenate([good] * 9 + [bad])
    assert stable_verdict(NUMBER, nine)[0].verdict in ("matched", "reproduced")
    assert sum(stable_verdict(NUMBER, nine)[1].values()) == BLOCKS


@pytest.mark.parametrize(
    ("k", "verdict"), [(95, "reproduced"), (50, "undecided"), (5, "not reproduced")]
)
def test_share_verdicts(k: int, verdict: str) -> None:
    """Most seeds (Wilson lower end > 50 %) reproduce a claim; few (upper end < 50 %) do not."""
    outcome = judge(SHARE, np.r_[np.ones(k), np.zeros(100 - k)])
    assert outcome.verdict == verdict and outcome.mean == k / 100
