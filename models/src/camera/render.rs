//! Spectral ray-traced rendering of the scene radiance seen by each pixel.
//!
//! # What one render computes
//!
//! For every pixel, the photo-electron radiance of each colour channel
//! `L_c = Σ_k L_λ(λ_k) · w_c(λ_k)` [e⁻ s⁻¹ m⁻² sr⁻¹] ([`super::SpectralResponse`]), where `L_λ` is
//! the spectral radiance arriving along the pixel's primary ray:
//!
//! * **Sun** (direct): `L = ρ(λ)/π · E_dni(λ) · cos θ_s · V` for a Lambertian surface, with a shadow
//!   ray for the visibility `V`; materials with a specular lobe use `f = ρ/π·c(θ_i)c(θ_o) + f_s`
//!   ([`crate::environment::material::Material::eval_brdf`], the diffuse coupling and the specular
//!   lobe are wavelength-independent, the diffuse albedo is spectral). `E_dni` from SPCTRAL2
//!   (Bird & Riordan 1986, [`crate::environment::sky::spectrl2`]) at the sun's zenith.
//! * **Sky**: radiance `L_sky(ω) = k(ω)·E_dhi/π` with `E_dhi` the diffuse horizontal irradiance
//!   of SPCTRAL2 and `k` the CIE general sky's distribution scaled to it (`env.sky_distribution`,
//!   [`crate::environment::sky_distribution`], physics.md §4.3: horizon brightening and the
//!   circumsolar region; type [`RenderConfig::sky_type`]); off: `k ≡ 1`, the isotropic sky of
//!   Liu & Jordan, Solar Energy 4(3):1, 1960. With `diffuse_bounces = 0` (or `space.multipath` or
//!   `space.diffuse_bounces` off) a surface gets the ambient term `ρ/π · E_dhi · V(n)` (the sky's
//!   irradiance on a tilted plane, no occlusion; isotropic: `V = (1 + n_z)/2`); with
//!   `diffuse_bounces ≥ 1` the sky light is sampled by cosine-weighted bounce rays instead, which
//!   also carry sun light reflected by other surfaces (one-sample Monte-Carlo estimate
//!   `ρ(λ)·L_in(λ)` per bounce, PBRT 4th ed. §13.6).
//! * **Sun disk**: rays within [`crate::environment::sun::SUN_RADIUS_DEG`] of the sun direction see
//!   `L = E_dni/Ω_sun`, `Ω_sun = 2π(1 − cos r_sun)` (uniform disk; limb darkening neglected).
//! * **Vehicle lamps** ([`super::light`]): `L = ρ/π · I(θ)·cos θ_s/d² · s(λ)` with a shadow ray per
//!   lamp and point; lit lenses seen directly emit `L_v = I/(A cos θ)`. Lit traffic-signal lenses
//!   (static-world triangles of [`StaticElement::TrafficLight`] whose bulb the lamp plan lit) emit the
//!   same way; signal lamps light other surfaces only with `render.lamps.signal_illumination`.
//! * **Retroreflection** (`env.retroreflection`; sign sheeting, road-marking beads): for the sun and
//!   each lamp, `L = f_retro(wi, wo) · E · s(λ) · ρ(λ)/ρ̄_A`, the material's retro lobe
//!   ([`crate::environment::material::Material::retro_brdf`]) coloured by its diffuse reflectance
//!   normalised to the luminous mean under CIE illuminant A (physics.md §3.6), with the light's shadow
//!   ray. The sky is not retroreflected.
//! * **Glass** (transmissive materials): the primary ray passes through up to
//!   [`RenderConfig::max_glass_crossings`] panes ([`crate::space::Space::closest_hit_through`]) and
//!   is attenuated by the slab transmittance at 550 nm and the incidence angle
//!   ([`crate::environment::material::Material::transmittance`]); the pane reflects the sky
//!   (`R_slab · L_sky(mirror direction)`). With `space.transmission` off the panes are opaque.
//! * **Fog** (`env.fog_extinction`, Koschmieder 1924): `L = L_0 e^{−σd} + L_air(1 − e^{−σd})` with
//!   `σ(λ_k)` from [`crate::environment::weather::extinction_per_m_with`] and the air light
//!   `L_air = L_sky` at the horizon in the ray's azimuth (Koschmieder's horizon sky); rays that
//!   leave the scene see `L_air`.
//!
//! # Exactness of the folded tables
//!
//! The spectral response is linear, so when every per-pixel factor is wavelength-independent
//! (geometry, visibility, the BRDF's lobe shape) the sum over bands can be taken first:
//! `Σ_k w_c,k ρ_k E_k/π · g = g · A_c` with `A_c = Σ_k w_c,k ρ_k E_k/π` precomputed per material
//! and light. This is the exact same sum. It is used ("channel lanes") unless a factor depends on
//! the wavelength per pixel: fog with a wavelength-dependent `σ(λ)` (`e^{−σ_k d}`) or diffuse
//! bounces (`ρ_x(λ) ρ_y(λ)`); then the renderer accumulates the spectrum per pixel ("band lanes")
//! and applies the weights at the end.
//!
//! # Time
//!
//! Each row is rendered at the time of its exposure window (`camera.rolling_shutter`: row `r`
//! starts `r·row_time_s` after row 0; [`ShutterTiming`]). The sensor pose is
//! [`WorldFrame::sensor_pose_at`]. Every ray carries its time ([`Ray::time_s`]) and is traced
//! through a [`Sweep`] of the frame's instances over the exposure windows (instance boxes swept by
//! their velocity), which places each moving object at `position + v·Δt` for that ray: the ray is
//! traced in the object's frame from the origin shifted by `−v·Δt`, the static world stays put.
//! Translation only: the object's rotation over Δt is neglected. Camera rays, rays behind glass,
//! shadow rays and bounce rays all see the scene at their pixel's time, so a moving object, its
//! shadow and what it uncovers stay consistent.
//! `camera.motion_blur` averages
//! [`RenderConfig::motion_samples`] stratified time samples over the exposure window for the pixels
//! whose image moves by more than [`RenderConfig::motion_threshold_px`] during the exposure (from
//! the relative velocity of the point seen); other pixels and `camera.motion_blur` off: one sample
//! at mid-exposure.
//!
//! # Parallelism
//!
//! Rows are rendered in blocks on the rayon pool; consecutive pixels of a row form the 8-ray (AVX2)
//! or 4-ray packets of [`crate::space::Space::trace_batch`], and their sun shadow rays (parallel, from nearby
//! points) the packets of [`crate::space::Space::occluded_batch`]. Scratch buffers are per task (no per-pixel
//! allocation). The only randomness (bounce directions, time jitter) is a hash of seed, cycle and
//! pixel, so the image does not depend on thread scheduling.

// Per-band / per-item index loops over several parallel tables read best with indices.
#![allow(clippy::needless_range_loop)]

use crate::rng::fmix64;
use std::collections::HashMap;
use std::f64::consts::PI;
use std::sync::Mutex;

use glam::{DVec3, Vec3};
use osiris_proto::osi3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::light::{LampConfig, LampLibrary, LampPlan, plan_lamps};
use super::{
    CHANNELS, ChannelImage, Flicker, FlickerSample, NO_OBJECT, RenderAux, ShutterTiming,
    SpectralBands, SpectralResponse, SunInView,
};
use crate::effects::{EffectInfo, Effects};
use crate::environment::assets::signals::SIGNAL_LENS_PART;
use crate::environment::lamps::{photopic_v, planck_radiance_w_m2_sr_nm};
use crate::environment::material::{Band, MaterialDb, RETROREFLECTION};
use crate::environment::scene::StaticElement;
use crate::environment::sky::{ClearSkyInput, spectrl2};
use crate::environment::sky_distribution::{
    CieSkyType, SKY_DISTRIBUTION, SkyDistribution, SkyDistributionCache,
};
use crate::environment::sun::SUN_RADIUS_DEG;
use crate::environment::weather;
use crate::error::ModelError;
use crate::frames::Pose;
use crate::space::{Hit, Ray, Sweep, Swept, TransmissionModel, surface_epsilon};
use crate::world::WorldFrame;

