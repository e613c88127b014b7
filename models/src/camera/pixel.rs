//! EMVA 1288 pixel model: photo-electrons → digital numbers with shot noise, dark current, read
//! noise, DSNU, PRNU, full well, conversion gain, ADC; LED flicker; auto exposure.
//!
//! # Signal chain of one pixel (EMVA 1288 Release 4.0 linear model, physics.md §3.1)
//!
//! For pixel `i` of CFA channel `c`, capture with exposure time `t`, photodiode sensitivity `s`
//! (1 = large PD), conversion gain `K` [DN/e⁻], analog gain `g`:
//!
//! 1. mean photo-electrons `μ_e = r_c,i · t · s · (1 + p_i)` with `r` the generation rate [e⁻/s]
//!    from the lens and `p_i` the PRNU gain map (`camera.prnu`), plus the LED-flicker pixels
//!    `(v/d) · f_on(t₀,row, t) · t · s · (1 + p_i)` with `v` the time-averaged rate, `d` the duty and
//!    `f_on` the on fraction of the row's window ([`super::PwmSource::on_fraction`]);
//! 2. mean dark electrons `μ_d = I_d(T) · t`, `I_d(T) = I_ref · 2^((T − T_ref)/T_2)`
//!    (`camera.dark_current`; doubling every T_2 ≈ 6–8 K);
//! 3. electrons `n ~ Poisson(μ_e + μ_d)` (`camera.shot_noise`; off: `n = μ_e + μ_d`), a normal
//!    approximation above 20 e⁻;
//! 4. `n ← min(n, full well)` (`camera.saturation`);
//! 5. `+ o_i` the DSNU offset map [e⁻] (`camera.dsnu`), `+ σ_r · N(0,1)` (`camera.read_noise`);
//!    where steps 3–5 are two independent normals (μ ≥ 20 e⁻, the full well beyond `μ + 8√μ`) and no
//!    other capture reads the same charge ([`ExposureSpec::shared_charge`]), they are drawn as one:
//!    `n = μ + √(μ + σ_r²)·z + o_i` (the sum of independent normals; same distribution, one draw);
//! 6. `y = round(K·g·n + black level)`, clipped to `[0, 2^bits − 1]` (the top clip is part of
//!    `camera.saturation`); rounding adds the quantisation noise σ_q² = 1/12 DN².
//!
//! The fixed-pattern maps (DSNU, PRNU) are drawn once from the model seed. The temporal noise of
//! each row comes from its own generator seeded from the capture's noise seed and the row index,
//! so the result does not depend on the thread schedule. Photon shot noise is drawn from a
//! generator keyed by the noise seed *without its top byte* (the capture index in the sensor step)
//! and the photodiode's integration window, so two reads of the same charge (IMX490 large PD at
//! high and low conversion gain) share their shot noise, as in the real pixel.

use crate::rng::splitmix64;
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};
use rand_distr::StandardNormal;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::{Cfa, ChannelImage, Flicker, GREEN, RawImage, ShutterTiming};
use crate::effects::{EffectInfo, Effects};
use crate::error::ModelError;

/// Photon shot noise.
pub const SHOT_NOISE: EffectInfo = EffectInfo {
    name: "camera.shot_noise",
    default_on: true,
    summary: "photon shot noise: n ~ Poisson(μ_e + μ_d) electrons (σ_e² = μ_e), normal approximation above 20 e⁻",
    source: "EMVA 1288 Release 4.0 (2021) linear model, σ_e² = μ_e (physics.md §3.1)",
    requires: None,
};

/// Read (floor) noise of the readout chain.
pub const READ_NOISE: EffectInfo = EffectInfo {
    name: "camera.read_noise",
    default_on: true,
    summary: "read noise: + σ_r·N(0,1) electrons per read (σ_d of EMVA 1288; σ_y² = K²(σ_d² + σ_e²) + 1/12)",
    source: "EMVA 1288 Release 4.0 (2021) (physics.md §3.1); IMX490 HCG 0.83 e⁻ / LCG 3.05 e⁻ (ISETCam sensorCreateIMX490.m, §3.3)",
    requires: None,
};

/// Dark current with its temperature dependence and shot noise.
pub const DARK_CURRENT: EffectInfo = EffectInfo {
    name: "camera.dark_current",
    default_on: true,
    summary: "dark signal: μ_d = I_ref·2^((T − T_ref)/T_2)·t_exp electrons, Poisson distributed with the photo-electrons",
    source: "EMVA 1288 Release 4.0 (2021) μ_d = μ_d,0 + μ_I·t_exp, doubling every ≈ 6–8 K (physics.md §3.1); IMX490 25.6 e⁻/s (ISETCam)",
    requires: None,
};

/// Dark-signal non-uniformity: a fixed offset map.
pub const DSNU: EffectInfo = EffectInfo {
    name: "camera.dsnu",
    default_on: true,
    summary: "DSNU: fixed per-pixel offset o_i ~ N(0, DSNU²) electrons, drawn once from the seed",
    source: "EMVA 1288 Release 4.0 (2021) DSNU = s_y,dark/K (physics.md §3.1)",
    requires: None,
};

