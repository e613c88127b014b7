//! FMCW baseband synthesis and processing against closed forms (physics.md §1.1, §1.6, §1.7).

mod common;
use common::{point_path, run_chain};

use num_complex::Complex64;
use osiris_models::constants::SPEED_OF_LIGHT_M_S as C_M_S;
use osiris_models::effects::Effects;
use osiris_models::radar::PathReturn;
use osiris_models::radar::antenna::FrontEndConfig;
use osiris_models::radar::baseband::{ChainDetection, RadarChain};
use osiris_models::radar::processing::{CfarKind, ProcessingConfig, Window};
use osiris_models::radar::waveform::{ArrayConfig, WaveformConfig};
use osiris_models::registry::catalogue;
use osiris_models::sensor::ModelError;

const K_B: f64 = 1.380649e-23;

fn effects(off: &[&str], on: &[&str]) -> Effects {
    let mut e = Effects::new(&catalogue());
    for n in off {
        e.set(n, false).unwrap();
    }
    for n in on {
        e.set(n, true).unwrap();
    }
    e
}

fn chain_with(processing: ProcessingConfig, e: &Effects) -> RadarChain {
    RadarChain::new(
        &WaveformConfig::default(),
        &ArrayConfig::default(),
        &FrontEndConfig::default(),
        &processing,
        e,
    )
    .unwrap()
}

fn chain() -> RadarChain {
    chain_with(ProcessingConfig::default(), &effects(&[], &[]))
}

fn strongest(d: &[ChainDetection]) -> ChainDetection {
    *d.iter()
        .max_by(|a, b| a.power_dbm.total_cmp(&b.power_dbm))
        .expect("a detection")
}

#[test]
fn range_velocity_azimuth_accuracy() {
    let w = WaveformConfig::default();
    let mut c = chain();
    // Off-grid ranges and velocities; azimuth 0° and 45°, elevation 0.
    for (r, v, az) in [
        (23.37, 3.71, 0.0),
        (61.93, -6.29, 45.0),
        (42.1, 0.0, -45.0),
        (8.77, 9.1, 20.0),
    ] {
        let d = run_chain(&mut c, &[point_path(r, v, az, 0.0, -80.0, 7)], 1);
        let s = strongest(&d);
        println!(
            "target {r} m {v} m/s {az}°: errors {:.3} m, {:.3} km/h, {:.2}°",
            s.range_m - r,
            (s.range_rate_m_s - v) * 3.6,
            s.azimuth_rad.to_degrees() - az
        );
        assert!((s.range_m - r).abs() < 0.30, "range {} vs {r}", s.range_m);
        assert!(
            (s.range_rate_m_s - v).abs() * 3.6 < 0.3,
            "velocity {} vs {v} m/s (|Δ| must be < 0.3 km/h)",
            s.range_rate_m_s
        );
        assert!(
            (s.azimuth_rad.to_degrees() - az).abs() < 1.0,
            "azimuth {} vs {az}°",
            s.azimuth_rad.to_degrees()
        );
        assert!(
            s.elevation_rad.to_degrees().abs() < 3.0,
            "elevation {}",
            s.elevation_rad.to_degrees()
        );
        assert_eq!(s.object_id, 7);
        assert!(v.abs() < w.max_velocity_m_s(3));
    }
}

#[test]
fn elevation_from_the_vertical_offset() {
    let mut c = chain();
    let s = strongest(&run_chain(
        &mut c,
        &[point_path(30.2, 1.0, 10.0, 8.0, -80.0, 1)],
        2,
    ));
    assert!(
        (s.elevation_rad.to_degrees() - 8.0).abs() < 2.0,
        "{}",
        s.elevation_rad.to_degrees()
    );
    assert!(
        (s.azimuth_rad.to_degrees() - 10.0).abs() < 1.0,
        "{}",
        s.azimuth_rad.to_degrees()
    );
}

