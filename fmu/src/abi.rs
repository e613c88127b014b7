//! The 34 FMI 2.0 co-simulation functions as generic Rust functions over raw C types.
//!
//! [`crate::export_fmi2!`] generates the `#[unsafe(no_mangle)] extern "C"` trampolines of a cdylib
//! from these; Rust tests call them in-process. Every function:
//! * catches panics: a panic returns `fmi2Fatal` (NULL from [`instantiate`]) and marks the instance
//!   broken, after which every call but [`free_instance`] returns `fmi2Error`;
//! * returns `fmi2Error` for a NULL instance, NULL arrays with a non-zero length, and calls the
//!   state machine does not allow, logging the reason (never UB for a well-formed call sequence of
//!   any order);
//! * copies what it needs from the caller's pointers during the call and keeps no pointer, except
//!   the OSMP input/config addresses, which are dereferenced only inside the window OSMP allows.
//!
//! # Safety (all `unsafe fn`s here)
//! `c` must be NULL or a live instance returned by [`instantiate`] and not yet freed, used by one
//! thread at a time. Array arguments must point to `n` valid elements (or be anything when `n` is
//! 0); string arguments must be NULL or NUL-terminated. These are FMI's own preconditions.

use std::any::Any;
use std::ffi::{CStr, c_char};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::PathBuf;

use crate::descriptor::FmuDescriptor;
use crate::ffi::*;
use crate::instance::{Instance, State};
use crate::logging::{CategorySet, LogCategory, Logger};

// -------------------------------------------------------------------------------------------------
// Helpers

/// The text of a panic payload.
fn panic_message(payload: &(dyn Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "(non-string panic payload)".to_string()
    }
}

/// Drop a panic payload without letting a panicking `Drop` escape.
fn drop_payload(payload: Box<dyn Any + Send>) {
    if let Err(again) = catch_unwind(AssertUnwindSafe(move || drop(payload))) {
        std::mem::forget(again);
    }
}

/// Run `f` on the instance behind `c` with the panic guard and the broken-instance check.
fn with_instance(
    c: Fmi2Component,
    func: &'static str,
    f: impl FnOnce(&mut Instance) -> Fmi2Status,
) -> Fmi2Status {
    if c.is_null() {
        return Fmi2Status::Error;
    }
    let inst = c.cast::<Instance>();
    let result = catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: `c` is a live instance from `instantiate`, used by this thread only (caller's
        // contract); the reference ends with this closure.
        let inst = unsafe { &mut *inst };
        if inst.broken {
            return inst.reject(
                func,
                "the instance is broken after an internal panic; only fmi2FreeInstance is possible",
            );
        }
        f(inst)
    }));
    match result {
        Ok(status) => status,
        Err(payload) => {
            let msg = panic_message(payload.as_ref());
            drop_payload(payload);
            let _ = catch_unwind(AssertUnwindSafe(|| {
                // SAFETY: as above; the closure's borrow ended when it unwound.
                let inst = unsafe { &mut *inst };
                inst.broken = true;
                inst.state = State::Fatal;
                inst.log(
                    Fmi2Status::Fatal,
                    LogCategory::Fmi,
                    &format!(
                        "{func}: internal panic: {msg}; the instance is unusable, only \
                         fmi2FreeInstance is possible"
                    ),
                );
            }));
            Fmi2Status::Fatal
        }
    }
}

/// Like [`with_instance`], for functions whose only job is to be rejected.
fn reject(c: Fmi2Component, func: &'static str, why: &'static str) -> Fmi2Status {
    with_instance(c, func, |inst| inst.reject(func, why))
}

