//! `osiris bench camera`: frames per second of the physical camera on a reference scene.
//!
//! The reference scene is an OSI ground truth of a street (built here, no files): the fallback road
//! plane, two rows of buildings (concrete boxes 8–20 m tall, casting shadows), poles, guardrails,
//! and moving traffic in both directions (cars, vans, trucks, pedestrians). The host drives along
//! +x at 10 m/s with the camera 1.3 m above the road looking forward; the sun stands 35° high, 40°
//! left of the view direction (shadows of buildings and cars in view; sky above the street).
//!
//! The timed unit is one whole [`CameraSensor`] step through the [`SensorModel`] trait (render,
//! lens, pixel model with the preset's 3-exposure HDR, HDR merge and companding, ISP, recognition,
//! OSI output), on a rayon pool of `threads` threads; the scene build is in the first (warm-up)
//! step and not timed. The JSON reports the median frame rate and the cost split of the median
//! frame from [`CameraSensor::times`] (with the renderer's own [`super::render::RenderStats`]:
//! camera rays, shadow rays, shading).

use std::time::Instant;

use serde_json::{Value, json};

use super::{CameraConfig, CameraSensor};
use crate::effects::Effects;
use crate::frames::Mounting;
use crate::sensor::{
    CommonConfig, ModelMode, SensorKind, SensorModel, SensorSetup, StepInput, StepOutput,
};
use osiris_proto::{id, osi3};

/// Target of the issue: frames/s of a 1280 × 960 frame on 2 threads.
pub const TARGET_FPS: f64 = 5.0;

/// Size of the reference street.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraBenchScene {
    /// Image size (width, height), px (absent: the preset's 1280 × 960).
    pub image: Option<(usize, usize)>,
    /// Buildings per side of the street.
    pub buildings_per_side: usize,
    /// Moving road users.
    pub vehicles: usize,
}

impl CameraBenchScene {
    /// The reference scene at the ISX019 size.
    pub const STREET: CameraBenchScene = CameraBenchScene {
        image: None,
        buildings_per_side: 20,
        vehicles: 60,
    };
    /// A small variant for unit tests.
    pub const SMALL: CameraBenchScene = CameraBenchScene {
        image: Some((160, 120)),
        buildings_per_side: 3,
        vehicles: 6,
    };
}

fn v3(x: f64, y: f64, z: f64) -> osi3::Vector3d {
    osi3::Vector3d {
        x: Some(x),
        y: Some(y),
        z: Some(z),
    }
}

fn dim(l: f64, w: f64, h: f64) -> osi3::Dimension3d {
    osi3::Dimension3d {
        length: Some(l),
        width: Some(w),
        height: Some(h),
    }
}

fn rpy(y: f64) -> osi3::Orientation3d {
    osi3::Orientation3d {
        roll: Some(0.0),
        pitch: Some(0.0),
        yaw: Some(y),
    }
}

fn moving(
    oid: u64,
    reference: &str,
    ty: osi3::moving_object::Type,
    pos: [f64; 3],
    d: [f64; 3],
    yaw: f64,
    speed: f64,
) -> osi3::MovingObject {
    osi3::MovingObject {
        id: Some(id(oid)),
        base: Some(osi3::BaseMoving {
            dimension: Some(dim(d[0], d[1], d[2])),
            position: Some(v3(pos[0], pos[1], pos[2])),
            orientation: Some(rpy(yaw)),
            velocity: Some(v3(speed * yaw.cos(), speed * yaw.sin(), 0.0)),
            orientation_rate: Some(rpy(0.0)),
            ..Default::default()
        }),
        r#type: Some(ty as i32),
        model_reference: Some(reference.into()),
        ..Default::default()
    }
}

fn stationary(oid: u64, reference: &str, pos: [f64; 3], d: [f64; 3]) -> osi3::StationaryObject {
    osi3::StationaryObject {
        id: Some(id(oid)),
        base: Some(osi3::BaseStationary {
            dimension: Some(dim(d[0], d[1], d[2])),
            position: Some(v3(pos[0], pos[1], pos[2])),
            orientation: Some(rpy(0.0)),
            ..Default::default()
        }),
        model_reference: Some(reference.into()),
        ..Default::default()
    }
}

/// Host vehicle id of the reference scene.
pub const HOST_ID: u64 = 1;

