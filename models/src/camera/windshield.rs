//! The windshield between the lens and the scene (physics.md §3.5): a flat, tilted slab of
//! laminated glass that attenuates each pixel's scene radiance with its Fresnel transmittance at the
//! pixel ray's incidence angle, shifts the ray sideways (refraction through a slab), and reflects the
//! sunlit dashboard into the image as a veiling luminance.
//!
//! # Geometry (sensor frame: x forward, y left, z up)
//!
//! The glass plane passes through `(distance_m, 0, 0)` on the optical axis with the unit normal
//! `n = (sin α, 0, cos α)` (α = `inclination_deg`, the glass's angle above the horizontal; a raked
//! windshield has α ≈ 25–35°, so the optical axis meets it at θ = 90° − α ≈ 60°). A pixel ray `d`
//! meets it at incidence `cos θ = d·n`.
//!
//! # Effects (each acts only when a `windshield` is configured)
//!
//! * `camera.windshield_transmission`: `L ← T(θ)·L`, `T` the unpolarised transmittance of a slab
//!   of index `refractive_index` and thickness `thickness_mm` with the internal transmittance
//!   `internal_transmittance` at normal incidence (`τ(θ) = τ_n^{1/cos θt}`), incoherent multiple
//!   reflections ([`crate::environment::material::dielectric_slab`]).
//! * `camera.windshield_refraction`: Snell's law at both faces. With parallel faces the ray leaves
//!   the slab parallel to itself, displaced by `Δ = t·sin(θ − θt)/cos θt` (sin θ = n sin θt) in the
//!   plane of incidence, so near objects shift in the image by ≈ Δ/R and far ones not at all. A
//!   wedge (`wedge_mrad`: the outer face turned about the sensor's y axis, the laminate thicker
//!   towards the top of the glass for a positive wedge, as in head-up-display windshields) also
//!   turns the ray, by `δ ≈ w·(√(n² − sin²θ)/cos θ − 1)` in the plane of incidence (a thin prism at
//!   oblique incidence): every object moves by about the same angle, and more where the glass is
//!   seen more obliquely. The renderer traces each pixel from the virtual origin
//!   `o = P₁ − (P₁·d')d'` (P₁ the exit point) along the exit direction `d'`.
//! * `camera.dashboard_reflection`: the inner face reflects the dashboard (a Lambertian plane of
//!   reflectance `dashboard_reflectance` below the glass, normal +z) into every pixel whose mirror
//!   ray `d − 2(d·n)n` points down: `L ← L + R(θ)·L_dash`, `L_dash = ρ_d/π·E_dash`, with the
//!   dashboard's illuminance through the glass `E_dash = T(θ_sun)·E_dni·sin(el_sun)` (sun ahead of
//!   the car, i.e. seen through the windshield) `+ T(θ_0)·E_dhi/2` (the front half of the sky
//!   through the glass at the optical axis' incidence θ_0; the ½ is GUESSED, a horizontal plane
//!   under a raked windshield).

use glam::{DMat3, DQuat, DVec3, Vec3};
use serde::{Deserialize, Serialize};

use crate::effects::EffectInfo;
use crate::environment::material::dielectric_slab;
use crate::error::ModelError;

/// Windshield transmittance.
pub const WINDSHIELD_TRANSMISSION: EffectInfo = EffectInfo {
    name: "camera.windshield_transmission",
    default_on: true,
    summary: "windshield transmittance: L ← T(θ)·L per pixel, T the unpolarised Fresnel transmittance of a tilted laminated-glass slab (index n, internal transmittance τ_n^{1/cos θt}, incoherent multiple reflections) at the pixel ray's incidence θ; acts only with a configured windshield",
    source: "Fresnel equations and incoherent slab sums (Born & Wolf, Principles of Optics, §1.5; physics.md §3.5); windscreen regular transmittance ≥ 70 % (UN ECE R43)",
    requires: None,
};

/// Windshield refraction.
pub const WINDSHIELD_REFRACTION: EffectInfo = EffectInfo {
    name: "camera.windshield_refraction",
    default_on: true,
    summary: "windshield refraction: Snell at both faces of the tilted laminate; parallel faces displace each ray by t·sin(θ − θt)/cos θt (near objects shift by ≈ Δ/R), a wedge w between them turns it by ≈ w·(√(n² − sin²θ)/cos θ − 1); acts only with a configured windshield",
    source: "plane-parallel plate displacement (Hecht, Optics, 5th ed., §5.2) and the thin prism at oblique incidence (§5.5.1); physics.md §3.5",
    requires: None,
};

