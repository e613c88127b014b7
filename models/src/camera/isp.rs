//! Image signal processor: black level, demosaic, white balance, colour correction to sRGB, tone
//! mapping, 8-bit sRGB output.
//!
//! # Pipeline ([`Isp::process`])
//!
//! 1. **Black level**: `x = max(DN − black_level_dn, 0)` of the linear (HDR-merged) RAW mosaic.
//! 2. **Demosaic** ([`demosaic`]): bilinear, or the gradient-corrected linear interpolation of
//!    Malvar, He, Cutler, "High-quality linear interpolation for demosaicing of Bayer-patterned
//!    color images", ICASSP 2004 (default). Both reproduce linear gradients exactly. Borders are
//!    mirrored (reflect-101, which keeps the CFA phase).
//! 3. **White balance**: per-channel gains `g_c` (green = 1): `auto` = gray world (Buchsbaum,
//!    J. Franklin Inst. 310, 1980: the mean of each channel is made equal to the green mean),
//!    `fixed` gains, or `daylight`: the gains that make a perfect white reflector under CIE D65
//!    give equal channels, `g_c = Σ_k w_G(λ_k)E(λ_k) / Σ_k w_c(λ_k)E(λ_k)` from the sensor's
//!    [`SpectralResponse`] weights `w_c` (physics.md §3.4).
//!    **Highlight clip**: white-balanced values are clipped at `(max_dn − black)·min_c g_c`, the
//!    level where the first channel saturates, so that saturated highlights stay neutral
//!    instead of turning magenta (the usual raw-converter practice, e.g. dcraw's `-H 0`).
//! 4. **Colour correction**: a 3×3 matrix from white-balanced camera RGB to linear sRGB (D65).
//!    `fitted` (default): least squares over a set of reflectance spectra under D65, camera side
//!    `c_i = g ∘ Σ_k w(λ_k)E(λ_k)R_i(λ_k)` (normalised so that white is (1, 1, 1)), target side the
//!    true linear sRGB `M_sRGB · XYZ_i` with `XYZ = Σ E R {x̄, ȳ, z̄} / Σ E ȳ` (CIE 015:2018, CIE 1931
//!    2° colour-matching functions, embedded at 10 nm), with the white-preserving constraint
//!    that every row sums to 1 (a neutral stays neutral). `fixed`: the configured matrix;
//!    `identity`.
//! 5. **Luminance** for recognition: `Y = 0.2126 R + 0.7152 G + 0.0722 B` of the linear sRGB
//!    (IEC 61966-2-1 / ITU-R BT.709 weights), in units of white-balanced green DN (linear in the
//!    scene luminance; only ratios are meaningful).
//! 6. **Exposure and tone mapping** (global, per channel so that neutrals stay neutral): scale
//!    `s = key / (exp(mean ln(δ + Y)) − δ)` (Reinhard, Stark, Shirley, Ferwerda, "Photographic tone
//!    reproduction for digital images", SIGGRAPH 2002, eq. 1–2; δ = 1 DN) or a fixed scale; then
//!    `reinhard`: `x(1 + x/L_w²)/(1 + x)` (ibid. eq. 4), `filmic`: Hable's curve (J. Hable,
//!    "Uncharted 2: HDR Lighting", GDC 2010: A = 0.15, B = 0.50, C = 0.10, D = 0.20, E = 0.02,
//!    F = 0.30, linear white W = 11.2, exposure bias 2), or `clip` to [0, 1].
//! 7. **sRGB encoding** (IEC 61966-2-1:1999): `12.92 L` for `L ≤ 0.0031308`, else
//!    `1.055 L^(1/2.4) − 0.055`, to 8 bit through a 65 536-entry table.
//!
//! Everything that does not change between frames (CCM, gains, the encoding table) is planned
//! in [`Isp::new`]; the per-frame passes run over rows with rayon and allocate nothing once the
//! buffers have their size.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::{BLUE, CHANNELS, Cfa, ChannelImage, GREEN, RED, RawImage, RgbImage, SpectralResponse};
use crate::effects::EffectInfo;
use crate::error::ModelError;

/// ISP stages are processing, not physics: none is an effect, but the list exists for symmetry.
pub const EFFECTS: &[EffectInfo] = &[];

/// First wavelength of the embedded tables, nm.
pub const TABLE_START_NM: f64 = 380.0;
/// Step of the embedded tables, nm.
pub const TABLE_STEP_NM: f64 = 10.0;

