"""Motion logs (`twin.motion.logs`), the sensor file (`twin.motion.sensor`), the series
(`twin.motion.series`) and the UDP replay (`twin.motion.replay`): tables in degrees or radians
with the sensor's signs, NMEA text sniffed, bad rows counted, resampling with gaps, and a log
sent over loopback UDP read back by the stream parser without a dropped line."""

from __future__ import annotations

import math
import socket
import threading
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from twin.errors import TwinError
from twin.motion.logs import read_motion, read_motion_log
from twin.motion.nmea import sentence
from twin.motion.replay import send, sentences
from twin.motion.sensor import Sensor
from twin.motion.series import MotionSeries
from twin.motion.stream import MotionStream


def table(n: int = 600, rate: float = 10.0) -> pd.DataFrame:
    """A minute of heave, roll and pitch [deg] at `rate`, heave positive down (a PSXN-style
    sensor)."""
    t = np.arange(n) / rate
    return pd.DataFrame({"time": t, "heave": -0.4 * np.sin(0.8 * t),
                         "roll_deg": 2.0 * np.sin(0.6 * t), "pitch_deg": np.cos(0.5 * t)})


def test_a_csv_and_a_parquet_log_read_the_same_with_the_sensors_signs(tmp_path: Path) -> None:
    """The same table as CSV and Parquet gives one series; degrees become radians, and a
    sensor file flipping heave and pitch turns them into the twin's convention."""
    frame = table()
    frame.to_csv(tmp_path / "log.csv", index=False)
    frame.to_parquet(tmp_path / "log.parquet")
    (tmp_path / "sensor.yaml").write_text("position: [10, -2, 5]\nsigns: {heave: -1, pitch: -1}\n")
    sensor = Sensor.load(tmp_path / "sensor.yaml")
    assert sensor.position == (10.0, -2.0, 5.0) and sensor.signs["roll"] == 1.0
    csv, parquet = (read_motion(tmp_path / name, sensor) for name in ("log.csv", "log.parquet"))
    np.testing.assert_allclose(csv.motion, parquet.motion, rtol=0, atol=1e-15)  # CSV text
    assert csv.channels == ("heave", "roll", "pitch") and csv.rate_hz == pytest.approx(10.0)
    np.testing.assert_allclose(csv.motion[:, 2], 0.4 * np.sin(0.8 * frame["time"]))
    np.testing.assert_allclose(csv.motion[:, 3], np.radians(frame["roll_deg"]))
    np.testing.assert_allclose(csv.motion[:, 4], -np.radians(frame["pitch_deg"]))
    assert np.isnan(csv.motion[:, 0]).all()


def test_bad_rows_are_counted_and_bad_files_named(tmp_path: Path) -> None:
    """A row without time and one back in time are skipped and counted; a table without
    `time` or without any motion column, and a sensor file with a bad sign, are refused with
    what is allowed."""
    frame = table(50)
    frame.loc[10, "time"] = np.nan
    frame.loc[20, "time"] = 0.5
    frame.to_csv(tmp_path / "log.csv", index=False)
    series = read_motion_log(tmp_path / "log.csv")
    assert series.issues == {"no time": 1, "out of order": 1} and len(series) == 48
    frame.drop(columns="time").to_csv(tmp_path / "notime.csv", index=False)
    with pytest.raises(TwinError, match="no `time` column"):
        read_motion_log(tmp_path / "notime.csv")
    frame[["time"]].to_csv(tmp_path / "nomotion.csv", index=False)
    with pytest.raises(TwinError, match="no motion column; allowed"):
        read_motion_log(tmp_path / "nomotion.csv")
    (tmp_path / "bad.yaml").write_text("signs: {heave: 2}\n")
    with pytest.raises(TwinError, match="allowed: \\+1 or -1"):
        Sensor.load(tmp_path / "bad.yaml")


def test_nmea_text_is_sniffed_and_iso_times_give_a_start(tmp_path: Path) -> None:
    """A file of stamped sentences is read as NMEA; a table with ISO times has a UTC start."""
    lines = [f"2026-08-01T14:00:{k / 10:06.3f}Z "
             + sentence(f"PSXN,23,{k % 7 / 10:.1f},0.0,90.0,0.0") for k in range(30)]
    (tmp_path / "mru.txt").write_text("\n".join(lines) + "\n")
    series = read_motion(tmp_path / "mru.txt")
    assert len(series) == 30 and series.start == np.datetime64("2026-08-01T14:00:00")
    frame = table(20)
    frame["time"] = pd.date_range("2026-08-01 14:00", periods=20, freq="100ms").strftime(
        "%Y-%m-%dT%H:%M:%S.%fZ")  # fmt: skip
    frame.to_csv(tmp_path / "iso.csv", index=False)
    iso = read_motion(tmp_path / "iso.csv")
    assert iso.start == np.datetime64("2026-08-01T14:00") and iso.time[-1] == pytest.approx(1.9)


