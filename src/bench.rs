//! `osiris bench <what>`: performance figures as one JSON line per benchmark. Keys carry their unit
//! (`_ms`, `_bytes`, ...). Targets live here, never in timed unit tests.
//!
//! * `fmu`: the cost of one `fmi2DoStep` of each packaged FMU, loaded by the bundled master, for a
//!   SensorView with 100 moving objects. A timed step is what an importer pays per cycle: set the
//!   OSMP input triple, `fmi2DoStep` (decode SensorView, model step, encode SensorData and
//!   PerceptionData), read the output triples and copy the bytes out.
//! * `space`: the space-design ray tracer on a ≈1 M-triangle street
//!   ([`osiris_models::space::bench`]).
//!
//! Every line also names the machine ([`machine`], key `machine`), and [`markdown_report`] turns
//! such lines into `docs/benchmarks.md` (`osiris bench report`).

use std::path::Path;
use std::time::Instant;

use anyhow::{Context, Result};
use osiris_models::SensorKind;
use osiris_proto::Message;
use serde_json::{Map, Value as Json, json};

use crate::master::{Fmu, InstanceOptions, OsmpSensor};

/// Objects in the benchmark SensorView.
pub const BENCH_OBJECTS: usize = 100;

/// Summary statistics of a sample of durations, ms.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stats {
    pub mean_ms: f64,
    pub median_ms: f64,
    pub p95_ms: f64,
    pub min_ms: f64,
}

impl Stats {
    /// Statistics of `samples_ms` (must not be empty).
    pub fn of(samples_ms: &mut [f64]) -> Stats {
        assert!(!samples_ms.is_empty(), "no samples");
        samples_ms.sort_by(f64::total_cmp);
        let n = samples_ms.len();
        let pct = |p: f64| samples_ms[(((n - 1) as f64) * p).round() as usize];
        Stats {
            mean_ms: samples_ms.iter().sum::<f64>() / n as f64,
            median_ms: pct(0.5),
            p95_ms: pct(0.95),
            min_ms: samples_ms[0],
        }
    }
}

fn round3(x: f64) -> Json {
    json!((x * 1e3).round() / 1e3)
}

/// Cars in the street SensorView of [`bench_radar_street`]: three lanes ahead of the radar.
pub const STREET_CARS: u64 = 40;

/// The physical radar's whole step (ray-traced propagation over a street of [`STREET_CARS`] cars in
/// three lanes, 8–86 m ahead, all at 10 m/s; then the baseband chain and the recognition), through
/// [`osiris_models::build_sensor`] as the FMU runs it: median of `frames` steps after one warm-up
/// step, on a rayon pool of `threads` threads. Keys `street_cars`, `street_step_ms` (median),
/// `street_step_p95_ms`, `street_detections` (of the last step). Merged into `osiris bench radar`.
pub fn bench_radar_street(threads: usize, frames: usize) -> Result<Json> {
    use osiris_models::{ModelMode, SensorConfig, StepInput, StepOutput, build_sensor};
    use osiris_proto::{id, osi3, timestamp_from_seconds};
    let v3 = |x: f64, y: f64, z: f64| osi3::Vector3d {
        x: Some(x),
        y: Some(y),
        z: Some(z),
    };
    let zero = || osi3::Orientation3d {
        roll: Some(0.0),
        pitch: Some(0.0),
        yaw: Some(0.0),
    };
    let cars = (0..STREET_CARS)
        .map(|i| {
            let lane = (i % 3) as f64 - 1.0;
            osi3::MovingObject {
                id: Some(id(100 + i)),
                base: Some(osi3::BaseMoving {
                    dimension: Some(osi3::Dimension3d {
                        length: Some(4.5),
                        width: Some(1.8),
                        height: Some(1.5),
                    }),
                    position: Some(v3(
                        8.0 + 6.0 * (i / 3) as f64 + 2.0 * lane,
                        3.5 * lane,
                        0.75,
                    )),
                    orientation: Some(zero()),
                    velocity: Some(v3(10.0, 0.0, 0.0)),
                    orientation_rate: Some(zero()),
                    ..Default::default()
                }),
                r#type: Some(osi3::moving_object::Type::Vehicle as i32),
                model_reference: Some("osiris:car".into()),
                ..Default::default()
            }
        })
        .collect();
    let view = osi3::SensorView {
        version: Some(osiris_proto::interface_version()),
        timestamp: Some(timestamp_from_seconds(0.0)),
        global_ground_truth: Some(osi3::GroundTruth {
            timestamp: Some(timestamp_from_seconds(0.0)),
            moving_object: cars,
            ..Default::default()
        }),
        ..Default::default()
    };
    let mut config = SensorConfig::default_for(SensorKind::Radar);
    config.mode = ModelMode::Physical;
    config.mounting.position_m = [0.0, 0.0, 0.5];
    config.seed = Some(1);
    let mut radar = build_sensor(config).context("the default physical radar")?;
    let request = radar.view_configuration_request();
    radar
        .apply_view_configuration(&request)
        .context("the radar's own view configuration")?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads.max(1))
        .build()
        .context("a rayon pool")?;
    let frames = frames.max(1);
    let mut out = StepOutput::default();
    let (mut step_ms, mut detections) = (Vec::with_capacity(frames), 0usize);
    pool.install(|| -> Result<()> {
        for f in 0..=frames {
            let input = StepInput {
                view: &view,
                time_s: 0.05 * f as f64,
                step_s: 0.05,
            };
            let t = Instant::now();
            radar.step(&input, &mut out).context("radar step")?;
            if f > 0 {
                step_ms.push(t.elapsed().as_secs_f64() * 1e3);
                detections = out.sensor_data.feature_data.as_ref().map_or(0, |fd| {
                    fd.radar_sensor.iter().map(|r| r.detection.len()).sum()
                });
            }
        }
        Ok(())
    })?;
    let step = Stats::of(&mut step_ms);
    Ok(json!({
        "street_cars": STREET_CARS,
        "street_step_ms": round3(step.median_ms),
        "street_step_p95_ms": round3(step.p95_ms),
        "street_detections": detections,
    }))
}

