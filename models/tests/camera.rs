//! End-to-end tests of the physical camera (`mode: physical, kind: camera`) through
//! `osiris_models::build_sensor`: render → lens → pixel → HDR → ISP → recognition.
//!
//! Each test names the parts of the chain it depends on.

mod common;
use common::{sun, v3};

use std::f64::consts::PI;

use glam::{DVec2, DVec3};
use osiris_models::camera::CameraConfig;
use osiris_models::camera::lens::{Lens, LensConfig};
use osiris_models::effects::Effects;
use osiris_models::registry::catalogue;
use osiris_models::sensor::{ModelMode, Mounting};
use osiris_models::{SensorConfig, SensorKind, SensorModel, StepInput, StepOutput, build_sensor};
use osiris_proto::perception::camera_image::{ColorFilterArray, Kind, SampleFormat};
use osiris_proto::{id, osi3, perception, timestamp_from_seconds};

/// Camera mounting (the default front camera's position; no host vehicle, so the vehicle frame is
/// the global frame).
const MOUNT: [f64; 3] = [1.9, 0.0, 1.3];
const W: usize = 320;
const H: usize = 240;

fn car(oid: u64, pos: [f64; 3]) -> osi3::MovingObject {
    let dim = [4.5, 1.8, 1.5];
    osi3::MovingObject {
        id: Some(id(oid)),
        base: Some(osi3::BaseMoving {
            dimension: Some(osi3::Dimension3d {
                length: Some(dim[0]),
                width: Some(dim[1]),
                height: Some(dim[2]),
            }),
            position: Some(v3(pos)),
            orientation: Some(osi3::Orientation3d {
                roll: Some(0.0),
                pitch: Some(0.0),
                yaw: Some(0.0),
            }),
            velocity: Some(v3([0.0; 3])),
            ..Default::default()
        }),
        r#type: Some(osi3::moving_object::Type::Vehicle as i32),
        vehicle_classification: Some(osi3::moving_object::VehicleClassification {
            r#type: Some(osi3::moving_object::vehicle_classification::Type::Car as i32),
            ..Default::default()
        }),
        model_reference: Some("osiris:car".into()),
        ..Default::default()
    }
}

/// A square board (face normal = object +x) of side `side_m` and material `material`.
fn board(
    oid: u64,
    pos: DVec3,
    roll: f64,
    yaw: f64,
    side_m: f64,
    material: &str,
) -> osi3::StationaryObject {
    osi3::StationaryObject {
        id: Some(id(oid)),
        base: Some(osi3::BaseStationary {
            dimension: Some(osi3::Dimension3d {
                length: Some(0.01),
                width: Some(side_m),
                height: Some(side_m),
            }),
            position: Some(v3(pos.to_array())),
            orientation: Some(osi3::Orientation3d {
                roll: Some(roll),
                pitch: Some(0.0),
                yaw: Some(yaw),
            }),
            ..Default::default()
        }),
        model_reference: Some(format!(
            "osiris:board?width_m={side_m}&height_m={side_m}&material={material}"
        )),
        ..Default::default()
    }
}

/// A SensorView without a host vehicle (vehicle frame = global frame).
fn view(
    moving: Vec<osi3::MovingObject>,
    stationary: Vec<osi3::StationaryObject>,
    env: osi3::EnvironmentalConditions,
    t: f64,
) -> osi3::SensorView {
    let mounting = Mounting {
        position_m: MOUNT,
        orientation_rad: [0.0; 3],
    };
    osi3::SensorView {
        version: Some(osiris_proto::interface_version()),
        timestamp: Some(timestamp_from_seconds(t)),
        sensor_id: Some(id(42)),
        mounting_position: Some(mounting.to_osi()),
        global_ground_truth: Some(osi3::GroundTruth {
            timestamp: Some(timestamp_from_seconds(t)),
            moving_object: moving,
            stationary_object: stationary,
            environmental_conditions: Some(env),
            ..Default::default()
        }),
        ..Default::default()
    }
}

