//! One FMU instance: the FMI 2.0 co-simulation state machine, the parameters, the model and the
//! OSMP buffers. Everything here is safe Rust over slices; [`crate::abi`] does the pointer work,
//! the panic guard and the NULL checks.
//!
//! The state machine, logging, status queries and the variable checks (against the descriptor's
//! table) serve both roles of [`crate::descriptor::Role`]; this file holds the sensor's parameters,
//! model and step, [`source`] the SensorView source's. The role-specific calls branch at their top
//! (`if self.desc.is_source()`).
//!
//! Error policy:
//! * a rejected call (wrong state, unknown value reference, a variable that cannot be set now,
//!   unsupported function) returns `fmi2Error`, logs the reason naming the function and the state,
//!   and changes nothing: the instance stays in its state;
//! * a failure of the simulation (broken configuration, model error, unusable granted
//!   configuration) returns `fmi2Error` and moves the instance to the `error` state, from which
//!   only `fmi2Get*`, `fmi2SetDebugLogging`, `fmi2Reset` and `fmi2FreeInstance` are possible;
//! * a panic (caught in [`crate::abi`]) returns `fmi2Fatal` and marks the instance broken: every
//!   later call but `fmi2FreeInstance` returns `fmi2Error`.

use std::ffi::CString;
use std::path::{Path, PathBuf};

use osiris_models::{ModelError, ModelMode, SensorConfig, SensorModel, StepInput, StepOutput};
use osiris_proto::{Message, osi3};

use crate::descriptor::{FmuDescriptor, SensorRole};
use crate::ffi::{self, Fmi2Status};
use crate::logging::{CategorySet, LogCategory, Logger};
use crate::osmp;
use crate::variables::{self, Causality, RealParam, Start, VarType, Variable, vr};

/// FMI 2.0 co-simulation states (§4.2.4). `stepInProgress`, `stepFailed` and `stepCanceled` never
/// occur (no asynchronous steps, no `fmi2Discard` from `fmi2DoStep`), so `slaveInitialized` is
/// always `stepComplete`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum State {
    /// After `fmi2Instantiate` / `fmi2Reset`.
    Instantiated,
    /// Between `fmi2EnterInitializationMode` and `fmi2ExitInitializationMode`.
    InitializationMode,
    /// After `fmi2ExitInitializationMode` (`stepComplete`).
    SlaveInitialized,
    /// After `fmi2Terminate`.
    Terminated,
    /// After a failed simulation call.
    Error,
    /// After an internal panic.
    Fatal,
}

impl State {
    /// The name used in log messages (the standard's state names).
    pub fn name(self) -> &'static str {
        match self {
            State::Instantiated => "instantiated",
            State::InitializationMode => "initializationMode",
            State::SlaveInitialized => "slaveInitialized",
            State::Terminated => "terminated",
            State::Error => "error",
            State::Fatal => "fatal",
        }
    }
}

use State::*;

mod source;

/// Input findings logged one per line per step; the rest are counted in one line (a frame with
/// 10⁵ broken objects must not flood the importer's log).
const MAX_INPUT_ISSUES_LOGGED: usize = 16;

/// Values the importer sets on a sensor (all back to their start values on `fmi2Reset`).
#[derive(Debug, Default, Clone, PartialEq)]
struct Params {
    /// `range_m`, `fov_horizontal_rad`, `fov_vertical_rad`: `Some` once explicitly set.
    real: [Option<f64>; 3],
    /// `config`: `Some` once explicitly set.
    config: Option<String>,
    /// `mode`: `Some` once explicitly set.
    mode: Option<String>,
    /// `OSMPSensorViewIn` triple.
    view_in: [i32; 3],
    /// `OSMPSensorViewInConfig` triple.
    view_config: [i32; 3],
}

const REAL_PARAMS: [RealParam; 3] = [
    RealParam::RangeM,
    RealParam::FovHorizontalRad,
    RealParam::FovVerticalRad,
];

/// An output binary variable with two buffers: the bytes published by step n stay intact until
/// step n + 2 starts.
#[derive(Debug, Default)]
struct DoubleBuffer {
    bufs: [Vec<u8>; 2],
    /// Index of the buffer the next publication writes.
    next: usize,
    /// Published `[base.lo, base.hi, size]`.
    published: [i32; 3],
}

impl DoubleBuffer {
    /// Serialize `msg` into the spare buffer and publish it.
    fn publish(&mut self, msg: &impl Message) -> Result<(), String> {
        let buf = &mut self.bufs[self.next];
        buf.clear();
        msg.encode(buf)
            .map_err(|e| format!("encoding failed: {e}"))?;
        self.published = osmp::publish(buf)?;
        self.next ^= 1;
        Ok(())
    }

    /// Copy `bytes` into the spare buffer and publish it.
    fn publish_bytes(&mut self, bytes: &[u8]) -> Result<(), String> {
        let buf = &mut self.bufs[self.next];
        buf.clear();
        buf.extend_from_slice(bytes);
        self.published = osmp::publish(buf)?;
        self.next ^= 1;
        Ok(())
    }

    /// Publish "no buffer" (0/0/0). The buffer of the last publication is kept intact.
    fn unpublish(&mut self) {
        self.published = [0; 3];
    }
}

