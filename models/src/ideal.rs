//! Ideal object-level reference model. To be written.
use crate::sensor::*;
use osiris_proto::osi3;

pub struct IdealSensor {
    config: SensorConfig,
}

impl IdealSensor {
    pub fn new(config: SensorConfig) -> Self {
        IdealSensor { config }
    }
}

impl SensorModel for IdealSensor {
    fn kind(&self) -> SensorKind {
        self.config.kind
    }
    fn mode(&self) -> ModelMode {
        ModelMode::Ideal
    }
    fn config(&self) -> &SensorConfig {
        &self.config
    }
    fn view_configuration_request(&self) -> osi3::SensorViewConfiguration {
        osi3::SensorViewConfiguration::default()
    }
    fn apply_view_configuration(&mut self, _g: &osi3::SensorViewConfiguration) -> Result<Vec<String>, ModelError> {
        Ok(vec![])
    }
    fn step(&mut self, _input: &StepInput<'_>, out: &mut StepOutput) -> Result<(), ModelError> {
        *out = StepOutput::default();
        Ok(())
    }
    fn reset(&mut self) {}
}
