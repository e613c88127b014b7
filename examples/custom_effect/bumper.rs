//! A consistency-catalogue effect written from scratch: radar blockage by a bumper edge
//! (knife-edge diffraction), which removes power from one side of the field of view and grows
//! with azimuth. Shared by `examples/custom_effect/main.rs` and `tests/consistency_extend.rs`.
//!
//! The workflow it demonstrates (GitHub issue 7, "a user adds an effect by implementing one trait
//! and registering it"):
//! 1. a campaign from the truth generator (`osiris::consistency::truth`), with the blockage applied
//!    to the measured trace as a hidden effect;
//! 2. `osiris consistency` with the built-in catalogue: the effect is not in it, so the misfit is
//!    not explained;
//! 3. the same run with [`BumperEdgeBlockage`] registered ([`Catalogue::register`]) and the
//!    catalogue passed to the workflow ([`cli::run_with_catalogue`]): the effect is accepted and its
//!    parameter fitted;
//! 4. "enabled": the fitted signature corrects the model's SensorData (what a user does before
//!    implementing the physics in the model) and the run is repeated: the headline error falls.

use std::path::Path;

use anyhow::{Context, Result};
use osiris::consistency::campaign::CampaignSensor;
use osiris::consistency::catalogue::{Catalogue, EffectSignature, Param};
use osiris::consistency::cli;
use osiris::consistency::pairing::read_trace;
use osiris::consistency::report::Summary;
use osiris::consistency::truth::{CampaignFiles, RadarTruth, write_radar};
use osiris::consistency::{ConsistencyArgs, NVARS, V_AZIMUTH};
use osiris_proto::osi3;

/// Wavelength at 76.5 GHz, m (c / f).
pub const LAMBDA_M: f64 = 299_792_458.0 / 76.5e9;
/// Distance from the antenna to the bumper edge, m (mounting CAD; guessed value).
pub const EDGE_DISTANCE_M: f64 = 0.05;
/// Azimuth of the hidden bumper edge in the example's "reality", deg (guessed mounting).
pub const HIDDEN_EDGE_AZIMUTH_DEG: f64 = 15.0;

/// One-way knife-edge diffraction loss J(ν) in dB (ITU-R P.526-15, eq. 31; J = 0 for
/// ν ≤ −0.78, where the approximation reaches 0 dB).
pub fn knife_edge_loss_db(nu: f64) -> f64 {
    if nu <= -0.78 {
        0.0
    } else {
        6.9 + 20.0 * (((nu - 0.1).powi(2) + 1.0).sqrt() + nu - 0.1).log10()
    }
}

/// Fresnel–Kirchhoff parameter of a ray passing an edge at `edge_m` from the antenna, `angle_rad`
/// inside the edge's shadow (ν = θ·√(2d/λ) for d ≪ the target range; ITU-R P.526-15 eq. 28).
pub fn fresnel_nu(angle_rad: f64, edge_m: f64) -> f64 {
    angle_rad * (2.0 * edge_m / LAMBDA_M).sqrt()
}

/// Two-way blockage loss (≤ 0 dB, in the residual's sign convention) of a detection at
/// `azimuth_deg` behind an edge at `edge_azimuth_deg`.
pub fn two_way_blockage_db(azimuth_deg: f64, edge_azimuth_deg: f64) -> f64 {
    let nu = fresnel_nu(
        (azimuth_deg - edge_azimuth_deg).to_radians(),
        EDGE_DISTANCE_M,
    );
    -2.0 * knife_edge_loss_db(nu)
}

/// The new effect: implements [`EffectSignature`], nothing else.
pub struct BumperEdgeBlockage {
    params: Vec<Param>,
    explanatory: Vec<String>,
}

impl Default for BumperEdgeBlockage {
    fn default() -> Self {
        BumperEdgeBlockage {
            // p0: azimuth of the bumper edge, deg (the side it blocks: positive azimuths).
            params: vec![Param::new("p0", [0.0, 60.0], 20.0)],
            explanatory: vec!["azimuth".to_owned()],
        }
    }
}

impl EffectSignature for BumperEdgeBlockage {
    fn id(&self) -> &str {
        "radar.bumper_edge_blockage"
    }
    fn quantity(&self) -> &str {
        "power_db"
    }
    fn params(&self) -> &[Param] {
        &self.params
    }
    fn eval(&self, x: &[f64], p: &[f64]) -> f64 {
        two_way_blockage_db(x[V_AZIMUTH], p[0])
    }
    fn explanatory(&self) -> &[String] {
        &self.explanatory
    }
    fn signature(&self) -> &str {
        "-2·J(ν), ν = (azimuth − p0)·√(2d/λ), J = ITU-R P.526 knife edge"
    }
    fn physics(&self) -> &str {
        "knife-edge diffraction past a bumper edge at d = 5 cm from the antenna (ITU-R P.526-15 \
         eq. 31), two-way; p0 = edge azimuth in deg"
    }
    fn discriminating_experiment(&self) -> &str {
        "reflectors at the same range on both sides of boresight"
    }
}

