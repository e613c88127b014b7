//! Spectral bands and the colour-filter × quantum-efficiency response of the pixels.
//!
//! The response of channel `c` at wavelength λ is the product of the silicon quantum efficiency,
//! the colour-filter transmittance and the IR-cut filter, `η_c(λ) = QE(λ)·CFA_c(λ)·T_IR(λ)`
//! (EMVA 1288 Release 4.0 §4: spectral quantum efficiency η(λ) of a colour channel; physics.md §3.1,
//! §3.4). The default is a *parametric* model of a Sony automotive BSI RGGB sensor (ISX019 /
//! IMX490 class); the manufacturers publish only relative curves under NDA, so every default
//! parameter is **guessed** from the shape of typical published relative-response plots
//! (peaks ≈ 600 / 530 / 460 nm, IR cut ≈ 650 nm). A measured table can replace the model
//! ([`SpectralConfig::measured`]).

use serde::{Deserialize, Serialize};

use super::CHANNELS;
use crate::constants::{PLANCK_J_S, SPEED_OF_LIGHT_M_S};
use crate::error::ModelError;

/// Planck constant × speed of light, J·m (CODATA 2018, exact).
pub const HC_J_M: f64 = PLANCK_J_S * SPEED_OF_LIGHT_M_S;

/// Sub-intervals per band for the band integral of the response (3-point Gauss–Legendre each).
const SUBINTERVALS: usize = 16;

/// 3-point Gauss–Legendre nodes on [−1, 1] and weights (Abramowitz & Stegun 25.4.29).
const GL3: [(f64, f64); 3] = [
    (-0.774_596_669_241_483_4, 5.0 / 9.0),
    (0.0, 8.0 / 9.0),
    (0.774_596_669_241_483_4, 5.0 / 9.0),
];

/// Wavelength bands the scene is rendered in: `centres_nm[k] ± width_nm/2`.
#[derive(Debug, Clone, PartialEq)]
pub struct SpectralBands {
    pub centres_nm: Vec<f64>,
    pub width_nm: f64,
}

impl SpectralBands {
    /// `n` equal bands covering `[start_nm, end_nm]`.
    pub fn uniform(start_nm: f64, end_nm: f64, n: usize) -> SpectralBands {
        let n = n.max(1);
        let width_nm = (end_nm - start_nm) / n as f64;
        SpectralBands {
            centres_nm: (0..n)
                .map(|k| start_nm + (k as f64 + 0.5) * width_nm)
                .collect(),
            width_nm,
        }
    }

    pub fn len(&self) -> usize {
        self.centres_nm.len()
    }

    pub fn is_empty(&self) -> bool {
        self.centres_nm.is_empty()
    }
}

/// Per channel and band: photo-electrons per joule of spectral radiance in the band,
/// `w_c(λ_k) = QE(λ_k) · CFA_c(λ_k) · T_IR(λ_k) · λ_k / (h c) · Δλ` [e⁻ nm J⁻¹], so that the
/// photo-electron radiance is `L_c = Σ_k L_λ(λ_k) · w_c(λ_k)` with `L_λ` in W m⁻² sr⁻¹ nm⁻¹.
#[derive(Debug, Clone, PartialEq)]
pub struct SpectralResponse {
    pub bands: SpectralBands,
    pub weights: [Vec<f64>; CHANNELS],
}

impl SpectralResponse {
    /// `L_c` of a spectrum sampled at the band centres (W m⁻² sr⁻¹ nm⁻¹ → e⁻ s⁻¹ m⁻² sr⁻¹).
    pub fn apply(&self, spectrum: &[f64]) -> [f64; CHANNELS] {
        let mut out = [0.0; CHANNELS];
        for (c, o) in out.iter_mut().enumerate() {
            *o = self.weights[c]
                .iter()
                .zip(spectrum)
                .map(|(w, s)| w * s)
                .sum();
        }
        out
    }
}

