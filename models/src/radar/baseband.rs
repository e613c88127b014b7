//! FMCW baseband, the waveform side of the chain: IF cube synthesis (samples × chirps × virtual
//! channels) from the propagation paths with thermal noise and impairments, windowing, range FFT,
//! Doppler FFT (in [`RadarChain::synthesize`], per channel) and non-coherent integration into the
//! range-Doppler map (in [`RadarChain::process`]). The detection side is a
//! second `impl RadarChain` in [`super::processing`]: the 2-D CFAR (`processing/cfar.rs`) and,
//! per CFAR hit, peak interpolation, TDM Doppler-ambiguity hypothesis test, angle FFT with a joint
//! fit of several targets per range-Doppler cell and the angle gate (`processing/angle.rs`).
//!
//! API contract (used by the radar sensor): one [`RadarChain`] per model instance, planned once;
//! the sensor declares its field of view ([`RadarChain::set_field_of_view`]); per frame
//! [`RadarChain::run`] synthesises the IF cube from the paths and processes it into detections.
//!
//! # IF model (physics.md §1.6)
//! Complex (IQ) ADC, IF = LO · conj(RX). Sample n of chirp m of virtual channel k = (Tx t, Rx r):
//!
//! `s = Σ_p a_p exp(j[2π f_b,p (t_adc + n/f_s) + 4π(R_p + v_p (m T_c' + t T_c))/λ + φ_k,p]) + w`
//!
//! with `f_b = 2 S R / c + 2 v / λ`, `T_c'` the per-Tx repetition interval (N_tx T_c in TDM-MIMO,
//! slot offset t T_c: the TDM velocity–angle coupling), and the array phase
//! `φ_k,p = −π (d_t · u_tx,p + d_r · u_rx,p)` with element positions d in λ/2 units and
//! `u = (cos el sin az, sin el)` (an element displaced towards the path shortens it: the phase falls,
//! consistently with the +4πR/λ range phase). Approximations (stated): stop-and-hop within a chirp
//! (the Doppler only shifts f_b), no range migration across the frame (R fixed, the range rate
//! only advances the phase), an ideal complex anti-alias filter passing beat frequencies in
//! [0, f_s) (paths beyond R_max are dropped, not folded), no ADC quantisation.
//! `w`: complex white Gaussian thermal noise of power `k T₀ F_n f_s` per sample referred to the
//! receiver input (physics.md §1.1; B = f_s for complex sampling).
//!
//! # Hot loop
//! For every cell (chirp m, virtual channel k) the fast-time samples are a sum of complex
//! exponentials at the paths' beat frequencies, `s[n] = Σ_p C_p e^{jω_p n}` with
//! `C_p = A_p e^{jΔ_p m} e^{jσ_p z_m} · c_p[k]` (separable slow-time, phase-noise and channel
//! factors, formed once per slot / channel). The direct sum costs N_s·N_p complex MACs per cell
//! (786 M per frame for 256 × 128 × 12 × 2000); it is evaluated instead as a type-1 non-uniform
//! FFT (Barnett, Magland, af Klinteberg, SIAM J. Sci. Comput. 41(5), 2019): each path is spread
//! onto a 2× oversampled grid with an 8-point exponential-of-semicircle kernel (weights computed
//! once per path and frame), one inverse FFT of 2 N_s points per cell, then a deconvolution by the
//! kernel's Fourier transform. Cost ≈ 8 N_p + FFT per cell (~30× fewer operations); the result
//! equals the direct sum to ≈ 1e-7 relative (the f32 limit; checked sample by sample in
//! `models/tests/radar_baseband.rs`). No per-sample trig; the spreading loop runs in an
//! AVX2 + FMA build with run-time dispatch (portable fallback); noise seeded per cell.
//!
//! One rayon task per virtual channel: its chirps' samples, then their range FFTs, then the
//! channel's Doppler FFTs while its range spectra (N_c × N_s, a per-task buffer) are still in
//! cache, written into the `[range][channel][Doppler]` cube; [`RadarChain::process`] then sums
//! the channels into the power map. With AVX2 + FMA and N_c a multiple of 4, four chirps of the
//! channel are spread together ([`spread_quad`]: each grid point holds the four cells' values in
//! one register, every access aligned, one kernel weight feeding four cells). The time-domain
//! cube and the Doppler cube are written with streaming stores (not read again in the task). The
//! thermal noise is the same per-cell `SmallRng` stream of `StandardNormal` deviates as before,
//! drawn by an inlined copy of the sampler ([`crate::rng::standard_normal`], bit-identical), four
//! cells' streams at once in AVX2 registers with the four-cell spreading
//! ([`crate::rng::NormalQuad`]).
//! Measured on the imaging preset (512 × 64 × 192, 2,000 paths; `osiris bench radar`, 2 threads):
//! the synthesis with the Doppler FFTs went from 80 + 21 ms to 49 ms per frame (docs/benchmarks/).

use crate::constants::SPEED_OF_LIGHT_M_S;
use crate::rng::{NormalQuad, splitmix64, standard_normal};
use std::sync::Arc;

use num_complex::{Complex, Complex64};
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};
use rand_distr::StandardNormal;
use rayon::prelude::*;
use rustfft::{Fft, FftPlanner};

use crate::effects::{EffectInfo, Effects};
use crate::error::ModelError;

use super::PathReturn;
use super::antenna::{Antennas, FrontEndConfig};
use super::processing::{self, CfarKind, MAX_ANGLE_PEAKS, ProcessingConfig};
use super::waveform::{ArrayConfig, InterfererConfig, PhaseNoiseConfig, WaveformConfig};

pub(super) type C32 = Complex<f32>;

/// `radar.receiver_compression`: AM/AM compression of the receiver and ADC clipping.
pub const RECEIVER_COMPRESSION: EffectInfo = EffectInfo {
    name: "radar.receiver_compression",
    default_on: true,
    summary: "memoryless AM/AM compression of the IF samples before the ADC, Rapp model \
              |y| = |x| / (1 + (|x|/A_sat)^{2p})^{1/(2p)} with A_sat from the input 1 dB compression \
              point (A_sat = A_1dB / (10^{p/10} − 1)^{1/(2p)}), then I and Q clipped at the ADC full \
              scale; off: linear receiver, unlimited ADC",
    source: "C. Rapp, \"Effects of HPA-nonlinearity on a 4-DPSK/OFDM-signal for a digital sound \
             broadcasting system\", 2nd European Conf. on Satellite Communications, 1991",
    requires: None,
};

/// `radar.phase_noise`: oscillator phase noise with range correlation.
pub const PHASE_NOISE: EffectInfo = EffectInfo {
    name: "radar.phase_noise",
    default_on: true,
    summary: "oscillator phase noise after range correlation: the IF of a path with delay τ carries \
              φ(t) − φ(t−τ), PSD 2L(f)·4 sin²(π f τ), L(f) = L₀/(1+(f/f_c)²); its chirp average \
              (×sinc²(f T_s)) has σ² = ∫ 2L(f) 4 sin²(π f τ) sinc²(f T_s) df and is applied as a \
              random phase σ(τ)·z per chirp (z ~ N(0,1) common to all paths: one oscillator), raising \
              the Doppler noise floor around strong targets, growing with range (intra-chirp range \
              skirts not modelled)",
    source: "M. C. Budge, M. P. Burt, \"Range correlation effects in radars\", IEEE National Radar \
             Conference 1993, pp. 212–216",
    requires: None,
};

/// `radar.interference`: another FMCW radar's chirps crossing ours.
pub const INTERFERENCE: EffectInfo = EffectInfo {
    name: "radar.interference",
    default_on: false,
    summary: "mutual interference of another FMCW radar: its chirp f_i(t) = f_0i + S_i (t − t_q) \
              mixed with our LO gives an IF sweep Δf(t) = f_v(t) − f_i(t); while Δf lies inside the \
              IF band [0, f_s) the ADC sees a chirped burst √P_i e^{j2π∫Δf dt} (per Rx with the \
              interferer's array phase), which raises the noise floor after the range FFT",
    source: "M. Goppelt, H.-L. Blöcher, W. Menzel, \"Automotive radar – investigation of mutual \
             interference mechanisms\", Adv. Radio Sci. 8, 55–60 (2010); M. Toth et al., \
             \"Analytical investigation of non-coherent mutual FMCW radar interference\", EuRAD 2018",
    requires: None,
};

/// Effects declared by this module.
pub const EFFECTS: &[EffectInfo] = &[RECEIVER_COMPRESSION, PHASE_NOISE, INTERFERENCE];

/// One detection of the processing chain (sensor frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChainDetection {
    /// Range, m (interpolated).
    pub range_m: f64,
    /// Range rate, m/s, positive away (interpolated; unfolded into ±N_tx v_max by the TDM
    /// hypothesis test with `velocity_disambiguation`, else within ±v_max).
    pub range_rate_m_s: f64,
    /// Azimuth, rad (about +z from +x).
    pub azimuth_rad: f64,
    /// Elevation, rad (positive up; 0 when the array has no vertical aperture).
    pub elevation_rad: f64,
    /// Received power of the peak referred to the receiver input, dBm.
    pub power_dbm: f64,
    /// Signal-to-noise ratio after processing, dB.
    pub snr_db: f64,
    /// Ground-truth object of the path within one range and Doppler bin of the detection that is
    /// nearest in azimuth (paths within half an angular resolution cell count as equally near;
    /// the strongest of those).
    pub object_id: u64,
}

/// The range-Doppler map of the last frame (non-coherent sum over the virtual channels).
#[derive(Debug, Clone, PartialEq)]
pub struct RangeDopplerMap {
    /// Number of range bins (rows).
    pub range_bins: usize,
    /// Number of Doppler bins (columns), zero velocity at column `doppler_bins / 2`.
    pub doppler_bins: usize,
    /// Range bin width, m.
    pub range_bin_m: f64,
    /// Doppler bin width, m/s.
    pub doppler_bin_m_s: f64,
    /// Power per cell referred to the receiver input as dBm (10 log10 of the window-normalised
    /// per-channel mean), row-major `[range][doppler]`.
    pub power_dbm: Vec<f32>,
}

