"""End-to-end sweeps with the real osiris binary on a LocalCluster of 2 worker processes: a
worker killed mid-sweep, a re-run that runs nothing, a variant that always fails, the CLI.

Missing binary: these fail under CI=true and are skipped elsewhere (conftest.osiris_bin)."""

import json
import os
import signal
import subprocess
import sys
import time

import pandas as pd
import pytest

from osiris_sweep import sweep
from osiris_sweep.spec import load_spec

from .conftest import REPO, scenario_runs

SMALL = """
[sweep]
name = "e2e"
sensors = ["radar"]
range_bins_m = [0, 25, 50, 75, 100, 150]
[scenario]
set = {{ duration_s = {duration} }}
[parameters]
"scenario.road_users.0.x_m" = [90.0, 140.0]
"scenario.environment.rain_mm_h" = [0.0, 16.0]
"config.seed" = [1, 2]
{extra}
"""


def write_spec(tmp_path, duration=0.5, extra=""):
    p = tmp_path / "spec.toml"
    p.write_text(SMALL.format(duration=duration, extra=extra))
    return p


def sweep_cli(*args, env=None):
    return subprocess.run([sys.executable, "-m", "osiris_sweep", *map(str, args)], capture_output=True,
                          text=True, cwd=REPO, env=env, timeout=600)


def test_worker_killed_mid_sweep(osiris_bin, tmp_path):
    spec = load_spec(write_spec(tmp_path))
    out = tmp_path / "out"
    killed = {}

    def kill_a_busy_worker(client, cluster, record):
        if killed:
            return
        busy = [w for w, keys in client.processing().items() if keys]
        if not busy:  # nothing running right now: try again after the next result
            return
        victim = busy[0]
        pid = client.run(os.getpid, workers=[victim])[victim]
        os.kill(pid, signal.SIGKILL)
        killed["pid"] = pid

    t0 = time.perf_counter()
    rc = sweep.run_sweep(spec, out, osiris_bin, workers=2, quiet=True, on_result=kill_a_busy_worker,
                         fmu_dir=os.environ.get("OSIRIS_FMU_DIR"))
    wall = time.perf_counter() - t0
    runs = pd.read_csv(out / "runs.csv")
    assert killed.get("pid"), "no worker was killed"
    assert rc == 0, runs[["hash", "status", "error"]].to_string()
    assert len(runs) == 8 and (runs["status"] == "ok").all()
    # Every execution is recorded with its worker. The variants that ran on the killed worker (the
    # one it was running, and any finished one whose result died with it before it was fetched)
    # ran again on the other worker: two attempts, the second elsewhere; every other variant once.
    recs = {h: json.loads((out / "runs" / h / "result.json").read_text()) for h in runs["hash"]}
    dead = f":{killed['pid']}"
    victims = {h for h, r in recs.items() if any(w.endswith(dead) for w in r["workers"])
               and not r["workers"][-1].endswith(dead)}
    assert victims, {h: r["workers"] for h, r in recs.items()}
    for h, r in recs.items():
        assert r["attempts"] == len(r["workers"]), (h, r["attempts"], r["workers"])
        assert r["attempts"] == (2 if h in victims else 1), (h, r["workers"], killed["pid"])
    assert dict(zip(runs["hash"], runs["attempts"])) == {h: r["attempts"] for h, r in recs.items()}
    results = pd.read_parquet(out / "results.parquet")
    assert set(results["run"]) == set(runs["hash"])  # every variant's rows
    assert {"scenario.road_users.0.x_m", "scenario.environment.rain_mm_h", "config.seed",
            "detection_probability", "range_error_rms_m", "false_alarms_per_frame", "step_ms_max",
            "status"} <= set(results.columns)
    assert (results["status"] != "failed").all()
    assert (results["frames_in_bin"].dropna() > 0).all()
    pdet = results["detection_probability"].dropna()
    assert ((pdet >= 0) & (pdet <= 1)).all()
    assert pd.read_csv(out / "results.csv").shape[0] == results.shape[0]
    html = (out / "report.html").read_text()
    assert "<svg" in html and "Detection probability vs range" in html
    assert "<script" not in html and 'src="http' not in html and "href=\"http" not in html
    print(f"8 variants, one worker killed, {wall:.1f} s")