/// Dashboard reflection in the windshield.
pub const DASHBOARD_REFLECTION: EffectInfo = EffectInfo {
    name: "camera.dashboard_reflection",
    default_on: true,
    summary: "dashboard reflection: the windshield's inner face mirrors the sunlit dashboard into the image as a veiling luminance R(θ)·ρ_d/π·E_dash, E_dash = T(θ_sun)·E_dni·sin el_sun (sun ahead) + T·E_dhi/2; acts only with a configured windshield",
    source: "Lambertian dashboard L = ρE/π and slab reflectance (physics.md §3.5); DIVP camera consistency factors (windshield, dashboard reflection)",
    requires: None,
};

/// The effects declared by this module.
pub const EFFECTS: &[EffectInfo] = &[
    WINDSHIELD_TRANSMISSION,
    WINDSHIELD_REFRACTION,
    DASHBOARD_REFLECTION,
];

/// The windshield in front of the camera (`"windshield"` key of the camera config).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct WindshieldConfig {
    /// Angle of the glass above the horizontal, deg (a raked passenger-car windshield: 25–35°).
    pub inclination_deg: f64,
    /// Distance from the camera's entrance pupil to the glass along the optical axis, m.
    pub distance_m: f64,
    /// Total thickness of the laminate, mm (2.1 mm glass + 0.76 mm PVB + 2.1 mm glass).
    pub thickness_mm: f64,
    /// Refractive index of the laminate (soda-lime glass 1.52, PVB 1.48: one slab of 1.52).
    pub refractive_index: f64,
    /// Internal transmittance at normal incidence (bulk absorption of a green-tinted laminate,
    /// GUESSED: 0.88 gives a regular transmittance of ≈ 0.81 at normal incidence; UN ECE R43
    /// requires ≥ 0.70).
    pub internal_transmittance: f64,
    /// Diffuse reflectance of the dashboard (a dark grey plastic, GUESSED 0.05).
    pub dashboard_reflectance: f64,
    /// Wedge angle between the two faces, mrad (positive: thicker towards the top of the glass).
    /// 0: plane-parallel. Head-up-display windshields carry a wedge of ≈ 0.3–0.7 mrad; thickness
    /// variation and curvature of an ordinary laminate act as a local wedge of the same order.
    pub wedge_mrad: f64,
    /// The camera's extrinsic calibration was done through this windshield (an end-of-line target
    /// calibration in the car): the glass's turn of the optical axis is part of the orientation
    /// the camera believes, so its outputs keep only the glass's variation over the field and the
    /// slab's displacement. `false`: calibrated without the glass (its full deviation shows).
    pub calibrated_through: bool,
}

impl Default for WindshieldConfig {
    fn default() -> Self {
        WindshieldConfig {
            inclination_deg: 28.0,
            distance_m: 0.10,
            thickness_mm: 4.96,
            refractive_index: 1.52,
            internal_transmittance: 0.88,
            dashboard_reflectance: 0.05,
            wedge_mrad: 0.0,
            calibrated_through: false,
        }
    }
}

impl WindshieldConfig {
    pub fn validate(&self) -> Result<(), ModelError> {
        let err = |k: &str, msg: String| {
            Err(ModelError::Config(format!("`camera.windshield.{k}` {msg}")))
        };
        for (k, v, lo, hi) in [
            ("inclination_deg", self.inclination_deg, 5.0, 90.0),
            ("distance_m", self.distance_m, 0.0, 2.0),
            ("thickness_mm", self.thickness_mm, 0.1, 30.0),
            ("refractive_index", self.refractive_index, 1.0, 2.5),
            (
                "internal_transmittance",
                self.internal_transmittance,
                0.01,
                1.0,
            ),
            (
                "dashboard_reflectance",
                self.dashboard_reflectance,
                0.0,
                1.0,
            ),
            ("wedge_mrad", self.wedge_mrad, -20.0, 20.0),
        ] {
            if !(v.is_finite() && (lo..=hi).contains(&v)) {
                return err(k, format!("must be in [{lo}, {hi}], got {v}"));
            }
        }
        Ok(())
    }

