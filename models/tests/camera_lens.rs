//! Lens model tests (`osiris_models::camera::lens`): projection and distortion against an independent
//! implementation of the OpenCV formulas, the camera equation and cos⁴ vignetting from the pinhole
//! geometry, the PSF's energy and second moment, flare ghost geometry, configuration errors.

use std::f64::consts::PI;

use glam::{DVec2, DVec3};
use osiris_models::camera::SunInView;
use osiris_models::camera::lens::{
    GhostConfig, GhostShape, IlluminationAxis, Lens, LensConfig, LensModel, RelativeIllumination,
};
use osiris_models::camera::{ChannelImage, Flicker, FlickerSample};
use osiris_models::effects::Effects;
use osiris_models::registry::catalogue;
use osiris_models::sensor::ModelError;

const PITCH: f64 = 3.0e-6;

fn effects(off: &[&str]) -> Effects {
    let mut e = Effects::new(&catalogue());
    for name in off {
        e.set(name, false).expect("known effect");
    }
    e
}

/// A lens without distortion coefficients (pinhole geometry).
fn pinhole_config() -> LensConfig {
    LensConfig {
        k1: 0.0,
        k2: 0.0,
        ..LensConfig::default()
    }
}

/// Independent OpenCV `projectPoints` (rational + tangential model) for a sensor-frame direction
/// (x forward, y left, z up) → (u, v).
fn opencv_project(d: DVec3, fx: f64, fy: f64, cx: f64, cy: f64, k: [f64; 6], p: [f64; 2]) -> DVec2 {
    // Camera frame of OpenCV: X right, Y down, Z forward.
    let (xc, yc, zc) = (-d.y, -d.z, d.x);
    let x = xc / zc;
    let y = yc / zc;
    let r2 = x * x + y * y;
    let r4 = r2 * r2;
    let r6 = r4 * r2;
    let radial =
        (1.0 + k[0] * r2 + k[1] * r4 + k[2] * r6) / (1.0 + k[3] * r2 + k[4] * r4 + k[5] * r6);
    let xpp = x * radial + 2.0 * p[0] * x * y + p[1] * (r2 + 2.0 * x * x);
    let ypp = y * radial + p[0] * (r2 + 2.0 * y * y) + 2.0 * p[1] * x * y;
    DVec2::new(fx * xpp + cx, fy * ypp + cy)
}

/// Independent OpenCV `fisheye::projectPoints` (Kannala–Brandt, no skew).
fn kb_project(d: DVec3, fx: f64, fy: f64, cx: f64, cy: f64, k: [f64; 4]) -> DVec2 {
    let (xc, yc, zc) = (-d.y, -d.z, d.x);
    let r = (xc * xc + yc * yc).sqrt();
    let theta = r.atan2(zc);
    let t2 = theta * theta;
    let td = theta * (1.0 + k[0] * t2 + k[1] * t2 * t2 + k[2] * t2.powi(3) + k[3] * t2.powi(4));
    let (a, b) = if r > 0.0 {
        (td * xc / r, td * yc / r)
    } else {
        (0.0, 0.0)
    };
    DVec2::new(fx * a + cx, fy * b + cy)
}

fn uniform_image(w: usize, h: usize, value: f32) -> ChannelImage {
    let mut img = ChannelImage::new(w, h);
    for p in &mut img.planes {
        p.iter_mut().for_each(|v| *v = value);
    }
    img
}

#[test]
fn effects_are_declared_in_the_catalogue() {
    let names: Vec<_> = catalogue().iter().map(|e| e.name).collect();
    for n in [
        "camera.vignetting",
        "camera.distortion",
        "camera.psf_blur",
        "camera.flare",
    ] {
        assert!(names.contains(&n), "{n} missing from the catalogue");
    }
}