/// A physical camera configuration: small image, the given camera JSON merged over
/// `{width_px, height_px}`.
fn config(fov_h_deg: f64, camera: serde_json::Value, effects_off: &[&str]) -> SensorConfig {
    let mut c = SensorConfig::default_for(SensorKind::Camera);
    c.mode = ModelMode::Physical;
    c.mounting = Mounting {
        position_m: MOUNT,
        orientation_rad: [0.0; 3],
    };
    c.fov_horizontal_rad = fov_h_deg.to_radians();
    c.fov_vertical_rad = (fov_h_deg * H as f64 / W as f64).to_radians();
    c.seed = Some(7);
    let mut cam = serde_json::json!({"width_px": W, "height_px": H});
    if let (Some(m), Some(extra)) = (cam.as_object_mut(), camera.as_object()) {
        for (k, v) in extra {
            m.insert(k.clone(), v.clone());
        }
    }
    c.camera = Some(serde_json::from_value::<CameraConfig>(cam).expect("camera config"));
    for name in effects_off {
        c.effects.insert((*name).to_string(), false);
    }
    c
}

fn run(sensor: &mut dyn SensorModel, v: &osi3::SensorView) -> StepOutput {
    let mut out = StepOutput::default();
    sensor
        .step(
            &StepInput {
                view: v,
                time_s: 0.0,
                step_s: 0.033,
            },
            &mut out,
        )
        .expect("camera step");
    out
}

fn image(out: &StepOutput, kind: Kind) -> Vec<&perception::CameraImage> {
    out.perception
        .camera
        .as_ref()
        .expect("camera perception")
        .image
        .iter()
        .filter(|i| i.kind == Some(kind as i32))
        .collect()
}

/// Samples of a RAW image as f64 DN.
fn samples(img: &perception::CameraImage) -> Vec<f64> {
    let data = img.data.as_deref().unwrap_or_default();
    match SampleFormat::try_from(img.sample_format.unwrap_or(0)) {
        Ok(SampleFormat::U16Le) => data
            .chunks_exact(2)
            .map(|c| f64::from(u16::from_le_bytes([c[0], c[1]])))
            .collect(),
        Ok(SampleFormat::U32Le) => data
            .chunks_exact(4)
            .map(|c| f64::from(u32::from_le_bytes([c[0], c[1], c[2], c[3]])))
            .collect(),
        other => panic!("unexpected sample format {other:?}"),
    }
}

/// The lens the sensor plans (same configuration), for `Lens::project`.
fn lens_of(c: &SensorConfig) -> Lens {
    let cam = c.camera.clone().unwrap_or_default();
    let effects = Effects::with_switches(&catalogue(), &c.effects).unwrap();
    let pitch = cam.resolve().unwrap().pixel_pitch_m;
    Lens::new(&cam.lens, W, H, pitch, c.fov_horizontal_rad, &effects).unwrap()
}

/// Independent OpenCV `projectPoints` (radial k1, k2 only) of a sensor-frame direction.
fn opencv(d: DVec3, f: f64, cx: f64, cy: f64, k1: f64, k2: f64) -> DVec2 {
    let (x, y) = (-d.y / d.x, -d.z / d.x);
    let r2 = x * x + y * y;
    let s = 1.0 + k1 * r2 + k2 * r2 * r2;
    DVec2::new(f * x * s + cx, f * y * s + cy)
}

/// Bilinear sample of a (w × h) image at continuous coordinates of its sample grid.
fn bilinear(img: &[f64], w: usize, h: usize, x: f64, y: f64) -> Option<f64> {
    if x < 0.0 || y < 0.0 || x > (w - 1) as f64 || y > (h - 1) as f64 {
        return None;
    }
    let (x0, y0) = (x.floor() as usize, y.floor() as usize);
    let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
    let (fx, fy) = (x - x0 as f64, y - y0 as f64);
    let a = img[y0 * w + x0] * (1.0 - fx) + img[y0 * w + x1] * fx;
    let b = img[y1 * w + x0] * (1.0 - fx) + img[y1 * w + x1] * fx;
    Some(a * (1.0 - fy) + b * fy)
}

/// Least-squares line (point, unit direction) through points.
fn fit_line(pts: &[DVec2]) -> (DVec2, DVec2) {
    let n = pts.len() as f64;
    let m = pts.iter().copied().sum::<DVec2>() / n;
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for p in pts {
        let d = *p - m;
        sxx += d.x * d.x;
        sxy += d.x * d.y;
        syy += d.y * d.y;
    }
    let angle = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    (m, DVec2::new(angle.cos(), angle.sin()))
}

