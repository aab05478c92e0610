"""Input checks shared by every layer: shape, finiteness, range.

Each returns a float64 array (a copy when a conversion was needed) or raises a
`TwinError` that names the argument and says what is allowed.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike
from pydantic import ValidationError

from twin.errors import TwinError


def as_array(value: ArrayLike, name: str, tail: tuple[int, ...] = ()) -> np.ndarray:
    """`value` as a finite float64 array whose trailing axes equal `tail`.

    Args:
        value: anything numpy can convert.
        name: the argument's name, used in the error message.
        tail: required trailing shape, e.g. `(6,)` for a batch of poses `(..., 6)`.

    Raises:
        TwinError: not numeric, wrong trailing shape, or a NaN/inf entry.
    """
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TwinError(f"{name} must be numeric, got {type(value).__name__}") from exc
    if tail and (array.ndim < len(tail) or array.shape[array.ndim - len(tail) :] != tail):
        want = "(..., " + ", ".join(map(str, tail)) + ")"
        raise TwinError(f"{name} must have shape {want}, got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise TwinError(f"{name} must be finite, got NaN or inf in {array.tolist()!r:.200}")
    return array


def check_range(value: np.ndarray, name: str, low: ArrayLike, high: ArrayLike) -> None:
    """Raise `TwinError` unless `low <= value <= high` element-wise (broadcast)."""
    low_a, high_a = np.broadcast_arrays(np.asarray(low, float), np.asarray(high, float))
    bad = (value < low_a) | (value > high_a)
    if np.any(bad):
        raise TwinError(
            f"{name} out of range: got {np.asarray(value)[bad].tolist()!r:.200}, "
            f"allowed [{np.min(low_a):g}, {np.max(high_a):g}]"
            + (
                ""
                if low_a.size == 1
                else f" per component {low_a.ravel().tolist()} .. {high_a.ravel().tolist()}"
            )
        )


def error_message(message: str, where: str) -> str:
    """One pydantic error's message as a person reads it, for the line `where: message`
    that the CLI (`explain`) and the REST API's 422 (`twin.web.models.unprocessable`) write:
    without pydantic's "Value error, " (a validator's ValueError, e.g. a `TwinError`) and,
    when the message names its field first (a TwinError's "sea_state: given together …"),
    without that name, which `where` already says.

    Args:
        message: pydantic's `msg` of the error.
        where: the field's dotted location ("" for the whole document: nothing stripped).
    """
    message = str(message).removeprefix("Value error, ")
    return message.removeprefix(f"{where}: ") if where else message


def explain(error: ValidationError) -> str:
    """A pydantic error as a person reads it: one `field: what is wrong (got …)` per mistake,
    without pydantic's type codes and documentation links; a document that is not JSON says so.
    """
    lines = []
    for item in error.errors(include_url=False):
        if item["type"] == "json_invalid":
            detail = str(item.get("ctx", {}).get("error", item["msg"])).removeprefix(
                "Invalid JSON: "
            )
            lines.append(f"not valid JSON: {detail}")
            continue
        where = ".".join(str(part) for part in item["loc"])
        message = error_message(item["msg"], where)
        got = item.get("input")
        shown = (
            f" (got {got!r})"
            if isinstance(got, str | int | float)
            and len(repr(got)) <= 40
            and item["type"] != "value_error"
            else ""
        )
        lines.append(f"{where}: {message}{shown}" if where else f"{message}{shown}")
    return "; ".join(lines)