/// A caller's input array (`None` if it is NULL or misaligned while `n > 0`).
///
/// # Safety
/// If non-NULL, `ptr` points to `n` valid `T`s for `'a`.
unsafe fn in_slice<'a, T>(ptr: *const T, n: usize) -> Option<&'a [T]> {
    if n == 0 {
        return Some(&[]);
    }
    if ptr.is_null() || !ptr.is_aligned() || n > isize::MAX as usize / size_of::<T>().max(1) {
        return None;
    }
    // SAFETY: non-NULL, aligned, in-bounds length; validity is the caller's contract.
    Some(unsafe { std::slice::from_raw_parts(ptr, n) })
}

/// A caller's output array (`None` if it is NULL or misaligned while `n > 0`).
///
/// # Safety
/// If non-NULL, `ptr` points to `n` writable `T`s for `'a`, not aliased by anything we read.
unsafe fn out_slice<'a, T>(ptr: *mut T, n: usize) -> Option<&'a mut [T]> {
    if n == 0 {
        return Some(&mut []);
    }
    if ptr.is_null() || !ptr.is_aligned() || n > isize::MAX as usize / size_of::<T>().max(1) {
        return None;
    }
    // SAFETY: as in `in_slice`.
    Some(unsafe { std::slice::from_raw_parts_mut(ptr, n) })
}

/// A caller's C string as UTF-8 (`None` for NULL or invalid UTF-8).
///
/// # Safety
/// `s` is NULL or NUL-terminated.
unsafe fn opt_str<'a>(s: *const c_char) -> Option<&'a str> {
    if s.is_null() {
        return None;
    }
    // SAFETY: NUL-terminated by contract.
    unsafe { CStr::from_ptr(s) }.to_str().ok()
}

/// The directory an `fmuResourceLocation` URI names.
///
/// Accepted: `file:///abs/path`, `file:/abs/path`, `file://localhost/abs/path`, with or without a
/// trailing slash, percent-encoded (`%20`); and, leniently, a plain absolute path. Other schemes
/// and hosts are errors.
pub fn resource_dir_from_uri(uri: &str) -> Result<PathBuf, String> {
    match url::Url::parse(uri) {
        Ok(url) if url.scheme() == "file" => url.to_file_path().map_err(|()| {
            format!("`{uri}` does not name a local directory (host or path unusable)")
        }),
        // `C:\x` parses as scheme `c`.
        Ok(url) if url.scheme().len() == 1 && std::path::Path::new(uri).is_absolute() => {
            Ok(PathBuf::from(uri))
        }
        Ok(url) => Err(format!(
            "unsupported URI scheme `{}` in `{uri}` (expected file:)",
            url.scheme()
        )),
        Err(_) if std::path::Path::new(uri).is_absolute() => Ok(PathBuf::from(uri)),
        Err(e) => Err(format!("`{uri}` is not a URI: {e}")),
    }
}

// -------------------------------------------------------------------------------------------------
// Inquire platform and version

/// `fmi2GetTypesPlatform`: `"default"`.
pub fn get_types_platform() -> *const c_char {
    c"default".as_ptr()
}

/// `fmi2GetVersion`: `"2.0"`.
pub fn get_version() -> *const c_char {
    c"2.0".as_ptr()
}

// -------------------------------------------------------------------------------------------------
// Creation, destruction, logging

/// `fmi2SetDebugLogging`: see [`crate::logging`] for the category rules.
///
/// # Safety
/// See the module docs.
pub unsafe fn set_debug_logging(
    c: Fmi2Component,
    logging_on: Fmi2Boolean,
    n_categories: usize,
    categories: *const Fmi2String,
) -> Fmi2Status {
    with_instance(c, "fmi2SetDebugLogging", |inst| {
        let names: Vec<Option<&str>> = if logging_on == FMI2_FALSE {
            Vec::new()
        } else {
            // SAFETY: FMI contract on `categories`.
            match unsafe { in_slice(categories, n_categories) } {
                // SAFETY: each entry is NULL or NUL-terminated.
                Some(cats) => cats.iter().map(|&s| unsafe { opt_str(s) }).collect(),
                None => {
                    return inst.reject(
                        "fmi2SetDebugLogging",
                        "categories is NULL with nCategories > 0",
                    );
                }
            }
        };
        inst.set_debug_logging(logging_on != FMI2_FALSE, &names)
    })
}

