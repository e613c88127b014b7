//! LiDAR recognition: point cloud → tracked oriented boxes (OSI `DetectedMovingObject`s).
//!
//! # Pipeline (per step)
//!
//! 1. **Fixed frame.** Points (sensor frame) are mapped with `EgoState::sensor_pose` into the fixed
//!    frame, whose +z is taken as "up".
//! 2. **Ground segmentation** by RANSAC (Fischler & Bolles, "Random sample consensus", CACM 24(6),
//!    1981): planes through 3 random points whose normal is within `ground_max_tilt_rad` of +z,
//!    scored by the number of points within `ground_inlier_distance_m` (on a strided subset of at
//!    most [`RANSAC_SCORE_POINTS`] points), refined by a least-squares fit `z = a·x + b·y + c` over
//!    all inliers. Inliers and points below the plane are removed; so are points higher than
//!    `max_height_above_ground_m`. The RNG is `SmallRng::seed_from_u64(seed)` every step, so the
//!    result depends only on the input.
//! 3. **Euclidean clustering** (Rusu, "Semantic 3D object maps for everyday manipulation in human
//!    living environments", PhD thesis TU München 2009, §4.3; PCL `EuclideanClusterExtraction`):
//!    region growing; neighbours within `cluster_tolerance_m` vertically and within a
//!    range-adaptive horizontal radius ([`adaptive_tolerance_m`]: samples `Δφ` apart on a surface
//!    seen at grazing incidence are `ρ·sin Δφ / sin(λ − Δφ)` apart), found through a voxel grid of
//!    edge `cluster_tolerance_m` (sorted cell keys). Clusters with fewer than
//!    `min_cluster_points` or more than `max_cluster_points` points are dropped.
//!    **Fragment merge**: sparse scan rows on a roof below the sensor (row spacing
//!    `Δρ ≈ ρ²·Δθ/Δh`, ≈ 2 m at 10 m for Δθ = 0.3°, Δh = 0.3 m) and single scan columns on side faces
//!    seen at very grazing incidence come out as separate clusters. After a first box fit (steps
//!    4–6), every cluster lying entirely inside the expected box of a larger vehicle cluster (grown
//!    by `merge_margin_m`, top at most `merge_margin_m` above it) is merged into it and the box is
//!    refitted. (An object hidden inside that expected box — e.g. a low object right behind a
//!    car — is merged too; the data cannot tell them apart.)
//! 4. **Oriented box** by the search-based L-shape fit with the closeness criterion (Zhang, Xu, Wang,
//!    Zhou, Cheng, "Efficient L-shape fitting for vehicle detection using laser scanners", IEEE IV
//!    2017): the heading θ ∈ [0, 90°) maximising `Σ 1 / max(min(d₁, d₂), d₀)` (d = distance of a
//!    point to the nearer rectangle edge along each axis, d₀ = 1 cm), on a 1° grid refined to 0.1°.
//!    Height: from the ground plane under the cluster to its highest point.
//! 5. **Classification** (rule-based, not learned): each class has a typical size
//!    ([`ObjectClass::typical_size_m`]); the cost `((m₁ − L)₊/σ)² + ((W − m₁)₊/σ)² + ((m₂ − W)₊/σ)² +
//!    ((h − H)/σ_h)²` of the measured largest/smallest horizontal extents `m₁ ≥ m₂` and height `h`
//!    treats the horizontal extents as lower bounds of the true size (one side may be hidden) with
//!    σ = 0.4 m, σ_h = 0.25 m (guessed); `Unknown` has the constant cost 9 (a 3σ miss). Scores
//!    `∝ prior·exp(−cost/2)` ([`CLASS_PRIOR`]), normalised; smoothed over the track's life.
//! 6. **Visible-side correction.** The length axis is the axis of the larger extent when that
//!    extent exceeds the class's width by more than 0.3 m, else (only one face seen) the axis closer
//!    to the line of sight. For classes that [`ObjectClass::extend_to_typical`], each horizontal
//!    size is at least the typical one; when an extent is shorter, the box is anchored at the face
//!    nearer to the sensor and extended away from it (the far faces are hidden).
//! 7. **Tracking** ([`super::tracking`]): box centres as position measurements (σ =
//!    `position_std_m`); yaw (modulo π, flipped to the velocity direction when moving), size, centre
//!    height and class scores are exponentially smoothed per track.
//!
//! Objects are reported like the ideal model (box centre, orientation and velocity relative to the
//! sensor, reference point CENTER), for confirmed (MEASURED) and coasting (PREDICTED) tracks. Each
//! input point of a box that updated (or started) a track reported this cycle belongs to that
//! track ([`LidarRecognition::detection_objects`]: the OSI `object_id` of its `LidarDetection`);
//! the output assembly splits moving and stationary objects by their ground truth
//! ([`crate::semantics`], which reads [`LidarRecognition::reported_ground_truth`] for coasting
//! tracks).

use glam::{DVec2, DVec3};
use osiris_proto::osi3;
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};
use serde::{Deserialize, Serialize};

use super::common::{self, ObjectClass, Report};
use super::tracking::{Measurement, Tracker, TrackerConfig, VelocityMeasurement};
use super::{EgoState, LidarPoint};
use crate::error::ModelError;

/// At most this many points score a RANSAC hypothesis (a strided subset).
pub const RANSAC_SCORE_POINTS: usize = 4000;
/// At most this many points enter the L-shape angle search of one cluster (a strided subset).
pub const LSHAPE_MAX_POINTS: usize = 400;
/// Closeness-criterion floor d₀ of the L-shape fit, m (Zhang et al. 2017 use 0.01 m).
pub const LSHAPE_D0_M: f64 = 0.01;