/// Photo-response non-uniformity: a fixed gain map.
pub const PRNU: EffectInfo = EffectInfo {
    name: "camera.prnu",
    default_on: true,
    summary: "PRNU: fixed per-pixel gain 1 + p_i, p_i ~ N(0, PRNU²), on the photo-electrons, drawn once from the seed",
    source: "EMVA 1288 Release 4.0 (2021) PRNU = √(s_y,50² − s_y,dark²)/(μ_y,50 − μ_y,dark) (physics.md §3.1)",
    requires: None,
};

/// Full-well and ADC saturation.
pub const SATURATION: EffectInfo = EffectInfo {
    name: "camera.saturation",
    default_on: true,
    summary: "saturation: n ← min(n, full well), y ← min(y, 2^bits − 1) (off: linear beyond both)",
    source: "EMVA 1288 Release 4.0 (2021) saturation capacity (physics.md §3.1); IMX490 full wells 22 000 / 7 900 e⁻ (ISETCam, §3.3)",
    requires: None,
};

/// Pixel effects (`camera.shot_noise`, `camera.read_noise`, `camera.dark_current`, `camera.dsnu`,
/// `camera.prnu`, `camera.saturation`; `camera.led_flicker` is declared by the renderer, which
/// splits the LED pixels out: this model integrates whatever [`Flicker`] samples it is given).
pub const EFFECTS: &[EffectInfo] = &[SHOT_NOISE, READ_NOISE, DARK_CURRENT, DSNU, PRNU, SATURATION];

/// Poisson means below this are drawn exactly; above, `μ + √μ·N(0,1)`.
const POISSON_EXACT_BELOW: f64 = 20.0;

/// Pixel parameters (`"pixel"` key of the camera config). `Default` is the ISX019-class preset.
///
/// The conversion gains are system gains in DN/e⁻ at unity analog gain. From a data sheet's
/// µV/e⁻: `K = CG[V/e⁻] · 2^bits / V_adc,full-scale`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PixelConfig {
    /// Colour-filter array layout.
    pub cfa: Cfa,
    /// Full-well (saturation) capacity of the (large) photodiode, e⁻.
    pub full_well_e: f64,
    /// System gain K of the main (high-conversion-gain) readout at unity analog gain, DN/e⁻.
    pub conversion_gain_dn_per_e: f64,
    /// Read noise of the main readout, e⁻ rms.
    pub read_noise_e: f64,
    /// Dark current of the (large) photodiode at `dark_reference_temperature_c`, e⁻/s.
    pub dark_current_e_per_s: f64,
    /// Reference die temperature of the dark currents, °C.
    pub dark_reference_temperature_c: f64,
    /// Temperature step that doubles the dark current, K (EMVA 1288: ≈ 6–8 K).
    pub dark_doubling_k: f64,
    /// Dark-signal non-uniformity, e⁻ rms (spatial).
    pub dsnu_e: f64,
    /// Photo-response non-uniformity, % rms (spatial).
    pub prnu_percent: f64,
    /// Black level (offset before the ADC), DN.
    pub black_level_dn: f64,
    /// ADC resolution, bits (8–16).
    pub adc_bits: u32,
    /// Analog gain before the ADC (linear, ≥ 1).
    pub analog_gain: f64,
    /// Rolling-shutter line time, s (absent: the readout of all rows takes `readout_fraction` of
    /// the frame cycle).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub row_time_s: Option<f64>,
    /// Fraction of the frame cycle the readout of all rows takes when `row_time_s` is absent
    /// (guessed: 0.9, i.e. 10 % vertical blanking).
    pub readout_fraction: f64,
    /// Shortest exposure time auto exposure may choose, s.
    pub min_exposure_s: f64,
    /// Longest exposure time auto exposure may choose, s.
    pub max_exposure_s: f64,
    /// Auto-exposure target: log-average green signal as a fraction of the saturation signal
    /// (default 10/78 ≈ 0.128, the mid-grey/saturation ratio of ISO 12232 saturation-based speed).
    pub ae_target_fraction: f64,
    /// Split pixel: system gain of the low-conversion-gain read of the large PD, DN/e⁻.
    pub lcg_conversion_gain_dn_per_e: f64,
    /// Split pixel: read noise of the low-conversion-gain read, e⁻ rms.
    pub lcg_read_noise_e: f64,
    /// Split pixel: sensitivity of the small PD relative to the large one.
    pub small_pd_relative_sensitivity: f64,
    /// Split pixel: full well of the small PD, e⁻.
    pub small_pd_full_well_e: f64,
    /// Split pixel: system gain of the small-PD read, DN/e⁻.
    pub small_pd_conversion_gain_dn_per_e: f64,
    /// Split pixel: read noise of the small-PD read, e⁻ rms.
    pub small_pd_read_noise_e: f64,
    /// Split pixel: dark current of the small PD at the reference temperature, e⁻/s.
    pub small_pd_dark_current_e_per_s: f64,
}