/// Rolling shutter: row r is exposed from `r · row_time_s` after row 0, and the renderer traces it
/// from the sensor pose (and object poses) of that time.
pub const ROLLING_SHUTTER: EffectInfo = EffectInfo {
    name: "camera.rolling_shutter",
    default_on: true,
    summary: "rolling shutter: row r integrates over [t0 + r·t_row, t0 + r·t_row + t_exp]; each row is \
              rendered from the sensor pose p(t) = p + v·t, R(t) = exp(ω t)·R and with moving objects \
              displaced by v_obj·t (first order); off: every row at the same time (global shutter)",
    source: "Liang, Chang, Chen, IEEE TIP 17(8):1323, 2008 (rolling-shutter distortion model); \
             Meingast, Geyer, Sastry, arXiv:cs/0503076, 2005",
    requires: None,
};

/// Motion blur: the pixel integrates the radiance over its exposure window.
pub const MOTION_BLUR: EffectInfo = EffectInfo {
    name: "camera.motion_blur",
    default_on: true,
    summary: "motion blur: L_pix = (1/S) Σ_s L(t_s), S = render.motion_samples stratified times \
              t_s over the row's exposure window (pixels whose image moves > motion_threshold_px \
              during the exposure); off: one sample at mid-exposure",
    source: "Cook, Porter, Carpenter, SIGGRAPH 1984 (distributed ray tracing over time); Monte-Carlo \
             estimate of the exposure integral",
    requires: None,
};

/// LED flicker: pixels that see a PWM-driven LED lamp directly are integrated by the pixel model.
pub const LED_FLICKER: EffectInfo = EffectInfo {
    name: "camera.led_flicker",
    default_on: true,
    summary: "LED flicker: pixels seeing a lit LED lens directly are passed to the pixel model as \
              (time-averaged radiance, PWM source) so that each row's exposure integrates the PWM \
              on-fraction; off: the lens is added to the image at its time-averaged radiance",
    source: "IEEE P2020 Automotive Imaging white paper (2018), LED flicker mitigation; PWM on-fraction \
             over the exposure window",
    requires: None,
};

/// Render effects (`camera.rolling_shutter`, `camera.motion_blur`, `camera.led_flicker`).
pub const EFFECTS: &[EffectInfo] = &[ROLLING_SHUTTER, MOTION_BLUR, LED_FLICKER];

/// Most spectral bands a render may use.
pub const MAX_BANDS: usize = 64;

/// Rendering parameters (`"render"` key of the camera config).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RenderConfig {
    /// Number of spectral bands (1…64). 16 bands of 25 nm resolve the CFA responses (FWHM ≈ 100 nm)
    /// and the SPCTRAL2 grid (10–20 nm in the visible) well enough for colour; LED lines narrower
    /// than a band are integrated by their band-centre sample.
    pub bands: usize,
    /// Start of the rendered range, nm.
    pub band_start_nm: f64,
    /// End of the rendered range, nm.
    pub band_end_nm: f64,
    /// Diffuse bounces: 0 = sky light as ambient term `(1 + n_z)/2`; ≥ 1 = cosine-weighted bounce
    /// rays (one per pixel and bounce; switches the renderer to band lanes).
    pub diffuse_bounces: u32,
    /// Time samples per pixel for `camera.motion_blur` (1…64; default 3). Odd counts use centred
    /// strata and reuse the mid-exposure sample; even counts jitter the strata.
    pub motion_samples: u32,
    /// Image motion during the exposure above which a pixel gets `motion_samples` samples, px.
    pub motion_threshold_px: f64,
    /// Day of year for the Earth–sun distance of SPCTRAL2 (1…366; default: the SPCTRAL2 check
    /// case, 172).
    pub day_of_year: u32,
    /// Clear-sky atmosphere (SPCTRAL2 inputs; `zenith_deg` and `day_of_year` are overridden).
    pub atmosphere: ClearSkyInput,
    /// Maximum number of glass panes a primary ray passes through.
    pub max_glass_crossings: u32,
    /// Length of primary rays, m (beyond: sky).
    pub max_distance_m: f64,
    /// Vehicle lamps.
    pub lamps: LampConfig,
    /// CIE general sky type (1…15, CIE S 011/E:2003) of the sky radiance distribution
    /// (`env.sky_distribution`); default 12, the CIE standard clear sky.
    pub sky_type: u8,
}

impl Default for RenderConfig {
    fn default() -> Self {
        RenderConfig {
            bands: 16,
            band_start_nm: 380.0,
            band_end_nm: 780.0,
            diffuse_bounces: 0,
            motion_samples: 3,
            motion_threshold_px: 1.0,
            day_of_year: 172,
            atmosphere: ClearSkyInput::default(),
            max_glass_crossings: 4,
            max_distance_m: 5000.0,
            lamps: LampConfig::default(),
            sky_type: crate::environment::sky_distribution::DEFAULT_CIE_SKY_TYPE,
        }
    }
}

impl RenderConfig {
    pub fn validate(&self) -> Result<(), ModelError> {
        let err =
            |k: &str, msg: String| Err(ModelError::Config(format!("`camera.render.{k}` {msg}")));
        if !(1..=MAX_BANDS).contains(&self.bands) {
            return err(
                "bands",
                format!("must be in 1..={MAX_BANDS}, got {}", self.bands),
            );
        }
        if !(self.band_start_nm.is_finite() && self.band_start_nm >= 300.0) {
            return err(
                "band_start_nm",
                format!("must be ≥ 300 nm, got {}", self.band_start_nm),
            );
        }
        if !(self.band_end_nm.is_finite()
            && self.band_end_nm > self.band_start_nm
            && self.band_end_nm <= 1100.0)
        {
            return err(
                "band_end_nm",
                format!(
                    "must be in (band_start_nm, 1100] nm, got {}",
                    self.band_end_nm
                ),
            );
        }
        if self.diffuse_bounces > 8 {
            return err(
                "diffuse_bounces",
                format!("must be in 0..=8, got {}", self.diffuse_bounces),
            );
        }
        if !(1..=64).contains(&self.motion_samples) {
            return err(
                "motion_samples",
                format!("must be in 1..=64, got {}", self.motion_samples),
            );
        }
        if !(self.motion_threshold_px.is_finite() && self.motion_threshold_px >= 0.0) {
            return err(
                "motion_threshold_px",
                format!("must be ≥ 0, got {}", self.motion_threshold_px),
            );
        }
        if !(1..=15).contains(&self.sky_type) {
            return err(
                "sky_type",
                format!(
                    "must be a CIE general sky type 1..=15, got {}",
                    self.sky_type
                ),
            );
        }
        if !(1..=366).contains(&self.day_of_year) {
            return err(
                "day_of_year",
                format!("must be in 1..=366, got {}", self.day_of_year),
            );
        }
        let a = &self.atmosphere;
        for (k, v, lo, hi) in [
            ("pressure_pa", a.pressure_pa, 1e4, 1.2e5),
            ("precipitable_water_cm", a.precipitable_water_cm, 0.0, 10.0),
            ("ozone_atm_cm", a.ozone_atm_cm, 0.0, 1.0),
            ("aod_500nm", a.aod_500nm, 0.0, 5.0),
            ("angstrom_alpha", a.angstrom_alpha, 0.0, 4.0),
            ("ground_albedo", a.ground_albedo, 0.0, 1.0),
        ] {
            if !(v.is_finite() && (lo..=hi).contains(&v)) {
                return err(
                    &format!("atmosphere.{k}"),
                    format!("must be in [{lo}, {hi}], got {v}"),
                );
            }
        }
        if self.max_glass_crossings > 16 {
            return err(
                "max_glass_crossings",
                format!("must be in 0..=16, got {}", self.max_glass_crossings),
            );
        }
        if !(self.max_distance_m.is_finite() && self.max_distance_m > 0.0) {
            return err(
                "max_distance_m",
                format!("must be > 0 m, got {}", self.max_distance_m),
            );
        }
        self.lamps.validate()
    }
}

/// What one render needs.
pub struct RenderInput<'a> {
    pub frame: &'a WorldFrame<'a>,
    /// Primary-ray directions in the sensor frame (x forward, y left, z up), unit, one per pixel,
    /// row-major (from [`super::lens::Lens::ray_directions`]).
    pub rays: &'a [Vec3],
    /// Primary-ray origins in the sensor frame, one per pixel (the windshield's refraction,
    /// `super::windshield`); `None`: every ray starts at the sensor origin.
    pub ray_origins: Option<&'a [Vec3]>,
    pub width: usize,
    pub height: usize,
    pub response: &'a SpectralResponse,
    pub timing: ShutterTiming,
    /// The SensorView's ground truth (sun, time of day, vehicle light states).
    pub ground_truth: &'a osi3::GroundTruth,
    pub seed: u64,
    pub cycle: u64,
}