def test_rerun_skips_finished_variants(counting_osiris, tmp_path):
    wrapper, log = counting_osiris
    spec = write_spec(tmp_path, duration=0.3)
    out = tmp_path / "out"
    r1 = sweep_cli(spec, "--out", out, "--osiris", wrapper, "--quiet")
    assert r1.returncode == 0, r1.stderr
    first = scenario_runs(log)
    assert first >= 8
    before = {p.name: (p / "result.json").stat().st_mtime_ns for p in (out / "runs").iterdir()}
    log.unlink()
    r2 = sweep_cli(spec, "--out", out, "--osiris", wrapper)
    assert r2.returncode == 0, r2.stderr
    assert scenario_runs(log) == 0, log.read_text()
    assert "8 already done, 0 to run" in r2.stderr
    after = {p.name: (p / "result.json").stat().st_mtime_ns for p in (out / "runs").iterdir()}
    assert after == before
    assert len(pd.read_parquet(out / "results.parquet")["run"].unique()) == 8


def test_failing_variant_reported_after_two_attempts(counting_osiris, tmp_path):
    wrapper, log = counting_osiris
    # mode = "bogus" is rejected by the FMU: 4 of the 8 variants always fail
    spec = tmp_path / "spec.toml"
    spec.write_text("""
[sweep]
sensors = ["radar"]
[scenario]
set = { duration_s = 0.3 }
[parameters]
"scenario.environment.rain_mm_h" = [0.0, 16.0]
"config.seed" = [1, 2]
"param.mode" = ["physical", "bogus"]
""")
    out = tmp_path / "out"
    r = sweep_cli(spec, "--out", out, "--osiris", wrapper, "--quiet")
    assert r.returncode == 1, r.stderr
    runs = pd.read_csv(out / "runs.csv")
    bad, good = runs[runs["param.mode"] == "bogus"], runs[runs["param.mode"] == "physical"]
    assert len(bad) == 4 and len(good) == 4
    assert (bad["status"] == "failed").all() and (bad["attempts"] == 2).all()
    assert bad["error"].str.contains("unknown model mode `bogus`").all()
    assert (good["status"] == "ok").all() and (good["attempts"] == 1).all()
    # each failing variant ran twice, each good one once
    assert scenario_runs(log) == 4 * 2 + 4
    results = pd.read_csv(out / "results.csv")
    assert set(results["run"]) == set(runs["hash"])
    assert (results[results["run"].isin(bad["hash"])]["status"] == "failed").all()
    html = (out / "report.html").read_text()
    assert "Failed runs (4)" in html and "unknown model mode" in html


def test_cli_usage_and_spec_errors(tmp_path, osiris_bin):
    bad = tmp_path / "bad.toml"
    bad.write_text("[sweep]\nsensors = ['sonar']\n")
    r = sweep_cli(bad, "--out", tmp_path / "o", "--osiris", osiris_bin)
    assert r.returncode == 2 and "sweep.sensors: unknown sensor 'sonar'" in r.stderr
    path = tmp_path / "path.toml"
    path.write_text("[sweep]\n[parameters]\n'scenario.environment.rain' = [1.0]\n")
    r = sweep_cli(path, "--out", tmp_path / "o", "--osiris", osiris_bin)
    assert r.returncode == 2 and "the scenario has no 'environment.rain'" in r.stderr
    r = sweep_cli(write_spec(tmp_path), "--out", tmp_path / "o", "--osiris", tmp_path / "nope")
    assert r.returncode == 2 and "not an executable file" in r.stderr
    r = sweep_cli(write_spec(tmp_path))  # no --out
    assert r.returncode == 2 and "--out" in r.stderr


def test_binary_lookup_error(tmp_path, monkeypatch):
    from osiris_sweep import runner

    monkeypatch.setenv("OSIRIS_BIN", str(tmp_path / "missing"))
    monkeypatch.setenv("PATH", str(tmp_path))
    monkeypatch.chdir(tmp_path)
    with pytest.raises(runner.BinaryNotFound, match=r"OSIRIS_BIN=.*missing.*target/release/osiris"):
        runner.find_osiris(None)


def test_scenario_file_errors_and_use(osiris_bin, tmp_path, base_scenario):
    spec = tmp_path / "f.toml"
    spec.write_text("[sweep]\n[scenario]\nfile = 'missing.json'\n")
    r = sweep_cli(spec, "--out", tmp_path / "o", "--osiris", osiris_bin)
    assert r.returncode == 2 and "scenario.file: cannot read" in r.stderr
    # a base scenario file with one road user: paths are checked against it, not the built-in one
    base = dict(base_scenario, road_users=base_scenario["road_users"][:1])
    (tmp_path / "base.json").write_text(json.dumps(base))
    spec.write_text("[sweep]\n[scenario]\nfile = 'base.json'\n[parameters]\n'scenario.road_users.1.x_m' = [1.0]\n")
    r = sweep_cli(spec, "--out", tmp_path / "o", "--osiris", osiris_bin)
    assert r.returncode == 2 and "index 1 out of range: road_users has 1 entries" in r.stderr
