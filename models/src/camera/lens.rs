//! Camera lens: intrinsics, Brown–Conrady distortion, vignetting, PSF blur, sun flare and ghosts.
//!
//! # Geometry
//! Sensor frame: x forward (optical axis), y left, z up. Image: u right, v down, pixel (i, j) covers
//! `[i, i+1) × [j, j+1)` so its centre is at `(i + 0.5, j + 0.5)`; the principal point is the image
//! centre plus `principal_point_offset_px`.
//!
//! * **Brown–Conrady** (OpenCV convention, Brown 1966; OpenCV calib3d, physics.md §3.2): a direction
//!   `d` maps to the normalised pinhole point `x' = −d_y/d_x`, `y' = −d_z/d_x`, then
//!   `x'' = x'·(1 + k1r² + k2r⁴ + k3r⁶)/(1 + k4r² + k5r⁴ + k6r⁶) + 2p1x'y' + p2(r² + 2x'²)`,
//!   `y'' = y'·(…) + p1(r² + 2y'²) + 2p2x'y'`, `u = f_x x'' + c_x`, `v = f_y y'' + c_y`.
//! * **Kannala–Brandt** fisheye (Kannala & Brandt, IEEE TPAMI 28(8):1335, 2006; OpenCV `fisheye`):
//!   θ = angle to the axis, `θ_d = θ(1 + k1θ² + k2θ⁴ + k3θ⁶ + k4θ⁸)`, `(x'', y'') = θ_d·(x', y')/r`.
//!
//! [`Lens::new`] inverts the model once per pixel centre (Newton iterations on the 2 × 2 Jacobian,
//! converged to < 1e-6 px) and keeps the unit ray directions; [`Lens::project`] is the forward
//! model. When no focal length is configured it follows from the horizontal field of view *through
//! the configured distortion*: the ray at the left/right image edge (through the principal point's
//! row) makes the angle `fov/2` with the axis. `camera.distortion` off keeps that focal length and
//! principal point and drops the distortion (Brown–Conrady → pinhole; Kannala–Brandt → the ideal
//! equidistant fisheye θ_d = θ).
//!
//! # Radiometry (the camera equation)
//! Image-plane irradiance of a scene of radiance L through a lens of f-number N and transmittance
//! T: `E = π L T cos⁴θ / (4 N²)` (Aggarwal, Hua & Ahuja, ICCV 2001; physics.md §3.2), so a pixel of
//! area `A = pitch²` collects `rate = L · (π/4)·(T/N²)·A · RI(θ)` [e⁻/s] for `L` in
//! e⁻ s⁻¹ m⁻² sr⁻¹ (the renderer's photo-electron radiance). `RI(θ) = cos⁴θ × table(θ or image
//! height)` is the relative illumination (`camera.vignetting`; off: 1), θ the field angle of the
//! pixel's ray. For strongly distorted or fisheye lenses cos⁴θ of the pinhole law is not the real
//! fall-off: give the measured relative-illumination table (it multiplies cos⁴θ).
//!
//! # PSF
//! A separable Gaussian of `σ = √(σ_lens² + σ_diff²)` px with `σ_diff = 0.42 λ N / pitch`, the
//! best Gaussian fit to the in-focus Airy pattern (Zhang, Zerubia & Olivo-Marin, Appl. Opt.
//! 46(10):1819, 2007: σ = 0.21 λ/NA with NA = 1/2N). The blur conserves the image's total signal: each
//! source pixel's kernel is renormalised over the pixels inside the image (light the kernel would
//! throw off the edge stays on the array, standing in for the light that comes in from outside).
//! Flicker samples (sparse LED pixels) are not blurred.
//!
//! # Flare (`camera.flare`, only when the renderer reports the sun in front of the camera)
//! The sun's power collected by the lens, `P_c = (π/4)(T/N²)·A·f_x f_y·L_sun,c·Ω_sun·RI(θ_sun)`
//! [e⁻/s], is partly redistributed (added; the disc itself is the renderer's):
//! * **veiling glare**: a uniform veil carrying `veiling_glare_fraction · P` over the image (the
//!   uniform stray-light floor that ISO 9358 measures as the veiling glare index);
//! * **halo**: `halo_fraction · P` spread by the normalised kernel
//!   `k(r) = (1 + r²/a²)^(−3/2) / (2πa²)` around the sun's image (a heavy-tailed scatter halo; a
//!   parametric stand-in for the glare spread function, guessed shape);
//! * **ghosts**: images of the aperture formed by pairs of internal reflections. After Hullin,
//!   Eisemann, Seidel & Lee, "Physically-based real-time lens flare rendering", ACM TOG 30(4) (SIGGRAPH
//!   2011): for a rotationally symmetric lens every ghost lies on the line from the light source's
//!   image through the optical centre, at a position that (paraxially) scales linearly with the
//!   source position, and has the shape of the aperture (polygonal for a bladed iris). Here ghost
//!   `g` is a uniform disc or hexagon of radius `radius_rel · h` (h = image half-diagonal) centred at
//!   `c + ratio·(s − c)` (s the sun's image, c the principal point; ratio < 0 mirrors through the
//!   centre) carrying `strength · P`. A parametric approximation: ratios, sizes and strengths are
//!   configuration (defaults guessed, of the order of two AR-coated surface reflections, 0.5 %² ≈
//!   2.5e-5 each, times the number of surface pairs).
//! * the sun **outside the image** but within `flare_margin_rel · h` of its border still makes
//!   veil, halo and ghosts, fading linearly to zero at the margin (light entering the front element
//!   from just outside the field of view still reflects inside the lens).

