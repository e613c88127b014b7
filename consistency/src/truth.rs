//! The INDEPENDENT truth generator of the hidden-effect protocol (validation.md §8).
//!
//! It writes whole campaigns — SensorView trace, measured SensorData trace, a "model" SensorData
//! trace and `consistency.toml` — from closed-form physics with hidden effects and realistic
//! nuisances. It shares no physics code with the osiris models or the effect catalogue: geometry,
//! radar equation, rain attenuation, antenna pattern, limiter, scan pattern and LiDAR intensity are
//! written out here again, in different functional forms where physics allows (Gaussian beam in
//! linear power, a Rapp limiter with smoothness 2, averaging in the linear domain before dB, a
//! rectangular-window range-FFT straddle loss). Only OSI I/O is shared.
//!
//! Hidden effects split in two kinds: *measurement physics* the model lacks (applied to the
//! measured trace) and *model bugs* (DIVP replicas, applied to the model trace). Either way the
//! residual meas − model carries the signature.

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use anyhow::Result;
use osiris_proto::{id, osi3};

use super::metrics::SplitMix;
use osiris_proto::trace::OsiTraceWriter;

/// Speed of light, m/s (exact, SI).
const C_M_S: f64 = 299_792_458.0;

/// Hidden effects of the radar truth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RadarHidden {
    /// Measurement: two-way Gaussian antenna main lobe of this 3 dB beamwidth, deg.
    AntennaPattern { beamwidth_deg: f64 },
    /// Measurement: two-way rain attenuation at this rain rate, mm/h (ITU-R P.838-3, 77 GHz).
    Rain { rain_mm_h: f64 },
    /// Measurement: Rapp limiter (smoothness 2) at this saturation SNR, dB.
    Compression { saturation_snr_db: f64 },
    /// Measurement: processing gain (R/knee)^exponent below the knee (STC decoy).
    Stc { knee_m: f64, exponent: f64 },
    /// Measurement: range-FFT straddle loss of a rectangular window, bin spacing c/(2B) (not in the
    /// catalogue).
    Scalloping { bandwidth_hz: f64 },
    /// Model bug (DIVP): power ∝ R⁻² instead of R⁻⁴.
    ModelSpreadingR2,
    /// Model bug (DIVP): RCS ∝ face area¹ instead of area².
    ModelAreaLinear,
}

/// A radar campaign design.
#[derive(Debug, Clone)]
pub struct RadarTruth {
    pub seed: u64,
    /// Sensor-to-reflector-row distances of the stations, m.
    pub distances_m: Vec<f64>,
    /// Trihedral edges, m.
    pub edges_m: Vec<f64>,
    /// Lateral offsets of the reflector columns, m.
    pub lateral_m: Vec<f64>,
    pub frames_per_station: usize,
    /// Reflectors face the sensor (aspect ≈ 0) instead of facing along −x.
    pub face_sensor: bool,
    pub hidden: Vec<RadarHidden>,
    /// Unknown calibration offset of the measured RCS, dB.
    pub calibration_offset_db: f64,
    /// Fraction of measured frames dropped.
    pub missing_fraction: f64,
    /// Measured detections carry the ground-truth object id.
    pub object_ids: bool,
    /// GT position uncertainty (σ of the per-station reflector position jitter), m.
    pub gt_sigma_m: f64,
}

impl Default for RadarTruth {
    fn default() -> Self {
        RadarTruth {
            seed: 1,
            distances_m: (0..16).map(|i| 3.0 + 5.0 * f64::from(i)).collect(),
            edges_m: vec![0.05, 0.10, 0.15],
            lateral_m: vec![-2.0, 0.0, 2.0],
            frames_per_station: 6,
            face_sensor: true,
            hidden: Vec::new(),
            calibration_offset_db: 1.3,
            missing_fraction: 0.1,
            object_ids: true,
            gt_sigma_m: 0.02,
        }
    }
}

/// Files of a generated campaign.
#[derive(Debug, Clone)]
pub struct CampaignFiles {
    pub toml: PathBuf,
    pub sensor_view: PathBuf,
    pub sensor_data: PathBuf,
    /// The "model" trace (for `--simulated`).
    pub simulated: PathBuf,
}

fn v3(x: f64, y: f64, z: f64) -> osi3::Vector3d {
    osi3::Vector3d {
        x: Some(x),
        y: Some(y),
        z: Some(z),
    }
}

fn ts(t: f64) -> osi3::Timestamp {
    osiris_proto::timestamp_from_seconds(t)
}

