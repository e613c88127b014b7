//! Detection and ranging: received waveform, APD/TIA noise, threshold detection, multi-echo, range
//! walk, intensity mapping, saturation and dropped rays.
//!
//! API contract (used by the LiDAR sensor): one [`Detector`] per model instance, built once;
//! [`Detector::detect`] is called once per pulse (or per surface group) from many threads.
//!
//! # Model
//! * **Waveform.** The received optical waveform of one pulse is `w(r) = Σ_i P_i p(r − R_i)` with a
//!   Gaussian pulse `p(r) = exp(−r²/2σ_r²)` in range units, `σ_r = (c/2)·FWHM/(2√(2 ln 2))`
//!   (physics.md §2.6; Winiwarter et al., RSE 269:112772, 2022). The background power adds a DC
//!   level that an AC-coupled (baseline-restored) receiver removes; it only adds shot noise.
//!   Returns are sorted by range and split into groups separated by more than 6σ_r (the tails of
//!   neighbouring groups are below 1.2·10⁻⁸ of their peaks there). A group whose extent is below σ_r
//!   is replaced by its moment-matched Gaussian (amplitude `ΣP·σ_r/σ_eff`, centre the power-weighted
//!   mean range, `σ_eff² = σ_r² + var`: pulse broadening by a slanted surface, Jutzi & Stilla,
//!   ISPRS J. 64:84, 2009) and handled in closed form; wider groups are merged into moment-matched
//!   clusters of extent ≤ σ_r/2 and sampled on a local grid (step σ_r/6 ≈ FWHM/16, reaching below
//!   the threshold on both sides, at most [`MAX_SAMPLES`] samples: very long groups get a coarser
//!   step) to find the local maxima (log-parabola interpolation) and the leading-edge threshold
//!   crossings. Peaks closer than the pulse-pair resolution merge into the stronger. No heap
//!   allocation per call.
//! * **Receiver noise** (APD + TIA, optical-equivalent at the detector): the current noise variance
//!   `σ_i² = 2q(R₀P_sig + R₀P_bg + I_d)M²F·B + i_n²B` with the McIntyre excess noise factor
//!   `F = kM + (1 − k)(2 − 1/M)` (McIntyre, IEEE TED 13:164, 1966), referred to the optical input
//!   as `σ_P = σ_i/(R₀M)`.
//! * **Threshold**: constant false-alarm rate per range gate against the noise floor of the current
//!   background, `T = σ_P(0, P_bg)·Q⁻¹(P_fa)` (Gaussian noise; Skolnik, *Introduction to Radar
//!   Systems*, §2.5; Kilpelä, PhD thesis, Univ. Oulu 2004, §2). False alarms themselves (echoes
//!   from noise alone) are not generated.
//! * **Detection**: an echo is detected when its noisy peak `Â = A + σ_P(A)·N(0,1)` exceeds `T`, so
//!   `P_d = Q((T − A)/σ_P(A))`.
//! * **Ranging**: from the interpolated peak (exact) or, with `lidar.range_walk`, from the leading-edge
//!   threshold crossing `r_cross = R − σ·√(2 ln(A/T))` corrected by the sensor's walk calibration
//!   (`walk_correction`). Timing jitter `σ_t = t_r/SNR` (Kilpelä 2004, eq. 2.4) with the 10–90 % rise
//!   time of the Gaussian `t_r = 1.687σ_t`; a range-noise floor (TDC, clock, calibration) makes the
//!   total 1σ error of a strong return equal `range_accuracy_m`; the range is quantised to
//!   `range_resolution_m`.
//! * **Intensity**: `reflectivity` = 100·Â/P_ref(R) (≈ ρ cos θ % for a Lambertian in clear air) or
//!   `power` (∝ Â). On the `u8` scale the Velodyne convention (VLS-128 manual 63-9483 Rev A,
//!   "calibrated reflectivity"): 0–100 diffuse reflectivity in %, 101–255 retro-reflectors, 255 = ideal
//!   retro-reflector / saturated.

use crate::constants::SPEED_OF_LIGHT_M_S;
use rand::Rng;
use rand::rngs::SmallRng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

use crate::effects::{EffectInfo, Effects};
use crate::error::ModelError;

/// Elementary charge, C (SI definition).
const Q_E_C: f64 = 1.602_176_634e-19;
/// 10–90 % rise time of a Gaussian pulse in units of its σ: √(2 ln 10) − √(2 ln(10/9)).
const GAUSS_RISE_PER_SIGMA: f64 = 1.687_063_6;
/// FWHM of a Gaussian in units of σ: 2√(2 ln 2).
const GAUSS_FWHM_PER_SIGMA: f64 = 2.354_820_045;
/// Returns farther apart than this many σ_r belong to different groups.
const GROUP_GAP_SIGMAS: f64 = 6.0;
/// Most waveform samples of one sampled group (stack buffer).
pub const MAX_SAMPLES: usize = 256;
/// Most echo candidates of one pulse before the return-mode selection (stack buffer); when more
/// peaks exist, the weakest are dropped.
pub const MAX_CANDIDATES: usize = 32;

/// Receiver noise: APD shot noise (signal, background, dark current) with excess noise, TIA thermal
/// noise; noisy peak amplitude, timing jitter and range-noise floor.
pub const DETECTOR_NOISE: EffectInfo = EffectInfo {
    name: "lidar.detector_noise",
    default_on: true,
    summary: "APD/TIA noise: σ_i² = 2q(R₀P_s + R₀P_bg + I_d)M²F·B + i_n²B, F = kM + (1−k)(2 − 1/M); \
              peak Â = A + σ_P·N, P_d = Q((T − A)/σ_P); jitter σ_t = t_r/SNR; off: noiseless, P_d = [A > T]",
    source: "McIntyre, IEEE Trans. Electron Devices 13:164 (1966); Kilpelä, PhD thesis, Univ. Oulu (2004)",
    requires: None,
};

/// Range walk: the range comes from the leading-edge threshold crossing, which moves with amplitude.
pub const RANGE_WALK: EffectInfo = EffectInfo {
    name: "lidar.range_walk",
    default_on: true,
    summary: "leading-edge timing walk: r_cross = R − σ_r·√(2 ln(A/T)) for a Gaussian pulse, corrected by the \
              sensor's walk calibration (measured amplitude or a constant reference); off: range from the peak",
    source: "Kilpelä, PhD thesis, Univ. Oulu (2004) §2.2; Gaussian closed form (physics.md §2.6)",
    requires: None,
};

/// Detector saturation: the TIA/ADC output clips at `saturation_power_w`.
pub const DETECTOR_SATURATION: EffectInfo = EffectInfo {
    name: "lidar.detector_saturation",
    default_on: true,
    summary: "receiver saturation: measured amplitude min(Â, P_sat); a clipped echo reports the scale maximum \
              (Velodyne retro-reflector region 101–255) and its walk correction under-corrects (range short)",
    source: "Velodyne VLS-128 manual 63-9483 Rev A (reflectivity byte); Kilpelä, PhD thesis (2004) §2.2",
    requires: None,
};

/// Dropped rays: a pulse yields no echo with a configured probability.
pub const DROPPED_RAYS: EffectInfo = EffectInfo {
    name: "lidar.dropped_rays",
    default_on: true,
    summary: "dropped rays: each pulse independently yields no echo with probability drop_probability \
              (Bernoulli; default 0)",
    source: "empirical point-dropout rates of automotive lidars (Manivasagam et al., LiDARsim, CVPR 2020)",
    requires: None,
};

/// Effects declared by this module.
pub const EFFECTS: &[EffectInfo] = &[
    DETECTOR_NOISE,
    RANGE_WALK,
    DETECTOR_SATURATION,
    DROPPED_RAYS,
];

/// Which echoes of a pulse are reported.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ReturnMode {
    /// The echo with the highest measured amplitude.
    #[default]
    Strongest,
    /// The farthest detected echo.
    Last,
    /// The nearest detected echo.
    First,
    /// Strongest then last; when they coincide, strongest then second strongest (Velodyne dual).
    Dual,
}

/// Scale of the reported intensity.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum IntensityScale {
    /// 0–100 (OSI `LidarDetection.intensity`, %).
    #[default]
    Percent,
    /// 0–255 (Velodyne reflectivity byte).
    U8,
}

/// What the intensity measures.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum IntensityMode {
    /// Calibrated reflectivity: 100·Â/P_ref(R) %.
    #[default]
    Reflectivity,
    /// Raw power: Â/`power_full_scale_w` × scale maximum.
    Power,
}

