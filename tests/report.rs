//! The KPI tables of `osiris::report` against a closed form: a host vehicle at a known pose, a sensor
//! mounted at a known offset and yaw, a car at a known global position and velocity, a detected
//! object reporting it 0.5 m too far and 0.3 m/s too fast. The expected range, azimuth and range
//! rate are computed here with plain trigonometry (no osiris frame code).

use osiris::report::{ReportBuilder, ReportStep};
use osiris_proto::osi3;

fn id(v: u64) -> Option<osi3::Identifier> {
    Some(osi3::Identifier { value: Some(v) })
}

fn v3(x: f64, y: f64, z: f64) -> Option<osi3::Vector3d> {
    Some(osi3::Vector3d {
        x: Some(x),
        y: Some(y),
        z: Some(z),
    })
}

fn yaw(y: f64) -> Option<osi3::Orientation3d> {
    Some(osi3::Orientation3d {
        roll: Some(0.0),
        pitch: Some(0.0),
        yaw: Some(y),
    })
}

const HOST: u64 = 1;
const CAR: u64 = 7;
const TRUCK_BEHIND: u64 = 8;
const POLE: u64 = 20;

// Host: box centre (10, 5, 0.8) m, yaw 30°, 20 m/s forward; rear axle 1.5 m behind the centre.
const HOST_C: [f64; 3] = [10.0, 5.0, 0.8];
const HOST_YAW_DEG: f64 = 30.0;
const HOST_SPEED: f64 = 20.0;
const TO_REAR: f64 = -1.5;
// Sensor: 2.0 m ahead of and 0.5 m left of the rear axle, 0.4 m up, yawed 10° to the left.
const MOUNT: [f64; 3] = [2.0, 0.5, 0.4];
const MOUNT_YAW_DEG: f64 = 10.0;
// Car: centre (60, 30, 0.75) m, velocity (-5, 2, 0) m/s.
const CAR_P: [f64; 3] = [60.0, 30.0, 0.75];
const CAR_V: [f64; 3] = [-5.0, 2.0, 0.0];
// Pole (stationary): centre (40, 30, 2) m.
const POLE_P: [f64; 3] = [40.0, 30.0, 2.0];

fn sensor_view() -> osi3::SensorView {
    let hy = HOST_YAW_DEG.to_radians();
    let mounting = osi3::MountingPosition {
        position: v3(MOUNT[0], MOUNT[1], MOUNT[2]),
        orientation: yaw(MOUNT_YAW_DEG.to_radians()),
    };
    let host = osi3::MovingObject {
        id: id(HOST),
        base: Some(osi3::BaseMoving {
            dimension: Some(osi3::Dimension3d {
                length: Some(4.5),
                width: Some(1.8),
                height: Some(1.5),
            }),
            position: v3(HOST_C[0], HOST_C[1], HOST_C[2]),
            orientation: yaw(hy),
            velocity: v3(HOST_SPEED * hy.cos(), HOST_SPEED * hy.sin(), 0.0),
            ..Default::default()
        }),
        r#type: Some(osi3::moving_object::Type::Vehicle as i32),
        vehicle_attributes: Some(osi3::moving_object::VehicleAttributes {
            bbcenter_to_rear: v3(TO_REAR, 0.0, 0.0),
            ..Default::default()
        }),
        ..Default::default()
    };
    let car = |oid: u64, p: [f64; 3], v: [f64; 3]| osi3::MovingObject {
        id: id(oid),
        base: Some(osi3::BaseMoving {
            dimension: Some(osi3::Dimension3d {
                length: Some(4.0),
                width: Some(1.8),
                height: Some(1.5),
            }),
            position: v3(p[0], p[1], p[2]),
            orientation: yaw(0.0),
            velocity: v3(v[0], v[1], v[2]),
            ..Default::default()
        }),
        r#type: Some(osi3::moving_object::Type::Vehicle as i32),
        vehicle_classification: Some(osi3::moving_object::VehicleClassification {
            r#type: Some(osi3::moving_object::vehicle_classification::Type::Car as i32),
            ..Default::default()
        }),
        ..Default::default()
    };
    let pole = osi3::StationaryObject {
        id: id(POLE),
        base: Some(osi3::BaseStationary {
            dimension: Some(osi3::Dimension3d {
                length: Some(0.2),
                width: Some(0.2),
                height: Some(4.0),
            }),
            position: v3(POLE_P[0], POLE_P[1], POLE_P[2]),
            orientation: yaw(0.0),
            ..Default::default()
        }),
        classification: Some(osi3::stationary_object::Classification {
            r#type: Some(osi3::stationary_object::classification::Type::Pole as i32),
            ..Default::default()
        }),
        ..Default::default()
    };
    osi3::SensorView {
        mounting_position: Some(mounting),
        host_vehicle_id: id(HOST),
        global_ground_truth: Some(osi3::GroundTruth {
            host_vehicle_id: id(HOST),
            moving_object: vec![
                host,
                car(CAR, CAR_P, CAR_V),
                // 30 m behind the host: outside a 60° field of view.
                car(TRUCK_BEHIND, [-20.0, -12.0, 0.75], [20.0, 10.0, 0.0]),
            ],
            stationary_object: vec![pole],
            ..Default::default()
        }),
        radar_sensor_view: vec![osi3::RadarSensorView {
            view_configuration: Some(osi3::RadarSensorViewConfiguration {
                mounting_position: Some(mounting),
                field_of_view_horizontal: Some(60f64.to_radians()),
                ..Default::default()
            }),
            ..Default::default()
        }],
        ..Default::default()
    }
}