use glam::{DVec2, DVec3, Vec3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::{CHANNELS, ChannelImage, Flicker, SunInView};
use crate::effects::{EffectInfo, Effects};
use crate::error::ModelError;

/// Relative illumination (natural vignetting × measured lens table).
pub const VIGNETTING: EffectInfo = EffectInfo {
    name: "camera.vignetting",
    default_on: true,
    summary: "relative illumination E(θ)/E(0) = cos⁴θ × measured table (field angle or image height); \
              off: 1 (the camera equation E = πLT/4N² itself always applies)",
    source: "cos⁴ law: Aggarwal, Hua & Ahuja, ICCV 2001 (physics.md §3.2); table: lens data sheet",
    requires: None,
};

/// Lens distortion.
pub const DISTORTION: EffectInfo = EffectInfo {
    name: "camera.distortion",
    default_on: true,
    summary: "Brown–Conrady x'' = x'(1+k1r²+k2r⁴+k3r⁶)/(1+k4r²+k5r⁴+k6r⁶) + 2p1x'y' + p2(r²+2x'²) or \
              Kannala–Brandt θ_d = θ(1+k1θ²+…+k4θ⁸); off: pinhole (equidistant fisheye)",
    source: "Brown, Photogramm. Eng. 32(3), 1966; OpenCV calib3d docs; Kannala & Brandt, IEEE TPAMI \
             28(8):1335, 2006 (physics.md §3.2)",
    requires: None,
};

/// Point-spread function blur.
pub const PSF_BLUR: EffectInfo = EffectInfo {
    name: "camera.psf_blur",
    default_on: true,
    summary: "separable Gaussian PSF, σ = √(σ_lens² + (0.42·λ·N/pitch)²) px (lens aberrations + \
              diffraction), energy conserving",
    source: "Gaussian fit to the Airy disc σ = 0.21 λ/NA: Zhang, Zerubia & Olivo-Marin, Appl. Opt. \
             46(10):1819, 2007",
    requires: None,
};

/// Sun flare: veiling glare, halo and ghosts.
pub const FLARE: EffectInfo = EffectInfo {
    name: "camera.flare",
    default_on: true,
    summary: "sun flare: of P = (π/4)(T/N²)A·f_x f_y·L_sun·Ω_sun a uniform veil (veiling_glare_fraction), \
              a halo (1+r²/a²)^(−3/2)/(2πa²) and aperture-shaped ghosts at c + ratio·(s − c)",
    source: "ghost geometry: Hullin, Eisemann, Seidel & Lee, ACM TOG 30(4), SIGGRAPH 2011; veiling \
             glare: ISO 9358; parametric approximation with guessed strengths",
    requires: None,
};

/// Lens effects (`camera.vignetting`, `camera.distortion`, `camera.psf_blur`, `camera.flare`).
pub const EFFECTS: &[EffectInfo] = &[VIGNETTING, DISTORTION, PSF_BLUR, FLARE];

/// Projection / distortion model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LensModel {
    /// Pinhole with Brown–Conrady radial (rational k1..k6) and tangential (p1, p2) distortion.
    #[default]
    BrownConrady,
    /// Kannala–Brandt fisheye (coefficients `fisheye_k`).
    KannalaBrandt,
}

/// What the abscissa of a relative-illumination table is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum IlluminationAxis {
    /// Field angle of the pixel's ray, rad.
    #[default]
    FieldAngleRad,
    /// Image height: distance of the pixel centre from the principal point divided by the image
    /// half-diagonal (0 = centre, 1 = corner of a centred image).
    ImageHeight,
}

/// A measured relative-illumination table (multiplies cos⁴θ), linearly interpolated, held
/// constant beyond its ends.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RelativeIllumination {
    pub axis: IlluminationAxis,
    /// `[abscissa, factor]` pairs, abscissa strictly increasing, factor ≥ 0.
    pub points: Vec<[f64; 2]>,
}

impl RelativeIllumination {
    /// The factor at an abscissa (linear interpolation, constant beyond the ends).
    pub fn factor(&self, x: f64) -> f64 {
        let p = &self.points;
        match p.len() {
            0 => 1.0,
            1 => p[0][1],
            n => {
                if x <= p[0][0] {
                    return p[0][1];
                }
                if x >= p[n - 1][0] {
                    return p[n - 1][1];
                }
                let i = p.partition_point(|q| q[0] <= x).clamp(1, n - 1);
                let (a, b) = (p[i - 1], p[i]);
                a[1] + (b[1] - a[1]) * (x - a[0]) / (b[0] - a[0])
            }
        }
    }
}

/// Shape of a ghost (the aperture's image).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GhostShape {
    /// A six-bladed iris.
    #[default]
    Hexagon,
    /// A round aperture.
    Disc,
}

/// One lens ghost.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GhostConfig {
    /// Position on the line from the principal point c to the sun's image s: centre = c + ratio·(s − c)
    /// (negative: on the far side of the centre).
    pub ratio: f64,
    /// Circumradius as a fraction of the image half-diagonal.
    pub radius_rel: f64,
    /// Fraction of the sun's collected power in this ghost.
    pub strength: f64,
    pub shape: GhostShape,
}

impl Default for GhostConfig {
    fn default() -> Self {
        GhostConfig {
            ratio: -1.0,
            radius_rel: 0.05,
            strength: 1e-4,
            shape: GhostShape::Hexagon,
        }
    }
}

