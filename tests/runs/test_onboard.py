"""The onboard report (`twin.runs.onboard`) on a synthetic motion log: per window the estimated
sea, each planner's probability at the current heading from the workability cells (the same
cells the per-heading advice reads), the advice ranked with the turn to each heading, alerts
under the threshold, a calm window refused with its reason, and its files."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from pydantic import ValidationError

from twin.errors import TwinError
from twin.runs.onboard import (
    OnboardReport,
    OnboardSpec,
    centre_motion,
    onboard_report,
    turn_to,
)
from twin.sea.synthesis import wave_components
from twin.spatial import rpy_to_matrix
from twin.vessel import load_raos, vessel_motion

GRID = [0.0, 90.0, 180.0, 270.0]
#: the cheapest cells that still run the engine: one seed, 10 s runs, two Hs, one Tp
CELLS = {"seeds": 1, "duration": 10.0, "hs_grid": [1.0, 2.0], "tp_grid": [8.0],
         "heading_grid": GRID}  # fmt: skip


def log(beta: float = 150.0, calm_first: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Three 10-min windows at 2 Hz of the SOV's motion in Hs 1.5 m, Tp 8 s at β [deg];
    the first window nearly still (Hs 2 cm) if `calm_first`."""
    t = np.arange(0.0, 1800.0, 0.5)
    sea = wave_components(1.5, 8.0, heading=np.radians(beta), seed=3, n_components=300)
    motion = vessel_motion(sea, load_raos("sov"), t)
    if calm_first:
        motion[t < 600.0] *= 0.01
    return t, motion


@pytest.fixture(scope="module")
def report(tmp_path_factory: pytest.TempPathFactory) -> OnboardReport:
    spec = OnboardSpec(window=600.0, threshold=0.9, workability=CELLS)
    cells = tmp_path_factory.mktemp("cells")
    start = np.datetime64("2026-08-01T14:00")
    return onboard_report(*log(), spec, start=start, data_dir=cells, scheduler="in-process")


def test_windows_estimate_the_sea(report: OnboardReport) -> None:
    """Each estimated window carries the sea that made the motion (Hs within 15 %, direction
    within 20°) and its start time in UTC."""
    done = report.windows[report.windows["refused"] == ""]
    assert len(done) == 2
    assert np.allclose(done["hs"], 1.5, rtol=0.15)
    assert np.all(np.abs(done["direction"] - 150.0) < 20.0)
    assert str(done["time"].iloc[0]) == "2026-08-01 14:10:00"


def test_calm_window_refused_with_its_reason(report: OnboardReport) -> None:
    """The still first window is refused as too calm: no probability, no alert, a note."""
    first = report.windows.iloc[0]
    assert "too calm" in first["refused"]
    assert np.isnan(first["probability"]) and not first["alert"]
    assert report.estimates[0] is None
    assert any("too calm" in note for note in report.notes)


def test_current_heading_reads_the_grid_cells(report: OnboardReport) -> None:
    """The probability at the current heading is the advice's probability at the cell heading
    nearest it (both from the one cell cache), and the cell is the nearest grid heading."""
    for row in report.windows[report.windows["refused"] == ""].itertuples():
        advice = report.advice[(report.advice["start"] == row.start)]
        at_cell = advice.loc[advice["heading"] == row.cell_heading, "probability"]
        assert at_cell.iloc[0] == pytest.approx(row.probability)
        gaps = np.abs(turn_to(row.direction, np.array(GRID)))
        assert row.cell_heading == GRID[int(np.argmin(gaps))]


def test_advice_ranked(report: OnboardReport) -> None:
    """Per window the grid's headings are ranked by probability (ties by the smaller turn),
    rank 1 is the window's best heading, and each turn takes the current β to that heading."""
    for row in report.windows[report.windows["refused"] == ""].itertuples():
        advice = report.advice[report.advice["start"] == row.start].sort_values("rank")
        assert sorted(advice["heading"]) == GRID
        p, turn = advice["probability"].to_numpy(), np.abs(advice["turn"].to_numpy())
        assert np.all((np.diff(p) < 0) | ((np.diff(p) == 0) & (np.diff(turn) >= 0)))
        assert advice["heading"].iloc[0] == row.best_heading
        reached = np.mod(row.direction - advice["turn"].to_numpy(), 360.0)
        assert np.allclose(np.mod(reached - advice["heading"].to_numpy() + 180, 360) - 180, 0)


