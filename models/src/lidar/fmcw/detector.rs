//! Beat-signal synthesis, FFT peak detection and up/down pairing of one FMCW beam
//! (physics.md §2.10).
//!
//! Per beam and ramp (up, then down), in noise units (complex white noise of unit power per sample):
//!
//! 1. **Synthesis.** s[n] = Σ_i a_i·exp(jφ_i[n]) + w[n], n < N, t_n = T_c − T_w + n/f_s, with
//!    * a_i = √(SNR_i/N), SNR_i = `CoherentReceiver::snr_per_watt`·P_i (physics.md §2.9): the
//!      rectangular-window peak SNR of return i is its coherent SNR;
//!    * speckle (`lidar.fmcw_speckle`): a_i × (x + jy)/√2, x, y ~ N(0, 1), per return and ramp;
//!    * φ_i = φ₀ + 2πf_b t ± Δψ(t) ± Δφ(t): f_b = f_up or f_down of [`super::ChirpPlan::beat_hz`], the
//!      down ramp conjugated so that its tone sits at +f_down;
//!    * chirp non-linearity (`lidar.fmcw_chirp_nonlinearity`): Δψ(t) = ψ(t) − ψ(t − τ) of the
//!      residual phase ψ of the quadratic frequency bow (quadratic in t, generated exactly by a
//!      second-order phasor recurrence);
//!    * phase noise (`lidar.fmcw_phase_noise`): Δφ[n] = σ·Σ_{k=n−d+1..n} s_k, a moving sum over
//!      d = round(τf_s) steps of one laser phase walk shared by all returns of the ramp; the steps are
//!      ±1 (Rademacher, 64 per random word) of variance σ² = 2πΔν/f_s. Its characteristic function
//!      cos(σ)^m differs from the Gaussian exp(−mσ²/2) by O(σ⁴m) — 10⁻⁶ relative at Δν = 100 kHz —
//!      so the beat spectrum is that of a Wiener phase (coherent fraction exp(−2πΔντ),
//!      physics.md §2.9) at the cost of one complex product per sample;
//!    * w[n] complex Gaussian, E|w|² = 1.
//! 2. **Spectrum.** Hann window w_n = ½ − ½cos(2πn/N), N-point FFT (planned once), power |X_k|².
//!    Noise power per bin: Σw² (= 3N/8); coherent gain of a tone on a bin: (Σw)² (= N²/4).
//! 3. **Peaks.** Bins above T = −ln(P_FA)·Σw² (exponential noise power: P(|X|² > T) = P_FA per bin)
//!    that are local maxima; the strongest first, a peak within ±2 bins of a stronger one (the Hann
//!    main lobe) dropped; a peak within 19 bins of a stronger one kept only if it also exceeds
//!    −ln(P_FA) times the smallest-of mean of 16 reference cells on either side beyond 3 guard cells
//!    (SO-CFAR, Richards 2014 §6.5, physics.md §1.7: rejects the window skirts of strong peaks,
//!    keeps a weak surface beside a strong one); with phase noise on, also −ln(P_FA) times the
//!    noise plus the expected phase-noise pedestal of the stronger peaks at that bin (the delayed
//!    self-heterodyne spectrum of the laser's calibrated linewidth, which reaches far beyond the
//!    reference cells at high SNR); at most
//!    `max_returns_per_beam` kept. Sub-bin frequency and peak power by a
//!    parabola through the log-power of the three bins (Gaussian interpolation); width: the −3 dB
//!    width walking down both sides, linearly interpolated.
//! 4. **Pairing.** A target gives one peak in each ramp. Up and down peaks are sorted by frequency and
//!    matched order-preservingly (targets of one beam see nearly the same range rate, so their order
//!    in f_R is the same in both ramps): the matching that pairs the most peaks among the admissible
//!    pairs (R ≥ −ΔR and |v_r| ≤ `max_range_rate_m_s`), ties broken by the smallest Σ|ln(P_up/P_down)|.
//!    Ambiguity: two targets whose Doppler difference exceeds their range-frequency difference swap
//!    order between the ramps and are paired wrongly (ghost ranges and rates), as in a real two-ramp
//!    sensor; unpaired peaks are dropped.
//!
//! A beam without returns is not synthesized: its false alarms are drawn in closed form (at most one
//! per ramp, probability 1 − (1 − P_FA)^N, uniform bin, power T + Exp(Σw²)).

use std::sync::Arc;

use num_complex::Complex;
use rand::Rng;
use rand_distr::StandardNormal;
use rustfft::{Fft, FftPlanner};

use crate::effects::Effects;
use crate::error::ModelError;

use super::{
    CHIRP_NONLINEARITY, ChirpPlan, CoherentReceiver, FmcwConfig, MAX_RETURNS_PER_BEAM, PHASE_NOISE,
    SPECKLE,
};

/// Object id of an echo with no contributor (a false alarm): `osiris_proto::INVALID_ID`.
pub const NO_OBJECT: u64 = osiris_proto::INVALID_ID;

/// −3 dB main-lobe width of the Hann window, bins (Harris, Proc. IEEE 66(1):51, 1978).
const HANN_3DB_BINS: f64 = 1.44;

/// Peaks within this many bins of a stronger one are its main lobe, not a second target.
const GUARD_BINS: usize = 2;

/// SO-CFAR guard cells on each side of a peak (the Hann main lobe ±2 bins, plus one).
const CFAR_GUARD_BINS: usize = 3;

/// Margin on the expected phase-noise pedestal (guessed, 10 dB): one ramp sees one realisation of
/// the laser's phase walk, whose spectrum spreads around its mean far more than white noise does
/// (and the sampled walk's spectrum lies above the Lorentzian towards f_s/2); without it, pedestal
/// bins 40–50 dB below a 90 dB peak pass as targets.
const PEDESTAL_MARGIN: f64 = 10.0;

/// SO-CFAR reference cells on each side.
const CFAR_REFERENCE_BINS: usize = 16;

/// Smallest of the mean powers of the reference cells left and right of bin `k` (circular).
fn smallest_of_mean(p: &[f32], k: usize) -> f64 {
    let n = p.len();
    let (mut left, mut right) = (0.0f64, 0.0f64);
    for i in CFAR_GUARD_BINS + 1..=CFAR_GUARD_BINS + CFAR_REFERENCE_BINS {
        left += p[(k + n - i % n) % n] as f64;
        right += p[(k + i) % n] as f64;
    }
    left.min(right) / CFAR_REFERENCE_BINS as f64
}