/// The reference street as a SensorView at time `t_s` (the host and traffic advance with time).
pub fn street_view(scene: &CameraBenchScene, t_s: f64) -> osi3::SensorView {
    use osi3::moving_object::Type;
    let host_x = 10.0 * t_s;
    let mut moving_objects = vec![moving(
        HOST_ID,
        "osiris:car",
        Type::Vehicle,
        [host_x, -1.75, 0.75],
        [4.5, 1.8, 1.5],
        0.0,
        10.0,
    )];
    let kinds = [
        ("osiris:car", [4.5, 1.8, 1.5]),
        ("osiris:van", [5.0, 2.0, 2.2]),
        ("osiris:car?paint=black", [4.5, 1.8, 1.5]),
        ("osiris:truck", [9.0, 2.5, 3.5]),
    ];
    for k in 0..scene.vehicles {
        let oid = 100 + k as u64;
        if k % 10 == 9 {
            // Pedestrians on the sidewalks.
            let y = if k % 20 == 9 { 7.5 } else { -7.5 };
            moving_objects.push(moving(
                oid,
                "osiris:pedestrian",
                Type::Pedestrian,
                [8.0 + 9.0 * k as f64 - 1.4 * t_s, y, 0.9],
                [0.4, 0.6, 1.8],
                std::f64::consts::PI,
                1.4,
            ));
            continue;
        }
        let (reference, d) = kinds[k % kinds.len()];
        // Alternate: same direction (lane y = −1.75 / −5.25), oncoming (y = 1.75 / 5.25).
        let lane = k % 4;
        let (y, yaw, speed) = match lane {
            0 => (-1.75, 0.0, 12.0),
            1 => (1.75, std::f64::consts::PI, 13.0),
            2 => (-5.25, 0.0, 9.0),
            _ => (5.25, std::f64::consts::PI, 11.0),
        };
        let x0 = 12.0 + 7.0 * k as f64;
        let x = x0 + speed * yaw.cos() * t_s;
        moving_objects.push(moving(
            oid,
            reference,
            Type::Vehicle,
            [x, y, 0.5 * d[2]],
            d,
            yaw,
            speed,
        ));
    }
    let mut stationary_objects = Vec::new();
    for k in 0..scene.buildings_per_side {
        for (s, y) in [(0u64, -16.0), (1, 16.0)] {
            let h = 8.0 + ((k * 7 + s as usize * 3) % 13) as f64;
            let l = 14.0 + ((k * 5) % 7) as f64;
            stationary_objects.push(stationary(
                1000 + 2 * k as u64 + s,
                "osiris:box?material=concrete",
                [-20.0 + 20.0 * k as f64, y, 0.5 * h],
                [l, 12.0, h],
            ));
        }
        for (s, y) in [(0u64, -9.0), (1, 9.0)] {
            stationary_objects.push(stationary(
                3000 + 2 * k as u64 + s,
                "osiris:pole",
                [-15.0 + 20.0 * k as f64, y, 3.0],
                [0.15, 0.15, 6.0],
            ));
        }
    }
    for s in [0u64, 1] {
        stationary_objects.push(stationary(
            5000 + s,
            "osiris:guardrail",
            [200.0, if s == 0 { -8.0 } else { 8.0 }, 0.375],
            [400.0, 0.3, 0.75],
        ));
    }
    let sec = t_s.floor();
    let timestamp = osi3::Timestamp {
        seconds: Some(sec as i64),
        nanos: Some(((t_s - sec) * 1e9) as u32),
    };
    osi3::SensorView {
        timestamp: Some(timestamp),
        host_vehicle_id: Some(id(HOST_ID)),
        global_ground_truth: Some(osi3::GroundTruth {
            timestamp: Some(timestamp),
            host_vehicle_id: Some(id(HOST_ID)),
            moving_object: moving_objects,
            stationary_object: stationary_objects,
            environmental_conditions: Some(osi3::EnvironmentalConditions {
                sun: Some(osi3::environmental_conditions::Sun {
                    // Azimuth counter-clockwise from north (+y) (`crate::environment::sun::sun_direction`):
                    // −50° puts the sun 40° left of the view direction (+x).
                    azimuth: Some(-50f64.to_radians()),
                    elevation: Some(35f64.to_radians()),
                    intensity: None,
                }),
                ..Default::default()
            }),
            ..Default::default()
        }),
        ..Default::default()
    }
}

/// The sensor configuration of the benchmark (ISX019 preset, 60° horizontal FoV, fixed seed): the
/// sensor-independent part and the camera parameters.
pub fn bench_config(scene: &CameraBenchScene) -> (CommonConfig, CameraConfig) {
    let camera = CameraConfig {
        width_px: scene.image.map(|i| i.0),
        height_px: scene.image.map(|i| i.1),
        ..Default::default()
    };
    let common = CommonConfig {
        kind: SensorKind::Camera,
        mode: ModelMode::Physical,
        range_m: 200.0,
        fov_horizontal_rad: 60f64.to_radians(),
        fov_vertical_rad: 45f64.to_radians(),
        update_cycle_s: 1.0 / 30.0,
        mounting: Mounting {
            position_m: [1.5, 0.0, 0.55],
            orientation_rad: [0.0; 3],
        },
        calibration: Default::default(),
        min_visible_fraction: 0.2,
        effects: Default::default(),
        weather: None,
        seed: Some(1),
        include_sensor_view: false,
    };
    (common, camera)
}

