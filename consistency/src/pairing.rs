//! Trace loading, timestamp pairing, association and paired residual rows.
//!
//! * A measured SensorData frame pairs with the SensorView of the same timestamp (±0.5 ms); frames
//!   missing from the measurement are counted, not errors. The simulated frame is the one with the
//!   same timestamp.
//! * Ground-truth ids of detections: a re-simulation's from the model's PerceptionData (every peak
//!   and point keeps its ground-truth object); a trace's from the detections' `object_id`s
//!   ([`truth_of_object_ids`]: OSI 3.8.0 — the id of a detected object, whose header names the
//!   ground truth — or, naming no detected object, a ground-truth label as in measured campaigns).
//! * Radar: per target and frame, the measured and the simulated detection of the target's
//!   ground-truth id (nearest to the ground-truth range when several); with `method = "gating"`, or
//!   when a trace carries no ids, the detection nearest to the ground-truth position inside a gate.
//! * LiDAR: measured and simulated points pair by `beam_id` (same beam, same target, nearest range);
//!   points on target per target and frame; points in depth gaps (no target, above the ground) per
//!   frame.
//! * Explanatory variables come from the ground truth (not from the noisy detections), so residuals
//!   are not regressed on noisy abscissae.

use std::collections::{BTreeMap, HashMap};
use std::f64::consts::PI;
use std::path::Path;

use anyhow::{Context, Result, bail};
use glam::DVec3;
use osiris_models::frames::{Pose, SensorFrame, moving_object_pose, stationary_object_pose};
use osiris_proto::osi3;

use super::campaign::{AssociationMethod, Campaign, CampaignSensor};
use super::{NVARS, Row, quantity};

/// LiDAR: paired points per target and frame at most.
pub const MAX_POINTS_PER_TARGET: usize = 48;

/// Frame-pairing tolerance, ns.
const PAIR_TOL_NS: i128 = 500_000;

/// Counts for detection probability and false alarms.
#[derive(Debug, Clone, Copy, Default, serde::Serialize)]
pub struct DetectionCounts {
    /// Target-frames where the simulation detected the target.
    pub sim_detected: usize,
    /// Target-frames where the measurement detected the target.
    pub meas_detected: usize,
    /// Target-frames detected by both.
    pub both: usize,
    /// Target-frames considered (target in a paired frame).
    pub opportunities: usize,
    /// Measured detections / points not associated with any target.
    pub meas_unassociated: usize,
    /// Simulated detections / points not associated with any target.
    pub sim_unassociated: usize,
}

/// The paired data of a campaign.
#[derive(Debug, Clone, Default)]
pub struct Paired {
    pub rows: Vec<Row>,
    /// SensorView frames.
    pub views: usize,
    /// Measured frames paired with a view and a simulated frame.
    pub paired_frames: usize,
    /// Views without a measured frame (missing from the measurement).
    pub missing_meas_frames: usize,
    /// Measured frames without a simulated frame.
    pub missing_sim_frames: usize,
    pub counts: DetectionCounts,
    /// All measured / simulated values per quantity (paired or not), for distribution metrics.
    pub meas_values: BTreeMap<&'static str, Vec<f64>>,
    pub sim_values: BTreeMap<&'static str, Vec<f64>>,
    pub warnings: Vec<String>,
}

/// Reads a whole `.osi` trace of `M`.
pub fn read_trace<M: prost::Message + Default>(path: &Path, what: &str) -> Result<Vec<M>> {
    osiris_proto::trace::read_messages::<M>(path)
        .with_context(|| format!("cannot read the {what} trace `{}`", path.display()))
}

/// Timestamp in ns.
pub fn ts_ns(ts: Option<&osi3::Timestamp>) -> Option<i128> {
    ts.map(|t| {
        i128::from(t.seconds.unwrap_or(0)) * 1_000_000_000 + i128::from(t.nanos.unwrap_or(0))
    })
}

fn view_ts(v: &osi3::SensorView) -> Option<i128> {
    ts_ns(
        v.timestamp.as_ref().or(v
            .global_ground_truth
            .as_ref()
            .and_then(|g| g.timestamp.as_ref())),
    )
}

/// Index of the entry of `sorted` (timestamp, index) nearest to `t` within the tolerance.
fn find_ts(sorted: &[(i128, usize)], t: i128) -> Option<usize> {
    let pos = sorted.partition_point(|(s, _)| *s < t);
    let mut best: Option<(i128, usize)> = None;
    for cand in [pos.checked_sub(1), Some(pos)].into_iter().flatten() {
        if let Some(&(s, i)) = sorted.get(cand) {
            let d = (s - t).abs();
            if d <= PAIR_TOL_NS && best.is_none_or(|(bd, _)| d < bd) {
                best = Some((d, i));
            }
        }
    }
    best.map(|(_, i)| i)
}

fn sorted_ts<T>(items: &[T], ts: impl Fn(&T) -> Option<i128>) -> Vec<(i128, usize)> {
    let mut v: Vec<(i128, usize)> = items
        .iter()
        .enumerate()
        .filter_map(|(i, m)| ts(m).map(|t| (t, i)))
        .collect();
    v.sort();
    v
}

/// Geometry of one target in one frame, from the ground truth.
#[derive(Debug, Clone, Copy)]
pub struct TargetGeometry {
    pub id: u64,
    /// Target centre in the sensor frame, m.
    pub centre_s: DVec3,
    pub range_m: f64,
    pub azimuth_deg: f64,
    pub elevation_deg: f64,
    /// Angle between the target's +x axis and the direction to the sensor, deg.
    pub aspect_deg: f64,
    /// Box dimensions (length, width, height), m.
    pub dims: DVec3,
    /// Target pose (global).
    pub pose: Pose,
    /// Height of the target's phase centre above the road below it, m (the asset's documented
    /// phase centre, `models/ASSETS.md`, placed by the ground-truth pose).
    pub phase_centre_height_m: f64,
    /// Rate of the sensor → target-centre range (OSI velocities of target and host), m/s.
    pub range_rate_m_s: f64,
    /// Rate of the target centre's azimuth in the (rotating) sensor frame, deg/s.
    pub azimuth_rate_deg_s: f64,
    /// The target stands still in the world (OSI velocity zero or a stationary object).
    pub stationary: bool,
}

struct FrameGeom {
    sensor: SensorFrame,
    targets: Vec<TargetGeometry>,
    /// Height of the sensor above the road below it, m.
    sensor_height_m: f64,
    /// Radar: the Doppler information on the azimuth misalignment gathered up to and including
    /// this frame, (m/s)²/rad² ([`calibration_information`]; 0 for other sensors).
    cal_w: f64,
}

/// The road surface of a SensorView's ground truth, as the models' scene builds it
/// (`models/src/environment/scene.rs`): the lanes' boundary polylines where there are any, else
/// the documented fallback ground plane at the host's wheel-contact height (z = 0 without a host).
enum Road {
    /// Boundary points of the lanes (global).
    Lanes(Vec<DVec3>),
    /// A horizontal plane at this global z, m.
    Plane(f64),
}

impl Road {
    fn of(gt: &osi3::GroundTruth, host: Option<&osi3::MovingObject>) -> Road {
        let points: Vec<DVec3> = gt
            .lane_boundary
            .iter()
            .flat_map(|b| b.boundary_line.iter())
            .filter_map(|p| p.position.as_ref())
            .filter_map(|p| Some(DVec3::new(p.x?, p.y?, p.z.unwrap_or(0.0))))
            .filter(|p| p.is_finite())
            .collect();
        if !points.is_empty() {
            return Road::Lanes(points);
        }
        Road::Plane(osiris_models::environment::scene::fallback_plane_z(host))
    }

    /// The road's height (global z) below a point: the nearest lane boundary point's z in the
    /// horizontal plane, or the fallback plane's.
    fn z_below(&self, p: DVec3) -> f64 {
        match self {
            Road::Plane(z) => *z,
            Road::Lanes(points) => points
                .iter()
                .min_by(|a, b| {
                    let da = (a.x - p.x).hypot(a.y - p.y);
                    let db = (b.x - p.x).hypot(b.y - p.y);
                    da.total_cmp(&db)
                })
                .map_or(0.0, |q| q.z),
        }
    }
}

