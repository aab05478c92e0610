"""The `twin` command: `twin serve` runs the live twin, `twin run` one scenario to a file,
`twin sweep` an operability sweep to a folder, `twin warm` compiles the kernels ahead."""

from __future__ import annotations

import argparse
import ipaddress
import json
import os
import re
import sys
from collections.abc import Sequence
from pathlib import Path

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


def seconds(text: str) -> float:
    """A positive, finite number of seconds, at most an hour (argparse type)."""
    value = float(text)
    if not 0.0 < value <= 3600.0:
        raise argparse.ArgumentTypeError(f"{text}: seconds are > 0 and ≤ 3600")
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
    parser = argparse.ArgumentParser(
        prog="twin",
        description="Digital twin of offshore wave-motion compensation (hybrid boarding "
        "gangway, 3UPU_UP and 4-UPR platforms).",
    )
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    serve = commands.add_parser(
        "serve",
        help="run the live twin: 3D viewer, REST API and landing page",
        description="Run the live twin until Ctrl-C or SIGTERM. POST and PATCH require the "
        "bearer token in the TWIN_TOKEN environment variable when it is set (at least 16 "
        "characters); a --host other than loopback requires it. Runs and sweeps execute on one "
        "Dask executor started with the server.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
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
        help="what the 3D viewer's browsers render: full, or light (no environment map and no "
        "shadows: for a browser without a GPU, on a remote desktop or a virtual machine)",
    )  # fmt: skip
    serve.add_argument(
        "--run-budget", type=seconds, metavar="SECONDS",
        help="wall-clock budget of one run; over it the run fails with a message (default: "
        "twin.sim.executor.RUN_BUDGET, 60 s)",
    )  # fmt: skip
    serve.set_defaults(handler=_serve)

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
        "spec", metavar="SPEC", type=Path, help="a JSON file of SweepSpec fields (twin.sim.sweep)"
    )
    sweep.add_argument(
        "--scheduler",
        help="a Dask scheduler address tcp://HOST:PORT, or 'in-process' (one worker thread "
        "in this process); default: a local cluster, one worker per core",
    )
    sweep.add_argument("--workers", type=workers, help="workers of the local cluster")
    sweep.add_argument("--out", type=Path, default=Path("sweep"), help="folder of the outputs")
    sweep.set_defaults(handler=_sweep)

    warm = commands.add_parser(
        "warm",
        help="compile every kernel into numba's disk cache (or load it from there)",
        description="Compile every kernel runner into numba's disk cache, or load it if it is "
        "there, so that a server, worker or test run that follows starts without compiling. "
        "On a first start this takes minutes; --processes splits it over processes that "
        "compile at once.",
    )
    warm.add_argument(
        "--processes", type=int, default=1, metavar="N",
        help="processes to compile in, 1-2 (one per share of twin.sim.engine.WARM_SHARES)",
    )  # fmt: skip
    warm.set_defaults(handler=_warm)
    return parser


def _serve(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    from twin.errors import TwinError
    from twin.web.server import Terminated, serve

    try:
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
            **({} if args.run_budget is None else {"run_budget": args.run_budget}),
        )
    except (KeyboardInterrupt, Terminated):  # how a server is stopped; serve has cleaned up
        pass
    except TwinError as exc:  # a token or bind refused, or the data directory held by another
        parser.error(str(exc))
    return 0


def _run(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    from pydantic import ValidationError

    from twin.sim import PAPER_PRESETS, Scenario, simulate

    if args.out is not None and args.out.suffix not in OUTPUTS:
        parser.error(f"--out {args.out}: suffix must be one of {', '.join(OUTPUTS)}")
    source = Path(args.scenario)
    if source.is_file():
        try:
            scenario = Scenario.model_validate_json(read_input(parser, source))
        except ValidationError as exc:
            parser.error(f"{source}: {exc}")
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

    from twin.sim.sweep import SweepSpec, heatmap_png, run_sweep

    if not args.spec.is_file():
        parser.error(f"{args.spec}: no such file")
    try:
        spec = SweepSpec.model_validate_json(read_input(parser, args.spec))
    except ValidationError as exc:  # its message names each bad field
        parser.error(f"{args.spec}: {exc}")
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


def _warm(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    from twin.sim.engine import warm_in_processes

    try:
        took = warm_in_processes(args.processes)
    except ValueError as exc:
        parser.error(str(exc))
    print(f"twin: compiled kernels ready in {took:.1f} s", flush=True)
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the `twin` command."""
    parser = build_parser()
    args = parser.parse_args(argv)
    return args.handler(args, parser)


if __name__ == "__main__":
    sys.exit(main())