    /// Unit normal of the glass (pointing forward and up).
    pub fn normal(&self) -> DVec3 {
        let a = self.inclination_deg.to_radians();
        DVec3::new(a.sin(), 0.0, a.cos())
    }

    fn alpha_per_m(&self) -> f64 {
        -self.internal_transmittance.ln() / (self.thickness_mm * 1e-3)
    }

    /// (transmittance, reflectance) of the slab at incidence `cos θ`.
    pub fn optics(&self, cos_theta: f64) -> (f64, f64) {
        let s = dielectric_slab(
            self.refractive_index,
            self.alpha_per_m(),
            self.thickness_mm * 1e-3,
            cos_theta,
        );
        (s.transmittance, s.reflectance)
    }

    /// Unit normal of the outer face: the inner face's normal turned by the wedge about the
    /// sensor's y axis, `n − w·u` normalised (u = (−cos α, 0, sin α), up the glass).
    pub fn outer_normal(&self) -> DVec3 {
        let a = self.inclination_deg.to_radians();
        let up = DVec3::new(-a.cos(), 0.0, a.sin());
        (self.normal() - self.wedge_mrad * 1e-3 * up).normalize()
    }

    /// A ray from the origin along the unit `d` through the glass: its exit direction d' (unit;
    /// = d for parallel faces) and its virtual origin `P₁ − (P₁·d')d'` (P₁ the exit point; the
    /// displacement, ⟂ d'). `None` when the ray does not meet the glass ahead or is totally
    /// reflected at the outer face.
    pub fn refract(&self, d: DVec3) -> Option<Refracted> {
        let n = self.normal();
        let c = d.dot(n);
        if c <= 1e-9 {
            return None;
        }
        // Entry: the plane n·p = n·(distance, 0, 0).
        let q = DVec3::new(self.distance_m, 0.0, 0.0);
        let p0 = d * (q.dot(n) / c);
        let ng = self.refractive_index;
        let dt = snell(d, n, 1.0 / ng)?;
        // Exit: the outer face through q + t·n (the thickness on the optical axis).
        let n2 = self.outer_normal();
        let q2 = q + n * (self.thickness_mm * 1e-3);
        let c2 = dt.dot(n2);
        if c2 <= 1e-9 {
            return None;
        }
        let p1 = p0 + dt * ((q2 - p0).dot(n2) / c2);
        let out = snell(dt, n2, ng)?;
        Some(Refracted {
            direction: out,
            origin: p1 - out * p1.dot(out),
        })
    }
}

/// A pixel ray after the windshield ([`WindshieldConfig::refract`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Refracted {
    /// The exit direction, unit.
    pub direction: DVec3,
    /// The virtual origin: the exit point less its component along `direction`, sensor frame, m.
    pub origin: DVec3,
}

/// Snell's law in vector form: the unit direction `d` crossing a face of unit normal `n`
/// (`d·n > 0`, n along the propagation) with the index ratio `eta` = n_from / n_to. `None`:
/// total internal reflection.
fn snell(d: DVec3, n: DVec3, eta: f64) -> Option<DVec3> {
    let c = d.dot(n);
    let k = 1.0 - eta * eta * (1.0 - c * c);
    (k >= 0.0).then(|| (eta * (d - c * n) + k.sqrt() * n).normalize())
}

/// What a windshield does to each pixel, planned once for the lens's rays.
#[derive(Debug, Clone, Default)]
pub struct WindshieldPlan {
    /// Per pixel: the factor on the scene radiance (1 without `camera.windshield_transmission`).
    pub transmittance: Vec<f32>,
    /// Per pixel: the glass reflectance towards the dashboard (0 without
    /// `camera.dashboard_reflection` or where the mirror ray points up).
    pub dashboard_reflectance: Vec<f32>,
    /// Per pixel: ray origins in the sensor frame (empty without `camera.windshield_refraction`).
    pub origins: Vec<Vec3>,
    /// Per pixel: ray directions after the glass, unit, sensor frame (empty without
    /// `camera.windshield_refraction`; equal to the lens rays for parallel faces).
    pub directions: Vec<Vec3>,
    /// Where the camera believes a lens ray looks, in its sensor frame: `calibration · ray`. The
    /// rotation taking the optical axis to its direction after the glass when the camera was
    /// calibrated through it (`calibrated_through`, refraction on); otherwise the identity.
    pub calibration: DMat3,
    /// Transmittance of the sunlight and skylight reaching the dashboard.
    config: WindshieldConfig,
}