#[test]
fn focal_length_from_fov_focal_length_m_and_px() {
    let fov = 60f64.to_radians();
    let lens = Lens::new(&pinhole_config(), 64, 48, PITCH, fov, &effects(&[])).unwrap();
    let f = 32.0 / (fov / 2.0).tan();
    assert!((lens.focal_length_px().0 - f).abs() < 1e-9);
    assert!((lens.focal_length_px().1 - f).abs() < 1e-9);
    assert_eq!(lens.principal_point_px(), (32.0, 24.0));

    let c = LensConfig {
        focal_length_m: Some(6e-3),
        principal_point_offset_px: [1.5, -2.0],
        ..pinhole_config()
    };
    let lens = Lens::new(&c, 64, 48, PITCH, fov, &effects(&[])).unwrap();
    assert!((lens.focal_length_px().0 - 2000.0).abs() < 1e-6);
    assert_eq!(lens.principal_point_px(), (33.5, 22.0));

    let c = LensConfig {
        fx_px: Some(500.0),
        fy_px: Some(510.0),
        focal_length_m: Some(6e-3),
        ..pinhole_config()
    };
    let lens = Lens::new(&c, 64, 48, PITCH, fov, &effects(&[])).unwrap();
    assert_eq!(lens.focal_length_px(), (500.0, 510.0));

    // With distortion the FoV edge ray (through the principal point's row) is at fov/2.
    let c = LensConfig {
        k1: -0.2,
        k2: 0.03,
        ..LensConfig::default()
    };
    let lens = Lens::new(&c, 64, 48, PITCH, fov, &effects(&[])).unwrap();
    let d = lens.unproject(DVec2::new(0.0, 24.0)).unwrap();
    let angle = d.x.acos();
    assert!((angle - fov / 2.0).abs() < 1e-9, "edge ray at {angle} rad");
}

#[test]
fn relative_illumination_is_cos4_of_the_pinhole_field_angle() {
    let (w, h) = (64, 48);
    let fov = 70f64.to_radians();
    let lens = Lens::new(&pinhole_config(), w, h, PITCH, fov, &effects(&[])).unwrap();
    let f = 0.5 * w as f64 / (fov / 2.0).tan();
    let ri = lens.relative_illumination();
    let mut min = 1.0f64;
    for y in 0..h {
        for x in 0..w {
            let a = (x as f64 + 0.5 - 32.0) / f;
            let b = (y as f64 + 0.5 - 24.0) / f;
            let cos2 = 1.0 / (1.0 + a * a + b * b);
            let expect = cos2 * cos2;
            let got = f64::from(ri[y * w + x]);
            assert!(
                (got / expect - 1.0).abs() < 1e-3,
                "pixel ({x}, {y}): {got} vs cos⁴θ = {expect}"
            );
            min = min.min(got);
        }
    }
    // The corner of a 70° × 54.6° image is at θ ≈ 40.3°: cos⁴ ≈ 0.34.
    assert!(min < 0.36 && min > 0.32, "corner RI {min}");

    // Off: 1 everywhere.
    let lens = Lens::new(
        &pinhole_config(),
        w,
        h,
        PITCH,
        fov,
        &effects(&["camera.vignetting"]),
    )
    .unwrap();
    assert!(lens.relative_illumination().iter().all(|&v| v == 1.0));
}