def test_alerts_under_the_threshold(report: OnboardReport) -> None:
    """A window alerts exactly when its probability is under the threshold; `alerts` lists
    those windows with the best heading and turn."""
    done = report.windows[report.windows["refused"] == ""]
    assert (done["alert"] == (done["probability"] < 0.9)).all()
    assert len(report.alerts()) == int(done["alert"].sum())


def test_files(report: OnboardReport, tmp_path: Path) -> None:
    """`write` gives the windows and advice CSVs, a JSON with no NaN (null instead), and a PNG."""
    paths = report.write(tmp_path)
    assert [p.name for p in paths] == ["onboard.csv", "advice.csv", "onboard.json",
                                       "timeline.png"]  # fmt: skip
    data = json.loads((tmp_path / "onboard.json").read_text())
    assert data["windows"][0]["probability"] is None
    assert data["windows"][1]["time"] == "2026-08-01T14:10:00Z"
    assert (tmp_path / "timeline.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_turn_signs() -> None:
    """From head seas (180°) to waves on the port bow... the bow turns by β − β': to reach
    β' = 150° it turns 30° to port (+), to reach 210° 30° to starboard (−); wrapped to ±180°."""
    assert turn_to(180.0, 150.0) == pytest.approx(30.0)
    assert turn_to(180.0, 210.0) == pytest.approx(-30.0)
    assert turn_to(10.0, 350.0) == pytest.approx(20.0)


def test_spec_refuses() -> None:
    """A window under 10 min or over an hour, and a strategy grid over 36 headings, are
    refused naming the field."""
    with pytest.raises(ValidationError, match="window"):
        OnboardSpec(window=300.0)
    with pytest.raises((TwinError, ValidationError), match="heading_grid"):
        OnboardSpec(workability={"heading_grid": [float(h) for h in range(0, 360, 5)]})


def test_short_log_refused() -> None:
    """A log shorter than one 10-min window has nothing to estimate: a TwinError."""
    t, motion = log(calm_first=False)
    with pytest.raises(TwinError):
        onboard_report(t[:600], motion[:600], OnboardSpec(workability=CELLS))


def test_centre_motion_keeps_absent_channels_absent() -> None:
    """A sensor 10 m up sees roll as sway; moved to the centre of motion its sway is the
    centre's again, and a channel the sensor does not give stays NaN (not a measured zero)."""
    _, motion = log(calm_first=False)
    position = np.array([0.0, 0.0, 10.0])
    sensor = motion.copy()
    sensor[:, :3] += (rpy_to_matrix(motion[:, 3:]) @ position) - position
    sensor[:, 0] = np.nan  # no surge
    centre = centre_motion(sensor, position)
    assert np.isnan(centre[:, 0]).all()
    assert np.allclose(centre[:, 1:], motion[:, 1:], atol=1e-9)


def test_cli_writes_the_report(tmp_path: Path) -> None:
    """`twin onboard LOG --out DIR` reads a CSV log (angles in degrees by their suffix) and
    writes the four files; the report's sea is the log's."""
    from twin.cli import main

    t, motion = log(calm_first=False)
    table = pd.DataFrame({"time": t, "heave": motion[:, 2],
                          "roll_deg": np.degrees(motion[:, 3]),
                          "pitch_deg": np.degrees(motion[:, 4])})  # fmt: skip
    table.to_csv(tmp_path / "log.csv", index=False)
    (tmp_path / "spec.json").write_text(json.dumps(CELLS))
    code = main(["onboard", str(tmp_path / "log.csv"), "--out", str(tmp_path / "out"),
                 "--window", "600", "--rate", "2", "--spec", str(tmp_path / "spec.json"),
                 "--headings", "0,90,180,270", "--data-dir", str(tmp_path / "cells"),
                 "--scheduler", "in-process"])  # fmt: skip
    assert code == 0
    windows = pd.read_csv(tmp_path / "out" / "onboard.csv")
    assert len(windows) == 3
    assert np.allclose(windows["hs"], 1.5, rtol=0.15)
    assert (tmp_path / "out" / "timeline.png").exists()
