//! [`Instance`]: a safe wrapper owning one `fmi2Component`, with per-instance logging.

use std::collections::VecDeque;
use std::ffi::{CStr, CString, c_char, c_int, c_void};
use std::fmt;
use std::ptr::NonNull;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

use super::library::{Fmi2CallbackFunctions, Fmi2Component, FmuShared};
use super::{Fmu, MasterError, ModelDescription, Result, ScalarVariable, Value, VarType};

unsafe extern "C" {
    /// `src/master/logger.c`: formats the printf-style message and calls [`osiris_master_log_sink`].
    fn osiris_master_logger(
        env: *mut c_void,
        instance: *const c_char,
        status: c_int,
        category: *const c_char,
        message: *const c_char,
        ...
    );
    fn calloc(nobj: usize, size: usize) -> *mut c_void;
    fn free(ptr: *mut c_void);
}

/// `fmi2Status`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[repr(i32)]
pub enum Fmi2Status {
    Ok = 0,
    Warning = 1,
    Discard = 2,
    Error = 3,
    Fatal = 4,
    Pending = 5,
}

impl Fmi2Status {
    /// Maps the C value; values outside the enum count as `Fatal` (the FMU is broken).
    pub fn from_raw(raw: c_int) -> Fmi2Status {
        match raw {
            0 => Fmi2Status::Ok,
            1 => Fmi2Status::Warning,
            2 => Fmi2Status::Discard,
            3 => Fmi2Status::Error,
            5 => Fmi2Status::Pending,
            _ => Fmi2Status::Fatal,
        }
    }
}

impl fmt::Display for Fmi2Status {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "fmi2{self:?}")
    }
}

/// One message from the FMU's logger callback (or a status note from the master, category `master`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LogRecord {
    /// `instanceName` as passed by the FMU.
    pub instance: String,
    pub status: Fmi2Status,
    /// Empty if the FMU passed NULL.
    pub category: String,
    /// The formatted message (FMI `#r12#` value-reference escapes are left as they are).
    pub message: String,
}

impl fmt::Display for LogRecord {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let status = format!("{:?}", self.status);
        if self.category.is_empty() {
            write!(f, "[{status}] {}: {}", self.instance, self.message)
        } else {
            write!(
                f,
                "[{status}] {} ({}): {}",
                self.instance, self.category, self.message
            )
        }
    }
}

/// A user log callback; may be called from any thread the FMU logs from.
pub type LogCallback = Arc<dyn Fn(&LogRecord) + Send + Sync>;

/// How to instantiate and where log messages go.
#[derive(Clone)]
pub struct InstanceOptions {
    /// `visible` argument of `fmi2Instantiate` (default false).
    pub visible: bool,
    /// `loggingOn` argument of `fmi2Instantiate` (default false: FMUs then log errors and warnings only).
    pub logging_on: bool,
    /// Print records with at least this status to stderr (default `Some(Warning)`; `None`: never).
    pub stderr_level: Option<Fmi2Status>,
    /// Called for every record.
    pub log_callback: Option<LogCallback>,
    /// How many records the instance keeps (oldest dropped first; default 1000).
    pub log_capacity: usize,
}

impl Default for InstanceOptions {
    fn default() -> Self {
        InstanceOptions {
            visible: false,
            logging_on: false,
            stderr_level: Some(Fmi2Status::Warning),
            log_callback: None,
            log_capacity: 1000,
        }
    }
}

impl fmt::Debug for InstanceOptions {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("InstanceOptions")
            .field("visible", &self.visible)
            .field("logging_on", &self.logging_on)
            .field("stderr_level", &self.stderr_level)
            .field(
                "log_callback",
                &self.log_callback.as_ref().map(|_| "Fn(&LogRecord)"),
            )
            .field("log_capacity", &self.log_capacity)
            .finish()
    }
}

