//! Optical (camera and LiDAR) properties of a material: the GGX microfacet specular lobe with the
//! Fresnel reflectance of a complex refractive index `n + ik`, the Gaussian retroreflective lobe, the
//! per-band optics (diffuse albedo and lobes; the visible band spectrally sampled), the transmission
//! of a slab (glass, lamp lenses) and the water film from which wet variants are derived. How the
//! lobes combine into the BRDF `f(wi, wo)` is in the [`material`](super) module doc (BRDF section);
//! [`Material`](super::Material) evaluates it.

use std::f64::consts::PI;

use glam::DVec3;
use num_complex::Complex64;

use super::{VISIBLE_SAMPLES, VISIBLE_START_NM, VISIBLE_STEP_NM};

/// GGX microfacet specular lobe with the Fresnel reflectance of a complex refractive index `n + ik`.
#[derive(Debug, Clone, PartialEq)]
pub struct SpecularLobe {
    pub(super) n: f64,
    k: f64,
    roughness: f64,
    pub(super) weight: f64,
    /// F at normal incidence.
    pub(super) f0: f64,
    /// Hemispherical (cosine-weighted) average of F, `2∫F(μ)μ dμ`.
    pub(super) f_hemi: f64,
    /// `1/√((1 − wF(0))(1 − wF̄))`.
    coupling_norm: f64,
}

impl SpecularLobe {
    /// A lobe of refractive index `n + ik`, GGX roughness α (clamped to [1e-4, 1]) and weight
    /// (clamped to [0, 1]).
    pub fn new(n: f64, k: f64, roughness: f64, weight: f64) -> SpecularLobe {
        let mut lobe = SpecularLobe {
            n,
            k,
            roughness: roughness.clamp(1e-4, 1.0),
            weight: weight.clamp(0.0, 1.0),
            f0: 0.0,
            f_hemi: 0.0,
            coupling_norm: 1.0,
        };
        lobe.f0 = lobe.fresnel(1.0);
        // Simpson on μ ∈ [0, 1] with 512 intervals (F is smooth; computed once per lobe).
        let m = 512;
        let h = 1.0 / m as f64;
        let mut s = 0.0;
        for i in 0..=m {
            let mu = i as f64 * h;
            let w = if i == 0 || i == m {
                1.0
            } else if i % 2 == 1 {
                4.0
            } else {
                2.0
            };
            s += w * lobe.fresnel(mu) * mu;
        }
        lobe.f_hemi = 2.0 * s * h / 3.0;
        let w = lobe.weight;
        lobe.coupling_norm = 1.0 / ((1.0 - w * lobe.f0) * (1.0 - w * lobe.f_hemi)).sqrt();
        lobe
    }

    /// Real part of the refractive index.
    pub fn n(&self) -> f64 {
        self.n
    }
    /// Extinction coefficient (0 for dielectrics).
    pub fn k(&self) -> f64 {
        self.k
    }
    /// GGX roughness α.
    pub fn roughness(&self) -> f64 {
        self.roughness
    }
    /// Weight (fraction of the surface that reflects specularly).
    pub fn weight(&self) -> f64 {
        self.weight
    }
    /// Fresnel reflectance at normal incidence (without the weight).
    pub fn f0(&self) -> f64 {
        self.f0
    }

    /// Unpolarised Fresnel reflectance at `cos θ` (without the weight).
    pub fn fresnel(&self, cos_theta: f64) -> f64 {
        fresnel_unpolarised(self.n, self.k, cos_theta)
    }

    /// Diffuse coupling factor `c(θ)` (see the `material` module doc, BRDF section).
    pub(super) fn coupling(&self, cos_theta: f64) -> f64 {
        (1.0 - self.weight * self.fresnel(cos_theta)) * self.coupling_norm
    }

    /// GGX normal distribution `D(h)` for `cos θh = n·h`.
    fn ggx_d(&self, cos_h: f64) -> f64 {
        if cos_h <= 0.0 {
            return 0.0;
        }
        let a2 = self.roughness * self.roughness;
        let d = cos_h * cos_h * (a2 - 1.0) + 1.0;
        a2 / (PI * d * d)
    }

