//! FMCW (frequency-modulated continuous-wave) coherent LiDAR at 1550 nm: the physics core of a
//! second LiDAR detection chain beside the pulsed one (physics.md §2.8, §2.9, §2.10).
//!
//! The scan, beam footprint (sub-rays), environment and space are the pulsed chain's; what changes is
//! the detection of one beam:
//!
//! * [`waveform`]: the triangular chirp (up then down, bandwidth B, chirp time T_c, slope κ = B/T_c),
//!   beat frequencies f_up = f_R − f_D and f_down = f_R + f_D, their inversion to range and range rate,
//!   resolutions and the unambiguous band (physics.md §2.8).
//! * [`coherent`]: heterodyne SNR of one chirp (LO shot noise, receiver noise, LO RIN, background shot
//!   noise) and the coherence roll-off (physics.md §2.9).
//! * [`detector`]: [`FmcwDetector`] (planned once: FFT plan, window, noise scale) and [`FmcwScratch`]
//!   (per worker thread: buffers) synthesize each chirp's complex beat signal, FFT it, threshold,
//!   interpolate and pair the up and down peaks into [`FmcwEcho`]es (physics.md §2.10).
//!
//! # Sign convention
//!
//! `range_rate_m_s` v_r is dR/dt, **positive receding**. f_D = −2v_r/λ is the optical Doppler shift
//! of the echo (positive for an approaching target). So a receding target raises the up-chirp beat
//! (f_up = f_R + 2v_r/λ) and lowers the down-chirp beat (f_down = f_R − 2v_r/λ), and
//! R = c(f_up + f_down)/(4κ), v_r = λ(f_up − f_down)/4.
//!
//! # Use from an engine
//!
//! [`FmcwDetector`] is immutable after [`FmcwDetector::new`] and `Send + Sync` (share it across a
//! rayon pool by reference); each worker owns one [`FmcwScratch`] ([`FmcwDetector::scratch`]) and one
//! random stream per beam. [`FmcwDetector::detect`] allocates nothing once the scratch has grown.

pub mod coherent;
pub mod detector;
pub mod waveform;

pub use coherent::{CoherentReceiver, NoisePsd};
pub use detector::{BeatSpectra, FmcwDetector, FmcwEcho, FmcwReturn, FmcwScratch};
pub use waveform::ChirpPlan;

use serde::{Deserialize, Serialize};

use crate::effects::EffectInfo;
use crate::error::ModelError;

/// `lidar.fmcw_speckle`: fully developed speckle of every sub-ray return, per chirp.
pub const SPECKLE: EffectInfo = EffectInfo {
    name: "lidar.fmcw_speckle",
    default_on: true,
    summary: "fully developed speckle: each sub-ray return's complex beat amplitude is multiplied, per chirp, \
              by a circular complex Gaussian of unit mean power, so its amplitude is Rayleigh and its intensity \
              exponential, p(I) = exp(−I/⟨I⟩)/⟨I⟩; off: deterministic amplitude with phase 4πR/λ",
    source: "physics.md §2.10; Goodman, Speckle Phenomena in Optics, Roberts & Co. 2007, ch. 2–3",
    requires: None,
};

/// `lidar.fmcw_phase_noise`: finite laser coherence (Lorentzian linewidth).
pub const PHASE_NOISE: EffectInfo = EffectInfo {
    name: "lidar.fmcw_phase_noise",
    default_on: true,
    summary: "laser phase noise: Wiener phase φ(t) of diffusion 2πΔν (Lorentzian linewidth Δν); the beat carries \
              φ(t) − φ(t − τ), τ = 2R/c, so the coherent peak keeps the fraction exp(−2τ/τ_c), τ_c = 1/(πΔν), \
              and the rest spreads into a pedestal of width ≈ 2Δν (SNR roll-off and peak broadening with \
              range); off: ideal coherent laser",
    source: "physics.md §2.9; Salvadé & Dändliker, JOSA A 17(5):927, 2000; Richter et al., IEEE JQE 22(11):2070, 1986",
    requires: None,
};

/// `lidar.fmcw_chirp_nonlinearity`: residual non-linearity of the optical chirp.
pub const CHIRP_NONLINEARITY: EffectInfo = EffectInfo {
    name: "lidar.fmcw_chirp_nonlinearity",
    default_on: true,
    summary: "chirp non-linearity: instantaneous frequency f(t) = f₀ + κt + δ·4(t/T_c)(1 − t/T_c) (quadratic \
              bow, peak deviation δ); the beat frequency sweeps by 8δτT_w/T_c² over the sampling window T_w, \
              smearing the peak in proportion to the range; off: ideal linear chirp",
    source: "physics.md §2.10; Zheng, Appl. Opt. 43(21):4189, 2004; Ahn, Lee & Kim, Appl. Opt. 44(35):7630, 2005",
    requires: None,
};

