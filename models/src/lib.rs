//! osiris sensor models. Model code never sees FMI: the FMU shell (`fmu/`) drives a
//! [`sensor::SensorModel`] and the co-simulation master (`src/master`) drives the FMUs.
//!
//! * [`sensor`]: the model trait, the sensor configuration (JSON) and [`sensor::build_sensor`].
//! * [`frames`]: OSI frame transforms (global -> host vehicle -> sensor), ISO 8855 axes.
//! * [`ideal`]: the ideal object-level reference model shared by all sensor kinds.
//! * [`input`]: screening of a SensorView (non-finite, implausible, duplicate) before any model sees it.
//! * [`effects`]: named, switchable physical effects.
//! * [`environment`]: scene geometry, materials, sun and sky, weather.
//! * [`space`]: ray-traced propagation (space design).
//! * [`world`]: the per-step world of a physical model (scene, space, sensor pose, weather).
//! * [`lidar`], [`radar`]: the physical sensor models.
//! * [`recognition`]: detected objects from raw perception output, with tracking.
//! * [`semantics`]: the OSI 3.8.0 detection semantics every model's output follows (detections →
//!   detected objects, moving vs stationary, pedestrian poses, camera boxes).
//! * [`error`], [`constants`], [`rng`]: leaves (the error type, physical constants, seed hashes).
//! * [`cpu`]: run-time choice of the SIMD kernels (`OSIRIS_SIMD=portable` forces the portable ones).

pub mod camera;
pub mod constants;
pub mod cpu;
pub mod effects;
pub mod environment;
pub mod error;
pub mod frames;
pub mod ideal;
pub mod input;
pub mod lidar;
pub mod radar;
pub mod recognition;
pub mod rng;
pub mod semantics;
pub mod sensor;
pub mod space;
pub mod special;
pub mod world;

pub use error::ModelError;
pub use sensor::{
    ModelMode, SensorConfig, SensorKind, SensorModel, StepInput, StepOutput, build_sensor,
};