fn intersect(a: (DVec2, DVec2), b: (DVec2, DVec2)) -> DVec2 {
    // a.0 + s a.1 = b.0 + t b.1.
    let det = a.1.x * (-b.1.y) - a.1.y * (-b.1.x);
    let r = b.0 - a.0;
    let s = (r.x * (-b.1.y) - r.y * (-b.1.x)) / det;
    a.0 + s * a.1
}

/// Depends on: renderer (board radiance in sun), lens (distortion, PSF), pixel model, HDR merge.
#[test]
fn checkerboard_corners_land_where_the_distortion_model_says() {
    let (k1, k2) = (-0.3, 0.02);
    let fov = 40.0;
    let c = config(
        fov,
        serde_json::json!({
            "lens": {"k1": k1, "k2": k2},
            "emit": {"raw_hdr_linear": true, "raw_companded": false, "isp": false}
        }),
        &[],
    );
    let lens = lens_of(&c);
    // Focal length from the FoV through the distortion (lens module contract): the ray at the
    // horizontal image edge is at fov/2.
    let t = (0.5 * fov).to_radians().tan();
    let f = 0.5 * W as f64 / (t * (1.0 + k1 * t * t + k2 * t.powi(4)));
    assert!((lens.focal_length_px().0 - f).abs() < 1e-9);
    let (cx, cy) = (0.5 * W as f64, 0.5 * H as f64);

    // 8 × 6 squares of 0.5 m, 10 m ahead, rolled 8° about the line of sight so that every edge
    // crosses the pixel grid at many phases (point-sampled pixels).
    let (cols, rows, s) = (8usize, 6usize, 0.5);
    let (roll, yaw) = (8f64.to_radians(), PI);
    // Board axes in the world: object +y and +z under p_world = Rz(yaw)·Rx(roll)·p_object.
    let a = DVec3::new(0.0, -roll.cos(), roll.sin());
    let b = DVec3::new(0.0, roll.sin(), roll.cos());
    let centre = DVec3::new(MOUNT[0] + 10.0, 0.0, 1.85);
    let mut boards = Vec::new();
    for i in 0..cols {
        for j in 0..rows {
            let p = centre + (i as f64 - 3.5) * s * a + (j as f64 - 2.5) * s * b;
            let mat = if (i + j) % 2 == 0 {
                "lambertian_5"
            } else {
                "lambertian_90"
            };
            boards.push(board(100 + (i * rows + j) as u64, p, roll, yaw, s, mat));
        }
    }
    // Sun behind the camera (west, 30° up) lights the board's face.
    let v = view(Vec::new(), boards, sun(PI / 2.0, 30f64.to_radians()), 0.0);
    let mut sensor = build_sensor(c.clone()).expect("physical camera");
    let out = run(sensor.as_mut(), &v);
    let lin = image(&out, Kind::RawHdrLinear);
    assert_eq!(lin.len(), 1);
    let raw = samples(lin[0]);
    let black = lin[0].black_level_dn.unwrap_or(0.0);
    assert_eq!(raw.len(), W * H);

    // 2 × 2 box sums (one R, two G, one B each): a luminance-like image whose sample (x, y) sits
    // at image position (x + 1, y + 1).
    let (lw, lh) = (W - 1, H - 1);
    let mut lum = vec![0.0; lw * lh];
    for y in 0..lh {
        for x in 0..lw {
            lum[y * lw + x] = raw[y * W + x]
                + raw[y * W + x + 1]
                + raw[(y + 1) * W + x]
                + raw[(y + 1) * W + x + 1]
                - 4.0 * black;
        }
    }
    let sample = |p: DVec2| bilinear(&lum, lw, lh, p.x - 1.0, p.y - 1.0);
    let cam = DVec3::from_array(MOUNT);
    let proj = |p: DVec3| opencv(p - cam, f, cx, cy, k1, k2);

    let mut worst = 0.0f64;
    let mut worst_pinhole = 0.0f64;
    let mut n_corners = 0;
    for i in 1..cols {
        for j in 1..rows {
            let corner = centre + (i as f64 - 4.0) * s * a + (j as f64 - 3.0) * s * b;
            let expect = proj(corner);
            let via_lens = lens
                .project((corner - cam).normalize())
                .expect("corner in the image");
            assert!(
                (via_lens - expect).length() < 0.01,
                "Lens::project vs OpenCV"
            );
            let pinhole = opencv(corner - cam, f, cx, cy, 0.0, 0.0);
            // Image directions of the two board edges through the corner.
            let ea = (proj(corner + 0.05 * a) - expect).normalize();
            let eb = (proj(corner + 0.05 * b) - expect).normalize();
            let side_px = (proj(corner + s * a) - expect).length();
            let mut lines = Vec::new();
            for (e, nrm) in [(ea, eb), (eb, ea)] {
                // Crossings of the mid level along profiles across the edge (direction ≈ the
                // other edge), at offsets 3 … side/2 − 2 px from the corner on both sides.
                let mut pts = Vec::new();
                let t_max = 0.5 * side_px - 2.0;
                let mut t = -t_max;
                while t <= t_max {
                    if t.abs() >= 3.0 {
                        let q = expect + t * e;
                        let prof: Vec<(f64, f64)> = (-24..=24)
                            .filter_map(|k| {
                                let sv = k as f64 * 0.25;
                                sample(q + sv * nrm).map(|v| (sv, v))
                            })
                            .collect();
                        if prof.len() == 49 {
                            let lo = prof.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
                            let hi = prof.iter().map(|p| p.1).fold(f64::NEG_INFINITY, f64::max);
                            let mid = 0.5 * (lo + hi);
                            let mut best: Option<f64> = None;
                            for w2 in prof.windows(2) {
                                let (d0, d1) = (w2[0].1 - mid, w2[1].1 - mid);
                                if d0 * d1 <= 0.0 && d0 != d1 {
                                    let sc = w2[0].0 + (w2[1].0 - w2[0].0) * d0 / (d0 - d1);
                                    if best.is_none_or(|b| sc.abs() < b.abs()) {
                                        best = Some(sc);
                                    }
                                }
                            }
                            if hi > 2.0 * lo.max(1.0)
                                && let Some(sc) = best
                            {
                                pts.push(q + sc * nrm);
                            }
                        }
                    }
                    t += 0.5;
                }
                assert!(pts.len() >= 10, "too few edge samples at corner ({i}, {j})");
                lines.push(fit_line(&pts));
            }
            let found = intersect(lines[0], lines[1]);
            worst = worst.max((found - expect).length());
            worst_pinhole = worst_pinhole.max((found - pinhole).length());
            n_corners += 1;
        }
    }
    eprintln!(
        "checkerboard: {n_corners} corners, worst error {worst:.3} px (vs the undistorted pinhole: {worst_pinhole:.2} px)"
    );
    assert!(worst <= 0.5, "corner error {worst} px");
    // The distortion is visible: the pinhole model misses some corners by more than 1 px.
    assert!(worst_pinhole > 1.0, "pinhole error only {worst_pinhole} px");
}