/// LiDAR recognition parameters (`lidar.recognition` in the sensor configuration).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LidarRecognitionConfig {
    /// RANSAC ground inlier distance, m.
    pub ground_inlier_distance_m: f64,
    /// Largest angle between the ground normal and the fixed frame's +z, rad.
    pub ground_max_tilt_rad: f64,
    /// RANSAC hypotheses per step.
    pub ransac_iterations: u32,
    /// Points higher than this above the ground are ignored (bridges, tree crowns), m.
    pub max_height_above_ground_m: f64,
    /// Euclidean clustering neighbour radius, m.
    pub cluster_tolerance_m: f64,
    /// Horizontal angular resolution assumed by the adaptive clustering radius, rad (0.2°:
    /// e.g. a 128-channel spinning LiDAR at 10 Hz).
    pub cluster_angular_resolution_rad: f64,
    /// Smallest incidence (grazing) angle on a surface that clustering keeps connected, rad
    /// (guessed).
    pub cluster_min_incidence_rad: f64,
    /// Smallest cluster kept, points.
    pub min_cluster_points: usize,
    /// Largest cluster kept, points.
    pub max_cluster_points: usize,
    /// A cluster lying entirely within the expected box of a vehicle cluster (extended to the
    /// class's typical size, see the module documentation) grown by this margin is merged into
    /// it, m (guessed).
    pub merge_margin_m: f64,
    /// Standard deviation of a box-centre measurement, m (guessed).
    pub position_std_m: f64,
    /// Smoothing factor (0–1] of yaw, size and class scores per update.
    pub attribute_smoothing: f64,
    /// Use the Doppler of the points (FMCW LiDAR: each point's range rate) to measure each box's
    /// velocity in one cycle ([`doppler_velocity`]): new tracks start with it, updates use it.
    pub doppler_velocity: bool,
    /// Floor of the standard deviation of one point's range rate, m/s (guessed: the FMCW preset's
    /// velocity resolution λ/(2T_w) is 0.30 m/s, physics.md §2.8; sub-bin interpolation at a car's
    /// SNR scatters one point's rate far less).
    pub range_rate_std_m_s: f64,
    /// RNG seed of RANSAC.
    pub seed: u64,
    /// Multi-object tracker.
    pub tracker: TrackerConfig,
}

impl Default for LidarRecognitionConfig {
    fn default() -> Self {
        LidarRecognitionConfig {
            ground_inlier_distance_m: 0.15,
            ground_max_tilt_rad: 0.2,
            ransac_iterations: 100,
            max_height_above_ground_m: 5.0,
            cluster_tolerance_m: 0.5,
            cluster_angular_resolution_rad: 0.2f64.to_radians(),
            cluster_min_incidence_rad: 6f64.to_radians(),
            min_cluster_points: 5,
            max_cluster_points: 50_000,
            merge_margin_m: 0.3,
            position_std_m: 0.15,
            attribute_smoothing: 0.4,
            doppler_velocity: true,
            range_rate_std_m_s: 0.05,
            seed: 0x5EED_1D4A,
            tracker: TrackerConfig::default(),
        }
    }
}

impl LidarRecognitionConfig {
    /// Checks the values (keys named `lidar.recognition.*`).
    pub fn validate(&self) -> Result<(), ModelError> {
        let pos = |key: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(ModelError::Config(format!(
                    "lidar.recognition.{key} must be a positive number (got {v})"
                )))
            }
        };
        pos("ground_inlier_distance_m", self.ground_inlier_distance_m)?;
        pos("max_height_above_ground_m", self.max_height_above_ground_m)?;
        pos("cluster_tolerance_m", self.cluster_tolerance_m)?;
        pos("position_std_m", self.position_std_m)?;
        if !(self.merge_margin_m.is_finite() && self.merge_margin_m >= 0.0) {
            return Err(ModelError::Config(format!(
                "lidar.recognition.merge_margin_m must be a non-negative number (got {})",
                self.merge_margin_m
            )));
        }
        let (res, inc) = (
            self.cluster_angular_resolution_rad,
            self.cluster_min_incidence_rad,
        );
        if !(res.is_finite() && res >= 0.0) {
            return Err(ModelError::Config(format!(
                "lidar.recognition.cluster_angular_resolution_rad must be a non-negative number (got {res})"
            )));
        }
        if !(inc.is_finite() && inc > res && inc <= std::f64::consts::FRAC_PI_2) {
            return Err(ModelError::Config(format!(
                "lidar.recognition.cluster_min_incidence_rad must be in (cluster_angular_resolution_rad, π/2] (got {inc})"
            )));
        }
        let t = self.ground_max_tilt_rad;
        if !(t.is_finite() && t > 0.0 && t < std::f64::consts::FRAC_PI_2) {
            return Err(ModelError::Config(format!(
                "lidar.recognition.ground_max_tilt_rad must be in (0, π/2) (got {t})"
            )));
        }
        if self.ransac_iterations == 0 {
            return Err(ModelError::Config(
                "lidar.recognition.ransac_iterations must be at least 1".into(),
            ));
        }
        if self.min_cluster_points == 0 || self.min_cluster_points > self.max_cluster_points {
            return Err(ModelError::Config(format!(
                "lidar.recognition.min_cluster_points must be in 1..=max_cluster_points (got {} and {})",
                self.min_cluster_points, self.max_cluster_points
            )));
        }
        let s = self.range_rate_std_m_s;
        if !(s.is_finite() && s > 0.0) {
            return Err(ModelError::Config(format!(
                "lidar.recognition.range_rate_std_m_s must be a positive number (got {s})"
            )));
        }
        let a = self.attribute_smoothing;
        if !(a.is_finite() && a > 0.0 && a <= 1.0) {
            return Err(ModelError::Config(format!(
                "lidar.recognition.attribute_smoothing must be in (0, 1] (got {a})"
            )));
        }
        self.tracker.validate("lidar.recognition.tracker")
    }
}

/// One point's row of the Doppler velocity fit: its horizontal line of sight and its
/// ego-compensated radial velocity.
#[derive(Debug, Clone, Copy, Default)]
pub struct DopplerRow {
    /// Horizontal components of the unit line of sight (fixed frame).
    pub los: [f64; 2],
    /// `d̂ · v_object` = range rate + `d̂ · v_sensor`, m/s.
    pub radial_m_s: f64,
}

/// Buffers of [`doppler_velocity`], reused from box to box and cycle to cycle.
#[derive(Debug, Clone, Default)]
pub struct DopplerScratch {
    rows: Vec<DopplerRow>,
    /// |residual| of each row after the first fit.
    abs: Vec<f64>,
}