/// `lidar.fmcw_ego_doppler`: the Doppler of the sensor's own motion.
pub const EGO_DOPPLER: EffectInfo = EffectInfo {
    name: "lidar.fmcw_ego_doppler",
    default_on: true,
    summary: "Doppler of the sensor's own motion: every point's range rate is d̂·(v_hit − v_s), so static \
              points of a moving sensor carry −d̂·v_s (the signal ego-motion estimation uses) and the beat \
              frequencies shift by 2ṙ/λ; off: ṙ = d̂·v_hit, as if the sensor stood still",
    source: "physics.md §2.8 (f_D = 2ṙ/λ) and §6.1",
    requires: None,
};

/// Effects declared by the FMCW chain.
pub const EFFECTS: &[EffectInfo] = &[SPECKLE, PHASE_NOISE, CHIRP_NONLINEARITY, EGO_DOPPLER];

/// The effects of the FMCW chain (the same as [`EFFECTS`]).
pub fn effects() -> Vec<EffectInfo> {
    EFFECTS.to_vec()
}

/// FMCW chain parameters (`"lidar": {"fmcw": {...}}`). The default is a 1550 nm automotive FMCW preset;
/// public data sheets (Aeva Aeries II, Aurora FirstLight) give ranges and point rates but not the
/// chirp design, so the values marked *guessed* are typical of the published FMCW LiDAR literature
/// (physics.md §2.8), not a particular sensor's.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FmcwConfig {
    /// Laser wavelength λ, nm (1550: telecom C band, the band of every announced automotive FMCW
    /// LiDAR: Aeva, Aurora/Blackmore, Scantinel).
    pub wavelength_nm: f64,
    /// Optical frequency excursion B of one chirp ramp, Hz (guessed 1 GHz).
    pub bandwidth_hz: f64,
    /// Duration T_c of one ramp (up, then the same down), s (guessed 10 µs: 2 ramps = 20 µs a beam).
    pub chirp_time_s: f64,
    /// Complex (I/Q) ADC sample rate f_s, Hz; the beat band is [−f_s/2, f_s/2) (guessed 400 MHz).
    pub adc_rate_hz: f64,
    /// Samples N per ramp (power of two), taken at the end of the ramp: the window
    /// T_w = N/f_s ≤ T_c sets the resolutions (1024 → 2.56 µs at 400 MHz; guessed: real sensors
    /// record longer ramps, this keeps the per-beam FFT cheap).
    pub samples_per_chirp: usize,
    /// Transmitted optical power (CW, per beam), W, for the engine's LiDAR equation (guessed 100 mW).
    pub tx_power_w: f64,
    /// Photodiode quantum efficiency η (InGaAs at 1550 nm ≈ 0.8; guessed); responsivity ηqλ/(hc).
    pub quantum_efficiency: f64,
    /// Heterodyne (mixing) efficiency η_het of the LO and the diffuse return (≤ 0.4 for an optimally
    /// truncated Gaussian LO on a speckle target; Rye & Frehlich, Appl. Opt. 31(16):2891, 1992).
    pub heterodyne_efficiency: f64,
    /// Local-oscillator power on the balanced detector, W (guessed 1 mW: LO shot noise dominates).
    pub lo_power_w: f64,
    /// Input-referred current noise density of the balanced receiver (TIA, thermal), A/√Hz
    /// (guessed 5 pA/√Hz, typical of InGaAs balanced receivers).
    pub receiver_noise_a_per_sqrt_hz: f64,
    /// Relative intensity noise of the LO, dB/Hz (guessed −150 dB/Hz).
    pub lo_rin_db_per_hz: f64,
    /// Common-mode rejection of the balanced detector applied to the LO RIN, dB (guessed 25 dB).
    pub balanced_cmrr_db: f64,
    /// Lorentzian laser linewidth Δν (FWHM), Hz (guessed 100 kHz: coherence length c/(πΔν) ≈ 950 m).
    pub linewidth_hz: f64,
    /// Peak deviation δ of the chirp's instantaneous frequency from linear (quadratic bow), Hz
    /// (guessed 100 kHz = 10⁻⁴ B, a linearised laser).
    pub nonlinearity_hz: f64,
    /// False-alarm probability per FFT bin and chirp, sets the threshold −ln(P_FA)·(noise per bin).
    pub false_alarm_probability: f64,
    /// Most echoes per beam (strongest peaks per chirp kept, 1–16).
    pub max_returns_per_beam: usize,
    /// Largest |range rate| accepted when pairing up and down peaks, m/s (guessed 100 m/s).
    pub max_range_rate_m_s: f64,
    /// How each ramp's windowed spectrum is produced: `"spectral"` (default: synthesized in the
    /// frequency domain on a few bins around each beat tone, false alarms elsewhere in closed
    /// form; physics.md §2.10) or `"time"` (the reference: the beat signal sample by sample, then
    /// the FFT; slower).
    pub synthesis: Synthesis,
    /// Whether the up and down ramps are measured one after the other (`"sequential"`, default:
    /// one laser, triangular sweep, 2T_c per beam) or at the same time (`"simultaneous"`: two
    /// lasers or two modulation sidebands sweeping up and down together, T_c per beam, no
    /// inter-chirp motion; physics.md §2.8).
    pub chirp_mode: ChirpMode,
    /// The beat spectra of selected beams in `PerceptionData.lidar.beat_spectrum` (debugging;
    /// absent, the default: none, no cost).
    pub emit_beat_spectra: Option<BeatSpectraRequest>,
}

