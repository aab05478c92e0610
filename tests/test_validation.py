"""pydantic errors as a person reads them: one formatter for the CLI and the REST API."""

from __future__ import annotations

import json
from typing import Any

import pytest
from pydantic import BaseModel, ValidationError, field_validator

from twin.errors import TwinError
from twin.validation import error_message, explain
from twin.web.models import unprocessable


class Sea(BaseModel):
    """A model whose validator raises a TwinError that names its field, as twin's do."""

    hs: float
    tp: float = 8.0

    @field_validator("hs")
    @classmethod
    def _hs_in_range(cls, hs: float) -> float:
        if not 0.0 <= hs <= 20.0:
            raise TwinError(f"hs: out of range, got {hs}, allowed [0, 20]")
        return hs


def test_error_message_drops_pydantics_prefix_and_the_field_named_twice() -> None:
    """error_message drops pydantic's prefix and a repeated field name, keeping a field other than
    the one located."""
    assert error_message("Value error, hs: out of range", "hs") == "out of range"
    assert error_message("Value error, hs: hs: twice", "hs") == "hs: twice"  # once only
    assert error_message("Value error, hs: out of range", "tp") == "hs: out of range"
    assert error_message("Input should be greater than 0", "duration") == (
        "Input should be greater than 0"
    )
    # the whole document (no location): the message keeps the field it names
    assert error_message("Value error, sea_state: given together with hs", "") == (
        "sea_state: given together with hs"
    )


def _errors(**values: Any) -> ValidationError:
    with pytest.raises(ValidationError) as caught:
        Sea(**values)
    return caught.value


def test_the_cli_and_the_rest_api_say_a_mistake_alike() -> None:
    """The same errors: `explain` (CLI) and the 422's message (REST) name each field once, the
    TwinError's words without pydantic's "Value error, "; the REST one adds what is allowed."""
    error = _errors(hs=25.0, tp="long")
    cli = explain(error)
    assert cli == (
        "hs: out of range, got 25.0, allowed [0, 20]; "
        "tp: Input should be a valid number, unable to parse string as a number (got 'long')"
    )
    body = [{"loc": ("body", *e["loc"]), "msg": e["msg"], "type": e["type"]}
            for e in error.errors(include_url=False)]  # fmt: skip
    answer = json.loads(bytes(unprocessable(body, {"tp": "> 0 s"}).body))
    assert answer["message"] == (
        "hs: out of range, got 25.0, allowed [0, 20]; "
        "tp: Input should be a valid number, unable to parse string as a number "
        "(allowed: > 0 s)"
    )
    assert answer["detail"][0]["msg"].startswith("Value error, hs: ")  # pydantic's own, kept


def test_a_rest_error_names_each_field_once_and_lists_the_allowed_values_once() -> None:
    """A location a nested validator repeats ("hs", "hs") is named once; "(allowed: …)" is
    not appended after a message that lists the allowed values itself, nor when it names types
    only; a range that says more is still appended."""
    body = [
        {"loc": ("body", "hs", "hs"), "msg": "Input should be greater than or equal to 0",
         "type": "greater_than_equal"},
        {"loc": ("body", "mechanism"), "msg": "Input should be 'hybrid', 'upu3up' or 'upr4'",
         "type": "literal_error"},
        {"loc": ("body", "planner"), "msg": "Input should be a valid string",
         "type": "string_type"},
        {"loc": ("body", "beta"), "msg": "Input should be a valid number", "type": "float_type"},
    ]  # fmt: skip
    ranges = {"hs": "array", "mechanism": "one of 'hybrid', 'upu3up', 'upr4'",
              "planner": "string or null", "beta": "0 ≤ beta ≤ 1 or null"}  # fmt: skip
    answer = json.loads(bytes(unprocessable(body, ranges).body))
    assert answer["message"].split("; ") == [
        "hs: Input should be greater than or equal to 0",
        "mechanism: Input should be 'hybrid', 'upu3up' or 'upr4'",
        "planner: Input should be a valid string",
        "beta: Input should be a valid number (allowed: 0 ≤ beta ≤ 1 or null)",
    ]