/// Colour filters, quantum efficiency and IR-cut filter (`"spectral"` key of the camera config).
///
/// Parametric model (used unless [`Self::measured`] is given):
/// * silicon QE: `QE(λ) = qe_peak · exp(−½((λ − qe_peak_nm)/σ)²)`, `σ = qe_fwhm_nm / 2.3548`;
/// * colour filter c: `CFA_c(λ) = floor + (peak − floor) · G_c(λ) + (1 − G_c(λ)) · N(λ)` with
///   `G_c(λ) = exp(−½((λ − peak_nm_c)/σ_c)²)`, `σ_c = cfa_fwhm_nm_c / 2.3548` (Gaussian-like dye
///   filters; the floor is the out-of-band leak). The red filter is a long-pass: `G_R = 1` above
///   its peak. `N(λ) = cfa_nir_leak / (1 + exp(−(λ − cfa_nir_onset_nm)/20 nm))` is the near-IR
///   transparency of the green and blue dyes (why cameras need the IR-cut filter);
/// * IR cut: `T_IR(λ) = ir_cut_transmittance / (1 + exp((λ − ir_cut_nm)/ir_cut_edge_nm))`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SpectralConfig {
    /// Peak quantum efficiency of the bare silicon (0, 1] (guessed: 0.7, BSI CMOS).
    pub qe_peak: f64,
    /// Wavelength of the QE peak, nm (guessed: 560 nm).
    pub qe_peak_nm: f64,
    /// Full width at half maximum of the QE curve, nm (guessed: 450 nm, giving QE ≈ 0.49 at
    /// 400 nm, 0.53 at 700 nm, 0.22 at 850 nm).
    pub qe_fwhm_nm: f64,
    /// Peak wavelengths of the R, G, B colour filters, nm (guessed: 600, 530, 460; the red filter is a
    /// long-pass from its peak on, the IR cut makes the red response peak near 600 nm).
    pub cfa_peak_nm: [f64; CHANNELS],
    /// FWHM of the R, G, B colour filters, nm (guessed: 100, 90, 80).
    pub cfa_fwhm_nm: [f64; CHANNELS],
    /// Peak transmittance of the colour filters [0, 1] (guessed: 0.9).
    pub cfa_peak_transmittance: f64,
    /// Out-of-band leak of the colour filters [0, peak) (guessed: 0.02).
    pub cfa_floor: f64,
    /// Near-IR transmittance the green and blue dyes reach far above `cfa_nir_onset_nm`
    /// [0, 1] (guessed: 0.85).
    pub cfa_nir_leak: f64,
    /// 50 % point of the near-IR transparency of the green and blue dyes, nm (guessed: 820 nm).
    pub cfa_nir_onset_nm: f64,
    /// IR-cut filter present.
    pub ir_cut: bool,
    /// 50 % wavelength of the IR-cut filter, nm (guessed: 650 nm).
    pub ir_cut_nm: f64,
    /// Edge width of the IR-cut filter (logistic scale), nm (guessed: 10 nm).
    pub ir_cut_edge_nm: f64,
    /// Pass-band transmittance of the IR-cut filter (guessed: 0.95).
    pub ir_cut_transmittance: f64,
    /// Measured total spectral quantum efficiency per channel, rows `[nm, η_r, η_g, η_b]` with
    /// `η_c = QE·CFA_c·T_IR` (as EMVA 1288 data sheets give it), strictly increasing wavelength;
    /// linear interpolation, zero outside the table. Replaces the parametric model when given.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub measured: Option<Vec<[f64; 4]>>,
}

impl Default for SpectralConfig {
    fn default() -> Self {
        SpectralConfig {
            qe_peak: 0.7,
            qe_peak_nm: 560.0,
            qe_fwhm_nm: 450.0,
            cfa_peak_nm: [600.0, 530.0, 460.0],
            cfa_fwhm_nm: [100.0, 90.0, 80.0],
            cfa_peak_transmittance: 0.9,
            cfa_floor: 0.02,
            cfa_nir_leak: 0.85,
            cfa_nir_onset_nm: 820.0,
            ir_cut: true,
            ir_cut_nm: 650.0,
            ir_cut_edge_nm: 10.0,
            ir_cut_transmittance: 0.95,
            measured: None,
        }
    }
}