/// The phase centre of an object's asset in its object frame (origin at the OSI box centre), m:
/// where its radar returns and their ground images start ("Phase centres and reference points" in
/// `models/ASSETS.md`: a trihedral's apex, a board's face centre). Assets without one (vehicles,
/// VRUs, furniture, user meshes, references that are not `osiris:` ones) use the box centre.
fn phase_centre_in_box(reference: &str, dims: DVec3) -> DVec3 {
    use osiris_models::environment::assets::{AssetRef, phase_centre};
    let dims = (dims.x > 0.0 && dims.y > 0.0 && dims.z > 0.0).then_some(dims);
    AssetRef::parse(reference)
        .ok()
        .and_then(|a| phase_centre(&a, dims))
        .unwrap_or(DVec3::ZERO)
}

fn frame_geometry(campaign: &Campaign, view: &osi3::SensorView) -> Result<FrameGeom> {
    let gt = view
        .global_ground_truth
        .as_ref()
        .context("a SensorView has no global_ground_truth")?;
    let host_id = view
        .host_vehicle_id
        .and_then(|i| i.value)
        .or(gt.host_vehicle_id.and_then(|i| i.value));
    let host = host_id.and_then(|h| {
        gt.moving_object
            .iter()
            .find(|o| o.id.and_then(|i| i.value) == Some(h))
    });
    let mounting = view.mounting_position.unwrap_or_else(|| {
        osiris_models::sensor::Mounting {
            position_m: campaign.sensor.mounting_position_m,
            orientation_rad: campaign.sensor.mounting_orientation_rad,
        }
        .to_osi()
    });
    let sensor = SensorFrame::new(host, &mounting);
    let road = Road::of(gt, host);
    let mut objects: Vec<(u64, Pose, DVec3, &str, DVec3)> = Vec::new();
    let dims = |d: Option<&osi3::Dimension3d>| {
        d.map(|d| {
            DVec3::new(
                d.length.unwrap_or(0.0),
                d.width.unwrap_or(0.0),
                d.height.unwrap_or(0.0),
            )
        })
        .unwrap_or(DVec3::ZERO)
    };
    for o in &gt.moving_object {
        let Some(id) = o.id.and_then(|i| i.value) else {
            continue;
        };
        if Some(id) == host_id {
            continue;
        }
        objects.push((
            id,
            moving_object_pose(o),
            dims(o.base.as_ref().and_then(|b| b.dimension.as_ref())),
            o.model_reference.as_deref().unwrap_or(""),
            osiris_models::frames::vec3_from_osi(o.base.as_ref().and_then(|b| b.velocity.as_ref())),
        ));
    }
    for o in &gt.stationary_object {
        let Some(id) = o.id.and_then(|i| i.value) else {
            continue;
        };
        objects.push((
            id,
            stationary_object_pose(o),
            dims(o.base.as_ref().and_then(|b| b.dimension.as_ref())),
            o.model_reference.as_deref().unwrap_or(""),
            DVec3::ZERO,
        ));
    }
    let wanted: Vec<u64> = if campaign.targets.is_empty() {
        objects.iter().map(|o| o.0).collect()
    } else {
        campaign.targets.iter().map(|t| t.id).collect()
    };
    let s_pos = sensor.pose.position;
    let mut targets = Vec::new();
    for (id, pose, dims, reference, velocity) in objects {
        if !wanted.contains(&id) {
            continue;
        }
        let c = sensor.point_to_sensor(pose.position);
        let range = c.length();
        // d/dt atan2(y, x) = (x·ẏ − y·ẋ)/(x² + y²) with the velocity seen in the rotating sensor
        // frame (osiris_models::frames::SensorFrame::relative_velocity).
        let c_dot = sensor.relative_velocity(pose.position, velocity);
        let azimuth_rate = (c.x * c_dot.y - c.y * c_dot.x) / (c.x * c.x + c.y * c.y).max(1e-9);
        let facing = pose.transform_vector(DVec3::X);
        let to_sensor = (s_pos - pose.position).normalize_or_zero();
        targets.push(TargetGeometry {
            id,
            centre_s: c,
            range_m: range,
            azimuth_deg: c.y.atan2(c.x).to_degrees(),
            elevation_deg: c.z.atan2(c.x.hypot(c.y)).to_degrees(),
            aspect_deg: facing.dot(to_sensor).clamp(-1.0, 1.0).acos().to_degrees(),
            dims,
            pose,
            phase_centre_height_m: {
                let pc = pose.transform_point(phase_centre_in_box(reference, dims));
                pc.z - road.z_below(pc)
            },
            range_rate_m_s: sensor.range_rate(pose.position, velocity),
            azimuth_rate_deg_s: azimuth_rate.to_degrees(),
            stationary: velocity.length() < STATIONARY_M_S,
        });
    }
    let sensor_height_m = s_pos.z - road.z_below(s_pos);
    Ok(FrameGeom {
        sensor,
        targets,
        sensor_height_m,
        cal_w: 0.0,
    })
}

/// A target moving slower than this counts as stationary, m/s.
const STATIONARY_M_S: f64 = 0.05;

/// The Doppler information on a radar's azimuth misalignment that one frame offers
/// (physics.md §7.3, §7.4): over the campaign's stationary targets at least
/// `MIN_AZIMUTH_RAD` off boresight, Σ g², g = ∂ṙ/∂δ = cos φ·(v_y cos θ − v_x sin θ) (m/s per rad) with
/// v the sensor's velocity in its own axes; 0 when the frame fails the online calibration's gates
/// (sensor slower than `MIN_SPEED_M_S`, fewer than `MIN_DETECTIONS` targets, Σ g² below
/// `MIN_WEIGHT`: the constants of `osiris_models::radar::calibration`, taken as the ground truth's
/// stationary targets all detected).
fn frame_information(geom: &FrameGeom) -> f64 {
    use osiris_models::radar::calibration::{
        MIN_AZIMUTH_RAD, MIN_DETECTIONS, MIN_SPEED_M_S, MIN_WEIGHT,
    };
    let v = geom.sensor.vector_to_sensor(geom.sensor.velocity);
    if !(v.is_finite() && v.truncate().length() >= MIN_SPEED_M_S) {
        return 0.0;
    }
    let (mut w, mut n) = (0.0, 0usize);
    for g in geom.targets.iter().filter(|g| g.stationary) {
        let (th, ph) = (g.azimuth_deg.to_radians(), g.elevation_deg.to_radians());
        if th.abs() < MIN_AZIMUTH_RAD {
            continue;
        }
        let d = ph.cos() * (v.y * th.cos() - v.x * th.sin());
        w += d * d;
        n += 1;
    }
    if n < MIN_DETECTIONS || w < MIN_WEIGHT {
        0.0
    } else {
        w
    }
}

/// Radar: per SensorView (index into `views`), the Doppler information on the azimuth
/// misalignment gathered from the first view up to and including it ([`frame_information`]
/// summed in time order): what a radar's online calibration (physics.md §7.3) could have used by
/// then. Every view counts, also those whose measured frame is missing (the radar ran that cycle).
fn calibration_information(
    campaign: &Campaign,
    views: &[osi3::SensorView],
    view_idx: &[(i128, usize)],
) -> Result<Vec<f64>> {
    let mut out = vec![0.0; views.len()];
    let mut sum = 0.0;
    for &(_, vi) in view_idx {
        sum += frame_information(&frame_geometry(campaign, &views[vi])?);
        out[vi] = sum;
    }
    Ok(out)
}

/// The angle between a target's facing axis (+x) and the direction to the sensor, both projected
/// on the horizontal plane, deg.
fn horizontal_aspect_deg(geom: &FrameGeom, g: &TargetGeometry) -> f64 {
    let facing = g
        .pose
        .transform_vector(DVec3::X)
        .truncate()
        .normalize_or_zero();
    let to_sensor = (geom.sensor.pose.position - g.pose.position)
        .truncate()
        .normalize_or_zero();
    facing.dot(to_sensor).clamp(-1.0, 1.0).acos().to_degrees()
}

