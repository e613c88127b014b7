//! `osiris bench <what>`: performance figures as one JSON line per benchmark. Keys carry their unit
//! (`_ms`, `_bytes`, ...). Targets live here, never in timed unit tests.
//!
//! * `fmu`: the cost of one `fmi2DoStep` of each packaged FMU, loaded by the bundled master, for a
//!   SensorView with 100 moving objects. A timed step is what an importer pays per cycle: set the
//!   OSMP input triple, `fmi2DoStep` (decode SensorView, model step, encode SensorData and
//!   PerceptionData), read the output triples and copy the bytes out.
//! * `space`: the space-design ray tracer on a ≈1 M-triangle street
//!   ([`osiris_models::space::bench`]).

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

#[cfg(test)]
mod tests {
    use super::*;

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
