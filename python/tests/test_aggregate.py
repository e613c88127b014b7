"""Aggregation of the KPI tables against numbers computed by hand from fixtures/*.csv."""

import math

import pytest

from osiris_sweep import aggregate

from .conftest import FIXTURES

EDGES = [0.0, 25.0, 50.0, 100.0]


@pytest.fixture
def rows():
    objects = [aggregate.read_objects(FIXTURES / "objects.csv")]
    frames = [aggregate.read_frames(FIXTURES / "frames.csv")]
    return aggregate.variant_rows(objects, frames, EDGES)


def by_key(rows):
    return {(r["sensor"], r["gt_id"], r["range_bin"]): r for r in rows}


def test_bins():
    assert aggregate.bin_of(0.0, EDGES) == (0.0, 25.0)
    assert aggregate.bin_of(25.0, EDGES) == (25.0, 50.0)  # [lo, hi)
    assert aggregate.bin_of(99.9, EDGES) == (50.0, 100.0)
    assert aggregate.bin_of(100.0, EDGES) == (100.0, math.inf)
    assert aggregate.bin_of(-1.0, EDGES) is None
    assert aggregate.bin_label(100.0, math.inf) == "[100,inf)"


def test_rows_per_object_and_bin(rows):
    k = by_key(rows)
    assert sorted(k) == [
        ("front_lidar", None, None),
        ("front_radar", 100, "[0,25)"),
        ("front_radar", 100, "[25,50)"),
        ("front_radar", 100, "[50,100)"),
        ("front_radar", 101, "[100,inf)"),
        ("front_radar", 101, "[50,100)"),
    ]
    # car 100 at 40 m and 45 m: both detected, range errors 0.5 and -0.3, range-rate 0.1 and -0.2
    r = k[("front_radar", 100, "[25,50)")]
    assert (r["frames_in_bin"], r["frames_detected"], r["detection_probability"]) == (2, 2, 1.0)
    assert r["range_error_mean_m"] == pytest.approx(0.1)
    assert r["range_error_rms_m"] == pytest.approx(math.sqrt((0.25 + 0.09) / 2))  # 0.41231
    assert r["range_rate_error_mean_mps"] == pytest.approx(-0.05)
    assert r["gt_type"] == "car"
    # car 100 at 50 m (bin [50,100)): missed; no errors
    r = k[("front_radar", 100, "[50,100)")]
    assert (r["frames_in_bin"], r["frames_detected"], r["detection_probability"]) == (1, 0, 0.0)
    assert r["range_error_mean_m"] is None and r["range_error_rms_m"] is None
    # car 100 at 10 m
    r = k[("front_radar", 100, "[0,25)")]
    assert (r["frames_in_bin"], r["frames_detected"], r["range_error_rms_m"]) == (1, 1, 0.0)
    # truck 101 at 80 m (missed) and 79 m (detected, +1.0 m, +0.4 m/s)
    r = k[("front_radar", 101, "[50,100)")]
    assert (r["frames_in_bin"], r["frames_detected"], r["detection_probability"]) == (2, 1, 0.5)
    assert r["range_error_mean_m"] == pytest.approx(1.0)
    assert r["range_error_rms_m"] == pytest.approx(1.0)
    assert r["range_rate_error_mean_mps"] == pytest.approx(0.4)
    # truck 101 at 120 m: beyond the last edge, detected, no range-rate error cell
    r = k[("front_radar", 101, "[100,inf)")]
    assert (r["range_lo_m"], r["range_hi_m"]) == (100.0, math.inf)
    assert r["range_error_mean_m"] == pytest.approx(2.0)
    assert r["range_rate_error_mean_mps"] is None


def test_per_run_columns(rows):
    k = by_key(rows)
    radar = k[("front_radar", 100, "[25,50)")]
    # 4 radar frames, false alarms 1 + 0 + 2 + 1 = 4; steps 10, 20, 30, 40 ms
    assert radar["sensor_frames"] == 4
    assert radar["false_alarms_per_frame"] == pytest.approx(1.0)
    assert radar["step_ms_mean"] == pytest.approx(25.0)
    assert radar["step_ms_max"] == pytest.approx(40.0)
    # the LiDAR saw no object: one row with its per-run figures (3 false alarms / 2 frames)
    lidar = k[("front_lidar", None, None)]
    assert lidar["sensor_frames"] == 2
    assert lidar["false_alarms_per_frame"] == pytest.approx(1.5)
    assert (lidar["step_ms_mean"], lidar["step_ms_max"]) == (pytest.approx(6.0), 7.0)
    assert lidar["frames_in_bin"] is None


def test_error_samples():
    e = aggregate.error_samples([aggregate.read_objects(FIXTURES / "objects.csv")])
    assert e["front_radar"]["range_error_m"] == [0.5, -0.3, 1.0, 2.0, 0.0]
    assert e["front_radar"]["range_rate_error_mps"] == [0.1, -0.2, 0.4, 0.0]


def test_missing_column(tmp_path):
    p = tmp_path / "objects.csv"
    p.write_text("sensor,frame\nfront_radar,0\n")
    with pytest.raises(aggregate.KpiError, match="missing columns"):
        aggregate.read_objects(p)