def test_resampling_marks_gaps_and_windows_keep_times() -> None:
    """Resampled at 4 Hz, a 10 s hole in a 10 Hz record is NaN there and counted as a gap; the
    rest interpolates; a window keeps the original times."""
    t = np.r_[np.arange(0, 20, 0.1), np.arange(30, 50, 0.1)]
    motion = np.full((t.size, 6), np.nan)
    motion[:, 2] = np.sin(t)
    series = MotionSeries(t, motion, ("heave",))
    uniform = series.resampled(4.0)
    hole = (uniform.time > 19.9 + 1e-9) & (uniform.time < 30.0 - 1e-9)  # the gap's samples
    assert np.isnan(uniform.motion[hole, 2]).all() and uniform.issues == {"gap": 1}
    np.testing.assert_allclose(uniform.motion[~hole, 2], np.sin(uniform.time[~hole]), atol=2e-3)
    assert series.window(30.0, 31.0).time[0] == pytest.approx(30.0)
    with pytest.raises(TwinError, match="increase strictly"):
        MotionSeries(np.array([0.0, 0.0]), np.zeros((2, 6)), ())


@pytest.mark.parametrize("fmt", ["psxn", "pashr", "tss1"])
def test_a_log_replayed_over_loopback_udp_arrives_whole(fmt: str) -> None:
    """`send` of 200 samples at 50 Hz (× 20 speed) to a loopback socket: every line arrives and
    the stream parser reads back the log's heave and roll to the format's resolution."""
    t = np.arange(200) / 50.0
    motion = np.full((200, 6), np.nan)
    motion[:, 2], motion[:, 3], motion[:, 4] = 0.3 * np.sin(t), 0.02 * np.sin(2 * t), 0.01
    series = MotionSeries(t, motion, ("heave", "roll", "pitch"),
                          heading=np.full(200, 45.0))  # fmt: skip
    expected = len(list(sentences(series, fmt)))
    receiver = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    receiver.bind(("127.0.0.1", 0))
    receiver.settimeout(10.0)
    stream, got = MotionStream("loopback"), []

    def receive() -> None:
        for _ in range(expected):
            data, _ = receiver.recvfrom(4096)
            got.extend(stream.feed(data, float(len(got))))

    thread = threading.Thread(target=receive)
    thread.start()
    sent = send(series, "127.0.0.1", receiver.getsockname()[1], fmt, 50.0, speed=20.0)
    thread.join(20.0)
    receiver.close()
    assert sent == expected and len(got) == 200 and stream.issues == {}
    heave = np.array([m[0] for _, m in got])
    roll = np.array([m[1] for _, m in got])
    np.testing.assert_allclose(heave, 0.3 * np.sin(t), atol=0.006)
    np.testing.assert_allclose(roll, 0.02 * np.sin(2 * t), atol=math.radians(0.006))


def test_send_refuses_a_speed_or_port_out_of_range() -> None:
    """Speeds outside 0.1-100 and ports outside 1-65535 are refused before anything is sent."""
    series = MotionSeries(np.arange(3.0), np.zeros((3, 6)), ("heave",))
    with pytest.raises(TwinError, match="speed"):
        send(series, "127.0.0.1", 9, speed=0.0)
    with pytest.raises(TwinError, match="port"):
        send(series, "127.0.0.1", 70000)


def test_a_parquet_log_is_read_by_its_content_not_its_name(tmp_path: Path) -> None:
    """A Parquet table saved as `.pq` (or without a suffix) reads as the same log as `.parquet`."""
    table().to_parquet(tmp_path / "log.parquet")
    table().to_parquet(tmp_path / "log.pq")
    want = read_motion(tmp_path / "log.parquet")
    got = read_motion(tmp_path / "log.pq")
    np.testing.assert_array_equal(got.motion, want.motion)
    assert got.channels == want.channels == ("heave", "roll", "pitch")