/// [`FmcwConfig::chirp_mode`]: when the down ramp is measured relative to the up ramp.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ChirpMode {
    /// Up ramp, then down ramp (one laser): the down ramp's window opens T_c after the up ramp's,
    /// so a target at range rate v_r has moved by v_r·T_c between them.
    #[default]
    Sequential,
    /// Up and down ramps at the same time (two lasers / sidebands, e.g. Aeva's): both windows see
    /// the same range; the beam's dwell is T_c instead of 2T_c.
    Simultaneous,
}

/// [`FmcwConfig::emit_beat_spectra`]: which beams' beat spectra go into
/// `PerceptionData.lidar.beat_spectrum`. A beam is emitted when its channel is in `channels` (empty:
/// any) and its azimuth in `azimuth_rad` (absent: any); the first `max_beams` such beams of the
/// cycle's scan plan, in firing order.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BeatSpectraRequest {
    /// Laser channels (the point cloud's `channel`); empty: every channel.
    pub channels: Vec<u32>,
    /// Azimuth window [from, to], rad, sensor frame, counter-clockwise from `from` to `to`
    /// (wraps through ±π); absent: every azimuth.
    pub azimuth_rad: Option<[f64; 2]>,
    /// Most beams emitted per cycle, 1 … [`MAX_EMITTED_BEAMS`] (default 8).
    pub max_beams: usize,
}

/// Upper bound of [`BeatSpectraRequest::max_beams`] (each beam is 2N floats in the output).
pub const MAX_EMITTED_BEAMS: usize = 4096;

impl Default for BeatSpectraRequest {
    fn default() -> BeatSpectraRequest {
        BeatSpectraRequest {
            channels: Vec::new(),
            azimuth_rad: None,
            max_beams: 8,
        }
    }
}

impl BeatSpectraRequest {
    /// Whether a firing of `channel` at `azimuth_rad` is selected (before the `max_beams` cap).
    pub fn selects(&self, channel: u32, azimuth_rad: f64) -> bool {
        if !self.channels.is_empty() && !self.channels.contains(&channel) {
            return false;
        }
        match self.azimuth_rad {
            Some([from, to]) => {
                let tau = std::f64::consts::TAU;
                (azimuth_rad - from).rem_euclid(tau) <= (to - from).rem_euclid(tau)
            }
            None => true,
        }
    }
}

/// [`FmcwConfig::synthesis`]: how the beat spectrum of a ramp is produced.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Synthesis {
    /// Frequency-domain synthesis around the tones (statistically equivalent, fast).
    #[default]
    Spectral,
    /// Time-domain synthesis and FFT (the reference).
    Time,
}

