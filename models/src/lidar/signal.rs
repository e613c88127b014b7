//! Signal propagation: the optical power of each sub-ray return at the detector (LiDAR equation),
//! the near-range biaxial overlap and the solar background.
//!
//! # LiDAR equation per sub-ray
//!
//! A sub-ray carrying the fraction w_i of the peak power P_t illuminates the patch it hits with
//! irradiance E = w_i P_t cos θ / A_patch. The patch radiates the radiance L = f_r E towards the
//! receiver (BRDF f_r, sr⁻¹, at the laser band, `wi = wo` = towards the sensor), and the receiver of
//! area A_r at range R collects P = L A_patch A_r / R² (the patch subtends A_r/R² of solid angle). So
//!
//!   P_i = P_t w_i f_r(wi, wo) cos θ A_r η_sys T²(R) O(R) / R²,
//!
//! which for a Lambertian target (f_r = ρ/π) filling the beam (Σw_i = 1) is the extended-target
//! equation P_r = P_t ρ cos θ A_r η T² / (πR²) of physics.md §2.1 (Kashani et al., Sensors 15:28099,
//! 2015; Wagner, ISPRS J. 65:505, 2010). Small targets fall out of the sampling: only the sub-rays
//! that hit them contribute. Retro-reflective lobes of the material BRDF give the strong returns of
//! signs and plates.
//!
//! T²(R) = exp(−2αR): two-way extinction by fog (Kim model) and rain (ITU-R P.1814) at the laser
//! wavelength (`environment::weather`), each switchable here and in `env.*`.

use glam::DVec3;

use crate::environment::sky_distribution::SkyDistribution;
use serde::{Deserialize, Serialize};

use crate::effects::{EffectInfo, Effects};
use crate::environment::weather::{self, Weather};
use crate::error::ModelError;

/// `lidar.overlap_function`: biaxial transmitter/receiver overlap at near range.
pub const OVERLAP_FUNCTION: EffectInfo = EffectInfo {
    name: "lidar.overlap_function",
    default_on: true,
    summary: "near-range overlap O(R) = A_overlap(r_t, r_r, d)/(πr_t²), r_t = r_t0 + Rθ_t/2, r_r = r_r0 + Rθ_r/2, \
              d = |d₀ + Rδ|, circle–circle intersection area; multiplies the received power; off: O = 1",
    source: "Halldórsson & Langerholc, Appl. Opt. 17(2):240, 1978; Stelmaszczyk et al., Appl. Opt. 44(7):1323, 2005",
    requires: None,
};

/// `lidar.incidence_angle`: received power falls with the incidence angle.
pub const INCIDENCE_ANGLE: EffectInfo = EffectInfo {
    name: "lidar.incidence_angle",
    default_on: true,
    summary: "P_i ∝ f_r(wi, wo) cos θ with θ the angle between the beam and the surface normal (Lambertian: \
              ρ cos θ/π); off: cos θ = 1 and the BRDF at normal incidence",
    source: "Kashani et al., Sensors 15(11):28099, 2015 (extended-target LiDAR equation)",
    requires: None,
};

/// `lidar.fog_extinction`: two-way fog extinction at the laser wavelength.
pub const FOG_EXTINCTION: EffectInfo = EffectInfo {
    name: "lidar.fog_extinction",
    default_on: true,
    summary: "T²_fog = exp(−2σ_fog R), σ_fog = (3.912/V)(λ/550 nm)^(−q(V)) (Kim q); off: T_fog = 1 (also off \
              when env.fog_extinction is off)",
    source: "Kim et al., Proc. SPIE 4214:26, 2001; ITU-R P.1814; physics.md §2.4",
    requires: Some("env.fog_extinction"),
};

