"""Figures a reliability test measured (inputs fuzzed, faults injected, load held).

`record` appends one JSON line to the file named by `TWIN_RELIABILITY_LOG` when it is set
(`scripts/reliability.py` sets it and renders docs/reliability.md from the lines); otherwise
it does nothing, so the tests run the same either way.
"""

from __future__ import annotations

import json
import os
from typing import Any


def record(test: str, **figures: Any) -> None:
    """Append `{"test": test, **figures}` to `$TWIN_RELIABILITY_LOG`, if set."""
    path = os.environ.get("TWIN_RELIABILITY_LOG")
    if path:
        with open(path, "a", encoding="utf-8") as log:
            log.write(json.dumps({"test": test, **figures}) + "\n")