/// What one run reports.
#[derive(Debug, Clone)]
pub struct Outcome {
    pub status: String,
    /// Headline RMS power residual (calibration offset removed), dB.
    pub power_rms_db: f64,
    /// Raw RMS power residual, dB.
    pub power_rms_raw_db: f64,
    pub accepted: Vec<String>,
    /// Fitted edge azimuth ± σ, deg (when the effect was in the catalogue).
    pub edge_azimuth_deg: Option<(f64, f64)>,
}

fn outcome(s: &Summary) -> Outcome {
    Outcome {
        status: s.status.clone(),
        power_rms_db: s.error.get("power_db").copied().unwrap_or(f64::NAN),
        power_rms_raw_db: s.error_raw.get("power_db").copied().unwrap_or(f64::NAN),
        accepted: s.accepted(),
        edge_azimuth_deg: s
            .effect("radar.bumper_edge_blockage")
            .map(|e| (e.params[0].value, e.params[0].sigma)),
    }
}

/// The three runs of the demonstration.
#[derive(Debug, Clone)]
pub struct Demo {
    pub without: Outcome,
    pub with: Outcome,
    pub enabled: Outcome,
}

fn write_trace(path: &Path, msgs: &[osi3::SensorData]) -> Result<()> {
    let mut w = osiris::trace::OsiTraceWriter::create(path)?;
    for m in msgs {
        w.write_message(m)?;
    }
    w.finish()?;
    Ok(())
}

/// Adds `db(azimuth_deg)` to the RCS and SNR of every radar detection of a trace.
fn adjust(path_in: &Path, path_out: &Path, db: impl Fn(f64) -> f64, quantise: bool) -> Result<()> {
    let mut sds: Vec<osi3::SensorData> = read_trace(path_in, "SensorData")?;
    for sd in &mut sds {
        let Some(fd) = sd.feature_data.as_mut() else {
            continue;
        };
        for rs in &mut fd.radar_sensor {
            for d in &mut rs.detection {
                let az = d
                    .position
                    .as_ref()
                    .and_then(|p| p.azimuth)
                    .context("detection without azimuth")?;
                let delta = db(az.to_degrees());
                if let Some(r) = d.rcs.as_mut() {
                    *r += delta;
                    if quantise {
                        // The vendor logs RCS in 0.5 dB steps (like the truth generator).
                        *r = (*r / 0.5).round() * 0.5;
                    }
                }
                if let Some(s) = d.snr.as_mut() {
                    *s += delta;
                }
            }
            // Detections pushed below the 10 dB threshold are not reported.
            rs.detection.retain(|d| d.snr.is_none_or(|s| s >= 10.0));
        }
    }
    write_trace(path_out, &sds)
}

/// `osiris consistency --meta <toml> --simulated <trace> --out <out> --history <out>/../history`.
fn args(files: &CampaignFiles, simulated: &Path, out: &Path) -> ConsistencyArgs {
    ConsistencyArgs {
        meta: files.toml.clone(),
        out: out.to_path_buf(),
        simulated: Some(simulated.to_path_buf()),
        model: None,
        enable: vec![],
        disable: vec![],
        history: out.parent().map(|d| d.join("history")),
    }
}

/// Runs the demonstration in `dir` (the truth campaign of `seed`): reports in
/// `dir/{without,with,enabled}/report.html`, the run registry in `dir/history`.
pub fn demo(dir: &Path, seed: u64) -> Result<Demo> {
    let spec = RadarTruth {
        seed,
        ..RadarTruth::default()
    };
    let files = write_radar(&dir.join("campaign"), &spec)?;
    // 1. Hidden effect: the measured trace passes the bumper edge.
    let clean = dir.join("campaign/sd_measured_clean.osi");
    std::fs::rename(&files.sensor_data, &clean)?;
    adjust(
        &clean,
        &files.sensor_data,
        |az| two_way_blockage_db(az, HIDDEN_EDGE_AZIMUTH_DEG),
        true,
    )?;
    // 2. The built-in catalogue.
    let without = cli::run_with(&args(&files, &files.simulated, &dir.join("without")), None)?;
    // 3. The effect registered.
    let mut catalogue = Catalogue::builtin(CampaignSensor::Radar)?;
    catalogue.register(Box::new(BumperEdgeBlockage::default()))?;
    let with = cli::run_with_catalogue(
        &args(&files, &files.simulated, &dir.join("with")),
        Some(&catalogue),
        None,
    )?;
    let fitted = with
        .effect("radar.bumper_edge_blockage")
        .context("the registered effect was evaluated")?
        .params[0]
        .value;
    // 4. Enabled: the fitted signature corrects the model output, the run is repeated.
    let corrected = dir.join("campaign/sd_model_corrected.osi");
    let effect = BumperEdgeBlockage::default();
    adjust(
        &files.simulated,
        &corrected,
        |az| {
            let mut x = [0.0; NVARS];
            x[V_AZIMUTH] = az;
            effect.eval(&x, &[fitted])
        },
        false,
    )?;
    let enabled = cli::run_with_catalogue(
        &args(&files, &corrected, &dir.join("enabled")),
        Some(&catalogue),
        None,
    )?;
    Ok(Demo {
        without: outcome(&without),
        with: outcome(&with),
        enabled: outcome(&enabled),
    })
}
