//! Per-frame KPI rows of a sensor: ground truth in the field of view against the reported detected
//! objects (`objects.csv`), and per-frame counts (`frames.csv`).
//!
//! * Ground truth = the `global_ground_truth` of the SensorView the sensor was given: every moving
//!   object except the host vehicle (`SensorView.host_vehicle_id`, else the ground truth's) and every
//!   stationary object.
//! * Sensor frame = the SensorView's `mounting_position` (else the first technology view's
//!   `view_configuration.mounting_position`) on the host vehicle ([`SensorFrame::new`]).
//! * Field of view = `field_of_view_horizontal` of the first `*_sensor_view[].view_configuration`
//!   (generic, radar, lidar, camera, ultrasonic): an object is in view when the azimuth of its
//!   bounding-box centre is within ± half of it. OSI 3.8.0's technology view configurations carry
//!   no range (only the top-level `SensorViewConfiguration` does), so range is not limited; without
//!   a declared field of view every object is in view.
//! * Detected objects (moving and stationary) are in the sensor frame of `SensorData.mounting_position`
//!   (OSI 3.x: the virtual sensor coordinate system of the SensorData's mounting; this is what the
//!   osiris models write, `models/src/semantics.rs`); they are moved into the SensorView's sensor
//!   frame when the two mountings differ. `base.velocity` is the velocity relative to the sensor, so
//!   the reported range rate is `p·v / |p|`.

use std::collections::HashSet;
use std::fmt::Write as _;

use glam::DVec3;
use osiris_models::frames::{Pose, SensorFrame, vec3_from_osi};
use osiris_proto::osi3;

/// `objects.csv` header.
pub const OBJECTS_HEADER: &str = "sensor,frame,time_s,gt_id,gt_type,gt_range_m,gt_azimuth_deg,gt_range_rate_mps,detected,tracking_id,det_range_m,range_error_m,det_range_rate_mps,range_rate_error_mps,existence_probability";
/// `frames.csv` header.
pub const FRAMES_HEADER: &str = "sensor,frame,time_s,ground_truth_in_fov,detected_objects,matched_objects,false_alarms,feature_detections,step_wall_ms,traffic_lights,traffic_light_state_errors,traffic_signs,lane_boundaries";

/// A ground-truth object in a sensor's field of view, and what the sensor reported about it.
#[derive(Debug, Clone, PartialEq)]
pub struct ObjectRow {
    pub frame: usize,
    pub time_s: f64,
    pub gt_id: u64,
    /// Lowercase type name (`car`, `truck`, `pedestrian`, …, `pole`, `barrier`, …).
    pub gt_type: String,
    pub gt_range_m: f64,
    pub gt_azimuth_deg: f64,
    pub gt_range_rate_mps: f64,
    /// Ground truth in the sensor frame (m): x forward, y left, z up.
    pub gt_position_m: [f64; 3],
    /// Ground-truth box length, width (m) and yaw relative to the sensor (rad).
    pub gt_box: [f64; 3],
    /// Ground-truth box height, m.
    pub gt_height_m: f64,
    pub detected: Option<DetectedMatch>,
}

/// The detected object that names a ground-truth object.
#[derive(Debug, Clone, PartialEq)]
pub struct DetectedMatch {
    pub tracking_id: Option<u64>,
    pub range_m: Option<f64>,
    pub range_rate_mps: Option<f64>,
    pub existence_probability: Option<f64>,
}

/// Per-frame counts.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameRow {
    pub frame: usize,
    pub time_s: f64,
    /// `None`: no ground truth for this frame.
    pub ground_truth_in_fov: Option<usize>,
    pub detected_objects: usize,
    /// Detected objects naming a ground-truth object present in the SensorView.
    pub matched_objects: Option<usize>,
    /// Detected objects naming no ground-truth object present in the SensorView.
    pub false_alarms: Option<usize>,
    pub feature_detections: usize,
    pub step_wall_ms: Option<f64>,
    /// Detected traffic-light bulbs (`SensorData.traffic_light`).
    pub traffic_lights: usize,
    /// Of those, bulbs whose reported lit/dark state differs from the ground truth's (mode
    /// CONSTANT or COUNTING = lit, OFF = dark; `None`: no ground truth).
    pub traffic_light_state_errors: Option<usize>,
    /// Detected traffic signs.
    pub traffic_signs: usize,
    /// Detected lane boundaries.
    pub lane_boundaries: usize,
}

