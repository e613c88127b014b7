//! Test-only helper of `osiris-fmu`: a real C-variadic `fmi2CallbackLogger`, the C function
//! `osiris_testlog_logger` in `c/logger.c` (built with `cc`, linked with this crate). It formats
//! each message with `vsnprintf`, as an importer does, and records it in the [`LogCollector`] its
//! `componentEnvironment` points to.
//!
//! Users declare the C function with their own `fmi2Status` type:
//!
//! ```ignore
//! unsafe extern "C" {
//!     fn osiris_testlog_logger(env: *mut c_void, name: *const c_char, status: Fmi2Status,
//!                              category: *const c_char, message: *const c_char, ...);
//! }
//! ```

use std::ffi::{CStr, c_char, c_int, c_void};

use std::sync::Mutex;

/// One logger call.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LogRecord {
    pub instance_name: String,
    /// The `fmi2Status` value (0 OK ... 4 Fatal).
    pub status: i32,
    pub category: String,
    /// The raw `message` argument, i.e. the printf format the FMU passed.
    pub format: String,
    /// The message after `vsnprintf`.
    pub message: String,
}

/// Collects the records of every logger call whose `componentEnvironment` points to it.
#[derive(Debug, Default)]
pub struct LogCollector {
    records: Mutex<Vec<LogRecord>>,
}

impl LogCollector {
    /// A boxed collector (its address is the `componentEnvironment`; keep it alive while any
    /// instance logs to it).
    pub fn new() -> Box<LogCollector> {
        Box::default()
    }

    /// The `componentEnvironment` pointer for this collector.
    pub fn env(&self) -> *mut c_void {
        self as *const LogCollector as *mut c_void
    }

    /// A copy of the records so far.
    pub fn records(&self) -> Vec<LogRecord> {
        self.records
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .clone()
    }

    /// Remove and return the records so far.
    pub fn take(&self) -> Vec<LogRecord> {
        std::mem::take(&mut *self.records.lock().unwrap_or_else(|e| e.into_inner()))
    }

    /// True if some record's message contains `needle`.
    pub fn contains(&self, needle: &str) -> bool {
        self.records().iter().any(|r| r.message.contains(needle))
    }
}

fn lossy(s: *const c_char) -> String {
    if s.is_null() {
        "(NULL)".to_string()
    } else {
        // SAFETY: the C logger passes NUL-terminated strings or NULL.
        unsafe { CStr::from_ptr(s) }.to_string_lossy().into_owned()
    }
}

/// Called by the C logger with the formatted message.
///
/// # Safety
/// `env` is NULL or a live [`LogCollector`]; the strings are NULL or NUL-terminated.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn osiris_testlog_sink(
    env: *mut c_void,
    instance_name: *const c_char,
    status: c_int,
    category: *const c_char,
    format: *const c_char,
    formatted: *const c_char,
) {
    let record = LogRecord {
        instance_name: lossy(instance_name),
        status,
        category: lossy(category),
        format: lossy(format),
        message: lossy(formatted),
    };
    if env.is_null() {
        eprintln!("[fmu log without collector] {record:?}");
        return;
    }
    // SAFETY: `env` is a live LogCollector (contract).
    let collector = unsafe { &*(env as *const LogCollector) };
    collector
        .records
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .push(record);
}
