//! Tests of the physical LiDAR model (`osiris_models::lidar`) against independent expectations:
//! the extended-target LiDAR equation (physics.md §2.1), fog extinction (Kim, physics.md §2.4),
//! scan geometry of the Velodyne presets (manuals / VLS128.yaml), beam footprint and mixed pixels
//! (physics.md §2.6), occlusion and rolling scan distortion (kinematics).
//!
//! Scenes are small ground truths (boards, a wall, a car; no lanes → a road plane at z = 0) seen
//! by a sensor on a static bench (no host: the mounting is the global pose) with small custom scan
//! patterns, so every test is quick in the dev profile.

mod common;
use common::{dim, lidar_step as run, quiet_lidar as quiet, rpy, v3};
use std::f64::consts::PI;

use glam::DVec3;
use osiris_models::effects::EffectSwitches;
use osiris_models::environment::weather::Weather;
use osiris_models::lidar::detection::{DetectorConfig, IntensityMode};
use osiris_models::lidar::scan::{FlashPattern, MemsPattern, Preset, ScanPattern};
use osiris_models::lidar::{LidarConfig, LidarSensor};
use osiris_models::{
    ModelError, ModelMode, Mounting, SensorConfig, SensorKind, SensorModel, StepInput, StepOutput,
};
use osiris_proto::{id, osi3, perception::LidarPerception};

const SENSOR_Z: f64 = 1.0;

/// A board facing −x (towards a sensor at the origin) with its face centre at `pos`.
fn board(
    oid: u64,
    pos: [f64; 3],
    w: f64,
    h: f64,
    material: &str,
    yaw: f64,
) -> osi3::StationaryObject {
    osi3::StationaryObject {
        id: Some(id(oid)),
        base: Some(osi3::BaseStationary {
            dimension: Some(dim([0.01, w, h])),
            position: Some(v3([pos[0], pos[1], pos[2]])),
            orientation: Some(rpy(0.0, 0.0, yaw)),
            ..Default::default()
        }),
        model_reference: Some(format!(
            "osiris:board?width_m={w}&height_m={h}&thickness_m=0&mount=none&material={material}"
        )),
        ..Default::default()
    }
}

fn car(oid: u64, pos: [f64; 3], yaw: f64, speed: f64) -> osi3::MovingObject {
    osi3::MovingObject {
        id: Some(id(oid)),
        base: Some(osi3::BaseMoving {
            dimension: Some(dim([4.5, 1.8, 1.5])),
            position: Some(v3([pos[0], pos[1], pos[2]])),
            orientation: Some(rpy(0.0, 0.0, yaw)),
            velocity: Some(v3([speed * yaw.cos(), speed * yaw.sin(), 0.0])),
            orientation_rate: Some(rpy(0.0, 0.0, 0.0)),
            ..Default::default()
        }),
        r#type: Some(osi3::moving_object::Type::Vehicle as i32),
        model_reference: Some("osiris:car".into()),
        ..Default::default()
    }
}

fn view(
    stationary: Vec<osi3::StationaryObject>,
    moving: Vec<osi3::MovingObject>,
) -> osi3::SensorView {
    osi3::SensorView {
        timestamp: Some(osi3::Timestamp {
            seconds: Some(1),
            nanos: Some(0),
        }),
        global_ground_truth: Some(osi3::GroundTruth {
            timestamp: Some(osi3::Timestamp {
                seconds: Some(1),
                nanos: Some(0),
            }),
            stationary_object: stationary,
            moving_object: moving,
            ..Default::default()
        }),
        ..Default::default()
    }
}

fn config(lidar: LidarConfig, effects: EffectSwitches) -> SensorConfig {
    SensorConfig {
        kind: SensorKind::Lidar,
        mode: ModelMode::Physical,
        range_m: 200.0,
        fov_horizontal_rad: 2.0 * PI,
        fov_vertical_rad: PI,
        update_cycle_s: 0.1,
        mounting: Mounting {
            position_m: [0.0, 0.0, SENSOR_Z],
            orientation_rad: [0.0; 3],
        },
        calibration: Default::default(),
        min_visible_fraction: 0.2,
        effects,
        weather: None,
        seed: Some(7),
        lidar: Some(lidar),
        radar: None,
        camera: None,
        include_sensor_view: false,
    }
}