/// A detected object (moving or stationary) in the SensorView's sensor frame.
#[derive(Debug, Clone, PartialEq)]
pub struct DetectedBox {
    pub tracking_id: Option<u64>,
    pub ground_truth_ids: Vec<u64>,
    pub position_m: Option<[f64; 3]>,
    /// Length, width (m), yaw (rad) in the sensor frame.
    pub size: [f64; 3],
    pub velocity_mps: Option<[f64; 3]>,
    pub existence_probability: Option<f64>,
    pub stationary: bool,
}

/// The sensor frame and field of view a SensorView declares.
#[derive(Debug, Clone, Copy)]
pub struct ViewGeometry {
    pub frame: SensorFrame,
    /// Full horizontal field of view, rad (`None`: not declared).
    pub fov_horizontal_rad: Option<f64>,
    pub host_id: Option<u64>,
    pub mounting: Pose,
}

impl ViewGeometry {
    /// The geometry of `view` (`None`: the view has no ground truth).
    pub fn of(view: &osi3::SensorView) -> Option<ViewGeometry> {
        let gt = view.global_ground_truth.as_ref()?;
        let configs: Vec<(Option<&osi3::MountingPosition>, Option<f64>)> = view
            .generic_sensor_view
            .iter()
            .filter_map(|v| v.view_configuration.as_ref())
            .map(|c| (c.mounting_position.as_ref(), c.field_of_view_horizontal))
            .chain(
                view.radar_sensor_view
                    .iter()
                    .filter_map(|v| v.view_configuration.as_ref())
                    .map(|c| (c.mounting_position.as_ref(), c.field_of_view_horizontal)),
            )
            .chain(
                view.lidar_sensor_view
                    .iter()
                    .filter_map(|v| v.view_configuration.as_ref())
                    .map(|c| (c.mounting_position.as_ref(), c.field_of_view_horizontal)),
            )
            .chain(
                view.camera_sensor_view
                    .iter()
                    .filter_map(|v| v.view_configuration.as_ref())
                    .map(|c| (c.mounting_position.as_ref(), c.field_of_view_horizontal)),
            )
            .chain(
                view.ultrasonic_sensor_view
                    .iter()
                    .filter_map(|v| v.view_configuration.as_ref())
                    .map(|c| (c.mounting_position.as_ref(), c.field_of_view_horizontal)),
            )
            .collect();
        let mounting = view
            .mounting_position
            .or_else(|| configs.iter().find_map(|(m, _)| m.copied()))
            .unwrap_or_default();
        let fov = configs
            .iter()
            .find_map(|(_, f)| *f)
            .filter(|f| f.is_finite() && *f > 0.0);
        let host_id = view
            .host_vehicle_id
            .or(gt.host_vehicle_id)
            .and_then(|i| i.value);
        let host = host_id.and_then(|h| {
            gt.moving_object
                .iter()
                .find(|o| o.id.and_then(|i| i.value) == Some(h))
        });
        Some(ViewGeometry {
            frame: SensorFrame::new(host, &mounting),
            fov_horizontal_rad: fov,
            host_id,
            mounting: Pose::from_mounting(&mounting),
        })
    }

    /// Whether a point in the sensor frame is inside the declared horizontal field of view.
    pub fn in_fov(&self, p_sensor: DVec3) -> bool {
        match self.fov_horizontal_rad {
            Some(fov) => p_sensor.y.atan2(p_sensor.x).abs() <= 0.5 * fov + 1e-12,
            None => true,
        }
    }
}

/// Lowercase name of a moving object's type (vehicles: their classification).
pub fn moving_type_name(o: &osi3::MovingObject) -> String {
    use osi3::moving_object::Type;
    match o.r#type() {
        Type::Vehicle => {
            let t = o
                .vehicle_classification
                .as_ref()
                .map(|c| c.r#type())
                .unwrap_or_default();
            use osi3::moving_object::vehicle_classification::Type as V;
            match t {
                V::SmallCar | V::CompactCar | V::Car | V::LuxuryCar => "car".to_owned(),
                V::HeavyTruck | V::Semitractor => "truck".to_owned(),
                V::DeliveryVan => "van".to_owned(),
                V::Motorbike => "motorcycle".to_owned(),
                V::Unknown => "vehicle".to_owned(),
                other => enum_name(other.as_str_name()),
            }
        }
        other => enum_name(other.as_str_name()),
    }
}