fn station_key(target: u64, a: f64, b: f64) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    target.hash(&mut h);
    ((a / 0.25).round() as i64).hash(&mut h);
    ((b / 0.5).round() as i64).hash(&mut h);
    h.finish()
}

fn vars(campaign: &Campaign, geom: &FrameGeom, g: &TargetGeometry) -> [f64; NVARS] {
    let (dr, el_dir, el_img) =
        super::two_ray_geometry(g.range_m, geom.sensor_height_m, g.phase_centre_height_m);
    let t = campaign.target(g.id);
    let area = t.and_then(|t| t.area_m2()).unwrap_or(g.dims.y * g.dims.z);
    let fog = campaign.environment.fog_visibility_m;
    [
        g.range_m,
        g.azimuth_deg,
        g.elevation_deg,
        g.aspect_deg,
        area,
        t.and_then(|t| t.edge_m).unwrap_or(0.0),
        t.and_then(|t| t.reflectivity_pct).unwrap_or(0.0),
        t.and_then(|t| t.size_m).map(|s| s[1]).unwrap_or(g.dims.z),
        t.and_then(|t| t.size_m).map(|s| s[0]).unwrap_or(g.dims.y),
        0.0,
        campaign.environment.rain_mm_h,
        if fog.is_finite() { fog } else { 1e9 },
        0.0,
        geom.sensor_height_m,
        g.phase_centre_height_m,
        campaign.sensor.wavelength_m(),
        0.0,
        0.0,
        dr,
        el_dir,
        el_img,
        g.range_rate_m_s,
        g.azimuth_rate_deg_s,
        geom.cal_w,
        0.0,
    ]
}

/// Loads the traces of a campaign (`sim` = the simulated SensorData) and pairs them.
pub fn load_and_pair(campaign: &Campaign, sim: &[osi3::SensorData]) -> Result<Paired> {
    let views: Vec<osi3::SensorView> = read_trace(&campaign.sensor_view, "SensorView")?;
    let meas: Vec<osi3::SensorData> = read_trace(&campaign.sensor_data, "measured SensorData")?;
    pair(campaign, &views, &meas, sim, None)
}

/// Ground-truth ids of detections from their `object_id`s (`ids`, feature-data order) in the
/// SensorData `sd` they belong to, by OSI 3.8.0 semantics: an `object_id` that is the
/// `header.tracking_id` of a detected (moving or stationary) object of `sd` stands for that
/// object's first `header.ground_truth_id` (none if it has none); an `object_id` that names no
/// detected object of `sd` is read as a ground-truth id itself — a *labelled* trace, as measured
/// campaigns are: their detections annotated with the ground-truth ids of the targets (OSI 3.8.0
/// has no other field for that). A labelled trace must therefore not also carry detected objects
/// whose tracking ids equal ground-truth ids of other objects.
pub fn truth_of_object_ids(
    sd: &osi3::SensorData,
    ids: impl Iterator<Item = Option<osi3::Identifier>>,
) -> Vec<Option<u64>> {
    let mut by_track: HashMap<u64, Option<u64>> = HashMap::new();
    let headers = sd
        .moving_object
        .iter()
        .map(|m| m.header.as_ref())
        .chain(sd.stationary_object.iter().map(|s| s.header.as_ref()));
    for h in headers.flatten() {
        if let Some(t) = h.tracking_id.and_then(|i| i.value) {
            by_track.insert(t, h.ground_truth_id.iter().find_map(|g| oid(Some(*g))));
        }
    }
    ids.map(|i| {
        let v = oid(i)?;
        by_track.get(&v).copied().unwrap_or(Some(v))
    })
    .collect()
}

/// The ground-truth id of every detection of one sensor block (`n` detections): from `known`
/// (`INVALID_ID` = none) when it has one entry per detection, else [`truth_of_object_ids`].
fn detection_truth(
    sd: &osi3::SensorData,
    ids: impl Iterator<Item = Option<osi3::Identifier>>,
    n: usize,
    known: Option<&[u64]>,
) -> Vec<Option<u64>> {
    match known {
        Some(k) if k.len() == n => k
            .iter()
            .map(|&v| (v != osiris_proto::INVALID_ID).then_some(v))
            .collect(),
        _ => truth_of_object_ids(sd, ids),
    }
}

/// Pairs views, measured and simulated frames by timestamp and builds the residual rows.
/// `sim_truth` (one entry per simulated frame, when the simulation knows it) gives the
/// ground-truth id of each of that frame's radar or LiDAR detections (a re-simulation takes them
/// from the model's PerceptionData, which keeps the ground truth of every peak and point);
/// without it the ids come from the traces ([`truth_of_object_ids`]).
pub fn pair(
    campaign: &Campaign,
    views: &[osi3::SensorView],
    meas: &[osi3::SensorData],
    sim: &[osi3::SensorData],
    sim_truth: Option<&[Vec<u64>]>,
) -> Result<Paired> {
    let mut out = Paired {
        views: views.len(),
        ..Default::default()
    };
    let view_idx = sorted_ts(views, view_ts);
    if view_idx.len() < views.len() {
        out.warnings.push(format!(
            "{} SensorView frame(s) without a timestamp ignored",
            views.len() - view_idx.len()
        ));
    }
    let sim_idx = sorted_ts(sim, |d| ts_ns(d.timestamp.as_ref()));
    let mut used_views = vec![false; views.len()];
    let meas_idx = sorted_ts(meas, |d| ts_ns(d.timestamp.as_ref()));
    if meas_idx.is_empty() {
        bail!("the measured SensorData trace has no frame with a timestamp");
    }
    let osi_id = campaign.sensor.osi_sensor_id;
    let cal_w = if campaign.sensor.kind == CampaignSensor::Radar {
        calibration_information(campaign, views, &view_idx)?
    } else {
        Vec::new()
    };
    let mut frame = 0usize;
    for &(t, mi) in &meas_idx {
        let md = &meas[mi];
        if let (Some(want), Some(got)) = (osi_id, md.sensor_id.and_then(|i| i.value))
            && want != got
        {
            continue;
        }
        let Some(vi) = find_ts(&view_idx, t) else {
            out.warnings.push(format!(
                "measured frame at t = {:.6} s has no SensorView",
                t as f64 * 1e-9
            ));
            continue;
        };
        used_views[vi] = true;
        let Some(si) = find_ts(&sim_idx, t) else {
            out.missing_sim_frames += 1;
            continue;
        };
        let mut geom = frame_geometry(campaign, &views[vi])?;
        geom.cal_w = cal_w.get(vi).copied().unwrap_or(0.0);
        let time_s = t as f64 * 1e-9;
        let known = sim_truth.and_then(|t| t.get(si)).map(Vec::as_slice);
        let sd = (&sim[si], known);
        match campaign.sensor.kind {
            CampaignSensor::Radar => radar_frame(campaign, &geom, md, sd, frame, time_s, &mut out),
            CampaignSensor::Lidar => lidar_frame(campaign, &geom, md, sd, frame, time_s, &mut out),
            CampaignSensor::Camera => {
                camera_frame(campaign, &geom, md, sd, frame, time_s, &mut out)
            }
        }
        frame += 1;
    }
    out.paired_frames = frame;
    out.missing_meas_frames = used_views.iter().filter(|u| !**u).count();
    if frame == 0 {
        bail!(
            "no measured frame could be paired with a SensorView and a simulated frame (timestamps differ?)"
        );
    }
    Ok(out)
}

fn oid(i: Option<osi3::Identifier>) -> Option<u64> {
    i.and_then(|i| i.value)
        .filter(|&v| v != osiris_proto::INVALID_ID)
}

fn radar_power(campaign: &Campaign, d: &osi3::RadarDetection) -> Option<f64> {
    let sem = &campaign.sensor.quantity_semantics;
    if sem.contains_key("rcs") {
        d.rcs
    } else if sem.contains_key("snr") {
        d.snr
    } else {
        d.rcs.or(d.snr)
    }
}

