//! Tests of the camera's spectral response, EMVA 1288 pixel model and HDR pipeline
//! (`osiris_models::camera::{spectral, pixel, hdr}`) against independent expectations:
//! numeric integrals of the spectral response, the EMVA 1288 photon-transfer method (physics.md
//! §3.1), dark-signal and non-uniformity measurements as EMVA 1288 prescribes them, the PWM
//! on-fraction of an LED over a row's window, and the linearity of the HDR merge (physics.md §3.3).

use osiris_models::camera::hdr::{HdrConfig, HdrMode, HdrPipeline};
use osiris_models::camera::pixel::{ExposureSpec, PixelConfig, PixelModel};
use osiris_models::camera::spectral::{HC_J_M, SpectralConfig};
use osiris_models::camera::{
    CameraPreset, ChannelImage, Flicker, FlickerSample, GREEN, PwmSource, RawImage, ShutterTiming,
    SpectralBands,
};
use osiris_models::effects::Effects;
use osiris_models::registry::catalogue;
use osiris_models::sensor::ModelError;

fn effects_off(off: &[&str]) -> Effects {
    let mut e = Effects::new(&catalogue());
    for name in off {
        e.set(name, false).unwrap();
    }
    e
}

const NOISE: [&str; 5] = [
    "camera.shot_noise",
    "camera.read_noise",
    "camera.dark_current",
    "camera.dsnu",
    "camera.prnu",
];

fn flat(w: usize, h: usize, rate: f32) -> ChannelImage {
    let mut img = ChannelImage::new(w, h);
    for p in &mut img.planes {
        p.fill(rate);
    }
    img
}

