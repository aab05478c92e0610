"""Motion logs (issue 40): a vessel's measured motion stored once, then named by runs
(`Scenario.base_motion = {"source": "log", "log": ID}`: every planner on the same measured
hour) and by the live session's replay.

    POST /api/motion-logs        store a log's samples; answers its ID (201)
    GET  /api/motion-logs        the stored logs
    POST /api/motion-logs/file   store a log file (CSV, Parquet or NMEA/TSS1 text as the body)
    GET  /api/motion-logs/{id}   one log's channels, length and what its reader skipped

The body is the samples a reader gave (`twin.motion.logs.read_motion`, `twin motion-replay`'s
input): `time` [s] and one list per motion present (`surge`, `sway`, `heave` [m], `roll`,
`pitch`, `yaw` in `angles`), at most `MAX_SAMPLES` samples, each finite, within the server's
body cap; the sensor's position on the hull; the log's name and UTC start if known. A file's
bytes (`/file`) are priced (`twin.web.upload_records.prescan`) and read by the readers
(`twin.motion.logs.read_motion`) in a bounded child (`twin.sim.measured.read_upload`), never
in the server's process. A log is stored under the hash of its content
(`twin.sim.measured.store_log`): the same log twice is one file.
"""

from __future__ import annotations

import threading
from dataclasses import replace
from datetime import datetime
from typing import Annotated, Any, Literal

import numpy as np
from fastapi import APIRouter, HTTPException, Query, Request, Response
from fastapi.concurrency import run_in_threadpool
from pydantic import BaseModel, ConfigDict, Field, model_validator

from twin.errors import TwinError
from twin.sim.measured import (
    CHANNELS,
    LOG_ID,
    MotionSeries,
    describe_log,
    log_dir,
    store_log,
    store_samples,
)
from twin.web.deps import GUARDED
from twin.web.upload_records import prescan
from twin.web.upload_worker import BoundedWorker, Budget, WorkerBusy

router = APIRouter(prefix="/api/motion-logs", tags=["motion logs"])

#: most samples one log may have (an hour at 50 Hz; 24 h at 2 Hz)
MAX_SAMPLES = 200_000
#: most logs listed
MAX_LISTED = 200
Motion = Literal["surge", "sway", "heave", "roll", "pitch", "yaw"]
#: what reading one uploaded file may take (a child's CPU and the request's wall clock, the
#: child's start of 1-2 s included): an 8 MB CSV reads in about a second
FILE_BUDGET = Budget(cpu=20.0, wall=60.0)
#: the children reading uploaded files, started at the first upload (`_reader`)
_readers: list[BoundedWorker] = []
_readers_lock = threading.Lock()
#: an uploaded file's name: letters, digits and `_ .,()+-`
NAME = r"^[\w .,()+-]*$"


class MotionLogBody(BaseModel):
    """A motion log's samples, as uploaded (module doc)."""

    model_config = ConfigDict(allow_inf_nan=False)

    time: list[float] = Field(..., min_length=2, max_length=MAX_SAMPLES,
                              description="[s] sample times, strictly increasing")  # fmt: skip
    motion: dict[Motion, list[float]] = Field(
        ..., description="one list per motion present, each as long as `time`: surge, sway, "
        "heave [m], roll, pitch, yaw [`angles`], in the twin's convention (x bow, y port, z up)",
    )  # fmt: skip
    angles: Literal["rad", "deg"] = Field("rad", description="unit of roll, pitch and yaw")
    start: datetime | None = Field(None, description="UTC time of t = 0, if known")

    @model_validator(mode="after")
    def _lengths(self) -> MotionLogBody:
        if not self.motion:
            raise TwinError(f"motion: empty; one list per motion of {list(CHANNELS)}")
        for name, values in self.motion.items():
            if len(values) != len(self.time):
                raise TwinError(f"motion.{name}: {len(values)} samples for {len(self.time)} "
                                "times; each motion as long as time")  # fmt: skip
        return self

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """(t (N,) [s], motion (N, 6) [m, rad], NaN for a motion absent)."""
        t = np.asarray(self.time, dtype=float)
        motion = np.full((t.size, 6), np.nan)
        for name, values in self.motion.items():
            column = np.asarray(values, dtype=float)
            angle = CHANNELS.index(name) >= 3
            motion[:, CHANNELS.index(name)] = np.radians(column) if angle and self.angles == "deg" \
                else column  # fmt: skip
        return t, motion

    def start_time(self) -> np.datetime64 | None:
        """`start` as a naive UTC datetime64[ns], or None."""
        if self.start is None:
            return None
        return np.datetime64(self.start.replace(tzinfo=None), "ns")


