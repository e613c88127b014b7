//! The three shipped sensor FMUs: one [`FmuDescriptor`] each, exported by the cdylib crates
//! `fmu/camera`, `fmu/radar` and `fmu/lidar` through [`crate::export_fmi2!`].

use osiris_models::{SensorConfig, SensorKind};

use crate::descriptor::FmuDescriptor;

pub mod camera;
pub mod lidar;
pub mod radar;

/// The descriptor of a sensor kind's FMU.
pub fn descriptor(kind: SensorKind) -> &'static FmuDescriptor {
    match kind {
        SensorKind::Camera => &camera::DESCRIPTOR,
        SensorKind::Radar => &radar::DESCRIPTOR,
        SensorKind::Lidar => &lidar::DESCRIPTOR,
    }
}

/// The built-in configuration of a sensor kind as pretty JSON: the content of the FMU's
/// `resources/config.json` (what the `config` parameter's start value names).
pub fn default_config_json(kind: SensorKind) -> String {
    let mut json = serde_json::to_string_pretty(&SensorConfig::default_for(kind))
        .expect("SensorConfig serializes to JSON");
    json.push('\n');
    json
}
