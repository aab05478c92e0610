"""`twin motion-log` and `twin motion-replay` (twin/cli.py) on the shipped example log
(assets/motion, synthetic, scripts/build_motion_example.py): stored and compared across every
hybrid planner on a window; replayed to a loopback socket; bad arguments are usage errors."""

from __future__ import annotations

import json
import socket
from pathlib import Path

import pytest

from twin.cli import main
from twin.planners import PLANNERS

LOG = Path(__file__).resolve().parents[2] / "assets" / "motion" / "mru_example.csv"
SENSOR = LOG.with_name("sensor.yaml")


def test_motion_log_stores_and_compares_every_planner(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """The example log is stored (its ID printed as JSON) and every hybrid planner is run on
    10 s of it, one line each with its tip error and first limit."""
    monkeypatch.delenv("TWIN_MOTION_LOGS", raising=False)
    code = main(["motion-log", str(LOG), "--sensor", str(SENSOR), "--data-dir", str(tmp_path),
                 "--compare", "--from", "600", "--to", "610"])  # fmt: skip
    out = capsys.readouterr().out.splitlines()
    assert code == 0
    stored = json.loads(out[0])
    assert (tmp_path / "motion_logs" / f"{stored['id']}.npz").is_file()
    assert stored["samples"] == 9000 and stored["channels"] == ["heave", "roll", "pitch"]
    hybrid = sorted(n for n, p in PLANNERS.items() if "hybrid" in p.mechanisms)
    rows = {line.split()[0]: line for line in out[2:]}
    assert sorted(rows) == hybrid


def test_motion_replay_sends_the_log_to_loopback(capsys: pytest.CaptureFixture[str]) -> None:
    """At × 100 speed, the first 9000 samples of the log go out as $PSXN,23 datagrams; the
    receiver gets sentences."""
    receiver = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    receiver.bind(("127.0.0.1", 0))
    receiver.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4 * 1024 * 1024)
    port = receiver.getsockname()[1]
    assert main(["motion-replay", str(LOG), "--sensor", str(SENSOR), "--udp",
                 f"127.0.0.1:{port}", "--speed", "100"]) == 0  # fmt: skip
    receiver.settimeout(1.0)
    first = receiver.recv(4096).decode()
    receiver.close()
    assert first.startswith("$PSXN,23,") and first.endswith("\r\n")
    assert "lines sent" in capsys.readouterr().err


@pytest.mark.parametrize("udp", ["127.0.0.1", "host:port", ":10110"])
def test_a_bad_destination_is_a_usage_error(udp: str, capsys: pytest.CaptureFixture[str]) -> None:
    """--udp without HOST:PORT exits 2 with the sub-command's usage line."""
    with pytest.raises(SystemExit) as exit_:
        main(["motion-replay", str(LOG), "--udp", udp])
    assert exit_.value.code == 2
    assert "twin motion-replay" in capsys.readouterr().err
