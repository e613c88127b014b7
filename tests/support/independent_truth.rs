//! A second, independent truth generator for the consistency workflow (GitHub issue 15).
//!
//! Written from the closed forms of `docs/physics.md` (radar §1, LiDAR §2) and the
//! hidden-effect protocol of `docs/validation.md` §8, without looking at the workflow's
//! own generator (`consistency/src/truth*.rs`) or at the effect catalogue's signatures: it shares
//! no physics code with the model or the catalogue, only the OSI messages and the trace writer.
//!
//! Each campaign is a folder with
//! * `sv.osi`: the SensorView trace (ground truth as a surveyor would log it: position jitter,
//!   target heights off by up to ±2 cm);
//! * `meas.osi`: the "measured" SensorData (the true geometry, every effect of the case, and the
//!   nuisances: Rician fluctuation and thermal noise / intensity noise, quantisation, an unknown
//!   calibration offset, ~10 % of the frames missing, no object ids);
//! * `model.osi`: the "model" SensorData, computed from the logged ground truth with the same
//!   physics minus the case's hidden effect (deterministic, with object ids);
//! * `consistency.toml` (schema `osiris.consistency/1`).
//!
//! Radar: triangular trihedrals (σ = 4πa⁴/(3λ²), Knott et al.) on posts, re-aimed at the sensor at
//! every station, seen by a 77 GHz radar on a parked host; SNR from the link budget of physics.md
//! §1.1 (worked example: 10 m² at 100 m → 25.8 dB after the FFT and beamforming gains), a CFAR-like
//! threshold of 13 dB (censors detections in deep multipath nulls), Rician fluctuation (a
//! non-fluctuating reflector plus a diffuse clutter/interference phasor of −16.5 dB) and complex
//! thermal noise added in the linear domain before dB. Reported power: an RCS estimate (the SNR
//! range-compensated with R⁴ at the measured range, boresight gain) or the SNR, per the case.
//!
//! LiDAR: Lambertian boards, free-standing (no post in the beam), facing the sensor, seen by a
//! 905 nm spinning LiDAR (0.2° rings, 0.4° columns, top-hat footprint 1.5 × 3 mrad), received
//! power P ∝ f·ρ·cosα·O(R)·T²/R² (physics.md §2.1, extended target) with f the fraction of the
//! footprint on the board; detection above a fixed threshold (a 10 % board is detected up to 100 m
//! in clear air), reported intensity = range-compensated reflectivity in % (1 DN quantisation).
//!
//! Constants marked GUESSED are not from a data sheet.

#![allow(dead_code)]

use std::f64::consts::PI;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use glam::DVec3;
use osiris::trace::OsiTraceWriter;
use osiris_proto::osi3;

// ---------------------------------------------------------------------------------------------
// Random numbers (SplitMix64 + Box–Muller): no dependency, reproducible per seed.

pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Rng {
        Rng(seed ^ 0x5DEE_CE66_D1CE_4E5B)
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.uniform()
    }
    /// Standard normal.
    pub fn normal(&mut self) -> f64 {
        let u1 = self.uniform().max(1e-300);
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (2.0 * PI * u2).cos()
    }
    /// Circular complex Gaussian with E|z|² = 1.
    pub fn cnormal(&mut self) -> C64 {
        C64::new(self.normal(), self.normal()).scale(std::f64::consts::FRAC_1_SQRT_2)
    }
}

// ---------------------------------------------------------------------------------------------
// Complex arithmetic (the two-ray sum and the Fresnel coefficient).

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct C64 {
    pub re: f64,
    pub im: f64,
}

impl C64 {
    pub const fn new(re: f64, im: f64) -> C64 {
        C64 { re, im }
    }
    pub fn expj(phi: f64) -> C64 {
        C64::new(phi.cos(), phi.sin())
    }
    pub fn add(self, o: C64) -> C64 {
        C64::new(self.re + o.re, self.im + o.im)
    }
    pub fn sub(self, o: C64) -> C64 {
        C64::new(self.re - o.re, self.im - o.im)
    }
    pub fn mul(self, o: C64) -> C64 {
        C64::new(
            self.re * o.re - self.im * o.im,
            self.re * o.im + self.im * o.re,
        )
    }
    pub fn div(self, o: C64) -> C64 {
        let d = o.re * o.re + o.im * o.im;
        C64::new(
            (self.re * o.re + self.im * o.im) / d,
            (self.im * o.re - self.re * o.im) / d,
        )
    }
    pub fn scale(self, s: f64) -> C64 {
        C64::new(self.re * s, self.im * s)
    }
    pub fn norm_sqr(self) -> f64 {
        self.re * self.re + self.im * self.im
    }
    pub fn abs(self) -> f64 {
        self.norm_sqr().sqrt()
    }
    /// Principal square root.
    pub fn sqrt(self) -> C64 {
        let r = self.abs();
        let re = ((r + self.re) * 0.5).max(0.0).sqrt();
        let im = ((r - self.re) * 0.5).max(0.0).sqrt();
        C64::new(re, if self.im < 0.0 { -im } else { im })
    }
}

// ---------------------------------------------------------------------------------------------
// OSI helpers.

fn ident(v: u64) -> Option<osi3::Identifier> {
    Some(osi3::Identifier { value: Some(v) })
}

fn stamp(t_ns: u64) -> Option<osi3::Timestamp> {
    Some(osi3::Timestamp {
        seconds: Some((t_ns / 1_000_000_000) as i64),
        nanos: Some((t_ns % 1_000_000_000) as u32),
    })
}

fn v3(p: DVec3) -> Option<osi3::Vector3d> {
    Some(osi3::Vector3d {
        x: Some(p.x),
        y: Some(p.y),
        z: Some(p.z),
    })
}

fn yaw_only(yaw: f64) -> Option<osi3::Orientation3d> {
    Some(osi3::Orientation3d {
        roll: Some(0.0),
        pitch: Some(0.0),
        yaw: Some(yaw),
    })
}

const HOST_ID: u64 = 1;
const SENSOR_ID: u64 = 10;
/// Host box: 4.5 × 1.8 × 1.5 m, centre at the origin's rear so the sensor sits at x = 0 on the
/// front bumper / roof edge.
const HOST_LEN: f64 = 4.5;
const HOST_H: f64 = 1.5;
const FRAME_DT_NS: u64 = 100_000_000;

/// The sensor mounting relative to the host's box centre (no `bbcenter_to_rear`: the host frame is
/// the box centre), for a sensor at global (0, 0, h).
fn mounting(h: f64) -> osi3::MountingPosition {
    osi3::MountingPosition {
        position: v3(DVec3::new(HOST_LEN / 2.0, 0.0, h - HOST_H / 2.0)),
        orientation: yaw_only(0.0),
    }
}

fn host_object(velocity: DVec3) -> osi3::MovingObject {
    osi3::MovingObject {
        id: ident(HOST_ID),
        base: Some(osi3::BaseMoving {
            dimension: Some(osi3::Dimension3d {
                length: Some(HOST_LEN),
                width: Some(1.8),
                height: Some(HOST_H),
            }),
            position: v3(DVec3::new(-HOST_LEN / 2.0, 0.0, HOST_H / 2.0)),
            orientation: yaw_only(0.0),
            velocity: v3(velocity),
            ..Default::default()
        }),
        r#type: Some(2), // TYPE_VEHICLE
        ..Default::default()
    }
}

/// One logged stationary object: box centre, box size (length, width, height), yaw, reference.
struct LoggedBox {
    id: u64,
    centre: DVec3,
    dims: DVec3,
    yaw: f64,
    model_reference: String,
    /// Velocity, m/s: a target that moves is logged as a moving object (OSI type OTHER) with it.
    velocity: DVec3,
}

fn sensor_view(frame: u64, h_sensor: f64, boxes: &[LoggedBox]) -> osi3::SensorView {
    sensor_view_moving(frame, h_sensor, boxes, DVec3::ZERO)
}

/// [`sensor_view`] of a host driving at `host_velocity` (global, m/s; the snapshot keeps the host
/// at the origin: each frame is a station of its own, as the targets of the clock-offset case).
fn sensor_view_moving(
    frame: u64,
    h_sensor: f64,
    boxes: &[LoggedBox],
    host_velocity: DVec3,
) -> osi3::SensorView {
    let t = frame * FRAME_DT_NS;
    let moving = boxes
        .iter()
        .filter(|b| b.velocity != DVec3::ZERO)
        .map(|b| osi3::MovingObject {
            id: ident(b.id),
            base: Some(osi3::BaseMoving {
                dimension: Some(osi3::Dimension3d {
                    length: Some(b.dims.x),
                    width: Some(b.dims.y),
                    height: Some(b.dims.z),
                }),
                position: v3(b.centre),
                orientation: yaw_only(b.yaw),
                velocity: v3(b.velocity),
                ..Default::default()
            }),
            r#type: Some(osi3::moving_object::Type::Other as i32),
            model_reference: Some(b.model_reference.clone()),
            ..Default::default()
        });
    let stationary = boxes
        .iter()
        .filter(|b| b.velocity == DVec3::ZERO)
        .map(|b| osi3::StationaryObject {
            id: ident(b.id),
            base: Some(osi3::BaseStationary {
                dimension: Some(osi3::Dimension3d {
                    length: Some(b.dims.x),
                    width: Some(b.dims.y),
                    height: Some(b.dims.z),
                }),
                position: v3(b.centre),
                orientation: yaw_only(b.yaw),
                ..Default::default()
            }),
            model_reference: Some(b.model_reference.clone()),
            ..Default::default()
        })
        .collect();
    osi3::SensorView {
        timestamp: stamp(t),
        sensor_id: ident(SENSOR_ID),
        mounting_position: Some(mounting(h_sensor)),
        host_vehicle_id: ident(HOST_ID),
        global_ground_truth: Some(osi3::GroundTruth {
            timestamp: stamp(t),
            host_vehicle_id: ident(HOST_ID),
            moving_object: std::iter::once(host_object(host_velocity))
                .chain(moving)
                .collect(),
            stationary_object: stationary,
            ..Default::default()
        }),
        ..Default::default()
    }
}

/// The SensorData of `frame` (timestamp, sensor id, mounting) carrying `feature_data`.
fn sensor_data(frame: u64, h_sensor: f64, feature_data: osi3::FeatureData) -> osi3::SensorData {
    osi3::SensorData {
        timestamp: stamp(frame * FRAME_DT_NS),
        sensor_id: ident(SENSOR_ID),
        mounting_position: Some(mounting(h_sensor)),
        feature_data: Some(feature_data),
        ..Default::default()
    }
}

fn sensor_data_radar(
    frame: u64,
    h_sensor: f64,
    dets: Vec<osi3::RadarDetection>,
) -> osi3::SensorData {
    let radar_sensor = vec![osi3::RadarDetectionData {
        detection: dets,
        ..Default::default()
    }];
    sensor_data(
        frame,
        h_sensor,
        osi3::FeatureData {
            radar_sensor,
            ..Default::default()
        },
    )
}

fn sensor_data_lidar(
    frame: u64,
    h_sensor: f64,
    dets: Vec<osi3::LidarDetection>,
) -> osi3::SensorData {
    let lidar_sensor = vec![osi3::LidarDetectionData {
        detection: dets,
        ..Default::default()
    }];
    sensor_data(
        frame,
        h_sensor,
        osi3::FeatureData {
            lidar_sensor,
            ..Default::default()
        },
    )
}

fn spherical(p: DVec3) -> Option<osi3::Spherical3d> {
    let r = p.length();
    Some(osi3::Spherical3d {
        distance: Some(r),
        azimuth: Some(p.y.atan2(p.x)),
        elevation: Some((p.z / r).asin()),
    })
}

fn write_trace<M: prost::Message>(path: &Path, msgs: &[M]) -> anyhow::Result<()> {
    let mut w = OsiTraceWriter::create(path)?;
    for m in msgs {
        w.write_message(m)?;
    }
    w.finish()?;
    Ok(())
}

/// What a generated campaign is.
#[derive(Debug, Clone)]
pub struct Written {
    /// `consistency.toml`.
    pub meta: PathBuf,
    /// The model's SensorData trace (for `--simulated`).
    pub model_trace: PathBuf,
    /// The hidden effect, as a short description (the answer key stays with the test).
    pub hidden: String,
    /// The hidden effect's value in its catalogue parameter's unit, where it has one (radar yaw
    /// misalignment: deg; radar clock offset: ms).
    pub hidden_value: Option<f64>,
    pub frames: usize,
    pub dropped_frames: usize,
}

/// Writes the campaign's `toml` as `consistency.toml` into `dir` and names what was written (the
/// model trace `model.osi` beside it, the hidden case and its value, the frames logged and lost).
fn write_campaign(
    dir: &Path,
    toml: String,
    hidden: &str,
    hidden_value: Option<f64>,
    frames: usize,
    dropped: usize,
) -> anyhow::Result<Written> {
    let meta = dir.join("consistency.toml");
    std::fs::write(&meta, toml)?;
    Ok(Written {
        meta,
        model_trace: dir.join("model.osi"),
        hidden: hidden.into(),
        hidden_value,
        frames,
        dropped_frames: dropped,
    })
}

fn db(x: f64) -> f64 {
    10.0 * x.log10()
}

fn undb(x: f64) -> f64 {
    10f64.powf(x / 10.0)
}

// ---------------------------------------------------------------------------------------------
// Radar.

/// Hidden-effect cases of the radar campaigns.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RadarCase {
    /// Two-ray road multipath, two-way (measured ×|F|⁴).
    GroundMultipath,
    /// The model spreads with R⁻² instead of R⁻⁴.
    TwoWaySpreading,
    /// The model's RCS ∝ face area¹ instead of area².
    RcsAreaScaling,
    /// The measurement has the Gaussian azimuth pattern, the model an isotropic antenna.
    AntennaPattern,
    /// ITU-R P.838-3 rain attenuation at 77 GHz, two-way.
    Rain,
    /// Nothing hidden.
    Null,
    /// Range-FFT scalloping (no window, no peak interpolation): not in the catalogue.
    OutOfCatalogue,
    /// The measuring radar is turned by 0.5–1.0° (either side) from its nominal mounting: it
    /// measures in its true frame and reports in the nominal one.
    YawMisalignment,
    /// The measuring radar's clock is 40–80 ms (either sign) off the ground truth's; the targets
    /// move (approaching, receding, crossing).
    TimeOffset,
}