/// Lens parameters (`"lens"` key of the camera config).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LensConfig {
    /// Focal length, m (converted with the pixel pitch). Absent (and no `fx_px`): from the sensor's
    /// `fov_horizontal_rad` through the distortion model.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub focal_length_m: Option<f64>,
    /// Horizontal focal length, px (wins over `focal_length_m`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fx_px: Option<f64>,
    /// Vertical focal length, px (absent: = f_x, square pixels).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fy_px: Option<f64>,
    /// Principal point minus the image centre, px (u right, v down).
    pub principal_point_offset_px: [f64; 2],
    /// f-number N = f / D (default 2.0: guessed, automotive front cameras are f/1.6–f/2.4).
    pub f_number: f64,
    /// Lens transmittance T (default 0.9: guessed, multi-element AR-coated glass).
    pub transmittance: f64,
    pub model: LensModel,
    /// Brown–Conrady radial coefficients (OpenCV order k1, k2, k3 in the numerator, k4, k5, k6 in
    /// the denominator). Default k1 = −0.08, k2 = 0.01 (guessed mild barrel lens).
    pub k1: f64,
    pub k2: f64,
    pub k3: f64,
    pub k4: f64,
    pub k5: f64,
    pub k6: f64,
    /// Brown–Conrady tangential (decentring) coefficients.
    pub p1: f64,
    pub p2: f64,
    /// Kannala–Brandt coefficients k1..k4 (`model: kannala_brandt`).
    pub fisheye_k: [f64; 4],
    /// Measured relative illumination (multiplies cos⁴θ); absent: cos⁴θ only.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub relative_illumination: Option<RelativeIllumination>,
    /// Gaussian PSF σ of the lens aberrations/defocus, px (default 0.5: guessed).
    pub psf_sigma_px: f64,
    /// Add the diffraction-limited Airy σ = 0.42 λ N / pitch in quadrature.
    pub psf_diffraction: bool,
    /// Wavelength of the diffraction term, nm (default 550, the middle of the visible band).
    pub psf_wavelength_nm: f64,
    /// Fraction of the sun's collected power spread uniformly over the image (default 0.005:
    /// guessed, the order of ISO 9358 veiling glare indices of good lenses, 0.5–3 %).
    pub veiling_glare_fraction: f64,
    /// Fraction of the sun's power in the scatter halo (default 0.01: guessed).
    pub halo_fraction: f64,
    /// Halo core radius a as a fraction of the image half-diagonal (default 0.02: guessed).
    pub halo_radius_rel: f64,
    /// The ghosts (default: five ghosts, guessed positions, sizes and strengths).
    pub ghosts: Vec<GhostConfig>,
    /// How far outside the image (fraction of the half-diagonal) the sun still makes flare
    /// (default 0.5: guessed).
    pub flare_margin_rel: f64,
}

impl Default for LensConfig {
    fn default() -> Self {
        let ghost = |ratio, radius_rel, strength, shape| GhostConfig {
            ratio,
            radius_rel,
            strength,
            shape,
        };
        LensConfig {
            focal_length_m: None,
            fx_px: None,
            fy_px: None,
            principal_point_offset_px: [0.0, 0.0],
            f_number: 2.0,
            transmittance: 0.9,
            model: LensModel::BrownConrady,
            k1: -0.08,
            k2: 0.01,
            k3: 0.0,
            k4: 0.0,
            k5: 0.0,
            k6: 0.0,
            p1: 0.0,
            p2: 0.0,
            fisheye_k: [0.0; 4],
            relative_illumination: None,
            psf_sigma_px: 0.5,
            psf_diffraction: true,
            psf_wavelength_nm: 550.0,
            veiling_glare_fraction: 0.005,
            halo_fraction: 0.01,
            halo_radius_rel: 0.02,
            ghosts: vec![
                ghost(-0.4, 0.03, 3e-5, GhostShape::Hexagon),
                ghost(-0.8, 0.06, 3e-5, GhostShape::Hexagon),
                ghost(-1.2, 0.10, 2e-5, GhostShape::Disc),
                ghost(0.4, 0.02, 2e-5, GhostShape::Hexagon),
                ghost(1.5, 0.15, 2e-5, GhostShape::Disc),
            ],
            flare_margin_rel: 0.5,
        }
    }
}

fn config_err(key: &str, msg: impl std::fmt::Display) -> ModelError {
    ModelError::Config(format!("`camera.lens.{key}` {msg}"))
}

fn check_finite(key: &str, v: f64) -> Result<(), ModelError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(config_err(key, format!("must be finite, got {v}")))
    }
}

fn check_range(key: &str, v: f64, lo: f64, hi: f64) -> Result<(), ModelError> {
    crate::error::check_range("camera.lens", key, v, lo, hi)
}

impl LensConfig {
    pub fn validate(&self) -> Result<(), ModelError> {
        if let Some(f) = self.focal_length_m
            && !(f.is_finite() && f > 0.0 && f < 1.0)
        {
            return Err(config_err(
                "focal_length_m",
                format!("must be in (0, 1) m, got {f}"),
            ));
        }
        for (key, v) in [("fx_px", self.fx_px), ("fy_px", self.fy_px)] {
            if let Some(f) = v
                && !(f.is_finite() && f > 0.0 && f < 1e7)
            {
                return Err(config_err(key, format!("must be in (0, 1e7) px, got {f}")));
            }
        }
        for (i, v) in self.principal_point_offset_px.iter().enumerate() {
            if !(v.is_finite() && v.abs() < 1e5) {
                return Err(config_err(
                    "principal_point_offset_px",
                    format!("[{i}] must be finite and below 1e5 px, got {v}"),
                ));
            }
        }
        check_range("f_number", self.f_number, 0.5, 64.0)?;
        if !(self.transmittance > 0.0 && self.transmittance <= 1.0) {
            return Err(config_err(
                "transmittance",
                format!("must be in (0, 1], got {}", self.transmittance),
            ));
        }
        for (key, v) in [
            ("k1", self.k1),
            ("k2", self.k2),
            ("k3", self.k3),
            ("k4", self.k4),
            ("k5", self.k5),
            ("k6", self.k6),
            ("p1", self.p1),
            ("p2", self.p2),
        ] {
            check_finite(key, v)?;
        }
        for v in self.fisheye_k {
            check_finite("fisheye_k", v)?;
        }
        if let Some(ri) = &self.relative_illumination {
            if ri.points.is_empty() {
                return Err(config_err(
                    "relative_illumination.points",
                    "must have at least one [abscissa, factor] pair",
                ));
            }
            for (i, p) in ri.points.iter().enumerate() {
                if !(p[0].is_finite() && p[0] >= 0.0 && p[1].is_finite() && p[1] >= 0.0) {
                    return Err(config_err(
                        "relative_illumination.points",
                        format!("[{i}] must be finite and ≥ 0, got {p:?}"),
                    ));
                }
                if i > 0 && p[0] <= ri.points[i - 1][0] {
                    return Err(config_err(
                        "relative_illumination.points",
                        format!("abscissae must increase strictly (entry {i})"),
                    ));
                }
            }
        }
        check_range("psf_sigma_px", self.psf_sigma_px, 0.0, 50.0)?;
        check_range("psf_wavelength_nm", self.psf_wavelength_nm, 200.0, 2000.0)?;
        check_range(
            "veiling_glare_fraction",
            self.veiling_glare_fraction,
            0.0,
            1.0,
        )?;
        check_range("halo_fraction", self.halo_fraction, 0.0, 1.0)?;
        if !(self.halo_radius_rel.is_finite()
            && self.halo_radius_rel > 0.0
            && self.halo_radius_rel <= 10.0)
        {
            return Err(config_err(
                "halo_radius_rel",
                format!("must be in (0, 10], got {}", self.halo_radius_rel),
            ));
        }
        check_range("flare_margin_rel", self.flare_margin_rel, 0.0, 10.0)?;
        for (i, g) in self.ghosts.iter().enumerate() {
            if !(g.ratio.is_finite() && g.ratio.abs() <= 10.0) {
                return Err(config_err(
                    "ghosts",
                    format!("[{i}].ratio must be in [−10, 10], got {}", g.ratio),
                ));
            }
            if !(g.radius_rel.is_finite() && g.radius_rel > 0.0 && g.radius_rel <= 2.0) {
                return Err(config_err(
                    "ghosts",
                    format!("[{i}].radius_rel must be in (0, 2], got {}", g.radius_rel),
                ));
            }
            if !(g.strength.is_finite() && (0.0..=1.0).contains(&g.strength)) {
                return Err(config_err(
                    "ghosts",
                    format!("[{i}].strength must be in [0, 1], got {}", g.strength),
                ));
            }
        }
        Ok(())
    }
}

