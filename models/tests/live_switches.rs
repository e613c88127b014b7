//! Every effect switch is live: for each effect of [`catalogue`], a reference scene where it
//! applies is run through the sensor that owns it (the public step API, as the FMU runs it) with
//! the effect at its default and toggled, at one seed, and the output must change. Where a closed
//! form gives the size or the sign of the change, it is checked too (fog and rain extinction
//! `exp(−2σR)`, the spreading law `(R/R₀)⁴`, the cosine of incidence, glass, dropped rays, ...).
//!
//! The cases are a table ([`CASES`]: effect → reference scene; [`ALSO`]: further sensors an
//! effect describes); an effect of the catalogue without a case fails
//! [`every_effect_has_a_live_case`] by name, so a new effect cannot be added without its live case.
//! One scene per sensor serves all of that sensor's effects: one baseline run, then one run per
//! toggled effect (the whole file runs in about a second in the dev profile). The camera cases
//! check only that some emitted image changes.

mod common;
use common::{db, sun, v3};

use std::f64::consts::PI;

use num_complex::Complex64;
use osiris_models::effects::EffectInfo;
use osiris_models::environment::weather::{self, Band, RoadWetness, Weather};
use osiris_models::lidar::detection::{DetectorConfig, IntensityMode};
use osiris_models::lidar::scan::{MemsPattern, ScanPattern};
use osiris_models::lidar::{LidarConfig, LidarSensor};
use osiris_models::radar::{RadarConfig, RadarSensor};
use osiris_models::registry::catalogue;
use osiris_models::{
    ModelMode, Mounting, SensorConfig, SensorKind, SensorModel, StepInput, StepOutput,
};
use osiris_proto::{INVALID_ID, id, osi3, timestamp_from_seconds};

/// The reference scene (and sensor) of an effect.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Bench {
    Lidar,
    /// The LiDAR scene through the FMCW chain (`preset: fmcw`).
    Fmcw,
    Radar,
    /// The radar on a host driving past stationary posts (online calibration).
    RadarDrive,
    Camera,
}

/// Effect → the scene where it is live. Every effect of the catalogue needs an entry.
const CASES: &[(&str, Bench)] = &[
    // Environment (weather, road, materials).
    ("env.fog_extinction", Bench::Lidar),
    ("env.rain_extinction", Bench::Lidar),
    // The camera scene's sky and sunlit surfaces (the sun is up in it).
    ("env.sky_distribution", Bench::Camera),
    ("env.atmospheric_absorption", Bench::Radar),
    ("env.wet_road", Bench::Lidar),
    ("env.wet_surfaces", Bench::Lidar),
    ("env.retroreflection", Bench::Lidar),
    // Space design.
    ("space.multipath", Bench::Radar),
    ("space.diffuse_bounces", Bench::Camera),
    ("space.transmission", Bench::Lidar),
    ("space.mmwave_roughness", Bench::Radar),
    ("space.fresnel_polarisation", Bench::Radar),
    // LiDAR.
    ("lidar.overlap_function", Bench::Lidar),
    ("lidar.incidence_angle", Bench::Lidar),
    ("lidar.fog_extinction", Bench::Lidar),
    ("lidar.rain_extinction", Bench::Lidar),
    ("lidar.solar_background", Bench::Lidar),
    ("lidar.detector_noise", Bench::Lidar),
    ("lidar.range_walk", Bench::Lidar),
    ("lidar.detector_saturation", Bench::Lidar),
    ("lidar.dropped_rays", Bench::Lidar),
    ("lidar.scan_motion", Bench::Lidar),
    ("lidar.vertical_divergence", Bench::Lidar),
    ("lidar.mixed_pixels", Bench::Lidar),
    ("lidar.fmcw_speckle", Bench::Fmcw),
    ("lidar.fmcw_phase_noise", Bench::Fmcw),
    ("lidar.fmcw_chirp_nonlinearity", Bench::Fmcw),
    ("lidar.fmcw_ego_doppler", Bench::Fmcw),
    // Radar.
    ("radar.two_way_spreading", Bench::Radar),
    ("radar.rcs_area_scaling", Bench::Radar),
    ("radar.ground_multipath", Bench::Radar),
    ("radar.multipath", Bench::Radar),
    ("radar.rain_attenuation", Bench::Radar),
    ("radar.atmospheric_absorption", Bench::Radar),
    ("radar.micro_doppler", Bench::Radar),
    ("radar.road_clutter", Bench::Radar),
    ("radar.diffuse_scattering", Bench::Radar),
    ("radar.antenna_pattern", Bench::Radar),
    ("radar.receiver_compression", Bench::Radar),
    ("radar.phase_noise", Bench::Radar),
    ("radar.interference", Bench::Radar),
    ("radar.mounting_misalignment", Bench::RadarDrive),
    // Camera.
    ("camera.rolling_shutter", Bench::Camera),
    ("camera.motion_blur", Bench::Camera),
    ("camera.led_flicker", Bench::Camera),
    ("camera.vignetting", Bench::Camera),
    ("camera.distortion", Bench::Camera),
    ("camera.psf_blur", Bench::Camera),
    ("camera.flare", Bench::Camera),
    ("camera.hdr_companding", Bench::Camera),
    ("camera.shot_noise", Bench::Camera),
    ("camera.read_noise", Bench::Camera),
    ("camera.dark_current", Bench::Camera),
    ("camera.dsnu", Bench::Camera),
    ("camera.prnu", Bench::Camera),
    ("camera.saturation", Bench::Camera),
    // Mounting and timing (every sensor; the bench runs them with [`calibrated`]).
    ("lidar.extrinsic_error", Bench::Lidar),
    ("lidar.time_offset", Bench::Lidar),
    ("radar.extrinsic_error", Bench::Radar),
    ("radar.time_offset", Bench::Radar),
    ("camera.extrinsic_error", Bench::Camera),
    ("camera.windshield_transmission", Bench::Camera),
    ("camera.windshield_refraction", Bench::Camera),
    ("camera.dashboard_reflection", Bench::Camera),
    ("camera.time_offset", Bench::Camera),
];