impl Default for PixelConfig {
    fn default() -> Self {
        PixelConfig::isx019()
    }
}

fn cfg_err(key: &str, what: &str, got: impl std::fmt::Display) -> ModelError {
    ModelError::Config(format!("`camera.pixel.{key}` must be {what}, got {got}"))
}

impl PixelConfig {
    /// ISX019-class (DOL HDR, 3 exposures, 12-bit ADC). Sony publishes no EMVA data for it; all
    /// values are **guessed** typical automotive BSI values: full well 10 000 e⁻, K = 0.403 DN/e⁻
    /// (full well = ADC range above a 64 DN black level), read noise 2.5 e⁻, dark current
    /// 25.6 e⁻/s at 25 °C (the IMX490 figure of ISETCam), doubling 6.5 K, DSNU 1 e⁻, PRNU 1 %,
    /// exposure 10 µs … 33 ms (one 30 fps frame). The split-pixel fields carry the IMX490 values.
    pub fn isx019() -> PixelConfig {
        PixelConfig {
            cfa: Cfa::Rggb,
            full_well_e: 10_000.0,
            conversion_gain_dn_per_e: 0.403,
            read_noise_e: 2.5,
            dark_current_e_per_s: 25.6,
            dark_reference_temperature_c: 25.0,
            dark_doubling_k: 6.5,
            dsnu_e: 1.0,
            prnu_percent: 1.0,
            black_level_dn: 64.0,
            adc_bits: 12,
            analog_gain: 1.0,
            row_time_s: None,
            readout_fraction: 0.9,
            min_exposure_s: 10e-6,
            max_exposure_s: 0.033,
            ae_target_fraction: 10.0 / 78.0,
            lcg_conversion_gain_dn_per_e: 0.1832,
            lcg_read_noise_e: 3.05,
            small_pd_relative_sensitivity: 0.1,
            small_pd_full_well_e: 7_900.0,
            small_pd_conversion_gain_dn_per_e: 0.1832,
            small_pd_read_noise_e: 2.96,
            small_pd_dark_current_e_per_s: 4.2,
        }
    }

    /// IMX490-class split pixel (ISETCam `sensorCreateIMX490.m` after Solhusvik et al., IISW 2019,
    /// physics.md §3.3): large PD full well 22 000 e⁻, HCG 200 µV/e⁻ (0.83 e⁻), LCG 49 µV/e⁻
    /// (3.05 e⁻), dark 25.6 e⁻/s; small PD relative QE 0.1, full well 7 900 e⁻, 2.96 e⁻ (LCG
    /// read), dark 4.2 e⁻/s. ADC full scale (**guessed**) such that the LCG read of a full large
    /// PD fills the 12-bit range above the 64 DN black level: K_LCG = 4031/22 000 = 0.1832 DN/e⁻,
    /// K_HCG = K_LCG·200/49 = 0.748 DN/e⁻; the small PD is read at LCG. Minimum exposure
    /// 86.128 µs (LUCID tech brief); maximum 33 ms (guessed, one 30 fps frame; the sensor allows 5 s).
    /// DSNU, PRNU, doubling temperature and reference temperature are guessed as for the ISX019.
    pub fn imx490() -> PixelConfig {
        PixelConfig {
            full_well_e: 22_000.0,
            conversion_gain_dn_per_e: 0.1832 * 200.0 / 49.0,
            read_noise_e: 0.83,
            min_exposure_s: 86.128e-6,
            ..PixelConfig::isx019()
        }
    }

    /// The defaults of a sensor preset.
    pub fn for_preset(preset: super::CameraPreset) -> PixelConfig {
        match preset {
            super::CameraPreset::Isx019 => PixelConfig::isx019(),
            super::CameraPreset::Imx490 => PixelConfig::imx490(),
        }
    }

