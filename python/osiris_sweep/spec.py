"""Sweep specification: TOML parsing, validation, grid/random designs, variant hashes.

A spec (see docs/sweep.md) names the sensors, a base scenario with fixed changes, and the swept
parameters under three prefixes:

* ``scenario.<dotted path>``: a value in the scenario JSON (``scenario.road_users.0.x_m``);
* ``config.<dotted path>``: a key of the sensor configuration (``config.seed``,
  ``config.weather.rain_mm_h``), merged into each sensor's default configuration and passed to
  ``osiris run --param config={...}``;
* ``param.<name>``: an FMU parameter (``param.range_m``, ``param.mode``), ``--param name=value``.

Every error is a :class:`SpecError` whose message names the offending key.
"""

from __future__ import annotations

import copy
import hashlib
import itertools
import json
import math
import random
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

SENSORS = ("camera", "radar", "lidar")
PREFIXES = ("scenario", "config", "param")

SWEEP_KEYS = {
    "name": str,
    "sensors": list,
    "design": str,
    "samples": int,
    "seed": int,
    "range_bins_m": list,
    "max_frames": int,
    "timeout_s": (int, float),
}
SCENARIO_KEYS = {"file": str, "set": dict}
TOP_KEYS = ("sweep", "scenario", "parameters")

# Top-level keys of the sensor configuration (models/src/registry.rs, `SensorConfig`; unknown
# keys are rejected there too, this only reports them before any run).
CONFIG_KEYS = (
    "mode",
    "range_m",
    "fov_horizontal_rad",
    "fov_vertical_rad",
    "update_cycle_s",
    "mounting",
    "calibration",
    "min_visible_fraction",
    "effects",
    "weather",
    "seed",
    "lidar",
    "radar",
    "camera",
    "include_sensor_view",
)

# Optional scenario keys that the printed scenario JSON omits while they are unset
# (scenario/src/lib.rs: `skip_serializing_if = "Option::is_none"`), by the kind of their parent.
_OPTIONAL_SCENARIO_KEYS = {
    "": {"guardrail"},
    "environment": {"fog_visibility_m"},
    "road_user": {"id", "model_reference", "dimension_m"},
    "static_object": {"id", "z_m", "model_reference", "dimension_m"},
    "guardrail": {"length_m", "id"},
    "sensor": {"mounting"},
}


class SpecError(ValueError):
    """An invalid sweep specification (exit status 2)."""


def _type_name(t) -> str:
    if isinstance(t, tuple):
        return " or ".join(_type_name(x) for x in t)
    return {str: "a string", int: "an integer", float: "a number", list: "a list", dict: "a table"}[t]


def _check_type(key: str, value, t) -> None:
    ok = isinstance(value, t) and not (isinstance(value, bool) and t in (int, (int, float)))
    if not ok:
        raise SpecError(f"{key}: expected {_type_name(t)}, got {type(value).__name__} {value!r}")


def _parent_kind(parts: list[str]) -> str:
    """The kind of object the path `parts` points to (for the optional-key table)."""
    if not parts:
        return ""
    if parts == ["environment"]:
        return "environment"
    if parts == ["ego"] or (len(parts) == 2 and parts[0] == "road_users"):
        return "road_user"
    if len(parts) == 2 and parts[0] == "static_objects":
        return "static_object"
    if parts == ["guardrail"]:
        return "guardrail"
    if len(parts) == 2 and parts[0] == "sensors":
        return "sensor"
    return "?"