/// Depends on: renderer (sun disk radiance, `RenderOutput.sun`), lens (flare), pixel model
/// (saturation), HDR (capture sequence).
#[test]
fn backlit_sunset_saturates_where_the_sun_is_and_flare_adds_light() {
    // Sun 3° above the horizon straight ahead (east = +x: azimuth 3π/2).
    let (az, el) = (1.5 * PI, 3f64.to_radians());
    let dir = osiris_models::environment::sun::sun_direction(Some(&sun(az, el)));
    assert!((dir - DVec3::new(el.cos(), 0.0, el.sin())).length() < 1e-12);
    let cam = serde_json::json!({
        "exposure_s": 0.002,
        "emit": {"raw_exposures": true, "raw_hdr_linear": true, "raw_companded": false, "isp": false}
    });
    let v = view(Vec::new(), Vec::new(), sun(az, el), 0.0);
    let mut outputs = Vec::new();
    // The isotropic sky: the ring's background is then the sky's E_dhi/π, against which a 20 %
    // flare gain is the criterion (the CIE clear sky's circumsolar region is 5-10x brighter there
    // and dilutes the same flare to ≈ 8 %).
    for off in [
        &["env.sky_distribution"][..],
        &["env.sky_distribution", "camera.flare"][..],
    ] {
        let c = config(60.0, cam.clone(), off);
        let mut sensor = build_sensor(c.clone()).expect("physical camera");
        outputs.push((c, run(sensor.as_mut(), &v)));
    }
    let (c, out) = &outputs[0];
    let lens = lens_of(c);
    let s = lens.project(dir).expect("sun in the image");
    let pixel = c.camera.as_ref().unwrap().resolve().unwrap().pixel;
    let caps = image(out, Kind::RawExposure);
    assert!(!caps.is_empty());
    let longest = caps
        .iter()
        .max_by(|a, b| a.exposure_time_s.partial_cmp(&b.exposure_time_s).unwrap())
        .unwrap();
    let data = samples(longest);
    let max_dn = f64::from((1u32 << longest.bit_depth.unwrap()) - 1);
    let k = longest.conversion_gain_dn_per_e.unwrap();
    let sat = (pixel.full_well_e * k + longest.black_level_dn.unwrap()).min(max_dn);
    let (su, sv) = (s.x.floor() as usize, s.y.floor() as usize);
    for y in sv - 1..=sv + 1 {
        for x in su - 1..=su + 1 {
            let dn = data[y * W + x];
            assert!(
                dn >= 0.99 * sat,
                "pixel ({x}, {y}) at {dn} DN, saturation {sat} DN"
            );
        }
    }

    // Flare: the ring 6…40 px around the sun (clear of the disc) is brighter with the effect on.
    let ring = |out: &StepOutput| -> f64 {
        let lin = samples(image(out, Kind::RawHdrLinear)[0]);
        let mut sum = 0.0;
        for (i, v) in lin.iter().enumerate() {
            let r = DVec2::new((i % W) as f64 + 0.5, (i / W) as f64 + 0.5).distance(s);
            if (6.0..40.0).contains(&r) {
                sum += v;
            }
        }
        sum
    };
    let (on, off) = (ring(&outputs[0].1), ring(&outputs[1].1));
    eprintln!(
        "sunset: sun at ({:.1}, {:.1}) px; ring signal flare on {on:.3e}, off {off:.3e}",
        s.x, s.y
    );
    assert!(on > 1.2 * off, "flare on {on} vs off {off}");
}