/// The velocity of one rigid object from the Doppler of its points in one cycle (FMCW LiDAR).
///
/// A point at `p` (fixed frame) with range rate `ṙ` (positive receding, relative to the sensor
/// origin moving at `v_s`) sees the object's velocity along its line of sight `d̂ = (p − s)/|p − s|`:
/// `d̂ · v = ṙ + d̂ · v_s`. With `v = (v_x, v_y, 0)` (ground objects) the points give the linear
/// system `A v = y` (rows `d̂_xy`), solved by least squares twice: over every point, then over the
/// points within `3·max(1.4826·MAD, σ_floor)` of the first fit (wheels, a second object). The
/// covariance is `σ̂² (AᵀA)⁻¹` with `σ̂² = max(Σ res²/(n − 2), σ_floor²)`: the component along the
/// line of sight is known to `σ̂/√n`, the one across it to `σ̂/(√n · spread of the bearings)`, so
/// a distant object gives its radial velocity well and its lateral one poorly, as it should.
/// `None` with fewer than 3 points carrying a range rate (a pulsed LiDAR) or when the bearings
/// cannot resolve even the radial component. The Doppler ego-motion of
/// [`super::ego_motion`] (Kellner et al. 2013 for radar) is the same equation with the roles of
/// object and sensor swapped.
pub fn doppler_velocity(
    ego: &EgoState,
    points: impl Iterator<Item = (DVec3, f64)>,
    sigma_floor_m_s: f64,
    scratch: &mut DopplerScratch,
) -> Option<VelocityMeasurement> {
    let s = ego.sensor_pose.position;
    let DopplerScratch { rows, abs } = scratch;
    rows.clear();
    for (p, rate) in points {
        if !rate.is_finite() {
            continue;
        }
        let d = p - s;
        let r = d.length();
        if r.is_nan() || r <= 1e-6 {
            continue;
        }
        let d = d / r;
        rows.push(DopplerRow {
            los: [d.x, d.y],
            radial_m_s: rate + d.dot(ego.sensor_velocity_m_s),
        });
    }
    if rows.len() < 3 {
        return None;
    }
    let solve = |rows: &[DopplerRow], keep: &dyn Fn(&DopplerRow) -> bool| {
        let (mut sxx, mut sxy, mut syy, mut bx, mut by, mut n) = (0.0, 0.0, 0.0, 0.0, 0.0, 0usize);
        for r in rows.iter().filter(|r| keep(r)) {
            let [x, y] = r.los;
            sxx += x * x;
            sxy += x * y;
            syy += y * y;
            bx += x * r.radial_m_s;
            by += y * r.radial_m_s;
            n += 1;
        }
        let det = sxx * syy - sxy * sxy;
        // The smaller eigenvalue of AᵀA relative to n: the spread of the bearings squared.
        let tr = sxx + syy;
        if n < 3 || det.is_nan() || det <= 1e-12 * tr * tr {
            return None;
        }
        let v = [(syy * bx - sxy * by) / det, (sxx * by - sxy * bx) / det];
        let inv = [[syy / det, -sxy / det], [-sxy / det, sxx / det]];
        Some((v, inv, n))
    };
    let res = |v: [f64; 2], r: &DopplerRow| r.radial_m_s - (r.los[0] * v[0] + r.los[1] * v[1]);
    let (v0, _, _) = solve(rows, &|_| true)?;
    abs.clear();
    abs.extend(rows.iter().map(|r| res(v0, r).abs()));
    let mid = abs.len() / 2;
    let mad = *abs.select_nth_unstable_by(mid, f64::total_cmp).1;
    let gate = 3.0 * (1.4826 * mad).max(sigma_floor_m_s);
    let (v, inv, n) = solve(rows, &|r| res(v0, r).abs() <= gate)?;
    let ss: f64 = rows
        .iter()
        .filter(|r| res(v0, r).abs() <= gate)
        .map(|r| res(v, r).powi(2))
        .sum();
    let var = (ss / (n - 2).max(1) as f64).max(sigma_floor_m_s * sigma_floor_m_s);
    let cov = [
        [var * inv[0][0], var * inv[0][1]],
        [var * inv[1][0], var * inv[1][1]],
    ];
    (v.iter().all(|x| x.is_finite()) && cov.iter().flatten().all(|x| x.is_finite())).then_some(
        VelocityMeasurement {
            value_m_s: v,
            cov_m2_s2: cov,
        },
    )
}

/// A ground plane `n · p + d = 0` (unit normal `n` with `n.z > 0`), fixed frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GroundPlane {
    pub normal: DVec3,
    pub d: f64,
}

impl GroundPlane {
    /// Signed height of `p` above the plane, m.
    pub fn height_of(&self, p: DVec3) -> f64 {
        self.normal.dot(p) + self.d
    }
    /// Plane height `z` at `(x, y)`.
    pub fn z_at(&self, x: f64, y: f64) -> f64 {
        -(self.normal.x * x + self.normal.y * y + self.d) / self.normal.z
    }
}

/// One box measured in a step (fixed frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoxMeasurement {
    pub centre_m: DVec3,
    /// Yaw of the length axis, rad (modulo π).
    pub yaw_rad: f64,
    /// (length, width, height), m (after the visible-side correction).
    pub size_m: [f64; 3],
    /// Measured (length, width, height) extents, m.
    pub extent_m: [f64; 3],
    /// Class probabilities in [`ObjectClass::ALL`] order.
    pub class_probabilities: [f64; 5],
    /// Most frequent ground-truth id of the points.
    pub ground_truth_id: Option<u64>,
    pub n_points: usize,
    /// Velocity from the Doppler of the points (FMCW LiDAR, [`doppler_velocity`]), fixed frame.
    pub velocity: Option<VelocityMeasurement>,
}

#[derive(Debug, Clone, Default)]
struct TrackAttr {
    yaw_rad: f64,
    size_m: [f64; 3],
    centre_z_m: f64,
    class_probabilities: [f64; 5],
    ground_truth_id: Option<u64>,
    has_moved: bool,
}

/// LiDAR object recognition with tracking (state kept across steps).
#[derive(Debug, Clone)]
pub struct LidarRecognition {
    config: LidarRecognitionConfig,
    tracker: Tracker<TrackAttr>,
    frame_jump: common::FrameJump,
    // Scratch buffers reused across steps.
    fixed: Vec<DVec3>,
    fixed_ids: Vec<u64>,
    /// Range rate of each `fixed` point (NaN: none).
    fixed_rates: Vec<f64>,
    /// Input index of each `fixed` point.
    fixed_src: Vec<u32>,
    /// Per input point: the index of its box in `boxes` (`u32::MAX`: none).
    point_box: Vec<u32>,
    /// Per box: the id of the track it updated or started this cycle, kept only when that track is
    /// reported.
    box_track: Vec<Option<u64>>,
    /// Per input point: the tracking id of the reported object it belongs to.
    detection_objects: Vec<Option<u64>>,
    /// (tracking id, ground truth of its last update) of the objects reported by the last step.
    reported: Vec<(u64, Option<u64>)>,
    keep: Vec<u32>,
    keys: Vec<(u64, u32)>,
    label: Vec<u32>,
    queue: Vec<u32>,
    cluster: Vec<u32>,
    ids: Vec<u64>,
    boxes: Vec<BoxMeasurement>,
    measurements: Vec<Measurement>,
    assignment: Vec<Option<usize>>,
    ground: Option<GroundPlane>,
    groups: Vec<Group>,
    order: Vec<u32>,
    /// Scratch of [`doppler_velocity`].
    doppler: DopplerScratch,
}