/// `fmi2Instantiate` for the FMU `desc`. Returns NULL (after logging the reason through the
/// callbacks' logger, if any) when `functions` or `instanceName` is NULL, `instanceName` is empty,
/// `fmuType` is not `fmi2CoSimulation`, or `fmuGUID` differs from [`FmuDescriptor::guid`]. An
/// unusable `fmuResourceLocation` is logged as a warning and treated as "no resources".
///
/// # Safety
/// `functions` is NULL or points to a valid `fmi2CallbackFunctions` (copied here); strings are
/// NULL or NUL-terminated.
#[allow(clippy::too_many_arguments)]
pub unsafe fn instantiate(
    desc: &'static FmuDescriptor,
    instance_name: Fmi2String,
    fmu_type: Fmi2Type,
    fmu_guid: Fmi2String,
    fmu_resource_location: Fmi2String,
    functions: *const Fmi2CallbackFunctions,
    visible: Fmi2Boolean,
    logging_on: Fmi2Boolean,
) -> Fmi2Component {
    let _ = visible; // no user interface
    let result = catch_unwind(AssertUnwindSafe(|| {
        if functions.is_null() || !functions.is_aligned() {
            return None;
        }
        // SAFETY: non-NULL, aligned, valid for the call (FMI contract); copied by value.
        let callbacks: Fmi2CallbackFunctions = unsafe { *functions };
        let name = if instance_name.is_null() {
            None
        } else {
            // SAFETY: NUL-terminated by contract.
            Some(unsafe { CStr::from_ptr(instance_name) }.to_owned())
        };
        let logging_on = logging_on != FMI2_FALSE;
        let logger = Logger::new(
            callbacks,
            name.clone().unwrap_or_default(),
            CategorySet::for_logging_on(logging_on),
        );
        let fail = |msg: String| {
            logger.log(
                Fmi2Status::Error,
                LogCategory::Fmi,
                &format!("fmi2Instantiate: {msg}"),
            );
            None
        };
        let Some(name) = name else {
            return fail("instanceName is NULL".into());
        };
        if name.is_empty() {
            return fail("instanceName is empty".into());
        }
        if fmu_type != FMI2_CO_SIMULATION {
            return fail(format!(
                "fmuType {fmu_type} is not supported: {} is a co-simulation FMU \
                 (fmi2CoSimulation = {FMI2_CO_SIMULATION})",
                desc.model_identifier
            ));
        }
        let expected = desc.guid();
        // SAFETY: NULL or NUL-terminated.
        match unsafe { opt_str(fmu_guid) } {
            None => return fail("fmuGUID is NULL or not UTF-8".into()),
            Some(guid) if guid != expected => {
                return fail(format!(
                    "GUID mismatch: the importer passed `{guid}`, this binary ({} {}) is `{expected}`; the \
                     modelDescription.xml and the binary come from different builds",
                    desc.model_identifier,
                    env!("CARGO_PKG_VERSION")
                ));
            }
            Some(_) => {}
        }
        let resources_dir = if fmu_resource_location.is_null() {
            None
        } else {
            // SAFETY: NUL-terminated by contract.
            let raw = unsafe { CStr::from_ptr(fmu_resource_location) };
            match raw.to_str() {
                Err(_) => {
                    logger.log(
                        Fmi2Status::Warning,
                        LogCategory::Fmi,
                        "fmi2Instantiate: fmuResourceLocation is not UTF-8; no resources available",
                    );
                    None
                }
                Ok("") => None,
                Ok(uri) => {
                    match resource_dir_from_uri(uri) {
                        Ok(dir) => Some(dir),
                        Err(e) => {
                            logger.log(
                            Fmi2Status::Warning,
                            LogCategory::Fmi,
                            &format!("fmi2Instantiate: fmuResourceLocation: {e}; no resources available"),
                        );
                            None
                        }
                    }
                }
            }
        };
        let inst = Instance::new(desc, logger, logging_on, resources_dir.clone());
        if inst.logger.is_enabled(LogCategory::Fmi, Fmi2Status::Ok) {
            inst.log(
                Fmi2Status::Ok,
                LogCategory::Fmi,
                &format!(
                    "fmi2Instantiate: {} {} (GUID {expected}), resources {}",
                    desc.model_identifier,
                    env!("CARGO_PKG_VERSION"),
                    resources_dir
                        .as_ref()
                        .map_or("none".to_string(), |d| format!("`{}`", d.display()))
                ),
            );
        }
        Some(Box::new(inst))
    }));
    match result {
        Ok(Some(inst)) => Box::into_raw(inst).cast(),
        Ok(None) => std::ptr::null_mut(),
        Err(payload) => {
            drop_payload(payload);
            std::ptr::null_mut()
        }
    }
}