impl Default for FmcwConfig {
    fn default() -> FmcwConfig {
        FmcwConfig {
            wavelength_nm: 1550.0,
            bandwidth_hz: 1.0e9,
            chirp_time_s: 10.0e-6,
            adc_rate_hz: 400.0e6,
            samples_per_chirp: 1024,
            tx_power_w: 0.1,
            quantum_efficiency: 0.8,
            heterodyne_efficiency: 0.4,
            lo_power_w: 1.0e-3,
            receiver_noise_a_per_sqrt_hz: 5.0e-12,
            lo_rin_db_per_hz: -150.0,
            balanced_cmrr_db: 25.0,
            linewidth_hz: 100.0e3,
            nonlinearity_hz: 100.0e3,
            false_alarm_probability: 1.0e-6,
            max_returns_per_beam: 4,
            max_range_rate_m_s: 100.0,
            synthesis: Synthesis::Spectral,
            chirp_mode: ChirpMode::Sequential,
            emit_beat_spectra: None,
        }
    }
}

/// Upper bound of [`FmcwConfig::max_returns_per_beam`] (the pairing works on fixed-size tables).
pub const MAX_RETURNS_PER_BEAM: usize = 16;

impl FmcwConfig {
    /// Wavelength λ, m.
    pub fn wavelength_m(&self) -> f64 {
        self.wavelength_nm * 1e-9
    }

