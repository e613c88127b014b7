"""report.html of the default `osiris run` in a headless Chromium: the page renders (a screenshot
that is not blank), every sensor has its section, and the page's own check
(`document.body.dataset.rendered`) names every section whose images and plots loaded with a
non-zero size.

Chromium is required under CI=true (.ci/run installs it); elsewhere the test is skipped without it.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import struct
import subprocess
import zlib
from pathlib import Path

import pytest


def _chromium() -> str:
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        exe = shutil.which(name)
        if exe:
            return exe
    if os.environ.get("CI") == "true":
        pytest.fail("chromium is missing: .ci/run installs it (apt-get install chromium)")
    pytest.skip("chromium is not installed (apt-get install chromium)")
    raise AssertionError("unreachable")


def _headless(exe: str, *args: str, timeout: int = 120) -> subprocess.CompletedProcess:
    cmd = [
        exe,
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-dev-shm-usage",
        "--hide-scrollbars",
        "--window-size=1280,2400",
        *args,
    ]
    proc = subprocess.run(cmd, capture_output=True, timeout=timeout, check=False)
    assert proc.returncode == 0, f"{' '.join(cmd)} exited {proc.returncode}:\n{proc.stderr.decode(errors='replace')[-4000:]}"
    return proc


def _png_grey_levels(path: Path) -> tuple[int, int, list[int]]:
    """Width, height and one grey level per pixel of every 4th row and column of an 8-bit RGB(A) or
    grey PNG (stdlib only: zlib and the PNG row filters)."""
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", f"{path} is not a PNG"
    pos, idat = 8, b""
    width = height = channels = 0
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos : pos + 4])
        kind = data[pos + 4 : pos + 8]
        body = data[pos + 8 : pos + 8 + length]
        if kind == b"IHDR":
            width, height, depth, colour, _, _, interlace = struct.unpack(">IIBBBBB", body)
            assert depth == 8 and interlace == 0, f"unsupported PNG: depth {depth}, interlace {interlace}"
            channels = {0: 1, 2: 3, 4: 2, 6: 4}[colour]
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    raw = zlib.decompress(idat)
    stride = width * channels
    prev = bytearray(stride)
    levels = []
    for y in range(height):
        row_start = y * (stride + 1)
        ftype = raw[row_start]
        line = bytearray(raw[row_start + 1 : row_start + 1 + stride])
        if ftype == 1:
            for i in range(channels, stride):
                line[i] = (line[i] + line[i - channels]) & 0xFF
        elif ftype == 2:
            line = bytearray((a + b) & 0xFF for a, b in zip(line, prev))
        elif ftype == 3:
            for i in range(stride):
                left = line[i - channels] if i >= channels else 0
                line[i] = (line[i] + ((left + prev[i]) >> 1)) & 0xFF
        elif ftype == 4:
            for i in range(stride):
                a = line[i - channels] if i >= channels else 0
                b = prev[i]
                c = prev[i - channels] if i >= channels else 0
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                line[i] = (line[i] + pred) & 0xFF
        if y % 4 == 0:
            for x in range(0, width, 4):
                px = line[x * channels : x * channels + min(channels, 3)]
                levels.append(sum(px) // len(px))
        prev = line
    return width, height, levels


@pytest.fixture(scope="module")
def report(default_run):
    path = default_run.out / "report.html"
    assert path.is_file(), f"osiris run wrote no {path}"
    summary = json.loads((default_run.out / "summary.json").read_text())
    assert Path(summary["report"]).resolve() == path.resolve()
    sensors = [s["sensor"] for s in summary["sensors"]]
    assert sensors, summary
    return path, sensors


def test_report_renders_in_headless_chromium(report, tmp_path):
    exe = _chromium()
    path, sensors = report
    url = path.resolve().as_uri()

    shot = tmp_path / "report.png"
    _headless(exe, f"--screenshot={shot}", url)
    assert shot.is_file() and shot.stat().st_size > 0, "no screenshot"
    width, height, levels = _png_grey_levels(shot)
    assert (width, height) == (1280, 2400), (width, height)
    # Not blank: dark text and plot lines, light background, colours in between.
    assert max(levels) - min(levels) > 100, (min(levels), max(levels))
    distinct = len(set(levels))
    assert distinct > 20, f"only {distinct} grey levels: a blank or failed page?"

    dom = _headless(exe, "--virtual-time-budget=5000", "--dump-dom", url).stdout.decode(errors="replace")
    for name in sensors:
        assert f'data-sensor="{name}"' in dom, f"no section of {name}"
    m = re.search(r'<body[^>]*data-rendered="([^"]*)"', dom)
    assert m, "the page's render check did not run (no data-rendered on <body>)"
    rendered = set(filter(None, m.group(1).split(",")))
    assert rendered == set(sensors), f"rendered {sorted(rendered)}, sensors {sorted(sensors)}"