impl RangeDopplerMap {
    /// The map as an 8-bit binary PGM image (netpbm "P5"): one row per range bin (range 0 at
    /// the top), one column per Doppler bin (zero velocity in the middle), grey level linear in
    /// dBm between `floor_dbm` (black) and `ceil_dbm` (white).
    pub fn to_pgm(&self, floor_dbm: f32, ceil_dbm: f32) -> Vec<u8> {
        let mut out = format!("P5\n{} {}\n255\n", self.doppler_bins, self.range_bins).into_bytes();
        let span = (ceil_dbm - floor_dbm).max(1e-6);
        out.extend(
            self.power_dbm
                .iter()
                .map(|&v| (((v - floor_dbm) / span).clamp(0.0, 1.0) * 255.0).round() as u8),
        );
        out
    }
}

/// Per-frame path data after the in-band filter.
#[derive(Debug, Clone, Copy)]
pub(super) struct PathPre {
    pub(super) beat_hz: f64,
    pub(super) range_rate_m_s: f64,
    pub(super) amplitude_sq_w: f64,
    pub(super) object_id: u64,
    /// Horizontal direction sine of the two-way path, mean of Tx and Rx `cos el sin az`.
    pub(super) sin_az: f64,
}

/// Range bins per task of the Doppler stage (8 complex f32 = one 64-byte cache line).
const DOPPLER_BINS_PER_TASK: usize = 8;

/// The baseband synthesis and signal processing, planned once (FFT plans, buffers).
pub struct RadarChain {
    pub(super) ns: usize,
    pub(super) nc: usize,
    pub(super) ntx: usize,
    pub(super) nrx: usize,
    pub(super) nk: usize,
    ncell: usize,
    pub(super) fs_hz: f64,
    pub(super) slope: f64,
    pub(super) lambda_m: f64,
    pub(super) t_chirp_s: f64,
    pub(super) t_rep_s: f64,
    t_adc_s: f64,
    start_freq_hz: f64,
    pub(super) tdm: bool,
    tx: Vec<[i32; 2]>,
    rx: Vec<[i32; 2]>,
    pub(super) virt: Vec<[i32; 2]>,
    noise_var_w: f64,
    phase_noise: Option<PhaseNoiseConfig>,
    /// Chirp-averaged residual phase-noise σ (rad) at τ = i · `pn_tau_step_s` (empty when off).
    pn_table: Vec<f32>,
    pn_tau_step_s: f64,
    interferer: Option<InterfererConfig>,
    /// Rapp A_sat (√W), smoothness p, ADC full scale per rail (√W).
    compression: Option<(f32, f32, f32)>,
    pub(super) proc: ProcessingConfig,
    range_win: Vec<f32>,
    doppler_win: Vec<f32>,
    /// Noise power of one range-Doppler cell of one channel, W-equivalent (σ² Σw_r² Σw_d²).
    pub(super) noise_cell: f64,
    /// Coherent gain (Σw_r Σw_d)².
    pub(super) coherent_gain: f64,
    fft_range: Arc<dyn Fft<f32>>,
    fft_doppler: Arc<dyn Fft<f32>>,
    pub(super) fft_az: Arc<dyn Fft<f32>>,
    pub(super) az_len: usize,
    pub(super) el_len: usize,
    pub(super) y_min: i32,
    pub(super) has_el: bool,
    pub(super) angle_win: Vec<f32>,
    // CFAR tables per range bin: reference cell count and α.
    pub(super) cfar_count: Vec<usize>,
    pub(super) cfar_alpha: Vec<f64>,
    pub(super) cfar_alpha_half: f64,
    // Per-frame buffers.
    pub(super) paths: Vec<PathPre>,
    /// NUFFT: oversampled grid size, kernel half-width (rad), deconvolution per output sample.
    nufft_m: usize,
    nufft_alpha: f64,
    nufft_corr: Vec<f32>,
    fft_grid: Arc<dyn Fft<f32>>,
    spread_base: Vec<u32>,
    /// Kernel weights per path, each twice (re, im lanes of the interleaved grid).
    spread_w: Vec<[f32; 2 * NUFFT_W]>,
    /// The same weights once each ([`spread_quad`]: half the bytes to stream per cell group).
    spread_w8: Vec<[f32; NUFFT_W]>,
    ad_re: Vec<f32>,
    ad_im: Vec<f32>,
    ck_re: Vec<f32>,
    ck_im: Vec<f32>,
    pn_sigma: Vec<f32>,
    pn_z: Vec<f32>,
    slot_re: Vec<f32>,
    slot_im: Vec<f32>,
    /// Slot factors interleaved four chirps at a time ([`spread_quad`]).
    slot4: Vec<Quad>,
    /// Synthesis buffers per rayon worker (by thread index), kept across frames.
    chan_bufs: Vec<std::sync::Mutex<ChannelBufs>>,
    interf: Vec<C32>,
    interf_active: Vec<bool>,
    interf_rx: Vec<C32>,
    cube_re: Vec<f32>,
    cube_im: Vec<f32>,
    pub(super) dop: Vec<C32>,
    pub(super) power: Vec<f32>,
    pub(super) row_prefix: Vec<f64>,
    pub(super) col_out: Vec<f64>,
    pub(super) col_guard: Vec<f64>,
    pub(super) hits: Vec<(usize, usize)>,
    /// CFAR hit per range-Doppler cell (`n · nc + d`; the per-angle range grouping).
    pub(super) hit_map: Vec<bool>,
    pub(super) os_scratch: Vec<f32>,
    timings_s: [f64; 4],
    pub(super) dets: Vec<[Option<ChainDetection>; MAX_ANGLE_PEAKS]>,
    /// (range bin, Doppler bin, index) of every path, sorted by range bin.
    pub(super) path_bins: Vec<(f64, f64, u32)>,
    /// Rows (elevation indices) of the angle grid holding virtual elements.
    pub(super) el_rows: Vec<usize>,
    /// Elevation search steering phasors e^{jπ z_r s_i}, `s_i = −1 + 2i/(8·el_len)`, real and
    /// imaginary parts, row-major (`[r · 8 el_len + i]`; empty with fewer than three rows):
    /// planned once.
    pub(super) el_steer_re: Vec<f64>,
    pub(super) el_steer_im: Vec<f64>,
    /// Σ w_k² of the angle window.
    pub(super) angle_win_sq: f64,
    /// The virtual array's coordinates for the angle fit's steering vectors.
    pub(super) steer_plan: processing::SteerPlan,
    /// Per virtual element: index into `el_rows` of its row.
    pub(super) el_row_of: Vec<usize>,
    /// Per virtual element: its column is occupied in every row (matched sub-apertures for the
    /// elevation estimate).
    pub(super) el_match: Vec<bool>,
    /// Angular resolution in sin-space: main-lobe half width of the angle window, in cells of
    /// 2 / N_az (N_az: horizontal aperture in λ/2).
    pub(super) angle_res_sin: f64,
    /// Two-way main lobe of the Tx / Rx patterns, `[az_min, az_max, el_min, el_max]` rad.
    lobe_rad: [f64; 4],
    /// Declared field of view (full horizontal, full vertical), rad; `None`: not declared.
    fov_rad: Option<(f64, f64)>,
    /// Angle gate: `lobe_rad` ∩ the declared field of view, rad.
    pub(super) gate_rad: [f64; 4],
    /// Period in sin-space of the horizontal / vertical array response, `2/g` with g the greatest
    /// common divisor of the element offsets (λ/2 units); `None` for g ≤ 1 (no grating lobes in
    /// [−1, 1]) or no aperture.
    pub(super) sy_period: Option<f64>,
    pub(super) sz_period: Option<f64>,
    /// TDM Doppler-ambiguity hypotheses are tested (`velocity_disambiguation` and TDM-MIMO with
    /// compensation and more than one Tx).
    pub(super) disambiguate: bool,
    /// Hypothesis test: per elevation sample inside the gate, the window × e^{jπ z s_z} weight of
    /// every virtual element (`[sample][k]`).
    pub(super) hyp_weights: Vec<Complex64>,
    /// Hypothesis test: the azimuth FFT bins whose sine lies inside the gate.
    pub(super) hyp_bins: Vec<usize>,
}

/// Greatest common divisor (Euclid).
fn gcd(a: u32, b: u32) -> u32 {
    if b == 0 { a } else { gcd(b, a % b) }
}

/// e^{jε} for a small phase (polynomial), exact sincos beyond 0.3 rad.
#[inline(always)]
fn cis_small(e: f32) -> (f32, f32) {
    if e.abs() < 0.3 {
        let e2 = e * e;
        (
            1.0 - e2 * (0.5 - e2 / 24.0),
            e * (1.0 - e2 / 6.0 * (1.0 - e2 / 20.0)),
        )
    } else {
        let (s, c) = e.sin_cos();
        (c, s)
    }
}

