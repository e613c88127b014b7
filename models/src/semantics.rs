//! OSI 3.8.0 detection semantics shared by the output assembly of every model (ideal and
//! physical, camera, radar and LiDAR).
//!
//! # The rules every `SensorData` follows
//!
//! 1. **Detections refer to detected objects.** `feature_data.*_sensor[].detection[].object_id` is
//!    the `header.tracking_id` of the detected object (moving or stationary, in the same
//!    `SensorData`) the model associated the detection with, and is left unset when the detection
//!    belongs to no reported object (OSI 3.8.0 `RadarDetection.object_id`: "ID of the detected
//!    object this detection is associated to"). Per model:
//!    * ideal: `tracking_id` = ground-truth id, and every detection comes from a reported body;
//!    * physical LiDAR / radar: the recognition's own association (point or detection → cluster →
//!      track, [`crate::recognition::lidar::LidarRecognition::detection_objects`]), set only when
//!      the track is reported in that cycle *and* was updated with that cluster (a coasting track
//!      has no detections; a tentative track is not reported);
//!    * physical camera: one detection per recognised object; the camera has no tracker, its
//!      `tracking_id` is the ground-truth id.
//!
//!    Ground-truth ids live in the detected objects' `header.ground_truth_id`. The ground-truth
//!    object of every single detection stays available in the perception extension, index for
//!    index: `RadarPeak.object_id`, `LidarPerception.object_id`, `CameraObject.object_id`.
//! 2. **Moving vs stationary follows the ground-truth kind** ([`split_by_truth`]). A detected
//!    object whose ground-truth object is a `StationaryObject` (guardrail, corner reflector, board,
//!    cone, …) is reported in `stationary_object` as a `DetectedStationaryObject` — header,
//!    `base` (position, dimension, orientation) and one candidate with probability 1 whose
//!    `StationaryObject.Classification` (type, material, density, colour) is copied from the ground
//!    truth ([`stationary_candidate`]). A detected object whose ground truth is a traffic sign,
//!    traffic-light bulb or road marking (a LiDAR cluster or radar track of a sign plate and its
//!    post) is stationary likewise, with a `TYPE_OTHER` candidate, metal for signs and signal
//!    heads ([`traffic_control_candidate`]). A ground-truth `MovingObject` stays a moving object whatever
//!    its speed (OSI: `moving_object` is about the kind of object, not its motion; a standing
//!    pedestrian is a moving object with movement state STATIONARY). A detected object without any
//!    ground truth (a false alarm) stays a moving object. The physical recognitions have no
//!    classifier for stationary structure: the kind and classification of their stationary objects
//!    come from the ground-truth bookkeeping (an idealisation; their position, size and tracking are
//!    the recognition's own). For a physical track that is coasting (no ground-truth id in its
//!    header this cycle) the ground truth of its last update decides, so a track does not jump
//!    between the lists.
//! 3. **Pedestrian poses** ([`pedestrian_poses`]). Every `CandidateMovingObject` of type PEDESTRIAN
//!    carries `head_pose` and `upper_body_pose`, expressed as OSI 3.8.0 defines them: orientations
//!    **relative to the host vehicle frame** (not the sensor frame of the object's `base`), x
//!    anterior (viewing / ventral direction), y left, z up. Source, in this order:
//!    * the ground truth's `pedestrian_attributes` of the detected object's ground-truth object:
//!      `head_pose` from the `TYPE_HEAD` bone, `upper_body_pose` from the `TYPE_UPPER_SPINE` bone
//!      (bones marked `missing` or without orientation are skipped). OSI gives bone orientations
//!      relative to the skeleton root; osiris reads the root frame as the pedestrian's body frame
//!      (`base.orientation`, origin shifted by `bbcenter_to_root`) and a bone orientation as that of
//!      an anatomical frame (x anterior, y left, z along the bone towards its far end), so an
//!      upright bone of a pedestrian facing forward has the identity orientation. Pose in the host
//!      frame: `R_host_globalᵀ · R_body_global · R_bone`;
//!    * else the detected object's body orientation (its `base.orientation`, rotated from the
//!      sensor into the host frame: `R_mount · R_sensor`) for both.
//!
//!    The physical recognitions do not estimate head or torso orientation: when their object has
//!    a pedestrian ground truth with a skeleton, the poses are the ground truth's (idealisation).
//! 4. **Camera boxes** ([`box_corners`]): `IMAGE_SHAPE_TYPE_BOX` detections carry **2** points,
//!    OSI's "first and third corner, box aligned horizontal resp. vertical": the smallest
//!    azimuth–elevation box containing the object's image (first = top-left = largest azimuth and
//!    elevation, second = bottom-right = smallest). No 3-point (oriented) form: an image box of an
//!    object is axis-aligned.

