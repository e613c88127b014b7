//! The FMI 2.0 C types (`fmi2TypesPlatform.h`, `fmi2FunctionTypes.h`), spelled in Rust.
//!
//! Enums that travel *into* the FMU (`fmi2Type`, `fmi2StatusKind`) are plain `c_int`s, so that an
//! out-of-range value from an importer is a checked error instead of an invalid Rust enum.
//! [`Fmi2Status`] only travels *out* (return values, logger argument, `fmi2GetStatus`), so it is a
//! `#[repr(C)]` enum, which has the size and values of the C enum.

#![allow(non_camel_case_types)]

use std::ffi::{c_char, c_int, c_uint, c_void};

/// `fmi2Component`: the instance handle (`void*`).
pub type Fmi2Component = *mut c_void;
/// `fmi2ComponentEnvironment`: the importer's opaque pointer handed back in callbacks (`void*`).
pub type Fmi2ComponentEnvironment = *mut c_void;
/// `fmi2FMUstate` (`void*`); never produced here (`canGetAndSetFMUstate="false"`).
pub type Fmi2FmuState = *mut c_void;
/// `fmi2ValueReference` (`unsigned int`).
pub type Fmi2ValueReference = c_uint;
/// `fmi2Real` (`double`).
pub type Fmi2Real = f64;
/// `fmi2Integer` (`int`).
pub type Fmi2Integer = c_int;
/// `fmi2Boolean` (`int`): [`FMI2_TRUE`] = 1, [`FMI2_FALSE`] = 0; any non-zero reads as true.
pub type Fmi2Boolean = c_int;
/// `fmi2Char` (`char`).
pub type Fmi2Char = c_char;
/// `fmi2String` (`const char*`, NUL-terminated).
pub type Fmi2String = *const c_char;
/// `fmi2Byte` (`char`).
pub type Fmi2Byte = c_char;
/// `fmi2Type` (`int`): [`FMI2_MODEL_EXCHANGE`] or [`FMI2_CO_SIMULATION`].
pub type Fmi2Type = c_int;
/// `fmi2StatusKind` (`int`), see the `FMI2_*_STATUS` constants.
pub type Fmi2StatusKind = c_int;

/// `fmi2True`.
pub const FMI2_TRUE: Fmi2Boolean = 1;
/// `fmi2False`.
pub const FMI2_FALSE: Fmi2Boolean = 0;
/// `fmi2ModelExchange`.
pub const FMI2_MODEL_EXCHANGE: Fmi2Type = 0;
/// `fmi2CoSimulation`.
pub const FMI2_CO_SIMULATION: Fmi2Type = 1;
/// `fmi2DoStepStatus`.
pub const FMI2_DO_STEP_STATUS: Fmi2StatusKind = 0;
/// `fmi2PendingStatus`.
pub const FMI2_PENDING_STATUS: Fmi2StatusKind = 1;
/// `fmi2LastSuccessfulTime`.
pub const FMI2_LAST_SUCCESSFUL_TIME: Fmi2StatusKind = 2;
/// `fmi2Terminated`.
pub const FMI2_TERMINATED: Fmi2StatusKind = 3;

/// `fmi2Status`. Ordered by severity, so `max` combines outcomes.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Fmi2Status {
    /// `fmi2OK`: all well.
    Ok = 0,
    /// `fmi2Warning`: not quite right, the computation continues (the logger was called).
    Warning = 1,
    /// `fmi2Discard`: only where the standard allows it (here: unsupported status kinds).
    Discard = 2,
    /// `fmi2Error`: the call failed.
    Error = 3,
    /// `fmi2Fatal`: the instance is irreparably broken (an internal panic).
    Fatal = 4,
    /// `fmi2Pending`: never returned (no asynchronous steps).
    Pending = 5,
}

impl Fmi2Status {
    /// The C name (`fmi2OK`, ...), for log messages.
    pub fn name(self) -> &'static str {
        match self {
            Fmi2Status::Ok => "fmi2OK",
            Fmi2Status::Warning => "fmi2Warning",
            Fmi2Status::Discard => "fmi2Discard",
            Fmi2Status::Error => "fmi2Error",
            Fmi2Status::Fatal => "fmi2Fatal",
            Fmi2Status::Pending => "fmi2Pending",
        }
    }
}

/// `fmi2CallbackLogger`: `void (*)(fmi2ComponentEnvironment, fmi2String instanceName, fmi2Status,
/// fmi2String category, fmi2String message, ...)`. `message` is a printf format; the shell always
/// passes `"%s"` and the text as the one variadic argument.
pub type Fmi2CallbackLogger = unsafe extern "C" fn(
    Fmi2ComponentEnvironment,
    Fmi2String,
    Fmi2Status,
    Fmi2String,
    Fmi2String,
    ...
);
/// `fmi2CallbackAllocateMemory`: `void* (*)(size_t nobj, size_t size)` (unused:
/// `canNotUseMemoryManagementFunctions="true"`).
pub type Fmi2CallbackAllocateMemory = unsafe extern "C" fn(usize, usize) -> *mut c_void;
/// `fmi2CallbackFreeMemory`: `void (*)(void*)` (unused).
pub type Fmi2CallbackFreeMemory = unsafe extern "C" fn(*mut c_void);
/// `fmi2StepFinished`: `void (*)(fmi2ComponentEnvironment, fmi2Status)` (unused: no asynchronous
/// steps).
pub type Fmi2StepFinished = unsafe extern "C" fn(Fmi2ComponentEnvironment, Fmi2Status);

/// `fmi2CallbackFunctions`. The shell copies it by value in `fmi2Instantiate`; every field may be
/// NULL (a NULL logger silences the instance).
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct Fmi2CallbackFunctions {
    /// `logger`.
    pub logger: Option<Fmi2CallbackLogger>,
    /// `allocateMemory`.
    pub allocate_memory: Option<Fmi2CallbackAllocateMemory>,
    /// `freeMemory`.
    pub free_memory: Option<Fmi2CallbackFreeMemory>,
    /// `stepFinished`.
    pub step_finished: Option<Fmi2StepFinished>,
    /// `componentEnvironment`, handed back as the logger's first argument.
    pub component_environment: Fmi2ComponentEnvironment,
}

impl Default for Fmi2CallbackFunctions {
    /// All NULL: no logger, no memory functions.
    fn default() -> Self {
        Fmi2CallbackFunctions {
            logger: None,
            allocate_memory: None,
            free_memory: None,
            step_finished: None,
            component_environment: std::ptr::null_mut(),
        }
    }
}
