"""The osiris binary: where it is, what it knows (scenario, FMU parameters, default sensor
configurations), and one variant's run as a Dask task (:func:`run_variant`)."""

from __future__ import annotations

import copy
import json
import os
import re
import shutil
import subprocess
import tempfile
import time
import zipfile
from pathlib import Path

from . import aggregate


class BinaryNotFound(RuntimeError):
    pass


class SetupFailed(RuntimeError):
    """The osiris binary failed before any variant ran (scenario, model description, preflight)."""


class RunFailed(RuntimeError):
    """`osiris run` failed (or its outputs are unusable) for one variant."""


def find_osiris(explicit: str | None = None) -> str:
    """`--osiris PATH`, else `$OSIRIS_BIN`, else `osiris` on PATH, else `./target/release/osiris`."""
    tried = []
    if explicit:
        p = Path(explicit)
        if p.is_file() and os.access(p, os.X_OK):
            return str(p.resolve())
        raise BinaryNotFound(f"--osiris {explicit}: not an executable file")
    env = os.environ.get("OSIRIS_BIN")
    if env:
        p = Path(env)
        if p.is_file() and os.access(p, os.X_OK):
            return str(p.resolve())
        tried.append(f"$OSIRIS_BIN={env} (not an executable file)")
    else:
        tried.append("$OSIRIS_BIN (unset)")
    which = shutil.which("osiris")
    if which:
        return which
    tried.append("`osiris` on PATH (none)")
    local = Path("target/release/osiris")
    if local.is_file() and os.access(local, os.X_OK):
        return str(local.resolve())
    tried.append(f"{local} (missing)")
    raise BinaryNotFound(
        "cannot find the osiris binary; tried " + ", ".join(tried)
        + ". Build it with `cargo build --release` or pass --osiris PATH."
    )


def _check_output(cmd: list[str], timeout: float = 120) -> str:
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    if r.returncode != 0:
        raise SetupFailed(f"`{' '.join(cmd)}` failed ({r.returncode}): {r.stderr.strip()[-2000:]}")
    return r.stdout


def builtin_scenario(osiris: str) -> dict:
    return json.loads(_check_output([osiris, "scenario"]))


def fmu_parameter_names(osiris: str, sensor: str) -> set[str]:
    """Names of the FMU's `causality="parameter"` variables (its modelDescription), less the
    OSMP buffer addresses."""
    xml = _check_output([osiris, "model-description", sensor])
    names = set()
    for m in re.finditer(r"<ScalarVariable\b[^>]*>", xml):
        tag = m.group(0)
        name = re.search(r'name="([^"]*)"', tag)
        if name and 'causality="parameter"' in tag and not name.group(1).startswith("OSMP"):
            names.add(name.group(1))
    return names


def preflight(osiris: str, sensors: list[str], fmu_dir: str | None = None) -> tuple[dict, str]:
    """A one-frame `osiris run` of the sensors before the workers start. It packages missing or
    stale FMUs once (without `--fmu-dir`, every `osiris run` checks them with cargo, which waits
    while another cargo build holds the build folder), and yields the default configuration of
    each sensor (`resources/config.json` of the FMU it ran) and the folder of those FMUs.

    Returns ({sensor: default configuration}, FMU folder)."""
    with tempfile.TemporaryDirectory(prefix="osiris-sweep-preflight-") as tmp:
        cmd = [osiris, "run", "--sensors", ",".join(sensors), "--max-frames", "1", "--quiet", "--out", tmp]
        if fmu_dir:
            cmd += ["--fmu-dir", fmu_dir]
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
        if r.returncode != 0:
            raise SetupFailed(f"`{' '.join(cmd)}` (preflight) failed ({r.returncode}): {r.stderr.strip()[-2000:]}")
        summary = json.loads(Path(tmp, "summary.json").read_text())
    out = {}
    for s in summary.get("sensors", []):
        kind = s.get("kind")
        if kind in sensors and kind not in out:
            with zipfile.ZipFile(s["fmu"]) as z:
                out[kind] = json.loads(z.read("resources/config.json"))
    missing = [s for s in sensors if s not in out]
    if missing:
        raise SetupFailed(f"preflight run reported no FMU for {missing}")
    dirs = {str(Path(s["fmu"]).parent) for s in summary["sensors"] if s.get("kind") in sensors}
    return out, fmu_dir or (dirs.pop() if len(dirs) == 1 else None)


