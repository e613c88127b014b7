//! The variable tables: the contract importers, the master and the packaging code work against.
//! The modelDescription.xml is rendered from the table of the FMU's role
//! ([`crate::FmuDescriptor::variables`]) and the ABI checks every get/set against it.
//!
//! ## Sensor FMUs ([`VARIABLES`], camera, radar, LiDAR)
//!
//! | type | VR | name | causality / variability / initial | start |
//! |---|---|---|---|---|
//! | Integer | 0, 1, 2 | `OSMPSensorViewIn.base.lo/.base.hi/.size` | input / discrete | 0 |
//! | Integer | 3, 4, 5 | `OSMPSensorDataOut.base.lo/.base.hi/.size` | output / discrete / exact | 0 |
//! | Integer | 6, 7, 8 | `OSMPSensorViewInConfigRequest.base.lo/.base.hi/.size` | calculatedParameter / fixed / calculated | — |
//! | Integer | 9, 10, 11 | `OSMPSensorViewInConfig.base.lo/.base.hi/.size` | parameter / fixed | 0 |
//! | Integer | 12, 13, 14 | `PerceptionDataOut.base.lo/.base.hi/.size` | output / discrete / exact | 0 |
//! | Integer | 15 | `count` | output / discrete / exact | 0 |
//! | Boolean | 0 | `valid` | output / discrete / exact | false |
//! | Real | 0 | `range_m` (m) | parameter / fixed | `SensorConfig::default_for(kind)` |
//! | Real | 1 | `fov_horizontal_rad` (rad) | parameter / fixed | idem |
//! | Real | 2 | `fov_vertical_rad` (rad) | parameter / fixed | idem |
//! | String | 0 | `config` | parameter / fixed | `"config.json"` |
//! | String | 1 | `mode` | parameter / fixed | the kind's default mode (`SensorConfig::default_for(kind).mode`) |
//!
//! ## SensorView source FMUs ([`SOURCE_VARIABLES`], `scenario.fmu`)
//!
//! | type | VR | name | causality / variability / initial | start |
//! |---|---|---|---|---|
//! | Integer | 0, 1, 2 | `OSMPSensorViewOut.base.lo/.base.hi/.size` | output / discrete / calculated | — |
//! | Integer | 3 | `count` | output / discrete / calculated | — |
//! | Boolean | 0 | `valid` | output / discrete / calculated | — |
//! | String | 0 | `scenario` | parameter / fixed | `"scenario.json"` |
//! | String | 1 | `trace_path` | parameter / fixed | `""` |
//! | String | 2 | `sensor` | parameter / fixed | `""` |
//!
//! The source's outputs are `calculated`: the view at the start time is published during
//! initialization (so a sensor stepped at the start time has an input), and they are
//! InitialUnknowns depending on the three parameters. The VRs of the output triple, `valid` and
//! `count` are those of the official OSMPDummySource.

use osiris_models::{SensorConfig, SensorKind};
use osiris_proto::{
    MIME_PERCEPTION_DATA, MIME_SENSOR_DATA, MIME_SENSOR_VIEW, MIME_SENSOR_VIEW_CONFIGURATION,
};