/// The sensor origin (global) and the global → sensor rotation angle, by hand.
fn sensor_origin() -> ([f64; 3], f64) {
    let hy = HOST_YAW_DEG.to_radians();
    // Offset of the sensor from the box centre in host axes: rear axle + mounting.
    let (ox, oy) = (TO_REAR + MOUNT[0], MOUNT[1]);
    let s = [
        HOST_C[0] + ox * hy.cos() - oy * hy.sin(),
        HOST_C[1] + ox * hy.sin() + oy * hy.cos(),
        HOST_C[2] + MOUNT[2],
    ];
    (s, hy + MOUNT_YAW_DEG.to_radians())
}

/// A global point in sensor coordinates, by hand.
fn to_sensor(p: [f64; 3]) -> [f64; 3] {
    let (s, a) = sensor_origin();
    let (dx, dy, dz) = (p[0] - s[0], p[1] - s[1], p[2] - s[2]);
    [
        dx * a.cos() + dy * a.sin(),
        -dx * a.sin() + dy * a.cos(),
        dz,
    ]
}

fn rotate_to_sensor(v: [f64; 3]) -> [f64; 3] {
    let (_, a) = sensor_origin();
    [
        v[0] * a.cos() + v[1] * a.sin(),
        -v[0] * a.sin() + v[1] * a.cos(),
        v[2],
    ]
}

fn norm(p: [f64; 3]) -> f64 {
    (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt()
}

fn sensor_data() -> osi3::SensorData {
    let hy = HOST_YAW_DEG.to_radians();
    let p = to_sensor(CAR_P);
    let r = norm(p);
    let scale = (r + 0.5) / r;
    let rel = rotate_to_sensor([
        CAR_V[0] - HOST_SPEED * hy.cos(),
        CAR_V[1] - HOST_SPEED * hy.sin(),
        0.0,
    ]);
    let u = [p[0] / r, p[1] / r, p[2] / r];
    let det_v = [
        rel[0] + 0.3 * u[0],
        rel[1] + 0.3 * u[1],
        rel[2] + 0.3 * u[2],
    ];
    let object = |tracking: u64, gt: u64, pos: [f64; 3], v: [f64; 3]| osi3::DetectedMovingObject {
        header: Some(osi3::DetectedItemHeader {
            tracking_id: id(tracking),
            ground_truth_id: vec![osi3::Identifier { value: Some(gt) }],
            existence_probability: Some(0.9),
            ..Default::default()
        }),
        base: Some(osi3::BaseMoving {
            position: v3(pos[0], pos[1], pos[2]),
            velocity: v3(v[0], v[1], v[2]),
            ..Default::default()
        }),
        ..Default::default()
    };
    osi3::SensorData {
        mounting_position: Some(osi3::MountingPosition {
            position: v3(MOUNT[0], MOUNT[1], MOUNT[2]),
            orientation: yaw(MOUNT_YAW_DEG.to_radians()),
        }),
        timestamp: Some(osi3::Timestamp {
            seconds: Some(1),
            nanos: Some(250_000_000),
        }),
        moving_object: vec![
            object(100, CAR, [p[0] * scale, p[1] * scale, p[2] * scale], det_v),
            // Names a ground-truth id the SensorView does not have: a false alarm.
            object(101, 999, [15.0, 1.0, 0.0], [0.0, 0.0, 0.0]),
        ],
        ..Default::default()
    }
}

fn csv_rows(text: &str) -> (Vec<String>, Vec<Vec<String>>) {
    let mut lines = text.lines();
    let header = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_owned)
        .collect();
    let rows = lines
        .map(|l| l.split(',').map(str::to_owned).collect())
        .collect();
    (header, rows)
}