def set_path(doc: dict, path: str, value, *, key: str, optional: dict | None = None) -> None:
    """Set `path` (dotted; list indices as numbers) in `doc`; the path must exist, except for a
    missing optional key (`optional`: parent kind -> keys) whose parents are then created.

    Raises SpecError naming `key` (the spec key) and the first missing part."""
    parts = path.split(".")
    if not path or any(p == "" for p in parts):
        raise SpecError(f"{key}: empty part in the dotted path {path!r}")
    node = doc
    free = False  # below an absent optional key: parts are created
    for i, part in enumerate(parts):
        last = i == len(parts) - 1
        where = ".".join(parts[:i]) or "the top level"
        if isinstance(node, list):
            try:
                idx = int(part)
            except ValueError:
                raise SpecError(f"{key}: {where} is a list; expected an index, got {part!r}") from None
            if not 0 <= idx < len(node):
                raise SpecError(f"{key}: index {idx} out of range: {where} has {len(node)} entries")
            if last:
                node[idx] = value
                return
            node = node[idx]
        elif isinstance(node, dict):
            if part not in node:
                allowed = (optional or {}).get(_parent_kind(parts[:i]), set())
                if not (free or part in allowed):
                    have = ", ".join(sorted(node)) or "nothing"
                    raise SpecError(
                        f"{key}: the scenario has no {'.'.join(parts[: i + 1])!r} ({where} has: {have})"
                    )
                free = True
                if not last:
                    node[part] = {}
            if last:
                node[part] = value
                return
            node = node[part]
        else:
            raise SpecError(
                f"{key}: {where} is a {type(node).__name__}, not a table or list; "
                f"cannot descend into {part!r}"
            )


_MISSING = object()


def get_path(doc, path: str):
    """The value at a dotted path, or _MISSING."""
    node = doc
    for part in path.split("."):
        if isinstance(node, list) and part.isdigit() and int(part) < len(node):
            node = node[int(part)]
        elif isinstance(node, dict) and part in node:
            node = node[part]
        else:
            return _MISSING
    return node


def _kind(v) -> str:
    if isinstance(v, bool):
        return "a boolean"
    if isinstance(v, (int, float)):
        return "a number"
    if isinstance(v, str):
        return "a string"
    if isinstance(v, list):
        return "a list"
    if isinstance(v, dict):
        return "a table"
    return type(v).__name__


def _check_value_types(axis: "Axis", current) -> None:
    """Swept scenario values must have the type of the value they replace (a number for a number)."""
    if current is _MISSING or current is None:
        return
    want = _kind(current)
    candidates = axis.values if axis.values is not None else [axis.low, axis.high]
    for v in candidates:
        if _kind(v) != want:
            raise SpecError(
                f"parameters.{axis.key!r}: value {v!r} is {_kind(v)}, but the scenario's "
                f"{axis.path} is {want} ({current!r})"
            )


def merge_dotted(doc: dict, parts: list[str], value) -> None:
    """Set a path (its parts) in a nested dict, creating tables on the way (sensor configuration)."""
    node = doc
    for part in parts[:-1]:
        if not isinstance(node.get(part), dict):
            node[part] = {}
        node = node[part]
    node[parts[-1]] = value


def flatten(table: dict, prefix: str = "") -> dict:
    """`{"a": {"b": 1}, "c.d": 2}` -> `{"a.b": 1, "c.d": 2}` (lists stay values)."""
    out = {}
    for k, v in table.items():
        name = f"{prefix}.{k}" if prefix else str(k)
        if isinstance(v, dict):
            out.update(flatten(v, name))
        else:
            out[name] = v
    return out


@dataclass
class Axis:
    """One swept parameter: grid values, or a random distribution."""

    key: str  # "scenario.road_users.0.x_m"
    parts: list[str] | None = None  # the path after the prefix (a TOML key part may hold dots)
    values: list | None = None  # grid, or random choices
    low: float | None = None
    high: float | None = None
    integer: bool = False

    @property
    def prefix(self) -> str:
        return self.key.split(".", 1)[0]

    @property
    def path(self) -> str:
        return self.key.split(".", 1)[1]

    def sample(self, rng: random.Random):
        if self.values is not None:
            return rng.choice(self.values)
        if self.integer:
            return rng.randint(int(self.low), int(self.high))
        return rng.uniform(self.low, self.high)