/// CIE 1931 2° standard observer colour-matching functions x̄, ȳ, z̄ at 380, 390, …, 780 nm.
/// Source: CIE 015:2018 "Colorimetry", 4th ed., table of the 1931 standard observer (the 1 nm
/// table sampled every 10 nm; identical to the CVRL file `ciexyz31_1.csv`, http://cvrl.ucl.ac.uk).
#[rustfmt::skip]
pub const CIE1931_XYZ_10NM: [[f64; 3]; 41] = [
    [0.001368, 0.000039, 0.006450], [0.004243, 0.000120, 0.020050],
    [0.014310, 0.000396, 0.067850], [0.043510, 0.001210, 0.207400],
    [0.134380, 0.004000, 0.645600], [0.283900, 0.011600, 1.385600],
    [0.348280, 0.023000, 1.747060], [0.336200, 0.038000, 1.772110],
    [0.290800, 0.060000, 1.669200], [0.195360, 0.090980, 1.287640],
    [0.095640, 0.139020, 0.812950], [0.032010, 0.208020, 0.465180],
    [0.004900, 0.323000, 0.272000], [0.009300, 0.503000, 0.158200],
    [0.063270, 0.710000, 0.078250], [0.165500, 0.862000, 0.042160],
    [0.290400, 0.954000, 0.020300], [0.433450, 0.994950, 0.008750],
    [0.594500, 0.995000, 0.003900], [0.762100, 0.952000, 0.002100],
    [0.916300, 0.870000, 0.001650], [1.026300, 0.757000, 0.001100],
    [1.062200, 0.631000, 0.000800], [1.002600, 0.503000, 0.000340],
    [0.854450, 0.381000, 0.000190], [0.642400, 0.265000, 0.000050],
    [0.447900, 0.175000, 0.000020], [0.283500, 0.107000, 0.000000],
    [0.164900, 0.061000, 0.000000], [0.087400, 0.032000, 0.000000],
    [0.046770, 0.017000, 0.000000], [0.022700, 0.008210, 0.000000],
    [0.011359, 0.004102, 0.000000], [0.005790, 0.002091, 0.000000],
    [0.002899, 0.001047, 0.000000], [0.001440, 0.000520, 0.000000],
    [0.000690, 0.000249, 0.000000], [0.000332, 0.000120, 0.000000],
    [0.000166, 0.000060, 0.000000], [0.000083, 0.000030, 0.000000],
    [0.000042, 0.000015, 0.000000],
];

/// CIE standard illuminant D65, relative spectral power (100 at 560 nm), at 380, 390, …, 780 nm.
/// Source: CIE 015:2018 / ISO 11664-2:2007 (CIE S 014-2), the 5 nm table sampled every 10 nm.
#[rustfmt::skip]
pub const D65_10NM: [f64; 41] = [
    49.9755, 54.6482, 82.7549, 91.4860, 93.4318, 86.6823, 104.865, 117.008, 117.812, 114.861,
    115.923, 108.811, 109.354, 107.802, 104.790, 107.689, 104.405, 104.046, 100.000, 96.3342,
    95.7880, 88.6856, 90.0062, 89.5991, 87.6987, 83.2886, 83.6992, 80.0268, 80.2146, 82.2778,
    78.2842, 69.7213, 71.6091, 74.3490, 61.6040, 69.8856, 75.0870, 63.5927, 46.4182, 66.8054,
    63.3828,
];

/// CIE XYZ → linear sRGB (IEC 61966-2-1:1999, D65 white).
pub const XYZ_TO_LINEAR_SRGB: [[f64; 3]; 3] = [
    [3.2406, -1.5372, -0.4986],
    [-0.9689, 1.8758, 0.0415],
    [0.0557, -0.2040, 1.0570],
];

/// Relative-luminance weights of linear sRGB (IEC 61966-2-1, = ITU-R BT.709).
pub const LUMA_WEIGHTS: [f64; 3] = [0.2126, 0.7152, 0.0722];

/// Linear interpolation of a 10 nm table (starting at 380 nm) at `nm`; 0 outside 380–780 nm.
pub fn table_at<const N: usize>(table: &[f64; N], nm: f64) -> f64 {
    let x = (nm - TABLE_START_NM) / TABLE_STEP_NM;
    if !(x >= 0.0 && x <= (N - 1) as f64) {
        return 0.0;
    }
    let i = (x.floor() as usize).min(N - 2);
    let t = x - i as f64;
    table[i] * (1.0 - t) + table[i + 1] * t
}

/// x̄, ȳ, z̄ of the CIE 1931 2° observer at `nm` (linear interpolation of the 10 nm table).
pub fn cmf_at(nm: f64) -> [f64; 3] {
    let mut out = [0.0; 3];
    for (k, o) in out.iter_mut().enumerate() {
        let col: [f64; 41] = std::array::from_fn(|i| CIE1931_XYZ_10NM[i][k]);
        *o = table_at(&col, nm);
    }
    out
}

/// D65 relative spectral power at `nm` (linear interpolation of the 10 nm table).
pub fn d65_at(nm: f64) -> f64 {
    table_at(&D65_10NM, nm)
}

/// sRGB encoding of a linear value in [0, 1] (IEC 61966-2-1:1999); values outside are clipped.
pub fn srgb_encode(linear: f64) -> f64 {
    let l = linear.clamp(0.0, 1.0);
    if l <= 0.003_130_8 {
        12.92 * l
    } else {
        1.055 * l.powf(1.0 / 2.4) - 0.055
    }
}

/// sRGB decoding (inverse of [`srgb_encode`]).
pub fn srgb_decode(encoded: f64) -> f64 {
    let v = encoded.clamp(0.0, 1.0);
    if v <= 0.040_45 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

fn mat_vec(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|r| m[r][0] * v[0] + m[r][1] * v[1] + m[r][2] * v[2])
}