impl RadarChain {
    /// Plan the chain.
    pub fn new(
        waveform: &WaveformConfig,
        array: &ArrayConfig,
        front_end: &FrontEndConfig,
        processing: &ProcessingConfig,
        effects: &Effects,
    ) -> Result<RadarChain, ModelError> {
        waveform.validate()?;
        array.validate()?;
        processing.validate()?;
        front_end.validate()?;
        let (ns, nc) = (waveform.samples_per_chirp, waveform.chirps_per_frame);
        let (ntx, nrx) = (array.n_tx(), array.n_rx());
        let nk = ntx * nrx;
        let cf = &processing.cfar;
        if 2 * (cf.guard_doppler + cf.train_doppler) + 1 > nc {
            return Err(ModelError::Config(format!(
                "`radar.processing.cfar.train_doppler` + `guard_doppler`: the CFAR window (2·{}+1 \
                 cells) exceeds the {nc} Doppler bins",
                cf.guard_doppler + cf.train_doppler
            )));
        }
        if 2 * (cf.guard_range + cf.train_range) + 1 > ns {
            return Err(ModelError::Config(format!(
                "`radar.processing.cfar.train_range` + `guard_range`: the CFAR window exceeds the \
                 {ns} range bins"
            )));
        }
        let noise_psd = front_end.noise_psd_w_per_hz();
        if !(noise_psd.is_finite() && noise_psd > 0.0) {
            return Err(ModelError::Config(
                "`radar.front_end.noise_figure_db` / `noise_temperature_k` give no finite noise power"
                    .into(),
            ));
        }
        let ncell = nk * nc;
        let mut planner = FftPlanner::<f32>::new();
        let virt = array.virtual_positions();
        let y_min = virt.iter().map(|p| p[0]).min().unwrap_or(0);
        let y_max = virt.iter().map(|p| p[0]).max().unwrap_or(0);
        let z_min = virt.iter().map(|p| p[1]).min().unwrap_or(0);
        let z_max = virt.iter().map(|p| p[1]).max().unwrap_or(0);
        let has_el = array.has_elevation();
        let az_len = processing
            .angle_fft_azimuth
            .max((y_max - y_min + 1) as usize);
        let el_len = if has_el {
            processing
                .angle_fft_elevation
                .max((z_max - z_min + 1) as usize)
        } else {
            1
        };
        // Angle window: separable over the grid rows / columns of the virtual aperture.
        let wy = processing
            .angle_window
            .coefficients((y_max - y_min + 1) as usize + 1);
        let wz = processing
            .angle_window
            .coefficients((z_max - z_min + 1) as usize + 1);
        let angle_win: Vec<f32> = virt
            .iter()
            .map(|p| {
                let iy = (p[0] - y_min) as usize + 1;
                let iz = (p[1] - z_min) as usize + 1;
                let a = |w: &Vec<f32>, i: usize, len: usize| {
                    if len <= 2 { 1.0 } else { w[i.min(len - 1)] }
                };
                a(&wy, iy, wy.len()) * if has_el { a(&wz, iz, wz.len()) } else { 1.0 }
            })
            .collect();
        let mut el_rows: Vec<usize> = virt
            .iter()
            .map(|p| ((p[1] - z_min) as usize).min(el_len - 1))
            .collect();
        el_rows.sort_unstable();
        el_rows.dedup();
        let el_steer: Vec<Complex64> = if has_el && el_rows.len() >= 3 {
            let m = 8 * el_len;
            el_rows
                .iter()
                .flat_map(|&r| {
                    (0..m).map(move |i| {
                        let s = -1.0 + 2.0 * i as f64 / m as f64;
                        Complex64::from_polar(1.0, std::f64::consts::PI * r as f64 * s)
                    })
                })
                .collect()
        } else {
            Vec::new()
        };
        let el_row_of: Vec<usize> = virt
            .iter()
            .map(|p| {
                let r = ((p[1] - z_min) as usize).min(el_len - 1);
                el_rows.binary_search(&r).unwrap_or(0)
            })
            .collect();
        // Columns present in every occupied row; without any, all elements (no matching).
        let col_in_all = |y: i32| {
            el_rows.iter().all(|&r| {
                virt.iter()
                    .any(|p| p[0] == y && ((p[1] - z_min) as usize).min(el_len - 1) == r)
            })
        };
        let mut el_match: Vec<bool> = virt.iter().map(|p| col_in_all(p[0])).collect();
        if !el_match.iter().any(|&m| m) {
            el_match.fill(true);
        }
        let angle_res_sin =
            processing.angle_window.main_lobe_half_width_bins() * 2.0 / (y_max - y_min + 1) as f64;
        let angle_win_sq: f64 = angle_win.iter().map(|&w| (w as f64).powi(2)).sum();
        // NUFFT plan: grid 2 N_s, ES kernel of W points; deconvolution 1 / ((M/2π) ψ̂(k)).
        let nufft_m = (2 * ns).max(2 * NUFFT_W);
        let nufft_alpha = std::f64::consts::PI * NUFFT_W as f64 / nufft_m as f64;
        let nufft_corr: Vec<f32> = (0..ns)
            .map(|n| {
                let k = n as f64 - (ns / 2) as f64;
                let psi_hat = es_kernel_transform(k * nufft_alpha, NUFFT_BETA) * nufft_alpha;
                (1.0 / (nufft_m as f64 / (2.0 * std::f64::consts::PI) * psi_hat)) as f32
            })
            .collect();
        let range_win = processing.range_window.coefficients(ns);
        let doppler_win = processing.doppler_window.coefficients(nc);
        let s1 = |w: &[f32]| w.iter().map(|&x| x as f64).sum::<f64>();
        let s2 = |w: &[f32]| w.iter().map(|&x| (x as f64).powi(2)).sum::<f64>();
        let noise_var_w = noise_psd * waveform.sample_rate_hz;
        let noise_cell = noise_var_w * s2(&range_win) * s2(&doppler_win);
        let coherent_gain = (s1(&range_win) * s1(&doppler_win)).powi(2);

        // CFAR reference counts and thresholds per range bin (edges have fewer rows).
        let (gr, wr) = (cf.guard_range, cf.guard_range + cf.train_range);
        let (gd, wd) = (cf.guard_doppler, cf.guard_doppler + cf.train_doppler);
        let rows = |n: usize, w: usize| (n + w).min(ns - 1) - n.saturating_sub(w) + 1;
        let cfar_count: Vec<usize> = (0..ns)
            .map(|n| rows(n, wr) * (2 * wd + 1) - rows(n, gr) * (2 * gd + 1))
            .collect();
        let mut alpha_of = std::collections::BTreeMap::new();
        let cfar_alpha = cfar_count
            .iter()
            .map(|&cnt| {
                *alpha_of.entry(cnt).or_insert_with(|| {
                    processing::cfar_alpha(cf.kind, cnt, nk, cf.p_fa, cf.os_rank)
                })
            })
            .collect();
        let interior = (2 * wr + 1) * (2 * wd + 1) - (2 * gr + 1) * (2 * gd + 1);
        let cfar_alpha_half = match cf.kind {
            CfarKind::Go | CfarKind::So => {
                processing::cfar_alpha(cf.kind, interior, nk, cf.p_fa, cf.os_rank)
            }
            _ => 0.0,
        };

        let compression = effects.is_on(&RECEIVER_COMPRESSION).then(|| {
            let p = front_end.rapp_smoothness;
            let a1db = (1e-3 * 10f64.powf(front_end.input_p1db_dbm / 10.0)).sqrt();
            let a_sat = a1db / (10f64.powf(p / 10.0) - 1.0).powf(1.0 / (2.0 * p));
            // A complex sinusoid of power P has |I| ≤ √P.
            let fs = (1e-3 * 10f64.powf(front_end.adc_full_scale_dbm / 10.0)).sqrt();
            (a_sat as f32, p as f32, fs as f32)
        });
        let nslots = nc * if waveform.tdm_mimo { ntx } else { 1 };
        // Paths pass the IF filter up to f_b = f_s: τ ≤ f_s / S (plus Doppler margin).
        let pn_tau_step_s = 1.1 * waveform.sample_rate_hz / waveform.slope_hz_per_s / 64.0;
        let pn_table = if effects.is_on(&PHASE_NOISE) {
            (0..=64)
                .map(|i| {
                    waveform
                        .phase_noise
                        .residual_variance_rad2(
                            i as f64 * pn_tau_step_s,
                            waveform.sampling_time_s(),
                        )
                        .sqrt() as f32
                })
                .collect()
        } else {
            Vec::new()
        };
        // Greatest common divisor of the element offsets along each axis: the array response is
        // periodic in sin-space with period 2/g (grating lobes for g > 1).
        let period = |axis: usize| {
            let g = virt
                .iter()
                .map(|p| (p[axis] - virt[0][axis]).unsigned_abs())
                .fold(0u32, gcd);
            (g > 1).then(|| 2.0 / f64::from(g))
        };
        let (sy_period, sz_period) = (period(0), period(1));
        let lobe_rad = Antennas::new(front_end, effects).main_lobe_rad();
        let steer_plan = processing::SteerPlan::new(&virt);
        let mut chain = RadarChain {
            ns,
            nc,
            ntx,
            nrx,
            nk,
            ncell,
            fs_hz: waveform.sample_rate_hz,
            slope: waveform.slope_hz_per_s,
            lambda_m: waveform.wavelength_m(),
            t_chirp_s: waveform.chirp_interval_s(),
            t_rep_s: waveform.tx_repetition_interval_s(ntx),
            t_adc_s: waveform.adc_start_time_s,
            start_freq_hz: waveform.carrier_frequency_hz
                - 0.5 * waveform.slope_hz_per_s * waveform.ramp_time_s,
            tdm: waveform.tdm_mimo,
            tx: array.tx.clone(),
            rx: array.rx.clone(),
            virt,
            noise_var_w,
            phase_noise: effects
                .is_on(&PHASE_NOISE)
                .then(|| waveform.phase_noise.clone()),
            pn_table,
            pn_tau_step_s,
            interferer: effects
                .is_on(&INTERFERENCE)
                .then(|| waveform.interferer.clone()),
            compression,
            proc: processing.clone(),
            range_win,
            doppler_win,
            noise_cell,
            coherent_gain,
            fft_range: planner.plan_fft_forward(ns),
            fft_doppler: planner.plan_fft_forward(nc),
            fft_az: planner.plan_fft_forward(az_len),
            az_len,
            el_len,
            y_min,
            has_el,
            angle_win,
            cfar_count,
            cfar_alpha,
            cfar_alpha_half,
            paths: Vec::new(),
            nufft_m,
            nufft_alpha,
            nufft_corr,
            fft_grid: planner.plan_fft_inverse(nufft_m),
            spread_base: Vec::new(),
            spread_w: Vec::new(),
            spread_w8: Vec::new(),
            ad_re: Vec::new(),
            ad_im: Vec::new(),
            ck_re: Vec::new(),
            ck_im: Vec::new(),
            pn_sigma: Vec::new(),
            pn_z: vec![0.0; nslots],
            slot_re: Vec::new(),
            slot_im: Vec::new(),
            slot4: Vec::new(),
            chan_bufs: Vec::new(),
            interf: vec![C32::default(); nslots * ns],
            interf_active: vec![false; nslots],
            interf_rx: vec![C32::new(1.0, 0.0); nrx],
            cube_re: vec![0.0; ncell * ns],
            cube_im: vec![0.0; ncell * ns],
            dop: vec![C32::default(); ncell * ns],
            power: vec![0.0; ns * nc],
            row_prefix: vec![0.0; ns * (3 * nc + 1)],
            col_out: vec![0.0; (ns + 1) * nc],
            col_guard: vec![0.0; (ns + 1) * nc],
            hits: Vec::new(),
            hit_map: Vec::new(),
            os_scratch: Vec::new(),
            timings_s: [0.0; 4],
            dets: Vec::new(),
            path_bins: Vec::new(),
            steer_plan,
            el_steer_re: el_steer.iter().map(|e| e.re).collect(),
            el_steer_im: el_steer.iter().map(|e| e.im).collect(),
            el_rows,
            angle_win_sq,
            el_row_of,
            el_match,
            angle_res_sin,
            lobe_rad,
            fov_rad: None,
            gate_rad: lobe_rad,
            sy_period,
            sz_period,
            disambiguate: waveform.tdm_mimo
                && processing.tdm_doppler_compensation
                && processing.velocity_disambiguation
                && ntx > 1,
            hyp_weights: Vec::new(),
            hyp_bins: Vec::new(),
        };
        chain.update_gate();
        Ok(chain)
    }

