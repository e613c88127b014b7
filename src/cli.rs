//! The `osiris` command line.
//!
//! * `osiris run`: the main job. Packages the FMUs if needed, steps all three over the built-in
//!   default scenario (or a scenario JSON / a SensorView `.osi` trace) with the bundled master, and
//!   writes SensorData traces, PerceptionData traces and a summary to `out/`.
//! * `osiris package [--out DIR]`: builds `camera.fmu`, `radar.fmu`, `lidar.fmu` (default `target/fmu/`).
//! * `osiris bench <what>`: one JSON line of figures per benchmark.
//! * `osiris export <trace> --out <file>`: one frame of a PerceptionData trace as PCD/PLY (LiDAR) or
//!   PNG/CSV (radar range-Doppler map).
//! * `osiris consistency --meta <campaign>/consistency.toml --out <dir>`: model vs measurement
//!   campaign, where it fails and which named effect explains it (summary.json, report.html).
//! * `osiris scenario`: prints the built-in default scenario as JSON (a starting point for your own).
//! * `osiris effects`: lists every named physical effect (name, default, formula, source).
//! * `osiris model-description <sensor>`: prints a sensor FMU's modelDescription.xml.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::{Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use osiris_models::SensorKind;
use osiris_proto::{Message, osi3, perception};

use crate::master::{Fmu, Frame, InstanceOptions, OsmpSensor, RunOptions, StepRecord, Value};
use crate::package::{self, PackageOptions};
use crate::scenario::{ScenarioConfig, SensorMount};
use crate::trace::{OsiTraceReader, OsiTraceWriter};

/// `print!` to stdout that ends the command quietly when stdout is closed (e.g. `osiris scenario |
/// head`) instead of panicking; other write errors are returned.
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        match write!(std::io::stdout().lock(), $($arg)*) {
            Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => return Ok(()),
            r => r?,
        }
    }};
}

/// `println!` counterpart of `out!`.
macro_rules! outln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        match writeln!(std::io::stdout().lock(), $($arg)*) {
            Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => return Ok(()),
            r => r?,
        }
    }};
}

/// Protobuf-version field of the trace file names: the messages are encoded by prost 0.14 ("014").
const PROTOBUF_VERSION_TAG: &str = "0.14";

/// Command-line arguments.
#[derive(Debug, Parser)]
#[command(
    name = "osiris",
    version,
    about = "Physics-based camera, radar and LiDAR sensor models as OSI/OSMP FMI 2.0 FMUs"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

/// Sensor names on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum SensorArg {
    Camera,
    Radar,
    Lidar,
}

impl From<SensorArg> for SensorKind {
    fn from(s: SensorArg) -> SensorKind {
        match s {
            SensorArg::Camera => SensorKind::Camera,
            SensorArg::Radar => SensorKind::Radar,
            SensorArg::Lidar => SensorKind::Lidar,
        }
    }
}

