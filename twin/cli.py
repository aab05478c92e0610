"""The `twin` command: `twin serve` runs the live twin, `twin run` one scenario to a file,
`twin sweep` an operability sweep to a folder, `twin workability` a site record's workability to a
folder, `twin warm` compiles the kernels ahead."""

from __future__ import annotations

import argparse
import ipaddress
import json
import math
import os
import re
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # imported where used: `twin --help` stays fast
    from twin.sim.motion_live import LiveMotion

#: mechanisms a command may name (twin.mechanisms.MECHANISMS)
MECHANISM_NAMES = ("hybrid", "upu3up", "upr4")
#: formats `twin run --out` writes, by file suffix
OUTPUTS = (".csv", ".parquet", ".json")
#: [bytes] largest scenario or sweep file read (a scenario is < 2 KiB)
MAX_INPUT_FILE = 1024 * 1024
_LABEL = r"[A-Za-z0-9]([A-Za-z0-9-]{0,61}[A-Za-z0-9])?"
_HOSTNAME = re.compile(rf"^(?=.{{1,253}}$){_LABEL}(\.{_LABEL})*$")


def port(text: str) -> int:
    """A TCP port number, 1-65535 (argparse type)."""
    value = int(text)
    if not 1 <= value <= 65535:
        raise argparse.ArgumentTypeError(f"{value}: a port is 1-65535")
    return value


def host(text: str) -> str:
    """An IP address or host name to bind (argparse type)."""
    try:
        ipaddress.ip_address(text)
    except ValueError:
        if not _HOSTNAME.match(text):
            raise argparse.ArgumentTypeError(
                f"{text!r}: not an IP address or host name (e.g. 127.0.0.1, 0.0.0.0, ::1)"
            ) from None
    return text


def workers(text: str) -> int:
    """A worker count, 1-256 (argparse type)."""
    value = int(text)
    if not 1 <= value <= 256:
        raise argparse.ArgumentTypeError(f"{value}: workers are 1-256")
    return value


def niceness(text: str) -> int:
    """A process niceness, 0-19 (argparse type)."""
    value = int(text)
    if not 0 <= value <= 19:
        raise argparse.ArgumentTypeError(f"{value}: niceness is 0-19")
    return value


def seconds(text: str) -> float:
    """A positive, finite number of seconds, at most an hour (argparse type)."""
    value = float(text)
    if not 0.0 < value <= 3600.0:
        raise argparse.ArgumentTypeError(f"{text}: seconds are > 0 and ≤ 3600")
    return value


#: `--max-store` suffixes
_UNITS = {"": 1, "K": 2**10, "M": 2**20, "G": 2**30, "T": 2**40}


def size(text: str) -> int:
    """A size in bytes, e.g. 2G, 500M, 1048576 (binary units; a trailing B is allowed)."""
    raw = text.strip().upper().removesuffix("B").removesuffix("I")
    unit = raw[-1:] if raw[-1:] in _UNITS and raw[-1:] else ""
    number = raw[: len(raw) - len(unit)]
    try:
        value = float(number) * _UNITS[unit]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r}: not a size; allowed e.g. 2G, 500M, 1048576"
        ) from None
    if not math.isfinite(value) or value < 1 or value >= 2**63:
        raise argparse.ArgumentTypeError(f"{text!r}: allowed 1 byte … 8 EiB")
    return int(value)


