//! Radar recognition: detections → tracked objects (OSI `DetectedMovingObject`s) with existence
//! probability.
//!
//! # Pipeline (per step)
//!
//! 1. **Ego-motion compensation** (Kellner, Barjenbruch, Klappstein, Dickmann, Dietmayer,
//!    "Instantaneous ego-motion estimation using Doppler radar", IEEE ITSC 2013): a stationary
//!    target seen along the unit direction `u` (sensor frame) has the range rate
//!    `ṙ_stat = −v_s · u` (`v_s` = sensor-origin velocity in the sensor frame; the sensor's rotation
//!    does not change ranges). The compensated range rate `ṙ_c = ṙ − ṙ_stat = v_target · u` is the
//!    target's own velocity along the line of sight; `|ṙ_c| ≤ moving_threshold_m_s` classifies a
//!    detection as **stationary**.
//! 2. **Below-ground ghosts** (multipath via the road surface): a detection lower (fixed-frame z)
//!    than `z_sensor − sensor_height_m − below_ground_margin_m − 2·r·elevation_std_rad` (the
//!    road, assumed level, minus a margin and twice the elevation uncertainty at range r) is
//!    dropped.
//! 3. **DBSCAN** (Ester, Kriegel, Sander, Xu, "A density-based algorithm for discovering clusters
//!    in large spatial databases with noise", KDD 1996) in the scaled space
//!    `(x / s_p, y / s_p, ṙ_c / s_v)` (`s_p` = `dbscan_position_scale_m`, `s_v` =
//!    `dbscan_velocity_scale_m_s`) with radius `dbscan_eps` and `dbscan_min_points` (1 by default:
//!    a single strong detection is a cluster; temporal persistence rejects false alarms). Noise
//!    points are dropped.
//! 4. **Guardrail ghosts**: the stationary detections are linked in x-y (single linkage, DBSCAN
//!    with one point, radius `guardrail_link_m`: a rail returns at its posts and joints, metres
//!    apart); a group of at least `guardrail_min_points` detections whose principal axis (PCA in
//!    x-y) is at least `guardrail_min_length_m` long and whose RMS distance to that axis is at most
//!    `guardrail_max_rms_m` is a reflecting line segment (guardrail, wall). A moving cluster whose
//!    line of sight from the sensor crosses such a segment and ends more than `ghost_margin_m`
//!    beyond it is a mirror image (the real target is in front of the segment), and a moving
//!    cluster within `rail_band_m` of a segment is Doppler-inconsistent (a moving return sitting on
//!    a static rail: the car → rail → radar path, which the radar places at the rail); both are
//!    dropped. With `ghost_rejection` off, steps 2 and 4 drop nothing.
//! 5. **Tracking** ([`super::tracking`]): a cluster gives its centroid (fixed frame) with covariance
//!    `σ_r²·u uᵀ + (r·σ_az)²·u⊥ u⊥ᵀ + σ_e²·I` (range/azimuth noise rotated into x-y plus the target
//!    extent `σ_e` = `extent_std_m`) and its mean compensated range rate as the EKF radial-velocity
//!    measurement `v · u`. Moving clusters start tentative tracks (velocity `ṙ_c·u`, the unobserved
//!    tangential part with the tracker's `initial_velocity_std_m_s`); stationary clusters only
//!    update existing tracks unless `track_stationary`. M-of-N confirmation is the temporal
//!    persistence check: a single-frame false alarm is never reported.
//! 6. **Output** for confirmed (MEASURED) and coasting (PREDICTED) tracks: the box centre
//!    (OSI's `base.position`) estimated from the track position, which is the reflection
//!    centroid on the face the radar sees: the class's typical box (length L, width W) with the
//!    track's heading is placed behind that face, `centre = c + u·((L/2)|u·h| + (W/2)|u·h⊥|)` with
//!    u the horizontal line of sight to the centroid and h the heading (a track without a heading
//!    is taken to show its rear or front, h = u); heading from the velocity, the class's typical
//!    size, existence probability, age, mean RCS, and class
//!    candidates from a rule-based RCS classifier: Gaussian likelihoods (σ = 5 dB, guessed) around
//!    the ideal model's typical 77 GHz RCS (car 10, truck 20, bicycle 0, pedestrian −5 dBsm, see
//!    [`crate::ideal::default_rcs_moving_dbsm`]), `Unknown` at a 2σ constant. Each input detection
//!    of a cluster that updated (or started) a track reported this cycle belongs to that track
//!    ([`RadarRecognition::detection_objects`]: the OSI `object_id` of its `RadarDetection`).
//! 7. **Free space** ([`super::free_space`], `free_space.enabled`): the detections kept by steps 2
//!    and 4 update a log-odds occupancy grid in the fixed frame (stationary ones occupy their cell,
//!    every ray frees the cells before it) and give the free-space boundary per azimuth sector.

use glam::{DVec2, DVec3};
use osiris_proto::osi3;
use serde::{Deserialize, Serialize};