/// How the sensor corrects the leading-edge walk (with `lidar.range_walk` on).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum WalkCorrection {
    /// From the measured (clipped) peak amplitude, as commercial sensors calibrate range against
    /// intensity: residual walk from amplitude noise, pulse broadening and saturation.
    #[default]
    Amplitude,
    /// A constant offset calibrated at `walk_reference_power_w`: the full amplitude-dependent walk
    /// remains (simple leading-edge discriminator).
    Constant,
}

/// Receiver and detector parameters (`"lidar": {"detector": {...}}`). Defaults: a Velodyne
/// VLS-128-like 905 nm Si-APD receiver; values marked *guessed* are typical data-sheet values, not
/// Velodyne figures.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DetectorConfig {
    /// Laser pulse FWHM, s (5 ns → cτ/2 = 0.75 m; physics.md §2.6; guessed for the VLS-128).
    pub pulse_fwhm_s: f64,
    /// APD unity-gain responsivity R₀ at the laser wavelength, A/W (Si at 905 nm ≈ 0.5–0.6; guessed).
    pub responsivity_a_per_w: f64,
    /// APD multiplication gain M (guessed: 100).
    pub apd_gain: f64,
    /// APD ionisation-coefficient ratio k (Si ≈ 0.02; McIntyre 1966).
    pub apd_ionization_ratio: f64,
    /// Receiver noise bandwidth B, Hz (≈ 0.44/FWHM for a matched Gaussian; guessed 100 MHz).
    pub bandwidth_hz: f64,
    /// Unmultiplied (bulk) APD dark current, A (guessed 0.1 nA).
    pub dark_current_a: f64,
    /// TIA input-referred noise current density (incl. 4kT/R_f), A/√Hz (guessed 2 pA/√Hz).
    pub tia_noise_a_per_sqrt_hz: f64,
    /// False-alarm probability per range gate that sets the threshold T = σ_n·Q⁻¹(P_fa).
    pub false_alarm_probability: f64,
    /// Peak optical power at which the TIA/ADC clips, W (guessed 100 µW).
    pub saturation_power_w: f64,
    /// Range quantisation, m (VLS-128: 4 mm; 0 = none).
    pub range_resolution_m: f64,
    /// Total 1σ range error of a strong, unsaturated return, m (VLS-128: ±3 cm, UNVERIFIED as 1σ).
    pub range_accuracy_m: f64,
    /// Minimum separation of two echoes, m (`None` = c·FWHM/2). Closer peaks merge into the stronger.
    pub pulse_pair_resolution_m: Option<f64>,
    /// Echoes reported per pulse.
    pub return_mode: ReturnMode,
    /// Intensity scale (percent 0–100 or u8 0–255).
    pub intensity_scale: IntensityScale,
    /// Intensity meaning (calibrated reflectivity or raw power).
    pub intensity_mode: IntensityMode,
    /// Power mode: peak power mapped to the scale maximum, W (`None` = `saturation_power_w`).
    pub power_full_scale_w: Option<f64>,
    /// u8 reflectivity scale: Â/P_ref at which the retro-reflector region reaches 255 (log mapping
    /// of 101–255 between 1 and this ratio; guessed 100).
    pub retro_full_scale_ratio: f64,
    /// Walk correction of the leading-edge discriminator.
    pub walk_correction: WalkCorrection,
    /// Reference peak power of the constant walk correction, W (guessed 1 µW).
    pub walk_reference_power_w: f64,
    /// Probability that a pulse yields no echo at all (`lidar.dropped_rays`).
    pub drop_probability: f64,
}

impl Default for DetectorConfig {
    fn default() -> Self {
        DetectorConfig {
            pulse_fwhm_s: 5e-9,
            responsivity_a_per_w: 0.5,
            apd_gain: 100.0,
            apd_ionization_ratio: 0.02,
            bandwidth_hz: 100e6,
            dark_current_a: 0.1e-9,
            tia_noise_a_per_sqrt_hz: 2e-12,
            false_alarm_probability: 1e-6,
            saturation_power_w: 100e-6,
            range_resolution_m: 0.004,
            range_accuracy_m: 0.03,
            pulse_pair_resolution_m: None,
            return_mode: ReturnMode::Strongest,
            intensity_scale: IntensityScale::Percent,
            intensity_mode: IntensityMode::Reflectivity,
            power_full_scale_w: None,
            retro_full_scale_ratio: 100.0,
            walk_correction: WalkCorrection::Amplitude,
            walk_reference_power_w: 1e-6,
            drop_probability: 0.0,
        }
    }
}

/// Optical power reaching the detector from one surface contribution of one pulse (one sub-ray
/// hit), after the LiDAR equation, optics efficiency, overlap and two-way extinction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Return {
    /// Range of the contribution (half the two-way path length), m.
    pub range_m: f64,
    /// Peak optical power at the detector, W.
    pub power_w: f64,
    /// Ground-truth object (`osiris_proto::INVALID_ID` = none).
    pub object_id: u64,
}

/// One detected echo of a pulse.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Echo {
    /// Measured range, m.
    pub range_m: f64,
    /// Detected peak optical power (before saturation), W.
    pub peak_power_w: f64,
    /// Intensity on the configured scale (percent 0–100 or 0–255).
    pub intensity: f32,
    /// Signal-to-noise ratio of the peak (amplitude ratio, linear).
    pub snr: f32,
    /// The receiver saturated on this echo.
    pub saturated: bool,
    /// Echo pulse width at the threshold, s.
    pub pulse_width_s: f32,
    /// Ground-truth object contributing most power to the echo.
    pub object_id: u64,
}

/// Calibration curve of the intensity mapping: the peak power a 100 % Lambertian target at normal
/// incidence in clear air returns at each range (the sensor's range-dependent calibration).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct IntensityCalibration {
    /// Ranges, m, ascending.
    pub range_m: Vec<f64>,
    /// Reference peak power at each range, W.
    pub reference_power_w: Vec<f64>,
}

/// The detection and ranging stage, planned once.
#[derive(Debug, Clone)]
pub struct Detector {
    config: DetectorConfig,
    noise_on: bool,
    walk_on: bool,
    saturation_on: bool,
    drop_on: bool,
    /// Pulse σ in range units, m.
    sigma_r_m: f64,
    /// Noise variance slope, W² per W of (signal + background) optical power.
    var_per_w: f64,
    /// Noise variance with no light (dark shot + TIA), W².
    var_dark_w2: f64,
    /// Q⁻¹(P_fa).
    threshold_sigmas: f64,
    /// Range-noise floor, m (1σ).
    range_floor_m: f64,
    pulse_pair_m: f64,
    power_full_scale_w: f64,
    /// Constant walk correction, m (σ_r·√(2 ln(A_ref/T₀))).
    walk_constant_m: f64,
    /// Calibration: ranges and P_ref·R² (W·m²).
    cal_range_m: Vec<f64>,
    cal_q_wm2: Vec<f64>,
}

/// One echo candidate before noise and selection.
#[derive(Debug, Clone, Copy, Default)]
struct Candidate {
    /// Noiseless peak range, m.
    range_m: f64,
    /// Noiseless peak amplitude, W.
    amplitude_w: f64,
    /// Effective Gaussian σ of the echo, m (for jitter).
    sigma_m: f64,
    /// Leading-edge crossing of the threshold (noiseless), m; `NAN` = the waveform does not fall
    /// below the threshold before the peak (range from the peak).
    edge_m: f64,
    /// Width at the threshold, m (range units).
    width_m: f64,
    object_id: u64,
}

/// Most moment-matched clusters of one sampled group (stack buffer); beyond, the last cluster
/// absorbs the remaining returns.
const MAX_CLUSTERS: usize = 64;

/// Moment-matched Gaussian of a set of nearby returns.
#[derive(Debug, Clone, Copy, Default)]
struct Cluster {
    /// Power-weighted mean range, m.
    range_m: f64,
    /// Peak amplitude ΣP·σ_r/σ, W.
    amplitude_w: f64,
    /// σ = √(σ_r² + var), m.
    sigma_m: f64,
    /// Object of the strongest return.
    object_id: u64,
}

