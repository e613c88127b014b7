//! The materials database: what every surface of a scene is made of, for each sensor band.
//!
//! A material carries, with a `source` string for every block of values:
//!
//! * **visible** (camera): a spectral reflectance sampled at 380..=780 nm in 10 nm steps (41 values,
//!   [`Material::reflectance_visible`] interpolates linearly), plus optional specular and
//!   retroreflective lobes;
//! * **nir** (LiDAR) at 905 and 1550 nm: a BRDF made of a Lambertian diffuse term, a GGX microfacet
//!   specular lobe with a Fresnel term from a complex refractive index, and a Gaussian retroreflective
//!   lobe ([`Material::eval_brdf`], sr⁻¹);
//! * **mmwave** (radar, 76–81 GHz): a complex relative permittivity `ε_r = ε' − jε''` (constant, an
//!   ITU-R P.2040 fit, a Cole–Cole tissue model, the ITU-R P.840 water model or a frequency table), or
//!   a conductor, optionally under coating layers and optionally as a slab of finite thickness; the
//!   reflection coefficient of the whole stack ([`Material::fresnel_mmwave`], TE/TM) and the slab
//!   transmission follow from the Fresnel equations and the Airy recursion (Orfanidis, *Electromagnetic
//!   Waves and Antennas*, ch. 6–7), the surface roughness from the Ament factor;
//! * **transmission** (glass, lamp lenses) in the visible and NIR: slab thickness and extinction
//!   coefficient `k(λ)`; with the Fresnel reflectance of both faces ([`Material::slab_optics`]);
//! * **wet variants**: a wet material may be *derived* from a dry one under a water film (Lekner & Dorf
//!   1988): darker diffuse term, a water specular lobe, drowned retroreflection and a water layer at
//!   mm-wave ([`Material::with_water_film`], [`MaterialDb::wet_variant`]).
//!
//! The shipped starter set is `models/resources/materials.json` ([`MaterialDb::builtin`]); users load
//! their own with [`MaterialDb::from_json_file`] or add to the built-in set with
//! [`MaterialDb::extend_from_json_file`]. Parametric `lambertian_<NN>` materials (ideal Lambertian
//! reflectance `NN` % in every band) are created on demand by [`MaterialDb::resolve`].
//! `models/resources/MATERIALS.md` documents every starter value with its source and flags the
//! estimates.
//!
//! # Conventions
//!
//! * Directions for the BRDF are unit vectors pointing *away* from the surface: `wi` towards the
//!   source, `wo` towards the receiver, `n` the surface normal on their side. Retroreflection is
//!   `wo = wi`.
//! * Time dependence `e^{jωt}`: lossy media have `ε = ε' − jε''` with `ε'' ≥ 0`; JSON stores
//!   `[ε', ε'']`.
//! * Fresnel reflection coefficients of a half-space (physics.md §1.3, θ the incidence angle from the
//!   normal): `Γ_TE = (cos θ − √(ε − sin²θ)) / (cos θ + √(ε − sin²θ))` (E-field ratio, horizontal
//!   polarisation for a ground bounce) and `Γ_TM = (ε cos θ − √(ε − sin²θ)) / (ε cos θ + √(ε − sin²θ))`
//!   (H-field ratio, vertical polarisation). So `Γ_TM(0) = −Γ_TE(0)`, `Γ_TM = 0` at the Brewster angle
//!   `tan θ_B = √ε`, and a perfect conductor has `Γ_TE = −1`, `Γ_TM = +1`.
//!
//! # JSON schema (`"schema": "osiris-materials/1"`)
//!
//! ```text
//! {
//!   "schema": "osiris-materials/1",
//!   "description": "...",                          optional
//!   "materials": {
//!     "<name>": {                                  [a-z0-9_]; `lambertian_*` is reserved
//!       "description": "...",                      optional
//!       "visible": {
//!         "reflectance": [41 × ρ_d],               380, 390, ..., 780 nm, each in [0, 1]
//!         "specular": LOBE,                        optional
//!         "retro": RETRO,                          optional
//!         "source": "..."
//!       },
//!       "nir": {
//!         "905":  { "diffuse": ρ_d, "specular": LOBE?, "retro": RETRO?, "source": "..." },
//!         "1550": { ... same ... }
//!       },
//!       "mmwave": {
//!         "eps_r": PERMITTIVITY,                   bulk material (not with "conductor": true)
//!         "conductor": false,                      metal: σ from sigma_s_per_m, else perfect conductor
//!         "sigma_s_per_m": 3.5e7,                  conductors only, optional
//!         "thickness_m": 0.004,                    optional: the bulk is a slab with `backing` behind
//!         "backing": "air" | "pec",                with thickness_m only; default "air"
//!         "layers": [ { "name": "...", "eps_r": PERMITTIVITY, "thickness_m": 1.2e-4,
//!                       "source": "..." (optional) } ],   coatings on top, outermost first
//!         "roughness_m": 0.0005,                   rms height σ_h of the top surface (default 0)
//!         "source": "..."
//!       },
//!       "transmission": {                          optional (glass, lenses): needs a specular lobe
//!         "thickness_m": 0.004,                    in every band (its n is the slab's index)
//!         "k_visible": [41 × k], "k_905": k, "k_1550": k,   extinction coefficient, α = 4πk/λ
//!         "source": "..."
//!       },
//!       "wet_of": "<dry name>",                    optional: this is the wet variant of <dry name>
//!       "water_film": {                            optional (needs wet_of): derive every band
//!         "thickness_m": 0.0005,                   instead of listing visible/nir/mmwave
//!         "roughness": 0.1,                        GGX α of the water surface
//!         "mmwave_roughness_m": 0.0002,            optional, default: the dry material's
//!         "retro_factor": 0.15,                    optional, default 1: scales the dry retro lobe
//!         "temperature_c": 15,                     optional, default 15 (water permittivity)
//!         "source": "..."
//!       }
//!     }
//!   }
//! }
//! LOBE  = { "n": 1.5, "k": 0.0 (default), "roughness": 0.03, "weight": 1.0 (default) }
//!         GGX (Trowbridge–Reitz) α = roughness in [1e-4, 1], Fresnel of n + ik, scaled by weight
//! RETRO = { "peak_sr": 300, "width_rad": 0.0081, "entrance_exponent": 0 (default) }
//! PERMITTIVITY =
//!     [ε', ε'']                                     constant
//!   | { "itu_p2040": [a, b, c, d] }                 ε' = a f^b, σ = c f^d (f in GHz)
//!   | { "water": { "temperature_c": 20 } }          ITU-R P.840 double-Debye model
//!   | { "cole_cole": { "eps_inf": 4, "sigma_s_per_m": 2e-4,
//!                      "terms": [[Δε, τ_s, α], ...] } }   ε∞ + Σ Δε/(1 + (jωτ)^(1−α)) + σ/(jωε₀)
//!   | { "table": [[f_GHz, ε', ε''], ...] }           linear in f, held beyond the ends
//! ```
//!
//! Unknown keys are errors. Every error names the file, the line and column, the material and the key.
//!
//! # BRDF
//!
//! `f(wi, wo) = ρ_d/π · c(θi) c(θo) + w F(wi·h) D(h) G₂(wi, wo) / (4 cos θi cos θo) + R(wi, wo)` with
//!
//! * `D` the GGX normal distribution and `G₂` the height-correlated Smith masking (Walter et al.,
//!   EGSR 2007; Heitz, JCGT 3(2), 2014), `F` the unpolarised Fresnel reflectance of `n + ik`, `w` the
//!   lobe weight;
//! * `c(θ) = (1 − wF(θ)) / √((1 − wF(0))(1 − wF̄))` (1 without a specular lobe): the diffuse light
//!   crosses the specular interface twice; normalised so that `ρ_d` stays the diffuse albedo at normal
//!   incidence and the diffuse albedo at incidence θ is `ρ_d (1 − wF(θ)) / (1 − wF(0))` (energy is
//!   conserved when `ρ_d ≤ 1 − wF(0)`, checked at load). `F̄` is the hemispherical average of `F`;
//! * `R = peak · exp(−γ²/σ²) · (cos θi cos θo)^(m/2)`, γ the angle between `wi` and `wo`: a Gaussian
//!   retroreflective lobe. At normal incidence `R(wi, wi)` equals the coefficient of retroreflection
//!   `R_A` (cd lx⁻¹ m⁻²) of retroreflective sheeting; its albedo is ≈ `peak π σ² cos^(1+m) θi`.
//!
//! The BRDF is reciprocal (`f(wi, wo) = f(wo, wi)`).

use crate::constants::SPEED_OF_LIGHT_M_S;
use std::collections::HashMap;
use std::f64::consts::{FRAC_1_PI, PI};
use std::path::Path;
use std::sync::OnceLock;

use glam::DVec3;
use num_complex::Complex64;
use serde::Deserialize;

use crate::effects::{EffectInfo, Effects};

// ---------------------------------------------------------------------------------------------------
// Effects

/// `env.wet_surfaces`: wet variants replace dry materials when the road is wet.
pub const WET_SURFACES: EffectInfo = EffectInfo {
    name: "env.wet_surfaces",
    default_on: true,
    summary: "wet road: materials with a wet variant are replaced by it (water film: diffuse darkened to \
              ρ(1−F)(1−r̄)/(1−ρr̄), water specular lobe n ≈ 1.33, water layer at mm-wave); off: surfaces stay dry",
    source: "Lekner & Dorf, Appl. Opt. 27(7):1278, 1988; water n, k: Segelstein 1981; water ε: ITU-R P.840",
    requires: None,
};

/// `space.mmwave_roughness`: the Ament roughness factor on the mm-wave reflection coefficient.
pub const MMWAVE_ROUGHNESS: EffectInfo = EffectInfo {
    name: "space.mmwave_roughness",
    default_on: true,
    summary: "rough-surface loss of the coherent mm-wave reflection: Γ · exp(−2 (k σ_h cos θ)²); off: smooth \
              surfaces",
    source: "Ament, Proc. IRE 41:142, 1953; Beckmann & Spizzichino, The Scattering of Electromagnetic Waves \
             from Rough Surfaces, 1963",
    requires: None,
};

/// `space.fresnel_polarisation`: polarisation- and angle-dependent Fresnel coefficients.
pub const FRESNEL_POLARISATION: EffectInfo = EffectInfo {
    name: "space.fresnel_polarisation",
    default_on: true,
    summary: "mm-wave reflection from the Fresnel/multilayer coefficients Γ_TE(θ), Γ_TM(θ); off: the \
              normal-incidence scalar Γ_TE(0) = (1 − √ε)/(1 + √ε) (stack value) for every angle and polarisation",
    source: "Fresnel equations; Orfanidis, Electromagnetic Waves and Antennas, ch. 6–7",
    requires: None,
};

/// `env.retroreflection`: the retroreflective BRDF lobe (sheeting, road-marking beads).
pub const RETROREFLECTION: EffectInfo = EffectInfo {
    name: "env.retroreflection",
    default_on: true,
    summary: "retroreflective lobe R = peak · exp(−γ²/σ²) (cos θi cos θo)^(m/2) around the source direction \
              (γ: angle between wi and wo); off: no retroreflection",
    source: "Gaussian retro lobe fitted to coefficients of retroreflection (ASTM D4956 R_A, EN 1436 R_L)",
    requires: None,
};

/// All effects of the materials database.
pub const EFFECTS: &[EffectInfo] = &[
    WET_SURFACES,
    MMWAVE_ROUGHNESS,
    FRESNEL_POLARISATION,
    RETROREFLECTION,
];

/// The material switches of one model instance (from an [`Effects`] set).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MaterialEffects {
    pub wet_surfaces: bool,
    pub mmwave_roughness: bool,
    pub fresnel_polarisation: bool,
    pub retroreflection: bool,
}

impl Default for MaterialEffects {
    fn default() -> Self {
        MaterialEffects {
            wet_surfaces: WET_SURFACES.default_on,
            mmwave_roughness: MMWAVE_ROUGHNESS.default_on,
            fresnel_polarisation: FRESNEL_POLARISATION.default_on,
            retroreflection: RETROREFLECTION.default_on,
        }
    }
}

impl MaterialEffects {
    /// The switches from an effect set that declares [`EFFECTS`] (panics if it does not).
    pub fn from_effects(effects: &Effects) -> MaterialEffects {
        MaterialEffects {
            wet_surfaces: effects.is_on(&WET_SURFACES),
            mmwave_roughness: effects.is_on(&MMWAVE_ROUGHNESS),
            fresnel_polarisation: effects.is_on(&FRESNEL_POLARISATION),
            retroreflection: effects.is_on(&RETROREFLECTION),
        }
    }
}

// ---------------------------------------------------------------------------------------------------
// Constants, bands

/// First visible sample, nm.
pub const VISIBLE_START_NM: f64 = 380.0;
/// Visible sample step, nm.
pub const VISIBLE_STEP_NM: f64 = 10.0;
/// Number of visible samples (380..=780 nm).
pub const VISIBLE_SAMPLES: usize = 41;

/// Vacuum permittivity, F/m (CODATA 2018).
const EPS0: f64 = 8.854_187_812_8e-12;
/// Schema tag of the JSON files.
pub const SCHEMA: &str = "osiris-materials/1";
/// Label of the built-in file in error messages.
const BUILTIN_LABEL: &str = "materials.json (builtin)";
/// The built-in starter set.
const BUILTIN_JSON: &str = include_str!("../../../resources/materials.json");

/// A sensor band of the optical (camera/LiDAR) models.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Band {
    /// Visible light at a wavelength in nm (380–780; clamped outside).
    Visible(f64),
    /// 905 nm LiDAR (also used for 850–950 nm sources).
    Nir905,
    /// 1550 nm LiDAR.
    Nir1550,
}

impl Band {
    /// The band for a wavelength in nm: visible up to 780 nm, the 905 nm band up to 1200 nm, the
    /// 1550 nm band beyond.
    pub fn for_wavelength_nm(lambda_nm: f64) -> Band {
        if lambda_nm <= 780.0 {
            Band::Visible(lambda_nm)
        } else if lambda_nm < 1200.0 {
            Band::Nir905
        } else {
            Band::Nir1550
        }
    }

    /// Wavelength of the band, nm.
    pub fn wavelength_nm(&self) -> f64 {
        match *self {
            Band::Visible(l) => l,
            Band::Nir905 => 905.0,
            Band::Nir1550 => 1550.0,
        }
    }
}

/// Polarisation of a mm-wave field relative to the plane of incidence.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Polarisation {
    /// Transverse electric (s, E perpendicular to the plane of incidence; horizontal for a ground bounce).
    Te,
    /// Transverse magnetic (p, E in the plane of incidence; vertical for a ground bounce).
    Tm,
}

// ---------------------------------------------------------------------------------------------------
// Ids and errors (contract)

/// Index of a material in a [`MaterialDb`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct MaterialId(pub u32);

/// Errors of material lookup and loading.
#[derive(Debug, thiserror::Error)]
pub enum MaterialError {
    #[error("unknown material `{0}`")]
    Unknown(String),
    #[error("materials database: {0}")]
    Invalid(String),
    /// A materials file could not be read.
    #[error("{file}: {message}")]
    Io { file: String, message: String },
    /// A materials file is malformed: JSON syntax, types, unknown or missing keys, or values out of
    /// range. `material` and `key` (dotted path inside the material) are set when known.
    #[error("{file}:{line}:{column}: {}", describe(.material, .key, .message))]
    Parse {
        file: String,
        line: usize,
        column: usize,
        material: Option<String>,
        key: Option<String>,
        message: String,
    },
}

fn describe(material: &Option<String>, key: &Option<String>, message: &str) -> String {
    match (material, key) {
        (Some(m), Some(k)) => format!("material `{m}`, key `{k}`: {message}"),
        (Some(m), None) => format!("material `{m}`: {message}"),
        (None, Some(k)) => format!("key `{k}`: {message}"),
        (None, None) => message.to_owned(),
    }
}

// ---------------------------------------------------------------------------------------------------
// Optical lobes

