//! Chirp sequence (FMCW) and MIMO array parameters with their derived quantities.
//!
//! Relations (physics.md §1.6; TI "Introduction to mmWave Sensing: FMCW Radars", Richards,
//! *Fundamentals of Radar Signal Processing*):
//! * beat frequency `f_b = 2 S R / c + 2 v / λ` (S = chirp slope);
//! * range resolution `ΔR = c / (2 B)` with `B = S N_s / f_s` the bandwidth swept while the ADC samples;
//! * maximum range (complex IQ sampling) `R_max = f_s c / (2 S)`;
//! * maximum unambiguous velocity `v_max = λ / (4 T_c')` and resolution `Δv = λ / (2 N_c T_c')`, with
//!   `T_c'` the repetition interval of the chirps of one Tx (`N_tx T_c` in TDM-MIMO).
//!
//! Defaults: a TI AWR1843-like front radar (3 Tx × 4 Rx = 12 virtual channels, 256 complex samples
//! at 10 Msps, 128 chirps per Tx, chirps inside 76–77 GHz). The numbers are a plausible AWR1843
//! profile chosen by us (guessed, not a TI reference configuration).

use crate::constants::SPEED_OF_LIGHT_M_S;
use serde::{Deserialize, Serialize};

use crate::error::ModelError;

/// Oscillator phase noise (the `radar.phase_noise` effect), a single-pole (Lorentzian) PSD
/// `L(f) = L₀ / (1 + (f/f_c)²)` with `L₀` the plateau in dBc/Hz.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PhaseNoiseConfig {
    /// Phase noise at `offset_hz`, dBc/Hz (−93 dBc/Hz at 1 MHz: TI AWR1843 datasheet figure as
    /// we recall it for 77–81 GHz; UNVERIFIED).
    pub level_dbc_hz: f64,
    /// Offset frequency at which `level_dbc_hz` is given, Hz.
    pub offset_hz: f64,
    /// Corner frequency of the single-pole PSD (PLL loop bandwidth), Hz (guessed 500 kHz).
    pub corner_hz: f64,
}

impl Default for PhaseNoiseConfig {
    fn default() -> Self {
        PhaseNoiseConfig {
            level_dbc_hz: -93.0,
            offset_hz: 1e6,
            corner_hz: 500e3,
        }
    }
}

impl PhaseNoiseConfig {
    /// Single-sideband PSD `L(f)` (linear, 1/Hz).
    pub fn psd_per_hz(&self, f_hz: f64) -> f64 {
        let at = |f: f64| 1.0 / (1.0 + (f / self.corner_hz).powi(2));
        10f64.powf(self.level_dbc_hz / 10.0) / at(self.offset_hz) * at(f_hz)
    }

    /// Variance of the residual IF phase error of a path with delay `tau_s`, averaged over one
    /// chirp's sampling time `t_s` (the slow-time, chirp-to-chirp part), rad²:
    /// `σ² = ∫₀^∞ 2 L(f) · 4 sin²(π f τ) · sinc²(f t_s) df` (Budge & Burt 1993: the mixer sees
    /// φ(t) − φ(t−τ), PSD S_φ(f)·4 sin²(π f τ), S_φ = 2L; the chirp average is a moving-average
    /// filter |sinc(f t_s)|²). Numerical quadrature on a log grid 1 Hz … 1 GHz.
    pub fn residual_variance_rad2(&self, tau_s: f64, t_s: f64) -> f64 {
        const N: usize = 4000;
        let (lo, hi) = (0f64, 9f64); // log10 f
        let h = (hi - lo) / N as f64;
        let mut sum = 0.0;
        for i in 0..N {
            let f = 10f64.powf(lo + (i as f64 + 0.5) * h);
            let x = std::f64::consts::PI * f * t_s;
            let sinc2 = if x.abs() < 1e-9 {
                1.0
            } else {
                (x.sin() / x).powi(2)
            };
            let s = (std::f64::consts::PI * f * tau_s).sin();
            // df = f ln10 d(log10 f).
            sum += 2.0 * self.psd_per_hz(f) * 4.0 * s * s * sinc2 * f * std::f64::consts::LN_10 * h;
        }
        sum
    }
}

