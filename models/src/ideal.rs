//! Ideal object-level reference model ([`IdealSensor`]), shared by the camera, radar and LiDAR FMUs.
//!
//! It runs until the physical models land and stays selectable afterwards (`mode: "ideal"`) as the
//! reference the physical models are compared with. It renders nothing and adds no noise: it reports
//! the ground-truth objects the sensor could see, in the sensor frame.
//!
//! # Algorithm (per step)
//!
//! 1. **Frames** ([`crate::frames`]): the host vehicle is `SensorView.host_vehicle_id` (else
//!    `GroundTruth.host_vehicle_id`); the sensor frame is the SensorView's `mounting_position` (else the
//!    configured mounting) on the host's rear-axle frame. Without any host id the vehicle frame is the
//!    global frame at rest (test benches). A host id that is not in the ground truth is an input error.
//! 2. **Bodies**: every moving object except the host and every stationary object becomes an oriented
//!    box in the sensor frame (`base.position` = box centre, `base.dimension`, `base.orientation`).
//!    A box that contains the sensor origin is neither reported nor an occluder (the sensor sits in or
//!    on it, like on the host). Objects without an `id` occlude but are not reported.
//! 3. **Samples** of a body: its centre, the point of the box closest to the sensor, and a grid on
//!    each face that faces the sensor (outward normal towards the sensor origin; far-side faces are
//!    skipped). The grid has `clamp(1 + ceil(edge / 2 m), 3, 17)` points per edge (a car face gets 3×3,
//!    a 400 m guardrail 17 along its length); points on an edge shared by two facing faces are kept once.
//! 4. **Field of view and range**: a sample is *in view* when `0 < r ≤ range_m`,
//!    `|azimuth| ≤ fov_horizontal/2` and `|elevation| ≤ fov_vertical/2` (both FoVs symmetric about
//!    the sensor's +x axis; angles as in [`crate::frames::Spherical`]). A body is a candidate when at
//!    least one of its samples is in view: any visible part of the box counts.
//! 5. **Occlusion**: for each in-view sample, the line of sight from the sensor origin to the sample
//!    is tested (slab test) against the oriented boxes of all *other* bodies that can lie in between
//!    (a bounding-sphere cone test selects them first). The **visible fraction** is
//!    `unoccluded in-view samples / in-view samples` (so a box cut by the FoV edge is not penalised for
//!    the part outside the FoV). The body is **visible** iff `fraction ≥ min_visible_fraction`.
//!
//! # Outputs
//!
//! * `SensorData.moving_object[]` / `stationary_object[]`: one detected object per visible body, in the
//!   (virtual) sensor frame: box centre, orientation relative to the sensor, dimension, velocity
//!   relative to the sensor (moving objects; includes the ego's own translation and rotation, see
//!   [`crate::frames::SensorFrame::relative_velocity`]), `tracking_id = ground_truth_id = GT id`,
//!   reference point `CENTER`, one candidate with probability 1 and the ground-truth type /
//!   classification. **Existence probability** `p = 0.5 + 0.5·(f − f_min)/(1 − f_min)` for the visible
//!   fraction `f` and `f_min = min_visible_fraction` (1 for a fully visible object, 0.5 at the
//!   threshold; `p = 1` when `f_min = 1`). **Age** is the time (s) the object has been visible without
//!   interruption (0 in the first cycle it is seen). **Movement state**: `MOVING` when the ground-truth
//!   speed exceeds [`MOVING_SPEED_THRESHOLD_M_S`], else `STOPPED` if it was seen moving before, else
//!   `STATIONARY`.
//! * Radar: `feature_data.radar_sensor[0].detection[]`, one per visible body, at the **detection point**:
//!   the point of the box closest to the sensor if it is in view and unoccluded, else the nearest
//!   unoccluded in-view surface sample, else the box centre. `radial_velocity` uses OSI's sign
//!   (positive **towards** the sensor, `= −d(range)/dt` of the detection point, which moves with the
//!   object's linear and angular velocity). `rcs` (dBsm) from [`default_rcs_moving_dbsm`] /
//!   [`default_rcs_stationary_dbsm`]; `snr` from [`ideal_radar_snr_db`]. The perception extension gets
//!   the same peaks (`range_rate_m_s = −radial_velocity`, `power_dbm` from [`ideal_radar_power_dbm`]).
//! * LiDAR: `feature_data.lidar_sensor[0].detection[]`, one point per unoccluded in-view face-grid
//!   sample of each visible body (exactly on the box surface), intensity (%) from
//!   [`default_lidar_intensity_percent`], `object_id` = GT id, `beam_id` unset. The perception
//!   extension gets the same points as a point cloud (x, y, z in the sensor frame, `PERCENT` scale,
//!   timestamp = measurement time, channel 0, echo 0, `pulses_fired` = number of face-grid samples
//!   tried, 905 nm).
//! * Camera: `feature_data.camera_sensor[0]`: one `CameraDetection` (`IMAGE_SHAPE_TYPE_BOX`) per
//!   visible body with OSI's two `CameraPoint`s (first and third corner of an axis-aligned box):
//!   the smallest azimuth–elevation box containing the directions of the 8 corners of its 3D box
//!   (first = largest azimuth and elevation, second = smallest; reported even where it extends
//!   outside the FoV for a partially visible object), both at the range of the box's point
//!   closest to the sensor ([`crate::semantics::box_corners`]). The ideal model renders **no
//!   image**: the perception extension's `camera` is present with no `image`.
//! * Every detection's `object_id` is the `tracking_id` (= ground-truth id) of the detected object
//!   it was made from, which is always reported; pedestrian candidates carry `head_pose` and
//!   `upper_body_pose` ([`crate::semantics`], rule 3).
//!
//! All detections use the same sensor frame as the detected objects (physical = virtual sensor:
//! `SensorDetectionHeader.mounting_position = SensorData.mounting_position`).

use crate::constants::SPEED_OF_LIGHT_M_S;
use std::collections::HashMap;

use glam::{DMat3, DVec3};
use osiris_proto::perception;
use osiris_proto::{id, osi3};
use prost::Message as _;