use super::common::{self, ObjectClass, Report};
use super::free_space::{FreeSpace, FreeSpaceDetection};
use super::tracking::{Measurement, RadialVelocity, Tracker, TrackerConfig};
use super::{EgoState, RadarDetection};
use crate::error::ModelError;

/// The centre of a box of `size_m` (length, width, height) whose face towards `sensor` holds the
/// reflection centroid `centroid` (fixed frame): `centroid + u·((L/2)|u·h| + (W/2)|u·h⊥|)` in the
/// horizontal plane, u the unit line of sight from the sensor to the centroid, h the unit heading
/// (`None`: the box shows its rear or front, h = u). The half-depth is the box's support along u.
pub fn box_centre_behind_face(
    centroid: DVec3,
    sensor: DVec3,
    heading: Option<DVec2>,
    size_m: [f64; 3],
) -> DVec3 {
    let u = (centroid - sensor).truncate().normalize_or_zero();
    if u == DVec2::ZERO {
        return centroid;
    }
    let h = heading.map_or(u, |h| h.normalize_or(u));
    let depth = 0.5 * size_m[0] * u.dot(h).abs() + 0.5 * size_m[1] * u.perp_dot(h).abs();
    centroid + (u * depth).extend(0.0)
}

/// Radar recognition parameters (`radar.recognition` in the sensor configuration).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RadarRecognitionConfig {
    /// Range measurement standard deviation, m (guessed, typical 77 GHz long-range radar).
    pub range_std_m: f64,
    /// Azimuth measurement standard deviation, rad (guessed).
    pub azimuth_std_rad: f64,
    /// Elevation measurement standard deviation, rad (guessed).
    pub elevation_std_rad: f64,
    /// Range-rate measurement standard deviation, m/s (guessed).
    pub range_rate_std_m_s: f64,
    /// Spread of the reflection centroid over an extended target, m (guessed).
    pub extent_std_m: f64,
    /// Compensated |range rate| above which a detection is moving, m/s.
    pub moving_threshold_m_s: f64,
    /// Height of the sensor above the road, m (guessed default: a bumper-mounted radar). The road
    /// is assumed level between the sensor and the target.
    pub sensor_height_m: f64,
    /// Fixed part of the below-ground ghost margin, m.
    pub below_ground_margin_m: f64,
    /// DBSCAN radius in scaled units.
    pub dbscan_eps: f64,
    /// DBSCAN core-point neighbourhood size (including the point itself).
    pub dbscan_min_points: usize,
    /// DBSCAN position scale, m.
    pub dbscan_position_scale_m: f64,
    /// DBSCAN velocity scale, m/s.
    pub dbscan_velocity_scale_m_s: f64,
    /// Fewest stationary detections of a guardrail cluster.
    pub guardrail_min_points: usize,
    /// Shortest guardrail segment, m.
    pub guardrail_min_length_m: f64,
    /// Largest RMS distance of guardrail detections to their line, m.
    pub guardrail_max_rms_m: f64,
    /// A moving cluster this far beyond a guardrail is a ghost, m.
    pub ghost_margin_m: f64,
    /// Stationary detections closer than this in x-y belong to one guardrail candidate, m
    /// (guessed: above the 2–4 m post spacing of a W-beam rail, below a lane's length of gap).
    pub guardrail_link_m: f64,
    /// A moving cluster within this distance of a guardrail line is a ghost (a moving return
    /// cannot sit on a static rail: a car → rail → radar path), m (guessed: the rail's fitted
    /// RMS).
    pub rail_band_m: f64,
    /// Stationary detections weaker than this are road clutter, dBsm: they are not clustered or
    /// tracked, fit no guardrail and occupy no free-space cell (the road up to them is still free). Guessed: road clutter per
    /// resolution cell is σ⁰·A ≈ −40 dBsm at 5–20 m (γ = −20 dB, physics.md §1.9), while posts,
    /// rails and kerbs return −20 dBsm and more.
    pub clutter_max_rcs_dbsm: f64,
    /// Whether stationary clusters start tracks.
    pub track_stationary: bool,
    /// Whether the ghost rejection runs (steps 2 and 4: below-ground detections dropped, mirror
    /// clusters behind a guardrail not tracked). Off, every detection is clustered and tracked;
    /// for measuring the rejection's effect ([`super::radar_stats`]).
    pub ghost_rejection: bool,
    /// Free space and occupancy grid from the detections ([`super::free_space`]).
    pub free_space: super::free_space::FreeSpaceConfig,
    /// Multi-object tracker.
    pub tracker: TrackerConfig,
}