/// Another FMCW radar whose chirps reach this one (the `radar.interference` effect).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct InterfererConfig {
    /// Start frequency of the interferer's chirps, Hz.
    pub start_frequency_hz: f64,
    /// Chirp slope of the interferer, Hz/s (differs from ours: the chirps cross).
    pub slope_hz_per_s: f64,
    /// Ramp duration of the interferer, s.
    pub ramp_time_s: f64,
    /// Chirp repetition interval of the interferer, s.
    pub chirp_interval_s: f64,
    /// Start of the interferer's first chirp relative to ours, s.
    pub delay_s: f64,
    /// Interferer power at our receiver input (after its Tx gain, one-way spreading, our Rx gain), dBm.
    pub power_dbm: f64,
    /// Direction of arrival of the interferer, azimuth, rad.
    pub azimuth_rad: f64,
    /// Direction of arrival of the interferer, elevation, rad.
    pub elevation_rad: f64,
}

impl Default for InterfererConfig {
    /// An oncoming radar at ≈ 50 m (guessed): 12 dBm + 12 dBi, one-way free space at 50 m, 12 dBi Rx
    /// → ≈ −60 dBm; a different slope so its chirps cross ours.
    fn default() -> Self {
        InterfererConfig {
            start_frequency_hz: 76.0e9,
            slope_hz_per_s: 25e12,
            ramp_time_s: 30e-6,
            chirp_interval_s: 41e-6,
            delay_s: 3.3e-6,
            power_dbm: -60.0,
            azimuth_rad: 0.0,
            elevation_rad: 0.0,
        }
    }
}

/// FMCW chirp sequence parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct WaveformConfig {
    /// Reference (centre) frequency of the chirps, Hz: λ = c/f for the range phase 4πR/λ and the
    /// Doppler 2v/λ.
    pub carrier_frequency_hz: f64,
    /// Chirp slope S, Hz/s.
    pub slope_hz_per_s: f64,
    /// Ramp duration, s (must cover `adc_start_time_s + samples_per_chirp / sample_rate_hz`).
    pub ramp_time_s: f64,
    /// Idle time between ramps, s (chirp interval T_c = idle + ramp).
    pub idle_time_s: f64,
    /// ADC start after the ramp start, s.
    pub adc_start_time_s: f64,
    /// Complex (IQ) ADC sampling rate f_s, Hz.
    pub sample_rate_hz: f64,
    /// Samples per chirp N_s.
    pub samples_per_chirp: usize,
    /// Chirps per frame and Tx, N_c (the Doppler FFT length).
    pub chirps_per_frame: usize,
    /// Time-division MIMO: the Tx antennas fire one after another, each in its own chirp slot
    /// (T_c' = N_tx T_c; a Tx-dependent Doppler phase couples velocity and angle, compensated in
    /// processing). `false`: idealised orthogonal simultaneous Tx (T_c' = T_c, no slot offset).
    pub tdm_mimo: bool,
    /// Oscillator phase noise (`radar.phase_noise`).
    pub phase_noise: PhaseNoiseConfig,
    /// Interfering radar (`radar.interference`, default off).
    pub interferer: InterfererConfig,
}

impl Default for WaveformConfig {
    fn default() -> Self {
        WaveformConfig {
            carrier_frequency_hz: 76.5e9,
            slope_hz_per_s: 15e12,
            ramp_time_s: 28e-6,
            idle_time_s: 4e-6,
            adc_start_time_s: 1e-6,
            sample_rate_hz: 10e6,
            samples_per_chirp: 256,
            chirps_per_frame: 128,
            tdm_mimo: true,
            phase_noise: PhaseNoiseConfig::default(),
            interferer: InterfererConfig::default(),
        }
    }
}

impl WaveformConfig {
    /// Wavelength at the reference frequency, m.
    pub fn wavelength_m(&self) -> f64 {
        SPEED_OF_LIGHT_M_S / self.carrier_frequency_hz
    }

