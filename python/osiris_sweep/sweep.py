"""A sweep on Dask: variants as tasks, results stored per variant as they complete, tables and
report at the end.

Layout of the output folder DIR:

* ``runs/<hash>/result.json``: one variant (parameters, status, error, attempts and the worker of
  each, wall time, result rows, error samples), written to a temporary folder and renamed into place when the variant
  completes; a re-run of the same spec into DIR skips every variant whose result is ``ok``;
* ``runs/<hash>/scenario.json``: the variant's scenario;
* ``results.parquet``, ``results.csv``: one row per (variant, sensor, ground-truth object, range
  bin) with the variant's parameters as columns;
* ``runs.csv``: one row per variant; ``report.html``: the sweep report.
"""

from __future__ import annotations

import json
import os
import shutil
import socket
import sys
import time
import uuid
from dataclasses import asdict
from pathlib import Path

from . import aggregate, runner
from .spec import Spec, SpecError, Variant, resolve_variants

RESULT = "result.json"
# Each execution of a variant task announces itself on this event topic before it runs, so that the
# client counts executions as they happen: a re-run after a worker died mid-task, and also a re-run
# of a finished task whose result died with its worker before it was fetched (which the scheduler's
# own retry counters do not see).
ATTEMPT_TOPIC = "osiris-sweep-attempt"


class Progress:
    def __init__(self, total: int, quiet: bool, stream=sys.stderr):
        self.total, self.quiet, self.stream = total, quiet, stream
        self.done = self.failed = 0
        self.t0 = time.perf_counter()
        self.tty = hasattr(stream, "isatty") and stream.isatty()

    def update(self, ok: bool, label: str = ""):
        self.done += 1
        self.failed += 0 if ok else 1
        if self.quiet:
            return
        n = 30
        k = int(n * self.done / max(self.total, 1))
        el = time.perf_counter() - self.t0
        line = (f"osiris-sweep [{'#' * k}{'.' * (n - k)}] {self.done}/{self.total} "
                f"({self.failed} failed) {el:6.1f} s {label}")
        if self.tty:
            self.stream.write("\r" + line.ljust(100))
            if self.done == self.total:
                self.stream.write("\n")
        else:
            self.stream.write(line + "\n")
        self.stream.flush()

    def info(self, msg: str):
        if not self.quiet:
            self.stream.write(f"osiris-sweep: {msg}\n")
            self.stream.flush()


def variant_payload(v: Variant, config_defaults: dict | None, fmu_dir: str | None = None) -> dict:
    d = asdict(v)
    d["fmu_dir"] = fmu_dir
    if v.config:
        d["config_defaults"] = config_defaults or {}
    return d


def load_result(run_dir: Path) -> dict | None:
    try:
        return json.loads((run_dir / RESULT).read_text())
    except (FileNotFoundError, json.JSONDecodeError):
        return None


def store_result(runs_dir: Path, v: Variant, record: dict) -> None:
    """Write runs/<hash>/ atomically: a temporary sibling folder renamed into place (an old result
    of the same variant, e.g. a failure being retried, is replaced)."""
    final = runs_dir / v.hash
    tmp = runs_dir / f".tmp-{v.hash}-{uuid.uuid4().hex[:8]}"
    tmp.mkdir(parents=True)
    (tmp / "scenario.json").write_text(json.dumps(v.scenario, indent=1))
    with open(tmp / RESULT, "w") as f:
        json.dump(record, f, allow_nan=True)
        f.flush()
        os.fsync(f.fileno())
    if final.exists():
        old = runs_dir / f".old-{v.hash}-{uuid.uuid4().hex[:8]}"
        os.rename(final, old)
        os.rename(tmp, final)
        shutil.rmtree(old, ignore_errors=True)
    else:
        os.rename(tmp, final)


def _run_announced(key: str, payload: dict, osiris: str, range_bins_m: list[float]) -> dict:
    """The Dask task: announce this execution of `key` (worker host and pid), then run the variant."""
    from distributed import get_worker

    get_worker().log_event(ATTEMPT_TOPIC, {"key": key, "process": f"{socket.gethostname()}:{os.getpid()}"})
    return runner.run_variant(payload, osiris, range_bins_m)