/// Cost split of one render, s of wall-clock time (ray-tracing shares: time summed over the worker
/// threads divided by their number).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RenderStats {
    /// Rays traced: camera rays (and motion-blur time samples, bounce rays), glass crossings,
    /// shadow rays.
    pub rays: u64,
    /// All ray tracing.
    pub trace_s: f64,
    /// Of which camera rays, motion-blur samples and diffuse bounces.
    pub camera_rays_s: f64,
    /// Of which shadow rays (sun and lamps).
    pub shadow_rays_s: f64,
    /// The rest: spectral shading, ray generation, glass, motion-blur bookkeeping.
    pub shading_s: f64,
}

/// What one render produces.
#[derive(Debug, Clone, Default)]
pub struct RenderOutput {
    /// Photo-electron radiance per channel, e⁻ s⁻¹ m⁻² sr⁻¹.
    pub radiance: ChannelImage,
    pub aux: RenderAux,
    /// Pixels seeing LED sources directly (only with `camera.led_flicker` on).
    pub flicker: Flicker,
    pub sun: Option<SunInView>,
    pub stats: RenderStats,
}

/// Solid angle of the solar disk, sr.
pub fn sun_solid_angle_sr() -> f64 {
    2.0 * PI * (1.0 - SUN_RADIUS_DEG.to_radians().cos())
}

/// The spectral renderer (plan once: band tables, light spectra; execute per frame).
pub struct Renderer {
    bands: SpectralBands,
    config: RenderConfig,
    effects: Effects,
    rolling: bool,
    blur: bool,
    flicker: bool,
    /// `env.retroreflection` on.
    retroreflection: bool,
    lamp_lib: LampLibrary,
    lamp_plan: LampPlan,
    /// Object id per pixel (before compaction into `aux.object_ids`).
    pixel_ids: Vec<u64>,
    id_map: HashMap<u64, u32>,
    /// The instances swept over each frame's exposure windows.
    sweep: Sweep,
    /// `env.sky_distribution` on.
    sky_shape: bool,
    /// The sky distribution of the last sun direction (recomputed when the sun moves).
    sky: SkyDistributionCache,
}

// ---------------------------------------------------------------------------------------------
// Frame plan
// ---------------------------------------------------------------------------------------------

/// Rows of the lane table (each `nl` lanes wide): `nm` materials, `ns` lamp spectra.
struct Rows {
    nm: usize,
    ns: usize,
}

impl Rows {
    /// ρ/π · E_dni per material.
    fn sun(&self, m: usize) -> usize {
        m
    }
    /// ρ/π · E_dhi per material.
    fn sky(&self, m: usize) -> usize {
        self.nm + m
    }
    /// ρ per material (band lanes only; channel lanes: w-weighted ρ, unused).
    fn rho(&self, m: usize) -> usize {
        2 * self.nm + m
    }
    /// ρ/π · s_spectrum per material (per lux).
    fn lamp(&self, s: usize, m: usize) -> usize {
        (3 + s) * self.nm + m
    }
    /// Retroreflected sun light per unit retro BRDF: `ρ(λ)/ρ̄_A · E_dni(λ)` per material.
    fn retro_sun(&self, m: usize) -> usize {
        (3 + self.ns) * self.nm + m
    }
    /// Retroreflected lamp light per unit retro BRDF and lux: `ρ(λ)/ρ̄_A · s(λ)` per material.
    fn retro_lamp(&self, s: usize, m: usize) -> usize {
        (4 + self.ns + s) * self.nm + m
    }
    fn base(&self) -> usize {
        (4 + 2 * self.ns) * self.nm
    }
    /// E_dni (for specular lobes).
    fn sun_e(&self) -> usize {
        self.base()
    }
    /// Sky radiance E_dhi/π (also the fog air light).
    fn sky_l(&self) -> usize {
        self.base() + 1
    }
    /// Sun disk radiance E_dni/Ω.
    fn disk(&self) -> usize {
        self.base() + 2
    }
    /// Lamp spectrum s(λ) (per cd/m² of luminance, per lux of illuminance).
    fn lamp_s(&self, s: usize) -> usize {
        self.base() + 3 + s
    }
    fn count(&self) -> usize {
        self.base() + 3 + self.ns
    }
}

/// Everything a frame's pixels share.
struct Ctx<'a> {
    frame: &'a WorldFrame<'a>,
    /// The frame's space with the moving instances at each ray's time.
    space: Swept<'a>,
    mats: &'a MaterialDb,
    rays: &'a [Vec3],
    origins: Option<&'a [Vec3]>,
    width: usize,
    nl: usize,
    bands: bool,
    rows: Rows,
    table: Vec<f32>,
    /// Channel weights w_c,k (band lanes only).
    weights: [[f32; MAX_BANDS]; CHANNELS],
    sigma: [f32; MAX_BANDS],
    fog: bool,
    /// The sky's radiance distribution relative to E_dhi/π.
    sky: &'a SkyDistribution,
    sun_dir: DVec3,
    sun_up: bool,
    cos_sun_radius: f64,
    /// Per material: transmissive (τ > 0 at normal incidence).
    transmissive: Vec<bool>,
    /// Per material: has a visible specular lobe.
    specular: Vec<bool>,
    lamps: &'a LampPlan,
    lamp_lib: &'a LampLibrary,
    min_lux: f64,
    /// Per scene mesh, per part: 1 head lamps, 2 tail lamps.
    part_role: Vec<Vec<u8>>,
    /// Per static-world part: a traffic-signal lens.
    static_lens: Vec<bool>,
    /// Per material: has a visible retroreflective lobe (and `env.retroreflection` is on).
    retro: Vec<bool>,
    bounces: u32,
    max_crossings: u32,
    max_distance_m: f64,
    seed: u64,
    flicker: bool,
}

struct GlassModel<'a> {
    mats: &'a MaterialDb,
}

impl TransmissionModel for GlassModel<'_> {
    fn transmittance(&self, hit: &Hit, direction: DVec3) -> f64 {
        self.mats
            .get(hit.material)
            .transmittance(Band::Visible(550.0), hit.cos_incidence(direction))
    }
}

/// One radiance sample to compute: a pixel at a time.
#[derive(Clone, Copy)]
struct Item {
    pixel: u32,
    dt: f64,
}

/// The result of one sample.
#[derive(Clone, Copy, Default)]
struct Sample {
    image: [f32; CHANNELS],
    emit: [f32; CHANNELS],
    /// Lamp index of the emission, `u32::MAX` if none.
    lamp: u32,
    depth: f32,
    object: u64,
    /// Angular speed of the image at this pixel, rad/s.
    angular_rate: f32,
}

/// A contribution waiting for its shadow ray: `acc[item] += (gd·T[rd] + gs·T[rs] + gr·T[rr]) (⊙ β)`.
#[derive(Clone, Copy)]
struct Pending {
    item: u32,
    rd: u32,
    rs: u32,
    /// Retroreflection row (only read when `gr ≠ 0`).
    rr: u32,
    gd: f32,
    gs: f32,
    gr: f32,
    beta: bool,
}

/// Per-task scratch.
#[derive(Default)]
struct Scratch {
    rays: Vec<Ray>,
    hits: Vec<Option<Hit>>,
    /// Items whose ray crossed glass: (item, the pane hit).
    glass_first: Vec<(u32, Hit)>,
    /// Items whose ray goes on behind a pane: (item, panes crossed).
    panes: Vec<(u32, u32)>,
    trans: Vec<f32>,
    refl: Vec<f32>,
    /// Per item: the sky factor of the fog's air light (horizon in the primary ray's azimuth).
    air: Vec<f32>,
    acc: Vec<f32>,
    emit: Vec<f32>,
    lamp: Vec<u32>,
    beta: Vec<f32>,
    vert: Vec<Option<Hit>>,
    pend: Vec<Pending>,
    srays: Vec<Ray>,
    socc: Vec<bool>,
    idx: Vec<u32>,
    items: Vec<Item>,
    samples: Vec<Sample>,
    blur: Vec<Sample>,
    flicker: Vec<FlickerSample>,
    flags: Vec<bool>,
    blur_idx: Vec<u32>,
    hits3: Vec<Option<Hit>>,
    dist: Vec<f64>,
    camera_s: f64,
    shadow_s: f64,
    rays_n: u64,
}