/// `osiris bench fmu`.
pub fn bench_fmu(fmu_dir: &Path, iterations: usize) -> Result<Json> {
    let iterations = iterations.max(1);
    let mut out = Map::new();
    out.insert("bench".into(), json!("fmu"));
    out.insert("objects".into(), json!(BENCH_OBJECTS));
    out.insert("iterations".into(), json!(iterations));
    let mut worst_median: f64 = 0.0;
    for kind in SensorKind::ALL {
        let path = fmu_dir.join(format!("{}.fmu", kind.name()));
        let fmu = Fmu::load(&path).with_context(|| format!("loading {}", path.display()))?;
        let mut sensor = OsmpSensor::instantiate(&fmu, kind.name(), InstanceOptions::default())?;
        sensor.initialize(0.0, &[])?;
        let scenario = crate::scenario::ScenarioConfig::with_traffic(BENCH_OBJECTS);
        let mount = scenario
            .sensors
            .iter()
            .find(|m| m.kind == kind)
            .context("the traffic scenario has every sensor kind")?;
        let view = scenario.sensor_view(0, mount);
        let bytes = view.encode_to_vec();
        let h = sensor.default_step_size().unwrap_or(0.05);
        let mut t = 0.0;
        let mut detected = 0;
        // Warm-up: first steps allocate the double buffers.
        for _ in 0..5 {
            sensor.step(&bytes, t, h)?;
            t += h;
        }
        let mut samples = Vec::with_capacity(iterations);
        let mut sd_bytes = 0;
        let mut pd_bytes = 0;
        for _ in 0..iterations {
            let start = Instant::now();
            let outputs = sensor.step(&bytes, t, h)?;
            samples.push(start.elapsed().as_secs_f64() * 1e3);
            t += h;
            sd_bytes = outputs.sensor_data.as_ref().map_or(0, Vec::len);
            pd_bytes = outputs.perception.as_ref().map_or(0, Vec::len);
            if let Some(sd) = &outputs.sensor_data {
                detected = osiris_proto::osi3::SensorData::decode(sd.as_slice())?
                    .moving_object
                    .len();
            }
        }
        sensor.terminate()?;
        let s = Stats::of(&mut samples);
        worst_median = worst_median.max(s.median_ms);
        let k = kind.name();
        out.insert(format!("{k}_step_ms_100_objects"), round3(s.median_ms));
        out.insert(format!("{k}_step_ms_100_objects_mean"), round3(s.mean_ms));
        out.insert(format!("{k}_step_ms_100_objects_p95"), round3(s.p95_ms));
        out.insert(format!("{k}_sensor_view_bytes"), json!(bytes.len()));
        out.insert(format!("{k}_sensor_data_bytes"), json!(sd_bytes));
        out.insert(format!("{k}_perception_data_bytes"), json!(pd_bytes));
        out.insert(format!("{k}_objects_detected"), json!(detected));
    }
    out.insert("step_ms_100_objects".into(), round3(worst_median));
    Ok(Json::Object(out))
}