fn host(x: f64) -> osi3::MovingObject {
    osi3::MovingObject {
        id: Some(id(1)),
        base: Some(osi3::BaseMoving {
            dimension: Some(osi3::Dimension3d {
                length: Some(4.5),
                width: Some(1.8),
                height: Some(1.5),
            }),
            position: Some(v3(x, 0.0, 0.0)),
            orientation: Some(osi3::Orientation3d {
                roll: Some(0.0),
                pitch: Some(0.0),
                yaw: Some(0.0),
            }),
            velocity: Some(v3(0.0, 0.0, 0.0)),
            ..Default::default()
        }),
        r#type: Some(osi3::moving_object::Type::Vehicle as i32),
        vehicle_attributes: Some(osi3::moving_object::VehicleAttributes {
            bbcenter_to_rear: Some(v3(0.0, 0.0, 0.0)),
            ..Default::default()
        }),
        ..Default::default()
    }
}

fn stationary(
    oid: u64,
    reference: String,
    pos: [f64; 3],
    dims: [f64; 3],
    yaw: f64,
) -> osi3::StationaryObject {
    osi3::StationaryObject {
        id: Some(id(oid)),
        base: Some(osi3::BaseStationary {
            dimension: Some(osi3::Dimension3d {
                length: Some(dims[0]),
                width: Some(dims[1]),
                height: Some(dims[2]),
            }),
            position: Some(v3(pos[0], pos[1], pos[2])),
            orientation: Some(osi3::Orientation3d {
                roll: Some(0.0),
                pitch: Some(0.0),
                yaw: Some(yaw),
            }),
            ..Default::default()
        }),
        model_reference: Some(reference),
        ..Default::default()
    }
}

fn view(
    t: f64,
    host_x: f64,
    mount: [f64; 3],
    objects: Vec<osi3::StationaryObject>,
) -> osi3::SensorView {
    let mounting = osi3::MountingPosition {
        position: Some(v3(mount[0], mount[1], mount[2])),
        orientation: Some(osi3::Orientation3d {
            roll: Some(0.0),
            pitch: Some(0.0),
            yaw: Some(0.0),
        }),
    };
    osi3::SensorView {
        timestamp: Some(ts(t)),
        sensor_id: Some(id(7)),
        host_vehicle_id: Some(id(1)),
        mounting_position: Some(mounting),
        global_ground_truth: Some(osi3::GroundTruth {
            timestamp: Some(ts(t)),
            host_vehicle_id: Some(id(1)),
            moving_object: vec![host(host_x)],
            stationary_object: objects,
            ..Default::default()
        }),
        ..Default::default()
    }
}

fn write_all<M: prost::Message>(path: &Path, msgs: &[M]) -> Result<()> {
    let mut w = OsiTraceWriter::create(path)?;
    for m in msgs {
        w.write_message(m)?;
    }
    w.finish()?;
    Ok(())
}

/// The three traces of a campaign in `dir` (SensorView, measured and "model" SensorData), and the
/// paths of all its files.
fn write_traces(
    dir: &Path,
    views: &[osi3::SensorView],
    meas: &[osi3::SensorData],
    sim: &[osi3::SensorData],
) -> Result<CampaignFiles> {
    let files = CampaignFiles {
        toml: dir.join("consistency.toml"),
        sensor_view: dir.join("sv.osi"),
        sensor_data: dir.join("sd_measured.osi"),
        simulated: dir.join("sd_model.osi"),
    };
    write_all(&files.sensor_view, views)?;
    write_all(&files.sensor_data, meas)?;
    write_all(&files.simulated, sim)?;
    Ok(files)
}

/// ITU-R P.838-3 specific attenuation at 77 GHz, horizontal polarisation, dB/km (k = 1.132,
/// α = 0.718; validation.md §9c).
fn itu_rain_db_per_km(rain_mm_h: f64) -> f64 {
    1.132 * rain_mm_h.powf(0.718)
}