#[test]
fn relative_illumination_table_multiplies_cos4() {
    let (w, h) = (40, 30);
    let fov = 60f64.to_radians();
    let base = Lens::new(&pinhole_config(), w, h, PITCH, fov, &effects(&[])).unwrap();
    for axis in [
        IlluminationAxis::FieldAngleRad,
        IlluminationAxis::ImageHeight,
    ] {
        let points = match axis {
            IlluminationAxis::FieldAngleRad => vec![[0.0, 1.0], [0.3, 0.9], [0.6, 0.5]],
            IlluminationAxis::ImageHeight => vec![[0.0, 1.0], [0.5, 0.95], [1.0, 0.7]],
        };
        let table = |x: f64| -> f64 {
            // Independent piecewise-linear interpolation.
            let p = &points;
            if x <= p[0][0] {
                return p[0][1];
            }
            for i in 1..p.len() {
                if x <= p[i][0] {
                    let t = (x - p[i - 1][0]) / (p[i][0] - p[i - 1][0]);
                    return p[i - 1][1] * (1.0 - t) + p[i][1] * t;
                }
            }
            p[p.len() - 1][1]
        };
        let c = LensConfig {
            relative_illumination: Some(RelativeIllumination {
                axis,
                points: points.clone(),
            }),
            ..pinhole_config()
        };
        let lens = Lens::new(&c, w, h, PITCH, fov, &effects(&[])).unwrap();
        let f = lens.focal_length_px().0;
        let half_diag = 0.5 * ((w * w + h * h) as f64).sqrt();
        for y in 0..h {
            for x in 0..w {
                let (du, dv) = (x as f64 + 0.5 - 20.0, y as f64 + 0.5 - 15.0);
                let abscissa = match axis {
                    IlluminationAxis::FieldAngleRad => (du.hypot(dv) / f).atan(),
                    IlluminationAxis::ImageHeight => du.hypot(dv) / half_diag,
                };
                let i = y * w + x;
                let ratio = f64::from(lens.relative_illumination()[i])
                    / f64::from(base.relative_illumination()[i]);
                assert!(
                    (ratio - table(abscissa)).abs() < 1e-5,
                    "{axis:?} ({x}, {y}): {ratio} vs {}",
                    table(abscissa)
                );
            }
        }
    }
}

#[test]
fn camera_equation_at_the_centre() {
    let (w, h) = (32, 24);
    let c = LensConfig {
        f_number: 1.8,
        transmittance: 0.85,
        ..pinhole_config()
    };
    let fov = 50f64.to_radians();
    let lens = Lens::new(&c, w, h, PITCH, fov, &effects(&["camera.psf_blur"])).unwrap();
    let l = 1.0e19f32;
    let mut img = uniform_image(w, h, l);
    let mut flicker = Flicker {
        samples: vec![FlickerSample {
            pixel: (12 * w + 16) as u32,
            value: [l; 3],
            source: 0,
        }],
        sources: Vec::new(),
    };
    lens.apply(&mut img, &mut flicker, None);
    let f = 0.5 * w as f64 / (fov / 2.0).tan();
    let k = PI / 4.0 * 0.85 / (1.8 * 1.8) * PITCH * PITCH;
    assert!((lens.throughput_m2_sr() / k - 1.0).abs() < 1e-12);
    // Pixel (16, 12): centre at (16.5, 12.5), 0.5 px off the axis in u and v.
    let cos2 = 1.0 / (1.0 + 2.0 * (0.5 / f).powi(2));
    let expect = k * f64::from(l) * cos2 * cos2;
    for ch in 0..3 {
        let got = f64::from(img.planes[ch][12 * w + 16]);
        assert!((got / expect - 1.0).abs() < 1e-5, "{got} vs {expect}");
    }
    let got = f64::from(flicker.samples[0].value[1]);
    assert!(
        (got / expect - 1.0).abs() < 1e-5,
        "flicker {got} vs {expect}"
    );
    // Scale: a white board in daylight, L ≈ 1e19 e⁻ s⁻¹ m⁻² sr⁻¹ (≈ 30 W m⁻² sr⁻¹ visible at
    // ≈ 2.8e18 photons/J, QE × filter ≈ 0.15), gives ≈ 1.9e7 e⁻/s at f/1.8, 3 µm: a 10 000 e⁻
    // full well in ≈ 0.5 ms.
    assert!(expect > 1e7 && expect < 3e7, "{expect}");
}