/// Linear sRGB (white of the illuminant = (1, 1, 1) up to the sRGB matrix rounding) of a
/// reflectance sampled at `bands_nm`, under the illuminant `illuminant` (same sampling), through
/// the CIE 1931 2° observer.
pub fn reflectance_to_linear_srgb(bands_nm: &[f64], illuminant: &[f64], refl: &[f64]) -> [f64; 3] {
    let mut xyz = [0.0; 3];
    let mut white_y = 0.0;
    for ((&nm, &e), &r) in bands_nm.iter().zip(illuminant).zip(refl) {
        let cmf = cmf_at(nm);
        for k in 0..3 {
            xyz[k] += e * r * cmf[k];
        }
        white_y += e * cmf[1];
    }
    if white_y > 0.0 {
        for v in &mut xyz {
            *v /= white_y;
        }
    }
    mat_vec(&XYZ_TO_LINEAR_SRGB, xyz)
}

/// The synthetic reflectance spectra the CCM is fitted over, sampled at `bands_nm` (reflectance
/// 0…1). No measured chart is embedded: the set is smooth spectra spanning the hue circle and
/// lightness, Gaussian peaks (420–660 nm, σ 25 and 50 nm), long- and short-pass edges (480–640 nm,
/// 15 nm wide), notches (magenta/purple) and greys (guessed stand-in for a ColorChecker; natural
/// and paint reflectances are smooth, Maloney, JOSA A 3(10), 1986).
pub fn training_reflectances(bands_nm: &[f64]) -> Vec<Vec<f64>> {
    let mut set: Vec<Vec<f64>> = Vec::new();
    let sample = |f: &dyn Fn(f64) -> f64| bands_nm.iter().map(|&l| f(l)).collect::<Vec<f64>>();
    for g in [0.05, 0.2, 0.5, 0.9] {
        set.push(sample(&|_| g));
    }
    for sigma in [25.0, 50.0] {
        for k in 0..9 {
            let mu = 420.0 + 30.0 * k as f64;
            set.push(sample(&|l| {
                0.05 + 0.8 * (-0.5 * ((l - mu) / sigma).powi(2)).exp()
            }));
        }
    }
    for k in 0..5 {
        let l0 = 480.0 + 40.0 * k as f64;
        set.push(sample(&|l| 0.05 + 0.85 / (1.0 + (-(l - l0) / 15.0).exp())));
        if k < 4 {
            set.push(sample(&|l| 0.05 + 0.85 / (1.0 + ((l - l0) / 15.0).exp())));
        }
    }
    for mu in [500.0, 550.0, 600.0] {
        set.push(sample(&|l| {
            0.85 - 0.75 * (-0.5 * ((l - mu) / 40.0).powi(2)).exp()
        }));
    }
    set
}

/// Camera channel responses `Σ_k w_c(λ_k) E(λ_k) R(λ_k)` of a reflectance under an illuminant.
pub fn camera_response(response: &SpectralResponse, illuminant: &[f64], refl: &[f64]) -> [f64; 3] {
    std::array::from_fn(|c| {
        response.weights[c]
            .iter()
            .zip(illuminant)
            .zip(refl)
            .map(|((w, e), r)| w * e * r)
            .sum()
    })
}

/// Solve a small dense linear system in place (Gaussian elimination with partial pivoting).
fn solve<const N: usize>(mut a: [[f64; N]; N], mut b: [f64; N]) -> Option<[f64; N]> {
    for col in 0..N {
        let piv = (col..N).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[piv][col].abs().partial_cmp(&1e-300) != Some(std::cmp::Ordering::Greater) {
            return None;
        }
        a.swap(col, piv);
        b.swap(col, piv);
        for row in col + 1..N {
            let f = a[row][col] / a[col][col];
            let pivot_row = a[col];
            for (dst, src) in a[row].iter_mut().zip(pivot_row).skip(col) {
                *dst -= f * src;
            }
            b[row] -= f * b[col];
        }
    }
    let mut x = [0.0; N];
    for row in (0..N).rev() {
        let s: f64 = (row + 1..N).map(|k| a[row][k] * x[k]).sum();
        x[row] = (b[row] - s) / a[row][row];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// White-preserving least-squares 3×3 matrix `M` with `M · cam_i ≈ target_i` and every row
/// summing to 1: per row, minimise `Σ_i (m·cam_i − t_i)² + ε‖m − e_r‖²` subject to `1ᵀm = 1`
/// (Lagrange multiplier; the small ridge ε = 1e-9·tr(AᵀA) keeps a degenerate response solvable
/// and pulls it towards the identity).
pub fn fit_ccm(cam: &[[f64; 3]], target: &[[f64; 3]]) -> [[f64; 3]; 3] {
    let mut ata = [[0.0; 3]; 3];
    for c in cam {
        for i in 0..3 {
            for j in 0..3 {
                ata[i][j] += c[i] * c[j];
            }
        }
    }
    let eps = 1e-9 * (ata[0][0] + ata[1][1] + ata[2][2]).max(1e-300);
    let mut m = [[0.0; 3]; 3];
    for (r, row) in m.iter_mut().enumerate() {
        let mut atb = [0.0; 3];
        for (c, t) in cam.iter().zip(target) {
            for i in 0..3 {
                atb[i] += c[i] * t[r];
            }
        }
        let mut k = [[0.0; 4]; 4];
        let mut rhs = [0.0; 4];
        for i in 0..3 {
            for j in 0..3 {
                k[i][j] = ata[i][j] + if i == j { eps } else { 0.0 };
            }
            k[i][3] = 1.0;
            k[3][i] = 1.0;
            rhs[i] = atb[i] + if i == r { eps } else { 0.0 };
        }
        rhs[3] = 1.0;
        *row = match solve(k, rhs) {
            Some(x) => [x[0], x[1], x[2]],
            None => std::array::from_fn(|i| if i == r { 1.0 } else { 0.0 }),
        };
    }
    m
}

/// Demosaicing method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Demosaic {
    /// Bilinear interpolation of each channel's neighbours.
    Bilinear,
    /// Malvar–He–Cutler 2004 gradient-corrected 5×5 kernels.
    #[default]
    Malvar,
}

/// White-balance mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum WhiteBalance {
    /// Gains from the sensor's spectral response under CIE D65 (white reflector → equal channels).
    #[default]
    Daylight,
    /// Gray world on the linear demosaiced image, every frame.
    Auto,
    /// `wb_gains` from the config.
    Fixed,
    /// Unit gains.
    None,
}