fn radar_frame(
    campaign: &Campaign,
    geom: &FrameGeom,
    md: &osi3::SensorData,
    (sd, sd_truth): (&osi3::SensorData, Option<&[u64]>),
    frame: usize,
    time_s: f64,
    out: &mut Paired,
) {
    let rcs_semantics = campaign.sensor.quantity_semantics.contains_key("rcs")
        || !campaign.sensor.quantity_semantics.contains_key("snr");
    let dets = |d: &osi3::SensorData| -> Vec<osi3::RadarDetection> {
        d.feature_data
            .as_ref()
            .and_then(|f| f.radar_sensor.first())
            .map(|r| r.detection.clone())
            .unwrap_or_default()
    };
    let (m, s) = (dets(md), dets(sd));
    for (name, list) in [("meas", &m), ("sim", &s)] {
        let values = if name == "meas" {
            &mut out.meas_values
        } else {
            &mut out.sim_values
        };
        for d in list.iter() {
            if let Some(p) = radar_power(campaign, d) {
                values.entry(quantity::POWER_DB).or_default().push(p);
            }
        }
    }
    let m_truth = detection_truth(md, m.iter().map(|d| d.object_id), m.len(), None);
    let s_truth = detection_truth(sd, s.iter().map(|d| d.object_id), s.len(), sd_truth);
    let by_id = |t: &[Option<u64>]| t.iter().any(Option::is_some);
    let use_ids = campaign.association.method == AssociationMethod::ObjectId;
    let (m_ids, s_ids) = (use_ids && by_id(&m_truth), use_ids && by_id(&s_truth));
    let mut m_used = vec![false; m.len()];
    let mut s_used = vec![false; s.len()];
    let pick = |list: &[osi3::RadarDetection],
                truth: &[Option<u64>],
                used: &mut [bool],
                ids: bool,
                g: &TargetGeometry|
     -> Option<usize> {
        pick_nearest(used, truth, ids, g.id, |i| {
            let p = list[i].position?;
            let r = p.distance.unwrap_or(f64::NAN);
            let az = p.azimuth.unwrap_or(0.0).to_degrees();
            if ids {
                return Some((r - g.range_m).abs());
            }
            // Gate: 2 m + 5 % in range, 3° in azimuth.
            let dr = (r - g.range_m) / (2.0 + 0.05 * g.range_m);
            let da = (az - g.azimuth_deg) / 3.0;
            let c = dr * dr + da * da;
            (!c.is_nan() && c <= 1.0).then_some(c)
        })
    };
    for g in &geom.targets {
        out.counts.opportunities += 1;
        let mi = pick(&m, &m_truth, &mut m_used, m_ids, g);
        let si = pick(&s, &s_truth, &mut s_used, s_ids, g);
        out.counts.meas_detected += usize::from(mi.is_some());
        out.counts.sim_detected += usize::from(si.is_some());
        let (Some(mi), Some(si)) = (mi, si) else {
            continue;
        };
        out.counts.both += 1;
        let (a, b) = (&m[mi], &s[si]);
        let (Some(pa), Some(pb)) = (a.position, b.position) else {
            continue;
        };
        let x = vars(campaign, geom, g);
        // A station is the target at one geometry: range, azimuth and (2° steps) the aspect it
        // shows the sensor in the horizontal plane (a board turned 4° or 40° at one place is two
        // stations; the elevation of a near target does not split its frames).
        let station = station_key(
            g.id ^ (((horizontal_aspect_deg(geom, g) / 2.0).round() as u64) << 48),
            g.range_m,
            g.azimuth_deg,
        );
        let mut push = |q: &'static str, meas: Option<f64>, sim: Option<f64>| {
            if let (Some(mv), Some(sv)) = (meas, sim)
                && mv.is_finite()
                && sv.is_finite()
            {
                let mut x = x;
                x[super::V_SIM] = sv;
                x[super::V_PRX] = if q == quantity::POWER_DB && rcs_semantics {
                    sv - 40.0 * g.range_m.max(1e-3).log10()
                } else {
                    sv
                };
                out.rows.push(Row {
                    quantity: q,
                    frame,
                    time_s,
                    target: g.id,
                    station,
                    meas: mv,
                    sim: sv,
                    x,
                });
            }
        };
        push(quantity::RANGE_M, pa.distance, pb.distance);
        push(
            quantity::AZIMUTH_DEG,
            pa.azimuth.map(f64::to_degrees),
            pb.azimuth.map(|v| v.to_degrees()),
        );
        push(
            quantity::RADIAL_VELOCITY_KMH,
            a.radial_velocity.map(|v| v * 3.6),
            b.radial_velocity.map(|v| v * 3.6),
        );
        push(
            quantity::POWER_DB,
            radar_power(campaign, a),
            radar_power(campaign, b),
        );
    }
    out.counts.meas_unassociated += m_used.iter().filter(|u| !**u).count();
    out.counts.sim_unassociated += s_used.iter().filter(|u| !**u).count();
    clutter_rows(
        campaign,
        geom,
        [(&m, &m_truth), (&s, &s_truth)],
        frame,
        time_s,
        out,
    );
}

/// Width of the range bands of the radar clutter rows, m.
pub const CLUTTER_BAND_M: f64 = 2.0;
/// The clutter rows' bands reach this slant range, m (constant-γ road clutter falls as R⁻⁴: a road
/// whose mean clutter is at the threshold at 15 m is 26 dB below it here).
pub const CLUTTER_MAX_RANGE_M: f64 = 60.0;
/// A clutter detection's radial velocity is within this of a stationary point's, m/s.
pub const CLUTTER_DOPPLER_GATE_M_S: f64 = 0.5;

/// The stationary clutter detections of one frame per range band: detections without a ground-truth
/// id, outside every target's association gate (2 m + 5 % in range, 3° in azimuth) and with the
/// radial velocity of a stationary point in their direction (OSI sign: v_s·u towards the sensor,
/// v_s the sensor's velocity in its axes; detections without a radial velocity count).
fn clutter_counts(
    geom: &FrameGeom,
    dets: &[osi3::RadarDetection],
    truth: &[Option<u64>],
) -> Vec<usize> {
    let bands = (CLUTTER_MAX_RANGE_M / CLUTTER_BAND_M).round() as usize;
    let mut counts = vec![0usize; bands];
    let v = geom.sensor.vector_to_sensor(geom.sensor.velocity);
    for (d, t) in dets.iter().zip(truth) {
        let Some(p) = d.position.filter(|_| t.is_none()) else {
            continue;
        };
        let Some(r) = p.distance.filter(|r| r.is_finite() && *r >= 0.0) else {
            continue;
        };
        let (az, el) = (p.azimuth.unwrap_or(0.0), p.elevation.unwrap_or(0.0));
        let Some(band) = Some((r / CLUTTER_BAND_M) as usize).filter(|b| *b < bands) else {
            continue;
        };
        let near_target = geom.targets.iter().any(|g| {
            let dr = (r - g.range_m) / (2.0 + 0.05 * g.range_m);
            let da = (az.to_degrees() - g.azimuth_deg) / 3.0;
            dr * dr + da * da <= 1.0
        });
        let u = DVec3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin());
        let moving = d
            .radial_velocity
            .is_some_and(|rv| (rv - v.dot(u)).abs() > CLUTTER_DOPPLER_GATE_M_S);
        if !near_target && !moving {
            counts[band] += 1;
        }
    }
    counts
}

/// The clutter shape of a band: the constant-γ mean road-clutter power (physics.md §1.10) at slant
/// range `r` from a sensor `h` above a flat road, relative to that at 10 m, dB:
/// 10·log10[(sin ψ/sin ψ₁₀)·(r/10)·(10/r)⁴] − 24.08·(ψ² − ψ₁₀²)/θ_el², ψ = asin(h/r) the grazing
/// angle (and the road's depression below a horizontal boresight), θ_el the campaign's elevation
/// 3 dB beamwidth (two-way Gaussian beam; no pattern term without one).
pub fn clutter_db(r: f64, h: f64, el_beamwidth_deg: Option<f64>) -> f64 {
    let psi = |r: f64| (h / r.max(h + 1e-3)).clamp(0.0, 1.0).asin().to_degrees();
    let (p, p10) = (psi(r), psi(10.0));
    let pattern = el_beamwidth_deg.filter(|b| *b > 0.0).map_or(0.0, |b| {
        // Two-way Gaussian power pattern exp(−8 ln2·ψ²/θ²) in dB: −24.08·ψ²/θ².
        -80.0 * std::f64::consts::LN_2 / std::f64::consts::LN_10 * (p * p - p10 * p10) / (b * b)
    });
    10.0 * (p.to_radians().sin() / p10.to_radians().sin()).log10() - 30.0 * (r / 10.0).log10()
        + pattern
}