impl LidarRecognition {
    pub fn new(config: &LidarRecognitionConfig) -> Result<LidarRecognition, ModelError> {
        config.validate()?;
        Ok(LidarRecognition {
            config: config.clone(),
            tracker: Tracker::new(config.tracker.clone()),
            frame_jump: common::FrameJump::default(),
            fixed: Vec::new(),
            fixed_ids: Vec::new(),
            fixed_rates: Vec::new(),
            fixed_src: Vec::new(),
            point_box: Vec::new(),
            box_track: Vec::new(),
            detection_objects: Vec::new(),
            reported: Vec::new(),
            keep: Vec::new(),
            keys: Vec::new(),
            label: Vec::new(),
            queue: Vec::new(),
            cluster: Vec::new(),
            ids: Vec::new(),
            boxes: Vec::new(),
            measurements: Vec::new(),
            assignment: Vec::new(),
            ground: None,
            groups: Vec::new(),
            order: Vec::new(),
            doppler: DopplerScratch::default(),
        })
    }

    /// The ground plane found in the last step (fixed frame), if any.
    pub fn ground_plane(&self) -> Option<GroundPlane> {
        self.ground
    }

    /// The boxes measured in the last step (fixed frame), before tracking.
    pub fn boxes(&self) -> &[BoxMeasurement] {
        &self.boxes
    }

    /// One cycle: `points` in the sensor frame → detected moving objects (sensor frame) appended to
    /// `out`.
    pub fn step(
        &mut self,
        ego: &EgoState,
        points: &[LidarPoint],
        out: &mut Vec<osi3::DetectedMovingObject>,
    ) {
        self.detect(ego, points);
        self.track(ego, out);
        self.detection_objects.clear();
        self.detection_objects.extend(
            self.point_box
                .iter()
                .map(|&b| self.box_track.get(b as usize).copied().flatten()),
        );
    }

    /// Per input point of the last [`LidarRecognition::step`] (same order): the `tracking_id` of
    /// the reported object whose box the point was part of, `None` when the point belongs to no
    /// reported object (ground, a dropped cluster, a tentative track).
    pub fn detection_objects(&self) -> &[Option<u64>] {
        &self.detection_objects
    }

    /// `(tracking id, ground-truth id of its last update)` of every object the last step reported
    /// (a coasting track keeps the ground truth of its last update here, while its header has none).
    pub fn reported_ground_truth(&self) -> &[(u64, Option<u64>)] {
        &self.reported
    }

    /// Steps 1–6 of the pipeline: the boxes of this step (see [`LidarRecognition::boxes`]).
    pub fn detect(&mut self, ego: &EgoState, points: &[LidarPoint]) {
        let cfg = self.config.clone();
        self.fixed.clear();
        self.fixed_ids.clear();
        self.fixed_rates.clear();
        self.fixed_src.clear();
        self.point_box.clear();
        self.point_box.resize(points.len(), u32::MAX);
        for (k, p) in points.iter().enumerate() {
            let q = ego.sensor_pose.transform_point(p.position_m);
            if q.is_finite() {
                self.fixed.push(q);
                self.fixed_ids.push(p.object_id);
                self.fixed_rates
                    .push(p.range_rate_m_s.map_or(f64::NAN, f64::from));
                self.fixed_src.push(k as u32);
            }
        }
        self.ground = fit_ground(
            &self.fixed,
            cfg.ground_inlier_distance_m,
            cfg.ground_max_tilt_rad,
            cfg.ransac_iterations,
            cfg.seed,
        );
        self.keep.clear();
        for (i, p) in self.fixed.iter().enumerate() {
            let h = match &self.ground {
                Some(g) => g.height_of(*p),
                None => f64::INFINITY,
            };
            if h > cfg.ground_inlier_distance_m && h <= cfg.max_height_above_ground_m
                || (self.ground.is_none())
            {
                self.keep.push(i as u32);
            }
        }
        euclidean_clusters(
            &self.fixed,
            &self.keep,
            cfg.cluster_tolerance_m,
            ego.sensor_pose.position,
            cfg.cluster_angular_resolution_rad,
            cfg.cluster_min_incidence_rad,
            &mut self.keys,
            &mut self.label,
            &mut self.queue,
        );
        // Clusters: `label[k]` for kept point k (in `keep` order).
        let sensor_xy = ego.sensor_pose.position.truncate();
        self.gather_groups();
        // Footprint merge: a fragment inside the expected box of a vehicle is part of it.
        let margin = cfg.merge_margin_m;
        let mut merged = false;
        self.fit_groups(sensor_xy, cfg.min_cluster_points, cfg.max_cluster_points);
        // Parents in descending size; a group that absorbs others is not absorbed itself.
        self.order.clear();
        self.order.extend(0..self.groups.len() as u32);
        let groups = &self.groups;
        self.order
            .sort_by_key(|&g| std::cmp::Reverse(groups[g as usize].n));
        for oi in 0..self.order.len() {
            let a = self.order[oi] as usize;
            let ga = self.groups[a];
            let Some(fa) = ga.fit else { continue };
            if ga.parent != u32::MAX || !class_of(&fa.class_probabilities).extend_to_typical() {
                continue;
            }
            for ob in (oi + 1)..self.order.len() {
                let b = self.order[ob] as usize;
                let gb = self.groups[b];
                if gb.parent != u32::MAX || gb.absorbed_any {
                    continue;
                }
                let inside = self.queue[gb.start..gb.end].iter().all(|&k| {
                    let p = self.fixed[self.keep[k as usize] as usize];
                    inside_box(&fa, p, margin)
                });
                if inside {
                    self.groups[b].parent = a as u32;
                    self.groups[a].absorbed_any = true;
                    merged = true;
                }
            }
        }
        if merged {
            for g in &self.groups {
                if g.parent != u32::MAX {
                    let l = self.groups[g.parent as usize].label;
                    for &k in &self.queue[g.start..g.end] {
                        self.label[k as usize] = l;
                    }
                }
            }
            self.gather_groups();
            self.fit_groups(sensor_xy, cfg.min_cluster_points, cfg.max_cluster_points);
        }
        self.boxes.clear();
        for gi in 0..self.groups.len() {
            let g = self.groups[gi];
            let Some(fit) = g.fit else { continue };
            self.fill_cluster(g);
            self.ids.clear();
            self.ids
                .extend(self.cluster.iter().map(|&i| self.fixed_ids[i as usize]));
            let gt = common::most_frequent_id(&mut self.ids);
            let b = self.boxes.len() as u32;
            for &i in &self.cluster {
                self.point_box[self.fixed_src[i as usize] as usize] = b;
            }
            let velocity = if cfg.doppler_velocity {
                doppler_velocity(
                    ego,
                    self.cluster
                        .iter()
                        .map(|&i| (self.fixed[i as usize], self.fixed_rates[i as usize])),
                    cfg.range_rate_std_m_s,
                    &mut self.doppler,
                )
            } else {
                None
            };
            self.boxes.push(BoxMeasurement {
                ground_truth_id: gt,
                velocity,
                ..fit
            });
        }
    }