/// The projection model in force (distortion coefficients zero when `camera.distortion` is off).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Model {
    Brown { k: [f64; 6], p: [f64; 2] },
    Fisheye { k: [f64; 4] },
}

impl Model {
    /// Brown–Conrady radial factor A/B and its derivative with respect to r².
    fn radial(k: &[f64; 6], r2: f64) -> (f64, f64) {
        let a = 1.0 + r2 * (k[0] + r2 * (k[1] + r2 * k[2]));
        let b = 1.0 + r2 * (k[3] + r2 * (k[4] + r2 * k[5]));
        let da = k[0] + r2 * (2.0 * k[1] + 3.0 * r2 * k[2]);
        let db = k[3] + r2 * (2.0 * k[4] + 3.0 * r2 * k[5]);
        (a / b, (da * b - a * db) / (b * b))
    }

    /// Kannala–Brandt θ_d(θ) and dθ_d/dθ.
    fn theta_d(k: &[f64; 4], t: f64) -> (f64, f64) {
        let t2 = t * t;
        let poly = 1.0 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3])));
        let dpoly = t2 * (3.0 * k[0] + t2 * (5.0 * k[1] + t2 * (7.0 * k[2] + t2 * 9.0 * k[3])));
        (t * poly, 1.0 + dpoly)
    }

    /// Brown–Conrady: undistorted normalised point → distorted, with the Jacobian
    /// [[∂x''/∂x', ∂x''/∂y'], [∂y''/∂x', ∂y''/∂y']].
    fn distort_brown(k: &[f64; 6], p: &[f64; 2], x: f64, y: f64) -> (DVec2, [f64; 4]) {
        let r2 = x * x + y * y;
        let (rad, drad) = Self::radial(k, r2);
        let (p1, p2) = (p[0], p[1]);
        let xd = x * rad + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
        let yd = y * rad + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
        let j = [
            rad + 2.0 * x * x * drad + 2.0 * p1 * y + 6.0 * p2 * x,
            2.0 * x * y * drad + 2.0 * p1 * x + 2.0 * p2 * y,
            2.0 * x * y * drad + 2.0 * p1 * x + 2.0 * p2 * y,
            rad + 2.0 * y * y * drad + 6.0 * p1 * y + 2.0 * p2 * x,
        ];
        (DVec2::new(xd, yd), j)
    }
}

/// A planned lens for one image size.
pub struct Lens {
    width: usize,
    height: usize,
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
    model: Model,
    /// Largest undistorted radius (Brown: r = |x'|; fisheye: θ) up to which the distortion is
    /// monotonic (projection beyond is rejected: the polynomial folds back).
    r_valid: f64,
    rays: Vec<Vec3>,
    /// cos⁴θ × table per pixel (1 with `camera.vignetting` off).
    relative_illumination: Vec<f32>,
    /// (π/4)·T/N²·pitch², m² sr (radiance → rate per pixel on the axis).
    throughput_m2_sr: f64,
    vignetting: bool,
    ri_table: Option<RelativeIllumination>,
    half_diagonal_px: f64,
    /// Normalised Gaussian taps (empty: no blur) and the reciprocal in-image kernel sums per
    /// column / row index (energy-conserving borders).
    psf_sigma_px: f64,
    taps: Vec<f32>,
    inv_norm_x: Vec<f32>,
    inv_norm_y: Vec<f32>,
    flare: bool,
    config: LensConfig,
}

/// Newton iterations of the undistortion.
const MAX_NEWTON: usize = 60;