#[test]
fn resolution_is_c_over_2b_and_lambda_over_2nt() {
    let w = WaveformConfig::default();
    let dr = C_M_S / (2.0 * w.sampled_bandwidth_hz());
    let dv = w.wavelength_m() / (2.0 * w.chirps_per_frame as f64 * 3.0 * w.chirp_interval_s());
    assert!((w.range_resolution_m() - dr).abs() < 1e-12);
    assert!((w.velocity_resolution_m_s(3) - dv).abs() < 1e-12);
    // Rectangular window: the classical resolution cell (main-lobe null-to-peak = 1 bin).
    let p = ProcessingConfig {
        range_window: Window::Rectangular,
        doppler_window: Window::Rectangular,
        ..ProcessingConfig::default()
    };
    let mut c = chain_with(p, &effects(&[], &[]));
    // Targets: local maxima within 6 dB of the strongest (sidelobes of the rectangular window are
    // at −13 dB) near the pair.
    let count_near = |d: &[ChainDetection], r: f64, v: f64| {
        let top = strongest(d).power_dbm;
        d.iter()
            .filter(|x| x.power_dbm > top - 6.0)
            .filter(|x| (x.range_m - r).abs() < 3.0 * dr && (x.range_rate_m_s - v).abs() < 3.0 * dv)
            .count()
    };
    // Two equal targets 1.5 cells apart in range (placed symmetrically about a bin, so the result
    // does not hinge on their relative phase) are resolved; 0.5 cells apart they merge.
    let r0 = 40.0 * dr;
    for (sep, expect) in [(1.5, 2), (0.5, 1)] {
        let (a, b) = (r0 - 0.5 * sep * dr, r0 + 0.5 * sep * dr);
        let d = run_chain(
            &mut c,
            &[
                point_path(a, 0.0, 0.0, 0.0, -80.0, 1),
                point_path(b, 0.0, 0.0, 0.0, -80.0, 2),
            ],
            3,
        );
        assert_eq!(
            count_near(&d, r0, 0.0),
            expect,
            "range separation {sep} cells: {d:?}"
        );
    }
    // Same in velocity (same range).
    let v0 = 10.0 * dv;
    for (sep, expect) in [(1.5, 2), (0.5, 1)] {
        let (a, b) = (v0 - 0.5 * sep * dv, v0 + 0.5 * sep * dv);
        let d = run_chain(
            &mut c,
            &[
                point_path(r0, a, 0.0, 0.0, -80.0, 1),
                point_path(r0, b, 0.0, 0.0, -80.0, 2),
            ],
            4,
        );
        assert_eq!(
            count_near(&d, r0, v0),
            expect,
            "velocity separation {sep} cells: {d:?}"
        );
    }
}

#[test]
fn main_lobe_half_power_width_is_the_windows() {
    // A target exactly on range bin 50 (range corrected for the beat frequency), then moved by half
    // the window's 3 dB width (Hann: 1.44 bins, Harris 1978): the power in bin 50 drops by 3 dB.
    let w = WaveformConfig::default();
    let dr = w.range_resolution_m();
    let mut c = chain_with(
        ProcessingConfig::default(),
        &effects(&["radar.phase_noise"], &[]),
    );
    let mut bin_power = |r: f64, v: f64, dbin: usize| {
        run_chain(&mut c, &[point_path(r, v, 0.0, 0.0, -70.0, 1)], 5);
        let m = c.range_doppler_map();
        m.power_dbm[50 * m.doppler_bins + m.doppler_bins / 2 + dbin] as f64
    };
    let on = bin_power(50.0 * dr, 0.0, 0);
    let off = bin_power((50.0 + 0.72) * dr, 0.0, 0);
    assert!((on - off - 3.01).abs() < 0.3, "range: {on} → {off} dBm");
    // Doppler: target on Doppler bin +5, then 0.72 bins beyond.
    let dv = w.velocity_resolution_m_s(3);
    let on = bin_power(50.0 * dr, 5.0 * dv, 5);
    let off = bin_power(50.0 * dr, 5.72 * dv, 5);
    // The Doppler moves the beat frequency by 2v/λ ≪ a range bin (< 0.01 bin here).
    assert!((on - off - 3.01).abs() < 0.3, "Doppler: {on} → {off} dBm");
}