    /// Fits the box of every group with `min_n..=max_n` points (in parallel; others get `None`).
    fn fit_groups(&mut self, sensor_xy: DVec2, min_n: usize, max_n: usize) {
        use rayon::prelude::*;
        let (fixed, keep, queue, ground) =
            (&self.fixed, &self.keep, &self.queue, self.ground.as_ref());
        self.groups.par_iter_mut().for_each_init(
            || (Vec::new(), Vec::new()),
            |(cluster, xy), g| {
                g.fit = None;
                if g.n < min_n || g.n > max_n {
                    return;
                }
                cluster.clear();
                cluster.extend(queue[g.start..g.end].iter().map(|&k| keep[k as usize]));
                g.fit = fit_box(fixed, cluster, ground, sensor_xy, xy);
            },
        );
    }

    /// Sorts the kept points by label (`queue` = permutation) and lists the label groups.
    fn gather_groups(&mut self) {
        self.queue.clear();
        self.queue.extend(0..self.keep.len() as u32);
        let label = &self.label;
        self.queue.sort_by_key(|&k| label[k as usize]);
        self.groups.clear();
        let mut start = 0;
        while start < self.queue.len() {
            let l = self.label[self.queue[start] as usize];
            let mut end = start;
            while end < self.queue.len() && self.label[self.queue[end] as usize] == l {
                end += 1;
            }
            self.groups.push(Group {
                label: l,
                start,
                end,
                n: end - start,
                fit: None,
                parent: u32::MAX,
                absorbed_any: false,
            });
            start = end;
        }
    }

    /// `cluster` = the point indices (into `fixed`) of group `g`.
    fn fill_cluster(&mut self, g: Group) {
        self.cluster.clear();
        self.cluster.extend(
            self.queue[g.start..g.end]
                .iter()
                .map(|&k| self.keep[k as usize]),
        );
    }