    /// Declare the sensor's field of view (full horizontal and vertical opening angles, symmetric
    /// about boresight, rad): the angle gate becomes the two-way main lobe ∩ this field of view
    /// (`ProcessingConfig::field_of_view_gate`). Until declared, the gate is the main lobe.
    pub fn set_field_of_view(&mut self, horizontal_rad: f64, vertical_rad: f64) {
        let fov = Some((horizontal_rad, vertical_rad));
        if fov != self.fov_rad {
            self.fov_rad = fov;
            self.update_gate();
        }
    }

    /// The angle gate `[az_min, az_max, el_min, el_max]`, rad: detections are reported only inside
    /// it (with `ProcessingConfig::field_of_view_gate`).
    pub fn angle_gate_rad(&self) -> [f64; 4] {
        self.gate_rad
    }

    /// Recompute the gate and the hypothesis test's elevation samples and azimuth bins.
    fn update_gate(&mut self) {
        let mut g = self.lobe_rad;
        if let Some((h, v)) = self.fov_rad {
            let (h, v) = (0.5 * h.abs(), 0.5 * v.abs());
            g = [g[0].max(-h), g[1].min(h), g[2].max(-v), g[3].min(v)];
        }
        self.gate_rad = g;
        // Elevation samples across the gate, spaced ≤ 1/(2 Z) in sin-space (Z: vertical aperture
        // in λ/2; a quarter of the first-null width 2/Z, ≤ 1 dB of beam loss between samples).
        let (z_min, z_max) = self
            .virt
            .iter()
            .fold((i32::MAX, i32::MIN), |(a, b), p| (a.min(p[1]), b.max(p[1])));
        let (s_lo, s_hi) = (g[2].sin(), g[3].sin());
        let n_el = if self.has_el && s_hi > s_lo {
            (((s_hi - s_lo) * 2.0 * f64::from(z_max - z_min + 1)).ceil() as usize).clamp(1, 64)
        } else {
            1
        };
        self.hyp_weights.clear();
        for i in 0..n_el {
            let sz = if n_el == 1 && !self.has_el {
                0.0
            } else {
                s_lo + (i as f64 + 0.5) * (s_hi - s_lo) / n_el as f64
            };
            for (p, w) in self.virt.iter().zip(&self.angle_win) {
                self.hyp_weights.push(Complex64::from_polar(
                    *w as f64,
                    std::f64::consts::PI * p[1] as f64 * sz,
                ));
            }
        }
        // Azimuth sines of the gate: the extremes of s_y = cos el sin az over the gate's box.
        let cos_el = g[2]
            .abs()
            .max(g[3].abs())
            .min(0.5 * std::f64::consts::PI)
            .cos();
        let (a0, a1) = (g[0].sin(), g[1].sin());
        let sy_lo = if a0 > 0.0 { a0 * cos_el } else { a0 };
        let sy_hi = if a1 < 0.0 { a1 * cos_el } else { a1 };
        let a = self.az_len as f64;
        self.hyp_bins = (0..self.az_len)
            .filter(|&q| {
                let signed = if q >= self.az_len / 2 {
                    q as f64 - a
                } else {
                    q as f64
                };
                let s = -2.0 * signed / a;
                // Half a bin of slack: the peak bin of a target at the gate's edge.
                s >= sy_lo - 1.0 / a && s <= sy_hi + 1.0 / a
            })
            .collect();
        if self.hyp_bins.is_empty() {
            self.hyp_bins = (0..self.az_len).collect();
        }
    }

    /// Thermal noise power per complex IF sample referred to the receiver input, `k T₀ F_n f_s`, W.
    pub fn noise_power_w(&self) -> f64 {
        self.noise_var_w
    }

    /// The time-domain IF cube of the last frame as split (re, im) √W arrays, layout
    /// `[k][m][n]` (virtual channel k = t·N_rx + r, chirp m, sample n), i.e. index
    /// `(k · N_c + m) · N_s + n`.
    pub fn last_cube(&self) -> (&[f32], &[f32]) {
        let len = self.ncell * self.ns;
        (&self.cube_re[..len], &self.cube_im[..len])
    }

    /// The non-coherently integrated range-Doppler power map of the last frame, `[range][doppler]`
    /// (Doppler bin d ↔ velocity `(d − N_c/2)·Δv` after the shift applied here), sum over the
    /// channels of `|X_k|²` in W × window gains.
    pub fn range_doppler_power(&self) -> &[f32] {
        &self.power
    }

    /// The range-Doppler map of the last frame as dBm per cell (zero Doppler centred).
    pub fn range_doppler_map(&self) -> RangeDopplerMap {
        let (ns, nc) = (self.ns, self.nc);
        let scale = 1.0 / (self.nk as f64 * self.coherent_gain);
        let mut power_dbm = vec![0f32; ns * nc];
        for n in 0..ns {
            for d in 0..nc {
                let src = self.power[n * nc + (d + nc / 2) % nc] as f64 * scale;
                power_dbm[n * nc + d] = (10.0 * (src * 1e3).max(1e-30).log10()) as f32;
            }
        }
        RangeDopplerMap {
            range_bins: ns,
            doppler_bins: nc,
            range_bin_m: SPEED_OF_LIGHT_M_S * self.fs_hz / (2.0 * self.slope * ns as f64),
            doppler_bin_m_s: self.lambda_m / (2.0 * nc as f64 * self.t_rep_s),
            power_dbm,
        }
    }

    /// One frame: synthesise the IF cube from `paths` (plus noise and impairments, random state
    /// from `seed`), process it, and append the detections to `out`.
    pub fn run(&mut self, paths: &[PathReturn], seed: u64, out: &mut Vec<ChainDetection>) {
        self.synthesize(paths, seed);
        self.process(out);
    }

    /// Per-path quantities for the frame: the fast-time rows r_p, slow-time A_p e^{jΔ_p m},
    /// channel phases c_p[k].
    fn prepare_paths(&mut self, paths: &[PathReturn]) {
        let (ns, nc, nk) = (self.ns, self.nc, self.nk);
        let lam = self.lambda_m;
        self.paths.clear();
        let mut dirs: Vec<([f64; 2], [f64; 2], f64)> = Vec::with_capacity(paths.len());
        for p in paths {
            let fb =
                2.0 * self.slope * p.range_m / SPEED_OF_LIGHT_M_S + 2.0 * p.range_rate_m_s / lam;
            let a2 = p.amplitude.norm_sqr();
            let finite = [
                p.range_m,
                p.range_rate_m_s,
                p.tx_azimuth_rad,
                p.tx_elevation_rad,
                p.rx_azimuth_rad,
                p.rx_elevation_rad,
                a2,
            ]
            .iter()
            .all(|v| v.is_finite());
            // Ideal complex anti-alias filter: beat frequencies in [0, f_s).
            if !finite || a2 <= 0.0 || !(0.0..self.fs_hz).contains(&fb) {
                continue;
            }
            self.paths.push(PathPre {
                beat_hz: fb,
                range_rate_m_s: p.range_rate_m_s,
                amplitude_sq_w: a2,
                object_id: p.object_id,
                sin_az: 0.5
                    * (p.tx_elevation_rad.cos() * p.tx_azimuth_rad.sin()
                        + p.rx_elevation_rad.cos() * p.rx_azimuth_rad.sin()),
            });
            let u = |az: f64, el: f64| [el.cos() * az.sin(), el.sin()];
            // The NUFFT evaluates k = n − N_s/2 ∈ [−N_s/2, N_s/2): fold e^{jω N_s/2} in here.
            let phase0 = 4.0 * std::f64::consts::PI * p.range_m / lam
                + 2.0 * std::f64::consts::PI * fb * (self.t_adc_s + (ns / 2) as f64 / self.fs_hz)
                + p.amplitude.arg();
            dirs.push((
                u(p.tx_azimuth_rad, p.tx_elevation_rad),
                u(p.rx_azimuth_rad, p.rx_elevation_rad),
                phase0,
            ));
        }
        let np = self.paths.len();
        for v in [
            &mut self.ad_re,
            &mut self.ad_im,
            &mut self.ck_re,
            &mut self.ck_im,
            &mut self.pn_sigma,
        ] {
            v.clear();
        }
        self.spread_base.clear();
        self.spread_base.resize(np, 0);
        self.spread_w.clear();
        self.spread_w.resize(np, [0.0; 2 * NUFFT_W]);
        self.spread_w8.clear();
        self.spread_w8.resize(np, [0.0; NUFFT_W]);
        self.ad_re.resize(nc * np, 0.0);
        self.ad_im.resize(nc * np, 0.0);
        self.ck_re.resize(nk * np, 0.0);
        self.ck_im.resize(nk * np, 0.0);
        self.pn_sigma.resize(np, 0.0);
        // Fast time via the NUFFT: per path the ES-kernel weights on the oversampled grid.
        let fs = self.fs_hz;
        let (m_grid, alpha) = (self.nufft_m, self.nufft_alpha);
        let h = 2.0 * std::f64::consts::PI / m_grid as f64;
        let beta = NUFFT_BETA;
        for ((p, (base, wts)), w8) in self
            .paths
            .iter()
            .zip(self.spread_base.iter_mut().zip(self.spread_w.iter_mut()))
            .zip(self.spread_w8.iter_mut())
        {
            let x = 2.0 * std::f64::consts::PI * p.beat_hz / fs;
            let l0 = ((x - alpha) / h).ceil() as i64;
            *base = l0.rem_euclid(m_grid as i64) as u32;
            for j in 0..NUFFT_W {
                let z = ((l0 + j as i64) as f64 * h - x) / alpha;
                let w = es_kernel(z, beta) as f32;
                wts[2 * j] = w;
                wts[2 * j + 1] = w;
                w8[j] = w;
            }
        }
        let four_pi_over_lam = 4.0 * std::f64::consts::PI / lam;
        let pi = std::f64::consts::PI;
        let mut rx_ph = vec![Complex64::default(); self.nrx];
        for (ip, (p, &(utx, urx, phase0))) in self.paths.iter().zip(&dirs).enumerate() {
            // Slow time: A e^{jΔm}, Δ = 4π v T_c'/λ; recurrence in f64 (128 steps).
            let a = Complex64::from_polar(p.amplitude_sq_w.sqrt(), phase0);
            let step =
                Complex64::from_polar(1.0, four_pi_over_lam * p.range_rate_m_s * self.t_rep_s);
            let mut z = a;
            for m in 0..nc {
                self.ad_re[m * np + ip] = z.re as f32;
                self.ad_im[m * np + ip] = z.im as f32;
                z *= step;
            }
            // Channel phase e^{j(φ_t + φ_r)} = e^{jφ_t} e^{jφ_r}: N_tx + N_rx `sincos` per path
            // instead of N_tx N_rx (f64 products, rounded to f32 as before).
            for (r, dr) in self.rx.iter().enumerate() {
                rx_ph[r] = Complex64::from_polar(
                    1.0,
                    -pi * (dr[0] as f64 * urx[0] + dr[1] as f64 * urx[1]),
                );
            }
            for (t, dt) in self.tx.iter().enumerate() {
                let slot = if self.tdm {
                    t as f64 * self.t_chirp_s
                } else {
                    0.0
                };
                let ph_t = four_pi_over_lam * p.range_rate_m_s * slot
                    - pi * (dt[0] as f64 * utx[0] + dt[1] as f64 * utx[1]);
                let e_t = Complex64::from_polar(1.0, ph_t);
                for (r, e_r) in rx_ph.iter().enumerate() {
                    let k = t * self.nrx + r;
                    let e = e_t * e_r;
                    self.ck_re[k * np + ip] = e.re as f32;
                    self.ck_im[k * np + ip] = e.im as f32;
                }
            }
            if !self.pn_table.is_empty() {
                // σ(τ) interpolated from the table, τ = 2R/c (from f_b).
                let tau = (p.beat_hz - 2.0 * p.range_rate_m_s / lam).max(0.0) / self.slope;
                let x = (tau / self.pn_tau_step_s).min((self.pn_table.len() - 1) as f64 - 1e-9);
                let i = x as usize;
                let f = (x - i as f64) as f32;
                self.pn_sigma[ip] = self.pn_table[i] * (1.0 - f) + self.pn_table[i + 1] * f;
            }
        }
    }

