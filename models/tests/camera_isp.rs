//! Tests of the camera ISP (`osiris_models::camera::isp`): black level, demosaic, white balance,
//! colour correction fitted from the spectral response, tone mapping and sRGB encoding. The
//! expectations are independent: the IEC 61966-2-1 formula, exact interpolation of smooth
//! gradients, and the true linear sRGB of test reflectances integrated here against the CIE 1931
//! colour-matching functions.

use osiris_models::camera::isp::{
    CIE1931_XYZ_10NM, ColourCorrection, D65_10NM, Demosaic, Isp, IspConfig, ToneMap, WhiteBalance,
    XYZ_TO_LINEAR_SRGB, demosaic, tone_curve, tone_curve_f32,
};
use osiris_models::camera::{
    BLUE, Cfa, ChannelImage, GREEN, RED, RawImage, RgbImage, SpectralBands, SpectralResponse,
};

/// A plausible RGB sensor: Gaussian CFA × QE curves (peaks 600 / 535 / 455 nm, σ 40 / 40 / 30 nm),
/// 10 nm bands from 400 to 700 nm, weights in e⁻·nm/J up to an arbitrary scale.
fn response() -> SpectralResponse {
    let bands = SpectralBands::uniform(395.0, 705.0, 31);
    let g = |mu: f64, s: f64, peak: f64| -> Vec<f64> {
        bands
            .centres_nm
            .iter()
            .map(|&l| peak * (-0.5 * ((l - mu) / s).powi(2)).exp() * l * 1e15)
            .collect()
    };
    SpectralResponse {
        weights: [
            g(600.0, 40.0, 0.45),
            g(535.0, 40.0, 0.6),
            g(455.0, 30.0, 0.5),
        ],
        bands,
    }
}

/// Table value at `nm` (380 + 10 k nm grid: the band centres of `response()` lie on it).
fn d65(nm: f64) -> f64 {
    D65_10NM[((nm - 380.0) / 10.0).round() as usize]
}

fn cmf(nm: f64) -> [f64; 3] {
    CIE1931_XYZ_10NM[((nm - 380.0) / 10.0).round() as usize]
}

/// IEC 61966-2-1:1999 sRGB encoding.
fn iec_encode(l: f64) -> f64 {
    if l <= 0.0031308 {
        12.92 * l
    } else {
        1.055 * l.powf(1.0 / 2.4) - 0.055
    }
}

/// A mosaic with `value[channel]` DN above `black` at every pixel.
fn flat_raw(w: usize, h: usize, cfa: Cfa, black: f64, value: [f64; 3]) -> RawImage {
    let mut data = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            data.push((black + value[cfa.channel(x, y)]).round() as u32);
        }
    }
    RawImage {
        width: w,
        height: h,
        data,
        bit_depth: 24,
        black_level_dn: black,
        conversion_gain_dn_per_e: 1.0,
        exposure_time_s: 0.01,
        analog_gain: 1.0,
        ..Default::default()
    }
}

#[test]
fn d65_white_point_from_the_embedded_tables() {
    // CIE 015: D65 chromaticity x = 0.31272, y = 0.32903 (2° observer).
    let mut xyz = [0.0; 3];
    for k in 0..41 {
        for c in 0..3 {
            xyz[c] += D65_10NM[k] * CIE1931_XYZ_10NM[k][c];
        }
    }
    let s = xyz[0] + xyz[1] + xyz[2];
    let (x, y) = (xyz[0] / s, xyz[1] / s);
    println!("D65 at 10 nm: x = {x:.5}, y = {y:.5}");
    assert!((x - 0.31272).abs() < 5e-4 && (y - 0.32903).abs() < 5e-4);
    // ∫ȳ dλ = 106.857 (CIE 1931, 1 nm table): the 10 nm sum × 10 nm is within 0.1 %.
    let ysum: f64 = CIE1931_XYZ_10NM.iter().map(|v| v[1]).sum::<f64>() * 10.0;
    assert!((ysum - 106.857).abs() < 0.1, "{ysum}");
}

