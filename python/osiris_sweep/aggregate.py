"""KPI tables of one `osiris run` (objects.csv, frames.csv) -> result rows.

objects.csv: sensor,frame,time_s,gt_id,gt_type,gt_range_m,gt_azimuth_deg,gt_range_rate_mps,detected,
tracking_id,det_range_m,range_error_m,det_range_rate_mps,range_rate_error_mps,existence_probability
(one row per sensor, SensorData frame and ground-truth object in the field of view; error cells
empty when not detected).

frames.csv: sensor,frame,time_s,ground_truth_in_fov,detected_objects,matched_objects,false_alarms,
feature_detections,step_wall_ms.

One result row per (sensor, ground-truth object, range bin): bins are [lo, hi) over
`gt_range_m` with the edges of `range_bins_m`, plus [last edge, inf); ranges below the first edge
are left out. Per-run columns (false alarms per frame, step time) are per sensor.
"""

from __future__ import annotations

import csv
import math

OBJECT_COLUMNS = (
    "sensor", "frame", "time_s", "gt_id", "gt_type", "gt_range_m", "gt_azimuth_deg",
    "gt_range_rate_mps", "detected", "tracking_id", "det_range_m", "range_error_m",
    "det_range_rate_mps", "range_rate_error_mps", "existence_probability",
)
FRAME_COLUMNS = (
    "sensor", "frame", "time_s", "ground_truth_in_fov", "detected_objects", "matched_objects",
    "false_alarms", "feature_detections", "step_wall_ms",
)
ROW_COLUMNS = (
    "sensor", "gt_id", "gt_type", "range_bin", "range_lo_m", "range_hi_m", "frames_in_bin",
    "frames_detected", "detection_probability", "range_error_mean_m", "range_error_rms_m",
    "range_rate_error_mean_mps", "sensor_frames", "false_alarms_per_frame", "step_ms_mean",
    "step_ms_max",
)


class KpiError(ValueError):
    pass


def _float(v: str) -> float | None:
    v = v.strip()
    return float(v) if v else None


def _read(path, columns) -> list[dict]:
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        missing = [c for c in columns if c not in (reader.fieldnames or [])]
        if missing:
            raise KpiError(f"{path}: missing columns {missing}")
        return list(reader)


def read_objects(path) -> list[dict]:
    rows = []
    for r in _read(path, OBJECT_COLUMNS):
        rows.append({
            "sensor": r["sensor"],
            "frame": int(r["frame"]),
            "gt_id": int(r["gt_id"]),
            "gt_type": r["gt_type"],
            "gt_range_m": float(r["gt_range_m"]),
            "detected": int(r["detected"]) != 0,
            "range_error_m": _float(r["range_error_m"]),
            "range_rate_error_mps": _float(r["range_rate_error_mps"]),
        })
    return rows


def read_frames(path) -> list[dict]:
    return [
        {
            "sensor": r["sensor"],
            "frame": int(r["frame"]),
            "false_alarms": int(r["false_alarms"]),
            "step_wall_ms": float(r["step_wall_ms"]),
        }
        for r in _read(path, FRAME_COLUMNS)
    ]


def bin_of(r: float, edges: list[float]) -> tuple[float, float] | None:
    if r < edges[0]:
        return None
    for lo, hi in zip(edges[:-1], edges[1:]):
        if r < hi:
            return (lo, hi)
    return (edges[-1], math.inf)


def bin_label(lo: float, hi: float) -> str:
    f = lambda x: "inf" if math.isinf(x) else f"{x:g}"  # noqa: E731
    return f"[{f(lo)},{f(hi)})"


def _mean(xs):
    return sum(xs) / len(xs) if xs else None


def _rms(xs):
    return math.sqrt(sum(x * x for x in xs) / len(xs)) if xs else None


def variant_rows(objects: list[list[dict]], frames: list[list[dict]], edges: list[float]) -> list[dict]:
    """Rows of one variant from the KPI tables of its run(s) (one list per `osiris run`)."""
    per_sensor = {}
    for table in frames:
        for f in table:
            s = per_sensor.setdefault(f["sensor"], {"frames": 0, "fa": 0, "steps": []})
            s["frames"] += 1
            s["fa"] += f["false_alarms"]
            s["steps"].append(f["step_wall_ms"])
    groups = {}
    for table in objects:
        for o in table:
            b = bin_of(o["gt_range_m"], edges)
            if b is None:
                continue
            g = groups.setdefault((o["sensor"], o["gt_id"], b), {"type": o["gt_type"], "n": 0, "det": 0,
                                                                   "re": [], "rre": []})
            g["n"] += 1
            if o["detected"]:
                g["det"] += 1
                if o["range_error_m"] is not None:
                    g["re"].append(o["range_error_m"])
                if o["range_rate_error_mps"] is not None:
                    g["rre"].append(o["range_rate_error_mps"])
    rows = []

    def sensor_cols(sensor):
        s = per_sensor.get(sensor)
        if not s or not s["frames"]:
            return {"sensor_frames": 0, "false_alarms_per_frame": None, "step_ms_mean": None, "step_ms_max": None}
        return {
            "sensor_frames": s["frames"],
            "false_alarms_per_frame": s["fa"] / s["frames"],
            "step_ms_mean": _mean(s["steps"]),
            "step_ms_max": max(s["steps"]),
        }

    for (sensor, gt_id, (lo, hi)), g in sorted(groups.items(), key=lambda kv: (kv[0][0], kv[0][1], kv[0][2][0])):
        rows.append({
            "sensor": sensor,
            "gt_id": gt_id,
            "gt_type": g["type"],
            "range_bin": bin_label(lo, hi),
            "range_lo_m": lo,
            "range_hi_m": hi,
            "frames_in_bin": g["n"],
            "frames_detected": g["det"],
            "detection_probability": g["det"] / g["n"],
            "range_error_mean_m": _mean(g["re"]),
            "range_error_rms_m": _rms(g["re"]),
            "range_rate_error_mean_mps": _mean(g["rre"]),
            **sensor_cols(sensor),
        })
    # A sensor that saw no object in its field of view still gets its per-run row.
    seen = {r["sensor"] for r in rows}
    for sensor in sorted(set(per_sensor) - seen):
        rows.append({**{c: None for c in ROW_COLUMNS}, "sensor": sensor, **sensor_cols(sensor)})
    return rows


def error_samples(objects: list[list[dict]]) -> dict:
    """Range and range-rate errors of every detected object row, per sensor (for the report)."""
    out = {}
    for table in objects:
        for o in table:
            if not o["detected"]:
                continue
            e = out.setdefault(o["sensor"], {"range_error_m": [], "range_rate_error_mps": []})
            if o["range_error_m"] is not None:
                e["range_error_m"].append(o["range_error_m"])
            if o["range_rate_error_mps"] is not None:
                e["range_rate_error_mps"].append(o["range_rate_error_mps"])
    return out
