"""Errors raised by the twin.

Every error is a `ValueError`, so callers that only know the standard library can still
catch bad input; messages say what was wrong and what is allowed.
"""

from __future__ import annotations


class TwinError(ValueError):
    """Base class of every error the twin raises on bad input or failed numerics."""


class ConvergenceError(TwinError):
    """An iterative solver (forward kinematics) did not reach its tolerance."""


class UnreachableError(TwinError):
    """A requested pose or state lies outside what a mechanism can reach."""