@dataclass
class Spec:
    name: str
    sensors: list[str]
    design: str
    axes: list[Axis]
    range_bins_m: list[float]
    scenario_file: Path | None = None
    scenario_set: dict = field(default_factory=dict)
    samples: int | None = None
    seed: int | None = None
    max_frames: int | None = None
    timeout_s: float = 600.0
    source: Path | None = None


@dataclass
class Variant:
    """One run of the sweep: the resolved inputs and its stable hash."""

    hash: str
    params: dict  # spec key -> value, e.g. {"scenario.environment.rain_mm_h": 16.0}
    sensors: list[str]
    scenario: dict
    fmu_params: dict  # name -> value
    config: dict  # nested overrides of the sensor configuration
    max_frames: int | None
    timeout_s: float


def _load_toml(path: Path) -> dict:
    try:
        with open(path, "rb") as f:
            return tomllib.load(f)
    except FileNotFoundError:
        raise SpecError(f"{path}: no such file") from None
    except tomllib.TOMLDecodeError as e:
        raise SpecError(f"{path}: TOML syntax error: {e}") from None


def _number(key: str, v) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise SpecError(f"{key}: expected a number, got {type(v).__name__} {v!r}")
    return v


def _parse_axis(key: str, value, design: str) -> Axis:
    where = f"parameters.{key!r}" if "." in key else f"parameters.{key}"
    prefix = key.split(".", 1)[0]
    if prefix not in PREFIXES or "." not in key:
        raise SpecError(
            f"{where}: unknown parameter; expected scenario.<dotted path>, config.<key> or "
            f"param.<FMU parameter>"
        )
    path = key.split(".", 1)[1]
    if prefix == "config":
        top = path.split(".", 1)[0]
        if top == "kind":
            raise SpecError(f"{where}: the sensor kind comes from [sweep] sensors, not config.kind")
        if top not in CONFIG_KEYS:
            raise SpecError(
                f"{where}: unknown sensor configuration key {top!r} (known: {', '.join(CONFIG_KEYS)})"
            )
    if prefix == "param" and ("." in path or path == "config"):
        raise SpecError(
            f"{where}: param.<name> takes one FMU parameter name"
            + ("; sweep the configuration with config.<key>" if path == "config" else "")
        )
    if isinstance(value, list):
        if not value:
            raise SpecError(f"{where}: empty list")
        return Axis(key, values=list(value))
    if design == "grid":
        raise SpecError(f"{where}: a grid design takes a list of values, got {type(value).__name__} {value!r}")
    if isinstance(value, dict):
        unknown = set(value) - {"min", "max", "choices"}
        if unknown:
            raise SpecError(f"{where}: unknown key {sorted(unknown)[0]!r} (expected min/max or choices)")
        if "choices" in value:
            if set(value) != {"choices"}:
                raise SpecError(f"{where}: choices cannot be combined with min/max")
            if not isinstance(value["choices"], list) or not value["choices"]:
                raise SpecError(f"{where}.choices: expected a non-empty list")
            return Axis(key, values=list(value["choices"]))
        if set(value) != {"min", "max"}:
            raise SpecError(f"{where}: a random range needs both min and max")
        lo = _number(f"{where}.min", value["min"])
        hi = _number(f"{where}.max", value["max"])
        if not lo <= hi:
            raise SpecError(f"{where}: min {lo} > max {hi}")
        return Axis(key, low=lo, high=hi, integer=isinstance(lo, int) and isinstance(hi, int))
    raise SpecError(
        f"{where}: a random design takes a list, {{min, max}} or {{choices = [...]}}, "
        f"got {type(value).__name__} {value!r}"
    )