impl RadarCase {
    pub const ALL: [RadarCase; 9] = [
        RadarCase::GroundMultipath,
        RadarCase::TwoWaySpreading,
        RadarCase::RcsAreaScaling,
        RadarCase::AntennaPattern,
        RadarCase::Rain,
        RadarCase::Null,
        RadarCase::OutOfCatalogue,
        RadarCase::YawMisalignment,
        RadarCase::TimeOffset,
    ];
    pub fn name(self) -> &'static str {
        match self {
            RadarCase::GroundMultipath => "ground_multipath",
            RadarCase::TwoWaySpreading => "two_way_spreading",
            RadarCase::RcsAreaScaling => "rcs_area_scaling",
            RadarCase::AntennaPattern => "antenna_pattern",
            RadarCase::Rain => "rain",
            RadarCase::Null => "null",
            RadarCase::OutOfCatalogue => "out_of_catalogue",
            RadarCase::YawMisalignment => "yaw_misalignment",
            RadarCase::TimeOffset => "time_offset",
        }
    }
}

/// 77 GHz.
pub const RADAR_FREQ_HZ: f64 = 77.0e9;
pub const C0: f64 = 299_792_458.0;
/// λ at 77 GHz, m (3.893 mm).
pub fn radar_lambda() -> f64 {
    C0 / RADAR_FREQ_HZ
}
/// SNR of σ = 10 m² at 100 m after range/Doppler FFT and 12-channel beamforming, dB (physics.md
/// §1.1 worked example: 15.0 + 10.8).
pub const SNR_REF_DB: f64 = 25.8;
/// CFAR-like detection threshold on the SNR, dB (CA-CFAR N = 24 at P_FA 1e-6 needs 12.7 dB:
/// physics.md §1.7).
pub const DET_THRESHOLD_DB: f64 = 13.0;
/// One-way 3 dB beamwidths, deg (GUESSED: a typical long/mid-range automotive radar).
pub const AZ_BW_DEG: f64 = 20.0;
pub const EL_BW_DEG: f64 = 12.0;
/// Road (asphalt) relative permittivity at 77 GHz (GUESSED, after Sarabandi et al. 1997, UNVERIFIED
/// in physics.md §1.3); e^{jωt} convention: ε' − jε''.
pub const EPS_ASPHALT: C64 = C64::new(3.18, -0.1);
/// ITU-R P.838-3 at 77 GHz, horizontal polarisation (physics.md §1.4).
pub const RAIN_K_H: f64 = 1.1320;
pub const RAIN_ALPHA_H: f64 = 0.7177;
/// Range resolution c/(2B) for B = 1 GHz, m (the scalloping period of the out-of-catalogue case).
pub const RANGE_BIN_M: f64 = C0 / 2.0 / 1.0e9;
/// Sensor mounting height, m (front bumper).
pub const RADAR_MOUNT_H: f64 = 0.5;

/// ITU-R P.838-3 specific attenuation, one-way dB/km, horizontal polarisation, horizontal path.
pub fn rain_db_per_km(rain_mm_h: f64) -> f64 {
    RAIN_K_H * rain_mm_h.powf(RAIN_ALPHA_H)
}

/// GO peak RCS of a triangular trihedral of edge a, m².
pub fn trihedral_rcs(edge_m: f64) -> f64 {
    4.0 * PI * edge_m.powi(4) / (3.0 * radar_lambda().powi(2))
}

/// Fresnel reflection coefficient for horizontal (TE, E parallel to the road) polarisation at
/// grazing angle ψ (physics.md §1.3).
pub fn fresnel_h(psi: f64, eps: C64) -> C64 {
    let s = C64::new(psi.sin(), 0.0);
    let root = eps.sub(C64::new(psi.cos().powi(2), 0.0)).sqrt();
    s.sub(root).div(s.add(root))
}

/// One-way Gaussian field (voltage) pattern: power pattern exp(−4 ln2 (θ/θ₃)²).
fn field_pattern(theta_deg: f64, bw_deg: f64) -> f64 {
    (-2.0 * 2f64.ln() * (theta_deg / bw_deg).powi(2)).exp()
}

/// The one-way pattern-propagation factor of the two-ray model, from the sensor phase centre to the
/// reflector's apex (phase centre) over a flat road at z = 0:
/// F = 1 + Γ(ψ)·(g(θ_img)/g(θ_dir))·(R_d/R_r)·e^{−jk(R_r − R_d)}.
pub fn two_ray_factor(sensor: DVec3, apex: DVec3, eps: C64) -> C64 {
    let d = (apex - sensor).truncate().length();
    let (hs, ht) = (sensor.z, apex.z);
    let r_d = (d * d + (ht - hs).powi(2)).sqrt();
    let r_r = (d * d + (ht + hs).powi(2)).sqrt();
    let psi = ((ht + hs) / d).atan();
    let th_dir = ((ht - hs) / d).atan().to_degrees();
    let th_img = (-(ht + hs) / d).atan().to_degrees();
    let k = 2.0 * PI / radar_lambda();
    let g = field_pattern(th_img, EL_BW_DEG) / field_pattern(th_dir, EL_BW_DEG);
    let gamma = fresnel_h(psi, eps);
    C64::new(1.0, 0.0).add(gamma.mul(C64::expj(-k * (r_r - r_d))).scale(g * r_d / r_r))
}

/// The physics switches of one radar simulation.
#[derive(Debug, Clone, Copy)]
struct RadarPhysics {
    /// Spreading exponent of the received power (4 = two-way).
    spreading: f64,
    /// RCS ∝ area^area_exp (2 = physical).
    area_exp: f64,
    azimuth_pattern: bool,
    multipath: Option<C64>,
    rain_db_km: f64,
    scalloping: bool,
}

/// SNR of a trihedral (dB) with apex at `apex`, facing the sensor.
fn radar_snr_db(p: &RadarPhysics, sensor: DVec3, apex: DVec3, edge: f64) -> f64 {
    let rel = apex - sensor;
    let r = rel.length();
    let az = rel.y.atan2(rel.x).to_degrees();
    let el = (rel.z / r).asin().to_degrees();
    // σ ∝ a⁴ physically; the area¹ bug keeps σ at a = 0.1 m and scales with (a²)¹.
    let sigma = trihedral_rcs(0.1) * (edge * edge / 0.01).powf(p.area_exp);
    let mut snr = SNR_REF_DB + db(sigma / 10.0) - 10.0 * p.spreading * (r / 100.0).log10();
    // Two-way: the power goes with g⁴ of the one-way field pattern g, and with |F|⁴.
    snr += 4.0 * db(field_pattern(el, EL_BW_DEG));
    if p.azimuth_pattern {
        snr += 4.0 * db(field_pattern(az, AZ_BW_DEG));
    }
    if let Some(eps) = p.multipath {
        snr += 4.0 * db(two_ray_factor(sensor, apex, eps).abs());
    }
    snr -= 2.0 * p.rain_db_km * r / 1000.0;
    if p.scalloping {
        // Rectangular window, no interpolation: the peak bin sees sinc²(δ), δ = offset from the
        // nearest bin centre in bins (−3.92 dB at δ = ½).
        let x = r / RANGE_BIN_M;
        let delta = x - x.round();
        let sinc = if delta.abs() < 1e-12 {
            1.0
        } else {
            (PI * delta).sin() / (PI * delta)
        };
        snr += db(sinc * sinc);
    }
    snr
}

struct Trihedral {
    id: u64,
    edge: f64,
    /// Height of the box top (reflector top on its post) above the road, as surveyed, m.
    top_logged: f64,
    /// True top height (surveyed ± up to 2 cm).
    top_true: f64,
}

/// A trihedral's box: its own bounding box (the posts are absorber-covered and not part of the
/// logged object: `mount=none`): x extent a/√3 (the corner at the back), y extent √2·a, z extent
/// 3a/√6 (one inner edge points up at 2a/√6 above the apex; the other two point down at −a/√6).
/// In its object frame the apex (inner corner, the phase centre) is at x = −a/(2√3) (the back of
/// the box) and a/(2√6) below the box centre, i.e. 2a/√6 below the top.
fn trihedral_dims(edge: f64) -> DVec3 {
    DVec3::new(
        edge / 3f64.sqrt(),
        2f64.sqrt() * edge,
        3.0 * edge / 6f64.sqrt(),
    )
}

/// The box centre height of a trihedral whose top is at `top` above the road.
fn trihedral_centre_z(edge: f64, top: f64) -> f64 {
    top - 1.5 * edge / 6f64.sqrt()
}

fn apex_from_box(centre: DVec3, yaw: f64, edge: f64) -> DVec3 {
    let back = DVec3::new(yaw.cos(), yaw.sin(), 0.0) * (-edge / (2.0 * 3f64.sqrt()));
    centre + back - DVec3::Z * (edge / (2.0 * 6f64.sqrt()))
}

/// A radar station: per target placed, (target index, horizontal range of the box centre, azimuth
/// deg). The sensor is at (0, 0, mount_h) looking along +x.
struct RadarStation {
    placed: Vec<(usize, f64, f64)>,
}

struct RadarDesign {
    edges: Vec<f64>,
    /// Apex heights, m (per target).
    apex_h: Vec<f64>,
    stations: Vec<RadarStation>,
    frames_per_station: usize,
    rain_mm_h: f64,
    asphalt: bool,
    snr_semantics: bool,
}

fn radar_design(case: RadarCase, rng: &mut Rng) -> RadarDesign {
    let mut stations = Vec::new();
    let slot_cycle = |n: usize, k: usize, i: usize| -> usize { (i + k) % n };
    match case {
        RadarCase::GroundMultipath => {
            // Three reflectors at apex heights 0.45 / 0.65 / 0.85 m, 10–60 m in 0.25 m steps, at
            // azimuths −4° / 0° / +4° and 0 / 1 / 2 m further (slots rotated between stations):
            // separated in range, so a radar that cannot resolve 4° in azimuth still sees each
            // reflector on its own.
            let az = [-4.0, 0.0, 4.0];
            for k in 0..=200usize {
                let r = 10.0 + 0.25 * k as f64;
                stations.push(RadarStation {
                    placed: (0..3)
                        .map(|i| {
                            let slot = slot_cycle(3, k, i);
                            (i, r + slot as f64, az[slot])
                        })
                        .collect(),
                });
            }
            RadarDesign {
                edges: vec![0.1, 0.1, 0.1],
                apex_h: vec![0.45, 0.65, 0.85],
                stations,
                frames_per_station: 3,
                rain_mm_h: 0.0,
                asphalt: true,
                snr_semantics: false,
            }
        }
        RadarCase::RcsAreaScaling => {
            let az = [-12.0, -6.0, 0.0, 6.0, 12.0];
            for k in 0..26usize {
                let r = 10.0 + 2.0 * k as f64;
                stations.push(RadarStation {
                    placed: (0..5).map(|i| (i, r, az[slot_cycle(5, k, i)])).collect(),
                });
            }
            RadarDesign {
                edges: vec![0.05, 0.08, 0.10, 0.12, 0.15],
                apex_h: vec![0.6; 5],
                stations,
                frames_per_station: 3,
                rain_mm_h: 0.0,
                asphalt: false,
                snr_semantics: false,
            }
        }
        RadarCase::AntennaPattern => {
            // A fan of nine azimuth slots ±20°, three reflectors rotated over them, 10–30 m.
            let az: Vec<f64> = (0..9).map(|i| -20.0 + 5.0 * i as f64).collect();
            for k in 0..45usize {
                let r = 10.0 + 20.0 * (k / 9) as f64 / 4.0;
                stations.push(RadarStation {
                    placed: (0..3).map(|i| (i, r, az[(3 * i + k) % 9])).collect(),
                });
            }
            RadarDesign {
                edges: vec![0.10, 0.12, 0.15],
                apex_h: vec![0.6; 3],
                stations,
                frames_per_station: 3,
                rain_mm_h: 0.0,
                asphalt: false,
                snr_semantics: false,
            }
        }
        RadarCase::Rain => {
            let az = [-6.0, 0.0, 6.0];
            for k in 0..36usize {
                let r = 10.0 + 4.0 * k as f64;
                stations.push(RadarStation {
                    placed: (0..3).map(|i| (i, r, az[slot_cycle(3, k, i)])).collect(),
                });
            }
            RadarDesign {
                edges: vec![0.12, 0.15, 0.20],
                apex_h: vec![0.6; 3],
                stations,
                frames_per_station: 3,
                rain_mm_h: 50.0,
                asphalt: false,
                snr_semantics: true,
            }
        }
        RadarCase::OutOfCatalogue => {
            // Random ranges (no grid that would alias the range bins).
            let az = [-6.0, 0.0, 6.0];
            for k in 0..60usize {
                stations.push(RadarStation {
                    placed: (0..3)
                        .map(|i| (i, rng.range(8.0, 80.0), az[slot_cycle(3, k, i)]))
                        .collect(),
                });
            }
            RadarDesign {
                edges: vec![0.08, 0.10, 0.15],
                apex_h: vec![0.6; 3],
                stations,
                frames_per_station: 3,
                rain_mm_h: 0.0,
                asphalt: false,
                snr_semantics: false,
            }
        }
        RadarCase::YawMisalignment => {
            // Five azimuth slots ±16° and ranges 8–63 m: a yaw moves every target by one angle,
            // a lateral offset by one that falls as 1/R, an azimuth scale by one that grows with
            // the azimuth.
            let az = [-16.0, -8.0, 0.0, 8.0, 16.0];
            for k in 0..30usize {
                let r = 8.0 + 52.0 * k as f64 / 29.0;
                // 0 / 1.5 / 3 m apart in range: a radar that cannot resolve 8° in azimuth still
                // sees each reflector on its own.
                stations.push(RadarStation {
                    placed: (0..3)
                        .map(|i| (i, r + 1.5 * i as f64, az[(2 * i + k) % 5]))
                        .collect(),
                });
            }
            RadarDesign {
                edges: vec![0.08, 0.10, 0.15],
                apex_h: vec![0.6; 3],
                stations,
                frames_per_station: 3,
                rain_mm_h: 0.0,
                asphalt: false,
                snr_semantics: false,
            }
        }
        RadarCase::TwoWaySpreading | RadarCase::Null | RadarCase::TimeOffset => {
            let az = [-6.0, 0.0, 6.0];
            for k in 0..40usize {
                let r = 5.0 * 1.08f64.powi(k as i32);
                stations.push(RadarStation {
                    placed: (0..3).map(|i| (i, r, az[slot_cycle(3, k, i)])).collect(),
                });
            }
            RadarDesign {
                edges: vec![0.08, 0.10, 0.15],
                apex_h: vec![0.6; 3],
                stations,
                frames_per_station: 3,
                rain_mm_h: 0.0,
                asphalt: false,
                snr_semantics: false,
            }
        }
    }
}

/// Writes a radar campaign for `case` and `seed` into `dir` (ground truth: 2 cm position jitter
/// per station, target heights off by up to ±2 cm).
pub fn radar_campaign(case: RadarCase, seed: u64, dir: &Path) -> anyhow::Result<Written> {
    radar_campaign_surveyed(case, seed, dir, 0.02, 0.02)
}