/// Benchmarks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum BenchWhat {
    /// Cost of one `fmi2DoStep` of each FMU for a SensorView with 100 moving objects.
    Fmu,
    /// Ray tracing on a ≈1 M-triangle street: BVH build, top-level update, Mrays/s (coherent LiDAR
    /// pattern and random rays) on 1 and 2 threads.
    Space,
    /// Physical LiDAR: VLS-128 full frames (≈230 k pulses) on the ≈1 M-triangle street, frames/s with
    /// 1 and 7 sub-rays per pulse.
    Lidar,
    /// Physical radar: the full chain (2,000 paths → IF cube 256 × 128 × 12 → FFTs → CFAR → angles),
    /// frames/s.
    Radar,
    /// Physical camera: 1280 × 960 frames (ISX019-class) of the reference street with sun, sky,
    /// shadows and 3-exposure HDR, frames/s and the cost split (render, lens, pixel, ISP,
    /// recognition).
    Camera,
    /// Consistency attribution: 10⁴ residual rows × 30 catalogue effects (forward selection, tie
    /// check, gates) on a rayon pool of the largest `--threads` (default 2), seconds.
    Consistency,
    /// The consistency workflow's hidden-effect protocol: campaigns with one hidden effect per
    /// case (or none, or one outside the catalogue) over 10 seeds; hit rate per case and wrong
    /// acceptances as JSON.
    ConsistencyProtocol,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Package the FMUs if needed, step them over a scenario and write traces and a summary.
    Run(RunArgs),
    /// Build camera.fmu, radar.fmu, lidar.fmu (see --sensors) and scenario.fmu.
    Package {
        /// Output folder.
        #[arg(long, value_name = "DIR")]
        out: Option<PathBuf>,
        /// Use prebuilt `libosiris_<sensor>.so` from this folder instead of building with cargo.
        #[arg(long, value_name = "DIR")]
        lib_dir: Option<PathBuf>,
        /// Build the libraries with the debug profile (default: the profile of this executable).
        #[arg(long)]
        debug: bool,
        /// Sensors to package (default: all).
        #[arg(long, value_enum, value_delimiter = ',')]
        sensors: Vec<SensorArg>,
    },
    /// Print one JSON line of benchmark figures.
    Bench {
        #[arg(value_enum)]
        what: BenchWhat,
        /// Timed steps per measurement.
        #[arg(long, default_value_t = 200)]
        iterations: usize,
        /// Folder with the packaged FMUs (packaged there first if missing or stale); `fmu` only.
        #[arg(long, value_name = "DIR")]
        fmu_dir: Option<PathBuf>,
        /// Thread counts to measure (`space`); the largest is used by `lidar` and `radar`.
        #[arg(long, value_delimiter = ',', default_values_t = [1usize, 2])]
        threads: Vec<usize>,
        /// Timed frames per measurement; `lidar`, `radar` and `camera` (default 10, 40 and 5).
        #[arg(long)]
        frames: Option<usize>,
    },
    /// Write one frame of a PerceptionData trace (`out/<sensor>.perception.osi`) as a file:
    /// a LiDAR point cloud as `.pcd` / `.ply`, a radar range-Doppler map as `.png` / `.csv`, a
    /// camera image as `.png` (8-bit ISP or 16-bit RAW).
    Export {
        /// PerceptionData trace written by `osiris run`.
        #[arg(value_name = "TRACE")]
        trace: PathBuf,
        /// Output file; the extension selects the format (.pcd, .ply, .png, .csv).
        #[arg(long, value_name = "FILE")]
        out: PathBuf,
        /// Frame index (0-based; default: the last frame that has the requested content).
        #[arg(long, value_name = "N")]
        frame: Option<usize>,
        /// Camera traces: which image to write as PNG: `isp` (8-bit sRGB, default), `raw`
        /// (companded HDR RAW, 16-bit), `linear` (linear HDR RAW, 16-bit), `exposure:<N>` (RAW of
        /// capture N).
        #[arg(long, value_name = "IMAGE")]
        image: Option<crate::export::CameraImageSel>,
    },
    /// Compare a model with a measurement campaign: paired residuals, metrics with tolerances,
    /// attribution of the misfit to named physical effects; writes summary.json and report.html.
    Consistency(crate::consistency::cli::ConsistencyArgs),
    /// Print the built-in default scenario as JSON.
    Scenario,
    /// List every named physical effect: name, default, formula, source.
    Effects {
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Print the modelDescription.xml of a sensor FMU.
    ModelDescription {
        #[arg(value_enum)]
        sensor: SensorArg,
    },
}

