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
//!
//! # Files
//!
//! This file holds the bands, ids, errors, effect switches and [`Material`] (which composes the
//! bands); the concepts live in private submodules, re-exported here: `optical` (lobes, per-band
//! optics, slab transmission, water film), `mmwave` (permittivity models, the Fresnel/Airy stack,
//! the Ament factor), `water` (water optical constants, the Lekner & Dorf wet albedo), `database`
//! ([`MaterialDb`]) and `parse` (the JSON loader).

mod database;
mod mmwave;
mod optical;
mod parse;
#[cfg(test)]
mod tests;
mod water;

pub use database::MaterialDb;
pub use mmwave::{
    Backing, ColeColeTerm, Layer, MmWave, Permittivity, StackResponse, ament_factor,
    fresnel_coefficient, water_permittivity_p840,
};
pub use optical::{
    BandOptics, RetroLobe, SlabOptics, SpecularLobe, Transmission, VisibleOptics, WaterFilm,
    fresnel_unpolarised,
};
pub use water::{exp_integral_e3, lekner_dorf_albedo, water_nk};

use std::f64::consts::{FRAC_1_PI, PI};

use glam::DVec3;
use num_complex::Complex64;

use crate::effects::{EffectInfo, Effects};
use optical::interpolate_visible;

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

/// First visible sample, nm.
pub const VISIBLE_START_NM: f64 = 380.0;
/// Visible sample step, nm.
pub const VISIBLE_STEP_NM: f64 = 10.0;
/// Number of visible samples (380..=780 nm).
pub const VISIBLE_SAMPLES: usize = 41;

/// Schema tag of the JSON files.
pub const SCHEMA: &str = "osiris-materials/1";

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

/// Reflectance and transmittance of a dielectric slab in air (index `n`, absorption coefficient
/// `alpha_per_m`, thickness `thickness_m`) at incidence `cos θ`: Fresnel at both faces per
/// polarisation, internal transmittance `τ = exp(−α d / cos θt)`, incoherent multiple reflections
/// `R = r + (1−r)²τ²r/(1 − r²τ²)`, `T = (1−r)²τ/(1 − r²τ²)`, averaged over s and p (unpolarised).
pub fn dielectric_slab(n: f64, alpha_per_m: f64, thickness_m: f64, cos_theta: f64) -> SlabOptics {
    let c = cos_theta.clamp(1e-9, 1.0);
    let sin_t = (1.0 - c * c).sqrt() / n;
    let cos_t = (1.0 - sin_t * sin_t).max(0.0).sqrt();
    let tau = (-alpha_per_m * thickness_m / cos_t.max(1e-9)).exp();
    let eps = Complex64::new(n * n, 0.0);
    let theta = c.acos();
    let (mut r_sum, mut t_sum) = (0.0, 0.0);
    for pol in [Polarisation::Te, Polarisation::Tm] {
        let r1 = fresnel_coefficient(eps, theta, pol).norm_sqr();
        let denom = 1.0 - r1 * r1 * tau * tau;
        r_sum += r1 + (1.0 - r1) * (1.0 - r1) * tau * tau * r1 / denom;
        t_sum += (1.0 - r1) * (1.0 - r1) * tau / denom;
    }
    SlabOptics {
        reflectance: 0.5 * r_sum,
        transmittance: 0.5 * t_sum,
    }
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

    /// The retroreflective lobe alone, `R(wi, wo)` in `band`, sr⁻¹: the part of
    /// [`Material::eval_brdf`] that [`Material::brdf_parts`] leaves out (0 without a lobe or when
    /// either direction is below the surface; the `env.retroreflection` switch is the caller's).
    pub fn retro_brdf(&self, band: Band, wi: DVec3, wo: DVec3, n: DVec3) -> f64 {
        let cos_i = n.dot(wi);
        let cos_o = n.dot(wo);
        if cos_i <= 0.0 || cos_o <= 0.0 {
            return 0.0;
        }
        self.retro_lobe(band)
            .map_or(0.0, |r| r.eval(wi, wo, cos_i, cos_o))
    }

    /// Whether the material has a retroreflective lobe in `band`.
    pub fn has_retro(&self, band: Band) -> bool {
        self.retro_lobe(band).is_some()
    }

    fn retro_lobe(&self, band: Band) -> Option<&RetroLobe> {
        match band {
            Band::Visible(_) => self.visible.retro.as_ref(),
            Band::Nir905 => self.nir905.retro.as_ref(),
            Band::Nir1550 => self.nir1550.retro.as_ref(),
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
        let alpha = 4.0 * PI * k / (lambda * 1e-9);
        Some(dielectric_slab(lobe.n, alpha, tr.thickness_m, cos_theta))
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