/// [`radar_campaign`] with the ground truth's per-station position jitter σ (m) and the bound of
/// the targets' height errors (m) as given (a better survey).
pub fn radar_campaign_surveyed(
    case: RadarCase,
    seed: u64,
    dir: &Path,
    pos_sigma: f64,
    height_error: f64,
) -> anyhow::Result<Written> {
    std::fs::create_dir_all(dir)?;
    let mut rng = Rng::new(seed.wrapping_mul(7919).wrapping_add(case as u64));
    let design = radar_design(case, &mut rng);
    let h_s = RADAR_MOUNT_H;
    let sensor = DVec3::new(0.0, 0.0, h_s);

    let truth = RadarPhysics {
        spreading: 4.0,
        area_exp: 2.0,
        azimuth_pattern: true,
        multipath: design.asphalt.then_some(EPS_ASPHALT),
        rain_db_km: rain_db_per_km(design.rain_mm_h),
        scalloping: case == RadarCase::OutOfCatalogue,
    };
    // The measuring radar's hidden yaw (rad) and clock offset (s), and the targets' motion: in
    // the time-offset case target 0 approaches and target 1 recedes along the line of sight at
    // 6 m/s, target 2 crosses at 5 m/s.
    let sign = |rng: &mut Rng| if rng.uniform() < 0.5 { -1.0 } else { 1.0 };
    let yaw_true = if case == RadarCase::YawMisalignment {
        (sign(&mut rng) * rng.range(0.5, 1.0)).to_radians()
    } else {
        0.0
    };
    let clock_s = if case == RadarCase::TimeOffset {
        sign(&mut rng) * rng.range(0.04, 0.08)
    } else {
        0.0
    };
    let motion = |ti: usize, az: f64| -> DVec3 {
        if case != RadarCase::TimeOffset {
            return DVec3::ZERO;
        }
        let los = DVec3::new(az.cos(), az.sin(), 0.0);
        match ti {
            0 => -6.0 * los,
            1 => 6.0 * los,
            _ => 5.0 * DVec3::new(-az.sin(), az.cos(), 0.0),
        }
    };
    let model = RadarPhysics {
        spreading: if case == RadarCase::TwoWaySpreading {
            2.0
        } else {
            4.0
        },
        area_exp: if case == RadarCase::RcsAreaScaling {
            1.0
        } else {
            2.0
        },
        azimuth_pattern: case != RadarCase::AntennaPattern,
        multipath: None,
        rain_db_km: 0.0,
        scalloping: false,
    };
    // Nuisances.
    let cal_db = rng.range(-3.0, 3.0);
    let targets: Vec<Trihedral> = design
        .edges
        .iter()
        .zip(&design.apex_h)
        .enumerate()
        .map(|(i, (&edge, &apex))| {
            let top = apex + 2.0 * edge / 6f64.sqrt();
            Trihedral {
                id: 100 + i as u64,
                edge,
                top_logged: top,
                top_true: top + rng.range(-height_error, height_error),
            }
        })
        .collect();
    let report = |snr_db: f64, range_m: f64| -> f64 {
        if design.snr_semantics {
            snr_db
        } else {
            // RCS estimate: σ = 10 m² · SNR/SNR_ref · (R/100 m)⁴, boresight gain assumed.
            snr_db - SNR_REF_DB + 10.0 + 40.0 * (range_m / 100.0).log10()
        }
    };

    let mut views = Vec::new();
    let mut meas = Vec::new();
    let mut sims = Vec::new();
    let mut frame = 0u64;
    let mut dropped = 0usize;
    for st in &design.stations {
        for _ in 0..design.frames_per_station {
            let mut logged = Vec::new();
            let mut m_dets = Vec::new();
            let mut s_dets = Vec::new();
            for &(ti, r, az_deg) in &st.placed {
                let t = &targets[ti];
                let az = az_deg.to_radians();
                // Re-aimed at the sensor: +x of the object points back to the sensor.
                let yaw = az + PI;
                let c_true = DVec3::new(
                    r * az.cos(),
                    r * az.sin(),
                    trihedral_centre_z(t.edge, t.top_true),
                );
                let target_velocity = motion(ti, az);
                let apex_true = apex_from_box(c_true, yaw, t.edge);
                let jitter = DVec3::new(rng.normal(), rng.normal(), rng.normal()) * pos_sigma;
                let c_log =
                    DVec3::new(c_true.x, c_true.y, trihedral_centre_z(t.edge, t.top_logged))
                        + jitter;
                logged.push(LoggedBox {
                    id: t.id,
                    centre: c_log,
                    dims: trihedral_dims(t.edge),
                    yaw,
                    // Posts are absorber-covered (not part of the radar scene): `mount=none`.
                    model_reference: format!("osiris:trihedral?edge_m={}&mount=none", t.edge),
                    velocity: target_velocity,
                });
                // Model: from the logged box (apex at the back of the box, 2a/√6 below its top).
                let apex_log = apex_from_box(c_log, yaw, t.edge);
                let rel = apex_log - sensor;
                let snr_s = radar_snr_db(&model, sensor, apex_log, t.edge);
                // OSI radial velocity: positive towards the sensor.
                let towards = |rel: DVec3| -rel.normalize().dot(target_velocity);
                if snr_s >= DET_THRESHOLD_DB {
                    s_dets.push(osi3::RadarDetection {
                        object_id: ident(t.id),
                        position: spherical(rel),
                        radial_velocity: Some(towards(rel)),
                        rcs: (!design.snr_semantics).then(|| report(snr_s, rel.length())),
                        snr: design.snr_semantics.then_some(snr_s),
                        existence_probability: Some(1.0),
                        ..Default::default()
                    });
                }
                // Measurement: Rician target + complex noise in the linear domain, threshold,
                // noisy range / azimuth, quantised power, calibration offset, no object id.
                // The measuring radar: the target where it is `clock_s` later, seen from a frame
                // turned by `yaw_true` about the vertical through the sensor.
                let apex_true = sensor
                    + glam::DMat3::from_rotation_z(-yaw_true)
                        * (apex_true + target_velocity * clock_s - sensor);
                let snr_t = radar_snr_db(&truth, sensor, apex_true, t.edge);
                let amp = undb(snr_t).sqrt();
                let clutter = rng.cnormal().scale(0.15);
                let noise = rng.cnormal();
                let snr_m = db(C64::new(1.0, 0.0)
                    .add(clutter)
                    .scale(amp)
                    .add(noise)
                    .norm_sqr());
                if snr_m >= DET_THRESHOLD_DB {
                    let rel_t = apex_true - sensor;
                    let r_m = rel_t.length() + 0.04 * rng.normal();
                    let az_m = rel_t.y.atan2(rel_t.x) + (0.2f64).to_radians() * rng.normal();
                    let el_m =
                        (rel_t.z / rel_t.length()).asin() + (0.5f64).to_radians() * rng.normal();
                    let value = ((report(snr_m, r_m) + cal_db) * 2.0).round() / 2.0;
                    m_dets.push(osi3::RadarDetection {
                        position: Some(osi3::Spherical3d {
                            distance: Some(r_m),
                            azimuth: Some(az_m),
                            elevation: Some(el_m),
                        }),
                        radial_velocity: Some(towards(rel_t) + 0.03 * rng.normal()),
                        rcs: (!design.snr_semantics).then_some(value),
                        snr: design.snr_semantics.then_some(value),
                        existence_probability: Some(1.0),
                        ..Default::default()
                    });
                }
            }
            views.push(sensor_view(frame, h_s, &logged));
            sims.push(sensor_data_radar(frame, h_s, s_dets));
            if rng.uniform() < 0.10 {
                dropped += 1;
            } else {
                meas.push(sensor_data_radar(frame, h_s, m_dets));
            }
            frame += 1;
        }
    }
    write_trace(&dir.join("sv.osi"), &views)?;
    write_trace(&dir.join("meas.osi"), &meas)?;
    write_trace(&dir.join("model.osi"), &sims)?;

    let toml = radar_toml(
        &format!("independent-radar-{}-{seed}", case.name()),
        &format!(
            "independent truth generator (tests/support/independent_truth.rs): trihedrals, hidden case `{}`",
            case.name()
        ),
        power_semantics(design.snr_semantics),
        design.rain_mm_h,
        if design.asphalt {
            "asphalt"
        } else {
            "absorber mats (no ground reflection)"
        },
        pos_sigma,
        &trihedral_targets_toml(&targets),
    );
    write_campaign(
        dir,
        toml,
        case.name(),
        match case {
            RadarCase::YawMisalignment => Some(yaw_true.to_degrees()),
            RadarCase::TimeOffset => Some(1e3 * clock_s),
            _ => None,
        },
        frame as usize,
        dropped,
    )
}

/// The power semantics of the trihedral campaigns: the SNR, or an RCS estimate assuming the
/// boresight gain.
fn power_semantics(snr: bool) -> &'static str {
    if snr {
        "snr = \"processed SNR in dB after range/Doppler FFT and beamforming; unknown calibration offset\""
    } else {
        "rcs = \"RCS estimate in dBsm: SNR range-compensated with R^4 at the measured range, boresight gain, unknown calibration offset, 0.5 dB steps\""
    }
}

/// The `consistency.toml` of a radar campaign (`sv.osi`, `meas.osi` in its folder): the sensor as
/// the generator's radar, `semantics` the `[sensor.quantity_semantics]` line, `targets` the
/// `[[target]]` tables.
fn radar_toml(
    id: &str,
    description: &str,
    semantics: &str,
    rain_mm_h: f64,
    ground: &str,
    pos_sigma: f64,
    targets: &str,
) -> String {
    let h_s = RADAR_MOUNT_H;
    format!(
        r#"schema = "osiris.consistency/1"

[run]
id = "{id}"
description = "{description}"
provenance = "synthetic"
licence = "MPL-2.0"

[sensor]
kind = "radar"
osi_sensor_id = {SENSOR_ID}
mounting_position_m = [{mx}, 0.0, {mz}]
mounting_orientation_rad = [0.0, 0.0, 0.0]
frequency_hz = {RADAR_FREQ_HZ:e}
bandwidth_hz = 1e9
mounting_height_m = {h_s}
polarisation = "horizontal"
antenna_beamwidth_az_deg = {AZ_BW_DEG}
antenna_beamwidth_el_deg = {EL_BW_DEG}
detection_threshold_db = {DET_THRESHOLD_DB}

[sensor.quantity_semantics]
{semantics}

[environment]
rain_mm_h = {rain_mm_h}
ground = "{ground}"

[uncertainty]
gt_position_sigma_m = {pos_sigma}
gt_height_sigma_m = 0.0115

[association]
method = "gating"

[bins]
explanatory = ["range", "azimuth", "area"]

[traces]
sensor_view = "sv.osi"
sensor_data = "meas.osi"

{targets}"#,
        mx = HOST_LEN / 2.0,
        mz = h_s - HOST_H / 2.0,
    )
}

// ---------------------------------------------------------------------------------------------
// Radar: online calibration, road clutter, diffuse scattering (issue 19).

/// Writes the three traces of a radar campaign into `dir`.
fn write_radar_traces(
    dir: &Path,
    views: &[osi3::SensorView],
    meas: &[osi3::SensorData],
    sims: &[osi3::SensorData],
) -> anyhow::Result<()> {
    write_trace(&dir.join("sv.osi"), views)?;
    write_trace(&dir.join("meas.osi"), meas)?;
    write_trace(&dir.join("model.osi"), sims)
}

/// The `[[target]]` tables of trihedrals.
fn trihedral_targets_toml(targets: &[Trihedral]) -> String {
    targets
        .iter()
        .map(|t| {
            format!(
                "[[target]]\nid = {}\nkind = \"trihedral\"\nedge_m = {}\nmaterial = \"aluminium\"\norientation = \"facing the sensor\"\n\n",
                t.id, t.edge
            )
        })
        .collect()
}

/// Three trihedrals (edges 10, 12, 15 cm, apexes 0.6 m up), their surveyed tops off by up to
/// `height_error`.
fn three_trihedrals(rng: &mut Rng, height_error: f64) -> Vec<Trihedral> {
    [0.10, 0.12, 0.15]
        .iter()
        .enumerate()
        .map(|(i, &edge)| {
            let top = 0.6 + 2.0 * edge / 6f64.sqrt();
            Trihedral {
                id: 100 + i as u64,
                edge,
                top_logged: top,
                top_true: top + rng.range(-height_error, height_error),
            }
        })
        .collect()
}

/// A detection at `rel` (sensor → scatterer in the radar's own axes) with the noise of the
/// generator's radar: range 4 cm, azimuth 0.2°, elevation 0.5°, radial velocity `rv_sigma`.
fn noisy_detection(
    rng: &mut Rng,
    rel: DVec3,
    radial_velocity: f64,
    rv_sigma: f64,
    rcs: f64,
) -> osi3::RadarDetection {
    let r = rel.length();
    osi3::RadarDetection {
        position: Some(osi3::Spherical3d {
            distance: Some(r + 0.04 * rng.normal()),
            azimuth: Some(rel.y.atan2(rel.x) + 0.2f64.to_radians() * rng.normal()),
            elevation: Some((rel.z / r).asin() + 0.5f64.to_radians() * rng.normal()),
        }),
        radial_velocity: Some(radial_velocity + rv_sigma * rng.normal()),
        rcs: Some(rcs),
        existence_probability: Some(1.0),
        ..Default::default()
    }
}

/// The measured power of a return of mean SNR `snr_db` (linear sum of the reflector with its
/// −16.5 dB Rician phasor, an extra circular Gaussian term of mean SNR `diffuse_snr` (linear) and
/// unit thermal noise), dB; and the reported RCS estimate with the calibration offset, 0.5 dB steps.
fn measured_rcs(
    rng: &mut Rng,
    snr_db: f64,
    diffuse_snr: f64,
    range_m: f64,
    cal_db: f64,
) -> (f64, f64) {
    let amp = undb(snr_db).sqrt();
    let clutter = rng.cnormal().scale(0.15);
    let diffuse = rng.cnormal().scale(diffuse_snr.sqrt());
    let noise = rng.cnormal();
    let snr_m = db(C64::new(1.0, 0.0)
        .add(clutter)
        .scale(amp)
        .add(diffuse)
        .add(noise)
        .norm_sqr());
    let rcs = snr_m - SNR_REF_DB + 10.0 + 40.0 * (range_m / 100.0).log10() + cal_db;
    (snr_m, (rcs * 2.0).round() / 2.0)
}

/// Hidden-effect cases of the online-calibration campaigns: the host stands for the first 40 % of
/// the stations, then drives at 12 m/s past the trihedrals (9–16° either side of boresight).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CalibrationCase {
    /// The measuring radar is turned by 0.5–1° and corrects its azimuths online from the Doppler
    /// of the stationary targets (physics.md §7.3) once the host drives; the model trace has the
    /// same (surveyed) yaw and no online calibration.
    SelfCalibrating,
    /// As `SelfCalibrating`, but the model trace has the nominal mounting: a yaw error and the
    /// online calibration together.
    YawAndSelfCalibrating,
    /// The measuring radar is turned by 0.5–1° and does not calibrate itself; model nominal.
    YawOnly,
    /// A self-calibrating radar without misalignment; model nominal: nothing hidden.
    Null,
}