/// Arguments of `osiris run`.
#[derive(Debug, clap::Args)]
pub struct RunArgs {
    /// Scenario JSON (default: the built-in scenario; see `osiris scenario`).
    #[arg(long, value_name = "FILE", conflicts_with = "trace")]
    pub scenario: Option<PathBuf>,
    /// Feed the SensorViews of this `.osi` trace to every sensor instead of a generated scenario.
    #[arg(long, value_name = "FILE")]
    pub trace: Option<PathBuf>,
    /// Step size for `--trace`, s (default: the time between frames).
    #[arg(long, value_name = "S")]
    pub step_size: Option<f64>,
    /// Sensors to run (default: camera, radar, lidar).
    #[arg(long, value_enum, value_delimiter = ',')]
    pub sensors: Vec<SensorArg>,
    /// Folder with the packaged FMUs (packaged there first if missing or stale).
    #[arg(long, value_name = "DIR")]
    pub fmu_dir: Option<PathBuf>,
    /// Output folder.
    #[arg(long, value_name = "DIR", default_value = "out")]
    pub out: PathBuf,
    /// FMU parameter `NAME=VALUE` for every sensor (e.g. `mode=ideal`, `range_m=80`); repeatable.
    #[arg(long = "param", value_name = "NAME=VALUE")]
    pub params: Vec<String>,
    /// Stop after this many frames.
    #[arg(long, value_name = "N")]
    pub max_frames: Option<usize>,
    /// Step the sensors of a frame in parallel threads.
    #[arg(long)]
    pub parallel: bool,
    /// Step every sensor at every frame (default: each sensor at its own cycle, the FMU's default
    /// step size, rounded to a multiple of the frame step).
    #[arg(long)]
    pub every_frame: bool,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
}

/// Run the command line.
/// Exit status of a consistency verdict that fails (a tolerance fails, status not EXPLAINED).
pub const EXIT_VERDICT: u8 = 1;
/// Exit status of a usage, input or I/O error (the message names the file, key or value).
pub const EXIT_ERROR: u8 = 2;
/// Exit status of an internal error (a panic: a bug).
pub const EXIT_INTERNAL: u8 = 3;

/// The exit status of an error returned by [`main_with`]: [`EXIT_VERDICT`] for a failed
/// consistency verdict, [`EXIT_ERROR`] for every other error.
pub fn exit_code(e: &anyhow::Error) -> u8 {
    if e.chain()
        .any(|c| c.is::<crate::consistency::cli::VerdictFailed>())
    {
        EXIT_VERDICT
    } else {
        EXIT_ERROR
    }
}

/// `osiris bench consistency-protocol`: needs the truth generators (feature `protocol`).
#[cfg(feature = "protocol")]
fn consistency_protocol() -> Result<serde_json::Value> {
    crate::consistency::protocol::bench_protocol(crate::consistency::protocol::PROTOCOL_SEEDS)
}

/// `osiris bench consistency-protocol` in a build without the truth generators.
#[cfg(not(feature = "protocol"))]
fn consistency_protocol() -> Result<serde_json::Value> {
    bail!(
        "`bench consistency-protocol` needs the truth generators, which this build leaves out: \
         cargo run --release --features protocol -- bench consistency-protocol"
    )
}

