import json
import os
import stat
from pathlib import Path

import pytest

from osiris_sweep import runner

FIXTURES = Path(__file__).parent / "fixtures"
REPO = Path(__file__).resolve().parents[2]


@pytest.fixture
def base_scenario():
    """`osiris scenario` as of writing (tests of the spec need no binary)."""
    return json.loads((FIXTURES / "base_scenario.json").read_text())


@pytest.fixture(scope="session")
def osiris_bin():
    """The osiris binary (--osiris / $OSIRIS_BIN / PATH / ./target/release/osiris). Missing: the
    end-to-end tests fail under CI=true and are skipped elsewhere."""
    cwd = os.getcwd()
    try:
        os.chdir(REPO)
        return runner.find_osiris(None)
    except runner.BinaryNotFound as e:
        if os.environ.get("CI") == "true":
            pytest.fail(f"CI=true and no osiris binary: {e}")
        pytest.skip(f"no osiris binary: {e}")
    finally:
        os.chdir(cwd)


@pytest.fixture
def counting_osiris(osiris_bin, tmp_path):
    """A wrapper of the osiris binary that logs every invocation (one line of arguments) before it
    execs the real one. Returns (wrapper path, log path)."""
    log = tmp_path / "osiris-invocations.log"
    wrapper = tmp_path / "osiris-wrapper"
    wrapper.write_text(f'#!/bin/sh\necho "$*" >> "{log}"\nexec "{osiris_bin}" "$@"\n')
    wrapper.chmod(wrapper.stat().st_mode | stat.S_IXUSR | stat.S_IXGRP | stat.S_IXOTH)
    return str(wrapper), log


def scenario_runs(log: Path) -> int:
    """`osiris run --scenario ...` invocations (variant runs) in a wrapper log."""
    if not log.exists():
        return 0
    return sum(1 for line in log.read_text().splitlines() if line.startswith("run --scenario"))