/// The instance's state in the FMI 2.0 co-simulation state machine, as far as the master tracks it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InstanceState {
    /// After `fmi2Instantiate` or `fmi2Reset`.
    Instantiated,
    /// Between `fmi2EnterInitializationMode` and `fmi2ExitInitializationMode`.
    InitializationMode,
    /// `slaveInitialized`: stepping.
    Initialized,
    /// After `fmi2Terminate`.
    Terminated,
    /// A call returned `fmi2Error`: only get functions, `fmi2Reset` and freeing are allowed.
    Error,
    /// A call returned `fmi2Fatal`: only freeing is allowed.
    Fatal,
}

/// Heap-allocated log state; its address is the instance's `componentEnvironment`.
struct LogState {
    name: String,
    records: Mutex<VecDeque<LogRecord>>,
    capacity: usize,
    warnings: AtomicUsize,
    stderr_level: Option<Fmi2Status>,
    callback: Option<LogCallback>,
}

impl LogState {
    fn push(&self, record: LogRecord) {
        if record.status >= Fmi2Status::Warning && record.status != Fmi2Status::Pending {
            self.warnings.fetch_add(1, Ordering::Relaxed);
        }
        if self
            .stderr_level
            .is_some_and(|level| record.status >= level)
        {
            eprintln!("{record}");
        }
        if let Some(cb) = &self.callback {
            cb(&record);
        }
        if self.capacity == 0 {
            return;
        }
        let mut records = self.records.lock().unwrap_or_else(|e| e.into_inner());
        if records.len() >= self.capacity {
            records.pop_front();
        }
        records.push_back(record);
    }

    fn last_lines(&self, n: usize) -> Vec<String> {
        let records = self.records.lock().unwrap_or_else(|e| e.into_inner());
        records
            .iter()
            .skip(records.len().saturating_sub(n))
            .map(ToString::to_string)
            .collect()
    }
}

fn lossy(ptr: *const c_char) -> String {
    if ptr.is_null() {
        String::new()
    } else {
        // SAFETY: the FMU passes NUL-terminated strings valid for the duration of the call.
        unsafe { CStr::from_ptr(ptr) }
            .to_string_lossy()
            .into_owned()
    }
}

/// Called by `logger.c` with the formatted message.
#[unsafe(no_mangle)]
extern "C" fn osiris_master_log_sink(
    env: *mut c_void,
    instance: *const c_char,
    status: c_int,
    category: *const c_char,
    message: *const c_char,
) {
    // A panic must not unwind into the FMU's C frames.
    let _ = std::panic::catch_unwind(|| {
        // SAFETY: a non-NULL `env` is the `componentEnvironment` we passed: a `Box<LogState>` the instance
        // keeps alive until after `fmi2FreeInstance`. `LogState` is `Sync` (Mutex/atomics).
        let state = unsafe { (env as *const LogState).as_ref() };
        let mut record = LogRecord {
            instance: lossy(instance),
            status: Fmi2Status::from_raw(status),
            category: lossy(category),
            message: lossy(message),
        };
        match state {
            Some(state) => {
                if record.instance.is_empty() {
                    record.instance.clone_from(&state.name);
                }
                state.push(record);
            }
            None => eprintln!("{record} (the FMU passed a NULL componentEnvironment)"),
        }
    });
}

unsafe extern "C" fn allocate_memory(nobj: usize, size: usize) -> *mut c_void {
    // SAFETY: plain C calloc.
    unsafe { calloc(nobj, size) }
}

unsafe extern "C" fn free_memory(ptr: *mut c_void) {
    // SAFETY: `ptr` came from `allocate_memory` (or is NULL).
    unsafe { free(ptr) }
}

/// Number of log lines attached to [`MasterError::Fmi`].
const ERROR_LOG_LINES: usize = 8;

