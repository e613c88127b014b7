"""Shared fixtures of the Python outside checks (run: `pytest tests/python -q` from the repo root,
inside the venv made by `.ci/setup-python`)."""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


class OsiWire:
    """Runs `examples/osi_wire.rs` (built once per pytest session)."""

    def __init__(self, exe: Path):
        self.exe = exe

    def run(self, *args: str | Path, stdout_expected: bool = False) -> bytes:
        proc = subprocess.run([str(self.exe), *map(str, args)], capture_output=True, timeout=120, check=False)
        assert proc.returncode == 0, (
            f"osi_wire {' '.join(map(str, args))} exited {proc.returncode}:\n"
            f"{proc.stderr.decode(errors='replace')}"
        )
        # The example prints nothing unexpected: no warnings, no debug output.
        assert proc.stderr == b"", proc.stderr.decode(errors="replace")
        if not stdout_expected:
            assert proc.stdout == b"", proc.stdout.decode(errors="replace")
        return proc.stdout

    def run_fail(self, *args: str | Path) -> subprocess.CompletedProcess:
        return subprocess.run([str(self.exe), *map(str, args)], capture_output=True, timeout=120, check=False)

    def decode_json(self, type_name: str, path: Path) -> dict:
        out = self.run("decode", type_name, path, stdout_expected=True)
        assert out.endswith(b"\n") and out.count(b"\n") == 1, "expected exactly one JSON line"
        return json.loads(out)


def _build_osi_wire() -> Path:
    # Escape hatch for debugging the tests against a prebuilt binary.
    prebuilt = os.environ.get("OSIRIS_OSI_WIRE")
    if prebuilt:
        return Path(prebuilt)
    proc = subprocess.run(
        [
            "cargo",
            "build",
            "--example",
            "osi_wire",
            "--message-format=json-render-diagnostics",
        ],
        cwd=REPO,
        capture_output=True,
        timeout=3600,
        check=False,
    )
    if proc.returncode != 0:
        pytest.fail("cargo build --example osi_wire failed:\n" + proc.stderr.decode(errors="replace")[-6000:])
    exe = None
    for line in proc.stdout.decode().splitlines():
        try:
            msg = json.loads(line)
        except json.JSONDecodeError:
            continue
        if (
            msg.get("reason") == "compiler-artifact"
            and msg.get("target", {}).get("name") == "osi_wire"
            and msg.get("executable")
        ):
            exe = Path(msg["executable"])
    assert exe is not None and exe.is_file(), "cargo did not report the osi_wire executable"
    return exe


@pytest.fixture(scope="session")
def osi_wire() -> OsiWire:
    return OsiWire(_build_osi_wire())


class OsirisRun:
    """The output folder of one `osiris run` (default scenario unless `args` say otherwise)."""

    def __init__(self, out: Path):
        self.out = out

    def traces(self, type_code: str, suffix: str = ".osi") -> dict[str, Path]:
        """Trace files of one OSI type (`sd`, `sv`, ...) by the sensor name at the end of the
        file name (`front-radar`, ...)."""
        found = {}
        for p in sorted(self.out.glob(f"*_{type_code}_*{suffix}")):
            found[p.stem.split("_")[-1]] = p
        return found


def osiris_command() -> list[str]:
    """The `osiris` executable: `$OSIRIS_BIN`, else `cargo run --release --` from the repo."""
    exe = os.environ.get("OSIRIS_BIN")
    if exe:
        return [exe]
    return ["cargo", "run", "--quiet", "--release", "--"]


def run_osiris(out: Path, *args: str, timeout: int = 1800) -> OsirisRun:
    """`osiris run --out OUT ARGS`, with the packaged FMUs of `$OSIRIS_FMU_DIR` when set."""
    cmd = [*osiris_command(), "run", "--quiet", "--out", str(out), *args]
    fmu_dir = os.environ.get("OSIRIS_FMU_DIR")
    if fmu_dir:
        cmd += ["--fmu-dir", fmu_dir]
    proc = subprocess.run(cmd, cwd=REPO, capture_output=True, timeout=timeout, check=False)
    assert proc.returncode == 0, (
        f"{' '.join(cmd)} exited {proc.returncode}:\n{proc.stderr.decode(errors='replace')[-6000:]}"
    )
    return OsirisRun(out)


@pytest.fixture(scope="session")
def default_run(tmp_path_factory) -> OsirisRun:
    """The default `osiris run` (built-in scenario, all three sensors), once per pytest session."""
    return run_osiris(tmp_path_factory.mktemp("default-run"))