impl WindshieldPlan {
    /// Plans the windshield for the pixel rays `rays` (sensor frame, unit).
    pub fn new(
        config: &WindshieldConfig,
        rays: &[Vec3],
        transmission: bool,
        refraction: bool,
        dashboard: bool,
    ) -> WindshieldPlan {
        let n = config.normal();
        let calibration = match config.refract(DVec3::X) {
            Some(r) if refraction && config.calibrated_through => {
                DMat3::from_quat(DQuat::from_rotation_arc(DVec3::X, r.direction))
            }
            _ => DMat3::IDENTITY,
        };
        let mut plan = WindshieldPlan {
            config: config.clone(),
            calibration,
            ..WindshieldPlan::default()
        };
        for r in rays {
            let d = r.as_dvec3().normalize_or(DVec3::X);
            let c = d.dot(n);
            let (t, rf) = if c > 0.0 {
                config.optics(c)
            } else {
                (1.0, 0.0)
            };
            plan.transmittance
                .push(if transmission { t as f32 } else { 1.0 });
            let mirror = d - 2.0 * d.dot(n) * n;
            plan.dashboard_reflectance
                .push(if dashboard && c > 0.0 && mirror.z < 0.0 {
                    rf as f32
                } else {
                    0.0
                });
            if refraction {
                let (o, dir) = config
                    .refract(d)
                    .map_or((DVec3::ZERO, d), |r| (r.origin, r.direction));
                plan.origins.push(o.as_vec3());
                plan.directions.push(dir.as_vec3());
            }
        }
        plan
    }