#[test]
fn checkerboard_corners_land_where_the_opencv_formula_says() {
    let (w, h) = (320, 240);
    let k = [-0.21, 0.06, -0.004, 0.02, -0.003, 0.001];
    let p = [0.0012, -0.0007];
    let c = LensConfig {
        k1: k[0],
        k2: k[1],
        k3: k[2],
        k4: k[3],
        k5: k[4],
        k6: k[5],
        p1: p[0],
        p2: p[1],
        principal_point_offset_px: [3.2, -1.7],
        ..LensConfig::default()
    };
    let lens = Lens::new(&c, w, h, PITCH, 60f64.to_radians(), &effects(&[])).unwrap();
    let (fx, fy) = lens.focal_length_px();
    let (cx, cy) = lens.principal_point_px();
    // A 0.25 m checkerboard on the plane 5 m ahead, 13 × 9 corners, tilted by 10° about z.
    let mut worst_proj = 0.0f64;
    let mut worst_back = 0.0f64;
    let mut max_distortion = 0.0f64;
    let (s, yaw) = (0.25, 10f64.to_radians());
    for i in -6..=6 {
        for j in -4..=4 {
            let lateral = i as f64 * s;
            let point = DVec3::new(5.0 + lateral * yaw.sin(), lateral * yaw.cos(), j as f64 * s);
            let d = point.normalize();
            let expect = opencv_project(d, fx, fy, cx, cy, k, p);
            let pinhole = opencv_project(d, fx, fy, cx, cy, [0.0; 6], [0.0; 2]);
            max_distortion = max_distortion.max((expect - pinhole).length());
            let got = lens.project(d).expect("corner in the image");
            worst_proj = worst_proj.max((got - expect).length());
            // The ray of that image point points at the corner.
            let back = lens.unproject(got).unwrap();
            let re = opencv_project(back, fx, fy, cx, cy, k, p);
            worst_back = worst_back.max((re - expect).length());
            assert!(back.angle_between(d) < 1e-6);
        }
    }
    assert!(worst_proj <= 0.01, "project error {worst_proj} px");
    assert!(worst_back <= 0.01, "re-projection error {worst_back} px");
    // The distortion matters (several px at the board's corners).
    assert!(max_distortion > 3.0, "distortion only {max_distortion} px");

    // Every pixel's ray re-projects onto its centre.
    let mut worst = 0.0f64;
    for (n, r) in lens.ray_directions().iter().enumerate() {
        let (x, y) = (n % w, n / w);
        let uv = opencv_project(r.as_dvec3(), fx, fy, cx, cy, k, p);
        worst = worst.max((uv - DVec2::new(x as f64 + 0.5, y as f64 + 0.5)).length());
        assert!((r.length() - 1.0).abs() < 1e-6);
    }
    // f32 directions: ≈ 6e-8 rad × f ≈ 2e-5 px.
    assert!(worst <= 0.01, "ray_directions re-projection {worst} px");

    // Distortion off: the same focal length, pinhole projection.
    let lens_off = Lens::new(
        &c,
        w,
        h,
        PITCH,
        60f64.to_radians(),
        &effects(&["camera.distortion"]),
    )
    .unwrap();
    assert_eq!(lens_off.focal_length_px(), (fx, fy));
    let d = DVec3::new(5.0, 1.2, -0.8).normalize();
    let got = lens_off.project(d).unwrap();
    let expect = opencv_project(d, fx, fy, cx, cy, [0.0; 6], [0.0; 2]);
    assert!((got - expect).length() < 1e-9);
    // Behind the camera: None.
    assert!(lens.project(DVec3::new(-1.0, 0.0, 0.0)).is_none());
}