/// State derived from the parameters and the steps (rebuilt from scratch on `fmi2Reset`).
struct Runtime {
    /// `fmi2SetupExperiment` start time, s.
    start_time_s: f64,
    /// `fmi2SetupExperiment` stop time, s, if defined.
    stop_time_s: Option<f64>,
    /// The model; `None` until built or after a parameter changed.
    model: Option<Box<dyn SensorModel>>,
    /// Encoded ConfigRequest, cached until a parameter or the Config changes (importers read
    /// lo/hi/size in separate calls and must see one buffer).
    config_request: Option<Vec<u8>>,
    /// The granted `OSMPSensorViewInConfig` bytes, copied at `fmi2ExitInitializationMode`
    /// (the importer's buffer is only valid until then).
    granted: Option<Vec<u8>>,
    sensor_data: DoubleBuffer,
    perception: DoubleBuffer,
    /// `count` output.
    count: i32,
    /// `valid` output.
    valid: bool,
    /// Reused step output.
    step_out: StepOutput,
    /// Frames published since instantiation/reset (for the log; the output's `cycle_counter` is
    /// the model's).
    frames_published: u64,
    /// End of the last successful step, s.
    last_successful_time_s: f64,
}

impl Runtime {
    fn new() -> Runtime {
        Runtime {
            start_time_s: 0.0,
            stop_time_s: None,
            model: None,
            config_request: None,
            granted: None,
            sensor_data: DoubleBuffer::default(),
            perception: DoubleBuffer::default(),
            count: 0,
            valid: false,
            step_out: StepOutput::default(),
            frames_published: 0,
            last_successful_time_s: 0.0,
        }
    }
}

/// One FMU instance (`fmi2Component` points to a boxed `Instance`).
pub(crate) struct Instance {
    desc: &'static FmuDescriptor,
    pub(crate) logger: Logger,
    logging_on_at_instantiate: bool,
    /// Directory the `fmuResourceLocation` URI names, if any.
    resources_dir: Option<PathBuf>,
    pub(crate) state: State,
    /// Set after an internal panic.
    pub(crate) broken: bool,
    /// A sensor's parameters (unused by a source).
    p: Params,
    rt: Runtime,
    /// A source's parameters, source and output (unused by a sensor).
    src: source::SourceIo,
    /// Results of the last `fmi2GetString`, valid until the next one.
    strings: Vec<CString>,
}

/// What a Set call changes.
enum SetEffect {
    None,
    /// A Real/String parameter: the model must be rebuilt and the request recomputed.
    Rebuild,
    /// The Config triple: the request must be recomputed.
    Request,
}

impl Instance {
    pub(crate) fn new(
        desc: &'static FmuDescriptor,
        logger: Logger,
        logging_on: bool,
        resources_dir: Option<PathBuf>,
    ) -> Instance {
        Instance {
            desc,
            logger,
            logging_on_at_instantiate: logging_on,
            resources_dir,
            state: Instantiated,
            broken: false,
            p: Params::default(),
            rt: Runtime::new(),
            src: source::SourceIo::default(),
            strings: Vec::new(),
        }
    }

