//! Recognition: from a sensor's raw perception output (LiDAR points, radar detections) to
//! detected objects (OSI `DetectedMovingObject`s), with tracking across steps.
//!
//! * [`lidar`]: ground segmentation (RANSAC plane), Euclidean clustering, oriented boxes,
//!   classification, tracking.
//! * [`radar`]: DBSCAN clustering, ego-motion compensation, ghost rejection, tracking.
//! * [`free_space`]: occupancy grid and free-space boundary from the radar's detections.
//! * [`radar_stats`]: ghost statistics of a radar run against the ground truth.
//! * [`tracking`]: Kalman-filter multi-object tracker shared by both.
//! * [`common`]: object classes and the OSI output of a track.

pub mod camera;
pub mod common;
pub mod ego_motion;
pub mod free_space;
pub mod lidar;
pub mod radar;
pub mod radar_stats;
pub mod tracking;
pub mod traffic;

use glam::DVec3;

use crate::frames::Pose;

/// The ground truth a track had at its last update, from a recogniser's reported
/// `(tracking id, ground truth)` pairs (`LidarRecognition::reported_ground_truth`,
/// `RadarRecognition::reported_ground_truth`): what the OSI semantics need for a coasting track.
pub fn last_truth_of(reported: &[(u64, Option<u64>)], tracking_id: u64) -> Option<u64> {
    reported
        .iter()
        .find(|r| r.0 == tracking_id)
        .and_then(|r| r.1)
}

/// The sensor's motion at the measurement time, for ego-motion compensation and for tracking in a
/// fixed frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EgoState {
    /// Measurement time, s.
    pub time_s: f64,
    /// Sensor frame → a fixed (non-moving) frame, e.g. the global or the scene frame.
    pub sensor_pose: Pose,
    /// Velocity of the sensor origin in the fixed frame, m/s.
    pub sensor_velocity_m_s: DVec3,
    /// Angular velocity of the sensor frame in the fixed frame, rad/s.
    pub sensor_angular_velocity_rad_s: DVec3,
}

/// One LiDAR point as recognition sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LidarPoint {
    /// Position in the sensor frame, m.
    pub position_m: DVec3,
    /// Intensity on the sensor's scale.
    pub intensity: f32,
    /// Range rate (FMCW LiDAR: the Doppler of the point), m/s, positive receding; `None` for a
    /// pulsed LiDAR.
    pub range_rate_m_s: Option<f32>,
    /// Ground-truth object of the point (simulation bookkeeping, only copied into
    /// `ground_truth_id`; never used by the algorithms). `osiris_proto::INVALID_ID` = none.
    pub object_id: u64,
}

/// One radar detection as recognition sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RadarDetection {
    /// Range, m.
    pub range_m: f64,
    /// Azimuth in the sensor frame (about +z from +x), rad.
    pub azimuth_rad: f64,
    /// Elevation (positive up), rad.
    pub elevation_rad: f64,
    /// Range rate, m/s, positive away from the sensor.
    pub range_rate_m_s: f64,
    /// Signal-to-noise ratio, dB.
    pub snr_db: f64,
    /// Radar cross-section estimate, dBsm.
    pub rcs_dbsm: f64,
    /// Ground-truth object (bookkeeping only, as for [`LidarPoint::object_id`]).
    pub object_id: u64,
}