impl Cluster {
    /// Moment matching of `returns` (non-empty, positive powers) convolved with a Gaussian pulse
    /// of σ `sigma_r_m`: same energy, mean and variance (Jutzi & Stilla 2009).
    fn of(returns: &[Return], sigma_r_m: f64) -> Cluster {
        let first = returns[0].range_m;
        let (mut p_sum, mut m1, mut m2) = (0.0, 0.0, 0.0);
        let mut best = returns[0];
        for r in returns {
            let d = r.range_m - first;
            p_sum += r.power_w;
            m1 += r.power_w * d;
            m2 += r.power_w * d * d;
            if r.power_w > best.power_w {
                best = *r;
            }
        }
        let mean = m1 / p_sum;
        let var = (m2 / p_sum - mean * mean).max(0.0);
        let sigma_m = (sigma_r_m * sigma_r_m + var).sqrt();
        Cluster {
            range_m: first + mean,
            amplitude_w: p_sum * sigma_r_m / sigma_m,
            sigma_m,
            object_id: best.object_id,
        }
    }
}

/// Gaussian tail probability Q(x) = P(N(0,1) > x).
pub fn gaussian_q(x: f64) -> f64 {
    0.5 * crate::special::erfc(x / std::f64::consts::SQRT_2)
}

/// Inverse of [`gaussian_q`] for p in (0, 1) (bisection; used once when planning).
pub fn gaussian_q_inv(p: f64) -> f64 {
    let (mut lo, mut hi) = (-40.0_f64, 40.0_f64);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if gaussian_q(mid) > p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

fn config_error(key: &str, what: &str) -> ModelError {
    ModelError::Config(format!("`lidar.detector.{key}`: {what}"))
}

fn positive(key: &str, v: f64) -> Result<(), ModelError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(config_error(
            key,
            &format!("must be a positive number, got {v}"),
        ))
    }
}

fn non_negative(key: &str, v: f64) -> Result<(), ModelError> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(config_error(
            key,
            &format!("must be a non-negative number, got {v}"),
        ))
    }
}

impl Detector {
    /// Plan the detector for a configuration, the effect switches and the intensity calibration.
    pub fn new(
        config: &DetectorConfig,
        effects: &Effects,
        calibration: IntensityCalibration,
    ) -> Result<Detector, ModelError> {
        let c = config;
        positive("pulse_fwhm_s", c.pulse_fwhm_s)?;
        positive("responsivity_a_per_w", c.responsivity_a_per_w)?;
        if !(c.apd_gain.is_finite() && c.apd_gain >= 1.0) {
            return Err(config_error(
                "apd_gain",
                &format!("must be ≥ 1, got {}", c.apd_gain),
            ));
        }
        if !(c.apd_ionization_ratio.is_finite() && (0.0..=1.0).contains(&c.apd_ionization_ratio)) {
            return Err(config_error(
                "apd_ionization_ratio",
                &format!("must be in [0, 1], got {}", c.apd_ionization_ratio),
            ));
        }
        positive("bandwidth_hz", c.bandwidth_hz)?;
        non_negative("dark_current_a", c.dark_current_a)?;
        non_negative("tia_noise_a_per_sqrt_hz", c.tia_noise_a_per_sqrt_hz)?;
        if !(c.false_alarm_probability > 0.0 && c.false_alarm_probability < 0.5) {
            return Err(config_error(
                "false_alarm_probability",
                &format!("must be in (0, 0.5), got {}", c.false_alarm_probability),
            ));
        }
        positive("saturation_power_w", c.saturation_power_w)?;
        non_negative("range_resolution_m", c.range_resolution_m)?;
        non_negative("range_accuracy_m", c.range_accuracy_m)?;
        if let Some(v) = c.pulse_pair_resolution_m {
            non_negative("pulse_pair_resolution_m", v)?;
        }
        if let Some(v) = c.power_full_scale_w {
            positive("power_full_scale_w", v)?;
        }
        if !(c.retro_full_scale_ratio.is_finite() && c.retro_full_scale_ratio > 1.0) {
            return Err(config_error(
                "retro_full_scale_ratio",
                &format!("must be > 1, got {}", c.retro_full_scale_ratio),
            ));
        }
        positive("walk_reference_power_w", c.walk_reference_power_w)?;
        if !(c.drop_probability.is_finite() && (0.0..=1.0).contains(&c.drop_probability)) {
            return Err(config_error(
                "drop_probability",
                &format!("must be in [0, 1], got {}", c.drop_probability),
            ));
        }

        // Intensity calibration.
        let cal = &calibration;
        if cal.range_m.len() != cal.reference_power_w.len() {
            return Err(ModelError::Config(format!(
                "LiDAR intensity calibration: {} ranges but {} reference powers",
                cal.range_m.len(),
                cal.reference_power_w.len()
            )));
        }
        for (i, (&r, &p)) in cal.range_m.iter().zip(&cal.reference_power_w).enumerate() {
            let ascending = i == 0 || r > cal.range_m[i - 1];
            if !(r.is_finite() && r > 0.0 && p.is_finite() && p >= 0.0 && ascending) {
                return Err(ModelError::Config(format!(
                    "LiDAR intensity calibration: entry {i} (range {r} m, power {p} W) must have \
                     positive ascending ranges and non-negative powers"
                )));
            }
        }
        if c.intensity_mode == IntensityMode::Reflectivity && cal.range_m.is_empty() {
            return Err(config_error(
                "intensity_mode",
                "`reflectivity` needs the sensor's intensity calibration, which is empty",
            ));
        }
        let cal_q_wm2 = cal
            .range_m
            .iter()
            .zip(&cal.reference_power_w)
            .map(|(r, p)| p * r * r)
            .collect();

        let m = c.apd_gain;
        let k = c.apd_ionization_ratio;
        let excess = k * m + (1.0 - k) * (2.0 - 1.0 / m);
        let r0 = c.responsivity_a_per_w;
        let b = c.bandwidth_hz;
        // Optical-equivalent variances: σ_P² = σ_i²/(R₀M)².
        let var_per_w = 2.0 * Q_E_C * excess * b / r0;
        let var_dark_w2 = (2.0 * Q_E_C * c.dark_current_a * m * m * excess * b
            + c.tia_noise_a_per_sqrt_hz.powi(2) * b)
            / (r0 * m).powi(2);
        let threshold_sigmas = gaussian_q_inv(c.false_alarm_probability);
        let sigma_r_m = 0.5 * SPEED_OF_LIGHT_M_S * c.pulse_fwhm_s / GAUSS_FWHM_PER_SIGMA;
        let quant_var = c.range_resolution_m.powi(2) / 12.0;
        let range_floor_m = (c.range_accuracy_m.powi(2) - quant_var).max(0.0).sqrt();
        let threshold0 = threshold_sigmas * var_dark_w2.sqrt();
        let walk_constant_m =
            sigma_r_m * (2.0 * (c.walk_reference_power_w / threshold0).max(1.0).ln()).sqrt();
        Ok(Detector {
            config: c.clone(),
            noise_on: effects.is_on(&DETECTOR_NOISE),
            walk_on: effects.is_on(&RANGE_WALK),
            saturation_on: effects.is_on(&DETECTOR_SATURATION),
            drop_on: effects.is_on(&DROPPED_RAYS),
            sigma_r_m,
            var_per_w,
            var_dark_w2,
            threshold_sigmas,
            range_floor_m,
            pulse_pair_m: c
                .pulse_pair_resolution_m
                .unwrap_or(0.5 * SPEED_OF_LIGHT_M_S * c.pulse_fwhm_s),
            power_full_scale_w: c.power_full_scale_w.unwrap_or(c.saturation_power_w),
            walk_constant_m,
            cal_range_m: calibration.range_m,
            cal_q_wm2,
        })
    }

    /// The configuration the detector was planned with.
    pub fn config(&self) -> &DetectorConfig {
        &self.config
    }

    /// Optical-equivalent noise (1σ) at the detector for a signal power and a background power, W:
    /// `σ_P = √(2qF B (P_sig + P_bg)/R₀ + (2q I_d M²F B + i_n²B)/(R₀M)²)`.
    pub fn noise_power_w(&self, signal_w: f64, background_w: f64) -> f64 {
        (self.var_per_w * (signal_w.max(0.0) + background_w.max(0.0)) + self.var_dark_w2).sqrt()
    }

    /// Noise-equivalent power in the receiver bandwidth without light (dark shot + TIA noise), W.
    pub fn noise_equivalent_power_w(&self) -> f64 {
        self.var_dark_w2.sqrt()
    }