def deep_merge(base: dict, over: dict) -> dict:
    out = copy.deepcopy(base)
    for k, v in over.items():
        if isinstance(v, dict) and isinstance(out.get(k), dict):
            out[k] = deep_merge(out[k], v)
        else:
            out[k] = copy.deepcopy(v)
    return out


def _param_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    return str(v)


def invocations(variant: dict, osiris: str, out_root: str, scenario_path: str) -> list[tuple[list[str], str]]:
    """The `osiris run` command lines of a variant and their output folders. One run for all
    sensors; one per sensor when the variant overrides the sensor configuration (`--param config`
    goes to every built-in sensor, and a configuration names its kind)."""
    per_sensor = bool(variant["config"]) and len(variant["sensors"]) > 1
    groups = [[s] for s in variant["sensors"]] if per_sensor else [list(variant["sensors"])]
    cmds = []
    for i, group in enumerate(groups):
        out = os.path.join(out_root, f"run{i}")
        cmd = [osiris, "run", "--scenario", scenario_path, "--sensors", ",".join(group),
               "--out", out, "--quiet", "--format", "osi"]
        if variant.get("fmu_dir"):
            cmd += ["--fmu-dir", variant["fmu_dir"]]
        if variant.get("max_frames"):
            cmd += ["--max-frames", str(variant["max_frames"])]
        for k in sorted(variant["fmu_params"]):
            cmd += ["--param", f"{k}={_param_value(variant['fmu_params'][k])}"]
        if variant["config"]:
            defaults = variant.get("config_defaults", {}).get(group[0])
            if defaults is None:
                raise RunFailed(f"no default configuration of the {group[0]} sensor to merge into")
            cfg = deep_merge(defaults, variant["config"])
            cmd += ["--param", "config=" + json.dumps(cfg, separators=(",", ":"))]
        cmds.append((cmd, out))
    return cmds


def run_variant(variant: dict, osiris: str, range_bins_m: list[float], require_kpi: bool = True) -> dict:
    """One variant (a Dask task): write its scenario, run osiris, aggregate the KPI tables.

    Returns {"hash", "rows", "errors", "wall_s", "osiris_wall_s", "host", "pid"}; raises RunFailed with the
    tail of osiris' error output when a run fails, so that Dask retries the task."""
    t0 = time.perf_counter()
    if not os.access(osiris, os.X_OK):
        # The client's path does not exist on this worker (another machine): osiris on its PATH.
        osiris = shutil.which("osiris") or osiris
    tmp = tempfile.mkdtemp(prefix=f"osiris-sweep-{variant['hash']}-")
    try:
        scenario_path = os.path.join(tmp, "scenario.json")
        with open(scenario_path, "w") as f:
            json.dump(variant["scenario"], f, indent=1)
        objects, frames = [], []
        osiris_wall = 0.0
        for cmd, out in invocations(variant, osiris, tmp, scenario_path):
            t1 = time.perf_counter()
            try:
                r = subprocess.run(cmd, capture_output=True, text=True, timeout=variant["timeout_s"])
            except subprocess.TimeoutExpired:
                raise RunFailed(f"osiris run timed out after {variant['timeout_s']} s") from None
            osiris_wall += time.perf_counter() - t1
            if r.returncode != 0:
                tail = "\n".join(r.stderr.strip().splitlines()[-6:])
                raise RunFailed(f"osiris run exited with status {r.returncode}: {tail}")
            obj_csv, frm_csv = os.path.join(out, "objects.csv"), os.path.join(out, "frames.csv")
            if not (os.path.isfile(obj_csv) and os.path.isfile(frm_csv)):
                if require_kpi:
                    raise RunFailed(
                        f"osiris run wrote no objects.csv / frames.csv in its --out folder "
                        f"(this osiris binary predates the KPI tables): {osiris}"
                    )
                continue
            objects.append(aggregate.read_objects(obj_csv))
            frames.append(aggregate.read_frames(frm_csv))
        rows = aggregate.variant_rows(objects, frames, range_bins_m) if objects else []
        return {
            "hash": variant["hash"],
            "rows": rows,
            "errors": aggregate.error_samples(objects),
            "wall_s": time.perf_counter() - t0,
            "osiris_wall_s": osiris_wall,
            "host": os.uname().nodename,
            "pid": os.getpid(),
        }
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