#[test]
fn processed_snr_and_power_match_the_closed_form() {
    // physics.md §1.1: SNR = P_r N_s N_c / (k T₀ F_n f_s) + 10 log N_virt (coherent beamforming),
    // minus the Hann processing loss of 10 log 1.5 = 1.76 dB per FFT dimension (Harris 1978).
    let w = WaveformConfig::default();
    let fe = FrontEndConfig::default();
    let dr = w.range_resolution_m();
    let p_dbm = -100.0;
    let mut c = chain();
    let noise_w = K_B * 290.0 * 10f64.powf(fe.noise_figure_db / 10.0) * w.sample_rate_hz;
    assert!((c.noise_power_w() / noise_w - 1.0).abs() < 1e-9);
    let expected = p_dbm - 10.0 * (noise_w * 1e3).log10()
        + 10.0 * ((w.samples_per_chirp * w.chirps_per_frame) as f64).log10()
        - 2.0 * 10.0 * 1.5f64.log10()
        + 10.0 * 12f64.log10();
    let mut snrs = Vec::new();
    for seed in 0..4 {
        let d = run_chain(
            &mut c,
            &[point_path(60.0 * dr, 0.0, 0.0, 0.0, p_dbm, 1)],
            seed,
        );
        let s = strongest(&d);
        assert!(
            (s.power_dbm - p_dbm).abs() < 1.0,
            "power {} dBm",
            s.power_dbm
        );
        snrs.push(s.snr_db);
    }
    let mean = snrs.iter().sum::<f64>() / snrs.len() as f64;
    println!("processed SNR {mean:.2} dB vs closed form {expected:.2} dB");
    assert!(
        (mean - expected).abs() < 1.5,
        "SNR {snrs:?} vs closed form {expected:.1} dB"
    );
}

fn false_alarm_rate(kind: CfarKind, p_fa: f64, frames: u64) -> f64 {
    let mut p = ProcessingConfig {
        peak_grouping: false,
        ..ProcessingConfig::default()
    };
    p.cfar.kind = kind;
    p.cfar.p_fa = p_fa;
    let mut c = chain_with(p, &effects(&[], &[]));
    let w = WaveformConfig::default();
    let cells = (w.samples_per_chirp * w.chirps_per_frame) as f64;
    let mut n = 0usize;
    for seed in 0..frames {
        n += run_chain(&mut c, &[], 100 + seed).len();
    }
    n as f64 / (cells * frames as f64)
}

#[test]
fn cfar_false_alarm_rate_on_noise_only_cubes() {
    for kind in [CfarKind::Ca, CfarKind::Os, CfarKind::Go, CfarKind::So] {
        let pfa = false_alarm_rate(kind, 1e-3, 3);
        println!("{kind:?}-CFAR: measured P_FA {pfa:.2e} (configured 1e-3)");
        assert!(
            pfa > 0.5e-3 && pfa < 2e-3,
            "{kind:?}: measured P_FA {pfa:e} for 1e-3"
        );
    }
}