/// Value references by base type (FMI 2.0 VRs are unique per base type only).
pub mod vr {
    /// Integer value references.
    pub mod integer {
        /// `OSMPSensorViewIn.base.lo`.
        pub const SENSOR_VIEW_IN_BASE_LO: u32 = 0;
        /// `OSMPSensorViewIn.base.hi`.
        pub const SENSOR_VIEW_IN_BASE_HI: u32 = 1;
        /// `OSMPSensorViewIn.size` (bytes).
        pub const SENSOR_VIEW_IN_SIZE: u32 = 2;
        /// `OSMPSensorDataOut.base.lo`.
        pub const SENSOR_DATA_OUT_BASE_LO: u32 = 3;
        /// `OSMPSensorDataOut.base.hi`.
        pub const SENSOR_DATA_OUT_BASE_HI: u32 = 4;
        /// `OSMPSensorDataOut.size` (bytes).
        pub const SENSOR_DATA_OUT_SIZE: u32 = 5;
        /// `OSMPSensorViewInConfigRequest.base.lo`.
        pub const CONFIG_REQUEST_BASE_LO: u32 = 6;
        /// `OSMPSensorViewInConfigRequest.base.hi`.
        pub const CONFIG_REQUEST_BASE_HI: u32 = 7;
        /// `OSMPSensorViewInConfigRequest.size` (bytes).
        pub const CONFIG_REQUEST_SIZE: u32 = 8;
        /// `OSMPSensorViewInConfig.base.lo`.
        pub const CONFIG_BASE_LO: u32 = 9;
        /// `OSMPSensorViewInConfig.base.hi`.
        pub const CONFIG_BASE_HI: u32 = 10;
        /// `OSMPSensorViewInConfig.size` (bytes).
        pub const CONFIG_SIZE: u32 = 11;
        /// `PerceptionDataOut.base.lo`.
        pub const PERCEPTION_DATA_OUT_BASE_LO: u32 = 12;
        /// `PerceptionDataOut.base.hi`.
        pub const PERCEPTION_DATA_OUT_BASE_HI: u32 = 13;
        /// `PerceptionDataOut.size` (bytes).
        pub const PERCEPTION_DATA_OUT_SIZE: u32 = 14;
        /// `count`: detected objects (moving + stationary) in the last SensorData.
        pub const COUNT: u32 = 15;

        /// The `[base.lo, base.hi, size]` triple of `OSMPSensorViewIn`.
        pub const SENSOR_VIEW_IN: [u32; 3] = [0, 1, 2];
        /// The triple of `OSMPSensorDataOut`.
        pub const SENSOR_DATA_OUT: [u32; 3] = [3, 4, 5];
        /// The triple of `OSMPSensorViewInConfigRequest`.
        pub const CONFIG_REQUEST: [u32; 3] = [6, 7, 8];
        /// The triple of `OSMPSensorViewInConfig`.
        pub const CONFIG: [u32; 3] = [9, 10, 11];
        /// The triple of `PerceptionDataOut`.
        pub const PERCEPTION_DATA_OUT: [u32; 3] = [12, 13, 14];
    }
    /// Boolean value references.
    pub mod boolean {
        /// `valid`: the last step produced SensorData from a valid input.
        pub const VALID: u32 = 0;
    }
    /// Real value references.
    pub mod real {
        /// `range_m`, m.
        pub const RANGE_M: u32 = 0;
        /// `fov_horizontal_rad`, rad.
        pub const FOV_HORIZONTAL_RAD: u32 = 1;
        /// `fov_vertical_rad`, rad.
        pub const FOV_VERTICAL_RAD: u32 = 2;
    }
    /// String value references.
    pub mod string {
        /// `config`: file name/path relative to the resources directory, inline JSON, or "".
        pub const CONFIG: u32 = 0;
        /// `mode`: `ideal` or `physical`.
        pub const MODE: u32 = 1;
    }
    /// Value references of the SensorView source FMUs ([`super::super::SOURCE_VARIABLES`]).
    pub mod source {
        /// Integer value references.
        pub mod integer {
            /// `OSMPSensorViewOut.base.lo`.
            pub const SENSOR_VIEW_OUT_BASE_LO: u32 = 0;
            /// `OSMPSensorViewOut.base.hi`.
            pub const SENSOR_VIEW_OUT_BASE_HI: u32 = 1;
            /// `OSMPSensorViewOut.size` (bytes).
            pub const SENSOR_VIEW_OUT_SIZE: u32 = 2;
            /// `count`: moving objects in the published view's ground truth.
            pub const COUNT: u32 = 3;
            /// The triple of `OSMPSensorViewOut`.
            pub const SENSOR_VIEW_OUT: [u32; 3] = [0, 1, 2];
        }
        /// Boolean value references.
        pub mod boolean {
            /// `valid`: a SensorView is published.
            pub const VALID: u32 = 0;
        }
        /// String value references.
        pub mod string {
            /// `scenario`: scenario JSON file (relative to the resources directory, or absolute),
            /// inline JSON, or "" for the built-in scenario.
            pub const SCENARIO: u32 = 0;
            /// `trace_path`: a SensorView trace to play instead of a scenario.
            pub const TRACE_PATH: u32 = 1;
            /// `sensor`: the scenario's sensor mount whose view is played ("": the first).
            pub const SENSOR: u32 = 2;
        }
    }
}

