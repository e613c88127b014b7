//! Coherent (heterodyne) detection of one chirp: noise terms, SNR and the coherence roll-off
//! (physics.md §2.9).
//!
//! The received field (power P_s, of which the fraction η_het mixes with the LO mode) beats with the
//! local oscillator (power P_LO) on a balanced photodiode pair of responsivity ℜ = ηqλ/(hc). The beat
//! current is i(t) = 2ℜ√(η_het P_s P_LO)·cos(2πf_b t + φ), of mean square ⟨i²⟩ = 2ℜ²η_het P_s P_LO.
//! Integrated coherently over the window T_w (the FFT bin is a matched filter of noise bandwidth
//! 1/T_w), the SNR of the beat peak is
//!
//! SNR = ⟨i²⟩·T_w / N₀,  N₀ = 2qℜ(P_LO + P_s + P_bg) + i_n² + RIN·(ℜP_LO)²·10^(−CMRR/10)  [A²/Hz],
//!
//! which in the LO-shot-noise limit is the photon count SNR = η·η_het·P_s·T_w/(hν) (Jelalian, *Laser
//! Radar Systems*, Artech House 1992, ch. 2; Fujii & Fukuchi, *Laser Remote Sensing*, CRC 2005, ch. 7).
//! Sunlight enters only through its shot noise 2qℜP_bg, negligible beside the LO's: FMCW is immune to
//! the solar background that raises the pulsed chain's threshold.

use crate::constants::{PLANCK_J_S, SPEED_OF_LIGHT_M_S};

use super::FmcwConfig;

/// Elementary charge q, C (SI 2019, exact).
pub const ELEMENTARY_CHARGE_C: f64 = 1.602_176_634e-19;

/// One-sided noise current densities at the balanced detector output, A²/Hz.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoisePsd {
    /// LO shot noise 2qℜP_LO.
    pub lo_shot: f64,
    /// Shot noise of the received signal itself, 2qℜP_s.
    pub signal_shot: f64,
    /// Shot noise of the background (sunlight) reaching the detector, 2qℜP_bg.
    pub background_shot: f64,
    /// Receiver (TIA, thermal) noise i_n².
    pub receiver: f64,
    /// LO relative-intensity noise left by the balanced detector, RIN·(ℜP_LO)²·10^(−CMRR/10).
    pub rin: f64,
}

impl NoisePsd {
    /// Sum of all terms N₀, A²/Hz.
    pub fn total(&self) -> f64 {
        self.lo_shot + self.signal_shot + self.background_shot + self.receiver + self.rin
    }
}

/// The coherent receiver of one beam, derived once from [`FmcwConfig`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CoherentReceiver {
    /// Photodiode responsivity ℜ = ηqλ/(hc), A/W.
    pub responsivity_a_per_w: f64,
    /// Heterodyne efficiency η_het.
    pub heterodyne_efficiency: f64,
    /// LO power, W.
    pub lo_power_w: f64,
    /// Coherent integration time (the sampling window T_w), s.
    pub window_s: f64,
    /// Receiver current noise density squared, A²/Hz.
    receiver_psd: f64,
    /// RIN (linear, 1/Hz) × 10^(−CMRR/10).
    rin_residual_per_hz: f64,
    /// Photon energy hν, J.
    photon_energy_j: f64,
    /// Quantum efficiency η.
    quantum_efficiency: f64,
    /// Laser linewidth Δν, Hz.
    pub linewidth_hz: f64,
}

impl CoherentReceiver {
    /// The receiver of a (validated) configuration.
    pub fn new(config: &FmcwConfig) -> CoherentReceiver {
        let lambda = config.wavelength_m();
        let photon_energy_j = PLANCK_J_S * SPEED_OF_LIGHT_M_S / lambda;
        CoherentReceiver {
            responsivity_a_per_w: config.quantum_efficiency * ELEMENTARY_CHARGE_C / photon_energy_j,
            heterodyne_efficiency: config.heterodyne_efficiency,
            lo_power_w: config.lo_power_w,
            window_s: config.samples_per_chirp as f64 / config.adc_rate_hz,
            receiver_psd: config.receiver_noise_a_per_sqrt_hz.powi(2),
            rin_residual_per_hz: 10f64
                .powf((config.lo_rin_db_per_hz - config.balanced_cmrr_db) / 10.0),
            photon_energy_j,
            quantum_efficiency: config.quantum_efficiency,
            linewidth_hz: config.linewidth_hz,
        }
    }

    /// The noise terms with P_s received and P_bg background at the detector, A²/Hz.
    pub fn noise_psd(&self, signal_w: f64, background_w: f64) -> NoisePsd {
        let r = self.responsivity_a_per_w;
        let two_q_r = 2.0 * ELEMENTARY_CHARGE_C * r;
        NoisePsd {
            lo_shot: two_q_r * self.lo_power_w,
            signal_shot: two_q_r * signal_w.max(0.0),
            background_shot: two_q_r * background_w.max(0.0),
            receiver: self.receiver_psd,
            rin: self.rin_residual_per_hz * (r * self.lo_power_w).powi(2),
        }
    }