#[test]
fn cube_matches_the_if_model_sample_by_sample() {
    // Negligible thermal noise (T = 1e-12 K), no impairments: every sample of the synthesised cube
    // equals the closed-form IF model of physics.md §1.6 with TDM slots and the array phase
    // −π(d_tx·u + d_rx·u) (positions in λ/2), evaluated here directly in f64.
    let w = WaveformConfig::default();
    let a = ArrayConfig::default();
    let fe = FrontEndConfig {
        noise_temperature_k: 1e-12,
        ..FrontEndConfig::default()
    };
    let e = effects(&["radar.phase_noise", "radar.receiver_compression"], &[]);
    let mut c = RadarChain::new(&w, &a, &fe, &ProcessingConfig::default(), &e).unwrap();
    let paths = [
        point_path(12.34, 3.3, 17.0, 4.0, -70.0, 1),
        point_path(71.9, -8.1, -40.0, -2.0, -76.0, 2),
        point_path(44.4, 0.7, 5.0, 0.0, -73.0, 3),
    ];
    run_chain(&mut c, &paths, 1);
    let (re, im) = c.last_cube();
    let (ns, nc, nrx) = (w.samples_per_chirp, w.chirps_per_frame, a.n_rx());
    let lam = w.wavelength_m();
    let tc = w.chirp_interval_s();
    let pi = std::f64::consts::PI;
    let mut err2 = 0.0;
    let mut sig2 = 0.0;
    for k in [0usize, 5, 11] {
        let (t, r) = (k / nrx, k % nrx);
        for m in [0usize, 1, 77, 127] {
            for n in 0..ns {
                let mut s = Complex64::new(0.0, 0.0);
                for p in &paths {
                    let fb =
                        2.0 * w.slope_hz_per_s * p.range_m / C_M_S + 2.0 * p.range_rate_m_s / lam;
                    let time = (m * 3 + t) as f64 * tc;
                    let u = [
                        p.rx_elevation_rad.cos() * p.rx_azimuth_rad.sin(),
                        p.rx_elevation_rad.sin(),
                    ];
                    let d = [a.tx[t][0] + a.rx[r][0], a.tx[t][1] + a.rx[r][1]];
                    let ph = 2.0 * pi * fb * (w.adc_start_time_s + n as f64 / w.sample_rate_hz)
                        + 4.0 * pi * (p.range_m + p.range_rate_m_s * time) / lam
                        - pi * (d[0] as f64 * u[0] + d[1] as f64 * u[1]);
                    s += p.amplitude * Complex64::from_polar(1.0, ph);
                }
                let i = (k * nc + m) * ns + n;
                err2 += (Complex64::new(re[i] as f64, im[i] as f64) - s).norm_sqr();
                sig2 += s.norm_sqr();
            }
        }
    }
    // f32 phases of up to 4πR/λ ≈ 2.3e5 rad limit the agreement to ~1e-5.
    let rel = (err2 / sig2).sqrt();
    println!("NUFFT cube vs direct IF model: relative RMS error {rel:e}");
    assert!(rel < 1e-4, "relative error {rel:e}");
}

#[test]
fn deterministic_for_a_seed() {
    let mut a = chain();
    let mut b = chain();
    let paths = [
        point_path(20.3, 2.0, 10.0, 0.0, -95.0, 1),
        point_path(55.0, -3.0, -30.0, 0.0, -105.0, 2),
    ];
    let da = run_chain(&mut a, &paths, 42);
    let db = run_chain(&mut b, &paths, 42);
    assert_eq!(da, db);
    assert_eq!(a.last_cube(), b.last_cube());
    run_chain(&mut b, &paths, 43);
    assert_ne!(a.last_cube(), b.last_cube());
}

#[test]
fn receiver_compression_limits_strong_targets() {
    // +5 dBm is 10 dB above the (guessed) −5 dBm input P1dB: compressed by several dB when on.
    let dr = WaveformConfig::default().range_resolution_m();
    let t = [point_path(30.0 * dr, 0.0, 0.0, 0.0, 5.0, 1)];
    let mut on = chain();
    let mut off = chain_with(
        ProcessingConfig::default(),
        &effects(&["radar.receiver_compression"], &[]),
    );
    let p_on = strongest(&run_chain(&mut on, &t, 1)).power_dbm;
    let p_off = strongest(&run_chain(&mut off, &t, 1)).power_dbm;
    assert!((p_off - 5.0).abs() < 0.5, "linear receiver: {p_off} dBm");
    assert!(p_on < 5.0 - 3.0, "compressed: {p_on} dBm");
    // A weak target is unaffected.
    let t = [point_path(30.0 * dr, 0.0, 0.0, 0.0, -90.0, 1)];
    let a = strongest(&run_chain(&mut on, &t, 1)).power_dbm;
    let b = strongest(&run_chain(&mut off, &t, 1)).power_dbm;
    assert!((a - b).abs() < 1e-3, "{a} vs {b}");
}