/// Effects that also get a second reference scene (another sensor they describe).
const ALSO: &[(&str, Bench)] = &[
    ("space.transmission", Bench::Radar),
    ("space.transmission", Bench::Camera),
    ("space.multipath", Bench::Camera),
    ("env.rain_extinction", Bench::Radar),
    ("env.wet_road", Bench::Radar),
];

fn info(name: &str) -> EffectInfo {
    catalogue()
        .into_iter()
        .find(|e| e.name == name)
        .unwrap_or_else(|| panic!("`{name}` is in CASES but not in the catalogue"))
}

/// The effects a bench toggles, in table order.
fn cases_of(bench: Bench) -> Vec<EffectInfo> {
    CASES
        .iter()
        .chain(ALSO)
        .filter(|c| c.1 == bench)
        .map(|c| info(c.0))
        .collect()
}

#[test]
fn every_effect_has_a_live_case() {
    let missing: Vec<&str> = catalogue()
        .iter()
        .map(|e| e.name)
        .filter(|n| !CASES.iter().any(|c| c.0 == *n))
        .collect();
    assert!(
        missing.is_empty(),
        "effects without a live-switch case in models/tests/live_switches.rs: {}",
        missing.join(", ")
    );
    for (name, _) in CASES.iter().chain(ALSO) {
        info(name);
    }
}

fn rpy(yaw: f64) -> osi3::Orientation3d {
    osi3::Orientation3d {
        roll: Some(0.0),
        pitch: Some(0.0),
        yaw: Some(yaw),
    }
}

fn dims(d: [f64; 3]) -> osi3::Dimension3d {
    osi3::Dimension3d {
        length: Some(d[0]),
        width: Some(d[1]),
        height: Some(d[2]),
    }
}

/// A board of `w × h` and `material` with its face centre at `pos`, facing the origin, turned by
/// `tilt` about the vertical.
fn board(oid: u64, pos: [f64; 3], w: f64, h: f64, material: &str, tilt: f64) -> osi3::MovingObject {
    let yaw = pos[1].atan2(pos[0]) + PI + tilt;
    osi3::MovingObject {
        id: Some(id(oid)),
        base: Some(osi3::BaseMoving {
            dimension: Some(dims([0.01, w, h])),
            position: Some(v3(pos)),
            orientation: Some(rpy(yaw)),
            velocity: Some(v3([0.0; 3])),
            orientation_rate: Some(rpy(0.0)),
            ..Default::default()
        }),
        r#type: Some(osi3::moving_object::Type::Other as i32),
        model_reference: Some(format!(
            "osiris:board?width_m={w}&height_m={h}&thickness_m=0&mount=none&material={material}"
        )),
        ..Default::default()
    }
}

/// A car at `pos` (yaw 0) moving with `vel`, tail lamps on.
fn car(oid: u64, pos: [f64; 3], vel: [f64; 3]) -> osi3::MovingObject {
    use osi3::moving_object::vehicle_classification::{LightState, Type, light_state};
    osi3::MovingObject {
        id: Some(id(oid)),
        base: Some(osi3::BaseMoving {
            dimension: Some(dims([4.5, 1.8, 1.5])),
            position: Some(v3(pos)),
            orientation: Some(rpy(vel[1].atan2(vel[0]))),
            velocity: Some(v3(vel)),
            orientation_rate: Some(rpy(0.0)),
            ..Default::default()
        }),
        r#type: Some(osi3::moving_object::Type::Vehicle as i32),
        vehicle_classification: Some(osi3::moving_object::VehicleClassification {
            r#type: Some(Type::Car as i32),
            light_state: Some(LightState {
                tail_light: Some(light_state::GenericLightState::On as i32),
                ..Default::default()
            }),
            ..Default::default()
        }),
        model_reference: Some("osiris:car".into()),
        ..Default::default()
    }
}

/// A SensorView without a host (the mounting is the global pose) at t = 1 s.
fn view(objects: Vec<osi3::MovingObject>, env: osi3::EnvironmentalConditions) -> osi3::SensorView {
    osi3::SensorView {
        version: Some(osiris_proto::interface_version()),
        timestamp: Some(timestamp_from_seconds(1.0)),
        global_ground_truth: Some(osi3::GroundTruth {
            timestamp: Some(timestamp_from_seconds(1.0)),
            moving_object: objects,
            environmental_conditions: Some(env),
            ..Default::default()
        }),
        ..Default::default()
    }
}

