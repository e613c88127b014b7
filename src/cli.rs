//! The `osiris` command line.
//!
//! * `osiris run`: the main job. Packages the FMUs if needed, steps all three (and any OSMP sensor FMU
//!   given with `--fmu`) over the built-in default scenario (or a scenario JSON, a SensorView `.osi` /
//!   `.mcap` trace, or an OSMP source FMU with `--source`) with the bundled master, and writes each
//!   sensor's SensorView, SensorData and PerceptionData traces (`.osi`, and/or one OSI `.mcap` per run
//!   with `--format`) and a summary to `out/`.
//! * `osiris package [--out DIR]`: builds `camera.fmu`, `radar.fmu`, `lidar.fmu` (default `target/fmu/`).
//! * `osiris bench <what>`: one JSON line of figures per benchmark, with the machine it ran on;
//!   `osiris bench report <json>...` turns such lines into docs/benchmarks.md.
//! * `osiris export <trace> --out <file>`: one frame of a PerceptionData trace (`.osi`, or a channel of
//!   an `.mcap`) as PCD/PLY (LiDAR), PNG/CSV (radar range-Doppler map) or PNG (camera).
//! * `osiris consistency --meta <campaign>/consistency.toml --out <dir>`: model vs measurement
//!   campaign, where it fails and which named effect explains it (summary.json, report.html).
//! * `osiris scenario`: prints the built-in default scenario as JSON (a starting point for your own).
//! * `osiris effects`: lists every named physical effect (name, default, formula, source);
//!   `--markdown` prints docs/effects.md.
//! * `osiris model-description <sensor>`: prints a sensor FMU's modelDescription.xml.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::{Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use osiris_models::SensorKind;
use osiris_proto::{Message, osi3, perception};

use crate::master::{
    Fmu, Frame, InstanceOptions, OsmpSensor, OsmpSource, RunOptions, StepRecord, Value,
};
use crate::package::{self, PackageOptions};
use crate::scenario::{ScenarioConfig, SensorMount};
use crate::trace::mcap::{ChannelHandle, McapTraceReader, McapTraceWriter, PERCEPTION_DATA_SCHEMA};
use crate::trace::{NamedOsiTraceWriter, OsiTraceReader, OsiTraceWriter};

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
    /// frames/s; and the whole sensor step (propagation, chain, recognition) on a 40-car street.
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
    /// Not a benchmark: turn the JSON lines of earlier `osiris bench` runs (the FILE arguments)
    /// into markdown, one table per line with the machine it ran on (docs/benchmarks.md).
    Report,
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
        /// `report`: files of `osiris bench` JSON lines.
        #[arg(value_name = "FILE")]
        files: Vec<PathBuf>,
        /// `report`: a paragraph printed under the title (e.g. the state of the machine).
        #[arg(long, value_name = "TEXT")]
        note: Option<String>,
    },
    /// Write one frame of a PerceptionData trace (`out/<sensor>.perception.osi`) as a file:
    /// a LiDAR point cloud as `.pcd` / `.ply`, a radar range-Doppler map as `.png` / `.csv`, a
    /// camera image as `.png` (8-bit ISP or 16-bit RAW).
    Export {
        /// PerceptionData trace written by `osiris run`: `<sensor>.perception.osi`, or the run's
        /// `.mcap` (with `--channel` when it holds several PerceptionData channels).
        #[arg(value_name = "TRACE")]
        trace: PathBuf,
        /// `.mcap` traces: the PerceptionData channel (topic), e.g. `front_radar.PerceptionDataOut`
        /// (default: the only PerceptionData channel).
        #[arg(long, value_name = "TOPIC")]
        channel: Option<String>,
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
    /// The report (report.html) and KPI tables (objects.csv, frames.csv) of a SensorData trace:
    /// `.osi`, or every SensorData channel of an `.mcap`; written by `osiris run` or another tool.
    View(crate::report::view::ViewArgs),
    /// Compare a model with a measurement campaign: paired residuals, metrics with tolerances,
    /// attribution of the misfit to named physical effects; writes summary.json and report.html.
    Consistency(crate::consistency::cli::ConsistencyArgs),
    /// Print the built-in default scenario as JSON.
    Scenario,
    /// List every named physical effect: name, default, formula, source.
    Effects {
        /// Print JSON instead of a table.
        #[arg(long, conflicts_with = "markdown")]
        json: bool,
        /// Print docs/effects.md (a markdown page with the table).
        #[arg(long)]
        markdown: bool,
    },
    /// Print the modelDescription.xml of a sensor FMU.
    ModelDescription {
        #[arg(value_enum)]
        sensor: SensorArg,
    },
}

