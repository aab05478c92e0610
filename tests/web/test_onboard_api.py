"""Onboard reports over REST (issue 40): a log uploaded as samples, the report polled to done
and equal to the library's, its timeline PNG; bad logs and over-priced reports are 422s saying
what is allowed; an unknown report a 404."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient

from tests.web.support import access, wait_for
from twin.runs.executor import IN_PROCESS, Executor
from twin.runs.onboard import OnboardSpec, onboard_report
from twin.sea.synthesis import wave_components
from twin.sim.live import LiveSession
from twin.vessel import DOFS, load_raos, vessel_motion
from twin.web import RunStore, create_app

#: the cheapest cells that still run the engine
CELLS = {"seeds": 1, "duration": 4.0, "hs_grid": [1.0, 2.0], "tp_grid": [8.0],
         "heading_grid": [0.0, 90.0, 180.0, 270.0]}  # fmt: skip


def log() -> tuple[np.ndarray, np.ndarray]:
    """10 min at 2 Hz of the SOV in Hs 1.5 m, Tp 8 s, β 150°."""
    t = np.arange(0.0, 600.0, 0.5)
    sea = wave_components(1.5, 8.0, heading=np.radians(150.0), seed=5, n_components=300)
    return t, vessel_motion(sea, load_raos("sov"), t)


def body(**change: Any) -> dict[str, Any]:
    """A request: the log (angles in degrees, no surge), a 10-min window, the tiny cells."""
    t, motion = log()
    channels = {name: motion[:, DOFS.index(name)] for name in DOFS if name != "surge"}
    out = {"time": t.tolist(), "angles": "deg", "window": 600.0, "workability": CELLS,
           "start": "2026-08-01T14:00:00Z",
           "motion": {k: (np.degrees(v) if DOFS.index(k) >= 3 else v).tolist()
                      for k, v in channels.items()}}  # fmt: skip
    return out | change


@pytest.fixture(scope="module")
def client(tmp_path_factory: pytest.TempPathFactory) -> Iterator[TestClient]:
    store = RunStore(tmp_path_factory.mktemp("data") / "runs.sqlite")
    with Executor.start(IN_PROCESS) as executor:
        app = create_app(LiveSession(), store, access=access(), executor=executor)
        with TestClient(app) as client:
            yield client
    store.close()


def test_round_trip(client: TestClient) -> None:
    """POST answers 202 with the report's Location; polled, it is done with the library's
    numbers for the same log (sea, probability, advice), and its timeline is a PNG."""
    answer = client.post("/api/onboard", json=body())
    assert answer.status_code == 202, answer.text
    where = answer.headers["Location"]
    last: dict[str, Any] = {}

    def finished() -> bool:
        nonlocal last
        last = client.get(where).json()
        return last["status"] != "running"

    assert wait_for(finished, 300.0, poll=0.2), last
    assert last["status"] == "done", last
    result = last["result"]
    t, motion = log()
    motion[:, 0] = np.nan
    library = onboard_report(t, motion, OnboardSpec(window=600.0, workability=CELLS))
    window = result["windows"][0]
    assert window["time"] == "2026-08-01T14:00:00Z"
    assert window["hs"] == pytest.approx(library.windows["hs"].iloc[0], rel=1e-6)
    assert window["probability"] == pytest.approx(library.windows["probability"].iloc[0])
    assert [a["heading"] for a in result["advice"]] == library.advice["heading"].tolist()
    png = client.get(f"{where}/timeline.png")
    assert png.status_code == 200 and png.content[:4] == b"\x89PNG"


@pytest.mark.parametrize(("change", "says"), [
    ({"motion": {"heave": [0.0] * 1200, "pitch": [0.0] * 1200}}, "roll"),
    ({"time": list(np.arange(0.0, 300.0, 0.5))}, "samples"),
    ({"window": 120.0}, "window"),
])  # fmt: skip
def test_bad_logs_refused(client: TestClient, change: dict[str, Any], says: str) -> None:
    """A log without roll, motions of another length than time, or a window under 10 min is a
    422 naming the problem."""
    answer = client.post("/api/onboard", json=body(**change))
    assert answer.status_code == 422
    assert says in answer.text


def test_uneven_and_short_logs_refused(client: TestClient) -> None:
    """Uneven times, a log shorter than one window and samples over 1 s apart are 422s at
    `time` saying what is allowed."""
    uneven = body()
    uneven["time"][5] += 0.2
    answer = client.post("/api/onboard", json=uneven)
    assert answer.status_code == 422 and "uniform" in answer.text
    answer = client.post("/api/onboard", json=body(window=1200.0))
    assert answer.status_code == 422 and "at least one window" in answer.text
    sparse = body()
    sparse["time"] = [2.0 * k for k in range(len(sparse["time"]))]
    answer = client.post("/api/onboard", json=sparse)
    assert answer.status_code == 422 and "1 Hz or faster" in answer.text
    assert answer.json()["detail"][0]["loc"] == ["body", "time"]


def test_priced_as_workability(client: TestClient) -> None:
    """A report whose cells would exceed workability's run cap is a 422 naming MAX_RUNS."""
    heavy = {**CELLS, "seeds": 50, "hs_grid": [0.5 * k for k in range(1, 41)],
             "tp_grid": [float(k) for k in range(3, 21)],
             "heading_grid": [float(h) for h in range(0, 360, 10)]}  # fmt: skip
    answer = client.post("/api/onboard", json=body(workability=heavy))
    assert answer.status_code == 422 and "MAX_RUNS" in answer.text


def test_unknown_report(client: TestClient) -> None:
    """An id no report has is a 404."""
    assert client.get("/api/onboard/" + "0" * 32).status_code == 404
