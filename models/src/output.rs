//! What every model's output of one cycle carries besides its technology's content, filled in one
//! place for the ideal and the physical models alike: the SensorData and PerceptionData headers
//! (version, measurement time, sensor id, mounting, host vehicle location, cycle counter, model
//! mode, the header of every detection list), the OSI 3.8.0 semantics of `crate::semantics`
//! (detections → detected objects, moving vs stationary ground truth, pedestrian poses) and, when
//! configured, the copy of the input SensorView. The FMU shell publishes what comes out; it fills
//! nothing itself.

use osiris_proto::{interface_version, osi3};

use crate::semantics::PoseFrames;
use crate::sensor::{CommonConfig, ModelMode, StepOutput};
use crate::world::{ViewFrame, WorldFrame};

/// The header values of one cycle, resolved once from the SensorView (`crate::world::ViewFrame`):
/// measurement time = the SensorView's timestamp, else its ground truth's, else the communication
/// point; sensor id = the SensorView's, else the granted one; mounting = the SensorView's, else the
/// configured one.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameHeader {
    pub timestamp: osi3::Timestamp,
    pub sensor_id: Option<osi3::Identifier>,
    pub mounting: osi3::MountingPosition,
    pub host_base: Option<osi3::BaseMoving>,
    /// Cycles completed before this one (`cycle_counter`).
    pub cycle: u64,
    pub mode: ModelMode,
}

impl FrameHeader {
    /// The header of a physical model's step.
    pub fn of_world(frame: &WorldFrame<'_>, cycle: u64) -> FrameHeader {
        FrameHeader {
            timestamp: frame.timestamp,
            sensor_id: frame.sensor_id,
            mounting: frame.mounting,
            host_base: frame.host_base.clone(),
            cycle,
            mode: ModelMode::Physical,
        }
    }

    /// The header of a step on a resolved view (`granted_sensor_id`: the handshake's).
    pub fn of_view(
        view: &osi3::SensorView,
        frame: &ViewFrame<'_>,
        granted_sensor_id: Option<u64>,
        cycle: u64,
        mode: ModelMode,
    ) -> FrameHeader {
        FrameHeader {
            timestamp: frame.timestamp,
            sensor_id: frame.sensor_id(view, granted_sensor_id),
            mounting: frame.mounting,
            host_base: frame.host.and_then(|h| h.base.clone()),
            cycle,
            mode,
        }
    }

    /// Fill every header field of `out`: SensorData `version`, `timestamp`, `sensor_id`,
    /// `mounting_position`, `host_vehicle_location`, `last_measurement_time`, the moving- and
    /// stationary-object headers; FeatureData `version` and the `header` of every detection list
    /// (measurement time, cycle counter, mounting, sensor id, `number_of_valid_detections` = the
    /// list's length; a camera list's `number_of_valid_points`); PerceptionData `osi_version`,
    /// `extension_version`, `timestamp`, `sensor_id`, `mounting_position`, `model_mode`,
    /// `cycle_counter`.
    pub fn fill(&self, out: &mut StepOutput) {
        let sd = &mut out.sensor_data;
        sd.version = Some(interface_version());
        sd.timestamp = Some(self.timestamp);
        sd.sensor_id = self.sensor_id;
        sd.mounting_position = Some(self.mounting);
        sd.host_vehicle_location = self.host_base.clone();
        sd.last_measurement_time = Some(self.timestamp);
        let entity_header = osi3::DetectedEntityHeader {
            measurement_time: Some(self.timestamp),
            cycle_counter: Some(self.cycle),
            data_qualifier: Some(osi3::detected_entity_header::DataQualifier::Available as i32),
        };
        sd.moving_object_header = Some(entity_header);
        sd.stationary_object_header = Some(entity_header);
        // Traffic lights, signs, road markings and lane boundaries: reported by the physical camera
        // only (`crate::recognition::traffic`); every other output carries no header for them.
        let traffic = (self.mode == ModelMode::Physical && out.perception.camera.is_some())
            .then_some(entity_header);
        sd.traffic_light_header = traffic;
        sd.traffic_sign_header = traffic;
        sd.road_marking_header = traffic;
        sd.lane_boundary_header = traffic;
        if let Some(fd) = sd.feature_data.as_mut() {
            fd.version = Some(interface_version());
            for d in &mut fd.radar_sensor {
                d.header = Some(self.detection_header(d.detection.len()));
            }
            for d in &mut fd.lidar_sensor {
                d.header = Some(self.detection_header(d.detection.len()));
            }
            for d in &mut fd.ultrasonic_sensor {
                d.header = Some(self.detection_header(d.detection.len()));
            }
            for d in &mut fd.camera_sensor {
                d.header = Some(self.detection_header(d.detection.len()));
                d.specific_header = Some(osi3::CameraDetectionSpecificHeader {
                    number_of_valid_points: Some(u32::try_from(d.point.len()).unwrap_or(u32::MAX)),
                });
            }
        }
        let p = &mut out.perception;
        p.osi_version = Some(interface_version());
        p.extension_version = Some(osiris_proto::PERCEPTION_EXTENSION_VERSION.to_string());
        p.timestamp = Some(self.timestamp);
        p.sensor_id = self.sensor_id;
        p.mounting_position = Some(self.mounting);
        p.model_mode = Some(self.mode.name().to_string());
        p.cycle_counter = Some(self.cycle);
    }

    /// The `SensorDetectionHeader` of a detection list of `detections` entries.
    pub fn detection_header(&self, detections: usize) -> osi3::SensorDetectionHeader {
        osi3::SensorDetectionHeader {
            measurement_time: Some(self.timestamp),
            cycle_counter: Some(self.cycle),
            mounting_position: Some(self.mounting),
            data_qualifier: Some(osi3::sensor_detection_header::DataQualifier::Available as i32),
            number_of_valid_detections: Some(u32::try_from(detections).unwrap_or(u32::MAX)),
            sensor_id: self.sensor_id,
            ..Default::default()
        }
    }
}

/// Finish a step's output after the model filled its technology's content: the headers
/// ([`FrameHeader::fill`]), the OSI semantics against the ground truth (`crate::semantics::complete`;
/// `last_truth_of`: the ground truth of a coasting track, by tracking id)
/// and, with `include_sensor_view`, the input SensorView in `SensorData.sensor_view`.
pub fn finish(
    out: &mut StepOutput,
    header: &FrameHeader,
    view: &osi3::SensorView,
    config: &CommonConfig,
    poses: &PoseFrames,
    last_truth_of: &dyn Fn(u64) -> Option<u64>,
) {
    header.fill(out);
    if let Some(gt) = view.global_ground_truth.as_ref() {
        crate::semantics::complete(&mut out.sensor_data, gt, poses, last_truth_of);
    }
    out.sensor_data.sensor_view.clear();
    if config.include_sensor_view {
        out.sensor_data.sensor_view.push(view.clone());
    }
}