/// One FMI 2.0 co-simulation instance.
///
/// * Status mapping: `fmi2OK` → `Ok`; `fmi2Warning` → `Ok` with a `master` warning record added to the log;
///   `fmi2Discard` → `Ok(Discard)` where a status is returned (`do_step`); `fmi2Error`, `fmi2Fatal` and
///   `fmi2Pending` (asynchronous stepping is not supported) → [`MasterError::Fmi`] with the last log lines.
/// * After `fmi2Error` only get functions and [`Instance::reset`] are passed on, after `fmi2Fatal` nothing
///   ([`MasterError::IllegalState`]); other call-order violations are left to the FMU to report.
/// * `Drop` calls `fmi2Terminate` if the instance is in initialization mode or initialized, then
///   `fmi2FreeInstance`.
///
/// # Thread safety
/// `Instance` is `Send` but not `Sync`: FMI 2.0 §2.1 lets different instances be called from different
/// threads in parallel; an instance needs no thread affinity, only calls that are not concurrent, which
/// `&mut self` on every FMU call and `!Sync` guarantee. The other raw pointers it owns (callbacks struct,
/// componentEnvironment) point to heap data owned by the instance whose log state is `Mutex`-protected, and
/// the shared library and function table are `Send + Sync`.
pub struct Instance {
    shared: Arc<FmuShared>,
    component: NonNull<c_void>,
    name: String,
    state: InstanceState,
    log: Box<LogState>,
    /// Some FMUs keep the pointer instead of copying the struct: keep it alive and at a stable address.
    _callbacks: Box<Fmi2CallbackFunctions>,
}

// SAFETY: see "Thread safety" above.
unsafe impl Send for Instance {}

impl fmt::Debug for Instance {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Instance")
            .field("name", &self.name)
            .field("model", &self.shared.model.model_name)
            .field("state", &self.state)
            .finish_non_exhaustive()
    }
}

fn cstring(what: &str, s: &str) -> Result<CString> {
    CString::new(s).map_err(|_| MasterError::NulInString {
        what: what.to_owned(),
    })
}

impl Instance {
    pub(crate) fn new(fmu: &Fmu, name: &str, options: InstanceOptions) -> Result<Instance> {
        let shared = fmu.shared.clone();
        let log = Box::new(LogState {
            name: name.to_owned(),
            records: Mutex::new(VecDeque::new()),
            capacity: options.log_capacity,
            warnings: AtomicUsize::new(0),
            stderr_level: options.stderr_level,
            callback: options.log_callback,
        });
        let callbacks = Box::new(Fmi2CallbackFunctions {
            logger: Some(osiris_master_logger),
            allocate_memory: Some(allocate_memory),
            free_memory: Some(free_memory),
            step_finished: None,
            component_environment: &*log as *const LogState as *mut c_void,
        });
        let c_name = cstring("instanceName", name)?;
        let guid = cstring("guid", &shared.model.guid)?;
        let resources = cstring("fmuResourceLocation", &shared.resource_location)?;
        // SAFETY: valid NUL-terminated strings and callbacks for the duration of the call; fmuType 1 =
        // fmi2CoSimulation.
        let component = unsafe {
            (shared.functions.instantiate)(
                c_name.as_ptr(),
                1,
                guid.as_ptr(),
                resources.as_ptr(),
                &*callbacks,
                c_int::from(options.visible),
                c_int::from(options.logging_on),
            )
        };
        let Some(component) = NonNull::new(component) else {
            return Err(MasterError::InstantiationFailed {
                instance: name.to_owned(),
                model: shared.model.model_name.clone(),
                log: log.last_lines(ERROR_LOG_LINES),
            });
        };
        Ok(Instance {
            shared,
            component,
            name: name.to_owned(),
            state: InstanceState::Instantiated,
            log,
            _callbacks: callbacks,
        })
    }

    /// The instance name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The tracked state.
    pub fn state(&self) -> InstanceState {
        self.state
    }

    /// The FMU's model description.
    pub fn model_description(&self) -> &ModelDescription {
        &self.shared.model
    }

    /// The FMU this instance belongs to.
    pub fn fmu(&self) -> Fmu {
        Fmu {
            shared: self.shared.clone(),
        }
    }

    /// The raw `fmi2Component` (valid while `self` lives; do not free it).
    pub fn raw_component(&self) -> Fmi2Component {
        self.component.as_ptr()
    }