/// Temperature of CIE standard illuminant A, K (CIE S 014-2: a Planckian radiator at 2856 K).
const ILLUMINANT_A_K: f64 = 2856.0;

/// Luminous mean of a reflectance under CIE illuminant A: `∫ρ S_A V dλ / ∫S_A V dλ` over
/// 380–780 nm (1 nm steps).
fn illuminant_a_mean(rho: impl Fn(f64) -> f64) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for k in 0..=400 {
        let l = 380.0 + k as f64;
        let w = planck_radiance_w_m2_sr_nm(l, ILLUMINANT_A_K) * photopic_v(l);
        num += rho(l) * w;
        den += w;
    }
    num / den
}

fn unit_f64(h: u64) -> f64 {
    (h >> 11) as f64 / (1u64 << 53) as f64
}

/// Items per call of [`Ctx::radiance`] (a multiple of the 8-ray packet width).
const RADIANCE_BATCH: usize = 1024;

/// Offset of secondary-ray origins from a surface, m.
fn eps_at(p: DVec3) -> f64 {
    1e-4 + 1e-6 * p.abs().max_element()
}

impl Renderer {
    pub fn new(config: &RenderConfig, effects: &Effects) -> Result<Renderer, ModelError> {
        config.validate()?;
        Ok(Renderer {
            bands: SpectralBands::uniform(config.band_start_nm, config.band_end_nm, config.bands),
            config: config.clone(),
            effects: effects.clone(),
            rolling: effects.is_on(&ROLLING_SHUTTER),
            blur: effects.is_on(&MOTION_BLUR),
            flicker: effects.is_on(&LED_FLICKER),
            retroreflection: effects.is_on(&RETROREFLECTION),
            lamp_lib: LampLibrary::new(&config.lamps),
            lamp_plan: LampPlan::default(),
            pixel_ids: Vec::new(),
            id_map: HashMap::new(),
            sweep: Sweep::new(),
            sky_shape: effects.is_on(&SKY_DISTRIBUTION),
            sky: SkyDistributionCache::new(),
        })
    }

    pub fn bands(&self) -> &SpectralBands {
        &self.bands
    }

    /// The configuration in force.
    pub fn config(&self) -> &RenderConfig {
        &self.config
    }

