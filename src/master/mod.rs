//! A small FMI 2.0 co-simulation master for OSMP sensor FMUs.
//!
//! Layers, bottom-up:
//!
//! * [`ModelDescription`] (`model_description.rs`): `modelDescription.xml` parsed with roxmltree, including the
//!   OSMP marker and the per-variable `osmp-binary-variable` annotations, grouped into checked
//!   [`BinaryVariable`] triples.
//! * [`Fmu`] (`library.rs`): an unpacked FMU (a temp dir it owns, or a caller's directory) with its
//!   `binaries/linux64/<modelIdentifier>.so` loaded by libloading (`RTLD_LOCAL`, so FMUs exporting the same
//!   `fmi2*` names coexist) and all 34 FMI 2.0 co-simulation functions resolved eagerly.
//! * [`Instance`] (`instance.rs`): a safe wrapper owning one `fmi2Component`: typed get/set by value
//!   reference or name, the call sequence, status → `Result`, per-instance logging (the C-variadic logger is
//!   `logger.c`), and a `Drop` that terminates and frees.
//! * [`OsmpSensor`] (`osmp.rs`): an OSMP sensor model on top of an instance: parameters, the
//!   SensorViewConfiguration handshake, and `step(sensor_view_bytes, t, h)` returning copies of the
//!   SensorData / PerceptionData buffers; [`OsmpSource`]: an OSMP source model (`OSMPSensorViewOut`).
//! * [`run`] (`cosim.rs`): steps several sensors in one process over a sequence of [`Frame`]s and hands each
//!   output to a sink; [`sensor_view_trace_frames`] and [`mcap_sensor_view_frames`] turn a SensorView
//!   `.osi` trace or `.mcap` channel into frames, [`source_frames`] steps an [`OsmpSource`] into frames.
//! * [`locate_fmu_library`] (`locate.rs`): finds (building it with cargo when needed) an osiris FMU cdylib
//!   of the current profile.
//!
//! Typical use:
//!
//! ```no_run
//! use osiris::master::{Fmu, InstanceOptions, OsmpSensor, Value};
//! # fn main() -> Result<(), osiris::master::MasterError> {
//! let fmu = Fmu::load("radar.fmu")?;
//! let mut sensor = OsmpSensor::instantiate(&fmu, "radar_front", InstanceOptions::default())?;
//! sensor.initialize(0.0, &[("mode", Value::from("ideal"))])?;
//! # let sensor_view_bytes: Vec<u8> = Vec::new();
//! let out = sensor.step(&sensor_view_bytes, 0.0, 0.05)?;
//! if let Some(bytes) = out.sensor_data { /* decode an osi3::SensorData */ }
//! # Ok(()) }
//! ```

mod cosim;
mod instance;
mod library;
mod locate;
mod model_description;
mod osmp;

use std::path::PathBuf;

pub use cosim::{
    Frame, RunOptions, RunSummary, StepRecord, mcap_sensor_view_frames, run,
    sensor_view_trace_frames, source_frames,
};
pub use instance::{Fmi2Status, Instance, InstanceOptions, InstanceState, LogCallback, LogRecord};
pub use library::{Fmi2CallbackFunctions, Fmi2Component, Fmi2Functions, Fmu};
pub use locate::{
    BuildPolicy, LocateOptions, fmu_library_file_name, locate_fmu_library, locate_fmu_library_with,
};
pub use model_description::{
    BaseType, BinaryRole, BinaryVariable, Causality, CoSimulation, DEFAULT_MIME, DefaultExperiment,
    Initial, ModelDescription, OSI_MIME_BASE, OSMP_NAMESPACE, OSMP_TOOL, OsmpBinaryAnnotation,
    OsmpMarker, ScalarVariable, Value, VarType, Variability, mime_base, mime_parameter,
};
pub use osmp::{
    OsmpSensor, OsmpSource, PERCEPTION_DATA_OUT, SENSOR_DATA_OUT, SENSOR_VIEW_IN,
    SENSOR_VIEW_IN_CONFIG, SENSOR_VIEW_IN_CONFIG_REQUEST, SENSOR_VIEW_OUT, StepOutputs,
    decode_pointer, encode_pointer,
};

/// Boxed error from a user callback (config grant, frame source, output sink).
pub type BoxError = Box<dyn std::error::Error + Send + Sync + 'static>;