/// `fmi2FreeInstance`: frees the instance (in any state, broken ones included). NULL is a no-op.
///
/// # Safety
/// See the module docs; `c` must not be used afterwards.
pub unsafe fn free_instance(c: Fmi2Component) {
    if c.is_null() {
        return;
    }
    let _ = catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: `c` came from `Box::into_raw` in `instantiate` and is freed once (contract).
        let inst = unsafe { Box::from_raw(c.cast::<Instance>()) };
        if inst.logger.is_enabled(LogCategory::Fmi, Fmi2Status::Ok) {
            inst.log(Fmi2Status::Ok, LogCategory::Fmi, "fmi2FreeInstance");
        }
        drop(inst);
    }));
}

// -------------------------------------------------------------------------------------------------
// Initialization, termination, reset

/// `fmi2SetupExperiment`: records start and stop time (stepping past the stop time is an
/// error); the tolerance is unused.
///
/// # Safety
/// See the module docs.
pub unsafe fn setup_experiment(
    c: Fmi2Component,
    tolerance_defined: Fmi2Boolean,
    tolerance: Fmi2Real,
    start_time: Fmi2Real,
    stop_time_defined: Fmi2Boolean,
    stop_time: Fmi2Real,
) -> Fmi2Status {
    with_instance(c, "fmi2SetupExperiment", |inst| {
        inst.setup_experiment(
            (tolerance_defined != FMI2_FALSE).then_some(tolerance),
            start_time,
            (stop_time_defined != FMI2_FALSE).then_some(stop_time),
        )
    })
}

/// `fmi2EnterInitializationMode`.
///
/// # Safety
/// See the module docs.
pub unsafe fn enter_initialization_mode(c: Fmi2Component) -> Fmi2Status {
    with_instance(c, "fmi2EnterInitializationMode", |inst| {
        inst.enter_initialization_mode()
    })
}

/// `fmi2ExitInitializationMode`: a sensor builds its model if needed and applies the granted
/// `OSMPSensorViewInConfig` (notes are logged as warnings and give `fmi2Warning`); a source builds
/// its source if needed and publishes the view at the start time.
///
/// # Safety
/// See the module docs.
pub unsafe fn exit_initialization_mode(c: Fmi2Component) -> Fmi2Status {
    with_instance(c, "fmi2ExitInitializationMode", |inst| {
        inst.exit_initialization_mode()
    })
}

/// `fmi2Terminate`.
///
/// # Safety
/// See the module docs.
pub unsafe fn terminate(c: Fmi2Component) -> Fmi2Status {
    with_instance(c, "fmi2Terminate", |inst| inst.terminate())
}

/// `fmi2Reset`: back to the state right after `fmi2Instantiate`, start values included.
///
/// # Safety
/// See the module docs.
pub unsafe fn reset(c: Fmi2Component) -> Fmi2Status {
    with_instance(c, "fmi2Reset", |inst| inst.reset())
}