def parse_spec(doc: dict, source: Path | None = None) -> Spec:
    """Check the structure and types of a parsed spec (no scenario paths yet)."""
    for k in doc:
        if k not in TOP_KEYS:
            raise SpecError(f"{k}: unknown table (expected {', '.join(TOP_KEYS)})")
    sweep = doc.get("sweep")
    if sweep is None:
        raise SpecError("sweep: missing table [sweep]")
    _check_type("sweep", sweep, dict)
    for k, v in sweep.items():
        if k not in SWEEP_KEYS:
            raise SpecError(f"sweep.{k}: unknown key (expected {', '.join(SWEEP_KEYS)})")
        _check_type(f"sweep.{k}", v, SWEEP_KEYS[k])
    name = sweep.get("name", source.stem if source else "sweep")
    sensors = sweep.get("sensors", ["radar"])
    if not sensors:
        raise SpecError("sweep.sensors: empty list")
    for s in sensors:
        if s not in SENSORS:
            raise SpecError(f"sweep.sensors: unknown sensor {s!r} (expected {', '.join(SENSORS)})")
    if len(set(sensors)) != len(sensors):
        raise SpecError("sweep.sensors: a sensor is listed twice")
    design = sweep.get("design", "grid")
    if design not in ("grid", "random"):
        raise SpecError(f"sweep.design: expected \"grid\" or \"random\", got {design!r}")
    if design == "random":
        if "samples" not in sweep:
            raise SpecError("sweep.samples: a random design needs samples = N")
        if sweep["samples"] < 1:
            raise SpecError(f"sweep.samples: expected >= 1, got {sweep['samples']}")
    else:
        for k in ("samples", "seed"):
            if k in sweep:
                raise SpecError(f"sweep.{k}: only for design = \"random\"")
    bins = sweep.get("range_bins_m", [0, 25, 50, 75, 100, 150, 200])
    if len(bins) < 2:
        raise SpecError("sweep.range_bins_m: expected at least two bin edges")
    for b in bins:
        _number("sweep.range_bins_m", b)
    if any(b >= a for a, b in zip(bins[1:], bins[:-1])) or any(not math.isfinite(b) for b in bins):
        raise SpecError(f"sweep.range_bins_m: edges must be finite and increasing, got {bins}")
    if "max_frames" in sweep and sweep["max_frames"] < 1:
        raise SpecError(f"sweep.max_frames: expected >= 1, got {sweep['max_frames']}")
    if "timeout_s" in sweep and sweep["timeout_s"] <= 0:
        raise SpecError(f"sweep.timeout_s: expected > 0, got {sweep['timeout_s']}")

    scen = doc.get("scenario", {})
    _check_type("scenario", scen, dict)
    for k, v in scen.items():
        if k not in SCENARIO_KEYS:
            raise SpecError(f"scenario.{k}: unknown key (expected {', '.join(SCENARIO_KEYS)})")
        _check_type(f"scenario.{k}", v, SCENARIO_KEYS[k])
    scenario_file = None
    if "file" in scen:
        scenario_file = Path(scen["file"])
        if not scenario_file.is_absolute() and source is not None:
            scenario_file = source.parent / scenario_file

    params = doc.get("parameters", {})
    _check_type("parameters", params, dict)
    # A bare TOML key `scenario.environment.rain_mm_h = [...]` is a nested table; quoted keys stay
    # dotted. Both mean the same.
    flat = {}

    def walk(table, prefix: tuple):
        for k, v in table.items():
            name = (*prefix, str(k))
            if isinstance(v, dict) and not (v and set(v) <= {"min", "max", "choices"}):
                walk(v, name)
            else:
                flat[name] = v

    walk(params, ())
    axes = []
    for parts, v in flat.items():
        if len(parts) == 1:  # a quoted "prefix.a.b" key
            parts = tuple(parts[0].split("."))
        axis = _parse_axis(".".join(parts), v, design)
        axis.parts = list(parts[1:])
        axes.append(axis)
    return Spec(
        name=name,
        sensors=list(sensors),
        design=design,
        axes=axes,
        range_bins_m=[float(b) for b in bins],
        scenario_file=scenario_file,
        scenario_set=flatten(scen.get("set", {})),
        samples=sweep.get("samples"),
        seed=sweep.get("seed"),
        max_frames=sweep.get("max_frames"),
        timeout_s=float(sweep.get("timeout_s", 600.0)),
        source=source,
    )


