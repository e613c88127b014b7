//! What distinguishes one FMU from another: its names, its [`Role`] (the OSMP model type: a sensor
//! or a SensorView source) and the model it runs. The ABI, the instance and the modelDescription
//! renderer are generic over it.
//!
//! The two roles the shell serves:
//! * [`Role::Sensor`]: an OSMP sensor model, SensorView in → SensorData (and PerceptionData) out;
//!   the variables of [`crate::variables::VARIABLES`]; the model is an
//!   [`osiris_models::SensorModel`].
//! * [`Role::Source`]: an OSMP SensorView source, nothing in → SensorView out; the variables of
//!   [`crate::variables::SOURCE_VARIABLES`]; the model is a [`ViewSource`].
//!
//! Everything else (the FMI state machine, logging, the panic guard, the variable checks, OSMP
//! double-buffered outputs, the modelDescription) is the same code for both.

use std::fmt;
use std::path::Path;
use std::sync::OnceLock;

use osiris_models::{ModelError, SensorConfig, SensorKind, SensorModel};

use crate::variables::{self, VarType, Variable};

/// Builds the model an instance drives from the effective configuration.
pub type ModelBuilder = fn(SensorConfig) -> Result<Box<dyn SensorModel>, ModelError>;

/// A SensorView source as the shell drives it: asked once per communication point for the view at
/// that time. Implementations never see FMI.
pub trait ViewSource: Send {
    /// The SensorView at `t_s` (the FMI time), `Ok(None)` when there is none (outside the
    /// recording). Problems that skip data but let the source go on are pushed to `notes` (logged as
    /// warnings); `Err` ends the simulation (`fmi2Error`).
    fn view_at(
        &mut self,
        t_s: f64,
        notes: &mut Vec<String>,
    ) -> Result<Option<SourceFrame<'_>>, String>;
}

/// One published SensorView of a [`ViewSource`].
#[derive(Debug, Clone, Copy)]
pub struct SourceFrame<'a> {
    /// The serialized `osi3::SensorView` (copied into the OSMP output buffer).
    pub bytes: &'a [u8],
    /// The `count` output: moving objects in the view's global ground truth.
    pub count: usize,
}

/// The String parameters of a source FMU ([`crate::variables::vr::source::string`]), as the
/// builder gets them: `Some` when the importer set them, `None` for the start value.
#[derive(Debug, Clone, Copy, Default)]
pub struct SourceSettings<'a> {
    /// `scenario`.
    pub scenario: Option<&'a str>,
    /// `trace_path`.
    pub trace_path: Option<&'a str>,
    /// `sensor`.
    pub sensor: Option<&'a str>,
    /// The directory `fmuResourceLocation` names, if any.
    pub resources_dir: Option<&'a Path>,
}

/// What a [`SourceBuilder`] returns.
pub struct SourceBuild {
    pub source: Box<dyn ViewSource>,
    /// Logged as warnings at initialization (`fmi2Warning`).
    pub warnings: Vec<String>,
    /// One line saying what is played, for the debug log.
    pub summary: String,
}