/// Colour-correction matrix mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ColourCorrection {
    /// Least squares from the sensor's spectral response (see the module doc).
    #[default]
    Fitted,
    /// `ccm` from the config.
    Fixed,
    /// No colour correction.
    Identity,
}

/// Tone-mapping curve.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ToneMap {
    /// Reinhard et al. 2002 global operator with white point `white_point`.
    #[default]
    Reinhard,
    /// Hable 2010 filmic curve.
    Filmic,
    /// Clip the exposure-scaled value to [0, 1].
    Clip,
}

/// ISP parameters (`"isp"` key of the camera config).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct IspConfig {
    /// Demosaicing method: `malvar` (default) or `bilinear`.
    pub demosaic: Demosaic,
    /// White balance: `daylight` (default), `auto`, `fixed`, `none`.
    pub white_balance: WhiteBalance,
    /// Gains (R, G, B) for `white_balance: fixed`, dimensionless.
    pub wb_gains: [f64; 3],
    /// Colour correction: `fitted` (default), `fixed`, `identity`.
    pub colour_correction: ColourCorrection,
    /// Matrix (rows R, G, B of linear sRGB) for `colour_correction: fixed`, applied to
    /// white-balanced camera RGB.
    pub ccm: [[f64; 3]; 3],
    /// Tone curve: `reinhard` (default), `filmic`, `clip`.
    pub tone_map: ToneMap,
    /// Key: the value the log-average luminance is mapped to before the tone curve (Reinhard 2002
    /// "middle grey" 0.18).
    pub exposure_key: f64,
    /// Fixed exposure scale (relative luminance per DN) instead of the key-based automatic one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub exposure_scale: Option<f64>,
    /// Reinhard white point L_w (exposure-scaled luminance that maps to 1); 4 is a guessed value
    /// (Reinhard 2002 use the scene maximum).
    pub white_point: f64,
}

impl Default for IspConfig {
    fn default() -> Self {
        IspConfig {
            demosaic: Demosaic::Malvar,
            white_balance: WhiteBalance::Daylight,
            wb_gains: [1.0; 3],
            colour_correction: ColourCorrection::Fitted,
            ccm: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            tone_map: ToneMap::Reinhard,
            exposure_key: 0.18,
            exposure_scale: None,
            white_point: 4.0,
        }
    }
}

impl IspConfig {
    pub fn validate(&self) -> Result<(), ModelError> {
        let err =
            |key: &str, what: String| Err(ModelError::Config(format!("`camera.isp.{key}` {what}")));
        if let Some(g) = self
            .wb_gains
            .iter()
            .find(|g| !(g.is_finite() && **g > 0.0 && **g < 1e3))
        {
            return err(
                "wb_gains",
                format!("must be finite gains in (0, 1000), got {g}"),
            );
        }
        if self
            .ccm
            .iter()
            .flatten()
            .any(|v| !(v.is_finite() && v.abs() < 1e3))
        {
            return err(
                "ccm",
                "must be a finite 3×3 matrix with |values| < 1000".into(),
            );
        }
        if !(self.exposure_key.is_finite() && self.exposure_key > 0.0 && self.exposure_key <= 1.0) {
            return err(
                "exposure_key",
                format!("must be in (0, 1], got {}", self.exposure_key),
            );
        }
        if let Some(s) = self.exposure_scale
            && !(s.is_finite() && s > 0.0)
        {
            return err("exposure_scale", format!("must be finite and > 0, got {s}"));
        }
        if !(self.white_point.is_finite() && self.white_point > 0.0) {
            return err(
                "white_point",
                format!("must be finite and > 0, got {}", self.white_point),
            );
        }
        Ok(())
    }
}

/// One tap of a demosaic kernel: (dx, dy, weight).
type Tap = (i8, i8, f32);

/// Kernels of one method: G at R/B, the other-colour at G with same-row neighbours (horizontal),
/// at G with same-column neighbours (vertical), and R at B / B at R (diagonal).
struct Kernels {
    g_at_rb: &'static [Tap],
    horizontal: &'static [Tap],
    vertical: &'static [Tap],
    diagonal: &'static [Tap],
}