    /// The dashboard's luminance factor ρ_d/π·E_dash per unit of (E_dni, E_dhi): the sunlight
    /// coefficient for a sun in direction `sun_sensor` (sensor frame, unit) and the skylight one.
    pub fn dashboard_coefficients(&self, sun_sensor: DVec3) -> (f64, f64) {
        let c = &self.config;
        let n = c.normal();
        let rho = c.dashboard_reflectance / std::f64::consts::PI;
        // The sun reaches the dashboard through the glass when it is ahead and above.
        let sun = if sun_sensor.z > 0.0 && sun_sensor.x > 0.0 && sun_sensor.dot(n) > 0.0 {
            c.optics(sun_sensor.dot(n)).0 * sun_sensor.z
        } else {
            0.0
        };
        let sky = 0.5 * c.optics(n.x).0;
        (rho * sun, rho * sky)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slab_displacement_matches_the_plate_formula() {
        let c = WindshieldConfig::default();
        let n = c.normal();
        for d in [
            DVec3::X,
            DVec3::new(1.0, 0.3, 0.1).normalize(),
            DVec3::new(1.0, -0.2, -0.2).normalize(),
        ] {
            let r = c.refract(d).unwrap();
            let o = r.origin;
            assert!(
                (r.direction - d).length() < 1e-12,
                "parallel faces keep the direction"
            );
            let cos = d.dot(n);
            let th = cos.acos();
            let tt = (th.sin() / c.refractive_index).asin();
            let want = c.thickness_mm * 1e-3 * (th - tt).sin() / tt.cos();
            assert!(
                (o.length() - want).abs() < 1e-12,
                "{} vs {want}",
                o.length()
            );
            assert!(o.dot(d).abs() < 1e-12);
        }
    }

    /// A wedge turns a ray in the vertical plane by the two-face Snell chain, written here with
    /// angles (elevation ψ above the horizontal; the inner normal at 90° − α, the outer one turned
    /// down by atan w), and by the thin-prism approximation w·(√(n² − sin²θ)/cos θ − 1).
    #[test]
    fn wedge_deviation_matches_snell_at_both_faces() {
        let c = WindshieldConfig {
            wedge_mrad: 1.0,
            ..WindshieldConfig::default()
        };
        let ng = c.refractive_index;
        let w = 1e-3f64;
        let psi_n = (90.0 - c.inclination_deg).to_radians();
        let psi_n2 = psi_n - w.atan();
        for e_deg in [-8.0f64, -3.0, 0.0, 4.0, 9.0] {
            let e = e_deg.to_radians();
            let th1 = psi_n - e;
            let tht = (th1.sin() / ng).asin();
            let psi_t = psi_n - tht;
            let th2 = psi_n2 - psi_t;
            let th3 = (ng * th2.sin()).asin();
            let psi_out = psi_n2 - th3;
            let want = psi_out - e;
            let d = DVec3::new(e.cos(), 0.0, e.sin());
            let r = c.refract(d).unwrap();
            let got = r.direction.z.atan2(r.direction.x) - e;
            assert!(r.direction.y.abs() < 1e-15);
            assert!((got - want).abs() < 1e-12, "e {e_deg}°: {got} vs {want}");
            let thin = w * ((ng * ng - th1.sin().powi(2)).sqrt() / th1.cos() - 1.0);
            assert!(
                (got - thin).abs() < 0.01 * thin,
                "e {e_deg}°: {got} vs thin {thin}"
            );
            // Upwards for a wedge thicker at the top: 1.5–2.5 mrad here.
            assert!(got > 1.0e-3 && got < 3.0e-3, "{got}");
        }
        // Parallel faces turn nothing.
        let flat = WindshieldConfig::default();
        let d = DVec3::new(1.0, 0.2, -0.05).normalize();
        assert!((flat.refract(d).unwrap().direction - d).length() < 1e-12);
    }

    #[test]
    fn dashboard_illuminance_through_the_glass() {
        let c = WindshieldConfig::default();
        let n = c.normal();
        // Fresnel (s and p) at the sun's incidence, written out here.
        let t_at = |cos_i: f64| {
            let sin_t = (1.0 - cos_i * cos_i).sqrt() / c.refractive_index;
            let cos_t = (1.0 - sin_t * sin_t).sqrt();
            let m = c.refractive_index;
            let rs = ((cos_i - m * cos_t) / (cos_i + m * cos_t)).powi(2);
            let rp = ((m * cos_i - cos_t) / (m * cos_i + cos_t)).powi(2);
            let tau = c.internal_transmittance.powf(1.0 / cos_t);
            [rs, rp]
                .iter()
                .map(|r| 0.5 * (1.0 - r).powi(2) * tau / (1.0 - r * r * tau * tau))
                .sum::<f64>()
        };
        let plan = WindshieldPlan::new(&c, &[Vec3::X], true, true, true);
        let el = 30f64.to_radians();
        let sun = DVec3::new(el.cos(), 0.0, el.sin());
        let (k_sun, k_sky) = plan.dashboard_coefficients(sun);
        let rho = c.dashboard_reflectance / std::f64::consts::PI;
        let want_sun = rho * t_at(sun.dot(n)) * el.sin();
        let want_sky = rho * 0.5 * t_at(n.x);
        assert!(
            (k_sun - want_sun).abs() < 1e-9 * want_sun,
            "{k_sun} vs {want_sun}"
        );
        assert!(
            (k_sky - want_sky).abs() < 1e-9 * want_sky,
            "{k_sky} vs {want_sky}"
        );
        // The sun behind the car does not reach the dashboard through the windshield.
        let (k_behind, _) = plan.dashboard_coefficients(DVec3::new(-el.cos(), 0.0, el.sin()));
        assert_eq!(k_behind, 0.0);
    }

    #[test]
    fn normal_incidence_transmittance_is_the_slab_closed_form() {
        let c = WindshieldConfig::default();
        // r = ((n−1)/(n+1))², T = (1−r)²τ/(1−r²τ²).
        let r = ((c.refractive_index - 1.0) / (c.refractive_index + 1.0)).powi(2);
        let tau = c.internal_transmittance;
        let want = (1.0 - r).powi(2) * tau / (1.0 - r * r * tau * tau);
        let (t, _) = c.optics(1.0);
        assert!((t - want).abs() < 1e-9, "{t} vs {want}");
        assert!((0.7..0.9).contains(&t), "{t}");
    }
}