    pub fn validate(&self) -> Result<(), ModelError> {
        let positive = [
            ("full_well_e", self.full_well_e),
            ("conversion_gain_dn_per_e", self.conversion_gain_dn_per_e),
            ("dark_doubling_k", self.dark_doubling_k),
            ("min_exposure_s", self.min_exposure_s),
            ("max_exposure_s", self.max_exposure_s),
            (
                "lcg_conversion_gain_dn_per_e",
                self.lcg_conversion_gain_dn_per_e,
            ),
            (
                "small_pd_relative_sensitivity",
                self.small_pd_relative_sensitivity,
            ),
            ("small_pd_full_well_e", self.small_pd_full_well_e),
            (
                "small_pd_conversion_gain_dn_per_e",
                self.small_pd_conversion_gain_dn_per_e,
            ),
        ];
        for (key, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(cfg_err(key, "finite and > 0", v));
            }
        }
        let non_negative = [
            ("read_noise_e", self.read_noise_e),
            ("dark_current_e_per_s", self.dark_current_e_per_s),
            ("dsnu_e", self.dsnu_e),
            ("prnu_percent", self.prnu_percent),
            ("black_level_dn", self.black_level_dn),
            ("lcg_read_noise_e", self.lcg_read_noise_e),
            ("small_pd_read_noise_e", self.small_pd_read_noise_e),
            (
                "small_pd_dark_current_e_per_s",
                self.small_pd_dark_current_e_per_s,
            ),
        ];
        for (key, v) in non_negative {
            if !(v.is_finite() && v >= 0.0) {
                return Err(cfg_err(key, "finite and ≥ 0", v));
            }
        }
        if !self.dark_reference_temperature_c.is_finite() {
            return Err(cfg_err(
                "dark_reference_temperature_c",
                "finite",
                self.dark_reference_temperature_c,
            ));
        }
        if self.prnu_percent >= 30.0 {
            return Err(cfg_err("prnu_percent", "< 30 %", self.prnu_percent));
        }
        if !(8..=16).contains(&self.adc_bits) {
            return Err(cfg_err("adc_bits", "in 8..=16", self.adc_bits));
        }
        let max_dn = ((1u32 << self.adc_bits) - 1) as f64;
        if self.black_level_dn >= max_dn {
            return Err(cfg_err(
                "black_level_dn",
                &format!("below the ADC maximum {max_dn} DN"),
                self.black_level_dn,
            ));
        }
        if !(self.analog_gain.is_finite() && (1.0..=1000.0).contains(&self.analog_gain)) {
            return Err(cfg_err("analog_gain", "in [1, 1000]", self.analog_gain));
        }
        if let Some(t) = self.row_time_s
            && !(t.is_finite() && t > 0.0 && t < 0.01)
        {
            return Err(cfg_err("row_time_s", "in (0, 0.01) s", t));
        }
        if !(self.readout_fraction.is_finite()
            && self.readout_fraction > 0.0
            && self.readout_fraction <= 1.0)
        {
            return Err(cfg_err(
                "readout_fraction",
                "in (0, 1]",
                self.readout_fraction,
            ));
        }
        if self.max_exposure_s > 10.0 || self.min_exposure_s > self.max_exposure_s {
            return Err(cfg_err(
                "max_exposure_s",
                "≥ min_exposure_s and ≤ 10 s",
                self.max_exposure_s,
            ));
        }
        if !(self.ae_target_fraction.is_finite()
            && self.ae_target_fraction > 0.0
            && self.ae_target_fraction <= 1.0)
        {
            return Err(cfg_err(
                "ae_target_fraction",
                "in (0, 1]",
                self.ae_target_fraction,
            ));
        }
        if self.small_pd_relative_sensitivity > 1.0 {
            return Err(cfg_err(
                "small_pd_relative_sensitivity",
                "≤ 1",
                self.small_pd_relative_sensitivity,
            ));
        }
        Ok(())
    }

    /// Rolling-shutter line time, s, for an image of `height` rows read within `frame_cycle_s`
    /// (the configured line time if any, else `readout_fraction · frame_cycle_s / height`).
    pub fn row_time_s(&self, height: usize, frame_cycle_s: f64) -> f64 {
        match self.row_time_s {
            Some(t) => t,
            None => {
                let cycle = if frame_cycle_s.is_finite() && frame_cycle_s > 0.0 {
                    frame_cycle_s
                } else {
                    0.0
                };
                self.readout_fraction * cycle / height.max(1) as f64
            }
        }
    }

    /// Dark current of the large photodiode at `temperature_c`, e⁻/s:
    /// `I_ref · 2^((T − T_ref)/T_2)`.
    pub fn dark_current_at(&self, temperature_c: f64) -> f64 {
        self.dark_current_e_per_s * self.dark_factor(temperature_c)
    }

    fn dark_factor(&self, temperature_c: f64) -> f64 {
        ((temperature_c - self.dark_reference_temperature_c) / self.dark_doubling_k)
            .clamp(-200.0, 200.0)
            .exp2()
    }
}

/// One capture of the HDR sequence.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExposureSpec {
    /// Exposure (integration) time, s.
    pub time_s: f64,
    /// Analog gain (linear) before the ADC.
    pub analog_gain: f64,
    /// Relative sensitivity of the photodiode used (1 = large PD; IMX490 small PD ≈ 0.1).
    pub relative_sensitivity: f64,
    /// Conversion gain of the readout, DN/e⁻ at unity analog gain.
    pub conversion_gain_dn_per_e: f64,
    /// Full-well capacity of the photodiode used, e⁻.
    pub full_well_e: f64,
    /// Read noise of this readout, e⁻ rms.
    pub read_noise_e: f64,
    /// Start of this capture relative to the row's start of the first capture, s.
    pub start_offset_s: f64,
    /// Index in the sequence (0 = the most sensitive).
    pub index: u32,
    /// Another capture reads the same charge (the split pixel's high- and low-gain reads of the
    /// large photodiode): the shot noise must come from the stream they share, apart from the read
    /// noise. Otherwise, above 20 e⁻ (the normal approximation) and away from the full well, the two
    /// independent normals are drawn as one (`μ + √(μ + σ_r²)·z`, the same distribution).
    pub shared_charge: bool,
}

