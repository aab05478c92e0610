"""PATCH /api/live `motion_source` (issue 40): the live session follows the live motion input
or replays a stored log at 1-8×; a bad choice is a 422 naming what is allowed and changes
nothing; the same token and origin checks as every other control route."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient

from tests.web.support import TOKEN, access
from twin.motion.series import MotionSeries
from twin.sim.live import LiveSession
from twin.sim.measured import LOG_DIR_ENV, store_log
from twin.sim.motion_live import LiveMotion
from twin.web.api import create_app
from twin.web.store import RunStore


@pytest.fixture()
def motion() -> LiveMotion:
    """A live motion input that has just received two seconds of a heaving hull."""
    live = LiveMotion("udp :test", stale_after=600.0)  # live however slow the app's start
    t = np.arange(100) / 50
    live.push([(float(ti), (float(np.sin(ti)), 0.01, 0.02)) for ti in t], time.monotonic())
    return live


@pytest.fixture()
def session(motion: LiveMotion) -> LiveSession:
    """A session that is not started: only requests move it."""
    return LiveSession({"sea_state": 3}, motion=motion)


def client_of(session: LiveSession, tmp_path: Path, token: str | None = None) -> TestClient:
    return TestClient(create_app(session, RunStore(tmp_path / "runs.sqlite"), access=access(token)))


def test_udp_then_sea(session: LiveSession, tmp_path: Path) -> None:
    """kind udp restarts the session on the stream (status live, the input's counts shown);
    kind sea returns to the synthesised sea."""
    client = client_of(session, tmp_path)
    state = client.patch("/api/live", json={"motion_source": {"kind": "udp"}}).json()
    assert state["restarted"] is True and state["restart_reason"] == "motion_source changed"
    source = state["motion_source"]
    assert (source["kind"], source["status"]) == ("udp", "live")
    assert source["input"]["counts"]["samples"] == 100 and source["input"]["latest"]["roll"] == 0.01
    state = client.patch("/api/live", json={"motion_source": {"kind": "sea"}}).json()
    assert state["motion_source"]["status"] == "synthesised" and state["t"] == 0.0


def test_a_stored_log_replays_at_its_speed(
    session: LiveSession, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """kind log with a stored ID: the scenario's base_motion is the log, speed as asked."""
    monkeypatch.setenv(LOG_DIR_ENV, str(tmp_path / "logs"))
    t = np.arange(200) / 10
    motion = np.full((200, 6), np.nan)
    motion[:, 2] = np.sin(t)
    key = store_log(MotionSeries(t, motion, ("heave",)))
    body = {"motion_source": {"kind": "log", "log": key, "speed": 8}}
    state = client_of(session, tmp_path).patch("/api/live", json=body).json()
    assert state["speed"] == 8.0 and state["motion_source"]["log"] == key
    assert state["motion_source"]["status"] == "playing" and session.scenario.base_motion.log == key


@pytest.mark.parametrize(
    ("source", "said"),
    [
        ({"kind": "log", "log": "0123456789abcdef", "speed": 9}, "speed"),
        ({"kind": "log", "log": "0123456789abcdef", "speed": 0.5}, "speed"),
        ({"kind": "wind"}, "kind"),
        ({"kind": "log"}, "log ID"),
        ({"kind": "log", "log": "not-an-id"}, "log"),
        ({"kind": "log", "log": "0123456789abcdef"}, "not stored"),
    ],
)
def test_a_bad_source_is_422_and_changes_nothing(
    session: LiveSession, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
    source: dict[str, Any], said: str,
) -> None:  # fmt: skip
    """A speed outside 1-8, an unknown kind, a log ID missing, malformed or not stored: 422
    whose message names it and lists what motion_source allows; the session is unchanged."""
    monkeypatch.setenv(LOG_DIR_ENV, str(tmp_path / "logs"))
    before = session.snapshot()
    response = client_of(session, tmp_path).patch("/api/live", json={"motion_source": source})
    assert response.status_code == 422, response.text
    answer = response.json()
    assert said in answer["message"]
    assert any("speed ≤ 8" in e.get("allowed", "") for e in answer["detail"])
    after = session.snapshot()
    assert (after["t"], after["restarts"], after["motion_source"]["kind"]) == (
        before["t"], before["restarts"], "sea")  # fmt: skip


def test_udp_without_an_input_is_422(tmp_path: Path) -> None:
    """A server started without --motion-udp refuses kind udp, saying how to start one."""
    response = client_of(LiveSession({"sea_state": 3}), tmp_path).patch(
        "/api/live", json={"motion_source": {"kind": "udp"}})  # fmt: skip
    assert response.status_code == 422 and "--motion-udp" in response.json()["message"]


def test_the_source_needs_the_token_and_the_origin(session: LiveSession, tmp_path: Path) -> None:
    """Without the token 401, from another origin 403: the hull motion stays the sea's."""
    client = client_of(session, tmp_path, token=TOKEN)
    body = {"motion_source": {"kind": "udp"}}
    assert client.patch("/api/live", json=body).status_code == 401
    evil = {"Origin": "http://evil.example", "Authorization": f"Bearer {TOKEN}"}
    assert client.patch("/api/live", json=body, headers=evil).status_code == 403
    assert session.motion_state()["kind"] == "sea"
    ours = {"Authorization": f"Bearer {TOKEN}"}
    assert client.patch("/api/live", json=body, headers=ours).status_code == 200