/// Lowercase name of a stationary object's type.
pub fn stationary_type_name(o: &osi3::StationaryObject) -> String {
    let t = o
        .classification
        .as_ref()
        .map(|c| c.r#type())
        .unwrap_or_default();
    enum_name(t.as_str_name())
}

fn enum_name(s: &str) -> String {
    s.strip_prefix("TYPE_").unwrap_or(s).to_ascii_lowercase()
}

/// The detected objects of `sd` in the sensor frame of `view_mounting` (the SensorView's mounting
/// relative to the host vehicle; `None`: keep the SensorData's own sensor frame).
pub fn detected_boxes(sd: &osi3::SensorData, view_mounting: Option<&Pose>) -> Vec<DetectedBox> {
    let sd_mounting = sd.mounting_position.as_ref().map(Pose::from_mounting);
    // SensorData sensor frame → SensorView sensor frame.
    let to_view = match (sd_mounting, view_mounting) {
        (Some(sd_m), Some(v)) if sd_m != *v => Some(v.inverse().compose(&sd_m)),
        _ => None,
    };
    let convert = |p: DVec3| to_view.map_or(p, |t| t.transform_point(p));
    let rotate = |v: DVec3| to_view.map_or(v, |t| t.transform_vector(v));
    let yaw_offset = to_view.map_or(0.0, |t| t.rotation.x_axis.y.atan2(t.rotation.x_axis.x));
    // One detected object (moving or stationary: the same header and base fields).
    let detected = |h: Option<&osi3::DetectedItemHeader>,
                    position: Option<&osi3::Vector3d>,
                    dim: Option<&osi3::Dimension3d>,
                    orientation: Option<&osi3::Orientation3d>,
                    velocity: Option<&osi3::Vector3d>,
                    stationary: bool| DetectedBox {
        tracking_id: h.and_then(|h| h.tracking_id).and_then(|i| i.value),
        ground_truth_ids: h
            .map(|h| h.ground_truth_id.iter().filter_map(|i| i.value).collect())
            .unwrap_or_default(),
        position_m: position.map(|p| convert(vec3_from_osi(Some(p))).to_array()),
        size: [
            dim.and_then(|d| d.length).unwrap_or(0.0),
            dim.and_then(|d| d.width).unwrap_or(0.0),
            orientation.and_then(|o| o.yaw).unwrap_or(0.0) + yaw_offset,
        ],
        velocity_mps: velocity.map(|v| rotate(vec3_from_osi(Some(v))).to_array()),
        existence_probability: h.and_then(|h| h.existence_probability),
        stationary,
    };
    let moving = sd.moving_object.iter().map(|o| {
        let b = o.base.as_ref();
        detected(
            o.header.as_ref(),
            b.and_then(|b| b.position.as_ref()),
            b.and_then(|b| b.dimension.as_ref()),
            b.and_then(|b| b.orientation.as_ref()),
            b.and_then(|b| b.velocity.as_ref()),
            false,
        )
    });
    let stationary = sd.stationary_object.iter().map(|o| {
        let b = o.base.as_ref();
        // A detected stationary object does not move: its velocity relative to the sensor is
        // not reported.
        detected(
            o.header.as_ref(),
            b.and_then(|b| b.position.as_ref()),
            b.and_then(|b| b.dimension.as_ref()),
            b.and_then(|b| b.orientation.as_ref()),
            None,
            true,
        )
    });
    moving.chain(stationary).collect()
}

/// Number of feature detections (radar, LiDAR, camera, ultrasonic) of `sd`.
pub fn feature_detections(sd: &osi3::SensorData) -> usize {
    sd.feature_data.as_ref().map_or(0, |fd| {
        fd.radar_sensor
            .iter()
            .map(|d| d.detection.len())
            .sum::<usize>()
            + fd.lidar_sensor
                .iter()
                .map(|d| d.detection.len())
                .sum::<usize>()
            + fd.camera_sensor
                .iter()
                .map(|d| d.detection.len())
                .sum::<usize>()
            + fd.ultrasonic_sensor
                .iter()
                .map(|d| d.detection.len())
                .sum::<usize>()
    })
}

/// Detected traffic-light bulbs whose reported state (lit: mode CONSTANT, FLASHING or COUNTING;
/// dark: OFF) differs from their ground truth's (lit: CONSTANT or COUNTING; dark: OFF; bulbs whose
/// ground truth is FLASHING or unknown are not judged).
pub fn traffic_light_state_errors(sd: &osi3::SensorData, gt: &osi3::GroundTruth) -> usize {
    use osi3::traffic_light::classification::Mode;
    let lit = |m: i32| m == Mode::Constant as i32 || m == Mode::Counting as i32;
    sd.traffic_light
        .iter()
        .filter(|d| {
            let Some(gid) = d
                .header
                .as_ref()
                .and_then(|h| h.ground_truth_id.first())
                .and_then(|i| i.value)
            else {
                return false;
            };
            let Some(truth) = gt
                .traffic_light
                .iter()
                .find(|t| t.id.and_then(|i| i.value) == Some(gid))
                .and_then(|t| t.classification.as_ref())
                .and_then(|c| c.mode)
            else {
                return false;
            };
            if !(lit(truth) || truth == Mode::Off as i32) {
                return false;
            }
            let Some(reported) = d
                .candidate
                .first()
                .and_then(|c| c.classification.as_ref())
                .and_then(|c| c.mode)
            else {
                return false;
            };
            (reported != Mode::Off as i32) != lit(truth)
        })
        .count()
}

/// The KPI rows of one SensorData frame: `frame` is the sensor's 0-based SensorData index,
/// `view` the SensorView the sensor was given (`None`: no ground truth).
pub fn frame_rows(
    frame: usize,
    time_s: f64,
    view: Option<&osi3::SensorView>,
    sd: &osi3::SensorData,
    step_wall_ms: Option<f64>,
) -> (FrameRow, Vec<ObjectRow>, Vec<DetectedBox>) {
    let geometry = view.and_then(ViewGeometry::of);
    let boxes = detected_boxes(sd, geometry.as_ref().map(|g| &g.mounting));
    let mut row = FrameRow {
        frame,
        time_s,
        ground_truth_in_fov: None,
        detected_objects: boxes.len(),
        matched_objects: None,
        false_alarms: None,
        feature_detections: feature_detections(sd),
        step_wall_ms,
        traffic_lights: sd.traffic_light.len(),
        traffic_light_state_errors: None,
        traffic_signs: sd.traffic_sign.len(),
        lane_boundaries: sd.lane_boundary.len(),
    };
    if let Some(gt) = view.and_then(|v| v.global_ground_truth.as_ref()) {
        row.traffic_light_state_errors = Some(traffic_light_state_errors(sd, gt));
    }
    let (Some(g), Some(gt)) = (geometry, view.and_then(|v| v.global_ground_truth.as_ref())) else {
        return (row, Vec::new(), boxes);
    };
    let mut present: HashSet<u64> = HashSet::new();
    let mut objects = Vec::new();
    let mut consider =
        |id: u64, kind: String, pose: Pose, v: DVec3, dim: Option<&osi3::Dimension3d>| {
            present.insert(id);
            let p = g.frame.point_to_sensor(pose.position);
            if !g.in_fov(p) {
                return;
            }
            let r_s = g.frame.rotation_to_sensor(&pose.rotation);
            let detected = boxes
                .iter()
                .find(|b| b.ground_truth_ids.contains(&id))
                .map(|b| {
                    let range = b.position_m.map(|p| DVec3::from_array(p).length());
                    let rate = match (b.position_m, b.velocity_mps) {
                        (Some(p), Some(v)) => {
                            let p = DVec3::from_array(p);
                            let n = p.length();
                            Some(if n > 0.0 {
                                p.dot(DVec3::from_array(v)) / n
                            } else {
                                0.0
                            })
                        }
                        _ => None,
                    };
                    DetectedMatch {
                        tracking_id: b.tracking_id,
                        range_m: range,
                        range_rate_mps: rate,
                        existence_probability: b.existence_probability,
                    }
                });
            objects.push(ObjectRow {
                frame,
                time_s,
                gt_id: id,
                gt_type: kind,
                gt_range_m: p.length(),
                gt_azimuth_deg: p.y.atan2(p.x).to_degrees(),
                gt_range_rate_mps: g.frame.range_rate(pose.position, v),
                gt_position_m: p.to_array(),
                gt_box: [
                    dim.and_then(|d| d.length).unwrap_or(0.0),
                    dim.and_then(|d| d.width).unwrap_or(0.0),
                    r_s.x_axis.y.atan2(r_s.x_axis.x),
                ],
                gt_height_m: dim.and_then(|d| d.height).unwrap_or(0.0),
                detected,
            });
        };
    for o in &gt.moving_object {
        let Some(id) = o.id.and_then(|i| i.value) else {
            continue;
        };
        if Some(id) == g.host_id {
            continue;
        }
        let pose = osiris_models::frames::moving_object_pose(o);
        let v = vec3_from_osi(o.base.as_ref().and_then(|b| b.velocity.as_ref()));
        consider(
            id,
            moving_type_name(o),
            pose,
            v,
            o.base.as_ref().and_then(|b| b.dimension.as_ref()),
        );
    }
    for o in &gt.stationary_object {
        let Some(id) = o.id.and_then(|i| i.value) else {
            continue;
        };
        let pose = osiris_models::frames::stationary_object_pose(o);
        consider(
            id,
            stationary_type_name(o),
            pose,
            DVec3::ZERO,
            o.base.as_ref().and_then(|b| b.dimension.as_ref()),
        );
    }
    let matched = boxes
        .iter()
        .filter(|b| b.ground_truth_ids.iter().any(|i| present.contains(i)))
        .count();
    row.ground_truth_in_fov = Some(objects.len());
    row.matched_objects = Some(matched);
    row.false_alarms = Some(boxes.len() - matched);
    (row, objects, boxes)
}

fn opt_f(v: Option<f64>) -> String {
    v.map_or(String::new(), |v| format!("{v:.4}"))
}

fn opt_u<T: std::fmt::Display>(v: Option<T>) -> String {
    v.map_or(String::new(), |v| v.to_string())
}

/// A CSV field: quoted when it holds a comma, quote or line break.
pub fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_owned()
    }
}

