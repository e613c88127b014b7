//! The registry: everything that names every model. The sensor configuration (JSON, [`SensorConfig`])
//! with the per-model parameters, its checks, [`build_sensor`] (the model a configuration asks
//! for) and the effect [`catalogue`] (every module's effects). The models themselves depend only on
//! [`crate::sensor`] (the trait, [`CommonConfig`], [`SensorSetup`]); this module is the top of the
//! crate's module graph.

use serde::{Deserialize, Serialize};

use crate::camera::{CameraConfig, CameraSensor};
use crate::effects::{EffectInfo, EffectSwitches, Effects};
use crate::environment::weather::Weather;
use crate::error::ModelError;
use crate::frames::{Calibration, Mounting};
use crate::ideal::IdealSensor;
use crate::lidar::{LidarConfig, LidarSensor};
use crate::radar::{RadarConfig, RadarSensor};
use crate::sensor::{CommonConfig, ModelMode, SensorKind, SensorModel, SensorSetup};

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
    /// Physical models: the real sensor's extrinsic error relative to `mounting` (roll, pitch,
    /// yaw in deg, translation in m, in the nominal sensor axes) and its clock offset (s) and drift
    /// (ppm), see [`Calibration`]; absent keys are 0. Acts through the effects
    /// `<sensor>.extrinsic_error` and `<sensor>.time_offset`.
    #[serde(default, skip_serializing_if = "Calibration::is_zero")]
    pub calibration: Calibration,
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
    /// Physical radar parameters (`kind: radar`); absent: the defaults. Its `preset` supplies
    /// every key not given (`crate::radar::preset`).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "crate::radar::preset::deserialize_optional"
    )]
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
            calibration: Calibration::default(),
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

    /// Parse and check a JSON configuration; errors name the line, column and what was expected,
    /// or the key whose value is out of range.
    pub fn from_json_str(text: &str) -> Result<SensorConfig, ModelError> {
        let cfg = SensorConfig::parse_json(text)?;
        cfg.validate()?;
        Ok(cfg)
    }

    /// Parse a JSON configuration without checking the values (for a caller that changes keys
    /// before it builds the model: [`build_sensor`] checks once); errors name the line and column.
    pub fn parse_json(text: &str) -> Result<SensorConfig, ModelError> {
        serde_json::from_str(text).map_err(|e| {
            ModelError::Config(format!(
                "JSON line {}, column {}: {e}",
                e.line(),
                e.column()
            ))
        })
    }

    /// Check ranges of every value.
    pub fn validate(&self) -> Result<(), ModelError> {
        self.check().map(|_| ())
    }

    /// [`Self::validate`], returning the effect switches resolved against the [`catalogue`].
    fn check(&self) -> Result<Effects, ModelError> {
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
        // Each model's parameters only under its own kind.
        for (given, kind) in [
            (self.lidar.is_some(), SensorKind::Lidar),
            (self.radar.is_some(), SensorKind::Radar),
            (self.camera.is_some(), SensorKind::Camera),
        ] {
            if given && self.kind != kind {
                return Err(ModelError::Config(format!(
                    "`{}` parameters given for a {} sensor",
                    kind.name(),
                    self.kind.name()
                )));
            }
        }
        if let Some(c) = &self.camera {
            c.resolve()?;
        }
        let effects = Effects::with_switches(&catalogue(), &self.effects)
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
        self.calibration.validate().map_err(ModelError::Config)?;
        Ok(effects)
    }
    /// The sensor-independent part (what every model reads).
    pub fn common(&self) -> CommonConfig {
        CommonConfig {
            kind: self.kind,
            mode: self.mode,
            range_m: self.range_m,
            fov_horizontal_rad: self.fov_horizontal_rad,
            fov_vertical_rad: self.fov_vertical_rad,
            update_cycle_s: self.update_cycle_s,
            mounting: self.mounting,
            calibration: self.calibration,
            min_visible_fraction: self.min_visible_fraction,
            effects: self.effects.clone(),
            weather: self.weather,
            seed: self.seed,
            include_sensor_view: self.include_sensor_view,
        }
    }

    /// A physical model's setup: the configuration checked ([`Self::validate`]), its effect
    /// switches resolved against the [`catalogue`] and the model's own parameters (`params`).
    fn setup<P>(&self, params: P) -> Result<SensorSetup<P>, ModelError> {
        let effects = self.check()?;
        Ok(SensorSetup {
            common: self.common(),
            params,
            effects,
        })
    }
}