#[test]
fn undistortion_converges_at_the_corners_of_a_strong_barrel_lens() {
    let (w, h) = (320, 240);
    let k = [-0.3, 0.0, 0.0, 0.0, 0.0, 0.0];
    let c = LensConfig {
        k1: -0.3,
        k2: 0.0,
        ..LensConfig::default()
    };
    let lens = Lens::new(&c, w, h, PITCH, 50f64.to_radians(), &effects(&[])).unwrap();
    let (fx, fy) = lens.focal_length_px();
    let (cx, cy) = lens.principal_point_px();
    for (x, y) in [(0, 0), (w - 1, 0), (0, h - 1), (w - 1, h - 1)] {
        let r = lens.ray_directions()[y * w + x].as_dvec3();
        let uv = opencv_project(r, fx, fy, cx, cy, k, [0.0; 2]);
        let err = (uv - DVec2::new(x as f64 + 0.5, y as f64 + 0.5)).length();
        assert!(err < 1e-4 * 20.0, "corner ({x}, {y}): {err} px");
        // In double precision the inversion itself is far below 1e-4 px.
        let exact = lens.unproject(DVec2::new(x as f64, y as f64)).unwrap();
        let e2 = (opencv_project(exact, fx, fy, cx, cy, k, [0.0; 2])
            - DVec2::new(x as f64, y as f64))
        .length();
        assert!(e2 < 1e-4, "corner ({x}, {y}) exact: {e2} px");
    }
    // Barrel: corners see wider than the pinhole of the same focal length.
    let corner = lens.unproject(DVec2::new(0.0, 0.0)).unwrap();
    let pin = DVec3::new(1.0, cx / fx, cy / fy).normalize();
    assert!(corner.x < pin.x);

    // A wider FoV where k1 = −0.3 folds back before the corners: a config error naming the key.
    let err = Lens::new(&c, w, h, PITCH, 90f64.to_radians(), &effects(&[]))
        .err()
        .expect("folding distortion must be refused");
    match err {
        ModelError::Config(m) => assert!(m.contains("camera.lens.k1"), "{m}"),
        other => panic!("{other:?}"),
    }
}

#[test]
fn kannala_brandt_fisheye_round_trip() {
    let (w, h) = (200, 160);
    let k = [0.02, -0.005, 0.001, 0.0];
    let c = LensConfig {
        model: LensModel::KannalaBrandt,
        fisheye_k: k,
        ..LensConfig::default()
    };
    let fov = 190f64.to_radians();
    let lens = Lens::new(&c, w, h, PITCH, fov, &effects(&[])).unwrap();
    let (fx, fy) = lens.focal_length_px();
    let (cx, cy) = lens.principal_point_px();
    let mut worst = 0.0f64;
    for (n, r) in lens.ray_directions().iter().enumerate() {
        let uv = kb_project(r.as_dvec3(), fx, fy, cx, cy, k);
        let want = DVec2::new((n % w) as f64 + 0.5, (n / w) as f64 + 0.5);
        worst = worst.max((uv - want).length());
    }
    assert!(worst < 0.01, "{worst} px");
    // A direction 92° off the axis (behind the image plane) is still imaged.
    let d = DVec3::new((92f64).to_radians().cos(), (92f64).to_radians().sin(), 0.0);
    let p = lens.project(d).expect("fisheye sees beyond 90°");
    assert!((p - kb_project(d, fx, fy, cx, cy, k)).length() < 1e-9);
    assert!(p.x < 5.0);
}