/// The machine a benchmark runs on, as `osiris bench` records it under `machine`: CPU model, logical
/// CPUs, physical cores (where `/proc/cpuinfo` tells), the threads a rayon pool gets by default
/// (`RAYON_NUM_THREADS`, else one per logical CPU; the FMUs' models use that pool), the SIMD
/// kernels, the build profile, the 1-minute load average when the bench started, and the osiris
/// version.
pub fn machine() -> Json {
    let cpuinfo = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let logical = std::thread::available_parallelism().map_or(1, |n| n.get());
    let default_threads = std::env::var("RAYON_NUM_THREADS")
        .ok()
        .and_then(|v| v.parse::<usize>().ok())
        .filter(|&n| n > 0)
        .unwrap_or(logical);
    let load = std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|l| l.split_whitespace().next()?.parse::<f64>().ok());
    json!({
        "cpu_model": cpu_model(&cpuinfo),
        "logical_cpus": logical,
        "physical_cores": physical_cores(&cpuinfo),
        "default_threads": default_threads,
        "simd": if osiris_models::cpu::avx2_fma() { "avx2" } else { "portable" },
        "profile": if cfg!(debug_assertions) { "debug" } else { "release" },
        "load_avg_1min": load,
        "osiris_version": env!("CARGO_PKG_VERSION"),
    })
}

/// The `model name` of the first processor in a `/proc/cpuinfo` text.
fn cpu_model(cpuinfo: &str) -> Option<String> {
    cpuinfo.lines().find_map(|l| {
        let (k, v) = l.split_once(':')?;
        (k.trim() == "model name").then(|| v.trim().to_owned())
    })
}

/// Distinct (`physical id`, `core id`) pairs in a `/proc/cpuinfo` text; `None` when it has none.
fn physical_cores(cpuinfo: &str) -> Option<usize> {
    let mut cores = std::collections::BTreeSet::new();
    for block in cpuinfo.split("\n\n") {
        let field = |name: &str| {
            block.lines().find_map(|l| {
                let (k, v) = l.split_once(':')?;
                (k.trim() == name).then(|| v.trim().to_owned())
            })
        };
        if let Some(core) = field("core id") {
            cores.insert((field("physical id").unwrap_or_default(), core));
        }
    }
    (!cores.is_empty()).then_some(cores.len())
}

/// Adds `bench` (when the benchmark left it out) and `machine` to a benchmark's figures.
pub fn stamp(figures: &mut Json, bench: &str) {
    if let Json::Object(map) = figures {
        map.entry("bench").or_insert_with(|| json!(bench));
        map.insert("machine".into(), machine());
    }
}

/// `docs/benchmarks.md` from `osiris bench` JSON lines: one section and one table per line, the
/// machine named above the table, then the benchmarks of `known` (name, description) that no line
/// covers, each with the command that measures it. `note` goes under the title.
pub fn markdown_report(runs: &[Json], known: &[(String, String)], note: Option<&str>) -> String {
    let mut md = String::from("# Benchmarks\n\n");
    md.push_str(
        "<!-- Generated by `osiris bench report` from the JSON lines of `osiris bench`; do not \
         edit. -->\n\n",
    );
    md.push_str(
        "Figures of `osiris bench <what>` (release build), one table per benchmark. Keys carry \
         their unit (`_ms`, `_s`, `_per_s`, …); `target` entries are the project's goals. Measure \
         and regenerate with\n\n```sh\ncargo run --release -- bench <what> > \
         docs/benchmarks/<what>.json\ncargo run --release -- bench report --note \
         \"$(cat docs/benchmarks/note.md)\" docs/benchmarks/*.json > docs/benchmarks.md\n```\n\n\
         `docs/benchmarks/note.md` says when and in what state the machine was.\n\n",
    );
    if let Some(note) = note.filter(|n| !n.trim().is_empty()) {
        md.push_str(note.trim());
        md.push_str("\n\n");
    }
    let mut seen = Vec::new();
    for run in runs {
        let name = run
            .get("bench")
            .and_then(Json::as_str)
            .unwrap_or("unnamed")
            .to_owned();
        md.push_str(&format!("## `osiris bench {name}`\n\n"));
        if let Some((_, about)) = known.iter().find(|(k, _)| *k == name) {
            md.push_str(about);
            md.push_str("\n\n");
        }
        md.push_str(&machine_line(run));
        md.push_str("\n\n| figure | value |\n|---|---|\n");
        let mut rows = Vec::new();
        flatten("", run, &mut rows);
        for (k, v) in rows {
            if k == "bench" || k == "machine" || k.starts_with("machine.") {
                continue;
            }
            md.push_str(&format!("| `{k}` | {} |\n", v.replace('|', "\\|")));
        }
        md.push('\n');
        seen.push(name);
    }
    let missing: Vec<_> = known.iter().filter(|(k, _)| !seen.contains(k)).collect();
    if !missing.is_empty() {
        md.push_str("## Not measured here\n\n");
        for (k, about) in missing {
            md.push_str(&format!(
                "* `osiris bench {k}`: {about} Measure: `cargo run --release -- bench {k} > \
                 docs/benchmarks/{k}.json`.\n"
            ));
        }
        md.push('\n');
    }
    md.truncate(md.trim_end().len());
    md.push('\n');
    md
}