// -------------------------------------------------------------------------------------------------
// Getting and setting variable values

macro_rules! get_set_arrays {
    ($inst:ident, $func:literal, $vr:ident, $nvr:ident, $value:ident, $in_or_out:ident) => {{
        // SAFETY: FMI contract on the arrays.
        let Some(vrs) = (unsafe { in_slice($vr, $nvr) }) else {
            return $inst.reject($func, "vr is NULL or misaligned with nvr > 0");
        };
        // SAFETY: FMI contract on the arrays.
        let Some(values) = (unsafe { $in_or_out($value, $nvr) }) else {
            return $inst.reject($func, "value is NULL or misaligned with nvr > 0");
        };
        (vrs, values)
    }};
}

/// `fmi2GetReal`: the Real parameters of a sensor (set value, else start value); a source has none.
///
/// # Safety
/// See the module docs.
pub unsafe fn get_real(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *mut Fmi2Real,
) -> Fmi2Status {
    with_instance(c, "fmi2GetReal", |inst| {
        let (vrs, values) = get_set_arrays!(inst, "fmi2GetReal", vr, nvr, value, out_slice);
        inst.get_real(vrs, values)
    })
}

/// `fmi2GetInteger`: OSMP triples and `count`. Reading a sensor's ConfigRequest computes it (once);
/// reading a source's outputs during initialization computes its view at the start time.
///
/// # Safety
/// See the module docs.
pub unsafe fn get_integer(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *mut Fmi2Integer,
) -> Fmi2Status {
    with_instance(c, "fmi2GetInteger", |inst| {
        let (vrs, values) = get_set_arrays!(inst, "fmi2GetInteger", vr, nvr, value, out_slice);
        inst.get_integer(vrs, values)
    })
}

/// `fmi2GetBoolean`: `valid`.
///
/// # Safety
/// See the module docs.
pub unsafe fn get_boolean(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *mut Fmi2Boolean,
) -> Fmi2Status {
    with_instance(c, "fmi2GetBoolean", |inst| {
        let (vrs, values) = get_set_arrays!(inst, "fmi2GetBoolean", vr, nvr, value, out_slice);
        inst.get_boolean(vrs, values)
    })
}

/// `fmi2GetString`: the String parameters (a sensor's `config`, `mode`; a source's `scenario`,
/// `trace_path`, `sensor`), set value, else start value. The returned pointers stay valid until the
/// next `fmi2GetString` on this instance.
///
/// # Safety
/// See the module docs.
pub unsafe fn get_string(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *mut Fmi2String,
) -> Fmi2Status {
    with_instance(c, "fmi2GetString", |inst| {
        let (vrs, values) = get_set_arrays!(inst, "fmi2GetString", vr, nvr, value, out_slice);
        match inst.get_string(vrs) {
            Ok(strings) => {
                for (v, s) in values.iter_mut().zip(strings) {
                    *v = s.as_ptr();
                }
                Fmi2Status::Ok
            }
            Err(status) => status,
        }
    })
}

/// `fmi2SetReal`: Real parameters (fixed: only before `fmi2ExitInitializationMode`).
///
/// # Safety
/// See the module docs.
pub unsafe fn set_real(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *const Fmi2Real,
) -> Fmi2Status {
    with_instance(c, "fmi2SetReal", |inst| {
        let (vrs, values) = get_set_arrays!(inst, "fmi2SetReal", vr, nvr, value, in_slice);
        inst.set_real(vrs, values)
    })
}