/// Run the benchmark on the reference street; `threads` defaults to 2, `frames` ≥ 1.
pub fn bench_camera(threads: Option<usize>, frames: usize) -> Value {
    bench_camera_on(&CameraBenchScene::STREET, threads, frames)
}

/// [`bench_camera`] on a given scene (tests use [`CameraBenchScene::SMALL`]): every effect at its
/// default, plus the frame rate with `camera.motion_blur` off (`without_motion_blur`) and with a
/// windshield (`with_windshield`: the default `camera.windshield`, its three effects on).
pub fn bench_camera_on(scene: &CameraBenchScene, threads: Option<usize>, frames: usize) -> Value {
    let mut v = bench_camera_with(scene, threads, frames, &[], false);
    let off = bench_camera_with(
        scene,
        threads,
        frames,
        &[("camera.motion_blur", false)],
        false,
    );
    let ws = bench_camera_with(scene, threads, frames, &[], true);
    if let Some(m) = v.as_object_mut() {
        m.insert("without_motion_blur".into(), off);
        m.insert("with_windshield".into(), ws);
    }
    v
}

/// [`bench_camera_on`] with effect switches, and with the default windshield when `windshield`.
pub fn bench_camera_with(
    scene: &CameraBenchScene,
    threads: Option<usize>,
    frames: usize,
    switches: &[(&str, bool)],
    windshield: bool,
) -> Value {
    let threads = threads.unwrap_or(2).max(1);
    let frames = frames.max(1);
    let pool = match rayon::ThreadPoolBuilder::new().num_threads(threads).build() {
        Ok(p) => p,
        Err(e) => return json!({ "error": format!("thread pool: {e}") }),
    };
    let (mut common, mut camera) = bench_config(scene);
    if windshield {
        camera.windshield = Some(super::windshield::WindshieldConfig::default());
    }
    for (k, on) in switches {
        common.effects.insert((*k).to_string(), *on);
    }
    // The effects a camera is asked about: the world's and its own.
    let known = [crate::world::effects(), super::effects()].concat();
    let effects = match Effects::with_switches(&known, &common.effects) {
        Ok(e) => e,
        Err(e) => return json!({ "error": format!("`effects`: {e}") }),
    };
    let setup = SensorSetup {
        common,
        params: camera,
        effects,
    };
    let mut sensor = match CameraSensor::from_setup(setup) {
        Ok(s) => s,
        Err(e) => return json!({ "error": e.to_string() }),
    };
    let (width, height) = (
        sensor.chain().resolved.width,
        sensor.chain().resolved.height,
    );
    let mut out = StepOutput::default();
    let dt = 1.0 / 30.0;
    let mut per_frame: Vec<(f64, super::StageTimes)> = Vec::with_capacity(frames);
    let mut build_s = 0.0;
    let mut error = None;
    pool.install(|| {
        for f in 0..=frames {
            let t_s = 1.0 + f as f64 * dt;
            let view = street_view(scene, t_s);
            let input = StepInput {
                view: &view,
                time_s: t_s,
                step_s: dt,
            };
            let t = Instant::now();
            if let Err(e) = sensor.step(&input, &mut out) {
                error = Some(e.to_string());
                return;
            }
            let wall = t.elapsed().as_secs_f64();
            if f == 0 {
                build_s = wall;
            } else {
                per_frame.push((wall, sensor.times()));
            }
        }
    });
    if let Some(e) = error {
        return json!({ "error": e });
    }
    per_frame.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (median, times) = per_frame[per_frame.len() / 2];
    let r = times.render;
    json!({
        "frames_per_s": 1.0 / median,
        "target_frames_per_s": TARGET_FPS,
        "width": width,
        "height": height,
        "threads": threads,
        "frames": frames,
        "frame_s": median,
        "first_frame_s": build_s,
        "render_s": times.render_s,
        "rays": r.rays,
        "trace_s": r.trace_s,
        "camera_rays_s": r.camera_rays_s,
        "shadow_rays_s": r.shadow_rays_s,
        "shading_s": r.shading_s,
        "lens_s": times.lens_s,
        "pixel_s": times.pixel_s,
        "isp_s": times.isp_s,
        "recognition_s": times.recognition_s,
        "moving_objects": scene.vehicles,
        "buildings": 2 * scene.buildings_per_side,
    })
}