impl CalibrationCase {
    pub const ALL: [CalibrationCase; 4] = [
        CalibrationCase::SelfCalibrating,
        CalibrationCase::YawAndSelfCalibrating,
        CalibrationCase::YawOnly,
        CalibrationCase::Null,
    ];
    pub fn name(self) -> &'static str {
        match self {
            CalibrationCase::SelfCalibrating => "self_calibrating",
            CalibrationCase::YawAndSelfCalibrating => "yaw_and_self_calibrating",
            CalibrationCase::YawOnly => "yaw_standing_and_driving",
            CalibrationCase::Null => "self_calibrating_null",
        }
    }
}

/// Host speed of the driving part of the calibration campaigns, m/s.
pub const CALIBRATION_SPEED_M_S: f64 = 12.0;
/// Radial-velocity noise of the calibration campaigns' radar, m/s (GUESSED: an interpolated
/// high-SNR peak is good to a few mm/s).
pub const CALIBRATION_RV_SIGMA_M_S: f64 = 0.01;

/// The generator's own online azimuth calibration (written from physics.md §7.3, not from the
/// model): per cycle of a host faster than 1 m/s, over the detections at least 3° off boresight
/// (at least two), Gauss–Newton on ṙ_towards = v·cos φ_m·cos(θ_m + δ) (OSI sign: positive
/// towards the sensor, host driving along +x at v) from the running estimate; the cycle's δ enters
/// a weighted mean with the weight Σ(∂ṙ/∂δ)². The cycle's own detections are corrected with the
/// estimate that includes them. All gates GUESSED.
#[derive(Default)]
struct SelfCalibration {
    sum_w: f64,
    sum_wd: f64,
}

impl SelfCalibration {
    fn estimate(&self) -> f64 {
        if self.sum_w > 0.0 {
            self.sum_wd / self.sum_w
        } else {
            0.0
        }
    }

    fn update(&mut self, v: f64, dets: &[osi3::RadarDetection]) {
        if v < 1.0 {
            return;
        }
        let used: Vec<(f64, f64, f64)> = dets
            .iter()
            .filter_map(|d| {
                let p = d.position?;
                let (az, el) = (p.azimuth?, p.elevation?);
                (az.abs() >= 3f64.to_radians()).then_some((az, el, d.radial_velocity?))
            })
            .collect();
        if used.len() < 2 {
            return;
        }
        let mut delta = self.estimate();
        let mut weight = 0.0;
        for _ in 0..4 {
            let (mut sgr, mut sgg) = (0.0, 0.0);
            for &(az, el, rv) in &used {
                let r = rv - v * el.cos() * (az + delta).cos();
                let g = -v * el.cos() * (az + delta).sin();
                sgr += g * r;
                sgg += g * g;
            }
            delta += sgr / sgg;
            weight = sgg;
        }
        self.sum_w += weight;
        self.sum_wd += weight * delta;
    }
}

/// Writes an online-calibration campaign (ground truth: 2 cm position jitter per frame, target
/// heights off by up to ±2 cm): three trihedrals at 9–16° either side of boresight and 8–51 m,
/// 40 stations of 3 frames, the host standing for the first 16, then driving at 12 m/s (its
/// velocity logged; the snapshots keep it at the origin), both parts over the whole range span;
/// ~10 % of the measured frames missing.
pub fn radar_calibration_campaign(
    case: CalibrationCase,
    seed: u64,
    dir: &Path,
) -> anyhow::Result<Written> {
    std::fs::create_dir_all(dir)?;
    let mut rng = Rng::new(seed.wrapping_mul(6151).wrapping_add(case as u64 + 40));
    let (pos_sigma, height_error) = (0.02, 0.02);
    let h_s = RADAR_MOUNT_H;
    let sensor = DVec3::new(0.0, 0.0, h_s);
    let sign = if rng.uniform() < 0.5 { -1.0 } else { 1.0 };
    let yaw_true = if case == CalibrationCase::Null {
        0.0
    } else {
        (sign * rng.range(0.5, 1.0)).to_radians()
    };
    let self_calibrating = case != CalibrationCase::YawOnly;
    // The yaw the model trace is simulated with (the surveyed mounting error).
    let yaw_model = if case == CalibrationCase::SelfCalibrating {
        yaw_true
    } else {
        0.0
    };
    let physics = RadarPhysics {
        spreading: 4.0,
        area_exp: 2.0,
        azimuth_pattern: true,
        multipath: None,
        rain_db_km: 0.0,
        scalloping: false,
    };
    let cal_db = rng.range(-3.0, 3.0);
    let targets = three_trihedrals(&mut rng, height_error);
    let az: [f64; 4] = [-16.0, -9.0, 9.0, 16.0];
    let stations = 40usize;
    let standing = 16usize;
    let mut calibration = SelfCalibration::default();
    let (mut views, mut meas, mut sims) = (Vec::new(), Vec::new(), Vec::new());
    let (mut frame, mut dropped) = (0u64, 0usize);
    for k in 0..stations {
        let v = if k < standing {
            0.0
        } else {
            CALIBRATION_SPEED_M_S
        };
        let host_v = DVec3::new(v, 0.0, 0.0);
        // Ranges in a stride-17 order over the 40 stations, so that the standing and the driving
        // stations each span 8–48 m (a lateral offset, ∝ 1/R, cannot pass for the phase).
        let r0 = 8.0 + 40.0 * ((17 * k) % stations) as f64 / (stations - 1) as f64;
        for _ in 0..3 {
            let (mut logged, mut m_dets, mut s_dets) = (Vec::new(), Vec::new(), Vec::new());
            for (i, t) in targets.iter().enumerate() {
                let a = az[(i + k) % 4].to_radians();
                let r = r0 + 1.5 * i as f64;
                let yaw = a + PI;
                let c_true = DVec3::new(
                    r * a.cos(),
                    r * a.sin(),
                    trihedral_centre_z(t.edge, t.top_true),
                );
                let jitter = DVec3::new(rng.normal(), rng.normal(), rng.normal()) * pos_sigma;
                let c_log =
                    DVec3::new(c_true.x, c_true.y, trihedral_centre_z(t.edge, t.top_logged))
                        + jitter;
                logged.push(LoggedBox {
                    id: t.id,
                    centre: c_log,
                    dims: trihedral_dims(t.edge),
                    yaw,
                    model_reference: format!("osiris:trihedral?edge_m={}&mount=none", t.edge),
                    velocity: DVec3::ZERO,
                });
                // A stationary target seen from a host moving at v: OSI radial velocity (towards
                // the sensor) v·u.
                let towards = |rel: DVec3| rel.normalize().dot(host_v);
                // Model: from the logged box, in the frame turned by the model's yaw.
                let rel_log = apex_from_box(c_log, yaw, t.edge) - sensor;
                let rel_s = glam::DMat3::from_rotation_z(-yaw_model) * rel_log;
                let snr_s = radar_snr_db(&physics, sensor, sensor + rel_s, t.edge);
                if snr_s >= DET_THRESHOLD_DB {
                    let rcs = snr_s - SNR_REF_DB + 10.0 + 40.0 * (rel_s.length() / 100.0).log10();
                    s_dets.push(osi3::RadarDetection {
                        object_id: ident(t.id),
                        position: spherical(rel_s),
                        radial_velocity: Some(towards(rel_log)),
                        rcs: Some(rcs),
                        existence_probability: Some(1.0),
                        ..Default::default()
                    });
                }
                // Measurement: the true apex in the radar's frame turned by the true yaw; the
                // Doppler is the host's motion along the true line of sight.
                let rel_world = apex_from_box(c_true, yaw, t.edge) - sensor;
                let rel_t = glam::DMat3::from_rotation_z(-yaw_true) * rel_world;
                let snr_t = radar_snr_db(&physics, sensor, sensor + rel_t, t.edge);
                let (snr_m, rcs) = measured_rcs(&mut rng, snr_t, 0.0, rel_t.length(), cal_db);
                if snr_m >= DET_THRESHOLD_DB {
                    m_dets.push(noisy_detection(
                        &mut rng,
                        rel_t,
                        towards(rel_world),
                        CALIBRATION_RV_SIGMA_M_S,
                        rcs,
                    ));
                }
            }
            // The radar calibrates itself every cycle (also those whose log is lost).
            if self_calibrating {
                calibration.update(v, &m_dets);
                let delta = calibration.estimate();
                for d in &mut m_dets {
                    if let Some(p) = d.position.as_mut() {
                        p.azimuth = p.azimuth.map(|a| a + delta);
                    }
                }
            }
            views.push(sensor_view_moving(frame, h_s, &logged, host_v));
            sims.push(sensor_data_radar(frame, h_s, s_dets));
            if rng.uniform() < 0.10 {
                dropped += 1;
            } else {
                meas.push(sensor_data_radar(frame, h_s, m_dets));
            }
            frame += 1;
        }
    }
    write_radar_traces(dir, &views, &meas, &sims)?;
    let toml = radar_toml(
        &format!("independent-radar-{}-{seed}", case.name()),
        &format!(
            "independent truth generator (tests/support/independent_truth.rs): trihedrals, host standing then driving, hidden case `{}`",
            case.name()
        ),
        power_semantics(false),
        0.0,
        "absorber mats (no ground reflection)",
        pos_sigma,
        &trihedral_targets_toml(&targets),
    );
    write_campaign(
        dir,
        toml,
        case.name(),
        (case != CalibrationCase::Null).then(|| yaw_true.to_degrees()),
        frame as usize,
        dropped,
    )
}

/// Hidden-effect cases of the road-clutter campaigns (a parked radar 0.5 m over asphalt, three
/// trihedrals at 20–60 m).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ClutterCase {
    /// The measuring radar sees the road's constant-γ backscatter (γ = −24…−18 dB); the model
    /// trace has no road clutter.
    RoadClutter,
    /// Neither has road clutter.
    Null,
    /// About 20 false alarms per frame spread uniformly over 0–60 m and ±40° (interference-like),
    /// no road clutter.
    FalseAlarms,
}

impl ClutterCase {
    pub fn name(self) -> &'static str {
        match self {
            ClutterCase::RoadClutter => "road_clutter",
            ClutterCase::Null => "clutter_null",
            ClutterCase::FalseAlarms => "uniform_false_alarms",
        }
    }
}

/// Azimuth cells of the generator's radar for the road, deg: 10° wide (a 12-channel array resolves
/// ≈ 9.5°, physics.md §1.6) across ±40° (GUESSED).
pub const CLUTTER_CELL_DEG: f64 = 10.0;
pub const CLUTTER_FOV_DEG: f64 = 40.0;

/// The measured road-clutter detections of one frame (physics.md §1.9, written here from the
/// closed forms): every resolution cell (range bin of c/2B = 15 cm from 1 to 60 m × azimuth cell)
/// of a flat road at z = 0 seen from `sensor` returns σ = γ·sin ψ·R·ΔR·Δφ with sin ψ = h/R, a
/// circular Gaussian amplitude of mean SNR S̄ from the link budget (two-way Gaussian azimuth and
/// elevation patterns at the cell's direction), plus unit thermal noise; a cell whose power exceeds
/// the threshold is one detection (no peak grouping, GUESSED) at the cell's centre.
fn road_clutter_detections(
    rng: &mut Rng,
    sensor: DVec3,
    gamma: f64,
    cal_db: f64,
) -> Vec<osi3::RadarDetection> {
    let h = sensor.z;
    let threshold = undb(DET_THRESHOLD_DB);
    let dphi = CLUTTER_CELL_DEG.to_radians();
    let n_az = (2.0 * CLUTTER_FOV_DEG / CLUTTER_CELL_DEG).round() as usize;
    let mut out = Vec::new();
    let mut r = 1.0 + 0.5 * RANGE_BIN_M;
    while r < 60.0 {
        let psi = (h / r).asin();
        let sigma = gamma * psi.sin() * r * RANGE_BIN_M * dphi;
        for j in 0..n_az {
            let phi = -CLUTTER_FOV_DEG.to_radians() + (j as f64 + 0.5) * dphi;
            let mut snr = SNR_REF_DB + db(sigma / 10.0) - 40.0 * (r / 100.0).log10();
            snr += 4.0 * db(field_pattern(phi.to_degrees(), AZ_BW_DEG));
            snr += 4.0 * db(field_pattern(-psi.to_degrees(), EL_BW_DEG));
            let mean = undb(snr);
            // Below T/40 a cell exceeds T with probability < e^-40: not drawn.
            if mean < threshold / 40.0 {
                continue;
            }
            let p = rng
                .cnormal()
                .scale(mean.sqrt())
                .add(rng.cnormal())
                .norm_sqr();
            if p >= threshold {
                let rel = DVec3::new(r * psi.cos() * phi.cos(), r * psi.cos() * phi.sin(), -h);
                let rcs = db(p) - SNR_REF_DB + 10.0 + 40.0 * (r / 100.0).log10() + cal_db;
                out.push(noisy_detection(
                    rng,
                    rel,
                    0.0,
                    0.03,
                    (rcs * 2.0).round() / 2.0,
                ));
            }
        }
        r += RANGE_BIN_M;
    }
    out
}

