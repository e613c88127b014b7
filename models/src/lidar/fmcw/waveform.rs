//! The triangular chirp of one beam: slope, beat frequencies, their inversion, resolutions and the
//! unambiguous band (physics.md §2.8).
//!
//! The laser sweeps up by B in T_c, then down by B in T_c; the slope is κ = B/T_c. An echo delayed by
//! τ = 2R/c beats with the local oscillator at the range frequency f_R = κτ = 2κR/c, shifted by the
//! echo's Doppler shift f_D = −2v_r/λ (v_r = dR/dt, positive receding): the up ramp gives
//! f_up = f_R − f_D, the down ramp (conjugated so that its tone is at +f_down) f_down = f_R + f_D.
//! Hence R = c(f_up + f_down)/(4κ) and v_r = λ(f_up − f_down)/4.
//!
//! The I/Q ADC samples N points at f_s at the end of each ramp (window T_w = N/f_s): frequency bins
//! are f_s/N wide and the band is [−f_s/2, f_s/2); a beat outside it aliases (wraps by f_s).

use crate::constants::SPEED_OF_LIGHT_M_S;

use super::FmcwConfig;

/// The chirp plan of one beam, derived once from [`FmcwConfig`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChirpPlan {
    /// Wavelength λ, m.
    pub wavelength_m: f64,
    /// Chirp slope κ = B/T_c, Hz/s.
    pub slope_hz_per_s: f64,
    /// Ramp duration T_c, s.
    pub chirp_time_s: f64,
    /// Complex ADC rate f_s, Hz.
    pub adc_rate_hz: f64,
    /// Samples per ramp N.
    pub samples: usize,
}

impl ChirpPlan {
    /// The plan of a (validated) configuration.
    pub fn new(config: &FmcwConfig) -> ChirpPlan {
        ChirpPlan {
            wavelength_m: config.wavelength_m(),
            slope_hz_per_s: config.bandwidth_hz / config.chirp_time_s,
            chirp_time_s: config.chirp_time_s,
            adc_rate_hz: config.adc_rate_hz,
            samples: config.samples_per_chirp,
        }
    }

    /// Sampling window T_w = N/f_s, s.
    pub fn window_s(&self) -> f64 {
        self.samples as f64 / self.adc_rate_hz
    }

    /// Start of the sampling window within the ramp, T_c − T_w, s (the window closes the ramp, so
    /// every echo from closer than c(T_c − T_w)/2 has arrived before it opens).
    pub fn window_start_s(&self) -> f64 {
        self.chirp_time_s - self.window_s()
    }

    /// FFT bin width f_s/N = 1/T_w, Hz.
    pub fn bin_hz(&self) -> f64 {
        self.adc_rate_hz / self.samples as f64
    }

    /// Bandwidth swept during the window, B_eff = κT_w, Hz.
    pub fn effective_bandwidth_hz(&self) -> f64 {
        self.slope_hz_per_s * self.window_s()
    }

    /// Round-trip delay τ = 2R/c, s.
    pub fn delay_s(range_m: f64) -> f64 {
        2.0 * range_m / SPEED_OF_LIGHT_M_S
    }

    /// Range frequency f_R = 2κR/c, Hz.
    pub fn range_frequency_hz(&self, range_m: f64) -> f64 {
        self.slope_hz_per_s * Self::delay_s(range_m)
    }

    /// Doppler shift of the echo f_D = −2v_r/λ, Hz (positive approaching; v_r positive receding).
    pub fn doppler_hz(&self, range_rate_m_s: f64) -> f64 {
        -2.0 * range_rate_m_s / self.wavelength_m
    }

    /// True beat frequencies (f_up, f_down) = (f_R − f_D, f_R + f_D), Hz, before aliasing.
    pub fn beat_hz(&self, range_m: f64, range_rate_m_s: f64) -> (f64, f64) {
        let fr = self.range_frequency_hz(range_m);
        let fd = self.doppler_hz(range_rate_m_s);
        (fr - fd, fr + fd)
    }

    /// The frequency the ADC sees, f wrapped into [−f_s/2, f_s/2), Hz.
    pub fn alias_hz(&self, f_hz: f64) -> f64 {
        let fs = self.adc_rate_hz;
        (f_hz + 0.5 * fs).rem_euclid(fs) - 0.5 * fs
    }

    /// Range and range rate (R, v_r) of a pair of beat frequencies:
    /// R = c(f_up + f_down)/(4κ), v_r = λ(f_up − f_down)/4.
    pub fn invert(&self, f_up_hz: f64, f_down_hz: f64) -> (f64, f64) {
        let range = SPEED_OF_LIGHT_M_S * (f_up_hz + f_down_hz) / (4.0 * self.slope_hz_per_s);
        let rate = self.wavelength_m * (f_up_hz - f_down_hz) / 4.0;
        (range, rate)
    }