impl Default for RadarRecognitionConfig {
    fn default() -> Self {
        RadarRecognitionConfig {
            range_std_m: 0.15,
            azimuth_std_rad: 0.005,
            elevation_std_rad: 0.02,
            range_rate_std_m_s: 0.1,
            extent_std_m: 0.3,
            moving_threshold_m_s: 0.5,
            sensor_height_m: 0.5,
            below_ground_margin_m: 0.5,
            dbscan_eps: 1.0,
            dbscan_min_points: 1,
            dbscan_position_scale_m: 2.0,
            dbscan_velocity_scale_m_s: 1.0,
            guardrail_min_points: 3,
            guardrail_min_length_m: 5.0,
            guardrail_max_rms_m: 0.5,
            ghost_margin_m: 1.0,
            guardrail_link_m: 6.0,
            clutter_max_rcs_dbsm: -25.0,
            rail_band_m: 0.5,
            track_stationary: false,
            ghost_rejection: true,
            free_space: super::free_space::FreeSpaceConfig::default(),
            tracker: TrackerConfig::default(),
        }
    }
}

impl RadarRecognitionConfig {
    /// Checks the values (keys named `radar.recognition.*`).
    pub fn validate(&self) -> Result<(), ModelError> {
        for (key, v) in [
            ("range_std_m", self.range_std_m),
            ("azimuth_std_rad", self.azimuth_std_rad),
            ("elevation_std_rad", self.elevation_std_rad),
            ("range_rate_std_m_s", self.range_rate_std_m_s),
            ("moving_threshold_m_s", self.moving_threshold_m_s),
            ("dbscan_eps", self.dbscan_eps),
            ("dbscan_position_scale_m", self.dbscan_position_scale_m),
            ("dbscan_velocity_scale_m_s", self.dbscan_velocity_scale_m_s),
            ("guardrail_min_length_m", self.guardrail_min_length_m),
            ("guardrail_max_rms_m", self.guardrail_max_rms_m),
            ("guardrail_link_m", self.guardrail_link_m),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(ModelError::Config(format!(
                    "radar.recognition.{key} must be a positive number (got {v})"
                )));
            }
        }
        for (key, v) in [
            ("extent_std_m", self.extent_std_m),
            ("below_ground_margin_m", self.below_ground_margin_m),
            ("ghost_margin_m", self.ghost_margin_m),
            ("rail_band_m", self.rail_band_m),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(ModelError::Config(format!(
                    "radar.recognition.{key} must be a non-negative number (got {v})"
                )));
            }
        }
        if self.clutter_max_rcs_dbsm.is_nan() {
            return Err(ModelError::Config(
                "radar.recognition.clutter_max_rcs_dbsm must be a number (dBsm; -inf: no clutter filter)"
                    .into(),
            ));
        }
        if !(self.sensor_height_m.is_finite() && self.sensor_height_m >= 0.0) {
            return Err(ModelError::Config(format!(
                "radar.recognition.sensor_height_m must be a non-negative number (got {})",
                self.sensor_height_m
            )));
        }
        if self.dbscan_min_points == 0 {
            return Err(ModelError::Config(
                "radar.recognition.dbscan_min_points must be at least 1".into(),
            ));
        }
        if self.guardrail_min_points < 2 {
            return Err(ModelError::Config(
                "radar.recognition.guardrail_min_points must be at least 2".into(),
            ));
        }
        self.free_space.validate("radar.recognition.free_space")?;
        self.tracker.validate("radar.recognition.tracker")
    }
}

/// A detection after compensation (fixed frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CompensatedDetection {
    /// Position, fixed frame, m.
    pub position_m: DVec3,
    /// Ego-compensated range rate `v_target · u`, m/s.
    pub range_rate_m_s: f64,
    pub range_m: f64,
    pub moving: bool,
    /// Rejected as a below-ground ghost.
    pub below_ground: bool,
    /// Stationary and weaker than `clutter_max_rcs_dbsm`: a return of the road surface itself.
    pub clutter: bool,
}

/// A cluster of detections (fixed frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RadarCluster {
    /// Centroid, m.
    pub position_m: DVec3,
    /// Mean compensated range rate, m/s.
    pub range_rate_m_s: f64,
    /// Mean RCS, dBsm.
    pub rcs_dbsm: f64,
    pub n_detections: usize,
    pub moving: bool,
    /// Rejected as a mirror image behind a guardrail.
    pub ghost: bool,
    pub ground_truth_id: Option<u64>,
}

/// A fitted guardrail / wall segment (fixed frame, x-y).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LineSegment {
    pub a: DVec2,
    pub b: DVec2,
}

/// Ego-compensated range rate of a detection (see the module documentation, step 1), m/s.
pub fn compensated_range_rate(ego: &EgoState, d: &RadarDetection) -> f64 {
    let u = direction(d.azimuth_rad, d.elevation_rad);
    let v_s = ego
        .sensor_pose
        .inverse_transform_vector(ego.sensor_velocity_m_s);
    d.range_rate_m_s + v_s.dot(u)
}

fn direction(az: f64, el: f64) -> DVec3 {
    DVec3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin())
}