/// `fmi2SetInteger`: a sensor's `OSMPSensorViewIn` triple (any time after instantiation) and
/// `OSMPSensorViewInConfig` triple (before `fmi2ExitInitializationMode`); a source has no settable
/// Integer.
///
/// # Safety
/// See the module docs.
pub unsafe fn set_integer(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *const Fmi2Integer,
) -> Fmi2Status {
    with_instance(c, "fmi2SetInteger", |inst| {
        let (vrs, values) = get_set_arrays!(inst, "fmi2SetInteger", vr, nvr, value, in_slice);
        inst.set_integer(vrs, values)
    })
}

/// `fmi2SetBoolean`: there is no settable Boolean (`valid` is an output).
///
/// # Safety
/// See the module docs.
pub unsafe fn set_boolean(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *const Fmi2Boolean,
) -> Fmi2Status {
    with_instance(c, "fmi2SetBoolean", |inst| {
        let (vrs, values) = get_set_arrays!(inst, "fmi2SetBoolean", vr, nvr, value, in_slice);
        inst.set_boolean(vrs, values)
    })
}

/// `fmi2SetString`: the String parameters (copied; before `fmi2ExitInitializationMode`).
///
/// # Safety
/// See the module docs.
pub unsafe fn set_string(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *const Fmi2String,
) -> Fmi2Status {
    with_instance(c, "fmi2SetString", |inst| {
        let (vrs, values) = get_set_arrays!(inst, "fmi2SetString", vr, nvr, value, in_slice);
        // SAFETY: each entry is NULL or NUL-terminated (contract).
        let owned: Vec<Option<String>> = values
            .iter()
            .map(|&s| unsafe { opt_str(s) }.map(str::to_owned))
            .collect();
        inst.set_string(vrs, &owned)
    })
}

// -------------------------------------------------------------------------------------------------
// FMU state (unsupported: canGetAndSetFMUstate="false", canSerializeFMUstate="false")

const NO_FMU_STATE: &str = "not supported (canGetAndSetFMUstate=\"false\")";
const NO_SERIALIZE: &str = "not supported (canSerializeFMUstate=\"false\")";

/// `fmi2GetFMUstate`: unsupported, `fmi2Error`.
///
/// # Safety
/// See the module docs.
pub unsafe fn get_fmu_state(c: Fmi2Component, fmu_state: *mut Fmi2FmuState) -> Fmi2Status {
    let _ = fmu_state;
    reject(c, "fmi2GetFMUstate", NO_FMU_STATE)
}

/// `fmi2SetFMUstate`: unsupported, `fmi2Error`.
///
/// # Safety
/// See the module docs.
pub unsafe fn set_fmu_state(c: Fmi2Component, fmu_state: Fmi2FmuState) -> Fmi2Status {
    let _ = fmu_state;
    reject(c, "fmi2SetFMUstate", NO_FMU_STATE)
}

/// `fmi2FreeFMUstate`: a NULL state (or a pointer to NULL) is ignored (`fmi2OK`), as FMI
/// requires; anything else cannot come from this FMU: `fmi2Error`.
///
/// # Safety
/// See the module docs; `fmu_state` is NULL or points to an `fmi2FMUstate`.
pub unsafe fn free_fmu_state(c: Fmi2Component, fmu_state: *mut Fmi2FmuState) -> Fmi2Status {
    with_instance(c, "fmi2FreeFMUstate", |inst| {
        // SAFETY: NULL-checked; points to an fmi2FMUstate by contract.
        if fmu_state.is_null() || unsafe { (*fmu_state).is_null() } {
            Fmi2Status::Ok
        } else {
            inst.reject("fmi2FreeFMUstate", NO_FMU_STATE)
        }
    })
}

/// `fmi2SerializedFMUstateSize`: unsupported, `fmi2Error`.
///
/// # Safety
/// See the module docs.
pub unsafe fn serialized_fmu_state_size(
    c: Fmi2Component,
    fmu_state: Fmi2FmuState,
    size: *mut usize,
) -> Fmi2Status {
    let _ = (fmu_state, size);
    reject(c, "fmi2SerializedFMUstateSize", NO_SERIALIZE)
}