use crate::frames::{
    SensorFrame, Spherical, moving_object_pose, moving_object_twist, rpy_to_osi,
    stationary_object_pose, vec3_to_osi,
};
use crate::handshake::Handshake;
use crate::output::{FrameHeader, finish};
use crate::semantics::PoseFrames;
use crate::sensor::*;
use crate::world::ViewFrame;

/// Ground-truth speed above which a moving object counts as `MOVING`, m/s.
pub const MOVING_SPEED_THRESHOLD_M_S: f64 = 0.1;

/// Target spacing of the face sample grid, m (see the module documentation).
pub const GRID_SPACING_M: f64 = 2.0;
/// Fewest / most grid points per box edge.
pub const GRID_MIN_POINTS: usize = 3;
pub const GRID_MAX_POINTS: usize = 17;

/// Carrier frequency the ideal radar's wavelength-dependent values assume, Hz (76–77 GHz band).
pub const IDEAL_RADAR_FREQUENCY_HZ: f64 = 76.5e9;
/// Transmit power of the ideal radar's power convention, dBm.
pub const IDEAL_RADAR_TX_POWER_DBM: f64 = 10.0;
/// Transmit and receive antenna gain of the ideal radar's power convention, dBi (each).
pub const IDEAL_RADAR_ANTENNA_GAIN_DBI: f64 = 20.0;
/// Constant of the ideal radar's SNR convention, dB (see [`ideal_radar_snr_db`]).
pub const IDEAL_RADAR_SNR_CONSTANT_DB: f64 = 90.0;
/// Wavelength the ideal LiDAR reports, nm.
pub const IDEAL_LIDAR_WAVELENGTH_NM: f64 = 905.0;

/// SNR of the ideal radar, dB: `snr = rcs − 40·log10(r / 1 m) + 90 dB`.
///
/// The shape of the monostatic radar equation (`P_r ∝ σ / r⁴`) with the constant chosen so that a
/// 10 dBsm car at 100 m has 20 dB. This is the ideal model's convention, not a sensor property.
pub fn ideal_radar_snr_db(rcs_dbsm: f64, range_m: f64) -> f64 {
    rcs_dbsm - 40.0 * range_m.max(1e-3).log10() + IDEAL_RADAR_SNR_CONSTANT_DB
}

/// Received power of the ideal radar, dBm, from the monostatic radar equation
/// `P_r = P_t·G_t·G_r·λ²·σ / ((4π)³·r⁴)` with `P_t` = [`IDEAL_RADAR_TX_POWER_DBM`],
/// `G_t = G_r` = [`IDEAL_RADAR_ANTENNA_GAIN_DBI`] and `λ = c / 76.5 GHz`
/// (≈ −101 dBm for 10 dBsm at 100 m). With [`ideal_radar_snr_db`] this implies a constant noise
/// floor of `power − snr ≈ −121.1 dBm` (after processing gain).
pub fn ideal_radar_power_dbm(rcs_dbsm: f64, range_m: f64) -> f64 {
    let lambda = SPEED_OF_LIGHT_M_S / IDEAL_RADAR_FREQUENCY_HZ;
    IDEAL_RADAR_TX_POWER_DBM + 2.0 * IDEAL_RADAR_ANTENNA_GAIN_DBI + 20.0 * lambda.log10() + rcs_dbsm
        - 30.0 * (4.0 * std::f64::consts::PI).log10()
        - 40.0 * range_m.max(1e-3).log10()
}

pub use crate::environment::assets::{model_reference_name, model_reference_param};

/// Peak RCS of a trihedral corner reflector of inner edge `a`, `σ = 4π·a⁴ / (3·λ²)`, in dBsm at the
/// ideal radar's wavelength (a = 0.1 m → ≈ 14.4 dBsm at 76.5 GHz).
pub fn trihedral_rcs_dbsm(edge_m: f64) -> f64 {
    let lambda = SPEED_OF_LIGHT_M_S / IDEAL_RADAR_FREQUENCY_HZ;
    let sigma = 4.0 * std::f64::consts::PI * edge_m.powi(4) / (3.0 * lambda * lambda);
    10.0 * sigma.log10()
}

/// Default radar cross-section of a moving object for the ideal radar, dBsm.
///
/// Orientation-independent typical 77 GHz values, rounded: car 10, van 15, truck/bus/trailer 20,
/// motorcycle 5, bicycle with rider 0, pedestrian −5, animal −5, other 0. Measured automotive-radar
/// RCS of cars spreads over roughly 0–20 dBsm with aspect, and of pedestrians over roughly −15–0 dBsm,
/// see e.g. Matsunami, Nakamura, Kajiwara, "RCS measurements for vehicles and pedestrian at 26 and
/// 79 GHz", ICSPCS 2012 (doi:10.1109/ICSPCS.2012.6508004); Fortuny-Guasch, Chareau, "Radar cross
/// section measurements of pedestrian dummies and humans in the 24/77 GHz frequency bands", JRC
/// report EUR 25762 EN, 2013 (doi:10.2788/80844); Lee, Kang, Kim, Lee, "Radar cross section
/// measurement with 77 GHz automotive FMCW radar", IEEE PIMRC 2016.
pub fn default_rcs_moving_dbsm(obj: &osi3::MovingObject) -> f64 {
    use osi3::moving_object::Type;
    use osi3::moving_object::vehicle_classification::Type as V;
    match obj.r#type.and_then(|t| Type::try_from(t).ok()) {
        Some(Type::Pedestrian) => -5.0,
        Some(Type::Animal) => -5.0,
        Some(Type::Vehicle) => {
            let class = obj
                .vehicle_classification
                .as_ref()
                .and_then(|c| c.r#type)
                .and_then(|t| V::try_from(t).ok());
            match class {
                Some(V::DeliveryVan) => 15.0,
                Some(
                    V::HeavyTruck
                    | V::Semitrailer
                    | V::Semitractor
                    | V::Trailer
                    | V::Bus
                    | V::Tram
                    | V::Train
                    | V::WorkMachine,
                ) => 20.0,
                Some(V::Motorbike) => 5.0,
                Some(V::Bicycle | V::StandupScooter | V::MicromobilityDevice | V::Wheelchair) => {
                    0.0
                }
                _ => 10.0,
            }
        }
        _ => 0.0,
    }
}