/// Depends on: renderer (object mask, car radiance), lens, pixel, ISP (luminance), recognition.
#[test]
fn recognition_finds_a_car_at_20_m_within_5_percent() {
    // The car's rear face 20 m ahead of the vehicle origin (the camera is 1.9 m further forward).
    let rear_x = 20.0;
    let c = config(
        40.0,
        serde_json::json!({"recognition": {"random_draw": false}}),
        &[],
    );
    let v = view(
        vec![car(7, [rear_x + 2.25, 0.0, 0.75])],
        Vec::new(),
        sun(PI / 2.0, 40f64.to_radians()),
        0.0,
    );
    let mut sensor = build_sensor(c).expect("physical camera");
    let out = run(sensor.as_mut(), &v);
    let mo = &out.sensor_data.moving_object;
    assert_eq!(mo.len(), 1, "one detection expected: {mo:?}");
    let base = mo[0].base.as_ref().unwrap();
    let x = base.position.as_ref().unwrap().x.unwrap();
    let len = base
        .dimension
        .as_ref()
        .and_then(|d| d.length)
        .unwrap_or(0.0);
    // OSI SensorData objects are in the sensor frame.
    let rear = x - 0.5 * len;
    let rear_truth = rear_x - MOUNT[0];
    eprintln!("car: sensor-frame centre x {x:.2} m, rear {rear:.2} m (truth {rear_truth} m)");
    assert!((rear / rear_truth - 1.0).abs() < 0.05, "rear at {rear} m");

    let objs = &out.perception.camera.as_ref().unwrap().object;
    assert_eq!(objs.len(), 1);
    let o = &objs[0];
    assert_eq!(o.type_code, Some(2));
    assert!(o.screen_width_px.unwrap_or(0) > 0 && o.screen_height_px.unwrap_or(0) > 0);
    let d = o.longitudinal_distance_m.unwrap();
    let truth = rear_x - MOUNT[0];
    eprintln!("car: DIVP longitudinal distance {d:.2} m (truth {truth} m)");
    assert!(
        (d / truth - 1.0).abs() < 0.05,
        "DIVP distance {d} m vs {truth} m"
    );
}