/// DBSCAN over `points` (already scaled) with radius `eps` and `min_points`; `labels[i]` = cluster
/// label (0, 1, …) or −1 for noise. O(n²) neighbour search (radar frames hold at most a few
/// hundred detections).
pub fn dbscan(
    points: &[[f64; 3]],
    eps: f64,
    min_points: usize,
    labels: &mut Vec<i32>,
    queue: &mut Vec<usize>,
) {
    const UNSEEN: i32 = -2;
    let n = points.len();
    labels.clear();
    labels.resize(n, UNSEEN);
    let eps2 = eps * eps;
    let d2 = |a: &[f64; 3], b: &[f64; 3]| {
        (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)
    };
    let count = |i: usize| points.iter().filter(|q| d2(&points[i], q) <= eps2).count();
    let mut next = 0;
    for i in 0..n {
        if labels[i] != UNSEEN {
            continue;
        }
        if count(i) < min_points {
            labels[i] = -1;
            continue;
        }
        labels[i] = next;
        queue.clear();
        queue.push(i);
        let mut head = 0;
        while head < queue.len() {
            let k = queue[head];
            head += 1;
            let core = k == i || count(k) >= min_points;
            if !core {
                continue;
            }
            for m in 0..n {
                if d2(&points[k], &points[m]) <= eps2 && (labels[m] == UNSEEN || labels[m] == -1) {
                    let was_unseen = labels[m] == UNSEEN;
                    labels[m] = next;
                    if was_unseen {
                        queue.push(m);
                    }
                }
            }
        }
        next += 1;
    }
}

