"""What a new user hits first (issue 27): one clear error per mistake, a sea set once, a
restart that says so, a sweep whose planner follows its mechanism."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from tests.web.support import access
from twin.cli import main
from twin.runs.sweep import SweepSpec
from twin.sim.live import LiveSession
from twin.web.api import create_app
from twin.web.store import RunStore

JSON = {"content-type": "application/json"}


@pytest.fixture(scope="module")
def client(tmp_path_factory: pytest.TempPathFactory) -> Iterator[TestClient]:
    session = LiveSession({"mechanism": "upr4"})
    store = RunStore(tmp_path_factory.mktemp("data") / "runs.sqlite")
    with TestClient(create_app(session, store, access=access())) as client:
        yield client
    store.close()


def test_a_body_that_is_not_json_says_so(client: TestClient) -> None:
    """A body that is not JSON is a 422 saying so, at which character, on both routes."""
    for path, method in (("/api/runs", "POST"), ("/api/live", "PATCH")):
        answer = client.request(method, path, content=b'{"mechanism": hybrid}', headers=JSON)
        assert answer.status_code == 422
        message = answer.json()["message"]
        assert message.startswith("the body is not valid JSON: ") and "at character" in message
        assert "0: JSON decode error" not in message


@pytest.mark.parametrize("sea", [{"hs": 2.0}, {"tp": 8.0}, {"hs": 2.0, "tp": 8.0}])
def test_sea_state_with_hs_or_tp_is_refused_naming_what_to_drop(
    client: TestClient, sea: dict[str, float]
) -> None:
    """sea_state with hs or tp is a 422 naming what to drop, and changes nothing."""
    before = client.get("/api/live").json()
    for method, path in (("POST", "/api/runs"), ("PATCH", "/api/live")):
        answer = client.request(method, path, json={"sea_state": 5, **sea})
        assert answer.status_code == 422, answer.text
        message = answer.json()["message"]
        assert message.startswith("sea_state: given together with") and "drop sea_state" in message
        assert all(name in message for name in sea)
    after = client.get("/api/live").json()
    assert (after["sea_state"], after["hs"], after["tp"]) == (
        before["sea_state"], before["hs"], before["tp"])  # fmt: skip


def test_a_live_sea_state_takes_over_from_hs_and_tp(client: TestClient) -> None:
    """A live sea_state set after hs and tp clears them (one sea at a time)."""
    assert client.patch("/api/live", json={"hs": 1.5, "tp": 7.0}).json()["hs"] == 1.5
    state = client.patch("/api/live", json={"sea_state": 3}).json()
    assert (state["sea_state"], state["hs"], state["tp"]) == (3, None, None)


def test_a_change_that_restarts_live_time_says_so(client: TestClient) -> None:
    """A knob keeps live time; a compare planner restarts it at 0 and says why."""
    knob = client.patch("/api/live", json={"k_e": 20.0}).json()
    assert knob["restarted"] is False
    compare = client.patch("/api/live", json={"compare_planner": "ik"}).json()
    assert compare["restarted"] is True and compare["t"] == 0.0
    assert compare["restart_reason"] == "compare_planner changed"
    assert compare["restarts"] == knob["restarts"] + 1
    assert client.get("/api/live").json()["restart_reason"] == "compare_planner changed"
    assert client.patch("/api/live", json={"compare_planner": None}).json()["restarted"] is True


def test_a_sweeps_planner_follows_its_mechanism() -> None:
    """A sweep without planners takes its mechanism's default planner."""
    assert SweepSpec(mechanism="upr4").planner == ["pid"]
    assert SweepSpec(mechanism="upu3up").planner == ["pid"]
    assert SweepSpec().planner == ["mtmp"]
    assert SweepSpec(mechanism="upr4", planner=None).scenarios()[0]["planner"] == "pid"


def test_a_mistyped_mechanism_is_one_error_without_pydantic_links(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A sweep spec with a mistyped mechanism exits 2 with one line naming the allowed ones (no
    pydantic links or type tags); a spec that is not JSON says so."""
    spec = tmp_path / "spec.json"
    spec.write_text(json.dumps({"mechanism": "3upu_up", "planner": ["pid"], "hs": [1.0]}))
    with pytest.raises(SystemExit) as exited:
        main(["sweep", str(spec), "--scheduler", "in-process", "--out", str(tmp_path / "o")])
    assert exited.value.code == 2
    err = capsys.readouterr().err
    assert "mechanism: Input should be 'hybrid', 'upu3up' or 'upr4' (got '3upu_up')" in err
    assert "does not plan" not in err and "pydantic.dev" not in err and "[type=" not in err
    spec.write_text("{not json")
    with pytest.raises(SystemExit):
        main(["sweep", str(spec), "--scheduler", "in-process", "--out", str(tmp_path / "o")])
    assert "not valid JSON" in capsys.readouterr().err