def load_spec(path: str | Path) -> Spec:
    path = Path(path)
    return parse_spec(_load_toml(path), source=path)


def design_points(spec: Spec) -> list[dict]:
    """The parameter combinations: the full grid (in spec order, last key fastest) or `samples`
    draws from a `random.Random(seed)` (the same seed gives the same points)."""
    if spec.design == "grid":
        keys = [a.key for a in spec.axes]
        return [dict(zip(keys, combo)) for combo in itertools.product(*(a.values for a in spec.axes))]
    rng = random.Random(spec.seed if spec.seed is not None else 0)
    return [{a.key: a.sample(rng) for a in spec.axes} for _ in range(spec.samples)]


def canonical_json(obj) -> str:
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), ensure_ascii=True, allow_nan=False)


def variant_hash(sensors, scenario: dict, fmu_params: dict, config: dict, max_frames) -> str:
    """Stable key of a variant: SHA-256 (first 16 hex digits) of the canonical JSON of everything
    that goes into its run (the resolved scenario, sensors, FMU parameters, configuration
    overrides, frame limit). Independent of the spec's key order and of Python's hash seed."""
    payload = {
        "v": 1,
        "sensors": list(sensors),
        "scenario": scenario,
        "param": {k: fmu_params[k] for k in sorted(fmu_params)},
        "config": config,
        "max_frames": max_frames,
    }
    return hashlib.sha256(canonical_json(payload).encode()).hexdigest()[:16]


def resolve_variants(spec: Spec, base_scenario: dict, fmu_param_names: dict | None = None) -> list[Variant]:
    """Expand the design into variants over `base_scenario` (the scenario JSON as a dict).

    Checks every scenario path against the base scenario and, if `fmu_param_names` (sensor ->
    set of names) is given, every `param.` name against the sensors' FMU parameters."""
    base = copy.deepcopy(base_scenario)
    for k, v in spec.scenario_set.items():
        set_path(base, k, v, key=f"scenario.set.{k}", optional=_OPTIONAL_SCENARIO_KEYS)
    for axis in spec.axes:
        if axis.prefix == "scenario":
            probe = copy.deepcopy(base)
            set_path(probe, axis.path, None, key=f"parameters.{axis.key!r}", optional=_OPTIONAL_SCENARIO_KEYS)
            _check_value_types(axis, get_path(base, axis.path))
        if axis.prefix == "param" and fmu_param_names is not None:
            for s in spec.sensors:
                names = fmu_param_names.get(s, set())
                if axis.path not in names:
                    raise SpecError(
                        f"parameters.{axis.key!r}: the {s} FMU has no parameter {axis.path!r} "
                        f"(it has: {', '.join(sorted(names))})"
                    )
    variants = []
    seen = set()
    for point in design_points(spec):
        scenario = copy.deepcopy(base)
        fmu_params, config = {}, {}
        for axis in spec.axes:
            value = point[axis.key]
            if axis.prefix == "scenario":
                set_path(scenario, axis.path, value, key=f"parameters.{axis.key!r}",
                         optional=_OPTIONAL_SCENARIO_KEYS)
            elif axis.prefix == "config":
                merge_dotted(config, axis.parts or axis.path.split("."), value)
            else:
                fmu_params[axis.path] = value
        h = variant_hash(spec.sensors, scenario, fmu_params, config, spec.max_frames)
        if h in seen:  # a random design over choices can draw the same point twice
            continue
        seen.add(h)
        variants.append(
            Variant(
                hash=h,
                params=dict(point),
                sensors=list(spec.sensors),
                scenario=scenario,
                fmu_params=fmu_params,
                config=config,
                max_frames=spec.max_frames,
                timeout_s=spec.timeout_s,
            )
        )
    return variants