fn col(header: &[String], row: &[String], name: &str) -> String {
    let i = header.iter().position(|h| h == name).unwrap();
    row[i].clone()
}

fn num(header: &[String], row: &[String], name: &str) -> f64 {
    col(header, row, name).parse().unwrap()
}

#[test]
fn kpi_tables_match_the_closed_form() {
    let view = sensor_view();
    let sd = sensor_data();
    let mut report = ReportBuilder::new("closed form");
    report.push(ReportStep {
        sensor: "front_radar",
        time_s: 0.0,
        sensor_view: Some(&view),
        sensor_data: &sd,
        perception: None,
        step_wall_ms: Some(2.5),
    });

    let (h, rows) = csv_rows(&report.objects_csv());
    assert_eq!(
        h.join(","),
        "sensor,frame,time_s,gt_id,gt_type,gt_range_m,gt_azimuth_deg,gt_range_rate_mps,detected,\
         tracking_id,det_range_m,range_error_m,det_range_rate_mps,range_rate_error_mps,\
         existence_probability"
    );
    // The car and the pole; not the host, not the truck behind.
    assert_eq!(rows.len(), 2, "{rows:?}");
    let car = rows
        .iter()
        .find(|r| col(&h, r, "gt_id") == CAR.to_string())
        .unwrap();
    let p = to_sensor(CAR_P);
    let r = norm(p);
    let az = p[1].atan2(p[0]).to_degrees();
    // Range rate: (car − sensor) · (v_car − v_sensor) / r, the sensor moving with the host.
    let (s, _) = sensor_origin();
    let hy = HOST_YAW_DEG.to_radians();
    let d = [CAR_P[0] - s[0], CAR_P[1] - s[1], CAR_P[2] - s[2]];
    let dv = [
        CAR_V[0] - HOST_SPEED * hy.cos(),
        CAR_V[1] - HOST_SPEED * hy.sin(),
        0.0,
    ];
    let rr = (d[0] * dv[0] + d[1] * dv[1] + d[2] * dv[2]) / r;
    assert!(r > 40.0 && az.abs() < 30.0, "test geometry: r {r}, az {az}");
    assert_eq!(col(&h, car, "sensor"), "front_radar");
    assert_eq!(col(&h, car, "frame"), "0");
    assert!((num(&h, car, "time_s") - 1.25).abs() < 1e-9);
    assert_eq!(col(&h, car, "gt_type"), "car");
    assert!(
        (num(&h, car, "gt_range_m") - r).abs() < 1e-3,
        "{car:?} vs {r}"
    );
    assert!(
        (num(&h, car, "gt_azimuth_deg") - az).abs() < 1e-3,
        "{car:?} vs {az}"
    );
    assert!(
        (num(&h, car, "gt_range_rate_mps") - rr).abs() < 1e-3,
        "{car:?} vs {rr}"
    );
    assert_eq!(col(&h, car, "detected"), "1");
    assert_eq!(col(&h, car, "tracking_id"), "100");
    assert!((num(&h, car, "det_range_m") - (r + 0.5)).abs() < 1e-3);
    assert!((num(&h, car, "range_error_m") - 0.5).abs() < 1e-3);
    assert!((num(&h, car, "det_range_rate_mps") - (rr + 0.3)).abs() < 1e-3);
    assert!((num(&h, car, "range_rate_error_mps") - 0.3).abs() < 1e-3);
    assert!((num(&h, car, "existence_probability") - 0.9).abs() < 1e-9);

    let pole = rows
        .iter()
        .find(|r| col(&h, r, "gt_id") == POLE.to_string())
        .unwrap();
    let pp = to_sensor(POLE_P);
    let pole_r = norm(pp);
    // A stationary object closes at the host's speed along the line of sight.
    let dp = [POLE_P[0] - s[0], POLE_P[1] - s[1], POLE_P[2] - s[2]];
    let pole_rr = -(dp[0] * HOST_SPEED * hy.cos() + dp[1] * HOST_SPEED * hy.sin()) / pole_r;
    assert_eq!(col(&h, pole, "gt_type"), "pole");
    assert!((num(&h, pole, "gt_range_m") - pole_r).abs() < 1e-3);
    assert!((num(&h, pole, "gt_range_rate_mps") - pole_rr).abs() < 1e-3);
    assert_eq!(col(&h, pole, "detected"), "0");
    for c in [
        "tracking_id",
        "det_range_m",
        "range_error_m",
        "det_range_rate_mps",
        "range_rate_error_mps",
        "existence_probability",
    ] {
        assert_eq!(col(&h, pole, c), "", "{c}");
    }

    let (fh, frames) = csv_rows(&report.frames_csv());
    assert_eq!(
        fh.join(","),
        "sensor,frame,time_s,ground_truth_in_fov,detected_objects,matched_objects,false_alarms,\
         feature_detections,step_wall_ms,traffic_lights,traffic_light_state_errors,traffic_signs,\
         lane_boundaries"
    );
    assert_eq!(frames.len(), 1);
    let f = &frames[0];
    assert_eq!(col(&fh, f, "ground_truth_in_fov"), "2");
    assert_eq!(col(&fh, f, "detected_objects"), "2");
    assert_eq!(col(&fh, f, "matched_objects"), "1");
    assert_eq!(col(&fh, f, "false_alarms"), "1");
    assert_eq!(col(&fh, f, "feature_detections"), "0");
    assert!((num(&fh, f, "step_wall_ms") - 2.5).abs() < 1e-9);
}