/// GGX microfacet specular lobe with the Fresnel reflectance of a complex refractive index `n + ik`.
#[derive(Debug, Clone, PartialEq)]
pub struct SpecularLobe {
    n: f64,
    k: f64,
    roughness: f64,
    weight: f64,
    /// F at normal incidence.
    f0: f64,
    /// Hemispherical (cosine-weighted) average of F, `2∫F(μ)μ dμ`.
    f_hemi: f64,
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

    /// Diffuse coupling factor `c(θ)` (see the module doc).
    fn coupling(&self, cos_theta: f64) -> f64 {
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
    fn eval(&self, wi: DVec3, wo: DVec3, n: DVec3, cos_i: f64, cos_o: f64) -> f64 {
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
    fn albedo(&self, cos_i: f64) -> f64 {
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
    fn eval(&self, wi: DVec3, wo: DVec3, cos_i: f64, cos_o: f64) -> f64 {
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
    fn albedo(&self, wi: DVec3, n: DVec3) -> f64 {
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

fn interpolate_visible(samples: &[f64; VISIBLE_SAMPLES], lambda_nm: f64) -> f64 {
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

// ---------------------------------------------------------------------------------------------------
// Permittivity and the mm-wave stack

/// One relaxation term of a Cole–Cole model: `Δε / (1 + (jωτ)^(1−α))`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ColeColeTerm {
    pub delta_eps: f64,
    pub tau_s: f64,
    pub alpha: f64,
}

/// A complex relative permittivity `ε' − jε''` as a function of frequency.
#[derive(Debug, Clone, PartialEq)]
pub enum Permittivity {
    /// Frequency-independent `ε' − jε''` (stores `ε'`, `ε''`).
    Constant { re: f64, loss: f64 },
    /// ITU-R P.2040 fit: `ε' = a f^b`, `σ = c f^d` (f in GHz), `ε'' = σ/(2πfε₀)`.
    ItuP2040 { a: f64, b: f64, c: f64, d: f64 },
    /// Liquid water, ITU-R P.840 double-Debye model (Liebe et al. 1991).
    Water { temperature_c: f64 },
    /// Cole–Cole relaxation model (Gabriel et al. 1996 for tissues).
    ColeCole {
        eps_inf: f64,
        sigma_s_per_m: f64,
        terms: Vec<ColeColeTerm>,
    },
    /// Tabulated `(f_GHz, ε', ε'')`, linear in frequency, held beyond the ends.
    Table(Vec<(f64, f64, f64)>),
    /// A conductor: `ε = 1 − jσ/(ωε₀)`.
    Conductor { sigma_s_per_m: f64 },
}

impl Permittivity {
    /// `ε_r = ε' − jε''` at `freq_hz`.
    pub fn eval(&self, freq_hz: f64) -> Complex64 {
        let omega = 2.0 * PI * freq_hz;
        match self {
            Permittivity::Constant { re, loss } => Complex64::new(*re, -loss),
            Permittivity::ItuP2040 { a, b, c, d } => {
                let f_ghz = freq_hz * 1e-9;
                let sigma = c * f_ghz.powf(*d);
                Complex64::new(a * f_ghz.powf(*b), -sigma / (omega * EPS0))
            }
            Permittivity::Water { temperature_c } => {
                water_permittivity_p840(freq_hz, *temperature_c)
            }
            Permittivity::ColeCole {
                eps_inf,
                sigma_s_per_m,
                terms,
            } => {
                let mut eps = Complex64::new(*eps_inf, -sigma_s_per_m / (omega * EPS0));
                for t in terms {
                    let jwt = Complex64::new(0.0, omega * t.tau_s);
                    eps += t.delta_eps / (1.0 + jwt.powf(1.0 - t.alpha));
                }
                eps
            }
            Permittivity::Table(rows) => {
                let f = freq_hz * 1e-9;
                let first = rows[0];
                let last = rows[rows.len() - 1];
                let (re, loss) = if f <= first.0 {
                    (first.1, first.2)
                } else if f >= last.0 {
                    (last.1, last.2)
                } else {
                    let i = rows.windows(2).position(|w| f <= w[1].0).unwrap_or(0);
                    let (a, b) = (rows[i], rows[i + 1]);
                    let t = (f - a.0) / (b.0 - a.0);
                    (a.1 + t * (b.1 - a.1), a.2 + t * (b.2 - a.2))
                };
                Complex64::new(re, -loss)
            }
            Permittivity::Conductor { sigma_s_per_m } => {
                Complex64::new(1.0, -sigma_s_per_m / (omega * EPS0))
            }
        }
    }
}

/// Complex permittivity of liquid water, ITU-R P.840 (eqs. for ε', ε'' after Liebe, Hufford & Manabe,
/// Int. J. Infrared Millim. Waves 12:659, 1991), returned as `ε' − jε''`.
pub fn water_permittivity_p840(freq_hz: f64, temperature_c: f64) -> Complex64 {
    let f = freq_hz * 1e-9;
    let theta = 300.0 / (temperature_c + 273.15);
    let e0 = 77.66 + 103.3 * (theta - 1.0);
    let e1 = 0.0671 * e0;
    let e2 = 3.52;
    let fp = 20.20 - 146.0 * (theta - 1.0) + 316.0 * (theta - 1.0) * (theta - 1.0);
    let fs = 39.8 * fp;
    let (xp, xs) = (f / fp, f / fs);
    let re = (e0 - e1) / (1.0 + xp * xp) + (e1 - e2) / (1.0 + xs * xs) + e2;
    let im = f * (e0 - e1) / (fp * (1.0 + xp * xp)) + f * (e1 - e2) / (fs * (1.0 + xs * xs));
    Complex64::new(re, -im)
}

/// One coating layer of a mm-wave stack.
#[derive(Debug, Clone, PartialEq)]
pub struct Layer {
    pub name: String,
    pub eps_r: Permittivity,
    pub thickness_m: f64,
    pub source: Option<String>,
}

/// What lies behind a slab.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Backing {
    Air,
    /// Perfect electric conductor.
    Pec,
}

/// mm-wave (radar) properties: `layers` (outermost first) over the bulk, which is a half-space or,
/// with `thickness_m`, a slab with `backing` behind.
#[derive(Debug, Clone, PartialEq)]
pub struct MmWave {
    /// Bulk permittivity (`None` for a perfect conductor).
    pub eps_r: Option<Permittivity>,
    /// Whether the bulk is a metal.
    pub conductor: bool,
    /// Slab thickness of the bulk, m (`None`: half-space).
    pub thickness_m: Option<f64>,
    pub backing: Backing,
    pub layers: Vec<Layer>,
    /// rms height of the top surface, m.
    pub roughness_m: f64,
    pub source: String,
}

/// Response of a mm-wave stack.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StackResponse {
    /// Reflection coefficient (TE: E-field ratio, TM: H-field ratio).
    pub gamma: Complex64,
    /// Amplitude of the tangential field transmitted into the back medium (0 into a conductor).
    pub t: Complex64,
    /// Reflected power fraction |Γ|².
    pub reflectance: f64,
    /// Power fraction transmitted into the back medium (the rest is absorbed in the layers).
    pub transmittance: f64,
}

/// Medium of a stack.
#[derive(Debug, Clone, Copy)]
enum Medium {
    Eps(Complex64),
    Pec,
}

/// Normalised z-wavenumber `√(ε − sin²θ)` on the decaying branch (Im ≤ 0 for `e^{−jkz}`).
fn nz(eps: Complex64, sin2: f64) -> Complex64 {
    let w = (eps - sin2).sqrt();
    if w.im > 0.0 || (w.im == 0.0 && w.re < 0.0) {
        -w
    } else {
        w
    }
}

/// Layers of a mm-wave stack handled without allocation.
const MAX_STACK: usize = 8;

/// Reflection and transmission of a plane wave from air at `incidence_rad` onto `layers`
/// (`(ε, thickness)`, outermost first) over the half-space `back` (Airy recursion; Orfanidis ch. 6–7).
fn stack_response(
    layers: &[(Complex64, f64)],
    back: Medium,
    freq_hz: f64,
    incidence_rad: f64,
    pol: Polarisation,
) -> StackResponse {
    let k0 = 2.0 * PI * freq_hz / SPEED_OF_LIGHT_M_S;
    let (sin_t, cos_t) = incidence_rad.sin_cos();
    let cos_t = cos_t.max(0.0);
    let sin2 = sin_t * sin_t;
    // Wave admittance normalised to the field whose reflection coefficient we track.
    let eta = |eps: Complex64| -> Complex64 {
        let z = nz(eps, sin2);
        match pol {
            Polarisation::Te => z,
            Polarisation::Tm => z / eps,
        }
    };
    let r = |a: Complex64, b: Medium| -> Complex64 {
        match b {
            Medium::Eps(eb) => {
                let eb = eta(eb);
                (a - eb) / (a + eb)
            }
            Medium::Pec => match pol {
                Polarisation::Te => Complex64::new(-1.0, 0.0),
                Polarisation::Tm => Complex64::new(1.0, 0.0),
            },
        }
    };
    let eta0 = Complex64::new(cos_t, 0.0);
    let n = layers.len();
    // gamma[i]: reflection coefficient at the front of medium i+1 (interface i), looking in.
    // gamma_p[i]: reflection coefficient of what lies behind interface i, referenced at interface i.
    // On the stack for the usual few layers (no allocation per ray).
    let zero = Complex64::new(0.0, 0.0);
    let (mut g_buf, mut gp_buf) = ([zero; MAX_STACK + 1], [zero; MAX_STACK + 1]);
    let (mut g_vec, mut gp_vec) = (Vec::new(), Vec::new());
    let (gamma, gamma_p): (&mut [Complex64], &mut [Complex64]) = if n <= MAX_STACK {
        (&mut g_buf[..=n], &mut gp_buf[..=n])
    } else {
        g_vec.resize(n + 1, zero);
        gp_vec.resize(n + 1, zero);
        (&mut g_vec, &mut gp_vec)
    };
    let eta_of = |i: usize| -> Complex64 { if i == 0 { eta0 } else { eta(layers[i - 1].0) } };
    // Interface n: between medium n (last layer or air) and the back.
    gamma[n] = r(eta_of(n), back);
    for i in (0..n).rev() {
        let (eps, d) = layers[i];
        let phase = Complex64::new(0.0, -2.0 * k0 * d) * nz(eps, sin2);
        gamma_p[i] = gamma[i + 1] * phase.exp();
        let ri = r(eta_of(i), Medium::Eps(eps));
        gamma[i] = (ri + gamma_p[i]) / (1.0 + ri * gamma_p[i]);
    }
    let g = gamma[0];
    // Forward tangential field through the stack: continuity at interface i gives
    // B_i = A_{i−1} (1 + Γ_i) / (1 + Γ'_{i+1}); then propagation across layer i.
    let mut a = Complex64::new(1.0, 0.0);
    for i in 0..n {
        let (eps, d) = layers[i];
        let b = a * (1.0 + gamma[i]) / (1.0 + gamma_p[i]);
        a = b * (Complex64::new(0.0, -k0 * d) * nz(eps, sin2)).exp();
    }
    let (t, transmittance) = match back {
        Medium::Pec => (Complex64::new(0.0, 0.0), 0.0),
        Medium::Eps(eb) => {
            let t = a * (1.0 + gamma[n]);
            let tr = if cos_t > 0.0 {
                t.norm_sqr() * eta(eb).re / eta0.re
            } else {
                0.0
            };
            (t, tr)
        }
    };
    StackResponse {
        gamma: g,
        t,
        reflectance: g.norm_sqr(),
        transmittance,
    }
}

/// Fresnel reflection coefficient of the interface air → half-space `ε` at `incidence_rad`
/// (physics.md §1.3 convention, see the module doc).
pub fn fresnel_coefficient(eps: Complex64, incidence_rad: f64, pol: Polarisation) -> Complex64 {
    stack_response(&[], Medium::Eps(eps), 1e9, incidence_rad, pol).gamma
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

/// Ament roughness factor `exp(−2 (k σ_h cos θ)²)` on the coherent reflection coefficient
/// (Ament 1953; Beckmann & Spizzichino 1963).
pub fn ament_factor(freq_hz: f64, roughness_m: f64, incidence_rad: f64) -> f64 {
    let k = 2.0 * PI * freq_hz / SPEED_OF_LIGHT_M_S;
    let x = k * roughness_m * incidence_rad.cos();
    (-2.0 * x * x).exp()
}

impl MmWave {
    fn bulk_medium(&self, freq_hz: f64) -> Medium {
        match (&self.eps_r, self.conductor) {
            (Some(e), _) => Medium::Eps(e.eval(freq_hz)),
            (None, true) => Medium::Pec,
            (None, false) => Medium::Eps(Complex64::new(1.0, 0.0)),
        }
    }

    /// The full response of the stack (layers, bulk, backing) without roughness.
    pub fn response(&self, freq_hz: f64, incidence_rad: f64, pol: Polarisation) -> StackResponse {
        let n = self.layers.len() + 1;
        let zero = (Complex64::new(0.0, 0.0), 0.0);
        let mut buf = [zero; MAX_STACK + 1];
        let mut heap = Vec::new();
        let layers: &mut [(Complex64, f64)] = if n <= buf.len() {
            &mut buf[..n]
        } else {
            heap.resize(n, zero);
            &mut heap
        };
        for (slot, l) in layers.iter_mut().zip(&self.layers) {
            *slot = (l.eps_r.eval(freq_hz), l.thickness_m);
        }
        let coats = self.layers.len();
        let (stack, back) = match (self.thickness_m, self.bulk_medium(freq_hz)) {
            (Some(d), Medium::Eps(e)) => {
                layers[coats] = (e, d);
                let back = match self.backing {
                    Backing::Air => Medium::Eps(Complex64::new(1.0, 0.0)),
                    Backing::Pec => Medium::Pec,
                };
                (&layers[..], back)
            }
            (_, bulk) => (&layers[..coats], bulk),
        };
        stack_response(stack, back, freq_hz, incidence_rad, pol)
    }

    /// Whether waves pass through (a slab with air behind).
    pub fn is_slab(&self) -> bool {
        self.thickness_m.is_some() && self.backing == Backing::Air && self.eps_r.is_some()
    }
}

// ---------------------------------------------------------------------------------------------------
// Water optical constants (for the wet derivation)

/// Liquid water, 25 °C: (λ µm, n, k), Segelstein 1981 (refractiveindex.info, main/H2O/Segelstein).
const WATER_NK: &[(f64, f64, f64)] = &[
    (0.380_189, 1.352740, 1.94e-9),
    (0.399_945, 1.349793, 1.58e-9),
    (0.449_780, 1.343889, 8.09e-10),
    (0.500_035, 1.339430, 9.24e-10),
    (0.549_541, 1.335972, 2.44e-9),
    (0.599_791, 1.333100, 9.63e-9),
    (0.650_130, 1.330683, 1.67e-8),
    (0.699_842, 1.328769, 3.35e-8),
    (0.749_894, 1.327201, 1.56e-7),
    (0.779_830, 1.326382, 1.41e-7),
    (0.899_498, 1.323648, 4.86e-7),
    (0.905_733, 1.323520, 5.15e-7),
    (1.548_817, 1.310923, 1.348e-4),
    (1.559_553, 1.310659, 1.240e-4),
];

/// Refractive index and extinction coefficient of liquid water at `lambda_nm` (linear in the
/// Segelstein table, held beyond its ends).
pub fn water_nk(lambda_nm: f64) -> (f64, f64) {
    let l = lambda_nm * 1e-3;
    let first = WATER_NK[0];
    let last = WATER_NK[WATER_NK.len() - 1];
    if l <= first.0 {
        return (first.1, first.2);
    }
    if l >= last.0 {
        return (last.1, last.2);
    }
    let i = WATER_NK.windows(2).position(|w| l <= w[1].0).unwrap_or(0);
    let (a, b) = (WATER_NK[i], WATER_NK[i + 1]);
    let t = (l - a.0) / (b.0 - a.0);
    (a.1 + t * (b.1 - a.1), a.2 + t * (b.2 - a.2))
}

/// Diffuse albedo at normal incidence of a Lambertian surface of albedo `rho` under a water film
/// (Lekner & Dorf 1988): `ρ_w = (1 − F₀) t_in ρ t_d (1 − r̄) / (1 − ρ r̄ t_d²)` with `r̄ = 1 − (1 − F̄)/n²`
/// the internal diffuse reflectance of the water surface, `t_in = e^{−αd}` and `t_d = e^{−2αd}` the
/// film transmittances for the collimated and the diffuse light (α = 4πk/λ; the diffuse one is the
/// Lambertian average `2 E₃(αd)`).
pub fn lekner_dorf_albedo(
    rho: f64,
    n_water: f64,
    k_water: f64,
    lambda_nm: f64,
    thickness_m: f64,
) -> f64 {
    let water = SpecularLobe::new(n_water, 0.0, 0.1, 1.0);
    let r_int = 1.0 - (1.0 - water.f_hemi) / (n_water * n_water);
    let tau = 4.0 * PI * k_water / (lambda_nm * 1e-9) * thickness_m;
    let t_in = (-tau).exp();
    let t_d = 2.0 * exp_integral_e3(tau);
    (1.0 - water.f0) * t_in * rho * t_d * (1.0 - r_int) / (1.0 - rho * r_int * t_d * t_d)
}

/// Exponential integral `E₃(x) = ∫₁^∞ e^{−xt} t⁻³ dt` for `x ≥ 0` (`2E₃(x)` is the transmittance of
/// a slab of optical depth `x` for Lambertian light). Via `E₁` (series below 1, continued fraction
/// above; Abramowitz & Stegun 5.1.11, 5.1.22) and `E_{n+1} = (e^{−x} − x Eₙ)/n`.
pub fn exp_integral_e3(x: f64) -> f64 {
    if x <= 0.0 {
        return 0.5;
    }
    let e1 = if x < 1.0 {
        const EULER_GAMMA: f64 = 0.577_215_664_901_532_9;
        let mut sum = 0.0;
        let mut term = 1.0;
        for k in 1..40 {
            term *= -x / k as f64;
            sum += term / k as f64;
        }
        -EULER_GAMMA - x.ln() - sum
    } else {
        // Lentz's continued fraction for e^x E1(x).
        let mut b = x + 1.0;
        let mut c = 1e300;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..200 {
            let a = -((i * i) as f64);
            b += 2.0;
            d = 1.0 / (a * d + b);
            c = b + a / c;
            let delta = c * d;
            h *= delta;
            if (delta - 1.0).abs() < 1e-15 {
                break;
            }
        }
        h * (-x).exp()
    };
    let e2 = (-x).exp() - x * e1;
    0.5 * ((-x).exp() - x * e2)
}

// ---------------------------------------------------------------------------------------------------
// Material

/// One material: optical properties per band, mm-wave stack, optional transmission, wet mapping.
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    pub name: String,
    pub description: String,
    pub visible: VisibleOptics,
    pub nir905: BandOptics,
    pub nir1550: BandOptics,
    pub mmwave: MmWave,
    pub transmission: Option<Transmission>,
    /// Name of the dry material this one is the wet variant of.
    pub wet_of: Option<String>,
    /// The water film this material was derived with (wet variants only).
    pub water_film: Option<WaterFilm>,
}

/// The lobes and diffuse albedo of a material in one band.
struct BandView<'a> {
    diffuse: f64,
    specular: Option<&'a SpecularLobe>,
    retro: Option<&'a RetroLobe>,
}

/// Reflectance of an ideal Lambertian parametric material, from its name `lambertian_<NN>`
/// (`NN` in 0..=100, digits with an optional decimal point), as a fraction.
pub fn parse_lambertian(name: &str) -> Option<f64> {
    let v = name.strip_prefix("lambertian_")?;
    let valid = !v.is_empty()
        && v.chars().all(|c| c.is_ascii_digit() || c == '.')
        && v.chars().filter(|&c| c == '.').count() <= 1
        && v.starts_with(|c: char| c.is_ascii_digit())
        && v.ends_with(|c: char| c.is_ascii_digit());
    if !valid {
        return None;
    }
    let p: f64 = v.parse().ok()?;
    (0.0..=100.0).contains(&p).then_some(p / 100.0)
}

impl Material {
    /// An ideal Lambertian material of reflectance `rho` (0..=1) in every band. At mm-wave it is a
    /// smooth, lossless dielectric half-space of normal-incidence power reflectance `rho`
    /// (`√ε = (1 + √ρ)/(1 − √ρ)`), a perfect conductor for `rho = 1`.
    pub fn lambertian(name: &str, rho: f64) -> Material {
        let rho = rho.clamp(0.0, 1.0);
        let source = format!("parametric: ideal Lambertian reflectance {:.4}", rho);
        let band = BandOptics {
            diffuse: rho,
            specular: None,
            retro: None,
            source: source.clone(),
        };
        let g = rho.sqrt();
        let mmwave = if rho >= 1.0 {
            MmWave {
                eps_r: None,
                conductor: true,
                thickness_m: None,
                backing: Backing::Air,
                layers: Vec::new(),
                roughness_m: 0.0,
                source: "parametric: perfect conductor (|Γ|² = 1)".to_owned(),
            }
        } else {
            let sqrt_eps = (1.0 + g) / (1.0 - g);
            MmWave {
                eps_r: Some(Permittivity::Constant {
                    re: sqrt_eps * sqrt_eps,
                    loss: 0.0,
                }),
                conductor: false,
                thickness_m: None,
                backing: Backing::Air,
                layers: Vec::new(),
                roughness_m: 0.0,
                source: format!("parametric: lossless dielectric with |Γ(0)|² = {rho:.4}"),
            }
        };
        Material {
            name: name.to_owned(),
            description: format!("Ideal Lambertian reflector, {:.4} in every band", rho),
            visible: VisibleOptics {
                reflectance: [rho; VISIBLE_SAMPLES],
                specular: None,
                retro: None,
                source,
            },
            nir905: band.clone(),
            nir1550: band,
            mmwave,
            transmission: None,
            wet_of: None,
            water_film: None,
        }
    }

    /// The wet variant of this material under `film`, named `name` (Lekner & Dorf 1988): per band the
    /// diffuse albedo becomes [`lekner_dorf_albedo`], the specular lobe is the water surface's
    /// (Segelstein 1981 index, GGX α = `film.roughness`; the dry lobe is drowned), the retro lobe is
    /// scaled by `film.retro_factor`, and a water layer (ITU-R P.840) is laid on the mm-wave stack.
    /// Meant for opaque surfaces: a transmission block is kept, but its slab index becomes the water's.
    pub fn with_water_film(&self, name: &str, film: &WaterFilm) -> Material {
        let d = film.thickness_m;
        let wet_band = |dry: &BandOptics, lambda_nm: f64| -> BandOptics {
            let (n, k) = water_nk(lambda_nm);
            BandOptics {
                diffuse: lekner_dorf_albedo(dry.diffuse, n, k, lambda_nm, d),
                specular: Some(SpecularLobe::new(n, 0.0, film.roughness, 1.0)),
                retro: dry.retro.map(|r| RetroLobe {
                    peak_sr: r.peak_sr * film.retro_factor,
                    ..r
                }),
                source: format!(
                    "derived at {lambda_nm} nm: {} over `{}`; dry: {}",
                    film_summary(film),
                    self.name,
                    dry.source
                ),
            }
        };
        let mut reflectance = [0.0; VISIBLE_SAMPLES];
        for (i, r) in reflectance.iter_mut().enumerate() {
            let l = VISIBLE_START_NM + VISIBLE_STEP_NM * i as f64;
            let (n, k) = water_nk(l);
            *r = lekner_dorf_albedo(self.visible.reflectance[i], n, k, l, d);
        }
        let (n550, _) = water_nk(550.0);
        let visible = VisibleOptics {
            reflectance,
            specular: Some(SpecularLobe::new(n550, 0.0, film.roughness, 1.0)),
            retro: self.visible.retro.map(|r| RetroLobe {
                peak_sr: r.peak_sr * film.retro_factor,
                ..r
            }),
            source: format!(
                "derived: {} over `{}`; dry: {}",
                film_summary(film),
                self.name,
                self.visible.source
            ),
        };
        let mut mmwave = self.mmwave.clone();
        if d > 0.0 {
            mmwave.layers.insert(
                0,
                Layer {
                    name: "water film".to_owned(),
                    eps_r: Permittivity::Water {
                        temperature_c: film.temperature_c,
                    },
                    thickness_m: d,
                    source: Some("ITU-R P.840 water permittivity".to_owned()),
                },
            );
        }
        if let Some(r) = film.mmwave_roughness_m {
            mmwave.roughness_m = r;
        }
        mmwave.source = format!(
            "derived: water layer {d} m (ITU-R P.840) over `{}`; dry: {}",
            self.name, mmwave.source
        );
        Material {
            name: name.to_owned(),
            description: format!("{} (wet: {} m water film)", self.description, d),
            visible,
            nir905: wet_band(&self.nir905, 905.0),
            nir1550: wet_band(&self.nir1550, 1550.0),
            mmwave,
            transmission: self.transmission.clone(),
            wet_of: Some(self.name.clone()),
            water_film: Some(film.clone()),
        }
    }

    fn view(&self, band: Band) -> BandView<'_> {
        match band {
            Band::Visible(l) => BandView {
                diffuse: self.visible.reflectance_at(l),
                specular: self.visible.specular.as_ref(),
                retro: self.visible.retro.as_ref(),
            },
            Band::Nir905 => BandView {
                diffuse: self.nir905.diffuse,
                specular: self.nir905.specular.as_ref(),
                retro: self.nir905.retro.as_ref(),
            },
            Band::Nir1550 => BandView {
                diffuse: self.nir1550.diffuse,
                specular: self.nir1550.specular.as_ref(),
                retro: self.nir1550.retro.as_ref(),
            },
        }
    }

    /// Spectral (diffuse) reflectance at `lambda_nm`, linear between the 10 nm samples.
    pub fn reflectance_visible(&self, lambda_nm: f64) -> f64 {
        self.visible.reflectance_at(lambda_nm)
    }

    /// Diffuse albedo ρ_d (normal incidence) in `band`.
    pub fn diffuse_albedo(&self, band: Band) -> f64 {
        self.view(band).diffuse
    }

    /// BRDF `f(wi, wo)` in sr⁻¹ with every lobe on (unit vectors away from the surface; 0 when either
    /// direction is below the surface).
    pub fn eval_brdf(&self, band: Band, wi: DVec3, wo: DVec3, n: DVec3) -> f64 {
        self.eval_brdf_with(band, wi, wo, n, &MaterialEffects::default())
    }

    /// [`Material::eval_brdf`] under the effect switches (`env.retroreflection`).
    pub fn eval_brdf_with(
        &self,
        band: Band,
        wi: DVec3,
        wo: DVec3,
        n: DVec3,
        fx: &MaterialEffects,
    ) -> f64 {
        let cos_i = n.dot(wi);
        let cos_o = n.dot(wo);
        if cos_i <= 0.0 || cos_o <= 0.0 {
            return 0.0;
        }
        let v = self.view(band);
        let mut f = v.diffuse * FRAC_1_PI;
        if let Some(s) = v.specular {
            f *= s.coupling(cos_i) * s.coupling(cos_o);
            f += s.eval(wi, wo, n, cos_i, cos_o);
        }
        if fx.retroreflection
            && let Some(r) = v.retro
        {
            f += r.eval(wi, wo, cos_i, cos_o);
        }
        f
    }

    /// The parts of [`Material::eval_brdf`] in `band` that do not depend on the diffuse reflectance
    /// (the retro lobe left out): `(c, f_s)` with `f = ρ_d/π · c + f_s`, where `c = c(θi)·c(θo)` is
    /// what the specular lobe leaves to the diffuse part (1 without a lobe) and `f_s` the specular
    /// lobe's BRDF, sr⁻¹. `(0, 0)` when either direction is below the surface. A renderer that folds
    /// `ρ_d` into its light tables evaluates the lobe once per light direction with this.
    pub fn brdf_parts(&self, band: Band, wi: DVec3, wo: DVec3, n: DVec3) -> (f64, f64) {
        let cos_i = n.dot(wi);
        let cos_o = n.dot(wo);
        if cos_i <= 0.0 || cos_o <= 0.0 {
            return (0.0, 0.0);
        }
        match self.specular_lobe(band) {
            Some(s) => (
                s.coupling(cos_i) * s.coupling(cos_o),
                s.eval(wi, wo, n, cos_i, cos_o),
            ),
            None => (1.0, 0.0),
        }
    }

    /// Whether the material has a specular lobe in `band`.
    pub fn has_specular(&self, band: Band) -> bool {
        self.specular_lobe(band).is_some()
    }

    /// The specular lobe of `band` (as [`Material::view`] picks it, without the diffuse lookup).
    fn specular_lobe(&self, band: Band) -> Option<&SpecularLobe> {
        match band {
            Band::Visible(_) => self.visible.specular.as_ref(),
            Band::Nir905 => self.nir905.specular.as_ref(),
            Band::Nir1550 => self.nir1550.specular.as_ref(),
        }
    }

    /// Directional-hemispherical reflectance `∫ f(wi, wo) cos θo dωo` at incidence `wi` (every lobe on):
    /// the diffuse part analytically, the specular and retro lobes numerically. ≤ 1 for a valid material.
    pub fn directional_hemispherical_reflectance(&self, band: Band, wi: DVec3, n: DVec3) -> f64 {
        let cos_i = n.dot(wi);
        if cos_i <= 0.0 {
            return 0.0;
        }
        let v = self.view(band);
        let mut a = v.diffuse;
        if let Some(s) = v.specular {
            a *= (1.0 - s.weight * s.fresnel(cos_i)) / (1.0 - s.weight * s.f0);
            a += s.albedo(cos_i);
        }
        if let Some(r) = v.retro {
            a += r.albedo(wi, n);
        }
        a
    }

    /// Reflectance of the specular lobe for a smooth surface (mirror direction), `w F(θ)`; 0 without
    /// a specular lobe. For transmissive materials see [`Material::slab_optics`].
    pub fn specular_reflectance(&self, band: Band, cos_theta: f64) -> f64 {
        self.view(band)
            .specular
            .map_or(0.0, |s| s.weight * s.fresnel(cos_theta))
    }

    /// Reflectance and transmittance of a transmissive slab (glass, lenses) at incidence `cos θ`:
    /// Fresnel at both faces (per polarisation, then averaged), internal transmittance
    /// `τ = exp(−α d / cos θt)`, incoherent multiple reflections. `None` for opaque materials.
    pub fn slab_optics(&self, band: Band, cos_theta: f64) -> Option<SlabOptics> {
        let tr = self.transmission.as_ref()?;
        let lobe = self.view(band).specular?;
        let lambda = band.wavelength_nm();
        let k = match band {
            Band::Visible(l) => interpolate_visible(&tr.k_visible, l),
            Band::Nir905 => tr.k_905,
            Band::Nir1550 => tr.k_1550,
        };
        let c = cos_theta.clamp(1e-9, 1.0);
        let n = lobe.n;
        let sin_t = (1.0 - c * c).sqrt() / n;
        let cos_t = (1.0 - sin_t * sin_t).max(0.0).sqrt();
        let alpha = 4.0 * PI * k / (lambda * 1e-9);
        let tau = (-alpha * tr.thickness_m / cos_t.max(1e-9)).exp();
        let eps = Complex64::new(n * n, 0.0);
        let theta = c.acos();
        let (mut r_sum, mut t_sum) = (0.0, 0.0);
        for pol in [Polarisation::Te, Polarisation::Tm] {
            let r1 = fresnel_coefficient(eps, theta, pol).norm_sqr();
            let denom = 1.0 - r1 * r1 * tau * tau;
            r_sum += r1 + (1.0 - r1) * (1.0 - r1) * tau * tau * r1 / denom;
            t_sum += (1.0 - r1) * (1.0 - r1) * tau / denom;
        }
        Some(SlabOptics {
            reflectance: 0.5 * r_sum,
            transmittance: 0.5 * t_sum,
        })
    }

    /// Transmittance through the material at `cos θ` in `band` (0 for opaque materials).
    pub fn transmittance(&self, band: Band, cos_theta: f64) -> f64 {
        self.slab_optics(band, cos_theta)
            .map_or(0.0, |s| s.transmittance)
    }

    /// Relative permittivity `ε' − jε''` of the bulk (below any coating layers) at `freq_hz`; `None`
    /// for a perfect conductor.
    pub fn eps_r_mmwave(&self, freq_hz: f64) -> Option<Complex64> {
        self.mmwave.eps_r.as_ref().map(|e| e.eval(freq_hz))
    }

    /// Whether the bulk is a metal.
    pub fn is_conductor(&self) -> bool {
        self.mmwave.conductor
    }

    /// Reflection coefficient of the smooth material (layers, bulk, backing) for a plane wave from
    /// air at `incidence_rad` (TE: E-field ratio, TM: H-field ratio; see the module doc).
    pub fn fresnel_mmwave(&self, freq_hz: f64, incidence_rad: f64, pol: Polarisation) -> Complex64 {
        self.mmwave.response(freq_hz, incidence_rad, pol).gamma
    }

    /// Transmission coefficient through a slab material (tangential field behind the slab relative to
    /// the incident one, phase referenced at the back face); `None` for opaque materials.
    pub fn transmission_mmwave(
        &self,
        freq_hz: f64,
        incidence_rad: f64,
        pol: Polarisation,
    ) -> Option<Complex64> {
        self.mmwave
            .is_slab()
            .then(|| self.mmwave.response(freq_hz, incidence_rad, pol).t)
    }

    /// Reflected and transmitted power fractions `(|Γ|², T)` of the smooth material; `T` is the power
    /// entering the back medium (behind a slab: air; for a half-space: the bulk itself).
    pub fn power_mmwave(&self, freq_hz: f64, incidence_rad: f64, pol: Polarisation) -> (f64, f64) {
        let r = self.mmwave.response(freq_hz, incidence_rad, pol);
        (r.reflectance, r.transmittance)
    }

    /// Ament roughness factor of the top surface `exp(−2 (k σ_h cos θ)²)`.
    pub fn ament_factor(&self, freq_hz: f64, incidence_rad: f64) -> f64 {
        ament_factor(freq_hz, self.mmwave.roughness_m, incidence_rad)
    }

    /// Coherent reflection coefficient under the effect switches: the Fresnel/multilayer coefficient
    /// (or, with `space.fresnel_polarisation` off, the normal-incidence TE value for every angle and
    /// polarisation) times the Ament factor (`space.mmwave_roughness`).
    pub fn reflection_mmwave(
        &self,
        freq_hz: f64,
        incidence_rad: f64,
        pol: Polarisation,
        fx: &MaterialEffects,
    ) -> Complex64 {
        let gamma = if fx.fresnel_polarisation {
            self.fresnel_mmwave(freq_hz, incidence_rad, pol)
        } else {
            self.fresnel_mmwave(freq_hz, 0.0, Polarisation::Te)
        };
        if fx.mmwave_roughness {
            gamma * self.ament_factor(freq_hz, incidence_rad)
        } else {
            gamma
        }
    }
}

fn film_summary(film: &WaterFilm) -> String {
    format!(
        "{} m water film (Lekner & Dorf 1988; water n, k: Segelstein 1981)",
        film.thickness_m
    )
}

// ---------------------------------------------------------------------------------------------------
// The database

/// All materials of a scene.
#[derive(Debug, Clone, Default)]
pub struct MaterialDb {
    materials: Vec<Material>,
    index: HashMap<String, MaterialId>,
    wet: HashMap<MaterialId, MaterialId>,
    dry: HashMap<MaterialId, MaterialId>,
}

impl MaterialDb {
    /// The shipped starter set (`models/resources/materials.json`).
    pub fn builtin() -> MaterialDb {
        static BUILTIN: OnceLock<MaterialDb> = OnceLock::new();
        BUILTIN
            .get_or_init(|| {
                let mut db = MaterialDb::default();
                if let Err(e) = db.extend_from_json_str(BUILTIN_JSON, BUILTIN_LABEL) {
                    panic!("built-in materials database is invalid: {e}");
                }
                db
            })
            .clone()
    }

    /// A database from a JSON document (errors are labelled `<string>`).
    pub fn from_json_str(text: &str) -> Result<MaterialDb, MaterialError> {
        let mut db = MaterialDb::default();
        db.extend_from_json_str(text, "<string>")?;
        Ok(db)
    }

    /// A database from a JSON file.
    pub fn from_json_file(path: impl AsRef<Path>) -> Result<MaterialDb, MaterialError> {
        let mut db = MaterialDb::default();
        db.extend_from_json_file(path)?;
        Ok(db)
    }

    /// Add the materials of a JSON file; a material of the same name is replaced (keeping its id), and
    /// wet variants derived from a replaced dry material are derived again. Returns the ids defined by
    /// the file, in file order.
    pub fn extend_from_json_file(
        &mut self,
        path: impl AsRef<Path>,
    ) -> Result<Vec<MaterialId>, MaterialError> {
        let path = path.as_ref();
        let label = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| MaterialError::Io {
            file: label.clone(),
            message: e.to_string(),
        })?;
        self.extend_from_json_str(&text, &label)
    }

    /// [`MaterialDb::extend_from_json_file`] on a string; `label` names it in errors. On error the
    /// database is unchanged.
    pub fn extend_from_json_str(
        &mut self,
        text: &str,
        label: &str,
    ) -> Result<Vec<MaterialId>, MaterialError> {
        let mut next = self.clone();
        let ids = parse::load(&mut next, text, label)?;
        *self = next;
        Ok(ids)
    }

    /// Id of a material already in the database.
    pub fn id(&self, name: &str) -> Option<MaterialId> {
        self.index.get(name).copied()
    }

    /// Id of a material, creating parametric ones (`lambertian_<percent>`) on first use.
    pub fn resolve(&mut self, name: &str) -> Result<MaterialId, MaterialError> {
        if let Some(id) = self.id(name) {
            return Ok(id);
        }
        match parse_lambertian(name) {
            Some(rho) => Ok(self.insert(Material::lambertian(name, rho))),
            None => Err(MaterialError::Unknown(name.to_owned())),
        }
    }

    /// Name of a material.
    pub fn name(&self, id: MaterialId) -> &str {
        &self.materials[id.0 as usize].name
    }

    /// The material of an id (panics on an id of another database).
    pub fn get(&self, id: MaterialId) -> &Material {
        &self.materials[id.0 as usize]
    }

    /// The material of a name, if present.
    pub fn by_name(&self, name: &str) -> Option<&Material> {
        self.id(name).map(|id| self.get(id))
    }

    /// Number of materials.
    pub fn len(&self) -> usize {
        self.materials.len()
    }

    /// Whether the database is empty.
    pub fn is_empty(&self) -> bool {
        self.materials.is_empty()
    }

    /// All materials with their ids, in id order.
    pub fn iter(&self) -> impl Iterator<Item = (MaterialId, &Material)> {
        self.materials
            .iter()
            .enumerate()
            .map(|(i, m)| (MaterialId(i as u32), m))
    }

    /// Add a material (e.g. one built with [`Material::with_water_film`]); a duplicate name or an
    /// unknown `wet_of` is an error.
    pub fn add(&mut self, material: Material) -> Result<MaterialId, MaterialError> {
        if self.index.contains_key(&material.name) {
            return Err(MaterialError::Invalid(format!(
                "duplicate material `{}`",
                material.name
            )));
        }
        if let Some(dry) = &material.wet_of {
            let dry_id = self
                .id(dry)
                .ok_or_else(|| MaterialError::Unknown(dry.clone()))?;
            if let Some(&other) = self.wet.get(&dry_id) {
                return Err(MaterialError::Invalid(format!(
                    "`{}` is already the wet variant of `{dry}`",
                    self.name(other)
                )));
            }
        }
        Ok(self.insert(material))
    }

    /// Insert or replace without checks; maintains the indices.
    fn insert(&mut self, material: Material) -> MaterialId {
        let id = match self.index.get(&material.name) {
            Some(&id) => {
                self.materials[id.0 as usize] = material;
                id
            }
            None => {
                let id = MaterialId(self.materials.len() as u32);
                self.index.insert(material.name.clone(), id);
                self.materials.push(material);
                id
            }
        };
        self.rebuild_wet_index();
        id
    }

    fn rebuild_wet_index(&mut self) {
        self.wet.clear();
        self.dry.clear();
        for (i, m) in self.materials.iter().enumerate() {
            if let Some(dry) = m.wet_of.as_ref().and_then(|d| self.index.get(d)) {
                self.wet.insert(*dry, MaterialId(i as u32));
                self.dry.insert(MaterialId(i as u32), *dry);
            }
        }
    }

    /// The wet variant of a material (`asphalt_dry` → `asphalt_wet`, ...); a wet material is its own
    /// wet variant; `None` for materials without one.
    pub fn wet_variant(&self, id: MaterialId) -> Option<MaterialId> {
        if self.dry.contains_key(&id) {
            Some(id)
        } else {
            self.wet.get(&id).copied()
        }
    }

    /// The dry material of a wet variant (`None` for dry materials).
    pub fn dry_variant(&self, id: MaterialId) -> Option<MaterialId> {
        self.dry.get(&id).copied()
    }

    /// The material to use for a surface: its wet variant when `wet` and `env.wet_surfaces` is on,
    /// else the material itself.
    pub fn surface(&self, id: MaterialId, wet: bool, fx: &MaterialEffects) -> MaterialId {
        if wet && fx.wet_surfaces {
            self.wet_variant(id).unwrap_or(id)
        } else {
            id
        }
    }

    /// Optical transmittance of a material at `cos θ` (0 for opaque materials).
    pub fn transmittance(&self, id: MaterialId, band: Band, cos_theta: f64) -> f64 {
        self.get(id).transmittance(band, cos_theta)
    }
}

// ---------------------------------------------------------------------------------------------------
// JSON loading

mod parse {
    use super::*;
    use serde::de::{self, MapAccess, Visitor};
    use std::fmt;