/// Result of the master's operations.
pub type Result<T, E = MasterError> = std::result::Result<T, E>;

/// Errors of the co-simulation master. Every variant names what it was working on (file, instance, function,
/// variable) and what was expected.
#[derive(Debug, thiserror::Error)]
pub enum MasterError {
    /// A file-system operation failed.
    #[error("cannot {action} `{path}`: {source}")]
    Io {
        action: &'static str,
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The FMU is not a readable zip archive.
    #[error("cannot unzip FMU `{path}`: {source}")]
    Zip {
        path: PathBuf,
        #[source]
        source: zip::result::ZipError,
    },
    /// A zip entry would escape the extraction directory or is forbidden by FMI 2.0 §2.3.
    #[error("FMU `{path}`: refusing zip entry `{entry}`: {reason}")]
    UnsafeZipEntry {
        path: PathBuf,
        entry: String,
        reason: &'static str,
    },
    /// An FMU file the master needs is missing.
    #[error("FMU `{fmu}`: missing `{expected}` ({what})")]
    MissingFile {
        fmu: PathBuf,
        expected: PathBuf,
        what: &'static str,
    },
    /// `modelDescription.xml` is malformed or violates FMI 2.0 / OSMP.
    #[error("{file}: {error}")]
    ModelDescription {
        file: String,
        #[source]
        error: ModelDescriptionError,
    },
    /// `dlopen` failed.
    #[error("cannot load FMU binary `{path}`: {source}")]
    LoadLibrary {
        path: PathBuf,
        #[source]
        source: libloading::Error,
    },
    /// An FMI 2.0 co-simulation function is not exported (§2.3 requires all 34).
    #[error(
        "FMU binary `{path}` does not export `{symbol}` (an FMI 2.0 co-simulation FMU must export all 34 functions)"
    )]
    MissingSymbol {
        path: PathBuf,
        symbol: &'static str,
        #[source]
        source: libloading::Error,
    },
    /// The binary reports an FMI version or types platform other than `2.0` / `default`.
    #[error("FMU binary `{path}`: {function} returned `{found}`, expected `{expected}`")]
    BinaryMismatch {
        path: PathBuf,
        function: &'static str,
        found: String,
        expected: &'static str,
    },
    /// `fmi2Instantiate` returned NULL.
    #[error("fmi2Instantiate of `{instance}` (model `{model}`) returned NULL{}", log_suffix(.log))]
    InstantiationFailed {
        instance: String,
        model: String,
        log: Vec<String>,
    },
    /// An FMI function returned Error, Fatal or (unsupported) Pending.
    #[error("{function} on instance `{instance}` returned {status}{}", log_suffix(.log))]
    Fmi {
        function: &'static str,
        instance: String,
        status: Fmi2Status,
        /// The instance's last log lines (most recent last).
        log: Vec<String>,
    },
    /// The master refused a call that is illegal in the instance's current state.
    #[error("instance `{instance}`: cannot {action} in state {state} (expected {expected})")]
    IllegalState {
        instance: String,
        action: &'static str,
        state: String,
        expected: &'static str,
    },
    /// No variable of that name exists.
    #[error("model `{model}` has no variable named `{name}`")]
    UnknownVariable { model: String, name: String },
    /// A value of the wrong type was given for a variable.
    #[error("variable `{name}` of model `{model}` is a {expected}, got a {found} value")]
    TypeMismatch {
        model: String,
        name: String,
        expected: VarType,
        found: &'static str,
    },
    /// A text could not be parsed as a value of the variable's type.
    #[error("invalid value for variable `{name}`: {reason}")]
    InvalidValue { name: String, reason: String },
    /// A string value contains an interior NUL byte.
    #[error("string value for `{what}` contains a NUL byte")]
    NulInString { what: String },
    /// The FMU is not a usable OSMP sensor model.
    #[error("model `{model}` is not a usable OSMP sensor: {reason}")]
    NotOsmpSensor { model: String, reason: String },
    /// An OSMP buffer is invalid (oversized input, negative size, undecodable configuration…).
    #[error("instance `{instance}`, binary variable `{prefix}`: {reason}")]
    Osmp {
        instance: String,
        prefix: String,
        reason: String,
    },
    /// The configuration-grant callback refused the SensorViewConfiguration request.
    #[error("instance `{instance}`: SensorViewConfiguration request not granted: {source}")]
    ConfigNotGranted {
        instance: String,
        #[source]
        source: BoxError,
    },
    /// A frame is inconsistent with the sensors given to [`run`].
    #[error("frame {frame_index} (t = {time} s): {reason}")]
    InvalidFrame {
        frame_index: usize,
        time: f64,
        reason: String,
    },
    /// The frame source failed.
    #[error("frame source failed after {frames_done} frames: {source}")]
    Source {
        frames_done: usize,
        #[source]
        source: BoxError,
    },
    /// The output sink failed.
    #[error("output sink failed at frame {frame_index}, sensor {sensor_index}: {source}")]
    Sink {
        frame_index: usize,
        sensor_index: usize,
        #[source]
        source: BoxError,
    },
    /// A sensor failed while [`run`] stepped it.
    #[error("sensor {sensor_index} failed at frame {frame_index}: {source}")]
    Sensor {
        frame_index: usize,
        sensor_index: usize,
        #[source]
        source: Box<MasterError>,
    },
    /// [`locate_fmu_library`] could neither find nor build the cdylib.
    #[error("cannot locate the `{kind}` FMU library: {reason}")]
    Locate { kind: String, reason: String },
}