#[test]
fn without_ground_truth_there_are_no_object_rows() {
    let sd = sensor_data();
    let mut report = ReportBuilder::new("no truth");
    report.push(ReportStep {
        sensor: "s",
        time_s: 0.0,
        sensor_view: None,
        sensor_data: &sd,
        perception: None,
        step_wall_ms: None,
    });
    assert_eq!(report.objects_csv().lines().count(), 1);
    let (fh, frames) = csv_rows(&report.frames_csv());
    let f = &frames[0];
    assert_eq!(col(&fh, f, "ground_truth_in_fov"), "");
    assert_eq!(col(&fh, f, "false_alarms"), "");
    assert_eq!(col(&fh, f, "detected_objects"), "2");
    assert_eq!(col(&fh, f, "step_wall_ms"), "");
}

#[test]
fn report_html_shows_a_range_doppler_map_and_detections() {
    use osiris_proto::perception;
    let view = sensor_view();
    let mut sd = sensor_data();
    sd.feature_data = Some(osi3::FeatureData {
        radar_sensor: vec![osi3::RadarDetectionData {
            detection: vec![osi3::RadarDetection {
                position: Some(osi3::Spherical3d {
                    distance: Some(30.0),
                    azimuth: Some(0.1),
                    elevation: Some(0.0),
                }),
                radial_velocity: Some(3.0),
                ..Default::default()
            }],
            ..Default::default()
        }],
        ..Default::default()
    });
    let (nr, nd) = (16u32, 8u32);
    let pd = perception::PerceptionData {
        radar: Some(perception::RadarPerception {
            range_doppler_map: Some(perception::RangeDopplerMap {
                range_bins: Some(nr),
                doppler_bins: Some(nd),
                range_bin_m: Some(0.5),
                range_rate_bin_m_s: Some(0.25),
                power_dbm: (0..nr * nd)
                    .map(|i| -100.0 + (i % 7) as f32 * 5.0)
                    .collect(),
            }),
            ..Default::default()
        }),
        ..Default::default()
    };
    let mut report = ReportBuilder::new("radar with a map");
    report.push(ReportStep {
        sensor: "front radar",
        time_s: 0.0,
        sensor_view: Some(&view),
        sensor_data: &sd,
        perception: Some(&pd),
        step_wall_ms: None,
    });
    let dir = tempfile::tempdir().unwrap();
    let paths = report.write(dir.path(), true).unwrap();
    let html = std::fs::read_to_string(paths.report_html.unwrap()).unwrap();
    assert!(
        html.contains("<section id=\"sensor-front-radar\" class=\"sensor\" data-kind=\"radar\""),
        "section"
    );
    assert!(html.contains("alt=\"range-Doppler map\" src=\"data:image/png;base64,"));
    assert!(html.contains("1 detections"), "radar bird's-eye view");
    // Self-contained.
    assert!(!html.contains("src=\"http") && !html.contains("<link"));
    assert!(html.contains("document.body.dataset.rendered"));
}

/// A ground-truth bulb `id` in `mode`.
fn bulb(id: u64, mode: osi3::traffic_light::classification::Mode) -> osi3::TrafficLight {
    osi3::TrafficLight {
        id: Some(osiris_proto::id(id)),
        classification: Some(osi3::traffic_light::Classification {
            mode: Some(mode as i32),
            ..Default::default()
        }),
        ..Default::default()
    }
}