use std::collections::HashMap;

use glam::{DMat3, DVec3};
use osiris_proto::osi3;

use crate::frames::{
    Pose, SensorFrame, Spherical, rotation_from_osi, rpy_from_rotation, rpy_to_osi, wrap_angle,
};

/// A ground-truth object by id.
#[derive(Debug, Clone, Copy)]
pub enum TruthRef<'a> {
    Moving(&'a osi3::MovingObject),
    Stationary(&'a osi3::StationaryObject),
    /// A traffic sign, traffic-light bulb or road marking (stationary ground truth outside
    /// `stationary_object`).
    TrafficControl(TrafficControlKind),
}

/// What kind of traffic-control entity a ground-truth id names.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TrafficControlKind {
    Sign,
    Light,
    Marking,
}

/// Ground-truth objects by id.
#[derive(Debug, Default)]
pub struct TruthIndex<'a> {
    by_id: HashMap<u64, TruthRef<'a>>,
}

impl<'a> TruthIndex<'a> {
    /// Index of every moving and stationary object of `gt` that has an id.
    pub fn new(gt: &'a osi3::GroundTruth) -> TruthIndex<'a> {
        let mut by_id = HashMap::with_capacity(gt.moving_object.len() + gt.stationary_object.len());
        for o in &gt.moving_object {
            if let Some(v) = o.id.and_then(|i| i.value) {
                by_id.insert(v, TruthRef::Moving(o));
            }
        }
        for o in &gt.stationary_object {
            if let Some(v) = o.id.and_then(|i| i.value) {
                by_id.insert(v, TruthRef::Stationary(o));
            }
        }
        let traffic = [
            (
                TrafficControlKind::Sign,
                gt.traffic_sign.iter().map(|t| t.id).collect::<Vec<_>>(),
            ),
            (
                TrafficControlKind::Light,
                gt.traffic_light.iter().map(|t| t.id).collect(),
            ),
            (
                TrafficControlKind::Marking,
                gt.road_marking.iter().map(|t| t.id).collect(),
            ),
        ];
        for (kind, ids) in traffic {
            for v in ids.into_iter().filter_map(|i| i.and_then(|i| i.value)) {
                by_id.entry(v).or_insert(TruthRef::TrafficControl(kind));
            }
        }
        TruthIndex { by_id }
    }

    pub fn get(&self, id: u64) -> Option<TruthRef<'a>> {
        self.by_id.get(&id).copied()
    }

    /// Whether `id` is stationary ground truth (a stationary object or a traffic-control entity).
    pub fn is_stationary(&self, id: u64) -> bool {
        matches!(
            self.get(id),
            Some(TruthRef::Stationary(_) | TruthRef::TrafficControl(_))
        )
    }
}

/// The rotations the pedestrian poses need: sensor → host vehicle (the mounting) and host vehicle
/// → global.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseFrames {
    /// Sensor → host vehicle rotation (`mounting_position.orientation`).
    pub sensor_to_host: DMat3,
    /// Host vehicle → global rotation.
    pub host_to_global: DMat3,
}