/// One surface seen by one sub-ray of the beam.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FmcwReturn {
    /// Range (half the two-way path), m.
    pub range_m: f64,
    /// Range rate dR/dt, m/s, positive receding.
    pub range_rate_m_s: f64,
    /// Received optical power at the detector (sub-ray weight included), W.
    pub power_w: f64,
    /// Ground-truth object ([`NO_OBJECT`] = none).
    pub object_id: u64,
}

/// One detected echo of a beam (a paired up and down beat peak).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FmcwEcho {
    /// Range c(f_up + f_down)/(4κ), m.
    pub range_m: f64,
    /// Range rate λ(f_up − f_down)/4, m/s, positive receding (OSI `radial_velocity`).
    pub range_rate_m_s: f64,
    /// Received power estimated from the two peaks (mean of the ramps), W: the true power times the
    /// speckle draw and the coherent fraction.
    pub power_w: f64,
    /// Peak SNR after the window (mean of the two ramps, linear → dB).
    pub snr_db: f64,
    /// −3 dB width of the beat peaks converted to range, (width in Hz)·c/(2κ), m (mean of the
    /// ramps): the FMCW counterpart of a pulse width, for OSI `echo_pulse_width`. ≈ 1.44·ΔR for an
    /// ideal point target (Hann), wider for phase noise, chirp non-linearity or a range spread.
    pub peak_width_m: f64,
    /// Up-ramp beat frequency (as measured, aliased into the band), Hz.
    pub beat_up_hz: f64,
    /// Down-ramp beat frequency, Hz.
    pub beat_down_hz: f64,
    /// Object contributing most power to both peaks ([`NO_OBJECT`] for a false alarm).
    pub object_id: u64,
}

/// One peak of one ramp's beat spectrum.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeatPeak {
    /// Interpolated frequency in [−f_s/2, f_s/2), Hz.
    pub frequency_hz: f64,
    /// Interpolated peak power |X|², noise units (the noise per bin is Σw²).
    pub power: f64,
    /// −3 dB width, bins.
    pub width_bins: f64,
}

/// Per-thread buffers of [`FmcwDetector::detect`].
#[derive(Debug, Clone)]
pub struct FmcwScratch {
    signal: Vec<Complex<f32>>,
    fft_scratch: Vec<Complex<f32>>,
    power: Vec<f32>,
    bits: Vec<u64>,
    candidates: Vec<(u32, f32)>,
    peaks: [Vec<BeatPeak>; 2],
    /// Drawn |a_i|² of each return in each ramp (noise units per sample).
    amps: Vec<[f64; 2]>,
}

impl FmcwScratch {
    /// The peaks of the last beam's up (`0`) or down (`1`) ramp, sorted by frequency.
    pub fn peaks(&self, ramp: usize) -> &[BeatPeak] {
        &self.peaks[ramp]
    }

    /// The power spectrum |X_k|² of the last synthesized ramp (FFT order), noise units.
    pub fn spectrum(&self) -> &[f32] {
        &self.power
    }
}

/// The FMCW detection of one beam, planned once (immutable, `Send + Sync`).
#[derive(Clone)]
pub struct FmcwDetector {
    config: FmcwConfig,
    plan: ChirpPlan,
    receiver: CoherentReceiver,
    speckle: bool,
    phase_noise: bool,
    nonlinearity: bool,
    fft: Arc<dyn Fft<f32>>,
    window: Vec<f32>,
    /// (Σw)².
    coherent_gain: f64,
    /// Σw²: noise power per bin.
    noise_bin: f64,
    /// −ln(P_FA)·Σw².
    threshold: f64,
    /// Phase-walk step σ = √(2πΔν/f_s), rad.
    pn_sigma: f64,
}

impl std::fmt::Debug for FmcwDetector {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FmcwDetector")
            .field("config", &self.config)
            .field("speckle", &self.speckle)
            .field("phase_noise", &self.phase_noise)
            .field("nonlinearity", &self.nonlinearity)
            .finish_non_exhaustive()
    }
}

/// Most phase-walk steps of one delay (longer delays are clamped: the coherent fraction there is
/// below exp(−2πΔν·4N/f_s), far into the incoherent regime at any realistic linewidth).
fn max_delay_samples(n: usize) -> usize {
    4 * n
}

