"""The web tests that time a running server, browser or worker against a budget (a crash's
recovery, a soak's latency, a render loop's rate, a server's shutdown) are marked `serial`:
`make test` runs them after the rest, alone, so that no other test's load eats their budget,
while everything else runs on two pytest-xdist workers."""

from __future__ import annotations

import pytest

#: modules of tests/web whose tests hold a running process to a time budget
SERIAL = {"test_browser", "test_cli", "test_crash", "test_load", "test_scene", "test_soak"}


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        if item.module is not None and item.module.__name__.rsplit(".", 1)[-1] in SERIAL:
            item.add_marker(pytest.mark.serial)