fn base_config(kind: SensorKind, height_m: f64) -> SensorConfig {
    let mut c = SensorConfig::default_for(kind);
    c.mode = ModelMode::Physical;
    c.mounting = Mounting {
        position_m: [0.0, 0.0, height_m],
        orientation_rad: [0.0; 3],
    };
    c.seed = Some(7);
    c
}

/// The mounting and timing effects act only through a non-zero `calibration` block: their
/// reference runs (baseline and toggled) add one (1° yaw, 0.05 m lateral offset, 50 ms clock
/// offset; every scene has a moving car), the other effects keep the calibrated sensor.
fn calibrated(mut c: SensorConfig, e: &EffectInfo) -> SensorConfig {
    if e.name.ends_with(".extrinsic_error") || e.name.ends_with(".time_offset") {
        c.calibration.yaw_deg = 1.0;
        c.calibration.y_m = 0.05;
        c.calibration.time_offset_s = 0.05;
    }
    c
}

fn is_mounting(e: &EffectInfo) -> bool {
    calibrated(SensorConfig::default_for(SensorKind::Radar), e)
        .calibration
        .yaw_deg
        != 0.0
}

fn toggled(c: SensorConfig, e: &EffectInfo) -> SensorConfig {
    let mut c = calibrated(c, e);
    c.effects.insert(e.name.to_owned(), !e.default_on);
    c
}

fn step(sensor: &mut dyn SensorModel, v: &osi3::SensorView) -> StepOutput {
    let mut out = StepOutput::default();
    sensor
        .step(
            &StepInput {
                view: v,
                time_s: 1.0,
                step_s: 0.05,
            },
            &mut out,
        )
        .expect("step");
    out
}

/// Fails with every message at once.
fn report(bench: &str, failures: Vec<String>) {
    assert!(
        failures.is_empty(),
        "{bench}: {} effect(s) not live or off their closed form:\n  {}",
        failures.len(),
        failures.join("\n  ")
    );
}

// ---------------------------------------------------------------------------------------------
// LiDAR
// ---------------------------------------------------------------------------------------------

const L_BOARD: u64 = 7;
const L_TILTED: u64 = 8;
const L_PANE: u64 = 10;
const L_BEHIND: u64 = 11;
const L_RETRO: u64 = 12;
const L_CAR: u64 = 20;
/// Range of the face of `L_BOARD`, m.
const L_BOARD_R: f64 = 15.0;
const L_DROP: f64 = 0.2;

fn lidar_weather() -> Weather {
    Weather {
        rain_mm_h: 20.0,
        fog_visibility_m: 300.0,
        road: RoadWetness::Wet,
        ..Weather::CLEAR
    }
}

/// A 1 m high LiDAR with a MEMS raster (60° × 24°, 30 × 64 points in 50 ms, 7 sub-rays) over the
/// road (partial overlap below 4 m), a board at 15 m, a board turned by 60°, a glass pane with a
/// board behind, retroreflective sheeting and a crossing car; fog, rain, a wet road, the sun up.
fn lidar_config() -> SensorConfig {
    let mut c = base_config(SensorKind::Lidar, 1.0);
    c.range_m = 200.0;
    c.fov_horizontal_rad = 2.0 * PI;
    c.fov_vertical_rad = PI;
    c.update_cycle_s = 0.1;
    c.weather = Some(lidar_weather());
    let mut l = LidarConfig {
        scan: Some(ScanPattern::Mems(MemsPattern {
            fov_horizontal_rad: 60f64.to_radians(),
            fov_vertical_rad: 24f64.to_radians(),
            lines: 30,
            points_per_line: 64,
            frame_time_s: 0.05,
            bidirectional: false,
            centre_rad: [0.0, (-6f64).to_radians()],
        })),
        ..Default::default()
    };
    l.beam.sub_rays = Some(7);
    l.detector = DetectorConfig {
        intensity_mode: IntensityMode::Power,
        power_full_scale_w: Some(1e-3),
        drop_probability: L_DROP,
        ..DetectorConfig::default()
    };
    c.lidar = Some(l);
    c
}

fn lidar_view() -> osi3::SensorView {
    let az = |deg: f64, r: f64, z: f64| {
        let a = deg.to_radians();
        [r * a.cos(), r * a.sin(), z]
    };
    view(
        vec![
            board(
                L_BOARD,
                az(3.0, L_BOARD_R, 1.5),
                2.5,
                2.5,
                "lambertian_50",
                0.0,
            ),
            board(
                L_TILTED,
                az(-10.0, 12.0, 1.2),
                2.0,
                2.0,
                "lambertian_50",
                60f64.to_radians(),
            ),
            board(L_PANE, az(15.0, 6.0, 1.0), 1.0, 1.0, "glass", 0.0),
            board(
                L_BEHIND,
                az(15.0, 12.0, 1.0),
                3.0,
                3.0,
                "lambertian_90",
                0.0,
            ),
            board(
                L_RETRO,
                az(26.0, 9.0, 1.0),
                0.6,
                0.6,
                "retroreflective_sheeting",
                0.0,
            ),
            car(L_CAR, [20.0, -9.0, 0.75], [0.0, 15.0, 0.0]),
        ],
        sun(PI, 40f64.to_radians()),
    )
}