    /// Chirp interval T_c (ramp + idle), s.
    pub fn chirp_interval_s(&self) -> f64 {
        self.ramp_time_s + self.idle_time_s
    }

    /// Repetition interval of the chirps of one Tx, T_c' (N_tx T_c in TDM-MIMO), s.
    pub fn tx_repetition_interval_s(&self, n_tx: usize) -> f64 {
        if self.tdm_mimo {
            n_tx as f64 * self.chirp_interval_s()
        } else {
            self.chirp_interval_s()
        }
    }

    /// ADC sampling time per chirp, s.
    pub fn sampling_time_s(&self) -> f64 {
        self.samples_per_chirp as f64 / self.sample_rate_hz
    }

    /// Bandwidth swept while the ADC samples, `B = S N_s / f_s`, Hz.
    pub fn sampled_bandwidth_hz(&self) -> f64 {
        self.slope_hz_per_s * self.sampling_time_s()
    }

    /// Range resolution `c / (2B)`, m (also the range-FFT bin width).
    pub fn range_resolution_m(&self) -> f64 {
        SPEED_OF_LIGHT_M_S / (2.0 * self.sampled_bandwidth_hz())
    }

    /// Maximum range with complex sampling, `f_s c / (2S)`, m.
    pub fn max_range_m(&self) -> f64 {
        self.sample_rate_hz * SPEED_OF_LIGHT_M_S / (2.0 * self.slope_hz_per_s)
    }

    /// Maximum unambiguous radial velocity `λ / (4 T_c')`, m/s.
    pub fn max_velocity_m_s(&self, n_tx: usize) -> f64 {
        self.wavelength_m() / (4.0 * self.tx_repetition_interval_s(n_tx))
    }

    /// Velocity resolution `λ / (2 N_c T_c')`, m/s (also the Doppler-FFT bin width).
    pub fn velocity_resolution_m_s(&self, n_tx: usize) -> f64 {
        self.wavelength_m()
            / (2.0 * self.chirps_per_frame as f64 * self.tx_repetition_interval_s(n_tx))
    }

    /// Frame duration (all chirps of all Tx), s.
    pub fn frame_time_s(&self, n_tx: usize) -> f64 {
        self.chirps_per_frame as f64 * self.tx_repetition_interval_s(n_tx)
    }

    /// Beat frequency of a path, `f_b = 2 S R / c + 2 v / λ`, Hz.
    pub fn beat_frequency_hz(&self, range_m: f64, range_rate_m_s: f64) -> f64 {
        2.0 * self.slope_hz_per_s * range_m / SPEED_OF_LIGHT_M_S
            + 2.0 * range_rate_m_s / self.wavelength_m()
    }