/// A flash grid centred on (azimuth, elevation) = (0, 0).
fn flash(rows: usize, cols: usize, fov_h: f64, fov_v: f64) -> LidarConfig {
    LidarConfig {
        scan: Some(ScanPattern::Flash(FlashPattern {
            rows,
            cols,
            fov_horizontal_rad: fov_h,
            fov_vertical_rad: fov_v,
            centre_rad: [0.0, 0.0],
        })),
        ..Default::default()
    }
}

fn cloud(out: &StepOutput) -> &LidarPerception {
    out.perception.lidar.as_ref().expect("lidar perception")
}

fn points(c: &LidarPerception) -> Vec<(DVec3, f32, u64)> {
    (0..c.x_m.len())
        .map(|i| {
            (
                DVec3::new(c.x_m[i].into(), c.y_m[i].into(), c.z_m[i].into()),
                c.intensity[i],
                c.object_id[i],
            )
        })
        .collect()
}

/// Extended-target LiDAR equation of physics.md §2.1 with the default optics (75 W, D_r = 25 mm,
/// η = 0.5): P = P_t ρ cos θ A_r η T² / (π R²), W.
fn lidar_equation_w(rho: f64, cos_theta: f64, range_m: f64, two_way_t: f64) -> f64 {
    let a_r = PI * 0.025f64.powi(2) / 4.0;
    75.0 * rho * cos_theta * a_r * 0.5 * two_way_t / (PI * range_m * range_m)
}

const FULL_SCALE_W: f64 = 1e-3;

/// Intensity = 100 % × detected peak power / 1 mW (power mode), so intensity ∝ received power.
fn power_mode(mut l: LidarConfig) -> LidarConfig {
    l.detector = DetectorConfig {
        intensity_mode: IntensityMode::Power,
        power_full_scale_w: Some(FULL_SCALE_W),
        ..DetectorConfig::default()
    };
    l
}

