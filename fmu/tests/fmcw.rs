//! The LiDAR FMU with the FMCW preset, through the C ABI as any FMI master drives it: configured by
//! inline JSON (`"lidar": {"preset": "fmcw"}`), it outputs OSI LiDAR detections with
//! `radial_velocity` that recover a car's speed at 50 m within 0.1 m/s (kinematics written here:
//! a point's radial velocity towards the sensor is −d̂·v_car).

mod common;

use common::*;
use osiris_fmu::sensors;
use osiris_fmu::variables::vr;
use osiris_models::SensorKind;
use osiris_proto::{Message, osi3};

const CONFIG: &str = r#"{
  "kind": "lidar", "mode": "physical", "range_m": 150,
  "fov_horizontal_rad": 0.3, "fov_vertical_rad": 0.1, "update_cycle_s": 0.1,
  "mounting": {"position_m": [0, 0, 1], "orientation_rad": [0, 0, 0]},
  "seed": 3,
  "lidar": {
    "preset": "fmcw",
    "scan": {"flash": {"rows": 8, "cols": 24, "fov_horizontal_rad": 0.087,
                       "fov_vertical_rad": 0.026, "centre_rad": [0, 0]}}
  }
}"#;

fn view(v_car: [f64; 3]) -> osi3::SensorView {
    let ts = osiris_proto::timestamp_from_seconds(1.0);
    let xyz = |x: f64, y: f64, z: f64| osi3::Vector3d {
        x: Some(x),
        y: Some(y),
        z: Some(z),
    };
    osi3::SensorView {
        timestamp: Some(ts),
        global_ground_truth: Some(osi3::GroundTruth {
            timestamp: Some(ts),
            moving_object: vec![osi3::MovingObject {
                id: Some(osiris_proto::id(5)),
                base: Some(osi3::BaseMoving {
                    dimension: Some(osi3::Dimension3d {
                        length: Some(4.5),
                        width: Some(1.8),
                        height: Some(1.5),
                    }),
                    position: Some(xyz(50.0, 0.0, 0.75)),
                    orientation: Some(osi3::Orientation3d {
                        roll: Some(0.0),
                        pitch: Some(0.0),
                        yaw: Some(v_car[1].atan2(v_car[0])),
                    }),
                    velocity: Some(xyz(v_car[0], v_car[1], v_car[2])),
                    ..Default::default()
                }),
                r#type: Some(osi3::moving_object::Type::Vehicle as i32),
                model_reference: Some("osiris:car".into()),
                ..Default::default()
            }],
            ..Default::default()
        }),
        ..Default::default()
    }
}

#[test]
fn the_fmcw_lidar_fmu_measures_a_cars_speed_at_50_m() {
    let i = Inst::new(sensors::descriptor(SensorKind::Lidar));
    assert_eq!(i.set_strings(&[vr::string::CONFIG], &[CONFIG]), OK);
    i.init();
    let v_car = [8.0, 0.0, 0.0];
    let bytes = view(v_car).encode_to_vec();
    i.set_input(&bytes);
    assert_eq!(i.step(1.0, 0.1), OK, "{:?}", i.records());
    let sd = i.sensor_data().expect("SensorData");
    let pd = i.perception().expect("PerceptionData");
    let cloud = pd.lidar.expect("LiDAR perception");
    let dets = &sd.feature_data.expect("feature data").lidar_sensor[0].detection;
    assert_eq!(dets.len(), cloud.object_id.len());
    // OSI radial velocity of every point on the car vs −d̂·v from its direction (spherical
    // position, elevation positive up).
    let mut errors: Vec<f64> = dets
        .iter()
        .zip(&cloud.object_id)
        .filter(|&(_, &o)| o == 5)
        .map(|(d, _)| {
            let p = d.position.expect("position");
            let (az, el) = (p.azimuth.unwrap(), p.elevation.unwrap());
            let dir = [el.cos() * az.cos(), el.cos() * az.sin(), el.sin()];
            let expected = -(dir[0] * v_car[0] + dir[1] * v_car[1] + dir[2] * v_car[2]);
            d.radial_velocity.expect("FMCW radial_velocity") - expected
        })
        .collect();
    assert!(errors.len() >= 40, "{} points on the car", errors.len());
    errors.sort_by(f64::total_cmp);
    let median = errors[errors.len() / 2];
    assert!(
        median.abs() < 0.1,
        "median radial-velocity error {median} m/s"
    );
}