    /// A copy of the kept log records (oldest first).
    pub fn log_records(&self) -> Vec<LogRecord> {
        self.log
            .records
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .iter()
            .cloned()
            .collect()
    }

    /// Removes and returns the kept log records.
    pub fn take_log(&self) -> Vec<LogRecord> {
        self.log
            .records
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .drain(..)
            .collect()
    }

    /// The last `n` records, formatted.
    pub fn last_log_lines(&self, n: usize) -> Vec<String> {
        self.log.last_lines(n)
    }

    /// How many records with status Warning or worse were logged (by the FMU or the master).
    pub fn warning_count(&self) -> usize {
        self.log.warnings.load(Ordering::Relaxed)
    }

    fn guard(&self, action: &'static str, allowed_in_error: bool) -> Result<()> {
        let refused = match self.state {
            InstanceState::Fatal => true,
            InstanceState::Error => !allowed_in_error,
            _ => false,
        };
        if refused {
            return Err(MasterError::IllegalState {
                instance: self.name.clone(),
                action,
                state: format!("{:?}", self.state),
                expected: if self.state == InstanceState::Fatal {
                    "only freeing (drop) after fmi2Fatal"
                } else {
                    "only get functions, reset or freeing after fmi2Error"
                },
            });
        }
        Ok(())
    }

    /// Maps a returned status; records warnings and moves to Error/Fatal.
    fn check(&mut self, function: &'static str, raw: c_int) -> Result<Fmi2Status> {
        let status = Fmi2Status::from_raw(raw);
        match status {
            Fmi2Status::Ok | Fmi2Status::Discard => Ok(status),
            Fmi2Status::Warning => {
                self.log.push(LogRecord {
                    instance: self.name.clone(),
                    status,
                    category: "master".to_owned(),
                    message: format!("{function} returned fmi2Warning"),
                });
                Ok(status)
            }
            Fmi2Status::Error | Fmi2Status::Fatal | Fmi2Status::Pending => {
                self.state = if status == Fmi2Status::Fatal {
                    InstanceState::Fatal
                } else {
                    InstanceState::Error
                };
                let mut log = self.log.last_lines(ERROR_LOG_LINES);
                if raw != status as c_int {
                    log.push(format!("(the FMU returned the invalid status value {raw})"));
                }
                Err(MasterError::Fmi {
                    function,
                    instance: self.name.clone(),
                    status,
                    log,
                })
            }
        }
    }

    fn call(
        &mut self,
        function: &'static str,
        allowed_in_error: bool,
        f: impl FnOnce(*mut c_void) -> c_int,
    ) -> Result<Fmi2Status> {
        self.guard(function, allowed_in_error)?;
        let raw = f(self.component.as_ptr());
        self.check(function, raw)
    }

    /// `fmi2SetDebugLogging` (empty `categories`: all).
    pub fn set_debug_logging(
        &mut self,
        logging_on: bool,
        categories: &[&str],
    ) -> Result<Fmi2Status> {
        let owned = categories
            .iter()
            .map(|c| cstring("log category", c))
            .collect::<Result<Vec<_>>>()?;
        let ptrs: Vec<*const c_char> = owned.iter().map(|c| c.as_ptr()).collect();
        let f = self.shared.functions.set_debug_logging;
        // SAFETY: `ptrs` holds `len` valid strings for the call.
        self.call("fmi2SetDebugLogging", true, |c| unsafe {
            f(c, c_int::from(logging_on), ptrs.len(), ptrs.as_ptr())
        })
    }

    /// `fmi2SetupExperiment`.
    pub fn setup_experiment(
        &mut self,
        tolerance: Option<f64>,
        start_time: f64,
        stop_time: Option<f64>,
    ) -> Result<Fmi2Status> {
        let f = self.shared.functions.setup_experiment;
        // SAFETY: scalar arguments only.
        self.call("fmi2SetupExperiment", false, |c| unsafe {
            f(
                c,
                c_int::from(tolerance.is_some()),
                tolerance.unwrap_or(0.0),
                start_time,
                c_int::from(stop_time.is_some()),
                stop_time.unwrap_or(0.0),
            )
        })
    }