/// "Machine: …" from a line's `machine` object and its `threads`.
fn machine_line(run: &Json) -> String {
    let m = run.get("machine");
    let field = |k: &str| m.and_then(|m| m.get(k)).filter(|v| !v.is_null());
    let Some(cpu) = field("cpu_model").and_then(Json::as_str) else {
        return "Machine: not recorded (a JSON line from before `machine` was added).".into();
    };
    let mut parts = vec![cpu.to_owned()];
    if let Some(n) = field("logical_cpus") {
        let cores = field("physical_cores").map_or(String::new(), |c| format!(" ({c} cores)"));
        parts.push(format!("{n} logical CPUs{cores}"));
    }
    let threads = match run.get("threads") {
        Some(Json::Array(a)) => Some(a.iter().map(value_text).collect::<Vec<_>>().join(" and ")),
        Some(t) if !t.is_null() => Some(value_text(t)),
        _ => field("default_threads").map(|t| format!("{} (rayon default)", value_text(t))),
    };
    if let Some(t) = threads {
        parts.push(format!("threads: {t}"));
    }
    if let Some(p) = field("profile").and_then(Json::as_str) {
        parts.push(format!("{p} build"));
    }
    if let Some(s) = field("simd").and_then(Json::as_str) {
        parts.push(format!("{s} kernels"));
    }
    if let Some(l) = field("load_avg_1min") {
        parts.push(format!("load average {} at the start", value_text(l)));
    }
    if let Some(v) = field("osiris_version").and_then(Json::as_str) {
        parts.push(format!("osiris {v}"));
    }
    format!("Machine: {}.", parts.join(", "))
}

/// `(dotted key, text)` for every leaf of `v` (objects flattened, arrays joined).
fn flatten(prefix: &str, v: &Json, rows: &mut Vec<(String, String)>) {
    match v {
        Json::Object(map) => {
            for (k, v) in map {
                let key = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                flatten(&key, v, rows);
            }
        }
        _ => rows.push((prefix.to_owned(), value_text(v))),
    }
}

/// A JSON value as table text: integers as they are, other numbers to 4 significant digits.
fn value_text(v: &Json) -> String {
    match v {
        Json::Null => "—".into(),
        Json::Bool(b) => b.to_string(),
        Json::Number(n) if n.is_f64() => significant(n.as_f64().unwrap_or(f64::NAN), 4),
        Json::Number(n) => n.to_string(),
        Json::String(s) => s.clone(),
        Json::Array(a) => a.iter().map(value_text).collect::<Vec<_>>().join(", "),
        Json::Object(_) => v.to_string(),
    }
}

/// `x` rounded to `digits` significant digits, without trailing zeros.
fn significant(x: f64, digits: i32) -> String {
    if x == 0.0 || !x.is_finite() {
        return x.to_string();
    }
    let decimals = (digits - 1 - x.abs().log10().floor() as i32).max(0) as usize;
    let s = format!("{x:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_owned()
    } else {
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn significant_digits() {
        assert_eq!(significant(16.6234, 4), "16.62");
        assert_eq!(significant(0.000123456, 4), "0.0001235");
        assert_eq!(significant(1234567.8, 4), "1234568");
        assert_eq!(significant(2.5, 4), "2.5");
        assert_eq!(significant(-0.5, 4), "-0.5");
    }

    #[test]
    fn cpuinfo_model_and_cores() {
        let info = "processor\t: 0\nmodel name\t: Test CPU 9000\nphysical id\t: 0\ncore id\t: 0\n\n\
                    processor\t: 1\nmodel name\t: Test CPU 9000\nphysical id\t: 0\ncore id\t: 0\n\n\
                    processor\t: 2\nmodel name\t: Test CPU 9000\nphysical id\t: 0\ncore id\t: 1\n";
        assert_eq!(cpu_model(info).as_deref(), Some("Test CPU 9000"));
        assert_eq!(physical_cores(info), Some(2)); // two hyperthreads share core 0
        assert_eq!(physical_cores("processor : 0\n"), None);
    }

    #[test]
    fn stats_of_known_sample() {
        let mut v: Vec<f64> = (1..=100).map(f64::from).collect();
        let s = Stats::of(&mut v);
        assert_eq!(s.min_ms, 1.0);
        assert!((s.mean_ms - 50.5).abs() < 1e-12);
        assert_eq!(s.median_ms, 51.0); // index round(99 * 0.5) = 50 -> value 51
        assert_eq!(s.p95_ms, 95.0); // index round(99 * 0.95) = 94 -> value 95
    }
}
