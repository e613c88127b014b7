"""`osiris-sweep bench`: the cost of running a variant as a Dask task instead of a bare
`osiris run`, and the throughput of 1 vs 2 workers."""

from __future__ import annotations

import json
import os
import platform
import statistics
import subprocess
import tempfile
import time

from . import runner
from .spec import parse_spec, resolve_variants
from .sweep import _make_cluster, variant_payload

BINS = [0, 25, 50, 75, 100, 150]


def _variants(osiris: str, rains: list[float]):
    spec = parse_spec({
        "sweep": {"name": "bench", "sensors": ["radar"], "range_bins_m": BINS},
        "parameters": {"scenario.environment.rain_mm_h": rains},
    })
    return resolve_variants(spec, runner.builtin_scenario(osiris))


def _cpu_model() -> str | None:
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or None


def _osiris_version(osiris: str) -> str | None:
    r = subprocess.run([osiris, "--version"], capture_output=True, text=True)
    return r.stdout.split()[-1] if r.returncode == 0 and r.stdout.split() else None


def _bare(osiris: str, v, fmu_dir) -> float:
    with tempfile.TemporaryDirectory(prefix="osiris-sweep-bench-") as tmp:
        path = os.path.join(tmp, "scenario.json")
        with open(path, "w") as f:
            json.dump(v.scenario, f, indent=1)
        cmd, _ = runner.invocations(variant_payload(v, None, fmu_dir), osiris, tmp, path)[0]
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, capture_output=True)
        return time.perf_counter() - t0


def main(osiris: str, repeats: int = 3, fmu_dir: str | None = None) -> dict:
    from distributed import Client

    (v,) = _variants(osiris, [0.0])
    # As a sweep does: one preflight run packages the FMU, then every run gets --fmu-dir.
    _, fmu_dir = runner.preflight(osiris, ["radar"], fmu_dir)
    kpi = True
    load_start = round(os.getloadavg()[0], 2)
    payload = variant_payload(v, None, fmu_dir)
    bare, task, dispatch = [], [], []
    with _make_cluster(1) as cluster, Client(cluster) as client:
        client.submit(lambda: 0, pure=False).result()  # worker up
        # Interleaved (bare, task, bare, task, ...): a change of the machine's load hits both alike.
        for _ in range(repeats):
            bare.append(_bare(osiris, v, fmu_dir))
            t0 = time.perf_counter()
            res = client.submit(runner.run_variant, payload, osiris, BINS, False, pure=False).result()
            task.append(time.perf_counter() - t0)
            # what the task adds around the osiris process: Dask round trip, scenario file, KPI tables
            dispatch.append(task[-1] - res["osiris_wall_s"])
            kpi = kpi and bool(res["rows"])

    four = [variant_payload(x, None, fmu_dir) for x in _variants(osiris, [0.0, 4.0, 8.0, 16.0])]
    throughput = {}
    for n in (1, 2):
        with _make_cluster(n) as cluster, Client(cluster) as client:
            client.wait_for_workers(n)
            client.run(lambda: 0)
            t0 = time.perf_counter()
            futs = [client.submit(runner.run_variant, p, osiris, BINS, False, pure=False) for p in four]
            client.gather(futs)
            throughput[n] = len(four) / ((time.perf_counter() - t0) / 60)

    bare_med, task_med = statistics.median(bare), statistics.median(task)
    line = {
        "what": "sweep",
        "bench": "sweep",
        "scenario": "built-in default, 2 s, radar",
        "repeats": repeats,
        "bare_run_s": bare,
        "task_s": task,
        "bare_run_median_s": bare_med,
        "task_median_s": task_med,
        "task_overhead_fraction": (task_med - bare_med) / bare_med,
        "dispatch_overhead_s": dispatch,
        "dispatch_overhead_median_s": statistics.median(dispatch),
        "dispatch_overhead_fraction": statistics.median(dispatch) / bare_med,
        "target_task_overhead_fraction": 0.05,
        "target_met": (task_med - bare_med) / bare_med < 0.05,
        "throughput_variants": len(four),
        "throughput_variants_per_min_1_worker": throughput[1],
        "throughput_variants_per_min_2_workers": throughput[2],
        "kpi_tables": kpi,
        "machine": {
            "cpu_model": _cpu_model(),
            "logical_cpus": os.cpu_count(),
            "load_avg_1min": load_start,
            "load_avg_1min_end": round(os.getloadavg()[0], 2),
            "python": platform.python_version(),
            "osiris": osiris,
            "osiris_version": _osiris_version(osiris),
        },
    }
    print(json.dumps(line, sort_keys=True))
    return line