/// Mean power (dBm) of the map row of range bin `n` away from the zero-Doppler target column.
fn doppler_floor(c: &RadarChain, n: usize) -> f64 {
    let m = c.range_doppler_map();
    let row = &m.power_dbm[n * m.doppler_bins..(n + 1) * m.doppler_bins];
    let lin: f64 = row
        .iter()
        .enumerate()
        .filter(|(d, _)| (*d as isize - m.doppler_bins as isize / 2).abs() > 8)
        .map(|(_, v)| 10f64.powf(*v as f64 / 10.0))
        .sum::<f64>()
        / (m.doppler_bins - 17) as f64;
    10.0 * lin.log10()
}

#[test]
fn phase_noise_raises_the_doppler_floor_with_range() {
    let dr = WaveformConfig::default().range_resolution_m();
    let mut on = chain();
    let mut off = chain_with(
        ProcessingConfig::default(),
        &effects(&["radar.phase_noise"], &[]),
    );
    let rise = |n: usize, on: &mut RadarChain, off: &mut RadarChain| {
        let t = [point_path(n as f64 * dr, 0.0, 0.0, 0.0, -40.0, 1)];
        run_chain(on, &t, 9);
        run_chain(off, &t, 9);
        doppler_floor(on, n) - doppler_floor(off, n)
    };
    let near = rise(10, &mut on, &mut off);
    let far = rise(200, &mut on, &mut off);
    // Range correlation: the residual phase noise grows with the delay.
    assert!(far > 3.0, "far target: floor rise {far} dB");
    assert!(far > near + 3.0, "near {near} dB, far {far} dB");
}

#[test]
fn interference_raises_the_noise_floor() {
    let mut on = chain_with(
        ProcessingConfig::default(),
        &effects(&[], &["radar.interference"]),
    );
    let mut off = chain();
    run_chain(&mut on, &[], 3);
    run_chain(&mut off, &[], 3);
    let median = |c: &RadarChain| {
        let mut v = c.range_doppler_map().power_dbm;
        v.sort_by(f32::total_cmp);
        v[v.len() / 2] as f64
    };
    let rise = median(&on) - median(&off);
    assert!(rise > 3.0, "noise floor rise {rise} dB");
}

#[test]
fn range_doppler_map_export() {
    let dr = WaveformConfig::default().range_resolution_m();
    let mut c = chain();
    run_chain(&mut c, &[point_path(40.0 * dr, 0.0, 0.0, 0.0, -70.0, 1)], 1);
    let m = c.range_doppler_map();
    assert_eq!((m.range_bins, m.doppler_bins), (256, 128));
    // The target's cell is the brightest: received power −70 dBm within the window scalloping.
    let (imax, vmax) = m
        .power_dbm
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(b.1))
        .unwrap();
    assert_eq!((imax / 128, imax % 128), (40, 64));
    assert!((vmax + 70.0).abs() < 0.5, "{vmax}");
    let pgm = m.to_pgm(-160.0, -60.0);
    let header = b"P5\n128 256\n255\n";
    assert_eq!(&pgm[..header.len()], header);
    assert_eq!(pgm.len(), header.len() + 256 * 128);
    let expect = ((vmax + 160.0) / 100.0 * 255.0).round() as u8;
    assert_eq!(pgm[header.len() + imax], expect);
}