/// FMI base type of a variable.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum VarType {
    Real,
    Integer,
    Boolean,
    String,
}

impl VarType {
    /// The XML element name (`Real`, ...).
    pub fn name(self) -> &'static str {
        match self {
            VarType::Real => "Real",
            VarType::Integer => "Integer",
            VarType::Boolean => "Boolean",
            VarType::String => "String",
        }
    }
}

/// `causality` attribute.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Causality {
    Parameter,
    CalculatedParameter,
    Input,
    Output,
}

impl Causality {
    /// The XML attribute value.
    pub fn name(self) -> &'static str {
        match self {
            Causality::Parameter => "parameter",
            Causality::CalculatedParameter => "calculatedParameter",
            Causality::Input => "input",
            Causality::Output => "output",
        }
    }
}

/// `variability` attribute.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Variability {
    Fixed,
    Discrete,
}

impl Variability {
    /// The XML attribute value.
    pub fn name(self) -> &'static str {
        match self {
            Variability::Fixed => "fixed",
            Variability::Discrete => "discrete",
        }
    }
}

/// `initial` attribute (written only where the table gives one).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Initial {
    Exact,
    Calculated,
}

impl Initial {
    /// The XML attribute value.
    pub fn name(self) -> &'static str {
        match self {
            Initial::Exact => "exact",
            Initial::Calculated => "calculated",
        }
    }
}

/// Which sensor-config value a Real parameter overrides.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RealParam {
    RangeM,
    FovHorizontalRad,
    FovVerticalRad,
}

impl RealParam {
    /// The value of this key in a configuration.
    pub fn get(self, config: &SensorConfig) -> f64 {
        match self {
            RealParam::RangeM => config.range_m,
            RealParam::FovHorizontalRad => config.fov_horizontal_rad,
            RealParam::FovVerticalRad => config.fov_vertical_rad,
        }
    }

    /// Overwrite this key in a configuration.
    pub fn set(self, config: &mut SensorConfig, value: f64) {
        match self {
            RealParam::RangeM => config.range_m = value,
            RealParam::FovHorizontalRad => config.fov_horizontal_rad = value,
            RealParam::FovVerticalRad => config.fov_vertical_rad = value,
        }
    }
}

/// Start value of a variable.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Start {
    /// No start value (calculatedParameter with `initial="calculated"`).
    None,
    Integer(i32),
    Boolean(bool),
    /// The sensor kind's built-in default (`SensorConfig::default_for(kind)`) of this key.
    RealDefault(RealParam),
    String(&'static str),
    /// The sensor kind's built-in default model mode (`SensorConfig::default_for(kind).mode`).
    ModeDefault,
}

impl Start {
    /// The Real start value for a sensor kind (`None` for a source FMU), if this is a Real start
    /// (the kind's defaults need a kind).
    pub fn real(self, kind: Option<SensorKind>) -> Option<f64> {
        match self {
            Start::RealDefault(p) => Some(p.get(&SensorConfig::default_for(kind?))),
            _ => None,
        }
    }

    /// The String start value for a sensor kind (`None` for a source FMU), if this is a String
    /// start (the kind's default mode needs a kind).
    pub fn string(self, kind: Option<SensorKind>) -> Option<&'static str> {
        match self {
            Start::String(s) => Some(s),
            Start::ModeDefault => Some(SensorConfig::default_for(kind?).mode.name()),
            _ => None,
        }
    }
}