#[test]
fn neutral_flat_field_gives_r_equal_g_equal_b() {
    let resp = response();
    // Fixed gains: channel DN chosen so that the white-balanced electrons are equal.
    let gains = [2.0, 1.0, 1.5];
    for tone in [ToneMap::Reinhard, ToneMap::Filmic, ToneMap::Clip] {
        for ccm in [ColourCorrection::Fitted, ColourCorrection::Identity] {
            let config = IspConfig {
                white_balance: WhiteBalance::Fixed,
                wb_gains: gains,
                colour_correction: ccm,
                tone_map: tone,
                ..Default::default()
            };
            let mut isp = Isp::new(&config, Cfa::Rggb, &resp).unwrap();
            let x = 6000.0;
            let raw = flat_raw(32, 24, Cfa::Rggb, 256.0, [x / 2.0, x, x / 1.5]);
            let mut out = RgbImage::default();
            let mut lum = Vec::new();
            isp.process(&raw, &mut out, &mut lum);
            assert_eq!(out.data.len(), 32 * 24 * 3);
            for p in out.data.chunks(3) {
                assert_eq!(p[0], p[1], "{tone:?} {ccm:?}: {p:?}");
                assert_eq!(p[1], p[2], "{tone:?} {ccm:?}: {p:?}");
            }
            // Relative luminance of a neutral = its white-balanced level (BT.709 weights sum to 1).
            for &y in &lum {
                assert!((y as f64 - x).abs() < 1e-3 * x, "{y}");
            }
            // Automatic exposure maps the (uniform) log-average to the key 0.18.
            if tone == ToneMap::Clip {
                let expect = (255.0 * iec_encode(0.18)).round() as u8;
                assert!(
                    out.data[0].abs_diff(expect) <= 1,
                    "{} vs {expect}",
                    out.data[0]
                );
            }
        }
    }
    // Daylight preset: gains from the response under D65, computed here independently.
    let white: Vec<f64> = (0..3)
        .map(|c| {
            resp.weights[c]
                .iter()
                .zip(&resp.bands.centres_nm)
                .map(|(w, &l)| w * d65(l))
                .sum()
        })
        .collect();
    let expect = [white[GREEN] / white[RED], 1.0, white[GREEN] / white[BLUE]];
    let config = IspConfig::default();
    let mut isp = Isp::new(&config, Cfa::Rggb, &resp).unwrap();
    let g = isp.white_balance_gains();
    for c in 0..3 {
        assert!(
            (g[c] - expect[c]).abs() < 1e-9 * expect[c],
            "{g:?} vs {expect:?}"
        );
    }
    // A D65-lit white reflector (channel signals ∝ white[c]) comes out neutral (±1 code).
    let scale = 2.0e5 / white[GREEN];
    let raw = flat_raw(
        16,
        16,
        Cfa::Rggb,
        64.0,
        [
            scale * white[RED],
            scale * white[GREEN],
            scale * white[BLUE],
        ],
    );
    let (mut out, mut lum) = (RgbImage::default(), Vec::new());
    isp.process(&raw, &mut out, &mut lum);
    for p in out.data.chunks(3) {
        assert!(
            p[0].abs_diff(p[1]) <= 1 && p[1].abs_diff(p[2]) <= 1,
            "{p:?}"
        );
    }
}

#[test]
fn srgb_encoding_matches_iec_61966_2_1() {
    let resp = response();
    let config = IspConfig {
        white_balance: WhiteBalance::None,
        colour_correction: ColourCorrection::Identity,
        tone_map: ToneMap::Clip,
        exposure_scale: Some(1.0 / 10_000.0),
        ..Default::default()
    };
    let mut isp = Isp::new(&config, Cfa::Rggb, &resp).unwrap();
    let (mut out, mut lum) = (RgbImage::default(), Vec::new());
    // Linear levels 0 … 1.2 (the last clips), including the linear segment below 0.0031308.
    for dn in [
        0.0, 5.0, 20.0, 31.0, 40.0, 100.0, 500.0, 1000.0, 2140.0, 5000.0, 7500.0, 10_000.0,
        12_000.0,
    ] {
        let raw = flat_raw(8, 8, Cfa::Rggb, 100.0, [dn; 3]);
        isp.process(&raw, &mut out, &mut lum);
        let l = (dn / 10_000.0f64).min(1.0);
        let expect = 255.0 * iec_encode(l);
        for &v in &out.data {
            assert!(
                (v as f64 - expect).abs() <= 0.5 + 1e-6,
                "linear {l}: {v} vs {expect:.3}"
            );
        }
    }
    // Published anchor: linear 0.5 → 0.7354 (188 of 255).
    assert!((osiris_models::camera::isp::srgb_encode(0.5) - 0.735_36).abs() < 1e-4);
    assert!((osiris_models::camera::isp::srgb_decode(0.735_36) - 0.5).abs() < 1e-4);
}