/// `lidar.rain_extinction`: two-way rain extinction at the laser wavelength.
pub const RAIN_EXTINCTION: EffectInfo = EffectInfo {
    name: "lidar.rain_extinction",
    default_on: true,
    summary: "T²_rain = exp(−2σ_rain R), σ_rain from γ = 1.076 R_rain^0.67 dB/km; off: T_rain = 1 (also off when \
              env.rain_extinction is off)",
    source: "ITU-R P.1814 (coefficient UNVERIFIED, physics.md §2.5)",
    requires: Some("env.rain_extinction"),
};

/// `lidar.solar_background`: sunlight reflected by the target into the receiver.
pub const SOLAR_BACKGROUND: EffectInfo = EffectInfo {
    name: "lidar.solar_background",
    default_on: true,
    summary: "P_bg = ρ (E_dir cos θ_s·[sunlit] + E_diff·V(n))/π · Δλ · A_r · Ω_FOV · η, Ω_FOV = π(θ_FOV/2)², E \
              from SPCTRAL2 at the laser wavelength for the sun of the ground truth, V(n) the sky view \
              factor of the surface; cos θ_s = 0 when the hit point is shadowed (ray towards the sun); a \
              beam that hits nothing sees the sky radiance L = E_diff·k(ω)/π of its direction \
              (env.sky_distribution); off: P_bg = 0",
    source: "physics.md §2.2, §4.3; Bird & Riordan SPCTRAL2 (SERI/TR-215-2436, 1984); ASTM G173-03; \
             CIE S 011/E:2003",
    requires: None,
};

/// Effects declared by this module.
pub const EFFECTS: &[EffectInfo] = &[
    OVERLAP_FUNCTION,
    INCIDENCE_ANGLE,
    FOG_EXTINCTION,
    RAIN_EXTINCTION,
    SOLAR_BACKGROUND,
];

/// Biaxial overlap geometry (defaults: the physics.md §2.3 example).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct OverlapConfig {
    /// Transmitter beam radius at the exit, m.
    pub r_t0_m: f64,
    /// Transmitter full divergence, rad.
    pub theta_t_rad: f64,
    /// Receiver aperture radius, m.
    pub r_r0_m: f64,
    /// Receiver full field of view, rad.
    pub theta_r_rad: f64,
    /// Axis separation at the sensor, m.
    pub d0_m: f64,
    /// Tilt between the axes, rad (the separation grows by Rδ).
    pub delta_rad: f64,
}

impl Default for OverlapConfig {
    fn default() -> Self {
        OverlapConfig {
            r_t0_m: 2.5e-3,
            theta_t_rad: 3e-3,
            r_r0_m: 12.5e-3,
            theta_r_rad: 10e-3,
            d0_m: 25e-3,
            delta_rad: 0.0,
        }
    }
}

/// Receiver and transmitter parameters of the LiDAR equation (`"lidar": {"signal": {...}}`).
/// Defaults are the physics.md §2.1/§2.2 example values (a GUESS for any particular sensor).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SignalConfig {
    /// Peak optical power of a pulse, W.
    pub peak_power_w: f64,
    /// Receiver aperture diameter D_r, m.
    pub aperture_diameter_m: f64,
    /// System optical efficiency η_sys (transmit × receive optics), 0…1.
    pub optics_efficiency: f64,
    /// Optical filter bandwidth Δλ, nm.
    pub filter_bandwidth_nm: f64,
    /// Receiver full field of view θ_FOV, rad (background solid angle).
    pub receiver_fov_rad: f64,
    /// Overlap geometry.
    pub overlap: OverlapConfig,
}

impl Default for SignalConfig {
    fn default() -> Self {
        SignalConfig {
            peak_power_w: 75.0,
            aperture_diameter_m: 25e-3,
            optics_efficiency: 0.5,
            filter_bandwidth_nm: 20.0,
            receiver_fov_rad: 2e-3,
            overlap: OverlapConfig::default(),
        }
    }
}