/// Depends on: pixel (captures), HDR (merge, companding, knees), ISP (8-bit image).
#[test]
fn every_emitted_image_kind_has_the_right_size_and_format() {
    let v = view(
        vec![car(7, [30.0, 0.0, 0.75])],
        Vec::new(),
        sun(PI, 45f64.to_radians()),
        0.0,
    );
    let all = serde_json::json!({"emit": {
        "raw_exposures": true, "raw_hdr_linear": true, "raw_companded": true, "isp": true
    }});
    let mut sensor = build_sensor(config(60.0, all, &[])).expect("physical camera");
    let out = run(sensor.as_mut(), &v);
    let cam = out.perception.camera.as_ref().unwrap();
    let n = W * H;
    let check = |img: &perception::CameraImage, fmt: SampleFormat, bytes: usize, channels: u32| {
        assert_eq!(img.width_px, Some(W as u32));
        assert_eq!(img.height_px, Some(H as u32));
        assert_eq!(img.sample_format, Some(fmt as i32));
        assert_eq!(img.channels, Some(channels));
        assert_eq!(
            img.data.as_ref().map(Vec::len),
            Some(n * bytes * channels as usize)
        );
    };
    let exposures = image(&out, Kind::RawExposure);
    assert!(!exposures.is_empty());
    for (k, img) in exposures.iter().enumerate() {
        check(img, SampleFormat::U16Le, 2, 1);
        assert_eq!(img.cfa, Some(ColorFilterArray::CfaRggb as i32));
        assert_eq!(img.exposure_index, Some(k as u32));
        assert!(img.exposure_time_s.unwrap() > 0.0);
        assert!((8..=16).contains(&img.bit_depth.unwrap()));
    }
    // Captures are ordered from the most sensitive.
    for w in exposures.windows(2) {
        assert!(w[0].exposure_time_s.unwrap() >= w[1].exposure_time_s.unwrap());
    }
    let lin = image(&out, Kind::RawHdrLinear);
    assert_eq!(lin.len(), 1);
    check(lin[0], SampleFormat::U32Le, 4, 1);
    assert!((16..=24).contains(&lin[0].bit_depth.unwrap()));
    let comp = image(&out, Kind::RawHdrCompanded);
    assert_eq!(comp.len(), 1);
    check(comp[0], SampleFormat::U16Le, 2, 1);
    assert!((12..=16).contains(&comp[0].bit_depth.unwrap()));
    assert!(
        !comp[0].companding_knee.is_empty(),
        "companded RAW without knees"
    );
    let isp = image(&out, Kind::Isp);
    assert_eq!(isp.len(), 1);
    check(isp[0], SampleFormat::U8, 1, 3);
    assert_eq!(isp[0].cfa, Some(ColorFilterArray::CfaRgb as i32));
    assert_eq!(
        cam.image.len(),
        exposures.len() + 3,
        "no other images than the emitted ones"
    );

    // Defaults: the companded RAW and the ISP image only.
    let mut sensor = build_sensor(config(60.0, serde_json::json!({}), &[])).unwrap();
    let out = run(sensor.as_mut(), &v);
    let kinds: Vec<_> = out
        .perception
        .camera
        .as_ref()
        .unwrap()
        .image
        .iter()
        .map(|i| i.kind)
        .collect();
    assert_eq!(
        kinds,
        vec![Some(Kind::RawHdrCompanded as i32), Some(Kind::Isp as i32)]
    );
}

#[test]
fn lens_config_errors_reach_the_sensor_with_the_key() {
    let c = config(60.0, serde_json::json!({"lens": {"f_number": -2.0}}), &[]);
    match build_sensor(c) {
        Err(osiris_models::sensor::ModelError::Config(m)) => {
            assert!(m.contains("camera.lens.f_number"), "{m}")
        }
        Err(e) => panic!("{e:?}"),
        Ok(_) => panic!("negative f-number accepted"),
    }
    let _ = LensConfig::default();
}