#[test]
fn black_level_is_subtracted() {
    let resp = response();
    let config = IspConfig {
        white_balance: WhiteBalance::None,
        colour_correction: ColourCorrection::Identity,
        tone_map: ToneMap::Clip,
        exposure_scale: Some(1.0 / 4000.0),
        ..Default::default()
    };
    let mut isp = Isp::new(&config, Cfa::Rggb, &resp).unwrap();
    let (mut out, mut lum) = (RgbImage::default(), Vec::new());
    // At the black level: zero signal, black image.
    let raw = flat_raw(8, 8, Cfa::Rggb, 4096.0, [0.0; 3]);
    isp.process(&raw, &mut out, &mut lum);
    assert!(out.data.iter().all(|&v| v == 0));
    assert!(lum.iter().all(|&y| y == 0.0));
    // The same signal above two different black levels gives the same output.
    let mut images = Vec::new();
    for black in [0.0, 168.0, 4096.0] {
        let raw = flat_raw(8, 8, Cfa::Rggb, black, [1000.0; 3]);
        isp.process(&raw, &mut out, &mut lum);
        assert!(lum.iter().all(|&y| (y - 1000.0).abs() < 1e-2), "{}", lum[0]);
        images.push(out.data.clone());
    }
    assert_eq!(images[0], images[1]);
    assert_eq!(images[0], images[2]);
    // Below the black level (noise): clipped at zero, never wraps.
    let mut raw = flat_raw(8, 8, Cfa::Rggb, 200.0, [0.0; 3]);
    raw.data.iter_mut().for_each(|v| *v = 150);
    isp.process(&raw, &mut out, &mut lum);
    assert!(out.data.iter().all(|&v| v == 0));
}

#[test]
fn demosaic_of_smooth_gradients_is_exact_inside() {
    let (w, h) = (64, 48);
    let field = |c: usize, x: f64, y: f64| -> f64 {
        match c {
            RED => 1000.0 + 7.0 * x + 3.0 * y + 40.0 * (x / 15.0).sin(),
            GREEN => 2000.0 - 4.0 * x + 6.0 * y + 30.0 * (y / 12.0).cos(),
            _ => 500.0 + 2.0 * x - 1.5 * y + 25.0 * ((x + y) / 20.0).sin(),
        }
    };
    for cfa in [Cfa::Rggb, Cfa::Bggr, Cfa::Grbg, Cfa::Gbrg] {
        let mut mosaic = vec![0.0f32; w * h];
        for y in 0..h {
            for x in 0..w {
                mosaic[y * w + x] = field(cfa.channel(x, y), x as f64, y as f64) as f32;
            }
        }
        for method in [Demosaic::Bilinear, Demosaic::Malvar] {
            let mut out = ChannelImage::default();
            demosaic(&mosaic, w, h, cfa, method, &mut out);
            let mut worst = 0.0f64;
            for y in 2..h - 2 {
                for x in 2..w - 2 {
                    for c in 0..3 {
                        let e =
                            (out.planes[c][y * w + x] as f64 - field(c, x as f64, y as f64)).abs();
                        worst = worst.max(e);
                    }
                }
            }
            println!("{cfa:?} {method:?}: worst error inside {worst:.3} DN");
            assert!(worst < 1.0, "{cfa:?} {method:?}: {worst}");
        }
        // A pure linear ramp is reproduced to float precision by both methods.
        let mut ramp = vec![0.0f32; w * h];
        for y in 0..h {
            for x in 0..w {
                ramp[y * w + x] = (100.0 + 5.0 * x as f64 + 2.0 * y as f64) as f32;
            }
        }
        for method in [Demosaic::Bilinear, Demosaic::Malvar] {
            let mut out = ChannelImage::default();
            demosaic(&ramp, w, h, cfa, method, &mut out);
            for y in 2..h - 2 {
                for x in 2..w - 2 {
                    for c in 0..3 {
                        let e = out.planes[c][y * w + x] as f64
                            - (100.0 + 5.0 * x as f64 + 2.0 * y as f64);
                        assert!(e.abs() < 1e-2, "{cfa:?} {method:?} ({x},{y}) c{c}: {e}");
                    }
                }
            }
        }
    }
}