fn relerr(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

fn mean(v: impl IntoIterator<Item = f64>) -> f64 {
    let (s, n) = v
        .into_iter()
        .fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    s / n as f64
}

/// Mean intensity of the points on object `oid` (and their count).
fn mean_intensity_on(out: &StepOutput, oid: u64) -> (f64, usize) {
    let p: Vec<f64> = points(cloud(out))
        .into_iter()
        .filter(|p| p.2 == oid)
        .map(|p| f64::from(p.1))
        .collect();
    (mean(p.iter().copied()), p.len())
}

#[test]
fn intensity_follows_the_extended_target_lidar_equation() {
    // ρ = 10 / 50 / 90 % boards at 5–100 m, normal incidence, clear air: P = P_t ρ A_r η /(πR²).
    for rho_pct in [10u32, 50, 90] {
        for r in [5.0, 20.0, 50.0, 100.0] {
            let v = view(
                vec![board(
                    7,
                    [r, 0.0, SENSOR_Z],
                    4.0,
                    4.0,
                    &format!("lambertian_{rho_pct}"),
                    PI,
                )],
                vec![],
            );
            let (out, _) = run(config(power_mode(flash(3, 3, 5e-4, 5e-4)), quiet()), &v);
            let (got, n) = mean_intensity_on(&out, 7);
            assert_eq!(n, 9, "ρ {rho_pct} % at {r} m: {n} points");
            let want =
                100.0 * lidar_equation_w(f64::from(rho_pct) / 100.0, 1.0, r, 1.0) / FULL_SCALE_W;
            assert!(
                relerr(got, want) < 0.03,
                "ρ {rho_pct} % at {r} m: intensity {got} vs {want}"
            );
        }
    }
}

#[test]
fn intensity_falls_with_cos_incidence_and_fog_extinction() {
    let r = 20.0;
    let at = |yaw: f64, fx: EffectSwitches, weather: Option<Weather>| {
        let v = view(
            vec![board(7, [r, 0.0, SENSOR_Z], 4.0, 4.0, "lambertian_50", yaw)],
            vec![],
        );
        let mut cfg = config(power_mode(flash(3, 3, 5e-4, 5e-4)), fx);
        cfg.weather = weather;
        let (out, _) = run(cfg, &v);
        mean_intensity_on(&out, 7).0
    };
    let normal = at(PI, quiet(), None);
    let want = 100.0 * lidar_equation_w(0.5, 1.0, r, 1.0) / FULL_SCALE_W;
    assert!(relerr(normal, want) < 0.03, "{normal} vs {want}");
    // 60° incidence: cos θ = 0.5.
    let tilted = at(PI + 60f64.to_radians(), quiet(), None);
    assert!(
        relerr(tilted / normal, 0.5) < 0.03,
        "cos 60°: ratio {}",
        tilted / normal
    );
    // Switched off: no cos θ.
    let mut fx = quiet();
    fx.insert("lidar.incidence_angle".into(), false);
    let tilted_off = at(PI + 60f64.to_radians(), fx, None);
    assert!(
        relerr(tilted_off / normal, 1.0) < 0.03,
        "incidence off: ratio {}",
        tilted_off / normal
    );
    // Fog, V = 200 m: Kim σ = 19.6 km⁻¹ at 905 nm (physics.md §2.4): T² = exp(−2σR).
    let fog = Weather {
        fog_visibility_m: 200.0,
        ..Weather::CLEAR
    };
    let foggy = at(PI, quiet(), Some(fog));
    let t2 = (-2.0 * 19.6e-3 * r).exp();
    assert!(
        relerr(foggy / normal, t2) < 0.03,
        "fog: ratio {} vs T² {t2}",
        foggy / normal
    );
    let mut fx = quiet();
    fx.insert("lidar.fog_extinction".into(), false);
    let fog_off = at(PI, fx, Some(fog));
    assert!(
        relerr(fog_off / normal, 1.0) < 0.01,
        "fog extinction off: ratio {}",
        fog_off / normal
    );
}

#[test]
fn range_error_is_within_the_configured_accuracy() {
    // Default detector: noise, range walk (amplitude-corrected) and 4 mm quantisation on.
    let accuracy = DetectorConfig::default().range_accuracy_m;
    for r in [5.0, 20.0, 50.0, 100.0] {
        let v = view(
            vec![board(7, [r, 0.0, SENSOR_Z], 4.0, 4.0, "lambertian_50", PI)],
            vec![],
        );
        let mut fx = EffectSwitches::new();
        fx.insert("lidar.solar_background".into(), false);
        let (out, _) = run(config(flash(10, 10, 2e-3, 2e-3), fx), &v);
        let errors: Vec<f64> = points(cloud(&out))
            .into_iter()
            .filter(|p| p.2 == 7)
            .map(|p| {
                let d = p.0.normalize();
                // True range along the beam to the plane x = r.
                p.0.length() - r / d.x
            })
            .collect();
        assert!(errors.len() >= 95, "{r} m: {} points", errors.len());
        let bias = mean(errors.iter().copied());
        let rms = mean(errors.iter().map(|e| e * e)).sqrt();
        assert!(bias.abs() <= accuracy, "{r} m: bias {bias}");
        assert!(
            rms <= 1.3 * accuracy,
            "{r} m: rms {rms} vs accuracy {accuracy}"
        );
    }
}

#[test]
fn vlp16_angular_resolution_equals_the_datasheet() {
    let lidar = LidarConfig {
        preset: Preset::Vlp16,
        ..Default::default()
    };
    let mut cfg = config(lidar, quiet());
    cfg.fov_horizontal_rad = 20f64.to_radians();
    let v = view(
        vec![board(
            7,
            [15.0, 0.0, SENSOR_Z],
            30.0,
            30.0,
            "lambertian_50",
            PI,
        )],
        vec![],
    );
    let (out, _) = run(cfg, &v);
    let c = cloud(&out);
    let mut elevations: Vec<i64> = (0..c.x_m.len())
        .map(|i| {
            let p = DVec3::new(c.x_m[i].into(), c.y_m[i].into(), c.z_m[i].into());
            (p.z.atan2(p.x.hypot(p.y)).to_degrees() * 100.0).round() as i64
        })
        .collect();
    elevations.sort();
    elevations.dedup();
    // ±15° in 2° steps (VLP-16 manual, Table 9-1).
    let want: Vec<i64> = (0..16).map(|k| (-1500 + 200 * k) as i64).collect();
    assert_eq!(elevations, want);
    // Azimuth step within a channel: 360° · 10 Hz · 55.296 µs = 0.19907°.
    let step_deg = 360.0 * 10.0 * 55.296e-6;
    let mut ch5: Vec<(i64, f64)> = (0..c.x_m.len())
        .filter(|&i| c.channel[i] == 5)
        .map(|i| {
            (
                c.timestamp_ns[i],
                f64::from(c.y_m[i]).atan2(f64::from(c.x_m[i])).to_degrees(),
            )
        })
        .collect();
    ch5.sort_by_key(|x| x.0);
    assert!(ch5.len() > 90, "{}", ch5.len());
    // The 20° window is swept in two parts (0 → −10° at the start of the revolution, +10° → 0 at
    // its end): compare consecutive firings only.
    let mut pairs = 0;
    for w in ch5.windows(2) {
        if w[1].0 - w[0].0 != 55_296 {
            continue;
        }
        pairs += 1;
        let d = w[0].1 - w[1].1; // clockwise: azimuth decreases
        assert!((d - step_deg).abs() < 2e-3, "step {d}° vs {step_deg}°");
    }
    assert!(pairs > 90, "{pairs}");
    assert_eq!(c.pulses_fired, Some(16 * ch5.len() as u64));
}

#[test]
fn vls128_preset_channels_span_the_datasheet_fov() {
    let mut cfg = config(LidarConfig::default(), quiet());
    cfg.fov_horizontal_rad = 2f64.to_radians();
    let s = LidarSensor::new(cfg).unwrap();
    let mut el: Vec<f64> = s
        .firings()
        .iter()
        .map(|f| f.elevation_rad.to_degrees())
        .collect();
    el.sort_by(f64::total_cmp);
    el.dedup();
    // 128 channels, −25° … +15°, finest spacing ≈ 0.11° (physics.md §2.7).
    assert_eq!(el.len(), 128);
    assert!((el[0] + 25.0).abs() < 1e-6 && (el[127] - 15.0).abs() < 1e-6);
    let finest = el.windows(2).map(|w| w[1] - w[0]).fold(f64::MAX, f64::min);
    assert!((finest - 0.11).abs() < 0.005, "{finest}");
    // Channel 0 is the lowest.
    let f0 = s.firings().iter().find(|f| f.channel == 0).unwrap();
    assert!((f0.elevation_rad.to_degrees() + 25.0).abs() < 1e-6);
}

#[test]
fn car_points_and_measured_width_vs_distance() {
    let step = 0.1f64.to_radians();
    for r in [10.0, 20.0, 40.0] {
        // Rear of the car towards the sensor (asset +x forward, car on the +x axis, yaw 0).
        let v = view(vec![], vec![car(9, [r + 2.25, 0.0, 0.75], 0.0, 0.0)]);
        let mut lidar = flash(9, 201, 200.0 * step, 4f64.to_radians());
        lidar.beam.sub_rays = Some(7);
        let (out, _) = run(config(lidar, quiet()), &v);
        let pts: Vec<DVec3> = points(cloud(&out))
            .into_iter()
            .filter(|p| p.2 == 9)
            .map(|p| p.0)
            .collect();
        // Rows over 4° and columns every 0.1°: ≈ (1.5 m/R)/(4°/8) rows × (1.8 m/R)/0.1° columns
        // cover the rear; the slanted rear window (specular glass) returns little, so at least 30 %.
        let expected = (1.5 / r / (4f64.to_radians() / 8.0)).min(9.0) * (1.8 / (r * step));
        assert!(
            pts.len() as f64 > 0.3 * expected,
            "{r} m: {} points on the car, ≈ {expected} expected",
            pts.len()
        );
        let (lo, hi) = pts
            .iter()
            .fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.y), b.max(p.y)));
        let width = hi - lo;
        // Between the car width minus one sample spacing per side and plus the horizontal
        // footprint D = Rβ_H (3 mrad) and one spacing (mixed / partial hits at the edges).
        let spacing = r * step;
        let (min_w, max_w) = (1.8 - 2.0 * spacing - 0.25, 1.8 + r * 3e-3 + spacing);
        assert!(
            width > min_w && width < max_w,
            "{r} m: width {width} not in [{min_w}, {max_w}]"
        );
    }
}