#[test]
fn bad_configuration_names_the_key() {
    let mut p = ProcessingConfig::default();
    p.cfar.train_doppler = 70;
    let e = RadarChain::new(
        &WaveformConfig::default(),
        &ArrayConfig::default(),
        &FrontEndConfig::default(),
        &p,
        &effects(&[], &[]),
    )
    .err()
    .unwrap();
    assert!(
        matches!(&e, ModelError::Config(m) if m.contains("cfar")),
        "{e}"
    );
    let w = WaveformConfig {
        sample_rate_hz: -1.0,
        ..WaveformConfig::default()
    };
    let e = RadarChain::new(
        &w,
        &ArrayConfig::default(),
        &FrontEndConfig::default(),
        &ProcessingConfig::default(),
        &effects(&[], &[]),
    )
    .err()
    .unwrap();
    assert!(
        e.to_string().contains("radar.waveform.sample_rate_hz"),
        "{e}"
    );
    let p = ProcessingConfig {
        range_window: Window::Blackman,
        ..ProcessingConfig::default()
    };
    assert!(serde_json::to_string(&p).unwrap().contains("blackman"));
}

/// Detections within `dr` m in range and `dv` m/s of (r, v).
fn near(d: &[ChainDetection], r: f64, v: f64, dr: f64, dv: f64) -> Vec<ChainDetection> {
    d.iter()
        .filter(|x| (x.range_m - r).abs() < dr && (x.range_rate_m_s - v).abs() < dv)
        .copied()
        .collect()
}

/// `target` with a carrier phase offset (the relative phase of returns in one cell).
fn target_phase(r: f64, az_deg: f64, el_deg: f64, dbm: f64, phase: f64, id: u64) -> PathReturn {
    let mut p = point_path(r, 0.0, az_deg, el_deg, dbm, id);
    p.amplitude *= Complex64::from_polar(1.0, phase);
    p
}

#[test]
fn three_targets_in_one_range_doppler_cell_are_three_detections() {
    // Three reflectors at 20 m range and −6 / 0 / +6 m lateral offset: azimuth ∓asin(0.3) =
    // ∓17.46°, the same range and Doppler cell. The 8-element horizontal aperture (λ/2) with the
    // rectangular angle window resolves Δ(sin az) = 2/8 = 0.25; the targets are 0.30 apart.
    // Each must be reported with its own azimuth (±1°), elevation 0 (±1.5°), range (±0.3 m) and
    // object id, whatever the carrier phases of the three returns (in phase = hardest).
    let az = 0.3f64.asin().to_degrees();
    let mut c = chain();
    for (seed, phases) in [
        (1u64, [0.0, 0.0, 0.0]),
        (2, [0.0, 2.0, 4.0]),
        (3, [1.0, 0.0, 3.0]),
        (4, [0.0, std::f64::consts::PI, 0.0]),
    ] {
        let paths = [
            target_phase(20.0, -az, 0.0, -80.0, phases[0], 1),
            target_phase(20.0, 0.0, 0.0, -80.0, phases[1], 2),
            target_phase(20.0, az, 0.0, -80.0, phases[2], 3),
        ];
        let d = run_chain(&mut c, &paths, seed);
        let cell = near(&d, 20.0, 0.0, 0.5, 0.5);
        assert_eq!(cell.len(), 3, "phases {phases:?}: {cell:#?}");
        for (truth, id) in [(-az, 1u64), (0.0, 2), (az, 3)] {
            let x = cell
                .iter()
                .min_by(|a, b| {
                    (a.azimuth_rad.to_degrees() - truth)
                        .abs()
                        .total_cmp(&(b.azimuth_rad.to_degrees() - truth).abs())
                })
                .unwrap();
            println!(
                "phases {phases:?} target {truth:.2}°: az {:.3}°, el {:.3}°, range {:.3} m, {:.1} dBm",
                x.azimuth_rad.to_degrees(),
                x.elevation_rad.to_degrees(),
                x.range_m,
                x.power_dbm
            );
            assert!((x.azimuth_rad.to_degrees() - truth).abs() < 1.0, "{x:?}");
            assert!(x.elevation_rad.to_degrees().abs() < 1.5, "{x:?}");
            assert!((x.range_m - 20.0).abs() < 0.3, "{x:?}");
            assert_eq!(x.object_id, id);
        }
    }
    // One angle per cell on request: one detection.
    let p = ProcessingConfig {
        max_angle_peaks_per_cell: 1,
        ..ProcessingConfig::default()
    };
    let mut c1 = chain_with(p, &effects(&[], &[]));
    let paths = [
        point_path(20.0, 0.0, -az, 0.0, -80.0, 1),
        point_path(20.0, 0.0, 0.0, 0.0, -80.0, 2),
        point_path(20.0, 0.0, az, 0.0, -80.0, 3),
    ];
    assert_eq!(
        near(&run_chain(&mut c1, &paths, 1), 20.0, 0.0, 0.5, 0.5).len(),
        1
    );
}

