//! The OSMP view-configuration handshake every model runs (OSMP: the model publishes a
//! `SensorViewConfiguration` request before initialization; the environment simulation answers with
//! the configuration it grants). The request carries the configured field of view, range, update
//! cycle, mounting and the technology's sensor-view configuration; a grant may narrow the field of
//! view or range (the model then works with the granted values) and sets the sensor id reported
//! when a SensorView carries none.

use osiris_proto::{id, interface_version, osi3, timestamp_from_seconds};

use crate::error::ModelError;
use crate::sensor::{CommonConfig, SensorKind};

/// The configuration in force and the granted sensor id, before and after the handshake.
#[derive(Debug, Clone, PartialEq)]
pub struct Handshake {
    config: CommonConfig,
    sensor_id: Option<u64>,
}

/// What [`Handshake::apply`] did.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Granted {
    /// Human-readable notes about adaptations (the shell logs them as warnings).
    pub notes: Vec<String>,
    /// Whether the field of view or range in force changed (a physical model re-plans).
    pub narrowed: bool,
}

impl Handshake {
    pub fn new(config: CommonConfig) -> Handshake {
        Handshake {
            config,
            sensor_id: None,
        }
    }

    /// The configuration in force (the configured one, narrowed by the grant).
    pub fn config(&self) -> &CommonConfig {
        &self.config
    }

    /// The sensor id granted by the environment simulation.
    pub fn sensor_id(&self) -> Option<u64> {
        self.sensor_id
    }

    /// The SensorViewConfiguration to ask the environment simulation for.
    pub fn request(&self) -> osi3::SensorViewConfiguration {
        let c = &self.config;
        let sensor_id = self.sensor_id.map(id);
        let mounting = Some(c.mounting.to_osi());
        let mut req = osi3::SensorViewConfiguration {
            version: Some(interface_version()),
            sensor_id,
            mounting_position: mounting,
            field_of_view_horizontal: Some(c.fov_horizontal_rad),
            field_of_view_vertical: Some(c.fov_vertical_rad),
            range: Some(c.range_m),
            update_cycle_time: Some(timestamp_from_seconds(c.update_cycle_s)),
            ..Default::default()
        };
        match c.kind {
            SensorKind::Radar => {
                req.radar_sensor_view_configuration
                    .push(osi3::RadarSensorViewConfiguration {
                        sensor_id,
                        mounting_position: mounting,
                        field_of_view_horizontal: Some(c.fov_horizontal_rad),
                        field_of_view_vertical: Some(c.fov_vertical_rad),
                        ..Default::default()
                    })
            }
            SensorKind::Lidar => {
                req.lidar_sensor_view_configuration
                    .push(osi3::LidarSensorViewConfiguration {
                        sensor_id,
                        mounting_position: mounting,
                        field_of_view_horizontal: Some(c.fov_horizontal_rad),
                        field_of_view_vertical: Some(c.fov_vertical_rad),
                        ..Default::default()
                    })
            }
            SensorKind::Camera => {
                req.camera_sensor_view_configuration
                    .push(osi3::CameraSensorViewConfiguration {
                        sensor_id,
                        mounting_position: mounting,
                        field_of_view_horizontal: Some(c.fov_horizontal_rad),
                        field_of_view_vertical: Some(c.fov_vertical_rad),
                        ..Default::default()
                    })
            }
        }
        req
    }

    /// Accept a granted configuration: adopts a granted field of view or range smaller than the
    /// one in force (with a note); larger grants, missing fields and unusable values are ignored
    /// (noted where relevant); keeps the granted sensor id. Never fails today; the `Result` lets a
    /// model refuse a grant it cannot run with.
    pub fn apply(
        &mut self,
        granted: &osi3::SensorViewConfiguration,
    ) -> Result<Granted, ModelError> {
        let mut notes = Vec::new();
        if let Some(v) = granted.sensor_id.and_then(|i| i.value) {
            self.sensor_id = Some(v);
        }
        let before = self.config.clone();
        // Technology-specific FoVs of the matching kind (the smallest grant wins).
        let (tech_h, tech_v): (Vec<Option<f64>>, Vec<Option<f64>>) = match self.config.kind {
            SensorKind::Radar => granted
                .radar_sensor_view_configuration
                .iter()
                .map(|t| (t.field_of_view_horizontal, t.field_of_view_vertical))
                .unzip(),
            SensorKind::Lidar => granted
                .lidar_sensor_view_configuration
                .iter()
                .map(|t| (t.field_of_view_horizontal, t.field_of_view_vertical))
                .unzip(),
            SensorKind::Camera => granted
                .camera_sensor_view_configuration
                .iter()
                .map(|t| (t.field_of_view_horizontal, t.field_of_view_vertical))
                .unzip(),
        };
        let mut adopt = |name: &str,
                         current: &mut f64,
                         values: &mut dyn Iterator<Item = Option<f64>>,
                         unit: &str| {
            let mut smallest: Option<f64> = None;
            for v in values.flatten() {
                if !(v.is_finite() && v > 0.0) {
                    notes.push(format!(
                        "granted {name} {v} is not a positive number; ignored"
                    ));
                    continue;
                }
                smallest = Some(smallest.map_or(v, |s: f64| s.min(v)));
            }
            if let Some(g) = smallest
                && g < *current
            {
                notes.push(format!(
                    "granted {name} {g:.6} {unit} is smaller than the requested {:.6} {unit}; the model uses the granted value",
                    *current
                ));
                *current = g;
            }
        };
        let c = &mut self.config;
        adopt(
            "field_of_view_horizontal",
            &mut c.fov_horizontal_rad,
            &mut std::iter::once(granted.field_of_view_horizontal).chain(tech_h),
            "rad",
        );
        adopt(
            "field_of_view_vertical",
            &mut c.fov_vertical_rad,
            &mut std::iter::once(granted.field_of_view_vertical).chain(tech_v),
            "rad",
        );
        adopt(
            "range",
            &mut c.range_m,
            &mut std::iter::once(granted.range),
            "m",
        );
        if let Some(ts) = granted.update_cycle_time.as_ref() {
            let t = osiris_proto::timestamp_to_seconds(ts);
            if t > 0.0 && (t - c.update_cycle_s).abs() > 1e-9 {
                notes.push(format!(
                    "granted update_cycle_time {t} s differs from the requested {} s; the model \
                     evaluates every SensorView it gets",
                    c.update_cycle_s
                ));
            }
        }
        let narrowed = c.fov_horizontal_rad != before.fov_horizontal_rad
            || c.fov_vertical_rad != before.fov_vertical_rad
            || c.range_m != before.range_m;
        Ok(Granted { notes, narrowed })
    }
}