#[test]
fn mixed_pixels_put_points_in_the_depth_gap_only_when_on() {
    // Near board (x = 20 m) covers y ∈ [0, 2], far board (x = 20.5 m) y ∈ [−2, 0]; 0.5 m apart, less
    // than cτ/2 = 0.75 m of the 5 ns pulse (physics.md §2.6). A 10 mrad beam with 19 sub-rays
    // scanned across the edge.
    let v = view(
        vec![
            board(1, [20.0, 1.0, SENSOR_Z], 2.0, 2.0, "lambertian_50", PI),
            board(2, [20.5, -1.0, SENSOR_Z], 2.0, 2.0, "lambertian_50", PI),
        ],
        vec![],
    );
    let in_gap = |on: bool| {
        let mut lidar = flash(1, 41, 0.6f64.to_radians(), 1e-4);
        lidar.beam.sub_rays = Some(19);
        lidar.beam.divergence_h_rad = Some(10e-3);
        lidar.beam.divergence_v_rad = Some(10e-3);
        let mut fx = quiet();
        fx.insert("lidar.mixed_pixels".into(), on);
        let (out, _) = run(config(lidar, fx), &v);
        let pts = points(cloud(&out));
        assert!(pts.len() >= 41, "{} points", pts.len());
        pts.iter().filter(|p| p.0.x > 20.1 && p.0.x < 20.4).count()
    };
    let on = in_gap(true);
    let off = in_gap(false);
    assert!(on >= 2, "mixed pixels on: {on} points in the gap");
    assert_eq!(off, 0, "mixed pixels off: {off} points in the gap");
}