    /// `fmi2EnterInitializationMode`.
    pub fn enter_initialization_mode(&mut self) -> Result<Fmi2Status> {
        let f = self.shared.functions.enter_initialization_mode;
        // SAFETY: valid component.
        let s = self.call("fmi2EnterInitializationMode", false, |c| unsafe { f(c) })?;
        self.state = InstanceState::InitializationMode;
        Ok(s)
    }

    /// `fmi2ExitInitializationMode`.
    pub fn exit_initialization_mode(&mut self) -> Result<Fmi2Status> {
        let f = self.shared.functions.exit_initialization_mode;
        // SAFETY: valid component.
        let s = self.call("fmi2ExitInitializationMode", false, |c| unsafe { f(c) })?;
        self.state = InstanceState::Initialized;
        Ok(s)
    }

    /// `fmi2DoStep(t, h, noSetFMUStatePriorToCurrentPoint)`; `Ok(Discard)` if the step was not completed.
    pub fn do_step(
        &mut self,
        current_communication_point: f64,
        step_size: f64,
        no_set_fmu_state_prior: bool,
    ) -> Result<Fmi2Status> {
        let f = self.shared.functions.do_step;
        // SAFETY: scalar arguments only.
        self.call("fmi2DoStep", false, |c| unsafe {
            f(
                c,
                current_communication_point,
                step_size,
                c_int::from(no_set_fmu_state_prior),
            )
        })
    }

    /// `fmi2Terminate`.
    pub fn terminate(&mut self) -> Result<Fmi2Status> {
        let f = self.shared.functions.terminate;
        // SAFETY: valid component.
        let s = self.call("fmi2Terminate", false, |c| unsafe { f(c) })?;
        self.state = InstanceState::Terminated;
        Ok(s)
    }

    /// `fmi2Reset`: back to the state after instantiation (also leaves the Error state).
    pub fn reset(&mut self) -> Result<Fmi2Status> {
        let f = self.shared.functions.reset;
        // SAFETY: valid component.
        let s = self.call("fmi2Reset", true, |c| unsafe { f(c) })?;
        self.state = InstanceState::Instantiated;
        Ok(s)
    }

    /// `fmi2CancelStep`.
    pub fn cancel_step(&mut self) -> Result<Fmi2Status> {
        let f = self.shared.functions.cancel_step;
        // SAFETY: valid component.
        self.call("fmi2CancelStep", false, |c| unsafe { f(c) })
    }

    /// `fmi2GetRealStatus(fmi2LastSuccessfulTime)`.
    pub fn last_successful_time(&mut self) -> Result<f64> {
        let f = self.shared.functions.get_real_status;
        let mut t = 0.0;
        // SAFETY: `t` is a valid out pointer; kind 2 = fmi2LastSuccessfulTime.
        self.call("fmi2GetRealStatus", true, |c| unsafe { f(c, 2, &mut t) })?;
        Ok(t)
    }

    /// `fmi2GetReal` into `values` (`values.len() == vrs.len()`).
    ///
    /// # Panics
    /// If the slices differ in length.
    pub fn get_real(&mut self, vrs: &[u32], values: &mut [f64]) -> Result<Fmi2Status> {
        assert_eq!(
            vrs.len(),
            values.len(),
            "get_real: one value per value reference"
        );
        let f = self.shared.functions.get_real;
        // SAFETY: both arrays hold `vrs.len()` elements.
        self.call("fmi2GetReal", true, |c| unsafe {
            f(c, vrs.as_ptr(), vrs.len(), values.as_mut_ptr())
        })
    }

    /// `fmi2GetInteger` into `values` (also for Enumeration variables).
    ///
    /// # Panics
    /// If the slices differ in length.
    pub fn get_integer(&mut self, vrs: &[u32], values: &mut [i32]) -> Result<Fmi2Status> {
        assert_eq!(
            vrs.len(),
            values.len(),
            "get_integer: one value per value reference"
        );
        let f = self.shared.functions.get_integer;
        // SAFETY: both arrays hold `vrs.len()` elements.
        self.call("fmi2GetInteger", true, |c| unsafe {
            f(c, vrs.as_ptr(), vrs.len(), values.as_mut_ptr())
        })
    }