    /// The interference bursts per chirp slot (time domain, before the Rx phase).
    fn prepare_interference(&mut self, seed: u64) {
        let Some(ic) = self.interferer.clone() else {
            return;
        };
        let ns = self.ns;
        let amp = (1e-3 * 10f64.powf(ic.power_dbm / 10.0)).sqrt();
        let u = [
            ic.elevation_rad.cos() * ic.azimuth_rad.sin(),
            ic.elevation_rad.sin(),
        ];
        for (r, dr) in self.rx.iter().enumerate() {
            let ph = -std::f64::consts::PI * (dr[0] as f64 * u[0] + dr[1] as f64 * u[1]);
            self.interf_rx[r] = C32::new(ph.cos() as f32, ph.sin() as f32);
        }
        let (fs, s, t_adc, f0) = (self.fs_hz, self.slope, self.t_adc_s, self.start_freq_hz);
        let t_s = ns as f64 / fs;
        let (slot_dt, two_pi) = (self.t_chirp_s, 2.0 * std::f64::consts::PI);
        self.interf
            .par_chunks_mut(ns)
            .zip(self.interf_active.par_iter_mut())
            .enumerate()
            .for_each(|(g, (row, active))| {
                row.fill(C32::default());
                *active = false;
                let tg = g as f64 * slot_dt;
                let (w0, w1) = (tg + t_adc, tg + t_adc + t_s);
                let q0 = ((w0 - ic.delay_s - ic.ramp_time_s) / ic.chirp_interval_s).floor() as i64;
                let q1 = ((w1 - ic.delay_s) / ic.chirp_interval_s).floor() as i64;
                for q in q0.max(0)..=q1 {
                    let tq = ic.delay_s + q as f64 * ic.chirp_interval_s;
                    let phi0 = (splitmix64(seed ^ splitmix64(q as u64 ^ 0x1F7E_0000)) >> 11) as f64
                        * (two_pi / (1u64 << 53) as f64);
                    for (n, v) in row.iter_mut().enumerate() {
                        let t = w0 + n as f64 / fs;
                        if t < tq || t > tq + ic.ramp_time_s {
                            continue;
                        }
                        // Δf(t) = f_v(t) − f_i(t) = a + b (t − tq).
                        let a = f0 + s * (tq - tg) - ic.start_frequency_hz;
                        let b = s - ic.slope_hz_per_s;
                        let x = t - tq;
                        let df = a + b * x;
                        if !(0.0..fs).contains(&df) {
                            continue;
                        }
                        // The interferer's own chirp phase is common to the burst: φ(t) =
                        // 2π(a x + b x²/2) + φ₀ (the phase origin at its chirp start).
                        let ph = two_pi * (a * x + 0.5 * b * x * x) + phi0;
                        let ph = ph.rem_euclid(two_pi);
                        *v += C32::new((amp * ph.cos()) as f32, (amp * ph.sin()) as f32);
                        *active = true;
                    }
                }
            });
    }

    /// Slow-time factor per chirp slot: `A_p e^{jΔ_p m} · e^{jσ_p z_slot}` (phase noise folded in),
    /// layout `[slot][path]`.
    fn prepare_slots(&mut self) {
        let (np, nc) = (self.paths.len(), self.nc);
        let nslots = self.pn_z.len();
        let per_m = nslots / nc;
        self.slot_re.clear();
        self.slot_im.clear();
        self.slot_re.resize(nslots * np, 0.0);
        self.slot_im.resize(nslots * np, 0.0);
        if np == 0 {
            return;
        }
        let (ad_re, ad_im) = (&self.ad_re, &self.ad_im);
        let (sigma, pn_z) = (&self.pn_sigma, &self.pn_z);
        let pn_on = !self.pn_table.is_empty();
        self.slot_re
            .par_chunks_mut(np)
            .zip(self.slot_im.par_chunks_mut(np))
            .enumerate()
            .for_each(|(slot, (re, im))| {
                let m = slot / per_m;
                let (ar, ai) = (&ad_re[m * np..(m + 1) * np], &ad_im[m * np..(m + 1) * np]);
                if pn_on {
                    let z = pn_z[slot];
                    for i in 0..np {
                        let (c, s) = cis_small(sigma[i] * z);
                        re[i] = ar[i] * c - ai[i] * s;
                        im[i] = ar[i] * s + ai[i] * c;
                    }
                } else {
                    re.copy_from_slice(ar);
                    im.copy_from_slice(ai);
                }
            });
        // The four-cell spreading's layout: per Tx slot offset t and group of four chirps, per
        // path the four chirps' factors interleaved, `[t][m / 4][path]`.
        self.slot4.clear();
        if !self.quad_spreading() {
            return;
        }
        let nt = if self.tdm { self.ntx } else { 1 };
        self.slot4.resize(nt * (nc / 4) * np, Quad::default());
        let (sl_re, sl_im, tdm, ntx) = (&self.slot_re, &self.slot_im, self.tdm, self.ntx);
        self.slot4
            .par_chunks_mut(np)
            .enumerate()
            .for_each(|(row, out)| {
                let (t, g) = (row / (nc / 4), row % (nc / 4));
                for c in 0..4 {
                    let m = 4 * g + c;
                    let slot = if tdm { m * ntx + t } else { m };
                    let (re, im) = (&sl_re[slot * np..][..np], &sl_im[slot * np..][..np]);
                    for ((q, r), i) in out.iter_mut().zip(re).zip(im) {
                        q.0[2 * c] = *r;
                        q.0[2 * c + 1] = *i;
                    }
                }
            });
    }

    /// Whether the cells are spread four at a time ([`spread_quad`]: AVX2 + FMA, chirps in
    /// groups of four).
    fn quad_spreading(&self) -> bool {
        crate::cpu::avx2_fma() && self.nc.is_multiple_of(4) && !self.paths.is_empty()
    }

    /// Synthesise the IF cube of one frame (cube, then range FFT per chirp).
    pub fn synthesize(&mut self, paths: &[PathReturn], seed: u64) {
        let t0 = std::time::Instant::now();
        self.synthesize_inner(paths, seed);
        self.timings_s[0] = t0.elapsed().as_secs_f64();
    }