/// Writes a radar campaign into `dir`.
pub fn write_radar(dir: &Path, spec: &RadarTruth) -> Result<CampaignFiles> {
    std::fs::create_dir_all(dir)?;
    let f_hz = 76.5e9;
    let lambda = C_M_S / f_hz;
    let mount = [3.7, 0.0, 0.5];
    let target_z = 0.5;
    // Radar constant: SNR = K σ / R⁴ with 40 dB for 10 m² at 100 m (guessed front end).
    let k_snr = 1e4 * 1e8 / 10.0;
    let mut rng = SplitMix(spec.seed.wrapping_mul(0x2545_F491_4F6C_DD1D) ^ 0xA5A5);
    let mut views = Vec::new();
    let mut meas = Vec::new();
    let mut sim = Vec::new();
    // (id, edge, lateral y, depth x): each size sits in its own row, 3 m deeper than the previous,
    // so no two reflectors share a position.
    let mut targets = Vec::new();
    let mut oid = 100u64;
    for (i, &a) in spec.edges_m.iter().enumerate() {
        for &y in &spec.lateral_m {
            targets.push((oid, a, y, 3.0 * i as f64));
            oid += 1;
        }
    }
    let rain = spec.hidden.iter().find_map(|h| match h {
        RadarHidden::Rain { rain_mm_h } => Some(*rain_mm_h),
        _ => None,
    });
    let mut frame = 0usize;
    for &d in &spec.distances_m {
        // The first reflector row sits at x = 0; the host moves so the sensor is `d` in front of it.
        let host_x = -d - mount[0];
        let sensor = [host_x + mount[0], mount[1], mount[2]];
        // Per-station GT error: the true reflector position differs from the surveyed one.
        let jitter: Vec<[f64; 2]> = targets
            .iter()
            .map(|_| {
                [
                    spec.gt_sigma_m * rng.normal(),
                    spec.gt_sigma_m * rng.normal(),
                ]
            })
            .collect();
        for _ in 0..spec.frames_per_station {
            let t = frame as f64 * 0.05;
            frame += 1;
            let objects: Vec<osi3::StationaryObject> = targets
                .iter()
                .map(|&(oid, a, y, x)| {
                    let yaw = if spec.face_sensor {
                        (sensor[1] - y).atan2(sensor[0] - x)
                    } else {
                        PI
                    };
                    stationary(
                        oid,
                        format!("osiris:trihedral?edge_m={a}"),
                        [x, y, target_z],
                        [a, a, a],
                        yaw,
                    )
                })
                .collect();
            views.push(view(t, host_x, mount, objects));
            let mut mdets = Vec::new();
            let mut sdets = Vec::new();
            for (k, &(oid, a, y, x)) in targets.iter().enumerate() {
                let nominal = [x - sensor[0], y - sensor[1], target_z - sensor[2]];
                let truep = [
                    nominal[0] + jitter[k][0],
                    nominal[1] + jitter[k][1],
                    nominal[2],
                ];
                let r_nom = (nominal[0].powi(2) + nominal[1].powi(2) + nominal[2].powi(2)).sqrt();
                let r = (truep[0].powi(2) + truep[1].powi(2) + truep[2].powi(2)).sqrt();
                let az = truep[1].atan2(truep[0]);
                let az_nom = nominal[1].atan2(nominal[0]);
                let el_nom = nominal[2].atan2(nominal[0].hypot(nominal[1]));
                let aspect = if spec.face_sensor { 0.0 } else { az.abs() };
                // Trihedral peak RCS 4πa⁴/(3λ²) (Knott), aspect loss: cos² of the aspect in
                // amplitude (guessed shape; only the decoy experiments use aspect ≠ 0).
                let sigma = 4.0 * PI * a.powi(4) / (3.0 * lambda * lambda) * aspect.cos().powi(4);
                let mut snr = k_snr * sigma / r.powi(4);
                for h in &spec.hidden {
                    match *h {
                        RadarHidden::AntennaPattern { beamwidth_deg } => {
                            let th = az.to_degrees() / beamwidth_deg;
                            // One-way Gaussian power pattern exp(−4 ln2 θ²/θ3²), two-way squared.
                            snr *= (-8.0 * 2f64.ln() * th * th).exp();
                        }
                        RadarHidden::Rain { rain_mm_h } => {
                            snr *= 10f64
                                .powf(-2.0 * itu_rain_db_per_km(rain_mm_h) * r / 1000.0 / 10.0);
                        }
                        RadarHidden::Stc { knee_m, exponent } if r < knee_m => {
                            snr *= (r / knee_m).powf(exponent);
                        }
                        RadarHidden::Scalloping { bandwidth_hz } => {
                            let bin = C_M_S / (2.0 * bandwidth_hz);
                            let u = (r / bin).fract();
                            let u = u.min(1.0 - u);
                            let s = if u > 1e-9 {
                                (PI * u).sin() / (PI * u)
                            } else {
                                1.0
                            };
                            snr *= s * s;
                        }
                        _ => {}
                    }
                }
                // Fluctuation + thermal noise, combined as complex amplitudes (linear domain).
                let (z1r, z1i, z2r, z2i) = (rng.normal(), rng.normal(), rng.normal(), rng.normal());
                let amp = snr.sqrt();
                let re = amp * (1.0 + 0.12 * z1r) + z2r / 2f64.sqrt();
                let im = amp * 0.12 * z1i + z2i / 2f64.sqrt();
                let mut p = re * re + im * im;
                for h in &spec.hidden {
                    if let RadarHidden::Compression { saturation_snr_db } = *h {
                        let ps = 10f64.powf(saturation_snr_db / 10.0);
                        p /= (1.0 + (p / ps).powi(2)).sqrt();
                    }
                }
                let r_meas = r + 0.04 * rng.normal();
                // Vendor RCS estimate: received power compensated with the measured range.
                let rcs_db =
                    10.0 * (p * r_meas.powi(4) / k_snr).log10() + spec.calibration_offset_db;
                let rcs_db = (rcs_db / 0.5).round() * 0.5;
                let snr_db = 10.0 * p.log10();
                let az_meas = az + (0.15f64).to_radians() * rng.normal();
                let vr = 0.014 * rng.normal();
                // Only detections above 10 dB SNR are reported.
                if snr_db >= 10.0 {
                    mdets.push(osi3::RadarDetection {
                        object_id: spec.object_ids.then(|| id(oid)),
                        position: Some(osi3::Spherical3d {
                            distance: Some(r_meas),
                            azimuth: Some(az_meas),
                            elevation: Some(el_nom),
                        }),
                        radial_velocity: Some(vr),
                        rcs: Some(rcs_db),
                        snr: Some(snr_db),
                        ..Default::default()
                    });
                }
                // The model: nominal geometry, peak RCS, plus its bugs.
                let mut sim_rcs = 10.0 * (4.0 * PI * a.powi(4) / (3.0 * lambda * lambda)).log10();
                for h in &spec.hidden {
                    match h {
                        RadarHidden::ModelSpreadingR2 => sim_rcs += 20.0 * (r_nom / 10.0).log10(),
                        RadarHidden::ModelAreaLinear => sim_rcs -= 20.0 * (a / 0.1).log10(),
                        _ => {}
                    }
                }
                sdets.push(osi3::RadarDetection {
                    object_id: Some(id(oid)),
                    position: Some(osi3::Spherical3d {
                        distance: Some(r_nom),
                        azimuth: Some(az_nom),
                        elevation: Some(el_nom),
                    }),
                    radial_velocity: Some(0.0),
                    rcs: Some(sim_rcs),
                    snr: Some(10.0 * (k_snr * 10f64.powf(sim_rcs / 10.0) / r_nom.powi(4)).log10()),
                    ..Default::default()
                });
            }
            let sd = |dets: Vec<osi3::RadarDetection>| osi3::SensorData {
                timestamp: Some(ts(t)),
                sensor_id: Some(id(7)),
                feature_data: Some(osi3::FeatureData {
                    radar_sensor: vec![osi3::RadarDetectionData {
                        detection: dets,
                        ..Default::default()
                    }],
                    ..Default::default()
                }),
                ..Default::default()
            };
            if rng.unit() >= spec.missing_fraction {
                meas.push(sd(mdets));
            }
            sim.push(sd(sdets));
        }
    }
    let files = write_traces(dir, &views, &meas, &sim)?;
    let mut toml = format!(
        r#"schema = "osiris.consistency/1"

[run]
id = "truth-radar-{seed}"
description = "synthetic trihedral sweep from the independent truth generator"
provenance = "osiris consistency::truth (seed {seed})"
licence = "MPL-2.0"

[sensor]
kind = "radar"
osi_sensor_id = 7
mounting_position_m = [{mx}, {my}, {mz}]
mounting_orientation_rad = [0.0, 0.0, 0.0]
frequency_hz = {f_hz}
bandwidth_hz = 1.0e9
mounting_height_m = {mz}
polarisation = "vertical"
antenna_beamwidth_az_deg = 20.0
antenna_beamwidth_el_deg = 10.0
detection_threshold_db = 10.0
quantity_semantics = {{ rcs = "vendor RCS estimate, dBsm", snr = "dB" }}

[environment]
rain_mm_h = {rain}
fog_visibility_m = inf
temperature_c = 15.0
ground = "asphalt"
sun = {{ elevation_deg = 30.0, azimuth_deg = 180.0 }}

[uncertainty]
gt_position_sigma_m = {gts}
gt_height_sigma_m = 0.01
gt_orientation_sigma_deg = 0.5

[association]
method = "{method}"

[tolerance]
range_m = 0.30
radial_velocity_kmh = 0.3
azimuth_deg = 1.0
power_db = 5.0

[bins]
range_m = [0.0, 10.0, 20.0, 40.0, 80.0, 160.0, 320.0]
azimuth_deg = [-60.0, -20.0, -5.0, 5.0, 20.0, 60.0]
explanatory = ["range", "azimuth", "area"]

[split]
cv_group_by = ["target"]
holdout_fraction = 0.3
seed = {seed}

[traces]
sensor_view = "sv.osi"
sensor_data = "sd_measured.osi"
"#,
        seed = spec.seed,
        mx = mount[0],
        my = mount[1],
        mz = mount[2],
        rain = rain.unwrap_or(0.0),
        gts = spec.gt_sigma_m,
        method = if spec.object_ids {
            "object_id"
        } else {
            "gating"
        },
    );
    for &(oid, a, _, _) in &targets {
        toml.push_str(&format!(
            "\n[[target]]\nid = {oid}\nkind = \"trihedral\"\nedge_m = {a}\nmaterial = \"metal\"\norientation = \"{}\"\n",
            if spec.face_sensor { "facing the sensor" } else { "facing -x" }
        ));
    }
    std::fs::write(&files.toml, toml)?;
    Ok(files)
}