    /// Smith Λ for GGX.
    fn smith_lambda(&self, cos_theta: f64) -> f64 {
        let c2 = cos_theta * cos_theta;
        let tan2 = ((1.0 - c2) / c2).max(0.0);
        0.5 * (-1.0 + (1.0 + self.roughness * self.roughness * tan2).sqrt())
    }

    /// Height-correlated masking-shadowing `G₂`.
    fn g2(&self, cos_i: f64, cos_o: f64) -> f64 {
        1.0 / (1.0 + self.smith_lambda(cos_i) + self.smith_lambda(cos_o))
    }

    /// The lobe's BRDF value for unit `wi`, `wo`, `n` above the surface (`cos_i`, `cos_o` > 0).
    pub(super) fn eval(&self, wi: DVec3, wo: DVec3, n: DVec3, cos_i: f64, cos_o: f64) -> f64 {
        let h = wi + wo;
        let len = h.length();
        if len < 1e-12 {
            return 0.0;
        }
        let h = h / len;
        let cos_h = n.dot(h);
        let f = self.fresnel(wi.dot(h).clamp(0.0, 1.0));
        self.weight * f * self.ggx_d(cos_h) * self.g2(cos_i, cos_o) / (4.0 * cos_i * cos_o)
    }

    /// Directional albedo of the lobe at `cos θi` (numerical, stratified GGX normal sampling).
    pub(super) fn albedo(&self, cos_i: f64) -> f64 {
        if cos_i <= 0.0 {
            return 0.0;
        }
        let sin_i = (1.0 - cos_i * cos_i).max(0.0).sqrt();
        let wi = DVec3::new(sin_i, 0.0, cos_i);
        let a2 = self.roughness * self.roughness;
        let m = 48;
        let mut sum = 0.0;
        for iu in 0..m {
            let u = (iu as f64 + 0.5) / m as f64;
            // θh from the GGX inverse CDF of D(h) cos θh.
            let cos_h = ((1.0 - u) / (1.0 + (a2 - 1.0) * u)).sqrt();
            let sin_h = (1.0 - cos_h * cos_h).max(0.0).sqrt();
            for iv in 0..2 * m {
                let phi = 2.0 * PI * (iv as f64 + 0.5) / (2 * m) as f64;
                let h = DVec3::new(sin_h * phi.cos(), sin_h * phi.sin(), cos_h);
                let i_h = wi.dot(h);
                if i_h <= 0.0 {
                    continue;
                }
                let wo = 2.0 * i_h * h - wi;
                if wo.z <= 0.0 {
                    continue;
                }
                sum += self.fresnel(i_h) * self.g2(cos_i, wo.z) * i_h / (cos_i * cos_h);
            }
        }
        self.weight * sum / (2 * m * m) as f64
    }
}

/// Gaussian retroreflective lobe `peak · exp(−γ²/σ²) · (cos θi cos θo)^(m/2)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RetroLobe {
    /// BRDF at `wo = wi`, normal incidence, sr⁻¹ (= R_A in cd lx⁻¹ m⁻²).
    pub peak_sr: f64,
    /// Gaussian 1/e width σ in the angle between `wi` and `wo`, rad.
    pub width_rad: f64,
    /// Exponent `m` of the entrance-angle factor.
    pub entrance_exponent: f64,
}

impl RetroLobe {
    pub(super) fn eval(&self, wi: DVec3, wo: DVec3, cos_i: f64, cos_o: f64) -> f64 {
        let gamma = wi.cross(wo).length().atan2(wi.dot(wo));
        let x = gamma / self.width_rad;
        if x > 10.0 {
            return 0.0;
        }
        let entrance = if self.entrance_exponent == 0.0 {
            1.0
        } else {
            (cos_i * cos_o).powf(0.5 * self.entrance_exponent)
        };
        self.peak_sr * (-x * x).exp() * entrance
    }