/// Writes a road-clutter campaign: a parked radar 0.5 m over a flat asphalt road, three trihedrals
/// at ±6° and 0°, 20–60 m (beyond the clutter, so that no clutter detection is taken for a
/// target), 30 stations of 4 frames, 2 cm ground-truth jitter, ~10 % of the measured frames
/// missing. `hidden_value`: γ in dB.
pub fn radar_clutter_campaign(case: ClutterCase, seed: u64, dir: &Path) -> anyhow::Result<Written> {
    std::fs::create_dir_all(dir)?;
    let mut rng = Rng::new(seed.wrapping_mul(4271).wrapping_add(case as u64 + 60));
    let (pos_sigma, height_error) = (0.02, 0.02);
    let h_s = RADAR_MOUNT_H;
    let sensor = DVec3::new(0.0, 0.0, h_s);
    let gamma_db = rng.range(-24.0, -18.0);
    let physics = RadarPhysics {
        spreading: 4.0,
        area_exp: 2.0,
        azimuth_pattern: true,
        multipath: None,
        rain_db_km: 0.0,
        scalloping: false,
    };
    let cal_db = rng.range(-3.0, 3.0);
    let targets = three_trihedrals(&mut rng, height_error);
    let az: [f64; 3] = [-6.0, 0.0, 6.0];
    let (mut views, mut meas, mut sims) = (Vec::new(), Vec::new(), Vec::new());
    let (mut frame, mut dropped) = (0u64, 0usize);
    for k in 0..30usize {
        let r0 = 20.0 + 40.0 * k as f64 / 29.0;
        for _ in 0..4 {
            let (mut logged, mut m_dets, mut s_dets) = (Vec::new(), Vec::new(), Vec::new());
            for (i, t) in targets.iter().enumerate() {
                let a = az[(i + k) % 3].to_radians();
                let r = r0 + 1.5 * i as f64;
                let yaw = a + PI;
                let c_true = DVec3::new(
                    r * a.cos(),
                    r * a.sin(),
                    trihedral_centre_z(t.edge, t.top_true),
                );
                let jitter = DVec3::new(rng.normal(), rng.normal(), rng.normal()) * pos_sigma;
                let c_log =
                    DVec3::new(c_true.x, c_true.y, trihedral_centre_z(t.edge, t.top_logged))
                        + jitter;
                logged.push(LoggedBox {
                    id: t.id,
                    centre: c_log,
                    dims: trihedral_dims(t.edge),
                    yaw,
                    model_reference: format!("osiris:trihedral?edge_m={}&mount=none", t.edge),
                    velocity: DVec3::ZERO,
                });
                let rel_s = apex_from_box(c_log, yaw, t.edge) - sensor;
                let snr_s = radar_snr_db(&physics, sensor, sensor + rel_s, t.edge);
                if snr_s >= DET_THRESHOLD_DB {
                    let rcs = snr_s - SNR_REF_DB + 10.0 + 40.0 * (rel_s.length() / 100.0).log10();
                    s_dets.push(osi3::RadarDetection {
                        object_id: ident(t.id),
                        position: spherical(rel_s),
                        radial_velocity: Some(0.0),
                        rcs: Some(rcs),
                        existence_probability: Some(1.0),
                        ..Default::default()
                    });
                }
                let rel_t = apex_from_box(c_true, yaw, t.edge) - sensor;
                let snr_t = radar_snr_db(&physics, sensor, sensor + rel_t, t.edge);
                let (snr_m, rcs) = measured_rcs(&mut rng, snr_t, 0.0, rel_t.length(), cal_db);
                if snr_m >= DET_THRESHOLD_DB {
                    m_dets.push(noisy_detection(&mut rng, rel_t, 0.0, 0.03, rcs));
                }
            }
            match case {
                ClutterCase::RoadClutter => m_dets.extend(road_clutter_detections(
                    &mut rng,
                    sensor,
                    undb(gamma_db),
                    cal_db,
                )),
                ClutterCase::FalseAlarms => {
                    // Poisson(20) by inversion.
                    let (mut n, mut p, l) = (0usize, rng.uniform(), (-20.0f64).exp());
                    while p > l {
                        p *= rng.uniform();
                        n += 1;
                    }
                    for _ in 0..n {
                        let (r, phi) = (rng.range(0.0, 60.0), rng.range(-40.0, 40.0).to_radians());
                        let rel = DVec3::new(r * phi.cos(), r * phi.sin(), 0.0);
                        let rcs = rng.range(-40.0, -20.0);
                        m_dets.push(noisy_detection(&mut rng, rel, 0.0, 0.03, rcs));
                    }
                }
                ClutterCase::Null => {}
            }
            views.push(sensor_view(frame, h_s, &logged));
            sims.push(sensor_data_radar(frame, h_s, s_dets));
            if rng.uniform() < 0.10 {
                dropped += 1;
            } else {
                meas.push(sensor_data_radar(frame, h_s, m_dets));
            }
            frame += 1;
        }
    }
    write_radar_traces(dir, &views, &meas, &sims)?;
    let toml = radar_toml(
        &format!("independent-radar-{}-{seed}", case.name()),
        &format!(
            "independent truth generator (tests/support/independent_truth.rs): parked radar over asphalt, trihedrals, hidden case `{}`",
            case.name()
        ),
        power_semantics(false),
        0.0,
        "asphalt",
        pos_sigma,
        &trihedral_targets_toml(&targets),
    );
    write_campaign(
        dir,
        toml,
        case.name(),
        (case == ClutterCase::RoadClutter).then_some(gamma_db),
        frame as usize,
        dropped,
    )
}

/// Hidden-effect cases of the board campaigns (rough metal boards turned 4–48° from the line of
/// sight).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BoardCase {
    /// The boards' surfaces are rough (σ_h = 0.2–0.5 mm): the measurement has the incoherent
    /// (diffuse) term, the model trace only the coherent one.
    DiffuseScattering,
    /// Smooth boards: nothing hidden.
    Null,
}

impl BoardCase {
    pub fn name(self) -> &'static str {
        match self {
            BoardCase::DiffuseScattering => "diffuse_scattering",
            BoardCase::Null => "boards_null",
        }
    }
}

/// Coherent RCS of a flat metal board of width `w` and height `h` turned by `aspect` (rad) about
/// its vertical axis from the line of sight, tilted to face the radar in elevation, with an rms
/// surface height `sigma_h` (m), m²: physical optics σ = (4π(wh)²/λ²)·cos²α·S(kw·sin α) (Knott,
/// Shaeffer & Tuley, *Radar Cross Section*, 2nd ed., ch. 5, the flat plate), the sinc² lobes
/// replaced by S(x) = 1/(1 + 2x²), their mean 1/(2x²) beyond the main lobe: a 1 GHz sweep moves a
/// lobe by 1.3 % of x, and the 2 cm survey by ≈ 1 lobe at 10°, so station-by-station lobes are not
/// reproducible (GUESSED interpolation); times the Ament coherent loss exp(−(2kσ_h cos α)²).
pub fn board_coherent_rcs(w: f64, h: f64, aspect: f64, sigma_h: f64) -> f64 {
    let k = 2.0 * PI / radar_lambda();
    let x = k * w * aspect.sin();
    4.0 * PI * (w * h).powi(2) / radar_lambda().powi(2) * aspect.cos().powi(2) / (1.0 + 2.0 * x * x)
        * (-(2.0 * k * sigma_h * aspect.cos()).powi(2)).exp()
}

/// Incoherent RCS of the same board, m²: Lambert's law on the power the roughness takes from the
/// coherent reflection (metal, |Γ|² = 1), σ⁰ = 4(1 − e^{−(2kσ_h cos α)²})·cos²α, over the face
/// area w·h (physics.md §1.9).
pub fn board_diffuse_rcs(w: f64, h: f64, aspect: f64, sigma_h: f64) -> f64 {
    let k = 2.0 * PI / radar_lambda();
    4.0 * (1.0 - (-(2.0 * k * sigma_h * aspect.cos()).powi(2)).exp()) * aspect.cos().powi(2) * w * h
}

/// Writes a board campaign: three metal boards (0.3 × 0.5, 0.4 × 0.4, 0.5 × 0.3 m, centres at the
/// sensor's height, tilted to face it in elevation) at −6°, 0°, +6°, 8–16 m, each turned 4–48°
/// (in 4° steps, either side) from the line of sight, 72 stations of 3 frames, RCS reported, 2 cm
/// ground-truth jitter, ~10 % of the measured frames missing. `hidden_value`: σ_h in mm.
pub fn radar_board_campaign(case: BoardCase, seed: u64, dir: &Path) -> anyhow::Result<Written> {
    std::fs::create_dir_all(dir)?;
    let mut rng = Rng::new(seed.wrapping_mul(3571).wrapping_add(case as u64 + 80));
    let pos_sigma = 0.02;
    let h_s = RADAR_MOUNT_H;
    let sensor = DVec3::new(0.0, 0.0, h_s);
    let sigma_h = match case {
        BoardCase::DiffuseScattering => rng.range(0.2e-3, 0.5e-3),
        BoardCase::Null => 0.0,
    };
    let cal_db = rng.range(-3.0, 3.0);
    let boards = [(0.3, 0.5), (0.4, 0.4), (0.5, 0.3)];
    let az: [f64; 3] = [-6.0, 0.0, 6.0];
    // SNR of an RCS σ at `rel` (sensor → board centre) by the link budget of physics.md §1.1 with
    // the two-way Gaussian patterns.
    let snr_of = |sigma: f64, rel: DVec3| {
        let r = rel.length();
        let (a, e) = (
            rel.y.atan2(rel.x).to_degrees(),
            (rel.z / r).asin().to_degrees(),
        );
        SNR_REF_DB + db(sigma / 10.0) - 40.0 * (r / 100.0).log10()
            + 4.0 * db(field_pattern(a, AZ_BW_DEG))
            + 4.0 * db(field_pattern(e, EL_BW_DEG))
    };
    let (mut views, mut meas, mut sims) = (Vec::new(), Vec::new(), Vec::new());
    let (mut frame, mut dropped) = (0u64, 0usize);
    for k in 0..72usize {
        let r0 = [8.0, 12.0, 16.0][(k / 12) % 3];
        for _ in 0..3 {
            let (mut logged, mut m_dets, mut s_dets) = (Vec::new(), Vec::new(), Vec::new());
            for (i, &(w, h)) in boards.iter().enumerate() {
                let a = az[(i + k) % 3].to_radians();
                let r = r0 + 1.5 * i as f64;
                // Aspect 4–48°, one side or the other by station.
                let side = if (k / 36) % 2 == 0 { 1.0 } else { -1.0 };
                let aspect = side * (4.0 + 4.0 * ((k + 4 * i) % 12) as f64).to_radians();
                let yaw = a + PI + aspect;
                let c_true = DVec3::new(r * a.cos(), r * a.sin(), h_s);
                let jitter = DVec3::new(rng.normal(), rng.normal(), rng.normal()) * pos_sigma;
                let c_log = c_true + jitter;
                logged.push(LoggedBox {
                    id: 100 + i as u64,
                    centre: c_log,
                    dims: DVec3::new(0.01, w, h),
                    yaw,
                    model_reference: format!(
                        "osiris:board?width_m={w}&height_m={h}&material=aluminium&mount=none"
                    ),
                    velocity: DVec3::ZERO,
                });
                // The aspect as each side sees it: the board's normal against the line of sight.
                let aspect_of = |c: DVec3| {
                    let normal = DVec3::new(yaw.cos(), yaw.sin(), 0.0);
                    let to_sensor = (sensor - c).truncate().normalize().extend(0.0);
                    normal.dot(to_sensor).clamp(-1.0, 1.0).acos()
                };
                // The RCS estimate: the SNR less that of 1 m² at the detected position.
                let rel_s = c_log - sensor;
                let snr_s = snr_of(board_coherent_rcs(w, h, aspect_of(c_log), sigma_h), rel_s);
                if snr_s >= DET_THRESHOLD_DB {
                    let rcs = snr_s - snr_of(1.0, rel_s);
                    s_dets.push(osi3::RadarDetection {
                        object_id: ident(100 + i as u64),
                        position: spherical(rel_s),
                        radial_velocity: Some(0.0),
                        rcs: Some(rcs),
                        existence_probability: Some(1.0),
                        ..Default::default()
                    });
                }
                let rel_t = c_true - sensor;
                let alpha = aspect_of(c_true);
                let snr_c = snr_of(board_coherent_rcs(w, h, alpha, sigma_h), rel_t);
                let snr_d = undb(snr_of(board_diffuse_rcs(w, h, alpha, sigma_h), rel_t));
                let (snr_m, _) = measured_rcs(&mut rng, snr_c, snr_d, rel_t.length(), 0.0);
                if snr_m >= DET_THRESHOLD_DB {
                    let rcs = ((snr_m - snr_of(1.0, rel_t) + cal_db) * 2.0).round() / 2.0;
                    m_dets.push(noisy_detection(&mut rng, rel_t, 0.0, 0.03, rcs));
                }
            }
            views.push(sensor_view(frame, h_s, &logged));
            sims.push(sensor_data_radar(frame, h_s, s_dets));
            if rng.uniform() < 0.10 {
                dropped += 1;
            } else {
                meas.push(sensor_data_radar(frame, h_s, m_dets));
            }
            frame += 1;
        }
    }
    write_radar_traces(dir, &views, &meas, &sims)?;
    let targets: String = boards
        .iter()
        .enumerate()
        .map(|(i, (w, h))| {
            format!(
                "[[target]]\nid = {}\nkind = \"board\"\nsize_m = [{w}, {h}]\nmaterial = \"aluminium\"\norientation = \"turned 4-48 deg from the line of sight\"\n\n",
                100 + i
            )
        })
        .collect();
    let toml = radar_toml(
        &format!("independent-radar-{}-{seed}", case.name()),
        &format!(
            "independent truth generator (tests/support/independent_truth.rs): metal boards turned off the line of sight, hidden case `{}`",
            case.name()
        ),
        "rcs = \"RCS estimate in dBsm: SNR range-compensated with R^4 and the antenna gains at the detected angle, unknown calibration offset, 0.5 dB steps\"",
        0.0,
        "absorber mats (no ground reflection)",
        pos_sigma,
        &targets,
    );
    write_campaign(
        dir,
        toml,
        case.name(),
        (case == BoardCase::DiffuseScattering).then_some(sigma_h * 1e3),
        frame as usize,
        dropped,
    )
}

// ---------------------------------------------------------------------------------------------
// LiDAR.

/// Hidden-effect cases of the LiDAR campaigns.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LidarCase {
    /// Biaxial transmitter/receiver overlap O(R) (physics.md §2.3), exact circle–circle form.
    Overlap,
    /// Beer–Lambert two-way extinction in fog of visibility V (Koschmieder, Kim q = 0 below 0.5 km).
    Fog,
    /// The measured beam has a vertical divergence; the model's beam is a line in elevation.
    VerticalDivergence,
    Null,
    /// The boards' true reflectivities are off their labels by a random factor per board.
    OutOfCatalogue,
    /// The receiver's linear range ends at a received power P_sat: the measured echo is
    /// min(P, P_sat) (APD / TIA clipping); the model's receiver is linear.
    Saturation,
    /// The sensor is turned 0.5–1° (either sign) about its vertical axis from its nominal
    /// mounting: it fires in its true frame and reports in the nominal one.
    YawMisalignment,
}

impl LidarCase {
    pub const ALL: [LidarCase; 7] = [
        LidarCase::Overlap,
        LidarCase::Fog,
        LidarCase::VerticalDivergence,
        LidarCase::Null,
        LidarCase::OutOfCatalogue,
        LidarCase::Saturation,
        LidarCase::YawMisalignment,
    ];
    pub fn name(self) -> &'static str {
        match self {
            LidarCase::Overlap => "overlap",
            LidarCase::Fog => "fog",
            LidarCase::VerticalDivergence => "vertical_divergence",
            LidarCase::Null => "null",
            LidarCase::OutOfCatalogue => "out_of_catalogue",
            LidarCase::Saturation => "saturation",
            LidarCase::YawMisalignment => "yaw_misalignment",
        }
    }
}