    /// `fmi2GetBoolean` into `values`.
    ///
    /// # Panics
    /// If the slices differ in length.
    pub fn get_boolean(&mut self, vrs: &[u32], values: &mut [bool]) -> Result<Fmi2Status> {
        assert_eq!(
            vrs.len(),
            values.len(),
            "get_boolean: one value per value reference"
        );
        let mut raw = vec![0 as c_int; vrs.len()];
        let f = self.shared.functions.get_boolean;
        // SAFETY: both arrays hold `vrs.len()` elements.
        let s = self.call("fmi2GetBoolean", true, |c| unsafe {
            f(c, vrs.as_ptr(), vrs.len(), raw.as_mut_ptr())
        })?;
        for (v, r) in values.iter_mut().zip(raw) {
            *v = r != 0;
        }
        Ok(s)
    }

    /// `fmi2GetString`; the strings are copied at once (they are valid only until the next call).
    pub fn get_string(&mut self, vrs: &[u32]) -> Result<Vec<String>> {
        let mut raw: Vec<*const c_char> = vec![std::ptr::null(); vrs.len()];
        let f = self.shared.functions.get_string;
        // SAFETY: both arrays hold `vrs.len()` elements.
        self.call("fmi2GetString", true, |c| unsafe {
            f(c, vrs.as_ptr(), vrs.len(), raw.as_mut_ptr())
        })?;
        Ok(raw.into_iter().map(lossy).collect())
    }

    /// `fmi2SetReal`.
    ///
    /// # Panics
    /// If the slices differ in length.
    pub fn set_real(&mut self, vrs: &[u32], values: &[f64]) -> Result<Fmi2Status> {
        assert_eq!(
            vrs.len(),
            values.len(),
            "set_real: one value per value reference"
        );
        let f = self.shared.functions.set_real;
        // SAFETY: both arrays hold `vrs.len()` elements.
        self.call("fmi2SetReal", false, |c| unsafe {
            f(c, vrs.as_ptr(), vrs.len(), values.as_ptr())
        })
    }

    /// `fmi2SetInteger` (also for Enumeration variables).
    ///
    /// # Panics
    /// If the slices differ in length.
    pub fn set_integer(&mut self, vrs: &[u32], values: &[i32]) -> Result<Fmi2Status> {
        assert_eq!(
            vrs.len(),
            values.len(),
            "set_integer: one value per value reference"
        );
        let f = self.shared.functions.set_integer;
        // SAFETY: both arrays hold `vrs.len()` elements.
        self.call("fmi2SetInteger", false, |c| unsafe {
            f(c, vrs.as_ptr(), vrs.len(), values.as_ptr())
        })
    }

    /// `fmi2SetBoolean` (passes `fmi2True` = 1 / `fmi2False` = 0).
    ///
    /// # Panics
    /// If the slices differ in length.
    pub fn set_boolean(&mut self, vrs: &[u32], values: &[bool]) -> Result<Fmi2Status> {
        assert_eq!(
            vrs.len(),
            values.len(),
            "set_boolean: one value per value reference"
        );
        let raw: Vec<c_int> = values.iter().map(|&b| c_int::from(b)).collect();
        let f = self.shared.functions.set_boolean;
        // SAFETY: both arrays hold `vrs.len()` elements.
        self.call("fmi2SetBoolean", false, |c| unsafe {
            f(c, vrs.as_ptr(), vrs.len(), raw.as_ptr())
        })
    }