/// Distance in x-y from `p` to the segment `seg`, m.
pub fn distance_to_segment(p: DVec2, seg: &LineSegment) -> f64 {
    let e = seg.b - seg.a;
    let l2 = e.length_squared();
    let s = if l2 > 0.0 {
        ((p - seg.a).dot(e) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (seg.a + s * e - p).length()
}

/// Whether the line of sight from `sensor` to `target` crosses `seg` and `target` lies more than
/// `margin_m` beyond it.
pub fn behind_segment(sensor: DVec2, target: DVec2, seg: &LineSegment, margin_m: f64) -> bool {
    let d = target - sensor;
    let e = seg.b - seg.a;
    let denom = d.perp_dot(e);
    if denom.abs() < 1e-12 {
        return false;
    }
    let w = seg.a - sensor;
    let t = w.perp_dot(e) / denom; // along the line of sight, 1 = target
    let s = w.perp_dot(d) / denom; // along the segment
    let len = d.length();
    (0.0..=1.0).contains(&s) && t > 0.0 && (1.0 - t) * len > margin_m
}

#[derive(Debug, Clone, Default)]
struct TrackAttr {
    centre_z_m: f64,
    rcs_dbsm: f64,
    class_probabilities: [f64; 5],
    ground_truth_id: Option<u64>,
    has_moved: bool,
}

/// Radar object recognition with tracking (state kept across steps).
#[derive(Debug, Clone)]
pub struct RadarRecognition {
    config: RadarRecognitionConfig,
    tracker: Tracker<TrackAttr>,
    frame_jump: common::FrameJump,
    compensated: Vec<CompensatedDetection>,
    kept: Vec<usize>,
    scaled: Vec<[f64; 3]>,
    labels: Vec<i32>,
    queue: Vec<usize>,
    members: Vec<usize>,
    ids: Vec<u64>,
    clusters: Vec<RadarCluster>,
    guardrails: Vec<LineSegment>,
    measurements: Vec<Measurement>,
    meas_cluster: Vec<usize>,
    assignment: Vec<Option<usize>>,
    /// Per input detection: the index of its cluster in `clusters` (`u32::MAX`: none).
    det_cluster: Vec<u32>,
    /// Per cluster: the id of the track it updated or started this cycle, kept only when that
    /// track is reported.
    cluster_track: Vec<Option<u64>>,
    /// Per input detection: the tracking id of the reported object it belongs to.
    detection_objects: Vec<Option<u64>>,
    /// (tracking id, ground truth of its last update) of the objects reported by the last step.
    reported: Vec<(u64, Option<u64>)>,
    /// Occupancy grid and free-space boundary (`None` when `free_space.enabled` is off).
    free_space: Option<FreeSpace>,
    /// Horizontal field of view, rad, and range, m, for the free-space sectors.
    field_of_view: (f64, f64),
}

impl RadarRecognition {
    pub fn new(config: &RadarRecognitionConfig) -> Result<RadarRecognition, ModelError> {
        config.validate()?;
        Ok(RadarRecognition {
            config: config.clone(),
            tracker: Tracker::new(config.tracker.clone()),
            frame_jump: common::FrameJump::default(),
            compensated: Vec::new(),
            kept: Vec::new(),
            scaled: Vec::new(),
            labels: Vec::new(),
            queue: Vec::new(),
            members: Vec::new(),
            ids: Vec::new(),
            clusters: Vec::new(),
            guardrails: Vec::new(),
            measurements: Vec::new(),
            meas_cluster: Vec::new(),
            assignment: Vec::new(),
            det_cluster: Vec::new(),
            cluster_track: Vec::new(),
            detection_objects: Vec::new(),
            reported: Vec::new(),
            free_space: if config.free_space.enabled {
                Some(FreeSpace::new(&config.free_space)?)
            } else {
                None
            },
            field_of_view: (std::f64::consts::FRAC_PI_2, 100.0),
        })
    }

    /// The sensor's horizontal field of view (rad) and range (m) in force, for the free-space
    /// sectors (set before [`RadarRecognition::step`] when they change).
    pub fn set_field_of_view(&mut self, horizontal_rad: f64, range_m: f64) {
        self.field_of_view = (horizontal_rad, range_m);
    }

    /// The occupancy grid and free-space boundary after the last step (`None`: disabled).
    pub fn free_space(&self) -> Option<&FreeSpace> {
        self.free_space.as_ref()
    }

    /// The compensated detections of the last step (same order as the input).
    pub fn compensated(&self) -> &[CompensatedDetection] {
        &self.compensated
    }
    /// The clusters of the last step (ghosts flagged).
    pub fn clusters(&self) -> &[RadarCluster] {
        &self.clusters
    }
    /// The guardrail segments of the last step.
    pub fn guardrails(&self) -> &[LineSegment] {
        &self.guardrails
    }

    /// One cycle: `detections` (sensor frame) → detected moving objects (sensor frame) appended
    /// to `out`.
    pub fn step(
        &mut self,
        ego: &EgoState,
        detections: &[RadarDetection],
        out: &mut Vec<osi3::DetectedMovingObject>,
    ) {
        self.detect(ego, detections);
        self.track(ego, out);
        if let Some(fs) = &mut self.free_space {
            // Step 7: the kept detections (not below ground, not in a mirror cluster).
            let (comp, det_cluster, clusters) =
                (&self.compensated, &self.det_cluster, &self.clusters);
            let kept = comp.iter().zip(det_cluster).filter_map(|(d, &k)| {
                // Road clutter is in no cluster, but frees the road up to it.
                let ghost = !d.clutter && clusters.get(k as usize)?.ghost;
                (!d.below_ground && !ghost).then_some(FreeSpaceDetection {
                    position_m: d.position_m,
                    moving: d.moving,
                    clutter: d.clutter,
                })
            });
            fs.update(ego, kept, self.field_of_view.0, self.field_of_view.1);
        }
        self.detection_objects.clear();
        self.detection_objects.extend(
            self.det_cluster
                .iter()
                .map(|&c| self.cluster_track.get(c as usize).copied().flatten()),
        );
    }

    /// Per input detection of the last [`RadarRecognition::step`] (same order): the
    /// `tracking_id` of the reported object whose cluster the detection was part of, `None` when it
    /// belongs to no reported object (below-ground or guardrail ghosts, DBSCAN noise, stationary
    /// clusters no track claimed, tentative tracks).
    pub fn detection_objects(&self) -> &[Option<u64>] {
        &self.detection_objects
    }

    /// `(tracking id, ground-truth id of its last update)` of every object the last step reported
    /// (a coasting track keeps the ground truth of its last update here, while its header has none).
    pub fn reported_ground_truth(&self) -> &[(u64, Option<u64>)] {
        &self.reported
    }

    /// Steps 1–4: compensated detections, clusters, guardrails and ghost flags.
    pub fn detect(&mut self, ego: &EgoState, detections: &[RadarDetection]) {
        let c = &self.config;
        self.compensated.clear();
        self.kept.clear();
        for (i, d) in detections.iter().enumerate() {
            let ok = d.range_m.is_finite()
                && d.range_m > 0.0
                && d.azimuth_rad.is_finite()
                && d.elevation_rad.is_finite()
                && d.range_rate_m_s.is_finite();
            let p_s = direction(d.azimuth_rad, d.elevation_rad) * d.range_m;
            let p = ego.sensor_pose.transform_point(p_s);
            let rr = compensated_range_rate(ego, d);
            let floor = ego.sensor_pose.position.z
                - c.sensor_height_m
                - c.below_ground_margin_m
                - 2.0 * d.range_m * c.elevation_std_rad;
            let below = c.ghost_rejection && ok && p.z < floor;
            let clutter = rr.abs() <= c.moving_threshold_m_s
                && d.rcs_dbsm.is_finite()
                && d.rcs_dbsm < c.clutter_max_rcs_dbsm;
            self.compensated.push(CompensatedDetection {
                position_m: p,
                range_rate_m_s: rr,
                range_m: d.range_m,
                moving: rr.abs() > c.moving_threshold_m_s,
                below_ground: below,
                clutter,
            });
            if ok && !below && !clutter {
                self.kept.push(i);
            }
        }
        self.scaled.clear();
        for &i in &self.kept {
            let d = &self.compensated[i];
            self.scaled.push([
                d.position_m.x / c.dbscan_position_scale_m,
                d.position_m.y / c.dbscan_position_scale_m,
                d.range_rate_m_s / c.dbscan_velocity_scale_m_s,
            ]);
        }
        dbscan(
            &self.scaled,
            c.dbscan_eps,
            c.dbscan_min_points,
            &mut self.labels,
            &mut self.queue,
        );
        let n_labels = self.labels.iter().copied().max().map_or(0, |m| m + 1);
        self.det_cluster.clear();
        self.det_cluster.resize(detections.len(), u32::MAX);
        self.clusters.clear();
        self.guardrails.clear();
        // Per-cluster statistics (O(n · clusters); small).
        for l in 0..n_labels {
            self.members.clear();
            self.members.extend(
                self.labels
                    .iter()
                    .enumerate()
                    .filter(|(_, x)| **x == l)
                    .map(|(k, _)| self.kept[k]),
            );
            if self.members.is_empty() {
                continue;
            }
            let n = self.members.len() as f64;
            let mut pos = DVec3::ZERO;
            let mut rr = 0.0;
            let mut rcs = 0.0;
            let mut moving = 0usize;
            self.ids.clear();
            for &i in &self.members {
                let d = &self.compensated[i];
                pos += d.position_m;
                rr += d.range_rate_m_s;
                let r = detections[i].rcs_dbsm;
                rcs += if r.is_finite() { r } else { 0.0 };
                moving += usize::from(d.moving);
                self.ids.push(detections[i].object_id);
            }
            let gt = common::most_frequent_id(&mut self.ids);
            for &i in &self.members {
                self.det_cluster[i] = self.clusters.len() as u32;
            }
            let moving = 2 * moving > self.members.len();
            self.clusters.push(RadarCluster {
                position_m: pos / n,
                range_rate_m_s: rr / n,
                rcs_dbsm: rcs / n,
                n_detections: self.members.len(),
                moving,
                ghost: false,
                ground_truth_id: gt,
            });
        }
        // Guardrails: the stationary detections linked in x-y within `guardrail_link_m` (a rail
        // returns at its posts and joints, metres apart, so the (x, y, ṙ) clusters split it).
        self.members.clear();
        self.members.extend(
            self.kept
                .iter()
                .copied()
                .filter(|&i| !self.compensated[i].moving),
        );
        self.scaled.clear();
        for &i in &self.members {
            let p = self.compensated[i].position_m;
            self.scaled
                .push([p.x / c.guardrail_link_m, p.y / c.guardrail_link_m, 0.0]);
        }
        dbscan(&self.scaled, 1.0, 1, &mut self.labels, &mut self.queue);
        let n_rails = self.labels.iter().copied().max().map_or(0, |m| m + 1);
        for l in 0..n_rails {
            let points = self
                .members
                .iter()
                .zip(&self.labels)
                .filter(move |(_, x)| **x == l)
                .map(|(&i, _)| self.compensated[i].position_m.truncate());
            if points.clone().count() >= c.guardrail_min_points
                && let Some(seg) =
                    fit_segment(points, c.guardrail_min_length_m, c.guardrail_max_rms_m)
            {
                self.guardrails.push(seg);
            }
        }
        let sensor = ego.sensor_pose.position.truncate();
        for cl in &mut self.clusters {
            if cl.moving && c.ghost_rejection {
                let p = cl.position_m.truncate();
                cl.ghost = self.guardrails.iter().any(|g| {
                    behind_segment(sensor, p, g, c.ghost_margin_m)
                        || distance_to_segment(p, g) <= c.rail_band_m
                });
            }
        }
    }

    fn track(&mut self, ego: &EgoState, out: &mut Vec<osi3::DetectedMovingObject>) {
        let c = &self.config;
        let t = ego.time_s;
        let sensor = ego.sensor_pose.position.truncate();
        if let Some(d) = self.frame_jump.check(ego) {
            self.tracker.shift([d.x, d.y]);
            for tr in self.tracker.tracks_mut() {
                tr.attr.centre_z_m += d.z;
            }
        }
        self.tracker.predict(t);
        self.measurements.clear();
        self.meas_cluster.clear();
        for (k, cl) in self.clusters.iter().enumerate() {
            if cl.ghost {
                continue;
            }
            let rel = cl.position_m.truncate() - sensor;
            let r = rel.length().max(1e-3);
            let u = rel / r;
            let w = u.perp();
            let vr = c.range_std_m.powi(2);
            let va = (r * c.azimuth_std_rad).powi(2);
            let ve = c.extent_std_m.powi(2);
            let cov = [
                [
                    vr * u.x * u.x + va * w.x * w.x + ve,
                    vr * u.x * u.y + va * w.x * w.y,
                ],
                [
                    vr * u.x * u.y + va * w.x * w.y,
                    vr * u.y * u.y + va * w.y * w.y + ve,
                ],
            ];
            self.measurements.push(Measurement {
                position_m: [cl.position_m.x, cl.position_m.y],
                position_cov_m2: cov,
                velocity: None,
                radial: Some(RadialVelocity {
                    value_m_s: cl.range_rate_m_s,
                    direction: [u.x, u.y],
                    variance_m2_s2: c.range_rate_std_m_s.powi(2),
                }),
            });
            self.meas_cluster.push(k);
        }
        self.tracker
            .associate(&self.measurements, |_, _| true, &mut self.assignment);
        self.cluster_track.clear();
        self.cluster_track.resize(self.clusters.len(), None);
        for j in 0..self.measurements.len() {
            let cl = self.clusters[self.meas_cluster[j]];
            let probs = rcs_class_probabilities(cl.rcs_dbsm);
            match self.assignment[j] {
                Some(i) => {
                    self.tracker.update(i, &self.measurements[j]);
                    self.cluster_track[self.meas_cluster[j]] = Some(self.tracker.tracks()[i].id);
                    let a = &mut self.tracker.tracks_mut()[i].attr;
                    const ALPHA: f64 = 0.3;
                    a.centre_z_m += ALPHA * (cl.position_m.z - a.centre_z_m);
                    a.rcs_dbsm += ALPHA * (cl.rcs_dbsm - a.rcs_dbsm);
                    a.class_probabilities = rcs_class_probabilities(a.rcs_dbsm);
                    a.ground_truth_id = cl.ground_truth_id;
                }
                None if cl.moving || c.track_stationary => {
                    let m = self.measurements[j];
                    let rv = m
                        .radial
                        .expect("radar measurements carry a radial velocity");
                    let v = [
                        rv.direction[0] * rv.value_m_s,
                        rv.direction[1] * rv.value_m_s,
                    ];
                    let cov = self
                        .tracker
                        .velocity_cov_from_radial(rv.direction, rv.variance_m2_s2);
                    let i = self.tracker.spawn(
                        &m,
                        v,
                        cov,
                        t,
                        TrackAttr {
                            centre_z_m: cl.position_m.z,
                            rcs_dbsm: cl.rcs_dbsm,
                            class_probabilities: probs,
                            ground_truth_id: cl.ground_truth_id,
                            has_moved: false,
                        },
                    );
                    self.cluster_track[self.meas_cluster[j]] = Some(self.tracker.tracks()[i].id);
                }
                None => {}
            }
        }
        self.tracker.finish_cycle();
        self.reported.clear();
        for tr in self.tracker.tracks_mut() {
            if !tr.is_reported() {
                continue;
            }
            self.reported.push((tr.id, tr.attr.ground_truth_id));
            let speed = tr.speed_m_s();
            let a = &mut tr.attr;
            let movement = common::movement_state(speed, &mut a.has_moved);
            let yaw = if speed > common::MOVING_SPEED_M_S {
                tr.x[3].atan2(tr.x[2])
            } else {
                0.0
            };
            let k = (0..5)
                .max_by(|&x, &y| a.class_probabilities[x].total_cmp(&a.class_probabilities[y]))
                .unwrap_or(4);
            let size = ObjectClass::ALL[k].typical_size_m();
            let centroid = DVec3::new(tr.x[0], tr.x[1], a.centre_z_m);
            let heading = (speed > common::MOVING_SPEED_M_S).then(|| DVec2::from_angle(yaw));
            out.push(common::detected_object(
                ego,
                &Report {
                    centre_m: box_centre_behind_face(
                        centroid,
                        ego.sensor_pose.position,
                        heading,
                        size,
                    ),
                    yaw_rad: yaw,
                    size_m: size,
                    velocity_m_s: DVec3::new(tr.x[2], tr.x[3], 0.0),
                    track_id: tr.id,
                    ground_truth_id: if tr.updated { a.ground_truth_id } else { None },
                    existence: tr.existence,
                    age_s: t - tr.birth_time_s,
                    measured: tr.updated,
                    movement,
                    class_probabilities: &a.class_probabilities,
                    rcs_dbsm: Some(a.rcs_dbsm),
                },
            ));
        }
        // A cluster's detections belong to its track's object only when that track is reported and
        // was updated by the cluster this cycle.
        let reported = &self.reported;
        let tracks = self.tracker.tracks();
        for t in &mut self.cluster_track {
            *t = t.filter(|id| {
                reported.iter().any(|r| r.0 == *id)
                    && tracks.iter().any(|tr| tr.id == *id && tr.updated)
            });
        }
    }

    /// The tracks (for inspection), with their existence probabilities.
    pub fn track_existence(&self) -> impl Iterator<Item = (u64, f64, bool)> + '_ {
        self.tracker
            .tracks()
            .iter()
            .map(|t| (t.id, t.existence, t.is_reported()))
    }

    /// Forget all tracks.
    pub fn reset(&mut self) {
        self.tracker.reset();
        self.frame_jump.reset();
        self.clusters.clear();
        self.guardrails.clear();
        self.compensated.clear();
        self.det_cluster.clear();
        self.cluster_track.clear();
        self.detection_objects.clear();
        self.reported.clear();
        if let Some(fs) = &mut self.free_space {
            fs.reset();
        }
    }
}

/// Class probabilities from a mean RCS (see the module documentation, step 6).
pub fn rcs_class_probabilities(rcs_dbsm: f64) -> [f64; 5] {
    const SIGMA_DB: f64 = 5.0;
    let typical = [10.0, 20.0, -5.0, 0.0];
    let mut p = [0.0; 5];
    for k in 0..4 {
        p[k] = (-0.5 * ((rcs_dbsm - typical[k]) / SIGMA_DB).powi(2)).exp();
    }
    p[4] = (-0.5 * 4.0f64).exp();
    let s: f64 = p.iter().sum();
    p.map(|v| v / s)
}

/// PCA line fit of x-y points: the segment spanned along the principal axis, if at least
/// `min_length_m` long with an RMS perpendicular distance of at most `max_rms_m`.
pub fn fit_segment(
    points: impl Iterator<Item = DVec2> + Clone,
    min_length_m: f64,
    max_rms_m: f64,
) -> Option<LineSegment> {
    let mut n = 0.0;
    let mut mean = DVec2::ZERO;
    for p in points.clone() {
        n += 1.0;
        mean += p;
    }
    if n < 2.0 {
        return None;
    }
    mean /= n;
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for p in points.clone() {
        let q = p - mean;
        sxx += q.x * q.x;
        sxy += q.x * q.y;
        syy += q.y * q.y;
    }
    // Principal axis of the 2×2 scatter matrix.
    let angle = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    let e = DVec2::new(angle.cos(), angle.sin());
    let (mut lo, mut hi, mut perp2) = (f64::INFINITY, f64::NEG_INFINITY, 0.0);
    for p in points {
        let q = p - mean;
        let s = q.dot(e);
        lo = lo.min(s);
        hi = hi.max(s);
        perp2 += q.perp_dot(e).powi(2);
    }
    let rms = (perp2 / n).sqrt();
    (hi - lo >= min_length_m && rms <= max_rms_m).then(|| LineSegment {
        a: mean + lo * e,
        b: mean + hi * e,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_centre_lies_behind_the_seen_face() {
        let car = [4.5, 1.8, 1.5];
        let s = DVec3::new(0.0, 0.0, 0.5);
        // Rear face seen straight on (heading away): L/2 behind it.
        let c = box_centre_behind_face(DVec3::new(20.0, 0.0, 0.7), s, Some(DVec2::X), car);
        assert!((c - DVec3::new(22.25, 0.0, 0.7)).length() < 1e-12, "{c}");
        // Crossing at 90°: W/2 behind the side.
        let c = box_centre_behind_face(DVec3::new(20.0, 0.0, 0.7), s, Some(DVec2::Y), car);
        assert!((c - DVec3::new(20.9, 0.0, 0.7)).length() < 1e-12, "{c}");
        // Line of sight at 30° to the heading: (L/2)cos 30° + (W/2)sin 30° along u.
        let u = DVec2::from_angle(30f64.to_radians());
        let p = (u * 10.0).extend(0.7);
        let c = box_centre_behind_face(p, DVec3::ZERO, Some(DVec2::X), car);
        let d = 2.25 * 30f64.to_radians().cos() + 0.9 * 0.5;
        assert!((c - (u * (10.0 + d)).extend(0.7)).length() < 1e-12, "{c}");
        // No heading: the rear or front is seen.
        let c = box_centre_behind_face(DVec3::new(0.0, -8.0, 0.0), DVec3::ZERO, None, car);
        assert!((c - DVec3::new(0.0, -10.25, 0.0)).length() < 1e-12, "{c}");
    }

    #[test]
    fn dbscan_two_blobs_and_noise() {
        let pts = [
            [0.0, 0.0, 0.0],
            [0.5, 0.0, 0.0],
            [0.0, 0.5, 0.0],
            [10.0, 0.0, 0.0],
            [10.4, 0.2, 0.0],
            [10.0, 0.3, 0.0],
            [50.0, 0.0, 0.0],
        ];
        let (mut l, mut q) = (Vec::new(), Vec::new());
        dbscan(&pts, 1.0, 2, &mut l, &mut q);
        assert_eq!(l, vec![0, 0, 0, 1, 1, 1, -1]);
        dbscan(&pts, 1.0, 1, &mut l, &mut q);
        assert_eq!(l[6], 2);
    }

    #[test]
    fn segment_crossing() {
        let seg = LineSegment {
            a: DVec2::new(0.0, 5.0),
            b: DVec2::new(50.0, 5.0),
        };
        let s = DVec2::ZERO;
        assert!(behind_segment(s, DVec2::new(20.0, 10.0), &seg, 1.0));
        assert!(!behind_segment(s, DVec2::new(20.0, 3.0), &seg, 1.0));
        assert!(!behind_segment(s, DVec2::new(20.0, 5.2), &seg, 1.0)); // 0.79 m beyond: within the margin
        assert!(!behind_segment(s, DVec2::new(100.0, 6.0), &seg, 1.0)); // crosses y = 5 at x = 83
    }

    #[test]
    fn rcs_classes() {
        let p = rcs_class_probabilities(10.0);
        assert!(p[0] > 0.5, "{p:?}");
        let p = rcs_class_probabilities(-6.0);
        assert!(p[2] > p[0], "{p:?}");
    }
}