/// (x, y, z, intensity, object id) of every point.
type Cloud = Vec<([f32; 3], f32, u64)>;

fn cloud(out: &StepOutput) -> Cloud {
    let c = out.perception.lidar.as_ref().expect("lidar perception");
    (0..c.x_m.len())
        .map(|i| {
            (
                [c.x_m[i], c.y_m[i], c.z_m[i]],
                c.intensity[i],
                c.object_id[i],
            )
        })
        .collect()
}

fn on_object(c: &Cloud, oid: u64) -> Vec<f64> {
    c.iter()
        .filter(|p| p.2 == oid)
        .map(|p| f64::from(p.1))
        .collect()
}

/// Mean intensity of the road points (sensor frame z ≈ −1 m: the road plane 1 m below the sensor).
fn road_intensity(c: &Cloud) -> f64 {
    let r: Vec<f64> = c
        .iter()
        .filter(|p| (p.0[2] + 1.0).abs() < 0.05)
        .map(|p| f64::from(p.1))
        .collect();
    assert!(r.len() > 100, "{} road points", r.len());
    mean(&r)
}

/// Mean range of the points on `oid`, m.
fn range_on(c: &Cloud, oid: u64) -> f64 {
    let r: Vec<f64> = c
        .iter()
        .filter(|p| p.2 == oid)
        .map(|p| {
            let [x, y, z] = p.0.map(f64::from);
            (x * x + y * y + z * z).sqrt()
        })
        .collect();
    mean(&r)
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

/// Mean intensity of the board ahead, toggled / baseline, against `want` (relative tolerance).
fn ratio_check(base: &Cloud, run: &Cloud, oid: u64, want: f64, tol: f64) -> Result<(), String> {
    let (b, r) = (on_object(base, oid), on_object(run, oid));
    if b.len() < 10 || r.len() < 10 {
        return Err(format!(
            "too few points on {oid}: {} / {}",
            b.len(),
            r.len()
        ));
    }
    let got = mean(&r) / mean(&b);
    if ((got - want) / want).abs() > tol {
        return Err(format!(
            "intensity ratio on object {oid} {got:.4}, closed form {want:.4}"
        ));
    }
    Ok(())
}

/// The closed-form expectation of toggling `name` off in the LiDAR scene (None: only "changes").
fn lidar_closed_form(name: &str, base: &Cloud, run: &Cloud) -> Result<(), String> {
    let w = lidar_weather();
    let b = weather::extinction_breakdown(&w, Band::Nir905);
    match name {
        // Extinction off: the board's power rises by exp(2σR) (σ of Kim at 905 nm / P.1814).
        "env.fog_extinction" | "lidar.fog_extinction" => ratio_check(
            base,
            run,
            L_BOARD,
            (2.0 * b.fog_per_m * L_BOARD_R).exp(),
            0.05,
        ),
        "env.rain_extinction" | "lidar.rain_extinction" => ratio_check(
            base,
            run,
            L_BOARD,
            (2.0 * b.rain_per_m * L_BOARD_R).exp(),
            0.03,
        ),
        // Incidence off: the board turned by 60° returns 1/cos 60° = 2 times the power.
        "lidar.incidence_angle" => ratio_check(base, run, L_TILTED, 2.0, 0.1),
        // Dropped rays off: about 1/(1 − p) times the points.
        "lidar.dropped_rays" => {
            let got = run.len() as f64 / base.len() as f64;
            let want = 1.0 / (1.0 - L_DROP);
            if (got - want).abs() > 0.08 {
                return Err(format!("point count ratio {got:.3}, 1/(1 − p) = {want:.3}"));
            }
            Ok(())
        }
        // Transmission off: the pane is opaque, the board behind it loses the points seen through it.
        "space.transmission" => {
            let (nb, nr) = (
                on_object(base, L_BEHIND).len(),
                on_object(run, L_BEHIND).len(),
            );
            if nr >= nb {
                return Err(format!(
                    "points on the board behind the pane: {nb} with, {nr} without transmission"
                ));
            }
            Ok(())
        }
        // Saturation off: the retroreflector's echoes are no longer clipped, so the walk correction
        // no longer under-corrects them (clipped: range short).
        "lidar.detector_saturation" => {
            let (rb, rr) = (range_on(base, L_RETRO), range_on(run, L_RETRO));
            if rr <= rb {
                return Err(format!(
                    "retroreflector mean range {rb:.4} m clipped vs {rr:.4} m unclipped"
                ));
            }
            Ok(())
        }
        // Dry road (either switch off): the asphalt loses its water film, whose darkening
        // ρ(1−F)(1−r̄)/(1−ρr̄) lowered the road's returns.
        "env.wet_road" | "env.wet_surfaces" => {
            let (wet, dry) = (road_intensity(base), road_intensity(run));
            if dry <= wet {
                return Err(format!("road intensity wet {wet:.4}, dry {dry:.4}"));
            }
            Ok(())
        }
        // Retroreflection off: the sheeting returns far less.
        "env.retroreflection" => {
            let (mb, mr) = (
                mean(&on_object(base, L_RETRO)),
                mean(&on_object(run, L_RETRO)),
            );
            if mr >= mb {
                return Err(format!(
                    "sheeting intensity {mb} with, {mr} without retroreflection"
                ));
            }
            Ok(())
        }
        _ => Ok(()),
    }
}

#[test]
fn lidar_switches_are_live() {
    let t = std::time::Instant::now();
    let v = lidar_view();
    let run = |c: SensorConfig| {
        let mut s = LidarSensor::new(c).expect("lidar config");
        cloud(&step(&mut s, &v))
    };
    let base = run(lidar_config());
    for oid in [L_BOARD, L_TILTED, L_BEHIND, L_RETRO, L_CAR] {
        assert!(
            on_object(&base, oid).len() >= 10,
            "the reference scene sees object {oid} ({} points)",
            on_object(&base, oid).len()
        );
    }
    let mut failures = Vec::new();
    let calibrated_base = std::cell::OnceCell::new();
    for e in cases_of(Bench::Lidar) {
        let base = if is_mounting(&e) {
            calibrated_base.get_or_init(|| run(calibrated(lidar_config(), &e)))
        } else {
            &base
        };
        let got = run(toggled(lidar_config(), &e));
        if got == *base {
            failures.push(format!("{}: the point cloud does not change", e.name));
        } else if let Err(m) = lidar_closed_form(e.name, base, &got) {
            failures.push(format!("{}: {m}", e.name));
        }
    }
    eprintln!("lidar: {:.1} s", t.elapsed().as_secs_f64());
    report("lidar", failures);
}

/// The LiDAR reference scene and scan through the FMCW chain (1550 nm, 512 samples per ramp).
fn fmcw_config() -> SensorConfig {
    let mut c = lidar_config();
    let l = c.lidar.as_mut().unwrap();
    l.preset = osiris_models::lidar::scan::Preset::Fmcw;
    l.detector = DetectorConfig::default();
    l.fmcw = Some(osiris_models::lidar::fmcw::FmcwConfig {
        samples_per_chirp: 512,
        ..Default::default()
    });
    c
}

#[test]
fn fmcw_switches_are_live() {
    // The LiDAR scene on a host driving at 5 m/s (the sensor's own Doppler exists).
    let mut v = lidar_view();
    let host = 99;
    v.global_ground_truth
        .as_mut()
        .unwrap()
        .moving_object
        .push(car(host, [0.0, 0.0, 0.75], [5.0, 0.0, 0.0]));
    v.host_vehicle_id = Some(id(host));
    // Points with their range rates.
    let run = |c: SensorConfig| {
        let mut s = LidarSensor::new(c).expect("FMCW lidar config");
        let out = step(&mut s, &v);
        let rates = out
            .perception
            .lidar
            .as_ref()
            .unwrap()
            .range_rate_m_s
            .clone();
        (cloud(&out), rates)
    };
    let base = run(fmcw_config());
    assert_eq!(base.1.len(), base.0.len(), "one range rate per point");
    for oid in [L_BOARD, L_CAR] {
        assert!(
            on_object(&base.0, oid).len() >= 10,
            "the reference scene sees object {oid} ({} points)",
            on_object(&base.0, oid).len()
        );
    }
    let mut failures = Vec::new();
    for e in cases_of(Bench::Fmcw) {
        if run(toggled(fmcw_config(), &e)) == base {
            failures.push(format!("{}: the point cloud does not change", e.name));
        }
    }
    report("fmcw", failures);
}

// ---------------------------------------------------------------------------------------------
// Radar
// ---------------------------------------------------------------------------------------------

const R_TRIHEDRAL: u64 = 7;
const R_TRIHEDRAL_R: f64 = 15.0;
const R_BEHIND: u64 = 8;
const R_PANE: u64 = 9;
const R_PLATE_A: u64 = 11;
const R_PLATE_B: u64 = 12;
const R_CAR: u64 = 20;
const R_CONCRETE: u64 = 21;
const R_RAIN_MM_H: f64 = 30.0;

fn radar_weather() -> Weather {
    Weather {
        rain_mm_h: R_RAIN_MM_H,
        road: RoadWetness::Wet,
        ..Weather::CLEAR
    }
}

fn radar_config() -> SensorConfig {
    let mut c = base_config(SensorKind::Radar, 1.0);
    c.fov_horizontal_rad = 120f64.to_radians();
    c.fov_vertical_rad = 30f64.to_radians();
    c.weather = Some(radar_weather());
    // `radar.interference` (off by default) uses the default interferer when switched on.
    let mut r = RadarConfig {
        emit_range_doppler_map: true,
        ..Default::default()
    };
    r.front_end.input_p1db_dbm = -50.0;
    // Room for the weak wheel paths beside the strong returns.
    r.propagation.max_paths = 4000;
    c.radar = Some(r);
    c
}

/// A moving object with `reference`, box `dim`, at `pos`, facing the radar (turned by `tilt`).
fn target(
    oid: u64,
    reference: &str,
    pos: [f64; 3],
    tilt: f64,
    dim: [f64; 3],
) -> osi3::MovingObject {
    let mut o = board(oid, pos, 1.0, 1.0, "aluminium", tilt);
    o.model_reference = Some(reference.to_owned());
    o.base.as_mut().unwrap().dimension = Some(dims(dim));
    o
}

/// A trihedral (edge 0.1 m) at 15 m, 10° right, one at 12 m, 20° left, behind a glass pane at 8 m, a
/// dihedral of two plates (two objects) at 20 m, 20° right, a concrete board at 10 m, 40° right,
/// a car driving away at 10 m/s 15 m ahead (spinning wheels); road below, rain, wet road. The
/// receiver compresses from −50 dBm (1 dB point), so that the strong returns compress.
fn radar_view() -> osi3::SensorView {
    let az = |deg: f64, r: f64, z: f64| {
        let a = deg.to_radians();
        [r * a.cos(), r * a.sin(), z]
    };
    let tri = |oid: u64, pos: [f64; 3]| {
        target(
            oid,
            "osiris:trihedral?edge_m=0.1",
            pos,
            0.0,
            [0.09, 0.15, 0.15],
        )
    };
    // Dihedral: two aluminium plates, a vertical 90° corner opening towards the radar.
    let (w, t) = (0.1, 0.004);
    let corner = az(-20.0, 20.0, 1.0);
    let a0 = corner[1].atan2(corner[0]);
    let plate = |oid: u64, side: f64| {
        // Plate normal at ±45° from the line of sight; the plate extends from the corner towards
        // the radar on its side.
        let n_dir = a0 + PI + side * PI / 4.0;
        let along = a0 + PI - side * PI / 4.0;
        let pos = [
            corner[0] + along.cos() * w / 2.0 - n_dir.cos() * t / 2.0,
            corner[1] + along.sin() * w / 2.0 - n_dir.sin() * t / 2.0,
            1.0,
        ];
        let mut o = target(
            oid,
            &format!(
                "osiris:board?width_m={w}&height_m={w}&thickness_m={t}&material=aluminium&mount=none"
            ),
            pos,
            0.0,
            [t, w, w],
        );
        o.base.as_mut().unwrap().orientation = Some(rpy(n_dir));
        o
    };
    let mut pane = board(R_PANE, az(20.0, 8.0, 1.0), 0.6, 0.6, "glass", 0.0);
    pane.base.as_mut().unwrap().dimension = Some(dims([0.01, 0.6, 0.6]));
    let mut concrete = board(R_CONCRETE, az(-40.0, 10.0, 1.0), 0.5, 0.5, "concrete", 0.0);
    concrete.model_reference = Some(
        "osiris:board?width_m=0.5&height_m=0.5&thickness_m=0.05&mount=none&material=concrete"
            .into(),
    );
    view(
        vec![
            tri(R_TRIHEDRAL, az(-10.0, R_TRIHEDRAL_R, 1.0)),
            tri(R_BEHIND, az(20.0, 12.0, 1.0)),
            pane,
            plate(R_PLATE_A, 1.0),
            plate(R_PLATE_B, -1.0),
            concrete,
            car(R_CAR, [15.0, 0.0, 0.75], [10.0, 0.0, 0.0]),
        ],
        osi3::EnvironmentalConditions::default(),
    )
}

/// What a radar step produces: the propagation paths and the baseband output (detections and
/// the range-Doppler map, as bytes).
#[derive(PartialEq)]
struct RadarRun {
    paths: Vec<(f64, f64, Complex64, u64)>,
    baseband: Vec<u8>,
}

fn power_of(r: &RadarRun, oid: u64) -> f64 {
    r.paths
        .iter()
        .filter(|p| p.3 == oid)
        .map(|p| p.2.norm_sqr())
        .sum()
}

/// Power of the strongest path of `oid` (its direct return), W.
fn direct_power(r: &RadarRun, oid: u64) -> f64 {
    r.paths
        .iter()
        .filter(|p| p.3 == oid)
        .map(|p| p.2.norm_sqr())
        .fold(0.0, f64::max)
}

fn radar_closed_form(name: &str, base: &RadarRun, run: &RadarRun) -> Result<(), String> {
    let lam = 299_792_458.0 / RadarConfig::default().waveform.carrier_frequency_hz;
    let f = RadarConfig::default().waveform.carrier_frequency_hz;
    let r = R_TRIHEDRAL_R;
    // Off: the trihedral's direct return, in dB, rises by `want_db` (± tol_db).
    let rise = |want_db: f64, tol_db: f64| -> Result<(), String> {
        let got = db(direct_power(run, R_TRIHEDRAL) / direct_power(base, R_TRIHEDRAL));
        if (got - want_db).abs() > tol_db {
            return Err(format!(
                "trihedral return changes by {got:.3} dB, closed form {want_db:.3} dB"
            ));
        }
        Ok(())
    };
    match name {
        // Rain off: + γ_R·2R (P.838-3 at the carrier, two-way path).
        "radar.rain_attenuation" | "env.rain_extinction" => {
            let g = weather::rain_attenuation_mmwave_db_per_km(R_RAIN_MM_H, f, 0.0, 0.0);
            let want = g * 2.0 * r / 1000.0;
            rise(want, 0.25 * want)
        }
        // Gases off: + γ_gas·2R (P.676 at 77–79 GHz).
        "radar.atmospheric_absorption" | "env.atmospheric_absorption" => {
            let g =
                weather::gas_attenuation_mmwave_db_per_km(f, Weather::CLEAR.water_vapour_g_m3());
            let want = g * 2.0 * r / 1000.0;
            rise(want, 0.25 * want)
        }
        // Spreading off: R⁴ → R₀⁴, the return rises by (R/R₀)⁴ (40 log R/R₀ dB).
        "radar.two_way_spreading" => {
            let r0 = RadarConfig::default().propagation.reference_range_m;
            rise(40.0 * (r / r0).log10(), 0.5)
        }
        // Single bounce only: the trihedral (σ = 4πa⁴/(3λ²) by its triple bounce) loses > 10 dB.
        "space.multipath" => {
            let loss = db(power_of(base, R_TRIHEDRAL) / power_of(run, R_TRIHEDRAL));
            let sigma = 4.0 * PI * 0.1f64.powi(4) / (3.0 * lam * lam);
            if loss < 10.0 {
                return Err(format!(
                    "trihedral (σ {:.1} dBsm) loses only {loss:.1} dB without multi-bounce paths",
                    db(sigma)
                ));
            }
            Ok(())
        }
        // Multipath between objects off: the dihedral of two plates loses > 10 dB.
        "radar.multipath" => {
            let p = |x: &RadarRun| power_of(x, R_PLATE_A) + power_of(x, R_PLATE_B);
            let loss = db(p(base) / p(run));
            if loss < 10.0 {
                return Err(format!("dihedral loses only {loss:.1} dB"));
            }
            Ok(())
        }
        // Transmission off: the pane is opaque, the trihedral behind it is gone.
        "space.transmission" => {
            let (b, o) = (power_of(base, R_BEHIND), power_of(run, R_BEHIND));
            if !(b > 0.0 && o == 0.0) {
                return Err(format!(
                    "reflector behind the pane: {b:e} W with, {o:e} W without"
                ));
            }
            Ok(())
        }
        // Ground multipath off: the image paths (via the road) disappear.
        "radar.ground_multipath" => {
            if run.paths.len() >= base.paths.len() {
                return Err(format!(
                    "{} paths with, {} without ground images",
                    base.paths.len(),
                    run.paths.len()
                ));
            }
            Ok(())
        }
        // Pattern off: every direction gets the peak gain, the board 40° off boresight gains.
        "radar.antenna_pattern" => {
            if direct_power(run, R_CONCRETE) <= direct_power(base, R_CONCRETE) {
                return Err("the board off boresight does not gain without the pattern".into());
            }
            Ok(())
        }
        // Roughness off: a smooth concrete board reflects more coherently.
        "space.mmwave_roughness" => {
            if power_of(run, R_CONCRETE) <= power_of(base, R_CONCRETE) {
                return Err("the concrete board does not gain without roughness".into());
            }
            Ok(())
        }
        // Off: the road returns nothing of its own (every static-world path is road clutter here).
        "radar.road_clutter" => {
            let road = |r: &RadarRun| r.paths.iter().filter(|p| p.3 == INVALID_ID).count();
            if road(base) == 0 || road(run) != 0 {
                return Err(format!(
                    "{} road paths with, {} without road clutter",
                    road(base),
                    road(run)
                ));
            }
            Ok(())
        }
        // Off: the car (rough paint) keeps only its coherent return: its total power falls.
        "radar.diffuse_scattering" => {
            if power_of(run, R_CAR) >= power_of(base, R_CAR) {
                return Err("the car does not lose power without diffuse scattering".into());
            }
            Ok(())
        }
        _ => Ok(()),
    }
}

#[test]
fn radar_switches_are_live() {
    let t = std::time::Instant::now();
    let v = radar_view();
    let run = |c: SensorConfig| {
        let mut s = RadarSensor::new(c).expect("radar config");
        let out = step(&mut s, &v);
        let paths = s
            .last_paths()
            .iter()
            .map(|p| (p.range_m, p.range_rate_m_s, p.amplitude, p.object_id))
            .collect();
        let radar = out.perception.radar.as_ref().expect("radar perception");
        let mut baseband = prost::Message::encode_to_vec(radar);
        baseband.extend(prost::Message::encode_to_vec(&out.sensor_data));
        RadarRun { paths, baseband }
    };
    let base = run(radar_config());
    for oid in [R_TRIHEDRAL, R_BEHIND, R_PLATE_A, R_CAR, R_CONCRETE] {
        assert!(
            power_of(&base, oid) > 0.0,
            "the reference scene sees object {oid}"
        );
    }
    let mut failures = Vec::new();
    let calibrated_base = std::cell::OnceCell::new();
    for e in cases_of(Bench::Radar) {
        let base = if is_mounting(&e) {
            calibrated_base.get_or_init(|| run(calibrated(radar_config(), &e)))
        } else {
            &base
        };
        let got = run(toggled(radar_config(), &e));
        if got.paths == base.paths && got.baseband == base.baseband {
            failures.push(format!(
                "{}: paths and baseband output do not change",
                e.name
            ));
        } else if let Err(m) = radar_closed_form(e.name, base, &got) {
            failures.push(format!("{}: {m}", e.name));
        }
    }
    eprintln!("radar: {:.1} s", t.elapsed().as_secs_f64());
    report("radar", failures);
}

/// The radar 1° misaligned on a host driving at 15 m/s past trihedral posts on both sides, five
/// cycles: the online calibration (`radar.mounting_misalignment`, off by default) turns every
/// reported azimuth by its estimate, which lies towards the misalignment.
#[test]
fn radar_drive_switches_are_live() {
    let config = || {
        let mut c = base_config(SensorKind::Radar, -0.25);
        c.mounting.position_m[0] = 2.3;
        c.calibration.yaw_deg = 1.0;
        c
    };
    let drive = |k: usize| {
        let t = 0.05 * k as f64;
        let mut host = car(1, [15.0 * t, 0.0, 0.75], [15.0, 0.0, 0.0]);
        host.model_reference = Some("osiris:car".into());
        let mut objects = vec![host];
        for j in 0..12u64 {
            for (side, y) in [(0, 5.0), (1, -5.0)] {
                objects.push(target(
                    100 + 2 * j + side,
                    "osiris:trihedral?edge_m=0.1",
                    [12.0 + 8.0 * j as f64, y, 0.5],
                    0.0,
                    [0.09, 0.15, 0.15],
                ));
                let o = objects.last_mut().unwrap();
                o.base.as_mut().unwrap().orientation = Some(rpy(PI));
            }
        }
        let mut v = view(objects, osi3::EnvironmentalConditions::default());
        v.timestamp = Some(timestamp_from_seconds(t));
        v.host_vehicle_id = Some(id(1));
        v.global_ground_truth.as_mut().unwrap().host_vehicle_id = Some(id(1));
        v
    };
    let run = |c: SensorConfig| {
        let mut s = RadarSensor::new(c).expect("radar config");
        let mut out = StepOutput::default();
        for k in 0..5 {
            out = step(&mut s, &drive(k));
        }
        out.perception.radar.expect("radar perception")
    };
    let base = run(config());
    let mut failures = Vec::new();
    for e in cases_of(Bench::RadarDrive) {
        let got = run(toggled(config(), &e));
        if got == base {
            failures.push(format!("{}: the radar output does not change", e.name));
        } else if e.name == "radar.mounting_misalignment" {
            let est = got
                .azimuth_misalignment_rad
                .unwrap_or(f64::NAN)
                .to_degrees();
            if !(0.5..1.5).contains(&est) {
                failures.push(format!("{}: estimate {est:.3}°, misalignment 1°", e.name));
            }
        }
    }
    report("radar drive", failures);
}

// ---------------------------------------------------------------------------------------------
// Camera
// ---------------------------------------------------------------------------------------------

const C_W: usize = 96;
const C_H: usize = 72;

/// A 96 × 72 camera (60° wide) looking east into a low sun (flare, saturation), a car crossing at
/// 20 m/s (rolling shutter, motion blur), a car ahead with its LED tail lamps on (flicker), a glass
/// pane in front of a white board; one diffuse bounce; fixed 10 ms exposure; every image kind
/// emitted.
fn camera_config() -> SensorConfig {
    let mut c = base_config(SensorKind::Camera, 1.3);
    c.fov_horizontal_rad = 60f64.to_radians();
    c.fov_vertical_rad = (60.0 * C_H as f64 / C_W as f64).to_radians();
    let cam = serde_json::json!({
        "width_px": C_W,
        "height_px": C_H,
        "exposure_s": 0.01,
        "render": {"diffuse_bounces": 1, "bands": 8},
        "emit": {"raw_exposures": true, "raw_hdr_linear": true, "raw_companded": true, "isp": true},
        // A windshield (the defaults), so that its effects act.
        "windshield": {}
    });
    c.camera = Some(serde_json::from_value(cam).expect("camera config"));
    c
}

fn camera_view() -> osi3::SensorView {
    view(
        vec![
            car(30, [10.0, -4.0, 0.75], [0.0, 20.0, 0.0]),
            car(31, [12.0, 1.5, 0.75], [0.0; 3]),
            board(40, [8.0, 3.0, 1.3], 1.0, 1.0, "glass", 0.0),
            board(41, [12.0, 4.5, 1.3], 2.5, 2.5, "lambertian_90", 0.0),
            board(42, [10.0, -5.0, 1.0], 2.0, 2.0, "lambertian_50", 0.0),
        ],
        sun(1.5 * PI, 3f64.to_radians()),
    )
}

#[test]
fn camera_switches_are_live() {
    let t = std::time::Instant::now();
    let v = camera_view();
    let run = |c: SensorConfig| -> Vec<Vec<u8>> {
        let mut s = osiris_models::camera::CameraSensor::new(c).expect("camera config");
        let out = step(&mut s, &v);
        out.perception
            .camera
            .as_ref()
            .expect("camera perception")
            .image
            .iter()
            .map(|i| i.data.clone().unwrap_or_default())
            .collect()
    };
    let base = run(camera_config());
    assert!(base.len() >= 4, "{} images", base.len());
    let mut failures = Vec::new();
    let calibrated_base = std::cell::OnceCell::new();
    for e in cases_of(Bench::Camera) {
        let base = if is_mounting(&e) {
            calibrated_base.get_or_init(|| run(calibrated(camera_config(), &e)))
        } else {
            &base
        };
        let got = run(toggled(camera_config(), &e));
        if got == *base {
            failures.push(format!("{}: no image changes", e.name));
        }
    }
    eprintln!("camera: {:.1} s", t.elapsed().as_secs_f64());
    report("camera", failures);
}