impl Lens {
    /// Plan the lens: `fov_horizontal_rad` gives the focal length when the config has none.
    pub fn new(
        config: &LensConfig,
        width: usize,
        height: usize,
        pixel_pitch_m: f64,
        fov_horizontal_rad: f64,
        effects: &Effects,
    ) -> Result<Lens, ModelError> {
        config.validate()?;
        if width == 0 || height == 0 {
            return Err(ModelError::Config(format!(
                "`camera.width_px`/`camera.height_px` must be > 0, got {width} × {height}"
            )));
        }
        if !(pixel_pitch_m.is_finite() && pixel_pitch_m > 0.0) {
            return Err(ModelError::Config(format!(
                "`camera.pixel_pitch_m` must be > 0, got {pixel_pitch_m}"
            )));
        }
        let distortion = effects.is_on(&DISTORTION);
        let configured = match config.model {
            LensModel::BrownConrady => Model::Brown {
                k: [
                    config.k1, config.k2, config.k3, config.k4, config.k5, config.k6,
                ],
                p: [config.p1, config.p2],
            },
            LensModel::KannalaBrandt => Model::Fisheye {
                k: config.fisheye_k,
            },
        };
        let model = if distortion {
            configured
        } else {
            match configured {
                Model::Brown { .. } => Model::Brown {
                    k: [0.0; 6],
                    p: [0.0; 2],
                },
                Model::Fisheye { .. } => Model::Fisheye { k: [0.0; 4] },
            }
        };
        let r_valid_conf = monotonic_limit(&configured);
        let r_valid = monotonic_limit(&model);

        // Focal length: explicit px, explicit m, or the FoV through the configured model.
        let fx = match (config.fx_px, config.focal_length_m) {
            (Some(f), _) => f,
            (None, Some(f)) => f / pixel_pitch_m,
            (None, None) => {
                if !(fov_horizontal_rad.is_finite() && fov_horizontal_rad > 0.0) {
                    return Err(ModelError::Config(format!(
                        "`fov_horizontal_rad` must be > 0 for the camera lens, got {fov_horizontal_rad}"
                    )));
                }
                let half = 0.5 * fov_horizontal_rad;
                let edge = match configured {
                    Model::Brown { k, .. } => {
                        if half >= 0.5 * std::f64::consts::PI {
                            return Err(ModelError::Config(format!(
                                "`fov_horizontal_rad` must be < π for a Brown–Conrady (pinhole) \
                                 lens, got {fov_horizontal_rad} (use `camera.lens.model: \
                                 kannala_brandt` or a focal length)"
                            )));
                        }
                        let t = half.tan();
                        if t > r_valid_conf {
                            return Err(config_err(
                                "k1",
                                format!(
                                    "the radial distortion (k1..k6) folds back inside the field of \
                                     view (monotonic only up to r = {r_valid_conf:.3}, the FoV edge is at \
                                     r = {t:.3})"
                                ),
                            ));
                        }
                        t * Model::radial(&k, t * t).0
                    }
                    Model::Fisheye { k } => {
                        if half > r_valid_conf {
                            return Err(config_err(
                                "fisheye_k",
                                format!(
                                    "θ_d(θ) folds back inside the field of view (monotonic up to \
                                     θ = {r_valid_conf:.3} rad, the FoV edge is at {half:.3} rad)"
                                ),
                            ));
                        }
                        Model::theta_d(&k, half).0
                    }
                };
                if edge.is_nan() || edge <= 0.0 {
                    return Err(config_err(
                        "k1",
                        "the distortion maps the FoV edge to the centre or beyond",
                    ));
                }
                0.5 * width as f64 / edge
            }
        };
        let fy = config.fy_px.unwrap_or(fx);
        let cx = 0.5 * width as f64 + config.principal_point_offset_px[0];
        let cy = 0.5 * height as f64 + config.principal_point_offset_px[1];
        let half_diagonal_px = 0.5 * ((width * width + height * height) as f64).sqrt();

        let vignetting = effects.is_on(&VIGNETTING);
        let ri_table = config.relative_illumination.clone();
        let mut lens = Lens {
            width,
            height,
            fx,
            fy,
            cx,
            cy,
            model,
            r_valid,
            rays: vec![Vec3::X; width * height],
            relative_illumination: vec![1.0; width * height],
            throughput_m2_sr: 0.25 * std::f64::consts::PI * config.transmittance
                / (config.f_number * config.f_number)
                * pixel_pitch_m
                * pixel_pitch_m,
            vignetting,
            ri_table,
            half_diagonal_px,
            psf_sigma_px: 0.0,
            taps: Vec::new(),
            inv_norm_x: Vec::new(),
            inv_norm_y: Vec::new(),
            flare: effects.is_on(&FLARE),
            config: config.clone(),
        };

        // Rays and relative illumination per pixel centre (rows in parallel).
        let mut rays = std::mem::take(&mut lens.rays);
        let mut ri = std::mem::take(&mut lens.relative_illumination);
        let worst = {
            let l = &lens;
            rays.par_chunks_mut(width)
                .zip(ri.par_chunks_mut(width))
                .enumerate()
                .map(|(row, (rays_row, ri_row))| {
                    let mut worst = 0.0f64;
                    let v = row as f64 + 0.5;
                    for (col, (ray, ri)) in rays_row.iter_mut().zip(ri_row.iter_mut()).enumerate() {
                        let u = col as f64 + 0.5;
                        match l.unproject(DVec2::new(u, v)) {
                            Some(d) => {
                                *ray = d.as_vec3();
                                *ri = l.relative_illumination_of(d, u, v) as f32;
                            }
                            None => worst = f64::INFINITY,
                        }
                    }
                    worst
                })
                .reduce(|| 0.0, f64::max)
        };
        if !worst.is_finite() {
            let key = match config.model {
                LensModel::BrownConrady => "k1",
                LensModel::KannalaBrandt => "fisheye_k",
            };
            return Err(config_err(
                key,
                "the distortion cannot be inverted over the whole image (it folds back before the \
                 image corners): reduce the distortion or the field of view",
            ));
        }
        lens.rays = rays;
        lens.relative_illumination = ri;

        // PSF.
        if effects.is_on(&PSF_BLUR) {
            let diff = if config.psf_diffraction {
                0.42 * config.psf_wavelength_nm * 1e-9 * config.f_number / pixel_pitch_m
            } else {
                0.0
            };
            let sigma = (config.psf_sigma_px.powi(2) + diff * diff).sqrt();
            if sigma > 1e-3 {
                let r = (4.0 * sigma).ceil().max(1.0) as usize;
                let mut taps: Vec<f64> = (0..=2 * r)
                    .map(|i| {
                        let d = i as f64 - r as f64;
                        (-0.5 * d * d / (sigma * sigma)).exp()
                    })
                    .collect();
                let s: f64 = taps.iter().sum();
                taps.iter_mut().for_each(|t| *t /= s);
                let inv_norm = |n: usize| -> Vec<f32> {
                    (0..n)
                        .map(|i| {
                            let z: f64 = (0..=2 * r)
                                .filter(|&k| {
                                    let j = i as isize + k as isize - r as isize;
                                    j >= 0 && (j as usize) < n
                                })
                                .map(|k| taps[k])
                                .sum();
                            (1.0 / z) as f32
                        })
                        .collect()
                };
                lens.inv_norm_x = inv_norm(width);
                lens.inv_norm_y = inv_norm(height);
                lens.taps = taps.iter().map(|&t| t as f32).collect();
                lens.psf_sigma_px = sigma;
            }
        }
        Ok(lens)
    }

