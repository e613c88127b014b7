//! osiris sensor models. Model code never sees FMI: the FMU shell (`fmu/`) drives a
//! [`sensor::SensorModel`] and the co-simulation master (`src/master`) drives the FMUs.
//!
//! * [`registry`]: the sensor configuration (JSON, [`SensorConfig`]), [`build_sensor`] and the
//!   effect catalogue ([`registry::catalogue`]): everything that names every model.
//! * [`sensor`]: the model trait and what every model is built from ([`CommonConfig`],
//!   [`SensorSetup`]).
//! * [`frames`]: OSI frame transforms (global -> host vehicle -> sensor), ISO 8855 axes, mounting.
//! * [`ideal`]: the ideal object-level reference model shared by all sensor kinds.
//! * [`handshake`]: the OSMP view-configuration handshake every model runs.
//! * [`output`]: what every model's output carries besides its technology's content (headers,
//!   OSI semantics, the optional SensorView copy), filled in one place.
//! * [`physical`]: the physical-sensor skeleton: the loop every physical model shares (world
//!   update, handshake, cycle counter, seed, output headers); each sensor fills in its
//!   [`physical::Physics`] (plan, perceive, emit).
//! * [`input`]: screening of a SensorView (non-finite, implausible, duplicate) before any model sees it.
//! * [`effects`]: named, switchable physical effects (the mechanism; each module lists its own).
//! * [`environment`]: scene geometry, materials, sun and sky, weather.
//! * [`space`]: ray-traced propagation (space design).
//! * [`world`]: the per-step world of a physical model (scene, space, sensor pose, weather).
//! * [`lidar`], [`radar`], [`camera`]: the physical sensor models.
//! * [`recognition`]: detected objects from raw perception output, with tracking.
//! * [`semantics`]: the OSI 3.8.0 detection semantics every model's output follows (detections →
//!   detected objects, moving vs stationary, pedestrian poses, camera boxes).
//! * [`error`], [`constants`], [`rng`], [`special`]: leaves (the error type, physical constants,
//!   seed hashes, special functions).
//! * [`cpu`]: run-time choice of the SIMD kernels (`OSIRIS_SIMD=portable` forces the portable ones).
//!
//! # Layers
//!
//! The modules import each other one way only, bottom to top (a module uses only modules of the
//! layers below it; `tests/module_graph.rs` fails on a cycle):
//!
//! 1. `error`, `constants`, `rng`, `special`, `cpu`, `input`: leaves.
//! 2. `effects`: the switch mechanism ([`effects::Effects`], [`effects::EffectInfo`]).
//! 3. `frames` → 4. `environment` → 5. `sensor` (trait, [`CommonConfig`]), `handshake` and
//!    `space` → 6. `world` (scene, space and pose of one step).
//! 7. `semantics`, `recognition` (its camera input is its own: `recognition::camera::CameraLens`,
//!    `PixelObjects`), then `output` (headers and semantics of every output).
//! 8. `ideal` and `physical` (the skeleton); `lidar`, `radar`, `camera` each implement
//!    [`physical::Physics`], list their effects and are built from a [`SensorSetup`] of their own
//!    parameters.
//! 9. `registry`: [`SensorConfig`] (with every model's parameters), [`build_sensor`], the
//!    effect catalogue.

pub mod camera;
pub mod constants;
pub mod cpu;
pub mod effects;
pub mod environment;
pub mod error;
pub mod frames;
pub mod handshake;
pub mod ideal;
pub mod input;
pub mod lidar;
pub mod output;
pub mod physical;
pub mod radar;
pub mod recognition;
pub mod registry;
pub mod rng;
pub mod semantics;
pub mod sensor;
pub mod space;
pub mod special;
pub mod world;

pub use error::ModelError;
pub use frames::Mounting;
pub use registry::{SensorConfig, build_sensor};
pub use sensor::{
    CommonConfig, ModelMode, SensorKind, SensorModel, SensorSetup, StepInput, StepOutput,
};