/// Role of an OSMP binary-variable component.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OsmpRole {
    BaseLo,
    BaseHi,
    Size,
}

impl OsmpRole {
    /// The annotation's `role` value.
    pub fn name(self) -> &'static str {
        match self {
            OsmpRole::BaseLo => "base.lo",
            OsmpRole::BaseHi => "base.hi",
            OsmpRole::Size => "size",
        }
    }
}

/// OSMP `osmp-binary-variable` annotation of one Integer component.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OsmpBinary {
    /// The notional binary variable's name (prefix), e.g. `OSMPSensorViewIn`.
    pub prefix: &'static str,
    pub role: OsmpRole,
    /// The MIME type of the buffer.
    pub mime_type: &'static str,
}

/// One scalar variable of the FMU.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Variable {
    pub name: &'static str,
    pub ty: VarType,
    pub vr: u32,
    pub causality: Causality,
    pub variability: Variability,
    /// `initial`, written only when `Some`.
    pub initial: Option<Initial>,
    pub start: Start,
    pub description: &'static str,
    /// Unit of a Real (declared in `UnitDefinitions`).
    pub unit: Option<&'static str>,
    pub osmp: Option<OsmpBinary>,
}

impl Variable {
    /// True for the fixed parameters (settable only before `fmi2ExitInitializationMode`).
    pub fn is_fixed_parameter(&self) -> bool {
        self.causality == Causality::Parameter && self.variability == Variability::Fixed
    }
}

#[allow(clippy::too_many_arguments)]
const fn binary(
    name: &'static str,
    vr: u32,
    prefix: &'static str,
    role: OsmpRole,
    mime_type: &'static str,
    causality: Causality,
    variability: Variability,
    initial: Option<Initial>,
    start: Start,
    description: &'static str,
) -> Variable {
    Variable {
        name,
        ty: VarType::Integer,
        vr,
        causality,
        variability,
        initial,
        start,
        description,
        unit: None,
        osmp: Some(OsmpBinary {
            prefix,
            role,
            mime_type,
        }),
    }
}

macro_rules! triple {
    ($prefix:literal, $vr0:expr, $mime:expr, $caus:expr, $var:expr, $init:expr, $start:expr, $what:literal) => {
        [
            binary(
                concat!($prefix, ".base.lo"),
                $vr0,
                $prefix,
                OsmpRole::BaseLo,
                $mime,
                $caus,
                $var,
                $init,
                $start,
                concat!($what, ": low 32 bits of the buffer address"),
            ),
            binary(
                concat!($prefix, ".base.hi"),
                $vr0 + 1,
                $prefix,
                OsmpRole::BaseHi,
                $mime,
                $caus,
                $var,
                $init,
                $start,
                concat!($what, ": high 32 bits of the buffer address"),
            ),
            binary(
                concat!($prefix, ".size"),
                $vr0 + 2,
                $prefix,
                OsmpRole::Size,
                $mime,
                $caus,
                $var,
                $init,
                $start,
                concat!($what, ": buffer size, bytes"),
            ),
        ]
    };
}