class MotionLogUpload(MotionLogBody):
    """A log to store: its samples, the sensor's position and a name."""

    sensor_position: tuple[float, float, float] = Field(
        (0.0, 0.0, 0.0), description="[m] the sensor in the vessel frame from the centre of "
        "motion (x bow, y port, z up), where surge, sway and heave were measured",
    )  # fmt: skip
    name: str = Field("upload", max_length=120, pattern=NAME,
                      description="the log's name, e.g. its file's")  # fmt: skip


@router.post("", status_code=201, dependencies=GUARDED,
             responses={422: {"description": "a malformed log, said what is allowed"}})
def create_motion_log(body: MotionLogUpload, response: Response) -> dict[str, Any]:
    """Store a log; answers its ID (the `log` of `Scenario.base_motion`) and summary."""
    t, motion = body.arrays()
    try:
        key = store_samples(t, motion, body.start_time(), body.name, body.sensor_position)
    except TwinError as exc:
        raise HTTPException(422, str(exc)) from None
    response.headers["Location"] = f"/api/motion-logs/{key}"
    return describe_log(key)


def _reader() -> BoundedWorker:
    """The one child that reads uploaded files, started at the first upload; it ends with the
    server (its pipe closes)."""
    with _readers_lock:
        if not _readers:
            _readers.append(BoundedWorker("twin.sim.measured", size=1))
        return _readers[0]


@router.post("/file", status_code=201, dependencies=GUARDED,
             responses={422: {"description": "a file the readers refuse, said why"},
                         503: {"description": "the reader is busy: retry"}})  # fmt: skip
async def upload_motion_log(
    request: Request,
    response: Response,
    name: Annotated[str, Query(max_length=120, pattern=NAME)] = "upload.csv",
    x: Annotated[float, Query(ge=-500.0, le=500.0)] = 0.0,
    y: Annotated[float, Query(ge=-500.0, le=500.0)] = 0.0,
    z: Annotated[float, Query(ge=-500.0, le=500.0)] = 0.0,
) -> dict[str, Any]:
    """Store a log file sent as the body (CSV or Parquet table, NMEA/TSS1 text; the format is
    sniffed, `name`'s ending is a hint), in the sensor's convention of the default sensor file
    (docs/motion.md), the sensor at (x, y, z) [m] in the vessel frame; answers its ID and
    summary, as the samples' POST does."""
    data = await request.body()
    try:
        if not data.startswith(b"PAR1"):  # text is priced before a parser sees it
            prescan(data.decode("utf-8", errors="replace"), "body")
        series: MotionSeries = await run_in_threadpool(
            _reader().call, "read_upload", data, name, budget=FILE_BUDGET)
        if len(series) > MAX_SAMPLES:
            raise TwinError(f"body: {len(series)} samples; allowed at most {MAX_SAMPLES}")
        key = store_log(replace(series, source=name), (x, y, z))
    except WorkerBusy as exc:
        raise HTTPException(503, str(exc), headers={"Retry-After": "2"}) from None
    except TwinError as exc:
        raise HTTPException(422, str(exc)) from None
    response.headers["Location"] = f"/api/motion-logs/{key}"
    return describe_log(key)


@router.get("")
def list_motion_logs() -> list[dict[str, Any]]:
    """The stored logs, newest first (at most `MAX_LISTED`)."""
    folder = log_dir()
    files = sorted(folder.glob("*.npz"), key=lambda p: p.stat().st_mtime, reverse=True) \
        if folder.is_dir() else []  # fmt: skip
    out = []
    for path in files[:MAX_LISTED]:
        if LOG_ID.match(path.stem):
            out.append(describe_log(path.stem))
    return out


@router.get("/{log_id}", responses={404: {"description": "no such log"}})
def get_motion_log(log_id: str) -> dict[str, Any]:
    """One stored log's summary."""
    try:
        return describe_log(log_id)
    except TwinError as exc:
        raise HTTPException(404, str(exc)) from None