/// Trace formats `osiris run` writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum TraceFormat {
    /// Single-channel `.osi` traces: SensorView, SensorData and PerceptionData per sensor.
    Osi,
    /// One OSI multi-channel `.mcap` trace with every sensor's channels.
    Mcap,
    /// Both.
    Both,
}

/// Arguments of `osiris run`.
#[derive(Debug, clap::Args)]
pub struct RunArgs {
    /// Scenario JSON (default: the built-in scenario; see `osiris scenario`).
    #[arg(long, value_name = "FILE", conflicts_with_all = ["trace", "source"])]
    pub scenario: Option<PathBuf>,
    /// Feed the SensorViews of this trace to every sensor instead of a generated scenario: an `.osi`
    /// SensorView trace or a SensorView channel of an `.mcap` trace (recognised by its magic).
    #[arg(long, value_name = "FILE", conflicts_with = "source")]
    pub trace: Option<PathBuf>,
    /// `--trace` `.mcap`: the SensorView channel (topic) to replay (default: the only one).
    #[arg(long, value_name = "TOPIC", requires = "trace")]
    pub channel: Option<String>,
    /// Step this OSMP source FMU (an `OSMPSensorViewOut` output, e.g. a scenario player) every frame
    /// and feed its SensorView to every sensor.
    #[arg(long, value_name = "FMU")]
    pub source: Option<PathBuf>,
    /// Frame step, s. `--source`: the master's step (default: the source's DefaultExperiment
    /// stepSize, else 0.01 s); `--trace`: overrides the time between frames.
    #[arg(long, value_name = "S")]
    pub step_size: Option<f64>,
    /// `--source`: simulated time, s (default: the source's DefaultExperiment stop − start time,
    /// else 2 s); `--max-frames` stops earlier.
    #[arg(long, value_name = "S", requires = "source")]
    pub duration: Option<f64>,
    /// Built-in sensors to run (default: camera, radar, lidar; none when `--fmu` is given).
    #[arg(long, value_enum, value_delimiter = ',')]
    pub sensors: Vec<SensorArg>,
    /// Add an OSMP sensor FMU (SensorView in, SensorData out) by another vendor, named NAME (default:
    /// its modelName); repeatable.
    #[arg(long = "fmu", value_name = "[NAME=]PATH")]
    pub fmus: Vec<String>,
    /// Folder with the packaged FMUs (packaged there first if missing or stale).
    #[arg(long, value_name = "DIR")]
    pub fmu_dir: Option<PathBuf>,
    /// Output folder.
    #[arg(long, value_name = "DIR", default_value = "out")]
    pub out: PathBuf,
    /// Trace format: `osi` (one `.osi` file per stream), `mcap` (one `.mcap` per run), `both`.
    #[arg(long, value_enum, default_value = "osi")]
    pub format: TraceFormat,
    /// FMU parameter `NAME=VALUE` for every built-in sensor (e.g. `mode=ideal`, `range_m=80`);
    /// repeatable.
    #[arg(long = "param", value_name = "NAME=VALUE")]
    pub params: Vec<String>,
    /// Stop after this many frames.
    #[arg(long, value_name = "N")]
    pub max_frames: Option<usize>,
    /// Step the sensors of a frame in parallel threads.
    #[arg(long)]
    pub parallel: bool,
    /// Step every sensor at every frame (default: each sensor at its own cycle, the FMU's default
    /// step size, at t0 + n·cycle on the master's clock with the frame nearest to each instant).
    #[arg(long)]
    pub every_frame: bool,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
    /// Write no report.html (objects.csv and frames.csv are still written).
    #[arg(long)]
    pub no_report: bool,
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
        Command::View(args) => {
            let paths = crate::report::view::view(&args)?;
            if let Some(p) = &paths.report_html {
                outln!("report       {}", p.display());
            }
            outln!("objects.csv  {}", paths.objects_csv.display());
            outln!("frames.csv   {}", paths.frames_csv.display());
            Ok(())
        }
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
            files,
            note,
        } => {
            if what == BenchWhat::Report {
                outln!("{}", bench_report(&files, note.as_deref())?.trim_end());
                return Ok(());
            }
            if !files.is_empty() {
                bail!("FILE arguments are for `osiris bench report` only");
            }
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
                BenchWhat::Radar => {
                    let frames = frames.unwrap_or(40).max(1);
                    let mut figures = osiris_models::radar::bench::bench_radar(max_threads, frames);
                    let street =
                        crate::bench::bench_radar_street(max_threads.unwrap_or(2), frames.min(10))?;
                    if let (Some(f), Some(s)) = (figures.as_object_mut(), street.as_object()) {
                        f.extend(s.clone());
                    }
                    figures
                }
                BenchWhat::Camera => osiris_models::camera::bench::bench_camera(
                    max_threads,
                    frames.unwrap_or(5).max(1),
                ),
                BenchWhat::Consistency => crate::consistency::bench::bench_consistency(max_threads),
                BenchWhat::ConsistencyProtocol => consistency_protocol()?,
                BenchWhat::Report => unreachable!("handled above"),
            };
            let mut figures = figures;
            if let Some(name) = what.to_possible_value() {
                crate::bench::stamp(&mut figures, name.get_name());
            }
            outln!("{}", serde_json::to_string(&figures)?);
            Ok(())
        }
        Command::Export {
            trace,
            channel,
            out,
            frame,
            image,
        } => {
            let what = crate::export::export_frame(&trace, channel.as_deref(), frame, &out, image)?;
            eprintln!("{what}");
            Ok(())
        }
        Command::Consistency(args) => crate::consistency::cli::run(args),
        Command::Scenario => {
            outln!("{}", ScenarioConfig::default().to_json_pretty());
            Ok(())
        }
        Command::Effects { json, markdown } => {
            let all = osiris_models::registry::catalogue();
            if markdown {
                out!("{}", effects_markdown(&all));
            } else if json {
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

/// `osiris bench report FILE...`: the markdown of every JSON line in the files.
fn bench_report(files: &[PathBuf], note: Option<&str>) -> Result<String> {
    if files.is_empty() {
        bail!(
            "`osiris bench report` needs the JSON files of earlier runs, e.g. \
             osiris bench report docs/benchmarks/*.json"
        );
    }
    let mut runs = Vec::new();
    for f in files {
        let text =
            std::fs::read_to_string(f).with_context(|| format!("reading {}", f.display()))?;
        for (i, line) in text.lines().enumerate() {
            if line.trim().is_empty() {
                continue;
            }
            let v: serde_json::Value = serde_json::from_str(line).with_context(|| {
                format!(
                    "{}:{}: not a JSON line of `osiris bench`",
                    f.display(),
                    i + 1
                )
            })?;
            runs.push(v);
        }
    }
    let known: Vec<(String, String)> = BenchWhat::value_variants()
        .iter()
        .filter(|w| **w != BenchWhat::Report)
        .filter_map(|w| w.to_possible_value())
        .map(|p| {
            let about = p.get_help().map(|h| h.to_string()).unwrap_or_default();
            let about = about.trim_end_matches('.').to_owned() + ".";
            (p.get_name().to_owned(), about)
        })
        .collect();
    Ok(crate::bench::markdown_report(&runs, &known, note))
}

/// `osiris effects --markdown`: the page docs/effects.md, generated from the catalogue.
pub fn effects_markdown(all: &[osiris_models::effects::EffectInfo]) -> String {
    let cell = |s: &str| s.replace('|', "\\|");
    let mut md = String::from(
        "# Named physical effects\n\n\
         <!-- Generated by `cargo run -- effects --markdown > docs/effects.md`; do not edit (a test \
         compares). -->\n\n\
         Every physical effect of the models is a named switch. Set it per FMU in the configuration \
         (`\"effects\": {\"lidar.range_walk\": false}`, see [fmu.md](fmu.md#configuration)), or per \
         re-simulation with `osiris consistency --enable/--disable` ([consistency.md](consistency.md)). \
         An effect that requires another applies only while that one is on too. `osiris effects` \
         prints the same list as text, `osiris effects --json` as JSON.\n\n\
         | effect | default | what it does | source |\n|---|---|---|---|\n",
    );
    for e in all {
        let requires = e
            .requires
            .map_or(String::new(), |r| format!(" Requires `{r}`."));
        md.push_str(&format!(
            "| `{}` | {} | {}{requires} | {} |\n",
            e.name,
            if e.default_on { "on" } else { "off" },
            cell(e.summary),
            cell(e.source),
        ));
    }
    md
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
    ensure_fmus_with(fmu_dir, sensors, &ProgressBar::hidden())
}

/// [`ensure_fmus`] showing what it packages on `bar` (its message; the `packaging` lines are
/// printed above it).
fn ensure_fmus_with(
    fmu_dir: Option<PathBuf>,
    sensors: &[SensorKind],
    bar: &ProgressBar,
) -> Result<PathBuf> {
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
        bar.set_message(format!("building the {} FMU library if stale", kind.name()));
        let lib = package::fmu_library(kind, None, None)?;
        let fmu = dir.join(format!("{}.fmu", kind.name()));
        if !package::is_up_to_date(&fmu, &lib) {
            bar.set_message(format!("packaging {}", fmu.display()));
            bar.suspend(|| eprintln!("packaging {}", fmu.display()));
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
    sensor_data_trace: Option<String>,
    sensor_view_trace: Option<String>,
    perception_trace: Option<String>,
    sensor_view_frames: usize,
    frames: usize,
    frames_with_sensor_data: usize,
    frames_with_perception_data: usize,
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
    /// Instance name, trace names, mcap topic prefix.
    name: String,
    /// `camera`, `radar`, `lidar`, or a foreign FMU's modelName.
    label: String,
    /// Index into the run's loaded FMUs.
    fmu: usize,
    /// The built-in kind (parameters from `--param` apply to these).
    builtin: Option<SensorKind>,
    /// Scenario input: the mounting whose SensorView the sensor gets.
    mount: Option<SensorMount>,
}

/// `--fmu [NAME=]PATH`.
fn parse_fmu_arg(arg: &str) -> (Option<String>, PathBuf) {
    match arg.split_once('=') {
        Some((name, path)) if !name.is_empty() && !name.contains('/') && !path.is_empty() => {
            (Some(name.to_owned()), PathBuf::from(path))
        }
        _ => (None, PathBuf::from(arg)),
    }
}

/// Seconds as ns for mcap times (negative: 0).
fn ns(t: f64) -> u64 {
    (t * 1e9).round().max(0.0) as u64
}

/// Where a run writes one sensor's streams.
#[derive(Default)]
struct SensorOutputs {
    sd: Option<crate::trace::NamedOsiTraceWriter>,
    sv: Option<crate::trace::NamedOsiTraceWriter>,
    /// PerceptionData `.osi`: (writer at the partial path, partial path, final path).
    pd: Option<(
        OsiTraceWriter<std::io::BufWriter<std::fs::File>>,
        PathBuf,
        PathBuf,
    )>,
    mcap_sv: Option<ChannelHandle>,
    mcap_sd: Option<ChannelHandle>,
    mcap_pd: Option<ChannelHandle>,
}

/// The input of a run.
enum RunInput {
    /// Scenario or trace frames, all read before the run.
    Frames(Vec<Frame>),
    /// An OSMP source FMU stepped every frame.
    Source {
        source: Box<OsmpSource>,
        start: f64,
        step: f64,
        frames: usize,
    },
}

fn run(args: RunArgs) -> Result<()> {
    let params = parse_params(&args.params)?;
    let foreign: Vec<(Option<String>, PathBuf)> =
        args.fmus.iter().map(|a| parse_fmu_arg(a)).collect();
    let kinds: Vec<SensorKind> = if args.sensors.is_empty() && !foreign.is_empty() {
        Vec::new()
    } else {
        sensor_list(&args.sensors)
    };
    if let Some(h) = args.step_size
        && !(h > 0.0 && h.is_finite())
    {
        bail!("--step-size {h}: expected a step > 0 s");
    }
    if let Some(d) = args.duration
        && !(d > 0.0 && d.is_finite())
    {
        bail!("--duration {d}: expected a time > 0 s");
    }

    // Foreign FMUs first: a bad path or a non-OSMP FMU is reported before anything is packaged.
    let mut fmus: Vec<(Fmu, PathBuf)> = Vec::new();
    let mut foreign_sensors = Vec::new();
    for (name, path) in &foreign {
        // One library per FMU file, however many instances: a second copy of the same binary in
        // the process would register its globals twice (e.g. protobuf descriptors, which aborts).
        let same = |p: &PathBuf| {
            p == path
                || std::fs::canonicalize(p)
                    .ok()
                    .is_some_and(|c| std::fs::canonicalize(path).ok() == Some(c))
        };
        let index = match fmus.iter().position(|(_, p)| same(p)) {
            Some(i) => i,
            None => {
                let fmu = Fmu::load(path).with_context(|| format!("--fmu {}", path.display()))?;
                fmus.push((fmu, path.clone()));
                fmus.len() - 1
            }
        };
        let label = fmus[index].0.model_description().model_name.clone();
        let name = name.clone().unwrap_or_else(|| label.clone());
        foreign_sensors.push(RunSensor {
            name,
            label,
            fmu: index,
            builtin: None,
            mount: None,
        });
    }

    // Input: the scenario's sensors of the requested kinds (one SensorView stream each), a trace or a
    // source fed to one instance of each requested kind.
    let builtin: Vec<RunSensor>;
    let (input, source_name, custom_name) = if let Some(trace) = &args.trace {
        builtin = kinds
            .iter()
            .map(|k| RunSensor {
                name: k.name().to_owned(),
                label: k.name().to_owned(),
                fmu: 0,
                builtin: Some(*k),
                mount: None,
            })
            .collect();
        let frames = trace_frames(trace, args.channel.as_deref())?;
        let stem = trace
            .file_stem()
            .map_or("trace".into(), |s| s.to_string_lossy().into_owned());
        (
            RunInput::Frames(frames),
            trace.display().to_string(),
            format!("replay-{stem}"),
        )
    } else if let Some(path) = &args.source {
        builtin = kinds
            .iter()
            .map(|k| RunSensor {
                name: k.name().to_owned(),
                label: k.name().to_owned(),
                fmu: 0,
                builtin: Some(*k),
                mount: None,
            })
            .collect();
        let fmu = Fmu::load(path).with_context(|| format!("--source {}", path.display()))?;
        let md = fmu.model_description();
        let model = md.model_name.clone();
        let experiment = md.default_experiment;
        let mut source = OsmpSource::instantiate(&fmu, "source", InstanceOptions::default())
            .with_context(|| format!("--source {}", path.display()))?;
        let start = experiment.and_then(|d| d.start_time).unwrap_or(0.0);
        let step = args
            .step_size
            .or(source.default_step_size())
            .filter(|h| *h > 0.0 && h.is_finite())
            .unwrap_or(DEFAULT_SOURCE_STEP_S);
        let duration = args
            .duration
            .or_else(|| {
                experiment
                    .and_then(|d| d.stop_time)
                    .map(|stop| stop - start)
                    .filter(|d| *d > 0.0)
            })
            .unwrap_or(DEFAULT_SOURCE_DURATION_S);
        let mut frames = ((duration / step) - 1e-9).ceil().max(1.0) as usize;
        if let Some(n) = args.max_frames {
            frames = frames.min(n);
        }
        source
            .initialize(start, &[])
            .with_context(|| format!("initialising the source FMU {}", path.display()))?;
        (
            RunInput::Source {
                source: Box::new(source),
                start,
                step,
                frames,
            },
            format!("OSMP source {model} ({})", path.display()),
            model,
        )
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
        if mounts.is_empty() && foreign_sensors.is_empty() {
            bail!("the scenario has no sensor of the requested kinds ({kinds:?})");
        }
        builtin = mounts
            .iter()
            .map(|m| RunSensor {
                name: m.name.clone(),
                label: m.kind.name().to_owned(),
                fmu: 0,
                builtin: Some(m.kind),
                mount: Some(m.clone()),
            })
            .collect();
        // Foreign sensors see the scenario from the first sensor's mounting, with their own ids.
        let template = scenario.sensors.first().context(
            "the scenario has no sensors (a foreign FMU takes the first one's mounting)",
        )?;
        for (k, s) in foreign_sensors.iter_mut().enumerate() {
            s.mount = Some(SensorMount {
                name: s.name.clone(),
                sensor_id: FOREIGN_SENSOR_ID_BASE + k as u64,
                ..template.clone()
            });
        }
        let all_mounts: Vec<SensorMount> = builtin
            .iter()
            .chain(&foreign_sensors)
            .filter_map(|s| s.mount.clone())
            .collect();
        let frames = scenario_frames(&scenario, &all_mounts, args.max_frames);
        let name = args
            .scenario
            .as_ref()
            .map_or("built-in default scenario".to_owned(), |p| {
                p.display().to_string()
            });
        (RunInput::Frames(frames), name, scenario.name.clone())
    };
    let mut run_sensors = builtin;
    run_sensors.extend(foreign_sensors);
    if run_sensors.is_empty() {
        bail!("no sensors to run: name built-in ones with --sensors or add FMUs with --fmu");
    }
    for (i, s) in run_sensors.iter().enumerate() {
        if run_sensors[..i].iter().any(|o| o.name == s.name) {
            bail!(
                "two sensors are named `{}`; name FMUs with --fmu NAME=PATH",
                s.name
            );
        }
    }
    let input = match input {
        RunInput::Frames(frames) => {
            let frames: Vec<Frame> = match args.max_frames {
                Some(n) => frames.into_iter().take(n).collect(),
                None => frames,
            };
            if frames.is_empty() {
                bail!("the scenario source produced no frames");
            }
            RunInput::Frames(frames)
        }
        source => source,
    };
    let (start_time, n_frames) = match &input {
        RunInput::Frames(f) => (f[0].time, f.len()),
        RunInput::Source {
            start,
            step,
            frames,
            ..
        } => (start + step, *frames),
    };

    // Progress (stderr; indicatif draws nothing when stderr is not a terminal): packaging, frames,
    // report.
    let bar = if args.quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new_spinner()
    };
    bar.enable_steady_tick(std::time::Duration::from_millis(120));
    bar.set_message("checking the FMUs");

    // Built-in FMUs (one per kind).
    let used_kinds: Vec<SensorKind> = SensorKind::ALL
        .into_iter()
        .filter(|k| run_sensors.iter().any(|s| s.builtin == Some(*k)))
        .collect();
    if !used_kinds.is_empty() {
        let fmu_dir = ensure_fmus_with(args.fmu_dir.clone(), &used_kinds, &bar)?;
        for kind in &used_kinds {
            let path = fmu_dir.join(format!("{}.fmu", kind.name()));
            let fmu = Fmu::load(&path).with_context(|| format!("loading {}", path.display()))?;
            for s in run_sensors.iter_mut().filter(|s| s.builtin == Some(*kind)) {
                s.fmu = fmus.len();
            }
            fmus.push((fmu, path));
        }
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;

    // Instances (one per sensor).
    let mut sensors = Vec::new();
    for rs in &run_sensors {
        let (fmu, path) = &fmus[rs.fmu];
        let mut sensor = OsmpSensor::instantiate(fmu, &rs.name, InstanceOptions::default())
            .with_context(|| format!("{} ({})", rs.name, path.display()))?;
        let md = fmu.model_description();
        let mut values = Vec::new();
        if rs.builtin.is_some() {
            for (name, text) in &params {
                let var = md.variable(name).with_context(|| {
                    format!(
                        "--param {name}: the {} FMU has no variable `{name}`",
                        rs.label
                    )
                })?;
                let value = Value::parse(var.var_type, text)
                    .map_err(|e| anyhow::anyhow!("--param {name}={text}: {e}"))?;
                values.push((name.as_str(), value));
            }
        }
        sensor
            .initialize(start_time, &values)
            .with_context(|| format!("initialising sensor `{}`", rs.name))?;
        sensors.push(sensor);
    }

    // Output traces, written under temporary names and renamed with their message counts.
    let stamp = std::time::SystemTime::now();
    let write_osi = args.format != TraceFormat::Mcap;
    let name = |type_code: &str, osi: &str, custom: &str| crate::trace::TraceName {
        timestamp_utc: stamp,
        type_code: type_code.to_owned(),
        osi_version: osi.to_owned(),
        protobuf_version: PROTOBUF_VERSION_TAG.to_owned(),
        custom: custom.to_owned(),
    };
    let mut mcap = if args.format == TraceFormat::Osi {
        None
    } else {
        let mut w = McapTraceWriter::create_in(&args.out, name("multi", "3.8.0", &custom_name))?;
        w.set_file_metadata(
            "description",
            &format!(
                "osiris run: {} sensor(s) ({}) fed by {source_name}",
                run_sensors.len(),
                run_sensors
                    .iter()
                    .map(|s| s.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        )?;
        w.set_file_metadata("data_sources", &source_name)?;
        Some(w)
    };
    let mut outputs: Vec<SensorOutputs> = Vec::new();
    let mut stats: Vec<SensorStats> = Vec::new();
    for (rs, sensor) in run_sensors.iter().zip(&sensors) {
        let (sv_in, sd_out, pd_out) = sensor.binary_variables();
        let osi_tag = |mime: &str| {
            crate::master::mime_parameter(mime, "version")
                .unwrap_or("3.8.0")
                .to_owned()
        };
        let has_pd = pd_out.is_some();
        let mut o = SensorOutputs::default();
        if write_osi {
            o.sd = Some(NamedOsiTraceWriter::create_in(
                &args.out,
                name("sd", &osi_tag(&sd_out.mime), &rs.name),
            )?);
            o.sv = Some(NamedOsiTraceWriter::create_in(
                &args.out,
                name("sv", &osi_tag(&sv_in.mime), &rs.name),
            )?);
            if has_pd {
                let path = args.out.join(format!("{}.perception.osi", rs.name));
                let partial = args.out.join(format!("{}.perception.osi.part", rs.name));
                o.pd = Some((OsiTraceWriter::create(&partial)?, partial, path));
            }
        }
        if let Some(w) = mcap.as_mut() {
            o.mcap_sv = Some(w.add_channel(
                &format!("{}.{}", rs.name, sv_in.prefix),
                "osi3.SensorView",
                Some(&format!("SensorView input of {} ({})", rs.name, rs.label)),
            )?);
            o.mcap_sd = Some(w.add_channel(
                &format!("{}.{}", rs.name, sd_out.prefix),
                "osi3.SensorData",
                Some(&format!("SensorData output of {} ({})", rs.name, rs.label)),
            )?);
            if let Some(pd) = pd_out {
                o.mcap_pd = Some(w.add_channel(
                    &format!("{}.{}", rs.name, pd.prefix),
                    PERCEPTION_DATA_SCHEMA,
                    Some(&format!(
                        "PerceptionData output of {} ({})",
                        rs.name, rs.label
                    )),
                )?);
            }
        }
        outputs.push(o);
        stats.push(SensorStats {
            sensor: rs.name.clone(),
            kind: rs.label.clone(),
            fmu: fmus[rs.fmu].1.display().to_string(),
            ..SensorStats::default()
        });
    }

    let mut report = crate::report::ReportBuilder::new(source_name.clone());
    for rs in &run_sensors {
        report.add_sensor(
            &rs.name,
            Some(crate::report::SectionKind::from_label(&rs.label)),
        );
    }

    bar.set_length(n_frames as u64);
    bar.set_style(
        ProgressStyle::with_template("{spinner} {msg} [{bar:40}] {pos}/{len} frames ({eta})")
            .expect("valid template")
            .progress_chars("=> "),
    );
    bar.set_message("stepping FMUs");
    let started = Instant::now();
    let mut last_frame = usize::MAX;
    let options = RunOptions {
        step_size: match &input {
            RunInput::Source { step, .. } => Some(*step),
            RunInput::Frames(_) => args.step_size,
        },
        parallel: args.parallel,
        multi_rate: !args.every_frame,
    };
    let sink = |rec: StepRecord<'_>| -> Result<()> {
        if rec.frame_index != last_frame {
            bar.inc(1);
            last_frame = rec.frame_index;
        }
        let s = &mut stats[rec.sensor_index];
        let o = &mut outputs[rec.sensor_index];
        s.frames += 1;
        if !rec.sensor_view.is_empty() {
            s.sensor_view_frames += 1;
            if let Some(w) = o.sv.as_mut() {
                w.write_raw(rec.sensor_view)?;
            }
            if let (Some(w), Some(c)) = (mcap.as_mut(), o.mcap_sv) {
                w.write(c, rec.sensor_view, ns(rec.frame_time))?;
            }
        }
        let done = ns(rec.time + rec.step_size);
        let mut sd_decoded = None;
        if let Some(bytes) = &rec.outputs.sensor_data {
            let sd = osi3::SensorData::decode(bytes.as_slice())
                .with_context(|| format!("decoding the SensorData of `{}`", rec.sensor_name))?;
            accumulate(s, &sd);
            sd_decoded = Some(sd);
            if let Some(w) = o.sd.as_mut() {
                w.write_raw(bytes)?;
            }
            if let (Some(w), Some(c)) = (mcap.as_mut(), o.mcap_sd) {
                w.write(c, bytes, done)?;
            }
        }
        let mut pd_decoded = None;
        if let Some(bytes) = &rec.outputs.perception {
            // Check it decodes: a broken extension message is an FMU bug worth stopping for.
            pd_decoded = Some(
                perception::PerceptionData::decode(bytes.as_slice()).with_context(|| {
                    format!("decoding the PerceptionData of `{}`", rec.sensor_name)
                })?,
            );
            s.frames_with_perception_data += 1;
            if let Some((w, _, _)) = o.pd.as_mut() {
                w.write_raw(bytes)?;
            }
            if let (Some(w), Some(c)) = (mcap.as_mut(), o.mcap_pd) {
                w.write(c, bytes, done)?;
            }
        }
        if let Some(sd) = &sd_decoded {
            let sv =
                if rec.sensor_view.is_empty() {
                    None
                } else {
                    Some(osi3::SensorView::decode(rec.sensor_view).with_context(|| {
                        format!("decoding the SensorView of `{}`", rec.sensor_name)
                    })?)
                };
            report.push(crate::report::ReportStep {
                sensor: rec.sensor_name,
                time_s: rec.time + rec.step_size,
                sensor_view: sv.as_ref(),
                sensor_data: sd,
                perception: pd_decoded.as_ref(),
                step_wall_ms: rec.step_wall_ms,
            });
        }
        Ok(())
    };
    let summary = match input {
        RunInput::Frames(frames) => crate::master::run(
            &mut sensors,
            frames.into_iter().map(Ok::<_, std::convert::Infallible>),
            &options,
            sink,
        )?,
        RunInput::Source {
            mut source,
            start,
            step,
            frames,
        } => {
            let summary = crate::master::run(
                &mut sensors,
                crate::master::source_frames(&mut source, start, step, frames),
                &options,
                sink,
            )?;
            source.terminate()?;
            summary
        }
    };
    let elapsed_s = started.elapsed().as_secs_f64();
    for sensor in &mut sensors {
        sensor.terminate()?;
    }
    let steps: usize = stats.iter().map(|s| s.frames).sum::<usize>().max(1);
    for (s, o) in stats.iter_mut().zip(outputs) {
        s.wall_ms_per_sensor_step = 1e3 * elapsed_s / steps as f64;
        if let Some(w) = o.sd {
            s.sensor_data_trace = Some(w.finish()?.display().to_string());
        }
        if let Some(w) = o.sv {
            s.sensor_view_trace = Some(w.finish()?.display().to_string());
        }
        if let Some((w, partial, path)) = o.pd {
            drop(w.finish()?);
            crate::trace::rename_trace(&partial, &path)?;
            s.perception_trace = Some(path.display().to_string());
        }
    }
    let mcap_path = match mcap {
        Some(w) => Some(w.finish_named()?.display().to_string()),
        None => None,
    };

    bar.set_style(ProgressStyle::with_template("{spinner} {msg}").expect("valid template"));
    bar.set_message(if args.no_report {
        "writing objects.csv, frames.csv"
    } else {
        "writing report.html, objects.csv, frames.csv"
    });
    let report_started = Instant::now();
    let report_paths = report.write(&args.out, !args.no_report)?;
    let report_s = report_started.elapsed().as_secs_f64();
    bar.finish_and_clear();
    let mut text = summary_text(
        &source_name,
        &summary,
        &stats,
        mcap_path.as_deref(),
        elapsed_s,
    );
    text.push('\n');
    if let Some(p) = &report_paths.report_html {
        text.push_str(&format!(
            "report                    {} ({report_s:.2} s)\n",
            p.display()
        ));
    }
    text.push_str(&format!(
        "KPI tables                {}, {}\n",
        report_paths.objects_csv.display(),
        report_paths.frames_csv.display()
    ));
    std::fs::write(args.out.join("summary.txt"), &text)?;
    let json = serde_json::json!({
        "source": source_name,
        "frames": summary.frames,
        "end_time_s": summary.end_time,
        "wall_time_s": elapsed_s,
        "mcap_trace": mcap_path,
        "report": report_paths.report_html.as_ref().map(|p| p.display().to_string()),
        "report_wall_time_s": report_s,
        "objects_csv": report_paths.objects_csv.display().to_string(),
        "frames_csv": report_paths.frames_csv.display().to_string(),
        "sensors": stats,
    });
    std::fs::write(
        args.out.join("summary.json"),
        serde_json::to_string_pretty(&json)? + "\n",
    )?;
    out!("{text}");
    Ok(())
}

/// `--source` frame step when neither `--step-size` nor the source's DefaultExperiment gives one, s.
pub const DEFAULT_SOURCE_STEP_S: f64 = 0.01;
/// `--source` duration when neither `--duration` nor the source's DefaultExperiment gives one, s.
pub const DEFAULT_SOURCE_DURATION_S: f64 = 2.0;
/// OSI sensor ids of foreign FMUs fed by the scenario: 1000, 1001, … in `--fmu` order.
pub const FOREIGN_SENSOR_ID_BASE: u64 = 1000;

fn accumulate(s: &mut SensorStats, sd: &osi3::SensorData) {
    s.frames_with_sensor_data += 1;
    s.moving_objects_detected_total += sd.moving_object.len();
    s.stationary_objects_detected_total += sd.stationary_object.len();
    s.max_moving_objects_in_a_frame = s.max_moving_objects_in_a_frame.max(sd.moving_object.len());
    s.feature_detections_total += crate::report::kpi::feature_detections(sd);
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
    mcap: Option<&str>,
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
    if let Some(m) = mcap {
        let _ = writeln!(t, "MCAP trace {m}");
    }
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
        for (what, path) in [
            ("SensorView trace      ", &s.sensor_view_trace),
            ("SensorData trace      ", &s.sensor_data_trace),
            ("PerceptionData trace  ", &s.perception_trace),
        ] {
            if let Some(p) = path {
                let _ = writeln!(t, "  {what}  {p}");
            }
        }
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

/// Frames of a SensorView trace, each SensorView fed to every sensor at its timestamp: an `.osi` trace,
/// or channel `channel` (default: the only SensorView channel) of an `.mcap` trace.
fn trace_frames(path: &Path, channel: Option<&str>) -> Result<Vec<Frame>> {
    if osiris_proto::trace::mcap::is_mcap_file(path)? {
        let reader = McapTraceReader::open(path)?;
        let ch = reader.select_channel("osi3.SensorView", channel)?;
        return Ok(
            crate::master::mcap_sensor_view_frames(&reader, ch.id)?.collect::<Result<_, _>>()?
        );
    }
    if let Some(c) = channel {
        bail!(
            "{}: --channel {c} is for .mcap traces; this is an .osi trace (one message stream)",
            path.display()
        );
    }
    Ok(
        crate::master::sensor_view_trace_frames(OsiTraceReader::open(path)?)
            .collect::<Result<_, _>>()?,
    )
}