#[test]
fn psf_conserves_energy_and_spreads_with_sigma() {
    let (w, h) = (64, 48);
    let sigma = 1.5;
    let c = LensConfig {
        psf_sigma_px: sigma,
        psf_diffraction: false,
        ..pinhole_config()
    };
    let lens = Lens::new(
        &c,
        w,
        h,
        PITCH,
        60f64.to_radians(),
        &effects(&["camera.vignetting"]),
    )
    .unwrap();
    assert!((lens.psf_sigma_px() - sigma).abs() < 1e-12);
    let k = lens.throughput_m2_sr();

    // A deterministic pseudo-random image including bright edge pixels.
    let mut img = ChannelImage::new(w, h);
    let mut state = 12345u64;
    for p in &mut img.planes {
        for v in p.iter_mut() {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            *v = ((state >> 33) as f64 / (1u64 << 31) as f64) as f32;
        }
        p[0] = 50.0;
        p[w * h - 1] = 80.0;
    }
    let before: Vec<f64> = img
        .planes
        .iter()
        .map(|p| p.iter().map(|&v| f64::from(v)).sum::<f64>() * k)
        .collect();
    lens.apply(&mut img, &mut Flicker::default(), None);
    for (ch, p) in img.planes.iter().enumerate() {
        let after: f64 = p.iter().map(|&v| f64::from(v)).sum();
        assert!(
            (after / before[ch] - 1.0).abs() < 1e-4,
            "channel {ch}: {after} vs {}",
            before[ch]
        );
    }

    // A point source spreads with second moment σ² per axis.
    let mut img = ChannelImage::new(w, h);
    let (x0, y0) = (30usize, 20usize);
    img.planes[1][y0 * w + x0] = 1.0;
    lens.apply(&mut img, &mut Flicker::default(), None);
    let p = &img.planes[1];
    let total: f64 = p.iter().map(|&v| f64::from(v)).sum();
    let (mut mx, mut my) = (0.0, 0.0);
    for (i, &v) in p.iter().enumerate() {
        let (x, y) = ((i % w) as f64 - x0 as f64, (i / w) as f64 - y0 as f64);
        mx += f64::from(v) * x * x;
        my += f64::from(v) * y * y;
    }
    let (sx, sy) = ((mx / total).sqrt(), (my / total).sqrt());
    assert!((sx / sigma - 1.0).abs() < 0.01, "σ_x {sx}");
    assert!((sy / sigma - 1.0).abs() < 0.01, "σ_y {sy}");
    assert!((total / k - 1.0).abs() < 1e-5);

    // Off: no spread.
    let lens = Lens::new(
        &c,
        w,
        h,
        PITCH,
        60f64.to_radians(),
        &effects(&["camera.psf_blur"]),
    )
    .unwrap();
    let mut img = ChannelImage::new(w, h);
    img.planes[1][y0 * w + x0] = 1.0;
    lens.apply(&mut img, &mut Flicker::default(), None);
    assert_eq!(img.planes[1].iter().filter(|&&v| v != 0.0).count(), 1);

    // Diffraction adds σ = 0.42 λ N / pitch in quadrature (λ = 550 nm, N = 8, 3 µm: 0.616 px).
    let c = LensConfig {
        psf_sigma_px: 0.5,
        psf_diffraction: true,
        psf_wavelength_nm: 550.0,
        f_number: 8.0,
        ..pinhole_config()
    };
    let lens = Lens::new(&c, w, h, PITCH, 60f64.to_radians(), &effects(&[])).unwrap();
    let diff = 0.42 * 550e-9 * 8.0 / PITCH;
    assert!((lens.psf_sigma_px() - (0.25f64 + diff * diff).sqrt()).abs() < 1e-12);
}

fn sun_at(u: f64, v: f64, lens: &Lens) -> SunInView {
    SunInView {
        direction_sensor: lens.unproject(DVec2::new(u, v)).unwrap(),
        radiance: [1e18, 2e18, 1e18],
        // Solar disc: 0.2665° radius.
        solid_angle_sr: PI * (0.2665f64.to_radians()).powi(2),
    }
}