pub fn main_with(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Run(args) => run(args),
        Command::Package {
            out,
            lib_dir,
            debug,
            sensors,
        } => {
            let opts = PackageOptions {
                out_dir: out.unwrap_or_else(package::default_fmu_dir),
                lib_dir,
                profile: debug.then(|| "dev".to_owned()),
                sensors: sensor_list(&sensors),
            };
            for path in package::package(&opts)? {
                outln!("{}", path.display());
            }
            Ok(())
        }
        Command::Bench {
            what,
            iterations,
            fmu_dir,
            threads,
            frames,
        } => {
            if threads.is_empty() || threads.contains(&0) {
                bail!("--threads: give thread counts >= 1, e.g. 1,2");
            }
            let max_threads = threads.iter().copied().max();
            let figures = match what {
                BenchWhat::Fmu => {
                    let fmu_dir = ensure_fmus(fmu_dir, &SensorKind::ALL)?;
                    crate::bench::bench_fmu(&fmu_dir, iterations)?
                }
                BenchWhat::Space => osiris_models::space::bench::bench_space(&threads),
                BenchWhat::Lidar => osiris_models::lidar::bench::bench_lidar(
                    max_threads,
                    frames.unwrap_or(10).max(1),
                ),
                BenchWhat::Radar => osiris_models::radar::bench::bench_radar(
                    max_threads,
                    frames.unwrap_or(40).max(1),
                ),
                BenchWhat::Camera => osiris_models::camera::bench::bench_camera(
                    max_threads,
                    frames.unwrap_or(5).max(1),
                ),
                BenchWhat::Consistency => crate::consistency::bench::bench_consistency(max_threads),
                BenchWhat::ConsistencyProtocol => consistency_protocol()?,
            };
            outln!("{}", serde_json::to_string(&figures)?);
            Ok(())
        }
        Command::Export {
            trace,
            out,
            frame,
            image,
        } => {
            let what = crate::export::export_frame(&trace, frame, &out, image)?;
            eprintln!("{what}");
            Ok(())
        }
        Command::Consistency(args) => crate::consistency::cli::run(args),
        Command::Scenario => {
            outln!("{}", ScenarioConfig::default().to_json_pretty());
            Ok(())
        }
        Command::Effects { json } => {
            let all = osiris_models::effects::catalogue();
            if json {
                let rows: Vec<_> = all
                    .iter()
                    .map(|e| {
                        serde_json::json!({
                            "name": e.name,
                            "default_on": e.default_on,
                            "summary": e.summary,
                            "source": e.source,
                            "requires": e.requires,
                        })
                    })
                    .collect();
                outln!("{}", serde_json::to_string_pretty(&rows)?);
            } else {
                for e in &all {
                    let state = if e.default_on { "on " } else { "off" };
                    outln!(
                        "{:<28} {state}  {}\n{:<33}source: {}",
                        e.name,
                        e.summary,
                        "",
                        e.source
                    );
                    if let Some(p) = e.requires {
                        outln!("{:<33}requires: {p}", "");
                    }
                }
            }
            Ok(())
        }
        Command::ModelDescription { sensor } => {
            out!(
                "{}",
                osiris_fmu::sensors::descriptor(sensor.into()).model_description()
            );
            Ok(())
        }
    }
}

fn sensor_list(args: &[SensorArg]) -> Vec<SensorKind> {
    if args.is_empty() {
        SensorKind::ALL.to_vec()
    } else {
        args.iter().map(|&s| s.into()).collect()
    }
}

/// The FMU folder to use: the given one as it is, or `target/fmu/`, where each FMU is (re)packaged
/// when it is missing or older than its library (cargo rebuilds a stale library first; an up-to-date
/// build is a no-op).
pub fn ensure_fmus(fmu_dir: Option<PathBuf>, sensors: &[SensorKind]) -> Result<PathBuf> {
    if let Some(dir) = fmu_dir {
        for kind in sensors {
            let p = dir.join(format!("{}.fmu", kind.name()));
            if !p.is_file() {
                bail!(
                    "{} is missing (package it with `osiris package --out {}`)",
                    p.display(),
                    dir.display()
                );
            }
        }
        return Ok(dir);
    }
    let dir = package::default_fmu_dir();
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    for &kind in sensors {
        let lib = package::fmu_library(kind, None, None)?;
        let fmu = dir.join(format!("{}.fmu", kind.name()));
        if !package::is_up_to_date(&fmu, &lib) {
            eprintln!("packaging {}", fmu.display());
            package::write_fmu(osiris_fmu::sensors::descriptor(kind), &lib, &fmu)?;
        }
    }
    Ok(dir)
}

fn parse_params(params: &[String]) -> Result<Vec<(String, String)>> {
    params
        .iter()
        .map(|p| {
            let (k, v) = p
                .split_once('=')
                .with_context(|| format!("--param `{p}`: expected NAME=VALUE, e.g. range_m=80"))?;
            Ok((k.trim().to_owned(), v.to_owned()))
        })
        .collect()
}

/// Per-sensor statistics of a run, for the summary.
#[derive(Debug, Default, serde::Serialize)]
struct SensorStats {
    sensor: String,
    kind: String,
    fmu: String,
    sensor_data_trace: String,
    perception_trace: String,
    frames: usize,
    frames_with_sensor_data: usize,
    moving_objects_detected_total: usize,
    stationary_objects_detected_total: usize,
    max_moving_objects_in_a_frame: usize,
    feature_detections_total: usize,
    distinct_ground_truth_ids: Vec<u64>,
    closest_object_m: Option<f64>,
    wall_ms_per_sensor_step: f64,
}