    pub fn width(&self) -> usize {
        self.width
    }

    pub fn height(&self) -> usize {
        self.height
    }

    /// Focal lengths (f_x, f_y) in pixels.
    pub fn focal_length_px(&self) -> (f64, f64) {
        (self.fx, self.fy)
    }

    /// Principal point (c_x, c_y) in pixels (pixel centres at +0.5).
    pub fn principal_point_px(&self) -> (f64, f64) {
        (self.cx, self.cy)
    }

    /// Unit primary-ray direction of every pixel centre in the sensor frame, row-major.
    pub fn ray_directions(&self) -> &[Vec3] {
        &self.rays
    }

    /// Relative illumination per pixel (cos⁴θ × table; 1 with `camera.vignetting` off), row-major.
    pub fn relative_illumination(&self) -> &[f32] {
        &self.relative_illumination
    }

    /// (π/4)·T/N²·pixel area, m² sr: photo-electron radiance → rate of a pixel on the axis.
    pub fn throughput_m2_sr(&self) -> f64 {
        self.throughput_m2_sr
    }

    /// σ of the Gaussian PSF in force, px (0: no blur).
    pub fn psf_sigma_px(&self) -> f64 {
        self.psf_sigma_px
    }

    /// The configuration the lens was planned from.
    pub fn config(&self) -> &LensConfig {
        &self.config
    }

    /// Image position (u right, v down, px) of a sensor-frame direction; None behind the camera
    /// or outside the image.
    pub fn project(&self, dir_sensor: DVec3) -> Option<DVec2> {
        self.project_unbounded(dir_sensor).filter(|p| {
            p.x >= 0.0 && p.y >= 0.0 && p.x < self.width as f64 && p.y < self.height as f64
        })
    }

    /// Image position of a direction anywhere in the image plane (also outside the image); None
    /// behind the camera (pinhole) or beyond the angle where the distortion folds back.
    pub fn project_unbounded(&self, dir_sensor: DVec3) -> Option<DVec2> {
        let d = dir_sensor;
        if !d.is_finite() {
            return None;
        }
        let n = match self.model {
            Model::Brown { k, p } => {
                if d.x <= 0.0 {
                    return None;
                }
                let (x, y) = (-d.y / d.x, -d.z / d.x);
                if x * x + y * y > self.r_valid * self.r_valid {
                    return None;
                }
                Model::distort_brown(&k, &p, x, y).0
            }
            Model::Fisheye { k } => {
                let lat = (d.y * d.y + d.z * d.z).sqrt();
                let theta = lat.atan2(d.x);
                if theta > self.r_valid {
                    return None;
                }
                if lat < 1e-300 {
                    DVec2::ZERO
                } else {
                    let td = Model::theta_d(&k, theta).0;
                    DVec2::new(-d.y / lat, -d.z / lat) * td
                }
            }
        };
        Some(DVec2::new(self.fx * n.x + self.cx, self.fy * n.y + self.cy))
    }

    /// Unit sensor-frame direction of an image point (u, v in px); None where the inversion does
    /// not converge.
    pub fn unproject(&self, uv: DVec2) -> Option<DVec3> {
        let xd = (uv.x - self.cx) / self.fx;
        let yd = (uv.y - self.cy) / self.fy;
        // Convergence in normalised units equivalent to 1e-6 px.
        let tol = 1e-6 / self.fx.max(self.fy);
        match self.model {
            Model::Brown { k, p } => {
                let (mut x, mut y) = (xd, yd);
                let mut ok = false;
                for _ in 0..MAX_NEWTON {
                    let (f, j) = Model::distort_brown(&k, &p, x, y);
                    let (ex, ey) = (f.x - xd, f.y - yd);
                    if ex.abs() < tol && ey.abs() < tol {
                        ok = true;
                        break;
                    }
                    let det = j[0] * j[3] - j[1] * j[2];
                    if det.is_nan() || det.abs() <= 1e-12 {
                        return None;
                    }
                    let dx = (j[3] * ex - j[1] * ey) / det;
                    let dy = (-j[2] * ex + j[0] * ey) / det;
                    x -= dx;
                    y -= dy;
                    if !(x.is_finite() && y.is_finite()) {
                        return None;
                    }
                }
                if !ok || x * x + y * y > self.r_valid * self.r_valid * (1.0 + 1e-9) {
                    return None;
                }
                Some(DVec3::new(1.0, -x, -y).normalize())
            }
            Model::Fisheye { k } => {
                let td = (xd * xd + yd * yd).sqrt();
                if td < 1e-300 {
                    return Some(DVec3::X);
                }
                let mut t = td;
                let mut ok = false;
                for _ in 0..MAX_NEWTON {
                    let (f, df) = Model::theta_d(&k, t);
                    let e = f - td;
                    if e.abs() < tol {
                        ok = true;
                        break;
                    }
                    if df.is_nan() || df <= 1e-12 {
                        return None;
                    }
                    t -= e / df;
                    if !t.is_finite() || t < 0.0 {
                        return None;
                    }
                }
                if !ok || t > self.r_valid * (1.0 + 1e-9) {
                    return None;
                }
                let s = t.sin();
                Some(DVec3::new(t.cos(), -s * xd / td, -s * yd / td).normalize())
            }
        }
    }