    /// Checks every key; the error names the key (`lidar.fmcw.<key>`) and what was expected.
    pub fn validate(&self) -> Result<(), ModelError> {
        fn positive(key: &str, v: f64) -> Result<(), ModelError> {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(ModelError::Config(format!(
                    "`lidar.fmcw.{key}` must be finite and > 0 (got {v})"
                )))
            }
        }
        fn non_negative(key: &str, v: f64) -> Result<(), ModelError> {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(ModelError::Config(format!(
                    "`lidar.fmcw.{key}` must be finite and ≥ 0 (got {v})"
                )))
            }
        }
        fn fraction(key: &str, v: f64) -> Result<(), ModelError> {
            if v.is_finite() && v > 0.0 && v <= 1.0 {
                Ok(())
            } else {
                Err(ModelError::Config(format!(
                    "`lidar.fmcw.{key}` must be in (0, 1] (got {v})"
                )))
            }
        }
        positive("wavelength_nm", self.wavelength_nm)?;
        positive("bandwidth_hz", self.bandwidth_hz)?;
        positive("chirp_time_s", self.chirp_time_s)?;
        positive("adc_rate_hz", self.adc_rate_hz)?;
        positive("tx_power_w", self.tx_power_w)?;
        fraction("quantum_efficiency", self.quantum_efficiency)?;
        fraction("heterodyne_efficiency", self.heterodyne_efficiency)?;
        positive("lo_power_w", self.lo_power_w)?;
        non_negative(
            "receiver_noise_a_per_sqrt_hz",
            self.receiver_noise_a_per_sqrt_hz,
        )?;
        if !self.lo_rin_db_per_hz.is_finite() {
            return Err(ModelError::Config(format!(
                "`lidar.fmcw.lo_rin_db_per_hz` must be finite (got {})",
                self.lo_rin_db_per_hz
            )));
        }
        non_negative("balanced_cmrr_db", self.balanced_cmrr_db)?;
        non_negative("linewidth_hz", self.linewidth_hz)?;
        non_negative("nonlinearity_hz", self.nonlinearity_hz)?;
        positive("max_range_rate_m_s", self.max_range_rate_m_s)?;
        let n = self.samples_per_chirp;
        if !(n.is_power_of_two() && (16..=1 << 16).contains(&n)) {
            return Err(ModelError::Config(format!(
                "`lidar.fmcw.samples_per_chirp` must be a power of two in 16 … 65536 (got {n})"
            )));
        }
        let window_s = n as f64 / self.adc_rate_hz;
        if window_s > self.chirp_time_s * (1.0 + 1e-9) {
            return Err(ModelError::Config(format!(
                "`lidar.fmcw.samples_per_chirp` / `adc_rate_hz` = {window_s:e} s exceeds `chirp_time_s` = {:e} s",
                self.chirp_time_s
            )));
        }
        let p = self.false_alarm_probability;
        if !(p.is_finite() && p > 0.0 && p < 1.0) {
            return Err(ModelError::Config(format!(
                "`lidar.fmcw.false_alarm_probability` must be in (0, 1) (got {p})"
            )));
        }
        let m = self.max_returns_per_beam;
        if !(1..=MAX_RETURNS_PER_BEAM).contains(&m) {
            return Err(ModelError::Config(format!(
                "`lidar.fmcw.max_returns_per_beam` must be in 1 … {MAX_RETURNS_PER_BEAM} (got {m})"
            )));
        }
        if let Some(req) = &self.emit_beat_spectra {
            let b = req.max_beams;
            if !(1..=MAX_EMITTED_BEAMS).contains(&b) {
                return Err(ModelError::Config(format!(
                    "`lidar.fmcw.emit_beat_spectra.max_beams` must be in 1 … {MAX_EMITTED_BEAMS} (got {b})"
                )));
            }
            if let Some(w) = req.azimuth_rad
                && !w.iter().all(|a| a.is_finite())
            {
                return Err(ModelError::Config(format!(
                    "`lidar.fmcw.emit_beat_spectra.azimuth_rad` must be two finite angles (got {w:?})"
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
    fn default_is_valid_and_round_trips() {
        let c = FmcwConfig::default();
        c.validate().unwrap();
        let json = serde_json::to_string(&c).unwrap();
        let back: FmcwConfig = serde_json::from_str(&json).unwrap();
        assert_eq!(back, c);
        let partial: FmcwConfig = serde_json::from_str(r#"{"linewidth_hz": 1e4}"#).unwrap();
        assert_eq!(partial.linewidth_hz, 1e4);
        assert!(serde_json::from_str::<FmcwConfig>(r#"{"linewidth": 1e4}"#).is_err());
        let time: FmcwConfig = serde_json::from_str(r#"{"synthesis": "time"}"#).unwrap();
        assert_eq!(time.synthesis, Synthesis::Time);
        assert_eq!(FmcwConfig::default().synthesis, Synthesis::Spectral);
        let bad = serde_json::from_str::<FmcwConfig>(r#"{"synthesis": "fast"}"#);
        assert!(bad.unwrap_err().to_string().contains("spectral"));
        let sim: FmcwConfig = serde_json::from_str(r#"{"chirp_mode": "simultaneous"}"#).unwrap();
        assert_eq!(sim.chirp_mode, ChirpMode::Simultaneous);
        let req: FmcwConfig =
            serde_json::from_str(r#"{"emit_beat_spectra": {"channels": [3, 4]}}"#).unwrap();
        let req = req.emit_beat_spectra.unwrap();
        assert_eq!((req.channels.as_slice(), req.max_beams), (&[3, 4][..], 8));
        assert!(req.selects(3, 1.0) && !req.selects(5, 1.0));
        let window = BeatSpectraRequest {
            azimuth_rad: Some([3.0, -3.0]),
            ..Default::default()
        };
        // Counter-clockwise from 3 rad through π to −3 rad.
        assert!(window.selects(0, 3.1) && window.selects(0, -3.1) && !window.selects(0, 0.0));
    }

    #[test]
    fn validate_names_the_key() {
        let bad = |f: &dyn Fn(&mut FmcwConfig), key: &str| {
            let mut c = FmcwConfig::default();
            f(&mut c);
            let msg = c.validate().unwrap_err().to_string();
            assert!(msg.contains(key), "{msg} should name {key}");
        };
        bad(&|c| c.samples_per_chirp = 1000, "samples_per_chirp");
        bad(&|c| c.samples_per_chirp = 8192, "chirp_time_s");
        bad(
            &|c| c.false_alarm_probability = 0.0,
            "false_alarm_probability",
        );
        bad(&|c| c.bandwidth_hz = -1.0, "bandwidth_hz");
        bad(&|c| c.quantum_efficiency = 1.5, "quantum_efficiency");
        bad(&|c| c.max_returns_per_beam = 0, "max_returns_per_beam");
        bad(&|c| c.linewidth_hz = f64::NAN, "linewidth_hz");
        bad(
            &|c| {
                c.emit_beat_spectra = Some(BeatSpectraRequest {
                    max_beams: 0,
                    ..Default::default()
                })
            },
            "emit_beat_spectra.max_beams",
        );
        bad(
            &|c| {
                c.emit_beat_spectra = Some(BeatSpectraRequest {
                    azimuth_rad: Some([0.0, f64::INFINITY]),
                    ..Default::default()
                })
            },
            "emit_beat_spectra.azimuth_rad",
        );
    }

    #[test]
    fn effects_are_declared_once() {
        let names: Vec<_> = effects().iter().map(|e| e.name).collect();
        assert_eq!(
            names,
            [
                "lidar.fmcw_speckle",
                "lidar.fmcw_phase_noise",
                "lidar.fmcw_chirp_nonlinearity",
                "lidar.fmcw_ego_doppler"
            ]
        );
    }
}