/// Fresnel transmittance and reflectance of a slab (index n, internal transmittance τ_n at normal
/// incidence, τ(θ) = τ_n^{1/cos θt}) at incidence θ, unpolarised, incoherent multiple reflections:
/// written out here from the Fresnel equations, independently of the model.
fn slab(n: f64, tau_n: f64, cos_i: f64) -> (f64, f64) {
    let sin_i = (1.0 - cos_i * cos_i).sqrt();
    let sin_t = sin_i / n;
    let cos_t = (1.0 - sin_t * sin_t).sqrt();
    let rs = ((cos_i - n * cos_t) / (cos_i + n * cos_t)).powi(2);
    let rp = ((n * cos_i - cos_t) / (n * cos_i + cos_t)).powi(2);
    let tau = tau_n.powf(1.0 / cos_t);
    let (mut t, mut r) = (0.0, 0.0);
    for r1 in [rs, rp] {
        let den = 1.0 - r1 * r1 * tau * tau;
        t += 0.5 * (1.0 - r1).powi(2) * tau / den;
        r += 0.5 * (r1 + (1.0 - r1).powi(2) * tau * tau * r1 / den);
    }
    (t, r)
}

/// Depends on: renderer, windshield, lens, pixel (linear HDR output). A windshield inclined 28°
/// (normal (sin 28°, 0, cos 28°)) scales each pixel's linear signal by the slab transmittance at
/// its ray's incidence; the dashboard's veil adds R(θ)·L_dash, the same L_dash everywhere, so the
/// veil of two pixels is in the ratio of their reflectances.
#[test]
fn windshield_transmits_and_reflects_the_dashboard_per_the_fresnel_slab() {
    let v = view(
        vec![car(7, [20.0, 0.0, 0.75])],
        Vec::new(),
        sun(1.5 * PI, 30f64.to_radians()),
        0.0,
    );
    let quiet = [
        "camera.shot_noise",
        "camera.read_noise",
        "camera.dark_current",
        "camera.dsnu",
        "camera.prnu",
        "camera.flare",
        "camera.psf_blur",
        // The veil is added before the lens: vignetting would scale it per pixel and the
        // distortion move it off the pixel whose ray it was computed for.
        "camera.vignetting",
        "camera.distortion",
    ];
    let linear = |windshield: bool, off: &[&str]| -> (Vec<f64>, SensorConfig) {
        let mut cam = serde_json::json!({
            "exposure_s": 0.0005,
            "emit": {"raw_hdr_linear": true, "raw_exposures": false, "raw_companded": false, "isp": false}
        });
        if windshield {
            cam["windshield"] = serde_json::json!({});
        }
        let off: Vec<&str> = quiet.iter().chain(off).copied().collect();
        let c = config(60.0, cam, &off);
        let mut s = build_sensor(c.clone()).expect("camera");
        let out = run(s.as_mut(), &v);
        let img = image(&out, Kind::RawHdrLinear)[0];
        let black = img.black_level_dn.unwrap_or(0.0);
        (samples(img).iter().map(|d| d - black).collect(), c)
    };
    let (plain, c) = linear(false, &[]);
    let (through, _) = linear(
        true,
        &[
            "camera.windshield_refraction",
            "camera.dashboard_reflection",
        ],
    );
    let (veiled, _) = linear(
        true,
        &[
            "camera.windshield_refraction",
            "camera.windshield_transmission",
        ],
    );
    let rays = lens_of(&c).ray_directions().to_vec();
    let a = 28f64.to_radians();
    let n = DVec3::new(a.sin(), 0.0, a.cos());
    // Sky (top rows), car, road: pixels with signal well above zero.
    let mut checked = 0;
    for (x, y) in [
        (160, 20),
        (40, 30),
        (290, 25),
        (160, 125),
        (60, 200),
        (270, 210),
    ] {
        let i = y * W + x;
        if plain[i] < 50.0 {
            continue;
        }
        let cos_i = rays[i].as_dvec3().normalize().dot(n);
        let (t, _) = slab(1.52, 0.88, cos_i);
        let got = through[i] / plain[i];
        assert!(
            (got / t - 1.0).abs() < 0.02,
            "pixel ({x}, {y}), incidence {:.1}°: signal ratio {got:.4}, slab T {t:.4}",
            cos_i.acos().to_degrees()
        );
        checked += 1;
    }
    assert!(checked >= 4, "{checked} pixels checked");
    // The veil: meas − plain = R(θ)·L_dash·gain for pixels whose mirror ray points down.
    let veil = |x: usize, y: usize| {
        let i = y * W + x;
        let d = rays[i].as_dvec3().normalize();
        (veiled[i] - plain[i], slab(1.52, 0.88, d.dot(n)).1)
    };
    // Two road pixels far apart, of the same CFA colour (even x, even y; the sky is bright enough
    // to change the HDR merge's capture).
    let (v1, r1) = veil(40, 214);
    let (v2, r2) = veil(280, 150);
    assert!(v1 > 0.0 && v2 > 0.0, "veil {v1} {v2}");
    assert!(
        ((v1 / v2) / (r1 / r2) - 1.0).abs() < 0.05,
        "veil ratio {:.4}, reflectance ratio {:.4}",
        v1 / v2,
        r1 / r2
    );
}

