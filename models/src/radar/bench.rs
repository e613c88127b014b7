//! `osiris bench radar`: throughput of the FMCW baseband chain (paths → detections) with the
//! default AWR1843-like configuration (256 samples × 128 chirps × 12 virtual channels) and 2,000
//! random paths.

use std::time::Instant;

use num_complex::Complex64;
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};
use serde_json::{Value, json};

use super::PathReturn;
use super::antenna::FrontEndConfig;
use super::baseband::RadarChain;
use super::processing::ProcessingConfig;
use super::waveform::{ArrayConfig, WaveformConfig};
use crate::effects::Effects;

/// Paths per frame in the benchmark.
pub const BENCH_PATHS: usize = 2000;
/// Target throughput of the full chain on 2 threads, frames/s.
pub const TARGET_FRAMES_PER_S: f64 = 20.0;

/// `n` random paths inside the unambiguous range / velocity of the default waveform: ranges
/// 1–95 m, range rates ±9 m/s, azimuth ±60°, elevation ±5°, received power −130 … −70 dBm.
pub fn random_paths(n: usize, seed: u64) -> Vec<PathReturn> {
    let mut rng = SmallRng::seed_from_u64(seed);
    (0..n)
        .map(|i| {
            let az = rng.random_range(-60f64..60.0).to_radians();
            let el = rng.random_range(-5f64..5.0).to_radians();
            let dbm: f64 = rng.random_range(-130.0..-70.0);
            let phase: f64 = rng.random_range(0.0..std::f64::consts::TAU);
            PathReturn {
                range_m: rng.random_range(1.0..95.0),
                range_rate_m_s: rng.random_range(-9.0..9.0),
                tx_azimuth_rad: az,
                tx_elevation_rad: el,
                rx_azimuth_rad: az,
                rx_elevation_rad: el,
                amplitude: Complex64::from_polar((1e-3 * 10f64.powf(dbm / 10.0)).sqrt(), phase),
                object_id: (i / 20) as u64,
            }
        })
        .collect()
}

/// CPU time of this process (user + system), s (Linux `/proc/self/stat`; None elsewhere).
fn process_cpu_s() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the parenthesised command name; utime and stime are fields 14 and 15.
    let rest = stat.rsplit_once(')')?.1;
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

/// Run `frames` frames (after one warm-up frame) on `threads` threads (default: rayon's global
/// pool size). Keys: `bench`, `frames_per_s`, `frame_ms`, `synthesize_ms`, `process_ms`,
/// `paths`, `threads`, `samples`, `chirps`, `virtual_channels`, `equivalent_cmacs_per_s` (the
/// complex multiply-accumulates a direct evaluation of the cube would need, per second of
/// synthesis: the synthesis uses a NUFFT), `stages_ms`, `frames_per_cpu_s_x_threads`,
/// `detections_per_frame`, `target`.
pub fn bench_radar(threads: Option<usize>, frames: usize) -> Value {
    let threads = threads.unwrap_or_else(rayon::current_num_threads).max(1);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a rayon pool");
    let waveform = WaveformConfig::default();
    let array = ArrayConfig::default();
    let effects = Effects::new(&[crate::world::effects(), super::effects()].concat());
    let mut chain = RadarChain::new(
        &waveform,
        &array,
        &FrontEndConfig::default(),
        &ProcessingConfig::default(),
        &effects,
    )
    .expect("the default radar configuration is valid");
    let paths = random_paths(BENCH_PATHS, 7);
    let frames = frames.max(1);
    let mut out = Vec::new();
    let (mut synth_s, mut proc_s, mut detections) = (0.0, 0.0, 0usize);
    let mut stages = [0.0f64; 4];
    let mut cpu_s = 0.0;
    pool.install(|| {
        chain.run(&paths, 0, &mut out);
        let c0 = process_cpu_s();
        for f in 0..frames {
            out.clear();
            let t0 = Instant::now();
            chain.synthesize(&paths, f as u64 + 1);
            let t1 = Instant::now();
            chain.process(&mut out);
            let t2 = Instant::now();
            synth_s += (t1 - t0).as_secs_f64();
            proc_s += (t2 - t1).as_secs_f64();
            detections += out.len();
            for (s, t) in stages.iter_mut().zip(chain.last_timings_s()) {
                *s += t / frames as f64;
            }
        }
        cpu_s = process_cpu_s().zip(c0).map_or(0.0, |(b, a)| b - a);
    });
    let frame_s = (synth_s + proc_s) / frames as f64;
    let cells = (waveform.samples_per_chirp * waveform.chirps_per_frame * array.n_virtual()) as f64;
    let fps = 1.0 / frame_s;
    json!({
        "bench": "radar",
        "frames_per_s": fps,
        "frame_ms": frame_s * 1e3,
        "synthesize_ms": synth_s / frames as f64 * 1e3,
        "process_ms": proc_s / frames as f64 * 1e3,
        "stages_ms": {
            "synthesize": stages[0] * 1e3,
            "doppler": stages[1] * 1e3,
            "cfar": stages[2] * 1e3,
            "estimate": stages[3] * 1e3,
        },
        "paths": BENCH_PATHS,
        "threads": threads,
        "frames": frames,
        "samples": waveform.samples_per_chirp,
        "chirps": waveform.chirps_per_frame,
        "virtual_channels": array.n_virtual(),
        "equivalent_cmacs_per_s": cells * BENCH_PATHS as f64 * frames as f64 / synth_s,
        "detections_per_frame": detections as f64 / frames as f64,
        "target": { "frames_per_s": TARGET_FRAMES_PER_S, "met": fps >= TARGET_FRAMES_PER_S },
        // Frames per process CPU-second × threads: the throughput with the threads' cores to
        // ourselves (the wall-clock figure drops when other processes share the cores).
        "frames_per_cpu_s_x_threads": if cpu_s > 0.0 { frames as f64 / cpu_s * threads as f64 } else { 0.0 },
        "cpus": std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bench_reports_the_keys() {
        let v = bench_radar(Some(1), 1);
        for k in [
            "frames_per_s",
            "paths",
            "threads",
            "synthesize_ms",
            "process_ms",
        ] {
            assert!(v.get(k).is_some(), "{k} missing: {v}");
        }
        assert_eq!(v["paths"], 2000);
        assert!(v["frames_per_s"].as_f64().unwrap() > 0.0);
    }
}