/// The clutter rows of one radar frame: per range band of [`CLUTTER_BAND_M`] out to
/// [`CLUTTER_MAX_RANGE_M`], the measured and the simulated stationary clutter detections
/// ([`clutter_counts`]); `range` the band's centre, `clutter_db` its clutter shape.
fn clutter_rows(
    campaign: &Campaign,
    geom: &FrameGeom,
    [(m, m_truth), (s, s_truth)]: [(&[osi3::RadarDetection], &[Option<u64>]); 2],
    frame: usize,
    time_s: f64,
    out: &mut Paired,
) {
    let (mc, sc) = (
        clutter_counts(geom, m, m_truth),
        clutter_counts(geom, s, s_truth),
    );
    let h = geom.sensor_height_m;
    let fog = campaign.environment.fog_visibility_m;
    for (b, (&mv, &sv)) in mc.iter().zip(&sc).enumerate() {
        let r = (b as f64 + 0.5) * CLUTTER_BAND_M;
        let mut x = [0.0; NVARS];
        x[super::V_RANGE] = r;
        x[super::V_SIM] = sv as f64;
        x[10] = campaign.environment.rain_mm_h;
        x[11] = if fog.is_finite() { fog } else { 1e9 };
        x[super::V_MOUNT_H] = h;
        x[super::V_WAVELENGTH] = campaign.sensor.wavelength_m();
        x[super::V_CAL_W] = geom.cal_w;
        x[super::V_CLUTTER_DB] = clutter_db(r, h, campaign.sensor.antenna_beamwidth_el_deg);
        out.rows.push(Row {
            quantity: quantity::CLUTTER_COUNT,
            frame,
            time_s,
            target: 0,
            station: station_key(0, r, h),
            meas: mv as f64,
            sim: sv as f64,
            x,
        });
    }
}

/// The unused detection of the lowest `cost` (`None`: not a candidate), restricted to those whose
/// ground-truth id is `id` when associating by ids; marks it used. The first of equal costs wins.
fn pick_nearest(
    used: &mut [bool],
    truth: &[Option<u64>],
    ids: bool,
    id: u64,
    cost: impl Fn(usize) -> Option<f64>,
) -> Option<usize> {
    let mut best: Option<(f64, usize)> = None;
    for i in 0..used.len() {
        if used[i] || (ids && truth[i] != Some(id)) {
            continue;
        }
        let Some(c) = cost(i) else { continue };
        if best.is_none_or(|(b, _)| c < b) {
            best = Some((c, i));
        }
    }
    let i = best.map(|(_, i)| i)?;
    used[i] = true;
    Some(i)
}

/// A camera detection: its angular box (`None` without finite points) and its object id.
type CameraDetectionBox = (Option<CameraBox>, Option<osi3::Identifier>);

/// The angular box of a camera detection, spanned by its points (OSI `CameraPoint.point`,
/// spherical in the sensor frame; a box detection has two, the first and third corner).
#[derive(Debug, Clone, Copy, PartialEq)]
struct CameraBox {
    /// Centre (azimuth, elevation), deg.
    centre: (f64, f64),
    /// Width (azimuth span) and height (elevation span), deg: the screen size.
    size: (f64, f64),
    /// The recognition's distance: the mean of the points' finite positive distances, m.
    distance_m: Option<f64>,
}

/// The angular box of a camera detection; `None` without finite points.
fn camera_box(data: &osi3::CameraDetectionData, d: &osi3::CameraDetection) -> Option<CameraBox> {
    let first = d.first_point_index? as usize;
    let n = d.number_of_points.unwrap_or(0) as usize;
    let points = data.point.get(first..first.checked_add(n)?)?;
    let (mut az, mut el) = (
        (f64::INFINITY, f64::NEG_INFINITY),
        (f64::INFINITY, f64::NEG_INFINITY),
    );
    let (mut dist, mut nd) = (0.0, 0usize);
    for p in points.iter().filter_map(|p| p.point.as_ref()) {
        let (a, e) = (p.azimuth?, p.elevation.unwrap_or(0.0));
        if !(a.is_finite() && e.is_finite()) {
            return None;
        }
        az = (az.0.min(a), az.1.max(a));
        el = (el.0.min(e), el.1.max(e));
        if let Some(r) = p.distance.filter(|r| r.is_finite() && *r > 0.0) {
            dist += r;
            nd += 1;
        }
    }
    az.0.is_finite().then(|| CameraBox {
        centre: (
            (0.5 * (az.0 + az.1)).to_degrees(),
            (0.5 * (el.0 + el.1)).to_degrees(),
        ),
        size: ((az.1 - az.0).to_degrees(), (el.1 - el.0).to_degrees()),
        distance_m: (nd > 0).then(|| dist / nd as f64),
    })
}

/// Camera detections (campaigns with `camera_detections`): per target and frame the measured and
/// the simulated detection of the target's ground-truth id (or, associating by gating or without
/// ids, the detection nearest in direction within 3°), rows of the direction of the detection's
/// angular box centre: `azimuth_deg`, `elevation_deg`; and the recognition outputs DIVP compared
/// between a real and a simulated camera (metrics, relative to the simulated value, %): the
/// box's screen size, `screen_width_pct` and `screen_height_pct` (boxes ≥ 0.05° in that
/// dimension), and the recognition distance, `recognition_distance_pct` (when both report one). A
/// mono camera's distance estimate is the recognition's output, not a measurement of the range.
fn camera_frame(
    campaign: &Campaign,
    geom: &FrameGeom,
    md: &osi3::SensorData,
    (sd, sd_truth): (&osi3::SensorData, Option<&[u64]>),
    frame: usize,
    time_s: f64,
    out: &mut Paired,
) {
    // (azimuth, elevation) per detection, and its object id.
    let dets = |d: &osi3::SensorData| -> Vec<CameraDetectionBox> {
        d.feature_data
            .as_ref()
            .into_iter()
            .flat_map(|f| f.camera_sensor.iter())
            .flat_map(|c| {
                c.detection
                    .iter()
                    .map(move |d| (camera_box(c, d), d.object_id))
            })
            .collect()
    };
    let (m, s) = (dets(md), dets(sd));
    let m_truth = detection_truth(md, m.iter().map(|d| d.1), m.len(), None);
    let s_truth = detection_truth(sd, s.iter().map(|d| d.1), s.len(), sd_truth);
    let by_id = |t: &[Option<u64>]| t.iter().any(Option::is_some);
    let use_ids = campaign.association.method == AssociationMethod::ObjectId;
    let (m_ids, s_ids) = (use_ids && by_id(&m_truth), use_ids && by_id(&s_truth));
    let mut m_used = vec![false; m.len()];
    let mut s_used = vec![false; s.len()];
    let pick = |list: &[CameraDetectionBox],
                truth: &[Option<u64>],
                used: &mut [bool],
                ids: bool,
                g: &TargetGeometry|
     -> Option<usize> {
        pick_nearest(used, truth, ids, g.id, |i| {
            let (az, el) = list[i].0?.centre;
            let cost = (az - g.azimuth_deg).hypot(el - g.elevation_deg);
            (ids || !(cost.is_nan() || cost > 3.0)).then_some(cost)
        })
    };
    for g in &geom.targets {
        out.counts.opportunities += 1;
        let mi = pick(&m, &m_truth, &mut m_used, m_ids, g);
        let si = pick(&s, &s_truth, &mut s_used, s_ids, g);
        out.counts.meas_detected += usize::from(mi.is_some());
        out.counts.sim_detected += usize::from(si.is_some());
        let (Some(mi), Some(si)) = (mi, si) else {
            continue;
        };
        out.counts.both += 1;
        let (Some(mb), Some(sb)) = (m[mi].0, s[si].0) else {
            continue;
        };
        let ((ma, me), (sa, se)) = (mb.centre, sb.centre);
        let x = vars(campaign, geom, g);
        let station = station_key(g.id, g.range_m, g.azimuth_deg);
        // Recognition outputs relative to the simulated value, %.
        let pct = |m: f64, s: f64| 100.0 * (m - s) / s;
        let min_size = 0.05;
        let recognition = [
            (quantity::SCREEN_WIDTH_PCT, mb.size.0, sb.size.0),
            (quantity::SCREEN_HEIGHT_PCT, mb.size.1, sb.size.1),
        ]
        .into_iter()
        .filter(|&(_, m, s)| m >= min_size && s >= min_size)
        .chain(
            mb.distance_m
                .zip(sb.distance_m)
                .map(|(m, s)| (quantity::RECOGNITION_DISTANCE_PCT, m, s)),
        )
        .map(|(q, m, s)| (q, pct(m, s), 0.0));
        for (q, meas, sim) in [
            (quantity::AZIMUTH_DEG, ma, sa),
            (quantity::ELEVATION_DEG, me, se),
        ]
        .into_iter()
        .chain(recognition)
        {
            let mut x = x;
            x[super::V_SIM] = sim;
            x[super::V_PRX] = sim;
            out.rows.push(Row {
                quantity: q,
                frame,
                time_s,
                target: g.id,
                station,
                meas,
                sim,
                x,
            });
        }
    }
    out.counts.meas_unassociated += m_used.iter().filter(|u| !**u).count();
    out.counts.sim_unassociated += s_used.iter().filter(|u| !**u).count();
}

