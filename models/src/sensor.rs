//! The sensor-model trait every FMU drives, and the sensor configuration it is built from.

use osiris_proto::{osi3, perception};
use serde::{Deserialize, Serialize};

pub use crate::error::ModelError;

use crate::camera::CameraConfig;
use crate::effects::EffectSwitches;
use crate::environment::weather::Weather;
use crate::lidar::LidarConfig;
use crate::radar::RadarConfig;

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

/// A mounting pose: the sensor frame relative to the host vehicle frame (rear-axle centre, ISO 8855),
/// as OSI `MountingPosition` (position m, orientation rad: roll, pitch, yaw).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Mounting {
    pub position_m: [f64; 3],
    #[serde(default)]
    pub orientation_rad: [f64; 3],
}

impl Mounting {
    pub fn to_osi(&self) -> osi3::MountingPosition {
        osi3::MountingPosition {
            position: Some(osi3::Vector3d {
                x: Some(self.position_m[0]),
                y: Some(self.position_m[1]),
                z: Some(self.position_m[2]),
            }),
            orientation: Some(osi3::Orientation3d {
                roll: Some(self.orientation_rad[0]),
                pitch: Some(self.orientation_rad[1]),
                yaw: Some(self.orientation_rad[2]),
            }),
        }
    }
}

/// Sensor configuration, read from the FMU's `config` parameter (a JSON file in the FMU's
/// `resources/`, or inline JSON); FMU numeric parameters set by the importer override single keys.
/// Unknown keys are rejected with their name, so typos do not pass silently.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorConfig {
    /// Sensor technology; must match the FMU.
    pub kind: SensorKind,
    /// `ideal` or `physical`.
    #[serde(default)]
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
    /// Ideal model: minimum fraction of an object's sample points with a free line of sight for
    /// the object to count as visible (0..1].
    #[serde(default = "default_min_visible_fraction")]
    pub min_visible_fraction: f64,
    /// Physical models: effect switches by name (`{"lidar.range_walk": false}`); effects not
    /// listed keep their defaults (`osiris effects` lists them). Unknown names are errors.
    #[serde(default, skip_serializing_if = "EffectSwitches::is_empty")]
    pub effects: EffectSwitches,
    /// Physical models: exact weather (rain rate, fog visibility, ...). Absent: taken from the
    /// ground truth's OSI `environmental_conditions` categories (a representative value per class).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub weather: Option<Weather>,
    /// Seed of the physical models' random noise (same seed + same input = same output).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    /// Physical LiDAR parameters (`kind: lidar`); absent: the defaults.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lidar: Option<LidarConfig>,
    /// Physical radar parameters (`kind: radar`); absent: the defaults.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radar: Option<RadarConfig>,
    /// Physical camera parameters (`kind: camera`); absent: the defaults.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub camera: Option<CameraConfig>,
    /// Copy the input SensorView into `SensorData.sensor_view` (OSI: "the sensor view the sensor
    /// data was derived from"), for receivers that need the ground truth with the sensor output.
    /// Off by default: the copy is as large as the SensorView.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub include_sensor_view: bool,
}

fn default_min_visible_fraction() -> f64 {
    0.2
}

impl SensorConfig {
    /// Built-in defaults of a sensor kind (also shipped as the FMU's `resources/config.json`).
    pub fn default_for(kind: SensorKind) -> SensorConfig {
        use std::f64::consts::PI;
        let (range_m, fov_h, fov_v, cycle, pos) = match kind {
            // Front camera behind the windscreen: 60° horizontal; 47° vertical is the 4:3
            // ISX019-class image's (2·atan(¾·tan 30°) = 46.8°).
            SensorKind::Camera => (
                150.0,
                60f64.to_radians(),
                47f64.to_radians(),
                0.033,
                [1.9, 0.0, 1.3],
            ),
            // Front mid-range radar in the bumper (the default waveform's unambiguous range,
            // `radar::waveform::WaveformConfig::max_range_m`, is 99.9 m).
            SensorKind::Radar => (
                100.0,
                90f64.to_radians(),
                10f64.to_radians(),
                0.05,
                [3.7, 0.0, 0.5],
            ),
            // Roof spinning LiDAR (VLS-128: elevations −25°…+15°, so ±25° keeps every channel).
            SensorKind::Lidar => (200.0, 2.0 * PI, 50f64.to_radians(), 0.1, [1.4, 0.0, 1.9]),
        };
        // Every kind runs its physical model by default (`ideal` is the reference mode).
        let mode = ModelMode::Physical;
        SensorConfig {
            kind,
            mode,
            range_m,
            fov_horizontal_rad: fov_h,
            fov_vertical_rad: fov_v,
            update_cycle_s: cycle,
            mounting: Mounting {
                position_m: pos,
                orientation_rad: [0.0; 3],
            },
            min_visible_fraction: default_min_visible_fraction(),
            effects: EffectSwitches::new(),
            weather: None,
            seed: None,
            lidar: None,
            radar: None,
            camera: None,
            include_sensor_view: false,
        }
    }

    /// Parse a JSON configuration; errors name the line, column and what was expected.
    pub fn from_json_str(text: &str) -> Result<SensorConfig, ModelError> {
        let cfg: SensorConfig = serde_json::from_str(text).map_err(|e| {
            ModelError::Config(format!(
                "JSON line {}, column {}: {e}",
                e.line(),
                e.column()
            ))
        })?;
        cfg.validate()?;
        Ok(cfg)
    }