/// True linear sRGB (D65 white = 1) of a reflectance, integrated here.
fn true_srgb(bands: &[f64], refl: &[f64]) -> [f64; 3] {
    let mut xyz = [0.0; 3];
    let mut wy = 0.0;
    for (&l, &r) in bands.iter().zip(refl) {
        let (e, m) = (d65(l), cmf(l));
        for c in 0..3 {
            xyz[c] += e * r * m[c];
        }
        wy += e * m[1];
    }
    std::array::from_fn(|row| {
        (0..3)
            .map(|k| XYZ_TO_LINEAR_SRGB[row][k] * xyz[k] / wy)
            .sum()
    })
}

#[test]
fn fitted_ccm_maps_camera_responses_to_true_linear_srgb() {
    let resp = response();
    let bands = resp.bands.centres_nm.clone();
    // Test reflectances, not in the training set: Gaussians, edges and a two-peak spectrum.
    let mut tests: Vec<Vec<f64>> = Vec::new();
    let sample = |f: &dyn Fn(f64) -> f64| bands.iter().map(|&l| f(l)).collect::<Vec<f64>>();
    for (mu, s) in [
        (435.0, 35.0),
        (490.0, 30.0),
        (525.0, 40.0),
        (575.0, 35.0),
        (615.0, 45.0),
        (650.0, 30.0),
    ] {
        tests.push(sample(&|l| {
            0.1 + 0.6 * (-0.5 * ((l - mu) / s).powi(2)).exp()
        }));
    }
    for l0 in [500.0, 580.0, 620.0] {
        tests.push(sample(&|l| 0.08 + 0.7 / (1.0 + (-(l - l0) / 20.0).exp())));
        tests.push(sample(&|l| 0.08 + 0.7 / (1.0 + ((l - l0) / 20.0).exp())));
    }
    tests.push(sample(&|l| {
        0.1 + 0.5 * (-0.5 * ((l - 450.0) / 25.0).powi(2)).exp()
            + 0.5 * (-0.5 * ((l - 640.0) / 30.0).powi(2)).exp()
    }));
    tests.push(sample(&|_| 0.35));

    let rms = |ccm: ColourCorrection| -> f64 {
        let config = IspConfig {
            colour_correction: ccm,
            ..Default::default()
        };
        let isp = Isp::new(&config, Cfa::Rggb, &resp).unwrap();
        let m = isp.ccm();
        let g = isp.white_balance_gains();
        let white: Vec<f64> = (0..3)
            .map(|c| {
                resp.weights[c]
                    .iter()
                    .zip(&bands)
                    .map(|(w, &l)| w * d65(l))
                    .sum()
            })
            .collect();
        let mut sum = 0.0;
        for r in &tests {
            let cam: Vec<f64> = (0..3)
                .map(|c| {
                    let s: f64 = resp.weights[c]
                        .iter()
                        .zip(&bands)
                        .zip(r)
                        .map(|((w, &l), r)| w * d65(l) * r)
                        .sum();
                    s * g[c] / white[GREEN]
                })
                .collect();
            let t = true_srgb(&bands, r);
            for row in 0..3 {
                let v: f64 = (0..3).map(|k| m[row][k] * cam[k]).sum();
                sum += (v - t[row]).powi(2);
            }
        }
        (sum / (3 * tests.len()) as f64).sqrt()
    };
    let fitted = rms(ColourCorrection::Fitted);
    let identity = rms(ColourCorrection::Identity);
    println!("linear sRGB RMS error: fitted CCM {fitted:.4}, identity {identity:.4}");
    // Test colours have linear sRGB values up to ≈ 0.7: the fitted matrix is within 0.03 RMS
    // (a few per cent of full scale) and much better than no correction.
    assert!(fitted < 0.03, "{fitted}");
    assert!(fitted < 0.5 * identity);
    // White-preserving: every row sums to 1.
    let isp = Isp::new(&IspConfig::default(), Cfa::Rggb, &resp).unwrap();
    for row in isp.ccm() {
        assert!((row.iter().sum::<f64>() - 1.0).abs() < 1e-9);
    }
}