    /// `fmi2SetString`.
    ///
    /// # Panics
    /// If the slices differ in length.
    pub fn set_string(&mut self, vrs: &[u32], values: &[&str]) -> Result<Fmi2Status> {
        assert_eq!(
            vrs.len(),
            values.len(),
            "set_string: one value per value reference"
        );
        let owned = values
            .iter()
            .map(|v| cstring("String value", v))
            .collect::<Result<Vec<_>>>()?;
        let ptrs: Vec<*const c_char> = owned.iter().map(|c| c.as_ptr()).collect();
        let f = self.shared.functions.set_string;
        // SAFETY: both arrays hold `vrs.len()` elements; the strings outlive the call.
        self.call("fmi2SetString", false, |c| unsafe {
            f(c, vrs.as_ptr(), vrs.len(), ptrs.as_ptr())
        })
    }

    fn variable(&self, name: &str) -> Result<ScalarVariable> {
        self.shared
            .model
            .variable(name)
            .cloned()
            .ok_or_else(|| MasterError::UnknownVariable {
                model: self.shared.model.model_name.clone(),
                name: name.to_owned(),
            })
    }

    /// Sets the variable `name`. A Real variable also accepts an Integer value; Integer and Enumeration
    /// variables take Integers.
    pub fn set(&mut self, name: &str, value: impl Into<Value>) -> Result<Fmi2Status> {
        let var = self.variable(name)?;
        let vr = [var.value_reference];
        let mismatch = |found: &'static str| MasterError::TypeMismatch {
            model: self.shared.model.model_name.clone(),
            name: name.to_owned(),
            expected: var.var_type,
            found,
        };
        match (var.var_type, value.into()) {
            (VarType::Real, Value::Real(v)) => self.set_real(&vr, &[v]),
            (VarType::Real, Value::Integer(v)) => self.set_real(&vr, &[f64::from(v)]),
            (VarType::Integer | VarType::Enumeration, Value::Integer(v)) => {
                self.set_integer(&vr, &[v])
            }
            (VarType::Boolean, Value::Boolean(v)) => self.set_boolean(&vr, &[v]),
            (VarType::String, Value::String(v)) => self.set_string(&vr, &[&v]),
            (_, other) => Err(mismatch(other.type_name())),
        }
    }

    /// Parses `text` for the type of variable `name` (see [`Value::parse`]) and sets it.
    pub fn set_from_str(&mut self, name: &str, text: &str) -> Result<Fmi2Status> {
        let var = self.variable(name)?;
        let value =
            Value::parse(var.var_type, text).map_err(|reason| MasterError::InvalidValue {
                name: name.to_owned(),
                reason,
            })?;
        self.set(name, value)
    }

    /// Gets the variable `name`.
    pub fn get(&mut self, name: &str) -> Result<Value> {
        let var = self.variable(name)?;
        let vr = [var.value_reference];
        Ok(match var.var_type {
            VarType::Real => {
                let mut v = [0.0];
                self.get_real(&vr, &mut v)?;
                Value::Real(v[0])
            }
            VarType::Integer | VarType::Enumeration => {
                let mut v = [0];
                self.get_integer(&vr, &mut v)?;
                Value::Integer(v[0])
            }
            VarType::Boolean => {
                let mut v = [false];
                self.get_boolean(&vr, &mut v)?;
                Value::Boolean(v[0])
            }
            VarType::String => Value::String(self.get_string(&vr)?.pop().unwrap_or_default()),
        })
    }
}

impl Drop for Instance {
    fn drop(&mut self) {
        let c = self.component.as_ptr();
        if matches!(
            self.state,
            InstanceState::InitializationMode | InstanceState::Initialized
        ) {
            // SAFETY: valid component; the status is irrelevant while freeing.
            let raw = unsafe { (self.shared.functions.terminate)(c) };
            if Fmi2Status::from_raw(raw) >= Fmi2Status::Error {
                let lines = self.log.last_lines(ERROR_LOG_LINES);
                eprintln!(
                    "instance `{}`: fmi2Terminate returned {raw} while dropping; {}",
                    self.name,
                    lines.join(" | ")
                );
            }
        }
        // SAFETY: the component is freed exactly once, here; the log state and callbacks it may use while
        // freeing are fields dropped after this function returns.
        unsafe { (self.shared.functions.free_instance)(c) };
    }
}