    #[derive(Deserialize)]
    #[serde(deny_unknown_fields)]
    struct RawFile {
        schema: String,
        #[serde(default)]
        #[allow(dead_code)]
        description: Option<String>,
        materials: RawMaterials,
    }

    /// The `materials` object, in file order, duplicates rejected.
    struct RawMaterials(Vec<(String, RawMaterial)>);

    impl<'de> Deserialize<'de> for RawMaterials {
        fn deserialize<D: de::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
            struct V;
            impl<'de> Visitor<'de> for V {
                type Value = RawMaterials;
                fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                    f.write_str("an object of materials by name")
                }
                fn visit_map<A: MapAccess<'de>>(
                    self,
                    mut map: A,
                ) -> Result<RawMaterials, A::Error> {
                    let mut out: Vec<(String, RawMaterial)> = Vec::new();
                    while let Some(name) = map.next_key::<String>()? {
                        if out.iter().any(|(n, _)| *n == name) {
                            return Err(de::Error::custom(format!("duplicate material `{name}`")));
                        }
                        let m = map.next_value::<RawMaterial>()?;
                        out.push((name, m));
                    }
                    Ok(RawMaterials(out))
                }
            }
            d.deserialize_map(V)
        }
    }

    #[derive(Deserialize)]
    #[serde(deny_unknown_fields)]
    struct RawMaterial {
        #[serde(default)]
        description: String,
        visible: Option<RawVisible>,
        nir: Option<RawNir>,
        mmwave: Option<RawMmWave>,
        transmission: Option<RawTransmission>,
        wet_of: Option<String>,
        water_film: Option<RawWaterFilm>,
    }

    #[derive(Deserialize)]
    #[serde(deny_unknown_fields)]
    struct RawVisible {
        reflectance: Vec<f64>,
        specular: Option<RawSpecular>,
        retro: Option<RawRetro>,
        source: String,
    }

    #[derive(Deserialize)]
    #[serde(deny_unknown_fields)]
    struct RawNir {
        #[serde(rename = "905")]
        nm905: RawBand,
        #[serde(rename = "1550")]
        nm1550: RawBand,
    }

    #[derive(Deserialize)]
    #[serde(deny_unknown_fields)]
    struct RawBand {
        diffuse: f64,
        specular: Option<RawSpecular>,
        retro: Option<RawRetro>,
        source: String,
    }

    fn one() -> f64 {
        1.0
    }

    fn fifteen() -> f64 {
        15.0
    }

    #[derive(Deserialize, Clone, Copy)]
    #[serde(deny_unknown_fields)]
    struct RawSpecular {
        n: f64,
        #[serde(default)]
        k: f64,
        roughness: f64,
        #[serde(default = "one")]
        weight: f64,
    }

    #[derive(Deserialize, Clone, Copy)]
    #[serde(deny_unknown_fields)]
    struct RawRetro {
        peak_sr: f64,
        width_rad: f64,
        #[serde(default)]
        entrance_exponent: f64,
    }

    #[derive(Deserialize, Clone, Copy, PartialEq, Eq)]
    #[serde(rename_all = "lowercase")]
    enum RawBacking {
        Air,
        Pec,
    }

    #[derive(Deserialize)]
    #[serde(deny_unknown_fields)]
    struct RawMmWave {
        eps_r: Option<Permittivity>,
        #[serde(default)]
        conductor: bool,
        sigma_s_per_m: Option<f64>,
        thickness_m: Option<f64>,
        backing: Option<RawBacking>,
        #[serde(default)]
        layers: Vec<RawLayer>,
        #[serde(default)]
        roughness_m: f64,
        source: String,
    }

    #[derive(Deserialize)]
    #[serde(deny_unknown_fields)]
    struct RawLayer {
        name: String,
        eps_r: Permittivity,
        thickness_m: f64,
        source: Option<String>,
    }

    #[derive(Deserialize)]
    #[serde(deny_unknown_fields)]
    struct RawTransmission {
        thickness_m: f64,
        k_visible: Vec<f64>,
        k_905: f64,
        k_1550: f64,
        source: String,
    }

    #[derive(Deserialize)]
    #[serde(deny_unknown_fields)]
    struct RawWaterFilm {
        thickness_m: f64,
        roughness: f64,
        mmwave_roughness_m: Option<f64>,
        #[serde(default = "one")]
        retro_factor: f64,
        #[serde(default = "fifteen")]
        temperature_c: f64,
        source: String,
    }

    impl<'de> Deserialize<'de> for Permittivity {
        fn deserialize<D: de::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
            let v = serde_json::Value::deserialize(d)?;
            permittivity_from_value(&v).map_err(de::Error::custom)
        }
    }

    const PERMITTIVITY_FORMS: &str = "expected [eps', eps''], {\"itu_p2040\": [a, b, c, d]}, {\"water\": \
        {\"temperature_c\": T}}, {\"cole_cole\": {\"eps_inf\", \"sigma_s_per_m\", \"terms\": [[d_eps, tau_s, \
        alpha], ...]}} or {\"table\": [[f_ghz, eps', eps''], ...]}";

    fn numbers(v: &serde_json::Value, len: Option<usize>) -> Option<Vec<f64>> {
        let a = v.as_array()?;
        if len.is_some_and(|n| a.len() != n) {
            return None;
        }
        a.iter().map(|x| x.as_f64()).collect()
    }

    fn permittivity_from_value(v: &serde_json::Value) -> Result<Permittivity, String> {
        let bad = |what: &str| format!("invalid permittivity ({what}): {PERMITTIVITY_FORMS}");
        if v.is_array() {
            let x = numbers(v, Some(2)).ok_or_else(|| bad("not two numbers"))?;
            return Ok(Permittivity::Constant {
                re: x[0],
                loss: x[1],
            });
        }
        let obj = v
            .as_object()
            .ok_or_else(|| bad("neither an array nor an object"))?;
        if obj.len() != 1 {
            return Err(bad("an object must have exactly one key"));
        }
        let (key, val) = obj.iter().next().expect("one key");
        match key.as_str() {
            "itu_p2040" => {
                let x = numbers(val, Some(4)).ok_or_else(|| bad("itu_p2040 needs 4 numbers"))?;
                Ok(Permittivity::ItuP2040 {
                    a: x[0],
                    b: x[1],
                    c: x[2],
                    d: x[3],
                })
            }
            "water" => {
                let o = val
                    .as_object()
                    .ok_or_else(|| bad("water needs an object"))?;
                if o.keys().any(|k| k != "temperature_c") {
                    return Err(bad("water takes only temperature_c"));
                }
                let t = match o.get("temperature_c") {
                    None => 15.0,
                    Some(t) => t
                        .as_f64()
                        .ok_or_else(|| bad("temperature_c must be a number"))?,
                };
                Ok(Permittivity::Water { temperature_c: t })
            }
            "cole_cole" => {
                let o = val
                    .as_object()
                    .ok_or_else(|| bad("cole_cole needs an object"))?;
                if o.keys()
                    .any(|k| !matches!(k.as_str(), "eps_inf" | "sigma_s_per_m" | "terms"))
                {
                    return Err(bad("cole_cole takes eps_inf, sigma_s_per_m and terms"));
                }
                let eps_inf = o
                    .get("eps_inf")
                    .and_then(|x| x.as_f64())
                    .ok_or_else(|| bad("cole_cole.eps_inf missing"))?;
                let sigma = o
                    .get("sigma_s_per_m")
                    .map_or(Some(0.0), |x| x.as_f64())
                    .ok_or_else(|| bad("sigma"))?;
                let terms = o
                    .get("terms")
                    .and_then(|t| t.as_array())
                    .ok_or_else(|| bad("cole_cole.terms missing"))?
                    .iter()
                    .map(|t| {
                        numbers(t, Some(3)).map(|x| ColeColeTerm {
                            delta_eps: x[0],
                            tau_s: x[1],
                            alpha: x[2],
                        })
                    })
                    .collect::<Option<Vec<_>>>()
                    .ok_or_else(|| bad("each term is [d_eps, tau_s, alpha]"))?;
                Ok(Permittivity::ColeCole {
                    eps_inf,
                    sigma_s_per_m: sigma,
                    terms,
                })
            }
            "table" => {
                let rows = val
                    .as_array()
                    .ok_or_else(|| bad("table needs an array"))?
                    .iter()
                    .map(|r| numbers(r, Some(3)).map(|x| (x[0], x[1], x[2])))
                    .collect::<Option<Vec<_>>>()
                    .ok_or_else(|| bad("each row is [f_ghz, eps', eps'']"))?;
                if rows.is_empty() {
                    return Err(bad("empty table"));
                }
                if rows.windows(2).any(|w| w[1].0 <= w[0].0) {
                    return Err(bad("table frequencies must increase"));
                }
                Ok(Permittivity::Table(rows))
            }
            other => Err(bad(&format!("unknown form `{other}`"))),
        }
    }

    /// 1-based (line, column) of byte offset `at`.
    fn line_col(text: &str, at: usize) -> (usize, usize) {
        let before = &text[..at.min(text.len())];
        let line = before.matches('\n').count() + 1;
        let column = before
            .rfind('\n')
            .map_or(before.chars().count(), |p| before[p + 1..].chars().count())
            + 1;
        (line, column)
    }

    /// Offset of `"key"` followed by `:` at or after `from`.
    fn find_key(text: &str, key: &str, from: usize) -> Option<usize> {
        let pat = format!("\"{key}\"");
        let mut start = from;
        while let Some(p) = text.get(start..)?.find(&pat) {
            let at = start + p;
            let rest = text[at + pat.len()..].trim_start();
            if rest.starts_with(':') {
                return Some(at);
            }
            start = at + pat.len();
        }
        None
    }

    /// Best-effort position of `key` (dotted) inside material `material`.
    fn locate(text: &str, material: &str, key: Option<&str>) -> (usize, usize) {
        let base = find_key(text, "materials", 0).unwrap_or(0);
        let Some(mut at) = find_key(text, material, base) else {
            return line_col(text, base);
        };
        if let Some(key) = key {
            for seg in key.split('.') {
                let seg = seg.split('[').next().unwrap_or(seg);
                if seg.is_empty() {
                    continue;
                }
                match find_key(text, seg, at) {
                    Some(p) => at = p,
                    None => break,
                }
            }
        }
        line_col(text, at)
    }

    /// Context of one load, for errors.
    struct Ctx<'a> {
        text: &'a str,
        file: &'a str,
    }

    impl Ctx<'_> {
        fn err(
            &self,
            material: &str,
            key: Option<&str>,
            message: impl Into<String>,
        ) -> MaterialError {
            let (line, column) = locate(self.text, material, key);
            MaterialError::Parse {
                file: self.file.to_owned(),
                line,
                column,
                material: Some(material.to_owned()),
                key: key.map(str::to_owned),
                message: message.into(),
            }
        }
    }

    fn check_range(
        ctx: &Ctx,
        m: &str,
        key: &str,
        v: f64,
        lo: f64,
        hi: f64,
    ) -> Result<f64, MaterialError> {
        if v.is_finite() && v >= lo && v <= hi {
            Ok(v)
        } else {
            Err(ctx.err(m, Some(key), format!("{v} is outside [{lo}, {hi}]")))
        }
    }

    fn check_source(ctx: &Ctx, m: &str, key: &str, s: &str) -> Result<String, MaterialError> {
        if s.trim().is_empty() {
            Err(ctx.err(
                m,
                Some(key),
                "empty source: every value needs its source (or `estimate: ...`)",
            ))
        } else {
            Ok(s.to_owned())
        }
    }

    fn lobe(ctx: &Ctx, m: &str, key: &str, s: &RawSpecular) -> Result<SpecularLobe, MaterialError> {
        check_range(ctx, m, &format!("{key}.n"), s.n, 1e-3, 100.0)?;
        check_range(ctx, m, &format!("{key}.k"), s.k, 0.0, 100.0)?;
        check_range(ctx, m, &format!("{key}.roughness"), s.roughness, 1e-4, 1.0)?;
        check_range(ctx, m, &format!("{key}.weight"), s.weight, 0.0, 1.0)?;
        Ok(SpecularLobe::new(s.n, s.k, s.roughness, s.weight))
    }

    fn retro(ctx: &Ctx, m: &str, key: &str, r: &RawRetro) -> Result<RetroLobe, MaterialError> {
        check_range(ctx, m, &format!("{key}.peak_sr"), r.peak_sr, 0.0, 1e7)?;
        check_range(
            ctx,
            m,
            &format!("{key}.width_rad"),
            r.width_rad,
            1e-5,
            PI / 2.0,
        )?;
        check_range(
            ctx,
            m,
            &format!("{key}.entrance_exponent"),
            r.entrance_exponent,
            0.0,
            100.0,
        )?;
        Ok(RetroLobe {
            peak_sr: r.peak_sr,
            width_rad: r.width_rad,
            entrance_exponent: r.entrance_exponent,
        })
    }

    fn energy(
        ctx: &Ctx,
        m: &str,
        key: &str,
        diffuse: f64,
        s: Option<&SpecularLobe>,
    ) -> Result<(), MaterialError> {
        if let Some(s) = s
            && diffuse > 1.0 - s.weight * s.f0 + 1e-9
        {
            return Err(ctx.err(
                m,
                Some(key),
                format!(
                    "diffuse {diffuse} + specular weight × F0 {:.4} exceeds 1 (energy conservation)",
                    s.weight * s.f0
                ),
            ));
        }
        Ok(())
    }

    fn band(ctx: &Ctx, m: &str, key: &str, b: &RawBand) -> Result<BandOptics, MaterialError> {
        let diffuse = check_range(ctx, m, &format!("{key}.diffuse"), b.diffuse, 0.0, 1.0)?;
        let specular = b
            .specular
            .as_ref()
            .map(|s| lobe(ctx, m, &format!("{key}.specular"), s))
            .transpose()?;
        energy(
            ctx,
            m,
            &format!("{key}.diffuse"),
            diffuse,
            specular.as_ref(),
        )?;
        Ok(BandOptics {
            diffuse,
            specular,
            retro: b
                .retro
                .as_ref()
                .map(|r| retro(ctx, m, &format!("{key}.retro"), r))
                .transpose()?,
            source: check_source(ctx, m, &format!("{key}.source"), &b.source)?,
        })
    }

    fn samples(
        ctx: &Ctx,
        m: &str,
        key: &str,
        v: &[f64],
        hi: f64,
    ) -> Result<[f64; VISIBLE_SAMPLES], MaterialError> {
        if v.len() != VISIBLE_SAMPLES {
            return Err(ctx.err(
                m,
                Some(key),
                format!(
                    "expected {VISIBLE_SAMPLES} samples (380..=780 nm in 10 nm steps), got {}",
                    v.len()
                ),
            ));
        }
        let mut out = [0.0; VISIBLE_SAMPLES];
        for (i, (o, &x)) in out.iter_mut().zip(v).enumerate() {
            *o = check_range(ctx, m, &format!("{key}[{i}]"), x, 0.0, hi)?;
        }
        Ok(out)
    }

    fn visible(ctx: &Ctx, m: &str, v: &RawVisible) -> Result<VisibleOptics, MaterialError> {
        let reflectance = samples(ctx, m, "visible.reflectance", &v.reflectance, 1.0)?;
        let specular = v
            .specular
            .as_ref()
            .map(|s| lobe(ctx, m, "visible.specular", s))
            .transpose()?;
        let max = reflectance.iter().copied().fold(0.0, f64::max);
        energy(ctx, m, "visible.reflectance", max, specular.as_ref())?;
        Ok(VisibleOptics {
            reflectance,
            specular,
            retro: v
                .retro
                .as_ref()
                .map(|r| retro(ctx, m, "visible.retro", r))
                .transpose()?,
            source: check_source(ctx, m, "visible.source", &v.source)?,
        })
    }

    fn permittivity(ctx: &Ctx, m: &str, key: &str, p: &Permittivity) -> Result<(), MaterialError> {
        let ok = match p {
            Permittivity::Constant { re, loss } => {
                re.is_finite() && *re > 0.0 && loss.is_finite() && *loss >= 0.0
            }
            Permittivity::ItuP2040 { a, b, c, d } => {
                *a > 0.0 && *c >= 0.0 && b.is_finite() && d.is_finite()
            }
            Permittivity::Water { temperature_c } => (-10.0..=60.0).contains(temperature_c),
            Permittivity::ColeCole {
                eps_inf,
                sigma_s_per_m,
                terms,
            } => {
                *eps_inf > 0.0
                    && *sigma_s_per_m >= 0.0
                    && terms.iter().all(|t| {
                        t.delta_eps >= 0.0 && t.tau_s > 0.0 && (0.0..1.0).contains(&t.alpha)
                    })
            }
            Permittivity::Table(rows) => rows.iter().all(|r| r.0 > 0.0 && r.1 > 0.0 && r.2 >= 0.0),
            Permittivity::Conductor { sigma_s_per_m } => *sigma_s_per_m > 0.0,
        };
        if ok {
            Ok(())
        } else {
            Err(ctx.err(
                m,
                Some(key),
                format!("non-physical permittivity {p:?} (need ε' > 0, ε'' ≥ 0)"),
            ))
        }
    }

    fn mmwave(ctx: &Ctx, m: &str, w: &RawMmWave) -> Result<MmWave, MaterialError> {
        let eps_r = match (&w.eps_r, w.conductor) {
            (Some(_), true) => {
                return Err(ctx.err(
                    m,
                    Some("mmwave.eps_r"),
                    "a conductor takes sigma_s_per_m, not eps_r",
                ));
            }
            (None, false) => {
                return Err(ctx.err(m, Some("mmwave"), "missing `eps_r` (or `conductor: true`)"));
            }
            (Some(e), false) => {
                permittivity(ctx, m, "mmwave.eps_r", e)?;
                Some(e.clone())
            }
            (None, true) => match w.sigma_s_per_m {
                Some(s) => {
                    check_range(ctx, m, "mmwave.sigma_s_per_m", s, 1.0, 1e10)?;
                    Some(Permittivity::Conductor { sigma_s_per_m: s })
                }
                None => None,
            },
        };
        if w.sigma_s_per_m.is_some() && !w.conductor {
            return Err(ctx.err(
                m,
                Some("mmwave.sigma_s_per_m"),
                "sigma_s_per_m needs `conductor: true`",
            ));
        }
        if let Some(t) = w.thickness_m {
            check_range(ctx, m, "mmwave.thickness_m", t, 1e-9, 10.0)?;
        }
        if w.backing.is_some() && w.thickness_m.is_none() {
            return Err(ctx.err(
                m,
                Some("mmwave.backing"),
                "backing needs thickness_m (a slab)",
            ));
        }
        let roughness_m = check_range(ctx, m, "mmwave.roughness_m", w.roughness_m, 0.0, 0.1)?;
        let mut layers = Vec::with_capacity(w.layers.len());
        for (i, l) in w.layers.iter().enumerate() {
            let key = format!("mmwave.layers[{i}]");
            permittivity(ctx, m, &format!("{key}.eps_r"), &l.eps_r)?;
            check_range(
                ctx,
                m,
                &format!("{key}.thickness_m"),
                l.thickness_m,
                1e-9,
                10.0,
            )?;
            layers.push(Layer {
                name: l.name.clone(),
                eps_r: l.eps_r.clone(),
                thickness_m: l.thickness_m,
                source: l.source.clone(),
            });
        }
        Ok(MmWave {
            eps_r,
            conductor: w.conductor,
            thickness_m: w.thickness_m,
            backing: match w.backing {
                Some(RawBacking::Pec) => Backing::Pec,
                _ => Backing::Air,
            },
            layers,
            roughness_m,
            source: check_source(ctx, m, "mmwave.source", &w.source)?,
        })
    }

    fn transmission(
        ctx: &Ctx,
        m: &str,
        t: &RawTransmission,
        bands: [&Option<SpecularLobe>; 3],
    ) -> Result<Transmission, MaterialError> {
        if bands.iter().any(|b| b.is_none()) {
            return Err(ctx.err(
                m,
                Some("transmission"),
                "a transmissive material needs a specular lobe in every band (its n is the slab's index)",
            ));
        }
        Ok(Transmission {
            thickness_m: check_range(
                ctx,
                m,
                "transmission.thickness_m",
                t.thickness_m,
                1e-9,
                10.0,
            )?,
            k_visible: samples(ctx, m, "transmission.k_visible", &t.k_visible, 10.0)?,
            k_905: check_range(ctx, m, "transmission.k_905", t.k_905, 0.0, 10.0)?,
            k_1550: check_range(ctx, m, "transmission.k_1550", t.k_1550, 0.0, 10.0)?,
            source: check_source(ctx, m, "transmission.source", &t.source)?,
        })
    }

    fn water_film(ctx: &Ctx, m: &str, f: &RawWaterFilm) -> Result<WaterFilm, MaterialError> {
        Ok(WaterFilm {
            thickness_m: check_range(ctx, m, "water_film.thickness_m", f.thickness_m, 0.0, 0.1)?,
            roughness: check_range(ctx, m, "water_film.roughness", f.roughness, 1e-4, 1.0)?,
            mmwave_roughness_m: f
                .mmwave_roughness_m
                .map(|r| check_range(ctx, m, "water_film.mmwave_roughness_m", r, 0.0, 0.1))
                .transpose()?,
            retro_factor: check_range(ctx, m, "water_film.retro_factor", f.retro_factor, 0.0, 1.0)?,
            temperature_c: check_range(
                ctx,
                m,
                "water_film.temperature_c",
                f.temperature_c,
                -10.0,
                60.0,
            )?,
            source: check_source(ctx, m, "water_film.source", &f.source)?,
        })
    }

    fn valid_name(name: &str) -> bool {
        !name.is_empty()
            && name
                .chars()
                .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_')
    }

    /// Parse `text` and insert its materials into `db`.
    pub(super) fn load(
        db: &mut MaterialDb,
        text: &str,
        file: &str,
    ) -> Result<Vec<MaterialId>, MaterialError> {
        let ctx = Ctx { text, file };
        let de = &mut serde_json::Deserializer::from_str(text);
        let raw: RawFile = serde_path_to_error::deserialize(de).map_err(|e| {
            let mut material = None;
            let mut key: Vec<String> = Vec::new();
            let mut in_materials = false;
            for seg in e.path().iter() {
                use serde_path_to_error::Segment;
                match seg {
                    Segment::Map { key: k } if material.is_none() && in_materials => {
                        material = Some(k.clone())
                    }
                    Segment::Map { key: k }
                        if k == "materials" && !in_materials && material.is_none() =>
                    {
                        in_materials = true
                    }
                    Segment::Map { key: k } if material.is_some() => key.push(k.clone()),
                    Segment::Seq { index } if material.is_some() => {
                        if let Some(last) = key.last_mut() {
                            last.push_str(&format!("[{index}]"));
                        }
                    }
                    _ => {}
                }
            }
            let inner = e.inner();
            let mut message = inner.to_string();
            // serde_json appends " at line L column C"; the error carries them separately.
            if let Some(p) = message.rfind(" at line ") {
                message.truncate(p);
            }
            MaterialError::Parse {
                file: file.to_owned(),
                line: inner.line(),
                column: inner.column(),
                material,
                key: (!key.is_empty()).then(|| key.join(".")),
                message,
            }
        })?;
        if raw.schema != SCHEMA {
            let (line, column) = find_key(text, "schema", 0).map_or((1, 1), |p| line_col(text, p));
            return Err(MaterialError::Parse {
                file: file.to_owned(),
                line,
                column,
                material: None,
                key: Some("schema".to_owned()),
                message: format!("unsupported schema `{}` (expected `{SCHEMA}`)", raw.schema),
            });
        }

        // Pass 1: explicit materials. Pass 2: materials derived from a water film.
        let mut ids = Vec::new();
        let mut replaced: Vec<String> = Vec::new();
        let mut derived: Vec<(String, String, WaterFilm, String)> = Vec::new();
        for (name, m) in &raw.materials.0 {
            if !valid_name(name) {
                return Err(ctx.err(name, None, "material names use a-z, 0-9 and `_`"));
            }
            if parse_lambertian(name).is_some() || name.starts_with("lambertian_") {
                return Err(ctx.err(
                    name,
                    None,
                    "`lambertian_<NN>` names are reserved for parametric materials",
                ));
            }
            if let Some(dry) = &m.wet_of
                && (dry == name || !valid_name(dry))
            {
                return Err(ctx.err(
                    name,
                    Some("wet_of"),
                    format!("invalid dry material `{dry}`"),
                ));
            }
            if let Some(film) = &m.water_film {
                let Some(dry) = &m.wet_of else {
                    return Err(ctx.err(
                        name,
                        Some("water_film"),
                        "water_film needs `wet_of` (the dry material)",
                    ));
                };
                for (k, present) in [
                    ("visible", m.visible.is_some()),
                    ("nir", m.nir.is_some()),
                    ("mmwave", m.mmwave.is_some()),
                    ("transmission", m.transmission.is_some()),
                ] {
                    if present {
                        return Err(ctx.err(
                            name,
                            Some(k),
                            "derived from water_film: remove this key",
                        ));
                    }
                }
                derived.push((
                    name.clone(),
                    dry.clone(),
                    water_film(&ctx, name, film)?,
                    m.description.clone(),
                ));
                continue;
            }
            let visible = match &m.visible {
                Some(v) => visible(&ctx, name, v)?,
                None => return Err(ctx.err(name, None, "missing key `visible`")),
            };
            let (nir905, nir1550) = match &m.nir {
                Some(n) => (
                    band(&ctx, name, "nir.905", &n.nm905)?,
                    band(&ctx, name, "nir.1550", &n.nm1550)?,
                ),
                None => return Err(ctx.err(name, None, "missing key `nir`")),
            };
            let mmwave = match &m.mmwave {
                Some(w) => mmwave(&ctx, name, w)?,
                None => return Err(ctx.err(name, None, "missing key `mmwave`")),
            };
            let transmission = m
                .transmission
                .as_ref()
                .map(|t| {
                    transmission(
                        &ctx,
                        name,
                        t,
                        [&visible.specular, &nir905.specular, &nir1550.specular],
                    )
                })
                .transpose()?;
            if db.id(name).is_some() {
                replaced.push(name.clone());
            }
            ids.push(db.insert(Material {
                name: name.clone(),
                description: m.description.clone(),
                visible,
                nir905,
                nir1550,
                mmwave,
                transmission,
                wet_of: m.wet_of.clone(),
                water_film: None,
            }));
        }
        for (name, dry, film, description) in &derived {
            let Some(dry_m) = db.by_name(dry) else {
                return Err(ctx.err(
                    name,
                    Some("wet_of"),
                    format!("unknown dry material `{dry}`"),
                ));
            };
            if dry_m.wet_of.is_some() {
                return Err(ctx.err(
                    name,
                    Some("wet_of"),
                    format!("`{dry}` is itself a wet variant"),
                ));
            }
            let mut wet = dry_m.with_water_film(name, film);
            if !description.is_empty() {
                wet.description = description.clone();
            }
            ids.push(db.insert(wet));
        }
        // Re-derive film-derived wet variants (from earlier loads) of replaced dry materials.
        let stale: Vec<(String, String, WaterFilm, String)> = db
            .materials
            .iter()
            .filter_map(|m| {
                let dry = m.wet_of.as_ref()?;
                let film = m.water_film.as_ref()?;
                (replaced.contains(dry) && !derived.iter().any(|d| d.0 == m.name)).then(|| {
                    (
                        m.name.clone(),
                        dry.clone(),
                        film.clone(),
                        m.description.clone(),
                    )
                })
            })
            .collect();
        for (name, dry, film, description) in stale {
            let mut wet = db
                .by_name(&dry)
                .expect("replaced dry material")
                .with_water_film(&name, &film);
            wet.description = description;
            db.insert(wet);
        }
        // Every wet_of must name a known dry material, with at most one wet variant each.
        let mut seen: HashMap<String, String> = HashMap::new();
        for m in &db.materials {
            if let Some(dry) = &m.wet_of {
                if db.id(dry).is_none() {
                    return Err(ctx.err(
                        &m.name,
                        Some("wet_of"),
                        format!("unknown dry material `{dry}`"),
                    ));
                }
                if let Some(other) = seen.insert(dry.clone(), m.name.clone()) {
                    return Err(ctx.err(
                        &m.name,
                        Some("wet_of"),
                        format!("`{dry}` already has the wet variant `{other}`"),
                    ));
                }
            }
        }
        Ok(ids)
    }
}