/// A detected bulb naming ground-truth bulb `id`, reported in `mode`.
fn detected(
    id: u64,
    mode: osi3::traffic_light::classification::Mode,
) -> osi3::DetectedTrafficLight {
    osi3::DetectedTrafficLight {
        header: Some(osi3::DetectedItemHeader {
            ground_truth_id: vec![osiris_proto::id(id)],
            ..Default::default()
        }),
        candidate: vec![osi3::detected_traffic_light::CandidateTrafficLight {
            probability: Some(1.0),
            classification: Some(osi3::traffic_light::Classification {
                mode: Some(mode as i32),
                ..Default::default()
            }),
        }],
        ..Default::default()
    }
}

/// A reported bulb state is an error when lit/dark differs from the ground truth's mode
/// (CONSTANT/COUNTING lit, OFF dark); FLASHING ground truth is not judged.
#[test]
fn traffic_light_state_errors_against_the_ground_truth_modes() {
    use osi3::traffic_light::classification::Mode;
    let gt = osi3::GroundTruth {
        traffic_light: vec![
            bulb(1, Mode::Constant),
            bulb(2, Mode::Off),
            bulb(3, Mode::Flashing),
            bulb(4, Mode::Counting),
        ],
        ..Default::default()
    };
    let sd = osi3::SensorData {
        traffic_light: vec![
            detected(1, Mode::Off),      // lit read dark: error
            detected(2, Mode::Off),      // right
            detected(3, Mode::Off),      // flashing: not judged
            detected(4, Mode::Constant), // counting read lit: right
            detected(9, Mode::Off),      // no ground truth: not judged
        ],
        ..Default::default()
    };
    assert_eq!(osiris::report::kpi::traffic_light_state_errors(&sd, &gt), 1);
    let sd2 = osi3::SensorData {
        traffic_light: vec![detected(2, Mode::Constant), detected(1, Mode::Constant)],
        ..Default::default()
    };
    assert_eq!(
        osiris::report::kpi::traffic_light_state_errors(&sd2, &gt),
        1
    );
}

/// The report's traffic-control table: per-frame counts of the reported bulbs, signs and lane
/// boundaries, and the bulb-state misreads against the ground truth.
#[test]
fn report_html_shows_the_traffic_control_outputs() {
    use osi3::traffic_light::classification::Mode;
    let mut view = sensor_view();
    let gt = view.global_ground_truth.as_mut().unwrap();
    gt.traffic_light = vec![bulb(77, Mode::Constant)];
    let mut report = ReportBuilder::new("traffic control");
    // Frame 0: nothing; frame 1: the bulb read lit, a sign, two boundaries; frame 2: read dark.
    let frames = [
        (vec![], 0, 0),
        (vec![detected(77, Mode::Constant)], 1, 2),
        (vec![detected(77, Mode::Off)], 0, 2),
    ];
    for (k, (lights, signs, boundaries)) in frames.into_iter().enumerate() {
        let mut sd = sensor_data();
        sd.timestamp = Some(osi3::Timestamp {
            seconds: Some(0),
            nanos: Some(100_000_000 * k as u32),
        });
        sd.traffic_light = lights;
        sd.traffic_sign = vec![osi3::DetectedTrafficSign::default(); signs];
        sd.lane_boundary = vec![osi3::DetectedLaneBoundary::default(); boundaries];
        report.push(ReportStep {
            sensor: "front camera",
            time_s: 0.1 * k as f64,
            sensor_view: Some(&view),
            sensor_data: &sd,
            perception: None,
            step_wall_ms: None,
        });
    }
    let dir = tempfile::tempdir().unwrap();
    let html =
        std::fs::read_to_string(report.write(dir.path(), true).unwrap().report_html.unwrap())
            .unwrap();
    assert!(html.contains("<h3>Traffic control</h3>"), "table");
    // Bulbs: 2 in 3 frames (0.67 per frame), max 1, in 2 of 3, first at 0.1 s.
    assert!(
        html.contains("<tr><td>traffic-light bulbs</td><td>0.67</td><td>1</td><td>2 / 3</td><td>0.100 s</td></tr>"),
        "{html}"
    );
    assert!(html.contains(
        "<tr><td>traffic signs</td><td>0.33</td><td>1</td><td>1 / 3</td><td>0.100 s</td></tr>"
    ));
    assert!(html.contains(
        "<tr><td>lane boundaries</td><td>1.33</td><td>2</td><td>2 / 3</td><td>0.100 s</td></tr>"
    ));
    assert!(
        html.contains("1 in 1 of 3 frames with ground truth"),
        "misreads"
    );
}