#[test]
fn a_single_target_gives_one_detection_per_cell_no_sidelobe_ghosts() {
    // Rectangular angle window: first sidelobe −13 dB, inside the 15 dB dynamic range, 1.5
    // resolution cells from the main lobe: only the component fit (sidelobes subtracted with
    // their target) keeps them out. Also with Hann, at 0° and 45°, weak and very strong targets,
    // and with an elevation.
    for window in [Window::Rectangular, Window::Hann] {
        let p = ProcessingConfig {
            angle_window: window,
            ..ProcessingConfig::default()
        };
        let mut c = chain_with(p, &effects(&[], &[]));
        for (i, (az, el, dbm)) in [
            (0.0, 0.0, -80.0),
            (45.0, 0.0, -80.0),
            (0.0, 0.0, -50.0),
            (45.0, 0.0, -50.0),
            (-30.0, 5.0, -60.0),
            (12.0, 0.0, -100.0),
        ]
        .into_iter()
        .enumerate()
        {
            let d = run_chain(
                &mut c,
                &[point_path(31.3, 2.2, az, el, dbm, 5)],
                i as u64 + 10,
            );
            let cell = near(&d, 31.3, 2.2, 0.6, 0.3);
            assert_eq!(cell.len(), 1, "{window:?} {az}° {dbm} dBm: {cell:#?}");
            let x = cell[0];
            assert!((x.azimuth_rad.to_degrees() - az).abs() < 1.0, "{x:?}");
            assert!((x.elevation_rad.to_degrees() - el).abs() < 1.5, "{x:?}");
        }
    }
}

#[test]
fn a_weak_target_three_resolution_cells_from_a_strong_one_is_found() {
    // Strong target at sin az = −0.35 and one 20 dB weaker at +0.40: 0.75 = 3 resolution cells
    // (2/8 each) apart, same range and Doppler. With a 25 dB angle dynamic range both are found
    // at their azimuths with their power difference (±1.5 dB); with the default 15 dB only the
    // strong one.
    let (s1, s2) = ((-0.35f64).asin().to_degrees(), 0.40f64.asin().to_degrees());
    let paths = [
        point_path(27.0, -3.0, s1, 0.0, -70.0, 1),
        point_path(27.0, -3.0, s2, 0.0, -90.0, 2),
    ];
    let p = ProcessingConfig {
        angle_peak_dynamic_range_db: 25.0,
        ..ProcessingConfig::default()
    };
    let mut c = chain_with(p, &effects(&[], &[]));
    let mut cell = near(&run_chain(&mut c, &paths, 3), 27.0, -3.0, 0.5, 0.3);
    cell.sort_by(|a, b| b.power_dbm.total_cmp(&a.power_dbm));
    assert_eq!(cell.len(), 2, "{cell:#?}");
    assert!(
        (cell[0].azimuth_rad.to_degrees() - s1).abs() < 1.0,
        "{cell:?}"
    );
    assert!(
        (cell[1].azimuth_rad.to_degrees() - s2).abs() < 1.0,
        "{cell:?}"
    );
    assert_eq!((cell[0].object_id, cell[1].object_id), (1, 2));
    let dp = cell[0].power_dbm - cell[1].power_dbm;
    assert!((dp - 20.0).abs() < 1.5, "power difference {dp} dB");
    for x in &cell {
        assert!(x.elevation_rad.to_degrees().abs() < 1.5, "{x:?}");
    }
    let mut c15 = chain();
    let cell = near(&run_chain(&mut c15, &paths, 3), 27.0, -3.0, 0.5, 0.3);
    assert_eq!(cell.len(), 1, "{cell:#?}");
}