/// Farthest range at which a single pulse at a 10 % board is detected (noise off: P > T), by
/// bisection between `lo` (detected) and `hi` (not detected).
fn max_range(weather: Option<Weather>, mut lo: f64, mut hi: f64) -> f64 {
    let detected = |r: f64| {
        let v = view(
            vec![board(7, [r, 0.0, SENSOR_Z], 3.0, 3.0, "lambertian_10", PI)],
            vec![],
        );
        let mut lidar = flash(1, 1, 1e-4, 1e-4);
        lidar.signal.peak_power_w = 2.5;
        let mut cfg = config(lidar, quiet());
        cfg.weather = weather;
        let (out, _) = run(cfg, &v);
        points(cloud(&out)).iter().any(|p| p.2 == 7)
    };
    assert!(detected(lo) && !detected(hi), "bracket [{lo}, {hi}]");
    while hi - lo > 0.02 {
        let m = 0.5 * (lo + hi);
        if detected(m) { lo = m } else { hi = m }
    }
    lo
}

#[test]
fn fog_at_50_m_visibility_cuts_the_maximum_range_by_the_expected_factor() {
    let r_clear = max_range(None, 20.0, 190.0);
    assert!(r_clear > 40.0, "{r_clear}");
    // Threshold fixed: P(R) = K e^{−2σR}/R² = K/R_clear². Kim σ(V = 50 m) = 78.2 km⁻¹ (physics.md
    // §2.4); solve e^{−2σR} R_clear² = R² by bisection.
    let sigma = 78.2e-3;
    let (mut lo, mut hi) = (1.0, r_clear);
    for _ in 0..60 {
        let m = 0.5 * (lo + hi);
        if (-2.0 * sigma * m).exp() * r_clear * r_clear > m * m {
            lo = m
        } else {
            hi = m
        }
    }
    let want = lo;
    let fog = Weather {
        fog_visibility_m: 50.0,
        ..Weather::CLEAR
    };
    let got = max_range(Some(fog), 2.0, r_clear);
    assert!(
        relerr(got, want) < 0.02,
        "fog max range {got} m vs {want} m (clear {r_clear} m)"
    );
    assert!(got / r_clear < 0.5);
}