/// Row generator for stream `stream` of seed `seed`.
fn row_rng(seed: u64, stream: u64, row: usize) -> SmallRng {
    SmallRng::seed_from_u64(splitmix64(
        seed ^ splitmix64(stream ^ splitmix64(row as u64)),
    ))
}

/// Inversion tables of [`poisson`]: `T[i][k] = k! / (k + i + 1)!`, the factors that take the
/// Poisson term `p_k = e^{−μ} μ^k / k!` to `p_{k+i+1} = p_k · μ^{i+1} · T[i][k]` (k < 64).
const POISSON_STEP: [[f64; 64]; 4] = {
    let mut t = [[0.0; 64]; 4];
    let mut k = 0;
    while k < 64 {
        let mut i = 0;
        let mut prod = 1.0;
        while i < 4 {
            prod *= (k + i + 1) as f64;
            t[i][k] = 1.0 / prod;
            i += 1;
        }
        k += 1;
    }
    t
};

/// Poisson deviate: below [`POISSON_EXACT_BELOW`] exact, by inversion (one uniform `u`, then the
/// smallest `k` with `F(k) = Σ_{j≤k} e^{−μ} μ^j / j! ≥ u`; Devroye 1986, *Non-Uniform Random Variate
/// Generation*, §X.3.2), stepping four terms at a time (each from the block's first term, so the
/// dependency chain is one product and one sum per four terms); else the normal approximation
/// `μ + √μ·z`.
#[inline]
fn poisson(rng: &mut SmallRng, mean: f64) -> f64 {
    if mean <= 0.0 {
        return 0.0;
    }
    if mean < POISSON_EXACT_BELOW {
        let u: f64 = rng.random();
        let m = [
            mean,
            mean * mean,
            mean * mean * mean,
            mean * mean * mean * mean,
        ];
        let mut p = (-mean).exp();
        let mut f = p;
        let mut k = 0usize;
        // Invariant: u > F(k − 1), p = p_k, f = F(k).
        loop {
            let a = std::array::from_fn::<f64, 4, _>(|i| p * (m[i] * POISSON_STEP[i][k]));
            let f1 = f + a[0];
            let f2 = f1 + a[1];
            let f3 = f2 + a[2];
            let f4 = f3 + a[3];
            // F(k + 4) ≥ u (or the table's end: P(K > 63 | μ < 20) < 1e-15): the answer is k plus
            // the number of F(k), …, F(k + 3) still below u.
            if u <= f4 || k >= 60 {
                let below = usize::from(u > f)
                    + usize::from(u > f1)
                    + usize::from(u > f2)
                    + usize::from(u > f3);
                return (k + below) as f64;
            }
            k += 4;
            p = a[3];
            f = f4;
        }
    } else {
        let z: f64 = rng.sample(StandardNormal);
        (mean + mean.sqrt() * z).max(0.0)
    }
}

/// The planned pixel array (fixed-pattern maps drawn once from the seed).
pub struct PixelModel {
    config: PixelConfig,
    width: usize,
    height: usize,
    shot: bool,
    read: bool,
    dark: bool,
    saturation: bool,
    /// DSNU offsets, e⁻ (empty: `camera.dsnu` off).
    dsnu_e: Vec<f32>,
    /// PRNU gains `1 + p_i` (empty: `camera.prnu` off).
    prnu_gain: Vec<f32>,
}

impl PixelModel {
    pub fn new(
        config: &PixelConfig,
        width: usize,
        height: usize,
        effects: &Effects,
        seed: u64,
    ) -> Result<PixelModel, ModelError> {
        config.validate()?;
        if width == 0 || height == 0 || width.checked_mul(height).is_none() {
            return Err(ModelError::Config(format!(
                "`camera.width_px`/`camera.height_px` must be > 0, got {width} × {height}"
            )));
        }
        let map = |stream: u64, sigma: f64, offset: f32| -> Vec<f32> {
            let mut v = vec![0f32; width * height];
            v.par_chunks_mut(width).enumerate().for_each(|(y, row)| {
                let mut rng = row_rng(seed, stream, y);
                for p in row {
                    let z: f64 = rng.sample(StandardNormal);
                    *p = offset + (sigma * z) as f32;
                }
            });
            v
        };
        let dsnu_e = if effects.is_on(&DSNU) && config.dsnu_e > 0.0 {
            map(0xD5A0, config.dsnu_e, 0.0)
        } else {
            Vec::new()
        };
        let prnu_gain = if effects.is_on(&PRNU) && config.prnu_percent > 0.0 {
            let mut m = map(0x9A00, config.prnu_percent / 100.0, 1.0);
            // A gain cannot be negative (only reachable for absurd PRNU values).
            m.iter_mut().for_each(|g| *g = g.max(0.0));
            m
        } else {
            Vec::new()
        };
        Ok(PixelModel {
            config: config.clone(),
            width,
            height,
            shot: effects.is_on(&SHOT_NOISE),
            read: effects.is_on(&READ_NOISE),
            dark: effects.is_on(&DARK_CURRENT),
            saturation: effects.is_on(&SATURATION),
            dsnu_e,
            prnu_gain,
        })
    }