// ---------------------------------------------------------------------------------------------------

#[cfg(test)]
mod tests {
    use super::*;

    const F77: f64 = 77e9;

    fn deg(d: f64) -> f64 {
        d.to_radians()
    }

    /// Direction at polar angle `theta_deg` from +z, azimuth `phi_deg`.
    fn dir(theta_deg: f64, phi_deg: f64) -> DVec3 {
        let (st, ct) = deg(theta_deg).sin_cos();
        let (sp, cp) = deg(phi_deg).sin_cos();
        DVec3::new(st * cp, st * sp, ct)
    }

    /// A minimal valid material JSON document with one material whose mm-wave block is `mmwave`.
    fn doc_with_mmwave(name: &str, mmwave: &str) -> String {
        format!(
            r#"{{"schema": "osiris-materials/1", "materials": {{ "{name}": {{
                "visible": {{"reflectance": [{refl}], "source": "test"}},
                "nir": {{"905": {{"diffuse": 0.5, "source": "test"}}, "1550": {{"diffuse": 0.5, "source": "test"}}}},
                "mmwave": {mmwave} }} }} }}"#,
            refl = vec!["0.5"; VISIBLE_SAMPLES].join(", ")
        )
    }

    fn half_space(re: f64, loss: f64) -> Material {
        let doc = doc_with_mmwave(
            "m",
            &format!(r#"{{"eps_r": [{re}, {loss}], "source": "test"}}"#),
        );
        MaterialDb::from_json_str(&doc)
            .unwrap()
            .by_name("m")
            .unwrap()
            .clone()
    }

    /// physics.md §1.3 closed forms in the grazing angle ψ = 90° − θ.
    fn closed_form(eps: Complex64, theta: f64, pol: Polarisation) -> Complex64 {
        let psi = PI / 2.0 - theta;
        let s = Complex64::new(psi.sin(), 0.0);
        let root = (eps - psi.cos() * psi.cos()).sqrt();
        match pol {
            Polarisation::Te => (s - root) / (s + root),
            Polarisation::Tm => (eps * s - root) / (eps * s + root),
        }
    }

    /// `brdf_parts` recombines to `eval_brdf` (retro lobe aside) for every built-in material.
    #[test]
    fn brdf_parts_recombine_to_the_brdf() {
        let db = MaterialDb::builtin();
        let n = DVec3::Z;
        let mut with_lobe = 0;
        for (_, m) in db.iter() {
            if m.visible.retro.is_some() {
                continue;
            }
            with_lobe += usize::from(m.has_specular(Band::Visible(550.0)));
            for (ti, pi, to, po) in [
                (0.0, 0.0, 0.0, 0.0),
                (30.0, 0.0, 30.0, 180.0),
                (60.0, 10.0, 20.0, 200.0),
                (85.0, 0.0, 40.0, 90.0),
            ] {
                let (wi, wo) = (dir(ti, pi), dir(to, po));
                let b = Band::Visible(550.0);
                let (c, fs) = m.brdf_parts(b, wi, wo, n);
                let f = m.diffuse_albedo(b) * FRAC_1_PI * c + fs;
                let e = m.eval_brdf(b, wi, wo, n);
                assert!((f - e).abs() <= 1e-12 * (1.0 + e), "{}: {f} vs {e}", m.name);
            }
            assert_eq!(
                m.brdf_parts(Band::Visible(550.0), -DVec3::Z, DVec3::Z, n),
                (0.0, 0.0)
            );
        }
        assert!(with_lobe > 0);
    }

    #[test]
    fn material_fresnel_matches_closed_forms() {
        for (re, loss) in [(4.0, 0.0), (4.0, 0.2), (3.2, 0.2), (6.31, 0.28)] {
            let m = half_space(re, loss);
            let eps = Complex64::new(re, -loss);
            for theta in [0.0, 10.0, 30.0, 45.0, 60.0, 80.0, 89.0] {
                for pol in [Polarisation::Te, Polarisation::Tm] {
                    let g = m.fresnel_mmwave(F77, deg(theta), pol);
                    let c = closed_form(eps, deg(theta), pol);
                    assert!(
                        (g - c).norm() < 1e-12,
                        "ε={eps} θ={theta} {pol:?}: {g} vs {c}"
                    );
                }
            }
        }
        // physics.md example: ε = 4 − j0.2, h = 0.5 m both ends, d = 10 m: |Γ_H| = 0.89, |Γ_V| = 0.63.
        let m = half_space(4.0, 0.2);
        let psi = (1.0f64 / 10.0).atan();
        let gh = m
            .fresnel_mmwave(F77, PI / 2.0 - psi, Polarisation::Te)
            .norm();
        let gv = m
            .fresnel_mmwave(F77, PI / 2.0 - psi, Polarisation::Tm)
            .norm();
        assert!(
            (gh - 0.89).abs() < 0.005 && (gv - 0.63).abs() < 0.005,
            "{gh} {gv}"
        );
    }

    #[test]
    fn material_normal_incidence_and_brewster() {
        let eps: f64 = 4.0;
        let m = half_space(eps, 0.0);
        let te = m.fresnel_mmwave(F77, 0.0, Polarisation::Te);
        let tm = m.fresnel_mmwave(F77, 0.0, Polarisation::Tm);
        let expected = (1.0 - eps.sqrt()) / (1.0 + eps.sqrt());
        assert!((te.re - expected).abs() < 1e-14 && te.im.abs() < 1e-14);
        assert!(
            (tm.re + expected).abs() < 1e-14,
            "Γ_TM(0) = −Γ_TE(0) in this convention"
        );
        // Brewster: |Γ_TM| vanishes at tan θ_B = √ε and is minimal there.
        let theta_b = eps.sqrt().atan();
        assert!(m.fresnel_mmwave(F77, theta_b, Polarisation::Tm).norm() < 1e-12);
        let (mut best, mut best_theta) = (f64::MAX, 0.0);
        for i in 0..9000 {
            let theta = deg(i as f64 * 0.01);
            let g = m.fresnel_mmwave(F77, theta, Polarisation::Tm).norm();
            if g < best {
                (best, best_theta) = (g, theta);
            }
        }
        assert!(
            (best_theta - theta_b).abs() < deg(0.01),
            "{} vs {}",
            best_theta.to_degrees(),
            theta_b.to_degrees()
        );
        // TE has no Brewster angle and grows monotonically.
        let mut last = 0.0;
        for i in 0..90 {
            let g = m
                .fresnel_mmwave(F77, deg(i as f64), Polarisation::Te)
                .norm();
            assert!(g >= last);
            last = g;
        }
    }

    #[test]
    fn material_lossless_slab_conserves_energy() {
        let doc = doc_with_mmwave(
            "slab",
            r#"{"eps_r": [2.3, 0.0], "thickness_m": 0.003, "backing": "air", "source": "test"}"#,
        );
        let db = MaterialDb::from_json_str(&doc).unwrap();
        let m = db.by_name("slab").unwrap();
        for f in [76e9, 77e9, 79e9, 81e9] {
            for theta in [0.0, 20.0, 45.0, 70.0, 85.0] {
                for pol in [Polarisation::Te, Polarisation::Tm] {
                    let g = m.fresnel_mmwave(f, deg(theta), pol);
                    let t = m.transmission_mmwave(f, deg(theta), pol).unwrap();
                    let sum = g.norm_sqr() + t.norm_sqr();
                    assert!((sum - 1.0).abs() < 1e-12, "f={f} θ={theta} {pol:?}: {sum}");
                    let (r, tp) = m.power_mmwave(f, deg(theta), pol);
                    assert!((r + tp - 1.0).abs() < 1e-12);
                }
            }
        }
        // A lossless layer over a lossless half-space: R + T·Re(η_back)/Re(η_0) = 1.
        let doc = doc_with_mmwave(
            "coated",
            r#"{"layers": [{"name": "c", "eps_r": [2.6, 0.0], "thickness_m": 0.0007}], "eps_r": [6.0, 0.0],
                "source": "test"}"#,
        );
        let db = MaterialDb::from_json_str(&doc).unwrap();
        let m = db.by_name("coated").unwrap();
        for theta in [0.0, 30.0, 60.0, 80.0] {
            for pol in [Polarisation::Te, Polarisation::Tm] {
                let (r, t) = m.power_mmwave(F77, deg(theta), pol);
                assert!((r + t - 1.0).abs() < 1e-12, "θ={theta} {pol:?}: {r} + {t}");
            }
        }
        // A lossy slab absorbs: R + T < 1.
        let doc = doc_with_mmwave(
            "lossy",
            r#"{"eps_r": [6.31, 0.28], "thickness_m": 0.004, "backing": "air", "source": "test"}"#,
        );
        let m = MaterialDb::from_json_str(&doc)
            .unwrap()
            .by_name("lossy")
            .unwrap()
            .clone();
        let (r, t) = m.power_mmwave(F77, 0.0, Polarisation::Te);
        assert!(r + t < 0.99 && r + t > 0.3, "{r} {t}");
    }

    #[test]
    fn material_half_and_quarter_wave_slabs() {
        let eps: f64 = 4.0;
        let lambda = SPEED_OF_LIGHT_M_S / F77;
        for (d, expect) in [
            (lambda / (2.0 * eps.sqrt()), 0.0),
            (lambda / (4.0 * eps.sqrt()), {
                // Γ = 2r/(1 + r²), r the air→slab coefficient.
                let r = (1.0 - eps.sqrt()) / (1.0 + eps.sqrt());
                (2.0 * r / (1.0 + r * r)).abs()
            }),
        ] {
            let doc = doc_with_mmwave(
                "s",
                &format!(r#"{{"eps_r": [{eps}, 0.0], "thickness_m": {d}, "source": "t"}}"#),
            );
            let m = MaterialDb::from_json_str(&doc)
                .unwrap()
                .by_name("s")
                .unwrap()
                .clone();
            for pol in [Polarisation::Te, Polarisation::Tm] {
                let g = m.fresnel_mmwave(F77, 0.0, pol).norm();
                assert!(
                    (g - expect).abs() < 1e-9,
                    "d={d} {pol:?}: |Γ|={g}, expected {expect}"
                );
            }
        }
    }

    #[test]
    fn material_conductors() {
        let db = MaterialDb::builtin();
        // Paint over a perfect conductor: all power is reflected (lossy paint aside, |Γ| ≈ 1).
        let paint = db.by_name("car_paint_white").unwrap();
        assert!(paint.is_conductor());
        let g = paint.fresnel_mmwave(F77, 0.0, Polarisation::Te).norm();
        assert!(g > 0.9 && g <= 1.0, "{g}");
        // Aluminium with σ: |Γ| just below 1; a perfect conductor: −1 (TE), +1 (TM).
        let al = db.by_name("aluminium").unwrap();
        let g = al.fresnel_mmwave(F77, 0.0, Polarisation::Te);
        assert!(g.norm() > 0.998 && g.norm() < 1.0 && g.re < 0.0, "{g}");
        let pec = Material::lambertian("p", 1.0);
        for theta in [0.0, 45.0, 85.0] {
            assert!((pec.fresnel_mmwave(F77, deg(theta), Polarisation::Te) + 1.0).norm() < 1e-12);
            assert!((pec.fresnel_mmwave(F77, deg(theta), Polarisation::Tm) - 1.0).norm() < 1e-12);
        }
        assert_eq!(pec.transmission_mmwave(F77, 0.0, Polarisation::Te), None);
        assert_eq!(pec.eps_r_mmwave(F77), None);
    }

    #[test]
    fn material_ament_factor_and_switches() {
        let db = MaterialDb::builtin();
        let asphalt = db.by_name("asphalt_dry").unwrap();
        let sigma = asphalt.mmwave.roughness_m;
        assert!(sigma > 0.0);
        for theta in [0.0, 30.0, 60.0, 85.0] {
            let k = 2.0 * PI * F77 / SPEED_OF_LIGHT_M_S;
            let x = k * sigma * deg(theta).cos();
            let expected = (-2.0 * x * x).exp();
            assert!((asphalt.ament_factor(F77, deg(theta)) - expected).abs() < 1e-15);
        }
        assert!((ament_factor(F77, 5e-4, PI / 2.0) - 1.0).abs() < 1e-12);
        assert!((ament_factor(F77, 0.0, 0.0) - 1.0).abs() < 1e-15);
        let theta = deg(40.0);
        let all = MaterialEffects::default();
        let g = asphalt.reflection_mmwave(F77, theta, Polarisation::Tm, &all);
        let smooth = asphalt.fresnel_mmwave(F77, theta, Polarisation::Tm);
        assert!((g - smooth * asphalt.ament_factor(F77, theta)).norm() < 1e-15);
        let no_rough = MaterialEffects {
            mmwave_roughness: false,
            ..all
        };
        assert_eq!(
            asphalt.reflection_mmwave(F77, theta, Polarisation::Tm, &no_rough),
            smooth
        );
        let scalar = MaterialEffects {
            mmwave_roughness: false,
            fresnel_polarisation: false,
            ..all
        };
        let g0 = asphalt.fresnel_mmwave(F77, 0.0, Polarisation::Te);
        for pol in [Polarisation::Te, Polarisation::Tm] {
            assert_eq!(asphalt.reflection_mmwave(F77, theta, pol, &scalar), g0);
        }
    }

    #[test]
    fn material_permittivity_models() {
        // ITU-R P.2040-3 concrete at 77 GHz: ε' = 5.24, σ = 0.0462·77^0.7822 S/m, ε'' = 17.98 σ / f_GHz.
        let concrete = MaterialDb::builtin()
            .by_name("concrete")
            .unwrap()
            .eps_r_mmwave(F77)
            .unwrap();
        let sigma = 0.0462 * 77f64.powf(0.7822);
        assert!((concrete.re - 5.24).abs() < 1e-12);
        assert!(
            (-concrete.im - 17.975 * sigma / 77.0).abs() < 1e-3,
            "{concrete}"
        );
        // Water, ITU-R P.840 at 77 GHz, 20 °C: about 8.8 − j15.9.
        let w = water_permittivity_p840(F77, 20.0);
        assert!(
            (w.re - 8.81).abs() < 0.05 && (-w.im - 15.90).abs() < 0.05,
            "{w}"
        );
        // Static limit of the water model: ε0 = 77.66 + 103.3(θ − 1).
        let w0 = water_permittivity_p840(1e3, 20.0);
        assert!((w0.re - (77.66 + 103.3 * (300.0 / 293.15 - 1.0))).abs() < 1e-3);
        // Dry skin (Gabriel 1996 terms) at 77 GHz: about 6.6 − j8.9.
        let skin = MaterialDb::builtin()
            .by_name("skin")
            .unwrap()
            .eps_r_mmwave(F77)
            .unwrap();
        assert!(
            (skin.re - 6.6).abs() < 0.2 && (-skin.im - 8.9).abs() < 0.3,
            "{skin}"
        );
        // Table: linear in frequency, held beyond the ends.
        let t = Permittivity::Table(vec![(76.0, 3.0, 0.1), (81.0, 3.5, 0.2)]);
        assert!((t.eval(78.5e9) - Complex64::new(3.25, -0.15)).norm() < 1e-12);
        assert_eq!(t.eval(70e9), Complex64::new(3.0, -0.1));
        assert_eq!(t.eval(90e9), Complex64::new(3.5, -0.2));
    }

    /// ∫ f cos θo dω over the hemisphere by brute force (midpoint in θo, φo).
    fn brute_albedo(m: &Material, band: Band, wi: DVec3, nt: usize, np: usize) -> f64 {
        let n = DVec3::Z;
        let (dt, dp) = (PI / 2.0 / nt as f64, 2.0 * PI / np as f64);
        let mut s = 0.0;
        for it in 0..nt {
            let t = (it as f64 + 0.5) * dt;
            for ip in 0..np {
                let p = (ip as f64 + 0.5) * dp;
                let wo = DVec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos());
                s += m.eval_brdf(band, wi, wo, n) * t.cos() * t.sin();
            }
        }
        s * dt * dp
    }

    #[test]
    fn material_lambertian_albedo_integral() {
        let mut db = MaterialDb::builtin();
        let id = db.resolve("lambertian_37").unwrap();
        let m = db.get(id).clone();
        for band in [Band::Visible(550.0), Band::Nir905, Band::Nir1550] {
            for theta in [0.0, 40.0, 75.0] {
                let wi = dir(theta, 10.0);
                assert!(
                    (m.eval_brdf(band, wi, dir(20.0, 200.0), DVec3::Z) - 0.37 / PI).abs() < 1e-15
                );
                let a = brute_albedo(&m, band, wi, 180, 90);
                assert!((a - 0.37).abs() < 1e-4, "{band:?} θ={theta}: {a}");
                let d = m.directional_hemispherical_reflectance(band, wi, DVec3::Z);
                assert!((d - 0.37).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn material_glossy_albedo_matches_numerical_integral() {
        // Rough lobes (α ≥ 0.25) are resolved by a brute-force grid: compare with the lobe-wise albedo.
        let db = MaterialDb::builtin();
        for (name, band) in [
            ("clothing_black_leather", Band::Nir905),
            ("steel", Band::Nir1550),
            ("aluminium", Band::Visible(600.0)),
            ("skin", Band::Nir905),
        ] {
            let m = db.by_name(name).unwrap();
            for theta in [0.0, 30.0, 60.0] {
                let wi = dir(theta, 0.0);
                let brute = brute_albedo(m, band, wi, 400, 400);
                let dhr = m.directional_hemispherical_reflectance(band, wi, DVec3::Z);
                assert!(
                    (brute - dhr).abs() < 2e-3 * dhr.max(0.1),
                    "{name} {band:?} θ={theta}: {brute} vs {dhr}"
                );
            }
        }
    }

    #[test]
    fn material_brdf_reciprocity_and_energy() {
        let db = MaterialDb::builtin();
        let n = DVec3::Z;
        for (_, m) in db.iter() {
            for band in [
                Band::Visible(450.0),
                Band::Visible(633.0),
                Band::Nir905,
                Band::Nir1550,
            ] {
                for (ti, pi) in [(0.0, 0.0), (25.0, 40.0), (60.0, 170.0), (80.0, 300.0)] {
                    for (to, po) in [
                        (5.0, 200.0),
                        (33.0, 40.0),
                        (60.0, 350.0),
                        (85.0, 10.0),
                        (60.0, 170.0),
                    ] {
                        let (wi, wo) = (dir(ti, pi), dir(to, po));
                        let a = m.eval_brdf(band, wi, wo, n);
                        let b = m.eval_brdf(band, wo, wi, n);
                        assert!(a >= 0.0 && a.is_finite());
                        assert!(
                            (a - b).abs() <= 1e-12 * a.abs().max(1.0),
                            "{} {band:?}: {a} vs {b}",
                            m.name
                        );
                    }
                }
                for theta in [0.0, 30.0, 60.0, 80.0, 88.0] {
                    let d = m.directional_hemispherical_reflectance(band, dir(theta, 0.0), n);
                    assert!(
                        (0.0..=1.0 + 1e-3).contains(&d),
                        "{} {band:?} θ={theta}: albedo {d}",
                        m.name
                    );
                }
                // Below the surface: no reflection.
                assert_eq!(m.eval_brdf(band, dir(100.0, 0.0), dir(30.0, 0.0), n), 0.0);
            }
        }
    }

    #[test]
    fn material_retro_lobe_peaks_at_source_direction() {
        let db = MaterialDb::builtin();
        let sheet = db.by_name("retroreflective_sheeting").unwrap();
        let n = DVec3::Z;
        for band in [Band::Visible(550.0), Band::Nir905, Band::Nir1550] {
            for theta in [0.0, 20.0, 45.0] {
                let wi = dir(theta, 30.0);
                let peak = sheet.eval_brdf(band, wi, wi, n);
                // Around wi (beyond the specular peak), the BRDF falls off in every direction.
                let (t, b) = wi.any_orthonormal_pair();
                for (da, db) in [
                    (0.2, 0.0),
                    (-0.2, 0.0),
                    (0.0, 0.3),
                    (0.3, -0.3),
                    (1.0, 0.0),
                    (0.0, -3.0),
                ] {
                    let wo = (wi + deg(da) * t + deg(db) * b).normalize();
                    assert!(
                        sheet.eval_brdf(band, wi, wo, n) < peak,
                        "{band:?} θ={theta} Δ=({da},{db})"
                    );
                }
                // Retro switched off: the peak is gone.
                let off = MaterialEffects {
                    retroreflection: false,
                    ..MaterialEffects::default()
                };
                let without = sheet.eval_brdf_with(band, wi, wi, n, &off);
                let c = n.dot(wi);
                let retro = sheet.view(band).retro.unwrap().eval(wi, wi, c, c);
                assert!((peak - without - retro).abs() < 1e-9 * peak && retro > 0.9 * peak);
            }
            // At normal incidence the peak is the coefficient of retroreflection R_A (+ diffuse, specular).
            let r = sheet.view(band).retro.unwrap();
            let peak = sheet.eval_brdf(band, n, n, n);
            let off = MaterialEffects {
                retroreflection: false,
                ..MaterialEffects::default()
            };
            assert!(
                (peak - sheet.eval_brdf_with(band, n, n, n, &off) - r.peak_sr).abs() < 1e-9,
                "{peak}"
            );
            // R_A at 0.2° / 0.5° observation as fitted (ASTM D4956 Type III white minima 250 / 95).
            let ra = |obs: f64| r.eval(n, dir(obs, 0.0), 1.0, deg(obs).cos());
            assert!(
                (ra(0.2) - 250.0).abs() < 5.0 && (ra(0.5) - 95.0).abs() < 5.0,
                "{} {}",
                ra(0.2),
                ra(0.5)
            );
            // Retro albedo ≈ peak π σ² (small σ).
            let a = r.albedo(n, n);
            let approx = r.peak_sr * PI * r.width_rad * r.width_rad;
            assert!((a - approx).abs() < 1e-3 * approx, "{a} vs {approx}");
        }
    }

    #[test]
    fn material_visible_interpolation() {
        let db = MaterialDb::builtin();
        let m = db.by_name("asphalt_dry").unwrap();
        for (i, &r) in m.visible.reflectance.iter().enumerate() {
            assert_eq!(m.reflectance_visible(380.0 + 10.0 * i as f64), r);
        }
        for i in 0..VISIBLE_SAMPLES - 1 {
            let l = 385.0 + 10.0 * i as f64;
            let mean = 0.5 * (m.visible.reflectance[i] + m.visible.reflectance[i + 1]);
            assert!((m.reflectance_visible(l) - mean).abs() < 1e-15);
        }
        let q = m.reflectance_visible(552.5);
        let expected = 0.75 * m.visible.reflectance[17] + 0.25 * m.visible.reflectance[18];
        assert!((q - expected).abs() < 1e-15);
        assert_eq!(m.reflectance_visible(300.0), m.visible.reflectance[0]);
        assert_eq!(m.reflectance_visible(900.0), m.visible.reflectance[40]);
        assert_eq!(
            m.diffuse_albedo(Band::Visible(550.0)),
            m.visible.reflectance[17]
        );
        assert_eq!(Band::for_wavelength_nm(903.0), Band::Nir905);
        assert_eq!(Band::for_wavelength_nm(1550.0), Band::Nir1550);
        assert_eq!(Band::for_wavelength_nm(600.0), Band::Visible(600.0));
    }

    #[test]
    fn material_lambertian_resolution() {
        let mut db = MaterialDb::builtin();
        let n = db.len();
        assert_eq!(db.id("lambertian_50"), None);
        let id = db.resolve("lambertian_50").unwrap();
        assert_eq!(db.len(), n + 1);
        assert_eq!(db.resolve("lambertian_50").unwrap(), id);
        assert_eq!(db.id("lambertian_50"), Some(id));
        assert_eq!(db.name(id), "lambertian_50");
        let m = db.get(id);
        assert_eq!(m.diffuse_albedo(Band::Visible(400.0)), 0.5);
        assert_eq!(m.diffuse_albedo(Band::Nir905), 0.5);
        assert_eq!(m.diffuse_albedo(Band::Nir1550), 0.5);
        let (r, _) = m.power_mmwave(F77, 0.0, Polarisation::Te);
        assert!((r - 0.5).abs() < 1e-12);
        assert_eq!(db.wet_variant(id), None);
        for (name, rho) in [
            ("lambertian_0", 0.0),
            ("lambertian_100", 1.0),
            ("lambertian_12.5", 0.125),
        ] {
            let id = db.resolve(name).unwrap();
            assert_eq!(db.get(id).diffuse_albedo(Band::Nir905), rho);
            let (r, _) = db.get(id).power_mmwave(F77, 0.0, Polarisation::Tm);
            assert!((r - rho).abs() < 1e-12, "{name}: {r}");
        }
        for bad in [
            "lambertian_101",
            "lambertian_",
            "lambertian_x",
            "lambertian_-5",
            "lambertian_1e1",
            "tarmac",
        ] {
            assert!(
                matches!(db.resolve(bad), Err(MaterialError::Unknown(_))),
                "{bad}"
            );
        }
    }

    #[test]
    fn material_starter_set_is_complete_and_sourced() {
        let db = MaterialDb::builtin();
        let contract = [
            "asphalt_dry",
            "asphalt_wet",
            "lane_paint_white",
            "lane_paint_white_wet",
            "thermal_barrier_paint",
            "car_paint_white",
            "car_paint_black",
            "glass",
            "aluminium",
            "steel",
            "rubber",
            "concrete",
            "skin",
            "clothing_cotton",
            "clothing_black_leather",
            "wood",
            "retroreflective_sheeting",
            "plastic_black",
            "polycarbonate",
        ];
        for name in contract {
            assert!(db.id(name).is_some(), "missing `{name}`");
        }
        for (_, m) in db.iter() {
            assert_eq!(m.visible.reflectance.len(), VISIBLE_SAMPLES);
            for s in [
                &m.visible.source,
                &m.nir905.source,
                &m.nir1550.source,
                &m.mmwave.source,
            ] {
                assert!(!s.trim().is_empty(), "{}: empty source", m.name);
            }
            if let Some(t) = &m.transmission {
                assert!(!t.source.is_empty());
            }
            // Every band answers.
            let g = m.fresnel_mmwave(F77, deg(30.0), Polarisation::Te);
            assert!(
                g.norm() <= 1.0 + 1e-12 && g.norm().is_finite(),
                "{}: {g}",
                m.name
            );
            assert!(m.diffuse_albedo(Band::Nir905).is_finite());
        }
        let pairs = [
            ("asphalt_dry", "asphalt_wet"),
            ("lane_paint_white", "lane_paint_white_wet"),
            ("concrete", "concrete_wet"),
            ("thermal_barrier_paint", "thermal_barrier_paint_wet"),
        ];
        for (dry, wet) in pairs {
            let (d, w) = (db.id(dry).unwrap(), db.id(wet).unwrap());
            assert_eq!(db.wet_variant(d), Some(w));
            assert_eq!(db.wet_variant(w), Some(w));
            assert_eq!(db.dry_variant(w), Some(d));
            assert_eq!(db.surface(d, true, &MaterialEffects::default()), w);
            assert_eq!(db.surface(d, false, &MaterialEffects::default()), d);
            let off = MaterialEffects {
                wet_surfaces: false,
                ..MaterialEffects::default()
            };
            assert_eq!(db.surface(d, true, &off), d);
        }
        assert_eq!(db.wet_variant(db.id("glass").unwrap()), None);
        assert_eq!(EFFECTS.len(), 4);
        let fx = MaterialEffects::from_effects(&Effects::new(EFFECTS));
        assert_eq!(fx, MaterialEffects::default());
    }

    #[test]
    fn material_wet_variants_follow_lekner_dorf() {
        let db = MaterialDb::builtin();
        let dry = db.by_name("asphalt_dry").unwrap();
        let wet = db.by_name("asphalt_wet").unwrap();
        let film = wet.water_film.as_ref().unwrap();
        // Wet asphalt is about half as bright (Lekner & Dorf 1988: 0.5–0.6 for ρ ≈ 0.2).
        for band in [Band::Visible(450.0), Band::Visible(650.0), Band::Nir905] {
            let (d, w) = (dry.diffuse_albedo(band), wet.diffuse_albedo(band));
            assert!(w < 0.7 * d && w > 0.45 * d, "{band:?}: dry {d}, wet {w}");
        }
        // Visible: darkening ratio (1 − F0)(1 − r̄)/(1 − ρ r̄) with r̄ = 1 − (1 − F̄)/n² ≈ 0.47 for n = 1.336.
        let (n, _) = water_nk(550.0);
        let lobe = SpecularLobe::new(n, 0.0, 0.1, 1.0);
        let r_int = 1.0 - (1.0 - lobe.f_hemi) / (n * n);
        assert!((r_int - 0.47).abs() < 0.02, "{r_int}");
        let rho = dry.reflectance_visible(550.0);
        let expected = (1.0 - lobe.f0) * rho * (1.0 - r_int) / (1.0 - rho * r_int);
        // (the film's absorption at 550 nm is negligible: 2E₃(αd) ≈ 1 − 6e-5)
        assert!((wet.reflectance_visible(550.0) - expected).abs() < 1e-4 * expected);
        // 1550 nm: the film absorbs (α ≈ 1.1e3 m⁻¹), darker than at 905 nm relative to dry.
        let r905 = wet.diffuse_albedo(Band::Nir905) / dry.diffuse_albedo(Band::Nir905);
        let r1550 = wet.diffuse_albedo(Band::Nir1550) / dry.diffuse_albedo(Band::Nir1550);
        assert!(r1550 < 0.6 * r905 && r1550 > 0.05, "{r905} {r1550}");
        // 2E₃: 1 at zero depth, e^{-2x}-like decay; E₃(1) = 0.10969 (Abramowitz & Stegun table 5.1).
        assert!((2.0 * exp_integral_e3(0.0) - 1.0).abs() < 1e-15);
        assert!((exp_integral_e3(1.0) - 0.109_691).abs() < 1e-6);
        assert!((exp_integral_e3(0.5) - 0.221_604).abs() < 1e-6);
        assert!((exp_integral_e3(2.0) - 0.030_133).abs() < 1e-6);
        // A water specular lobe appears; the mm-wave stack gains a water layer.
        assert!(wet.nir905.specular.is_some() && dry.nir905.specular.is_none());
        assert_eq!(wet.mmwave.layers.len(), dry.mmwave.layers.len() + 1);
        assert!((wet.mmwave.layers[0].thickness_m - film.thickness_m).abs() < 1e-15);
        let gd = dry.fresnel_mmwave(F77, 0.0, Polarisation::Te).norm();
        let gw = wet.fresnel_mmwave(F77, 0.0, Polarisation::Te).norm();
        assert!(
            gw > gd,
            "water raises the normal-incidence reflection: {gd} → {gw}"
        );
        // Drowned beads: the wet marking's retro lobe is scaled by retro_factor.
        let paint = db.by_name("lane_paint_white").unwrap();
        let paint_wet = db.by_name("lane_paint_white_wet").unwrap();
        let f = paint_wet.water_film.as_ref().unwrap().retro_factor;
        assert!(f < 1.0);
        assert!(
            (paint_wet.nir905.retro.unwrap().peak_sr - f * paint.nir905.retro.unwrap().peak_sr)
                .abs()
                < 1e-12
        );
        // A zero-depth film only adds the water surface.
        let film0 = WaterFilm {
            thickness_m: 0.0,
            ..film.clone()
        };
        let damp = dry.with_water_film("damp", &film0);
        assert_eq!(damp.mmwave.layers.len(), dry.mmwave.layers.len());
    }

    #[test]
    fn material_glass_slab_optics() {
        let db = MaterialDb::builtin();
        let glass = db.by_name("glass").unwrap();
        let s = glass.slab_optics(Band::Visible(550.0), 1.0).unwrap();
        // Two faces of n = 1.525: R ≈ 2·0.043/(1 + 0.043) ≈ 0.083, absorption ≈ 2 % over 4 mm.
        assert!((s.reflectance - 0.083).abs() < 0.003, "{s:?}");
        assert!(s.transmittance > 0.89 && s.transmittance < 0.92, "{s:?}");
        for band in [Band::Visible(400.0), Band::Nir905, Band::Nir1550] {
            for c in [1.0, 0.7, 0.3, 0.05] {
                let s = glass.slab_optics(band, c).unwrap();
                assert!(s.reflectance + s.transmittance <= 1.0 + 1e-12);
                assert!(s.reflectance > 0.0 && s.transmittance > 0.0);
            }
        }
        // Grazing incidence reflects more.
        assert!(glass.slab_optics(Band::Nir905, 0.1).unwrap().reflectance > 0.3);
        assert_eq!(
            db.by_name("asphalt_dry")
                .unwrap()
                .slab_optics(Band::Nir905, 1.0),
            None
        );
        assert_eq!(
            db.transmittance(db.id("concrete").unwrap(), Band::Nir905, 1.0),
            0.0
        );
        assert!(db.transmittance(db.id("polycarbonate").unwrap(), Band::Nir905, 1.0) > 0.85);
        // mm-wave: glass and bumper plastic are slabs that transmit.
        let t = glass
            .transmission_mmwave(F77, 0.0, Polarisation::Te)
            .unwrap();
        assert!(t.norm_sqr() > 0.3 && t.norm_sqr() < 1.0);
        assert!(
            db.by_name("plastic_black")
                .unwrap()
                .transmission_mmwave(F77, 0.0, Polarisation::Te)
                .is_some()
        );
        assert_eq!(
            db.by_name("concrete")
                .unwrap()
                .transmission_mmwave(F77, 0.0, Polarisation::Te),
            None
        );
    }

    fn parse_err(doc: &str) -> (String, MaterialError) {
        let e = MaterialDb::from_json_str(doc).unwrap_err();
        (e.to_string(), e)
    }

    #[test]
    fn material_json_errors_name_material_and_key() {
        // Wrong type deep inside a material: serde path + line/column.
        let doc = doc_with_mmwave(
            "tarmac",
            r#"{"eps_r": [3.2, 0.2], "roughness_m": "rough", "source": "x"}"#,
        );
        let (msg, e) = parse_err(&doc);
        assert!(
            msg.contains("material `tarmac`") && msg.contains("mmwave.roughness_m"),
            "{msg}"
        );
        match e {
            MaterialError::Parse {
                line,
                column,
                material,
                key,
                ..
            } => {
                assert_eq!(material.as_deref(), Some("tarmac"));
                assert_eq!(key.as_deref(), Some("mmwave.roughness_m"));
                assert_eq!(line, 4);
                assert!(column > 1);
            }
            other => panic!("{other:?}"),
        }
        // Unknown key.
        let doc = doc_with_mmwave(
            "tarmac",
            r#"{"eps_r": [3.2, 0.2], "roughnes_m": 0.001, "source": "x"}"#,
        );
        let (msg, _) = parse_err(&doc);
        assert!(
            msg.contains("material `tarmac`") && msg.contains("unknown field `roughnes_m`"),
            "{msg}"
        );
        // Missing source.
        let doc = doc_with_mmwave("tarmac", r#"{"eps_r": [3.2, 0.2]}"#);
        let (msg, _) = parse_err(&doc);
        assert!(
            msg.contains("material `tarmac`, key `mmwave`") && msg.contains("source"),
            "{msg}"
        );
        // Semantic: wrong number of visible samples, located at the key.
        let doc = doc_with_mmwave("tarmac", r#"{"eps_r": [3.2, 0.2], "source": "x"}"#)
            .replacen("0.5, ", "", 1);
        let (msg, e) = parse_err(&doc);
        assert!(
            msg.contains("material `tarmac`, key `visible.reflectance`") && msg.contains("got 40"),
            "{msg}"
        );
        assert!(matches!(e, MaterialError::Parse { line: 2, .. }), "{e:?}");
        // Semantic: out of range, non-physical permittivity, bad permittivity form, empty source.
        for (mmwave, key) in [
            (r#"{"eps_r": [3.2, -0.2], "source": "x"}"#, "mmwave.eps_r"),
            (
                r#"{"eps_r": {"itu": [1, 0, 0, 0]}, "source": "x"}"#,
                "mmwave.eps_r",
            ),
            (
                r#"{"eps_r": [3.2, 0.2], "roughness_m": -1, "source": "x"}"#,
                "mmwave.roughness_m",
            ),
            (r#"{"eps_r": [3.2, 0.2], "source": " "}"#, "mmwave.source"),
            (
                r#"{"conductor": true, "eps_r": [3.2, 0.2], "source": "x"}"#,
                "mmwave.eps_r",
            ),
            (
                r#"{"eps_r": [3.2, 0.2], "backing": "pec", "source": "x"}"#,
                "mmwave.backing",
            ),
        ] {
            let (msg, _) = parse_err(&doc_with_mmwave("tarmac", mmwave));
            assert!(
                msg.contains("material `tarmac`") && msg.contains(&format!("key `{key}`")),
                "{mmwave}: {msg}"
            );
        }
        // Energy conservation of diffuse + specular.
        let doc = doc_with_mmwave("m", r#"{"eps_r": [3, 0], "source": "x"}"#).replace(
            r#""905": {"diffuse": 0.5,"#,
            r#""905": {"diffuse": 0.99, "specular": {"n": 1.5, "roughness": 0.1},"#,
        );
        let (msg, _) = parse_err(&doc);
        assert!(
            msg.contains("key `nir.905.diffuse`") && msg.contains("energy"),
            "{msg}"
        );
        // JSON syntax error: line and column, no material.
        let (msg, e) =
            parse_err("{\n  \"schema\": \"osiris-materials/1\",\n  \"materials\": {,}\n}");
        assert!(
            matches!(
                e,
                MaterialError::Parse {
                    line: 3,
                    material: None,
                    ..
                }
            ),
            "{msg}"
        );
        // Wrong schema, duplicate material, reserved names, unknown wet_of.
        let (msg, _) = parse_err(r#"{"schema": "v0", "materials": {}}"#);
        assert!(msg.contains("key `schema`"), "{msg}");
        let one = doc_with_mmwave("a", r#"{"eps_r": [3, 0], "source": "x"}"#);
        let body = one
            .split_once("\"a\":")
            .unwrap()
            .1
            .trim_end()
            .trim_end_matches('}')
            .trim_end()
            .trim_end_matches('}');
        let dup = format!(
            r#"{{"schema": "osiris-materials/1", "materials": {{"a": {body}, "a": {body}}}}}"#
        );
        let (msg, _) = parse_err(&dup);
        assert!(msg.contains("duplicate material `a`"), "{msg}");
        let (msg, _) = parse_err(&doc_with_mmwave(
            "lambertian_20",
            r#"{"eps_r": [3, 0], "source": "x"}"#,
        ));
        assert!(msg.contains("reserved"), "{msg}");
        let wet = r#"{"schema": "osiris-materials/1", "materials": {"a_wet": {"wet_of": "nothing",
            "water_film": {"thickness_m": 0.001, "roughness": 0.1, "source": "x"}}}}"#;
        let (msg, e) = parse_err(wet);
        assert!(
            msg.contains("material `a_wet`, key `wet_of`") && msg.contains("nothing"),
            "{msg}"
        );
        assert!(matches!(e, MaterialError::Parse { line: 1, .. }), "{e:?}");
    }

    #[test]
    fn material_files_and_extension() {
        let dir = std::env::temp_dir().join(format!("osiris-material-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        // A user file overriding asphalt_dry: its film-derived wet variant is derived again.
        let mut doc = doc_with_mmwave("asphalt_dry", r#"{"eps_r": [3.0, 0.1], "source": "user"}"#);
        doc = doc.replace("\"diffuse\": 0.5", "\"diffuse\": 0.1");
        let path = dir.join("user.json");
        std::fs::write(&path, &doc).unwrap();
        let mut db = MaterialDb::builtin();
        let n = db.len();
        let wet_before = db.by_name("asphalt_wet").unwrap().nir905.diffuse;
        let id_before = db.id("asphalt_dry").unwrap();
        let ids = db.extend_from_json_file(&path).unwrap();
        assert_eq!(ids, vec![id_before]);
        assert_eq!(db.len(), n);
        assert_eq!(db.by_name("asphalt_dry").unwrap().nir905.diffuse, 0.1);
        let wet_after = db.by_name("asphalt_wet").unwrap().nir905.diffuse;
        assert!(wet_after < 0.5 * wet_before, "{wet_before} → {wet_after}");
        assert_eq!(db.wet_variant(id_before), db.id("asphalt_wet"));
        // Errors name the file; a failed load leaves the database unchanged.
        let bad = dir.join("bad.json");
        std::fs::write(&bad, doc.replace("\"user\"", "\"\"")).unwrap();
        let e = db.extend_from_json_file(&bad).unwrap_err().to_string();
        assert!(
            e.starts_with(&bad.display().to_string()) && e.contains("material `asphalt_dry`"),
            "{e}"
        );
        assert_eq!(db.by_name("asphalt_dry").unwrap().mmwave.source, "user");
        let missing = MaterialDb::from_json_file(dir.join("missing.json")).unwrap_err();
        assert!(matches!(missing, MaterialError::Io { .. }));
        let loaded = MaterialDb::from_json_file(&path).unwrap();
        assert_eq!(loaded.len(), 1);
        std::fs::remove_dir_all(&dir).ok();
        // add(): a wet variant built in code.
        let mut db = MaterialDb::builtin();
        let film = db
            .by_name("asphalt_wet")
            .unwrap()
            .water_film
            .clone()
            .unwrap();
        let flooded = db
            .by_name("wood")
            .unwrap()
            .with_water_film("wood_wet", &film);
        let id = db.add(flooded).unwrap();
        assert_eq!(db.wet_variant(db.id("wood").unwrap()), Some(id));
        let again = db
            .by_name("wood")
            .unwrap()
            .with_water_film("wood_wet2", &film);
        assert!(matches!(db.add(again), Err(MaterialError::Invalid(_))));
    }
}