/// One sensor of a run: an FMU instance fed by one SensorView stream.
struct RunSensor {
    name: String,
    kind: SensorKind,
}

fn run(args: RunArgs) -> Result<()> {
    let kinds = sensor_list(&args.sensors);
    let params = parse_params(&args.params)?;

    // Scenario source: the scenario's sensors of the requested kinds (one SensorView stream each),
    // or a SensorView trace fed to one instance of each requested kind.
    let (run_sensors, frames, source_name) = if let Some(trace) = &args.trace {
        let sensors: Vec<RunSensor> = kinds
            .iter()
            .map(|k| RunSensor {
                name: k.name().to_owned(),
                kind: *k,
            })
            .collect();
        (sensors, trace_frames(trace)?, trace.display().to_string())
    } else {
        let scenario = match &args.scenario {
            Some(path) => ScenarioConfig::from_json_file(path)?,
            None => ScenarioConfig::default(),
        };
        let mounts: Vec<SensorMount> = scenario
            .sensors
            .iter()
            .filter(|m| kinds.contains(&m.kind))
            .cloned()
            .collect();
        if mounts.is_empty() {
            bail!("the scenario has no sensor of the requested kinds ({kinds:?})");
        }
        let frames = scenario_frames(&scenario, &mounts, args.max_frames);
        let sensors = mounts
            .iter()
            .map(|m| RunSensor {
                name: m.name.clone(),
                kind: m.kind,
            })
            .collect();
        let name = args
            .scenario
            .as_ref()
            .map_or("built-in default scenario".to_owned(), |p| {
                p.display().to_string()
            });
        (sensors, frames, name)
    };
    let frames: Vec<Frame> = match args.max_frames {
        Some(n) => frames.into_iter().take(n).collect(),
        None => frames,
    };
    if frames.is_empty() {
        bail!("the scenario source produced no frames");
    }
    let used_kinds: Vec<SensorKind> = SensorKind::ALL
        .into_iter()
        .filter(|k| run_sensors.iter().any(|s| s.kind == *k))
        .collect();
    let fmu_dir = ensure_fmus(args.fmu_dir.clone(), &used_kinds)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;

    // FMUs (one per kind) and instances (one per sensor).
    let mut fmus = std::collections::HashMap::new();
    for kind in &used_kinds {
        let path = fmu_dir.join(format!("{}.fmu", kind.name()));
        fmus.insert(
            *kind,
            Fmu::load(&path).with_context(|| format!("loading {}", path.display()))?,
        );
    }
    let mut sensors = Vec::new();
    for rs in &run_sensors {
        let fmu = &fmus[&rs.kind];
        let mut sensor = OsmpSensor::instantiate(fmu, &rs.name, InstanceOptions::default())?;
        let md = fmu.model_description();
        let mut values = Vec::new();
        for (name, text) in &params {
            let var = md.variable(name).with_context(|| {
                format!(
                    "--param {name}: the {} FMU has no variable `{name}`",
                    rs.kind.name()
                )
            })?;
            let value = Value::parse(var.var_type, text)
                .map_err(|e| anyhow::anyhow!("--param {name}={text}: {e}"))?;
            values.push((name.as_str(), value));
        }
        sensor
            .initialize(frames[0].time, &values)
            .with_context(|| format!("initialising sensor `{}`", rs.name))?;
        sensors.push(sensor);
    }

    // Output traces.
    let n_frames = frames.len();
    let mut sd_writers = Vec::new();
    let mut pd_writers = Vec::new();
    let mut stats: Vec<SensorStats> = Vec::new();
    let stamp = std::time::SystemTime::now();
    for rs in &run_sensors {
        let sd_name = crate::trace::trace_file_name(
            stamp,
            "sd",
            "380",
            PROTOBUF_VERSION_TAG,
            n_frames as u64,
            &rs.name,
        )?;
        let pd_name = format!("{}.perception.osi", rs.name);
        sd_writers.push(OsiTraceWriter::create(args.out.join(&sd_name))?);
        pd_writers.push(OsiTraceWriter::create(args.out.join(&pd_name))?);
        stats.push(SensorStats {
            sensor: rs.name.clone(),
            kind: rs.kind.name().to_owned(),
            fmu: fmu_dir
                .join(format!("{}.fmu", rs.kind.name()))
                .display()
                .to_string(),
            sensor_data_trace: args.out.join(&sd_name).display().to_string(),
            perception_trace: args.out.join(&pd_name).display().to_string(),
            ..SensorStats::default()
        });
    }

    let bar = if args.quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(n_frames as u64)
    };
    bar.set_style(
        ProgressStyle::with_template("{spinner} {msg} [{bar:40}] {pos}/{len} frames ({eta})")
            .expect("valid template")
            .progress_chars("=> "),
    );
    bar.set_message("stepping FMUs");
    let started = Instant::now();
    let mut last_frame = usize::MAX;
    let options = RunOptions {
        step_size: args.step_size,
        parallel: args.parallel,
        multi_rate: !args.every_frame,
    };
    let summary = crate::master::run(
        &mut sensors,
        frames.into_iter().map(Ok::<_, std::convert::Infallible>),
        &options,
        |rec: StepRecord<'_>| -> Result<()> {
            if rec.frame_index != last_frame {
                bar.inc(1);
                last_frame = rec.frame_index;
            }
            let s = &mut stats[rec.sensor_index];
            s.frames += 1;
            if let Some(bytes) = &rec.outputs.sensor_data {
                sd_writers[rec.sensor_index].write_raw(bytes)?;
                let sd = osi3::SensorData::decode(bytes.as_slice())
                    .context("decoding the FMU's SensorData")?;
                accumulate(s, &sd);
            }
            if let Some(bytes) = &rec.outputs.perception {
                pd_writers[rec.sensor_index].write_raw(bytes)?;
                // Check it decodes: a broken extension message is an FMU bug worth stopping for.
                perception::PerceptionData::decode(bytes.as_slice())
                    .context("decoding the FMU's PerceptionData")?;
            }
            Ok(())
        },
    )?;
    bar.finish_and_clear();
    let elapsed_s = started.elapsed().as_secs_f64();
    for w in sd_writers.iter_mut().chain(pd_writers.iter_mut()) {
        w.flush()?;
    }
    for (i, s) in stats.iter_mut().enumerate() {
        let steps: usize = summary.sensor_data_frames.iter().sum::<usize>().max(1);
        s.wall_ms_per_sensor_step = 1e3 * elapsed_s / steps as f64;
        debug_assert_eq!(summary.sensor_data_frames[i], s.frames_with_sensor_data);
    }
    for sensor in &mut sensors {
        sensor.terminate()?;
    }

    let text = summary_text(&source_name, &summary, &stats, elapsed_s);
    std::fs::write(args.out.join("summary.txt"), &text)?;
    let json = serde_json::json!({
        "source": source_name,
        "frames": summary.frames,
        "end_time_s": summary.end_time,
        "wall_time_s": elapsed_s,
        "sensors": stats,
    });
    std::fs::write(
        args.out.join("summary.json"),
        serde_json::to_string_pretty(&json)? + "\n",
    )?;
    out!("{text}");
    Ok(())
}

