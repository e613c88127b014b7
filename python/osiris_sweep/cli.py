"""`osiris-sweep SPEC --out DIR [--scheduler ADDRESS] [--workers N] [--osiris PATH] [--quiet]`
and `osiris-sweep bench [--osiris PATH]`.

Exit status: 0 every variant succeeded, 1 some variant failed, 2 usage or spec error (or the
osiris binary failed before any variant ran: `osiris scenario`, `model-description`, the preflight
run)."""

from __future__ import annotations

import argparse
import os
import sys

from . import runner
from .spec import SpecError, load_spec


def _sweep_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="osiris-sweep",
        description="Run an osiris scenario sweep on Dask and write results.parquet, results.csv, "
        "runs.csv and report.html into DIR (`osiris-sweep bench` prints the benchmark line).",
    )
    p.add_argument("spec", help="sweep spec (TOML, see docs/sweep.md)")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder (a re-run skips finished variants)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="address of a running Dask scheduler (tcp://host:8786); default: a LocalCluster")
    p.add_argument("--workers", type=int, default=2, metavar="N",
                   help="LocalCluster worker processes, one thread each (default 2)")
    p.add_argument("--osiris", metavar="PATH",
                   help="osiris binary (default: $OSIRIS_BIN, osiris on PATH, ./target/release/osiris)")
    p.add_argument("--fmu-dir", metavar="DIR", default=os.environ.get("OSIRIS_FMU_DIR") or None,
                   help="osiris run --fmu-dir for every run (default: $OSIRIS_FMU_DIR; else the FMUs the "
                   "first run packages, on a LocalCluster)")
    p.add_argument("--quiet", action="store_true", help="no progress output")
    return p


def _bench_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="osiris-sweep bench",
                                description="Print one JSON line: per-task overhead and throughput")
    p.add_argument("--osiris", metavar="PATH")
    p.add_argument("--fmu-dir", metavar="DIR", default=os.environ.get("OSIRIS_FMU_DIR") or None)
    p.add_argument("--repeats", type=int, default=3)
    return p


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    try:
        if argv[:1] == ["bench"]:
            args = _bench_parser().parse_args(argv[1:])
            from . import bench

            osiris = runner.find_osiris(args.osiris)
            bench.main(osiris, repeats=args.repeats, fmu_dir=args.fmu_dir)
            return 0
        args = _sweep_parser().parse_args(argv)
    except SystemExit as e:  # argparse: usage errors exit 2, --help 0
        return int(e.code or 0)
    except runner.BinaryNotFound as e:
        print(f"osiris-sweep: {e}", file=sys.stderr)
        return 2
    except runner.SetupFailed as e:
        print(f"osiris-sweep: {e}", file=sys.stderr)
        return 2
    if args.workers < 1:
        print("osiris-sweep: --workers must be >= 1", file=sys.stderr)
        return 2
    try:
        spec = load_spec(args.spec)
        osiris = runner.find_osiris(args.osiris)
        from .sweep import run_sweep

        return run_sweep(spec, args.out, osiris, scheduler=args.scheduler, workers=args.workers,
                         quiet=args.quiet, fmu_dir=args.fmu_dir)
    except SpecError as e:
        print(f"osiris-sweep: {args.spec}: {e}", file=sys.stderr)
        return 2
    except runner.BinaryNotFound as e:
        print(f"osiris-sweep: {e}", file=sys.stderr)
        return 2
    except runner.SetupFailed as e:
        print(f"osiris-sweep: {e}", file=sys.stderr)
        return 2