const BILINEAR: Kernels = Kernels {
    g_at_rb: &[(-1, 0, 0.25), (1, 0, 0.25), (0, -1, 0.25), (0, 1, 0.25)],
    horizontal: &[(-1, 0, 0.5), (1, 0, 0.5)],
    vertical: &[(0, -1, 0.5), (0, 1, 0.5)],
    diagonal: &[(-1, -1, 0.25), (1, -1, 0.25), (-1, 1, 0.25), (1, 1, 0.25)],
};

/// Malvar, He, Cutler 2004, Fig. 2 (weights / 8).
const MALVAR: Kernels = Kernels {
    g_at_rb: &[
        (0, 0, 4.0 / 8.0),
        (-1, 0, 2.0 / 8.0),
        (1, 0, 2.0 / 8.0),
        (0, -1, 2.0 / 8.0),
        (0, 1, 2.0 / 8.0),
        (-2, 0, -1.0 / 8.0),
        (2, 0, -1.0 / 8.0),
        (0, -2, -1.0 / 8.0),
        (0, 2, -1.0 / 8.0),
    ],
    horizontal: &[
        (0, 0, 5.0 / 8.0),
        (-1, 0, 4.0 / 8.0),
        (1, 0, 4.0 / 8.0),
        (-2, 0, -1.0 / 8.0),
        (2, 0, -1.0 / 8.0),
        (-1, -1, -1.0 / 8.0),
        (1, -1, -1.0 / 8.0),
        (-1, 1, -1.0 / 8.0),
        (1, 1, -1.0 / 8.0),
        (0, -2, 0.5 / 8.0),
        (0, 2, 0.5 / 8.0),
    ],
    vertical: &[
        (0, 0, 5.0 / 8.0),
        (0, -1, 4.0 / 8.0),
        (0, 1, 4.0 / 8.0),
        (0, -2, -1.0 / 8.0),
        (0, 2, -1.0 / 8.0),
        (-1, -1, -1.0 / 8.0),
        (1, -1, -1.0 / 8.0),
        (-1, 1, -1.0 / 8.0),
        (1, 1, -1.0 / 8.0),
        (-2, 0, 0.5 / 8.0),
        (2, 0, 0.5 / 8.0),
    ],
    diagonal: &[
        (0, 0, 6.0 / 8.0),
        (-1, -1, 2.0 / 8.0),
        (1, -1, 2.0 / 8.0),
        (-1, 1, 2.0 / 8.0),
        (1, 1, 2.0 / 8.0),
        (-2, 0, -1.5 / 8.0),
        (2, 0, -1.5 / 8.0),
        (0, -2, -1.5 / 8.0),
        (0, 2, -1.5 / 8.0),
    ],
};

/// Mirror an index into 0..n (reflect-101: −1 → 1, n → n − 2), which keeps the CFA phase.
#[inline]
fn mirror(i: isize, n: usize) -> usize {
    let n = n as isize;
    let mut i = i;
    if i < 0 {
        i = -i;
    }
    if i >= n {
        i = 2 * (n - 1) - i;
    }
    i.clamp(0, n - 1) as usize
}

