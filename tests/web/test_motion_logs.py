"""REST motion logs (`/api/motion-logs`, `twin.web.routers.motion`): a log's samples, or a log
file's bytes (`/file`, read in a bounded child), stored under its content's ID, listed and
described, named by a run's `base_motion`; malformed logs a 422 saying what is allowed; the
store capped; storing needs the token where the server has one."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient

from tests.web.support import TOKEN, access
from twin.motion.tss1 import format_tss1
from twin.sim import measured, simulate
from twin.sim.live import LiveSession
from twin.sim.measured import LOG_DIR_ENV
from twin.web.api import create_app
from twin.web.store import RunStore


@pytest.fixture()
def app_client(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> TestClient:
    """An app with a token, its logs in a folder of the test's own."""
    monkeypatch.setenv(LOG_DIR_ENV, str(tmp_path / "logs"))
    app = create_app(LiveSession({"sea_state": 3}), RunStore(tmp_path / "runs.sqlite"),
                     access=access(TOKEN))  # fmt: skip
    return TestClient(app)


def samples(n: int = 400, dt: float = 0.1) -> dict:
    """A 40 s heave-roll-pitch log in degrees."""
    t = np.arange(n) * dt
    return {"time": t.tolist(), "angles": "deg", "name": "mru 14-15.csv",
            "motion": {"heave": (0.5 * np.sin(0.7 * t)).tolist(),
                       "roll": (2.0 * np.sin(0.5 * t)).tolist(),
                       "pitch": (0.8 * np.cos(0.6 * t)).tolist()},
            "sensor_position": [5.0, 0.0, 3.0], "start": "2026-08-01T14:00:00Z"}  # fmt: skip


AUTH = {"Authorization": f"Bearer {TOKEN}"}


def test_a_stored_log_is_listed_described_and_drives_a_run(app_client: TestClient) -> None:
    """POST stores the log (201, its ID in Location); storing it again gives the same ID; the
    list and the log's page describe it; a run naming it has its base motion."""
    posted = app_client.post("/api/motion-logs", json=samples(), headers=AUTH)
    assert posted.status_code == 201, posted.text
    log = posted.json()
    assert posted.headers["Location"] == f"/api/motion-logs/{log['id']}"
    assert log["samples"] == 400 and log["channels"] == ["heave", "roll", "pitch"]
    assert log["duration"] == pytest.approx(39.9)
    assert log["start"] == "2026-08-01T14:00:00.000000000Z"
    again = app_client.post("/api/motion-logs", json=samples(), headers=AUTH).json()
    assert again["id"] == log["id"]
    assert [x["id"] for x in app_client.get("/api/motion-logs").json()] == [log["id"]]
    assert app_client.get(f"/api/motion-logs/{log['id']}").json()["name"] == "mru 14-15.csv"
    source = {"source": "log", "log": log["id"], "offset": 10.0}
    run = simulate({"planner": "qp", "duration": 20.0, "base_motion": source})
    assert np.ptp(run.series["base_pose"][:, 2]) > 0.5  # the log's heave moves the mount


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"motion": {"heave": [0.0, 1.0]}}, "motion.heave: 2 samples for 400 times"),
        ({"motion": {}}, "motion: empty"),
        ({"time": [0.0, 0.0, 0.0]}, "samples for 3 times"),
        ({"motion": {"bogus": [0.0] * 400}}, "bogus"),
        ({"name": "../../etc/passwd"}, "name"),
    ],
)
def test_a_malformed_log_is_a_422_saying_what_is_allowed(
    app_client: TestClient, change: dict, message: str
) -> None:
    """Mismatched lengths, an empty motion, an unknown channel and a path as a name are 422s
    naming what is wrong; nothing is stored."""
    body = samples() | change
    answer = app_client.post("/api/motion-logs", json=body, headers=AUTH)
    assert answer.status_code == 422 and message in answer.text, answer.text
    assert app_client.get("/api/motion-logs").json() == []


