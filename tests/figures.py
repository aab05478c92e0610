"""Figures a reliability test measured (inputs fuzzed, faults injected, load held).

`record` appends one JSON line to the file named by `TWIN_RELIABILITY_LOG` when it is set
(`scripts/reliability.py` sets it and renders docs/reliability.md from the lines); otherwise
it does nothing, so the tests run the same either way. `fuzz` gives a property test its
reproducible hypothesis settings and marks how many inputs it tries; tests/conftest.py
records that count once the test has passed.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from typing import Any

from hypothesis import settings


def record(test: str, **figures: Any) -> None:
    """Append `{"test": test, **figures}` to `$TWIN_RELIABILITY_LOG`, if set."""
    path = os.environ.get("TWIN_RELIABILITY_LOG")
    if path:
        with open(path, "a", encoding="utf-8") as log:
            log.write(json.dumps({"test": test, **figures}) + "\n")


def fuzz(examples: int) -> Callable[[Callable], Callable]:
    """Reproducible hypothesis settings (`examples` inputs, no per-example deadline: a wall-clock
    limit would fail a loaded machine, and speed is the benchmarks' business); the test
    carries `fuzz_examples` for the conftest fixture that records it."""

    def decorate(test: Callable) -> Callable:
        test = settings(max_examples=examples, deadline=None, derandomize=True, database=None)(
            test
        )
        test.fuzz_examples = examples  # type: ignore[attr-defined]
        return test

    return decorate