impl FmcwDetector {
    /// Plans the detector: validates `config`, reads the three switches of [`super::EFFECTS`] from
    /// `effects` (which must declare them), plans the FFT and the window.
    pub fn new(config: &FmcwConfig, effects: &Effects) -> Result<FmcwDetector, ModelError> {
        config.validate()?;
        let n = config.samples_per_chirp;
        let window: Vec<f32> = (0..n)
            .map(|i| (0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / n as f64).cos()) as f32)
            .collect();
        let sum: f64 = window.iter().map(|&w| w as f64).sum();
        let sum2: f64 = window.iter().map(|&w| (w as f64).powi(2)).sum();
        let fft = FftPlanner::<f32>::new().plan_fft_forward(n);
        Ok(FmcwDetector {
            config: config.clone(),
            plan: ChirpPlan::new(config),
            receiver: CoherentReceiver::new(config),
            speckle: effects.is_on(&SPECKLE),
            phase_noise: effects.is_on(&PHASE_NOISE) && config.linewidth_hz > 0.0,
            nonlinearity: effects.is_on(&CHIRP_NONLINEARITY) && config.nonlinearity_hz > 0.0,
            fft,
            window,
            coherent_gain: sum * sum,
            noise_bin: sum2,
            threshold: -config.false_alarm_probability.ln() * sum2,
            pn_sigma: (2.0 * std::f64::consts::PI * config.linewidth_hz / config.adc_rate_hz)
                .sqrt(),
        })
    }

    /// A scratch for one worker thread.
    pub fn scratch(&self) -> FmcwScratch {
        let n = self.config.samples_per_chirp;
        let m = self.config.max_returns_per_beam;
        FmcwScratch {
            signal: vec![Complex::default(); n],
            fft_scratch: vec![Complex::default(); self.fft.get_inplace_scratch_len()],
            power: vec![0.0; n],
            bits: Vec::with_capacity((n + max_delay_samples(n)) / 64 + 2),
            candidates: Vec::with_capacity(n / 2),
            peaks: [Vec::with_capacity(m), Vec::with_capacity(m)],
            amps: Vec::new(),
        }
    }

    /// The configuration.
    pub fn config(&self) -> &FmcwConfig {
        &self.config
    }

    /// The chirp plan.
    pub fn plan(&self) -> &ChirpPlan {
        &self.plan
    }

    /// The coherent receiver.
    pub fn receiver(&self) -> &CoherentReceiver {
        &self.receiver
    }

    /// Detection threshold on |X|², noise units.
    pub fn threshold(&self) -> f64 {
        self.threshold
    }

    /// Noise power per bin Σw², noise units.
    pub fn noise_per_bin(&self) -> f64 {
        self.noise_bin
    }

    /// Coherent gain of the window (Σw)².
    pub fn coherent_gain(&self) -> f64 {
        self.coherent_gain
    }

    /// Detects the echoes of one beam and **appends** them to `out` (at most
    /// `max_returns_per_beam`). `returns` are the sub-ray hits of the beam; `background_w` the
    /// background (solar) power at the detector, W.
    pub fn detect<R: Rng + ?Sized>(
        &self,
        scratch: &mut FmcwScratch,
        returns: &[FmcwReturn],
        background_w: f64,
        rng: &mut R,
        out: &mut Vec<FmcwEcho>,
    ) {
        if returns.is_empty() {
            self.false_alarms(rng, out);
            return;
        }
        let total_w: f64 = returns.iter().map(|r| r.power_w.max(0.0)).sum();
        let n0 = self.receiver.noise_psd(total_w, background_w).total();
        let snr_per_w = self.receiver.snr_per_watt(n0);
        for ramp in 0..2 {
            self.synthesize(scratch, returns, snr_per_w, ramp, rng);
            self.spectrum(scratch);
            self.find_peaks(scratch, ramp);
        }
        self.pair(scratch, returns, snr_per_w, out);
    }

    /// Fills `scratch.signal` with the beat signal of one ramp (0 up, 1 down, conjugated).
    fn synthesize<R: Rng + ?Sized>(
        &self,
        s: &mut FmcwScratch,
        returns: &[FmcwReturn],
        snr_per_w: f64,
        ramp: usize,
        rng: &mut R,
    ) {
        let n = self.config.samples_per_chirp;
        let noise_scale = std::f32::consts::FRAC_1_SQRT_2;
        for z in s.signal.iter_mut() {
            let re: f32 = rng.sample(StandardNormal);
            let im: f32 = rng.sample(StandardNormal);
            *z = Complex::new(re * noise_scale, im * noise_scale);
        }
        s.amps.clear();
        s.amps.resize(returns.len(), [0.0; 2]);

        // One laser phase walk per ramp, shared by every return: steps s_k = ±1 for
        // k = −d_max+1 … N−1, stored at bit index k + d_max.
        let dt = 1.0 / self.config.adc_rate_hz;
        let d_of = |r: &FmcwReturn| -> usize {
            let d = (ChirpPlan::delay_s(r.range_m.max(0.0)) / dt).round();
            (d as usize).min(max_delay_samples(n))
        };
        let d_max = if self.phase_noise {
            returns.iter().map(d_of).max().unwrap_or(0)
        } else {
            0
        };
        s.bits.clear();
        if d_max > 0 {
            let words = (n + d_max).div_ceil(64);
            s.bits.extend((0..words).map(|_| rng.next_u64()));
        }
        let bit = |bits: &[u64], idx: usize| -> i32 {
            if (bits[idx >> 6] >> (idx & 63)) & 1 == 1 {
                1
            } else {
                -1
            }
        };
        let sign = if ramp == 0 { 1.0 } else { -1.0 };
        let t0 = self.plan.window_start_s();
        let tc = self.config.chirp_time_s;
        let lambda = self.plan.wavelength_m;
        let two_pi = 2.0 * std::f64::consts::PI;
        let step_up = Complex::from_polar(1.0, 2.0 * self.pn_sigma);
        let step_down = step_up.conj();

        for (i, r) in returns.iter().enumerate() {
            if !(r.power_w > 0.0 && r.range_m.is_finite()) {
                continue;
            }
            let mut amp = Complex::new((snr_per_w * r.power_w / n as f64).sqrt(), 0.0);
            if self.speckle {
                let x: f64 = rng.sample(StandardNormal);
                let y: f64 = rng.sample(StandardNormal);
                amp *= Complex::new(x, y) * std::f64::consts::FRAC_1_SQRT_2;
            }
            s.amps[i][ramp] = amp.norm_sqr();
            let (f_up, f_down) = self.plan.beat_hz(r.range_m, r.range_rate_m_s);
            let f_b = if ramp == 0 { f_up } else { f_down };
            // Phase φ(t) = φ₀ + c1·t + c2·t² in absolute ramp time t.
            let tau = ChirpPlan::delay_s(r.range_m);
            let mut c1 = two_pi * f_b;
            let mut c2 = 0.0;
            if self.nonlinearity {
                // ψ(t) = 2πδ(2t²/T − 4t³/(3T²)) → ψ(t) − ψ(t − τ) has the t² and t terms below.
                let delta = self.config.nonlinearity_hz;
                c2 += sign * -two_pi * delta * 4.0 * tau / (tc * tc);
                c1 += sign * two_pi * delta * (4.0 * tau / tc) * (1.0 + tau / tc);
            }
            let phi0 = (sign * 4.0 * std::f64::consts::PI * r.range_m / lambda).rem_euclid(two_pi);
            let start = phi0 + c1 * t0 + c2 * t0 * t0;
            let big_c1 = (c1 + 2.0 * c2 * t0) * dt;
            let big_c2 = c2 * dt * dt;
            let mut z = amp * Complex::from_polar(1.0, start.rem_euclid(two_pi));
            let mut rot = Complex::from_polar(1.0, (big_c1 + big_c2).rem_euclid(two_pi));
            let q = Complex::from_polar(1.0, (2.0 * big_c2).rem_euclid(two_pi));
            let d = if self.phase_noise { d_of(r) } else { 0 };
            if d > 0 {
                // Δφ[0] = σ·Σ_{k=−d+1..0} s_k.
                let mut acc = 0i32;
                for k in (d_max + 1 - d)..=d_max {
                    acc += bit(&s.bits, k);
                }
                let mut p = Complex::from_polar(1.0, self.pn_sigma * acc as f64);
                for (idx, out) in s.signal.iter_mut().enumerate() {
                    let v = z * p;
                    *out += Complex::new(v.re as f32, v.im as f32);
                    z *= rot;
                    rot *= q;
                    let k_new = idx + 1 + d_max;
                    if k_new < n + d_max {
                        match bit(&s.bits, k_new) - bit(&s.bits, k_new - d) {
                            2 => p *= step_up,
                            -2 => p *= step_down,
                            _ => {}
                        }
                    }
                }
            } else if big_c2 != 0.0 {
                for out in s.signal.iter_mut() {
                    *out += Complex::new(z.re as f32, z.im as f32);
                    z *= rot;
                    rot *= q;
                }
            } else {
                for out in s.signal.iter_mut() {
                    *out += Complex::new(z.re as f32, z.im as f32);
                    z *= rot;
                }
            }
        }
    }

    /// Windows and transforms `scratch.signal`, writes `scratch.power`.
    fn spectrum(&self, s: &mut FmcwScratch) {
        for (z, &w) in s.signal.iter_mut().zip(&self.window) {
            *z *= w;
        }
        self.fft
            .process_with_scratch(&mut s.signal, &mut s.fft_scratch);
        for (p, z) in s.power.iter_mut().zip(&s.signal) {
            *p = z.norm_sqr();
        }
    }

    /// Signed frequency of a (fractional) bin index, Hz.
    fn bin_frequency_hz(&self, k: f64) -> f64 {
        let n = self.config.samples_per_chirp as f64;
        let k = if k >= 0.5 * n { k - n } else { k };
        k * self.plan.bin_hz()
    }

    /// Expected |X|² in bin `k` of the phase-noise pedestal of a peak of power `peak` in bin `j`:
    /// the delayed self-heterodyne spectrum of a Lorentzian laser (linewidth Δν, delay τ from the
    /// peak's beat frequency, τ ≈ |f|/κ), per unit tone power
    /// s(f) = (Δν/π)/(Δν² + f²)·[1 − e^(−2πΔντ)(cos 2πfτ + (Δν/f) sin 2πfτ)]
    /// (Richter et al. 1986; physics.md §2.9), times the bin width and the Hann window's noise
    /// bandwidth (1.5 bins), scaled by the peak's coherent power `peak / e^(−2πΔντ)`.
    fn pedestal_per_bin(&self, peak: f64, j: usize, k: usize) -> f64 {
        let n = self.config.samples_per_chirp;
        let d = k.abs_diff(j);
        let bins = d.min(n - d) as f64;
        if bins < 1.0 {
            return 0.0;
        }
        let bin_hz = self.plan.bin_hz();
        let f = bins * bin_hz;
        let f_peak = self.bin_frequency_hz(j as f64).abs();
        let tau = f_peak / self.plan.slope_hz_per_s;
        let dnu = self.config.linewidth_hz;
        let x = 2.0 * std::f64::consts::PI;
        let coherent = (-x * dnu * tau).exp();
        let s = dnu / std::f64::consts::PI / (dnu * dnu + f * f)
            * (1.0 - coherent * ((x * f * tau).cos() + dnu / f * (x * f * tau).sin()));
        PEDESTAL_MARGIN * peak / coherent.max(1e-12) * s.max(0.0) * bin_hz * 1.5
    }

    /// Thresholds, selects and interpolates the peaks of `scratch.power` into `scratch.peaks[ramp]`.
    fn find_peaks(&self, s: &mut FmcwScratch, ramp: usize) {
        let n = self.config.samples_per_chirp;
        let p = &s.power;
        let t = self.threshold as f32;
        s.candidates.clear();
        for k in 0..n {
            let v = p[k];
            if v > t && v >= p[(k + n - 1) % n] && v > p[(k + 1) % n] {
                s.candidates.push((k as u32, v));
            }
        }
        s.candidates
            .sort_unstable_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
        let peaks = &mut s.peaks[ramp];
        peaks.clear();
        let mut kept = [0usize; MAX_RETURNS_PER_BEAM];
        let mut n_kept = 0;
        for &(k, _) in &s.candidates {
            if n_kept == self.config.max_returns_per_beam {
                break;
            }
            let k = k as usize;
            let dist = |j: usize| {
                let d = k.abs_diff(j);
                d.min(n - d)
            };
            if kept[..n_kept].iter().any(|&j| dist(j) <= GUARD_BINS) {
                continue;
            }
            // Beside a stronger peak, stand out from the local level too (SO-CFAR).
            if kept[..n_kept]
                .iter()
                .any(|&j| dist(j) <= CFAR_GUARD_BINS + CFAR_REFERENCE_BINS)
                && (p[k] as f64) < self.threshold / self.noise_bin * smallest_of_mean(p, k)
            {
                continue;
            }
            // And from the phase-noise pedestal the stronger peaks spread over the spectrum
            // (known from the laser's calibrated linewidth: noise to this detector).
            if self.phase_noise {
                let pedestal: f64 = kept[..n_kept]
                    .iter()
                    .map(|&j| self.pedestal_per_bin(p[j] as f64, j, k))
                    .sum();
                if (p[k] as f64) < self.threshold / self.noise_bin * (self.noise_bin + pedestal) {
                    continue;
                }
            }
            kept[n_kept] = k;
            n_kept += 1;
            // Gaussian (log-parabolic) interpolation.
            let floor = 1e-30f64;
            let a = (p[(k + n - 1) % n] as f64).max(floor).ln();
            let b = (p[k] as f64).max(floor).ln();
            let c = (p[(k + 1) % n] as f64).max(floor).ln();
            let denom = a - 2.0 * b + c;
            let delta = if denom < 0.0 {
                (0.5 * (a - c) / denom).clamp(-0.5, 0.5)
            } else {
                0.0
            };
            let peak = (b - 0.25 * (a - c) * delta).exp().max(p[k] as f64);
            // −3 dB width, walking down both sides.
            let half = 0.5 * peak;
            let side = |dir: isize| -> f64 {
                let mut j = k as isize;
                for steps in 0..n / 2 {
                    let next = (j + dir).rem_euclid(n as isize);
                    let pj = p[j.rem_euclid(n as isize) as usize] as f64;
                    let pn = p[next as usize] as f64;
                    if pn < half {
                        let frac = if pj > pn {
                            (pj - half) / (pj - pn)
                        } else {
                            0.0
                        };
                        return steps as f64 + frac.clamp(0.0, 1.0);
                    }
                    j = next;
                }
                (n / 2) as f64
            };
            let width = (side(-1) + side(1)).max(0.0);
            peaks.push(BeatPeak {
                frequency_hz: self.bin_frequency_hz(k as f64 + delta),
                power: peak,
                width_bins: width,
            });
        }
        peaks.sort_unstable_by(|a, b| a.frequency_hz.total_cmp(&b.frequency_hz));
    }

    /// Whether an (up, down) pair is a physical target: R ≥ −ΔR and |v_r| ≤ the configured bound.
    fn admissible(&self, f_up: f64, f_down: f64) -> bool {
        let bin = self.plan.bin_hz();
        f_up + f_down >= -2.0 * bin
            && (f_up - f_down).abs()
                <= 4.0 * self.config.max_range_rate_m_s / self.plan.wavelength_m
    }

    /// Pairs `scratch.peaks` into echoes (order-preserving matching, see the module notes).
    fn pair(
        &self,
        s: &FmcwScratch,
        returns: &[FmcwReturn],
        snr_per_w: f64,
        out: &mut Vec<FmcwEcho>,
    ) {
        let (ups, downs) = (&s.peaks[0], &s.peaks[1]);
        let (nu, nd) = (ups.len(), downs.len());
        if nu == 0 || nd == 0 {
            return;
        }
        // best[i][j]: (pairs, cost) over the first i up and j down peaks; move: 0 skip up,
        // 1 skip down, 2 pair.
        const M: usize = MAX_RETURNS_PER_BEAM + 1;
        let mut best = [[(0u8, 0.0f64, 0u8); M]; M];
        let better = |a: (u8, f64), b: (u8, f64)| a.0 > b.0 || (a.0 == b.0 && a.1 < b.1);
        for i in 0..=nu {
            for j in 0..=nd {
                if i == 0 && j == 0 {
                    continue;
                }
                let mut cand: Option<(u8, f64, u8)> = None;
                let mut offer = |c: (u8, f64, u8)| match cand {
                    Some(b) if !better((c.0, c.1), (b.0, b.1)) => {}
                    _ => cand = Some(c),
                };
                if i > 0 {
                    let b = best[i - 1][j];
                    offer((b.0, b.1, 0));
                }
                if j > 0 {
                    let b = best[i][j - 1];
                    offer((b.0, b.1, 1));
                }
                if i > 0 && j > 0 {
                    let (u, d) = (&ups[i - 1], &downs[j - 1]);
                    if self.admissible(u.frequency_hz, d.frequency_hz) {
                        let b = best[i - 1][j - 1];
                        offer((b.0 + 1, b.1 + (u.power / d.power).ln().abs(), 2));
                    }
                }
                best[i][j] = cand.expect("at least one move");
            }
        }
        let mut pairs = [(0usize, 0usize); MAX_RETURNS_PER_BEAM];
        let mut count = 0;
        let (mut i, mut j) = (nu, nd);
        while i > 0 || j > 0 {
            match best[i][j].2 {
                0 => i -= 1,
                1 => j -= 1,
                _ => {
                    pairs[count] = (i - 1, j - 1);
                    count += 1;
                    i -= 1;
                    j -= 1;
                }
            }
        }
        let bin = self.plan.bin_hz();
        let n = self.config.samples_per_chirp as f64;
        let to_watts = n / (self.coherent_gain * snr_per_w);
        for &(iu, id) in pairs[..count].iter().rev() {
            let (u, d) = (&ups[iu], &downs[id]);
            let (range, rate) = self.plan.invert(u.frequency_hz, d.frequency_hz);
            // The strongest return whose beats fall on both peaks.
            let tol_u = (2.0 + 0.5 * u.width_bins) * bin;
            let tol_d = (2.0 + 0.5 * d.width_bins) * bin;
            let mut object_id = NO_OBJECT;
            let mut strongest = 0.0;
            for (r, a) in returns.iter().zip(&s.amps) {
                let (fu, fd) = self.plan.beat_hz(r.range_m, r.range_rate_m_s);
                let du = self.plan.alias_hz(fu - u.frequency_hz).abs();
                let dd = self.plan.alias_hz(fd - d.frequency_hz).abs();
                let w = a[0] + a[1];
                if du <= tol_u && dd <= tol_d && w > strongest {
                    strongest = w;
                    object_id = r.object_id;
                }
            }
            out.push(FmcwEcho {
                range_m: range.max(0.0),
                range_rate_m_s: rate,
                power_w: 0.5 * (u.power + d.power) * to_watts,
                snr_db: 10.0 * (0.5 * (u.power + d.power) / self.noise_bin).log10(),
                peak_width_m: 0.5 * (u.width_bins + d.width_bins) * bin * self.plan.range_per_hz(),
                beat_up_hz: u.frequency_hz,
                beat_down_hz: d.frequency_hz,
                object_id,
            });
        }
    }

    /// False alarms of a beam without returns, drawn in closed form (module notes).
    fn false_alarms<R: Rng + ?Sized>(&self, rng: &mut R, out: &mut Vec<FmcwEcho>) {
        let n = self.config.samples_per_chirp;
        let p_any = -(n as f64 * (-self.config.false_alarm_probability).ln_1p()).exp_m1();
        let mut f = [0.0f64; 2];
        let mut pw = [0.0f64; 2];
        for ramp in 0..2 {
            if rng.random::<f64>() >= p_any {
                return;
            }
            let k = rng.random_range(0..n) as f64 + rng.random::<f64>() - 0.5;
            f[ramp] = self.bin_frequency_hz(k.rem_euclid(n as f64));
            let e: f64 = rng.sample(rand_distr::Exp1);
            pw[ramp] = self.threshold + e * self.noise_bin;
        }
        if !self.admissible(f[0], f[1]) {
            return;
        }
        let (range, rate) = self.plan.invert(f[0], f[1]);
        let mean = 0.5 * (pw[0] + pw[1]);
        // No signal, so no SNR-per-watt scale: power referred to the LO-limited receiver.
        let n0 = self.receiver.noise_psd(0.0, 0.0).total();
        let to_watts = n as f64 / (self.coherent_gain * self.receiver.snr_per_watt(n0));
        out.push(FmcwEcho {
            range_m: range.max(0.0),
            range_rate_m_s: rate,
            power_w: mean * to_watts,
            snr_db: 10.0 * (mean / self.noise_bin).log10(),
            peak_width_m: HANN_3DB_BINS * self.plan.bin_hz() * self.plan.range_per_hz(),
            beat_up_hz: f[0],
            beat_down_hz: f[1],
            object_id: NO_OBJECT,
        });
    }
}