impl SignalConfig {
    /// Check the values; errors name the key.
    pub fn validate(&self) -> Result<(), ModelError> {
        let o = &self.overlap;
        for (key, v, allow_zero) in [
            ("peak_power_w", self.peak_power_w, false),
            ("aperture_diameter_m", self.aperture_diameter_m, false),
            ("optics_efficiency", self.optics_efficiency, false),
            ("filter_bandwidth_nm", self.filter_bandwidth_nm, false),
            ("receiver_fov_rad", self.receiver_fov_rad, false),
            ("overlap.r_t0_m", o.r_t0_m, false),
            ("overlap.theta_t_rad", o.theta_t_rad, true),
            ("overlap.r_r0_m", o.r_r0_m, false),
            ("overlap.theta_r_rad", o.theta_r_rad, true),
            ("overlap.d0_m", o.d0_m, true),
        ] {
            let ok = v.is_finite() && (v > 0.0 || (allow_zero && v == 0.0));
            if !ok {
                return Err(ModelError::Config(format!(
                    "`lidar.signal.{key}` must be a finite number {} 0, got {v}",
                    if allow_zero { "≥" } else { ">" }
                )));
            }
        }
        if self.optics_efficiency > 1.0 {
            return Err(ModelError::Config(format!(
                "`lidar.signal.optics_efficiency` must be ≤ 1, got {}",
                self.optics_efficiency
            )));
        }
        if !o.delta_rad.is_finite() {
            return Err(ModelError::Config(
                "`lidar.signal.overlap.delta_rad` must be finite".into(),
            ));
        }
        Ok(())
    }

    /// Receiver area A_r = πD_r²/4, m².
    pub fn aperture_area_m2(&self) -> f64 {
        std::f64::consts::PI * self.aperture_diameter_m.powi(2) / 4.0
    }

    /// Receiver solid angle Ω_FOV = π(θ_FOV/2)², sr.
    pub fn fov_solid_angle_sr(&self) -> f64 {
        std::f64::consts::PI * (0.5 * self.receiver_fov_rad).powi(2)
    }
}

/// Area of the intersection of two circles of radii `r1`, `r2` whose centres are `d` apart
/// (physics.md §2.3), m².
pub fn circle_overlap_area(r1: f64, r2: f64, d: f64) -> f64 {
    use std::f64::consts::PI;
    if d >= r1 + r2 {
        return 0.0;
    }
    if d <= (r1 - r2).abs() {
        return PI * r1.min(r2).powi(2);
    }
    let a1 = ((d * d + r1 * r1 - r2 * r2) / (2.0 * d * r1))
        .clamp(-1.0, 1.0)
        .acos();
    let a2 = ((d * d + r2 * r2 - r1 * r1) / (2.0 * d * r2))
        .clamp(-1.0, 1.0)
        .acos();
    let k = ((-d + r1 + r2) * (d + r1 - r2) * (d - r1 + r2) * (d + r1 + r2)).max(0.0);
    r1 * r1 * a1 + r2 * r2 * a2 - 0.5 * k.sqrt()
}

/// Biaxial overlap O(R) ∈ [0, 1] (physics.md §2.3).
pub fn overlap(o: &OverlapConfig, range_m: f64) -> f64 {
    let r_t = o.r_t0_m + 0.5 * range_m * o.theta_t_rad;
    let r_r = o.r_r0_m + 0.5 * range_m * o.theta_r_rad;
    let d = (o.d0_m + range_m * o.delta_rad).abs();
    (circle_overlap_area(r_t, r_r, d) / (std::f64::consts::PI * r_t * r_t)).clamp(0.0, 1.0)
}

/// The signal stage planned for one step: constants of the equation and the effect switches.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SignalPlan {
    /// P_t A_r η_sys, W m².
    pub gain_w_m2: f64,
    pub overlap: Option<OverlapConfig>,
    /// Apply cos θ and the BRDF at the actual incidence.
    pub incidence: bool,
    /// Two-way extinction coefficient 2α, m⁻¹.
    pub two_alpha_per_m: f64,
}