/// FWHM → σ of a Gaussian: 2·√(2 ln 2).
const FWHM_PER_SIGMA: f64 = 2.354_820_045_030_949;

fn gaussian(x: f64, centre: f64, fwhm: f64) -> f64 {
    let s = fwhm / FWHM_PER_SIGMA;
    let u = (x - centre) / s;
    (-0.5 * u * u).exp()
}

fn cfg_err(key: &str, what: &str, got: impl std::fmt::Display) -> ModelError {
    ModelError::Config(format!("`camera.spectral.{key}` must be {what}, got {got}"))
}

impl SpectralConfig {
    pub fn validate(&self) -> Result<(), ModelError> {
        let pos = |key: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(cfg_err(key, "finite and > 0", v))
            }
        };
        let unit = |key: &str, v: f64| {
            if v.is_finite() && (0.0..=1.0).contains(&v) {
                Ok(())
            } else {
                Err(cfg_err(key, "in [0, 1]", v))
            }
        };
        if !(self.qe_peak.is_finite() && self.qe_peak > 0.0 && self.qe_peak <= 1.0) {
            return Err(cfg_err("qe_peak", "in (0, 1]", self.qe_peak));
        }
        pos("qe_peak_nm", self.qe_peak_nm)?;
        pos("qe_fwhm_nm", self.qe_fwhm_nm)?;
        for c in 0..CHANNELS {
            pos("cfa_peak_nm", self.cfa_peak_nm[c])?;
            pos("cfa_fwhm_nm", self.cfa_fwhm_nm[c])?;
        }
        unit("cfa_peak_transmittance", self.cfa_peak_transmittance)?;
        unit("cfa_floor", self.cfa_floor)?;
        unit("cfa_nir_leak", self.cfa_nir_leak)?;
        pos("cfa_nir_onset_nm", self.cfa_nir_onset_nm)?;
        if self.cfa_floor > self.cfa_peak_transmittance {
            return Err(cfg_err(
                "cfa_floor",
                "≤ cfa_peak_transmittance",
                self.cfa_floor,
            ));
        }
        pos("ir_cut_nm", self.ir_cut_nm)?;
        pos("ir_cut_edge_nm", self.ir_cut_edge_nm)?;
        unit("ir_cut_transmittance", self.ir_cut_transmittance)?;
        if let Some(table) = &self.measured {
            if table.len() < 2 {
                return Err(cfg_err(
                    "measured",
                    "a table of at least 2 rows",
                    table.len(),
                ));
            }
            for (i, row) in table.iter().enumerate() {
                if !row.iter().all(|v| v.is_finite()) || row[0] <= 0.0 {
                    return Err(cfg_err(
                        "measured",
                        "rows [nm > 0, η_r, η_g, η_b] of finite numbers",
                        format!("row {i} = {row:?}"),
                    ));
                }
                if row[1..].iter().any(|&v| !(0.0..=1.0).contains(&v)) {
                    return Err(cfg_err(
                        "measured",
                        "quantum efficiencies in [0, 1]",
                        format!("row {i} = {row:?}"),
                    ));
                }
                if i > 0 && row[0] <= table[i - 1][0] {
                    return Err(cfg_err(
                        "measured",
                        "strictly increasing wavelengths",
                        format!("row {i} = {row:?}"),
                    ));
                }
            }
        }
        Ok(())
    }

    /// Silicon quantum efficiency of the parametric model at `nm` (electrons per photon).
    pub fn silicon_qe(&self, nm: f64) -> f64 {
        self.qe_peak * gaussian(nm, self.qe_peak_nm, self.qe_fwhm_nm)
    }

    /// Colour-filter transmittance of channel `c` of the parametric model at `nm`.
    pub fn cfa_transmittance(&self, c: usize, nm: f64) -> f64 {
        let g = if c == super::RED && nm >= self.cfa_peak_nm[c] {
            1.0
        } else {
            gaussian(nm, self.cfa_peak_nm[c], self.cfa_fwhm_nm[c])
        };
        let u = (-(nm - self.cfa_nir_onset_nm) / 20.0).clamp(-700.0, 700.0);
        let nir = self.cfa_nir_leak / (1.0 + u.exp());
        self.cfa_floor + (self.cfa_peak_transmittance - self.cfa_floor) * g + (1.0 - g) * nir
    }

    /// IR-cut filter transmittance at `nm` (1 without the filter).
    pub fn ir_cut_transmittance_at(&self, nm: f64) -> f64 {
        if !self.ir_cut {
            return 1.0;
        }
        let u = ((nm - self.ir_cut_nm) / self.ir_cut_edge_nm).clamp(-700.0, 700.0);
        self.ir_cut_transmittance / (1.0 + u.exp())
    }

    /// Total spectral quantum efficiency of channel `c` at `nm`, `η_c = QE·CFA_c·T_IR` (or the
    /// measured table), electrons per incident photon.
    pub fn efficiency(&self, c: usize, nm: f64) -> f64 {
        if let Some(table) = &self.measured {
            return interpolate(table, c + 1, nm);
        }
        self.silicon_qe(nm) * self.cfa_transmittance(c, nm) * self.ir_cut_transmittance_at(nm)
    }

    /// The response of the configured sensor sampled on `bands`: the band average of
    /// `η_c(λ)·λ/(hc)` (composite 3-point Gauss–Legendre, 16 sub-intervals per band) times the band width, so a
    /// band-constant spectral radiance gives exactly the integral `∫ L_λ η_c λ/(hc) dλ` over the band.
    pub fn response(&self, bands: &SpectralBands) -> Result<SpectralResponse, ModelError> {
        self.validate()?;
        let dl = bands.width_nm;
        if !(dl.is_finite() && dl > 0.0) {
            return Err(ModelError::Config(format!(
                "spectral band width must be finite and > 0 nm, got {dl}"
            )));
        }
        if bands
            .centres_nm
            .iter()
            .any(|l| !(l.is_finite() && *l > 0.0))
        {
            return Err(ModelError::Config(
                "spectral band centres must be finite and > 0 nm".into(),
            ));
        }
        let mut weights: [Vec<f64>; CHANNELS] = Default::default();
        for (c, w) in weights.iter_mut().enumerate() {
            w.extend(bands.centres_nm.iter().map(|&centre| {
                let h = dl / SUBINTERVALS as f64;
                let mut sum = 0.0;
                for s in 0..SUBINTERVALS {
                    let mid = centre - 0.5 * dl + (s as f64 + 0.5) * h;
                    for (u, wgt) in GL3 {
                        let nm = mid + 0.5 * h * u;
                        sum += wgt * 0.5 * h * self.efficiency(c, nm) * nm * 1e-9 / HC_J_M;
                    }
                }
                sum
            }));
        }
        Ok(SpectralResponse {
            bands: bands.clone(),
            weights,
        })
    }
}

/// Linear interpolation of column `col` of a table with strictly increasing column 0; zero
/// outside.
fn interpolate(table: &[[f64; 4]], col: usize, nm: f64) -> f64 {
    let (Some(first), Some(last)) = (table.first(), table.last()) else {
        return 0.0;
    };
    if nm < first[0] || nm > last[0] {
        return 0.0;
    }
    let i = table.partition_point(|r| r[0] <= nm);
    if i == 0 {
        return first[col];
    }
    if i >= table.len() {
        return last[col];
    }
    let (a, b) = (table[i - 1], table[i]);
    let f = (nm - a[0]) / (b[0] - a[0]);
    a[col] + f * (b[col] - a[col])
}