#[test]
fn no_points_behind_an_opaque_wall() {
    let v = view(
        vec![
            board(1, [20.0, 0.0, 2.0], 10.0, 4.0, "lambertian_50", PI),
            board(2, [30.0, 0.0, SENSOR_Z], 2.0, 2.0, "lambertian_90", PI),
        ],
        vec![],
    );
    let mut lidar = flash(20, 40, 20f64.to_radians(), 10f64.to_radians());
    lidar.beam.sub_rays = Some(7);
    let (out, _) = run(config(lidar, EffectSwitches::new()), &v);
    let pts = points(cloud(&out));
    assert!(pts.len() > 600, "{}", pts.len());
    assert!(pts.iter().all(|p| p.2 != 2), "a point on the hidden board");
    // The wall face is at x = 20 m; 20.2 m leaves > 6σ of range noise (3 cm).
    let far = pts.iter().filter(|p| p.0.x > 20.2).count();
    assert_eq!(far, 0, "{far} points behind the wall");
}

#[test]
fn scan_motion_moves_a_receding_car_during_the_sweep() {
    // A car driving away at 20 m/s; one MEMS line across its rear over 0.1 s. With the effect on,
    // the range grows by v·t over the sweep (slope 20 m/s); off, the whole line sees t = 0.
    let v = view(vec![], vec![car(9, [20.0 + 2.25, 0.0, 0.75], 0.0, 20.0)]);
    let slope = |on: bool| {
        let lidar = LidarConfig {
            scan: Some(ScanPattern::Mems(MemsPattern {
                fov_horizontal_rad: 4f64.to_radians(),
                fov_vertical_rad: 1e-4,
                lines: 1,
                points_per_line: 200,
                frame_time_s: 0.1,
                bidirectional: false,
                centre_rad: [0.0, (-0.25f64 / 20.0).atan()],
            })),
            ..Default::default()
        };
        let mut fx = quiet();
        fx.insert("lidar.scan_motion".into(), on);
        let (out, _) = run(config(lidar, fx), &v);
        let c = cloud(&out);
        let samples: Vec<(f64, f64)> = (0..c.x_m.len())
            .filter(|&i| c.object_id[i] == 9)
            .map(|i| {
                (
                    (c.timestamp_ns[i] - 1_000_000_000) as f64 * 1e-9,
                    f64::from(c.x_m[i]),
                )
            })
            .collect();
        assert!(samples.len() > 50, "{}", samples.len());
        let mt = mean(samples.iter().map(|s| s.0));
        let mx = mean(samples.iter().map(|s| s.1));
        let cov: f64 = samples.iter().map(|s| (s.0 - mt) * (s.1 - mx)).sum();
        let var: f64 = samples.iter().map(|s| (s.0 - mt).powi(2)).sum();
        cov / var
    };
    let on = slope(true);
    assert!((on - 20.0).abs() < 2.0, "slope {on} m/s");
    let off = slope(false);
    assert!(off.abs() < 2.0, "slope {off} m/s");
}