#[test]
fn flare_ghosts_lie_on_the_sun_centre_line_only_with_the_effect() {
    let (w, h) = (160, 120);
    let ghost_r = 0.05;
    let c = LensConfig {
        veiling_glare_fraction: 0.0,
        halo_fraction: 0.0,
        ghosts: vec![
            GhostConfig {
                ratio: -1.0,
                radius_rel: ghost_r,
                strength: 1e-3,
                shape: GhostShape::Disc,
            },
            GhostConfig {
                ratio: 0.5,
                radius_rel: ghost_r,
                strength: 1e-3,
                shape: GhostShape::Hexagon,
            },
        ],
        ..pinhole_config()
    };
    let fov = 60f64.to_radians();
    let lens = Lens::new(&c, w, h, PITCH, fov, &effects(&["camera.psf_blur"])).unwrap();
    let (cx, cy) = lens.principal_point_px();
    let f = lens.focal_length_px().0;
    let half_diag = 0.5 * ((w * w + h * h) as f64).sqrt();
    let (su, sv) = (130.0, 30.0);
    let sun = sun_at(su, sv, &lens);

    let mut img = ChannelImage::new(w, h);
    lens.apply(&mut img, &mut Flicker::default(), Some(&sun));
    // Expected ghost level: P·strength/(πR²), P = (π/4)(T/N²)A·f²·L·Ω·cos⁴θ_sun.
    let a = (su - cx) / f;
    let b = (sv - cy) / f;
    let cos2 = 1.0 / (1.0 + a * a + b * b);
    let p_green = lens.throughput_m2_sr() * f * f * 2e18 * sun.solid_angle_sr * cos2 * cos2;
    let r = ghost_r * half_diag;
    let disc_level = p_green * 1e-3 / (PI * r * r);
    let hex_level = p_green * 1e-3 / (1.5 * 3f64.sqrt() * r * r);
    let at = |u: f64, v: f64| f64::from(img.planes[1][v as usize * w + u as usize]);
    // Mirrored through the centre (ratio −1) and half-way to the sun (ratio 0.5).
    let g1 = (2.0 * cx - su, 2.0 * cy - sv);
    let g2 = (cx + 0.5 * (su - cx), cy + 0.5 * (sv - cy));
    assert!((at(g1.0, g1.1) / disc_level - 1.0).abs() < 1e-4);
    assert!((at(g2.0, g2.1) / hex_level - 1.0).abs() < 1e-4);
    // Nothing off the line (perpendicular to it, at twice the ghost radius from g1).
    let dir = DVec2::new(su - cx, sv - cy).normalize();
    let perp = DVec2::new(-dir.y, dir.x) * 2.0 * r;
    assert_eq!(at(g1.0 + perp.x, g1.1 + perp.y), 0.0);
    // Every lit pixel lies within a ghost radius of the line through the sun and the centre.
    for (i, &v) in img.planes[1].iter().enumerate() {
        if v > 0.0 {
            let q = DVec2::new((i % w) as f64 + 0.5 - cx, (i / w) as f64 + 0.5 - cy);
            let dist = (q.x * dir.y - q.y * dir.x).abs();
            assert!(dist <= r + 1e-9, "lit pixel {i} at {dist} px from the line");
        }
    }
    // Total ghost power ≈ 2·strength·P (pixel-discretised shapes: within 10 %).
    let total: f64 = img.planes[1].iter().map(|&v| f64::from(v)).sum();
    assert!((total / (2e-3 * p_green) - 1.0).abs() < 0.1, "{total}");

    // Effect off: no light.
    let lens_off = Lens::new(
        &c,
        w,
        h,
        PITCH,
        fov,
        &effects(&["camera.psf_blur", "camera.flare"]),
    )
    .unwrap();
    let mut img = ChannelImage::new(w, h);
    lens_off.apply(&mut img, &mut Flicker::default(), Some(&sun));
    assert!(img.planes.iter().all(|p| p.iter().all(|&v| v == 0.0)));

    // Sun just outside the right border (within the margin): ghosts still appear, weaker; far
    // outside the margin: none.
    let near = sun_at(w as f64 + 10.0, 60.0, &lens);
    let mut img = ChannelImage::new(w, h);
    lens.apply(&mut img, &mut Flicker::default(), Some(&near));
    let lit: f64 = img.planes[1].iter().map(|&v| f64::from(v)).sum();
    assert!(lit > 0.0);
    let far = sun_at(w as f64 + 0.6 * half_diag + 5.0, 60.0, &lens);
    let mut img = ChannelImage::new(w, h);
    lens.apply(&mut img, &mut Flicker::default(), Some(&far));
    assert!(img.planes.iter().all(|p| p.iter().all(|&v| v == 0.0)));
}