    fn synthesize_inner(&mut self, paths: &[PathReturn], seed: u64) {
        self.prepare_paths(paths);
        if self.phase_noise.is_some() {
            let mut rng = SmallRng::seed_from_u64(splitmix64(seed ^ 0x50A5_E000));
            for z in self.pn_z.iter_mut() {
                *z = rng.sample(StandardNormal);
            }
        }
        if self.interferer.is_some() {
            self.prepare_interference(seed);
        }
        self.prepare_slots();
        let (ns, nc, nk, nrx, ntx) = (self.ns, self.nc, self.nk, self.nrx, self.ntx);
        let np = self.paths.len();
        let quad = self.quad_spreading();
        let mut cube_re = std::mem::take(&mut self.cube_re);
        let mut cube_im = std::mem::take(&mut self.cube_im);
        let workers = rayon::current_num_threads().max(1);
        if self.chan_bufs.len() < workers {
            self.chan_bufs.resize_with(workers, Default::default);
        }
        let dop = DisjointMut::new(&mut self.dop);
        let this = &*self;
        let (sl_re, sl_im, ck_re, ck_im) = (
            &this.slot_re[..],
            &this.slot_im[..],
            &this.ck_re[..],
            &this.ck_im[..],
        );
        let slot4 = &this.slot4[..];
        let chan_bufs = &this.chan_bufs[..];
        let sigma = (0.5 * this.noise_var_w).sqrt() as f32;
        let tdm = this.tdm;
        let (interf, interf_active, interf_rx) = (
            &this.interf[..],
            &this.interf_active[..],
            &this.interf_rx[..],
        );
        let interf_on = this.interferer.is_some();
        let compression = this.compression;
        let (range_win, doppler_win) = (&this.range_win[..], &this.doppler_win[..]);
        let (fft, fft_doppler) = (this.fft_range.clone(), this.fft_doppler.clone());
        let (m_grid, corr, grid_fft) = (this.nufft_m, &this.nufft_corr[..], this.fft_grid.clone());
        let (spread_base, spread_w) = (&this.spread_base[..], &this.spread_w[..]);
        let spread_w8 = &this.spread_w8[..];
        let scratch_len = fft
            .get_inplace_scratch_len()
            .max(grid_fft.get_inplace_scratch_len())
            .max(fft_doppler.get_inplace_scratch_len());
        let simd = crate::cpu::avx2_fma();
        // One task per virtual channel: its chirps' fast-time samples, range FFTs, then its
        // Doppler FFTs while the channel's range spectra are still in cache.
        let chunk = nc * ns;
        cube_re
            .par_chunks_mut(chunk)
            .zip(cube_im.par_chunks_mut(chunk))
            .enumerate()
            .for_each(|(k, (cre, cim))| {
                // This worker's buffers (kept across frames: the channel's range spectra
                // alone are 256 kB, which the allocator would map and unmap per task).
                let slot = rayon::current_thread_index().unwrap_or(0) % chan_bufs.len();
                let mut guard = chan_bufs[slot].lock().unwrap_or_else(|e| e.into_inner());
                let bufs = &mut *guard;
                let grids = if quad { 4 } else { 1 } * (m_grid + NUFFT_W);
                bufs.scratch.resize(scratch_len, C32::default());
                bufs.grid.resize(grids, C32::default());
                bufs.grid4
                    .resize(if quad { m_grid + NUFFT_W } else { 0 }, Quad::default());
                bufs.cbuf.resize(2 * np, 0.0);
                bufs.spec.resize(chunk, C32::default());
                bufs.rows.resize(DOPPLER_BINS_PER_TASK * nc, C32::default());
                bufs.tre.resize(ns, 0.0);
                bufs.tim.resize(ns, 0.0);
                bufs.noise4.resize(if quad { 2 * ns } else { 0 }, [0.0; 4]);
                let ChannelBufs {
                    scratch,
                    grid,
                    grid4,
                    cbuf,
                    spec: sp,
                    rows,
                    tre,
                    tim,
                    noise4,
                } = bufs;
                let slot_of = |m: usize| if tdm { m * ntx + k / nrx } else { m };
                let cr = &ck_re[k * np..(k + 1) * np];
                let ci = &ck_im[k * np..(k + 1) * np];
                // Chirp m's samples (in `re`, `im`) → noise, interference, compression → the
                // cube, and windowed into the channel's range spectra (FFT below).
                // The noise: the cell's stream `SmallRng::seed_from_u64(cell_seed(cell))` of
                // `StandardNormal` deviates, (re, im) per sample; drawn here, or four cells'
                // at once into `noise4` (lane c: chirp m + c of the group).
                let cell_seed = |m: usize| splitmix64(seed ^ splitmix64((k * nc + m) as u64));
                let mut finish =
                    |m: usize,
                     re: &mut [f32],
                     im: &mut [f32],
                     lane: Option<(&[[f32; 4]], usize)>| {
                        if let Some((noise4, c)) = lane {
                            for ((r, i), z) in
                                re.iter_mut().zip(im.iter_mut()).zip(noise4.chunks_exact(2))
                            {
                                *r += sigma * z[0][c];
                                *i += sigma * z[1][c];
                            }
                        } else {
                            let mut rng = SmallRng::seed_from_u64(cell_seed(m));
                            for (r, i) in re.iter_mut().zip(im.iter_mut()) {
                                // `rng.sample::<f32, _>(StandardNormal)`, inlined.
                                let nr = standard_normal(&mut rng) as f32;
                                let ni = standard_normal(&mut rng) as f32;
                                *r += sigma * nr;
                                *i += sigma * ni;
                            }
                        }
                        if interf_on {
                            let slot = slot_of(m);
                            if interf_active[slot] {
                                let rxp = interf_rx[k % nrx];
                                for (n, v) in interf[slot * ns..(slot + 1) * ns].iter().enumerate()
                                {
                                    let x = v * rxp;
                                    re[n] += x.re;
                                    im[n] += x.im;
                                }
                            }
                        }
                        if let Some((a_sat, p, full)) = compression {
                            compress(re, im, a_sat, p, full);
                        }
                        // The cube is not read again this frame: streaming stores.
                        stream_copy(&mut cre[m * ns..(m + 1) * ns], re);
                        stream_copy(&mut cim[m * ns..(m + 1) * ns], im);
                        let row = &mut sp[m * ns..(m + 1) * ns];
                        for n in 0..ns {
                            row[n] = C32::new(re[n] * range_win[n], im[n] * range_win[n]);
                        }
                    };
                // Type-1 NUFFT per cell: spread C_p = slot_p · ck_p with the ES kernel onto
                // the oversampled grid, inverse FFT, deconvolve.
                let mut m = 0;
                while m < nc {
                    if np == 0 {
                        tre.fill(0.0);
                        tim.fill(0.0);
                        finish(m, tre, tim, None);
                        m += 1;
                        continue;
                    }
                    if quad {
                        // Four chirps at once (same channel, slots of one `slot4` row).
                        let t = if tdm { k / nrx } else { 0 };
                        let row = (t * (nc / 4) + m / 4) * np;
                        grid4.fill(Quad::default());
                        spread_quad(grid4, &slot4[row..row + np], cr, ci, spread_base, spread_w8);
                        split_quad(grid4, grid);
                        NormalQuad::seed_from_u64([0, 1, 2, 3].map(|c| cell_seed(m + c)))
                            .fill(noise4);
                        for (c, grid) in grid.chunks_exact_mut(m_grid + NUFFT_W).enumerate() {
                            nufft_finish(grid, m_grid, &*grid_fft, scratch, corr, tre, tim);
                            finish(m + c, tre, tim, Some((noise4, c)));
                        }
                        m += 4;
                        continue;
                    }
                    let slot = slot_of(m);
                    let adr = &sl_re[slot * np..(slot + 1) * np];
                    let adi = &sl_im[slot * np..(slot + 1) * np];
                    let grid = &mut grid[..m_grid + NUFFT_W];
                    grid.fill(C32::default());
                    spread_cell(simd, grid, [adr, adi, cr, ci], spread_base, spread_w, cbuf);
                    nufft_finish(grid, m_grid, &*grid_fft, scratch, corr, tre, tim);
                    finish(m, tre, tim, None);
                    m += 1;
                }
                fft.process_with_scratch(sp, scratch);
                // Doppler FFTs of this channel, blocks of DOPPLER_BINS_PER_TASK range bins
                // (the gather across the chirps reads each cache line once), into the
                // `[range][channel][Doppler]` cube.
                for n0 in (0..ns).step_by(DOPPLER_BINS_PER_TASK) {
                    let nb = DOPPLER_BINS_PER_TASK.min(ns - n0);
                    let rows = &mut rows[..nb * nc];
                    gather_doppler(rows, sp, ns, n0, doppler_win);
                    fft_doppler.process_with_scratch(rows, scratch);
                    for (b, row) in rows.chunks_exact(nc).enumerate() {
                        // SAFETY: task k writes only the elements (n · N_k + k) · N_c + d of
                        // channel k: no two tasks write the same element, and nothing reads
                        // `dop` during the loop.
                        let dst = unsafe { dop.slice(((n0 + b) * nk + k) * nc, nc) };
                        stream_copy(c32_as_f32_mut(dst), c32_as_f32(row));
                    }
                }
                stream_fence();
            });
        self.cube_re = cube_re;
        self.cube_im = cube_im;
    }

    /// Non-coherent integration, CFAR, interpolation, angle estimation (the Doppler FFTs ran in
    /// [`Self::synthesize`], per channel).
    pub fn process(&mut self, out: &mut Vec<ChainDetection>) {
        let t0 = std::time::Instant::now();
        self.integrate();
        let t1 = std::time::Instant::now();
        self.cfar();
        let t2 = std::time::Instant::now();
        self.estimate(out);
        let t3 = std::time::Instant::now();
        self.timings_s[1] = (t1 - t0).as_secs_f64();
        self.timings_s[2] = (t2 - t1).as_secs_f64();
        self.timings_s[3] = (t3 - t2).as_secs_f64();
    }

    /// Wall-clock seconds of the last frame's stages: synthesis (incl. the range and Doppler
    /// FFTs), non-coherent integration, CFAR, estimation (interpolation, angle, object id).
    pub fn last_timings_s(&self) -> [f64; 4] {
        self.timings_s
    }

    /// The range-Doppler power map: `Σ_k |X_k|²` over the virtual channels, per range bin.
    fn integrate(&mut self) {
        let (nc, nk) = (self.nc, self.nk);
        let per = nk * nc;
        let dop = &self.dop[..];
        self.power
            .par_chunks_mut(nc * DOPPLER_BINS_PER_TASK)
            .enumerate()
            .for_each(|(task, pw)| {
                let n0 = task * DOPPLER_BINS_PER_TASK;
                for (b, pw) in pw.chunks_mut(nc).enumerate() {
                    pw.fill(0.0);
                    let rows = &dop[(n0 + b) * per..(n0 + b + 1) * per];
                    for k in 0..nk {
                        for (p, v) in pw.iter_mut().zip(&rows[k * nc..(k + 1) * nc]) {
                            *p += v.norm_sqr();
                        }
                    }
                }
            });
    }
}

/// Per-worker buffers of the synthesis.
#[derive(Debug, Default)]
struct ChannelBufs {
    scratch: Vec<C32>,
    /// One cell's NUFFT grid (with the kernel's wrap-around tail); four of them with the
    /// four-cell spreading.
    grid: Vec<C32>,
    /// Four cells' grids, interleaved ([`spread_quad`]).
    grid4: Vec<Quad>,
    /// Path coefficients of one cell ([`spread_cell`]).
    cbuf: Vec<f32>,
    /// The channel's range spectra, `[chirp][range bin]` (windowed, before the Doppler FFT).
    spec: Vec<C32>,
    /// Doppler FFT rows of a block of range bins.
    rows: Vec<C32>,
    /// One chirp's fast-time samples.
    tre: Vec<f32>,
    tim: Vec<f32>,
    /// Four chirps' noise deviates, `[2n + (0: re, 1: im)][chirp]` ([`NormalQuad`]).
    noise4: Vec<[f32; 4]>,
}