    /// Range a single ramp would report from its beat alone, c·f/(2κ), m: on the up ramp it is
    /// R + v_r·c/(κλ) (range–Doppler coupling: [`Self::coupling_m_per_m_s`]).
    pub fn single_chirp_range_m(&self, f_beat_hz: f64) -> f64 {
        SPEED_OF_LIGHT_M_S * f_beat_hz / (2.0 * self.slope_hz_per_s)
    }

    /// Range–Doppler coupling of one ramp: apparent range shift per unit range rate, c/(κλ), s
    /// (m per m/s; up ramp +, down ramp −).
    pub fn coupling_m_per_m_s(&self) -> f64 {
        SPEED_OF_LIGHT_M_S / (self.slope_hz_per_s * self.wavelength_m)
    }

    /// Range per hertz of beat frequency, c/(2κ), m/Hz.
    pub fn range_per_hz(&self) -> f64 {
        SPEED_OF_LIGHT_M_S / (2.0 * self.slope_hz_per_s)
    }

    /// Range resolution (one bin of f_R), ΔR = c/(2κT_w) = c/(2B_eff), m.
    pub fn range_resolution_m(&self) -> f64 {
        SPEED_OF_LIGHT_M_S / (2.0 * self.effective_bandwidth_hz())
    }

    /// Velocity resolution (one bin of f_D, i.e. each peak moved by one bin), Δv = λ/(2T_w), m/s.
    pub fn velocity_resolution_m_s(&self) -> f64 {
        self.wavelength_m / (2.0 * self.window_s())
    }

    /// Largest unambiguous range of a static target (f_R < f_s/2), R_max = c·f_s/(4κ), m.
    pub fn max_range_m(&self) -> f64 {
        SPEED_OF_LIGHT_M_S * self.adc_rate_hz / (4.0 * self.slope_hz_per_s)
    }

    /// Largest unambiguous |range rate| at zero range (|f_D| < f_s/2), λf_s/4, m/s.
    pub fn max_range_rate_m_s(&self) -> f64 {
        self.wavelength_m * self.adc_rate_hz / 4.0
    }

    /// Whether both beats of (R, v_r) lie inside the band (−f_s/2, f_s/2): then both are measured at
    /// their true frequencies and the pair inverts to the true range and rate.
    pub fn is_unambiguous(&self, range_m: f64, range_rate_m_s: f64) -> bool {
        let (up, down) = self.beat_hz(range_m, range_rate_m_s);
        let half = 0.5 * self.adc_rate_hz;
        up.abs() < half && down.abs() < half
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const C: f64 = 299_792_458.0;

    #[test]
    fn beats_follow_the_closed_form() {
        let cfg = FmcwConfig::default();
        let plan = ChirpPlan::new(&cfg);
        let (r, v) = (80.0, 12.0); // receding
        let kappa = cfg.bandwidth_hz / cfg.chirp_time_s;
        let lambda = cfg.wavelength_nm * 1e-9;
        let f_r = 2.0 * kappa * r / C;
        let (up, down) = plan.beat_hz(r, v);
        // Receding: the echo is red-shifted by 2v/λ, so the up-ramp beat grows.
        assert!((up - (f_r + 2.0 * v / lambda)).abs() < 1e-3);
        assert!((down - (f_r - 2.0 * v / lambda)).abs() < 1e-3);
        let (r2, v2) = plan.invert(up, down);
        assert!((r2 - r).abs() < 1e-9 && (v2 - v).abs() < 1e-9);
        // Coupling: the up ramp alone reads R + v·c/(κλ).
        let apparent = plan.single_chirp_range_m(up);
        assert!((apparent - (r + v * C / (kappa * lambda))).abs() < 1e-6);
    }

    #[test]
    fn resolutions_and_ambiguity_from_the_adc() {
        let cfg = FmcwConfig::default();
        let plan = ChirpPlan::new(&cfg);
        let tw = cfg.samples_per_chirp as f64 / cfg.adc_rate_hz;
        let kappa = cfg.bandwidth_hz / cfg.chirp_time_s;
        let lambda = cfg.wavelength_nm * 1e-9;
        assert!((plan.range_resolution_m() - C / (2.0 * kappa * tw)).abs() < 1e-12);
        assert!((plan.velocity_resolution_m_s() - lambda / (2.0 * tw)).abs() < 1e-12);
        let r_max = C * cfg.adc_rate_hz / (4.0 * kappa);
        assert!((plan.max_range_m() - r_max).abs() < 1e-9);
        assert!(plan.is_unambiguous(0.99 * r_max, 0.0));
        assert!(!plan.is_unambiguous(1.01 * r_max, 0.0));
        // Aliasing wraps by f_s.
        let f = 0.6 * cfg.adc_rate_hz;
        assert!((plan.alias_hz(f) - (f - cfg.adc_rate_hz)).abs() < 1e-6);
        assert!((plan.max_range_rate_m_s() - lambda * cfg.adc_rate_hz / 4.0).abs() < 1e-12);
    }
}