    /// Detection threshold at a background power, W: `T = σ_P(0, P_bg)·Q⁻¹(P_fa)`.
    pub fn threshold_power_w(&self, background_w: f64) -> f64 {
        self.threshold_sigmas * self.noise_power_w(0.0, background_w)
    }

    /// Probability that an isolated echo of peak power `power_w` is detected (Gaussian noise):
    /// `P_d = Q((T − A)/σ_P(A))`; a step at T with `lidar.detector_noise` off.
    pub fn detection_probability(&self, power_w: f64, background_w: f64) -> f64 {
        let t = self.threshold_power_w(background_w);
        if self.noise_on {
            gaussian_q((t - power_w) / self.noise_power_w(power_w, background_w))
        } else if power_w > t {
            1.0
        } else {
            0.0
        }
    }

    /// Pulse σ in range units, m (`(c/2)·FWHM/2.355`).
    pub fn pulse_sigma_m(&self) -> f64 {
        self.sigma_r_m
    }

    /// Minimum separation of two echoes, m.
    pub fn pulse_pair_resolution_m(&self) -> f64 {
        self.pulse_pair_m
    }

    /// Reference power P_ref(R) of the intensity calibration at a range, W (P_ref·R² interpolated
    /// linearly in R, held constant beyond the table: R⁻² extrapolation). 0 without calibration.
    pub fn reference_power_w(&self, range_m: f64) -> f64 {
        let rs = &self.cal_range_m;
        let qs = &self.cal_q_wm2;
        if rs.is_empty() || range_m <= 0.0 {
            return 0.0;
        }
        let q = if range_m <= rs[0] {
            qs[0]
        } else if range_m >= rs[rs.len() - 1] {
            qs[qs.len() - 1]
        } else {
            let i = rs.partition_point(|&r| r <= range_m);
            let (r0, r1) = (rs[i - 1], rs[i]);
            let f = (range_m - r0) / (r1 - r0);
            qs[i - 1] + f * (qs[i] - qs[i - 1])
        };
        q / (range_m * range_m)
    }

    fn scale_max(&self) -> f64 {
        match self.config.intensity_scale {
            IntensityScale::Percent => 100.0,
            IntensityScale::U8 => 255.0,
        }
    }

    /// Intensity of an echo from its measured (clipped) amplitude.
    fn intensity(&self, measured_w: f64, range_m: f64, saturated: bool) -> f32 {
        let max = self.scale_max();
        if saturated {
            return max as f32;
        }
        let v = match self.config.intensity_mode {
            IntensityMode::Power => max * measured_w / self.power_full_scale_w,
            IntensityMode::Reflectivity => {
                let p_ref = self.reference_power_w(range_m);
                if p_ref <= 0.0 {
                    return max as f32;
                }
                let ratio = measured_w / p_ref;
                match self.config.intensity_scale {
                    IntensityScale::Percent => 100.0 * ratio,
                    IntensityScale::U8 => {
                        if ratio <= 1.0 {
                            100.0 * ratio
                        } else {
                            // Velodyne retro-reflector region 101–255, log-mapped.
                            101.0 + 154.0 * ratio.ln() / self.config.retro_full_scale_ratio.ln()
                        }
                    }
                }
            }
        };
        v.clamp(0.0, max) as f32
    }

    /// Detect the echoes of one pulse from its returns (any order; may be reordered), with the
    /// optical background power `background_w` (W, at the detector) and noise from `rng`. Echoes are
    /// appended to `out` in the order of the configured return mode.
    pub fn detect(
        &self,
        returns: &mut [Return],
        background_w: f64,
        rng: &mut SmallRng,
        out: &mut Vec<Echo>,
    ) {
        if self.drop_on
            && self.config.drop_probability > 0.0
            && rng.random::<f64>() < self.config.drop_probability
        {
            return;
        }
        let background_w = if background_w.is_finite() {
            background_w.max(0.0)
        } else {
            0.0
        };
        let threshold = self.threshold_power_w(background_w);

        // Drop unusable returns (move them to the end), sort the rest by range.
        let mut n = 0;
        for i in 0..returns.len() {
            let r = returns[i];
            if r.range_m.is_finite() && r.power_w.is_finite() && r.power_w > 0.0 {
                returns.swap(n, i);
                n += 1;
            }
        }
        let returns = &mut returns[..n];
        if returns.is_empty() {
            return;
        }
        returns.sort_unstable_by(|a, b| a.range_m.total_cmp(&b.range_m));

        let mut cands = [Candidate::default(); MAX_CANDIDATES];
        let mut n_cands = 0usize;
        let gap = GROUP_GAP_SIGMAS * self.sigma_r_m;
        let mut start = 0;
        while start < returns.len() {
            let mut end = start + 1;
            while end < returns.len() && returns[end].range_m - returns[end - 1].range_m <= gap {
                end += 1;
            }
            let group = &returns[start..end];
            start = end;
            self.group_candidates(group, threshold, &mut cands, &mut n_cands);
        }

        // Noise, detection, ranging, intensity.
        let mut echoes = [None::<Echo>; MAX_CANDIDATES];
        let mut n_echoes = 0;
        for cand in &cands[..n_cands] {
            if let Some(e) = self.measure(cand, threshold, background_w, rng) {
                echoes[n_echoes] = Some(e);
                n_echoes += 1;
            }
        }
        let echoes = &echoes[..n_echoes];
        if echoes.is_empty() {
            return;
        }
        // Echoes are in ascending range (candidates were produced in range order).
        let strongest = (0..echoes.len())
            .max_by(|&a, &b| {
                let (a, b) = (echoes[a].unwrap(), echoes[b].unwrap());
                a.peak_power_w.total_cmp(&b.peak_power_w)
            })
            .unwrap_or(0);
        let last = echoes.len() - 1;
        match self.config.return_mode {
            ReturnMode::Strongest => out.extend(echoes[strongest]),
            ReturnMode::Last => out.extend(echoes[last]),
            ReturnMode::First => out.extend(echoes[0]),
            ReturnMode::Dual => {
                out.extend(echoes[strongest]);
                let second = if last != strongest {
                    Some(last)
                } else {
                    (0..echoes.len())
                        .filter(|&i| i != strongest)
                        .max_by(|&a, &b| {
                            let (a, b) = (echoes[a].unwrap(), echoes[b].unwrap());
                            a.peak_power_w.total_cmp(&b.peak_power_w)
                        })
                };
                if let Some(s) = second {
                    out.extend(echoes[s]);
                }
            }
        }
    }

    /// Push a candidate, dropping the weakest when full (keeps range order).
    fn push_candidate(cands: &mut [Candidate; MAX_CANDIDATES], n: &mut usize, c: Candidate) {
        if *n < MAX_CANDIDATES {
            cands[*n] = c;
            *n += 1;
            return;
        }
        let (weakest, w) = cands
            .iter()
            .enumerate()
            .min_by(|a, b| a.1.amplitude_w.total_cmp(&b.1.amplitude_w))
            .map(|(i, c)| (i, c.amplitude_w))
            .unwrap_or((0, 0.0));
        if c.amplitude_w > w {
            cands.copy_within(weakest + 1.., weakest);
            cands[MAX_CANDIDATES - 1] = c;
        }
    }