/// Ring spacing and column step, deg (GUESSED: a 128-ring class sensor in its dense band).
pub const LIDAR_RING_STEP_DEG: f64 = 0.2;
pub const LIDAR_RINGS: usize = 128;
pub const LIDAR_RING0_DEG: f64 = -15.0;
pub const LIDAR_COL_STEP_DEG: f64 = 0.4;
/// Full-angle footprint divergence, mrad (VLS-128: 3.0 H × 1.5 V per physics.md §2.7; here the
/// vertical one is the larger, GUESSED, so the DIVP "vertical divergence" effect is visible).
pub const LIDAR_DIV_H_MRAD: f64 = 1.5;
pub const LIDAR_DIV_V_MRAD: f64 = 3.0;
/// Saturation power of the `Saturation` case, in the units of the threshold below: the echo of a
/// 50 % board at 10 m (GUESSED: a 90 % board clips inside 13.4 m, a 10 % one inside 4.5 m).
pub const LIDAR_SATURATION_POWER: f64 = 0.5 / (10.0 * 10.0);

/// Detection threshold on ρ·f·cosα·O·T²/R² (a 10 % board is detected to 100 m in clear air).
pub const LIDAR_THRESHOLD: f64 = 0.1 / (100.0 * 100.0);
/// Sensor height, m (roof).
pub const LIDAR_MOUNT_H: f64 = 1.6;
/// Fog visibility of the fog case, m.
pub const FOG_VISIBILITY_M: f64 = 200.0;

/// Extinction coefficient at 905 nm, 1/m, from the visibility (Koschmieder 3.912/V with Kim's
/// wavelength exponent; q = 0 for V < 500 m, physics.md §2.4).
pub fn fog_extinction_per_m(vis_m: f64) -> f64 {
    let v_km = vis_m / 1000.0;
    let q = if v_km > 50.0 {
        1.6
    } else if v_km > 6.0 {
        1.3
    } else if v_km > 1.0 {
        0.16 * v_km + 0.34
    } else if v_km > 0.5 {
        v_km - 0.5
    } else {
        0.0
    };
    3.912 / vis_m * (905.0f64 / 550.0).powf(-q)
}

/// Biaxial overlap O(R) (physics.md §2.3): transmitter radius r_t0 + Rθ_t/2, receiver field of view
/// r_r0 + Rθ_r/2, axis separation d₀ (parallel axes), O = A_overlap/(π r_t²). The example set of
/// physics.md: r_t0 = 2.5 mm, θ_t = 3 mrad, r_r0 = 12.5 mm, θ_r = 10 mrad, d₀ = 25 mm.
pub fn overlap(range_m: f64) -> f64 {
    let (rt0, tht, rr0, thr, d) = (0.0025, 0.003, 0.0125, 0.010, 0.025);
    let rt = rt0 + range_m * tht / 2.0;
    let rr = rr0 + range_m * thr / 2.0;
    if d >= rt + rr {
        return 0.0;
    }
    if d <= (rr - rt).abs() {
        return (rt.min(rr) / rt).powi(2);
    }
    let a1 = rt
        * rt
        * ((d * d + rt * rt - rr * rr) / (2.0 * d * rt))
            .clamp(-1.0, 1.0)
            .acos();
    let a2 = rr
        * rr
        * ((d * d + rr * rr - rt * rt) / (2.0 * d * rr))
            .clamp(-1.0, 1.0)
            .acos();
    let a3 = 0.5
        * ((-d + rt + rr) * (d + rt - rr) * (d - rt + rr) * (d + rt + rr))
            .max(0.0)
            .sqrt();
    ((a1 + a2 - a3) / (PI * rt * rt)).clamp(0.0, 1.0)
}

#[derive(Debug, Clone, Copy)]
struct LidarPhysics {
    overlap: bool,
    extinction_per_m: f64,
    div_v_mrad: f64,
}

struct Board {
    id: u64,
    width: f64,
    height: f64,
    /// Labelled reflectivity, %.
    refl_label: f64,
    /// True reflectivity, %.
    refl_true: f64,
    /// Centre height above the road, m.
    z: f64,
}

struct LidarDesign {
    boards: Vec<Board>,
    /// Stations: per board placed, (board index, horizontal range, azimuth deg).
    stations: Vec<Vec<(usize, f64, f64)>>,
    frames_per_station: usize,
    fog_vis_m: f64,
}

fn lidar_design(case: LidarCase, rng: &mut Rng) -> LidarDesign {
    let board = |id: u64, w: f64, h: f64, refl: f64, z: f64| Board {
        id,
        width: w,
        height: h,
        refl_label: refl,
        refl_true: refl,
        z,
    };
    let triple = |ranges: &[f64], lateral: f64| -> Vec<Vec<(usize, f64, f64)>> {
        // Three boards side by side, `lateral` m apart, at each range (rotated between stations).
        ranges
            .iter()
            .enumerate()
            .map(|(k, &r)| {
                (0..3)
                    .map(|i| {
                        let y = lateral * (((i + k) % 3) as f64 - 1.0);
                        (i, r.hypot(y), y.atan2(r).to_degrees())
                    })
                    .collect()
            })
            .collect()
    };
    match case {
        LidarCase::Overlap => {
            let ranges = [
                2.0, 2.25, 2.5, 2.75, 3.0, 3.25, 3.5, 4.0, 4.5, 5.0, 6.0, 7.0, 8.0, 10.0, 12.0,
                15.0, 20.0, 25.0,
            ];
            LidarDesign {
                boards: vec![
                    board(200, 0.5, 0.5, 10.0, 1.4),
                    board(201, 0.5, 0.5, 50.0, 1.5),
                    board(202, 0.5, 0.5, 90.0, 1.6),
                ],
                stations: triple(&ranges, 0.8),
                frames_per_station: 3,
                fog_vis_m: f64::INFINITY,
            }
        }
        LidarCase::Fog => {
            let ranges: Vec<f64> = (0..10).map(|k| 5.0 + 5.0 * k as f64).collect();
            LidarDesign {
                boards: vec![
                    board(200, 0.5, 0.5, 10.0, 1.4),
                    board(201, 0.5, 0.5, 50.0, 1.5),
                    board(202, 0.5, 0.5, 90.0, 1.6),
                ],
                stations: triple(&ranges, 1.5),
                frames_per_station: 3,
                fog_vis_m: FOG_VISIBILITY_M,
            }
        }
        LidarCase::VerticalDivergence => {
            let ranges: Vec<f64> = (0..12).map(|k| 5.0 + 5.0 * k as f64).collect();
            LidarDesign {
                boards: vec![
                    board(200, 0.5, 0.3, 50.0, 1.5),
                    board(201, 0.5, 0.5, 50.0, 1.5),
                    board(202, 0.5, 1.0, 50.0, 1.5),
                ],
                stations: triple(&ranges, 1.5),
                frames_per_station: 3,
                fog_vis_m: f64::INFINITY,
            }
        }
        LidarCase::YawMisalignment => {
            // Three boards 25° apart in azimuth at each range (rotated between stations), so that
            // a turned sensor's points cannot be taken for a neighbour's.
            let ranges: Vec<f64> = (0..10).map(|k| 5.0 + 5.0 * k as f64).collect();
            let stations = ranges
                .iter()
                .enumerate()
                .map(|(k, &r)| {
                    (0..3)
                        .map(|i| (i, r, 25.0 * (((i + k) % 3) as f64 - 1.0)))
                        .collect()
                })
                .collect();
            LidarDesign {
                boards: vec![
                    board(200, 0.5, 0.5, 10.0, 1.4),
                    board(201, 0.5, 0.5, 50.0, 1.5),
                    board(202, 0.5, 0.5, 90.0, 1.6),
                ],
                stations,
                frames_per_station: 3,
                fog_vis_m: f64::INFINITY,
            }
        }
        LidarCase::Null | LidarCase::OutOfCatalogue | LidarCase::Saturation => {
            let ranges: Vec<f64> = (0..10).map(|k| 5.0 + 5.0 * k as f64).collect();
            let mut boards = vec![
                board(200, 0.5, 0.5, 10.0, 1.4),
                board(201, 0.5, 0.5, 50.0, 1.5),
                board(202, 0.5, 0.5, 90.0, 1.6),
                board(203, 0.5, 0.5, 10.0, 1.6),
                board(204, 0.5, 0.5, 50.0, 1.4),
                board(205, 0.5, 0.5, 90.0, 1.5),
            ];
            if case == LidarCase::OutOfCatalogue {
                // Dirty / aged boards: true reflectivity off the label by a log-normal factor of
                // 2 dB σ per board (not in any catalogue entry: the model trusts the labels).
                for b in &mut boards {
                    b.refl_true = b.refl_label * undb(2.0 * rng.normal());
                }
            }
            let mut stations = triple(&ranges, 1.5);
            for st in triple(&ranges, 1.5) {
                stations.push(
                    st.into_iter()
                        .map(|(i, r, a)| (i + 3, r + 2.5, a))
                        .collect(),
                );
            }
            LidarDesign {
                boards,
                stations,
                frames_per_station: 3,
                fog_vis_m: f64::INFINITY,
            }
        }
    }
}

/// One LiDAR return: (beam id, ring elevation, column azimuth, range along the beam, relative
/// power ρ·f·cosα·O·T²/R² with ρ a fraction, reported reflectivity %).
struct Return {
    beam: u64,
    dir: DVec3,
    range: f64,
    power: f64,
}

/// Traces the beams that can reach a board (centre `c`, facing yaw, w × h) from the sensor at
/// `o`; returns the returns above zero power (before thresholding).
fn trace_board(
    p: &LidarPhysics,
    o: DVec3,
    c: DVec3,
    yaw: f64,
    w: f64,
    h: f64,
    refl_pct: f64,
) -> Vec<Return> {
    let n = DVec3::new(yaw.cos(), yaw.sin(), 0.0);
    let u_axis = DVec3::new(-yaw.sin(), yaw.cos(), 0.0);
    let rel = c - o;
    let dist = rel.length();
    let margin = 0.5 * (w.hypot(h)) + 0.01 * dist + 0.05;
    let half_ang = (margin / dist).atan();
    let el_c = (rel.z / dist).asin();
    let az_c = rel.y.atan2(rel.x);
    let col_step = LIDAR_COL_STEP_DEG.to_radians();
    let ncols = (2.0 * PI / col_step).round() as i64;
    let mut out = Vec::new();
    for ring in 0..LIDAR_RINGS {
        let el = (LIDAR_RING0_DEG + LIDAR_RING_STEP_DEG * ring as f64).to_radians();
        if (el - el_c).abs() > half_ang {
            continue;
        }
        let j0 = ((az_c - half_ang) / col_step).floor() as i64;
        let j1 = ((az_c + half_ang) / col_step).ceil() as i64;
        for j in j0..=j1 {
            let az = j as f64 * col_step;
            let d = DVec3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin());
            let denom = n.dot(d);
            if denom.abs() < 1e-6 {
                continue;
            }
            let t = n.dot(rel) / denom;
            if t <= 0.0 {
                continue;
            }
            let hit = o + d * t - c;
            let (u, v) = (hit.dot(u_axis), hit.z);
            // Top-hat footprint, full angles.
            let fu = 0.5 * LIDAR_DIV_H_MRAD * 1e-3 * t;
            let fv = 0.5 * p.div_v_mrad * 1e-3 * t;
            let frac = |x: f64, f: f64, half: f64| -> f64 {
                if f <= 0.0 {
                    return if x.abs() <= half { 1.0 } else { 0.0 };
                }
                let lo = (x - f).max(-half);
                let hi = (x + f).min(half);
                ((hi - lo) / (2.0 * f)).clamp(0.0, 1.0)
            };
            let f = frac(u, fu, w / 2.0) * frac(v, fv, h / 2.0);
            if f <= 0.0 {
                continue;
            }
            let cos_a = denom.abs();
            let ovl = if p.overlap { overlap(t) } else { 1.0 };
            let trans2 = (-2.0 * p.extinction_per_m * t).exp();
            let power = refl_pct / 100.0 * f * cos_a * ovl * trans2 / (t * t);
            let col = j.rem_euclid(ncols) as u64;
            out.push(Return {
                beam: ring as u64 * ncols as u64 + col,
                dir: d,
                range: t,
                power,
            });
        }
    }
    out
}

/// The part of a board campaign's `consistency.toml` that the pulsed and the FMCW LiDAR campaigns
/// share: ground-truth uncertainty, association by object id and beam, bins, traces.
fn board_campaign_tail(pos_sigma: f64) -> String {
    format!(
        r#"[uncertainty]
gt_position_sigma_m = {pos_sigma}
gt_height_sigma_m = 0.0115

[association]
method = "object_id"
pairing = "beam_id"

[bins]
explanatory = ["range", "reflectivity", "height"]

[traces]
sensor_view = "sv.osi"
sensor_data = "meas.osi"

"#
    )
}

/// The frames of a board campaign: per station and frame, every board placed at its true centre
/// (board height + `height_err`) and logged at that centre with the board's nominal height and a
/// jitter of `pos_sigma` per axis; `per_board(rng, board, true centre, logged centre, yaw,
/// measured, simulated)` adds the board's detections to either side. 10 % of the measured frames
/// are dropped. Writes `sv.osi`, `meas.osi` and `model.osi` into `dir`; returns the frame count
/// and the dropped frames.
fn write_board_frames(
    dir: &Path,
    design: &LidarDesign,
    height_err: &[f64],
    pos_sigma: f64,
    rng: &mut Rng,
    mut per_board: impl FnMut(
        &mut Rng,
        &Board,
        DVec3,
        DVec3,
        f64,
        &mut Vec<osi3::LidarDetection>,
        &mut Vec<osi3::LidarDetection>,
    ),
) -> anyhow::Result<(u64, usize)> {
    let h_s = LIDAR_MOUNT_H;
    let mut views = Vec::new();
    let mut meas = Vec::new();
    let mut sims = Vec::new();
    let mut frame = 0u64;
    let mut dropped = 0usize;
    for st in &design.stations {
        for _ in 0..design.frames_per_station {
            let mut logged = Vec::new();
            let mut m_dets = Vec::new();
            let mut s_dets = Vec::new();
            for &(bi, r, az_deg) in st {
                let b = &design.boards[bi];
                let az = az_deg.to_radians();
                let yaw = az + PI;
                let c_true = DVec3::new(r * az.cos(), r * az.sin(), b.z + height_err[bi]);
                let jitter = DVec3::new(rng.normal(), rng.normal(), rng.normal()) * pos_sigma;
                let c_log = DVec3::new(c_true.x, c_true.y, b.z) + jitter;
                logged.push(LoggedBox {
                    id: b.id,
                    centre: c_log,
                    dims: DVec3::new(0.01, b.width, b.height),
                    yaw,
                    model_reference: format!(
                        "osiris:board?width_m={}&height_m={}&thickness_m=0.01&material=lambertian_{}&mount=none",
                        b.width, b.height, b.refl_label
                    ),
                    velocity: DVec3::ZERO,
                });
                per_board(rng, b, c_true, c_log, yaw, &mut m_dets, &mut s_dets);
            }
            views.push(sensor_view(frame, h_s, &logged));
            sims.push(sensor_data_lidar(frame, h_s, s_dets));
            if rng.uniform() < 0.10 {
                dropped += 1;
            } else {
                meas.push(sensor_data_lidar(frame, h_s, m_dets));
            }
            frame += 1;
        }
    }
    write_trace(&dir.join("sv.osi"), &views)?;
    write_trace(&dir.join("meas.osi"), &meas)?;
    write_trace(&dir.join("model.osi"), &sims)?;
    Ok((frame, dropped))
}