/// `dst.copy_from_slice(src)` with non-temporal (streaming) stores on x86-64 (SSE2): data that is
/// not read again soon goes to memory without first reading its cache lines (half the memory
/// traffic of plain stores). The writing task ends with [`stream_fence`].
fn stream_copy(dst: &mut [f32], src: &[f32]) {
    assert_eq!(dst.len(), src.len());
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_loadu_ps, _mm_stream_ps};
        // Head up to 16-byte alignment, 4-float streaming stores, tail.
        let head = dst.as_ptr().align_offset(16).min(dst.len());
        let (d0, rest) = dst.split_at_mut(head);
        let (s0, srest) = src.split_at(head);
        d0.copy_from_slice(s0);
        let body = rest.len() / 4 * 4;
        for (d, s) in rest[..body].chunks_exact_mut(4).zip(srest.chunks_exact(4)) {
            // SAFETY: `d` is 4 f32 at a 16-byte aligned address (head skipped), `s` 4 f32.
            unsafe { _mm_stream_ps(d.as_mut_ptr(), _mm_loadu_ps(s.as_ptr())) };
        }
        rest[body..].copy_from_slice(&srest[body..]);
    }
    #[cfg(not(target_arch = "x86_64"))]
    dst.copy_from_slice(src);
}

/// Order the streaming stores of [`stream_copy`] before the task's later stores (and so before
/// any thread that synchronises with its end reads them).
fn stream_fence() {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a store fence (SSE, baseline on x86-64).
    unsafe {
        std::arch::x86_64::_mm_sfence()
    };
}

/// A slice that several rayon tasks write at disjoint indices (the Doppler cube, written per
/// channel in its `[range][channel][Doppler]` layout).
#[derive(Clone, Copy)]
struct DisjointMut<T> {
    ptr: *mut T,
    len: usize,
}

// SAFETY: the tasks write disjoint elements (the callers of `slice` guarantee it); `T: Send`
// values may be written from any thread.
unsafe impl<T: Send> Send for DisjointMut<T> {}
unsafe impl<T: Send> Sync for DisjointMut<T> {}

impl<T> DisjointMut<T> {
    fn new(s: &mut [T]) -> DisjointMut<T> {
        DisjointMut {
            ptr: s.as_mut_ptr(),
            len: s.len(),
        }
    }

    /// Elements `at .. at + n`.
    ///
    /// # Safety
    /// No other live reference (in any thread) may overlap them, and the slice given to `new`
    /// must outlive the result.
    #[allow(clippy::mut_from_ref)]
    unsafe fn slice(&self, at: usize, n: usize) -> &mut [T] {
        assert!(at + n <= self.len, "DisjointMut: {at} + {n} > {}", self.len);
        // SAFETY: in bounds (checked); exclusivity and lifetime are the caller's contract.
        unsafe { std::slice::from_raw_parts_mut(self.ptr.add(at), n) }
    }
}

/// The NUFFT's last steps for one cell: fold the kernel's wrap-around tail of `grid` onto its
/// start, inverse FFT of the `m_grid` points, deconvolve into the `re`, `im` fast-time samples.
fn nufft_finish(
    grid: &mut [C32],
    m_grid: usize,
    fft: &dyn Fft<f32>,
    scratch: &mut [C32],
    corr: &[f32],
    re: &mut [f32],
    im: &mut [f32],
) {
    let ns = re.len();
    let (main, tail) = grid.split_at_mut(m_grid);
    for (g, t) in main.iter_mut().zip(tail.iter()) {
        *g += *t;
    }
    fft.process_with_scratch(main, scratch);
    // Sample n is grid point (n + m_grid − ns/2) mod m_grid: the last ns/2 grid points, then the
    // first ns/2 (no integer division per sample).
    let (tail, head) = (&main[m_grid - ns / 2..], &main[..ns - ns / 2]);
    for (n, v) in tail.iter().chain(head).enumerate() {
        let v = *v * corr[n];
        re[n] = v.re;
        im[n] = v.im;
    }
}

/// Rapp AM/AM compression, then I/Q clipping at the ADC full scale: the gain
/// g = (1 + (|x|/A_sat)^{2p})^{−1/(2p)} of [`RECEIVER_COMPRESSION`], with `x2 = |x|²/A_sat²`.
fn compress(re: &mut [f32], im: &mut [f32], a_sat: f32, p: f32, full: f32) {
    // The default smoothness p = 2 (and p = 1) with square roots instead of two `powf` per sample
    // (the same gain within a few ulp; `powf` was ≈ 20 % of the IF synthesis).
    // The square roots are computed for every sample and selected (the loop vectorises); `powf`
    // only where needed.
    if p == 2.0 {
        compress_with::<true>(re, im, a_sat, full, |x2| {
            1.0 / (1.0 + x2 * x2).sqrt().sqrt()
        });
    } else if p == 1.0 {
        compress_with::<true>(re, im, a_sat, full, |x2| 1.0 / (1.0 + x2).sqrt());
    } else {
        compress_with::<false>(re, im, a_sat, full, |x2| (1.0 + x2.powf(p)).powf(-0.5 / p));
    }
}

/// [`compress`] with the gain `g(x2)` as a function of `x2 = |x|²/A_sat²`; `SELECT`: `g` is
/// cheap and free of side effects, evaluated for every sample (no branch).
#[inline(always)]
fn compress_with<const SELECT: bool>(
    re: &mut [f32],
    im: &mut [f32],
    a_sat: f32,
    full: f32,
    g: impl Fn(f32) -> f32,
) {
    let inv_a2 = 1.0 / (a_sat * a_sat);
    for (r, i) in re.iter_mut().zip(im.iter_mut()) {
        let x2 = (*r * *r + *i * *i) * inv_a2;
        // Below |x|/A_sat = 1e-2 the gain differs from 1 by < 1e-8 (p ≥ 1): 1 (× 1 is exact).
        if SELECT {
            let gain = g(x2);
            let gain = if x2 > 1e-4 { gain } else { 1.0 };
            *r *= gain;
            *i *= gain;
        } else if x2 > 1e-4 {
            let g = g(x2);
            *r *= g;
            *i *= g;
        }
        *r = r.clamp(-full, full);
        *i = i.clamp(-full, full);
    }
}

/// Width (grid points) of the NUFFT spreading kernel: relative error ≈ 10^{−(W−1)} (Barnett et al.
/// 2019) — 8 points give ~1e-7, below f32 resolution.
const NUFFT_W: usize = 8;
/// ES-kernel shape β = 2.30 W for oversampling 2 (Barnett, Magland, af Klinteberg, "A parallel
/// non-uniform fast Fourier transform library based on an exponential of semicircle kernel",
/// SIAM J. Sci. Comput. 41(5), 2019).
const NUFFT_BETA: f64 = 2.30 * NUFFT_W as f64;

/// Exponential-of-semicircle kernel φ(z) = e^{β(√(1−z²) − 1)} on |z| ≤ 1.
fn es_kernel(z: f64, beta: f64) -> f64 {
    if z.abs() >= 1.0 {
        0.0
    } else {
        (beta * ((1.0 - z * z).sqrt() - 1.0)).exp()
    }
}

/// ∫_{−1}^{1} φ(z) cos(ξ z) dz (composite Simpson, 2000 intervals; φ is smooth and ≈ e^{−β} at
/// the ends).
fn es_kernel_transform(xi: f64, beta: f64) -> f64 {
    const N: usize = 2000;
    let h = 2.0 / N as f64;
    let f = |z: f64| es_kernel(z, beta) * (xi * z).cos();
    let mut s = f(-1.0) + f(1.0);
    for i in 1..N {
        let z = -1.0 + i as f64 * h;
        s += if i % 2 == 1 { 4.0 } else { 2.0 } * f(z);
    }
    s * h / 3.0
}

/// Spread one cell's path coefficients `C_p = slot_p · ck_p` (`f = [slot_re, slot_im, ck_re,
/// ck_im]`) onto the (interleaved complex) NUFFT grid; `cbuf` holds 2·N_p floats.
fn spread_cell(
    simd: bool,
    grid: &mut [C32],
    f: [&[f32]; 4],
    base: &[u32],
    w: &[[f32; 2 * NUFFT_W]],
    cbuf: &mut [f32],
) {
    #[inline(always)]
    fn body(
        grid: &mut [C32],
        f: [&[f32]; 4],
        base: &[u32],
        w: &[[f32; 2 * NUFFT_W]],
        cbuf: &mut [f32],
    ) {
        let [ar, ai, br, bi] = f;
        let np = ar.len();
        let (cre, cim) = cbuf[..2 * np].split_at_mut(np);
        // Complex products, structure of arrays (vectorises).
        for i in 0..np {
            cre[i] = ar[i] * br[i] - ai[i] * bi[i];
            cim[i] = ar[i] * bi[i] + ai[i] * br[i];
        }
        // The grid as interleaved (re, im) f32 pairs.
        let g: &mut [f32] = bytemuck_c32(grid);
        for p in 0..np {
            let b = 2 * base[p] as usize;
            let g: &mut [f32; 2 * NUFFT_W] =
                (&mut g[b..b + 2 * NUFFT_W]).try_into().expect("support");
            let (vr, vi) = (cre[p], cim[p]);
            let wp = &w[p];
            for j in 0..NUFFT_W {
                g[2 * j] += vr * wp[2 * j];
                g[2 * j + 1] += vi * wp[2 * j + 1];
            }
        }
    }
    #[cfg(target_arch = "x86_64")]
    {
        #[target_feature(enable = "avx2,fma")]
        fn avx2(
            grid: &mut [C32],
            f: [&[f32]; 4],
            base: &[u32],
            w: &[[f32; 2 * NUFFT_W]],
            cbuf: &mut [f32],
        ) {
            body(grid, f, base, w, cbuf)
        }
        if simd {
            // SAFETY: `simd` is true only when the CPU supports AVX2 and FMA (run-time check).
            return unsafe { avx2(grid, f, base, w, cbuf) };
        }
    }
    let _ = simd;
    body(grid, f, base, w, cbuf)
}

/// Four cells' complex values at one grid point, interleaved `[re₀, im₀, …, re₃, im₃]` (32-byte
/// aligned: one AVX register).
#[derive(Debug, Clone, Copy, Default)]
#[repr(C, align(32))]
pub(super) struct Quad([f32; 8]);

