//! What distinguishes one sensor FMU from another: its kind, names and the model builder. The ABI
//! and the modelDescription renderer are generic over it.

use std::fmt;
use std::sync::OnceLock;

use osiris_models::{ModelError, SensorConfig, SensorKind, SensorModel};

/// Builds the model an instance drives from the effective configuration.
pub type ModelBuilder = fn(SensorConfig) -> Result<Box<dyn SensorModel>, ModelError>;

/// Static description of one sensor FMU (one per cdylib, see [`crate::sensors`]).
pub struct FmuDescriptor {
    /// The sensor technology; a `config` JSON with another `kind` is rejected.
    pub kind: SensorKind,
    /// `modelName` of the modelDescription, e.g. `osiris radar`.
    pub model_name: &'static str,
    /// FMI `modelIdentifier`: the cdylib's lib name and the binary's file stem, e.g. `osiris_radar`.
    pub model_identifier: &'static str,
    /// `description` of the modelDescription.
    pub description: &'static str,
    /// Model construction ([`osiris_models::build_sensor`] for the shipped FMUs; tests inject
    /// others).
    pub build_model: ModelBuilder,
    guid: OnceLock<String>,
}

impl FmuDescriptor {
    /// A descriptor whose instances run [`osiris_models::build_sensor`].
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

    /// A descriptor with a custom model builder (for tests and experiments; the GUID does not
    /// depend on the builder).
    pub const fn with_builder(
        kind: SensorKind,
        model_name: &'static str,
        model_identifier: &'static str,
        description: &'static str,
        build_model: ModelBuilder,
    ) -> FmuDescriptor {
        FmuDescriptor {
            kind,
            model_name,
            model_identifier,
            description,
            build_model,
            guid: OnceLock::new(),
        }
    }

    /// The FMU's GUID: a UUID v5 of the modelDescription rendered with an empty guid (see
    /// [`crate::model_description::compute_guid`]). The same string the XML carries and
    /// `fmi2Instantiate` checks. Computed once per descriptor.
    pub fn guid(&self) -> &str {
        self.guid
            .get_or_init(|| crate::model_description::compute_guid(self))
    }

    /// `DefaultExperiment/@stepSize`: the sensor cycle of the built-in configuration, s.
    pub fn default_step_size_s(&self) -> f64 {
        SensorConfig::default_for(self.kind).update_cycle_s
    }

    /// The complete modelDescription.xml of this FMU.
    pub fn model_description(&self) -> String {
        crate::model_description::render(self)
    }
}

impl fmt::Debug for FmuDescriptor {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("FmuDescriptor")
            .field("kind", &self.kind)
            .field("model_name", &self.model_name)
            .field("model_identifier", &self.model_identifier)
            .finish_non_exhaustive()
    }
}