#[test]
fn angle_peak_and_front_end_keys_are_validated() {
    let new = |p: &ProcessingConfig, fe: &FrontEndConfig| {
        RadarChain::new(
            &WaveformConfig::default(),
            &ArrayConfig::default(),
            fe,
            p,
            &effects(&[], &[]),
        )
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default()
    };
    let fe = FrontEndConfig::default();
    for (p, key) in [
        (
            ProcessingConfig {
                angle_peak_dynamic_range_db: -1.0,
                ..ProcessingConfig::default()
            },
            "radar.processing.angle_peak_dynamic_range_db",
        ),
        (
            ProcessingConfig {
                max_angle_peaks_per_cell: 0,
                ..ProcessingConfig::default()
            },
            "radar.processing.max_angle_peaks_per_cell",
        ),
        (
            ProcessingConfig {
                max_angle_peaks_per_cell: 99,
                ..ProcessingConfig::default()
            },
            "radar.processing.max_angle_peaks_per_cell",
        ),
    ] {
        assert!(new(&p, &fe).contains(key), "{key}");
    }
    let p = ProcessingConfig::default();
    for (fe, key) in [
        (
            FrontEndConfig {
                input_p1db_dbm: f64::NAN,
                ..FrontEndConfig::default()
            },
            "radar.front_end.input_p1db_dbm",
        ),
        (
            FrontEndConfig {
                adc_full_scale_dbm: f64::INFINITY,
                ..FrontEndConfig::default()
            },
            "radar.front_end.adc_full_scale_dbm",
        ),
        (
            FrontEndConfig {
                rapp_smoothness: 0.0,
                ..FrontEndConfig::default()
            },
            "radar.front_end.rapp_smoothness",
        ),
    ] {
        assert!(new(&p, &fe).contains(key), "{key}");
    }
    // Serde: the new keys have defaults and round-trip.
    let fe: FrontEndConfig = serde_json::from_str(r#"{"input_p1db_dbm": -10.0}"#).unwrap();
    assert_eq!(fe.input_p1db_dbm, -10.0);
    assert_eq!(
        fe.rapp_smoothness,
        FrontEndConfig::default().rapp_smoothness
    );
    let p: ProcessingConfig =
        serde_json::from_str(r#"{"angle_peak_dynamic_range_db": 20.0}"#).unwrap();
    assert_eq!(p.angle_peak_dynamic_range_db, 20.0);
    assert_eq!(p.max_angle_peaks_per_cell, 4);
}

#[test]
fn compression_follows_the_front_end_p1db() {
    // A −20 dBm target: linear with the default P1dB (−5 dBm), compressed by several dB with a
    // P1dB of −35 dBm (the Rapp gain at 15 dB over P1dB, p = 2, and ADC clipping).
    let e = effects(&[], &[]);
    let power = |p1db: f64| {
        let fe = FrontEndConfig {
            input_p1db_dbm: p1db,
            adc_full_scale_dbm: p1db + 2.0,
            ..FrontEndConfig::default()
        };
        let mut c = RadarChain::new(
            &WaveformConfig::default(),
            &ArrayConfig::default(),
            &fe,
            &ProcessingConfig::default(),
            &e,
        )
        .unwrap();
        strongest(&run_chain(
            &mut c,
            &[point_path(25.3, 1.0, 0.0, 0.0, -20.0, 1)],
            1,
        ))
        .power_dbm
    };
    let linear = power(-5.0);
    assert!((linear + 20.0).abs() < 1.0, "{linear}");
    let compressed = power(-35.0);
    assert!(compressed < linear - 5.0, "{compressed} vs {linear}");
}