/// Which target a LiDAR point belongs to: the target of its ground-truth id `truth` (when
/// associating by id), else the target whose box (inflated by 0.2 m) contains it.
fn lidar_target(
    campaign: &Campaign,
    geom: &FrameGeom,
    d: &osi3::LidarDetection,
    truth: Option<u64>,
    use_ids: bool,
) -> Option<usize> {
    if use_ids {
        if let Some(id) = truth {
            return geom.targets.iter().position(|t| t.id == id);
        }
        return None;
    }
    let _ = campaign;
    let p = osiris_models::frames::Spherical::from_osi(d.position.as_ref()?).to_cartesian();
    let g = geom.sensor.point_to_global(p);
    geom.targets.iter().position(|t| {
        let l = t.pose.inverse_transform_point(g);
        let h = t.dims * 0.5 + DVec3::splat(0.2);
        l.x.abs() <= h.x && l.y.abs() <= h.y && l.z.abs() <= h.z
    })
}

/// FMCW LiDAR points need this many points on a target (each side) for its spread rows.
const MIN_SPREAD_POINTS: usize = 8;

fn sd(v: &[f64]) -> f64 {
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
}

/// FMCW LiDAR spread rows per target and frame (each side over its own points on the target):
/// [`quantity::INTENSITY_SD_DB`] over the points whose footprint lies wholly on the target
/// ([`edge_beam`]), [`quantity::RANGE_SD_M`] over the points' depth along the target box's x axis
/// (a board's normal: flat in truth, so its spread is the range noise and smear). The row's `sim`
/// variable is the simulated spread.
fn fmcw_spreads(
    campaign: &Campaign,
    geom: &FrameGeom,
    (m, m_t): (&[osi3::LidarDetection], &[Option<usize>]),
    (s, s_t): (&[osi3::LidarDetection], &[Option<usize>]),
    frame: usize,
    time_s: f64,
    out: &mut Paired,
) {
    for (i, g) in geom.targets.iter().enumerate() {
        let collect = |dets: &[osi3::LidarDetection], tg: &[Option<usize>]| {
            let (mut idb, mut depth) = (Vec::new(), Vec::new());
            for (d, t) in dets.iter().zip(tg) {
                if *t != Some(i) {
                    continue;
                }
                let Some(pos) = d.position.as_ref() else {
                    continue;
                };
                let p = osiris_models::frames::Spherical::from_osi(pos).to_cartesian();
                depth.push(
                    g.pose
                        .inverse_transform_point(geom.sensor.point_to_global(p))
                        .x,
                );
                if let Some(v) = d.intensity
                    && !edge_beam(campaign, geom, g, d)
                {
                    idb.push(10.0 * v.max(0.01).log10());
                }
            }
            (idb, depth)
        };
        let (mi, md) = collect(m, m_t);
        let (si, sdp) = collect(s, s_t);
        let x0 = vars(campaign, geom, g);
        let station = station_key(g.id, g.range_m, g.azimuth_deg);
        for (q, a, b) in [
            (quantity::INTENSITY_SD_DB, &mi, &si),
            (quantity::RANGE_SD_M, &md, &sdp),
        ] {
            if a.len() < MIN_SPREAD_POINTS || b.len() < MIN_SPREAD_POINTS {
                continue;
            }
            let (sm, ss) = (sd(a), sd(b));
            let mut x = x0;
            x[super::V_SIM] = ss;
            out.rows.push(Row {
                quantity: q,
                frame,
                time_s,
                target: g.id,
                station,
                meas: sm,
                sim: ss,
                x,
            });
        }
    }
}

/// A LiDAR target's centroid azimuth needs this many of its points on each side.
const MIN_CENTROID_POINTS: usize = 3;
/// Azimuth gate of the centroid association beyond a target's own half-width, deg (the yaw bound
/// of the `lidar.extrinsic_error` catalogue entry).
const CENTROID_GATE_DEG: f64 = 5.0;

/// The association gate of a target's centroid (sensor frame).
struct CentroidGate {
    /// Azimuth of the box centre, rad.
    azimuth_rad: f64,
    /// Half-width of the box (inflated by 0.2 m) seen from the sensor, rad.
    half_width_rad: f64,
    /// Range span of the inflated box, m.
    range_m: (f64, f64),
    /// Height span (global z) of the inflated box, m.
    z_m: (f64, f64),
}

/// LiDAR [`quantity::AZIMUTH_DEG`] rows per target and frame: the azimuth (sensor frame, deg) of
/// the centroid direction Σ u_i / |Σ u_i| of the target's points on each side. A sensor turned by
/// ψ from its nominal mounting reports every point ψ off, so the centroid moves by −ψ while the
/// per-beam pairing (same beam id, same reported direction) cannot see it (physics.md §7.1).
///
/// A turned sensor's points leave the target's box sideways, so the box association would cut
/// the centroid's shift; here a point belongs to the target when its height and range lie within
/// the box (inflated by 0.2 m, as [`lidar_target`]) and its azimuth within the box's half-width
/// plus [`CENTROID_GATE_DEG`]. A target with another one inside that gate (at a range the gate
/// could confuse) gets no row.
fn centroid_azimuths(
    campaign: &Campaign,
    geom: &FrameGeom,
    m: &[osi3::LidarDetection],
    s: &[osi3::LidarDetection],
    frame: usize,
    time_s: f64,
    out: &mut Paired,
) {
    let gates: Vec<CentroidGate> = geom
        .targets
        .iter()
        .map(|t| {
            let half_diag = 0.5 * t.dims.x.hypot(t.dims.y) + 0.2;
            let zc = t.pose.position.z;
            let hz = 0.5 * t.dims.z + 0.2;
            CentroidGate {
                azimuth_rad: t.azimuth_deg.to_radians(),
                half_width_rad: (half_diag / t.range_m.max(0.1)).min(1.0).asin(),
                range_m: (t.range_m - half_diag, t.range_m + half_diag),
                z_m: (zc - hz, zc + hz),
            }
        })
        .collect();
    let gate = CENTROID_GATE_DEG.to_radians();
    let wrap = |a: f64| (a + 3.0 * PI).rem_euclid(2.0 * PI) - PI;
    let centroid = |dets: &[osi3::LidarDetection], i: usize| {
        let g = &gates[i];
        let (mut sum, mut n) = (DVec3::ZERO, 0usize);
        for p in dets.iter().filter_map(|d| d.position.as_ref()) {
            let c = osiris_models::frames::Spherical::from_osi(p).to_cartesian();
            let (r, z) = (c.length(), geom.sensor.point_to_global(c).z);
            if r < g.range_m.0 || r > g.range_m.1 || z < g.z_m.0 || z > g.z_m.1 || r == 0.0 {
                continue;
            }
            if wrap(c.y.atan2(c.x) - g.azimuth_rad).abs() <= g.half_width_rad + gate {
                sum += c / r;
                n += 1;
            }
        }
        (n >= MIN_CENTROID_POINTS).then(|| sum.y.atan2(sum.x).to_degrees())
    };
    for (i, g) in geom.targets.iter().enumerate() {
        let gi = &gates[i];
        let crowded = gates.iter().enumerate().any(|(j, gj)| {
            j != i
                && gj.range_m.0 <= gi.range_m.1
                && gj.range_m.1 >= gi.range_m.0
                && wrap(gj.azimuth_rad - gi.azimuth_rad).abs()
                    <= gi.half_width_rad + gj.half_width_rad + 2.0 * gate
        });
        if crowded {
            continue;
        }
        let (Some(am), Some(as_)) = (centroid(m, i), centroid(s, i)) else {
            continue;
        };
        // The residual wraps into (−180°, 180°].
        let d = (am - as_ + 540.0).rem_euclid(360.0) - 180.0;
        let mut x = vars(campaign, geom, g);
        x[super::V_SIM] = as_;
        out.rows.push(Row {
            quantity: quantity::AZIMUTH_DEG,
            frame,
            time_s,
            target: g.id,
            station: station_key(g.id, g.range_m, g.azimuth_deg),
            meas: as_ + d,
            sim: as_,
            x,
        });
    }
}