/// Appends the boards' `[[target]]` tables to the campaign's `toml`, writes `consistency.toml`
/// into `dir` and names what was written (`hidden`: the case).
fn finish_board_campaign(
    dir: &Path,
    mut toml: String,
    design: &LidarDesign,
    hidden: &str,
    frames: u64,
    dropped: usize,
) -> anyhow::Result<Written> {
    for b in &design.boards {
        let _ = writeln!(
            toml,
            "[[target]]\nid = {}\nkind = \"board\"\nreflectivity_pct = {}\nsize_m = [{}, {}]\nmaterial = \"lambertian_{}\"\norientation = \"facing the sensor\"\n",
            b.id, b.refl_label, b.width, b.height, b.refl_label
        );
    }
    write_campaign(dir, toml, hidden, None, frames as usize, dropped)
}

/// Writes a LiDAR campaign for `case` and `seed` into `dir`.
pub fn lidar_campaign(case: LidarCase, seed: u64, dir: &Path) -> anyhow::Result<Written> {
    std::fs::create_dir_all(dir)?;
    let mut rng = Rng::new(seed.wrapping_mul(104_729).wrapping_add(100 + case as u64));
    let design = lidar_design(case, &mut rng);
    let h_s = LIDAR_MOUNT_H;
    let o = DVec3::new(0.0, 0.0, h_s);
    let ext = if design.fog_vis_m.is_finite() {
        fog_extinction_per_m(design.fog_vis_m)
    } else {
        0.0
    };
    let truth = LidarPhysics {
        overlap: true,
        extinction_per_m: ext,
        div_v_mrad: LIDAR_DIV_V_MRAD,
    };
    let model = LidarPhysics {
        overlap: case != LidarCase::Overlap,
        extinction_per_m: if case == LidarCase::Fog { 0.0 } else { ext },
        div_v_mrad: if case == LidarCase::VerticalDivergence {
            0.0
        } else {
            LIDAR_DIV_V_MRAD
        },
    };
    let cal_db = rng.range(-1.0, 1.0);
    let range_offset = rng.range(-0.02, 0.02);
    let pos_sigma = 0.01;
    let height_err: Vec<f64> = design
        .boards
        .iter()
        .map(|_| rng.range(-0.02, 0.02))
        .collect();
    // The sensor's true yaw from its nominal mounting, rad (positive: turned left).
    let yaw_err = if case == LidarCase::YawMisalignment {
        let sign = if rng.uniform() < 0.5 { -1.0 } else { 1.0 };
        sign * rng.range(0.5, 1.0).to_radians()
    } else {
        0.0
    };
    // A point of the world in the true sensor frame (about the sensor's vertical axis).
    let to_true = |c: DVec3| {
        let (s, co) = (-yaw_err).sin_cos();
        let d = c - o;
        o + DVec3::new(co * d.x - s * d.y, s * d.x + co * d.y, d.z)
    };

    let (frame, dropped) = write_board_frames(
        dir,
        &design,
        &height_err,
        pos_sigma,
        &mut rng,
        |rng, b, c_true, c_log, yaw, m_dets, s_dets| {
            for ret in trace_board(&model, o, c_log, yaw, b.width, b.height, b.refl_label) {
                if ret.power < LIDAR_THRESHOLD {
                    continue;
                }
                let intensity = (100.0 * ret.power * ret.range * ret.range).round();
                s_dets.push(osi3::LidarDetection {
                    object_id: ident(b.id),
                    beam_id: ident(ret.beam),
                    position: spherical(ret.dir * ret.range),
                    intensity: Some(intensity),
                    existence_probability: Some(1.0),
                    ..Default::default()
                });
            }
            // The measured sensor fires in its true frame and reports in the nominal one.
            let (c_m, yaw_m) = (to_true(c_true), yaw - yaw_err);
            for ret in trace_board(&truth, o, c_m, yaw_m, b.width, b.height, b.refl_true) {
                // Speckle / shot noise: 5 % of the power, plus 0.3 % reflectivity-equivalent
                // additive noise at the reference range.
                let mut p = ret.power * (1.0 + 0.05 * rng.normal())
                    + 0.003 * 0.1 / (100.0 * 100.0) * rng.normal();
                if case == LidarCase::Saturation {
                    p = p.min(LIDAR_SATURATION_POWER);
                }
                if p < LIDAR_THRESHOLD {
                    continue;
                }
                let r_m = ret.range + range_offset + 0.02 * rng.normal();
                let intensity = (100.0 * p * ret.range * ret.range * undb(cal_db))
                    .round()
                    .clamp(0.0, 255.0);
                m_dets.push(osi3::LidarDetection {
                    beam_id: ident(ret.beam),
                    position: spherical(ret.dir * r_m),
                    intensity: Some(intensity),
                    existence_probability: Some(1.0),
                    ..Default::default()
                });
            }
        },
    )?;

    let mut toml = String::new();
    let fog = if design.fog_vis_m.is_finite() {
        format!("{}", design.fog_vis_m)
    } else {
        "\"inf\"".into()
    };
    let _ = writeln!(
        toml,
        r#"schema = "osiris.consistency/1"

[run]
id = "independent-lidar-{name}-{seed}"
description = "independent truth generator (tests/support/independent_truth.rs): Lambertian boards, hidden case `{name}`"
provenance = "synthetic"
licence = "MPL-2.0"

[sensor]
kind = "lidar"
osi_sensor_id = {SENSOR_ID}
mounting_position_m = [{mx}, 0.0, {mz}]
mounting_orientation_rad = [0.0, 0.0, 0.0]
wavelength_nm = 905
beam_divergence_mrad = {LIDAR_DIV_V_MRAD}
range_accuracy_m = 0.02

[sensor.quantity_semantics]
intensity = "range-compensated reflectivity in % (clear air, full overlap assumed), 1 DN steps, unknown gain calibration"

[environment]
fog_visibility_m = {fog}
"#,
        name = case.name(),
        mx = HOST_LEN / 2.0,
        mz = h_s - HOST_H / 2.0,
    );
    toml.push_str(&board_campaign_tail(pos_sigma));
    finish_board_campaign(dir, toml, &design, case.name(), frame, dropped)
}

// ---------------------------------------------------------------------------------------------
// FMCW (coherent) LiDAR, 1550 nm. Written from the physics (Goodman, Speckle Phenomena in Optics;
// physics.md §2.8–2.10 as equations, not the model's code): a return of power P (the Lambertian
// boards of `trace_board`, no biaxial overlap: a coaxial coherent receiver) is detected when
// P·X > threshold, X the speckle intensity factor; its reported reflectivity is 100·P·X·R² (a
// float, range-compensated); its range and radial velocity carry white noise.

/// Hidden-effect cases of the FMCW LiDAR campaigns.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FmcwCase {
    /// Fully developed speckle: X ~ Exp(1) per return (one look), the model has X = 1.
    Speckle,
    /// Laser linewidth Δν = [`FMCW_LINEWIDTH_HZ`]: the coherent fraction exp(−4πΔνR/c) of the
    /// power, the model has a perfectly coherent laser.
    PhaseNoise,
    /// Chirp non-linearity: a range smear of σ = [`FMCW_SMEAR_PER_M`]·R in the measurement.
    ChirpNonlinearity,
    Null,
}

impl FmcwCase {
    pub fn name(self) -> &'static str {
        match self {
            FmcwCase::Speckle => "fmcw_speckle",
            FmcwCase::PhaseNoise => "fmcw_phase_noise",
            FmcwCase::ChirpNonlinearity => "fmcw_chirp_nonlinearity",
            FmcwCase::Null => "fmcw_null",
        }
    }
}

/// The LiDAR's mounting on the host (x, z), m, as the campaigns write it.
pub fn lidar_mounting() -> (f64, f64) {
    (HOST_LEN / 2.0, LIDAR_MOUNT_H - HOST_H / 2.0)
}

/// The radar's mounting (x, z) on the host, m (as in the campaigns' `consistency.toml`).
pub fn radar_mounting() -> (f64, f64) {
    (HOST_LEN / 2.0, RADAR_MOUNT_H - HOST_H / 2.0)
}

/// Laser linewidth of the phase-noise case, Hz (GUESSED: a DFB-class laser; −2.7 dB at 50 m).
pub const FMCW_LINEWIDTH_HZ: f64 = 300e3;
/// Range smear of the chirp case, σ_R / R (GUESSED: 0.1 m at 50 m).
pub const FMCW_SMEAR_PER_M: f64 = 0.002;
/// Coherent detection threshold on ρ·f·cosα/R², 20 dB below the pulsed one (shot-noise-limited
/// heterodyne gain, GUESSED): a 10 % board at 50 m is 26 dB above it.
pub const FMCW_THRESHOLD: f64 = LIDAR_THRESHOLD / 100.0;
/// Range and radial-velocity noise (1σ) of a point, m and m/s (both sides).
pub const FMCW_RANGE_SIGMA_M: f64 = 0.02;
pub const FMCW_VELOCITY_SIGMA_M_S: f64 = 0.05;

/// Coherent fraction of the power at range R for a laser of linewidth Δν (Lorentzian line,
/// τ_c = 1/(πΔν), delay τ = 2R/c): exp(−2τ/τ_c) = exp(−4πΔνR/c).
pub fn coherent_fraction(range_m: f64, linewidth_hz: f64) -> f64 {
    (-4.0 * PI * linewidth_hz * range_m / 299_792_458.0).exp()
}

/// Writes an FMCW LiDAR campaign for `case` and `seed` into `dir` (`sensor.lidar_preset = "fmcw"`).
pub fn fmcw_lidar_campaign(case: FmcwCase, seed: u64, dir: &Path) -> anyhow::Result<Written> {
    std::fs::create_dir_all(dir)?;
    let mut rng = Rng::new(seed.wrapping_mul(7_919).wrapping_add(300 + case as u64));
    let design = lidar_design(LidarCase::Null, &mut rng);
    let h_s = LIDAR_MOUNT_H;
    let o = DVec3::new(0.0, 0.0, h_s);
    let geometry = LidarPhysics {
        overlap: false,
        extinction_per_m: 0.0,
        div_v_mrad: LIDAR_DIV_V_MRAD,
    };
    // Gain calibration known to ±0.5 dB (GUESSED: a coherent receiver's gain follows its LO power).
    let cal_db = rng.range(-0.5, 0.5);
    let range_offset = rng.range(-0.02, 0.02);
    let pos_sigma = 0.01;
    let height_err: Vec<f64> = design
        .boards
        .iter()
        .map(|_| rng.range(-0.02, 0.02))
        .collect();
    // One side of the comparison (`hidden`: the truth, with the case's effect; else the model).
    #[allow(clippy::too_many_arguments)]
    fn returns(
        rng: &mut Rng,
        case: FmcwCase,
        hidden: bool,
        p: &LidarPhysics,
        o: DVec3,
        c: DVec3,
        yaw: f64,
        b: &Board,
        cal: f64,
        range_offset: f64,
        id: Option<u64>,
    ) -> Vec<osi3::LidarDetection> {
        let refl = if hidden { b.refl_true } else { b.refl_label };
        let mut out = Vec::new();
        for ret in trace_board(p, o, c, yaw, b.width, b.height, refl) {
            let mut power = ret.power * (1.0 + 0.05 * rng.normal());
            if hidden && case == FmcwCase::PhaseNoise {
                power *= coherent_fraction(ret.range, FMCW_LINEWIDTH_HZ);
            }
            if hidden && case == FmcwCase::Speckle {
                // Exponential intensity: −ln U, U uniform in (0, 1].
                power *= -(1.0 - rng.uniform()).ln();
            }
            if power < FMCW_THRESHOLD {
                continue;
            }
            let mut sigma_r = FMCW_RANGE_SIGMA_M;
            if hidden && case == FmcwCase::ChirpNonlinearity {
                sigma_r = sigma_r.hypot(FMCW_SMEAR_PER_M * ret.range);
            }
            let r_m = ret.range + range_offset + sigma_r * rng.normal();
            out.push(osi3::LidarDetection {
                object_id: id.and_then(ident),
                beam_id: ident(ret.beam),
                position: spherical(ret.dir * r_m),
                intensity: Some(100.0 * power * ret.range * ret.range * cal),
                radial_velocity: Some(FMCW_VELOCITY_SIGMA_M_S * rng.normal()),
                existence_probability: Some(1.0),
                ..Default::default()
            });
        }
        out
    }

    let (frame, dropped) = write_board_frames(
        dir,
        &design,
        &height_err,
        pos_sigma,
        &mut rng,
        |rng, b, c_true, c_log, yaw, m_dets, s_dets| {
            s_dets.extend(returns(
                rng,
                case,
                false,
                &geometry,
                o,
                c_log,
                yaw,
                b,
                1.0,
                0.0,
                Some(b.id),
            ));
            m_dets.extend(returns(
                rng,
                case,
                true,
                &geometry,
                o,
                c_true,
                yaw,
                b,
                undb(cal_db),
                range_offset,
                None,
            ));
        },
    )?;

    let mut toml = String::new();
    let _ = writeln!(
        toml,
        r#"schema = "osiris.consistency/1"

[run]
id = "independent-lidar-{name}-{seed}"
description = "independent truth generator (tests/support/independent_truth.rs): FMCW LiDAR, Lambertian boards, hidden case `{name}`"
provenance = "synthetic"
licence = "MPL-2.0"

[sensor]
kind = "lidar"
lidar_preset = "fmcw"
osi_sensor_id = {SENSOR_ID}
mounting_position_m = [{mx}, 0.0, {mz}]
mounting_orientation_rad = [0.0, 0.0, 0.0]
wavelength_nm = 1550
beam_divergence_mrad = {LIDAR_DIV_V_MRAD}
range_accuracy_m = {FMCW_RANGE_SIGMA_M}

[sensor.quantity_semantics]
intensity = "range-compensated reflectivity in % (coherent peak power × R²), float, unknown gain calibration"
radial_velocity = "m/s, positive towards the sensor (OSI)"

[environment]
fog_visibility_m = "inf"
"#,
        name = case.name(),
        mx = HOST_LEN / 2.0,
        mz = h_s - HOST_H / 2.0,
    );
    toml.push_str(&board_campaign_tail(pos_sigma));
    finish_board_campaign(dir, toml, &design, case.name(), frame, dropped)
}