    /// Check the values; errors name the key (`radar.waveform.<key>`).
    pub fn validate(&self) -> Result<(), ModelError> {
        let err = |k: &str, m: String| Err(ModelError::Config(format!("`radar.waveform.{k}` {m}")));
        for (k, v) in [
            ("carrier_frequency_hz", self.carrier_frequency_hz),
            ("slope_hz_per_s", self.slope_hz_per_s),
            ("ramp_time_s", self.ramp_time_s),
            ("sample_rate_hz", self.sample_rate_hz),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return err(k, format!("must be finite and > 0, got {v}"));
            }
        }
        for (k, v) in [
            ("idle_time_s", self.idle_time_s),
            ("adc_start_time_s", self.adc_start_time_s),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return err(k, format!("must be finite and ≥ 0, got {v}"));
            }
        }
        for (k, v) in [
            ("samples_per_chirp", self.samples_per_chirp),
            ("chirps_per_frame", self.chirps_per_frame),
        ] {
            if !(4..=16384).contains(&v) {
                return err(k, format!("must be in 4..=16384, got {v}"));
            }
        }
        if self.adc_start_time_s + self.sampling_time_s() > self.ramp_time_s * (1.0 + 1e-9) {
            return err(
                "ramp_time_s",
                format!(
                    "({} s) must cover adc_start_time_s + samples_per_chirp / sample_rate_hz = {} s",
                    self.ramp_time_s,
                    self.adc_start_time_s + self.sampling_time_s()
                ),
            );
        }
        let pn = &self.phase_noise;
        if !pn.level_dbc_hz.is_finite() || pn.level_dbc_hz > 0.0 {
            return err(
                "phase_noise.level_dbc_hz",
                format!("must be finite and ≤ 0, got {}", pn.level_dbc_hz),
            );
        }
        for (k, v) in [
            ("phase_noise.offset_hz", pn.offset_hz),
            ("phase_noise.corner_hz", pn.corner_hz),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return err(k, format!("must be finite and > 0, got {v}"));
            }
        }
        let i = &self.interferer;
        for (k, v) in [
            ("interferer.start_frequency_hz", i.start_frequency_hz),
            ("interferer.ramp_time_s", i.ramp_time_s),
            ("interferer.chirp_interval_s", i.chirp_interval_s),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return err(k, format!("must be finite and > 0, got {v}"));
            }
        }
        for (k, v) in [
            ("interferer.slope_hz_per_s", i.slope_hz_per_s),
            ("interferer.delay_s", i.delay_s),
            ("interferer.power_dbm", i.power_dbm),
            ("interferer.azimuth_rad", i.azimuth_rad),
            ("interferer.elevation_rad", i.elevation_rad),
        ] {
            if !v.is_finite() {
                return err(k, format!("must be finite, got {v}"));
            }
        }
        if i.chirp_interval_s < i.ramp_time_s {
            return err(
                "interferer.chirp_interval_s",
                "must be ≥ interferer.ramp_time_s".into(),
            );
        }
        Ok(())
    }
}

/// Tx / Rx antenna layout. Positions are `[horizontal, vertical]` in units of λ/2 (integers: the
/// angle FFT works on the λ/2 grid); horizontal positive along the sensor's +y (left), vertical
/// along +z (up). The virtual array element of (Tx t, Rx r) sits at `tx[t] + rx[r]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ArrayConfig {
    /// Tx element positions, λ/2 units; TDM firing order is the list order.
    pub tx: Vec<[i32; 2]>,
    /// Rx element positions, λ/2 units.
    pub rx: Vec<[i32; 2]>,
}

impl Default for ArrayConfig {
    /// TI AWR1843BOOST-like: Rx at 0, 1, 2, 3 (λ/2); Tx1 at 0, Tx3 at 4 (2λ) in the same row, Tx2
    /// at 2 and one λ/2 up → 8 horizontal virtual elements + 4 elevated (azimuth and elevation).
    fn default() -> Self {
        ArrayConfig {
            tx: vec![[0, 0], [4, 0], [2, 1]],
            rx: vec![[0, 0], [1, 0], [2, 0], [3, 0]],
        }
    }
}

impl ArrayConfig {
    /// Number of Tx.
    pub fn n_tx(&self) -> usize {
        self.tx.len()
    }

    /// Number of Rx.
    pub fn n_rx(&self) -> usize {
        self.rx.len()
    }

    /// Number of virtual channels N_tx N_rx.
    pub fn n_virtual(&self) -> usize {
        self.tx.len() * self.rx.len()
    }

    /// Virtual element positions (λ/2 units), channel k = t · N_rx + r.
    pub fn virtual_positions(&self) -> Vec<[i32; 2]> {
        self.tx
            .iter()
            .flat_map(|t| self.rx.iter().map(move |r| [t[0] + r[0], t[1] + r[1]]))
            .collect()
    }

    /// Whether the virtual array has a vertical aperture (elevation can be estimated).
    pub fn has_elevation(&self) -> bool {
        let v = self.virtual_positions();
        v.iter().any(|p| p[1] != v[0][1])
    }