/// Depends on: renderer, windshield, recognition, feature-data output. A windshield with an 8 mrad
/// wedge turns a ray at elevation e up by δ(e) = w·(√(n² − sin²θ)/cos θ − 1), θ = 62° − e (written
/// out here; 0.75° on the axis, more below it), so each edge of the car's detection box comes out
/// lower by the δ of its elevation. A camera calibrated through the same glass
/// (`calibrated_through`) takes the axis' δ(0) into its orientation: its box is lower only by the
/// rest, δ(e) − δ(0), and its ground-plane distance much nearer the glass-free one.
#[test]
fn windshield_wedge_lowers_the_detections_unless_calibrated_through_the_glass() {
    let v = view(
        vec![car(7, [22.25, 0.0, 0.75])],
        Vec::new(),
        sun(PI / 2.0, 40f64.to_radians()),
        0.0,
    );
    // (box edge elevations deg, DIVP distance m) of the one detection.
    let detect = |windshield: Option<serde_json::Value>| -> ([f64; 2], f64) {
        let mut cam = serde_json::json!({"recognition": {"random_draw": false}});
        if let Some(w) = windshield {
            cam["windshield"] = w;
        }
        let c = config(40.0, cam, &["camera.distortion", "camera.motion_blur"]);
        let mut s = build_sensor(c).expect("camera");
        let out = run(s.as_mut(), &v);
        let fd = out.sensor_data.feature_data.as_ref().expect("feature data");
        let cd = &fd.camera_sensor[0];
        assert_eq!(cd.detection.len(), 1, "one detection: {:?}", cd.detection);
        let el = |k: usize| {
            cd.point[k]
                .point
                .as_ref()
                .unwrap()
                .elevation
                .unwrap()
                .to_degrees()
        };
        let d = out.perception.camera.as_ref().unwrap().object[0]
            .longitudinal_distance_m
            .unwrap();
        ([el(0), el(1)], d)
    };
    let (n, w) = (1.52f64, 8e-3);
    let delta = |e_deg: f64| {
        let th = (62.0 - e_deg).to_radians();
        (w * ((n * n - th.sin().powi(2)).sqrt() / th.cos() - 1.0)).to_degrees()
    };
    let centre = |e: [f64; 2]| 0.5 * (e[0] + e[1]);
    let (plain, d_plain) = detect(None);
    let (wedged, d_wedged) = detect(Some(serde_json::json!({"wedge_mrad": 8.0})));
    let (calibrated, d_cal) = detect(Some(
        serde_json::json!({"wedge_mrad": 8.0, "calibrated_through": true}),
    ));
    let want = 0.5 * (delta(plain[0]) + delta(plain[1]));
    eprintln!(
        "box centre elevation: plain {:.3}°, wedge {:.3}°, calibrated {:.3}° (δ at the edges \
         {want:.3}°, on the axis {:.3}°); distance {d_plain:.2} / {d_wedged:.2} / {d_cal:.2} m",
        centre(plain),
        centre(wedged),
        centre(calibrated),
        delta(0.0)
    );
    let px = 40.0 / W as f64;
    let shift = centre(plain) - centre(wedged);
    assert!((shift - want).abs() < px, "shift {shift:.3}° vs {want:.3}°");
    let rest = centre(plain) - centre(calibrated);
    assert!(
        (rest - (want - delta(0.0))).abs() < px,
        "calibrated: shift {rest:.3}° vs {:.3}°",
        want - delta(0.0)
    );
    // Uncalibrated, the lowered box bottom reads as a nearer ground contact; calibrated, most of
    // that error is gone.
    assert!(d_wedged < d_plain - 1.0, "{d_wedged} vs {d_plain}");
    assert!(
        (d_cal - d_plain).abs() < 0.5 * (d_wedged - d_plain).abs(),
        "{d_cal} vs {d_plain} (uncalibrated {d_wedged})"
    );
}