    /// Echo candidates of one group of overlapping returns (sorted by range).
    fn group_candidates(
        &self,
        group: &[Return],
        threshold: f64,
        cands: &mut [Candidate; MAX_CANDIDATES],
        n_cands: &mut usize,
    ) {
        let s = self.sigma_r_m;
        let first = group[0].range_m;
        let extent = group[group.len() - 1].range_m - first;
        if extent <= s {
            // Moment-matched single Gaussian.
            let cl = Cluster::of(group, s);
            let (mean_range, sigma, amplitude) = (cl.range_m, cl.sigma_m, cl.amplitude_w);
            let ratio = amplitude / threshold;
            let (edge, width) = if ratio > 1.0 {
                let h = sigma * (2.0 * ratio.ln()).sqrt();
                (mean_range - h, 2.0 * h)
            } else {
                (mean_range, 0.0)
            };
            if amplitude > 0.0 {
                Self::push_candidate(
                    cands,
                    n_cands,
                    Candidate {
                        range_m: mean_range,
                        amplitude_w: amplitude,
                        sigma_m: sigma,
                        edge_m: edge,
                        width_m: width,
                        object_id: cl.object_id,
                    },
                );
            }
            return;
        }

        // Sampled waveform on a local grid reaching below the threshold on both sides: a Gaussian
        // of amplitude P falls to T at σ·√(2 ln(P/T)) (at least 3σ).
        let p_total: f64 = group.iter().map(|r| r.power_w).sum();
        let margin = s * (2.0 * (p_total / threshold).max(90.0).ln()).sqrt();
        let lo = first - margin;
        let hi = group[group.len() - 1].range_m + margin;
        let mut step = s / 6.0;
        if (hi - lo) / step > (MAX_SAMPLES - 1) as f64 {
            step = (hi - lo) / (MAX_SAMPLES - 1) as f64;
        }
        let n = (((hi - lo) / step).ceil() as usize + 1).min(MAX_SAMPLES);
        // Sub-rays on nearly the same range are merged into moment-matched clusters (extent
        // ≤ σ_r/2: the mixture differs from its matched Gaussian by < 1 %), then every cluster's
        // Gaussian is added on its ±5σ window with the exact multiplicative recurrence
        // g(x + h) = g(x)·e^{−(2xh + h²)/2σ²} (three exp per cluster, none per sample).
        let mut clusters = [Cluster::default(); MAX_CLUSTERS];
        let mut n_clusters = 0;
        let mut i = 0;
        while i < group.len() {
            let mut j = i + 1;
            while j < group.len()
                && (group[j].range_m - group[i].range_m <= 0.5 * s
                    || n_clusters + 1 == MAX_CLUSTERS)
            {
                j += 1;
            }
            clusters[n_clusters] = Cluster::of(&group[i..j], s);
            n_clusters += 1;
            i = j;
        }
        let clusters = &clusters[..n_clusters];
        let mut w = [0.0f64; MAX_SAMPLES];
        for cl in clusters {
            let reach = 5.0 * cl.sigma_m;
            let j0 = ((cl.range_m - reach - lo) / step).ceil().max(0.0) as usize;
            let j1 = (((cl.range_m + reach - lo) / step).floor().max(0.0) as usize).min(n - 1);
            if j0 > j1 {
                continue;
            }
            let inv2 = 0.5 / (cl.sigma_m * cl.sigma_m);
            let x = lo + j0 as f64 * step - cl.range_m;
            let mut g = cl.amplitude_w * (-x * x * inv2).exp();
            let mut ratio = (-(2.0 * x * step + step * step) * inv2).exp();
            let c = (-2.0 * step * step * inv2).exp();
            for wj in &mut w[j0..=j1] {
                *wj += g;
                g *= ratio;
                ratio *= c;
            }
        }
        let w = &w[..n];
        let floor = 0.05 * threshold;
        let mut last_kept: Option<usize> = None; // index into cands of this group's last candidate
        for j in 1..n.saturating_sub(1) {
            if !(w[j] > w[j - 1]
                && w[j] >= w[j + 1]
                && w[j] > floor
                && w[j - 1] > 0.0
                && w[j + 1] > 0.0)
            {
                continue;
            }
            // Log-parabola interpolation (exact for a Gaussian).
            let (a, b, c) = (w[j - 1].ln(), w[j].ln(), w[j + 1].ln());
            let denom = a - 2.0 * b + c;
            let (delta, peak_ln) = if denom < 0.0 {
                let d = 0.5 * (a - c) / denom;
                (d, b - 0.25 * (a - c) * d)
            } else {
                (0.0, b)
            };
            let range = lo + (j as f64 + delta) * step;
            let amplitude = peak_ln.exp();
            // Effective σ from the log curvature: ln w ≈ const − (r − R)²/2σ².
            let sigma = if denom < 0.0 {
                step * (-1.0 / denom).sqrt()
            } else {
                s
            };
            // Leading edge: walk left to the threshold crossing.
            let mut edge = f64::NAN;
            let mut i = j;
            while i > 0 {
                if w[i - 1] < threshold && w[i] >= threshold {
                    let f = (threshold - w[i - 1]) / (w[i] - w[i - 1]);
                    edge = lo + (i as f64 - 1.0 + f) * step;
                    break;
                }
                if w[i - 1] > w[i] {
                    break; // a valley above the threshold: no separate leading edge
                }
                i -= 1;
            }
            let mut trail = f64::NAN;
            let mut i = j;
            while i + 1 < n {
                if w[i + 1] < threshold && w[i] >= threshold {
                    let f = (w[i] - threshold) / (w[i] - w[i + 1]);
                    trail = lo + (i as f64 + f) * step;
                    break;
                }
                if w[i + 1] > w[i] {
                    break;
                }
                i += 1;
            }
            // Width at the threshold; one-sided (doubled) where a neighbouring echo keeps the
            // waveform above the threshold.
            let width = match (edge.is_finite(), trail.is_finite()) {
                (true, true) => trail - edge,
                (true, false) => 2.0 * (range - edge),
                (false, true) => 2.0 * (trail - range),
                (false, false) => 0.0,
            };
            // Dominant contributor at the peak.
            let mut best = (0.0, clusters[0].object_id);
            for cl in clusters {
                let d = (cl.range_m - range) / cl.sigma_m;
                let p = cl.amplitude_w * (-0.5 * d * d).exp();
                if p > best.0 {
                    best = (p, cl.object_id);
                }
            }
            let cand = Candidate {
                range_m: range,
                amplitude_w: amplitude,
                sigma_m: sigma,
                edge_m: edge,
                width_m: width,
                object_id: best.1,
            };
            // Pulse-pair resolution: a peak too close to the previous one merges into the stronger.
            if let Some(k) = last_kept
                && k < *n_cands
                && range - cands[k].range_m < self.pulse_pair_m
            {
                if amplitude > cands[k].amplitude_w {
                    cands[k] = cand;
                }
                continue;
            }
            Self::push_candidate(cands, n_cands, cand);
            last_kept = Some(*n_cands - 1);
        }
    }

