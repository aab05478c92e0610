"""Does an object implement a protocol? `isinstance` with a `runtime_checkable` protocol only
asks whether the members exist; `conformance` also holds each method's positional parameters
against the protocol's (a method that takes one argument too few or too many fails here, not
deep inside a run). Used by tests/planners/test_protocols.py and tests/sim/test_protocols.py.
"""

from __future__ import annotations

import inspect
from typing import Any, Protocol

_POSITIONAL = (inspect.Parameter.POSITIONAL_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD)


def protocol_members(protocol: type) -> dict[str, Any]:
    """The members a protocol declares (its own and its protocol bases'), name → the
    declaration (a function or a property)."""
    members: dict[str, Any] = {}
    for base in reversed(protocol.__mro__):
        if base is Protocol or not getattr(base, "_is_protocol", False):
            continue
        for name, value in vars(base).items():
            if name == "__call__" or not name.startswith("_"):
                members[name] = value
    return members


def _arity(signature: inspect.Signature) -> tuple[int, int, bool]:
    """(required positional parameters, all positional parameters, takes *args)."""
    params = list(signature.parameters.values())
    positional = [p for p in params if p.kind in _POSITIONAL]
    required = [p for p in positional if p.default is inspect.Parameter.empty]
    star = any(p.kind is inspect.Parameter.VAR_POSITIONAL for p in params)
    return len(required), len(positional), star


def conformance(obj: object, protocol: type) -> list[str]:
    """What keeps `obj` from implementing `protocol`: missing members, non-callable methods,
    methods whose positional parameters do not take the protocol's calls. Empty if none."""
    problems = []
    for name, declared in protocol_members(protocol).items():
        if not hasattr(obj, name):
            problems.append(f"{type(obj).__name__} has no {name!r}")
            continue
        if isinstance(declared, property):
            continue
        method = getattr(obj, name)
        if not callable(method):
            problems.append(f"{type(obj).__name__}.{name} is not callable")
            continue
        want_required, want_all, _ = _arity(inspect.signature(declared))
        want_required, want_all = want_required - 1, want_all - 1  # the protocol's self
        have_required, have_all, star = _arity(inspect.signature(method))
        if have_required > want_required or (have_all < want_all and not star):
            problems.append(
                f"{type(obj).__name__}.{name} takes {have_required}-{have_all} positional "
                f"arguments; {protocol.__name__} calls it with {want_required}-{want_all}"
            )
    return problems
