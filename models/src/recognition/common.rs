//! Pieces shared by the LiDAR and radar recognition: object classes and the OSI output of a track.

use glam::{DMat3, DVec3};
use osiris_proto::{id, osi3};

use super::EgoState;
use crate::frames::{rpy_from_rotation, rpy_to_osi, vec3_to_osi};

/// Object classes of the rule-based classifiers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ObjectClass {
    Car,
    Truck,
    Pedestrian,
    Bicycle,
    Unknown,
}

impl ObjectClass {
    /// All classes, in the order of the probability arrays.
    pub const ALL: [ObjectClass; 5] = [
        ObjectClass::Car,
        ObjectClass::Truck,
        ObjectClass::Pedestrian,
        ObjectClass::Bicycle,
        ObjectClass::Unknown,
    ];

    /// Typical (length, width, height), m. Rounded typical values: European mid-size car
    /// 4.5 × 1.8 × 1.5, heavy truck 10 × 2.5 × 3.5, adult pedestrian 0.6 × 0.6 × 1.75, bicycle with
    /// rider 1.8 × 0.6 × 1.7 (guessed round numbers, not a cited standard; Unknown: 1 m cube).
    pub fn typical_size_m(self) -> [f64; 3] {
        match self {
            ObjectClass::Car => [4.5, 1.8, 1.5],
            ObjectClass::Truck => [10.0, 2.5, 3.5],
            ObjectClass::Pedestrian => [0.6, 0.6, 1.75],
            ObjectClass::Bicycle => [1.8, 0.6, 1.7],
            ObjectClass::Unknown => [1.0, 1.0, 1.0],
        }
    }

    /// Whether an extent below the typical size means that part of the object is hidden (vehicles
    /// seen from one side): the box is then extended to the typical size.
    pub fn extend_to_typical(self) -> bool {
        matches!(
            self,
            ObjectClass::Car | ObjectClass::Truck | ObjectClass::Bicycle
        )
    }

    /// The OSI candidate of this class with probability `p`.
    pub fn candidate(self, p: f64) -> osi3::detected_moving_object::CandidateMovingObject {
        use osi3::moving_object::Type;
        use osi3::moving_object::vehicle_classification::Type as V;
        let vehicle = |v: V| {
            Some(osi3::moving_object::VehicleClassification {
                r#type: Some(v as i32),
                ..Default::default()
            })
        };
        let (t, vc) = match self {
            ObjectClass::Car => (Type::Vehicle, vehicle(V::Car)),
            ObjectClass::Truck => (Type::Vehicle, vehicle(V::HeavyTruck)),
            ObjectClass::Bicycle => (Type::Vehicle, vehicle(V::Bicycle)),
            ObjectClass::Pedestrian => (Type::Pedestrian, None),
            ObjectClass::Unknown => (Type::Unknown, None),
        };
        osi3::detected_moving_object::CandidateMovingObject {
            probability: Some(p),
            r#type: Some(t as i32),
            vehicle_classification: vc,
            ..Default::default()
        }
    }
}

/// Speed (fixed frame) above which a track counts as moving, m/s (guessed; above the velocity
/// noise of a converged track).
pub const MOVING_SPEED_M_S: f64 = 0.5;

/// What a recognition reports for one track (fixed frame).
pub(crate) struct Report<'a> {
    pub centre_m: DVec3,
    pub yaw_rad: f64,
    /// (length, width, height), m.
    pub size_m: [f64; 3],
    pub velocity_m_s: DVec3,
    pub track_id: u64,
    pub ground_truth_id: Option<u64>,
    pub existence: f64,
    pub age_s: f64,
    pub measured: bool,
    pub movement: osi3::detected_moving_object::MovementState,
    /// Class probabilities in [`ObjectClass::ALL`] order.
    pub class_probabilities: &'a [f64; 5],
    pub rcs_dbsm: Option<f64>,
}