/// Demosaic a black-level-subtracted mosaic (`mosaic[y·w + x]`) into three full planes. Images
/// smaller than 3 × 3 are filled by nearest same-channel pixel through the mirrored taps.
pub fn demosaic(
    mosaic: &[f32],
    width: usize,
    height: usize,
    cfa: Cfa,
    method: Demosaic,
    out: &mut ChannelImage,
) {
    if out.width != width || out.height != height || out.planes[0].len() != width * height {
        out.resize(width, height);
    }
    if width == 0 || height == 0 {
        return;
    }
    let k = match method {
        Demosaic::Bilinear => &BILINEAR,
        Demosaic::Malvar => &MALVAR,
    };
    // Interior pixels: each kernel as flat index offsets (planned once per call).
    let flat = |taps: &[Tap]| -> Vec<(isize, f32)> {
        taps.iter()
            .map(|&(dx, dy, wt)| (dy as isize * width as isize + dx as isize, wt))
            .collect()
    };
    // Kernel ids: 0 green at red/blue, 1 horizontal, 2 vertical, 3 diagonal.
    let kernels = [
        flat(k.g_at_rb),
        flat(k.horizontal),
        flat(k.vertical),
        flat(k.diagonal),
    ];
    let [pr, pg, pb] = &mut out.planes;
    pr.par_chunks_mut(width)
        .zip(pg.par_chunks_mut(width))
        .zip(pb.par_chunks_mut(width))
        .enumerate()
        .for_each_init(
            || [(); 4].map(|_| Vec::<f32>::new()),
            |conv, (y, ((rr, rg), rb))| {
                let row_inside = y >= 2 && y + 2 < height;
                if row_inside && width > 4 {
                    // Per column parity: own channel and the two interpolated (channel, kernel id).
                    let plan = [0usize, 1].map(|px| {
                        let c0 = cfa.channel(px, y);
                        if c0 == GREEN {
                            let (hc, vc) = if cfa.channel(px + 1, y) == RED {
                                (RED, BLUE)
                            } else {
                                (BLUE, RED)
                            };
                            (c0, (hc, 1), (vc, 2))
                        } else {
                            let other = if c0 == RED { BLUE } else { RED };
                            (c0, (GREEN, 0), (other, 3))
                        }
                    });
                    // Each kernel over the whole interior span, tap by tap (vectorises; every pixel
                    // sums its taps in order). Twice the arithmetic of the kernels a pixel needs,
                    // at several times the speed.
                    let base = y * width;
                    let span = width - 4;
                    for (c, taps) in conv.iter_mut().zip(&kernels) {
                        c.clear();
                        c.resize(span, 0.0);
                        for &(o, wt) in taps {
                            let start = ((base + 2) as isize + o) as usize;
                            for (a, &m) in c.iter_mut().zip(&mosaic[start..start + span]) {
                                *a += wt * m;
                            }
                        }
                    }
                    for x in 2..width - 2 {
                        let (c0, (ca, ka), (cb, kb)) = plan[x & 1];
                        let mut v = [0.0f32; CHANNELS];
                        v[c0] = mosaic[base + x];
                        v[ca] = conv[ka][x - 2];
                        v[cb] = conv[kb][x - 2];
                        rr[x] = v[RED];
                        rg[x] = v[GREEN];
                        rb[x] = v[BLUE];
                    }
                }
                let tap = |x: usize, taps: &[Tap]| -> f32 {
                    let mut s = 0.0f32;
                    if row_inside && x >= 2 && x + 2 < width {
                        // Interior: no mirroring needed.
                        let centre = (y * width + x) as isize;
                        for &(dx, dy, wt) in taps {
                            let i = centre + dy as isize * width as isize + dx as isize;
                            s += wt * mosaic[i as usize];
                        }
                    } else {
                        for &(dx, dy, wt) in taps {
                            let xx = mirror(x as isize + dx as isize, width);
                            let yy = mirror(y as isize + dy as isize, height);
                            s += wt * mosaic[yy * width + xx];
                        }
                    }
                    s
                };
                let border: &mut dyn Iterator<Item = usize> = if row_inside && width > 4 {
                    &mut [0, 1, width - 2, width - 1].into_iter()
                } else {
                    &mut (0..width)
                };
                for x in border {
                    let c0 = cfa.channel(x, y);
                    let own = mosaic[y * width + x];
                    let mut v = [0.0f32; CHANNELS];
                    v[c0] = own;
                    if c0 == GREEN {
                        let h = cfa.channel(mirror(x as isize + 1, width), y);
                        let (hc, vc) = if h == RED { (RED, BLUE) } else { (BLUE, RED) };
                        v[hc] = tap(x, k.horizontal);
                        v[vc] = tap(x, k.vertical);
                    } else {
                        v[GREEN] = tap(x, k.g_at_rb);
                        let other = if c0 == RED { BLUE } else { RED };
                        v[other] = tap(x, k.diagonal);
                    }
                    rr[x] = v[RED];
                    rg[x] = v[GREEN];
                    rb[x] = v[BLUE];
                }
            },
        );
}

/// Hable's filmic curve without normalisation.
fn hable(x: f64) -> f64 {
    const A: f64 = 0.15;
    const B: f64 = 0.50;
    const C: f64 = 0.10;
    const D: f64 = 0.20;
    const E: f64 = 0.02;
    const F: f64 = 0.30;
    ((x * (A * x + C * B) + D * E) / (x * (A * x + B) + D * F)) - E / F
}

/// The global tone curve: exposure-scaled linear value (≥ 0) → display-linear value in [0, 1].
/// Monotonically non-decreasing for every mode.
pub fn tone_curve(mode: ToneMap, white_point: f64, x: f64) -> f64 {
    let x = x.max(0.0);
    let y = match mode {
        ToneMap::Clip => x,
        ToneMap::Reinhard => x * (1.0 + x / (white_point * white_point)) / (1.0 + x),
        ToneMap::Filmic => {
            const W: f64 = 11.2;
            const BIAS: f64 = 2.0;
            hable(BIAS * x.min(W / BIAS)) / hable(W)
        }
    };
    y.clamp(0.0, 1.0)
}

/// [`tone_curve`] in f32 arithmetic (the per-pixel path of [`Isp::process`]; agrees with the f64
/// curve to ≈ 1e-6, far below the 8-bit output step).
#[inline]
pub fn tone_curve_f32(mode: ToneMap, white_point: f32, x: f32) -> f32 {
    let x = x.max(0.0);
    let y = match mode {
        ToneMap::Clip => x,
        ToneMap::Reinhard => x * (1.0 + x / (white_point * white_point)) / (1.0 + x),
        ToneMap::Filmic => {
            const W: f32 = 11.2;
            const BIAS: f32 = 2.0;
            let hable = |x: f32| -> f32 {
                const A: f32 = 0.15;
                const B: f32 = 0.50;
                const C: f32 = 0.10;
                const D: f32 = 0.20;
                const E: f32 = 0.02;
                const F: f32 = 0.30;
                ((x * (A * x + C * B) + D * E) / (x * (A * x + B) + D * F)) - E / F
            };
            hable(BIAS * x.min(W / BIAS)) / hable(W)
        }
    };
    y.clamp(0.0, 1.0)
}

/// Size of the sRGB encoding table (linear [0, 1] → u8).
const SRGB_LUT_SIZE: usize = 65_536;