def workers_or_more(text: str) -> int:
    """A count ≥ 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: not a whole number") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r}: allowed ≥ 1")
    return value


def origin(text: str) -> str:
    """A browser origin, scheme://host[:port] (argparse type)."""
    from twin.web.access import normalise_origin

    try:
        normalise_origin(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text


def read_input(parser: argparse.ArgumentParser, path: Path) -> bytes:
    """A scenario or sweep file's bytes; a missing, unreadable or oversized file is a usage
    error naming it."""
    try:
        size = path.stat().st_size
        if size > MAX_INPUT_FILE:
            parser.error(f"{path}: {size} bytes; a scenario file is at most {MAX_INPUT_FILE}")
        return path.read_bytes()
    except OSError as exc:
        parser.error(f"{path}: cannot read: {exc.strerror}")


def build_parser() -> argparse.ArgumentParser:
    """The `twin` parser: one sub-command per `_add_*` below, in the order `twin --help`
    lists them."""
    parser = argparse.ArgumentParser(
        prog="twin",
        description="Digital twin of offshore wave-motion compensation (hybrid boarding "
        "gangway, 3UPU_UP and 4-UPR platforms).",
    )
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    _add_serve(commands)
    _add_run(commands)
    _add_sweep(commands)
    _add_workability(commands)
    _add_onboard(commands)
    _add_motion_log(commands)
    _add_motion_replay(commands)
    _add_warm(commands)
    return parser


def _add_serve(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """`twin serve` and its options, in the order its --help lists them."""
    serve = commands.add_parser(
        "serve",
        help="run the live twin: 3D viewer, REST API and landing page",
        description="Run the live twin until Ctrl-C or SIGTERM. POST and PATCH require the "
        "bearer token in the TWIN_TOKEN environment variable when it is set (at least 16 "
        "characters); a --host other than loopback requires it. Runs and sweeps execute on one "
        "Dask executor started with the server.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    _add_serve_places(serve)
    _add_serve_clients(serve)
    _add_serve_store(serve)
    serve.set_defaults(handler=_serve)


def _add_serve_places(serve: argparse.ArgumentParser) -> None:
    """`twin serve`: where it listens, keeps its runs and executes them (--host … --workers)."""
    serve.add_argument(
        "--host", type=host, default="127.0.0.1", help="interface to bind (0.0.0.0: all)"
    )
    serve.add_argument("--port", type=port, default=8000, help="REST API and landing page")
    serve.add_argument("--viser-port", type=port, default=8080, help="3D viewer")
    serve.add_argument(
        "--data-dir", type=Path, default=Path("data"),
        help="run store folder; one server at a time (a second one exits 2)",
    )  # fmt: skip
    serve.add_argument("--no-viewer", action="store_true", help="serve REST only, no 3D viewer")
    serve.add_argument(
        "--scheduler",
        help="a Dask scheduler tcp://HOST:PORT for runs and sweeps (its workers need twin "
        "installed), or 'in-process'; default: a local cluster, one worker per core, started "
        "once",
    )
    serve.add_argument(
        "--workers", type=workers, help="workers of the local cluster (default: the cores)"
    )
    serve.add_argument(
        "--worker-nice", type=niceness, default=0, metavar="N",
        help="niceness 0-19 of the local cluster's workers once warm: batch work yields the "
        "CPU to the REST server (default 0; 10 on a machine of its own)",
    )  # fmt: skip


def _add_serve_clients(serve: argparse.ArgumentParser) -> None:
    """`twin serve`: whom it answers and how it treats their browsers and runs (--allow-host
    … --private)."""
    serve.add_argument(
        "--allow-host", action="append", default=[], metavar="NAME", type=host,
        help="another Host name the server answers to, REST and 3D viewer (repeatable); "
        "loopback names and the --host address always are",
    )  # fmt: skip
    serve.add_argument(
        "--allow-origin", action="append", default=[], metavar="ORIGIN", type=origin,
        help="another browser origin scheme://host:port trusted as the server's own (e.g. a TLS "
        "proxy's https://twin.example.com; repeatable); http on an allowed host at --port or "
        "--viser-port always is",
    )  # fmt: skip
    serve.add_argument(
        "--graphics", default="full",
        help="what the 3D viewer's browsers render at first: full, or light (no environment map "
        "and no shadows: for a browser without a GPU, on a remote desktop or a virtual "
        "machine); a browser whose WebGL renderer is software is switched to light on its own, "
        "and each browser switches its own under View -> Graphics",
    )  # fmt: skip
    serve.add_argument(
        "--run-budget", type=seconds, metavar="SECONDS",
        help="wall-clock budget of one run; over it the run fails with a message (default: "
        "twin.runs.executor.RUN_BUDGET, 60 s)",
    )  # fmt: skip
    serve.add_argument(
        "--forwarded-allow-ips", action="append", default=[], metavar="ADDRESS",
        help="a proxy whose X-Forwarded-For names the client (repeatable; '*' trusts any); "
        "default none: the client is the socket's peer address, which the limits apply to",
    )  # fmt: skip
    serve.add_argument(
        "--motion-udp", type=int, metavar="PORT",
        help="listen for a motion sensor's NMEA/TSS1 sentences on this UDP port (loopback "
        "senders only unless --motion-udp-allow); `twin motion-replay LOG --udp` sends them",
    )  # fmt: skip
    serve.add_argument(
        "--motion-udp-allow", action="append", default=[], metavar="ADDRESS",
        help="another sender address whose datagrams --motion-udp reads (repeatable; binds all "
        "interfaces); datagrams from any other address are counted and dropped",
    )  # fmt: skip
    serve.add_argument(
        "--motion-sensor", type=Path, default=None, metavar="FILE",
        help="the --motion-udp sensor's file (YAML/JSON, docs/motion.md): its position on the "
        "hull, from which the motion is moved to the mount; default: the centre of motion",
    )  # fmt: skip
    serve.add_argument(
        "--private", action="store_true",
        help="with TWIN_TOKEN, reading stored runs and sweeps (GET /api/runs…, /api/sweeps…) "
        "needs the token too; default: anyone who can reach the server may read them",
    )  # fmt: skip


def _add_serve_store(serve: argparse.ArgumentParser) -> None:
    """`twin serve`: the run store's limits and the Dask dashboard (--max-store … --dashboard)."""
    serve.add_argument(
        "--max-store", type=size, metavar="SIZE",
        help="most the run store may hold, e.g. 2G or 500M (runs' series, sweeps' tables and "
        "heatmaps); a submission that would pass it answers 507; default: no limit",
    )  # fmt: skip
    serve.add_argument(
        "--max-runs", type=workers_or_more, metavar="N",
        help="most runs the store may hold (507 beyond); default: no limit",
    )  # fmt: skip
    serve.add_argument(
        "--retain", action="store_true",
        help="when the store is full, delete its oldest finished results that are not pinned "
        "(POST /api/runs/{id}/pin) instead of refusing",
    )  # fmt: skip
    serve.add_argument(
        "--dashboard", action="store_true",
        help="serve the Dask scheduler's dashboard on 127.0.0.1 (a free port, printed); "
        "default off",
    )  # fmt: skip


def _add_run(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """`twin run`: one scenario to the end."""
    run = commands.add_parser(
        "run",
        help="run one scenario to the end and print its metrics",
        description="Run one scenario to the end with a progress bar, print its metrics as "
        "JSON and optionally write its series.",
    )
    run.add_argument(
        "scenario",
        metavar="SCENARIO",
        help="a JSON file of Scenario fields, or a preset name from twin.sim.PAPER_PRESETS",
    )
    run.add_argument(
        "--out", type=Path, help=f"write the series here; format by suffix: {', '.join(OUTPUTS)}"
    )
    run.set_defaults(handler=_run)


def _add_sweep(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """`twin sweep`: an operability sweep to a folder."""
    sweep = commands.add_parser(
        "sweep",
        help="run an operability sweep and write its table and heatmap",
        description="Run a grid of Hs × Tp × heading × planner × (β, k_e, k_c) with several "
        "seeds per cell on the executor `twin serve` uses (a local Dask cluster unless "
        "--scheduler is given), with a progress bar; print the operability table and write "
        "operability.csv, operability.json and heatmap.png.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    sweep.add_argument(
        "spec", metavar="SPEC", type=Path, help="a JSON file of SweepSpec fields (twin.runs.sweep)"
    )
    sweep.add_argument(
        "--scheduler",
        help="a Dask scheduler address tcp://HOST:PORT, or 'in-process' (one worker thread "
        "in this process); default: a local cluster, one worker per core",
    )
    sweep.add_argument("--workers", type=workers, help="workers of the local cluster")
    sweep.add_argument("--out", type=Path, default=Path("sweep"), help="folder of the outputs")
    sweep.set_defaults(handler=_sweep)


def _add_workability(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """`twin workability`: a site record's workability to a folder."""
    workability = commands.add_parser(
        "workability",
        help="a site record's workability per planner: CSV, JSON and PNG plots",
        description="Evaluate a site's wave record (NDBC standard meteorological file, CSV or "
        "Parquet time series, Hs × Tp scatter table, or forecast) for each planner: the share "
        "of time it is operable, per month, beside the Hs-threshold estimate, with limiting "
        "constraints and weather windows (twin.runs.workability). Runs go through the executor "
        "`twin serve` uses, with a progress bar; operability cells are cached in --data-dir.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    workability.add_argument("record", metavar="RECORD", type=Path, help="the record file")
    workability.add_argument(
        "--kind", choices=("ndbc", "timeseries", "scatter", "forecast"),
        help="the record's format (default: sniffed)",
    )  # fmt: skip
    workability.add_argument(
        "--planner", nargs="+", metavar="NAME", help="planners (default: the mechanism's)"
    )
    workability.add_argument("--mechanism", default="hybrid", choices=MECHANISM_NAMES)
    workability.add_argument("--seeds", type=int, default=3, help="sea seeds per cell or row")
    workability.add_argument("--method", default="cells", choices=("cells", "direct"))
    workability.add_argument(
        "--heading-strategy", metavar="STRATEGY",
        help="fixed:DEG (relative heading, Scenario.heading: 180 head seas), best:DEG,DEG,… "
        "(the best of a set) or record (the record's vessel heading column); default fixed:150",
    )  # fmt: skip
    workability.add_argument(
        "--vessel-heading", type=float, metavar="DEG",
        help="compass heading the bow points to [deg true], held on every row of a record with "
        "wave directions (the record strategy without a heading column)",
    )  # fmt: skip
    workability.add_argument(
        "--duplicates", choices=("error", "mean", "first"),
        help="rows sharing a time: refused naming their lines (default), averaged, or the "
        "first in the file kept",
    )  # fmt: skip
    workability.add_argument(
        "--spec", type=Path,
        help="a JSON file of WorkabilitySpec fields; the options above override it",
    )  # fmt: skip
    workability.add_argument(
        "--scheduler",
        help="a Dask scheduler address tcp://HOST:PORT, or 'in-process'; default: a local "
        "cluster, one worker per core (started only if a cell is not cached)",
    )
    workability.add_argument("--workers", type=workers, help="workers of the local cluster")
    workability.add_argument(
        "--data-dir", type=Path, default=Path("data"), help="folder of the cell cache"
    )
    workability.add_argument(
        "--out", type=Path, default=Path("workability"), help="folder of the outputs"
    )
    workability.set_defaults(handler=_workability)


def _add_onboard(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """`twin onboard`: a motion log's sea, operability now and heading advice (issue 40)."""
    onboard = commands.add_parser(
        "onboard",
        help="estimate the sea from a vessel motion log and report operability and heading "
        "advice per window",
        description="Per window of a motion log (twin.motion.logs.read_motion): the sea "
        "estimated from the vessel's motion (wave buoy analogy, zero forward speed), each "
        "planner's probability of being operable at the current relative heading (the "
        "workability cells, cached in --data-dir), the strategy grid's headings ranked, and "
        "alerts under --threshold. Writes onboard.csv, advice.csv, onboard.json, timeline.png.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    onboard.add_argument("log", metavar="LOG", type=Path, help="the motion log file")
    onboard.add_argument("--window", type=float, default=1200.0, help="[s] window, 600-3600")
    onboard.add_argument("--rate", type=float, default=10.0, help="[Hz] resampling rate")
    onboard.add_argument(
        "--sensor", type=Path,
        help="the sensor file (YAML/JSON: position, signs, angle_unit); default: at the centre of "
        "motion, in the twin's convention",
    )  # fmt: skip
    onboard.add_argument("--threshold", type=float, default=0.5, help="[-] alert level")
    onboard.add_argument("--headings", metavar="DEG,DEG,…", help="the strategy grid [deg, "
                         "Scenario.heading]; default every 30°")  # fmt: skip
    onboard.add_argument("--planner", nargs="+", metavar="NAME", help="planners")
    onboard.add_argument("--mechanism", default="hybrid", choices=MECHANISM_NAMES)
    onboard.add_argument("--spec", type=Path, help="a JSON file of WorkabilitySpec fields")
    onboard.add_argument("--scheduler", help="as twin workability --scheduler")
    onboard.add_argument("--workers", type=workers, help="workers of the local cluster")
    onboard.add_argument("--data-dir", type=Path, default=Path("data"),
                         help="folder of the cell cache")  # fmt: skip
    onboard.add_argument("--out", type=Path, default=Path("onboard"), help="output folder")
    onboard.set_defaults(handler=_onboard)


def _onboard(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    from pydantic import ValidationError

    from twin.errors import TwinError
    from twin.motion.logs import read_motion
    from twin.motion.sensor import Sensor
    from twin.runs.onboard import DEFAULT_HEADINGS, OnboardSpec, centre_motion, onboard_report
    from twin.validation import explain

    try:
        fields = json.loads(read_input(parser, args.spec)) if args.spec is not None else {}
        fields |= {"mechanism": args.mechanism, "heading_grid": DEFAULT_HEADINGS}
        if args.headings:
            fields["heading_grid"] = [float(v) for v in args.headings.split(",") if v.strip()]
        if args.planner:
            fields["planners"] = args.planner
        spec = OnboardSpec(window=args.window, threshold=args.threshold, workability=fields)
        sensor = Sensor.load(args.sensor) if args.sensor is not None else Sensor()
        series = read_motion(args.log, sensor, rate_hz=args.rate)
        report = onboard_report(
            series.time, centre_motion(series.motion, sensor.position), spec, start=series.start,
            data_dir=args.data_dir, scheduler=args.scheduler, n_workers=args.workers,
        )  # fmt: skip
    except ValidationError as exc:
        parser.error(explain(exc))
    except (TwinError, ValueError) as exc:  # TwinError is a ValueError; so is a bad number
        parser.error(str(exc))
    for note in report.notes:
        print(f"twin: note: {note}", file=sys.stderr)
    written = report.write(args.out)
    for alert in report.alerts():
        print(f"ALERT {alert['start'] / 60:6.1f} min {alert['planner']}: P(operable) "
              f"{alert['probability']:.2f}; best heading {alert['best_heading']:g}° "
              f"(turn {alert['turn']:+.0f}°, + to port)")  # fmt: skip
    print(f"twin: {len(report.estimates)} windows, {report.runs} runs ({report.new_runs} new); "
          f"wrote {', '.join(p.name for p in written)} to {args.out}", file=sys.stderr)  # fmt: skip
    return 0


def _add_motion_log(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """`twin motion-log`: store a motion log; with --compare, every planner on a window of it."""
    log = commands.add_parser(
        "motion-log",
        help="store a vessel motion log for runs (and compare every planner on a window of it)",
        description="Read a motion log (CSV, Parquet or NMEA/TSS1 text; twin.motion.logs) with "
        "its sensor file, store it in --data-dir/motion_logs and print its ID, the `log` of "
        'a scenario\'s "base_motion": {"source": "log", "log": ID}. With --compare, run every '
        "planner of --mechanism on the log from --from to --to seconds and print each one's "
        "tip error, limit violations and first limit: would it have held?",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    log.add_argument("log", metavar="LOG", type=Path, help="the motion log file")
    log.add_argument("--sensor", type=Path, help="its sensor file (YAML/JSON; default: at the "
                     "centre of motion, the twin's signs)")  # fmt: skip
    log.add_argument("--data-dir", type=Path, default=Path("data"), help="the store's folder")
    log.add_argument("--compare", action="store_true", help="run every planner on the window")
    log.add_argument("--from", dest="start", type=float, default=0.0, help="[s] window start")
    log.add_argument("--to", dest="end", type=float, help="[s] window end (default: the log's)")
    log.add_argument("--mechanism", default="hybrid", choices=MECHANISM_NAMES)
    log.set_defaults(handler=_motion_log)


def _motion_log(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    from twin.errors import TwinError
    from twin.motion.logs import read_motion
    from twin.motion.sensor import Sensor
    from twin.planners import PLANNERS
    from twin.sim import simulate_many
    from twin.sim.measured import LOG_DIR_ENV, store_log

    os.environ[LOG_DIR_ENV] = str(args.data_dir / "motion_logs")
    try:
        sensor = Sensor.load(args.sensor) if args.sensor is not None else Sensor()
        series = read_motion(args.log, sensor)
        key = store_log(series, sensor.position)
        print(json.dumps({"id": key, "samples": len(series), "duration": series.duration,
                          "channels": list(series.channels), "issues": series.issues}))
        if not args.compare:
            return 0
        end = series.duration if args.end is None else args.end
        planners = sorted(n for n, p in PLANNERS.items() if args.mechanism in p.mechanisms)
        source = {"source": "log", "log": key, "offset": args.start}
        runs = simulate_many([{"mechanism": args.mechanism, "planner": p, "base_motion": source,
                               "duration": end - args.start} for p in planners], progress=True)
    except (TwinError, ValueError) as exc:  # a pydantic error is a ValueError too
        parser.error(str(exc))
    print(f"{'planner':8} {'tip error max [mm]':>19} {'violations':>10}  first limit")
    for name, run in zip(planners, runs, strict=True):
        m = run.metrics
        bound = m.get("first_bound") or {}
        limit = f"{bound['limit']} at {bound['t']:.1f} s" if bound else "none"
        print(f"{name:8} {1e3 * m['tip_position_error_max']:19.1f} {m['violations']:10d}  {limit}"
              + ("  (tracking diverged)" if m.get("tracking_diverged") else ""))
    return 0


def _add_motion_replay(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """`twin motion-replay`: a motion log sent as an MRU's sentences over UDP (issue 40)."""
    replay = commands.add_parser(
        "motion-replay",
        help="send a motion log over UDP as an MRU would ($PSXN,23, $PASHR or TSS1)",
        description="Replay a motion log (CSV, Parquet or NMEA/TSS1 text; twin.motion.logs) as "
        "the sentences a motion sensor sends, one UDP datagram per line, paced in real time "
        "(× --speed): the live input of `twin serve --motion-udp PORT`, for demos and tests.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    replay.add_argument("log", metavar="LOG", type=Path, help="the motion log file")
    replay.add_argument("--udp", required=True, metavar="HOST:PORT", help="where to send")
    replay.add_argument("--rate", type=float, default=None, help="[Hz] lines per second "
                        "(default the log's own rate)")  # fmt: skip
    replay.add_argument("--format", default="psxn", choices=("psxn", "pashr", "tss1"))
    replay.add_argument("--speed", type=float, default=1.0, help="× real time, 0.1-100")
    replay.add_argument("--sensor", type=Path, help="the log's sensor file (YAML/JSON)")
    replay.set_defaults(handler=_motion_replay)


def _motion_replay(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    from twin.errors import TwinError
    from twin.motion.logs import read_motion
    from twin.motion.replay import send
    from twin.motion.sensor import Sensor

    host, _, port = args.udp.rpartition(":")
    if not host or not port.isdigit():
        parser.error(f"--udp {args.udp!r}: HOST:PORT expected, e.g. 127.0.0.1:10110")
    try:
        sensor = Sensor.load(args.sensor) if args.sensor is not None else None
        series = read_motion(args.log, sensor)
        if args.rate is not None and not 0.1 <= args.rate <= 200.0:
            raise TwinError(f"--rate {args.rate!r} Hz; allowed 0.1 to 200")
        print(f"twin: sending {args.log.name} ({series.duration:.0f} s) to {host}:{port} as "
              f"{args.format}, × {args.speed:g}", file=sys.stderr)  # fmt: skip
        sent = send(series, host, int(port), args.format, args.rate, args.speed)
    except (TwinError, OSError) as exc:
        parser.error(str(exc))
    except KeyboardInterrupt:
        return 130
    print(f"twin: {sent} lines sent", file=sys.stderr)
    return 0


def _add_warm(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """`twin warm`: compile the kernels ahead."""
    warm = commands.add_parser(
        "warm",
        help="compile every kernel into numba's disk cache (or load it from there)",
        description="Compile every kernel runner into numba's disk cache, or load it if it is "
        "there, so that a server, worker or test run that follows starts without compiling. "
        "On a first start this takes minutes; --processes splits it over processes that "
        "compile at once.",
    )
    warm.add_argument(
        "--processes", type=int, default=None, metavar="N",
        help="processes to compile in, 1-2 (one per share of twin.sim.engine.WARM_SHARES); "
        "default: one per core",
    )  # fmt: skip
    warm.set_defaults(handler=_warm)


def _serve(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    from twin.errors import TwinError
    from twin.motion.sensor import Sensor
    from twin.web.motion_udp import listening
    from twin.web.server import Terminated

    try:
        sensor = None if args.motion_sensor is None else Sensor.load(args.motion_sensor)
        position = (0.0, 0.0, 0.0) if sensor is None else sensor.position
        with listening(args.motion_udp, args.motion_udp_allow, position) as listener:
            _serve_with(args, None if listener is None else listener.live)
    except (KeyboardInterrupt, Terminated):  # how a server is stopped; serve has cleaned up
        pass
    except TwinError as exc:  # a token or bind refused, or the data directory held by another
        parser.error(str(exc))
    return 0


def _serve_with(args: argparse.Namespace, motion: LiveMotion | None = None) -> None:
    """`serve` with the parsed options and the live motion input (`--motion-udp`), if any."""
    from twin.web.server import serve

    serve(
        args.host,
        args.port,
        args.viser_port,
        args.data_dir,
        token=os.environ.get("TWIN_TOKEN") or None,  # not an option: argv is visible to all
        viewer=not args.no_viewer,
        scheduler=args.scheduler,
        workers=args.workers,
        allow_hosts=tuple(args.allow_host),
        allow_origins=tuple(args.allow_origin),
        graphics=args.graphics,
        forwarded_allow_ips=tuple(args.forwarded_allow_ips),
        private=args.private,
        dashboard=args.dashboard,
        max_store=args.max_store,
        max_runs=args.max_runs,
        retain=args.retain,
        worker_nice=args.worker_nice,
        motion=motion,
        **({} if args.run_budget is None else {"run_budget": args.run_budget}),
    )


def _run(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    from pydantic import ValidationError

    from twin.sim import PAPER_PRESETS, Scenario, simulate
    from twin.validation import explain

    if args.out is not None and args.out.suffix not in OUTPUTS:
        parser.error(f"--out {args.out}: suffix must be one of {', '.join(OUTPUTS)}")
    source = Path(args.scenario)
    if source.is_file():
        try:
            scenario = Scenario.model_validate_json(read_input(parser, source))
        except ValidationError as exc:
            parser.error(f"{source}: {explain(exc)}")
    elif args.scenario in PAPER_PRESETS:
        scenario = PAPER_PRESETS[args.scenario]
    else:
        parser.error(
            f"{args.scenario}: no such file and no such preset; presets: {sorted(PAPER_PRESETS)}"
        )
    result = simulate(scenario, progress=True)
    if args.out is not None:
        write = {".csv": result.to_csv, ".parquet": result.to_parquet, ".json": result.to_json}
        write[args.out.suffix](args.out)
        print(f"twin: wrote {len(result.series['t'])} samples to {args.out}", file=sys.stderr)
    print(json.dumps(result.metrics, indent=2))
    return 0


def _sweep(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    from pydantic import ValidationError

    from twin.runs.sweep import SweepSpec, heatmap_png, run_sweep
    from twin.validation import explain

    if not args.spec.is_file():
        parser.error(f"{args.spec}: no such file")
    try:
        spec = SweepSpec.model_validate_json(read_input(parser, args.spec))
    except ValidationError as exc:  # its message names each bad field
        parser.error(f"{args.spec}: {explain(exc)}")
    try:
        result = run_sweep(
            spec, scheduler=args.scheduler, n_workers=args.workers, progress=True
        )
    except ValueError as exc:  # a bad --scheduler address
        parser.error(str(exc))
    args.out.mkdir(parents=True, exist_ok=True)
    result.table.to_csv(args.out / "operability.csv", index=False)
    (args.out / "operability.json").write_text(json.dumps(result.to_dict(), indent=2) + "\n")
    heatmap_png(result, args.out / "heatmap.png")
    print(result.table.to_string(index=False))
    print(f"\n{result.criterion}", file=sys.stderr)
    print(
        f"twin: {len(result.runs)} runs in {result.elapsed:.1f} s on {result.scheduler}; "
        f"wrote operability.csv, operability.json, heatmap.png to {args.out}",
        file=sys.stderr,
    )
    return 0


def _workability(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    from pydantic import ValidationError

    from twin.errors import TwinError
    from twin.runs.workability import (
        HeadingStrategy,
        WorkabilitySpec,
        read_site_record,
        run_workability,
    )
    from twin.validation import explain

    try:
        fields = {}
        if args.spec is not None:
            fields = json.loads(read_input(parser, args.spec))
        given: dict[str, object] = {"mechanism": args.mechanism, "seeds": args.seeds,
                                    "method": args.method}  # fmt: skip
        if args.vessel_heading is not None:
            if args.heading_strategy not in (None, "record"):
                raise TwinError("--vessel-heading holds the bow at a compass heading (the record "
                                "strategy); it does not go with --heading-strategy "
                                f"{args.heading_strategy}")  # fmt: skip
            given["heading"] = HeadingStrategy(kind="record", vessel_heading=args.vessel_heading)
        elif args.heading_strategy is not None or "heading" not in fields:
            given["heading"] = HeadingStrategy.parse(args.heading_strategy or "fixed:150")
        if args.duplicates is not None:
            given["duplicates"] = args.duplicates
        if args.planner:
            given["planners"] = args.planner
        spec = WorkabilitySpec(**{**fields, **given})
        record = read_site_record(args.record, spec, kind=args.kind)
    except ValidationError as exc:  # its message names each bad field
        parser.error(explain(exc))
    except (TwinError, json.JSONDecodeError) as exc:
        parser.error(str(exc))
    try:
        result = run_workability(
            spec, record, scheduler=args.scheduler, n_workers=args.workers,
            data_dir=args.data_dir, progress=True,
        )  # fmt: skip
    except ValueError as exc:  # a bad --scheduler address or a record the strategy cannot use
        parser.error(str(exc))
    warnings = record.warnings()  # rows skipped over 5 %: said first, as warnings
    for note in result.notes:
        print(f"twin: {'warning' if note in warnings else 'note'}: {note}", file=sys.stderr)
    written = result.write(args.out)
    for planner, value in result.summary["workability"].items():
        print(f"{planner:>6}: {100 * value:5.1f} % workable")
    for limit, entry in result.summary["threshold"].items():
        print(f"Hs < {limit} m: {100 * entry['workability']:5.1f} % (threshold estimate)")
    print(f"\n{spec.criterion}", file=sys.stderr)
    print(
        f"twin: {record.n} rows ({sum(record.skipped.values())} skipped), {result.runs} runs "
        f"({result.new_runs} new) in {result.elapsed:.1f} s; wrote "
        f"{', '.join(p.name for p in written)} to {args.out}",
        file=sys.stderr,
    )
    return 0


def _warm(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    from twin.sim.engine import warm_in_processes
    from twin.web.warmup import Warmup

    try:
        took = warm_in_processes(args.processes, progress=Warmup().kernel_done)
    except ValueError as exc:
        parser.error(str(exc))
    print(f"twin: compiled kernels ready in {took:.1f} s", flush=True)
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the `twin` command."""
    parser = build_parser()
    args = parser.parse_args(argv)
    return args.handler(args, command_parser(parser, args.command))


def command_parser(parser: argparse.ArgumentParser, command: str) -> argparse.ArgumentParser:
    """The parser of one sub-command of `parser`, whichever `_add_*` added it: a handler's
    `parser.error` then prints that sub-command's usage line (`twin run [-h] …`), not
    `twin COMMAND`'s."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return action.choices[command]
    raise LookupError(f"no sub-command {command!r}")


if __name__ == "__main__":
    sys.exit(main())