/// The median gap between distinct sorted angles (rad), in deg; 0 with fewer than two distinct.
/// Angles closer than 1e-4 rad (0.006°) count as one beam line.
fn median_spacing_deg(mut a: Vec<f64>) -> f64 {
    a.retain(|v| v.is_finite());
    a.sort_by(f64::total_cmp);
    a.dedup_by(|x, y| (*x - *y).abs() < 1e-4);
    let mut gaps: Vec<f64> = a.windows(2).map(|w| w[1] - w[0]).collect();
    if gaps.is_empty() {
        return 0.0;
    }
    gaps.sort_by(f64::total_cmp);
    gaps[gaps.len() / 2].to_degrees()
}

/// Whether a LiDAR detection's footprint may straddle the edge of its target's silhouette: the
/// point, in the target's box frame, lies within the footprint radius R·θ/2 (θ = the campaign's
/// `beam_divergence_mrad`, 3 mrad when absent) plus 2 σ_gt of a face edge.
fn edge_beam(
    campaign: &Campaign,
    geom: &FrameGeom,
    g: &TargetGeometry,
    d: &osi3::LidarDetection,
) -> bool {
    let Some(pos) = d.position.as_ref() else {
        return false;
    };
    if !(g.dims.y > 0.0 && g.dims.z > 0.0) {
        return false;
    }
    let p = osiris_models::frames::Spherical::from_osi(pos).to_cartesian();
    let l = g
        .pose
        .inverse_transform_point(geom.sensor.point_to_global(p));
    let theta = campaign.sensor.beam_divergence_mrad.unwrap_or(3.0) * 1e-3;
    let margin = 0.5 * theta * p.length() + 2.0 * campaign.uncertainty.gt_position_sigma_m.max(0.0);
    l.y.abs() > 0.5 * g.dims.y - margin || l.z.abs() > 0.5 * g.dims.z - margin
}