impl SignalPlan {
    /// Plan for `config`, the switches and `weather` at wavelength `wavelength_nm`.
    pub fn new(
        config: &SignalConfig,
        effects: &Effects,
        weather: &Weather,
        wavelength_nm: f64,
    ) -> SignalPlan {
        SignalPlan {
            gain_w_m2: config.peak_power_w * config.aperture_area_m2() * config.optics_efficiency,
            overlap: effects.is_on(&OVERLAP_FUNCTION).then_some(config.overlap),
            incidence: effects.is_on(&INCIDENCE_ANGLE),
            two_alpha_per_m: 2.0 * extinction_per_m(weather, wavelength_nm, effects),
        }
    }

    /// Received power of one sub-ray return, W: `weight · f_r · cos θ · P_t A_r η · T² · O / R²`
    /// (`brdf_sr` in sr⁻¹, `cos_theta` of the incidence, both as the caller evaluated them under
    /// [`SignalPlan::incidence`]).
    #[inline]
    pub fn power_w(&self, weight: f64, brdf_sr: f64, cos_theta: f64, range_m: f64) -> f64 {
        if range_m <= 0.0 {
            return 0.0;
        }
        let o = self.overlap.map_or(1.0, |o| overlap(&o, range_m));
        weight * brdf_sr * cos_theta * self.gain_w_m2 * (-self.two_alpha_per_m * range_m).exp() * o
            / (range_m * range_m)
    }

    /// The clear-air reference power of a 100 % Lambertian target at normal incidence, W (the
    /// intensity calibration curve: overlap included when on, extinction excluded).
    pub fn reference_power_w(&self, range_m: f64) -> f64 {
        let o = self.overlap.map_or(1.0, |o| overlap(&o, range_m));
        self.gain_w_m2 * o / (std::f64::consts::PI * range_m * range_m)
    }
}

/// Power extinction coefficient at `wavelength_nm`, m⁻¹, honouring `lidar.fog_extinction`,
/// `lidar.rain_extinction` and the `env.*` switches.
pub fn extinction_per_m(w: &Weather, wavelength_nm: f64, effects: &Effects) -> f64 {
    let band = if wavelength_nm < 1200.0 {
        weather::Band::Nir905
    } else {
        weather::Band::Nir1550
    };
    let b = weather::extinction_breakdown(w, band);
    let env = weather::extinction_per_m_with(w, band, effects);
    // Start from the env-gated total, remove what the lidar switches turn off.
    let mut a = env;
    if !effects.is_on(&FOG_EXTINCTION) && effects.is_on(&weather::FOG_EXTINCTION) {
        a -= b.fog_per_m;
    }
    if !effects.is_on(&RAIN_EXTINCTION) && effects.is_on(&weather::RAIN_EXTINCTION) {
        a -= b.rain_per_m;
    }
    a.max(0.0)
}

/// Solar background illumination at the laser wavelength (from the ground truth's sun).
#[derive(Debug, Clone)]
pub struct SolarPlan {
    /// Unit vector towards the sun, scene frame.
    pub sun_dir: DVec3,
    /// Direct normal spectral irradiance, W m⁻² nm⁻¹.
    pub dni_w_m2_nm: f64,
    /// Diffuse horizontal spectral irradiance, W m⁻² nm⁻¹.
    pub dhi_w_m2_nm: f64,
    /// Δλ · A_r · Ω_FOV · η / π, m² sr nm.
    pub k: f64,
    /// The sky's radiance distribution relative to the isotropic sky E_diff/π (physics.md §4.3).
    pub sky: SkyDistribution,
}