impl From<SensorConfig> for CommonConfig {
    fn from(config: SensorConfig) -> CommonConfig {
        config.common()
    }
}

impl TryFrom<SensorConfig> for SensorSetup<LidarConfig> {
    type Error = ModelError;
    fn try_from(config: SensorConfig) -> Result<Self, ModelError> {
        let params = config.lidar.clone().unwrap_or_default();
        config.setup(params)
    }
}

impl TryFrom<SensorConfig> for SensorSetup<RadarConfig> {
    type Error = ModelError;
    fn try_from(config: SensorConfig) -> Result<Self, ModelError> {
        let params = config.radar.clone().unwrap_or_default();
        config.setup(params)
    }
}

impl TryFrom<SensorConfig> for SensorSetup<CameraConfig> {
    type Error = ModelError;
    fn try_from(config: SensorConfig) -> Result<Self, ModelError> {
        let params = config.camera.clone().unwrap_or_default();
        config.setup(params)
    }
}

/// Build the model a configuration asks for (the configuration is checked once, here).
pub fn build_sensor(config: SensorConfig) -> Result<Box<dyn SensorModel>, ModelError> {
    Ok(match config.mode {
        ModelMode::Ideal => {
            config.validate()?;
            Box::new(IdealSensor::new(config))
        }
        ModelMode::Physical => match config.kind {
            SensorKind::Lidar => Box::new(LidarSensor::new(config)?),
            SensorKind::Radar => Box::new(RadarSensor::new(config)?),
            SensorKind::Camera => Box::new(CameraSensor::new(config)?),
        },
    })
}

/// Every physical effect osiris declares, sorted by name: the catalogue `osiris effects` prints and
/// `docs/effects.md` lists (generated by `osiris effects --markdown`; a test keeps it in step).
pub fn catalogue() -> Vec<EffectInfo> {
    let mut all: Vec<EffectInfo> = [
        &crate::world::effects()[..],
        &crate::lidar::effects()[..],
        &crate::radar::effects()[..],
        &crate::camera::effects()[..],
    ]
    .concat();
    all.sort_by_key(|e| e.name);
    all
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn required_effects_exist_and_gate_their_children() {
        let all = catalogue();
        let names: Vec<&str> = all.iter().map(|e| e.name).collect();
        for e in &all {
            if let Some(p) = e.requires {
                assert!(names.contains(&p), "{} requires undeclared {p}", e.name);
                assert_ne!(p, e.name);
            }
        }
        let fog = all
            .iter()
            .find(|e| e.name == "lidar.fog_extinction")
            .unwrap();
        assert_eq!(fog.requires, Some("env.fog_extinction"));
        let mut fx = Effects::new(&all);
        assert!(fx.is_on(fog));
        fx.set("env.fog_extinction", false).unwrap();
        assert!(!fx.is_on(fog), "the parent switch turns the child off");
        assert!(fx.switch(fog), "the child's own switch is untouched");
        fx.set("env.fog_extinction", true).unwrap();
        fx.set("lidar.fog_extinction", false).unwrap();
        assert!(!fx.is_on(fog));
    }

    #[test]
    fn catalogue_names_are_unique_and_documented() {
        let all = catalogue();
        assert!(all.len() >= 10);
        for w in all.windows(2) {
            assert_ne!(w[0].name, w[1].name, "effect declared twice");
        }
        for e in &all {
            let (layer, effect) = e.name.split_once('.').expect("`<layer>.<effect>`");
            assert!(!layer.is_empty() && !effect.is_empty(), "{}", e.name);
            assert!(
                !e.summary.is_empty() && !e.source.is_empty(),
                "{} lacks its formula or source",
                e.name
            );
        }
    }
}
