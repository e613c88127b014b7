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
//!      so the beat spectrum is that of a Wiener phase (coherent fraction exp(−2πΔντ), physics.md
//!      §2.9) at the cost of one complex product per sample;
//!    * w[n] complex Gaussian, E|w|² = 1.
//! 2. **Spectrum.** Hann window w_n = ½ − ½cos(2πn/N), N-point FFT (planned once), power |X_k|².
//!    Noise power per bin: Σw² (= 3N/8); coherent gain of a tone on a bin: (Σw)² (= N²/4).
//! 3. **Peaks.** Bins above T = −ln(P_FA)·Σw² (exponential noise power: P(|X|² > T) = P_FA per bin)
//!    that are local maxima; the strongest first, a peak within ±2 bins of a stronger one (the Hann
//!    main lobe) dropped; at most `max_returns_per_beam` kept. Sub-bin frequency and peak power by a
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
            let near = kept[..n_kept].iter().any(|&j| {
                let d = k.abs_diff(j);
                d.min(n - d) <= GUARD_BINS
            });
            if near {
                continue;
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
                        let frac = if pj > pn { (pj - half) / (pj - pn) } else { 0.0 };
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
            && (f_up - f_down).abs() <= 4.0 * self.config.max_range_rate_m_s / self.plan.wavelength_m
    }

    /// Pairs `scratch.peaks` into echoes (order-preserving matching, see the module notes).
    fn pair(&self, s: &FmcwScratch, returns: &[FmcwReturn], snr_per_w: f64, out: &mut Vec<FmcwEcho>) {
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
mod tests {
    use super::*;
}