impl SolarPlan {
    /// The sun at `elevation_rad` (above the horizon) and scene-frame direction `sun_dir`; None when
    /// the sun is down. Irradiance from SPCTRAL2 (default atmosphere) at `wavelength_nm`, averaged
    /// over the filter passband.
    pub fn new(
        config: &SignalConfig,
        sun_dir: DVec3,
        wavelength_nm: f64,
        sky: SkyDistribution,
    ) -> Option<SolarPlan> {
        use crate::environment::sky::{ClearSkyInput, spectrl2};
        let elevation = sun_dir.z.clamp(-1.0, 1.0).asin();
        if elevation <= 0.0 {
            return None;
        }
        let input = ClearSkyInput {
            zenith_deg: 90.0 - elevation.to_degrees(),
            ..ClearSkyInput::default()
        };
        let s = spectrl2(&input);
        let half = 0.5 * config.filter_bandwidth_nm;
        let (a, b) = (wavelength_nm - half, wavelength_nm + half);
        Some(SolarPlan {
            sun_dir: sun_dir.normalize(),
            dni_w_m2_nm: s.band_mean_dni(a, b),
            dhi_w_m2_nm: s.band_mean_dhi(a, b),
            k: background_factor(config),
            sky,
        })
    }

    /// Background power, W, from a surface of diffuse reflectance `rho` with facing normal `n`,
    /// `sunlit` when nothing blocks the sun.
    #[inline]
    pub fn power_w(&self, rho: f64, n: DVec3, sunlit: bool) -> f64 {
        let cos_s = if sunlit {
            n.dot(self.sun_dir).max(0.0)
        } else {
            0.0
        };
        rho * (self.dni_w_m2_nm * cos_s + self.dhi_w_m2_nm * self.sky.view_factor(n)) * self.k
    }

    /// Background power, W, of a beam that hits nothing in direction `dir` (scene frame, unit):
    /// the sky radiance L = E_diff·k(ω)/π over the receiver's field of view,
    /// `P = L · Δλ · A_r · Ω_FOV · η = E_diff · k(ω) · k_bg` (physics.md §2.2). Below the horizon
    /// (nothing hit within range: the road ends) none.
    #[inline]
    pub fn sky_power_w(&self, dir: DVec3) -> f64 {
        if dir.z <= 0.0 {
            return 0.0;
        }
        self.dhi_w_m2_nm * self.sky.factor(dir) * self.k
    }
}

/// Δλ · A_r · Ω_FOV · η / π (physics.md §2.2), m² sr nm.
pub fn background_factor(c: &SignalConfig) -> f64 {
    c.filter_bandwidth_nm * c.aperture_area_m2() * c.fov_solid_angle_sr() * c.optics_efficiency
        / std::f64::consts::PI
}