    pub fn render(&mut self, input: &RenderInput<'_>, out: &mut RenderOutput) {
        let (w, h) = (input.width, input.height);
        let n = w * h;
        out.radiance.resize(w, h);
        out.aux.object_index.clear();
        out.aux.object_index.resize(n, NO_OBJECT);
        out.aux.depth_m.clear();
        out.aux.depth_m.resize(n, f32::INFINITY);
        out.aux.object_ids.clear();
        out.flicker.clear();
        out.sun = None;
        out.stats = RenderStats::default();
        if n == 0 || input.rays.len() < n {
            return;
        }
        let t_start = std::time::Instant::now();
        let frame = input.frame;
        let mats = &frame.scene.materials;
        // Sun and sky (SPCTRAL2).
        let sun_dir = crate::environment::sun::sun_direction(
            input.ground_truth.environmental_conditions.as_ref(),
        )
        .normalize();
        let el_deg = sun_dir.z.clamp(-1.0, 1.0).asin().to_degrees();
        let sky = spectrl2(&ClearSkyInput {
            zenith_deg: 90.0 - el_deg,
            day_of_year: self.config.day_of_year,
            ..self.config.atmosphere
        });
        let sun_up = el_deg > 0.0;
        // The sky's radiance distribution (planned once per sun direction).
        let ty = self.sky_shape.then(|| {
            CieSkyType::standard(self.config.sky_type).expect("sky_type validated to 1..=15")
        });
        self.sky.plan(sun_dir, ty);
        plan_lamps(
            &mut self.lamp_plan,
            &self.config.lamps,
            &self.lamp_lib,
            frame.scene,
            input.ground_truth,
            frame.host_id,
            sun_up,
            input.timing.frame_time_s + input.timing.start_offset_s,
        );

        // Bands, weights, fog.
        let resp = input.response;
        let centres = &resp.bands.centres_nm;
        let nb = centres.len().min(MAX_BANDS);
        let mut sigma = [0f32; MAX_BANDS];
        for (k, s) in sigma.iter_mut().enumerate().take(nb) {
            *s = weather::extinction_per_m_with(
                &frame.weather,
                weather::Band::Visible { nm: centres[k] },
                &self.effects,
            ) as f32;
        }
        let smax = sigma[..nb].iter().copied().fold(0f32, f32::max);
        let smin = sigma[..nb].iter().copied().fold(f32::INFINITY, f32::min);
        let fog = smax > 0.0;
        // Bounce rays only with `space.multipath` (indirect light) and `space.diffuse_bounces`.
        let bounces = frame
            .space
            .effects
            .diffuse_bounce_rays(self.config.diffuse_bounces);
        let bands_mode = bounces > 0 || (fog && smax - smin > 1e-6 * smax);
        let nl = if bands_mode { nb } else { CHANNELS };
        if !bands_mode {
            sigma[..CHANNELS].fill(smax);
        }
        let mut weights = [[0f32; MAX_BANDS]; CHANNELS];
        for c in 0..CHANNELS {
            for k in 0..nb {
                weights[c][k] = resp.weights[c].get(k).copied().unwrap_or(0.0) as f32;
            }
        }
        let nm = mats.len();
        let rows = Rows {
            nm,
            ns: self.lamp_lib.spectra.len(),
        };
        let omega = sun_solid_angle_sr();
        // Spectral row values at band k, then folded to lanes.
        let mut table = vec![0f32; rows.count() * nl];
        let mut put = |row: usize, f: &dyn Fn(usize) -> f64| {
            let dst = &mut table[row * nl..(row + 1) * nl];
            if bands_mode {
                for (k, d) in dst.iter_mut().enumerate() {
                    *d = f(k) as f32;
                }
            } else {
                for (c, d) in dst.iter_mut().enumerate() {
                    *d = (0..nb)
                        .map(|k| resp.weights[c].get(k).copied().unwrap_or(0.0) * f(k))
                        .sum::<f64>() as f32;
                }
            }
        };
        let dni: Vec<f64> = centres.iter().map(|&l| sky.dni_at(l)).collect();
        let dhi: Vec<f64> = centres.iter().map(|&l| sky.dhi_at(l)).collect();
        let spectra: Vec<Vec<f64>> = self
            .lamp_lib
            .spectra
            .iter()
            .map(|s| centres.iter().map(|&l| s.w_per_nm_per_lm(l)).collect())
            .collect();
        for (id, m) in mats.iter() {
            let i = id.0 as usize;
            let rho: Vec<f64> = centres.iter().map(|&l| m.reflectance_visible(l)).collect();
            put(rows.sun(i), &|k| rho[k] / PI * dni[k]);
            put(rows.sky(i), &|k| rho[k] / PI * dhi[k]);
            put(rows.rho(i), &|k| rho[k]);
            for (s, sp) in spectra.iter().enumerate() {
                put(rows.lamp(s, i), &|k| rho[k] / PI * sp[k]);
            }
            // Retroreflection: the lobe's light carries the sheeting's colour, ρ(λ) normalised to
            // its luminous mean under CIE illuminant A (the illuminant R_A is measured with), so that
            // R_A = L_v / E_⊥ holds photometrically for illuminant A (physics.md §3.6).
            if self.retroreflection && m.has_retro(Band::Visible(550.0)) {
                let rho_a = illuminant_a_mean(|l| m.reflectance_visible(l));
                if rho_a > 0.0 {
                    put(rows.retro_sun(i), &|k| rho[k] / rho_a * dni[k]);
                    for (s, sp) in spectra.iter().enumerate() {
                        put(rows.retro_lamp(s, i), &|k| rho[k] / rho_a * sp[k]);
                    }
                }
            }
        }
        put(rows.sun_e(), &|k| dni[k]);
        put(rows.sky_l(), &|k| dhi[k] / PI);
        put(rows.disk(), &|k| dni[k] / omega);
        for (s, sp) in spectra.iter().enumerate() {
            put(rows.lamp_s(s), &|k| sp[k]);
        }
        let transmissive: Vec<bool> = (0..nm)
            .map(|i| {
                mats.get(crate::environment::material::MaterialId(i as u32))
                    .transmittance(Band::Visible(550.0), 1.0)
                    > 0.0
            })
            .collect();
        let specular: Vec<bool> = (0..nm)
            .map(|i| {
                mats.get(crate::environment::material::MaterialId(i as u32))
                    .has_specular(Band::Visible(550.0))
            })
            .collect();
        let retro: Vec<bool> = (0..nm)
            .map(|i| {
                self.retroreflection
                    && mats
                        .get(crate::environment::material::MaterialId(i as u32))
                        .has_retro(Band::Visible(550.0))
            })
            .collect();
        let static_lens: Vec<bool> = frame
            .scene
            .static_world
            .mesh
            .parts
            .iter()
            .map(|p| p.name == SIGNAL_LENS_PART)
            .collect();
        let part_role: Vec<Vec<u8>> = frame
            .scene
            .meshes
            .iter()
            .map(|m| {
                m.mesh
                    .parts
                    .iter()
                    .map(|p| match p.name.as_str() {
                        "head_lamps" => 1,
                        "tail_lamps" => 2,
                        _ => 0,
                    })
                    .collect()
            })
            .collect();
        // The sun in view (for flare).
        let sun_sensor = frame.sensor_pose.inverse_transform_vector(sun_dir);
        if sun_up && sun_sensor.x > 0.0 {
            let o = frame.sensor_origin();
            let blocked = frame
                .space
                .any_hit(&Ray::new(o, sun_dir).with_t_max(self.config.max_distance_m));
            if !blocked {
                let mut radiance = [0.0; CHANNELS];
                for (c, r) in radiance.iter_mut().enumerate() {
                    *r = (0..nb)
                        .map(|k| resp.weights[c].get(k).copied().unwrap_or(0.0) * dni[k] / omega)
                        .sum();
                }
                out.sun = Some(SunInView {
                    direction_sensor: sun_sensor,
                    radiance,
                    solid_angle_sr: omega,
                });
            }
        }

        // Times: row r's window starts at base + r·row_time.
        let timing = input.timing;
        let base = timing.frame_time_s - frame.time_s + timing.start_offset_s;
        let row_time = if self.rolling { timing.row_time_s } else { 0.0 };
        let exposure = timing.exposure_s.max(0.0);
        let blur_samples = if self.blur {
            self.config.motion_samples
        } else {
            1
        };
        let threshold = self.config.motion_threshold_px;

        // Moving instances where they are at each ray's time: every item's time lies in
        // [base, base + (h − 1)·row_time + exposure].
        let space = self.sweep.update(
            frame.space,
            (
                base,
                base + h.saturating_sub(1) as f64 * row_time + exposure,
            ),
        );

        let ctx = Ctx {
            frame,
            space,
            mats,
            rays: input.rays,
            origins: input.ray_origins.filter(|o| o.len() == input.rays.len()),
            width: w,
            nl,
            bands: bands_mode,
            rows,
            table,
            weights,
            sigma,
            fog,
            sky: self.sky.planned().expect("planned above"),
            sun_dir,
            sun_up,
            cos_sun_radius: SUN_RADIUS_DEG.to_radians().cos(),
            transmissive,
            specular,
            lamps: &self.lamp_plan,
            lamp_lib: &self.lamp_lib,
            min_lux: self.config.lamps.min_illuminance_lux,
            part_role,
            static_lens,
            retro,
            bounces,
            max_crossings: self.config.max_glass_crossings,
            max_distance_m: self.config.max_distance_m,
            seed: fmix64(input.seed ^ input.cycle.wrapping_mul(0x9E37_79B9_7F4A_7C15)),
            flicker: self.flicker,
        };

        self.pixel_ids.clear();
        self.pixel_ids.resize(n, u64::MAX);
        let rows_per_task = (4096 / w.max(1)).clamp(1, 64);
        let chunk = rows_per_task * w;
        let flicker_all = Mutex::new(Vec::<FlickerSample>::new());
        let stats = Mutex::new(([0f64; 2], 0u64));
        let [p0, p1, p2] = &mut out.radiance.planes;
        p0.par_chunks_mut(chunk)
            .zip(p1.par_chunks_mut(chunk))
            .zip(p2.par_chunks_mut(chunk))
            .zip(out.aux.depth_m.par_chunks_mut(chunk))
            .zip(self.pixel_ids.par_chunks_mut(chunk))
            .enumerate()
            .for_each_init(Scratch::default, |s, (ci, ((((r, g), b), depth), ids))| {
                let first_pixel = ci * chunk;
                let count = r.len();
                s.items.clear();
                for i in 0..count {
                    let pixel = first_pixel + i;
                    let row = pixel / w;
                    s.items.push(Item {
                        pixel: pixel as u32,
                        dt: base + row as f64 * row_time + 0.5 * exposure,
                    });
                }
                let mut samples = std::mem::take(&mut s.samples);
                let items = std::mem::take(&mut s.items);
                ctx.radiance_batched(&items, s, &mut samples);
                s.flicker.clear();
                for (i, smp) in samples.iter().enumerate() {
                    r[i] = smp.image[0];
                    g[i] = smp.image[1];
                    b[i] = smp.image[2];
                    depth[i] = smp.depth;
                    ids[i] = smp.object;
                }
                // Motion blur: more time samples where the image moves.
                let mut items = items;
                if blur_samples > 1 && exposure > 0.0 {
                    let ifov = ctx.ifov_rad(first_pixel);
                    items.clear();
                    // Pixels the moving image sweeps over: dilate each moving pixel by its
                    // motion (within this block of rows).
                    s.flags.clear();
                    s.flags.resize(count, false);
                    let rows_here = count / w;
                    let rad_of = |smp: &Sample| {
                        let m = f64::from(smp.angular_rate) * exposure / ifov;
                        (m > threshold).then(|| (m.ceil() as usize).min(256))
                    };
                    // Horizontal and vertical sweeps: a pixel is flagged when it lies within the
                    // motion radius of a moving pixel of its row or column (O(pixels)).
                    for y in 0..rows_here {
                        let mut reach: Option<usize> = None;
                        for x in 0..w {
                            if let Some(rad) = rad_of(&samples[y * w + x]) {
                                reach = Some(reach.map_or(x + rad, |r| r.max(x + rad)));
                            }
                            if reach.is_some_and(|r| x <= r) {
                                s.flags[y * w + x] = true;
                            }
                        }
                        let mut reach: Option<isize> = None;
                        for x in (0..w).rev() {
                            if let Some(rad) = rad_of(&samples[y * w + x]) {
                                let lo = x as isize - rad as isize;
                                reach = Some(reach.map_or(lo, |r| r.min(lo)));
                            }
                            if reach.is_some_and(|r| x as isize >= r) {
                                s.flags[y * w + x] = true;
                            }
                        }
                    }
                    if rows_here > 1 {
                        for x in 0..w {
                            for y in 0..rows_here {
                                if let Some(rad) = rad_of(&samples[y * w + x]) {
                                    for yy in y.saturating_sub(rad)..(y + rad + 1).min(rows_here) {
                                        s.flags[yy * w + x] = true;
                                    }
                                }
                            }
                        }
                    }
                    // Sample-major order with one jitter per row: consecutive items are
                    // neighbouring pixels at the same time (coherent ray packets).
                    s.blur_idx.clear();
                    s.blur_idx
                        .extend((0..count as u32).filter(|&i| s.flags[i as usize]));
                    let nf = s.blur_idx.len();
                    // Odd sample counts use centred strata (k + ½)/n, whose middle one is the
                    // mid-exposure sample already traced above (reused, not traced again); even
                    // counts jitter each stratum per row.
                    let reuse = (blur_samples % 2 == 1).then_some(blur_samples / 2);
                    for k in (0..blur_samples).filter(|&k| Some(k) != reuse) {
                        for &i in &s.blur_idx {
                            let pixel = first_pixel + i as usize;
                            let row = pixel / w;
                            let j = if reuse.is_some() {
                                0.5
                            } else {
                                unit_f64(fmix64(
                                    ctx.seed ^ (row as u64).wrapping_mul(0x2545_F491_4F6C_DD1D),
                                ))
                            };
                            let f = (f64::from(k) + j) / f64::from(blur_samples);
                            items.push(Item {
                                pixel: pixel as u32,
                                dt: base + row as f64 * row_time + f * exposure,
                            });
                        }
                    }
                    if nf > 0 {
                        let mut blur = std::mem::take(&mut s.blur);
                        ctx.radiance_batched(&items, s, &mut blur);
                        let inv = 1.0 / blur_samples as f32;
                        for (f, &i) in s.blur_idx.iter().enumerate() {
                            let i = i as usize;
                            let mut img = [0f32; CHANNELS];
                            let mut em = [0f32; CHANNELS];
                            let mut lamp = u32::MAX;
                            for k in 0..blur_samples as usize {
                                let smp = match reuse {
                                    Some(m) if k == m as usize => &samples[i],
                                    Some(m) if k > m as usize => &blur[(k - 1) * nf + f],
                                    _ => &blur[k * nf + f],
                                };
                                for c in 0..CHANNELS {
                                    img[c] += smp.image[c] * inv;
                                    em[c] += smp.emit[c] * inv;
                                }
                                if smp.lamp != u32::MAX {
                                    lamp = smp.lamp;
                                }
                            }
                            r[i] = img[0];
                            g[i] = img[1];
                            b[i] = img[2];
                            samples[i].emit = em;
                            samples[i].lamp = lamp;
                        }
                        s.blur = blur;
                    }
                }
                // Emission: into the image or the flicker list.
                for (i, smp) in samples.iter().enumerate() {
                    if smp.lamp == u32::MAX {
                        continue;
                    }
                    let pwm = ctx.lamps.lamps[smp.lamp as usize].pwm;
                    if ctx.flicker && pwm.is_some() {
                        s.flicker.push(FlickerSample {
                            pixel: (first_pixel + i) as u32,
                            value: smp.emit,
                            source: smp.lamp as u16,
                        });
                    } else {
                        r[i] += smp.emit[0];
                        g[i] += smp.emit[1];
                        b[i] += smp.emit[2];
                    }
                }
                if !s.flicker.is_empty() {
                    flicker_all
                        .lock()
                        .expect("flicker list")
                        .extend_from_slice(&s.flicker);
                }
                let mut st = stats.lock().expect("stats");
                for (a, b) in st.0.iter_mut().zip([&mut s.camera_s, &mut s.shadow_s]) {
                    *a += std::mem::take(b);
                }
                st.1 += std::mem::take(&mut s.rays_n);
                drop(st);
                s.items = items;
                s.samples = samples;
            });
        drop(ctx);

        // Flicker sources: every lamp, indexed by lamp number (sources without PWM never sampled).
        let mut fl = flicker_all.into_inner().expect("flicker list");
        if !fl.is_empty() {
            fl.sort_by_key(|f| f.pixel);
            out.flicker.samples = fl;
            out.flicker.sources = self
                .lamp_plan
                .lamps
                .iter()
                .map(|l| {
                    l.pwm.unwrap_or(super::PwmSource {
                        frequency_hz: 0.0,
                        duty: 1.0,
                        phase_s: 0.0,
                    })
                })
                .collect();
        }

        // Object ids → indices.
        self.id_map.clear();
        let mut last = (u64::MAX, NO_OBJECT);
        for (idx, &id) in out.aux.object_index.iter_mut().zip(&self.pixel_ids) {
            if id == u64::MAX {
                continue;
            }
            if id != last.0 {
                let next = out.aux.object_ids.len() as u32;
                let k = *self.id_map.entry(id).or_insert_with(|| {
                    out.aux.object_ids.push(id);
                    next
                });
                last = (id, k);
            }
            *idx = last.1;
        }
        let ([camera_s, shadow_s], rays) = stats.into_inner().expect("stats");
        let trace_s = camera_s + shadow_s;
        let total = t_start.elapsed().as_secs_f64();
        // Per-task trace time summed over threads; scale to wall-clock share.
        let threads = rayon::current_num_threads().max(1) as f64;
        out.stats.rays = rays;
        out.stats.trace_s = (trace_s / threads).min(total);
        out.stats.camera_rays_s = camera_s / threads;
        out.stats.shadow_rays_s = shadow_s / threads;
        out.stats.shading_s = (total - out.stats.trace_s).max(0.0);
    }
}