    /// SNR per watt of received power for a given noise density N₀: 2ℜ²η_het P_LO T_w / N₀, 1/W.
    pub fn snr_per_watt(&self, noise_psd_a2_per_hz: f64) -> f64 {
        2.0 * self.responsivity_a_per_w.powi(2)
            * self.heterodyne_efficiency
            * self.lo_power_w
            * self.window_s
            / noise_psd_a2_per_hz
    }

    /// SNR (linear, power) of the beat peak of one chirp for P_s received (ideal coherent laser,
    /// rectangular window): 2ℜ²η_het P_s P_LO T_w / N₀.
    pub fn snr(&self, signal_w: f64, background_w: f64) -> f64 {
        let n0 = self.noise_psd(signal_w, background_w).total();
        self.snr_per_watt(n0) * signal_w
    }

    /// The LO-shot-noise (quantum) limit η·η_het·P_s·T_w/(hν): the detected photon count.
    pub fn shot_limited_snr(&self, signal_w: f64) -> f64 {
        self.quantum_efficiency * self.heterodyne_efficiency * signal_w * self.window_s
            / self.photon_energy_j
    }

    /// Coherence time τ_c = 1/(πΔν), s (infinite for Δν = 0).
    pub fn coherence_time_s(&self) -> f64 {
        1.0 / (std::f64::consts::PI * self.linewidth_hz)
    }

    /// Fraction of the beat power left in the coherent peak at round-trip delay τ,
    /// exp(−2τ/τ_c) = exp(−2πΔν·τ) (Salvadé & Dändliker 2000); the rest is a pedestal ≈ 2Δν wide.
    pub fn coherent_fraction(&self, delay_s: f64) -> f64 {
        (-2.0 * std::f64::consts::PI * self.linewidth_hz * delay_s).exp()
    }
}

#[cfg(test)]
// Tests vary one or two keys of the preset at a time.
#[allow(clippy::field_reassign_with_default)]
mod tests {
    use super::*;

    #[test]
    fn shot_noise_limit_and_range_law() {
        let mut cfg = FmcwConfig::default();
        // Ideal receiver: only LO shot noise.
        cfg.receiver_noise_a_per_sqrt_hz = 0.0;
        cfg.lo_rin_db_per_hz = -400.0;
        let rx = CoherentReceiver::new(&cfg);
        let h = 6.626_070_15e-34;
        let c = 299_792_458.0;
        let nu = c / (cfg.wavelength_nm * 1e-9);
        let tw = cfg.samples_per_chirp as f64 / cfg.adc_rate_hz;
        let p = 1e-9;
        let expected = cfg.quantum_efficiency * cfg.heterodyne_efficiency * p * tw / (h * nu);
        // Signal shot noise 2qℜP_s is 10⁻⁶ of the LO's here.
        assert!((rx.snr(p, 0.0) / expected - 1.0).abs() < 1e-4);
        assert!((rx.shot_limited_snr(p) / expected - 1.0).abs() < 1e-12);
        // P_r ∝ 1/R² (extended target): doubling the range costs 6.02 dB.
        let p_at = |r: f64| 1e-9 * (10.0 / r).powi(2);
        let db = 10.0 * (rx.snr(p_at(20.0), 0.0) / rx.snr(p_at(10.0), 0.0)).log10();
        assert!((db + 20.0 * 2f64.log10()).abs() < 1e-3, "{db}");
    }

    #[test]
    fn noise_terms_and_solar_immunity() {
        let cfg = FmcwConfig::default();
        let rx = CoherentReceiver::new(&cfg);
        let q = 1.602_176_634e-19;
        let r = rx.responsivity_a_per_w;
        let n = rx.noise_psd(0.0, 1e-6);
        assert!((n.lo_shot - 2.0 * q * r * cfg.lo_power_w).abs() < 1e-30);
        assert!((n.receiver - cfg.receiver_noise_a_per_sqrt_hz.powi(2)).abs() < 1e-35);
        let rin = 10f64.powf((cfg.lo_rin_db_per_hz - cfg.balanced_cmrr_db) / 10.0)
            * (r * cfg.lo_power_w).powi(2);
        assert!((n.rin / rin - 1.0).abs() < 1e-12);
        // 1 µW of sunlight beside 1 mW of LO: the SNR falls by 0.1 %, not by orders of magnitude.
        let ratio = rx.snr(1e-9, 1e-6) / rx.snr(1e-9, 0.0);
        assert!(ratio > 0.998 && ratio < 1.0, "{ratio}");
    }

    #[test]
    fn coherence_roll_off() {
        let mut cfg = FmcwConfig::default();
        cfg.linewidth_hz = 1e6;
        let rx = CoherentReceiver::new(&cfg);
        let tau_c = 1.0 / (std::f64::consts::PI * 1e6);
        assert!((rx.coherence_time_s() - tau_c).abs() < 1e-18);
        let tau = 0.5e-6;
        assert!((rx.coherent_fraction(tau) - (-2.0 * tau / tau_c).exp()).abs() < 1e-12);
        cfg.linewidth_hz = 0.0;
        assert_eq!(CoherentReceiver::new(&cfg).coherent_fraction(tau), 1.0);
    }
}