/// Background power P_bg = ρ E_λ cos θ_s/π · Δλ · A_r · Ω_FOV · η, W (physics.md §2.2), for a given
/// spectral irradiance `e_w_m2_nm` on the surface normal.
pub fn solar_background_w(c: &SignalConfig, rho: f64, e_w_m2_nm: f64, cos_theta_s: f64) -> f64 {
    rho * e_w_m2_nm * cos_theta_s.max(0.0) * background_factor(c)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs()
    }

    #[test]
    fn overlap_matches_the_reference_example() {
        // physics.md §2.3: O = 0 below 1.5 m, 0.20 at 2 m, 0.70 at 3 m, 0.97 at 4 m, 1 beyond 5 m.
        let o = OverlapConfig::default();
        assert_eq!(overlap(&o, 1.0), 0.0);
        assert_eq!(overlap(&o, 1.45), 0.0);
        assert!(
            (overlap(&o, 2.0) - 0.20).abs() < 0.02,
            "{}",
            overlap(&o, 2.0)
        );
        assert!(
            (overlap(&o, 3.0) - 0.70).abs() < 0.02,
            "{}",
            overlap(&o, 3.0)
        );
        assert!(
            (overlap(&o, 4.0) - 0.97).abs() < 0.02,
            "{}",
            overlap(&o, 4.0)
        );
        assert_eq!(overlap(&o, 5.5), 1.0);
        assert_eq!(overlap(&o, 100.0), 1.0);
    }

    #[test]
    fn lidar_equation_matches_the_reference_example() {
        // physics.md §2.1: 75 W, ρ = 0.1, D_r = 25 mm, η = 0.5: 5.9 µW at 10 m, 234 nW at 50 m,
        // 59 nW at 100 m, 15 nW at 200 m.
        let fx = Effects::new(&[crate::world::effects(), crate::lidar::effects()].concat());
        let p = SignalPlan::new(&SignalConfig::default(), &fx, &Weather::CLEAR, 905.0);
        let lam = 0.1 / std::f64::consts::PI;
        for (r, want) in [
            (10.0, 5.9e-6),
            (50.0, 234e-9),
            (100.0, 59e-9),
            (200.0, 15e-9),
        ] {
            let got = p.power_w(1.0, lam, 1.0, r);
            assert!(rel(got, want) < 0.03, "{r} m: {got} vs {want}");
        }
    }

    #[test]
    fn sky_beam_background_equals_a_white_surface_under_the_same_sky() {
        use crate::environment::sky_distribution::{CieSkyType, SkyDistribution};
        let c = SignalConfig::default();
        let sun = DVec3::new(0.5, 0.2, 0.8).normalize();
        // Isotropic sky: L = E_diff/π everywhere, the radiance of a white Lambertian horizontal
        // surface lit by that sky alone (in shadow): the same background.
        let iso = SolarPlan::new(&c, sun, 905.0, SkyDistribution::isotropic()).unwrap();
        let white = iso.power_w(1.0, DVec3::Z, false);
        for dir in [DVec3::Z, DVec3::new(1.0, 0.0, 0.1).normalize()] {
            assert!(rel(iso.sky_power_w(dir), white) < 1e-12);
        }
        // A vertical surface sees half the isotropic sky: (1 + n_z)/2.
        assert!(rel(iso.power_w(1.0, DVec3::X, false), 0.5 * white) < 1e-12);
        // Below the horizon no sky.
        assert_eq!(iso.sky_power_w(DVec3::new(1.0, 0.0, -0.1).normalize()), 0.0);
        // CIE clear sky: the cosine-weighted mean of the sky beams' background over the hemisphere
        // is the white horizontal surface's (the distribution keeps E_diff), within 1 %.
        let ty = CieSkyType::standard(12).unwrap();
        let cie = SolarPlan::new(&c, sun, 905.0, SkyDistribution::cie(ty, sun)).unwrap();
        let (n_mu, n_phi) = (200, 400);
        let mut e = 0.0;
        for i in 0..n_mu {
            let mu = (i as f64 + 0.5) / n_mu as f64;
            for j in 0..n_phi {
                let phi = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / n_phi as f64;
                let st = (1.0 - mu * mu).sqrt();
                let d = DVec3::new(st * phi.cos(), st * phi.sin(), mu);
                e += cie.sky_power_w(d) * mu;
            }
        }
        e *= (1.0 / n_mu as f64) * (2.0 * std::f64::consts::PI / n_phi as f64)
            / std::f64::consts::PI;
        assert!(rel(e, white) < 0.01, "{e} vs {white}");
        // Towards the sun the clear sky is brighter than at the zenith, opposite it darker.
        let anti = DVec3::new(-sun.x, -sun.y, 0.3).normalize();
        assert!(cie.sky_power_w(sun) > 2.0 * cie.sky_power_w(DVec3::Z));
        assert!(cie.sky_power_w(anti) < cie.sky_power_w(DVec3::Z));
    }

    #[test]
    fn solar_background_matches_the_reference_example() {
        // physics.md §2.2: ρ = 0.1, Δλ = 20 nm, 2 mrad FOV, D_r = 25 mm, η = 0.5: 0.40 nW at 905 nm
        // (E = 0.817 W/m²/nm), 0.13 nW at 1550 nm (E = 0.270).
        let c = SignalConfig::default();
        assert!(rel(solar_background_w(&c, 0.1, 0.817, 1.0), 0.40e-9) < 0.02);
        assert!(rel(solar_background_w(&c, 0.1, 0.270, 1.0), 0.13e-9) < 0.03);
    }
}
