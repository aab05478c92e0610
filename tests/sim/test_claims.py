"""The verdict rules of twin.sim.claims: Student-t CI of the mean, Wilson interval, and which
verdict a paper's number or a share gets (docs/reproduction.md, "Claims at a glance")."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from twin.sim.claims import Claim, judge, mean_ci, wilson

NUMBER = Claim("x", "test", "a number", 10.0)
SHARE = Claim("s", "test", "a claim", None, kind="share")


def test_mean_ci_is_student_t() -> None:
    """mean ± t(0.975, n − 1)·s/√n, and it covers the true mean about 95 % of the time."""
    x = np.array([1.0, 2.0, 4.0, 7.0])
    half = stats.t.ppf(0.975, 3) * x.std(ddof=1) / 2.0
    assert mean_ci(x) == pytest.approx((x.mean() - half, x.mean() + half))
    rng = np.random.default_rng(0)
    covered = [lo <= 0.0 <= hi for lo, hi in (mean_ci(rng.normal(size=20)) for _ in range(2000))]
    assert 0.93 < np.mean(covered) < 0.97


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
        (np.linspace(9.5, 13.5, 101), "reproduced"),  # 10 inside 5-95 %, not in the CI
        (np.linspace(11.0, 13.0, 101), "not reproduced"),  # 10 below every seed
    ],
)
def test_number_verdicts(values: np.ndarray, verdict: str) -> None:
    """matched: CI of the mean holds it; reproduced: 5-95 % range does; else not."""
    assert judge(NUMBER, values).verdict == verdict


@pytest.mark.parametrize(
    ("k", "verdict"), [(95, "reproduced"), (50, "undecided"), (5, "not reproduced")]
)
def test_share_verdicts(k: int, verdict: str) -> None:
    """Most seeds (Wilson lower end > 50 %) reproduce a claim; few (upper end < 50 %) do not."""
    outcome = judge(SHARE, np.r_[np.ones(k), np.zeros(100 - k)])
    assert outcome.verdict == verdict and outcome.mean == k / 100