/// `fmi2SerializeFMUstate`: unsupported, `fmi2Error`.
///
/// # Safety
/// See the module docs.
pub unsafe fn serialize_fmu_state(
    c: Fmi2Component,
    fmu_state: Fmi2FmuState,
    serialized_state: *mut Fmi2Byte,
    size: usize,
) -> Fmi2Status {
    let _ = (fmu_state, serialized_state, size);
    reject(c, "fmi2SerializeFMUstate", NO_SERIALIZE)
}

/// `fmi2DeSerializeFMUstate`: unsupported, `fmi2Error`.
///
/// # Safety
/// See the module docs.
pub unsafe fn deserialize_fmu_state(
    c: Fmi2Component,
    serialized_state: *const Fmi2Byte,
    size: usize,
    fmu_state: *mut Fmi2FmuState,
) -> Fmi2Status {
    let _ = (serialized_state, size, fmu_state);
    reject(c, "fmi2DeSerializeFMUstate", NO_SERIALIZE)
}

/// `fmi2GetDirectionalDerivative`: unsupported (`providesDirectionalDerivative="false"`),
/// `fmi2Error`.
///
/// # Safety
/// See the module docs.
pub unsafe fn get_directional_derivative(
    c: Fmi2Component,
    v_unknown_ref: *const Fmi2ValueReference,
    n_unknown: usize,
    v_known_ref: *const Fmi2ValueReference,
    n_known: usize,
    dv_known: *const Fmi2Real,
    dv_unknown: *mut Fmi2Real,
) -> Fmi2Status {
    let _ = (
        v_unknown_ref,
        n_unknown,
        v_known_ref,
        n_known,
        dv_known,
        dv_unknown,
    );
    reject(
        c,
        "fmi2GetDirectionalDerivative",
        "not supported (providesDirectionalDerivative=\"false\")",
    )
}

// -------------------------------------------------------------------------------------------------
// Co-simulation

/// `fmi2SetRealInputDerivatives`: unsupported (`canInterpolateInputs="false"`; there are no Real
/// inputs), `fmi2Error`.
///
/// # Safety
/// See the module docs.
pub unsafe fn set_real_input_derivatives(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    order: *const Fmi2Integer,
    value: *const Fmi2Real,
) -> Fmi2Status {
    let _ = (vr, nvr, order, value);
    reject(
        c,
        "fmi2SetRealInputDerivatives",
        "not supported (canInterpolateInputs=\"false\")",
    )
}

/// `fmi2GetRealOutputDerivatives`: unsupported (`maxOutputDerivativeOrder="0"`), `fmi2Error`.
///
/// # Safety
/// See the module docs.
pub unsafe fn get_real_output_derivatives(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    order: *const Fmi2Integer,
    value: *mut Fmi2Real,
) -> Fmi2Status {
    let _ = (vr, nvr, order, value);
    reject(
        c,
        "fmi2GetRealOutputDerivatives",
        "not supported (maxOutputDerivativeOrder=\"0\")",
    )
}

/// `fmi2DoStep`: a sensor decodes the SensorView, runs the model, publishes SensorData and
/// PerceptionData (double-buffered). No input (address 0 or size ≤ 0): `fmi2OK` with 0/0/0 outputs
/// and `valid = false`. Malformed input or a model input error: `fmi2Warning`, frame skipped. A
/// source publishes its SensorView at `t + h` (double-buffered; 0/0/0 and `valid = false` outside
/// its recording).
///
/// # Safety
/// See the module docs; the `OSMPSensorViewIn` buffer must be valid (OSMP).
pub unsafe fn do_step(
    c: Fmi2Component,
    current_communication_point: Fmi2Real,
    communication_step_size: Fmi2Real,
    no_set_fmu_state_prior_to_current_point: Fmi2Boolean,
) -> Fmi2Status {
    let _ = no_set_fmu_state_prior_to_current_point;
    with_instance(c, "fmi2DoStep", |inst| {
        inst.do_step(current_communication_point, communication_step_size)
    })
}