    /// Relative illumination of a ray `d` at image point (u, v): cos⁴θ × table (1 when
    /// `camera.vignetting` is off).
    fn relative_illumination_of(&self, d: DVec3, u: f64, v: f64) -> f64 {
        if !self.vignetting {
            return 1.0;
        }
        let cos_t = (d.x / d.length()).max(0.0);
        let natural = cos_t.powi(4);
        let table = match &self.ri_table {
            None => 1.0,
            Some(t) => match t.axis {
                IlluminationAxis::FieldAngleRad => t.factor(cos_t.clamp(-1.0, 1.0).acos()),
                IlluminationAxis::ImageHeight => {
                    t.factor((u - self.cx).hypot(v - self.cy) / self.half_diagonal_px)
                }
            },
        };
        natural * table
    }

    /// Radiance → rate factor of one pixel, m² sr (throughput × relative illumination).
    pub fn radiance_to_rate(&self, pixel: usize) -> f64 {
        self.throughput_m2_sr * f64::from(self.relative_illumination[pixel])
    }

    /// The sun's image position (possibly outside the image) and the fade factor of its flare
    /// (1 inside the image, falling linearly to 0 at `flare_margin_rel` outside); None when it
    /// makes no flare.
    pub fn sun_flare_position(&self, sun: &SunInView) -> Option<(DVec2, f64)> {
        let p = self.project_unbounded(sun.direction_sensor)?;
        let (w, h) = (self.width as f64, self.height as f64);
        let dx = (-p.x).max(p.x - w).max(0.0);
        let dy = (-p.y).max(p.y - h).max(0.0);
        let outside = dx.hypot(dy);
        if outside <= 0.0 {
            return Some((p, 1.0));
        }
        let margin = self.config.flare_margin_rel * self.half_diagonal_px;
        (outside < margin).then(|| (p, 1.0 - outside / margin))
    }

    /// Radiance [e⁻ s⁻¹ m⁻² sr⁻¹] → electron generation rate per pixel [e⁻/s], in place (also the
    /// flicker samples), then PSF blur and flare from `sun`.
    pub fn apply(&self, img: &mut ChannelImage, flicker: &mut Flicker, sun: Option<&SunInView>) {
        let (w, h) = (img.width, img.height);
        if w != self.width || h != self.height {
            // Not this lens's image (a programming error upstream): convert with the axial factor.
            for p in &mut img.planes {
                p.iter_mut()
                    .for_each(|v| *v = (f64::from(*v) * self.throughput_m2_sr) as f32);
            }
            return;
        }
        let k = self.throughput_m2_sr;
        let ri = &self.relative_illumination;
        for plane in &mut img.planes {
            plane
                .par_chunks_mut(w.max(1))
                .zip(ri.par_chunks(w.max(1)))
                .for_each(|(row, ri_row)| {
                    // f32 product (k ≈ 1e-12 m²·sr and the rates stay far inside f32's range).
                    let k = k as f32;
                    for (v, &r) in row.iter_mut().zip(ri_row) {
                        *v *= k * r;
                    }
                });
        }
        for s in &mut flicker.samples {
            let f = ri.get(s.pixel as usize).map_or(0.0, |&r| k * f64::from(r));
            for v in &mut s.value {
                *v = (f64::from(*v) * f) as f32;
            }
        }
        if !self.taps.is_empty() {
            let mut scratch = vec![0.0f32; w * h];
            for plane in &mut img.planes {
                self.blur_plane(plane, &mut scratch);
            }
        }
        if self.flare
            && let Some(sun) = sun
        {
            self.add_flare(img, sun);
        }
    }

    /// Separable energy-conserving Gaussian blur of one plane (scratch: w·h).
    fn blur_plane(&self, plane: &mut [f32], scratch: &mut [f32]) {
        let (w, h) = (self.width, self.height);
        let taps = &self.taps;
        let r = (taps.len() / 2) as isize;
        let (nx, ny) = (&self.inv_norm_x, &self.inv_norm_y);
        // Horizontal: scratch[x] = Σ_k plane[x−k]/Z(x−k)·t_k (scatter from each source, normalised).
        scratch
            .par_chunks_mut(w)
            .zip(plane.par_chunks(w))
            .for_each(|(out, inp)| {
                let ru = r as usize;
                // Interior `[2r, w − 2r)`: every source is ≥ r from the border (normalisation
                // 1); tap by tap over the whole span (vectorises; each pixel still sums its
                // taps in order).
                let (lo, hi) = (2 * ru, w.saturating_sub(2 * ru).max(2 * ru));
                if lo < hi {
                    let span = &mut out[lo..hi];
                    span.fill(0.0);
                    for (k, &t) in taps.iter().enumerate() {
                        let src = &inp[lo - ru + k..hi - ru + k];
                        for (o, &a) in span.iter_mut().zip(src) {
                            *o += a * t;
                        }
                    }
                }
                for (x, o) in out.iter_mut().enumerate() {
                    if (lo..hi).contains(&x) {
                        continue;
                    }
                    let mut acc = 0.0f32;
                    for (k, &t) in taps.iter().enumerate() {
                        let j = x as isize + k as isize - r;
                        if j >= 0 && (j as usize) < w {
                            let j = j as usize;
                            acc += inp[j] * nx[j] * t;
                        }
                    }
                    *o = acc;
                }
            });
        // Vertical: plane[y] = Σ_k scratch[y−k]/Z(y−k)·t_k.
        let src: &[f32] = scratch;
        plane.par_chunks_mut(w).enumerate().for_each(|(y, out)| {
            out.iter_mut().for_each(|v| *v = 0.0);
            for (k, &t) in taps.iter().enumerate() {
                let j = y as isize + k as isize - r;
                if j < 0 || j as usize >= h {
                    continue;
                }
                let j = j as usize;
                let wgt = t * ny[j];
                let row = &src[j * w..(j + 1) * w];
                for (o, &s) in out.iter_mut().zip(row) {
                    *o += s * wgt;
                }
            }
        });
    }

