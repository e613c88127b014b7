//! The sensor-model trait every FMU drives, and what every model is built from (the
//! sensor-independent configuration [`CommonConfig`], [`SensorSetup`]). Nothing here names a
//! concrete model: the sensor configuration (JSON) and `build_sensor` are the registry's
//! (`crate::registry`).

use osiris_proto::{osi3, perception};
use serde::{Deserialize, Serialize};

pub use crate::error::ModelError;
pub use crate::frames::{Calibration, Mounting};

use crate::effects::{EffectSwitches, Effects};
use crate::environment::weather::Weather;

/// Which sensor technology a model simulates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SensorKind {
    Camera,
    Radar,
    Lidar,
}

impl SensorKind {
    pub const ALL: [SensorKind; 3] = [SensorKind::Camera, SensorKind::Radar, SensorKind::Lidar];

    /// Lower-case name (`camera`, `radar`, `lidar`): the FMU's file stem and config key.
    pub fn name(self) -> &'static str {
        match self {
            SensorKind::Camera => "camera",
            SensorKind::Radar => "radar",
            SensorKind::Lidar => "lidar",
        }
    }
}

impl std::str::FromStr for SensorKind {
    type Err = ModelError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "camera" => Ok(SensorKind::Camera),
            "radar" => Ok(SensorKind::Radar),
            "lidar" => Ok(SensorKind::Lidar),
            other => Err(ModelError::Config(format!(
                "unknown sensor kind `{other}` (expected camera, radar or lidar)"
            ))),
        }
    }
}

/// Which model an FMU runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ModelMode {
    /// Ideal object-level reference model: ground-truth objects inside the field of view and range,
    /// occluded by other objects' boxes, transformed into the sensor frame.
    #[default]
    Ideal,
    /// The physics-based model of the sensor (perception from ray-traced propagation).
    Physical,
}

impl ModelMode {
    pub fn name(self) -> &'static str {
        match self {
            ModelMode::Ideal => "ideal",
            ModelMode::Physical => "physical",
        }
    }
}

impl std::str::FromStr for ModelMode {
    type Err = ModelError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "ideal" => Ok(ModelMode::Ideal),
            "physical" => Ok(ModelMode::Physical),
            other => Err(ModelError::Config(format!(
                "unknown model mode `{other}` (expected `ideal` or `physical`)"
            ))),
        }
    }
}

/// The sensor-independent part of a sensor configuration: the keys every model reads, with the
/// meaning and names of the JSON configuration's (`crate::registry::SensorConfig`, which also
/// carries the per-model parameters and checks every value). A model keeps the one in force
/// ([`SensorModel::config`]); the view-configuration handshake may narrow its field of view and range.
#[derive(Debug, Clone, PartialEq)]
pub struct CommonConfig {
    /// Sensor technology.
    pub kind: SensorKind,
    /// `ideal` or `physical`.
    pub mode: ModelMode,
    /// Maximum detection range, m.
    pub range_m: f64,
    /// Full horizontal field of view, rad (symmetric about the sensor's +x axis).
    pub fov_horizontal_rad: f64,
    /// Full vertical field of view, rad (symmetric about the sensor's +x axis).
    pub fov_vertical_rad: f64,
    /// Sensor cycle, s (the FMU's DefaultExperiment stepSize).
    pub update_cycle_s: f64,
    /// Mounting used for the OSMP configuration request and when a SensorView carries none.
    pub mounting: Mounting,
    /// Physical models: how the real sensor differs from `mounting` and from the ground-truth
    /// clock (extrinsic error, time offset; [`Calibration`]). All zero: a perfectly calibrated
    /// sensor.
    pub calibration: Calibration,
    /// Ideal model: minimum fraction of an object's sample points with a free line of sight for
    /// the object to count as visible (0..1].
    pub min_visible_fraction: f64,
    /// Physical models: effect switches by name (effects not listed keep their defaults).
    pub effects: EffectSwitches,
    /// Physical models: exact weather; absent: taken from the ground truth's OSI categories.
    pub weather: Option<Weather>,
    /// Seed of the physical models' random noise (same seed + same input = same output).
    pub seed: Option<u64>,
    /// Copy the input SensorView into `SensorData.sensor_view`.
    pub include_sensor_view: bool,
}

/// What a physical model is built from: the sensor-independent configuration, the model's own
/// parameters (its configuration key, `lidar`, `radar` or `camera`; absent: the defaults) and the
/// effect switches resolved against every effect osiris declares. The registry
/// (`crate::registry`) makes one from a checked sensor configuration; the models' `new` accept
/// anything that converts into one (a `SensorConfig` does).
#[derive(Debug, Clone, PartialEq)]
pub struct SensorSetup<P> {
    pub common: CommonConfig,
    pub params: P,
    pub effects: Effects,
}

/// What one step gets.
pub struct StepInput<'a> {
    /// The decoded SensorView of this communication point.
    pub view: &'a osi3::SensorView,
    /// Communication point (simulation time at the start of the step), s.
    pub time_s: f64,
    /// Communication step size, s.
    pub step_s: f64,
}

/// What one step produces. The model fills both messages; the host reuses them between steps.
#[derive(Debug, Default, Clone)]
pub struct StepOutput {
    pub sensor_data: osi3::SensorData,
    pub perception: perception::PerceptionData,
}

/// A sensor model as the FMU shell sees it. No FMI in sight: inputs and outputs are decoded OSI
/// messages and our perception extension.
pub trait SensorModel: Send {
    fn kind(&self) -> SensorKind;
    fn mode(&self) -> ModelMode;
    /// The configuration in effect (after the granted view configuration was applied).
    fn config(&self) -> &CommonConfig;
    /// The SensorViewConfiguration the model asks the environment simulation for (OSMP handshake).
    fn view_configuration_request(&self) -> osi3::SensorViewConfiguration;
    /// Accept the configuration the environment simulation granted; returns human-readable notes
    /// about adaptations (logged as warnings), or an error if the model cannot run with it.
    fn apply_view_configuration(
        &mut self,
        granted: &osi3::SensorViewConfiguration,
    ) -> Result<Vec<String>, ModelError>;
    /// Simulate one sensor cycle. `out` is cleared by the model and refilled, headers included
    /// (the FMU shell publishes it as it is): the shipped models fill them with
    /// `crate::output::finish`, the physical ones through the skeleton of `crate::physical`.
    fn step(&mut self, input: &StepInput<'_>, out: &mut StepOutput) -> Result<(), ModelError>;
    /// Forget all state accumulated over steps (trackers, counters, random state), as after creation.
    fn reset(&mut self);
}