/// One `objects.csv` line (with its line break).
pub fn object_line(out: &mut String, sensor: &str, r: &ObjectRow) {
    let d = r.detected.as_ref();
    let det_range = d.and_then(|d| d.range_m);
    let det_rate = d.and_then(|d| d.range_rate_mps);
    let _ = writeln!(
        out,
        "{},{},{:.6},{},{},{:.4},{:.4},{:.4},{},{},{},{},{},{},{}",
        csv_field(sensor),
        r.frame,
        r.time_s,
        r.gt_id,
        csv_field(&r.gt_type),
        r.gt_range_m,
        r.gt_azimuth_deg,
        r.gt_range_rate_mps,
        u8::from(d.is_some()),
        opt_u(d.and_then(|d| d.tracking_id)),
        opt_f(det_range),
        opt_f(det_range.map(|x| x - r.gt_range_m)),
        opt_f(det_rate),
        opt_f(det_rate.map(|x| x - r.gt_range_rate_mps)),
        opt_f(d.and_then(|d| d.existence_probability)),
    );
}

/// One `frames.csv` line (with its line break).
pub fn frame_line(out: &mut String, sensor: &str, r: &FrameRow) {
    let _ = writeln!(
        out,
        "{},{},{:.6},{},{},{},{},{},{},{},{},{},{}",
        csv_field(sensor),
        r.frame,
        r.time_s,
        opt_u(r.ground_truth_in_fov),
        r.detected_objects,
        opt_u(r.matched_objects),
        opt_u(r.false_alarms),
        r.feature_detections,
        r.step_wall_ms.map_or(String::new(), |v| format!("{v:.3}")),
        r.traffic_lights,
        opt_u(r.traffic_light_state_errors),
        r.traffic_signs,
        r.lane_boundaries,
    );
}