#[test]
fn tone_map_is_monotonic() {
    for mode in [ToneMap::Reinhard, ToneMap::Filmic, ToneMap::Clip] {
        let mut last = -1.0;
        for i in 0..=20_000 {
            let x = i as f64 * 1e-3;
            let y = tone_curve(mode, 4.0, x);
            // The per-pixel f32 path agrees with the f64 curve far below one 8-bit step.
            let y32 = f64::from(tone_curve_f32(mode, 4.0, x as f32));
            assert!(
                (y32 - y).abs() < 1e-5,
                "{mode:?} at {x}: f32 {y32} vs f64 {y}"
            );
            assert!(y >= last, "{mode:?} at {x}");
            assert!((0.0..=1.0).contains(&y));
            last = y;
        }
        assert_eq!(tone_curve(mode, 4.0, 0.0), 0.0);
    }
    // Reinhard 2002 eq. 4 reaches 1 exactly at the white point, and x/(1+x) far below it.
    assert!((tone_curve(ToneMap::Reinhard, 4.0, 4.0) - 1.0).abs() < 1e-12);
    assert!((tone_curve(ToneMap::Reinhard, 1e6, 1.0) - 0.5).abs() < 1e-9);
    // Through the whole ISP: brighter flat fields never give darker pixels.
    let resp = response();
    for tone in [ToneMap::Reinhard, ToneMap::Filmic] {
        let config = IspConfig {
            tone_map: tone,
            exposure_scale: Some(1e-4),
            ..Default::default()
        };
        let mut isp = Isp::new(&config, Cfa::Rggb, &resp).unwrap();
        let (mut out, mut lum) = (RgbImage::default(), Vec::new());
        let mut last = [0u8; 3];
        for k in 0..60 {
            let dn = 10.0 * 1.25f64.powi(k);
            let raw = flat_raw(4, 4, Cfa::Rggb, 0.0, [dn; 3]);
            isp.process(&raw, &mut out, &mut lum);
            let p = [out.data[15], out.data[16], out.data[17]];
            for c in 0..3 {
                assert!(p[c] >= last[c], "{tone:?}: {p:?} after {last:?}");
            }
            last = p;
        }
    }
}

#[test]
fn bad_config_names_the_key() {
    let resp = response();
    let config = IspConfig {
        exposure_key: 0.0,
        ..Default::default()
    };
    let e = Isp::new(&config, Cfa::Rggb, &resp)
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("camera.isp.exposure_key"), "{e}");
    let config = IspConfig {
        wb_gains: [1.0, -1.0, 1.0],
        ..Default::default()
    };
    assert!(
        config
            .validate()
            .unwrap_err()
            .to_string()
            .contains("camera.isp.wb_gains")
    );
    let c: IspConfig = serde_json::from_str(
        r#"{"demosaic": "bilinear", "white_balance": "auto", "tone_map": "filmic"}"#,
    )
    .unwrap();
    assert_eq!(c.demosaic, Demosaic::Bilinear);
    assert!(serde_json::from_str::<IspConfig>(r#"{"gamma": 2.2}"#).is_err());
}

#[test]
fn saturated_highlights_stay_neutral() {
    let resp = response();
    let mut isp = Isp::new(&IspConfig::default(), Cfa::Rggb, &resp).unwrap();
    let g = isp.white_balance_gains();
    assert!(
        g[RED] > 1.05 || g[BLUE] > 1.05,
        "test needs unequal gains: {g:?}"
    );
    // Every channel at full scale (a clipped sun / headlamp) in a darker surround.
    let mut raw = flat_raw(32, 32, Cfa::Rggb, 64.0, [500.0, 1000.0, 700.0]);
    raw.bit_depth = 16;
    for y in 8..24 {
        for x in 8..24 {
            raw.data[y * 32 + x] = raw.max_dn();
        }
    }
    let (mut out, mut lum) = (RgbImage::default(), Vec::new());
    isp.process(&raw, &mut out, &mut lum);
    for y in 10..22 {
        for x in 10..22 {
            let p = &out.data[3 * (y * 32 + x)..3 * (y * 32 + x) + 3];
            assert!(p[0] == p[1] && p[1] == p[2], "({x},{y}): {p:?}");
        }
    }
}