    /// Check the values; errors name the key (`radar.array.<key>`).
    pub fn validate(&self) -> Result<(), ModelError> {
        for (k, list) in [("tx", &self.tx), ("rx", &self.rx)] {
            if list.is_empty() || list.len() > 64 {
                return Err(ModelError::Config(format!(
                    "`radar.array.{k}` must list 1..=64 element positions, got {}",
                    list.len()
                )));
            }
            if list.iter().flatten().any(|v| v.abs() > 1024) {
                return Err(ModelError::Config(format!(
                    "`radar.array.{k}` positions must be within ±1024 half-wavelengths"
                )));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn awr1843_like_defaults() {
        let w = WaveformConfig::default();
        let a = ArrayConfig::default();
        w.validate().unwrap();
        a.validate().unwrap();
        assert_eq!(a.n_virtual(), 12);
        assert!(a.has_elevation());
        // B = 15 MHz/µs × 25.6 µs = 384 MHz → ΔR = c / 2B = 0.390 m; R_max = 10 MHz·c / 30 MHz/µs.
        assert!((w.sampled_bandwidth_hz() - 384e6).abs() < 1.0);
        assert!((w.range_resolution_m() - SPEED_OF_LIGHT_M_S / 768e6).abs() < 1e-9);
        assert!((w.max_range_m() - 99.93).abs() < 0.01);
        // T_c' = 3 × 32 µs: v_max = λ/(4 T_c') = 10.2 m/s, Δv = λ/(2·128·96 µs) = 0.159 m/s.
        assert!((w.max_velocity_m_s(3) - w.wavelength_m() / 384e-6).abs() < 1e-9);
        assert!((w.velocity_resolution_m_s(3) - 0.1595).abs() < 1e-3);
        // Sweep stays inside 76–77 GHz.
        let f_lo = w.carrier_frequency_hz - w.slope_hz_per_s * w.ramp_time_s / 2.0;
        assert!(f_lo >= 76e9 && f_lo + w.slope_hz_per_s * w.ramp_time_s <= 77e9);
    }

    #[test]
    fn phase_noise_range_correlation() {
        let pn = PhaseNoiseConfig::default();
        let ts = 25.6e-6;
        // Short delays: φ(t) − φ(t−τ) ≈ τ φ'(t): the variance grows as τ².
        let (a, b) = (
            pn.residual_variance_rad2(50e-9, ts),
            pn.residual_variance_rad2(100e-9, ts),
        );
        assert!((b / a - 4.0).abs() < 0.2, "{a} {b}");
        // Without chirp averaging and for τ → ∞ the two phases decorrelate: σ² → 2·∫S_φ =
        // 2π L₀ f_c for the single-pole PSD (closed form).
        let l0 = pn.psd_per_hz(0.0);
        let limit = 2.0 * std::f64::consts::PI * l0 * pn.corner_hz;
        let v = pn.residual_variance_rad2(1e-3, 0.0);
        assert!((v / limit - 1.0).abs() < 0.05, "{v} vs {limit}");
        // Finite τ, no averaging: 2π L₀ f_c (1 − e^{−2π f_c τ}).
        let tau = 300e-9;
        let closed = limit * (1.0 - (-2.0 * std::f64::consts::PI * pn.corner_hz * tau).exp());
        let v = pn.residual_variance_rad2(tau, 0.0);
        assert!((v / closed - 1.0).abs() < 0.05, "{v} vs {closed}");
    }

    #[test]
    fn bad_values_name_the_key() {
        let w = WaveformConfig {
            ramp_time_s: 10e-6,
            ..WaveformConfig::default()
        };
        let e = w.validate().unwrap_err().to_string();
        assert!(e.contains("radar.waveform.ramp_time_s"), "{e}");
        let w = WaveformConfig {
            samples_per_chirp: 0,
            ..WaveformConfig::default()
        };
        assert!(
            w.validate()
                .unwrap_err()
                .to_string()
                .contains("samples_per_chirp")
        );
        let a = ArrayConfig {
            tx: vec![],
            rx: vec![[0, 0]],
        };
        assert!(
            a.validate()
                .unwrap_err()
                .to_string()
                .contains("radar.array.tx")
        );
        let w: Result<WaveformConfig, _> = serde_json::from_str(r#"{"slope": 1}"#);
        assert!(w.is_err());
    }
}
