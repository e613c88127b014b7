//! `osiris bench radar`: throughput of the FMCW baseband chain (paths → detections) with the
//! default AWR1843-like configuration (256 samples × 128 chirps × 12 virtual channels) and with the
//! 4D imaging preset (512 × 64 × 192), 2,000 random paths each.

use std::time::Instant;

use num_complex::Complex64;
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};
use serde_json::{Value, json};

use super::baseband::RadarChain;
use super::preset::RadarPreset;
use super::{PathReturn, RadarConfig};
use crate::effects::Effects;

/// Paths per frame in the benchmark.
pub const BENCH_PATHS: usize = 2000;
/// Target throughput of the full chain on 2 threads, frames/s.
pub const TARGET_FRAMES_PER_S: f64 = 20.0;

/// `n` random paths inside the unambiguous range / velocity of the default waveform: ranges
/// 1–95 m, range rates ±9 m/s, azimuth ±60°, elevation ±5°, received power −130 … −70 dBm.
pub fn random_paths(n: usize, seed: u64) -> Vec<PathReturn> {
    random_paths_within(n, seed, 95.0, 9.0, 5.0)
}

/// `n` random paths: ranges 1 m … `range_m`, range rates ±`rate_m_s`, azimuth ±60°, elevation
/// ±`elevation_deg`, received power −130 … −70 dBm.
pub fn random_paths_within(
    n: usize,
    seed: u64,
    range_m: f64,
    rate_m_s: f64,
    elevation_deg: f64,
) -> Vec<PathReturn> {
    let mut rng = SmallRng::seed_from_u64(seed);
    (0..n)
        .map(|i| {
            let az = rng.random_range(-60f64..60.0).to_radians();
            let el = rng.random_range(-elevation_deg..elevation_deg).to_radians();
            let dbm: f64 = rng.random_range(-130.0..-70.0);
            let phase: f64 = rng.random_range(0.0..std::f64::consts::TAU);
            PathReturn {
                range_m: rng.random_range(1.0..range_m),
                range_rate_m_s: rng.random_range(-rate_m_s..rate_m_s),
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
/// synthesis: the synthesis uses a NUFFT), `stages_ms` (`synthesize`: IF cube, range and
/// Doppler FFTs; `integrate`: the non-coherent sum over the channels; `cfar`; `estimate`),
/// `frames_per_cpu_s_x_threads`, `detections_per_frame`, `target`.
///
/// The same figures for the 4D imaging preset (`"radar": {"preset": "imaging"}`, 512 samples ×
/// 64 chirps × 192 virtual channels, paths to 200 m and ±30 m/s, elevation ±10°) under `imaging`,
/// and flat as `imaging_frames_per_s`, `imaging_frame_ms`, `imaging_target_frames_per_s`.
pub fn bench_radar(threads: Option<usize>, frames: usize) -> Value {
    let threads = threads.unwrap_or_else(rayon::current_num_threads).max(1);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a rayon pool");
    let frames = frames.max(1);
    let mut v = bench_chain(
        &pool,
        &RadarConfig::default(),
        &random_paths(BENCH_PATHS, 7),
        frames,
        TARGET_FRAMES_PER_S,
    );
    let imaging = bench_chain(
        &pool,
        &RadarPreset::Imaging.config(),
        &random_paths_within(BENCH_PATHS, 7, 200.0, 30.0, 10.0),
        frames,
        TARGET_IMAGING_FRAMES_PER_S,
    );
    let m = v.as_object_mut().expect("an object");
    m.insert("bench".into(), json!("radar"));
    m.insert("threads".into(), json!(threads));
    m.insert("frames".into(), json!(frames));
    m.insert(
        "cpus".into(),
        json!(
            std::thread::available_parallelism()
                .map(|n| n.get())
                .unwrap_or(1)
        ),
    );
    m.insert(
        "imaging_frames_per_s".into(),
        imaging["frames_per_s"].clone(),
    );
    m.insert("imaging_frame_ms".into(), imaging["frame_ms"].clone());
    m.insert(
        "imaging_target_frames_per_s".into(),
        json!(TARGET_IMAGING_FRAMES_PER_S),
    );
    m.insert("imaging".into(), imaging);
    v
}

/// Target throughput of the imaging preset's chain on 2 threads, frames/s (issue #19).
pub const TARGET_IMAGING_FRAMES_PER_S: f64 = 10.0;

/// One configuration's figures (see [`bench_radar`]).
fn bench_chain(
    pool: &rayon::ThreadPool,
    config: &RadarConfig,
    paths: &[PathReturn],
    frames: usize,
    target_fps: f64,
) -> Value {
    let (waveform, array) = (&config.waveform, &config.array);
    let effects = Effects::new(&[crate::world::effects(), super::effects()].concat());
    let mut chain = RadarChain::new(
        waveform,
        array,
        &config.front_end,
        &config.processing,
        &effects,
    )
    .expect("the preset radar configuration is valid");
    let mut out = Vec::new();
    let (mut synth_s, mut proc_s, mut detections) = (0.0, 0.0, 0usize);
    let mut stages = [0.0f64; 4];
    let mut cpu_s = 0.0;
    pool.install(|| {
        chain.run(paths, 0, &mut out);
        let c0 = process_cpu_s();
        for f in 0..frames {
            out.clear();
            let t0 = Instant::now();
            chain.synthesize(paths, f as u64 + 1);
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
    let threads = pool.current_num_threads();
    json!({
        "preset": config.preset.name(),
        "frames_per_s": fps,
        "frame_ms": frame_s * 1e3,
        "synthesize_ms": synth_s / frames as f64 * 1e3,
        "process_ms": proc_s / frames as f64 * 1e3,
        "stages_ms": {
            "synthesize": stages[0] * 1e3,
            "integrate": stages[1] * 1e3,
            "cfar": stages[2] * 1e3,
            "estimate": stages[3] * 1e3,
        },
        "paths": paths.len(),
        "samples": waveform.samples_per_chirp,
        "chirps": waveform.chirps_per_frame,
        "virtual_channels": array.n_virtual(),
        "equivalent_cmacs_per_s": cells * paths.len() as f64 * frames as f64 / synth_s,
        "detections_per_frame": detections as f64 / frames as f64,
        "target": { "frames_per_s": target_fps, "met": fps >= target_fps },
        // Frames per process CPU-second × threads: the throughput with the threads' cores to
        // ourselves (the wall-clock figure drops when other processes share the cores).
        "frames_per_cpu_s_x_threads": if cpu_s > 0.0 { frames as f64 / cpu_s * threads as f64 } else { 0.0 },
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
        assert!(v["imaging_frames_per_s"].as_f64().unwrap() > 0.0, "{v}");
        assert_eq!(v["imaging"]["virtual_channels"], 192);
        assert_eq!(v["imaging"]["preset"], "imaging");
    }
}