/// Fraction of a transmitter spot of radius r_t = a·R inside a receiver field of view of radius
/// r_r = b·R whose axis is d = 1 away (physics.md §2.3, scale-free): the circle–circle overlap area
/// over π r_t², with a = (1 − 1/ratio)/(2 r_on) and b = (1 + 1/ratio)/(2 r_on), so that it starts at
/// R = r_on and is complete at R = ratio·r_on.
pub fn biaxial_overlap(range_m: f64, r_on_m: f64, full_ratio: f64) -> f64 {
    let rt = range_m * (1.0 - 1.0 / full_ratio) / (2.0 * r_on_m);
    let rr = range_m * (1.0 + 1.0 / full_ratio) / (2.0 * r_on_m);
    if rt <= 0.0 {
        return 0.0;
    }
    let area = osiris_models::lidar::signal::circle_overlap_area(rt, rr, 1.0);
    (area / (std::f64::consts::PI * rt * rt)).clamp(0.0, 1.0)
}

/// Hidden effects of the LiDAR truth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LidarHidden {
    /// Measurement: biaxial receiver overlap (physics.md §2.3) starting at `r_on_m` and complete at
    /// `full_ratio` × `r_on_m` (transmitter spot and receiver field of view growing linearly with
    /// range, their axes a fixed distance apart); the model has none (DIVP).
    Overlap { r_on_m: f64, full_ratio: f64 },
    /// Measurement: vertical beam divergence, mrad; the model has none (DIVP).
    VerticalDivergence { mrad: f64 },
    /// Measurement: mixed pixels at depth edges within this horizontal footprint, mrad (DIVP).
    MixedPixels { footprint_mrad: f64 },
    /// Measurement: two-way fog extinction at this visibility, m (Koschmieder α = 3.912/V).
    Fog { visibility_m: f64 },
}

