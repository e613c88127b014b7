//! Re-simulation of a campaign through `osiris_models::build_sensor`: the same `SensorModel` code
//! path the FMU runs (configuration request → granted view configuration → one `step` per
//! SensorView frame), with effect switches from `--enable` / `--disable`.

use std::path::Path;

use anyhow::{Context, Result, anyhow};
use osiris_models::effects::EffectSwitches;
use osiris_models::environment::weather::Weather;
use osiris_models::{
    ModelMode, Mounting, SensorConfig, SensorKind, StepInput, StepOutput, build_sensor,
};
use osiris_proto::osi3;

use super::campaign::{Campaign, CampaignSensor};
use super::pairing::ts_ns;

/// Why a re-simulation could not run.
#[derive(Debug, thiserror::Error)]
pub enum SimulateError {
    #[error(transparent)]
    Other(#[from] anyhow::Error),
}

/// The model configuration of a campaign: `--model` JSON, else the campaign's `sensor.model`, else
/// the built-in defaults of the kind; then mode physical, the campaign's mounting and weather, the
/// effect switches and the seed.
pub fn model_config(
    campaign: &Campaign,
    model: Option<&Path>,
    switches: &EffectSwitches,
    seed: u64,
) -> Result<SensorConfig> {
    let kind = match campaign.sensor.kind {
        CampaignSensor::Radar => SensorKind::Radar,
        CampaignSensor::Lidar => SensorKind::Lidar,
        CampaignSensor::Camera => SensorKind::Camera,
    };
    let path = model
        .map(Path::to_path_buf)
        .or_else(|| campaign.sensor.model.clone());
    let mut cfg = match path {
        Some(p) => {
            let text = std::fs::read_to_string(&p).with_context(|| {
                format!("cannot read the model configuration `{}`", p.display())
            })?;
            SensorConfig::from_json_str(&text)
                .map_err(|e| anyhow!("model configuration `{}`: {e}", p.display()))?
        }
        None => {
            let mut c = SensorConfig::default_for(kind);
            c.mounting = Mounting {
                position_m: campaign.sensor.mounting_position_m,
                orientation_rad: campaign.sensor.mounting_orientation_rad,
            };
            c
        }
    };
    if cfg.kind != kind {
        anyhow::bail!(
            "the model configuration is for a {} sensor, the campaign for a {}",
            cfg.kind.name(),
            kind.name()
        );
    }
    if let Some(name) = campaign.sensor.lidar_preset.as_deref() {
        // The campaign's `sensor.lidar_preset` selects the LiDAR model's preset (e.g. the FMCW
        // chain); a model configuration that names another preset is an error, not overridden.
        let preset: osiris_models::lidar::scan::Preset =
            serde_json::from_value(serde_json::Value::String(name.to_owned()))
                .map_err(|e| anyhow!("`sensor.lidar_preset` = `{name}`: {e}"))?;
        let lidar = cfg.lidar.get_or_insert_with(Default::default);
        if lidar.preset != preset && lidar.preset != Default::default() {
            anyhow::bail!(
                "the model configuration's LiDAR preset is {:?}, the campaign's `sensor.lidar_preset` `{name}`",
                lidar.preset
            );
        }
        lidar.preset = preset;
    }
    cfg.mode = ModelMode::Physical;
    let env = &campaign.environment;
    cfg.weather = Some(Weather {
        rain_mm_h: env.rain_mm_h,
        fog_visibility_m: env.fog_visibility_m,
        temperature_c: env.temperature_c,
        ..Weather::default()
    });
    for (k, v) in switches {
        cfg.effects.insert(k.clone(), *v);
    }
    cfg.seed = Some(seed);
    cfg.validate().map_err(|e| anyhow!("{e}"))?;
    Ok(cfg)
}

/// What a re-simulation produced.
#[derive(Debug, Clone, Default)]
pub struct Simulation {
    /// One SensorData per SensorView frame (OSI 3.8.0 semantics: a detection's `object_id` is the
    /// tracking id of the detected object it belongs to, if any).
    pub frames: Vec<osi3::SensorData>,
    /// Per frame, the ground-truth id of each radar or LiDAR detection (feature-data order,
    /// `INVALID_ID` = none), from the model's PerceptionData (radar peaks and LiDAR points are the
    /// detections, index for index).
    pub truth: Vec<Vec<u64>>,
}

/// The ground-truth id of each radar / LiDAR detection of a step, from its PerceptionData.
fn detection_truth(step: &StepOutput) -> Vec<u64> {
    let p = &step.perception;
    if let Some(r) = p.radar.as_ref() {
        return r
            .peak
            .iter()
            .map(|k| {
                k.object_id
                    .and_then(|i| i.value)
                    .unwrap_or(osiris_proto::INVALID_ID)
            })
            .collect();
    }
    p.lidar
        .as_ref()
        .map(|l| l.object_id.clone())
        .unwrap_or_default()
}

/// Runs the model over every SensorView frame; returns one SensorData per frame and the
/// ground-truth ids of their detections.
pub fn simulate(
    config: SensorConfig,
    views: &[osi3::SensorView],
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Simulation, SimulateError> {
    let mut model = match build_sensor(config.clone()) {
        Ok(m) => m,
        Err(e) => return Err(SimulateError::Other(anyhow!("{e}"))),
    };
    let request = model.view_configuration_request();
    model
        .apply_view_configuration(&request)
        .map_err(|e| anyhow!("view configuration: {e}"))?;
    let mut out = Simulation {
        frames: Vec::with_capacity(views.len()),
        truth: Vec::with_capacity(views.len()),
    };
    let mut step = StepOutput::default();
    let times: Vec<f64> = views
        .iter()
        .enumerate()
        .map(|(i, v)| {
            ts_ns(v.timestamp.as_ref())
                .map(|t| t as f64 * 1e-9)
                .unwrap_or(i as f64 * config.update_cycle_s)
        })
        .collect();
    for (i, view) in views.iter().enumerate() {
        let dt = times
            .get(i + 1)
            .map(|t| t - times[i])
            .filter(|d| *d > 0.0)
            .unwrap_or(config.update_cycle_s);
        // A model panic must not take the workflow down: it becomes an error naming the frame.
        let stepped = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            model.step(
                &StepInput {
                    view,
                    time_s: times[i],
                    step_s: dt,
                },
                &mut step,
            )
        }));
        match stepped {
            Ok(r) => r.map_err(|e| anyhow!("frame {i} (t = {:.3} s): {e}", times[i]))?,
            Err(p) => {
                let why = p
                    .downcast_ref::<&str>()
                    .map(|s| s.to_string())
                    .or_else(|| p.downcast_ref::<String>().cloned())
                    .unwrap_or_else(|| "unknown panic".into());
                return Err(SimulateError::Other(anyhow!(
                    "the model panicked at frame {i} (t = {:.3} s): {why}",
                    times[i]
                )));
            }
        }
        let mut sd = step.sensor_data.clone();
        if sd.timestamp.is_none() {
            sd.timestamp = view.timestamp;
        }
        out.frames.push(sd);
        out.truth.push(detection_truth(&step));
        progress(i + 1, views.len());
    }
    Ok(out)
}