def test_repeated_times_and_unknown_logs_are_refused(app_client: TestClient) -> None:
    """Times that do not increase are a 422; an unknown or malformed ID is a 404."""
    body = samples(4)
    body["time"] = [0.0, 1.0, 1.0, 2.0]
    assert app_client.post("/api/motion-logs", json=body, headers=AUTH).status_code == 422
    assert app_client.get("/api/motion-logs/" + "a" * 16).status_code == 404
    assert app_client.get("/api/motion-logs/..%2F..%2Fx").status_code == 404


def test_storing_needs_the_token(app_client: TestClient) -> None:
    """Without the token (or with a wrong one) POST is refused; reading stays open."""
    assert app_client.post("/api/motion-logs", json=samples()).status_code in (401, 403)
    wrong = {"Authorization": "Bearer wrong-token-wrong-token"}
    refused = app_client.post("/api/motion-logs", json=samples(), headers=wrong)
    assert refused.status_code in (401, 403)
    assert app_client.get("/api/motion-logs").status_code == 200


def test_an_hour_at_10_hz_fits_the_upload_cap(app_client: TestClient) -> None:
    """The hour the batch question asks about (36,000 samples of heave, roll and pitch, about
    3 MB of JSON, over the 64 KiB of a scenario's body) is stored: the uploads' cap applies."""
    body = samples(36_000)
    answer = app_client.post("/api/motion-logs", json=body, headers=AUTH)
    assert answer.status_code == 201, answer.text[:200]
    assert answer.json()["samples"] == 36_000 and answer.json()["duration"] == pytest.approx(3599.9)


def test_the_store_refuses_a_log_past_its_cap(app_client: TestClient,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    """With room for one log only, the second is a 422 naming the cap and is not stored; the
    list still shows the first, read from its header."""
    first = app_client.post("/api/motion-logs", json=samples(), headers=AUTH).json()
    monkeypatch.setattr(measured, "MAX_STORED", first["samples"] * 7 * 8 * 2)
    refused = app_client.post("/api/motion-logs", json=samples(800), headers=AUTH)
    assert refused.status_code == 422 and "allowed ≤" in refused.text, refused.text
    assert [x["id"] for x in app_client.get("/api/motion-logs").json()] == [first["id"]]


def test_a_log_file_is_stored_from_its_bytes(app_client: TestClient) -> None:
    """A CSV table (angles in degrees) and the same motion as stamped TSS1 lines, each sent as
    the body of /file, are read in the bounded child and stored: samples, channels, name and
    the sensor's position as given; an unreadable body and a NUL are 422s naming why."""
    t = np.arange(300) * 0.1
    heave, roll = 0.5 * np.sin(0.7 * t), 2.0 * np.sin(0.5 * t)
    csv = "time,heave,roll_deg\n" + "".join(f"{a:.1f},{b:.4f},{c:.4f}\n"
                                            for a, b, c in zip(t, heave, roll, strict=True))
    stored = app_client.post("/api/motion-logs/file?name=mru.csv&x=5&z=3", content=csv,
                             headers=AUTH)  # fmt: skip
    assert stored.status_code == 201, stored.text
    log = stored.json()
    assert log["samples"] == 300 and log["channels"] == ["heave", "roll"]
    assert log["name"] == "mru.csv" and log["sensor_position"] == [5.0, 0.0, 3.0]
    assert app_client.get(stored.headers["Location"]).json()["id"] == log["id"]
    tss1 = "".join(f"{a:.1f} {format_tss1(b, np.radians(c), 0.0)}\r\n"
                   for a, b, c in zip(t, heave, roll, strict=True))  # fmt: skip
    nmea = app_client.post("/api/motion-logs/file?name=mru.nmea", content=tss1, headers=AUTH)
    assert nmea.status_code == 201, nmea.text
    assert nmea.json()["samples"] == 300 and nmea.json()["duration"] == pytest.approx(29.9)
    bad = app_client.post("/api/motion-logs/file", content="a,b\n1,2\n", headers=AUTH)
    assert bad.status_code == 422 and "no `time` column" in bad.text
    nul = app_client.post("/api/motion-logs/file", content="time\x00,heave\n", headers=AUTH)
    assert nul.status_code == 422 and "NUL" in nul.text
    assert app_client.post("/api/motion-logs/file", content=csv).status_code in (401, 403)