/// A LiDAR campaign design: boards in a row at x = 0, the host backing away station by station.
#[derive(Debug, Clone)]
pub struct LidarTruth {
    pub seed: u64,
    pub distances_m: Vec<f64>,
    /// (lateral offset m, reflectivity %, yaw offset deg from facing −x, width m, height m).
    pub boards: Vec<(f64, f64, f64, f64, f64)>,
    /// An extra board this far behind the first board, shifted so it shows beside it (mixed pixels).
    pub back_board_gap_m: Option<f64>,
    pub frames_per_station: usize,
    pub hidden: Vec<LidarHidden>,
    /// Vertical ring spacing, deg, and horizontal step, deg.
    pub ring_step_deg: f64,
    pub az_step_deg: f64,
    pub missing_fraction: f64,
}

impl Default for LidarTruth {
    fn default() -> Self {
        LidarTruth {
            seed: 1,
            distances_m: vec![
                1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.5, 8.0, 10.0, 13.0, 16.0, 20.0, 25.0, 30.0,
            ],
            boards: vec![
                (-3.0, 10.0, 0.0, 1.0, 1.0),
                (-1.5, 50.0, 30.0, 1.0, 0.6),
                (0.0, 90.0, 0.0, 1.0, 0.8),
                (1.5, 50.0, -45.0, 1.0, 1.0),
                (3.0, 90.0, 60.0, 1.0, 0.5),
            ],
            back_board_gap_m: None,
            frames_per_station: 3,
            hidden: Vec::new(),
            ring_step_deg: 0.5,
            az_step_deg: 1.0,
            missing_fraction: 0.1,
        }
    }
}

