//! The FMI logger, called safely: always with the format `"%s"` and the text as its one argument,
//! never with a NULL logger, only for enabled categories.
//!
//! Every message has a *topic* ([`LogCategory::Fmi`], [`LogCategory::Osmp`] or
//! [`LogCategory::Osi`]) and a status. A message is delivered when `logAll`, its topic, or the
//! category of its status (`logStatusWarning` / `logStatusError` / `logStatusFatal`) is enabled.
//! The `category` argument the logger gets is the status category for warnings, errors and fatal
//! errors, and the topic otherwise.
//!
//! Enabled categories:
//! * `fmi2Instantiate(loggingOn = true)` or `fmi2SetDebugLogging(true, 0, ..)`: all.
//! * `loggingOn = false` (either call): debug logging off; the three status categories stay on, so
//!   errors and warnings (e.g. a GUID mismatch) are still reported. FMI 2.0 defines `loggingOn` as
//!   switching *debug* logging.
//! * `fmi2SetDebugLogging(true, n > 0, categories)`: exactly the named categories.

use std::ffi::{CString, c_char};

use crate::ffi::{Fmi2CallbackFunctions, Fmi2Status};

/// The log categories declared in every osiris modelDescription.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum LogCategory {
    /// `logStatusWarning`.
    StatusWarning,
    /// `logStatusError`.
    StatusError,
    /// `logStatusFatal`.
    StatusFatal,
    /// `logAll`.
    All,
    /// `FMI`: calls, states, parameters.
    Fmi,
    /// `OSMP`: binary variables (addresses, sizes, buffers, the configuration handshake).
    Osmp,
    /// `OSI`: message content (decoding, model notes).
    Osi,
}

impl LogCategory {
    /// All categories in modelDescription order.
    pub const ALL: [LogCategory; 7] = [
        LogCategory::StatusWarning,
        LogCategory::StatusError,
        LogCategory::StatusFatal,
        LogCategory::All,
        LogCategory::Fmi,
        LogCategory::Osmp,
        LogCategory::Osi,
    ];

    /// The category name of the modelDescription and the logger.
    pub fn name(self) -> &'static str {
        match self {
            LogCategory::StatusWarning => "logStatusWarning",
            LogCategory::StatusError => "logStatusError",
            LogCategory::StatusFatal => "logStatusFatal",
            LogCategory::All => "logAll",
            LogCategory::Fmi => "FMI",
            LogCategory::Osmp => "OSMP",
            LogCategory::Osi => "OSI",
        }
    }

    /// The category name as a C string.
    fn c_name(self) -> &'static std::ffi::CStr {
        match self {
            LogCategory::StatusWarning => c"logStatusWarning",
            LogCategory::StatusError => c"logStatusError",
            LogCategory::StatusFatal => c"logStatusFatal",
            LogCategory::All => c"logAll",
            LogCategory::Fmi => c"FMI",
            LogCategory::Osmp => c"OSMP",
            LogCategory::Osi => c"OSI",
        }
    }

    /// Description written into the modelDescription.
    pub fn description(self) -> &'static str {
        match self {
            LogCategory::StatusWarning => "Messages of calls that return fmi2Warning",
            LogCategory::StatusError => "Messages of calls that return fmi2Error",
            LogCategory::StatusFatal => "Messages of calls that return fmi2Fatal",
            LogCategory::All => "All messages",
            LogCategory::Fmi => "FMI calls, states and parameters",
            LogCategory::Osmp => "OSMP binary variables and the SensorViewConfiguration handshake",
            LogCategory::Osi => "OSI message content: decoding and model notes",
        }
    }

    /// Look a category up by name (case-sensitive, as FMI names are).
    pub fn from_name(name: &str) -> Option<LogCategory> {
        LogCategory::ALL.into_iter().find(|c| c.name() == name)
    }

    fn bit(self) -> u8 {
        1 << (self as u8)
    }

    /// The category a status is reported under, if any.
    fn for_status(status: Fmi2Status) -> Option<LogCategory> {
        match status {
            Fmi2Status::Warning => Some(LogCategory::StatusWarning),
            Fmi2Status::Error => Some(LogCategory::StatusError),
            Fmi2Status::Fatal => Some(LogCategory::StatusFatal),
            _ => None,
        }
    }
}

/// Set of enabled categories.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CategorySet(u8);

impl CategorySet {
    /// Every category.
    pub fn all() -> CategorySet {
        CategorySet(LogCategory::ALL.iter().fold(0, |m, c| m | c.bit()))
    }

    /// Only the three status categories (what `loggingOn = false` leaves on).
    pub fn status_only() -> CategorySet {
        CategorySet(
            LogCategory::StatusWarning.bit()
                | LogCategory::StatusError.bit()
                | LogCategory::StatusFatal.bit(),
        )
    }

    /// No category.
    pub fn none() -> CategorySet {
        CategorySet(0)
    }

    /// The default of `loggingOn`.
    pub fn for_logging_on(logging_on: bool) -> CategorySet {
        if logging_on {
            CategorySet::all()
        } else {
            CategorySet::status_only()
        }
    }

    /// Add a category.
    pub fn insert(&mut self, c: LogCategory) {
        self.0 |= c.bit();
    }

    /// Is this category enabled?
    pub fn contains(self, c: LogCategory) -> bool {
        self.0 & c.bit() != 0
    }
}

/// The logger of one instance (or of a failing `fmi2Instantiate`).
#[derive(Debug, Clone)]
pub struct Logger {
    callbacks: Fmi2CallbackFunctions,
    instance_name: CString,
    /// Enabled categories.
    pub enabled: CategorySet,
}

impl Logger {
    /// A logger over the importer's callbacks (copied) for the named instance.
    pub fn new(
        callbacks: Fmi2CallbackFunctions,
        instance_name: CString,
        enabled: CategorySet,
    ) -> Logger {
        Logger {
            callbacks,
            instance_name,
            enabled,
        }
    }

    /// The instance name.
    pub fn instance_name(&self) -> &std::ffi::CStr {
        &self.instance_name
    }

    /// Would a message of this topic and status be delivered?
    pub fn is_enabled(&self, topic: LogCategory, status: Fmi2Status) -> bool {
        self.callbacks.logger.is_some()
            && (self.enabled.contains(LogCategory::All)
                || self.enabled.contains(topic)
                || LogCategory::for_status(status).is_some_and(|c| self.enabled.contains(c)))
    }

    /// Deliver a message if enabled. `#` is escaped as `##` (FMI gives `#` a meaning in messages),
    /// NUL bytes become spaces.
    pub fn log(&self, status: Fmi2Status, topic: LogCategory, message: &str) {
        if !self.is_enabled(topic, status) {
            return;
        }
        let Some(logger) = self.callbacks.logger else {
            return;
        };
        let category = LogCategory::for_status(status).unwrap_or(topic);
        let text = CString::new(message.replace('#', "##").replace('\0', " "))
            .unwrap_or_else(|_| CString::from(c"(unprintable message)"));
        // SAFETY: the logger is the importer's function, called with its own environment pointer,
        // valid NUL-terminated strings that outlive the call, and a "%s" format that consumes
        // exactly the one `const char*` argument passed.
        unsafe {
            logger(
                self.callbacks.component_environment,
                self.instance_name.as_ptr(),
                status,
                category.c_name().as_ptr(),
                c"%s".as_ptr(),
                text.as_ptr() as *const c_char,
            );
        }
    }
}