const VIEW_IN: [Variable; 3] = triple!(
    "OSMPSensorViewIn",
    0,
    MIME_SENSOR_VIEW,
    Causality::Input,
    Variability::Discrete,
    None,
    Start::Integer(0),
    "Input osi3::SensorView (address 0 or size 0: no input this step)"
);
const DATA_OUT: [Variable; 3] = triple!(
    "OSMPSensorDataOut",
    3,
    MIME_SENSOR_DATA,
    Causality::Output,
    Variability::Discrete,
    Some(Initial::Exact),
    Start::Integer(0),
    "Output osi3::SensorData, valid until the start of the second fmi2DoStep after the producing one"
);
const CONFIG_REQUEST: [Variable; 3] = triple!(
    "OSMPSensorViewInConfigRequest",
    6,
    MIME_SENSOR_VIEW_CONFIGURATION,
    Causality::CalculatedParameter,
    Variability::Fixed,
    Some(Initial::Calculated),
    Start::None,
    "Requested osi3::SensorViewConfiguration (echoes OSMPSensorViewInConfig once that is set)"
);
const CONFIG: [Variable; 3] = triple!(
    "OSMPSensorViewInConfig",
    9,
    MIME_SENSOR_VIEW_CONFIGURATION,
    Causality::Parameter,
    Variability::Fixed,
    None,
    Start::Integer(0),
    "Granted osi3::SensorViewConfiguration, read at fmi2ExitInitializationMode"
);
const PERCEPTION_OUT: [Variable; 3] = triple!(
    "PerceptionDataOut",
    12,
    MIME_PERCEPTION_DATA,
    Causality::Output,
    Variability::Discrete,
    Some(Initial::Exact),
    Start::Integer(0),
    "Output osiris.perception.PerceptionData (raw perception), same lifetime as OSMPSensorDataOut"
);

/// Every variable, in modelDescription order (the 1-based position is the ModelStructure index).
pub static VARIABLES: [Variable; 22] = [
    VIEW_IN[0],
    VIEW_IN[1],
    VIEW_IN[2],
    DATA_OUT[0],
    DATA_OUT[1],
    DATA_OUT[2],
    CONFIG_REQUEST[0],
    CONFIG_REQUEST[1],
    CONFIG_REQUEST[2],
    CONFIG[0],
    CONFIG[1],
    CONFIG[2],
    PERCEPTION_OUT[0],
    PERCEPTION_OUT[1],
    PERCEPTION_OUT[2],
    Variable {
        name: "count",
        ty: VarType::Integer,
        vr: vr::integer::COUNT,
        causality: Causality::Output,
        variability: Variability::Discrete,
        initial: Some(Initial::Exact),
        start: Start::Integer(0),
        description: "Number of detected objects (moving + stationary) in the last SensorData",
        unit: None,
        osmp: None,
    },
    Variable {
        name: "valid",
        ty: VarType::Boolean,
        vr: vr::boolean::VALID,
        causality: Causality::Output,
        variability: Variability::Discrete,
        initial: Some(Initial::Exact),
        start: Start::Boolean(false),
        description: "True when the last fmi2DoStep produced SensorData from a valid SensorView",
        unit: None,
        osmp: None,
    },
    Variable {
        name: "range_m",
        ty: VarType::Real,
        vr: vr::real::RANGE_M,
        causality: Causality::Parameter,
        variability: Variability::Fixed,
        initial: None,
        start: Start::RealDefault(RealParam::RangeM),
        description: "Maximum detection range, m (overrides the config's range_m when set)",
        unit: Some("m"),
        osmp: None,
    },
    Variable {
        name: "fov_horizontal_rad",
        ty: VarType::Real,
        vr: vr::real::FOV_HORIZONTAL_RAD,
        causality: Causality::Parameter,
        variability: Variability::Fixed,
        initial: None,
        start: Start::RealDefault(RealParam::FovHorizontalRad),
        description: "Full horizontal field of view, rad (overrides the config's fov_horizontal_rad when set)",
        unit: Some("rad"),
        osmp: None,
    },
    Variable {
        name: "fov_vertical_rad",
        ty: VarType::Real,
        vr: vr::real::FOV_VERTICAL_RAD,
        causality: Causality::Parameter,
        variability: Variability::Fixed,
        initial: None,
        start: Start::RealDefault(RealParam::FovVerticalRad),
        description: "Full vertical field of view, rad (overrides the config's fov_vertical_rad when set)",
        unit: Some("rad"),
        osmp: None,
    },
    Variable {
        name: "config",
        ty: VarType::String,
        vr: vr::string::CONFIG,
        causality: Causality::Parameter,
        variability: Variability::Fixed,
        initial: None,
        start: Start::String("config.json"),
        description: "Sensor configuration: a JSON file path relative to the FMU's resources directory \
                      (or absolute), inline JSON starting with '{', or empty for the built-in defaults",
        unit: None,
        osmp: None,
    },
    Variable {
        name: "mode",
        ty: VarType::String,
        vr: vr::string::MODE,
        causality: Causality::Parameter,
        variability: Variability::Fixed,
        initial: None,
        start: Start::ModeDefault,
        description: "Model to run: ideal or physical (overrides the config's mode when set)",
        unit: None,
        osmp: None,
    },
];