    /// The sun's collected power per channel, e⁻/s (before the flare fractions), and its image
    /// position; None when it makes no flare.
    pub fn sun_power(&self, sun: &SunInView) -> Option<([f64; CHANNELS], DVec2)> {
        let (p, fade) = self.sun_flare_position(sun)?;
        let d = sun.direction_sensor.normalize_or_zero();
        let ri = self.relative_illumination_of(d, p.x, p.y);
        let f = self.throughput_m2_sr * self.fx * self.fy * sun.solid_angle_sr * ri * fade;
        let mut power = [0.0; CHANNELS];
        for (o, &l) in power.iter_mut().zip(&sun.radiance) {
            *o = (f * l).max(0.0);
        }
        Some((power, p))
    }

    fn add_flare(&self, img: &mut ChannelImage, sun: &SunInView) {
        let Some((power, s)) = self.sun_power(sun) else {
            return;
        };
        let (w, h) = (self.width, self.height);
        let cfg = &self.config;
        let veil = cfg.veiling_glare_fraction / (w * h) as f64;
        let a = cfg.halo_radius_rel * self.half_diagonal_px;
        let halo_norm = cfg.halo_fraction / (2.0 * std::f64::consts::PI * a * a);
        let inv_a2 = 1.0 / (a * a);
        let c = DVec2::new(self.cx, self.cy);
        for (plane, &pw) in img.planes.iter_mut().zip(&power) {
            if pw.is_nan() || pw <= 0.0 {
                continue;
            }
            plane.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
                let dy = y as f64 + 0.5 - s.y;
                for (x, v) in row.iter_mut().enumerate() {
                    let dx = x as f64 + 0.5 - s.x;
                    let q = 1.0 + (dx * dx + dy * dy) * inv_a2;
                    let add = pw * (veil + halo_norm / (q * q.sqrt()));
                    *v += add as f32;
                }
            });
            for g in &cfg.ghosts {
                let centre = c + g.ratio * (s - c);
                let rr = g.radius_rel * self.half_diagonal_px;
                let area = match g.shape {
                    GhostShape::Disc => std::f64::consts::PI * rr * rr,
                    GhostShape::Hexagon => 1.5 * 3f64.sqrt() * rr * rr,
                };
                let level = (pw * g.strength / area) as f32;
                let x0 = (centre.x - rr).floor().max(0.0) as usize;
                let y0 = (centre.y - rr).floor().max(0.0) as usize;
                let x1 = ((centre.x + rr).ceil().max(0.0) as usize).min(w);
                let y1 = ((centre.y + rr).ceil().max(0.0) as usize).min(h);
                for y in y0..y1 {
                    let dy = y as f64 + 0.5 - centre.y;
                    for x in x0..x1 {
                        let dx = x as f64 + 0.5 - centre.x;
                        if inside_ghost(g.shape, dx, dy, rr) {
                            plane[y * w + x] += level;
                        }
                    }
                }
            }
        }
    }
}

/// Whether (dx, dy) from a ghost's centre lies inside its shape of circumradius `r` (hexagon with
/// vertices on the ±u axis).
pub fn inside_ghost(shape: GhostShape, dx: f64, dy: f64, r: f64) -> bool {
    match shape {
        GhostShape::Disc => dx * dx + dy * dy <= r * r,
        GhostShape::Hexagon => {
            let s3 = 3f64.sqrt();
            dy.abs() <= 0.5 * s3 * r && s3 * dx.abs() + dy.abs() <= s3 * r
        }
    }
}

/// Largest undistorted radius (Brown: r of the normalised pinhole point, up to 20 ≈ 87°;
/// fisheye: θ up to π) below which the distorted radius grows monotonically.
fn monotonic_limit(model: &Model) -> f64 {
    const STEPS: usize = 20_000;
    match model {
        Model::Brown { k, .. } => {
            let r_max = 20.0;
            let mut prev = 0.0;
            for i in 1..=STEPS {
                let r = r_max * i as f64 / STEPS as f64;
                let rd = r * Model::radial(k, r * r).0;
                if rd.is_nan() || rd <= prev {
                    return r_max * (i - 1) as f64 / STEPS as f64;
                }
                prev = rd;
            }
            r_max
        }
        Model::Fisheye { k } => {
            let t_max = std::f64::consts::PI;
            let mut prev = 0.0;
            for i in 1..=STEPS {
                let t = t_max * i as f64 / STEPS as f64;
                let td = Model::theta_d(k, t).0;
                if td.is_nan() || td <= prev {
                    return t_max * (i - 1) as f64 / STEPS as f64;
                }
                prev = td;
            }
            t_max
        }
    }
}

/// Recognition's view of the lens (image size, pinhole parameters, pixel rays, projection).
impl crate::recognition::camera::CameraLens for Lens {
    fn width(&self) -> usize {
        Lens::width(self)
    }
    fn height(&self) -> usize {
        Lens::height(self)
    }
    fn focal_length_px(&self) -> (f64, f64) {
        Lens::focal_length_px(self)
    }
    fn principal_point_px(&self) -> (f64, f64) {
        Lens::principal_point_px(self)
    }
    fn ray_directions(&self) -> &[Vec3] {
        Lens::ray_directions(self)
    }
    fn project(&self, dir_sensor: DVec3) -> Option<DVec2> {
        Lens::project(self, dir_sensor)
    }
}