/// Spread the path coefficients of four cells of one channel, `C_p = slot4_p[c] · ck_p` for the
/// cells c = 0..4, onto their interleaved grids `g4`: the products and sums of [`spread_cell`]
/// for each cell, in the same order (the grid updates fused multiply-adds: one rounding instead
/// of two, ≲ 1e-7 relative), but one kernel weight feeds four cells and every grid access is one
/// aligned register (no cache-line splits). AVX2 only ([`RadarChain::quad_spreading`]).
fn spread_quad(
    g4: &mut [Quad],
    slot4: &[Quad],
    ck_re: &[f32],
    ck_im: &[f32],
    base: &[u32],
    w: &[[f32; NUFFT_W]],
) {
    #[cfg(target_arch = "x86_64")]
    {
        #[target_feature(enable = "avx2,fma")]
        fn avx2(
            g4: &mut [Quad],
            slot4: &[Quad],
            ck_re: &[f32],
            ck_im: &[f32],
            base: &[u32],
            w: &[[f32; NUFFT_W]],
        ) {
            use std::arch::x86_64::*;
            let np = slot4.len();
            let (ck_re, ck_im, base, w) = (&ck_re[..np], &ck_im[..np], &base[..np], &w[..np]);
            let len = g4.len();
            let g = g4.as_mut_ptr().cast::<f32>();
            for p in 0..np {
                let b = base[p] as usize;
                assert!(b + NUFFT_W <= len, "kernel support inside the grid");
                // SAFETY: `Quad` is 8 f32, 32-byte aligned: an aligned AVX load.
                let s = unsafe { _mm256_load_ps(slot4[p].0.as_ptr()) };
                let (cr, ci) = (_mm256_set1_ps(ck_re[p]), _mm256_set1_ps(ck_im[p]));
                // (s_re c_re − s_im c_im, s_im c_re + s_re c_im) per cell.
                let sw = _mm256_permute_ps::<0b1011_0001>(s);
                let c = _mm256_addsub_ps(_mm256_mul_ps(s, cr), _mm256_mul_ps(sw, ci));
                let wp = &w[p];
                for (j, &w) in wp.iter().enumerate() {
                    let wj = _mm256_set1_ps(w);
                    // SAFETY: grid point b + j < len (asserted above): an aligned `Quad`.
                    unsafe {
                        let q = g.add(8 * (b + j));
                        _mm256_store_ps(q, _mm256_fmadd_ps(c, wj, _mm256_load_ps(q)));
                    }
                }
            }
        }
        if crate::cpu::avx2_fma() {
            // SAFETY: the CPU supports AVX2 and FMA (run-time check).
            return unsafe { avx2(g4, slot4, ck_re, ck_im, base, w) };
        }
    }
    let _ = (g4, slot4, ck_re, ck_im, base, w);
    unreachable!("spread_quad runs only with AVX2 + FMA (RadarChain::quad_spreading)");
}

/// 4 × 4 transpose of 64-bit elements (complex f32 values) in four AVX registers: `r[i][j]` →
/// `r[j][i]` (shuffles only: the bits are unchanged).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn transpose4(r: [std::arch::x86_64::__m256d; 4]) -> [std::arch::x86_64::__m256d; 4] {
    use std::arch::x86_64::*;
    let t0 = _mm256_unpacklo_pd(r[0], r[1]);
    let t1 = _mm256_unpackhi_pd(r[0], r[1]);
    let t2 = _mm256_unpacklo_pd(r[2], r[3]);
    let t3 = _mm256_unpackhi_pd(r[2], r[3]);
    [
        _mm256_permute2f128_pd::<0x20>(t0, t2),
        _mm256_permute2f128_pd::<0x20>(t1, t3),
        _mm256_permute2f128_pd::<0x31>(t0, t2),
        _mm256_permute2f128_pd::<0x31>(t1, t3),
    ]
}

/// The four cells interleaved in `g4` into their own grids, `out` = four consecutive grids of
/// `g4.len()` points, `out[c][l] = g4[l][c]`: 4 × 4 transposes with AVX2, else per element.
fn split_quad(g4: &[Quad], out: &mut [C32]) {
    let len = g4.len();
    let (o0, rest) = out.split_at_mut(len);
    let (o1, rest) = rest.split_at_mut(len);
    let (o2, o3) = rest.split_at_mut(len);
    let o3 = &mut o3[..len];
    #[allow(unused_mut)]
    let mut done = 0;
    #[cfg(target_arch = "x86_64")]
    {
        #[target_feature(enable = "avx2,fma")]
        fn avx2(g4: &[Quad], mut o: [&mut [C32]; 4]) -> usize {
            use std::arch::x86_64::*;
            let body = g4.len() / 4 * 4;
            for l in (0..body).step_by(4) {
                // SAFETY: `Quad` is 32 bytes, 32-byte aligned, points l..l+4 < len: aligned loads.
                let mut r = [_mm256_setzero_pd(); 4];
                for (i, r) in r.iter_mut().enumerate() {
                    *r = unsafe { _mm256_load_pd(g4[l + i].0.as_ptr().cast()) };
                }
                for (o, c) in o.iter_mut().zip(transpose4(r)) {
                    let dst = &mut o[l..l + 4];
                    // SAFETY: 4 C32 (32 bytes) in bounds (sliced above), unaligned store.
                    unsafe { _mm256_storeu_pd(dst.as_mut_ptr().cast(), c) };
                }
            }
            body
        }
        if crate::cpu::avx2_fma() {
            // SAFETY: the CPU supports AVX2 and FMA (run-time check).
            done = unsafe { avx2(g4, [&mut *o0, &mut *o1, &mut *o2, &mut *o3]) };
        }
    }
    for (l, q) in g4.iter().enumerate().skip(done) {
        o0[l] = C32::new(q.0[0], q.0[1]);
        o1[l] = C32::new(q.0[2], q.0[3]);
        o2[l] = C32::new(q.0[4], q.0[5]);
        o3[l] = C32::new(q.0[6], q.0[7]);
    }
}

/// The Doppler FFT input of `rows.len() / N_c` range bins from n0 on: `rows[b · N_c + m] =
/// spec[m · N_s + n0 + b] · w[m]` (the channel's range spectra transposed and windowed). Blocks
/// of 4 chirps × 4 range bins as 4 × 4 AVX2 transposes where the shape allows, else per element;
/// the same products either way.
fn gather_doppler(rows: &mut [C32], spec: &[C32], ns: usize, n0: usize, w: &[f32]) {
    let nc = w.len();
    let nb = rows.len() / nc;
    #[cfg(target_arch = "x86_64")]
    {
        #[target_feature(enable = "avx2,fma")]
        fn avx2(rows: &mut [C32], spec: &[C32], ns: usize, n0: usize, w: &[f32]) {
            use std::arch::x86_64::*;
            let (nc, nb) = (w.len(), rows.len() / w.len());
            for m in (0..nc).step_by(4) {
                for b0 in (0..nb).step_by(4) {
                    let mut r = [_mm256_setzero_pd(); 4];
                    for (i, r) in r.iter_mut().enumerate() {
                        let src = &spec[(m + i) * ns + n0 + b0..][..4];
                        // SAFETY: 4 C32 (32 bytes) in bounds (sliced above), unaligned load.
                        let v = unsafe { _mm256_loadu_ps(src.as_ptr().cast()) };
                        *r = _mm256_castps_pd(_mm256_mul_ps(v, _mm256_set1_ps(w[m + i])));
                    }
                    for (j, c) in transpose4(r).into_iter().enumerate() {
                        let dst = &mut rows[(b0 + j) * nc + m..][..4];
                        // SAFETY: 4 C32 in bounds (sliced above), unaligned store.
                        unsafe { _mm256_storeu_pd(dst.as_mut_ptr().cast(), c) };
                    }
                }
            }
        }
        if crate::cpu::avx2_fma() && nc.is_multiple_of(4) && nb.is_multiple_of(4) {
            // SAFETY: the CPU supports AVX2 and FMA (run-time check).
            return unsafe { avx2(rows, spec, ns, n0, w) };
        }
    }
    for (m, w) in w.iter().enumerate() {
        let src = &spec[m * ns + n0..][..nb];
        for (b, v) in src.iter().enumerate() {
            rows[b * nc + m] = *v * *w;
        }
    }
}

/// View a `Complex<f32>` slice as its interleaved (re, im) `f32`s.
fn c32_as_f32(s: &[C32]) -> &[f32] {
    // SAFETY: as in `bytemuck_c32`, read-only.
    unsafe { std::slice::from_raw_parts(s.as_ptr().cast::<f32>(), 2 * s.len()) }
}

/// View a `Complex<f32>` slice as its interleaved (re, im) `f32`s.
fn c32_as_f32_mut(s: &mut [C32]) -> &mut [f32] {
    bytemuck_c32(s)
}

/// View a `Complex<f32>` slice as its interleaved (re, im) `f32`s.
fn bytemuck_c32(s: &mut [C32]) -> &mut [f32] {
    let len = 2 * s.len();
    // SAFETY: `num_complex::Complex<f32>` is `#[repr(C)]` { re, im }: two f32 without padding,
    // alignment 4; the new slice covers exactly the same memory with the same lifetime.
    unsafe { std::slice::from_raw_parts_mut(s.as_mut_ptr().cast::<f32>(), len) }
}

#[cfg(test)]
mod tests {
    use super::compress;

    /// The Rapp gain in f64, written from the formula: g = (1 + (|x|/A)^{2p})^{−1/(2p)}.
    fn rapp(amp_over_a: f64, p: f64) -> f64 {
        (1.0 + amp_over_a.powf(2.0 * p)).powf(-1.0 / (2.0 * p))
    }

    #[test]
    fn compression_follows_rapp_for_every_smoothness() {
        let a_sat = 0.37f32;
        for p in [1.0f32, 2.0, 3.0, 0.7] {
            let amps: Vec<f32> = (0..200)
                .map(|k| a_sat * 10f32.powf(-1.9 + 4.0 * k as f32 / 199.0))
                .collect();
            // Half the amplitude in I, the rest in Q: the gain depends on |x| only.
            let mut re: Vec<f32> = amps.iter().map(|a| a * 0.6).collect();
            let mut im: Vec<f32> = amps.iter().map(|a| a * 0.8).collect();
            compress(&mut re, &mut im, a_sat, p, f32::MAX);
            for (k, &a) in amps.iter().enumerate() {
                let got = f64::from(re[k]).hypot(f64::from(im[k])) / f64::from(a);
                let want = rapp(f64::from(a) / f64::from(a_sat), f64::from(p));
                assert!(
                    (got / want - 1.0).abs() < 2e-6,
                    "p = {p}, |x|/A = {}: gain {got} vs {want}",
                    a / a_sat
                );
            }
        }
        // ADC clipping after the compression.
        let (mut re, mut im) = (vec![10.0f32, -10.0], vec![-10.0f32, 0.0]);
        compress(&mut re, &mut im, 1e3, 2.0, 0.5);
        assert_eq!((re, im), (vec![0.5, -0.5], vec![-0.5, 0.0]));
    }
}