    /// The configuration the model was planned with.
    pub fn config(&self) -> &PixelConfig {
        &self.config
    }

    /// Array size (width, height), px.
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// CFA layout of the array.
    pub fn cfa(&self) -> Cfa {
        self.config.cfa
    }

    /// The DSNU offset map, e⁻ (empty when `camera.dsnu` is off).
    pub fn dsnu_map_e(&self) -> &[f32] {
        &self.dsnu_e
    }

    /// The PRNU gain map `1 + p_i` (empty when `camera.prnu` is off).
    pub fn prnu_map(&self) -> &[f32] {
        &self.prnu_gain
    }

    /// The single-exposure capture of the configuration (base of the HDR sequence).
    pub fn base_exposure(&self, time_s: f64) -> ExposureSpec {
        ExposureSpec {
            time_s,
            analog_gain: self.config.analog_gain,
            relative_sensitivity: 1.0,
            conversion_gain_dn_per_e: self.config.conversion_gain_dn_per_e,
            full_well_e: self.config.full_well_e,
            read_noise_e: self.config.read_noise_e,
            start_offset_s: 0.0,
            index: 0,
            shared_charge: false,
        }
    }

    /// The reads of a split pixel (IMX490 class), all integrating over the same window:
    /// large PD at high conversion gain, large PD at low conversion gain, small PD.
    pub fn split_pixel_captures(&self, time_s: f64) -> [ExposureSpec; 3] {
        let c = &self.config;
        let hcg = ExposureSpec {
            shared_charge: true,
            ..self.base_exposure(time_s)
        };
        let lcg = ExposureSpec {
            conversion_gain_dn_per_e: c.lcg_conversion_gain_dn_per_e,
            read_noise_e: c.lcg_read_noise_e,
            index: 1,
            ..hcg
        };
        let spd = ExposureSpec {
            shared_charge: false,
            relative_sensitivity: c.small_pd_relative_sensitivity,
            conversion_gain_dn_per_e: c.small_pd_conversion_gain_dn_per_e,
            full_well_e: c.small_pd_full_well_e,
            read_noise_e: c.small_pd_read_noise_e,
            index: 2,
            ..hcg
        };
        [hcg, lcg, spd]
    }

    /// Largest code of the ADC, DN.
    pub fn max_dn(&self) -> u32 {
        (1u32 << self.config.adc_bits) - 1
    }

    /// Electrons at which a capture saturates: the full well or the ADC range, whichever is
    /// reached first.
    pub fn saturation_e(&self, exposure: &ExposureSpec) -> f64 {
        let k = exposure.conversion_gain_dn_per_e * exposure.analog_gain;
        let adc = (f64::from(self.max_dn()) - self.config.black_level_dn) / k;
        exposure.full_well_e.min(adc)
    }

    /// Dark current of the photodiode a capture reads at `temperature_c`, e⁻/s (the small PD's
    /// when the capture's relative sensitivity is below 1).
    pub fn dark_current_e_per_s(&self, exposure: &ExposureSpec, temperature_c: f64) -> f64 {
        let c = &self.config;
        let reference = if exposure.relative_sensitivity < 1.0 {
            c.small_pd_dark_current_e_per_s
        } else {
            c.dark_current_e_per_s
        };
        reference * c.dark_factor(temperature_c)
    }

    /// Exposure time an auto-exposure loop converges to for this rate image, s.
    ///
    /// Converged AE in closed form (the signal is linear in the exposure time): the log-average
    /// of the green generation rate, `R̄ = exp(mean ln max(r_G, 1 e⁻/s))` (the scene "key",
    /// Reinhard et al., SIGGRAPH 2002; robust to a sun disk in view), is placed at
    /// `ae_target_fraction` of the saturation signal of the base capture:
    /// `t = f · N_sat / R̄`, clamped to `[min_exposure_s, max_exposure_s]`.
    pub fn auto_exposure_s(&self, rate: &ChannelImage) -> f64 {
        let c = &self.config;
        let plane = &rate.planes[GREEN];
        if plane.is_empty() {
            return c.max_exposure_s;
        }
        let chunk = rate.width.max(1);
        // Σ ln max(r, 1) as logarithms of products of eight factors (each clamped to 10³⁰ e⁻/s,
        // far above any physical rate, so that a product stays inside f64's range): one
        // logarithm per eight pixels. Non-finite rates count as 1 e⁻/s.
        let sums: Vec<f64> = plane
            .par_chunks(chunk)
            .map(|row| {
                let factor = |v: f32| {
                    let v = f64::from(v);
                    if v.is_finite() {
                        v.clamp(1.0, 1e30)
                    } else {
                        1.0
                    }
                };
                let mut groups = row.chunks_exact(8);
                let mut sum = 0.0;
                for g in &mut groups {
                    sum += g.iter().fold(1.0, |p, &v| p * factor(v)).ln();
                }
                sum + groups
                    .remainder()
                    .iter()
                    .fold(1.0, |p, &v| p * factor(v))
                    .ln()
            })
            .collect();
        let mean_ln = sums.iter().sum::<f64>() / plane.len() as f64;
        let key = mean_ln.exp();
        let sat = self.saturation_e(&self.base_exposure(1.0));
        let t = c.ae_target_fraction * sat / key;
        if t.is_finite() {
            t.clamp(c.min_exposure_s, c.max_exposure_s)
        } else {
            c.max_exposure_s
        }
    }