fn timing(frame_time_s: f64) -> ShutterTiming {
    ShutterTiming {
        frame_time_s,
        row_time_s: 0.0,
        start_offset_s: 0.0,
        exposure_s: 0.01,
    }
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

fn var(v: &[f64]) -> f64 {
    let m = mean(v);
    v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (v.len() - 1) as f64
}

fn as_f64(raw: &RawImage) -> Vec<f64> {
    raw.data.iter().map(|&v| f64::from(v)).collect()
}

/// Expose one frame.
fn shot(
    model: &PixelModel,
    rate: &ChannelImage,
    spec: &ExposureSpec,
    temperature_c: f64,
    seed: u64,
) -> RawImage {
    let mut raw = RawImage::default();
    model.expose(
        rate,
        &Flicker::default(),
        spec,
        &timing(0.0),
        temperature_c,
        seed,
        &mut raw,
    );
    raw
}

/// Temporal variance from two frames: var(a − b)/2, and the mean of both.
fn temporal(a: &RawImage, b: &RawImage) -> (f64, f64) {
    let d: Vec<f64> = a
        .data
        .iter()
        .zip(&b.data)
        .map(|(&x, &y)| f64::from(x) - f64::from(y))
        .collect();
    let m = 0.5 * (mean(&as_f64(a)) + mean(&as_f64(b)));
    (m, var(&d) / 2.0)
}

/// Average of `n` frames per pixel.
fn average(
    model: &PixelModel,
    rate: &ChannelImage,
    spec: &ExposureSpec,
    temperature_c: f64,
    n: u64,
) -> Vec<f64> {
    let mut acc = vec![0.0; rate.len()];
    for k in 0..n {
        let raw = shot(model, rate, spec, temperature_c, 1000 + k);
        for (a, &v) in acc.iter_mut().zip(&raw.data) {
            *a += f64::from(v) / n as f64;
        }
    }
    acc
}

// ---------------------------------------------------------------------------------------------
// Spectral response
// ---------------------------------------------------------------------------------------------

/// Composite Simpson integral of `f` over [a, b] with `n` (even) intervals.
fn simpson(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    let h = (b - a) / n as f64;
    let mut s = f(a) + f(b);
    for i in 1..n {
        s += f(a + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
    }
    s * h / 3.0
}

#[test]
fn spectral_weights_match_numeric_integral() {
    let cfg = SpectralConfig::default();
    let bands = SpectralBands::uniform(380.0, 780.0, 16);
    let resp = cfg.response(&bands).unwrap();
    for c in 0..3 {
        for (k, &centre) in bands.centres_nm.iter().enumerate() {
            let half = 0.5 * bands.width_nm;
            // ∫ η_c(λ) λ/(hc) dλ over the band [e⁻ nm J⁻¹].
            let exact = simpson(
                |nm| cfg.efficiency(c, nm) * nm * 1e-9 / HC_J_M,
                centre - half,
                centre + half,
                2000,
            );
            let w = resp.weights[c][k];
            assert!(
                (w - exact).abs()
                    <= 1e-3 * exact + 1e-6 * resp.weights[c].iter().cloned().fold(0.0, f64::max),
                "channel {c} band {k}: {w} vs {exact}"
            );
        }
    }
    // A flat spectrum of 1 W m⁻² sr⁻¹ nm⁻¹ gives Σ w = ∫ η λ/(hc) dλ over 380–780 nm.
    let flat = vec![1.0; bands.len()];
    let lc = resp.apply(&flat);
    for (c, l) in lc.iter().enumerate() {
        let exact = simpson(
            |nm| cfg.efficiency(c, nm) * nm * 1e-9 / HC_J_M,
            380.0,
            780.0,
            4000,
        );
        assert!((l / exact - 1.0).abs() < 1e-3, "channel {c}");
    }
}

#[test]
fn spectral_measured_table_closed_form() {
    // η_c(λ) = a_c + b_c λ on 300–900 nm: ∫(a + bλ)λ dλ = a(λ₂² − λ₁²)/2 + b(λ₂³ − λ₁³)/3.
    let coef = [(0.1, 4e-4), (0.5, 0.0), (0.6, -5e-4)];
    let table: Vec<[f64; 4]> = (0..=12)
        .map(|i| {
            let nm = 300.0 + 50.0 * i as f64;
            [
                nm,
                coef[0].0 + coef[0].1 * nm,
                coef[1].0 + coef[1].1 * nm,
                coef[2].0 + coef[2].1 * nm,
            ]
        })
        .collect();
    let cfg = SpectralConfig {
        measured: Some(table),
        ..SpectralConfig::default()
    };
    cfg.validate().unwrap();
    let bands = SpectralBands::uniform(400.0, 700.0, 6);
    let resp = cfg.response(&bands).unwrap();
    for (c, &(a, b)) in coef.iter().enumerate() {
        for (k, &centre) in bands.centres_nm.iter().enumerate() {
            let (l1, l2) = (centre - 25.0, centre + 25.0);
            let integral_nm2 = a * (l2 * l2 - l1 * l1) / 2.0 + b * (l2.powi(3) - l1.powi(3)) / 3.0;
            let exact = integral_nm2 * 1e-9 / HC_J_M;
            let w = resp.weights[c][k];
            assert!(
                (w / exact - 1.0).abs() < 1e-9,
                "channel {c} band {k}: {w} vs {exact}"
            );
        }
    }
}

#[test]
fn spectral_default_shape_is_an_rggb_sensor_with_ir_cut() {
    let cfg = SpectralConfig::default();
    let peak = |c: usize| {
        (380..=780)
            .map(|nm| (nm, cfg.efficiency(c, nm as f64)))
            .fold((0, 0.0), |a, b| if b.1 > a.1 { b } else { a })
    };
    let (r, g, b) = (peak(0), peak(1), peak(2));
    assert!((585..=625).contains(&r.0), "red peak {} nm", r.0);
    assert!((515..=545).contains(&g.0), "green peak {} nm", g.0);
    assert!((445..=475).contains(&b.0), "blue peak {} nm", b.0);
    // Peak QE of the channels of a BSI sensor with IR cut: 0.3–0.7.
    for (c, p) in [r, g, b].iter().enumerate() {
        assert!((0.3..0.7).contains(&p.1), "channel {c} peak η {}", p.1);
    }
    // IR cut: the red response at 750 nm is below 2 % of its peak; without the filter it is not.
    assert!(cfg.efficiency(0, 750.0) < 0.02 * r.1);
    let no_ir = SpectralConfig {
        ir_cut: false,
        ..SpectralConfig::default()
    };
    assert!(no_ir.efficiency(0, 750.0) > 0.2 * r.1);
}

#[test]
fn spectral_bad_config_names_the_key() {
    let cfg = SpectralConfig {
        qe_peak: 1.5,
        ..SpectralConfig::default()
    };
    match cfg.validate() {
        Err(ModelError::Config(m)) => assert!(m.contains("camera.spectral.qe_peak"), "{m}"),
        other => panic!("{other:?}"),
    }
    let cfg = SpectralConfig {
        measured: Some(vec![[500.0, 0.1, 0.1, 0.1], [400.0, 0.1, 0.1, 0.1]]),
        ..SpectralConfig::default()
    };
    match cfg.validate() {
        Err(ModelError::Config(m)) => assert!(m.contains("camera.spectral.measured"), "{m}"),
        other => panic!("{other:?}"),
    }
    let r: Result<SpectralConfig, _> = serde_json::from_str(r#"{"qe_peek": 0.5}"#);
    assert!(r.is_err(), "unknown keys are rejected");
}

// ---------------------------------------------------------------------------------------------
// Pixel: photon transfer, dark signal, non-uniformities
// ---------------------------------------------------------------------------------------------

const N: usize = 256;

#[test]
fn photon_transfer_gives_conversion_gain_and_read_noise() {
    let cfg = PixelConfig::default();
    let model = PixelModel::new(&cfg, N, N, &effects_off(&[]), 7).unwrap();
    let t = 0.01;
    let spec = model.base_exposure(t);
    // −40 °C: the dark shot noise is negligible (2^(−65/6.5) of 25.6 e⁻/s).
    let temp = -40.0;
    let dark = flat(N, N, 0.0);
    let (mu_dark, var_dark) = temporal(
        &shot(&model, &dark, &spec, temp, 1),
        &shot(&model, &dark, &spec, temp, 2),
    );
    // Flat-field sweep up to 70 % of the full well.
    let mut xs = Vec::new();
    let mut ys = Vec::new();
    for level in 1..=14 {
        let electrons = 500.0 * level as f64;
        let rate = flat(N, N, (electrons / t) as f32);
        let a = shot(&model, &rate, &spec, temp, 100 + level);
        let b = shot(&model, &rate, &spec, temp, 200 + level);
        let (m, v) = temporal(&a, &b);
        xs.push(m - mu_dark);
        ys.push(v - var_dark);
    }
    // Least-squares slope through the origin of σ²_y − σ²_y,dark vs μ_y − μ_y,dark (EMVA 1288).
    let k =
        xs.iter().zip(&ys).map(|(x, y)| x * y).sum::<f64>() / xs.iter().map(|x| x * x).sum::<f64>();
    let k_true = cfg.conversion_gain_dn_per_e;
    assert!(
        (k / k_true - 1.0).abs() < 0.05,
        "K = {k} DN/e⁻, configured {k_true}"
    );
    // Read noise from the dark temporal variance: σ_d = √(σ²_y,dark − 1/12)/K.
    let read = (var_dark - 1.0 / 12.0).sqrt() / k;
    assert!(
        (read / cfg.read_noise_e - 1.0).abs() < 0.05,
        "read noise {read} e⁻, configured {}",
        cfg.read_noise_e
    );
    eprintln!(
        "PTC: K = {k:.4} DN/e⁻ (config {k_true}), read noise {read:.3} e⁻ (config {})",
        cfg.read_noise_e
    );
    // The dark level is the black level.
    assert!(
        (mu_dark - cfg.black_level_dn).abs() < 0.1,
        "dark mean {mu_dark}"
    );
}

#[test]
fn dark_frames_give_dark_current_doubling_and_dsnu() {
    let cfg = PixelConfig {
        dsnu_e: 3.0,
        ..PixelConfig::default()
    };
    let model = PixelModel::new(&cfg, N, N, &effects_off(&[]), 11).unwrap();
    let dark = flat(N, N, 0.0);
    let k = cfg.conversion_gain_dn_per_e;
    let mut currents = Vec::new();
    for temp in [25.0, 45.0] {
        let (t1, t2) = (0.1, 1.0);
        let m1 = mean(&as_f64(&shot(
            &model,
            &dark,
            &model.base_exposure(t1),
            temp,
            5,
        )));
        let m2 = mean(&as_f64(&shot(
            &model,
            &dark,
            &model.base_exposure(t2),
            temp,
            6,
        )));
        let current = (m2 - m1) / k / (t2 - t1);
        let expected = 25.6 * 2f64.powf((temp - 25.0) / 6.5);
        assert!(
            (current / expected - 1.0).abs() < 0.05,
            "{temp} °C: {current} e⁻/s vs {expected}"
        );
        currents.push(current);
    }
    let doubling = 20.0 / (currents[1] / currents[0]).log2();
    assert!((doubling / 6.5 - 1.0).abs() < 0.05, "doubling {doubling} K");
    eprintln!(
        "dark current {:.2} / {:.2} e⁻/s, doubling {doubling:.2} K",
        currents[0], currents[1]
    );

    // DSNU: spatial variance of the average of M dark frames, less the temporal part.
    let spec = model.base_exposure(1e-4);
    let m = 16;
    let avg = average(&model, &dark, &spec, 25.0, m);
    let (_, var_t) = temporal(
        &shot(&model, &dark, &spec, 25.0, 1),
        &shot(&model, &dark, &spec, 25.0, 2),
    );
    let dsnu = ((var(&avg) - var_t / m as f64).max(0.0)).sqrt() / k;
    assert!(
        (dsnu / 3.0 - 1.0).abs() < 0.05,
        "DSNU {dsnu} e⁻, configured 3"
    );
    eprintln!("DSNU {dsnu:.3} e⁻ (config 3)");

    // Off: no dark signal, no fixed pattern.
    let model = PixelModel::new(
        &cfg,
        N,
        N,
        &effects_off(&["camera.dark_current", "camera.dsnu"]),
        11,
    )
    .unwrap();
    let m1 = mean(&as_f64(&shot(
        &model,
        &dark,
        &model.base_exposure(1.0),
        45.0,
        5,
    )));
    assert!((m1 - cfg.black_level_dn).abs() < 0.05, "dark off: {m1}");
    assert!(model.dsnu_map_e().is_empty());
    let avg = average(&model, &dark, &spec, 25.0, m);
    let dsnu_off = ((var(&avg) - var_t / m as f64).max(0.0)).sqrt() / k;
    assert!(dsnu_off < 0.3, "DSNU off: {dsnu_off}");
}

#[test]
fn bright_flat_field_gives_prnu() {
    let cfg = PixelConfig::default();
    let k = cfg.conversion_gain_dn_per_e;
    let run = |off: &[&str]| {
        let model = PixelModel::new(&cfg, N, N, &effects_off(off), 3).unwrap();
        let t = 0.01;
        let spec = model.base_exposure(t);
        // 50 % of saturation.
        let rate = flat(N, N, (0.5 * cfg.full_well_e / t) as f32);
        let dark = flat(N, N, 0.0);
        let m = 16;
        let bright = average(&model, &rate, &spec, 25.0, m);
        let black = average(&model, &dark, &spec, 25.0, m);
        let (_, vt_bright) = temporal(
            &shot(&model, &rate, &spec, 25.0, 1),
            &shot(&model, &rate, &spec, 25.0, 2),
        );
        let (_, vt_dark) = temporal(
            &shot(&model, &dark, &spec, 25.0, 1),
            &shot(&model, &dark, &spec, 25.0, 2),
        );
        let s50 = var(&bright) - vt_bright / m as f64;
        let sdark = var(&black) - vt_dark / m as f64;
        let signal = mean(&bright) - mean(&black);
        assert!(
            (signal / (k * 0.5 * cfg.full_well_e) - 1.0).abs() < 0.01,
            "signal {signal} DN"
        );
        (s50 - sdark).max(0.0).sqrt() / signal
    };
    let prnu = run(&[]);
    assert!(
        (prnu / 0.01 - 1.0).abs() < 0.05,
        "PRNU {prnu}, configured 1 %"
    );
    eprintln!("PRNU {:.4} % (config 1 %)", prnu * 100.0);
    let prnu_off = run(&["camera.prnu"]);
    assert!(prnu_off < 0.002, "PRNU off: {prnu_off}");
}

#[test]
fn noise_free_pixel_is_the_linear_model_and_switches_remove_noise() {
    let cfg = PixelConfig::default();
    let k = cfg.conversion_gain_dn_per_e;
    let t = 0.004;
    let rate_e_s = 1.234e6; // 4936 e⁻
    let rate = flat(16, 16, rate_e_s as f32);
    let model = PixelModel::new(&cfg, 16, 16, &effects_off(&NOISE), 1).unwrap();
    let raw = shot(&model, &rate, &model.base_exposure(t), 40.0, 9);
    let expected = (k * rate_e_s * t + cfg.black_level_dn).round() as u32;
    assert!(
        raw.data.iter().all(|&v| v == expected),
        "{} vs {expected}",
        raw.data[0]
    );
    assert_eq!(raw.bit_depth, 12);
    assert_eq!(raw.conversion_gain_dn_per_e, k);
    // Shot noise alone: σ²_y = K² μ_e + 1/12.
    let others: Vec<&str> = NOISE
        .iter()
        .copied()
        .filter(|&n| n != "camera.shot_noise")
        .collect();
    let model = PixelModel::new(&cfg, N, N, &effects_off(&others), 1).unwrap();
    let rate = flat(N, N, rate_e_s as f32);
    let spec = model.base_exposure(t);
    let (_, v) = temporal(
        &shot(&model, &rate, &spec, 40.0, 1),
        &shot(&model, &rate, &spec, 40.0, 2),
    );
    let expected_var = k * k * rate_e_s * t + 1.0 / 12.0;
    assert!(
        (v / expected_var - 1.0).abs() < 0.03,
        "shot only: {v} vs {expected_var}"
    );
    // Read noise alone in the dark: σ²_y = K² σ_r² + 1/12.
    let others: Vec<&str> = NOISE
        .iter()
        .copied()
        .filter(|&n| n != "camera.read_noise")
        .collect();
    let model = PixelModel::new(&cfg, N, N, &effects_off(&others), 1).unwrap();
    let dark = flat(N, N, 0.0);
    let (_, v) = temporal(
        &shot(&model, &dark, &spec, 40.0, 1),
        &shot(&model, &dark, &spec, 40.0, 2),
    );
    let expected_var = k * k * cfg.read_noise_e.powi(2) + 1.0 / 12.0;
    // Shot noise off, everything else on: a bright flat field has only the read noise left
    // (the fixed patterns cancel in the frame difference; −40 °C: no dark shot noise).
    let model = PixelModel::new(&cfg, N, N, &effects_off(&["camera.shot_noise"]), 1).unwrap();
    let (_, v_bright) = temporal(
        &shot(&model, &rate, &spec, -40.0, 1),
        &shot(&model, &rate, &spec, -40.0, 2),
    );
    assert!(
        (v_bright / expected_var - 1.0).abs() < 0.05,
        "shot off: {v_bright} vs {expected_var}"
    );
    assert!(
        (v / expected_var - 1.0).abs() < 0.05,
        "read only: {v} vs {expected_var}"
    );
}

#[test]
fn saturation_clips_at_full_well_and_adc() {
    let cfg = PixelConfig::default();
    let k = cfg.conversion_gain_dn_per_e;
    let t = 0.01;
    let rate = flat(N, N, (5.0 * cfg.full_well_e / t) as f32);
    let model = PixelModel::new(&cfg, N, N, &effects_off(&[]), 1).unwrap();
    let raw = shot(&model, &rate, &model.base_exposure(t), 25.0, 1);
    assert!(raw.data.iter().all(|&v| v <= 4095));
    // Full well 10 000 e⁻ → 64 + 0.403·10 000 = 4094 DN (the ADC top 4095 is above).
    let m = mean(&as_f64(&raw));
    let full = cfg.black_level_dn + k * cfg.full_well_e;
    assert!((m - full).abs() < 0.5, "saturated mean {m} vs {full}");
    // Off: linear beyond the full well and the ADC.
    let model = PixelModel::new(&cfg, N, N, &effects_off(&["camera.saturation"]), 1).unwrap();
    let raw = shot(&model, &rate, &model.base_exposure(t), 25.0, 1);
    let m = mean(&as_f64(&raw));
    let linear = cfg.black_level_dn + k * 5.0 * cfg.full_well_e;
    assert!(
        (m / linear - 1.0).abs() < 0.005,
        "saturation off: {m} vs {linear}"
    );
}

#[test]
fn fixed_pattern_is_fixed_and_output_deterministic() {
    let cfg = PixelConfig::default();
    let a = PixelModel::new(&cfg, 64, 32, &effects_off(&[]), 5).unwrap();
    let b = PixelModel::new(&cfg, 64, 32, &effects_off(&[]), 5).unwrap();
    let c = PixelModel::new(&cfg, 64, 32, &effects_off(&[]), 6).unwrap();
    assert_eq!(a.dsnu_map_e(), b.dsnu_map_e());
    assert_eq!(a.prnu_map(), b.prnu_map());
    assert_ne!(a.dsnu_map_e(), c.dsnu_map_e());
    let rate = flat(64, 32, 1e5);
    let spec = a.base_exposure(0.01);
    assert_eq!(
        shot(&a, &rate, &spec, 25.0, 9),
        shot(&b, &rate, &spec, 25.0, 9)
    );
    assert_ne!(
        shot(&a, &rate, &spec, 25.0, 9).data,
        shot(&a, &rate, &spec, 25.0, 10).data
    );
}

// ---------------------------------------------------------------------------------------------
// LED flicker
// ---------------------------------------------------------------------------------------------

/// Overlap of [t0, t0 + t] with the on-intervals [n P, n P + d P], by brute force.
fn overlap_s(t0: f64, t: f64, period: f64, duty: f64) -> f64 {
    let steps = 200_000;
    let dt = t / steps as f64;
    (0..steps)
        .filter(|i| {
            let s = t0 + (*i as f64 + 0.5) * dt;
            (s / period).fract() * period < duty * period
        })
        .count() as f64
        * dt
}

#[test]
fn led_flicker_integrates_pwm_over_each_row() {
    let cfg = PixelConfig::default();
    let k = cfg.conversion_gain_dn_per_e;
    let (w, h) = (4, 24);
    let model = PixelModel::new(&cfg, w, h, &effects_off(&NOISE), 1).unwrap();
    let src = PwmSource {
        frequency_hz: 90.0,
        duty: 0.1,
        phase_s: 0.0,
    };
    let period = 1.0 / 90.0;
    // Time-averaged rate 1e5 e⁻/s: on-state 1e6 e⁻/s.
    let v = 1e5f32;
    let flicker = Flicker {
        samples: (0..h)
            .map(|y| FlickerSample {
                pixel: (y * w + 1) as u32,
                value: [v; 3],
                source: 0,
            })
            .collect(),
        sources: vec![src],
    };
    let dark = flat(w, h, 0.0);
    let row_time = 0.5e-3;
    let expose = |t: f64| {
        let mut raw = RawImage::default();
        let timing = ShutterTiming {
            frame_time_s: 0.0,
            row_time_s: row_time,
            start_offset_s: 0.0,
            exposure_s: t,
        };
        model.expose(
            &dark,
            &flicker,
            &model.base_exposure(t),
            &timing,
            25.0,
            1,
            &mut raw,
        );
        raw
    };
    // 1 ms exposures: rows starting inside the on-time see it fully or partly, later rows nothing.
    let raw = expose(1e-3);
    let mut seen_full = false;
    let mut seen_zero = false;
    for y in 0..h {
        let t0 = y as f64 * row_time;
        let electrons = f64::from(v) / 0.1 * overlap_s(t0, 1e-3, period, 0.1);
        let expected = k * electrons + cfg.black_level_dn;
        let got = f64::from(raw.data[y * w + 1]);
        assert!(
            (got - expected).abs() <= 1.0,
            "row {y}: {got} vs {expected}"
        );
        seen_full |= electrons > 999.0;
        seen_zero |= electrons == 0.0;
        // The other pixels of the row are dark.
        assert_eq!(raw.data[y * w], cfg.black_level_dn as u32);
    }
    assert!(seen_full && seen_zero);
    // Row 0 [0, 1 ms] lies inside the 1.11 ms on-time: full on-state signal 1000 e⁻.
    assert!((f64::from(raw.data[1]) - (k * 1000.0 + 64.0)).abs() <= 1.0);
    // Row 10 [5, 6 ms]: off.
    assert_eq!(raw.data[10 * w + 1], 64);
    // Exposures of two full periods see the duty-weighted average v·t at every row.
    let t = 2.0 * period;
    let raw = expose(t);
    for y in 0..h {
        let expected = k * f64::from(v) * t + cfg.black_level_dn;
        let got = f64::from(raw.data[y * w + 1]);
        assert!(
            (got - expected).abs() <= 1.0,
            "row {y}: {got} vs {expected}"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Auto exposure, configuration
// ---------------------------------------------------------------------------------------------

#[test]
fn auto_exposure_places_the_key_at_the_target() {
    let cfg = PixelConfig::default();
    let model = PixelModel::new(&cfg, 32, 32, &effects_off(&[]), 1).unwrap();
    let mut rate = flat(32, 32, 0.0);
    rate.planes[GREEN].fill(1e6);
    let t = model.auto_exposure_s(&rate);
    // 10/78 of the 10 000 e⁻ full well at 1e6 e⁻/s.
    let expected = 10.0 / 78.0 * 1e4 / 1e6;
    assert!((t / expected - 1.0).abs() < 1e-6, "{t} vs {expected}");
    // A sun disk in 1 % of the pixels at 1e5× the rate moves the log-average by 1e5^0.01 ≈ 12 %.
    for v in rate.planes[GREEN].iter_mut().take(10) {
        *v = 1e11;
    }
    let t_sun = model.auto_exposure_s(&rate);
    assert!(t_sun > 0.85 * t, "sun in view: {t_sun} vs {t}");
    // Clamped to the configured range.
    rate.planes[GREEN].fill(1.0);
    assert_eq!(model.auto_exposure_s(&rate), cfg.max_exposure_s);
    rate.planes[GREEN].fill(1e15);
    assert_eq!(model.auto_exposure_s(&rate), cfg.min_exposure_s);
}

#[test]
fn pixel_config_presets_validation_and_row_time() {
    let isx = PixelConfig::for_preset(CameraPreset::Isx019);
    let imx = PixelConfig::for_preset(CameraPreset::Imx490);
    isx.validate().unwrap();
    imx.validate().unwrap();
    // IMX490: HCG/LCG ratio 200/49 µV/e⁻, 0.83 e⁻ HCG read noise, 22 000 e⁻ full well (ISETCam).
    assert!(
        (imx.conversion_gain_dn_per_e / imx.lcg_conversion_gain_dn_per_e - 200.0 / 49.0).abs()
            < 1e-9
    );
    assert_eq!(imx.read_noise_e, 0.83);
    assert_eq!(imx.full_well_e, 22_000.0);
    assert_eq!(imx.small_pd_full_well_e, 7_900.0);
    // Row time: configured, or 90 % of the cycle over the rows.
    assert!((isx.row_time_s(960, 1.0 / 30.0) - 0.9 / 30.0 / 960.0).abs() < 1e-15);
    let fixed = PixelConfig {
        row_time_s: Some(15e-6),
        ..isx.clone()
    };
    assert_eq!(fixed.row_time_s(960, 1.0 / 30.0), 15e-6);
    for (json, key) in [
        (r#"{"full_well_e": -1}"#, "camera.pixel.full_well_e"),
        (r#"{"adc_bits": 20}"#, "camera.pixel.adc_bits"),
        (r#"{"prnu_percent": -1}"#, "camera.pixel.prnu_percent"),
        (
            r#"{"min_exposure_s": 0.1, "max_exposure_s": 0.01}"#,
            "camera.pixel.max_exposure_s",
        ),
    ] {
        let cfg: PixelConfig = serde_json::from_str(json).unwrap();
        match cfg.validate() {
            Err(ModelError::Config(m)) => assert!(m.contains(key), "{m}"),
            other => panic!("{json}: {other:?}"),
        }
        assert!(PixelModel::new(&cfg, 4, 4, &effects_off(&[]), 0).is_err());
    }
    assert!(serde_json::from_str::<PixelConfig>(r#"{"ful_well_e": 1}"#).is_err());
}

// ---------------------------------------------------------------------------------------------
// HDR
// ---------------------------------------------------------------------------------------------

/// A ramp of rates over the columns: r(x) = r_min · 10^(decades · x/(w − 1)).
fn ramp(w: usize, h: usize, r_min: f64, decades: f64) -> (ChannelImage, Vec<f64>) {
    let rates: Vec<f64> = (0..w)
        .map(|x| r_min * 10f64.powf(decades * x as f64 / (w - 1) as f64))
        .collect();
    let mut img = ChannelImage::new(w, h);
    for p in &mut img.planes {
        for y in 0..h {
            for x in 0..w {
                p[y * w + x] = rates[x] as f32;
            }
        }
    }
    (img, rates)
}

fn hdr_frame(
    model: &PixelModel,
    hdr: &HdrPipeline,
    rate: &ChannelImage,
    base_s: f64,
    temperature_c: f64,
) -> (Vec<ExposureSpec>, RawImage) {
    let specs = hdr.captures(model, base_s);
    let caps: Vec<RawImage> = specs
        .iter()
        .enumerate()
        .map(|(k, s)| {
            let mut raw = RawImage::default();
            model.expose(
                rate,
                &Flicker::default(),
                s,
                &timing(0.0),
                temperature_c,
                42 ^ ((k as u64 + 1) << 56),
                &mut raw,
            );
            raw
        })
        .collect();
    let mut merged = RawImage::default();
    hdr.merge(&caps, &mut merged);
    (specs, merged)
}

#[test]
fn dol_captures_are_consecutive_with_ratio() {
    let model = PixelModel::new(&PixelConfig::default(), 8, 8, &effects_off(&[]), 0).unwrap();
    let hdr = HdrPipeline::new(&HdrConfig::default(), &effects_off(&[])).unwrap();
    let c = hdr.captures(&model, 0.016);
    assert_eq!(c.len(), 3);
    assert_eq!(c[0].time_s, 0.016);
    assert!((c[1].time_s - 0.001).abs() < 1e-15 && (c[2].time_s - 0.0000625).abs() < 1e-15);
    assert_eq!(c[1].start_offset_s, 0.016);
    assert!((c[2].start_offset_s - 0.017).abs() < 1e-15);
    assert_eq!(c.iter().map(|s| s.index).collect::<Vec<_>>(), vec![0, 1, 2]);
    let single = HdrPipeline::new(
        &HdrConfig {
            mode: HdrMode::Single,
            ..HdrConfig::default()
        },
        &effects_off(&[]),
    )
    .unwrap();
    assert_eq!(single.captures(&model, 0.01).len(), 1);
    // Mode names are a contract.
    for (s, m) in [
        ("single", HdrMode::Single),
        ("dol", HdrMode::Dol),
        ("split_pixel", HdrMode::SplitPixel),
    ] {
        let cfg: HdrConfig = serde_json::from_str(&format!(r#"{{"mode": "{s}"}}"#)).unwrap();
        assert_eq!(cfg.mode, m);
    }
    let imx = HdrConfig::for_preset(CameraPreset::Imx490);
    assert_eq!((imx.mode, imx.bit_depth), (HdrMode::SplitPixel, 24));
    for (json, key) in [
        (r#"{"bit_depth": 32}"#, "camera.hdr.bit_depth"),
        (r#"{"exposure_ratio": 1}"#, "camera.hdr.exposure_ratio"),
        (
            r#"{"knees": [[0, 0], [10, 5], [5, 8]]}"#,
            "camera.hdr.knees",
        ),
    ] {
        let cfg: HdrConfig = serde_json::from_str(json).unwrap();
        match HdrPipeline::new(&cfg, &effects_off(&[])) {
            Err(ModelError::Config(m)) => assert!(m.contains(key), "{m}"),
            Err(e) => panic!("{json}: {e:?}"),
            Ok(_) => panic!("{json}: accepted"),
        }
    }
}

#[test]
fn dol_merge_noise_free_is_linear_over_100_db() {
    let cfg = PixelConfig::default();
    let (w, h) = (400, 2);
    let model = PixelModel::new(&cfg, w, h, &effects_off(&NOISE), 0).unwrap();
    let hdr = HdrPipeline::new(&HdrConfig::default(), &effects_off(&[])).unwrap();
    let base = 0.01;
    // 2e3 … 2e8 e⁻/s: 20 e⁻ in the long capture up to 0.8 of the short one's full well.
    let (rate, rates) = ramp(w, h, 2e3, 5.0);
    let (_, merged) = hdr_frame(&model, &hdr, &rate, base, 25.0);
    assert_eq!(merged.bit_depth, 20);
    let g0 = cfg.conversion_gain_dn_per_e * base;
    for (x, &r) in rates.iter().enumerate() {
        let ideal = cfg.black_level_dn + r * g0;
        let got = f64::from(merged.data[x]);
        assert!(
            (got - ideal).abs() <= (0.005 * (ideal - cfg.black_level_dn)).max(2.0),
            "x {x}: rate {r:.4e}: {got} vs {ideal}"
        );
    }
    assert!(merged.data.iter().all(|&v| v < 1 << 20));
}

#[test]
fn dol_merge_with_noise_is_linear_over_100_db() {
    let cfg = PixelConfig::default();
    let (w, h) = (60, 400);
    let model = PixelModel::new(&cfg, w, h, &effects_off(&[]), 3).unwrap();
    let hdr = HdrPipeline::new(&HdrConfig::default(), &effects_off(&[])).unwrap();
    let base = 0.01;
    // 10⁵ range (100 dB): 2e3 … 2e8 e⁻/s. −40 °C: no dark signal to subtract.
    let (rate, rates) = ramp(w, h, 2e3, 5.0);
    let (_, merged) = hdr_frame(&model, &hdr, &rate, base, -40.0);
    let g0 = cfg.conversion_gain_dn_per_e * base;
    let mut worst = (0.0f64, 0.0, 0.0);
    for (x, &r) in rates.iter().enumerate() {
        let col: Vec<f64> = (0..h)
            .map(|y| (f64::from(merged.data[y * w + x]) - cfg.black_level_dn) / (r * g0))
            .collect();
        let m = mean(&col);
        let sem = (var(&col) / h as f64).sqrt();
        // 1.5 % where the SNR allows, else 4 standard errors of the column mean.
        let tol = 0.015f64.max(4.0 * sem);
        assert!(
            (m - 1.0).abs() < tol,
            "x {x} rate {r:.3e}: merged/true {m:.4} ± {sem:.4}"
        );
        if (m - 1.0).abs() > worst.0 {
            worst = ((m - 1.0).abs(), r, sem);
        }
    }
    eprintln!(
        "DOL merge with noise over 100 dB: worst |merged/true − 1| = {:.4} at {:.3e} e⁻/s (± {:.4})",
        worst.0, worst.1, worst.2
    );
}

#[test]
fn split_pixel_merge_is_linear_and_shares_shot_noise() {
    let cfg = PixelConfig::imx490();
    let (w, h) = (40, 400);
    let model = PixelModel::new(&cfg, w, h, &effects_off(&[]), 3).unwrap();
    let hdr_cfg = HdrConfig::for_preset(CameraPreset::Imx490);
    let hdr = HdrPipeline::new(&hdr_cfg, &effects_off(&[])).unwrap();
    let base = 0.01;
    // Small PD saturates at 7 900 e⁻ / 0.1 = 79 000 large-PD e⁻ (7.9e6 e⁻/s at 10 ms): 2e2 … 6e6.
    let (rate, rates) = ramp(w, h, 2e2, 4.5);
    let (specs, merged) = hdr_frame(&model, &hdr, &rate, base, -40.0);
    assert_eq!(specs.len(), 3);
    assert!(
        specs
            .iter()
            .all(|s| s.time_s == base && s.start_offset_s == 0.0)
    );
    assert_eq!(merged.bit_depth, 24);
    let g0 = cfg.conversion_gain_dn_per_e * base;
    for (x, &r) in rates.iter().enumerate() {
        let col: Vec<f64> = (0..h)
            .map(|y| (f64::from(merged.data[y * w + x]) - cfg.black_level_dn) / (r * g0))
            .collect();
        let m = mean(&col);
        let sem = (var(&col) / h as f64).sqrt();
        let tol = 0.015f64.max(4.0 * sem);
        assert!(
            (m - 1.0).abs() < tol,
            "x {x} rate {r:.3e}: merged/true {m:.4} ± {sem:.4}"
        );
    }
    // HCG and LCG read the same charge: their fluctuations are correlated (shot noise shared).
    let rate = flat(w, h, (3000.0 / base) as f32);
    let specs = hdr.captures(&model, base);
    let expose = |s: &ExposureSpec, seed: u64| {
        let mut raw = RawImage::default();
        model.expose(
            &rate,
            &Flicker::default(),
            s,
            &timing(0.0),
            -40.0,
            seed,
            &mut raw,
        );
        as_f64(&raw)
    };
    let a = expose(&specs[0], 42 ^ (1 << 56));
    let b = expose(&specs[1], 42 ^ (2 << 56));
    let (ma, mb) = (mean(&a), mean(&b));
    let cov = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (x - ma) * (y - mb))
        .sum::<f64>()
        / a.len() as f64;
    let corr = cov / (var(&a) * var(&b)).sqrt();
    // Expected: shot σ² 3000 e⁻² vs read 0.83² / 3.05² e⁻² and PRNU (≈ 30² e⁻²) → ρ ≈ 0.99.
    let ka = cfg.conversion_gain_dn_per_e;
    let kb = cfg.lcg_conversion_gain_dn_per_e;
    let common = 3000.0 + (0.01f64 * 3000.0).powi(2) + 1.0;
    let va = common + 0.83f64.powi(2) + 1.0 / 12.0 / (ka * ka);
    let vb = common + 3.05f64.powi(2) + 1.0 / 12.0 / (kb * kb);
    let expected = common / (va * vb).sqrt();
    eprintln!("HCG/LCG correlation {corr:.4} (expected {expected:.4})");
    assert!(
        (corr - expected).abs() < 0.01,
        "HCG/LCG correlation {corr} vs {expected}"
    );
}

#[test]
fn single_mode_copies_and_does_not_compand() {
    let model = PixelModel::new(&PixelConfig::default(), 8, 8, &effects_off(&[]), 0).unwrap();
    let cfg = HdrConfig {
        mode: HdrMode::Single,
        ..HdrConfig::default()
    };
    let hdr = HdrPipeline::new(&cfg, &effects_off(&[])).unwrap();
    let (rate, _) = ramp(8, 8, 1e4, 2.0);
    let specs = hdr.captures(&model, 0.01);
    let mut raw = RawImage::default();
    model.expose(
        &rate,
        &Flicker::default(),
        &specs[0],
        &timing(0.0),
        25.0,
        1,
        &mut raw,
    );
    let mut merged = RawImage::default();
    hdr.merge(std::slice::from_ref(&raw), &mut merged);
    assert_eq!(merged, raw);
    let mut comp = RawImage::default();
    hdr.compand(&merged, &mut comp);
    assert_eq!(comp, raw);
}

#[test]
fn compand_then_decompand_within_half_a_step() {
    for (bits, out_bits) in [(20, 12), (24, 12), (24, 16)] {
        let cfg = HdrConfig {
            bit_depth: bits,
            companded_bits: out_bits,
            ..HdrConfig::default()
        };
        let hdr = HdrPipeline::new(&cfg, &effects_off(&[])).unwrap();
        let knees = hdr.knees().to_vec();
        assert_eq!(knees[0].input_dn, 0.0);
        assert_eq!(knees.last().unwrap().input_dn, ((1u64 << bits) - 1) as f64);
        assert_eq!(
            knees.last().unwrap().output_dn,
            ((1u64 << out_bits) - 1) as f64
        );
        let in_max = (1u64 << bits) - 1;
        let xs: Vec<u32> = (0..20_000u64)
            .map(|i| ((i * i * 7919) % (in_max + 1)) as u32)
            .chain([0, 1, 511, 512, 513, 4095, 4096, in_max as u32])
            .collect();
        let linear = RawImage {
            width: xs.len(),
            height: 1,
            data: xs.clone(),
            bit_depth: bits,
            black_level_dn: 64.0,
            ..RawImage::default()
        };
        let mut comp = RawImage::default();
        hdr.compand(&linear, &mut comp);
        assert_eq!(comp.bit_depth, out_bits);
        assert_eq!(
            comp.black_level_dn, 64.0,
            "black level in the slope-1 segment"
        );
        for (&x, &c) in xs.iter().zip(&comp.data) {
            assert!(c < 1 << out_bits);
            // Step of the segment: Δx/Δy of the knee interval holding x.
            let i = knees
                .iter()
                .position(|k| k.input_dn > f64::from(x))
                .unwrap_or(knees.len() - 1)
                .max(1);
            let step = (knees[i].input_dn - knees[i - 1].input_dn)
                / (knees[i].output_dn - knees[i - 1].output_dn);
            let back = hdr.decompand(c);
            assert!(
                (back - f64::from(x)).abs() <= 0.5 * step.max(1.0) + 0.5,
                "{bits}→{out_bits}: x {x} → {c} → {back} (step {step})"
            );
            if x < 512 {
                assert_eq!(c, x, "slope-1 segment is the identity");
            }
        }
        // Monotonic.
        let mut sorted = xs.clone();
        sorted.sort_unstable();
        let mut prev = 0.0;
        for &x in &sorted {
            let y = hdr.compand_value(f64::from(x));
            assert!(y >= prev);
            prev = y;
        }
    }
    // Off: identity.
    let hdr = HdrPipeline::new(
        &HdrConfig::default(),
        &effects_off(&["camera.hdr_companding"]),
    )
    .unwrap();
    let linear = RawImage {
        width: 3,
        height: 1,
        data: vec![0, 1000, 1_000_000],
        bit_depth: 20,
        ..RawImage::default()
    };
    let mut comp = RawImage::default();
    hdr.compand(&linear, &mut comp);
    assert_eq!(comp, linear);
    assert_eq!(hdr.decompand(1000), 1000.0);
}

#[test]
fn hdr_saturation_clips_at_the_merged_range() {
    let cfg = PixelConfig::default();
    let model = PixelModel::new(&cfg, 8, 2, &effects_off(&NOISE), 0).unwrap();
    let hdr = HdrPipeline::new(&HdrConfig::default(), &effects_off(&[])).unwrap();
    // Far above the shortest capture's full well: every capture saturated.
    let rate = flat(8, 2, 1e12);
    let (_, merged) = hdr_frame(&model, &hdr, &rate, 0.01, 25.0);
    let top = cfg.black_level_dn + cfg.conversion_gain_dn_per_e * cfg.full_well_e * 256.0;
    for &v in &merged.data {
        assert!(v < 1 << 20);
        assert!((f64::from(v) - top).abs() <= 256.0, "{v} vs {top}");
    }
    let mut comp = RawImage::default();
    hdr.compand(&merged, &mut comp);
    assert!(comp.data.iter().all(|&v| v <= 4095 && v > 3000));
}