/// The ISP (keeps white-balance / tone state across frames).
pub struct Isp {
    cfa: Cfa,
    config: IspConfig,
    /// Colour-correction matrix (white-balanced camera RGB → linear sRGB).
    ccm: [[f64; 3]; 3],
    /// Planned white-balance gains (daylight / fixed / none).
    planned_gains: [f64; 3],
    /// Gains used in the last frame.
    last_gains: [f64; 3],
    /// Exposure scale used in the last frame (relative luminance per DN).
    last_scale: f64,
    srgb_lut: Vec<u8>,
    mosaic: Vec<f32>,
    rgb: ChannelImage,
    row_sums: Vec<[f64; 3]>,
    row_log: Vec<f64>,
}

impl Isp {
    /// Plan the ISP for a sensor: the colour-correction matrix is fitted to the sensor's
    /// spectral response.
    pub fn new(
        config: &IspConfig,
        cfa: Cfa,
        response: &SpectralResponse,
    ) -> Result<Isp, ModelError> {
        config.validate()?;
        let bands = &response.bands.centres_nm;
        for (c, w) in response.weights.iter().enumerate() {
            if w.len() != bands.len() || w.iter().any(|v| !v.is_finite()) {
                return Err(ModelError::Config(format!(
                    "`camera.spectral`: response channel {c} has {} finite weights for {} bands",
                    w.iter().filter(|v| v.is_finite()).count(),
                    bands.len()
                )));
            }
        }
        let illuminant: Vec<f64> = bands.iter().map(|&l| d65_at(l)).collect();
        let ones = vec![1.0; bands.len()];
        let white = camera_response(response, &illuminant, &ones);
        let daylight: [f64; 3] = std::array::from_fn(|c| {
            if white[c] > 0.0 && white[GREEN] > 0.0 {
                white[GREEN] / white[c]
            } else {
                1.0
            }
        });
        let planned_gains = match config.white_balance {
            WhiteBalance::Daylight => daylight,
            WhiteBalance::Fixed => config.wb_gains,
            WhiteBalance::Auto | WhiteBalance::None => [1.0; 3],
        };
        let ccm = match config.colour_correction {
            ColourCorrection::Identity => [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            ColourCorrection::Fixed => config.ccm,
            ColourCorrection::Fitted => {
                // The fit is for daylight-balanced camera RGB normalised so that white = (1, 1, 1).
                let norm = if white[GREEN] > 0.0 {
                    white[GREEN]
                } else {
                    1.0
                };
                let set = training_reflectances(bands);
                let cam: Vec<[f64; 3]> = set
                    .iter()
                    .map(|r| {
                        let c = camera_response(response, &illuminant, r);
                        std::array::from_fn(|k| c[k] * daylight[k] / norm)
                    })
                    .collect();
                let target: Vec<[f64; 3]> = set
                    .iter()
                    .map(|r| reflectance_to_linear_srgb(bands, &illuminant, r))
                    .collect();
                fit_ccm(&cam, &target)
            }
        };
        let srgb_lut = (0..SRGB_LUT_SIZE)
            .map(|i| {
                let l = i as f64 / (SRGB_LUT_SIZE - 1) as f64;
                (255.0 * srgb_encode(l)).round() as u8
            })
            .collect();
        Ok(Isp {
            cfa,
            config: config.clone(),
            ccm,
            planned_gains,
            last_gains: planned_gains,
            last_scale: 0.0,
            srgb_lut,
            mosaic: Vec::new(),
            rgb: ChannelImage::default(),
            row_sums: Vec::new(),
            row_log: Vec::new(),
        })
    }

    /// The colour-correction matrix in use (white-balanced camera RGB → linear sRGB).
    pub fn ccm(&self) -> [[f64; 3]; 3] {
        self.ccm
    }

    /// White-balance gains (R, G, B) of the last frame (the planned ones before the first).
    pub fn white_balance_gains(&self) -> [f64; 3] {
        self.last_gains
    }

    /// Exposure scale of the last frame (exposure-scaled value per unit of relative luminance).
    pub fn exposure_scale(&self) -> f64 {
        self.last_scale
    }

    /// Process a linear (HDR-merged) RAW mosaic into 8-bit sRGB; also writes the linear relative
    /// luminance (Y of linear sRGB, white-balanced, before tone mapping) of every pixel.
    pub fn process(&mut self, raw: &RawImage, out: &mut RgbImage, luminance: &mut Vec<f32>) {
        let (w, h) = (raw.width, raw.height);
        let n = w * h;
        out.width = w;
        out.height = h;
        out.data.resize(n * 3, 0);
        luminance.resize(n, 0.0);
        if n == 0 || raw.data.len() < n {
            out.data.fill(0);
            luminance.fill(0.0);
            return;
        }
        // 1. Black level.
        let black = raw.black_level_dn as f32;
        self.mosaic.resize(n, 0.0);
        self.mosaic
            .par_chunks_mut(w)
            .zip(raw.data[..n].par_chunks(w))
            .for_each(|(m, r)| {
                for (m, &v) in m.iter_mut().zip(r) {
                    *m = (v as f32 - black).max(0.0);
                }
            });
        // 2. Demosaic.
        demosaic(
            &self.mosaic,
            w,
            h,
            self.cfa,
            self.config.demosaic,
            &mut self.rgb,
        );
        // 3. White balance.
        let gains = if self.config.white_balance == WhiteBalance::Auto {
            self.row_sums.resize(h, [0.0; 3]);
            let [pr, pg, pb] = &self.rgb.planes;
            self.row_sums.par_iter_mut().enumerate().for_each(|(y, s)| {
                let row = y * w..(y + 1) * w;
                *s = [
                    pr[row.clone()].iter().map(|&v| v as f64).sum(),
                    pg[row.clone()].iter().map(|&v| v as f64).sum(),
                    pb[row].iter().map(|&v| v as f64).sum(),
                ];
            });
            let mut m = [0.0; 3];
            for s in &self.row_sums {
                for c in 0..3 {
                    m[c] += s[c];
                }
            }
            std::array::from_fn(|c| {
                if m[c] > 0.0 && m[GREEN] > 0.0 {
                    (m[GREEN] / m[c]).clamp(1e-3, 1e3)
                } else {
                    1.0
                }
            })
        } else {
            self.planned_gains
        };
        self.last_gains = gains;
        // 4.–5. Highlight clip, colour correction and luminance.
        let g32: [f32; 3] = std::array::from_fn(|c| gains[c] as f32);
        let clip = ((raw.max_dn() as f64 - raw.black_level_dn).max(0.0)
            * gains.iter().copied().fold(f64::INFINITY, f64::min)) as f32;
        let m: [[f32; 3]; 3] =
            std::array::from_fn(|r| std::array::from_fn(|c| self.ccm[r][c] as f32));
        let luma: [f32; 3] = std::array::from_fn(|c| LUMA_WEIGHTS[c] as f32);
        self.row_log.resize(h, 0.0);
        {
            let [pr, pg, pb] = &mut self.rgb.planes;
            pr.par_chunks_mut(w)
                .zip(pg.par_chunks_mut(w))
                .zip(pb.par_chunks_mut(w))
                .zip(luminance.par_chunks_mut(w))
                .zip(self.row_log.par_iter_mut())
                .for_each(|((((rr, rg), rb), ly), lg)| {
                    // Σ ln(1 + y) as ln of products of 24 factors (each 1 + y ≤ 1 + 10¹², so a
                    // product stays below 10²⁸⁹, inside f64's range): one logarithm per 24 pixels.
                    let mut acc = 0.0f64;
                    let mut prod = 1.0f64;
                    for x in 0..w {
                        let cam = [
                            (rr[x] * g32[0]).min(clip),
                            (rg[x] * g32[1]).min(clip),
                            (rb[x] * g32[2]).min(clip),
                        ];
                        let s: [f32; 3] = std::array::from_fn(|r| {
                            m[r][0] * cam[0] + m[r][1] * cam[1] + m[r][2] * cam[2]
                        });
                        rr[x] = s[0];
                        rg[x] = s[1];
                        rb[x] = s[2];
                        let y = (luma[0] * s[0] + luma[1] * s[1] + luma[2] * s[2]).max(0.0);
                        ly[x] = y;
                        prod *= 1.0 + f64::from(y.min(1e12));
                        if x % 24 == 23 {
                            acc += prod.ln();
                            prod = 1.0;
                        }
                    }
                    *lg = acc + prod.ln();
                });
        }
        // 6. Exposure.
        let scale = match self.config.exposure_scale {
            Some(s) => s,
            None => {
                let log_avg = (self.row_log.iter().sum::<f64>() / n as f64).exp() - 1.0;
                self.config.exposure_key / log_avg.max(1e-6)
            }
        };
        self.last_scale = scale;
        // 6.–7. Tone curve and sRGB encoding.
        let (mode, wp) = (self.config.tone_map, self.config.white_point);
        let lut = &self.srgb_lut;
        let top = (SRGB_LUT_SIZE - 1) as f64;
        let [pr, pg, pb] = &self.rgb.planes;
        out.data.par_chunks_mut(3 * w).enumerate().for_each_init(
            Vec::<u32>::new,
            |codes, (y, row)| {
                let (wp, scale, top) = (wp as f32, scale as f32, top as f32);
                let range = y * w..(y + 1) * w;
                let planes = [&pr[range.clone()], &pg[range.clone()], &pb[range]];
                codes.resize(w, 0);
                for (c, plane) in planes.into_iter().enumerate() {
                    // The curve over the row (one mode per loop: vectorises), then the table.
                    fn curve(
                        f: impl Fn(f32) -> f32,
                        plane: &[f32],
                        scale: f32,
                        top: f32,
                        codes: &mut [u32],
                    ) {
                        for (k, &v) in codes.iter_mut().zip(plane) {
                            // f(·) ∈ [0, 1]: round half up by truncation.
                            *k = (f(scale * v) * top + 0.5) as u32;
                        }
                    }
                    let tone = |m: ToneMap| move |x: f32| tone_curve_f32(m, wp, x);
                    match mode {
                        ToneMap::Clip => curve(tone(ToneMap::Clip), plane, scale, top, codes),
                        ToneMap::Reinhard => {
                            curve(tone(ToneMap::Reinhard), plane, scale, top, codes)
                        }
                        ToneMap::Filmic => curve(tone(ToneMap::Filmic), plane, scale, top, codes),
                    }
                    for (x, &k) in codes.iter().enumerate() {
                        row[3 * x + c] = lut[k as usize];
                    }
                }
            },
        );
    }

    pub fn reset(&mut self) {
        self.last_gains = self.planned_gains;
        self.last_scale = 0.0;
    }
}