#[cfg(test)]
// Tests vary one or two keys of the preset at a time.
#[allow(clippy::field_reassign_with_default)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand::rngs::SmallRng;

    const C: f64 = 299_792_458.0;
    const H: f64 = 6.626_070_15e-34;

    fn detector(cfg: &FmcwConfig, speckle: bool, phase_noise: bool, nonlin: bool) -> FmcwDetector {
        let mut e = Effects::new(super::super::EFFECTS);
        e.set("lidar.fmcw_speckle", speckle).unwrap();
        e.set("lidar.fmcw_phase_noise", phase_noise).unwrap();
        e.set("lidar.fmcw_chirp_nonlinearity", nonlin).unwrap();
        FmcwDetector::new(cfg, &e).unwrap()
    }

    fn ret(range_m: f64, range_rate_m_s: f64, power_w: f64, object_id: u64) -> FmcwReturn {
        FmcwReturn {
            range_m,
            range_rate_m_s,
            power_w,
            object_id,
        }
    }

    /// Received power that gives a (rectangular-window) coherent SNR `snr` with no background.
    fn watts_for_snr(det: &FmcwDetector, snr: f64) -> f64 {
        let rx = det.receiver();
        snr / rx.snr_per_watt(rx.noise_psd(0.0, 0.0).total())
    }

    fn run(det: &FmcwDetector, returns: &[FmcwReturn], seed: u64) -> Vec<FmcwEcho> {
        let mut s = det.scratch();
        let mut out = Vec::new();
        det.detect(
            &mut s,
            returns,
            0.0,
            &mut SmallRng::seed_from_u64(seed),
            &mut out,
        );
        out
    }

    fn kappa(cfg: &FmcwConfig) -> f64 {
        cfg.bandwidth_hz / cfg.chirp_time_s
    }

    fn window_s(cfg: &FmcwConfig) -> f64 {
        cfg.samples_per_chirp as f64 / cfg.adc_rate_hz
    }

    #[test]
    fn recovers_range_and_rate_and_aliases_beyond_the_band() {
        let cfg = FmcwConfig::default();
        let det = detector(&cfg, false, false, false);
        let p = watts_for_snr(&det, 1e4);
        let lambda = cfg.wavelength_nm * 1e-9;
        let tw = window_s(&cfg);
        let dr = C / (2.0 * kappa(&cfg) * tw);
        let dv = lambda / (2.0 * tw);
        let bin = 1.0 / tw;
        for (r, v) in [(60.0, -15.0), (23.4, 7.5), (180.0, 30.0)] {
            let f_r = 2.0 * kappa(&cfg) * r / C;
            // Receding (v > 0) raises the up-ramp beat.
            let (up, down) = (f_r + 2.0 * v / lambda, f_r - 2.0 * v / lambda);
            let echoes = run(&det, &[ret(r, v, p, 7)], 1);
            assert_eq!(echoes.len(), 1, "{echoes:?}");
            let e = echoes[0];
            assert!((e.beat_up_hz - up).abs() < bin, "{} vs {up}", e.beat_up_hz);
            assert!((e.beat_down_hz - down).abs() < bin);
            assert!((e.range_m - r).abs() < dr, "{} vs {r}", e.range_m);
            assert!(
                (e.range_rate_m_s - v).abs() < dv,
                "{} vs {v}",
                e.range_rate_m_s
            );
            assert_eq!(e.object_id, 7);
        }
        // Beyond R_max = c·f_s/(4κ) the beats wrap by f_s: never reported at the true range.
        let r_max = C * cfg.adc_rate_hz / (4.0 * kappa(&cfg));
        for r in [1.2 * r_max, 1.7 * r_max] {
            for e in run(&det, &[ret(r, 0.0, p, 7)], 2) {
                assert!((e.range_m - r).abs() > 5.0 * dr, "{e:?} at {r}");
            }
        }
    }

    #[test]
    fn snr_follows_the_coherent_lidar_equation() {
        let mut cfg = FmcwConfig::default();
        cfg.receiver_noise_a_per_sqrt_hz = 0.0;
        cfg.lo_rin_db_per_hz = -400.0;
        let det = detector(&cfg, false, false, false);
        let nu = C / (cfg.wavelength_nm * 1e-9);
        let tw = window_s(&cfg);
        // Extended target: P_r = P₀·(10 m / R)².
        let p0 = 2e-9;
        let p_at = |r: f64| p0 * (10.0 / r).powi(2);
        let n = cfg.samples_per_chirp as f64;
        // Hann: (Σw)²/(N·Σw²) = (N²/4)/(N·3N/8) = 2/3 of the matched-filter SNR.
        let expected_db = |r: f64| {
            let snr = cfg.quantum_efficiency * cfg.heterodyne_efficiency * p_at(r) * tw / (H * nu);
            10.0 * (snr * (n * n / 4.0) / (n * 3.0 * n / 8.0)).log10()
        };
        let mut measured = Vec::new();
        for r in [10.0, 20.0, 40.0] {
            let mut sum = 0.0;
            for seed in 0..8 {
                let e = run(&det, &[ret(r, 0.0, p_at(r), 1)], seed);
                assert_eq!(e.len(), 1);
                sum += e[0].snr_db;
            }
            let db = sum / 8.0;
            assert!(
                (db - expected_db(r)).abs() < 0.5,
                "{r} m: {db} vs {}",
                expected_db(r)
            );
            measured.push(db);
        }
        // Doubling the range: −6.02 dB.
        for w in measured.windows(2) {
            assert!((w[1] - w[0] + 6.02).abs() < 0.5, "{measured:?}");
        }
    }

    #[test]
    fn false_alarm_rate_matches_the_threshold() {
        let mut cfg = FmcwConfig::default();
        cfg.false_alarm_probability = 0.01;
        let det = detector(&cfg, false, false, false);
        let n = cfg.samples_per_chirp as f64;
        // Exponential noise power of mean Σw² = 3N/8: P(|X|² > T) = P_FA at T = −ln(P_FA)·3N/8.
        let t = -(0.01f64).ln() * 3.0 * n / 8.0;
        assert!((det.threshold() / t - 1.0).abs() < 1e-3);
        let mut s = det.scratch();
        let mut rng = SmallRng::seed_from_u64(3);
        let (mut over, mut total) = (0usize, 0usize);
        for _ in 0..100 {
            det.synthesize(&mut s, &[], 1.0, 0, &mut rng);
            det.spectrum(&mut s);
            over += s.spectrum().iter().filter(|&&p| p as f64 > t).count();
            total += s.spectrum().len();
        }
        let rate = over as f64 / total as f64;
        // 102 400 bins: σ ≈ 3 %.
        assert!((rate / 0.01 - 1.0).abs() < 0.12, "{rate}");
    }

    #[test]
    fn empty_beams_draw_false_alarms_in_closed_form() {
        let mut cfg = FmcwConfig::default();
        let n = cfg.samples_per_chirp as f64;
        // P(≥ 1 crossing in a ramp) = 1 − (1 − p)^N = ½.
        cfg.false_alarm_probability = 1.0 - 0.5f64.powf(1.0 / n);
        cfg.max_range_rate_m_s = 1e9; // every pair with R ≥ 0 is admissible
        let det = detector(&cfg, true, true, true);
        let mut s = det.scratch();
        let mut rng = SmallRng::seed_from_u64(4);
        let mut out = Vec::new();
        let beams = 4000;
        for _ in 0..beams {
            det.detect(&mut s, &[], 0.0, &mut rng, &mut out);
        }
        // Both ramps (¼), f_up + f_down ≥ 0 for two uniform frequencies (≈ ½).
        let rate = out.len() as f64 / beams as f64;
        assert!((rate - 0.125).abs() < 0.02, "{rate}");
        assert!(
            out.iter()
                .all(|e| e.object_id == NO_OBJECT && e.range_m >= 0.0)
        );
        cfg.false_alarm_probability = 1e-12;
        let det = detector(&cfg, true, true, true);
        out.clear();
        for _ in 0..1000 {
            det.detect(&mut s, &[], 0.0, &mut rng, &mut out);
        }
        assert!(out.is_empty());
    }

    #[test]
    fn detection_probability_of_a_speckle_target_is_swerling_1() {
        let mut cfg = FmcwConfig::default();
        cfg.false_alarm_probability = 1e-4;
        let det = detector(&cfg, true, false, false);
        let tw = window_s(&cfg);
        // A static target exactly on bin 40.
        let r = 40.0 / tw * C / (2.0 * kappa(&cfg));
        let snr_mf = 15.0;
        let snr_bin = snr_mf * 2.0 / 3.0; // Hann
        let p = watts_for_snr(&det, snr_mf);
        // Exponential signal+noise power of mean Σw²(1 + S): P_D = P_FA^(1/(1 + S)).
        let expected = 1e-4f64.powf(1.0 / (1.0 + snr_bin));
        let mut s = det.scratch();
        let mut rng = SmallRng::seed_from_u64(5);
        let snr_per_w = watts_for_snr(&det, 1.0).recip();
        let trials = 400;
        let mut hits = 0;
        for _ in 0..trials {
            det.synthesize(&mut s, &[ret(r, 0.0, p, 1)], snr_per_w, 0, &mut rng);
            det.spectrum(&mut s);
            if s.spectrum()[40] as f64 > det.threshold() {
                hits += 1;
            }
        }
        let pd = hits as f64 / trials as f64;
        assert!((pd - expected).abs() < 0.08, "{pd} vs {expected}");
    }

    /// Peak power (noise units) of the strongest up-ramp peak, 0 when none.
    fn up_peak_powers(det: &FmcwDetector, r: f64, p: f64, draws: u64) -> Vec<f64> {
        let mut s = det.scratch();
        let mut out = Vec::new();
        (0..draws)
            .map(|seed| {
                let mut rng = SmallRng::seed_from_u64(100 + seed);
                det.detect(&mut s, &[ret(r, 0.0, p, 1)], 0.0, &mut rng, &mut out);
                s.peaks(0).iter().map(|q| q.power).fold(0.0, f64::max)
            })
            .collect()
    }

    #[test]
    fn speckle_intensity_is_exponential() {
        let cfg = FmcwConfig::default();
        let on = detector(&cfg, true, false, false);
        let p = watts_for_snr(&on, 1e4);
        let i = up_peak_powers(&on, 37.0, p, 400);
        let mean = i.iter().sum::<f64>() / i.len() as f64;
        let sd = (i.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / i.len() as f64).sqrt();
        assert!((sd / mean - 1.0).abs() < 0.15, "CV {}", sd / mean);
        for x in [0.25, 0.5, 1.0, 2.0] {
            let frac = i.iter().filter(|&&v| v < mean * x).count() as f64 / i.len() as f64;
            let expected = 1.0 - (-x).exp();
            assert!(
                (frac - expected).abs() < 0.07,
                "x {x}: {frac} vs {expected}"
            );
        }
        let off = detector(&cfg, false, false, false);
        let i = up_peak_powers(&off, 37.0, p, 50);
        let mean = i.iter().sum::<f64>() / i.len() as f64;
        let sd = (i.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / i.len() as f64).sqrt();
        assert!(sd / mean < 0.05, "CV off {}", sd / mean);
    }

    /// Mean echo power / true power and mean peak width of the echo nearest `r`.
    fn mean_power_ratio_and_width(det: &FmcwDetector, r: f64, p: f64, draws: u64) -> (f64, f64) {
        let (mut ratio, mut width, mut n) = (0.0, 0.0, 0.0);
        for seed in 0..draws {
            let echoes = run(det, &[ret(r, 0.0, p, 1)], 1000 + seed);
            if let Some(e) = echoes
                .iter()
                .min_by(|a, b| (a.range_m - r).abs().total_cmp(&(b.range_m - r).abs()))
            {
                ratio += e.power_w / p;
                width += e.peak_width_m;
                n += 1.0;
            }
        }
        (ratio / draws as f64, width / n)
    }

    #[test]
    fn phase_noise_rolls_off_the_peak_and_broadens_it() {
        let mut cfg = FmcwConfig::default();
        cfg.linewidth_hz = 1e6;
        let det = detector(&cfg, false, true, false);
        let p = watts_for_snr(&det, 1e5);
        let n = cfg.samples_per_chirp;
        let dt = 1.0 / cfg.adc_rate_hz;
        let d = 2.0 * std::f64::consts::PI * cfg.linewidth_hz;
        // Expected power at the tone of a Wiener-phase beat through the Hann window:
        // E|Σ w_n e^{jΔφ_n}|² = Σ_n Σ_m w_n w_m exp(−2πΔν·min(|n − m|dt, τ)), over (Σw)².
        let w: Vec<f64> = (0..n)
            .map(|i| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / n as f64).cos())
            .collect();
        let sw: f64 = w.iter().sum();
        let expected = |r: f64| {
            let tau = 2.0 * r / C;
            let mut lag_sum = vec![0.0; n];
            for a in 0..n {
                for b in a..n {
                    lag_sum[b - a] += w[a] * w[b];
                }
            }
            let mut e = lag_sum[0];
            for (l, s) in lag_sum.iter().enumerate().skip(1) {
                e += 2.0 * s * (-d * (l as f64 * dt).min(tau)).exp();
            }
            e / (sw * sw)
        };
        // Up-ramp peak nearest the true beat: mean power over the ideal N·SNR/4 (Hann, noise
        // units) and mean width in bins.
        let snr = 1e5;
        let up_peak = |det: &FmcwDetector, r: f64, draws: u64| {
            let mut s = det.scratch();
            let mut out = Vec::new();
            let f_up = 2.0 * kappa(&cfg) * r / C;
            let (mut ratio, mut width) = (0.0, 0.0);
            for seed in 0..draws {
                let mut rng = SmallRng::seed_from_u64(500 + seed);
                det.detect(&mut s, &[ret(r, 0.0, p, 1)], 0.0, &mut rng, &mut out);
                let q = s
                    .peaks(0)
                    .iter()
                    .min_by(|a, b| {
                        (a.frequency_hz - f_up)
                            .abs()
                            .total_cmp(&(b.frequency_hz - f_up).abs())
                    })
                    .copied()
                    .expect("a peak");
                ratio += q.power / (n as f64 * snr / 4.0);
                width += q.width_bins;
            }
            (ratio / draws as f64, width / draws as f64)
        };
        let mut last = f64::INFINITY;
        for r in [7.5, 15.0, 30.0] {
            let (ratio, _) = up_peak(&det, r, 60);
            let exp = expected(r);
            assert!((ratio / exp - 1.0).abs() < 0.2, "{r} m: {ratio} vs {exp}");
            assert!(ratio < last);
            last = ratio;
        }
        // The pedestal widens the peak as the coherent fraction falls.
        // (Ranges on whole bins, so that the window's own −3 dB width is the same at both.)
        let dr = C / (2.0 * kappa(&cfg) * window_s(&cfg));
        let (_, near) = up_peak(&det, 13.0 * dr, 40);
        let (_, far) = up_peak(&det, 102.0 * dr, 40);
        assert!(far > 1.1 * near, "width {near} → {far} bins");
        // Off: no roll-off, no broadening.
        let off = detector(&cfg, false, false, false);
        let (ratio, w_near) = up_peak(&off, 13.0 * dr, 20);
        let (ratio_far, w_far) = up_peak(&off, 102.0 * dr, 20);
        // (Log-parabolic interpolation on the Hann window: a few % of scalloping left.)
        assert!(
            (ratio - 1.0).abs() < 0.1 && (ratio_far - 1.0).abs() < 0.1,
            "{ratio} {ratio_far}"
        );
        assert!((w_far / w_near - 1.0).abs() < 0.1, "{w_near} {w_far}");
    }

    #[test]
    fn the_phase_noise_pedestal_of_a_strong_peak_gives_no_second_echo() {
        // One surface at 10, 40 and 100 m, SNR 10⁶ per chirp (60 dB, a near board), default
        // linewidth: the pedestal exceeds the noise floor over tens of bins, but the detector
        // treats it as noise, so each beam gives exactly one echo, at the surface's range. The same
        // with phase noise off.
        let cfg = FmcwConfig::default();
        for phase_noise in [true, false] {
            let det = detector(&cfg, true, phase_noise, true);
            let p = watts_for_snr(&det, 1e6);
            for r in [10.0, 40.0, 100.0] {
                let mut extra = 0;
                for seed in 0..100 {
                    let echoes = run(&det, &[ret(r, 0.0, p, 1)], 7000 + seed);
                    assert!(
                        echoes.iter().any(|e| (e.range_m - r).abs() < 1.0),
                        "{r} m, seed {seed}: no echo at the surface ({echoes:?})"
                    );
                    extra += echoes.len() - 1;
                }
                assert!(
                    extra <= 1,
                    "phase noise {phase_noise}, {r} m: {extra} extra echoes in 100 beams"
                );
            }
        }
    }

    #[test]
    fn chirp_nonlinearity_smears_with_range() {
        let mut cfg = FmcwConfig::default();
        cfg.nonlinearity_hz = 50e6;
        let on = detector(&cfg, false, false, true);
        let off = detector(&cfg, false, false, false);
        let p = watts_for_snr(&on, 1e5);
        let tw = window_s(&cfg);
        let tc = cfg.chirp_time_s;
        // Bow δf(t) = 4δ(t/T)(1 − t/T): over the window at the ramp's end the beat sweeps by
        // τ·|δf′| range = 8δτT_w/T_c²; a linear sweep through a Hann window has its −3 dB points
        // where w² = ½ (stationary phase), 0.364 of the sweep.
        let smear_m = |r: f64| {
            let sweep = 8.0 * cfg.nonlinearity_hz * (2.0 * r / C) * tw / (tc * tc);
            0.364 * sweep * C / (2.0 * kappa(&cfg))
        };
        let (_, near) = mean_power_ratio_and_width(&on, 20.0, p, 10);
        let (_, far) = mean_power_ratio_and_width(&on, 150.0, p, 10);
        assert!(far > 3.0 * near, "{near} → {far}");
        assert!(
            (far / smear_m(150.0) - 1.0).abs() < 0.3,
            "{far} vs {}",
            smear_m(150.0)
        );
        let (_, near) = mean_power_ratio_and_width(&off, 20.0, p, 10);
        let (_, far) = mean_power_ratio_and_width(&off, 150.0, p, 10);
        assert!((far / near - 1.0).abs() < 0.1, "{near} → {far}");
    }

    #[test]
    fn glass_pane_and_car_behind_give_two_echoes() {
        let cfg = FmcwConfig::default();
        let dr = C / (2.0 * kappa(&cfg) * window_s(&cfg));
        // Phase noise off: its pedestal around the strong peaks can add spurious peaks (module notes).
        for (speckle, pn, nl) in [(false, false, false), (true, false, true)] {
            let det = detector(&cfg, speckle, pn, nl);
            let p = watts_for_snr(&det, 1e4);
            // Ego closing at 10 m/s on both.
            let returns = [ret(10.0, -10.0, 0.3 * p, 1), ret(14.0, -10.0, p, 2)];
            let mut echoes = run(&det, &returns, 11);
            echoes.sort_by(|a, b| a.range_m.total_cmp(&b.range_m));
            assert_eq!(echoes.len(), 2, "{echoes:?}");
            for (e, (r, id)) in echoes.iter().zip([(10.0, 1), (14.0, 2)]) {
                assert!((e.range_m - r).abs() < dr, "{e:?}");
                assert!((e.range_rate_m_s + 10.0).abs() < 0.5, "{e:?}");
                assert_eq!(e.object_id, id);
            }
        }
    }

    /// Same seed, same returns, one switch flipped: the echoes differ.
    fn switch_changes_output(flip: usize) {
        let mut cfg = FmcwConfig::default();
        cfg.nonlinearity_hz = 5e6;
        let mut on = [true; 3];
        let base = detector(&cfg, on[0], on[1], on[2]);
        on[flip] = false;
        let other = detector(&cfg, on[0], on[1], on[2]);
        let p = watts_for_snr(&base, 1e4);
        let returns = [ret(120.0, 3.0, p, 1)];
        let a = run(&base, &returns, 9);
        let b = run(&other, &returns, 9);
        assert!(!a.is_empty() && !b.is_empty());
        assert_ne!(a, b);
    }

    #[test]
    fn speckle_switch_changes_the_output() {
        switch_changes_output(0);
    }

    #[test]
    fn phase_noise_switch_changes_the_output() {
        switch_changes_output(1);
    }

    #[test]
    fn nonlinearity_switch_changes_the_output() {
        switch_changes_output(2);
    }
}