fn accumulate(s: &mut SensorStats, sd: &osi3::SensorData) {
    s.frames_with_sensor_data += 1;
    s.moving_objects_detected_total += sd.moving_object.len();
    s.stationary_objects_detected_total += sd.stationary_object.len();
    s.max_moving_objects_in_a_frame = s.max_moving_objects_in_a_frame.max(sd.moving_object.len());
    if let Some(fd) = &sd.feature_data {
        s.feature_detections_total += fd
            .radar_sensor
            .iter()
            .map(|d| d.detection.len())
            .sum::<usize>()
            + fd.lidar_sensor
                .iter()
                .map(|d| d.detection.len())
                .sum::<usize>()
            + fd.camera_sensor
                .iter()
                .map(|d| d.detection.len())
                .sum::<usize>();
    }
    let headers = sd
        .moving_object
        .iter()
        .filter_map(|o| o.header.as_ref())
        .chain(
            sd.stationary_object
                .iter()
                .filter_map(|o| o.header.as_ref()),
        );
    for h in headers {
        for id in h.ground_truth_id.iter().filter_map(|i| i.value) {
            if let Err(pos) = s.distinct_ground_truth_ids.binary_search(&id) {
                s.distinct_ground_truth_ids.insert(pos, id);
            }
        }
    }
    let positions = sd
        .moving_object
        .iter()
        .filter_map(|o| o.base.as_ref()?.position.as_ref())
        .chain(
            sd.stationary_object
                .iter()
                .filter_map(|o| o.base.as_ref()?.position.as_ref()),
        );
    for p in positions {
        let r =
            (p.x.unwrap_or(0.0).powi(2) + p.y.unwrap_or(0.0).powi(2) + p.z.unwrap_or(0.0).powi(2))
                .sqrt();
        s.closest_object_m = Some(s.closest_object_m.map_or(r, |c| c.min(r)));
    }
}

