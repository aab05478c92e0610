"""Mechanism layer: kinematics of the three mechanisms of the source papers.

`MECHANISMS` maps the registry names every other layer uses to the classes.
"""

from __future__ import annotations

from twin.mechanisms.gangway import Gangway
from twin.mechanisms.hybrid import JOINT_NAMES, HybridBoardingSystem
from twin.mechanisms.legs import LegLayout, LegState
from twin.mechanisms.stewart import StewartPlatform
from twin.mechanisms.upr4 import Upr4
from twin.mechanisms.upu3up import Upu3Up

MECHANISMS: dict[str, type] = {
    "hybrid": HybridBoardingSystem,
    "upu3up": Upu3Up,
    "upr4": Upr4,
}

__all__ = [
    "JOINT_NAMES",
    "MECHANISMS",
    "Gangway",
    "HybridBoardingSystem",
    "LegLayout",
    "LegState",
    "StewartPlatform",
    "Upr4",
    "Upu3Up",
]