/// The OSI detected object of a report, in the sensor frame like the ideal model: box centre,
/// orientation relative to the sensor, velocity relative to the sensor
/// `R_sᵀ·(v − v_s − ω_s × (p − s))`, reference point CENTER.
pub(crate) fn detected_object(ego: &EgoState, r: &Report<'_>) -> osi3::DetectedMovingObject {
    use osi3::detected_item_header::MeasurementState;
    use osi3::detected_moving_object::ReferencePoint;
    let pose = &ego.sensor_pose;
    let position = pose.inverse_transform_point(r.centre_m);
    let rot = pose.rotation.transpose() * DMat3::from_rotation_z(r.yaw_rad);
    let rel_v = r.velocity_m_s
        - ego.sensor_velocity_m_s
        - ego
            .sensor_angular_velocity_rad_s
            .cross(r.centre_m - pose.position);
    let velocity = pose.inverse_transform_vector(rel_v);
    let mut order: [usize; 5] = [0, 1, 2, 3, 4];
    order.sort_by(|&a, &b| r.class_probabilities[b].total_cmp(&r.class_probabilities[a]));
    let candidate = order
        .iter()
        .filter(|&&k| r.class_probabilities[k] >= 0.01)
        .map(|&k| ObjectClass::ALL[k].candidate(r.class_probabilities[k]))
        .collect();
    osi3::DetectedMovingObject {
        header: Some(osi3::DetectedItemHeader {
            tracking_id: Some(id(r.track_id)),
            ground_truth_id: r.ground_truth_id.map(id).into_iter().collect(),
            existence_probability: Some(r.existence),
            age: Some(r.age_s.max(0.0)),
            measurement_state: Some(if r.measured {
                MeasurementState::Measured as i32
            } else {
                MeasurementState::Predicted as i32
            }),
            sensor_id: Vec::new(),
        }),
        base: Some(osi3::BaseMoving {
            dimension: Some(osi3::Dimension3d {
                length: Some(r.size_m[0]),
                width: Some(r.size_m[1]),
                height: Some(r.size_m[2]),
            }),
            position: Some(vec3_to_osi(position)),
            orientation: Some(rpy_to_osi(rpy_from_rotation(&rot))),
            velocity: Some(vec3_to_osi(velocity)),
            ..Default::default()
        }),
        reference_point: Some(ReferencePoint::Center as i32),
        movement_state: Some(r.movement as i32),
        candidate,
        radar_specifics: r
            .rcs_dbsm
            .map(|rcs| osi3::RadarSpecificObjectData { rcs: Some(rcs) }),
        ..Default::default()
    }
}

/// The most frequent id in `ids` other than `INVALID_ID` (sorts `ids`).
pub(crate) fn most_frequent_id(ids: &mut [u64]) -> Option<u64> {
    ids.sort_unstable();
    let mut best: Option<(u64, usize)> = None;
    let mut i = 0;
    while i < ids.len() {
        let v = ids[i];
        let mut j = i;
        while j < ids.len() && ids[j] == v {
            j += 1;
        }
        if v != osiris_proto::INVALID_ID && best.is_none_or(|(_, n)| j - i > n) {
            best = Some((v, j - i));
        }
        i = j;
    }
    best.map(|(v, _)| v)
}

/// Movement state of a track from its speed and whether it has moved before.
pub(crate) fn movement_state(
    speed_m_s: f64,
    has_moved: &mut bool,
) -> osi3::detected_moving_object::MovementState {
    use osi3::detected_moving_object::MovementState;
    if speed_m_s > MOVING_SPEED_M_S {
        *has_moved = true;
        MovementState::Moving
    } else if *has_moved {
        MovementState::Stopped
    } else {
        MovementState::Stationary
    }
}

/// Largest discrepancy between the sensor's new position and the one its velocity predicts
/// before the fixed frame counts as re-based, m (guessed: far above the one-cycle integration
/// error of a vehicle's velocity, far below the scene's origin grid).
pub const FRAME_JUMP_THRESHOLD_M: f64 = 2.0;

/// Detects a re-based fixed frame (the scene frame moves its origin when the host drives far,
/// see [`crate::environment::scene`]): the sensor position jumps by more than its velocity
/// explains. Tracks are then shifted by the unexplained displacement so that they stay valid.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct FrameJump {
    last: Option<(f64, DVec3, DVec3)>,
}

impl FrameJump {
    /// The displacement to add to fixed-frame track positions, if the frame was re-based.
    pub fn check(&mut self, ego: &EgoState) -> Option<DVec3> {
        let now = (
            ego.time_s,
            ego.sensor_pose.position,
            ego.sensor_velocity_m_s,
        );
        let last = self.last.replace(now);
        let (t0, p0, v0) = last?;
        let dt = ego.time_s - t0;
        if !(dt.is_finite() && dt >= 0.0) {
            return None;
        }
        let expected = p0 + 0.5 * (v0 + ego.sensor_velocity_m_s) * dt;
        let jump = ego.sensor_pose.position - expected;
        (jump.is_finite() && jump.length() > FRAME_JUMP_THRESHOLD_M).then_some(jump)
    }

    pub fn reset(&mut self) {
        self.last = None;
    }
}