fn log_suffix(log: &[String]) -> String {
    if log.is_empty() {
        String::new()
    } else {
        format!("; last log lines:\n  {}", log.join("\n  "))
    }
}

/// What is wrong with a `modelDescription.xml` (wrapped in [`MasterError::ModelDescription`] with the file).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ModelDescriptionError {
    #[error("not well-formed XML: {0}")]
    Xml(String),
    #[error("root element is <{found}>, expected <fmiModelDescription>")]
    WrongRoot { found: String },
    #[error(
        "fmiVersion=\"{found}\", expected fmiVersion=\"2.0\" (this master imports FMI 2.0 only)"
    )]
    UnsupportedFmiVersion { found: String },
    #[error("no <CoSimulation> element, expected an FMI 2.0 co-simulation FMU")]
    NoCoSimulation,
    #[error("no <{element}> in <{parent}>")]
    MissingElement {
        element: &'static str,
        parent: &'static str,
    },
    #[error("{element} lacks the required attribute `{attribute}`")]
    MissingAttribute {
        element: String,
        attribute: &'static str,
    },
    #[error("{element} has {attribute}=\"{value}\", expected {expected}")]
    InvalidAttribute {
        element: String,
        attribute: &'static str,
        value: String,
        expected: String,
    },
    #[error("variable name `{name}` is used twice, expected unique names")]
    DuplicateVariableName { name: String },
    #[error("variable `{name}` {reason}")]
    InvalidVariable { name: String, reason: String },
    #[error(
        "variable `{variable}` has an osmp-binary-variable annotation but the model has no OSMP marker, expected \
         <VendorAnnotations><Tool name=\"net.pmsf.osmp\"><osmp:osmp version=\"1.x.y\" osi-version=\"…\"/></Tool>"
    )]
    MissingOsmpMarker { variable: String },
    #[error("variable `{variable}`: invalid OSMP binary-variable annotation: {reason}")]
    InvalidBinaryAnnotation { variable: String, reason: String },
    #[error(
        "OSMP binary variable `{prefix}` is incomplete: missing {}, expected Integer variables `{prefix}.base.lo`, \
         `{prefix}.base.hi` and `{prefix}.size`",
        .missing.iter().map(|r| format!("`{prefix}.{r}`")).collect::<Vec<_>>().join(", ")
    )]
    IncompleteBinaryVariable {
        prefix: String,
        missing: Vec<&'static str>,
    },
    #[error(
        "OSMP binary variable `{prefix}`: its three variables differ in {attribute} ({values}), expected identical"
    )]
    BinaryVariableMismatch {
        prefix: String,
        attribute: &'static str,
        values: String,
    },
    #[error(
        "OSMP binary variable `{prefix}`: MIME type \"{mime}\" has no `version=` and the OSMP marker has no \
         osi-version, expected one of them"
    )]
    MissingMimeVersion { prefix: String, mime: String },
    #[error(
        "a variable is named `{prefix}`, like the OSMP binary variable; expected no variable with that name"
    )]
    PrefixNameClash { prefix: String },
}