fn lidar_frame(
    campaign: &Campaign,
    geom: &FrameGeom,
    md: &osi3::SensorData,
    (sd, sd_truth): (&osi3::SensorData, Option<&[u64]>),
    frame: usize,
    time_s: f64,
    out: &mut Paired,
) {
    let dets = |d: &osi3::SensorData| -> Vec<osi3::LidarDetection> {
        d.feature_data
            .as_ref()
            .and_then(|f| f.lidar_sensor.first())
            .map(|r| r.detection.clone())
            .unwrap_or_default()
    };
    let (m, s) = (dets(md), dets(sd));
    let m_truth = detection_truth(md, m.iter().map(|d| d.object_id), m.len(), None);
    let s_truth = detection_truth(sd, s.iter().map(|d| d.object_id), s.len(), sd_truth);
    let has_ids = |t: &[Option<u64>]| t.iter().any(Option::is_some);
    let use_ids = campaign.association.method == AssociationMethod::ObjectId
        && has_ids(&m_truth)
        && has_ids(&s_truth);
    let m_t: Vec<Option<usize>> = m
        .iter()
        .zip(&m_truth)
        .map(|(d, t)| lidar_target(campaign, geom, d, *t, use_ids))
        .collect();
    let s_t: Vec<Option<usize>> = s
        .iter()
        .zip(&s_truth)
        .map(|(d, t)| lidar_target(campaign, geom, d, *t, use_ids))
        .collect();
    for (list, tg, values) in [
        (&m, &m_t, &mut out.meas_values),
        (&s, &s_t, &mut out.sim_values),
    ] {
        for (d, t) in list.iter().zip(tg) {
            if t.is_some()
                && let Some(i) = d.intensity
            {
                values.entry(quantity::INTENSITY_PCT).or_default().push(i);
            }
        }
    }
    // Points on target and gap points.
    let nt = geom.targets.len();
    let mut m_count = vec![0usize; nt];
    let mut s_count = vec![0usize; nt];
    let above_ground = |d: &osi3::LidarDetection| -> bool {
        d.position
            .as_ref()
            .map(|p| {
                let c = osiris_models::frames::Spherical::from_osi(p).to_cartesian();
                geom.sensor.point_to_global(c).z > 0.3
            })
            .unwrap_or(false)
    };
    let (mut m_gap, mut s_gap) = (0usize, 0usize);
    for (d, t) in m.iter().zip(&m_t) {
        match t {
            Some(i) => m_count[*i] += 1,
            None if above_ground(d) => m_gap += 1,
            None => {}
        }
    }
    for (d, t) in s.iter().zip(&s_t) {
        match t {
            Some(i) => s_count[*i] += 1,
            None if above_ground(d) => s_gap += 1,
            None => {}
        }
    }
    // Received-power proxy of each target, dB: the mean simulated intensity of its points, less
    // 20·log10 R where the logged intensity is range-compensated reflectivity (the default; an
    // intensity semantics that says "power" or "raw" is taken as received power).
    let power_semantics = campaign
        .sensor
        .quantity_semantics
        .get("intensity")
        .is_some_and(|s| {
            let s = s.to_ascii_lowercase();
            s.contains("power") || s.contains("raw")
        });
    let s_prx: Vec<f64> = (0..nt)
        .map(|i| {
            let v: Vec<f64> = s
                .iter()
                .zip(&s_t)
                .filter(|(_, t)| **t == Some(i))
                .filter_map(|(d, _)| d.intensity)
                .collect();
            if v.is_empty() {
                return 0.0;
            }
            let mean = v.iter().sum::<f64>() / v.len() as f64;
            let r = geom.targets[i].range_m.max(0.1);
            10.0 * mean.max(1e-3).log10()
                - if power_semantics {
                    0.0
                } else {
                    20.0 * r.log10()
                }
        })
        .collect();
    // The scan's beam lattice: the median spacing of the simulated points' distinct azimuths and
    // elevations over the frame, deg (0 where fewer than two).
    let lattice = {
        let (mut az, mut el) = (Vec::new(), Vec::new());
        for p in s.iter().filter_map(|d| d.position.as_ref()) {
            az.extend(p.azimuth);
            el.extend(p.elevation);
        }
        (median_spacing_deg(az), median_spacing_deg(el))
    };
    out.counts.meas_unassociated += m_gap;
    out.counts.sim_unassociated += s_gap;
    let mut frame_x = [0.0; NVARS];
    frame_x[super::V_RANGE] = geom.targets.iter().map(|t| t.range_m).fold(0.0, f64::max);
    frame_x[10] = campaign.environment.rain_mm_h;
    frame_x[11] = if campaign.environment.fog_visibility_m.is_finite() {
        campaign.environment.fog_visibility_m
    } else {
        1e9
    };
    let sp = geom.sensor.pose.position;
    frame_x[super::V_SIM] = s_gap as f64;
    out.rows.push(Row {
        quantity: quantity::GAP_POINTS,
        frame,
        time_s,
        target: 0,
        station: station_key(0, sp.x + 1000.0 * sp.y, sp.z),
        meas: m_gap as f64,
        sim: s_gap as f64,
        x: frame_x,
    });
    for (i, g) in geom.targets.iter().enumerate() {
        out.counts.opportunities += 1;
        out.counts.meas_detected += usize::from(m_count[i] > 0);
        out.counts.sim_detected += usize::from(s_count[i] > 0);
        out.counts.both += usize::from(m_count[i] > 0 && s_count[i] > 0);
        if m_count[i] == 0 && s_count[i] == 0 {
            continue;
        }
        let mut x = vars(campaign, geom, g);
        let station = station_key(g.id, g.range_m, g.azimuth_deg);
        let (mc, sc) = (m_count[i] as f64, s_count[i] as f64);
        x[super::V_SIM] = (sc + 0.5).ln();
        x[super::V_PRX] = s_prx[i];
        x[super::V_BEAM_AZ] = lattice.0;
        x[super::V_BEAM_EL] = lattice.1;
        out.rows.push(Row {
            quantity: quantity::POINTS_LOG_RATIO,
            frame,
            time_s,
            target: g.id,
            station,
            meas: (mc + 0.5).ln(),
            sim: (sc + 0.5).ln(),
            x,
        });
        if sc > 0.0 {
            x[super::V_SIM] = 100.0;
            out.rows.push(Row {
                quantity: quantity::POINTS_ON_TARGET_PCT,
                frame,
                time_s,
                target: g.id,
                station,
                meas: 100.0 * mc / sc,
                sim: 100.0,
                x,
            });
        }
    }
    centroid_azimuths(campaign, geom, &m, &s, frame, time_s, out);
    if campaign.sensor.is_fmcw() {
        fmcw_spreads(campaign, geom, (&m, &m_t), (&s, &s_t), frame, time_s, out);
    }
    // Beam-id pairing of points on targets.
    if campaign.association.pairing != "beam_id" {
        return;
    }
    let mut sim_by_beam: HashMap<u64, Vec<usize>> = HashMap::new();
    for (j, d) in s.iter().enumerate() {
        if let (Some(b), Some(_)) = (d.beam_id.and_then(|b| b.value), s_t[j]) {
            sim_by_beam.entry(b).or_default().push(j);
        }
    }
    if sim_by_beam.is_empty() && !s.is_empty() && frame == 0 {
        out.warnings
            .push("simulated LiDAR points carry no beam_id: point pairing skipped".into());
    }
    // At most MAX_POINTS_PER_TARGET measured points per target and frame are paired, spread
    // evenly over the target's points (a statistical sample keeps near-range targets from
    // swamping the rows).
    let mut seen = vec![0usize; nt];
    for (i, d) in m.iter().enumerate() {
        let (Some(ti), Some(b)) = (m_t[i], d.beam_id.and_then(|b| b.value)) else {
            continue;
        };
        seen[ti] += 1;
        let stride = m_count[ti].div_ceil(MAX_POINTS_PER_TARGET).max(1);
        if !(seen[ti] - 1).is_multiple_of(stride) {
            continue;
        }
        let Some(cands) = sim_by_beam.get(&b) else {
            continue;
        };
        let rm = d.position.and_then(|p| p.distance).unwrap_or(f64::NAN);
        let Some(&j) = cands
            .iter()
            .filter(|&&j| s_t[j] == Some(ti))
            .min_by(|&&a, &&b2| {
                let da = (s[a].position.and_then(|p| p.distance).unwrap_or(f64::NAN) - rm).abs();
                let db = (s[b2].position.and_then(|p| p.distance).unwrap_or(f64::NAN) - rm).abs();
                da.total_cmp(&db)
            })
        else {
            continue;
        };
        let g = &geom.targets[ti];
        let x0 = vars(campaign, geom, g);
        let station = station_key(g.id, g.range_m, g.azimuth_deg);
        let rs = s[j].position.and_then(|p| p.distance).unwrap_or(f64::NAN);
        let mut push = |q: &'static str, mv: f64, sv: f64| {
            if mv.is_finite() && sv.is_finite() {
                let mut x = x0;
                x[super::V_SIM] = sv;
                out.rows.push(Row {
                    quantity: q,
                    frame,
                    time_s,
                    target: g.id,
                    station,
                    meas: mv,
                    sim: sv,
                    x,
                });
            }
        };
        push(quantity::RANGE_M, rm, rs);
        // FMCW: the point's radial velocity (OSI sign), km/h.
        if let (Some(vm), Some(vs)) = (d.radial_velocity, s[j].radial_velocity) {
            push(quantity::RADIAL_VELOCITY_KMH, vm * 3.6, vs * 3.6);
        }
        // Intensity only from beams whose footprint lies wholly on the target: at the silhouette's
        // edge the lit fraction of the footprint, and so the intensity, hinges on sub-footprint
        // positions that the ground truth does not pin down (σ_gt) — an edge beam's intensity
        // residual says nothing about the physics.
        if edge_beam(campaign, geom, g, d) {
            continue;
        }
        if let (Some(im), Some(is)) = (d.intensity, s[j].intensity) {
            push(quantity::INTENSITY_PCT, im, is);
            // Ratio in dB; the `sim` variable of this row is the simulated intensity in %.
            let db = 10.0 * (im.max(0.01) / is.max(0.01)).log10();
            let mut x = x0;
            x[super::V_SIM] = is;
            // The point's received-power proxy, dB: its simulated intensity, less 20·log10 R
            // where the logged intensity is range-compensated reflectivity (what a receiver's
            // saturation acts on).
            x[super::V_PRX] = 10.0 * is.max(1e-3).log10()
                - if power_semantics {
                    0.0
                } else {
                    20.0 * rs.max(0.1).log10()
                };
            out.rows.push(Row {
                quantity: quantity::INTENSITY_DB,
                frame,
                time_s,
                target: g.id,
                station,
                meas: db,
                sim: 0.0,
                x,
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use osiris_proto::id;

    fn object(tracking: u64, truth: &[u64]) -> osi3::DetectedMovingObject {
        osi3::DetectedMovingObject {
            header: Some(osi3::DetectedItemHeader {
                tracking_id: Some(id(tracking)),
                ground_truth_id: truth.iter().map(|&g| id(g)).collect(),
                ..Default::default()
            }),
            ..Default::default()
        }
    }

    /// OSI 3.8.0 object ids resolve through the detected objects' headers; ids that name no
    /// detected object are ground-truth labels; unset and MAX(uint64) ids are none.
    #[test]
    fn object_ids_resolve_through_detected_objects_or_are_labels() {
        let sd = osi3::SensorData {
            moving_object: vec![object(1, &[100]), object(2, &[])],
            stationary_object: vec![osi3::DetectedStationaryObject {
                header: Some(osi3::DetectedItemHeader {
                    tracking_id: Some(id(3)),
                    ground_truth_id: vec![id(500)],
                    ..Default::default()
                }),
                ..Default::default()
            }],
            ..Default::default()
        };
        let ids = [
            Some(id(1)),
            Some(id(3)),
            Some(id(2)),
            Some(id(42)),
            None,
            Some(id(osiris_proto::INVALID_ID)),
        ];
        assert_eq!(
            truth_of_object_ids(&sd, ids.into_iter()),
            vec![Some(100), Some(500), None, Some(42), None, None]
        );
        // Known per-detection truth wins when it has one entry per detection.
        let known = [7, osiris_proto::INVALID_ID];
        assert_eq!(
            detection_truth(&sd, [Some(id(1)), None].into_iter(), 2, Some(&known)),
            vec![Some(7), None]
        );
        assert_eq!(
            detection_truth(&sd, [Some(id(1))].into_iter(), 1, Some(&known)),
            vec![Some(100)]
        );
    }
}