    /// The sensor model of a sensor FMU (the sensor-only paths are reached only for sensors).
    fn sensor_role(&self) -> &'static SensorRole {
        self.desc
            .as_sensor()
            .expect("a sensor-only path reached on a source FMU")
    }

    // ---------------------------------------------------------------------------------------------
    // Logging and status helpers

    pub(crate) fn log(&self, status: Fmi2Status, topic: LogCategory, msg: &str) {
        self.logger.log(status, topic, msg);
    }

    fn debug(&self, topic: LogCategory, msg: impl FnOnce() -> String) {
        if self.logger.is_enabled(topic, Fmi2Status::Ok) {
            self.logger.log(Fmi2Status::Ok, topic, &msg());
        }
    }

    /// Reject a call: log, return `fmi2Error`, leave the state alone.
    pub(crate) fn reject(&self, func: &str, msg: &str) -> Fmi2Status {
        self.log(
            Fmi2Status::Error,
            LogCategory::Fmi,
            &format!("{func}: {msg}"),
        );
        Fmi2Status::Error
    }

    /// A failed simulation call: log, enter the `error` state, return `fmi2Error`.
    fn fail(&mut self, func: &str, topic: LogCategory, msg: &str) -> Fmi2Status {
        self.log(Fmi2Status::Error, topic, &format!("{func}: {msg}"));
        self.state = Error;
        Fmi2Status::Error
    }

    /// Reject the call unless the state is one of `allowed`.
    fn check_state(&self, func: &str, allowed: &[State]) -> Result<(), Fmi2Status> {
        if allowed.contains(&self.state) {
            return Ok(());
        }
        let names: Vec<&str> = allowed.iter().map(|s| s.name()).collect();
        Err(self.reject(
            func,
            &format!(
                "not allowed in state {} (allowed in: {})",
                self.state.name(),
                names.join(", ")
            ),
        ))
    }

    // ---------------------------------------------------------------------------------------------
    // Life cycle

    pub(crate) fn set_debug_logging(
        &mut self,
        logging_on: bool,
        categories: &[Option<&str>],
    ) -> Fmi2Status {
        const F: &str = "fmi2SetDebugLogging";
        if let Err(s) = self.check_state(
            F,
            &[
                Instantiated,
                InitializationMode,
                SlaveInitialized,
                Terminated,
                Error,
            ],
        ) {
            return s;
        }
        if !logging_on {
            self.logger.enabled = CategorySet::status_only();
            return Fmi2Status::Ok;
        }
        if categories.is_empty() {
            self.logger.enabled = CategorySet::all();
            return Fmi2Status::Ok;
        }
        let mut set = CategorySet::none();
        let mut unknown = Vec::new();
        for c in categories {
            match c {
                None => return self.reject(F, "a category is NULL or not UTF-8"),
                Some(name) => match LogCategory::from_name(name) {
                    Some(cat) => set.insert(cat),
                    None => unknown.push(format!("`{name}`")),
                },
            }
        }
        self.logger.enabled = set;
        if unknown.is_empty() {
            Fmi2Status::Ok
        } else {
            let known: Vec<&str> = LogCategory::ALL.iter().map(|c| c.name()).collect();
            self.log(
                Fmi2Status::Warning,
                LogCategory::Fmi,
                &format!(
                    "{F}: unknown log categories {} ignored (known: {})",
                    unknown.join(", "),
                    known.join(", ")
                ),
            );
            Fmi2Status::Warning
        }
    }

    pub(crate) fn setup_experiment(
        &mut self,
        tolerance: Option<f64>,
        start_s: f64,
        stop_s: Option<f64>,
    ) -> Fmi2Status {
        const F: &str = "fmi2SetupExperiment";
        if let Err(s) = self.check_state(F, &[Instantiated]) {
            return s;
        }
        if !start_s.is_finite() {
            return self.reject(F, &format!("startTime {start_s} is not finite"));
        }
        if let Some(stop) = stop_s
            && (stop.is_nan() || stop < start_s)
        {
            return self.reject(F, &format!("stopTime {stop} is before startTime {start_s}"));
        }
        self.rt.start_time_s = start_s;
        self.rt.stop_time_s = stop_s;
        self.rt.last_successful_time_s = start_s;
        self.debug(LogCategory::Fmi, || {
            format!(
                "{F}: startTime {start_s} s, stopTime {stop_s:?} s, \
                 tolerance {tolerance:?} (unused)"
            )
        });
        Fmi2Status::Ok
    }

    pub(crate) fn enter_initialization_mode(&mut self) -> Fmi2Status {
        const F: &str = "fmi2EnterInitializationMode";
        if let Err(s) = self.check_state(F, &[Instantiated]) {
            return s;
        }
        self.state = InitializationMode;
        self.debug(LogCategory::Fmi, || {
            format!("{F}: entered initializationMode")
        });
        Fmi2Status::Ok
    }

    pub(crate) fn exit_initialization_mode(&mut self) -> Fmi2Status {
        const F: &str = "fmi2ExitInitializationMode";
        if let Err(s) = self.check_state(F, &[InitializationMode]) {
            return s;
        }
        if self.desc.is_source() {
            return self.source_exit_initialization_mode();
        }
        let mut status = match self.ensure_model() {
            Ok(s) => s,
            Err(msg) => return self.fail(F, LogCategory::Fmi, &msg),
        };
        // Apply the granted configuration, if the importer set one.
        match self.read_granted_config() {
            Err(msg) => return self.fail(F, LogCategory::Osmp, &msg),
            Ok(None) => self.debug(LogCategory::Osmp, || {
                format!(
                    "{F}: no OSMPSensorViewInConfig set; running without a granted \
                     SensorViewConfiguration"
                )
            }),
            Ok(Some(bytes)) => {
                let granted = match osi3::SensorViewConfiguration::decode(bytes.as_slice()) {
                    Ok(g) => g,
                    Err(e) => {
                        return self.fail(
                            F,
                            LogCategory::Osmp,
                            &format!(
                                "OSMPSensorViewInConfig is not a valid SensorViewConfiguration: {e}"
                            ),
                        );
                    }
                };
                let model = self.rt.model.as_mut().expect("ensure_model succeeded");
                match model.apply_view_configuration(&granted) {
                    Ok(notes) => {
                        for note in &notes {
                            self.log(
                                Fmi2Status::Warning,
                                LogCategory::Osmp,
                                &format!("{F}: granted SensorViewConfiguration: {note}"),
                            );
                        }
                        if !notes.is_empty() {
                            status = status.max(Fmi2Status::Warning);
                        }
                    }
                    Err(e) => {
                        let msg = format!("the granted SensorViewConfiguration is unusable: {e}");
                        return self.fail(F, LogCategory::Osmp, &msg);
                    }
                }
                self.rt.granted = Some(bytes);
            }
        }
        self.state = SlaveInitialized;
        self.debug(LogCategory::Fmi, || format!("{F}: slave initialized"));
        status
    }

    pub(crate) fn terminate(&mut self) -> Fmi2Status {
        const F: &str = "fmi2Terminate";
        if let Err(s) = self.check_state(F, &[SlaveInitialized]) {
            return s;
        }
        self.state = Terminated;
        self.debug(LogCategory::Fmi, || {
            format!("{F}: terminated after {} frames", self.rt.frames_published)
        });
        Fmi2Status::Ok
    }

    /// Back to the state right after `fmi2Instantiate`: start values, no model, no buffers, the
    /// logging categories of `loggingOn`.
    pub(crate) fn reset(&mut self) -> Fmi2Status {
        const F: &str = "fmi2Reset";
        if let Err(s) = self.check_state(
            F,
            &[
                Instantiated,
                InitializationMode,
                SlaveInitialized,
                Terminated,
                Error,
            ],
        ) {
            return s;
        }
        self.p = Params::default();
        self.rt = Runtime::new();
        self.src = source::SourceIo::default();
        self.strings.clear();
        self.state = Instantiated;
        self.logger.enabled = CategorySet::for_logging_on(self.logging_on_at_instantiate);
        self.debug(LogCategory::Fmi, || {
            format!("{F}: back to instantiated, start values restored")
        });
        Fmi2Status::Ok
    }

    // ---------------------------------------------------------------------------------------------
    // Variables

    const GET_STATES: [State; 4] = [InitializationMode, SlaveInitialized, Terminated, Error];
    const SET_STATES: [State; 3] = [Instantiated, InitializationMode, SlaveInitialized];

    /// Look a variable up and check that it may be set now.
    fn settable(&self, func: &str, ty: VarType, vr: u32) -> Result<&'static Variable, Fmi2Status> {
        let Some(v) = self.desc.variable(ty, vr) else {
            return Err(self.reject(func, &format!("unknown {} value reference {vr}", ty.name())));
        };
        match v.causality {
            Causality::Input => Ok(v),
            Causality::Parameter if v.is_fixed_parameter() => {
                if matches!(self.state, Instantiated | InitializationMode) {
                    Ok(v)
                } else {
                    Err(self.reject(
                        func,
                        &format!(
                            "fixed parameter `{}` can only be set before \
                             fmi2ExitInitializationMode (state {})",
                            v.name,
                            self.state.name()
                        ),
                    ))
                }
            }
            Causality::Parameter => Ok(v),
            Causality::Output => Err(self.reject(
                func,
                &format!(
                    "`{}` is an output, computed by the FMU; it cannot be set",
                    v.name
                ),
            )),
            Causality::CalculatedParameter => Err(self.reject(
                func,
                &format!(
                    "`{}` is a calculatedParameter, computed by the FMU; it cannot be set",
                    v.name
                ),
            )),
        }
    }

    /// Check the state and every value reference of a Set call; the variables in order.
    fn check_set(
        &self,
        func: &str,
        ty: VarType,
        vrs: &[u32],
    ) -> Result<Vec<&'static Variable>, Fmi2Status> {
        self.check_state(func, &Self::SET_STATES)?;
        vrs.iter().map(|&vr| self.settable(func, ty, vr)).collect()
    }

    fn apply_effect(&mut self, effect: SetEffect) {
        match effect {
            SetEffect::None => {}
            SetEffect::Rebuild => {
                self.rt.model = None;
                self.rt.config_request = None;
            }
            SetEffect::Request => self.rt.config_request = None,
        }
    }

    pub(crate) fn set_real(&mut self, vrs: &[u32], values: &[f64]) -> Fmi2Status {
        const F: &str = "fmi2SetReal";
        let vars = match self.check_set(F, VarType::Real, vrs) {
            Ok(v) => v,
            Err(s) => return s,
        };
        for (v, &value) in vars.iter().zip(values) {
            let i = v.vr as usize;
            let old = self.p.real[i];
            self.p.real[i] = Some(value);
            if old.map(f64::to_bits) != Some(value.to_bits()) {
                self.apply_effect(SetEffect::Rebuild);
            }
            self.debug(LogCategory::Fmi, || format!("{F}: {} = {value}", v.name));
        }
        Fmi2Status::Ok
    }

    pub(crate) fn set_integer(&mut self, vrs: &[u32], values: &[i32]) -> Fmi2Status {
        const F: &str = "fmi2SetInteger";
        let vars = match self.check_set(F, VarType::Integer, vrs) {
            Ok(v) => v,
            Err(s) => return s,
        };
        for (v, &value) in vars.iter().zip(values) {
            let effect = match v.vr {
                0..=2 => {
                    self.p.view_in[v.vr as usize] = value;
                    SetEffect::None
                }
                9..=11 => {
                    self.debug(LogCategory::Osmp, || format!("{F}: {} = {value}", v.name));
                    let slot =
                        &mut self.p.view_config[(v.vr - vr::integer::CONFIG_BASE_LO) as usize];
                    let changed = *slot != value;
                    *slot = value;
                    if changed {
                        SetEffect::Request
                    } else {
                        SetEffect::None
                    }
                }
                _ => unreachable!("settable() admits only the input and Config triples"),
            };
            self.apply_effect(effect);
        }
        Fmi2Status::Ok
    }

    pub(crate) fn set_boolean(&mut self, vrs: &[u32], _values: &[ffi::Fmi2Boolean]) -> Fmi2Status {
        // The only Boolean is the output `valid`: check_set rejects every VR.
        match self.check_set("fmi2SetBoolean", VarType::Boolean, vrs) {
            Ok(_) => Fmi2Status::Ok,
            Err(s) => s,
        }
    }

    pub(crate) fn set_string(&mut self, vrs: &[u32], values: &[Option<String>]) -> Fmi2Status {
        const F: &str = "fmi2SetString";
        let vars = match self.check_set(F, VarType::String, vrs) {
            Ok(v) => v,
            Err(s) => return s,
        };
        if let Some(i) = values.iter().position(Option::is_none) {
            return self.reject(
                F,
                &format!("value {i} (for `{}`) is NULL or not UTF-8", vars[i].name),
            );
        }
        if self.desc.is_source() {
            return self.source_set_string(&vars, values);
        }
        for (v, value) in vars.iter().zip(values) {
            let value = value.clone().expect("checked above");
            self.debug(LogCategory::Fmi, || format!("{F}: {} = {value:?}", v.name));
            let slot = match v.vr {
                vr::string::CONFIG => &mut self.p.config,
                vr::string::MODE => &mut self.p.mode,
                _ => unreachable!("String VRs are 0 and 1"),
            };
            let changed = slot.as_deref() != Some(value.as_str());
            *slot = Some(value);
            if changed {
                self.apply_effect(SetEffect::Rebuild);
            }
        }
        Fmi2Status::Ok
    }

    pub(crate) fn get_real(&mut self, vrs: &[u32], out: &mut [f64]) -> Fmi2Status {
        const F: &str = "fmi2GetReal";
        if let Err(s) = self.check_state(F, &Self::GET_STATES) {
            return s;
        }
        let mut values = Vec::with_capacity(vrs.len());
        for &r in vrs {
            let Some(v) = self.desc.variable(VarType::Real, r) else {
                return self.reject(F, &format!("unknown Real value reference {r}"));
            };
            let start = v
                .start
                .real(self.desc.sensor_kind())
                .expect("Real parameters have a start");
            values.push(self.p.real[r as usize].unwrap_or(start));
        }
        out.copy_from_slice(&values);
        Fmi2Status::Ok
    }

    pub(crate) fn get_integer(&mut self, vrs: &[u32], out: &mut [i32]) -> Fmi2Status {
        const F: &str = "fmi2GetInteger";
        if let Err(s) = self.check_state(F, &Self::GET_STATES) {
            return s;
        }
        if let Some(&r) = vrs
            .iter()
            .find(|&&r| self.desc.variable(VarType::Integer, r).is_none())
        {
            return self.reject(F, &format!("unknown Integer value reference {r}"));
        }
        if self.desc.is_source() {
            return self.source_get_integer(vrs, out);
        }
        let mut status = Fmi2Status::Ok;
        let mut request = [0; 3];
        if vrs.iter().any(|r| vr::integer::CONFIG_REQUEST.contains(r)) {
            match self.ensure_config_request() {
                Ok((s, triple)) => {
                    status = s;
                    request = triple;
                }
                Err(msg) => return self.fail(F, LogCategory::Osmp, &msg),
            }
        }
        for (o, &r) in out.iter_mut().zip(vrs) {
            *o = match r {
                0..=2 => self.p.view_in[r as usize],
                3..=5 => self.rt.sensor_data.published[(r - 3) as usize],
                6..=8 => request[(r - 6) as usize],
                9..=11 => self.p.view_config[(r - 9) as usize],
                12..=14 => self.rt.perception.published[(r - 12) as usize],
                vr::integer::COUNT => self.rt.count,
                _ => unreachable!("checked above"),
            };
        }
        status
    }

    pub(crate) fn get_boolean(&mut self, vrs: &[u32], out: &mut [ffi::Fmi2Boolean]) -> Fmi2Status {
        const F: &str = "fmi2GetBoolean";
        if let Err(s) = self.check_state(F, &Self::GET_STATES) {
            return s;
        }
        if let Some(&r) = vrs
            .iter()
            .find(|&&r| self.desc.variable(VarType::Boolean, r).is_none())
        {
            return self.reject(F, &format!("unknown Boolean value reference {r}"));
        }
        if self.desc.is_source()
            && let Err(s) = self.source_ensure_initial_outputs(F)
        {
            return s;
        }
        out.fill(if self.rt.valid {
            ffi::FMI2_TRUE
        } else {
            ffi::FMI2_FALSE
        });
        Fmi2Status::Ok
    }

    /// The values of a GetString call; the returned strings live in the instance until the next
    /// GetString.
    pub(crate) fn get_string(&mut self, vrs: &[u32]) -> Result<&[CString], Fmi2Status> {
        const F: &str = "fmi2GetString";
        self.check_state(F, &Self::GET_STATES)?;
        let mut values = Vec::with_capacity(vrs.len());
        for &r in vrs {
            let Some(v) = self.desc.variable(VarType::String, r) else {
                return Err(self.reject(F, &format!("unknown String value reference {r}")));
            };
            let start = v
                .start
                .string(self.desc.sensor_kind())
                .expect("String parameters have a start");
            let value = if self.desc.is_source() {
                self.src.string(r)
            } else {
                match r {
                    vr::string::CONFIG => self.p.config.as_deref(),
                    _ => self.p.mode.as_deref(),
                }
            };
            let value = value.unwrap_or(start);
            // Set values were NUL-free C strings.
            values.push(CString::new(value).unwrap_or_default());
        }
        self.strings = values;
        Ok(&self.strings)
    }

    // ---------------------------------------------------------------------------------------------
    // Configuration and model

    /// The granted Config bytes: the importer's buffer while it is valid (up to
    /// `fmi2ExitInitializationMode`), the copy made there afterwards. `None` if none was set.
    fn read_granted_config(&self) -> Result<Option<Vec<u8>>, String> {
        if matches!(self.state, Instantiated | InitializationMode) {
            match osmp::address(self.p.view_config) {
                Ok(None) => Ok(None),
                Ok(Some((addr, len))) => {
                    // SAFETY: OSMP: the importer's OSMPSensorViewInConfig buffer is valid from its
                    // fmi2SetInteger until fmi2ExitInitializationMode returns; we are before that.
                    let bytes = unsafe { osmp::bytes(addr, len) }.to_vec();
                    Ok(Some(bytes))
                }
                Err(e) => Err(format!("OSMPSensorViewInConfig: {e}")),
            }
        } else {
            Ok(self.rt.granted.clone())
        }
    }

    /// The effective configuration: the `config` JSON (or built-in defaults) with the explicitly
    /// set Real/String parameters applied. Also returns warnings to log.
    fn resolve_config(&self) -> Result<(SensorConfig, Vec<String>, String), String> {
        let kind = self.sensor_role().kind;
        let mut warnings = Vec::new();
        let text = self.p.config.as_deref().unwrap_or(
            match variables::find(VarType::String, vr::string::CONFIG) {
                Some(Variable {
                    start: Start::String(s),
                    ..
                }) => s,
                _ => "config.json",
            },
        );
        let trimmed = text.trim();
        let (mut config, origin) = if trimmed.is_empty() {
            (
                SensorConfig::default_for(kind),
                "built-in defaults".to_string(),
            )
        } else if trimmed.starts_with('{') {
            let c = SensorConfig::parse_json(trimmed)
                .map_err(|e| format!("parameter `config` (inline JSON): {e}"))?;
            (c, "inline JSON".to_string())
        } else {
            let rel = Path::new(trimmed);
            let full = if rel.is_absolute() {
                Some(rel.to_path_buf())
            } else if let Some(dir) = &self.resources_dir {
                Some(dir.join(rel))
            } else if self.p.config.is_none() {
                warnings.push(format!(
                    "no resource location was passed to fmi2Instantiate, so `config` = {trimmed:?} cannot be \
                     read; using the built-in {} defaults (which the shipped resources/config.json holds)",
                    kind.name()
                ));
                None
            } else {
                return Err(format!(
                    "parameter `config` = {trimmed:?} is a path relative to the FMU's resources directory, but \
                     fmi2Instantiate got no resource location; pass one, use an absolute path, inline JSON, or \
                     \"\" for the built-in defaults"
                ));
            };
            match full {
                None => (
                    SensorConfig::default_for(kind),
                    "built-in defaults".to_string(),
                ),
                Some(path) => {
                    let json = std::fs::read_to_string(&path).map_err(|e| {
                        format!("cannot read config file `{}`: {e}", path.display())
                    })?;
                    let c = SensorConfig::parse_json(&json)
                        .map_err(|e| format!("config file `{}`: {e}", path.display()))?;
                    (c, format!("config file `{}`", path.display()))
                }
            }
        };
        if config.kind != kind {
            return Err(format!(
                "{origin} declares kind `{}`, but this is the {} FMU `{}`",
                config.kind.name(),
                kind.name(),
                self.desc.model_identifier
            ));
        }
        let mut overrides = Vec::new();
        for (param, value) in REAL_PARAMS.iter().zip(self.p.real) {
            if let Some(v) = value {
                param.set(&mut config, v);
                overrides
                    .push(variables::find(VarType::Real, *param as u32).map_or("?", |v| v.name));
            }
        }
        if let Some(mode) = &self.p.mode {
            config.mode = mode
                .trim()
                .parse::<ModelMode>()
                .map_err(|e| format!("parameter `mode`: {e}"))?;
            overrides.push("mode");
        }
        let mut source = origin;
        if !overrides.is_empty() {
            source.push_str(&format!(
                ", overridden by parameters {}",
                overrides.join(", ")
            ));
        }
        // Checked once, when the model is built (`ensure_model`).
        Ok((config, warnings, source))
    }

    /// Build the model if there is none. `Ok(fmi2Warning)` if warnings were logged.
    fn ensure_model(&mut self) -> Result<Fmi2Status, String> {
        if self.rt.model.is_some() {
            return Ok(Fmi2Status::Ok);
        }
        let (config, warnings, source) = self.resolve_config()?;
        for w in &warnings {
            self.log(Fmi2Status::Warning, LogCategory::Fmi, w);
        }
        let summary = format!(
            "{} {} model: range {} m, field of view {} x {} rad, cycle {} s ({source})",
            config.mode.name(),
            config.kind.name(),
            config.range_m,
            config.fov_horizontal_rad,
            config.fov_vertical_rad,
            config.update_cycle_s
        );
        let model = (self.sensor_role().build_model)(config)
            .map_err(|e| format!("{e} (configuration from {source})"))?;
        self.debug(LogCategory::Fmi, || format!("built the {summary}"));
        self.rt.model = Some(model);
        Ok(if warnings.is_empty() {
            Fmi2Status::Ok
        } else {
            Fmi2Status::Warning
        })
    }

    /// The published ConfigRequest triple, computing and caching the request if needed.
    fn ensure_config_request(&mut self) -> Result<(Fmi2Status, [i32; 3]), String> {
        let mut status = Fmi2Status::Ok;
        if self.rt.config_request.is_none() {
            let bytes = match self.read_granted_config()? {
                Some(granted) => {
                    osi3::SensorViewConfiguration::decode(granted.as_slice()).map_err(|e| {
                        format!(
                            "OSMPSensorViewInConfig is not a valid SensorViewConfiguration: {e}"
                        )
                    })?;
                    self.debug(LogCategory::Osmp, || {
                        format!(
                            "OSMPSensorViewInConfigRequest echoes the granted configuration \
                             ({} bytes)",
                            granted.len()
                        )
                    });
                    granted
                }
                None => {
                    status = self.ensure_model()?;
                    let model = self.rt.model.as_ref().expect("ensure_model succeeded");
                    // The model's request as it is (`osiris_models::handshake`).
                    let request = model.view_configuration_request();
                    let bytes = request.encode_to_vec();
                    self.debug(LogCategory::Osmp, || {
                        format!(
                            "OSMPSensorViewInConfigRequest computed ({} bytes): {request:?}",
                            bytes.len()
                        )
                    });
                    bytes
                }
            };
            self.rt.config_request = Some(bytes);
        }
        let bytes = self.rt.config_request.as_deref().expect("set above");
        Ok((status, osmp::publish(bytes)?))
    }

    // ---------------------------------------------------------------------------------------------
    // Stepping

    pub(crate) fn do_step(&mut self, t: f64, h: f64) -> Fmi2Status {
        const F: &str = "fmi2DoStep";
        if let Err(s) = self.check_state(F, &[SlaveInitialized]) {
            return s;
        }
        if !t.is_finite() || !h.is_finite() || h <= 0.0 {
            return self.reject(
                F,
                &format!("currentCommunicationPoint {t} s and communicationStepSize {h} s must be finite, h > 0"),
            );
        }
        if let Some(stop) = self.rt.stop_time_s
            && t + h > stop + 1e-9 * stop.abs().max(1.0)
        {
            return self.reject(
                F,
                &format!("step [{t}, {}] s goes past stopTime {stop} s", t + h),
            );
        }
        if self.desc.is_source() {
            return self.source_do_step(t, h);
        }

        let addr = match osmp::address(self.p.view_in) {
            Ok(a) => a,
            Err(e) => {
                self.skip_frame();
                self.log(
                    Fmi2Status::Warning,
                    LogCategory::Osmp,
                    &format!("{F}: OSMPSensorViewIn: {e}; frame skipped"),
                );
                self.rt.last_successful_time_s = t + h;
                return Fmi2Status::Warning;
            }
        };
        let Some((addr, len)) = addr else {
            self.skip_frame();
            self.rt.last_successful_time_s = t + h;
            self.debug(LogCategory::Osmp, || {
                format!("{F}: no SensorView at t = {t} s; outputs 0/0/0, valid = false")
            });
            return Fmi2Status::Ok;
        };
        // SAFETY: OSMP: the importer's OSMPSensorViewIn buffer is valid from its fmi2SetInteger
        // until the end of the next fmi2DoStep; we decode it here and keep no pointer.
        let mut view = match osi3::SensorView::decode(unsafe { osmp::bytes(addr, len) }) {
            Ok(v) => v,
            Err(e) => {
                self.skip_frame();
                self.log(
                    Fmi2Status::Warning,
                    LogCategory::Osi,
                    &format!(
                        "{F}: OSMPSensorViewIn ({len} bytes at {addr:#x}) is not a valid \
                         SensorView: {e}; frame skipped"
                    ),
                );
                self.rt.last_successful_time_s = t + h;
                return Fmi2Status::Warning;
            }
        };

        // Bad values are named here, once, before any model sees them (osiris_models::input).
        let screening = osiris_models::input::screen_view(&mut view);
        self.log_input_issues(F, t, &screening.issues);
        if screening.frame_skipped {
            self.skip_frame();
            self.rt.last_successful_time_s = t + h;
            return Fmi2Status::Warning;
        }
        let clean = if screening.is_clean() {
            Fmi2Status::Ok
        } else {
            Fmi2Status::Warning
        };

        let Some(model) = self.rt.model.as_mut() else {
            return self.fail(
                F,
                LogCategory::Fmi,
                "internal error: no model after initialization",
            );
        };
        // The model fills the whole output, headers included (`osiris_models::output`); the shell
        // publishes it as it is.
        let out = &mut self.rt.step_out;
        let result = model.step(
            &StepInput {
                view: &view,
                time_s: t,
                step_s: h,
            },
            out,
        );
        match result {
            Ok(()) => {}
            Err(ModelError::Input(msg)) => {
                self.skip_frame();
                self.log(
                    Fmi2Status::Warning,
                    LogCategory::Osi,
                    &format!(
                        "{F}: the model rejected the SensorView at t = {t} s: {msg}; frame skipped"
                    ),
                );
                self.rt.last_successful_time_s = t + h;
                return Fmi2Status::Warning;
            }
            Err(e) => {
                self.skip_frame();
                return self.fail(
                    F,
                    LogCategory::Osi,
                    &format!("model step at t = {t} s failed: {e}"),
                );
            }
        }
        let count = out.sensor_data.moving_object.len() + out.sensor_data.stationary_object.len();

        let published = self
            .rt
            .sensor_data
            .publish(&self.rt.step_out.sensor_data)
            .map_err(|e| format!("OSMPSensorDataOut: {e}"))
            .and_then(|()| {
                self.rt
                    .perception
                    .publish(&self.rt.step_out.perception)
                    .map_err(|e| format!("PerceptionDataOut: {e}"))
            });
        if let Err(msg) = published {
            self.skip_frame();
            return self.fail(F, LogCategory::Osmp, &msg);
        }
        self.rt.count = i32::try_from(count).unwrap_or(i32::MAX);
        self.rt.valid = true;
        self.rt.frames_published += 1;
        self.rt.last_successful_time_s = t + h;
        self.debug(LogCategory::Osmp, || {
            format!(
                "{F}: t = {t} s: SensorData {} bytes, PerceptionData {} bytes, {count} objects",
                self.rt.sensor_data.published[2], self.rt.perception.published[2]
            )
        });
        clean
    }

    /// Log the findings of the input screening as fmi2Warning: the first
    /// [`MAX_INPUT_ISSUES_LOGGED`] one per line, then one line counting the rest.
    fn log_input_issues(&mut self, f: &str, t: f64, issues: &[osiris_models::input::InputIssue]) {
        for issue in issues.iter().take(MAX_INPUT_ISSUES_LOGGED) {
            self.log(
                Fmi2Status::Warning,
                LogCategory::Osi,
                &format!("{f}: SensorView at t = {t} s: {issue}"),
            );
        }
        if issues.len() > MAX_INPUT_ISSUES_LOGGED {
            self.log(
                Fmi2Status::Warning,
                LogCategory::Osi,
                &format!(
                    "{f}: SensorView at t = {t} s: {} more findings of the same kind not listed",
                    issues.len() - MAX_INPUT_ISSUES_LOGGED
                ),
            );
        }
    }

    /// Publish "no output" for this step.
    fn skip_frame(&mut self) {
        self.rt.sensor_data.unpublish();
        self.rt.perception.unpublish();
        self.rt.count = 0;
        self.rt.valid = false;
    }

    // ---------------------------------------------------------------------------------------------
    // Status queries (fmi2Get*Status)

    const STATUS_STATES: [State; 2] = [SlaveInitialized, Terminated];

    pub(crate) fn get_status(
        &mut self,
        kind: ffi::Fmi2StatusKind,
    ) -> Result<Fmi2Status, Fmi2Status> {
        const F: &str = "fmi2GetStatus";
        self.check_state(F, &Self::STATUS_STATES)?;
        match kind {
            ffi::FMI2_DO_STEP_STATUS | ffi::FMI2_PENDING_STATUS => {
                self.debug(LogCategory::Fmi, || {
                    format!("{F}: no asynchronous step is ever pending")
                });
                Err(Fmi2Status::Discard)
            }
            other => Err(self.reject(F, &format!("status kind {other} has no fmi2Status value"))),
        }
    }

    pub(crate) fn get_real_status(&mut self, kind: ffi::Fmi2StatusKind) -> Result<f64, Fmi2Status> {
        const F: &str = "fmi2GetRealStatus";
        self.check_state(F, &Self::STATUS_STATES)?;
        match kind {
            ffi::FMI2_LAST_SUCCESSFUL_TIME => Ok(self.rt.last_successful_time_s),
            other => Err(self.reject(F, &format!("status kind {other} has no fmi2Real value"))),
        }
    }

    pub(crate) fn get_integer_status(&mut self, kind: ffi::Fmi2StatusKind) -> Fmi2Status {
        const F: &str = "fmi2GetIntegerStatus";
        if let Err(s) = self.check_state(F, &Self::STATUS_STATES) {
            return s;
        }
        self.debug(LogCategory::Fmi, || {
            format!("{F}: status kind {kind} has no fmi2Integer value")
        });
        Fmi2Status::Discard
    }

    pub(crate) fn get_boolean_status(
        &mut self,
        kind: ffi::Fmi2StatusKind,
    ) -> Result<bool, Fmi2Status> {
        const F: &str = "fmi2GetBooleanStatus";
        self.check_state(F, &Self::STATUS_STATES)?;
        match kind {
            // The slave never asks to end the simulation.
            ffi::FMI2_TERMINATED => Ok(false),
            other => Err(self.reject(F, &format!("status kind {other} has no fmi2Boolean value"))),
        }
    }

    pub(crate) fn get_string_status(&mut self, kind: ffi::Fmi2StatusKind) -> Fmi2Status {
        const F: &str = "fmi2GetStringStatus";
        if let Err(s) = self.check_state(F, &Self::STATUS_STATES) {
            return s;
        }
        if kind == ffi::FMI2_PENDING_STATUS {
            self.debug(LogCategory::Fmi, || {
                format!("{F}: no asynchronous step is ever pending")
            });
            Fmi2Status::Discard
        } else {
            self.reject(F, &format!("status kind {kind} has no fmi2String value"))
        }
    }
}