#[test]
fn same_seed_same_output_and_outputs_are_consistent() {
    let v = view(
        vec![board(
            7,
            [30.0, 0.0, SENSOR_Z],
            4.0,
            4.0,
            "lambertian_50",
            PI,
        )],
        vec![car(9, [15.0, 3.0, 0.75], 0.3, 5.0)],
    );
    let mut cfg = config(
        flash(16, 64, 40f64.to_radians(), 10f64.to_radians()),
        EffectSwitches::new(),
    );
    cfg.lidar.as_mut().unwrap().beam.sub_rays = Some(7);
    let (a, _) = run(cfg.clone(), &v);
    let (b, _) = run(cfg, &v);
    assert_eq!(cloud(&a), cloud(&b));
    let c = cloud(&a);
    let n = c.x_m.len();
    assert!(n > 100);
    let fd = a.sensor_data.feature_data.as_ref().unwrap();
    let dets = &fd.lidar_sensor[0].detection;
    assert_eq!(dets.len(), n);
    assert_eq!(
        fd.lidar_sensor[0]
            .header
            .as_ref()
            .unwrap()
            .number_of_valid_detections,
        Some(n as u32)
    );
    for (i, d) in dets.iter().enumerate() {
        let p = DVec3::new(c.x_m[i].into(), c.y_m[i].into(), c.z_m[i].into());
        let s = d.position.as_ref().unwrap();
        assert!((s.distance.unwrap() - p.length()).abs() < 1e-4);
        assert!((s.azimuth.unwrap() - p.y.atan2(p.x)).abs() < 1e-5);
        assert_eq!(
            d.beam_id.and_then(|b| b.value),
            Some(u64::from(c.channel[i]))
        );
    }
    assert_eq!(a.perception.model_mode.as_deref(), Some("physical"));
    assert_eq!(c.wavelength_nm, Some(903.0));
    assert_eq!(c.pulses_fired, Some(16 * 64));
}

#[test]
fn bad_configuration_values_name_their_key() {
    let err = |l: LidarConfig| match LidarSensor::new(config(l, EffectSwitches::new())) {
        Err(ModelError::Config(m)) => m,
        Err(e) => panic!("{e}"),
        Ok(_) => panic!("accepted"),
    };
    let mut l = LidarConfig::default();
    l.beam.sub_rays = Some(8);
    assert!(err(l).contains("lidar.beam.sub_rays"));
    let mut l = LidarConfig::default();
    l.signal.peak_power_w = -1.0;
    assert!(err(l).contains("lidar.signal.peak_power_w"));
    let l = flash(0, 3, 0.1, 0.1);
    assert!(err(l).contains("lidar.scan.flash.rows"));
    let text = r#"{"kind":"lidar","mode":"physical","range_m":100,"fov_horizontal_rad":1,"fov_vertical_rad":0.5,
        "update_cycle_s":0.1,"mounting":{"position_m":[0,0,1]},
        "lidar":{"preset":"vlp16","scan":{"spinning":{"elevation_rad":[0.1],"rpm":600}}}}"#;
    let cfg = SensorConfig::from_json_str(text).unwrap();
    match osiris_models::build_sensor(cfg) {
        Err(ModelError::Config(m)) => assert!(m.contains("lidar.scan.spinning"), "{m}"),
        _ => panic!("accepted a spinning pattern without a firing period"),
    }
}