    /// Check ranges of every value.
    pub fn validate(&self) -> Result<(), ModelError> {
        let positive = |name: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(ModelError::Config(format!(
                    "`{name}` must be a finite number > 0, got {v}"
                )))
            }
        };
        positive("range_m", self.range_m)?;
        positive("fov_horizontal_rad", self.fov_horizontal_rad)?;
        positive("fov_vertical_rad", self.fov_vertical_rad)?;
        positive("update_cycle_s", self.update_cycle_s)?;
        if self.fov_horizontal_rad > 2.0 * std::f64::consts::PI + 1e-9 {
            return Err(ModelError::Config(format!(
                "`fov_horizontal_rad` must be <= 2π, got {}",
                self.fov_horizontal_rad
            )));
        }
        if self.fov_vertical_rad > std::f64::consts::PI + 1e-9 {
            return Err(ModelError::Config(format!(
                "`fov_vertical_rad` must be <= π, got {}",
                self.fov_vertical_rad
            )));
        }
        if !(self.min_visible_fraction > 0.0 && self.min_visible_fraction <= 1.0) {
            return Err(ModelError::Config(format!(
                "`min_visible_fraction` must be in (0, 1], got {}",
                self.min_visible_fraction
            )));
        }
        if let Some(w) = &self.weather {
            w.validate()
                .map_err(|e| ModelError::Config(format!("`weather`: {e}")))?;
        }
        if self.lidar.is_some() && self.kind != SensorKind::Lidar {
            return Err(ModelError::Config(format!(
                "`lidar` parameters given for a {} sensor",
                self.kind.name()
            )));
        }
        if self.radar.is_some() && self.kind != SensorKind::Radar {
            return Err(ModelError::Config(format!(
                "`radar` parameters given for a {} sensor",
                self.kind.name()
            )));
        }
        if self.camera.is_some() && self.kind != SensorKind::Camera {
            return Err(ModelError::Config(format!(
                "`camera` parameters given for a {} sensor",
                self.kind.name()
            )));
        }
        if let Some(c) = &self.camera {
            c.resolve()?;
        }
        let known = crate::effects::catalogue();
        crate::effects::Effects::with_switches(&known, &self.effects)
            .map_err(|e| ModelError::Config(format!("`effects`: {e}")))?;
        if self
            .mounting
            .position_m
            .iter()
            .chain(&self.mounting.orientation_rad)
            .any(|v| !v.is_finite())
        {
            return Err(ModelError::Config(
                "`mounting` values must be finite".into(),
            ));
        }
        Ok(())
    }
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
    fn config(&self) -> &SensorConfig;
    /// The SensorViewConfiguration the model asks the environment simulation for (OSMP handshake).
    fn view_configuration_request(&self) -> osi3::SensorViewConfiguration;
    /// Accept the configuration the environment simulation granted; returns human-readable notes
    /// about adaptations (logged as warnings), or an error if the model cannot run with it.
    fn apply_view_configuration(
        &mut self,
        granted: &osi3::SensorViewConfiguration,
    ) -> Result<Vec<String>, ModelError>;
    /// Simulate one sensor cycle. `out` is cleared by the model and refilled.
    fn step(&mut self, input: &StepInput<'_>, out: &mut StepOutput) -> Result<(), ModelError>;
    /// Forget all state accumulated over steps (trackers, counters, random state), as after creation.
    fn reset(&mut self);
}

/// Build the model a configuration asks for.
pub fn build_sensor(config: SensorConfig) -> Result<Box<dyn SensorModel>, ModelError> {
    config.validate()?;
    let include_sensor_view = config.include_sensor_view;
    let model: Box<dyn SensorModel> = match config.mode {
        ModelMode::Ideal => Box::new(crate::ideal::IdealSensor::new(config)),
        ModelMode::Physical => match config.kind {
            SensorKind::Lidar => crate::lidar::build(config)?,
            SensorKind::Radar => crate::radar::build(config)?,
            SensorKind::Camera => crate::camera::build(config)?,
        },
    };
    Ok(if include_sensor_view {
        Box::new(WithSensorView(model))
    } else {
        model
    })
}

/// A model whose SensorData also carries a copy of its input SensorView
/// (`SensorConfig::include_sensor_view`).
struct WithSensorView(Box<dyn SensorModel>);

impl SensorModel for WithSensorView {
    fn kind(&self) -> SensorKind {
        self.0.kind()
    }
    fn mode(&self) -> ModelMode {
        self.0.mode()
    }
    fn config(&self) -> &SensorConfig {
        self.0.config()
    }
    fn view_configuration_request(&self) -> osi3::SensorViewConfiguration {
        self.0.view_configuration_request()
    }
    fn apply_view_configuration(
        &mut self,
        granted: &osi3::SensorViewConfiguration,
    ) -> Result<Vec<String>, ModelError> {
        self.0.apply_view_configuration(granted)
    }
    fn step(&mut self, input: &StepInput<'_>, out: &mut StepOutput) -> Result<(), ModelError> {
        self.0.step(input, out)?;
        out.sensor_data.sensor_view.clear();
        out.sensor_data.sensor_view.push(input.view.clone());
        Ok(())
    }
    fn reset(&mut self) {
        self.0.reset()
    }
}