// ---------------------------------------------------------------------------------------------
// Camera detections (issue 19: mounting and timing effects of a camera).
//
// Cars (4.5 × 1.8 × 1.5 m boxes) stand or cross in front of a camera 1.3 m above the road on a
// parked host. A detection is the smallest azimuth–elevation box containing the directions of the
// car box's eight corners (OSI `CameraDetection` with two `CameraPoint`s, the first and third
// corner, at the distance of the box centre). The measuring camera sees the true boxes from its
// true frame at its own clock, with 0.05° of noise per box edge (≈ 1 px at a 1000 px focal
// length), ~10 % of the frames missing and no object ids; the model sees the logged boxes
// (2 cm survey jitter) from the nominal frame.

/// Hidden-effect cases of the camera detection campaigns.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CameraCase {
    /// Nothing hidden.
    Null,
    /// The camera is turned 0.5–1.0° in yaw (either side) from its nominal mounting.
    YawMisalignment,
    /// The camera is pitched 0.3–0.8° (either sign) from its nominal mounting.
    PitchMisalignment,
    /// The camera's clock is 40–80 ms (either sign) off the ground truth's; cars cross.
    TimeOffset,
    /// The measuring camera looks through a windshield (28° rake, 4.96 mm, n = 1.52, 0.10 m ahead)
    /// whose faces meet at a 1–2 mrad wedge, thicker at the top; the model sees no glass.
    Windshield,
}

impl CameraCase {
    pub fn name(self) -> &'static str {
        match self {
            CameraCase::Null => "null",
            CameraCase::YawMisalignment => "yaw_misalignment",
            CameraCase::PitchMisalignment => "pitch_misalignment",
            CameraCase::TimeOffset => "time_offset",
            CameraCase::Windshield => "windshield",
        }
    }
}

/// Camera height above the road, m.
pub const CAMERA_MOUNT_H: f64 = 1.3;
const CAR_DIMS: DVec3 = DVec3::new(4.5, 1.8, 1.5);
/// Noise of each edge of a measured detection's angular box, deg (GUESSED: ≈ 1 px).
const CAMERA_EDGE_NOISE_DEG: f64 = 0.05;

/// The camera's mounting (x, z) relative to the host's box centre.
pub fn camera_mounting() -> (f64, f64) {
    (HOST_LEN / 2.0, CAMERA_MOUNT_H - HOST_H / 2.0)
}

/// The angular box of a car (centre `c`, yaw `yaw`, global) seen from a camera at `sensor` whose
/// axes are `axes` (columns: its x, y, z in global coordinates): ((az_min, el_min),
/// (az_max, el_max)) in rad, and the distance to the centre, m.
fn angular_box(
    sensor: DVec3,
    axes: glam::DMat3,
    c: DVec3,
    yaw: f64,
) -> ((f64, f64), (f64, f64), f64) {
    angular_box_through(sensor, axes, c, yaw, None)
}

/// [`angular_box`] seen through the generator's windshield `glass` (when given).
fn angular_box_through(
    sensor: DVec3,
    axes: glam::DMat3,
    c: DVec3,
    yaw: f64,
    glass: Option<&GenWindshield>,
) -> ((f64, f64), (f64, f64), f64) {
    let (s, co) = yaw.sin_cos();
    let (mut az0, mut az1, mut el0, mut el1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for i in 0..8 {
        let l = DVec3::new(
            if i & 1 == 0 { -0.5 } else { 0.5 } * CAR_DIMS.x,
            if i & 2 == 0 { -0.5 } else { 0.5 } * CAR_DIMS.y,
            if i & 4 == 0 { -0.5 } else { 0.5 } * CAR_DIMS.z,
        );
        let g = c + DVec3::new(co * l.x - s * l.y, s * l.x + co * l.y, l.z);
        let mut p = axes.transpose() * (g - sensor);
        if let Some(w) = glass {
            p = w.seen(p);
        }
        let az = p.y.atan2(p.x);
        let el = p.z.atan2(p.x.hypot(p.y));
        az0 = az0.min(az);
        az1 = az1.max(az);
        el0 = el0.min(el);
        el1 = el1.max(el);
    }
    let centre = axes.transpose() * (c - sensor);
    ((az0, el0), (az1, el1), centre.length())
}

/// The generator's own windshield (independent of the model's code): a glass of index `n`
/// between two planes in the camera frame (x forward, z up), the inner one through
/// (`dist_m`, 0, 0) inclined `incl_deg` above the horizontal, the outer one `thick_m` further along
/// the inner normal and turned by `wedge_rad` about y (thicker towards the top).
#[derive(Debug, Clone, Copy)]
pub struct GenWindshield {
    pub incl_deg: f64,
    pub dist_m: f64,
    pub thick_m: f64,
    pub n: f64,
    pub wedge_rad: f64,
}

impl GenWindshield {
    /// The glass of the windshield case with a wedge of `wedge_rad`.
    pub fn raked(wedge_rad: f64) -> GenWindshield {
        GenWindshield {
            incl_deg: 28.0,
            dist_m: 0.10,
            thick_m: 4.96e-3,
            n: 1.52,
            wedge_rad,
        }
    }

    /// A camera ray along the unit `d` after the glass: (a point on it, its direction). Snell at
    /// each face: the tangential component scales by the index ratio, the normal one fills the
    /// unit length.
    fn trace(&self, d: DVec3) -> (DVec3, DVec3) {
        let a = self.incl_deg.to_radians();
        let n1 = DVec3::new(a.sin(), 0.0, a.cos());
        // The outer normal: n1 turned about y by the wedge, towards the glass's downward direction
        // (cos α, 0, −sin α): the faces part going up the glass.
        let (sw, cw) = self.wedge_rad.sin_cos();
        let n2 = DVec3::new(n1.x * cw + n1.z * sw, 0.0, n1.z * cw - n1.x * sw);
        let cross = |d: DVec3, nrm: DVec3, ratio: f64| {
            let tang = (d - nrm * d.dot(nrm)) * ratio;
            tang + nrm * (1.0 - tang.length_squared()).sqrt()
        };
        let q1 = DVec3::new(self.dist_m, 0.0, 0.0);
        let p_in = d * (q1.dot(n1) / d.dot(n1));
        let inside = cross(d, n1, 1.0 / self.n);
        let q2 = q1 + n1 * self.thick_m;
        let p_out = p_in + inside * ((q2 - p_in).dot(n2) / inside.dot(n2));
        (p_out, cross(inside, n2, self.n))
    }

    /// The camera ray that sees the point `p` (camera frame) through the glass: the direction
    /// `d` whose traced ray passes through `p`, by fixed-point iteration.
    pub fn seen(&self, p: DVec3) -> DVec3 {
        let mut d = p.normalize();
        for _ in 0..30 {
            let (o, out) = self.trace(d);
            d = (d + (p - o).normalize() - out).normalize();
        }
        d
    }
}

fn camera_detection(
    k: usize,
    id: Option<u64>,
    (lo, hi, r): ((f64, f64), (f64, f64), f64),
) -> (osi3::CameraDetection, [osi3::CameraPoint; 2]) {
    let point = |az: f64, el: f64| osi3::CameraPoint {
        existence_probability: Some(1.0),
        point: Some(osi3::Spherical3d {
            distance: Some(r),
            azimuth: Some(az),
            elevation: Some(el),
        }),
        point_rmse: None,
    };
    (
        osi3::CameraDetection {
            existence_probability: Some(1.0),
            object_id: id.and_then(ident),
            image_shape_type: Some(osi3::camera_detection::ImageShapeType::Box as i32),
            first_point_index: Some(2 * k as u32),
            number_of_points: Some(2),
            ..Default::default()
        },
        [point(lo.0, lo.1), point(hi.0, hi.1)],
    )
}

fn sensor_data_camera(
    frame: u64,
    h_sensor: f64,
    dets: Vec<(osi3::CameraDetection, [osi3::CameraPoint; 2])>,
) -> osi3::SensorData {
    let (detection, points): (Vec<_>, Vec<_>) = dets.into_iter().unzip();
    let camera_sensor = vec![osi3::CameraDetectionData {
        detection,
        point: points.into_iter().flatten().collect(),
        ..Default::default()
    }];
    sensor_data(
        frame,
        h_sensor,
        osi3::FeatureData {
            camera_sensor,
            ..Default::default()
        },
    )
}

/// Writes a camera detection campaign for `case` and `seed` into `dir`: 36 stations × 3 frames,
/// three cars per station at 8–60 m and ±20°: car 0 stands (its rear to the camera), car 1 crosses
/// to the left and car 2 to the right at 3–6 m/s.
pub fn camera_campaign(case: CameraCase, seed: u64, dir: &Path) -> anyhow::Result<Written> {
    std::fs::create_dir_all(dir)?;
    let mut rng = Rng::new(seed.wrapping_mul(6007).wrapping_add(case as u64));
    let sign = |rng: &mut Rng| if rng.uniform() < 0.5 { -1.0 } else { 1.0 };
    let h_s = CAMERA_MOUNT_H;
    let sensor = DVec3::new(0.0, 0.0, h_s);
    let (yaw_true, pitch_true, clock_s) = match case {
        CameraCase::YawMisalignment => (
            (sign(&mut rng) * rng.range(0.5, 1.0)).to_radians(),
            0.0,
            0.0,
        ),
        CameraCase::PitchMisalignment => (
            0.0,
            (sign(&mut rng) * rng.range(0.3, 0.8)).to_radians(),
            0.0,
        ),
        CameraCase::TimeOffset => (0.0, 0.0, sign(&mut rng) * rng.range(0.04, 0.08)),
        CameraCase::Null | CameraCase::Windshield => (0.0, 0.0, 0.0),
    };
    let glass =
        (case == CameraCase::Windshield).then(|| GenWindshield::raked(rng.range(1.0e-3, 2.0e-3)));
    // A windshield campaign is a calibration-grade one: its elevation tolerance is the box
    // centre's noise (0.05°), a quarter of the others'.
    let (tol_az, tol_el) = if glass.is_some() {
        (0.2, 0.05)
    } else {
        (0.2, 0.2)
    };
    // The true camera axes: yaw about the vertical, then pitch about the new y (OSI: positive
    // pitch turns +x down).
    let true_axes =
        glam::DMat3::from_rotation_z(yaw_true) * glam::DMat3::from_rotation_y(pitch_true);
    let nominal_axes = glam::DMat3::IDENTITY;
    let pos_sigma = 0.02;
    let azimuths = [-20.0f64, -10.0, 0.0, 10.0, 20.0];

    let mut views = Vec::new();
    let mut meas = Vec::new();
    let mut sims = Vec::new();
    let mut frame = 0u64;
    let mut dropped = 0usize;
    for k in 0..36usize {
        // Per station: each car's range, azimuth slot and crossing speed.
        let placed: Vec<(u64, f64, f64, f64)> = (0..3)
            .map(|i| {
                let r = 8.0 + 52.0 * ((k * 7 + 11 * i) % 36) as f64 / 35.0;
                let az = azimuths[(2 * i + k) % 5].to_radians();
                let speed = match i {
                    0 => 0.0,
                    1 => rng.range(3.0, 6.0),
                    _ => -rng.range(3.0, 6.0),
                };
                (200 + i as u64, r, az, speed)
            })
            .collect();
        for _ in 0..3 {
            let mut logged = Vec::new();
            let (mut m_dets, mut s_dets) = (Vec::new(), Vec::new());
            for &(id, r, az, speed) in &placed {
                // Box centre at the road: the car's centre 0.75 m above it.
                let c_true = DVec3::new(r * az.cos(), r * az.sin(), 0.5 * CAR_DIMS.z);
                // Crossing: velocity perpendicular to the line of sight (positive: to the left).
                let v = speed * DVec3::new(-az.sin(), az.cos(), 0.0);
                // Standing cars show their rear; crossing ones their side.
                let yaw = if speed == 0.0 { az } else { az + 0.5 * PI };
                let jitter = DVec3::new(rng.normal(), rng.normal(), rng.normal()) * pos_sigma;
                let c_log = c_true + jitter;
                logged.push(LoggedBox {
                    id,
                    centre: c_log,
                    dims: CAR_DIMS,
                    yaw,
                    model_reference: "osiris:car".into(),
                    velocity: v,
                });
                let sim_box = angular_box(sensor, nominal_axes, c_log, yaw);
                let sk = s_dets.len();
                s_dets.push(camera_detection(sk, Some(id), sim_box));
                // The measuring camera: the car where it is `clock_s` later, from its true axes.
                let (lo, hi, rr) = angular_box_through(
                    sensor,
                    true_axes,
                    c_true + v * clock_s,
                    yaw,
                    glass.as_ref(),
                );
                let n = |rng: &mut Rng| CAMERA_EDGE_NOISE_DEG.to_radians() * rng.normal();
                let noisy = (
                    (lo.0 + n(&mut rng), lo.1 + n(&mut rng)),
                    (hi.0 + n(&mut rng), hi.1 + n(&mut rng)),
                    rr,
                );
                let mk = m_dets.len();
                m_dets.push(camera_detection(mk, None, noisy));
            }
            views.push(sensor_view(frame, h_s, &logged));
            sims.push(sensor_data_camera(frame, h_s, s_dets));
            if rng.uniform() < 0.10 {
                dropped += 1;
            } else {
                meas.push(sensor_data_camera(frame, h_s, m_dets));
            }
            frame += 1;
        }
    }
    write_trace(&dir.join("sv.osi"), &views)?;
    write_trace(&dir.join("meas.osi"), &meas)?;
    write_trace(&dir.join("model.osi"), &sims)?;
    let toml = format!(
        r#"schema = "osiris.consistency/1"

[run]
id = "independent-camera-{name}-{seed}"
description = "independent truth generator (tests/support/independent_truth.rs): camera detections of standing and crossing cars, hidden case `{name}`"
provenance = "synthetic"
licence = "MPL-2.0"

[sensor]
kind = "camera"
osi_sensor_id = {SENSOR_ID}
mounting_position_m = [{mx}, 0.0, {mz}]
mounting_orientation_rad = [0.0, 0.0, 0.0]

[uncertainty]
gt_position_sigma_m = {pos_sigma}

[association]
method = "gating"

[tolerance]
azimuth_deg = {tol_az}
elevation_deg = {tol_el}

[bins]
explanatory = ["range", "azimuth"]

[traces]
sensor_view = "sv.osi"
sensor_data = "meas.osi"

[[target]]
id = 200
kind = "car"

[[target]]
id = 201
kind = "car"

[[target]]
id = 202
kind = "car"
"#,
        name = case.name(),
        mx = HOST_LEN / 2.0,
        mz = h_s - HOST_H / 2.0,
    );
    write_campaign(
        dir,
        toml,
        case.name(),
        match case {
            CameraCase::YawMisalignment => Some(yaw_true.to_degrees()),
            CameraCase::PitchMisalignment => Some(pitch_true.to_degrees()),
            CameraCase::TimeOffset => Some(1e3 * clock_s),
            CameraCase::Windshield => glass.map(|g| 1e3 * g.wedge_rad),
            CameraCase::Null => None,
        },
        frame as usize,
        dropped,
    )
}