/// `fmi2CancelStep`: steps are never asynchronous, so there is nothing to cancel: `fmi2Error`.
///
/// # Safety
/// See the module docs.
pub unsafe fn cancel_step(c: Fmi2Component) -> Fmi2Status {
    reject(
        c,
        "fmi2CancelStep",
        "not allowed: no asynchronous step is ever in progress (canRunAsynchronuously=\"false\")",
    )
}

/// `fmi2GetStatus`: `fmi2Discard` for `fmi2DoStepStatus` / `fmi2PendingStatus` (nothing is ever
/// pending).
///
/// # Safety
/// See the module docs.
pub unsafe fn get_status(
    c: Fmi2Component,
    s: Fmi2StatusKind,
    value: *mut Fmi2Status,
) -> Fmi2Status {
    with_instance(c, "fmi2GetStatus", |inst| {
        if value.is_null() || !value.is_aligned() {
            return inst.reject("fmi2GetStatus", "value is NULL");
        }
        match inst.get_status(s) {
            Ok(v) => {
                // SAFETY: non-NULL, aligned, writable (contract).
                unsafe { value.write(v) };
                Fmi2Status::Ok
            }
            Err(status) => status,
        }
    })
}

/// `fmi2GetRealStatus`: `fmi2LastSuccessfulTime` = end of the last successful step, s.
///
/// # Safety
/// See the module docs.
pub unsafe fn get_real_status(
    c: Fmi2Component,
    s: Fmi2StatusKind,
    value: *mut Fmi2Real,
) -> Fmi2Status {
    with_instance(c, "fmi2GetRealStatus", |inst| {
        if value.is_null() || !value.is_aligned() {
            return inst.reject("fmi2GetRealStatus", "value is NULL");
        }
        match inst.get_real_status(s) {
            Ok(v) => {
                // SAFETY: non-NULL, aligned, writable (contract).
                unsafe { value.write(v) };
                Fmi2Status::Ok
            }
            Err(status) => status,
        }
    })
}

/// `fmi2GetIntegerStatus`: no Integer status exists in FMI 2.0: `fmi2Discard`.
///
/// # Safety
/// See the module docs.
pub unsafe fn get_integer_status(
    c: Fmi2Component,
    s: Fmi2StatusKind,
    value: *mut Fmi2Integer,
) -> Fmi2Status {
    let _ = value;
    with_instance(c, "fmi2GetIntegerStatus", |inst| inst.get_integer_status(s))
}

/// `fmi2GetBooleanStatus`: `fmi2Terminated` is always false.
///
/// # Safety
/// See the module docs.
pub unsafe fn get_boolean_status(
    c: Fmi2Component,
    s: Fmi2StatusKind,
    value: *mut Fmi2Boolean,
) -> Fmi2Status {
    with_instance(c, "fmi2GetBooleanStatus", |inst| {
        if value.is_null() || !value.is_aligned() {
            return inst.reject("fmi2GetBooleanStatus", "value is NULL");
        }
        match inst.get_boolean_status(s) {
            Ok(v) => {
                // SAFETY: non-NULL, aligned, writable (contract).
                unsafe { value.write(if v { FMI2_TRUE } else { FMI2_FALSE }) };
                Fmi2Status::Ok
            }
            Err(status) => status,
        }
    })
}

/// `fmi2GetStringStatus`: `fmi2Discard` for `fmi2PendingStatus` (nothing is ever pending).
///
/// # Safety
/// See the module docs.
pub unsafe fn get_string_status(
    c: Fmi2Component,
    s: Fmi2StatusKind,
    value: *mut Fmi2String,
) -> Fmi2Status {
    let _ = value;
    with_instance(c, "fmi2GetStringStatus", |inst| inst.get_string_status(s))
}