    fn track(&mut self, ego: &EgoState, out: &mut Vec<osi3::DetectedMovingObject>) {
        let t = ego.time_s;
        let var = self.config.position_std_m.powi(2);
        let alpha = self.config.attribute_smoothing;
        if let Some(d) = self.frame_jump.check(ego) {
            self.tracker.shift([d.x, d.y]);
            for tr in self.tracker.tracks_mut() {
                tr.attr.centre_z_m += d.z;
            }
        }
        self.tracker.predict(t);
        self.measurements.clear();
        self.measurements
            .extend(self.boxes.iter().map(|b| Measurement {
                position_m: [b.centre_m.x, b.centre_m.y],
                position_cov_m2: [[var, 0.0], [0.0, var]],
                radial: None,
                velocity: b.velocity,
            }));
        self.tracker
            .associate(&self.measurements, |_, _| true, &mut self.assignment);
        self.box_track.clear();
        for (j, b) in self.boxes.iter().enumerate() {
            match self.assignment[j] {
                Some(i) => {
                    self.tracker.update(i, &self.measurements[j]);
                    let tr = &mut self.tracker.tracks_mut()[i];
                    self.box_track.push(Some(tr.id));
                    let a = &mut tr.attr;
                    // Yaw modulo π: move towards the measurement along the shorter way.
                    let d = wrap_half_pi(b.yaw_rad - a.yaw_rad);
                    a.yaw_rad += alpha * d;
                    for k in 0..3 {
                        a.size_m[k] += alpha * (b.size_m[k] - a.size_m[k]);
                    }
                    a.centre_z_m += alpha * (b.centre_m.z - a.centre_z_m);
                    for k in 0..5 {
                        a.class_probabilities[k] +=
                            alpha * (b.class_probabilities[k] - a.class_probabilities[k]);
                    }
                    a.ground_truth_id = b.ground_truth_id;
                }
                None => {
                    // A new object starts with the velocity of its points' Doppler (FMCW), else
                    // at rest with the tracker's prior.
                    let (v0, vcov) = match b.velocity {
                        Some(v) => (v.value_m_s, v.cov_m2_s2),
                        None => ([0.0, 0.0], self.tracker.velocity_cov_unknown()),
                    };
                    let i = self.tracker.spawn(
                        &self.measurements[j],
                        v0,
                        vcov,
                        t,
                        TrackAttr {
                            yaw_rad: b.yaw_rad,
                            size_m: b.size_m,
                            centre_z_m: b.centre_m.z,
                            class_probabilities: b.class_probabilities,
                            ground_truth_id: b.ground_truth_id,
                            has_moved: false,
                        },
                    );
                    self.box_track.push(Some(self.tracker.tracks()[i].id));
                }
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
            let (vx, vy) = (tr.x[2], tr.x[3]);
            let a = &mut tr.attr;
            // Heading: the box axis is ambiguous by π; a moving object points along its velocity.
            if speed > common::MOVING_SPEED_M_S
                && (a.yaw_rad.cos() * vx + a.yaw_rad.sin() * vy) < 0.0
            {
                a.yaw_rad += std::f64::consts::PI;
            }
            a.yaw_rad = crate::frames::wrap_angle(a.yaw_rad);
            let movement = common::movement_state(speed, &mut a.has_moved);
            out.push(common::detected_object(
                ego,
                &Report {
                    centre_m: DVec3::new(tr.x[0], tr.x[1], a.centre_z_m),
                    yaw_rad: a.yaw_rad,
                    size_m: a.size_m,
                    velocity_m_s: DVec3::new(vx, vy, 0.0),
                    track_id: tr.id,
                    ground_truth_id: if tr.updated { a.ground_truth_id } else { None },
                    existence: tr.existence,
                    age_s: t - tr.birth_time_s,
                    measured: tr.updated,
                    movement,
                    class_probabilities: &a.class_probabilities,
                    rcs_dbsm: None,
                },
            ));
        }
        // A box's points belong to its track's object only when that track is reported and was
        // updated by the box this cycle.
        let reported = &self.reported;
        let tracks = self.tracker.tracks();
        for t in &mut self.box_track {
            *t = t.filter(|id| {
                reported.iter().any(|r| r.0 == *id)
                    && tracks.iter().any(|tr| tr.id == *id && tr.updated)
            });
        }
    }

    /// Forget all tracks.
    pub fn reset(&mut self) {
        self.tracker.reset();
        self.frame_jump.reset();
        self.ground = None;
        self.boxes.clear();
        self.point_box.clear();
        self.box_track.clear();
        self.detection_objects.clear();
        self.reported.clear();
    }
}

/// Angle wrapped into (−π/2, π/2] (difference of two axes, which are equal modulo π).
fn wrap_half_pi(a: f64) -> f64 {
    use std::f64::consts::PI;
    let w = a.rem_euclid(PI);
    if w > PI / 2.0 { w - PI } else { w }
}

/// RANSAC ground plane (see the module documentation), `None` with fewer than 3 points or when no
/// hypothesis within the tilt limit has 3 inliers.
pub fn fit_ground(
    points: &[DVec3],
    inlier_distance_m: f64,
    max_tilt_rad: f64,
    iterations: u32,
    seed: u64,
) -> Option<GroundPlane> {
    let n = points.len();
    if n < 3 {
        return None;
    }
    let mut rng = SmallRng::seed_from_u64(seed);
    let stride = n.div_ceil(RANSAC_SCORE_POINTS).max(1);
    let cos_tilt = max_tilt_rad.cos();
    let mut best: Option<(usize, GroundPlane)> = None;
    for _ in 0..iterations {
        let a = points[rng.random_range(0..n)];
        let b = points[rng.random_range(0..n)];
        let c = points[rng.random_range(0..n)];
        let nrm = (b - a).cross(c - a);
        let len = nrm.length();
        if len.is_nan() || len <= 1e-9 {
            continue;
        }
        let mut nrm = nrm / len;
        if nrm.z < 0.0 {
            nrm = -nrm;
        }
        if nrm.z < cos_tilt {
            continue;
        }
        let plane = GroundPlane {
            normal: nrm,
            d: -nrm.dot(a),
        };
        let score = points
            .iter()
            .step_by(stride)
            .filter(|p| plane.height_of(**p).abs() <= inlier_distance_m)
            .count();
        if best.is_none_or(|(s, _)| score > s) {
            best = Some((score, plane));
        }
    }
    let (_, plane) = best?;
    // Least-squares refinement z = a·x + b·y + c over all inliers (normal equations, centred).
    let mut cnt = 0.0;
    let mut mean = DVec3::ZERO;
    for p in points {
        if plane.height_of(*p).abs() <= inlier_distance_m {
            cnt += 1.0;
            mean += *p;
        }
    }
    if cnt < 3.0 {
        return Some(plane);
    }
    mean /= cnt;
    let (mut sxx, mut sxy, mut syy, mut sxz, mut syz) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for p in points {
        if plane.height_of(*p).abs() <= inlier_distance_m {
            let q = *p - mean;
            sxx += q.x * q.x;
            sxy += q.x * q.y;
            syy += q.y * q.y;
            sxz += q.x * q.z;
            syz += q.y * q.z;
        }
    }
    let det = sxx * syy - sxy * sxy;
    if det.is_nan() || det.abs() <= 1e-9 * (sxx * syy).max(1e-300) {
        return Some(plane);
    }
    let ga = (sxz * syy - syz * sxy) / det;
    let gb = (syz * sxx - sxz * sxy) / det;
    let normal = DVec3::new(-ga, -gb, 1.0).normalize();
    let refined = GroundPlane {
        normal,
        d: -normal.dot(mean),
    };
    if refined.normal.z >= cos_tilt && refined.d.is_finite() {
        Some(refined)
    } else {
        Some(plane)
    }
}

fn cell_key(p: DVec3, inv: f64) -> Option<u64> {
    const OFF: i64 = 1 << 20;
    let c = (p * inv).floor();
    let (i, j, k) = (c.x as i64 + OFF, c.y as i64 + OFF, c.z as i64 + OFF);
    let lim = 1i64 << 21;
    if (0..lim).contains(&i) && (0..lim).contains(&j) && (0..lim).contains(&k) {
        Some(((i as u64) << 42) | ((j as u64) << 21) | k as u64)
    } else {
        None
    }
}

/// Horizontal neighbour radius of Euclidean clustering at horizontal range `rho_m`:
/// `max(tol, ρ·sin Δφ / sin(λ − Δφ))` — the adaptive breakpoint distance of Borges & Aldon
/// ("Line extraction in 2D range images for mobile robotics", J. Intell. Robot. Syst. 40, 2004):
/// the spacing of consecutive samples `Δφ` apart on a surface seen at incidence (grazing) angle λ.
pub fn adaptive_tolerance_m(
    tol_m: f64,
    rho_m: f64,
    resolution_rad: f64,
    incidence_rad: f64,
) -> f64 {
    tol_m
        .max(rho_m * resolution_rad.sin() / (incidence_rad - resolution_rad).sin())
        .min(tol_m.max(MAX_ADAPTIVE_TOLERANCE_M))
}

/// Upper limit of the adaptive clustering radius, m (guessed: keeps objects more than 2 m apart
/// separate at any range and bounds the neighbour search).
pub const MAX_ADAPTIVE_TOLERANCE_M: f64 = 2.0;

/// Euclidean clustering of `points[subset]` (see the module documentation): two points are
/// neighbours when their vertical distance is at most `tol` and their horizontal distance at most
/// [`adaptive_tolerance_m`] at the smaller of their horizontal ranges from `sensor`. On return
/// `label[k]` is the cluster label of `subset[k]` (labels 0, 1, … in order of discovery; points
/// outside the voxel key range get their own label).
#[allow(clippy::too_many_arguments)]
pub fn euclidean_clusters(
    points: &[DVec3],
    subset: &[u32],
    tol: f64,
    sensor: DVec3,
    resolution_rad: f64,
    incidence_rad: f64,
    keys: &mut Vec<(u64, u32)>,
    label: &mut Vec<u32>,
    queue: &mut Vec<u32>,
) {
    let inv = 1.0 / tol;
    let tol_of = |p: DVec3| {
        adaptive_tolerance_m(
            tol,
            (p - sensor).truncate().length(),
            resolution_rad,
            incidence_rad,
        )
    };
    keys.clear();
    label.clear();
    label.resize(subset.len(), u32::MAX);
    for (k, &i) in subset.iter().enumerate() {
        if let Some(key) = cell_key(points[i as usize], inv) {
            keys.push((key, k as u32));
        }
    }
    keys.sort_unstable();
    let mut next = 0u32;
    for seed in 0..subset.len() {
        if label[seed] != u32::MAX {
            continue;
        }
        label[seed] = next;
        queue.clear();
        queue.push(seed as u32);
        let mut head = 0;
        while head < queue.len() {
            let k = queue[head] as usize;
            head += 1;
            let p = points[subset[k] as usize];
            let Some(key) = cell_key(p, inv) else {
                continue;
            };
            let tol_p = tol_of(p);
            let m = (tol_p * inv).ceil() as u64;
            let (ci, cj, ck) = (
                key >> 42,
                (key >> 21) & ((1 << 21) - 1),
                key & ((1 << 21) - 1),
            );
            for i in ci.saturating_sub(m)..=ci + m {
                for j in cj.saturating_sub(m)..=cj + m {
                    // Cells (i, j, ck − 1 ..= ck + 1) are contiguous in key order.
                    let base = (i << 42) | (j << 21);
                    let k_lo = base | ck.saturating_sub(1);
                    let k_hi = base | (ck + 1).min((1 << 21) - 1);
                    let lo = keys.partition_point(|e| e.0 < k_lo);
                    for e in &keys[lo..] {
                        if e.0 > k_hi {
                            break;
                        }
                        let n = e.1 as usize;
                        if label[n] != u32::MAX {
                            continue;
                        }
                        let q = points[subset[n] as usize];
                        if (q.z - p.z).abs() > tol {
                            continue;
                        }
                        let t = tol_p.min(tol_of(q));
                        if (q - p).truncate().length_squared() <= t * t {
                            label[n] = next;
                            queue.push(n as u32);
                        }
                    }
                }
            }
        }
        next += 1;
    }
}

/// A label group of [`LidarRecognition::detect`].
#[derive(Debug, Clone, Copy)]
struct Group {
    label: u32,
    start: usize,
    end: usize,
    n: usize,
    fit: Option<BoxMeasurement>,
    parent: u32,
    absorbed_any: bool,
}

/// The most probable class.
fn class_of(p: &[f64; 5]) -> ObjectClass {
    ObjectClass::ALL[(0..5).max_by(|&a, &b| p[a].total_cmp(&p[b])).unwrap_or(4)]
}

/// Whether `p` lies inside box `b` grown by `margin_m` (horizontally and at the top).
fn inside_box(b: &BoxMeasurement, p: DVec3, margin_m: f64) -> bool {
    let d = (p - b.centre_m).truncate();
    let (s, c) = b.yaw_rad.sin_cos();
    let along = d.x * c + d.y * s;
    let across = -d.x * s + d.y * c;
    along.abs() <= 0.5 * b.size_m[0] + margin_m
        && across.abs() <= 0.5 * b.size_m[1] + margin_m
        && p.z <= b.centre_m.z + 0.5 * b.size_m[2] + margin_m
}

/// Prior class probabilities of the LiDAR classifier in [`ObjectClass::ALL`] order (guessed
/// urban-traffic mix: car 0.4, truck 0.1, pedestrian 0.25, bicycle 0.1, unknown 0.15). They
/// break ties between shapes the size alone cannot separate (a cyclist seen head-on looks like a
/// pedestrian).
pub const CLASS_PRIOR: [f64; 5] = [0.4, 0.1, 0.25, 0.1, 0.15];

/// Class probabilities from measured extents (see the module documentation, step 5).
pub fn classify(extent_major_m: f64, extent_minor_m: f64, height_m: f64) -> [f64; 5] {
    const SIGMA: f64 = 0.4;
    const SIGMA_H: f64 = 0.25;
    const UNKNOWN_COST: f64 = 9.0;
    let mut cost = [0.0; 5];
    for (k, c) in ObjectClass::ALL.iter().enumerate() {
        if *c == ObjectClass::Unknown {
            cost[k] = UNKNOWN_COST;
            continue;
        }
        let [l, w, h] = c.typical_size_m();
        let sq = |v: f64| v * v;
        cost[k] = sq((extent_major_m - l).max(0.0) / SIGMA)
            + sq((w - extent_major_m).max(0.0) / SIGMA)
            + sq((extent_minor_m - w).max(0.0) / SIGMA)
            + sq((height_m - h) / SIGMA_H);
    }
    let min = cost.iter().copied().fold(f64::INFINITY, f64::min);
    let mut p = [0.0; 5];
    for k in 0..5 {
        p[k] = CLASS_PRIOR[k] * (-(cost[k] - min) / 2.0).exp();
    }
    let s: f64 = p.iter().sum();
    for v in &mut p {
        *v /= s;
    }
    p
}

/// Closeness criterion of Zhang et al. (2017) for the heading `theta`.
fn closeness(xy: &[DVec2], theta: f64) -> f64 {
    let e1 = DVec2::new(theta.cos(), theta.sin());
    let e2 = DVec2::new(-theta.sin(), theta.cos());
    let (mut lo1, mut hi1, mut lo2, mut hi2) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for p in xy {
        let (c1, c2) = (p.dot(e1), p.dot(e2));
        lo1 = lo1.min(c1);
        hi1 = hi1.max(c1);
        lo2 = lo2.min(c2);
        hi2 = hi2.max(c2);
    }
    let mut score = 0.0;
    for p in xy {
        let (c1, c2) = (p.dot(e1), p.dot(e2));
        let d1 = (hi1 - c1).min(c1 - lo1);
        let d2 = (hi2 - c2).min(c2 - lo2);
        score += 1.0 / d1.min(d2).max(LSHAPE_D0_M);
    }
    score
}

/// Oriented box of one cluster (steps 4–6 of the module documentation). `None` for a degenerate
/// cluster.
pub fn fit_box(
    points: &[DVec3],
    cluster: &[u32],
    ground: Option<&GroundPlane>,
    sensor_xy: DVec2,
    xy: &mut Vec<DVec2>,
) -> Option<BoxMeasurement> {
    if cluster.is_empty() {
        return None;
    }
    // Horizontal coordinates relative to the cluster mean (conditioning), z range.
    let mut mean = DVec2::ZERO;
    let (mut zmin, mut zmax) = (f64::INFINITY, f64::NEG_INFINITY);
    for &i in cluster {
        let p = points[i as usize];
        mean += p.truncate();
        zmin = zmin.min(p.z);
        zmax = zmax.max(p.z);
    }
    mean /= cluster.len() as f64;
    xy.clear();
    let stride = cluster.len().div_ceil(LSHAPE_MAX_POINTS).max(1);
    xy.extend(
        cluster
            .iter()
            .step_by(stride)
            .map(|&i| points[i as usize].truncate() - mean),
    );
    // Heading search: 1° grid over [0, 90°), then 0.1° around the best.
    let deg = std::f64::consts::PI / 180.0;
    let mut best = (f64::NEG_INFINITY, 0.0);
    for k in 0..90 {
        let th = k as f64 * deg;
        let s = closeness(xy, th);
        if s > best.0 {
            best = (s, th);
        }
    }
    let coarse = best.1;
    for k in -10..=10 {
        let th = coarse + k as f64 * 0.1 * deg;
        let s = closeness(xy, th);
        if s > best.0 {
            best = (s, th);
        }
    }
    let theta = best.1;
    // Extents over all points.
    xy.clear();
    xy.extend(
        cluster
            .iter()
            .map(|&i| points[i as usize].truncate() - mean),
    );
    let e = [
        DVec2::new(theta.cos(), theta.sin()),
        DVec2::new(-theta.sin(), theta.cos()),
    ];
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for p in xy.iter() {
        for a in 0..2 {
            let c = p.dot(e[a]);
            lo[a] = lo[a].min(c);
            hi[a] = hi[a].max(c);
        }
    }
    let ext = [hi[0] - lo[0], hi[1] - lo[1]];
    let ground_z = ground.map_or(zmin, |g| g.z_at(mean.x, mean.y));
    let bottom = ground_z.min(zmin);
    let height = (zmax - bottom).max(0.05);
    let (major, minor) = if ext[0] >= ext[1] {
        (ext[0], ext[1])
    } else {
        (ext[1], ext[0])
    };
    let probs = classify(major, minor, height);
    let class = ObjectClass::ALL[(0..5)
        .max_by(|&a, &b| probs[a].total_cmp(&probs[b]))
        .unwrap_or(4)];
    let [tl, tw, _] = class.typical_size_m();
    // Length axis (module documentation, step 6).
    let s_rel = sensor_xy - mean;
    let los = -s_rel.normalize_or_zero();
    let len_axis = if major > tw + 0.3 || class == ObjectClass::Unknown {
        if ext[0] >= ext[1] { 0 } else { 1 }
    } else if e[0].dot(los).abs() >= e[1].dot(los).abs() {
        0
    } else {
        1
    };
    let wid_axis = 1 - len_axis;
    let extend = class.extend_to_typical();
    let want = |axis: usize, typical: f64| {
        if extend {
            ext[axis].max(typical)
        } else {
            ext[axis].max(0.05)
        }
    };
    let size_len = want(len_axis, tl);
    let size_wid = want(wid_axis, tw);
    let mut centre = DVec2::ZERO;
    for (axis, size) in [(len_axis, size_len), (wid_axis, size_wid)] {
        let s = s_rel.dot(e[axis]);
        let c = if size <= ext[axis] + 1e-9 || (s > lo[axis] && s < hi[axis]) {
            0.5 * (lo[axis] + hi[axis])
        } else if s <= lo[axis] {
            lo[axis] + 0.5 * size
        } else {
            hi[axis] - 0.5 * size
        };
        centre += c * e[axis];
    }
    let centre = centre + mean;
    let yaw = e[len_axis].y.atan2(e[len_axis].x);
    Some(BoxMeasurement {
        centre_m: DVec3::new(centre.x, centre.y, bottom + 0.5 * height),
        yaw_rad: yaw,
        size_m: [size_len, size_wid, height],
        extent_m: [ext[len_axis], ext[wid_axis], zmax - zmin],
        class_probabilities: probs,
        ground_truth_id: None,
        n_points: cluster.len(),
        velocity: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn doppler_velocity_solves_the_line_of_sight_equations() {
        // A moving sensor (v_s = (10, 0, 0)) and points of an object moving at v = (−4, 2, 0) over
        // ±5° of bearing at 20 m; each range rate is d̂·(v − v_s). A wheel point (outlier, +3 m/s)
        // is gated out; the radial component is recovered exactly, the lateral one too (no noise).
        let ego = EgoState {
            time_s: 0.0,
            sensor_pose: crate::frames::Pose::new(DVec3::new(0.0, 0.0, 1.0), glam::DMat3::IDENTITY),
            sensor_velocity_m_s: DVec3::new(10.0, 0.0, 0.0),
            sensor_angular_velocity_rad_s: DVec3::ZERO,
        };
        let v = DVec3::new(-4.0, 2.0, 0.0);
        let pts: Vec<(DVec3, f64)> = (0..41)
            .map(|i| {
                let b = (-5.0 + 0.25 * f64::from(i)).to_radians();
                let p = DVec3::new(20.0 * b.cos(), 20.0 * b.sin(), 0.5);
                let d = (p - ego.sensor_pose.position).normalize();
                let outlier = if i == 7 { 3.0 } else { 0.0 };
                (p, d.dot(v - ego.sensor_velocity_m_s) + outlier)
            })
            .collect();
        let mut rows = DopplerScratch::default();
        let m = doppler_velocity(&ego, pts.iter().copied(), 0.05, &mut rows).unwrap();
        assert!((m.value_m_s[0] + 4.0).abs() < 1e-9, "{:?}", m.value_m_s);
        assert!((m.value_m_s[1] - 2.0).abs() < 1e-9, "{:?}", m.value_m_s);
        // Along the line of sight (x) the variance is the floor over n; across it, larger by the
        // inverse spread of the bearings squared.
        assert!(
            m.cov_m2_s2[1][1] > 50.0 * m.cov_m2_s2[0][0],
            "{:?}",
            m.cov_m2_s2
        );
        // Points without a range rate (pulsed LiDAR), or all on one bearing: no velocity.
        let none: Vec<(DVec3, f64)> = pts.iter().map(|(p, _)| (*p, f64::NAN)).collect();
        assert!(doppler_velocity(&ego, none.into_iter(), 0.05, &mut rows).is_none());
        let one = vec![(DVec3::new(20.0, 0.0, 1.0), -14.0); 10];
        assert!(doppler_velocity(&ego, one.into_iter(), 0.05, &mut rows).is_none());
    }

    #[test]
    fn classification_by_size() {
        let argmax = |p: [f64; 5]| (0..5).max_by(|&a, &b| p[a].total_cmp(&p[b])).unwrap();
        assert_eq!(
            ObjectClass::ALL[argmax(classify(4.4, 1.8, 1.45))],
            ObjectClass::Car
        );
        // Car seen from behind: only its width is visible.
        assert_eq!(
            ObjectClass::ALL[argmax(classify(1.8, 0.1, 1.5))],
            ObjectClass::Car
        );
        assert_eq!(
            ObjectClass::ALL[argmax(classify(0.5, 0.4, 1.75))],
            ObjectClass::Pedestrian
        );
        assert_eq!(
            ObjectClass::ALL[argmax(classify(9.0, 2.5, 3.4))],
            ObjectClass::Truck
        );
        assert_eq!(
            ObjectClass::ALL[argmax(classify(0.3, 0.3, 0.3))],
            ObjectClass::Unknown
        );
        let p = classify(4.4, 1.8, 1.45);
        assert!((p.iter().sum::<f64>() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn half_pi_wrap() {
        use std::f64::consts::PI;
        assert!((wrap_half_pi(PI - 0.1) + 0.1).abs() < 1e-12);
        assert!((wrap_half_pi(0.2) - 0.2).abs() < 1e-12);
        assert!((wrap_half_pi(-PI / 2.0 - 0.1) - (PI / 2.0 - 0.1)).abs() < 1e-12);
    }
}