    /// Directional albedo at incidence `wi` (numerical, polar grid around `wi`).
    pub(super) fn albedo(&self, wi: DVec3, n: DVec3) -> f64 {
        let cos_i = n.dot(wi);
        if cos_i <= 0.0 {
            return 0.0;
        }
        let (t, b) = wi.any_orthonormal_pair();
        let g_max = (8.0 * self.width_rad).min(PI);
        let (ng, np) = (160, 96);
        let dg = g_max / ng as f64;
        let dp = 2.0 * PI / np as f64;
        let mut sum = 0.0;
        for ig in 0..ng {
            let g = (ig as f64 + 0.5) * dg;
            let (sg, cg) = g.sin_cos();
            for ip in 0..np {
                let (sp, cp) = ((ip as f64 + 0.5) * dp).sin_cos();
                let wo = cg * wi + sg * (cp * t + sp * b);
                let cos_o = n.dot(wo);
                if cos_o <= 0.0 {
                    continue;
                }
                sum += self.eval(wi, wo, cos_i, cos_o) * cos_o * sg;
            }
        }
        sum * dg * dp
    }
}

/// Optical properties of a material in one band.
#[derive(Debug, Clone, PartialEq)]
pub struct BandOptics {
    /// Diffuse albedo ρ_d at normal incidence.
    pub diffuse: f64,
    pub specular: Option<SpecularLobe>,
    pub retro: Option<RetroLobe>,
    pub source: String,
}

/// Visible-band optics: a spectral diffuse reflectance and wavelength-independent lobes.
#[derive(Debug, Clone, PartialEq)]
pub struct VisibleOptics {
    /// ρ_d at 380, 390, ..., 780 nm.
    pub reflectance: [f64; VISIBLE_SAMPLES],
    pub specular: Option<SpecularLobe>,
    pub retro: Option<RetroLobe>,
    pub source: String,
}

impl VisibleOptics {
    /// Linear interpolation of the spectral reflectance (held constant outside 380–780 nm).
    pub fn reflectance_at(&self, lambda_nm: f64) -> f64 {
        interpolate_visible(&self.reflectance, lambda_nm)
    }
}

pub(super) fn interpolate_visible(samples: &[f64; VISIBLE_SAMPLES], lambda_nm: f64) -> f64 {
    let x =
        ((lambda_nm - VISIBLE_START_NM) / VISIBLE_STEP_NM).clamp(0.0, (VISIBLE_SAMPLES - 1) as f64);
    if x.is_nan() {
        return samples[0];
    }
    let i = (x.floor() as usize).min(VISIBLE_SAMPLES - 2);
    let t = x - i as f64;
    samples[i] * (1.0 - t) + samples[i + 1] * t
}

/// Transmission of a slab (glass, lamp lens) in the visible and NIR.
#[derive(Debug, Clone, PartialEq)]
pub struct Transmission {
    /// Slab thickness, m.
    pub thickness_m: f64,
    /// Extinction coefficient k at 380..=780 nm.
    pub k_visible: [f64; VISIBLE_SAMPLES],
    pub k_905: f64,
    pub k_1550: f64,
    pub source: String,
}

/// Reflectance and transmittance of a slab (both faces, incoherent multiple reflections).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SlabOptics {
    pub reflectance: f64,
    pub transmittance: f64,
}

/// A water film that turns a dry material into its wet variant (Lekner & Dorf 1988).
#[derive(Debug, Clone, PartialEq)]
pub struct WaterFilm {
    /// Film depth, m.
    pub thickness_m: f64,
    /// GGX roughness α of the water surface.
    pub roughness: f64,
    /// rms height of the water surface at mm-wave, m (`None`: the dry material's).
    pub mmwave_roughness_m: Option<f64>,
    /// Factor on the dry retroreflective lobe (drowned beads), 0..=1.
    pub retro_factor: f64,
    /// Water temperature, °C (mm-wave permittivity).
    pub temperature_c: f64,
    pub source: String,
}

/// Unpolarised Fresnel reflectance of the interface air → `n + ik` at `cos θ`.
pub fn fresnel_unpolarised(n: f64, k: f64, cos_theta: f64) -> f64 {
    let c = cos_theta.clamp(0.0, 1.0);
    let eps = Complex64::new(n, k) * Complex64::new(n, k);
    let w = (eps - (1.0 - c * c)).sqrt();
    let rs = (c - w) / (c + w);
    let rp = (eps * c - w) / (eps * c + w);
    0.5 * (rs.norm_sqr() + rp.norm_sqr())
}