    /// Noise, threshold test, range and intensity of one candidate.
    fn measure(
        &self,
        cand: &Candidate,
        threshold: f64,
        background_w: f64,
        rng: &mut SmallRng,
    ) -> Option<Echo> {
        let sigma_p = self.noise_power_w(cand.amplitude_w, background_w);
        let measured = if self.noise_on {
            let n: f64 = rng.sample(StandardNormal);
            cand.amplitude_w + sigma_p * n
        } else {
            cand.amplitude_w
        };
        if measured <= threshold {
            return None;
        }
        let saturated = self.saturation_on && measured > self.config.saturation_power_w;
        let clipped = if self.saturation_on {
            measured.min(self.config.saturation_power_w)
        } else {
            measured
        };
        let snr = measured / sigma_p;
        // An echo whose waveform never fell below the threshold before its peak (riding on the tail
        // of a nearer echo) has no leading edge of its own: its range comes from the digitised peak.
        let mut range = if self.walk_on && cand.edge_m.is_finite() {
            let edge = cand.edge_m;
            let correction = match self.config.walk_correction {
                WalkCorrection::Constant => self.walk_constant_m,
                WalkCorrection::Amplitude => {
                    self.sigma_r_m * (2.0 * (clipped / threshold).max(1.0).ln()).sqrt()
                }
            };
            edge + correction
        } else {
            cand.range_m
        };
        if self.noise_on {
            // Jitter from the noiseless SNR (a property of the signal slope, not of one draw).
            let true_snr = (cand.amplitude_w / sigma_p).max(1.0);
            let jitter_m = GAUSS_RISE_PER_SIGMA * cand.sigma_m / true_snr;
            let n: f64 = rng.sample(StandardNormal);
            range += (jitter_m * jitter_m + self.range_floor_m * self.range_floor_m).sqrt() * n;
        }
        let res = self.config.range_resolution_m;
        if res > 0.0 {
            range = (range / res).round() * res;
        }
        let intensity = self.intensity(clipped, range, saturated);
        Some(Echo {
            range_m: range,
            peak_power_w: measured,
            intensity,
            snr: snr as f32,
            saturated,
            pulse_width_s: (2.0 * cand.width_m / SPEED_OF_LIGHT_M_S) as f32,
            object_id: cand.object_id,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    /// 100 % Lambertian reference: P_ref = K/R², K = 5.9·10⁻³ W·m² (physics.md §2.1 example scaled
    /// from ρ = 0.1 to ρ = 1: 59 µW at 10 m).
    const K_REF_WM2: f64 = 5.9e-3;

    fn calibration() -> IntensityCalibration {
        let range_m = vec![1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0, 300.0];
        let reference_power_w = range_m.iter().map(|r| K_REF_WM2 / (r * r)).collect();
        IntensityCalibration {
            range_m,
            reference_power_w,
        }
    }

    fn detector(config: &DetectorConfig, switches: &[(&str, bool)]) -> Detector {
        let mut effects = Effects::new(EFFECTS);
        for (name, on) in switches {
            effects.set(name, *on).unwrap();
        }
        Detector::new(config, &effects, calibration()).unwrap()
    }

    fn ret(range_m: f64, power_w: f64, object_id: u64) -> Return {
        Return {
            range_m,
            power_w,
            object_id,
        }
    }

    fn run(det: &Detector, returns: &[Return], bg: f64, rng: &mut SmallRng) -> Vec<Echo> {
        let mut r = returns.to_vec();
        let mut out = Vec::new();
        det.detect(&mut r, bg, rng, &mut out);
        out
    }

    const NOISE_OFF: (&str, bool) = ("lidar.detector_noise", false);
    const WALK_OFF: (&str, bool) = ("lidar.range_walk", false);
    const SAT_OFF: (&str, bool) = ("lidar.detector_saturation", false);

    /// Independent closed form of the optical-equivalent noise σ_P (McIntyre excess noise, shot +
    /// TIA), written out from the textbook expression.
    fn sigma_p(c: &DetectorConfig, signal_w: f64, bg_w: f64) -> f64 {
        let q = 1.602_176_634e-19;
        let m = c.apd_gain;
        let f = c.apd_ionization_ratio * m + (1.0 - c.apd_ionization_ratio) * (2.0 - 1.0 / m);
        let i_primary = c.responsivity_a_per_w * (signal_w + bg_w) + c.dark_current_a;
        let var_i = 2.0 * q * i_primary * m * m * f * c.bandwidth_hz
            + c.tia_noise_a_per_sqrt_hz.powi(2) * c.bandwidth_hz;
        var_i.sqrt() / (c.responsivity_a_per_w * m)
    }

    #[test]
    fn noise_and_threshold_follow_closed_form() {
        let c = DetectorConfig::default();
        let d = detector(&c, &[]);
        let nep = sigma_p(&c, 0.0, 0.0);
        assert!((d.noise_equivalent_power_w() / nep - 1.0).abs() < 1e-12);
        // Q⁻¹(10⁻⁶) = 4.753424 (standard normal tables).
        assert!((gaussian_q_inv(1e-6) - 4.753_424).abs() < 1e-4);
        assert!((gaussian_q(1.0) - 0.158_655_25).abs() < 1e-6);
        let t = d.threshold_power_w(1e-9);
        assert!((t / (4.753_424 * sigma_p(&c, 0.0, 1e-9)) - 1.0).abs() < 1e-4);
        // Default receiver: threshold of a few nW (physics.md §2.1: 15 nW at 200 m for ρ = 0.1).
        assert!(t > 1e-9 && t < 5e-9, "threshold {t}");
    }

    /// Range statistics (bias, rms) of `n` pulses with one return.
    fn range_stats(d: &Detector, r: f64, a: f64, n: usize, seed: u64) -> (f64, f64) {
        let mut rng = SmallRng::seed_from_u64(seed);
        let (mut sum, mut sum2) = (0.0, 0.0);
        for _ in 0..n {
            let e = run(d, &[ret(r, a, 3)], 0.0, &mut rng);
            assert_eq!(e.len(), 1);
            let err = e[0].range_m - r;
            sum += err;
            sum2 += err * err;
        }
        (sum / n as f64, (sum2 / n as f64).sqrt())
    }

    #[test]
    fn strong_return_range_error_within_accuracy() {
        let c = DetectorConfig::default();
        let d = detector(&c, &[]);
        // 80 % Lambertian at 20 m: 11.8 µW, shot-noise SNR ≈ 200.
        let a = 0.8 * K_REF_WM2 / 400.0;
        let (bias, rms) = range_stats(&d, 20.0, a, 20_000, 7);
        assert!(bias.abs() < 0.002, "bias {bias}");
        assert!(rms <= 1.02 * c.range_accuracy_m, "rms {rms}");
        assert!(rms >= 0.95 * c.range_accuracy_m, "rms {rms}");
        // Weaker returns add leading-edge jitter σ = t_r/SNR (t_r = 1.687σ, Gaussian 10–90 %) in
        // quadrature to the strong-return accuracy.
        let s = 0.5 * 299_792_458.0 * 5e-9 / (2.0 * (2.0 * 2f64.ln()).sqrt());
        for a in [2e-8, 1e-7, 4e-7] {
            let snr = a / sigma_p(&c, a, 0.0);
            let jitter = 1.687 * s / snr;
            // Residual walk of the amplitude correction from the noisy amplitude:
            // δr = σ_r·(σ_P/A)/√(2 ln(A/T)) (first-order expansion of σ_r√(2 ln(Â/T))).
            let t = 4.753_424 * sigma_p(&c, 0.0, 0.0);
            let walk = s / snr / (2.0 * (a / t).ln()).sqrt();
            let expected = (c.range_accuracy_m.powi(2) + jitter * jitter + walk * walk).sqrt();
            let (bias, rms) = range_stats(&d, 60.0, a, 20_000, 8);
            assert!(
                (rms / expected - 1.0).abs() < 0.05,
                "A {a}: rms {rms} vs {expected}"
            );
            assert!(bias.abs() < 0.1 * expected, "A {a}: bias {bias}");
        }
    }

    #[test]
    fn echo_found_above_threshold_lost_below() {
        let c = DetectorConfig::default();
        let d = detector(&c, &[NOISE_OFF]);
        let mut rng = SmallRng::seed_from_u64(1);
        for bg in [0.0, 1e-9, 1e-8] {
            let t = d.threshold_power_w(bg);
            assert_eq!(run(&d, &[ret(80.0, 1.01 * t, 1)], bg, &mut rng).len(), 1);
            assert!(run(&d, &[ret(80.0, 0.99 * t, 1)], bg, &mut rng).is_empty());
        }
        // Sunlight raises the threshold (shot noise of the background).
        assert!(d.threshold_power_w(1e-8) > 1.5 * d.threshold_power_w(0.0));
    }

    #[test]
    fn detection_probability_follows_gaussian_closed_form() {
        let c = DetectorConfig::default();
        let d = detector(&c, &[]);
        let bg = 0.5e-9;
        let t = 4.753_424 * sigma_p(&c, 0.0, bg);
        let mut rng = SmallRng::seed_from_u64(11);
        let n = 20_000;
        for k in [-1.5, -0.5, 0.0, 0.5, 1.0, 2.0] {
            // A such that (A − T)/σ_P(T) = k (σ evaluated at the signal itself below).
            let a = t + k * sigma_p(&c, t, bg);
            let expected =
                0.5 * crate::special::erfc((t - a) / sigma_p(&c, a, bg) / std::f64::consts::SQRT_2);
            let hits = (0..n)
                .filter(|_| !run(&d, &[ret(60.0, a, 1)], bg, &mut rng).is_empty())
                .count();
            let p = hits as f64 / n as f64;
            let tol = 4.0 * (expected * (1.0 - expected) / n as f64).sqrt() + 0.002;
            assert!((p - expected).abs() < tol, "k {k}: P_d {p} vs {expected}");
        }
    }

    #[test]
    fn power_mode_intensity_proportional_to_lambertian_power() {
        let c = DetectorConfig {
            intensity_mode: IntensityMode::Power,
            power_full_scale_w: Some(10e-6),
            ..DetectorConfig::default()
        };
        let d = detector(&c, &[NOISE_OFF]);
        let mut rng = SmallRng::seed_from_u64(2);
        // Extended Lambertian target: P ∝ ρ cos θ / R² (physics.md §2.1).
        let cases = [
            (0.5, 0.0_f64, 20.0),
            (0.2, 60f64.to_radians(), 40.0),
            (0.9, 0.3, 25.0),
        ];
        let mut prev: Option<(f64, f32)> = None;
        for (rho, theta, r) in cases {
            let p = K_REF_WM2 * rho * theta.cos() / (r * r);
            let e = run(&d, &[ret(r, p, 1)], 0.0, &mut rng);
            assert_eq!(e.len(), 1);
            let expected = 100.0 * p / 10e-6;
            assert!(
                (e[0].intensity as f64 / expected - 1.0).abs() < 1e-5,
                "{e:?} {expected}"
            );
            if let Some((p0, i0)) = prev {
                let ratio = e[0].intensity as f64 / i0 as f64;
                assert!((ratio / (p / p0) - 1.0).abs() < 1e-5);
            }
            prev = Some((p, e[0].intensity));
        }
    }

    #[test]
    fn reflectivity_mode_returns_rho() {
        let mut rng = SmallRng::seed_from_u64(3);
        let c = DetectorConfig::default();
        let d = detector(&c, &[NOISE_OFF]);
        for rho in [0.1, 0.5, 0.9] {
            for r in [7.5, 30.0, 150.0, 250.0] {
                let e = run(&d, &[ret(r, rho * K_REF_WM2 / (r * r), 1)], 0.0, &mut rng);
                assert_eq!(e.len(), 1);
                assert!(
                    (e[0].intensity as f64 - 100.0 * rho).abs() < 0.2,
                    "{rho} {r} {e:?}"
                );
            }
        }
        // Velodyne byte: diffuse 0–100, retro-reflectors 101–255 (log), saturation 255.
        let c = DetectorConfig {
            intensity_scale: IntensityScale::U8,
            ..DetectorConfig::default()
        };
        let d = detector(&c, &[NOISE_OFF]);
        let r = 50.0;
        let p_ref = K_REF_WM2 / (r * r);
        let e = run(&d, &[ret(r, 0.5 * p_ref, 1)], 0.0, &mut rng);
        assert!((e[0].intensity - 50.0).abs() < 0.2);
        let e = run(&d, &[ret(r, 10.0 * p_ref, 1)], 0.0, &mut rng);
        let expected = 101.0 + 154.0 * 10f64.ln() / 100f64.ln();
        assert!((e[0].intensity as f64 - expected).abs() < 0.2, "{e:?}");
        let e = run(&d, &[ret(r, 1e-3, 1)], 0.0, &mut rng);
        assert!(e[0].saturated && e[0].intensity == 255.0);
    }

    #[test]
    fn multi_echo_modes() {
        let mut rng = SmallRng::seed_from_u64(4);
        let two = [ret(25.0, 0.3e-6, 2), ret(20.0, 1e-6, 1)];
        let pick = |mode: ReturnMode, returns: &[Return], rng: &mut SmallRng| {
            let c = DetectorConfig {
                return_mode: mode,
                ..DetectorConfig::default()
            };
            run(&detector(&c, &[NOISE_OFF]), returns, 0.0, rng)
        };
        let near = |e: &Echo, r: f64| (e.range_m - r).abs() < 0.005;
        let e = pick(ReturnMode::Strongest, &two, &mut rng);
        assert!(e.len() == 1 && near(&e[0], 20.0) && e[0].object_id == 1);
        let e = pick(ReturnMode::Last, &two, &mut rng);
        assert!(e.len() == 1 && near(&e[0], 25.0) && e[0].object_id == 2);
        let e = pick(ReturnMode::First, &two, &mut rng);
        assert!(e.len() == 1 && near(&e[0], 20.0));
        let e = pick(ReturnMode::Dual, &two, &mut rng);
        assert!(
            e.len() == 2 && near(&e[0], 20.0) && near(&e[1], 25.0),
            "{e:?}"
        );
        // Strongest is also last: strongest + second strongest (Velodyne dual).
        let three = [
            ret(20.0, 0.3e-6, 1),
            ret(25.0, 0.5e-6, 2),
            ret(30.0, 1e-6, 3),
        ];
        let e = pick(ReturnMode::Dual, &three, &mut rng);
        assert!(
            e.len() == 2 && near(&e[0], 30.0) && near(&e[1], 25.0),
            "{e:?}"
        );
        // Returns 1.0 m apart (> cτ/2 = 0.75 m, > 2σ_r: bimodal) stay separate.
        let close = [ret(20.0, 1e-6, 1), ret(21.0, 0.8e-6, 2)];
        let e = pick(ReturnMode::Dual, &close, &mut rng);
        assert!(e.len() == 2, "{e:?}");
        assert!(
            (e[0].range_m - 20.0).abs() < 0.02 && (e[1].range_m - 21.0).abs() < 0.02,
            "{e:?}"
        );
        assert!((e[0].range_m - 20.0).abs() < 0.02 && (e[1].range_m - 21.0).abs() < 0.02);
    }

    #[test]
    fn configured_pulse_pair_resolution_merges_close_echoes() {
        let mut rng = SmallRng::seed_from_u64(12);
        let returns = [ret(20.0, 0.6e-6, 1), ret(21.0, 1e-6, 2)];
        let c = DetectorConfig {
            return_mode: ReturnMode::Dual,
            pulse_pair_resolution_m: Some(1.5),
            ..DetectorConfig::default()
        };
        let e = run(&detector(&c, &[NOISE_OFF]), &returns, 0.0, &mut rng);
        assert_eq!(e.len(), 1, "{e:?}");
        assert_eq!(e[0].object_id, 2);
        assert!((e[0].range_m - 21.0).abs() < 0.02, "{e:?}");
        // Default (c·FWHM/2 = 0.75 m): both.
        let c = DetectorConfig {
            return_mode: ReturnMode::Dual,
            ..DetectorConfig::default()
        };
        let d = detector(&c, &[NOISE_OFF]);
        assert!((d.pulse_pair_resolution_m() - 0.749_481).abs() < 1e-5);
        assert_eq!(run(&d, &returns, 0.0, &mut rng).len(), 2);
    }

    #[test]
    fn returns_closer_than_pulse_blend_into_one_echo() {
        let mut rng = SmallRng::seed_from_u64(5);
        let c = DetectorConfig {
            return_mode: ReturnMode::Dual,
            ..DetectorConfig::default()
        };
        let d = detector(&c, &[NOISE_OFF, WALK_OFF]);
        // 0.3 m (closed-form moment match) and 0.5 m (sampled waveform, still unimodal: < 2σ_r).
        for sep in [0.3, 0.5] {
            let e = run(
                &d,
                &[ret(20.0, 0.5e-6, 1), ret(20.0 + sep, 0.5e-6, 2)],
                0.0,
                &mut rng,
            );
            assert_eq!(e.len(), 1, "{sep}: {e:?}");
            assert!((e[0].range_m - (20.0 + sep / 2.0)).abs() < 0.005, "{e:?}");
            assert!(e[0].peak_power_w > 0.5e-6 && e[0].peak_power_w < 1e-6);
        }
        // A slanted surface: 61 sub-rays spread uniformly over ±0.15 m: one echo at the centre with
        // the moment-matched amplitude ΣP·σ/√(σ² + var) and a broadened pulse.
        let s = d.pulse_sigma_m();
        let subrays: Vec<Return> = (0..61)
            .map(|i| ret(30.0 - 0.15 + 0.3 * i as f64 / 60.0, 1e-8, 7))
            .collect();
        let var = (0..61)
            .map(|i| (-0.15 + 0.3 * i as f64 / 60.0_f64).powi(2))
            .sum::<f64>()
            / 61.0;
        let e = run(&d, &subrays, 0.0, &mut rng);
        assert_eq!(e.len(), 1);
        assert!((e[0].range_m - 30.0).abs() < 0.005);
        let expected = 61e-8 * s / (s * s + var).sqrt();
        assert!(
            (e[0].peak_power_w / expected - 1.0).abs() < 1e-9,
            "{e:?} {expected}"
        );
        let single = run(&d, &[ret(30.0, expected, 7)], 0.0, &mut rng);
        assert!(e[0].pulse_width_s > single[0].pulse_width_s);
    }

    #[test]
    fn saturation_clamps_and_flags() {
        let mut rng = SmallRng::seed_from_u64(6);
        let c = DetectorConfig {
            intensity_mode: IntensityMode::Power,
            power_full_scale_w: Some(10e-3),
            ..DetectorConfig::default()
        };
        let d = detector(&c, &[NOISE_OFF]);
        let e = run(&d, &[ret(10.0, 1e-3, 1)], 0.0, &mut rng);
        assert!(e[0].saturated && e[0].intensity == 100.0);
        assert!((e[0].peak_power_w - 1e-3).abs() < 1e-12);
        // Amplitude walk correction from the clipped amplitude under-corrects: range short by
        // σ_r(√(2 ln(A/T)) − √(2 ln(P_sat/T))).
        let t = d.threshold_power_w(0.0);
        let s = d.pulse_sigma_m();
        let short = s * ((2.0 * (1e-3 / t).ln()).sqrt() - (2.0 * (100e-6 / t).ln()).sqrt());
        assert!(
            (10.0 - e[0].range_m - short).abs() <= 0.0021,
            "{e:?} {short}"
        );
        assert!(short > 0.1);
        // Below saturation: unflagged, linear.
        let e = run(&d, &[ret(10.0, 50e-6, 1)], 0.0, &mut rng);
        assert!(!e[0].saturated && (e[0].intensity - 0.5).abs() < 1e-5);
        assert!((e[0].range_m - 10.0).abs() <= 0.0021);
        // Off: linear to any amplitude, no flag, no saturation walk.
        let d = detector(&c, &[NOISE_OFF, SAT_OFF]);
        let e = run(&d, &[ret(10.0, 1e-3, 1)], 0.0, &mut rng);
        assert!(!e[0].saturated && (e[0].intensity - 10.0).abs() < 1e-4);
        assert!((e[0].range_m - 10.0).abs() <= 0.0021);
    }

    #[test]
    fn range_walk_follows_gaussian_closed_form() {
        let mut rng = SmallRng::seed_from_u64(8);
        let a_ref = 1e-6;
        let c = DetectorConfig {
            walk_correction: WalkCorrection::Constant,
            walk_reference_power_w: a_ref,
            ..DetectorConfig::default()
        };
        let d = detector(&c, &[NOISE_OFF, SAT_OFF]);
        let t = sigma_p(&c, 0.0, 0.0) * 4.753_424;
        // σ_r = (c/2)·FWHM/(2√(2 ln 2)) = 0.3183 m for 5 ns.
        let s = 0.5 * 299_792_458.0 * 5e-9 / (2.0 * (2.0 * 2f64.ln()).sqrt());
        let r = 40.0;
        let mut prev_err = f64::INFINITY;
        for a in [5e-9, 1e-8, 1e-7, 1e-6, 1e-5, 1e-4] {
            let e = run(&d, &[ret(r, a, 1)], 0.0, &mut rng);
            let err = e[0].range_m - r;
            let expected = s * ((2.0 * (a_ref / t).ln()).sqrt() - (2.0 * (a / t).ln()).sqrt());
            assert!(
                (err - expected).abs() <= 0.0021,
                "A {a}: {err} vs {expected}"
            );
            // Stronger echoes cross earlier: the error falls monotonically with amplitude.
            assert!(err < prev_err);
            prev_err = err;
            if a < a_ref {
                assert!(err > 0.0);
            } else if a > a_ref {
                assert!(err < 0.0);
            }
        }
        // Off: range from the peak, exact up to quantisation.
        let d = detector(&c, &[NOISE_OFF, SAT_OFF, WALK_OFF]);
        for a in [5e-9, 1e-6, 1e-4] {
            let e = run(&d, &[ret(r, a, 1)], 0.0, &mut rng);
            assert!((e[0].range_m - r).abs() <= 0.0021);
        }
    }

    #[test]
    fn dropped_rays_at_configured_rate() {
        let c = DetectorConfig {
            drop_probability: 0.25,
            ..DetectorConfig::default()
        };
        let d = detector(&c, &[]);
        let mut rng = SmallRng::seed_from_u64(9);
        let n = 20_000;
        let got = (0..n)
            .filter(|_| run(&d, &[ret(20.0, 1e-6, 1)], 0.0, &mut rng).is_empty())
            .count() as f64
            / n as f64;
        assert!(
            (got - 0.25).abs() < 4.0 * (0.25 * 0.75 / n as f64).sqrt(),
            "{got}"
        );
        let d = detector(&c, &[("lidar.dropped_rays", false)]);
        assert!((0..1000).all(|_| run(&d, &[ret(20.0, 1e-6, 1)], 0.0, &mut rng).len() == 1));
    }

    #[test]
    fn deterministic_for_seed() {
        let c = DetectorConfig {
            return_mode: ReturnMode::Dual,
            ..DetectorConfig::default()
        };
        let d = detector(&c, &[]);
        let returns: Vec<Return> = (0..40)
            .map(|i| {
                ret(
                    10.0 + 0.37 * i as f64,
                    1e-8 * (1.0 + (i % 7) as f64),
                    i as u64,
                )
            })
            .collect();
        let a = run(&d, &returns, 1e-9, &mut SmallRng::seed_from_u64(42));
        let mut reversed = returns.clone();
        reversed.reverse();
        let b = run(&d, &reversed, 1e-9, &mut SmallRng::seed_from_u64(42));
        assert!(!a.is_empty());
        assert_eq!(a, b);
        let c2 = run(&d, &returns, 1e-9, &mut SmallRng::seed_from_u64(43));
        assert_ne!(a, c2);
    }

    #[test]
    fn config_errors_name_the_key() {
        let effects = Effects::new(EFFECTS);
        let bad = DetectorConfig {
            apd_gain: 0.5,
            ..DetectorConfig::default()
        };
        match Detector::new(&bad, &effects, calibration()) {
            Err(ModelError::Config(m)) => assert!(m.contains("apd_gain"), "{m}"),
            other => panic!("{other:?}"),
        }
        let bad = DetectorConfig {
            pulse_fwhm_s: f64::NAN,
            ..DetectorConfig::default()
        };
        assert!(
            matches!(Detector::new(&bad, &effects, calibration()), Err(ModelError::Config(m)) if m.contains("pulse_fwhm_s"))
        );
        match Detector::new(
            &DetectorConfig::default(),
            &effects,
            IntensityCalibration::default(),
        ) {
            Err(ModelError::Config(m)) => assert!(m.contains("intensity_mode"), "{m}"),
            other => panic!("{other:?}"),
        }
        let power = DetectorConfig {
            intensity_mode: IntensityMode::Power,
            ..DetectorConfig::default()
        };
        assert!(Detector::new(&power, &effects, IntensityCalibration::default()).is_ok());
        // JSON: defaults, enums, unknown keys.
        let parsed: DetectorConfig = serde_json::from_str("{}").unwrap();
        assert_eq!(parsed, DetectorConfig::default());
        let parsed: DetectorConfig =
            serde_json::from_str(r#"{"return_mode": "dual", "intensity_scale": "u8"}"#).unwrap();
        assert_eq!(parsed.return_mode, ReturnMode::Dual);
        assert!(serde_json::from_str::<DetectorConfig>(r#"{"gain": 3}"#).is_err());
    }

    #[test]
    fn ignores_bad_returns_without_panicking() {
        let d = detector(&DetectorConfig::default(), &[]);
        let mut rng = SmallRng::seed_from_u64(10);
        let e = run(
            &d,
            &[
                ret(f64::NAN, 1e-6, 1),
                ret(20.0, -1.0, 2),
                ret(20.0, f64::INFINITY, 3),
                ret(30.0, 1e-6, 4),
            ],
            f64::NAN,
            &mut rng,
        );
        assert_eq!(e.len(), 1);
        assert_eq!(e[0].object_id, 4);
        assert!(run(&d, &[], 0.0, &mut rng).is_empty());
    }

    /// Timing of `detect` (prints only; run with
    /// `cargo test -p osiris-models --release --lib lidar::detection::tests::bench -- --ignored --nocapture`).
    #[test]
    #[ignore]
    fn bench_detect() {
        let d = detector(&DetectorConfig::default(), &[]);
        let mut rng = SmallRng::seed_from_u64(1);
        let mut out = Vec::with_capacity(4);
        let cases: [(&str, Vec<Return>); 3] = [
            ("1 return", vec![ret(50.0, 1e-7, 1)]),
            (
                "19 sub-rays, one surface",
                (0..19)
                    .map(|i| ret(50.0 + 0.01 * i as f64, 1e-8, 1))
                    .collect(),
            ),
            (
                "19 sub-rays, two surfaces",
                (0..19)
                    .map(|i| {
                        ret(
                            50.0 + if i < 9 { 0.0 } else { 1.2 } + 0.01 * i as f64,
                            1e-8,
                            1,
                        )
                    })
                    .collect(),
            ),
        ];
        for (name, returns) in cases {
            let mut buf = returns.clone();
            let n = 200_000;
            let t0 = std::time::Instant::now();
            let mut count = 0;
            for _ in 0..n {
                buf.copy_from_slice(&returns);
                out.clear();
                d.detect(&mut buf, 1e-10, &mut rng, &mut out);
                count += out.len();
            }
            let ns = t0.elapsed().as_secs_f64() * 1e9 / n as f64;
            println!("{name}: {ns:.0} ns per pulse ({count} echoes)");
        }
    }
}