class AttemptLog:
    """Executions per task key, each as the "host:pid" of the worker process that ran it, from the
    announcements the tasks publish (kept on the client: unbounded, unlike the scheduler's log)."""

    def __init__(self):
        self.workers: dict[str, list[str]] = {}

    def __call__(self, event):
        _, msg = event
        if isinstance(msg, dict) and "key" in msg:
            # "worker" (the worker's address) is added by the scheduler
            self.workers.setdefault(msg["key"], []).append(str(msg.get("process", msg.get("worker", "?"))))

    def of(self, key: str) -> list[str]:
        return list(self.workers.get(key, []))


def _make_cluster(workers: int):
    import dask
    from distributed import LocalCluster

    # A task on a worker that dies is re-run once; a second death fails it (KilledWorker).
    dask.config.set({"distributed.scheduler.allowed-failures": 1})
    return LocalCluster(
        n_workers=workers,
        threads_per_worker=1,
        processes=True,
        dashboard_address=None,
        silence_logs=50,
    )


def run_sweep(
    spec: Spec,
    out_dir: str | Path,
    osiris: str,
    scheduler: str | None = None,
    workers: int = 2,
    quiet: bool = False,
    on_result=None,
    fmu_dir: str | None = None,
) -> int:
    """Run (the unfinished part of) a sweep into `out_dir`. Returns the exit status: 0 when every
    variant succeeded, 1 when any failed. `on_result(client, cluster, record)` is called after
    each stored result (tests use it to kill a worker mid-sweep). `fmu_dir`: `osiris run --fmu-dir`
    for every run (default: for a LocalCluster, the folder of the FMUs the preflight run used)."""
    from distributed import Client, as_completed

    out = Path(out_dir)
    runs_dir = out / "runs"
    runs_dir.mkdir(parents=True, exist_ok=True)

    if spec.scenario_file:
        try:
            base = json.loads(Path(spec.scenario_file).read_text())
        except (OSError, json.JSONDecodeError) as e:
            raise SpecError(f"scenario.file: cannot read {spec.scenario_file}: {e}") from None
        if not isinstance(base, dict):
            raise SpecError(f"scenario.file: {spec.scenario_file} is not a JSON object")
    else:
        base = runner.builtin_scenario(osiris)
    names = {s: runner.fmu_parameter_names(osiris, s) for s in spec.sensors}
    variants = resolve_variants(spec, base, names)
    needs_config = any(v.config for v in variants)

    done, pending = {}, []
    for v in variants:
        rec = load_result(runs_dir / v.hash)
        if rec is not None and rec.get("status") == "ok":
            done[v.hash] = rec
        else:
            pending.append(v)
    progress = Progress(len(pending), quiet)
    progress.info(
        f"{spec.name}: {len(variants)} variants, {len(done)} already done, {len(pending)} to run"
    )
    (out / "spec.json").write_text(json.dumps({
        "name": spec.name, "sensors": spec.sensors, "design": spec.design,
        "range_bins_m": spec.range_bins_m, "variants": [v.hash for v in variants],
        "parameters": [a.key for a in spec.axes], "osiris": osiris,
    }, indent=1))

    if pending:
        # The preflight run packages missing FMUs once (not in parallel in every worker) and
        # yields the default configurations that config.* overrides are merged into.
        defaults, run_fmu_dir = None, fmu_dir
        if needs_config or not scheduler:
            defaults, found = runner.preflight(osiris, spec.sensors, fmu_dir)
            if not scheduler:  # the workers share this machine's files
                run_fmu_dir = found
        cluster = None if scheduler else _make_cluster(workers)
        client = Client(scheduler if scheduler else cluster)
        attempt_log = AttemptLog()
        client.subscribe_topic(ATTEMPT_TOPIC, attempt_log)
        try:
            by_key = {}
            futures = []
            for v in pending:
                key = f"osiris-variant-{v.hash}-{uuid.uuid4().hex[:6]}"
                fut = client.submit(
                    _run_announced, key, variant_payload(v, defaults, run_fmu_dir), osiris, spec.range_bins_m,
                    key=key, retries=1, pure=False,
                )
                by_key[fut.key] = v
                futures.append(fut)
            for fut in as_completed(futures):
                v = by_key[fut.key]
                # An announcement lost with a worker killed within milliseconds of the task's start
                # leaves the count short; a finished or failed task ran at least once.
                workers = attempt_log.of(fut.key)
                record = {
                    "hash": v.hash, "params": v.params, "sensors": v.sensors,
                    "fmu_params": v.fmu_params, "config": v.config,
                }
                if fut.status == "finished":
                    res = fut.result()
                    record.update(status="ok", error="", attempts=max(len(workers), 1), workers=workers,
                                  wall_s=res["wall_s"], osiris_wall_s=res["osiris_wall_s"], rows=res["rows"],
                                  errors=res["errors"], host=res["host"])
                else:
                    exc = fut.exception()
                    killed = type(exc).__name__ == "KilledWorker"
                    msg = f"{type(exc).__name__}: {exc}" if not isinstance(exc, runner.RunFailed) else str(exc)
                    record.update(status="failed", error=msg,
                                  attempts=len(workers) if killed else max(len(workers), 1), workers=workers,
                                  wall_s=None, osiris_wall_s=None, rows=[], errors={}, host=None)
                store_result(runs_dir, v, record)
                done[v.hash] = record
                fut.release()
                progress.update(record["status"] == "ok", v.hash)
                if on_result is not None:
                    on_result(client, cluster, record)
        finally:
            client.close()
            if cluster is not None:
                cluster.close()

    records = [done[v.hash] for v in variants]
    write_tables(out, spec, records)
    from . import report

    report.write_report(out / "report.html", spec, records)
    failed = [r for r in records if r["status"] != "ok"]
    progress.info(
        f"{len(records) - len(failed)} ok, {len(failed)} failed; "
        f"wrote {out / 'results.parquet'}, {out / 'results.csv'}, {out / 'runs.csv'}, {out / 'report.html'}"
    )
    return 1 if failed else 0