/// Builds the source an instance drives from its parameters; `Err` names the parameter (and file)
/// at fault.
pub type SourceBuilder = fn(&SourceSettings<'_>) -> Result<SourceBuild, String>;

/// A sensor FMU's model.
#[derive(Debug, Clone, Copy)]
pub struct SensorRole {
    /// The sensor technology; a `config` JSON with another `kind` is rejected.
    pub kind: SensorKind,
    /// Model construction ([`osiris_models::build_sensor`] for the shipped FMUs; tests inject
    /// others).
    pub build_model: ModelBuilder,
}

/// A source FMU's model.
#[derive(Debug, Clone, Copy)]
pub struct SourceRole {
    pub build_source: SourceBuilder,
    /// `DefaultExperiment` `(stepSize, stopTime)`, s.
    pub default_experiment: fn() -> (f64, f64),
    /// The files of the FMU's `resources/` directory: `(name, content)`.
    pub resources: fn() -> Vec<(&'static str, String)>,
}

/// The OSMP model type of an FMU (see the module documentation).
#[derive(Debug, Clone, Copy)]
pub enum Role {
    Sensor(SensorRole),
    Source(SourceRole),
}

/// Static description of one FMU (one per cdylib, see [`crate::sensors`] and [`crate::sources`]).
pub struct FmuDescriptor {
    pub role: Role,
    /// `modelName` of the modelDescription, e.g. `osiris radar`.
    pub model_name: &'static str,
    /// FMI `modelIdentifier`: the cdylib's lib name and the binary's file stem, e.g. `osiris_radar`.
    pub model_identifier: &'static str,
    /// `description` of the modelDescription.
    pub description: &'static str,
    guid: OnceLock<String>,
}

impl FmuDescriptor {
    /// A sensor FMU whose instances run [`osiris_models::build_sensor`].
    pub const fn new(
        kind: SensorKind,
        model_name: &'static str,
        model_identifier: &'static str,
        description: &'static str,
    ) -> FmuDescriptor {
        FmuDescriptor::with_builder(
            kind,
            model_name,
            model_identifier,
            description,
            osiris_models::build_sensor,
        )
    }

    /// A sensor FMU with a custom model builder (for tests and experiments; the GUID does not
    /// depend on the builder).
    pub const fn with_builder(
        kind: SensorKind,
        model_name: &'static str,
        model_identifier: &'static str,
        description: &'static str,
        build_model: ModelBuilder,
    ) -> FmuDescriptor {
        FmuDescriptor {
            role: Role::Sensor(SensorRole { kind, build_model }),
            model_name,
            model_identifier,
            description,
            guid: OnceLock::new(),
        }
    }

    /// A SensorView source FMU.
    pub const fn source(
        model_name: &'static str,
        model_identifier: &'static str,
        description: &'static str,
        role: SourceRole,
    ) -> FmuDescriptor {
        FmuDescriptor {
            role: Role::Source(role),
            model_name,
            model_identifier,
            description,
            guid: OnceLock::new(),
        }
    }

    /// The sensor model of a sensor FMU.
    pub fn as_sensor(&self) -> Option<&SensorRole> {
        match &self.role {
            Role::Sensor(s) => Some(s),
            Role::Source(_) => None,
        }
    }

    /// The source model of a source FMU.
    pub fn as_source(&self) -> Option<&SourceRole> {
        match &self.role {
            Role::Source(s) => Some(s),
            Role::Sensor(_) => None,
        }
    }

    /// The sensor technology of a sensor FMU.
    pub fn sensor_kind(&self) -> Option<SensorKind> {
        self.as_sensor().map(|s| s.kind)
    }

    /// True for a SensorView source.
    pub fn is_source(&self) -> bool {
        matches!(self.role, Role::Source(_))
    }

    /// The short name: the `.fmu` file stem and the `osiris-<name>-fmu` crate (`radar`, `scenario`):
    /// the model identifier without its `osiris_` prefix.
    pub fn name(&self) -> &'static str {
        self.model_identifier
            .strip_prefix("osiris_")
            .unwrap_or(self.model_identifier)
    }

    /// The variable table of this FMU's role, in modelDescription order.
    pub fn variables(&self) -> &'static [Variable] {
        match self.role {
            Role::Sensor(_) => &variables::VARIABLES,
            Role::Source(_) => &variables::SOURCE_VARIABLES,
        }
    }

    /// The variable with this base type and value reference.
    pub fn variable(&self, ty: VarType, vr: u32) -> Option<&'static Variable> {
        self.variables().iter().find(|v| v.ty == ty && v.vr == vr)
    }

    /// The FMU's GUID: a UUID v5 of the modelDescription rendered with an empty guid (see
    /// [`crate::model_description::compute_guid`]). The same string the XML carries and
    /// `fmi2Instantiate` checks. Computed once per descriptor.
    pub fn guid(&self) -> &str {
        self.guid
            .get_or_init(|| crate::model_description::compute_guid(self))
    }

    /// `DefaultExperiment/@stepSize`, s: a sensor's built-in `update_cycle_s`, a source's own.
    pub fn default_step_size_s(&self) -> f64 {
        match self.role {
            Role::Sensor(s) => SensorConfig::default_for(s.kind).update_cycle_s,
            Role::Source(s) => (s.default_experiment)().0,
        }
    }

    /// `DefaultExperiment/@stopTime`, s: none for a sensor, a source's own.
    pub fn default_stop_time_s(&self) -> Option<f64> {
        match self.role {
            Role::Sensor(_) => None,
            Role::Source(s) => Some((s.default_experiment)().1),
        }
    }

    /// The files of the FMU's `resources/` directory, `(name, content)`: a sensor's
    /// `config.json` (its built-in configuration, what the `config` start value names), a
    /// source's own.
    pub fn resource_files(&self) -> Vec<(&'static str, String)> {
        match self.role {
            Role::Sensor(s) => vec![("config.json", crate::sensors::default_config_json(s.kind))],
            Role::Source(s) => (s.resources)(),
        }
    }

    /// The complete modelDescription.xml of this FMU.
    pub fn model_description(&self) -> String {
        crate::model_description::render(self)
    }
}

impl fmt::Debug for FmuDescriptor {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let role = match self.role {
            Role::Sensor(s) => format!("sensor ({})", s.kind.name()),
            Role::Source(_) => "source".to_owned(),
        };
        f.debug_struct("FmuDescriptor")
            .field("role", &role)
            .field("model_name", &self.model_name)
            .field("model_identifier", &self.model_identifier)
            .finish_non_exhaustive()
    }
}