impl PoseFrames {
    /// From the sensor frame (sensor → global) and the mounting (sensor → host):
    /// `R_host→global = R_sensor→global · R_mountᵀ`.
    pub fn new(frame: &SensorFrame, mounting: &osi3::MountingPosition) -> PoseFrames {
        let sensor_to_host = Pose::from_mounting(mounting).rotation;
        PoseFrames {
            sensor_to_host,
            host_to_global: frame.pose.rotation * sensor_to_host.transpose(),
        }
    }
}

/// The orientation (skeleton-root frame) of the first usable bone of type `t`.
fn bone_rotation(
    attrs: &osi3::moving_object::PedestrianAttributes,
    t: osi3::moving_object::pedestrian_attributes::bone::Type,
) -> Option<DMat3> {
    attrs
        .skeleton_bone
        .iter()
        .find(|b| b.r#type == Some(t as i32) && b.missing != Some(true) && b.orientation.is_some())
        .map(|b| rotation_from_osi(b.orientation.as_ref()))
        .filter(|r| r.is_finite())
}

/// `(head_pose, upper_body_pose)` relative to the host vehicle frame (module documentation,
/// rule 3): from `truth`'s `pedestrian_attributes` where it has the bone, else from
/// `body_in_sensor` (the detected object's orientation in the sensor frame).
pub fn pedestrian_poses(
    truth: Option<&osi3::MovingObject>,
    body_in_sensor: &DMat3,
    frames: &PoseFrames,
) -> (osi3::Orientation3d, osi3::Orientation3d) {
    use osi3::moving_object::pedestrian_attributes::bone::Type as Bone;
    let body_host = frames.sensor_to_host * *body_in_sensor;
    let from_bone = |t: Bone| -> Option<DMat3> {
        let obj = truth?;
        let attrs = obj.pedestrian_attributes.as_ref()?;
        let bone = bone_rotation(attrs, t)?;
        let body_global = rotation_from_osi(obj.base.as_ref().and_then(|b| b.orientation.as_ref()));
        Some(frames.host_to_global.transpose() * body_global * bone)
    };
    let osi = |m: DMat3| {
        let [r, p, y] = rpy_from_rotation(&m);
        rpy_to_osi([wrap_angle(r), p, wrap_angle(y)])
    };
    let head = from_bone(Bone::Head).unwrap_or(body_host);
    let upper = from_bone(Bone::UpperSpine).unwrap_or(body_host);
    (osi(head), osi(upper))
}

/// The candidate of a detected stationary object: probability 1, the ground truth's type,
/// material, density and colour.
pub fn stationary_candidate(
    truth: &osi3::StationaryObject,
) -> osi3::detected_stationary_object::CandidateStationaryObject {
    let c = truth.classification.as_ref();
    osi3::detected_stationary_object::CandidateStationaryObject {
        probability: Some(1.0),
        classification: Some(osi3::stationary_object::Classification {
            r#type: Some(
                c.and_then(|c| c.r#type)
                    .unwrap_or(osi3::stationary_object::classification::Type::Unknown as i32),
            ),
            material: c.and_then(|c| c.material),
            density: c.and_then(|c| c.density),
            color: c.and_then(|c| c.color),
            ..Default::default()
        }),
    }
}

/// The candidate of a detected traffic sign or signal head seen as structure by a LiDAR or radar:
/// `TYPE_OTHER` (OSI has no stationary-object type for them), metal, solid; a road marking:
/// `TYPE_OTHER`, other material.
pub fn traffic_control_candidate(
    kind: TrafficControlKind,
) -> osi3::detected_stationary_object::CandidateStationaryObject {
    use osi3::stationary_object::classification::{Density, Material, Type};
    let material = match kind {
        TrafficControlKind::Sign | TrafficControlKind::Light => Material::Metal,
        TrafficControlKind::Marking => Material::Other,
    };
    osi3::detected_stationary_object::CandidateStationaryObject {
        probability: Some(1.0),
        classification: Some(osi3::stationary_object::Classification {
            r#type: Some(Type::Other as i32),
            material: Some(material as i32),
            density: Some(Density::Solid as i32),
            ..Default::default()
        }),
    }
}

/// A detected moving object as a detected stationary object with the candidate `candidate`: the
/// same header, position, dimension and orientation, sensor-specific data. Velocity, movement
/// state and the moving candidates are dropped.
pub fn stationary_from_moving(
    m: osi3::DetectedMovingObject,
    candidate: osi3::detected_stationary_object::CandidateStationaryObject,
) -> osi3::DetectedStationaryObject {
    let base = m.base.map(|b| osi3::BaseStationary {
        dimension: b.dimension,
        position: b.position,
        orientation: b.orientation,
        ..Default::default()
    });
    let base_rmse = m.base_rmse.map(|b| osi3::BaseStationary {
        dimension: b.dimension,
        position: b.position,
        orientation: b.orientation,
        ..Default::default()
    });
    osi3::DetectedStationaryObject {
        header: m.header,
        base,
        base_rmse,
        candidate: vec![candidate],
        color_description: m.color_description,
        radar_specifics: m.radar_specifics,
        lidar_specifics: m.lidar_specifics,
        camera_specifics: m.camera_specifics,
        ultrasonic_specifics: m.ultrasonic_specifics,
    }
}

/// The ground-truth id a detected object stands for: the first of its header's
/// `ground_truth_id`s, else `last_truth(tracking_id)` (a coasting physical track).
fn truth_id_of(
    header: Option<&osi3::DetectedItemHeader>,
    last_truth: &dyn Fn(u64) -> Option<u64>,
) -> Option<u64> {
    let h = header?;
    h.ground_truth_id
        .iter()
        .find_map(|i| i.value)
        .or_else(|| h.tracking_id.and_then(|t| t.value).and_then(last_truth))
}

/// Rule 2 of the module documentation: moves every detected moving object whose ground truth is a
/// stationary object into `sd.stationary_object` (appended, in order). `last_truth` gives the
/// ground truth of a tracking id whose header carries none this cycle.
pub fn split_by_truth(
    sd: &mut osi3::SensorData,
    truth: &TruthIndex<'_>,
    last_truth: &dyn Fn(u64) -> Option<u64>,
) {
    if !sd
        .moving_object
        .iter()
        .any(|m| truth_id_of(m.header.as_ref(), last_truth).is_some_and(|g| truth.is_stationary(g)))
    {
        return;
    }
    let moving = std::mem::take(&mut sd.moving_object);
    for m in moving {
        match truth_id_of(m.header.as_ref(), last_truth).and_then(|g| truth.get(g)) {
            Some(TruthRef::Stationary(s)) => {
                sd.stationary_object
                    .push(stationary_from_moving(m, stationary_candidate(s)));
            }
            Some(TruthRef::TrafficControl(kind)) => {
                sd.stationary_object
                    .push(stationary_from_moving(m, traffic_control_candidate(kind)));
            }
            _ => sd.moving_object.push(m),
        }
    }
}

/// Rule 3 of the module documentation: sets `head_pose` and `upper_body_pose` on every pedestrian
/// candidate of `sd.moving_object`.
pub fn fill_pedestrian_poses(
    sd: &mut osi3::SensorData,
    truth: &TruthIndex<'_>,
    frames: &PoseFrames,
    last_truth: &dyn Fn(u64) -> Option<u64>,
) {
    let ped = osi3::moving_object::Type::Pedestrian as i32;
    for m in &mut sd.moving_object {
        if !m.candidate.iter().any(|c| c.r#type == Some(ped)) {
            continue;
        }
        let gt = match truth_id_of(m.header.as_ref(), last_truth).and_then(|g| truth.get(g)) {
            Some(TruthRef::Moving(o)) => Some(o),
            _ => None,
        };
        let body = rotation_from_osi(m.base.as_ref().and_then(|b| b.orientation.as_ref()));
        let (head, upper) = pedestrian_poses(gt, &body, frames);
        for c in m.candidate.iter_mut().filter(|c| c.r#type == Some(ped)) {
            c.head_pose = Some(head);
            c.upper_body_pose = Some(upper);
        }
    }
}

/// Rules 2 and 3 on a model's `SensorData` ([`split_by_truth`], then [`fill_pedestrian_poses`]).
pub fn complete(
    sd: &mut osi3::SensorData,
    gt: &osi3::GroundTruth,
    frames: &PoseFrames,
    last_truth: &dyn Fn(u64) -> Option<u64>,
) {
    let truth = TruthIndex::new(gt);
    split_by_truth(sd, &truth, last_truth);
    fill_pedestrian_poses(sd, &truth, frames, last_truth);
}

/// Rule 4 of the module documentation: the two corners (first = largest azimuth and elevation,
/// second = smallest) of the smallest azimuth–elevation box containing `directions` (sensor frame,
/// any length), both at `distance_m`. Azimuths are unwrapped around the mean direction, so a box
/// straddling ±π stays small. `None` without a finite, non-zero direction.
pub fn box_corners(
    directions: impl IntoIterator<Item = DVec3>,
    distance_m: f64,
) -> Option<[Spherical; 2]> {
    let dirs: Vec<DVec3> = directions
        .into_iter()
        .filter(|d| d.is_finite() && d.length_squared() > 0.0)
        .map(DVec3::normalize)
        .collect();
    let mean = dirs.iter().copied().sum::<DVec3>();
    let first = *dirs.first()?;
    let az0 = if mean.truncate().length_squared() > 1e-24 {
        mean.y.atan2(mean.x)
    } else {
        first.y.atan2(first.x)
    };
    let (mut az_lo, mut az_hi) = (f64::INFINITY, f64::NEG_INFINITY);
    let (mut el_lo, mut el_hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for d in &dirs {
        let s = Spherical::from_cartesian(*d);
        let a = az0 + wrap_angle(s.azimuth - az0);
        az_lo = az_lo.min(a);
        az_hi = az_hi.max(a);
        el_lo = el_lo.min(s.elevation);
        el_hi = el_hi.max(s.elevation);
    }
    let corner = |az: f64, el: f64| Spherical {
        distance: distance_m,
        azimuth: wrap_angle(az),
        elevation: el,
    };
    Some([corner(az_hi, el_hi), corner(az_lo, el_lo)])
}

/// The tracking ids of `sd`'s detected objects (moving and stationary).
fn tracking_ids(sd: &osi3::SensorData) -> std::collections::HashSet<u64> {
    sd.moving_object
        .iter()
        .map(|m| m.header.as_ref())
        .chain(sd.stationary_object.iter().map(|s| s.header.as_ref()))
        .filter_map(|h| h.and_then(|h| h.tracking_id).and_then(|i| i.value))
        .collect()
}

/// Every violation of the rules above in `sd` (empty: the message follows them). With `gt`, also
/// checks that no moving object names a stationary ground-truth object. Used by the tests of every
/// model; cheap.
pub fn violations(sd: &osi3::SensorData, gt: Option<&osi3::GroundTruth>) -> Vec<String> {
    let mut out = Vec::new();
    let ids = tracking_ids(sd);
    let check_id = |out: &mut Vec<String>, what: &str, k: usize, oid: Option<osi3::Identifier>| {
        if let Some(i) = oid {
            match i.value {
                Some(v) if ids.contains(&v) => {}
                v => out.push(format!(
                    "{what}[{k}].object_id = {v:?} names no detected object (tracking ids {ids:?})"
                )),
            }
        }
    };
    if let Some(fd) = sd.feature_data.as_ref() {
        for r in &fd.radar_sensor {
            for (k, d) in r.detection.iter().enumerate() {
                check_id(&mut out, "radar detection", k, d.object_id);
            }
        }
        for l in &fd.lidar_sensor {
            for (k, d) in l.detection.iter().enumerate() {
                check_id(&mut out, "lidar detection", k, d.object_id);
            }
        }
        for c in &fd.camera_sensor {
            for (k, d) in c.detection.iter().enumerate() {
                check_id(&mut out, "camera detection", k, d.object_id);
            }
            let box_type = osi3::camera_detection::ImageShapeType::Box as i32;
            for (k, d) in c.detection.iter().enumerate() {
                if d.image_shape_type == Some(box_type)
                    && !matches!(d.number_of_points, Some(2 | 3))
                {
                    out.push(format!(
                        "camera detection[{k}] is a box with {:?} points (OSI: 2 or 3)",
                        d.number_of_points
                    ));
                }
                let first = d.first_point_index.unwrap_or(0) as usize;
                let n = d.number_of_points.unwrap_or(0) as usize;
                if first + n > c.point.len() {
                    out.push(format!(
                        "camera detection[{k}] refers to points {first}..{} of {}",
                        first + n,
                        c.point.len()
                    ));
                }
            }
        }
    }
    let ped = osi3::moving_object::Type::Pedestrian as i32;
    for (k, m) in sd.moving_object.iter().enumerate() {
        for c in &m.candidate {
            if c.r#type == Some(ped) && (c.head_pose.is_none() || c.upper_body_pose.is_none()) {
                out.push(format!(
                    "moving_object[{k}]: pedestrian candidate without head_pose / upper_body_pose"
                ));
            }
        }
    }
    if let Some(gt) = gt {
        let truth = TruthIndex::new(gt);
        for (k, m) in sd.moving_object.iter().enumerate() {
            for g in m.header.iter().flat_map(|h| &h.ground_truth_id) {
                if g.value.is_some_and(|v| truth.is_stationary(v)) {
                    out.push(format!(
                        "moving_object[{k}] has the stationary ground truth {:?}",
                        g.value
                    ));
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frames::rotation_from_rpy;

    #[test]
    fn box_corners_straddling_the_back() {
        // Directions at azimuth ±170°: the box spans 20°, not 340°.
        let d = |az: f64, el: f64| {
            Spherical {
                distance: 1.0,
                azimuth: az.to_radians(),
                elevation: el.to_radians(),
            }
            .to_cartesian()
        };
        let [a, b] = box_corners([d(170.0, 1.0), d(-170.0, -2.0)], 5.0).unwrap();
        assert!((a.azimuth.to_degrees() - -170.0).abs() < 1e-9, "{a:?}");
        assert!((b.azimuth.to_degrees() - 170.0).abs() < 1e-9, "{b:?}");
        assert!((a.elevation.to_degrees() - 1.0).abs() < 1e-9);
        assert!((b.elevation.to_degrees() + 2.0).abs() < 1e-9);
        assert_eq!((a.distance, b.distance), (5.0, 5.0));
        assert!(box_corners([DVec3::ZERO], 1.0).is_none());
    }

    #[test]
    fn body_pose_fallback_is_the_host_relative_orientation() {
        // Sensor yawed 90° left on the host; an object facing the sensor's +x faces the host's +y.
        let frames = PoseFrames {
            sensor_to_host: rotation_from_rpy(0.0, 0.0, std::f64::consts::FRAC_PI_2),
            host_to_global: rotation_from_rpy(0.0, 0.0, 0.3),
        };
        let (h, u) = pedestrian_poses(None, &DMat3::IDENTITY, &frames);
        assert!((h.yaw.unwrap() - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert_eq!(h, u);
    }
}