/// Default radar cross-section of a stationary object for the ideal radar, dBsm.
///
/// A model reference `osiris:trihedral?edge_m=a` gets the closed form [`trihedral_rcs_dbsm`].
/// Otherwise by classification type: building/bridge/wall 20, barrier (guardrail) 10, reflective
/// structure 15, overhead/vertical/rectangular structure and emitting structure 10, pole 0, tree 0,
/// pylon/traffic cone and construction-site element −5, delineator −5, curbstone/speed bump −10,
/// vegetation −10, other/unknown 0. Rounded typical values; the ideal model's convention.
pub fn default_rcs_stationary_dbsm(obj: &osi3::StationaryObject) -> f64 {
    use osi3::stationary_object::classification::Type as S;
    if let Some(r) = obj.model_reference.as_deref()
        && model_reference_name(r) == Some("trihedral")
        && let Some(a) = model_reference_param(r, "edge_m").and_then(|v| v.parse::<f64>().ok())
        && a.is_finite()
        && a > 0.0
    {
        return trihedral_rcs_dbsm(a);
    }
    match obj
        .classification
        .as_ref()
        .and_then(|c| c.r#type)
        .and_then(|t| S::try_from(t).ok())
    {
        Some(S::Building | S::Bridge | S::Wall) => 20.0,
        Some(S::ReflectiveStructure) => 15.0,
        Some(S::Barrier) => 10.0,
        Some(
            S::OverheadStructure
            | S::VerticalStructure
            | S::RectangularStructure
            | S::EmittingStructure,
        ) => 10.0,
        Some(S::Pole | S::Tree) => 0.0,
        Some(S::Pylon | S::ConstructionSiteElement | S::Delineator) => -5.0,
        Some(S::Curbstone | S::SpeedBump | S::Vegetation) => -10.0,
        _ => 0.0,
    }
}

/// Default LiDAR intensity of an object for the ideal LiDAR, % (0–100).
///
/// A model reference with `material=lambertian_NN` gets `NN` %; otherwise 50 % for every object
/// except reflective structures (retro-reflectors, 100 %) and vegetation/trees (30 %). The ideal
/// model's convention; the physical LiDAR computes intensity from reflectance and range.
pub fn default_lidar_intensity_percent(
    model_reference: Option<&str>,
    stationary_type: Option<i32>,
) -> f64 {
    use osi3::stationary_object::classification::Type as S;
    if let Some(v) = model_reference
        .and_then(|r| model_reference_param(r, "material"))
        .and_then(|m| {
            m.strip_prefix("lambertian_")
                .and_then(|v| v.parse::<f64>().ok())
        })
        && v.is_finite()
    {
        return v.clamp(0.0, 100.0);
    }
    match stationary_type.and_then(|t| S::try_from(t).ok()) {
        Some(S::ReflectiveStructure) => 100.0,
        Some(S::Vegetation | S::Tree) => 30.0,
        _ => 50.0,
    }
}

// ---------------------------------------------------------------------------------------------------
// Geometry

/// An oriented box in the sensor frame.
#[derive(Debug, Clone, Copy)]
struct Obb {
    center: DVec3,
    /// Box → sensor rotation (columns: box axes).
    rot: DMat3,
    rot_t: DMat3,
    /// Half extents (length/2, width/2, height/2), m, ≥ 0.
    half: DVec3,
    /// The sensor origin in box coordinates.
    origin_local: DVec3,
}

impl Obb {
    fn new(center: DVec3, rot: DMat3, half: DVec3) -> Obb {
        let rot_t = rot.transpose();
        Obb {
            center,
            rot,
            rot_t,
            half,
            origin_local: rot_t * (-center),
        }
    }

    fn local_to_sensor(&self, local: DVec3) -> DVec3 {
        self.center + self.rot * local
    }

    fn contains_origin(&self) -> bool {
        let o = self.origin_local.abs();
        o.x <= self.half.x && o.y <= self.half.y && o.z <= self.half.z
    }

    /// The point of the box closest to the sensor origin (sensor frame).
    fn closest_point_to_origin(&self) -> DVec3 {
        self.local_to_sensor(self.origin_local.clamp(-self.half, self.half))
    }

    /// The 8 corners, x slowest: (−,−,−), (−,−,+), (−,+,−), …, (+,+,+).
    fn corners(&self) -> [DVec3; 8] {
        let mut out = [DVec3::ZERO; 8];
        for (k, c) in out.iter_mut().enumerate() {
            let s = DVec3::new(
                if k & 4 != 0 { 1.0 } else { -1.0 },
                if k & 2 != 0 { 1.0 } else { -1.0 },
                if k & 1 != 0 { 1.0 } else { -1.0 },
            );
            *c = self.local_to_sensor(s * self.half);
        }
        out
    }

    /// Does the segment from the sensor origin to `p` (sensor frame) pass through the box strictly
    /// before reaching `p`? Slab test on `o + t·d`, `t ∈ (0, 1)`, with a small margin at both ends so
    /// that boxes touching the sensor or the sample point do not count.
    fn blocks_segment_to(&self, p: DVec3) -> bool {
        let o = self.origin_local;
        let d = self.rot_t * p;
        let mut t0 = f64::NEG_INFINITY;
        let mut t1 = f64::INFINITY;
        for i in 0..3 {
            let (oi, di, hi) = (o[i], d[i], self.half[i]);
            if di.abs() < 1e-15 {
                if oi.abs() > hi {
                    return false;
                }
            } else {
                let inv = 1.0 / di;
                let (a, b) = ((-hi - oi) * inv, (hi - oi) * inv);
                let (a, b) = if a < b { (a, b) } else { (b, a) };
                t0 = t0.max(a);
                t1 = t1.min(b);
                if t0 > t1 {
                    return false;
                }
            }
        }
        t1 > 1e-9 && t0 < 1.0 - 1e-6 && t0 < t1
    }

    /// Which faces face the sensor: `[axis][0 = negative side, 1 = positive side]`.
    fn facing(&self) -> [[bool; 2]; 3] {
        let mut f = [[false; 2]; 3];
        for (a, fa) in f.iter_mut().enumerate() {
            fa[0] = -self.origin_local[a] > self.half[a];
            fa[1] = self.origin_local[a] > self.half[a];
        }
        f
    }
}

fn grid_points(half: f64) -> usize {
    if half <= 0.0 {
        1
    } else {
        let n = 1.0 + (2.0 * half / GRID_SPACING_M).ceil();
        (n as usize).clamp(GRID_MIN_POINTS, GRID_MAX_POINTS)
    }
}

fn grid_coord(half: f64, i: usize, n: usize) -> f64 {
    if n <= 1 {
        0.0
    } else {
        -half + 2.0 * half * i as f64 / (n - 1) as f64
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum SampleKind {
    Centre,
    Closest,
    Grid,
}

#[derive(Debug, Clone, Copy)]
struct Sample {
    p: DVec3,
    kind: SampleKind,
    in_view: bool,
    visible: bool,
}

/// Push the face-grid samples of the faces facing the sensor (edges shared by two facing faces once).
fn push_face_grid(obb: &Obb, out: &mut Vec<Sample>) -> usize {
    let facing = obb.facing();
    let h = obb.half;
    let mut n_pushed = 0;
    for a in 0..3 {
        for (side, sign) in [(0usize, -1.0f64), (1usize, 1.0f64)] {
            if !facing[a][side] {
                continue;
            }
            let u = (a + 1) % 3;
            let v = (a + 2) % 3;
            let nu = grid_points(h[u]);
            let nv = grid_points(h[v]);
            // An edge point of this face lies on the neighbouring face across that edge; keep it only
            // on the face with the lowest axis index among the facing ones.
            let shared = |axis: usize, i: usize, n: usize| -> bool {
                if n <= 1 || axis > a {
                    return false;
                }
                (i == 0 && facing[axis][0]) || (i == n - 1 && facing[axis][1])
            };
            for i in 0..nu {
                if shared(u, i, nu) {
                    continue;
                }
                for j in 0..nv {
                    if shared(v, j, nv) {
                        continue;
                    }
                    let mut local = DVec3::ZERO;
                    local[a] = sign * h[a];
                    local[u] = grid_coord(h[u], i, nu);
                    local[v] = grid_coord(h[v], j, nv);
                    out.push(Sample {
                        p: obb.local_to_sensor(local),
                        kind: SampleKind::Grid,
                        in_view: false,
                        visible: false,
                    });
                    n_pushed += 1;
                }
            }
        }
    }
    n_pushed
}

// ---------------------------------------------------------------------------------------------------
// Model

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
enum Source {
    Moving(usize),
    Stationary(usize),
}

#[derive(Debug, Clone, Copy)]
struct Body {
    source: Source,
    id: Option<u64>,
    obb: Obb,
    /// Bounding-sphere radius, m.
    radius: f64,
    /// Distance of the box centre from the sensor, m.
    dist: f64,
    contains_sensor: bool,
    /// Global pose and twist (for velocities of points).
    centre_global: DVec3,
    velocity: DVec3,
    angular_velocity: DVec3,
}

/// A visible body and what the outputs need of it.
#[derive(Debug, Clone, Copy)]
struct Seen {
    body: usize,
    fraction: f64,
    existence: f64,
    /// Detection point in the sensor frame.
    detection_point: DVec3,
    /// Range of this body's LiDAR points in `Scratch::lidar_points`.
    lidar_start: usize,
    lidar_end: usize,
}

#[derive(Debug, Default)]
struct Scratch {
    bodies: Vec<Body>,
    samples: Vec<Sample>,
    occluders: Vec<usize>,
    seen: Vec<Seen>,
    lidar_points: Vec<DVec3>,
}

#[derive(Debug, Clone, Copy)]
struct Track {
    first_seen_s: f64,
    last_cycle: u64,
    has_moved: bool,
}

/// The ideal object-level sensor model (see the module documentation).
pub struct IdealSensor {
    /// The configuration in force and the granted sensor id.
    handshake: Handshake,
    cycle: u64,
    /// Per (is stationary, GT id): continuous-visibility tracks for age and movement state.
    tracks: HashMap<(bool, u64), Track>,
    scratch: Scratch,
}

impl IdealSensor {
    /// The ideal model of a configuration (a [`CommonConfig`], or anything that converts into one,
    /// such as the JSON sensor configuration).
    pub fn new(config: impl Into<CommonConfig>) -> Self {
        IdealSensor {
            handshake: Handshake::new(config.into()),
            cycle: 0,
            tracks: HashMap::new(),
            scratch: Scratch::default(),
        }
    }

    /// Ground-truth ids and visible fractions (0..1] of the objects reported by the last step, in
    /// output order (moving and stationary objects interleaved as in the ground truth walk).
    pub fn visible_fractions(&self) -> Vec<(u64, f64)> {
        self.scratch
            .seen
            .iter()
            .map(|s| {
                (
                    self.scratch.bodies[s.body]
                        .id
                        .unwrap_or(osiris_proto::INVALID_ID),
                    s.fraction,
                )
            })
            .collect()
    }

    fn in_view(&self, p: DVec3) -> bool {
        let s = Spherical::from_cartesian(p);
        let c = self.handshake.config();
        s.distance > 0.0
            && s.distance <= c.range_m
            && (c.fov_horizontal_rad >= std::f64::consts::TAU - 1e-9
                || s.azimuth.abs() <= 0.5 * c.fov_horizontal_rad + 1e-12)
            && s.elevation.abs() <= 0.5 * c.fov_vertical_rad + 1e-12
    }

    fn existence_probability(&self, fraction: f64) -> f64 {
        let fmin = self.handshake.config().min_visible_fraction;
        if fmin >= 1.0 {
            1.0
        } else {
            (0.5 + 0.5 * (fraction - fmin) / (1.0 - fmin)).clamp(0.0, 1.0)
        }
    }

    /// Build the bodies of a ground truth in the sensor frame.
    fn collect_bodies(
        &mut self,
        gt: &osi3::GroundTruth,
        host_id: Option<u64>,
        frame: &SensorFrame,
    ) {
        let bodies = &mut self.scratch.bodies;
        bodies.clear();
        let mut push = |source: Source,
                        id: Option<u64>,
                        centre: DVec3,
                        rot: DMat3,
                        dim: Option<&osi3::Dimension3d>,
                        v: DVec3,
                        w: DVec3| {
            let half = match dim {
                Some(d) => {
                    0.5 * DVec3::new(
                        d.length.unwrap_or(0.0).abs(),
                        d.width.unwrap_or(0.0).abs(),
                        d.height.unwrap_or(0.0).abs(),
                    )
                }
                None => DVec3::ZERO,
            };
            if !(centre.is_finite() && half.is_finite() && rot.is_finite()) {
                return;
            }
            let obb = Obb::new(
                frame.point_to_sensor(centre),
                frame.rotation_to_sensor(&rot),
                half,
            );
            bodies.push(Body {
                source,
                id,
                obb,
                radius: half.length(),
                dist: obb.center.length(),
                contains_sensor: obb.contains_origin(),
                centre_global: centre,
                velocity: v,
                angular_velocity: w,
            });
        };
        for (i, obj) in gt.moving_object.iter().enumerate() {
            let oid = obj.id.as_ref().and_then(|i| i.value);
            if oid.is_some() && oid == host_id {
                continue;
            }
            let pose = moving_object_pose(obj);
            let (v, w) = moving_object_twist(obj);
            let dim = obj.base.as_ref().and_then(|b| b.dimension.as_ref());
            push(
                Source::Moving(i),
                oid,
                pose.position,
                pose.rotation,
                dim,
                v,
                w,
            );
        }
        for (i, obj) in gt.stationary_object.iter().enumerate() {
            let oid = obj.id.as_ref().and_then(|i| i.value);
            let pose = stationary_object_pose(obj);
            let dim = obj.base.as_ref().and_then(|b| b.dimension.as_ref());
            push(
                Source::Stationary(i),
                oid,
                pose.position,
                pose.rotation,
                dim,
                DVec3::ZERO,
                DVec3::ZERO,
            );
        }
    }

    /// Visibility of every reportable body; fills `scratch.seen` and `scratch.lidar_points`.
    /// Returns the number of face-grid samples tried.
    fn evaluate_visibility(&mut self) -> u64 {
        let mut scratch = std::mem::take(&mut self.scratch);
        scratch.seen.clear();
        scratch.lidar_points.clear();
        let mut grid_tried = 0u64;
        let range = self.handshake.config().range_m;
        for ti in 0..scratch.bodies.len() {
            let b = scratch.bodies[ti];
            if b.id.is_none() || b.contains_sensor || b.dist - b.radius > range {
                continue;
            }
            let samples = &mut scratch.samples;
            samples.clear();
            samples.push(Sample {
                p: b.obb.center,
                kind: SampleKind::Centre,
                in_view: false,
                visible: false,
            });
            samples.push(Sample {
                p: b.obb.closest_point_to_origin(),
                kind: SampleKind::Closest,
                in_view: false,
                visible: false,
            });
            grid_tried += push_face_grid(&b.obb, samples) as u64;
            let mut n_in_view = 0usize;
            for s in samples.iter_mut() {
                s.in_view = self.in_view(s.p);
                n_in_view += usize::from(s.in_view);
            }
            if n_in_view == 0 {
                continue;
            }
            // Broad phase: bodies whose bounding sphere overlaps the cone of sight lines to this body.
            scratch.occluders.clear();
            let dir_t = b.obb.center / b.dist.max(1e-12);
            let alpha_t = if b.dist > b.radius {
                (b.radius / b.dist).asin()
            } else {
                std::f64::consts::PI
            };
            for (oi, o) in scratch.bodies.iter().enumerate() {
                if oi == ti || o.contains_sensor || o.radius <= 0.0 {
                    continue;
                }
                if o.dist - o.radius >= b.dist + b.radius {
                    continue; // entirely beyond the target
                }
                if o.dist > o.radius && alpha_t < std::f64::consts::PI {
                    let alpha_o = (o.radius / o.dist).asin();
                    let cos_sep = (o.obb.center / o.dist).dot(dir_t).clamp(-1.0, 1.0);
                    if cos_sep.acos() > alpha_t + alpha_o + 1e-9 {
                        continue;
                    }
                }
                scratch.occluders.push(oi);
            }
            let mut n_visible = 0usize;
            for s in samples.iter_mut().filter(|s| s.in_view) {
                s.visible = !scratch
                    .occluders
                    .iter()
                    .any(|&oi| scratch.bodies[oi].obb.blocks_segment_to(s.p));
                n_visible += usize::from(s.visible);
            }
            let fraction = n_visible as f64 / n_in_view as f64;
            if n_visible == 0 || fraction < self.handshake.config().min_visible_fraction {
                continue;
            }
            // Detection point: the closest point if seen, else the nearest seen surface sample.
            let closest = samples[1];
            let detection_point = if closest.visible {
                closest.p
            } else {
                samples
                    .iter()
                    .filter(|s| s.visible && s.kind == SampleKind::Grid)
                    .min_by(|a, b| a.p.length_squared().total_cmp(&b.p.length_squared()))
                    .map_or(b.obb.center, |s| s.p)
            };
            let lidar_start = scratch.lidar_points.len();
            scratch.lidar_points.extend(
                samples
                    .iter()
                    .filter(|s| s.visible && s.kind == SampleKind::Grid)
                    .map(|s| s.p),
            );
            scratch.seen.push(Seen {
                body: ti,
                fraction,
                existence: self.existence_probability(fraction),
                detection_point,
                lidar_start,
                lidar_end: scratch.lidar_points.len(),
            });
        }
        self.scratch = scratch;
        grid_tried
    }
}

fn dimension_of(b: &Body) -> osi3::Dimension3d {
    osi3::Dimension3d {
        length: Some(2.0 * b.obb.half.x),
        width: Some(2.0 * b.obb.half.y),
        height: Some(2.0 * b.obb.half.z),
    }
}

/// Reusable parts of the previous output, taken before the output is cleared.
#[derive(Default)]
struct Recycled {
    moving: Vec<osi3::DetectedMovingObject>,
    stationary: Vec<osi3::DetectedStationaryObject>,
    radar: Vec<osi3::RadarDetection>,
    lidar: Vec<osi3::LidarDetection>,
    camera: Vec<osi3::CameraDetection>,
    camera_points: Vec<osi3::CameraPoint>,
    peaks: Vec<perception::RadarPeak>,
    cloud: Option<perception::LidarPerception>,
}

impl Recycled {
    fn take(out: &mut StepOutput) -> Recycled {
        let sd = &mut out.sensor_data;
        let mut r = Recycled {
            moving: std::mem::take(&mut sd.moving_object),
            stationary: std::mem::take(&mut sd.stationary_object),
            ..Default::default()
        };
        if let Some(fd) = sd.feature_data.as_mut() {
            if let Some(x) = fd.radar_sensor.first_mut() {
                r.radar = std::mem::take(&mut x.detection);
            }
            if let Some(x) = fd.lidar_sensor.first_mut() {
                r.lidar = std::mem::take(&mut x.detection);
            }
            if let Some(x) = fd.camera_sensor.first_mut() {
                r.camera = std::mem::take(&mut x.detection);
                r.camera_points = std::mem::take(&mut x.point);
            }
        }
        if let Some(radar) = out.perception.radar.as_mut() {
            r.peaks = std::mem::take(&mut radar.peak);
        }
        r.cloud = out.perception.lidar.take();
        r.moving.clear();
        r.stationary.clear();
        r.radar.clear();
        r.lidar.clear();
        r.camera.clear();
        r.camera_points.clear();
        r.peaks.clear();
        if let Some(c) = r.cloud.as_mut() {
            c.x_m.clear();
            c.y_m.clear();
            c.z_m.clear();
            c.intensity.clear();
            c.timestamp_ns.clear();
            c.channel.clear();
            c.echo.clear();
            c.object_id.clear();
            c.range_rate_m_s.clear();
            c.beat_spectrum.clear();
            c.intensity_scale = None;
            c.wavelength_nm = None;
            c.pulses_fired = None;
        }
        r
    }
}

impl SensorModel for IdealSensor {
    fn kind(&self) -> SensorKind {
        self.handshake.config().kind
    }

    fn mode(&self) -> ModelMode {
        ModelMode::Ideal
    }

    fn config(&self) -> &CommonConfig {
        self.handshake.config()
    }

    fn view_configuration_request(&self) -> osi3::SensorViewConfiguration {
        self.handshake.request()
    }

    /// Adopts a granted FoV or range smaller than the configured one (with a note); larger grants,
    /// missing fields and unusable values are ignored (noted where relevant). Never fails.
    fn apply_view_configuration(
        &mut self,
        granted: &osi3::SensorViewConfiguration,
    ) -> Result<Vec<String>, ModelError> {
        Ok(self.handshake.apply(granted)?.notes)
    }

    fn step(&mut self, input: &StepInput<'_>, out: &mut StepOutput) -> Result<(), ModelError> {
        use osi3::detected_moving_object::{CandidateMovingObject, MovementState, ReferencePoint};
        use osi3::detected_stationary_object::CandidateStationaryObject;

        let rec = Recycled::take(out);
        out.sensor_data.clear();
        out.perception.clear();

        let view = input.view;
        let resolved = ViewFrame::resolve(view, &self.handshake.config().mounting, input.time_s)?;
        let cycle = self.cycle;
        self.cycle += 1;
        let header = FrameHeader::of_view(
            view,
            &resolved,
            self.handshake.sensor_id(),
            cycle,
            ModelMode::Ideal,
        );
        let sensor_id = header.sensor_id;
        let ViewFrame {
            gt,
            host_id,
            mounting,
            frame,
            timestamp: measurement_time,
            ..
        } = resolved;
        let now_s = osiris_proto::timestamp_to_seconds(&measurement_time);

        self.collect_bodies(gt, host_id, &frame);
        let grid_tried = self.evaluate_visibility();

        // Tracks: age and movement history per (kind, GT id), continuous visibility only.
        let mut tracks = std::mem::take(&mut self.tracks);
        let prev_cycle = cycle.wrapping_sub(1);
        let kind = self.handshake.config().kind;
        let sd = &mut out.sensor_data;

        let mut moving = rec.moving;
        let mut stationary = rec.stationary;
        let scratch = &self.scratch;
        for s in &scratch.seen {
            let b = &scratch.bodies[s.body];
            let gid = b.id.unwrap_or(osiris_proto::INVALID_ID);
            let is_stationary = matches!(b.source, Source::Stationary(_));
            let speed = b.velocity.length();
            let track = tracks.entry((is_stationary, gid)).or_insert(Track {
                first_seen_s: now_s,
                last_cycle: cycle,
                has_moved: false,
            });
            if track.last_cycle != prev_cycle && track.last_cycle != cycle {
                *track = Track {
                    first_seen_s: now_s,
                    last_cycle: cycle,
                    has_moved: false,
                };
            }
            track.last_cycle = cycle;
            let movement_state = if speed > MOVING_SPEED_THRESHOLD_M_S {
                track.has_moved = true;
                MovementState::Moving
            } else if track.has_moved {
                MovementState::Stopped
            } else {
                MovementState::Stationary
            };
            let header = osi3::DetectedItemHeader {
                tracking_id: Some(id(gid)),
                ground_truth_id: vec![id(gid)],
                existence_probability: Some(s.existence),
                age: Some((now_s - track.first_seen_s).max(0.0)),
                measurement_state: Some(
                    osi3::detected_item_header::MeasurementState::Measured as i32,
                ),
                sensor_id: sensor_id.into_iter().collect(),
            };
            let orientation = rpy_to_osi(crate::frames::rpy_from_rotation(&b.obb.rot));
            let rcs = match b.source {
                Source::Moving(i) => default_rcs_moving_dbsm(&gt.moving_object[i]),
                Source::Stationary(i) => default_rcs_stationary_dbsm(&gt.stationary_object[i]),
            };
            let radar_specifics = (kind == SensorKind::Radar)
                .then_some(osi3::RadarSpecificObjectData { rcs: Some(rcs) });
            match b.source {
                Source::Moving(i) => {
                    let obj = &gt.moving_object[i];
                    let velocity = frame.relative_velocity(b.centre_global, b.velocity);
                    moving.push(osi3::DetectedMovingObject {
                        header: Some(header),
                        base: Some(osi3::BaseMoving {
                            dimension: Some(dimension_of(b)),
                            position: Some(vec3_to_osi(b.obb.center)),
                            orientation: Some(orientation),
                            velocity: Some(vec3_to_osi(velocity)),
                            ..Default::default()
                        }),
                        reference_point: Some(ReferencePoint::Center as i32),
                        movement_state: Some(movement_state as i32),
                        candidate: vec![CandidateMovingObject {
                            probability: Some(1.0),
                            r#type: obj.r#type,
                            vehicle_classification: obj.vehicle_classification,
                            moving_object_classification: obj.moving_object_classification.clone(),
                            ..Default::default()
                        }],
                        radar_specifics,
                        ..Default::default()
                    });
                }
                Source::Stationary(i) => {
                    let obj = &gt.stationary_object[i];
                    stationary.push(osi3::DetectedStationaryObject {
                        header: Some(header),
                        base: Some(osi3::BaseStationary {
                            dimension: Some(dimension_of(b)),
                            position: Some(vec3_to_osi(b.obb.center)),
                            orientation: Some(orientation),
                            ..Default::default()
                        }),
                        candidate: vec![CandidateStationaryObject {
                            probability: Some(1.0),
                            classification: obj.classification.clone(),
                        }],
                        radar_specifics,
                        ..Default::default()
                    });
                }
            }
        }
        tracks.retain(|_, t| t.last_cycle == cycle);
        self.tracks = tracks;
        sd.moving_object = moving;
        sd.stationary_object = stationary;

        // Raw detections (their headers are filled by `output::finish`).
        let mut fd = osi3::FeatureData::default();
        let p = &mut out.perception;

        match kind {
            SensorKind::Radar => {
                let mut dets = rec.radar;
                let mut peaks = rec.peaks;
                for s in &scratch.seen {
                    let b = &scratch.bodies[s.body];
                    let gid = b.id.unwrap_or(osiris_proto::INVALID_ID);
                    let rcs = match b.source {
                        Source::Moving(i) => default_rcs_moving_dbsm(&gt.moving_object[i]),
                        Source::Stationary(i) => {
                            default_rcs_stationary_dbsm(&gt.stationary_object[i])
                        }
                    };
                    let sph = Spherical::from_cartesian(s.detection_point);
                    let pg = frame.point_to_global(s.detection_point);
                    let v_point = b.velocity + b.angular_velocity.cross(pg - b.centre_global);
                    let range_rate = frame.range_rate(pg, v_point);
                    let snr = ideal_radar_snr_db(rcs, sph.distance);
                    dets.push(osi3::RadarDetection {
                        existence_probability: Some(s.existence),
                        object_id: Some(id(gid)),
                        position: Some(sph.to_osi()),
                        radial_velocity: Some(-range_rate),
                        rcs: Some(rcs),
                        snr: Some(snr),
                        ..Default::default()
                    });
                    peaks.push(perception::RadarPeak {
                        range_m: Some(sph.distance),
                        range_rate_m_s: Some(range_rate),
                        azimuth_rad: Some(sph.azimuth),
                        elevation_rad: Some(sph.elevation),
                        power_dbm: Some(ideal_radar_power_dbm(rcs, sph.distance)),
                        snr_db: Some(snr),
                        rcs_dbsm: Some(rcs),
                        object_id: Some(id(gid)),
                    });
                }
                fd.radar_sensor.push(osi3::RadarDetectionData {
                    header: None,
                    detection: dets,
                });
                p.radar = Some(perception::RadarPerception {
                    peak: peaks,
                    waveform: None,
                    range_doppler_map: None,
                    ..Default::default()
                });
            }
            SensorKind::Lidar => {
                let mut dets = rec.lidar;
                let mut cloud = rec.cloud.unwrap_or_default();
                let t_ns = osiris_proto::timestamp_to_nanos(&measurement_time);
                for s in &scratch.seen {
                    let b = &scratch.bodies[s.body];
                    let gid = b.id.unwrap_or(osiris_proto::INVALID_ID);
                    let intensity = match b.source {
                        Source::Moving(i) => default_lidar_intensity_percent(
                            gt.moving_object[i].model_reference.as_deref(),
                            None,
                        ),
                        Source::Stationary(i) => {
                            let o = &gt.stationary_object[i];
                            default_lidar_intensity_percent(
                                o.model_reference.as_deref(),
                                o.classification.as_ref().and_then(|c| c.r#type),
                            )
                        }
                    };
                    for &pt in &scratch.lidar_points[s.lidar_start..s.lidar_end] {
                        dets.push(osi3::LidarDetection {
                            existence_probability: Some(1.0),
                            object_id: Some(id(gid)),
                            position: Some(Spherical::from_cartesian(pt).to_osi()),
                            intensity: Some(intensity),
                            ..Default::default()
                        });
                        cloud.x_m.push(pt.x as f32);
                        cloud.y_m.push(pt.y as f32);
                        cloud.z_m.push(pt.z as f32);
                        cloud.intensity.push(intensity as f32);
                        cloud.timestamp_ns.push(t_ns);
                        cloud.channel.push(0);
                        cloud.echo.push(0);
                        cloud.object_id.push(gid);
                    }
                }
                cloud.intensity_scale =
                    Some(perception::lidar_perception::IntensityScale::Percent as i32);
                cloud.wavelength_nm = Some(IDEAL_LIDAR_WAVELENGTH_NM);
                cloud.pulses_fired = Some(grid_tried);
                fd.lidar_sensor.push(osi3::LidarDetectionData {
                    header: None,
                    detection: dets,
                });
                p.lidar = Some(cloud);
            }
            SensorKind::Camera => {
                use osi3::camera_detection::ImageShapeType;
                let mut dets = rec.camera;
                let mut points = rec.camera_points;
                for s in &scratch.seen {
                    let b = &scratch.bodies[s.body];
                    let gid = b.id.unwrap_or(osiris_proto::INVALID_ID);
                    let (is_moving, is_vehicle, is_pedestrian, is_animal) = match b.source {
                        Source::Moving(i) => {
                            let t = gt.moving_object[i].r#type;
                            (
                                true,
                                t == Some(osi3::moving_object::Type::Vehicle as i32),
                                t == Some(osi3::moving_object::Type::Pedestrian as i32),
                                t == Some(osi3::moving_object::Type::Animal as i32),
                            )
                        }
                        Source::Stationary(_) => (false, false, false, false),
                    };
                    let first = points.len();
                    let range = b.obb.closest_point_to_origin().length();
                    let corners = crate::semantics::box_corners(b.obb.corners(), range);
                    for c in corners.into_iter().flatten() {
                        points.push(osi3::CameraPoint {
                            existence_probability: Some(s.existence),
                            point: Some(c.to_osi()),
                            point_rmse: None,
                        });
                    }
                    dets.push(osi3::CameraDetection {
                        existence_probability: Some(s.existence),
                        object_id: Some(id(gid)),
                        image_shape_type: Some(ImageShapeType::Box as i32),
                        shape_classification_moving_object: Some(is_moving),
                        shape_classification_stationary_object: Some(!is_moving),
                        shape_classification_vehicle: Some(is_vehicle),
                        shape_classification_pedestrian: Some(is_pedestrian),
                        shape_classification_animal: Some(is_animal),
                        shape_classification_probability: Some(1.0),
                        first_point_index: Some(u32::try_from(first).unwrap_or(u32::MAX)),
                        number_of_points: Some(
                            u32::try_from(points.len() - first).unwrap_or(u32::MAX),
                        ),
                        ..Default::default()
                    });
                }
                let n_points = u32::try_from(points.len()).unwrap_or(u32::MAX);
                fd.camera_sensor.push(osi3::CameraDetectionData {
                    header: None,
                    specific_header: Some(osi3::CameraDetectionSpecificHeader {
                        number_of_valid_points: Some(n_points),
                    }),
                    detection: dets,
                    point: points,
                });
                p.camera = Some(perception::CameraPerception::default());
            }
        }
        out.sensor_data.feature_data = Some(fd);
        // Headers, and the pedestrian poses (the split into moving and stationary objects is by
        // construction).
        finish(
            out,
            &header,
            view,
            self.handshake.config(),
            &PoseFrames::new(&frame, &mounting),
            &|_| None,
        );
        Ok(())
    }

    fn reset(&mut self) {
        self.cycle = 0;
        self.tracks.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn snr_and_power_conventions() {
        assert!((ideal_radar_snr_db(10.0, 100.0) - 20.0).abs() < 1e-12);
        let p = ideal_radar_power_dbm(10.0, 100.0);
        assert!((p + 101.1).abs() < 0.1, "{p}");
        // Constant implied noise floor.
        let n1 = ideal_radar_power_dbm(10.0, 100.0) - ideal_radar_snr_db(10.0, 100.0);
        let n2 = ideal_radar_power_dbm(-5.0, 7.0) - ideal_radar_snr_db(-5.0, 7.0);
        assert!((n1 - n2).abs() < 1e-9 && (n1 + 121.1).abs() < 0.1, "{n1}");
    }

    #[test]
    fn model_reference_parsing() {
        let r = "osiris:board?width_m=1&height_m=1&material=lambertian_50";
        assert_eq!(model_reference_name(r), Some("board"));
        assert_eq!(
            model_reference_param(r, "material").as_deref(),
            Some("lambertian_50")
        );
        assert_eq!(model_reference_param(r, "paint"), None);
        assert_eq!(model_reference_name("osiris:truck"), Some("truck"));
        assert_eq!(default_lidar_intensity_percent(Some(r), None), 50.0);
        assert_eq!(
            default_lidar_intensity_percent(Some("osiris:board?material=lambertian_80"), None),
            80.0
        );
        let t = trihedral_rcs_dbsm(0.1);
        assert!((t - 14.4).abs() < 0.1, "{t}");
    }

    #[test]
    fn slab_test_closed_forms() {
        // Unit cube (half 0.5) centred at (5, 0, 0).
        let b = Obb::new(
            DVec3::new(5.0, 0.0, 0.0),
            DMat3::IDENTITY,
            DVec3::splat(0.5),
        );
        assert!(b.blocks_segment_to(DVec3::new(10.0, 0.0, 0.0)));
        assert!(!b.blocks_segment_to(DVec3::new(4.0, 0.0, 0.0))); // ends before the box
        assert!(!b.blocks_segment_to(DVec3::new(4.5, 0.0, 0.0))); // ends on its face
        assert!(!b.blocks_segment_to(DVec3::new(10.0, 3.0, 0.0))); // passes beside (y = 1.5 at x = 5)
        assert!(b.blocks_segment_to(DVec3::new(10.0, 0.9, 0.0))); // y = 0.45 at x = 5
        // Rotated 45° about z: the corner reaches y = 0.707 at x = 5.
        let r = DMat3::from_rotation_z(std::f64::consts::FRAC_PI_4);
        let b = Obb::new(DVec3::new(5.0, 0.0, 0.0), r, DVec3::splat(0.5));
        assert!(b.blocks_segment_to(DVec3::new(10.0, 1.3, 0.0))); // y = 0.65 at x = 5
        assert!(!b.blocks_segment_to(DVec3::new(10.0, 1.5, 0.0))); // y = 0.75 at x = 5
    }

    #[test]
    fn face_grid_counts() {
        // Looking at the front face of a 4×2×1.5 box head-on from below its top: one face only.
        let b = Obb::new(
            DVec3::new(10.0, 0.0, 0.0),
            DMat3::IDENTITY,
            DVec3::new(2.0, 1.0, 0.75),
        );
        let mut v = Vec::new();
        assert_eq!(push_face_grid(&b, &mut v), 9);
        // Seen from the front-left and above: three faces, shared edges once.
        let b = Obb::new(
            DVec3::new(10.0, -5.0, -3.0),
            DMat3::IDENTITY,
            DVec3::new(1.0, 1.0, 1.0),
        );
        let mut v = Vec::new();
        let n = push_face_grid(&b, &mut v);
        // 3×3 grids on three faces meeting in a corner: 27 − 3 shared edges·3 + 1 shared corner = 19.
        assert_eq!(n, 19);
        for s in &v {
            for t in &v {
                if !std::ptr::eq(s, t) {
                    assert!((s.p - t.p).length() > 1e-9);
                }
            }
        }
    }
}
