//! osiris sensor models. Model code never sees FMI: the FMU shell (`fmu/`) drives a
//! [`sensor::SensorModel`] and the co-simulation master (`src/master`) drives the FMUs.
//!
//! * [`sensor`]: the model trait, the sensor configuration (JSON) and [`sensor::build_sensor`].
//! * [`frames`]: OSI frame transforms (global -> host vehicle -> sensor), ISO 8855 axes.
//! * [`ideal`]: the ideal object-level reference model shared by all sensor kinds.
//! * [`effects`]: named, switchable physical effects.
//! * [`environment`]: scene geometry, materials, sun and sky, weather.
//! * [`space`]: ray-traced propagation (space design).

pub mod effects;
pub mod environment;
pub mod frames;
pub mod ideal;
pub mod sensor;
pub mod space;

pub use sensor::{
    ModelError, ModelMode, SensorConfig, SensorKind, SensorModel, StepInput, StepOutput,
    build_sensor,
};