struct Board {
    id: u64,
    centre: [f64; 3],
    /// Unit normal (board +x axis, facing the sensor side).
    normal: [f64; 3],
    /// Unit in-plane horizontal axis (board +y).
    side: [f64; 3],
    w: f64,
    h: f64,
    refl: f64,
}

/// Writes a LiDAR campaign into `dir`.
pub fn write_lidar(dir: &Path, spec: &LidarTruth) -> Result<CampaignFiles> {
    std::fs::create_dir_all(dir)?;
    let mount = [1.4, 0.0, 1.0];
    let board_z = 1.0;
    let mut rng = SplitMix(spec.seed.wrapping_mul(0x9E37_79B9) ^ 0x1D4);
    let mut boards = Vec::new();
    for (i, &(y, refl, yaw_deg, w, h)) in spec.boards.iter().enumerate() {
        let yaw = PI + yaw_deg.to_radians();
        boards.push(Board {
            id: 200 + i as u64,
            centre: [0.0, y, board_z],
            normal: [yaw.cos(), yaw.sin(), 0.0],
            side: [-yaw.sin(), yaw.cos(), 0.0],
            w,
            h,
            refl,
        });
    }
    if let Some(gap) = spec.back_board_gap_m {
        let b0 = &spec.boards[0];
        boards.push(Board {
            id: 200 + spec.boards.len() as u64,
            centre: [gap, b0.0 + 0.6 * b0.3, board_z],
            normal: [-1.0, 0.0, 0.0],
            side: [0.0, -1.0, 0.0],
            w: b0.3,
            h: b0.4,
            refl: 50.0,
        });
    }
    let overlap = spec.hidden.iter().find_map(|h| {
        if let LidarHidden::Overlap { r_on_m, full_ratio } = h {
            Some((*r_on_m, *full_ratio))
        } else {
            None
        }
    });
    let vdiv = spec
        .hidden
        .iter()
        .find_map(|h| {
            if let LidarHidden::VerticalDivergence { mrad } = h {
                Some(mrad * 1e-3)
            } else {
                None
            }
        })
        .unwrap_or(0.0);
    let mixed = spec.hidden.iter().find_map(|h| {
        if let LidarHidden::MixedPixels { footprint_mrad } = h {
            Some(footprint_mrad * 1e-3)
        } else {
            None
        }
    });
    let fog = spec.hidden.iter().find_map(|h| {
        if let LidarHidden::Fog { visibility_m } = h {
            Some(*visibility_m)
        } else {
            None
        }
    });
    let (mut views, mut meas, mut sim) = (Vec::new(), Vec::new(), Vec::new());
    let dz = spec.ring_step_deg.to_radians();
    let daz = spec.az_step_deg.to_radians();
    let mut frame = 0usize;
    for &d in &spec.distances_m {
        let host_x = -d - mount[0];
        let s = [host_x + mount[0], mount[1], mount[2]];
        for _ in 0..spec.frames_per_station {
            let t = frame as f64 * 0.1;
            frame += 1;
            // Scan phase and a small pitch vibration differ per frame (shared by the model run,
            // which replays the same firings).
            let az_phase = rng.unit() * daz;
            let el_phase = rng.unit() * dz;
            let objects = boards
                .iter()
                .map(|b| {
                    let yaw = b.normal[1].atan2(b.normal[0]);
                    let refl = b.refl.round() as u32;
                    stationary(
                        b.id,
                        format!(
                            "osiris:board?width_m={}&height_m={}&material=lambertian_{refl}",
                            b.w, b.h
                        ),
                        b.centre,
                        [0.02, b.w, b.h],
                        yaw,
                    )
                })
                .collect();
            views.push(view(t, host_x, mount, objects));
            // Angular boxes of the boards seen from the sensor.
            let rel = |p: [f64; 3]| [p[0] - s[0], p[1] - s[1], p[2] - s[2]];
            let boxes: Vec<[f64; 4]> = boards
                .iter()
                .map(|b| {
                    let mut bx = [
                        f64::INFINITY,
                        f64::NEG_INFINITY,
                        f64::INFINITY,
                        f64::NEG_INFINITY,
                    ];
                    for (u, v) in [(-0.5, -0.5), (0.5, -0.5), (-0.5, 0.5), (0.5, 0.5)] {
                        let c = [
                            b.centre[0] + b.side[0] * u * b.w,
                            b.centre[1] + b.side[1] * u * b.w,
                            b.centre[2] + v * b.h,
                        ];
                        let r = rel(c);
                        let az = r[1].atan2(r[0]);
                        let el = r[2].atan2(r[0].hypot(r[1]));
                        bx = [bx[0].min(az), bx[1].max(az), bx[2].min(el), bx[3].max(el)];
                    }
                    bx
                })
                .collect();
            let az_lo = boxes.iter().map(|b| b[0]).fold(f64::INFINITY, f64::min) - 0.02;
            let az_hi = boxes.iter().map(|b| b[1]).fold(f64::NEG_INFINITY, f64::max) + 0.02;
            let el_lo = boxes.iter().map(|b| b[2]).fold(f64::INFINITY, f64::min) - 0.02;
            let el_hi = boxes.iter().map(|b| b[3]).fold(f64::NEG_INFINITY, f64::max) + 0.02;
            let (mut mp, mut sp) = (Vec::new(), Vec::new());
            let ring0 = ((el_lo - el_phase) / dz).floor() as i64;
            let ring1 = ((el_hi - el_phase) / dz).ceil() as i64;
            let col0 = ((az_lo - az_phase) / daz).floor() as i64;
            let col1 = ((az_hi - az_phase) / daz).ceil() as i64;
            for ring in ring0..=ring1 {
                let el = el_phase + ring as f64 * dz;
                for col in col0..=col1 {
                    let az = az_phase + col as f64 * daz;
                    let dir = [el.cos() * az.cos(), el.cos() * az.sin(), el.sin()];
                    let beam = ((ring + 1000) as u64) * 100_000 + (col + 50_000) as u64;
                    // Plane range of board k along the beam.
                    let range_to = |b: &Board| -> f64 {
                        let c = rel(b.centre);
                        let num = c[0] * b.normal[0] + c[1] * b.normal[1] + c[2] * b.normal[2];
                        let den =
                            dir[0] * b.normal[0] + dir[1] * b.normal[1] + dir[2] * b.normal[2];
                        if den.abs() < 1e-9 {
                            f64::INFINITY
                        } else {
                            num / den
                        }
                    };
                    let inside = |k: usize, ext_az: f64, ext_el: f64| {
                        let bx = boxes[k];
                        az >= bx[0] - ext_az
                            && az <= bx[1] + ext_az
                            && el >= bx[2] - ext_el
                            && el <= bx[3] + ext_el
                    };
                    let nearest = |ext_el: f64| -> Option<(usize, f64)> {
                        (0..boards.len())
                            .filter(|&k| inside(k, 0.0, ext_el))
                            .map(|k| (k, range_to(&boards[k])))
                            .filter(|(_, r)| r.is_finite() && *r > 0.0)
                            .min_by(|a, b| a.1.total_cmp(&b.1))
                    };
                    let point = |k: usize,
                                 r: f64,
                                 overlap_on: bool,
                                 fog_on: bool|
                     -> osi3::LidarDetection {
                        let b = &boards[k];
                        // Incidence: angle between −dir and the board normal.
                        let cosi =
                            -(dir[0] * b.normal[0] + dir[1] * b.normal[1] + dir[2] * b.normal[2]);
                        let mut i = b.refl * cosi.max(0.0);
                        if overlap_on && let Some((r_on, ratio)) = overlap {
                            i *= biaxial_overlap(r, r_on, ratio);
                        }
                        if fog_on && let Some(v) = fog {
                            i *= (-2.0 * 3.912 / v * r).exp();
                        }
                        osi3::LidarDetection {
                            object_id: Some(id(b.id)),
                            position: Some(osi3::Spherical3d {
                                distance: Some(r),
                                azimuth: Some(az),
                                elevation: Some(el),
                            }),
                            intensity: Some(i),
                            beam_id: Some(id(beam)),
                            ..Default::default()
                        }
                    };
                    // The model: centre ray, nearest board, Lambertian intensity.
                    if let Some((k, r)) = nearest(0.0) {
                        sp.push(point(k, r, false, false));
                    }
                    // The measurement.
                    if let Some(fp) = mixed {
                        // Footprint straddling a depth edge: blended range, no object.
                        let hits: Vec<(usize, f64)> = (0..boards.len())
                            .filter(|&k| inside(k, fp / 2.0, 0.0))
                            .map(|k| (k, range_to(&boards[k])))
                            .filter(|(_, r)| r.is_finite() && *r > 0.0)
                            .collect();
                        if hits.len() >= 2 {
                            let rmin = hits.iter().map(|h| h.1).fold(f64::INFINITY, f64::min);
                            let rmax = hits.iter().map(|h| h.1).fold(0.0, f64::max);
                            let edge = hits.iter().any(|&(k, _)| !inside(k, -fp / 2.0, 0.0));
                            if rmax - rmin > 0.3 && edge {
                                mp.push(osi3::LidarDetection {
                                    object_id: None,
                                    position: Some(osi3::Spherical3d {
                                        distance: Some(0.5 * (rmin + rmax)),
                                        azimuth: Some(az),
                                        elevation: Some(el),
                                    }),
                                    intensity: Some(20.0),
                                    beam_id: Some(id(beam)),
                                    ..Default::default()
                                });
                                continue;
                            }
                        }
                    }
                    if let Some((k, r)) = nearest(vdiv / 2.0) {
                        let mut p = point(k, r + 0.02 * rng.normal(), true, true);
                        // Intensity noise 5 % and integer quantisation (Velodyne-like 0–100 %).
                        if let Some(i) = p.intensity.as_mut() {
                            *i = (*i * (1.0 + 0.05 * rng.normal())).round().max(1.0);
                        }
                        mp.push(p);
                    }
                }
            }
            let sd = |dets: Vec<osi3::LidarDetection>| osi3::SensorData {
                timestamp: Some(ts(t)),
                sensor_id: Some(id(7)),
                feature_data: Some(osi3::FeatureData {
                    lidar_sensor: vec![osi3::LidarDetectionData {
                        detection: dets,
                        ..Default::default()
                    }],
                    ..Default::default()
                }),
                ..Default::default()
            };
            if rng.unit() >= spec.missing_fraction {
                meas.push(sd(mp));
            }
            sim.push(sd(sp));
        }
    }
    let files = write_traces(dir, &views, &meas, &sim)?;
    let mut toml = format!(
        r#"schema = "osiris.consistency/1"

[run]
id = "truth-lidar-{seed}"
description = "synthetic board sweep from the independent truth generator"
provenance = "osiris consistency::truth (seed {seed})"
licence = "MPL-2.0"

[sensor]
kind = "lidar"
osi_sensor_id = 7
mounting_position_m = [{mx}, {my}, {mz}]
mounting_orientation_rad = [0.0, 0.0, 0.0]
wavelength_nm = 905.0
beam_divergence_mrad = 3.0
range_accuracy_m = 0.02
quantity_semantics = {{ intensity = "%, 0-100 diffuse reflectivity" }}

[environment]
rain_mm_h = 0.0
fog_visibility_m = {fog}
temperature_c = 15.0

[uncertainty]
gt_position_sigma_m = 0.0
gt_height_sigma_m = 0.0
gt_orientation_sigma_deg = 0.5

[association]
method = "object_id"
pairing = "beam_id"

[tolerance]
range_m = 0.30
intensity_pct = 10.0
intensity_db = 3.0
points_on_target_pct = 20.0
gap_points = 1.0

[bins]
range_m = [0.0, 2.5, 5.0, 10.0, 20.0, 40.0]
incidence_deg = [0.0, 15.0, 35.0, 50.0, 70.0]
reflectivity_pct = [0.0, 30.0, 70.0, 100.0]

[split]
cv_group_by = ["target"]
holdout_fraction = 0.3
seed = {seed}

[traces]
sensor_view = "sv.osi"
sensor_data = "sd_measured.osi"
"#,
        seed = spec.seed,
        mx = mount[0],
        my = mount[1],
        mz = mount[2],
        fog = fog.map(|v| format!("{v}")).unwrap_or_else(|| "inf".into()),
    );
    for b in &boards {
        toml.push_str(&format!(
            "\n[[target]]\nid = {}\nkind = \"lambertian_board\"\nreflectivity_pct = {}\nsize_m = [{}, {}]\nmaterial = \"lambertian_{}\"\n",
            b.id,
            b.refl,
            b.w,
            b.h,
            b.refl.round()
        ));
    }
    std::fs::write(&files.toml, toml)?;
    Ok(files)
}