    /// Expose the array: `rate` in e⁻/s per pixel and channel (the pixel reads its CFA channel),
    /// flicker samples integrated per row over the capture's window.
    #[allow(clippy::too_many_arguments)]
    pub fn expose(
        &self,
        rate: &ChannelImage,
        flicker: &Flicker,
        exposure: &ExposureSpec,
        timing: &ShutterTiming,
        temperature_c: f64,
        noise_seed: u64,
        out: &mut RawImage,
    ) {
        let (w, h) = (self.width, self.height);
        let cfg = &self.config;
        out.width = w;
        out.height = h;
        // Every sample is written below: no need to clear the previous frame's.
        out.data.resize(w * h, 0);
        out.bit_depth = cfg.adc_bits;
        out.black_level_dn = cfg.black_level_dn;
        out.exposure_time_s = exposure.time_s;
        out.analog_gain = exposure.analog_gain;
        out.conversion_gain_dn_per_e = exposure.conversion_gain_dn_per_e * exposure.analog_gain;
        out.row_time_s = timing.row_time_s;
        out.exposure_index = exposure.index;

        let t = if exposure.time_s.is_finite() {
            exposure.time_s.max(0.0)
        } else {
            0.0
        };
        let sens = exposure.relative_sensitivity.max(0.0);
        let gain = exposure.conversion_gain_dn_per_e * exposure.analog_gain;
        let black = cfg.black_level_dn;
        let top = if self.saturation {
            f64::from(self.max_dn())
        } else {
            f64::from(u32::MAX)
        };
        let full_well = if self.saturation {
            exposure.full_well_e
        } else {
            f64::INFINITY
        };
        let mu_dark = if self.dark {
            self.dark_current_e_per_s(exposure, temperature_c) * t
        } else {
            0.0
        };
        let read_sigma = if self.read {
            exposure.read_noise_e
        } else {
            0.0
        };
        let same_size = rate.width == w && rate.height == h;
        let cfa = cfg.cfa;
        let shot = self.shot;

        // Flicker samples of each row (sorted by pixel; one allocation per capture).
        let mut flick: Vec<(u32, u32)> = flicker
            .samples
            .iter()
            .enumerate()
            .filter(|(_, s)| {
                (s.pixel as usize) < w * h && (s.source as usize) < flicker.sources.len()
            })
            .map(|(k, s)| (s.pixel, k as u32))
            .collect();
        flick.sort_unstable();

        // Shot noise keyed by the photodiode's integration window, not by the read (see the
        // module documentation).
        let shot_seed = splitmix64(
            (noise_seed & 0x00FF_FFFF_FFFF_FFFF)
                ^ splitmix64(exposure.time_s.to_bits())
                ^ splitmix64(exposure.start_offset_s.to_bits() ^ 0x5555)
                ^ splitmix64(exposure.relative_sensitivity.to_bits() ^ 0xAAAA),
        );
        let row_start0 = timing.frame_time_s + timing.start_offset_s + exposure.start_offset_s;

        // One row at a time, in passes over a row buffer of electrons: the arithmetic passes
        // (mean, DN conversion) vectorise; the random draws keep their order per stream.
        out.data
            .par_chunks_mut(w)
            .enumerate()
            .for_each_init(Vec::<f64>::new, |e, (y, row)| {
                e.clear();
                e.resize(w, 0.0);
                let base = y * w;
                // 1. Mean photo-electrons of the row's CFA channels: r·t·s.
                if same_size {
                    // Negative, NaN and infinite rates give no light (`max` ignores NaN).
                    let mu = |r: f32| {
                        let r = f64::from(r);
                        if r < f64::INFINITY {
                            r.max(0.0) * t * sens
                        } else {
                            0.0
                        }
                    };
                    let even = &rate.planes[cfa.channel(0, y)][base..base + w];
                    let odd = &rate.planes[cfa.channel(1, y)][base..base + w];
                    let mut pairs = e.chunks_exact_mut(2);
                    for ((e, a), b) in (&mut pairs)
                        .zip(even.chunks_exact(2))
                        .zip(odd.chunks_exact(2))
                    {
                        e[0] = mu(a[0]);
                        e[1] = mu(b[1]);
                    }
                    if let Some(last) = pairs.into_remainder().first_mut() {
                        *last = mu(even[w - 1]);
                    }
                }
                // 2. LED pixels: (v/d)·f_on(t₀, t)·t·s.
                let lo = flick.partition_point(|&(p, _)| (p as usize) < base);
                let hi = flick.partition_point(|&(p, _)| (p as usize) < base + w);
                if lo < hi {
                    let t0 = row_start0 + y as f64 * timing.row_time_s;
                    for &(p, k) in &flick[lo..hi] {
                        let x = p as usize - base;
                        let s = &flicker.samples[k as usize];
                        let src = &flicker.sources[s.source as usize];
                        let v = f64::from(s.value[cfa.channel(x, y)]);
                        let duty = if src.duty > 0.0 && src.frequency_hz > 0.0 {
                            src.duty.min(1.0)
                        } else {
                            1.0
                        };
                        if v.is_finite() && v > 0.0 {
                            e[x] += v / duty * src.on_fraction(t0, t) * t * sens;
                        }
                    }
                }
                // 3. PRNU gain, dark electrons.
                if let Some(prnu) = self.prnu_gain.get(base..base + w) {
                    for (e, &g) in e.iter_mut().zip(prnu) {
                        *e *= f64::from(g);
                    }
                }
                if mu_dark != 0.0 {
                    e.iter_mut().for_each(|e| *e += mu_dark);
                }
                let dsnu = self.dsnu_e.get(base..base + w);
                if shot && read_sigma > 0.0 && !exposure.shared_charge {
                    // 4.–5. Shot and read noise in one pass: one normal of variance μ + σ_r² where
                    // the shot noise is normal and the full well out of reach (μ + 8√μ below it),
                    // else as below.
                    let mut shot_rng = row_rng(shot_seed, 0x5407, y);
                    let mut read_rng = row_rng(noise_seed, 0x4EAD, y);
                    let var_r = read_sigma * read_sigma;
                    for (x, e) in e.iter_mut().enumerate() {
                        let mean = *e;
                        let offset = dsnu.map_or(0.0, |d| f64::from(d[x]));
                        *e = if mean >= POISSON_EXACT_BELOW && mean + 8.0 * mean.sqrt() < full_well
                        {
                            let z: f64 = shot_rng.sample(StandardNormal);
                            mean + (mean + var_r).sqrt() * z + offset
                        } else {
                            let z: f64 = read_rng.sample(StandardNormal);
                            poisson(&mut shot_rng, mean).min(full_well) + offset + read_sigma * z
                        };
                    }
                } else {
                    // 4. Shot noise, full well.
                    if shot {
                        let mut rng = row_rng(shot_seed, 0x5407, y);
                        for e in e.iter_mut() {
                            *e = poisson(&mut rng, *e);
                        }
                    }
                    if full_well < f64::INFINITY {
                        e.iter_mut().for_each(|e| *e = e.min(full_well));
                    }
                    // 5. DSNU offset, read noise.
                    if let Some(dsnu) = dsnu {
                        for (e, &o) in e.iter_mut().zip(dsnu) {
                            *e += f64::from(o);
                        }
                    }
                    if read_sigma > 0.0 {
                        let mut rng = row_rng(noise_seed, 0x4EAD, y);
                        for e in e.iter_mut() {
                            let z: f64 = rng.sample(StandardNormal);
                            *e += read_sigma * z;
                        }
                    }
                }
                // 6. ADC: round half up of the value clamped to [0, top] (`as` truncates;
                // `f64::round` is a libm call on baseline x86-64).
                for (px, &e) in row.iter_mut().zip(e.iter()) {
                    *px = ((e * gain + black).clamp(0.0, top) + 0.5) as u32;
                }
            });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The exact sampler against the closed-form Poisson pmf `e^{−μ} μ^k / k!`: each probability
    /// within 5 standard errors of its empirical frequency, mean and variance both μ.
    #[test]
    fn poisson_deviates_follow_the_pmf() {
        for (seed, mu) in [(1u64, 0.3), (2, 2.5), (3, 7.0), (4, 12.5), (5, 19.9)] {
            let mut rng = row_rng(seed, 0x7E57, 0);
            let n = 200_000usize;
            let mut counts = vec![0usize; 80];
            let (mut s1, mut s2) = (0.0, 0.0);
            for _ in 0..n {
                let k = poisson(&mut rng, mu);
                assert!(k >= 0.0 && k.fract() == 0.0);
                counts[(k as usize).min(79)] += 1;
                s1 += k;
                s2 += k * k;
            }
            let mean = s1 / n as f64;
            let var = s2 / n as f64 - mean * mean;
            assert!(
                (mean - mu).abs() < 5.0 * (mu / n as f64).sqrt(),
                "μ {mu}: mean {mean}"
            );
            assert!((var / mu - 1.0).abs() < 0.03, "μ {mu}: variance {var}");
            let mut ln_pk = -mu;
            for (k, &c) in counts.iter().enumerate().take(60) {
                if k > 0 {
                    ln_pk += mu.ln() - (k as f64).ln();
                }
                let p = ln_pk.exp();
                let se = (p * (1.0 - p) / n as f64).sqrt();
                let freq = c as f64 / n as f64;
                assert!(
                    (freq - p).abs() <= 5.0 * se + 1e-5,
                    "μ {mu}, k {k}: frequency {freq} vs pmf {p}"
                );
            }
        }
    }
}