impl Ctx<'_> {
    fn row(&self, r: usize) -> &[f32] {
        &self.table[r * self.nl..(r + 1) * self.nl]
    }

    /// The static-world element that triangle `t` belongs to: its triangle range and its
    /// ground-truth object id (`u64::MAX` if it is not an object; an empty range if `t` has no
    /// owner, so that it is looked up again next time).
    fn static_owner(&self, t: u32) -> (u32, u32, u64) {
        self.frame
            .scene
            .static_owner(t)
            .map_or((0, 0, u64::MAX), |o| {
                let id = o.element.ground_truth_id().unwrap_or(u64::MAX);
                (o.first_triangle, o.first_triangle + o.triangle_count, id)
            })
    }

    /// Angular size of a pixel near `pixel`, rad.
    fn ifov_rad(&self, pixel: usize) -> f64 {
        let a = self.rays[pixel].as_dvec3();
        let b = if !(pixel + 1).is_multiple_of(self.width) && pixel + 1 < self.rays.len() {
            self.rays[pixel + 1].as_dvec3()
        } else if pixel > 0 {
            self.rays[pixel - 1].as_dvec3()
        } else {
            return 1e-3;
        };
        a.angle_between(b).max(1e-6)
    }

    fn pose_at(&self, dt: f64) -> Pose {
        if dt == 0.0 {
            self.frame.sensor_pose
        } else {
            self.frame.sensor_pose_at(dt)
        }
    }

    fn traced(&self, s: &mut Scratch, which: bool) {
        let t = std::time::Instant::now();
        if which {
            s.hits.resize(s.rays.len(), None);
            self.space.trace_batch(&s.rays, &mut s.hits);
            s.camera_s += t.elapsed().as_secs_f64();
        } else {
            s.socc.resize(s.srays.len(), false);
            self.space.occluded_batch(&s.srays, &mut s.socc);
            s.shadow_s += t.elapsed().as_secs_f64();
        }
        s.rays_n += if which { s.rays.len() } else { s.srays.len() } as u64;
    }

    /// Whether a hit is on a lit lamp lens (a vehicle lamp, or the front of a lit traffic-signal
    /// lens): the lamp index.
    fn lit_lamp(&self, hit: &Hit) -> Option<u32> {
        let Some(inst) = hit.instance else {
            if !hit.front_face || !self.static_lens.get(usize::from(hit.part)).copied()? {
                return None;
            }
            return match self.frame.scene.static_element(hit.triangle)? {
                StaticElement::TrafficLight(id) => self.lamps.signal_lamps.get(&id).copied(),
                _ => None,
            };
        };
        let inst = inst as usize;
        let si = self.frame.scene.instances.get(inst)?;
        let role = *self.part_role.get(si.mesh)?.get(hit.part as usize)?;
        if role == 0 {
            return None;
        }
        let slots = self.lamps.instance_lamps.get(inst)?;
        let local = si.pose_local.inverse_transform_point(hit.point);
        let side = usize::from(local.y >= 0.0);
        let k = slots[side + 2 * usize::from(role == 2)];
        (k != u32::MAX).then_some(k)
    }

    /// [`Self::radiance`] in batches of at most [`RADIANCE_BATCH`] items, so that the per-ray
    /// scratch (rays, hit records, lane accumulators) stays in the core's L2 cache.
    fn radiance_batched(&self, items: &[Item], s: &mut Scratch, out: &mut Vec<Sample>) {
        out.clear();
        out.resize(items.len(), Sample::default());
        for (batch, samples) in items
            .chunks(RADIANCE_BATCH)
            .zip(out.chunks_mut(RADIANCE_BATCH))
        {
            self.radiance(batch, s, samples);
        }
    }

    /// Compute one sample per item (`out`: one default sample per item).
    fn radiance(&self, items: &[Item], s: &mut Scratch, out: &mut [Sample]) {
        let n = items.len();
        let nl = self.nl;
        // Primary rays.
        s.rays.clear();
        let mut pose_cache: (f64, Pose) = (f64::NAN, self.frame.sensor_pose);
        for it in items {
            if it.dt != pose_cache.0 {
                pose_cache = (it.dt, self.pose_at(it.dt));
            }
            let pose = &pose_cache.1;
            let d = pose.rotation * self.rays[it.pixel as usize].as_dvec3();
            let o = match self.origins {
                Some(o) => pose.transform_point(o[it.pixel as usize].as_dvec3()),
                None => pose.position,
            };
            s.rays.push(
                Ray::new(o, d)
                    .with_t_max(self.max_distance_m)
                    .at_time(it.dt),
            );
        }
        self.traced(s, true);
        // Glass (the first surface of the items whose ray passes glass is kept aside).
        s.glass_first.clear();
        s.panes.clear();
        s.trans.clear();
        s.trans.resize(n, 1.0);
        s.refl.clear();
        s.refl.resize(n, 0.0);
        s.lamp.clear();
        s.lamp.resize(n, u32::MAX);
        let glass = GlassModel { mats: self.mats };
        for i in 0..n {
            let Some(hit) = &s.hits[i] else { continue };
            if let Some(l) = self.lit_lamp(hit) {
                s.lamp[i] = l;
                continue;
            }
            if self.max_crossings > 0 && self.transmissive[hit.material.0 as usize] {
                let ray = s.rays[i];
                let cos = hit.cos_incidence(ray.direction);
                let optics = self
                    .mats
                    .get(hit.material)
                    .slab_optics(Band::Visible(550.0), cos);
                if let Some(so) = optics {
                    let n = hit.facing_normal();
                    let mirror = ray.direction - 2.0 * ray.direction.dot(n) * n;
                    s.refl[i] = (so.reflectance * self.sky.factor(mirror)) as f32;
                }
                s.glass_first.push((i as u32, *hit));
                // Through the pane (as `Space::closest_hit_through`, from the pane already found;
                // τ of `GlassModel`): the rays go on in a batch below.
                if self.frame.space.effects.transmission {
                    let tau = optics.map_or(0.0, |so| so.transmittance).clamp(0.0, 1.0);
                    if tau > 0.0 {
                        s.trans[i] = tau as f32;
                        s.panes.push((i as u32, 1));
                    }
                }
            }
        }
        // Batches of the rays behind panes, until each meets an opaque surface, the sky or its
        // `max_crossings`-th pane.
        while !s.panes.is_empty() {
            s.srays.clear();
            for &(i, _) in &s.panes {
                let (ray, hit) = (s.rays[i as usize], s.hits[i as usize].expect("a pane"));
                let t_min = hit.distance_m + surface_epsilon(hit.point, hit.distance_m);
                s.srays.push(ray.with_t_min(t_min));
            }
            let t = std::time::Instant::now();
            s.hits3.clear();
            s.hits3.resize(s.srays.len(), None);
            self.space.trace_batch(&s.srays, &mut s.hits3);
            s.camera_s += t.elapsed().as_secs_f64();
            s.rays_n += s.srays.len() as u64;
            let mut keep = 0;
            for j in 0..s.panes.len() {
                let (i, crossed) = s.panes[j];
                let (ray, next) = (s.srays[j], s.hits3[j]);
                s.hits[i as usize] = next;
                let Some(h) = next else { continue };
                if crossed >= self.max_crossings {
                    continue;
                }
                let tau = glass.transmittance(&h, ray.direction).clamp(0.0, 1.0);
                if tau > 0.0 {
                    s.trans[i as usize] *= tau as f32;
                    s.panes[keep] = (i, crossed + 1);
                    keep += 1;
                }
            }
            s.panes.truncate(keep);
        }
        s.srays.clear();

        // Shading.
        s.acc.clear();
        s.acc.resize(n * nl, 0.0);
        s.emit.clear();
        s.emit.resize(n * nl, 0.0);
        s.pend.clear();
        s.srays.clear();
        s.air.clear();
        s.air.resize(n, 1.0);
        let sky_l = self.rows.sky_l();
        let mut owner = (0u32, 0u32, u64::MAX);
        let mut glass_next = 0;
        for i in 0..n {
            let ray = s.rays[i];
            // The first surface on the ray (glass, or what the ray stopped at).
            let first = match s.glass_first.get(glass_next) {
                Some((g, hit)) if *g as usize == i => {
                    glass_next += 1;
                    Some(hit)
                }
                _ => s.hits[i].as_ref(),
            };
            let smp = &mut out[i];
            smp.lamp = u32::MAX;
            smp.object = u64::MAX;
            smp.depth = f32::INFINITY;
            if let Some(f) = first {
                smp.depth = f.distance_m as f32;
                smp.object = match f.object_id {
                    Some(id) => id,
                    None => {
                        // Neighbouring pixels mostly hit the same static element: look its
                        // triangle range up once.
                        if !(owner.0..owner.1).contains(&f.triangle) {
                            owner = self.static_owner(f.triangle);
                        }
                        owner.2
                    }
                };
                let v_rel = f.velocity_m_s - self.frame.sensor_point_velocity(f.point);
                let perp = v_rel - ray.direction * v_rel.dot(ray.direction);
                smp.angular_rate =
                    (perp.length_squared() as f32).sqrt() / f.distance_m.max(1e-3) as f32;
            } else {
                smp.angular_rate = self
                    .frame
                    .sensor_angular_velocity_rad_s
                    .cross(ray.direction)
                    .length() as f32;
            }
            if self.fog {
                s.air[i] = self
                    .sky
                    .factor(DVec3::new(ray.direction.x, ray.direction.y, 0.0))
                    as f32;
            }
            let acc = &mut s.acc[i * nl..(i + 1) * nl];
            // Glass reflects the sky.
            if s.refl[i] > 0.0 {
                let r = s.refl[i];
                for (a, l) in acc.iter_mut().zip(self.row(sky_l)) {
                    *a += r * l;
                }
            }
            let tr = s.trans[i];
            if s.lamp[i] != u32::MAX {
                // Lit lens seen directly: L_v = I(θ)/(A cos θ).
                let lamp = &self.lamps.lamps[s.lamp[i] as usize];
                let to_cam = -ray.direction;
                let dir_l = lamp.to_lamp(to_cam);
                let cos = dir_l.x.max(0.1);
                let iv = self.lamp_lib.distributions[lamp.distribution].intensity_cd_dir(dir_l);
                let lv = (iv / (lamp.area_m2 * cos)) as f32 * tr;
                let em = &mut s.emit[i * nl..(i + 1) * nl];
                for (e, l) in em.iter_mut().zip(self.row(self.rows.lamp_s(lamp.spectrum))) {
                    *e += lv * l;
                }
                smp.lamp = s.lamp[i];
                continue;
            }
            let Some(hit) = s.hits[i] else {
                // Sky (and the sun disk).
                let k = tr * self.sky.factor(ray.direction) as f32;
                for (a, l) in acc.iter_mut().zip(self.row(sky_l)) {
                    *a += k * l;
                }
                if self.sun_up && ray.direction.dot(self.sun_dir) >= self.cos_sun_radius {
                    for (a, l) in acc.iter_mut().zip(self.row(self.rows.disk())) {
                        *a += tr * l;
                    }
                }
                continue;
            };
            self.shade_point(
                i as u32,
                &hit,
                -ray.direction,
                ray.time_s,
                tr,
                !self.bands || self.bounces == 0,
                false,
                s,
            );
        }
        self.resolve_shadows(s);
        s.dist.clear();
        s.dist.extend(
            s.hits
                .iter()
                .map(|h| h.map_or(f64::INFINITY, |h| h.distance_m)),
        );
        if self.bounces > 0 {
            self.bounce(items, s);
        }
        // Fog and channel fold.
        for i in 0..n {
            let depth = s.dist[i];
            let acc = &mut s.acc[i * nl..(i + 1) * nl];
            let em = &mut s.emit[i * nl..(i + 1) * nl];
            if self.fog {
                let air = &self.table[sky_l * nl..(sky_l + 1) * nl];
                let k = s.air[i];
                for l in 0..nl {
                    let t = (-(f64::from(self.sigma[l]) * depth)).exp() as f32;
                    acc[l] = acc[l] * t + k * air[l] * (1.0 - t);
                    em[l] *= t;
                }
            }
            let smp = &mut out[i];
            if self.bands {
                for c in 0..CHANNELS {
                    let w = &self.weights[c][..nl];
                    smp.image[c] = acc.iter().zip(w).map(|(a, w)| a * w).sum();
                    smp.emit[c] = em.iter().zip(w).map(|(a, w)| a * w).sum();
                }
            } else {
                smp.image.copy_from_slice(&acc[..CHANNELS]);
                smp.emit.copy_from_slice(&em[..CHANNELS]);
            }
        }
    }

    /// Direct light at a surface point seen at `time_s` (its shadow rays at that time): sun
    /// (shadow ray), sky ambient (`ambient`), lamps (shadow rays). `beta`: multiply by the item's
    /// bounce throughput.
    #[allow(clippy::too_many_arguments)]
    fn shade_point(
        &self,
        item: u32,
        hit: &Hit,
        wo: DVec3,
        time_s: f64,
        weight: f32,
        ambient: bool,
        beta: bool,
        s: &mut Scratch,
    ) {
        let nl = self.nl;
        let m = hit.material.0 as usize;
        let n = hit.facing_normal();
        let p = hit.point + n * eps_at(hit.point);
        let mat = self.mats.get(hit.material);
        let lobe = self.specular[m];
        // Diffuse coupling a (the table rows carry ρ/π) and specular f_s for a light direction wi.
        let brdf = |wi: DVec3| -> (f64, f64) {
            if lobe {
                mat.brdf_parts(Band::Visible(550.0), wi, wo, n)
            } else {
                (1.0, 0.0)
            }
        };
        if ambient {
            let vf = self.sky.view_factor(n) as f32 * weight;
            let row = self.rows.sky(m);
            let acc = &mut s.acc[item as usize * nl..(item as usize + 1) * nl];
            if beta {
                let b = &s.beta[item as usize * nl..(item as usize + 1) * nl];
                for l in 0..nl {
                    acc[l] += vf * b[l] * self.table[row * nl + l];
                }
            } else {
                for (a, t) in acc.iter_mut().zip(&self.table[row * nl..(row + 1) * nl]) {
                    *a += vf * t;
                }
            }
            // Specular reflection of the sky (mirror direction above the horizon).
            if lobe {
                let mirror = 2.0 * n.dot(wo) * n - wo;
                if mirror.z > 0.0 && !beta {
                    let r = (mat
                        .specular_reflectance(Band::Visible(550.0), n.dot(wo).clamp(0.0, 1.0))
                        * self.sky.factor(mirror)) as f32
                        * weight;
                    let sky = self.rows.sky_l();
                    for (a, t) in acc.iter_mut().zip(&self.table[sky * nl..(sky + 1) * nl]) {
                        *a += r * t;
                    }
                }
            }
        }
        // Retroreflective lobe (wavelength-independent shape, coloured by the `retro_*` rows).
        let retro = self.retro[m];
        let fr = |wi: DVec3| -> f64 {
            if retro {
                mat.retro_brdf(Band::Visible(550.0), wi, wo, n)
            } else {
                0.0
            }
        };
        // Sun.
        let cos_s = n.dot(self.sun_dir);
        if self.sun_up && cos_s > 0.0 {
            let (a, fs) = brdf(self.sun_dir);
            s.pend.push(Pending {
                item,
                rd: self.rows.sun(m) as u32,
                rs: self.rows.sun_e() as u32,
                rr: self.rows.retro_sun(m) as u32,
                gd: (a * cos_s) as f32 * weight,
                gs: (fs * cos_s) as f32 * weight,
                gr: (fr(self.sun_dir) * cos_s) as f32 * weight,
                beta,
            });
            // `sun_dir` is a unit vector already.
            s.srays.push(Ray {
                origin: p,
                direction: self.sun_dir,
                t_min: 0.0,
                t_max: self.max_distance_m,
                time_s,
            });
        }
        // Lamps.
        for lamp in self.lamps.lamps.iter().filter(|l| l.illuminates) {
            let d = lamp.position - p;
            let r2 = d.length_squared();
            if r2 < 1e-6 {
                continue;
            }
            let r = r2.sqrt();
            let wi = d / r;
            let cos_i = n.dot(wi);
            if cos_i <= 0.0 {
                continue;
            }
            let iv =
                self.lamp_lib.distributions[lamp.distribution].intensity_cd_dir(lamp.to_lamp(-wi));
            let e = iv * cos_i / r2;
            if e < self.min_lux {
                continue;
            }
            let (a, fs) = brdf(wi);
            s.pend.push(Pending {
                item,
                rd: self.rows.lamp(lamp.spectrum, m) as u32,
                rs: self.rows.lamp_s(lamp.spectrum) as u32,
                rr: self.rows.retro_lamp(lamp.spectrum, m) as u32,
                gd: (a * e) as f32 * weight,
                gs: (fs * e) as f32 * weight,
                gr: (fr(wi) * e) as f32 * weight,
                beta,
            });
            s.srays.push(
                Ray::new(p, wi)
                    .with_t_max((r - 0.02).max(0.0))
                    .at_time(time_s),
            );
        }
    }

    fn resolve_shadows(&self, s: &mut Scratch) {
        if s.srays.is_empty() {
            return;
        }
        self.traced(s, false);
        let nl = self.nl;
        for (pd, &occ) in s.pend.iter().zip(&s.socc) {
            if occ {
                continue;
            }
            let i = pd.item as usize;
            let acc = &mut s.acc[i * nl..(i + 1) * nl];
            let td = &self.table[pd.rd as usize * nl..(pd.rd as usize + 1) * nl];
            let ts = &self.table[pd.rs as usize * nl..(pd.rs as usize + 1) * nl];
            let tr = &self.table[pd.rr as usize * nl..(pd.rr as usize + 1) * nl];
            if pd.beta {
                let b = &s.beta[i * nl..(i + 1) * nl];
                for l in 0..nl {
                    acc[l] += b[l] * (pd.gd * td[l] + pd.gs * ts[l] + pd.gr * tr[l]);
                }
            } else {
                for l in 0..nl {
                    acc[l] += pd.gd * td[l] + pd.gs * ts[l] + pd.gr * tr[l];
                }
            }
        }
        s.pend.clear();
        s.srays.clear();
    }

    /// Cosine-weighted diffuse bounces (band lanes): throughput β ⊙= ρ at each vertex.
    fn bounce(&self, items: &[Item], s: &mut Scratch) {
        let nl = self.nl;
        let n = items.len();
        s.beta.clear();
        s.beta.resize(n * nl, 1.0);
        s.vert.clear();
        s.vert.extend((0..n).map(|i| {
            if s.lamp[i] == u32::MAX {
                s.hits[i]
            } else {
                None
            }
        }));
        // Fold the glass transmittance of the primary path into β.
        for i in 0..n {
            let t = s.trans[i];
            s.beta[i * nl..(i + 1) * nl].iter_mut().for_each(|b| *b = t);
        }
        for b in 0..self.bounces {
            s.rays.clear();
            s.idx.clear();
            for i in 0..n {
                let Some(v) = s.vert[i] else { continue };
                let nrm = v.facing_normal();
                let h = fmix64(
                    self.seed
                        ^ (u64::from(items[i].pixel) << 8)
                        ^ u64::from(b)
                        ^ items[i].dt.to_bits(),
                );
                let u1 = unit_f64(h);
                let u2 = unit_f64(fmix64(h));
                // Malley's method: uniform disk sample lifted to the hemisphere.
                let r = u1.sqrt();
                let phi = 2.0 * PI * u2;
                let (t1, t2) = nrm.any_orthonormal_pair();
                let d = (t1 * (r * phi.cos())
                    + t2 * (r * phi.sin())
                    + nrm * (1.0 - u1).max(0.0).sqrt())
                .normalize();
                s.rays.push(
                    Ray::new(v.point + nrm * eps_at(v.point), d)
                        .with_t_max(self.max_distance_m)
                        .at_time(items[i].dt),
                );
                s.idx.push(i as u32);
            }
            if s.rays.is_empty() {
                break;
            }
            self.traced(s, true);
            let last = b + 1 == self.bounces;
            let sky_l = self.rows.sky_l();
            for j in 0..s.idx.len() {
                let i = s.idx[j] as usize;
                let v = s.vert[i].expect("active vertex");
                let rho = self.rows.rho(v.material.0 as usize);
                for l in 0..nl {
                    s.beta[i * nl + l] *= self.table[rho * nl + l];
                }
                match s.hits[j] {
                    None => {
                        let k = self.sky.factor(s.rays[j].direction) as f32;
                        for l in 0..nl {
                            s.acc[i * nl + l] +=
                                k * s.beta[i * nl + l] * self.table[sky_l * nl + l];
                        }
                        s.vert[i] = None;
                    }
                    Some(hit) => {
                        let wo = -s.rays[j].direction;
                        self.shade_point(i as u32, &hit, wo, items[i].dt, 1.0, last, true, s);
                        s.vert[i] = Some(hit);
                    }
                }
            }
            self.resolve_shadows(s);
        }
    }
}