#[test]
fn veil_and_halo_carry_their_fractions() {
    let (w, h) = (200, 160);
    let c = LensConfig {
        veiling_glare_fraction: 0.01,
        halo_fraction: 0.02,
        halo_radius_rel: 0.01,
        ghosts: Vec::new(),
        ..pinhole_config()
    };
    let lens = Lens::new(
        &c,
        w,
        h,
        PITCH,
        40f64.to_radians(),
        &effects(&["camera.psf_blur"]),
    )
    .unwrap();
    let sun = sun_at(100.0, 80.0, &lens);
    let (power, s) = lens.sun_power(&sun).unwrap();
    assert!((s - DVec2::new(100.0, 80.0)).length() < 1e-9);
    let mut img = ChannelImage::new(w, h);
    lens.apply(&mut img, &mut Flicker::default(), Some(&sun));
    let total: f64 = img.planes[0].iter().map(|&v| f64::from(v)).sum();
    // Veil 1 % in full; the halo core a = 1.28 px around the centre: the fraction of the kernel
    // (1+r²/a²)^(−3/2)/(2πa²) inside radius R is 1 − 1/√(1+R²/a²) ≈ 1 − a/R: ≥ 97 % within 80 px.
    let expect_lo = power[0] * (0.01 + 0.02 * 0.97);
    let expect_hi = power[0] * (0.01 + 0.02);
    assert!(
        total > expect_lo && total < expect_hi * 1.001,
        "{total} vs {expect_lo}..{expect_hi}"
    );
    // Veil is uniform: a far corner gets ≈ P·0.01/(w·h) plus a small halo tail.
    let corner = f64::from(img.planes[0][0]);
    let veil = power[0] * 0.01 / (w * h) as f64;
    assert!(corner > veil && corner < 1.05 * veil, "{corner} vs {veil}");
}

#[test]
fn bad_configs_name_the_key() {
    let cases: Vec<(LensConfig, &str)> = vec![
        (
            LensConfig {
                f_number: 0.0,
                ..LensConfig::default()
            },
            "camera.lens.f_number",
        ),
        (
            LensConfig {
                transmittance: 1.5,
                ..LensConfig::default()
            },
            "camera.lens.transmittance",
        ),
        (
            LensConfig {
                k3: f64::NAN,
                ..LensConfig::default()
            },
            "camera.lens.k3",
        ),
        (
            LensConfig {
                psf_sigma_px: -1.0,
                ..LensConfig::default()
            },
            "camera.lens.psf_sigma_px",
        ),
        (
            LensConfig {
                relative_illumination: Some(RelativeIllumination {
                    axis: IlluminationAxis::FieldAngleRad,
                    points: vec![[0.2, 1.0], [0.1, 0.9]],
                }),
                ..LensConfig::default()
            },
            "camera.lens.relative_illumination.points",
        ),
        (
            LensConfig {
                ghosts: vec![GhostConfig {
                    radius_rel: 0.0,
                    ..GhostConfig::default()
                }],
                ..LensConfig::default()
            },
            "camera.lens.ghosts",
        ),
        (
            LensConfig {
                focal_length_m: Some(-1.0),
                ..LensConfig::default()
            },
            "camera.lens.focal_length_m",
        ),
    ];
    for (c, key) in cases {
        match c.validate() {
            Err(ModelError::Config(m)) => assert!(m.contains(key), "{m} should name {key}"),
            other => panic!("{key}: {other:?}"),
        }
        assert!(Lens::new(&c, 64, 48, PITCH, 1.0, &effects(&[])).is_err());
    }
    // JSON: unknown keys are refused, absent keys take the defaults.
    assert!(serde_json::from_str::<LensConfig>(r#"{"f_numbr": 2}"#).is_err());
    let c: LensConfig = serde_json::from_str(r#"{"f_number": 1.6, "k1": -0.1}"#).unwrap();
    assert_eq!(c.f_number, 1.6);
    assert_eq!(c.transmittance, LensConfig::default().transmittance);
    c.validate().unwrap();
}