def _cell(v):
    if isinstance(v, (list, dict)):
        return json.dumps(v)
    return v


def results_frame(spec: Spec, records: list[dict]):
    import pandas as pd

    keys = [a.key for a in spec.axes]
    rows = []
    for rec in records:
        base = {"run": rec["hash"], **{k: _cell(rec["params"].get(k)) for k in keys}}
        if rec["status"] != "ok" or not rec["rows"]:
            for s in rec["sensors"] if rec["status"] != "ok" else []:
                rows.append({**base, **{c: None for c in aggregate.ROW_COLUMNS}, "sensor": s,
                             "status": rec["status"]})
            continue
        for r in rec["rows"]:
            status = "ok" if r.get("gt_id") is not None else "no_objects_in_fov"
            rows.append({**base, **r, "status": status})
    cols = ["run", *keys, *aggregate.ROW_COLUMNS, "status"]
    df = pd.DataFrame(rows, columns=cols)
    for c in ("gt_id", "frames_in_bin", "frames_detected", "sensor_frames"):
        df[c] = df[c].astype("Int64")
    for c in ("range_lo_m", "range_hi_m", "detection_probability", "range_error_mean_m", "range_error_rms_m",
              "range_rate_error_mean_mps", "false_alarms_per_frame", "step_ms_mean", "step_ms_max"):
        df[c] = pd.to_numeric(df[c], errors="coerce").astype("float64")
    return df


def runs_frame(spec: Spec, records: list[dict]):
    import pandas as pd

    keys = [a.key for a in spec.axes]
    rows = [
        {"hash": r["hash"], **{k: _cell(r["params"].get(k)) for k in keys}, "status": r["status"],
         "error": r["error"], "attempts": r["attempts"], "wall_s": r["wall_s"]}
        for r in records
    ]
    return pd.DataFrame(rows, columns=["hash", *keys, "status", "error", "attempts", "wall_s"])


def _atomic(path: Path, write):
    tmp = path.with_name(f".{path.name}.{uuid.uuid4().hex[:8]}")
    write(tmp)
    os.replace(tmp, path)


def write_tables(out: Path, spec: Spec, records: list[dict]) -> None:
    df = results_frame(spec, records)
    _atomic(out / "results.parquet", lambda p: df.to_parquet(p, index=False, engine="pyarrow"))
    _atomic(out / "results.csv", lambda p: df.to_csv(p, index=False))
    runs = runs_frame(spec, records)
    _atomic(out / "runs.csv", lambda p: runs.to_csv(p, index=False))