fn summary_text(
    source: &str,
    summary: &crate::master::RunSummary,
    stats: &[SensorStats],
    elapsed_s: f64,
) -> String {
    use std::fmt::Write;
    let mut t = String::new();
    let _ = writeln!(t, "osiris run: {source}");
    let _ = writeln!(
        t,
        "{} frames, simulated until t = {:.3} s, wall time {:.2} s",
        summary.frames,
        summary.end_time.unwrap_or(0.0),
        elapsed_s
    );
    for s in stats {
        let n = s.frames_with_sensor_data.max(1) as f64;
        let _ = writeln!(t, "\n[{}] {} FMU {}", s.sensor, s.kind, s.fmu);
        let _ = writeln!(
            t,
            "  SensorData frames       {} of {}",
            s.frames_with_sensor_data, s.frames
        );
        let _ = writeln!(
            t,
            "  moving objects / frame  {:.2} (max {}), stationary objects / frame {:.2}",
            s.moving_objects_detected_total as f64 / n,
            s.max_moving_objects_in_a_frame,
            s.stationary_objects_detected_total as f64 / n
        );
        let _ = writeln!(
            t,
            "  feature detections      {:.1} per frame",
            s.feature_detections_total as f64 / n
        );
        let _ = writeln!(
            t,
            "  ground-truth ids seen   {:?}",
            s.distinct_ground_truth_ids
        );
        if let Some(c) = s.closest_object_m {
            let _ = writeln!(t, "  closest object          {c:.2} m");
        }
        let _ = writeln!(t, "  SensorData trace        {}", s.sensor_data_trace);
        let _ = writeln!(t, "  PerceptionData trace    {}", s.perception_trace);
    }
    t
}

/// Frames of the scenario: one SensorView per sensor per step.
fn scenario_frames(
    scenario: &ScenarioConfig,
    mounts: &[SensorMount],
    max_frames: Option<usize>,
) -> Vec<Frame> {
    let steps = scenario.step_count().min(max_frames.unwrap_or(usize::MAX));
    (0..steps)
        .map(|step| {
            let views = mounts
                .iter()
                .map(|m| scenario.sensor_view(step, m).encode_to_vec())
                .collect();
            Frame::per_sensor(scenario.time_s(step), views)
        })
        .collect()
}

/// Frames of a SensorView `.osi` trace: each SensorView is fed to every sensor, at its timestamp.
fn trace_frames(path: &Path) -> Result<Vec<Frame>> {
    Ok(
        crate::master::sensor_view_trace_frames(OsiTraceReader::open(path)?)
            .collect::<Result<_, _>>()?,
    )
}