#[test]
fn recognition_boxes_a_car_within_0_4_m_of_ground_truth() {
    // End to end: VLS-128 (90° window) → points → recognition, three cycles. Cars seen obliquely
    // (rear and side visible) and broadside; the centre in the sensor frame is (x, y, 0.75 − 1).
    // (Seen end-on, only the rear face visible, the box centre was 0.4 m short: not asserted here.)
    // The built-in car is rounded (plan corners of 0.35 m, sides of 10 m radius, flanks of 1.5 m
    // vertical radius: models/ASSETS.md); the L-shape fit of such a body lands up to 0.4 m from the
    // box centre (0.37 m at (12, −3), towards the sensor; the box-shaped car gave ≤ 0.3 m).
    for (cx, cy, yaw) in [(12.0, -3.0, -0.7), (15.0, 0.0, PI / 2.0), (20.0, 5.0, 0.8)] {
        let v = view(vec![], vec![car(9, [cx, cy, 0.75], yaw, 0.0)]);
        let mut cfg = config(LidarConfig::default(), EffectSwitches::new());
        cfg.fov_horizontal_rad = 90f64.to_radians();
        let mut s = LidarSensor::new(cfg).unwrap();
        let mut out = StepOutput::default();
        for k in 0..3 {
            let mut v = v.clone();
            let t = osi3::Timestamp {
                seconds: Some(1),
                nanos: Some(k * 100_000_000),
            };
            v.timestamp = Some(t);
            v.global_ground_truth.as_mut().unwrap().timestamp = Some(t);
            let input = StepInput {
                view: &v,
                time_s: 1.0 + 0.1 * f64::from(k),
                step_s: 0.1,
            };
            s.step(&input, &mut out).unwrap();
        }
        let objects = &out.sensor_data.moving_object;
        assert!(!objects.is_empty(), "({cx}, {cy}): no object recognised");
        let want = DVec3::new(cx, cy, -0.25);
        let best = objects
            .iter()
            .filter_map(|o| o.base.as_ref()?.position.as_ref())
            .map(|p| DVec3::new(p.x.unwrap_or(0.0), p.y.unwrap_or(0.0), p.z.unwrap_or(0.0)))
            .min_by(|a, b| (*a - want).length().total_cmp(&(*b - want).length()))
            .unwrap();
        let d = (best - want).truncate().length();
        assert!(
            d <= 0.4,
            "({cx}, {cy}, yaw {yaw}): box centre {best}, {d} m from ground truth"
        );
    }
}

#[test]
fn ego_motion_during_the_sweep_is_compensated_to_the_measurement_time() {
    // The sensor rides on a host at 20 m/s towards a wall; one MEMS line over 0.1 s. The wall
    // comes 2 m closer during the sweep, but points expressed in the sensor frame of the
    // measurement time all lie on the wall as seen at t = 0 (slope 0, same x as with the whole
    // sweep traced at t = 0).
    let mut host = car(1, [0.0, 0.0, 0.75], 0.0, 20.0);
    host.model_reference = None;
    let mut v = view(
        vec![board(7, [40.0, 0.0, 1.5], 20.0, 10.0, "lambertian_50", PI)],
        vec![host],
    );
    v.host_vehicle_id = Some(id(1));
    let xs = |on: bool| {
        let lidar = LidarConfig {
            scan: Some(ScanPattern::Mems(MemsPattern {
                fov_horizontal_rad: 4f64.to_radians(),
                fov_vertical_rad: 1e-4,
                lines: 1,
                points_per_line: 200,
                frame_time_s: 0.1,
                bidirectional: false,
                centre_rad: [0.0, 0.0],
            })),
            ..Default::default()
        };
        let mut fx = quiet();
        fx.insert("lidar.scan_motion".into(), on);
        let mut cfg = config(lidar, fx);
        cfg.mounting.position_m = [2.0, 0.0, 1.0];
        let (out, _) = run(cfg, &v);
        let c = cloud(&out);
        (0..c.x_m.len())
            .filter(|&i| c.object_id[i] == 7)
            .map(|i| {
                (
                    (c.timestamp_ns[i] - 1_000_000_000) as f64 * 1e-9,
                    f64::from(c.x_m[i]),
                )
            })
            .collect::<Vec<_>>()
    };
    let (on, off) = (xs(true), xs(false));
    assert!(
        on.len() > 150 && off.len() > 150,
        "{} {}",
        on.len(),
        off.len()
    );
    let x_off = mean(off.iter().map(|s| s.1));
    let x_on = mean(on.iter().map(|s| s.1));
    assert!(
        (x_on - x_off).abs() < 0.05,
        "compensated mean x {x_on} vs {x_off} at t = 0"
    );
    let mt = mean(on.iter().map(|s| s.0));
    let cov: f64 = on.iter().map(|s| (s.0 - mt) * (s.1 - x_on)).sum();
    let var: f64 = on.iter().map(|s| (s.0 - mt).powi(2)).sum();
    assert!((cov / var).abs() < 1.0, "x drifts at {} m/s", cov / var);
}