const VIEW_OUT: [Variable; 3] = triple!(
    "OSMPSensorViewOut",
    0,
    MIME_SENSOR_VIEW,
    Causality::Output,
    Variability::Discrete,
    Some(Initial::Calculated),
    Start::None,
    "Output osi3::SensorView, valid until the start of the second fmi2DoStep after the producing one \
     (fmi2ExitInitializationMode publishes the view at the start time)"
);

/// Every variable of a SensorView source FMU, in modelDescription order.
pub static SOURCE_VARIABLES: [Variable; 8] = [
    VIEW_OUT[0],
    VIEW_OUT[1],
    VIEW_OUT[2],
    Variable {
        name: "valid",
        ty: VarType::Boolean,
        vr: vr::source::boolean::VALID,
        causality: Causality::Output,
        variability: Variability::Discrete,
        initial: Some(Initial::Calculated),
        start: Start::None,
        description: "True when OSMPSensorViewOut holds a SensorView (false outside the scenario's \
                      [0, duration_s] or after the trace's last message)",
        unit: None,
        osmp: None,
    },
    Variable {
        name: "count",
        ty: VarType::Integer,
        vr: vr::source::integer::COUNT,
        causality: Causality::Output,
        variability: Variability::Discrete,
        initial: Some(Initial::Calculated),
        start: Start::None,
        description: "Number of moving objects (the host included) in the published SensorView's \
                      global ground truth",
        unit: None,
        osmp: None,
    },
    Variable {
        name: "scenario",
        ty: VarType::String,
        vr: vr::source::string::SCENARIO,
        causality: Causality::Parameter,
        variability: Variability::Fixed,
        initial: None,
        start: Start::String("scenario.json"),
        description: "Scenario to play: a JSON file path relative to the FMU's resources directory \
                      (or absolute), inline JSON starting with '{', or empty for the built-in \
                      scenario (which the shipped resources/scenario.json holds)",
        unit: None,
        osmp: None,
    },
    Variable {
        name: "trace_path",
        ty: VarType::String,
        vr: vr::source::string::TRACE_PATH,
        causality: Causality::Parameter,
        variability: Variability::Fixed,
        initial: None,
        start: Start::String(""),
        description: "SensorView trace (.osi) to play instead of a scenario, relative to the \
                      resources directory or absolute; t = 0 is its first message",
        unit: None,
        osmp: None,
    },
    Variable {
        name: "sensor",
        ty: VarType::String,
        vr: vr::source::string::SENSOR,
        causality: Causality::Parameter,
        variability: Variability::Fixed,
        initial: None,
        start: Start::String(""),
        description: "Name of the scenario's sensor mount whose SensorView is played (empty: the \
                      first of the scenario's sensors); unused for a trace",
        unit: None,
        osmp: None,
    },
];

/// The sensor variable with this base type and value reference (the table of one FMU:
/// [`crate::FmuDescriptor::variable`]).
pub fn find(ty: VarType, vr: u32) -> Option<&'static Variable> {
    VARIABLES.iter().find(|v| v.ty == ty && v.vr == vr)
}

/// 1-based ModelStructure index of a sensor variable (its position in [`VARIABLES`]).
pub fn index_of(ty: VarType, vr: u32) -> Option<usize> {
    VARIABLES
        .iter()
        .position(|v| v.ty == ty && v.vr == vr)
        .map(|i| i + 1)
}
