//! Sky radiance distribution over the hemisphere: the CIE standard general sky (physics.md §4.3).
//!
//! Source: CIE S 011/E:2003 = ISO 15469:2004, "Spatial distribution of daylight — CIE standard
//! general sky". The luminance of a sky element at zenith angle Z and angular distance χ from the
//! sun, relative to the zenith luminance, is
//!
//! ```text
//! L(Z, χ)/L_z = f(χ)·φ(Z) / (f(Z_s)·φ(0))
//! φ(Z) = 1 + a·exp(b / cos Z)            (gradation; φ(90°) = 1 for b < 0)
//! f(χ) = 1 + c·(exp(d·χ) − exp(d·π/2)) + e·cos²χ   (indicatrix)
//! ```
//!
//! with (a, b, c, d, e) one of the standard's 15 sky types ([`CIE_SKY_TYPES`]; type 12 is the CIE
//! standard clear sky, low atmospheric turbidity, the default; type 1 the overcast sky with steep
//! gradation). The distribution is scaled so that its integral over the hemisphere gives the diffuse
//! horizontal irradiance of SPCTRAL2 (physics.md §4.2):
//! `L(ω) = (E_dhi/π)·k(ω)`, `k(ω) = π·ℓ(ω) / ∫ ℓ cos Z dΩ` with ℓ = L/L_z, so that an isotropic sky
//! has k ≡ 1. The spectral shape is the DHI's in every direction (the real clear sky is bluer at the
//! zenith and whiter near the horizon and the sun; that colour gradient is not modelled).
//!
//! Below the horizon (directions with z ≤ 0, which see the ground or the fog's air light) the
//! factor is the horizon's in the same azimuth. The irradiance on a tilted surface of normal n is
//! `E(n) = (E_dhi/π)·∫_{z>0, n·ω>0} k(ω)(n·ω) dΩ` = E_dhi·V(n) with the view factor V tabulated over
//! the normal's elevation and its azimuth from the sun ([`SkyDistribution::view_factor`]); an
//! isotropic sky gives V = (1 + n_z)/2.
//!
//! Effect `env.sky_distribution`: on, the camera's sky, its sky-lit surfaces, glass and specular
//! reflections of the sky and the fog's air light follow the CIE distribution; off, the isotropic
//! sky E_dhi/π of Liu & Jordan (Solar Energy 4(3):1, 1960).

use std::f64::consts::{FRAC_PI_2, PI};

use glam::DVec3;

use crate::effects::EffectInfo;

/// The sky radiance distribution of the environment.
pub const SKY_DISTRIBUTION: EffectInfo = EffectInfo {
    name: "env.sky_distribution",
    default_on: true,
    summary: "sky radiance distribution: L(Z, χ) = (E_dhi/π)·π·ℓ/∫ℓ cos Z dΩ with the CIE general sky ℓ = f(χ)φ(Z)/(f(Z_s)φ(0)), φ = 1 + a·e^{b/cos Z}, f = 1 + c(e^{dχ} − e^{dπ/2}) + e·cos²χ (type 12 clear sky by default): horizon brightening and circumsolar region, integral = SPCTRAL2 DHI; off: isotropic E_dhi/π",
    source: "CIE S 011/E:2003 = ISO 15469:2004 (CIE standard general sky); physics.md §4.3",
    requires: None,
};

/// The five parameters of a CIE general sky type: gradation (a, b), indicatrix (c, d, e).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CieSkyType {
    pub a: f64,
    pub b: f64,
    pub c: f64,
    pub d: f64,
    pub e: f64,
}

/// The 15 standard sky types of CIE S 011/E:2003 (Table 1), type 1 at index 0: 1–6 overcast to
/// partly cloudy without or with a weak sun, 7–10 partly cloudy, 11–15 clear (12: the CIE
/// standard clear sky, 13: clear, polluted, 14–15: cloudless turbid with a broad solar corona).
pub const CIE_SKY_TYPES: [CieSkyType; 15] = [
    CieSkyType {
        a: 4.0,
        b: -0.70,
        c: 0.0,
        d: -1.0,
        e: 0.00,
    },
    CieSkyType {
        a: 4.0,
        b: -0.70,
        c: 2.0,
        d: -1.5,
        e: 0.15,
    },
    CieSkyType {
        a: 1.1,
        b: -0.80,
        c: 0.0,
        d: -1.0,
        e: 0.00,
    },
    CieSkyType {
        a: 1.1,
        b: -0.80,
        c: 2.0,
        d: -1.5,
        e: 0.15,
    },
    CieSkyType {
        a: 0.0,
        b: -1.00,
        c: 0.0,
        d: -1.0,
        e: 0.00,
    },
    CieSkyType {
        a: 0.0,
        b: -1.00,
        c: 2.0,
        d: -1.5,
        e: 0.15,
    },
    CieSkyType {
        a: 0.0,
        b: -1.00,
        c: 5.0,
        d: -2.5,
        e: 0.30,
    },
    CieSkyType {
        a: 0.0,
        b: -1.00,
        c: 10.0,
        d: -3.0,
        e: 0.45,
    },
    CieSkyType {
        a: -1.0,
        b: -0.55,
        c: 2.0,
        d: -1.5,
        e: 0.15,
    },
    CieSkyType {
        a: -1.0,
        b: -0.55,
        c: 5.0,
        d: -2.5,
        e: 0.30,
    },
    CieSkyType {
        a: -1.0,
        b: -0.55,
        c: 10.0,
        d: -3.0,
        e: 0.45,
    },
    CieSkyType {
        a: -1.0,
        b: -0.32,
        c: 10.0,
        d: -3.0,
        e: 0.45,
    },
    CieSkyType {
        a: -1.0,
        b: -0.32,
        c: 16.0,
        d: -3.0,
        e: 0.30,
    },
    CieSkyType {
        a: -1.0,
        b: -0.15,
        c: 16.0,
        d: -3.0,
        e: 0.30,
    },
    CieSkyType {
        a: -1.0,
        b: -0.15,
        c: 24.0,
        d: -2.8,
        e: 0.15,
    },
];

/// Default sky type: 12, the CIE standard clear sky.
pub const DEFAULT_CIE_SKY_TYPE: u8 = 12;

impl CieSkyType {
    /// The standard type `n` (1…15).
    pub fn standard(n: u8) -> Option<CieSkyType> {
        CIE_SKY_TYPES.get(usize::from(n).checked_sub(1)?).copied()
    }

    /// Gradation φ(Z) at zenith angle `z` (rad); the horizon and below: φ(90°) = 1 + a·[b ≥ 0].
    pub fn gradation(&self, z: f64) -> f64 {
        let c = z.cos();
        if c <= 1e-9 {
            return if self.b < 0.0 { 1.0 } else { 1.0 + self.a };
        }
        1.0 + self.a * (self.b / c).exp()
    }

    /// Indicatrix f(χ) at the angular distance `chi` (rad) from the sun.
    pub fn indicatrix(&self, chi: f64) -> f64 {
        1.0 + self.c * ((self.d * chi).exp() - (self.d * FRAC_PI_2).exp())
            + self.e * chi.cos().powi(2)
    }
}

/// Grid of the view-factor table: the normal's z (= sin of its elevation) −1…1 and the cosine of
/// its azimuth from the sun 1…−1, both uniform (a lookup needs no trigonometric function).
const VF_EL: usize = 37;
const VF_AZ: usize = 19;
/// Quadrature of the hemisphere (midpoint rule in cos Z and azimuth).
const Q_MU: usize = 64;
const Q_PHI: usize = 128;

/// A sky radiance distribution for one sun position: the factor k(ω) relative to the isotropic sky
/// and the view factors of tilted surfaces (plan once per sun position, look up per ray).
#[derive(Debug, Clone)]
pub struct SkyDistribution {
    /// `None`: isotropic.
    cie: Option<CieSkyType>,
    /// Unit vector to the sun (z up).
    sun: DVec3,
    /// 1/(f(Z_s)·φ(0)).
    inv_zenith: f64,
    /// π / ∫ ℓ cos Z dΩ.
    scale: f64,
    /// V(n) per (normal elevation, azimuth from the sun).
    view: Vec<f64>,
}

impl SkyDistribution {
    /// The isotropic sky (k ≡ 1, V = (1 + n_z)/2).
    pub fn isotropic() -> SkyDistribution {
        SkyDistribution {
            cie: None,
            sun: DVec3::Z,
            inv_zenith: 1.0,
            scale: 1.0,
            view: Vec::new(),
        }
    }

    /// The CIE general sky `ty` with the sun in direction `sun` (z up; a sun below the horizon is
    /// placed on it: the twilight sky keeps the shape of a low sun).
    pub fn cie(ty: CieSkyType, sun: DVec3) -> SkyDistribution {
        let mut sun = sun.normalize_or(DVec3::Z);
        if sun.z < 0.0 {
            sun = DVec3::new(sun.x, sun.y, 0.0).normalize_or(DVec3::X);
        }
        let zs = sun.z.clamp(-1.0, 1.0).acos();
        let inv_zenith = 1.0 / (ty.indicatrix(zs) * ty.gradation(0.0));
        let mut s = SkyDistribution {
            cie: Some(ty),
            sun,
            inv_zenith,
            scale: 1.0,
            view: Vec::new(),
        };
        // ∫ ℓ cos Z dΩ = ∫∫ ℓ μ dμ dφ (midpoint rule; ℓ is smooth on this grid: the circumsolar
        // peak e^{dχ} has a width of 1/|d| ≥ 0.33 rad).
        let dirs = quadrature();
        let integral: f64 = dirs.iter().map(|(w, d)| w * d.z * s.relative(*d)).sum();
        s.scale = PI / integral;
        // View factors: V(n) = (1/π)·∫ k(ω) max(0, n·ω) dΩ.
        let k: Vec<(f64, DVec3)> = dirs.iter().map(|(w, d)| (w * s.factor(*d), *d)).collect();
        let (ux, uy) = s.sun_axes();
        s.view = (0..VF_EL * VF_AZ)
            .map(|i| {
                let z = -1.0 + 2.0 * (i / VF_AZ) as f64 / (VF_EL - 1) as f64;
                let ca = 1.0 - 2.0 * (i % VF_AZ) as f64 / (VF_AZ - 1) as f64;
                let (h, sa) = (
                    (1.0 - z * z).max(0.0).sqrt(),
                    (1.0 - ca * ca).max(0.0).sqrt(),
                );
                let n = (ux * ca + uy * sa) * h + DVec3::Z * z;
                k.iter().map(|(wk, d)| wk * n.dot(*d).max(0.0)).sum::<f64>() / PI
            })
            .collect();
        s
    }

    /// Whether this is the isotropic sky.
    pub fn is_isotropic(&self) -> bool {
        self.cie.is_none()
    }

    /// Horizontal unit vectors: towards the sun's azimuth and 90° to its left.
    fn sun_axes(&self) -> (DVec3, DVec3) {
        let ux = DVec3::new(self.sun.x, self.sun.y, 0.0).normalize_or(DVec3::X);
        (ux, DVec3::Z.cross(ux))
    }

    /// ℓ = L/L_z in direction `dir` (unit, z up; clamped to the horizon below it).
    fn relative(&self, dir: DVec3) -> f64 {
        let Some(ty) = self.cie else { return 1.0 };
        let z = dir.z.clamp(0.0, 1.0).acos();
        let chi = dir.dot(self.sun).clamp(-1.0, 1.0).acos();
        ty.indicatrix(chi) * ty.gradation(z) * self.inv_zenith
    }

    /// The sky radiance in direction `dir` relative to the isotropic sky E_dhi/π: k(ω) (1 for the
    /// isotropic sky). Directions below the horizon get the horizon's value in their azimuth.
    pub fn factor(&self, dir: DVec3) -> f64 {
        if self.cie.is_none() {
            return 1.0;
        }
        let d = if dir.z < 0.0 {
            DVec3::new(dir.x, dir.y, 0.0).normalize_or(DVec3::X)
        } else {
            dir.normalize_or(DVec3::Z)
        };
        self.scale * self.relative(d)
    }

    /// Sky irradiance on a surface of unit normal `n` relative to the DHI: V(n) (bilinear in the
    /// tabulated n_z and cosine of the normal's azimuth from the sun; the isotropic sky:
    /// (1 + n_z)/2).
    pub fn view_factor(&self, n: DVec3) -> f64 {
        if self.cie.is_none() {
            return 0.5 * (1.0 + n.z.clamp(-1.0, 1.0));
        }
        let (ux, uy) = self.sun_axes();
        let (a, b) = (n.dot(ux), n.dot(uy));
        let h = (a * a + b * b).sqrt();
        let ca = if h > 1e-12 { a / h } else { 1.0 };
        let fe = ((n.z.clamp(-1.0, 1.0) + 1.0) / 2.0 * (VF_EL - 1) as f64)
            .clamp(0.0, (VF_EL - 1) as f64);
        let fa = ((1.0 - ca) / 2.0 * (VF_AZ - 1) as f64).clamp(0.0, (VF_AZ - 1) as f64);
        let (ie, ia) = ((fe as usize).min(VF_EL - 2), (fa as usize).min(VF_AZ - 2));
        let (te, ta) = (fe - ie as f64, fa - ia as f64);
        let v = |e: usize, a: usize| self.view[e * VF_AZ + a];
        (1.0 - te) * ((1.0 - ta) * v(ie, ia) + ta * v(ie, ia + 1))
            + te * ((1.0 - ta) * v(ie + 1, ia) + ta * v(ie + 1, ia + 1))
    }
}

/// The sky distribution of the last sun direction, for a sensor that plans it per frame: planned
/// once per sun position and reused while the sun direction is unchanged (the cosine between the
/// two above 1 − 1e-12). The camera's renderer and the LiDAR's solar background keep one each.
#[derive(Debug, Clone, Default)]
pub struct SkyDistributionCache {
    /// The sun direction the distribution was planned for, and the distribution.
    planned: Option<(DVec3, SkyDistribution)>,
}

impl SkyDistributionCache {
    /// An empty cache (the first [`Self::plan`] plans).
    pub fn new() -> SkyDistributionCache {
        SkyDistributionCache::default()
    }

    /// The distribution for the sun in direction `sun_dir`: the CIE general sky `ty` for it
    /// ([`SkyDistribution::cie`]; `None`: [`SkyDistribution::isotropic`]), planned anew where the
    /// sun has moved since the last plan, else the cached one. `ty` is taken to be the same on
    /// every call.
    pub fn plan(&mut self, sun_dir: DVec3, ty: Option<CieSkyType>) -> &SkyDistribution {
        if !self
            .planned
            .as_ref()
            .is_some_and(|(d, _)| d.dot(sun_dir) > 1.0 - 1e-12)
        {
            let dist = match ty {
                Some(ty) => SkyDistribution::cie(ty, sun_dir),
                None => SkyDistribution::isotropic(),
            };
            self.planned = Some((sun_dir, dist));
        }
        &self.planned.as_ref().expect("planned above").1
    }

    /// The distribution of the last [`Self::plan`] (`None` before the first).
    pub fn planned(&self) -> Option<&SkyDistribution> {
        self.planned.as_ref().map(|(_, d)| d)
    }
}

/// Midpoint quadrature of the upper hemisphere: (solid angle, direction) per cell, uniform in
/// μ = cos Z and azimuth (equal-area cells).
fn quadrature() -> Vec<(f64, DVec3)> {
    let w = (1.0 / Q_MU as f64) * (2.0 * PI / Q_PHI as f64);
    (0..Q_MU * Q_PHI)
        .map(|i| {
            let mu = (i / Q_PHI) as f64 / Q_MU as f64 + 0.5 / Q_MU as f64;
            let phi = 2.0 * PI * ((i % Q_PHI) as f64 + 0.5) / Q_PHI as f64;
            let s = (1.0 - mu * mu).sqrt();
            (w, DVec3::new(s * phi.cos(), s * phi.sin(), mu))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sun_at(elevation_deg: f64, azimuth_deg: f64) -> DVec3 {
        let (e, a) = (elevation_deg.to_radians(), azimuth_deg.to_radians());
        DVec3::new(e.cos() * a.cos(), e.cos() * a.sin(), e.sin())
    }

    fn dir(zenith_deg: f64, azimuth_deg: f64) -> DVec3 {
        sun_at(90.0 - zenith_deg, azimuth_deg)
    }

    /// ∫ f(ω) dΩ over the upper hemisphere: midpoint rule in Z and azimuth (nz × na cells, weights
    /// sin Z dZ dφ), independent of the module's equal-area quadrature.
    fn hemisphere_integral(nz: usize, na: usize, f: impl Fn(DVec3) -> f64) -> f64 {
        let (dz, da) = (FRAC_PI_2 / nz as f64, 2.0 * PI / na as f64);
        let mut sum = 0.0;
        for i in 0..nz {
            let z = (i as f64 + 0.5) * dz;
            for j in 0..na {
                let a = (j as f64 + 0.5) * da;
                let d = DVec3::new(z.sin() * a.cos(), z.sin() * a.sin(), z.cos());
                sum += f(d) * z.sin() * dz * da;
            }
        }
        sum
    }

    /// The CIE clear sky (type 12) written out from CIE S 011 for this test:
    /// ℓ = (1 + 10(e^{−3χ} − e^{−3π/2}) + 0.45cos²χ)(1 − e^{−0.32/cos Z}) / ((…)(Z_s)·(1 − e^{−0.32})).
    fn clear_sky_closed_form(z: f64, chi: f64, zs: f64) -> f64 {
        let f = |x: f64| {
            1.0 + 10.0 * ((-3.0 * x).exp() - (-3.0 * FRAC_PI_2).exp()) + 0.45 * x.cos().powi(2)
        };
        let phi = |z: f64| {
            if z.cos() <= 1e-12 {
                1.0
            } else {
                1.0 - (-0.32 / z.cos()).exp()
            }
        };
        f(chi) * phi(z) / (f(zs) * phi(0.0))
    }

    #[test]
    fn zenith_horizon_and_circumsolar_ratios_follow_the_closed_form() {
        let sun = sun_at(40.0, 30.0);
        let s = SkyDistribution::cie(CieSkyType::standard(12).unwrap(), sun);
        let zs = 50f64.to_radians();
        let zenith = s.factor(DVec3::Z);
        // Horizon 90° in azimuth from the sun: χ = acos(cos 50°·0 + …) from the dot product.
        for (zd, ad) in [
            (90.0, 120.0),
            (90.0, 210.0),
            (60.0, 300.0),
            (45.0, 30.0),
            (50.0, 35.0),
        ] {
            let d = dir(zd, ad);
            let chi = d.dot(sun).clamp(-1.0, 1.0).acos();
            let want = clear_sky_closed_form(zd.to_radians(), chi, zs);
            let got = s.factor(d) / zenith;
            assert!(
                (got - want).abs() <= 1e-9 * want.max(1.0),
                "Z {zd} az {ad}: {got} vs {want}"
            );
        }
        // A clear sky's horizon away from the sun is brighter than its zenith (≈ 2–4×), the region
        // around the sun far brighter still.
        let horizon = s.factor(dir(90.0, 210.0)) / zenith;
        assert!((1.5..5.0).contains(&horizon), "horizon/zenith {horizon}");
        let circumsolar = s.factor(dir(52.0, 32.0)) / zenith;
        assert!(circumsolar > 5.0, "circumsolar/zenith {circumsolar}");
    }

    #[test]
    fn hemispherical_integral_gives_the_dhi_within_one_percent() {
        // An independent quadrature (Gauss-free: midpoint in Z and azimuth, 1/4° cells, weights
        // sin Z dZ dφ) of k(ω)·cos Z over the hemisphere must give π (so that ∫ L cos dΩ = E_dhi).
        for (ty, el) in [
            (12u8, 40.0),
            (12, 10.0),
            (1, 30.0),
            (13, 65.0),
            (15, 5.0),
            (7, 20.0),
        ] {
            let s = SkyDistribution::cie(CieSkyType::standard(ty).unwrap(), sun_at(el, -70.0));
            let sum = hemisphere_integral(360, 720, |d| s.factor(d) * d.z);
            assert!(
                (sum / PI - 1.0).abs() < 0.01,
                "type {ty}, sun {el}°: {}",
                sum / PI
            );
        }
    }

    #[test]
    fn view_factors_are_the_irradiance_of_tilted_planes() {
        // Isotropic: (1 + n_z)/2.
        let iso = SkyDistribution::isotropic();
        for n in [DVec3::Z, DVec3::X, -DVec3::Z, DVec3::new(0.6, 0.0, 0.8)] {
            assert!((iso.view_factor(n) - 0.5 * (1.0 + n.z)).abs() < 1e-12);
            assert_eq!(iso.factor(n), 1.0);
        }
        let sun = sun_at(30.0, 0.0);
        let s = SkyDistribution::cie(CieSkyType::standard(12).unwrap(), sun);
        // A horizontal plane receives the DHI; a downward one nothing.
        assert!(
            (s.view_factor(DVec3::Z) - 1.0).abs() < 0.01,
            "{}",
            s.view_factor(DVec3::Z)
        );
        assert!(s.view_factor(-DVec3::Z) < 1e-9);
        // A wall facing the sun gets more sky light than one facing away (circumsolar region);
        // on average walls get more than the isotropic half of the DHI: the sky is brightest near
        // the horizon, which a vertical plane faces and the horizontal DHI weights by cos Z.
        let towards = s.view_factor(DVec3::X);
        let away = s.view_factor(-DVec3::X);
        assert!(towards > 1.5 * away, "{towards} vs {away}");
        assert!((towards + away) / 2.0 > 0.5, "{towards} {away}");
        // Against a direct integration of the same factor for a tilted normal.
        let n = DVec3::new(0.3, 0.5, 0.6).normalize();
        let e = hemisphere_integral(180, 360, |d| s.factor(d) * n.dot(d).max(0.0));
        let want = e / PI;
        assert!(
            (s.view_factor(n) - want).abs() < 0.02 * want,
            "{} vs {want}",
            s.view_factor(n)
        );
    }

    #[test]
    fn below_the_horizon_the_horizon_value_holds() {
        let s = SkyDistribution::cie(CieSkyType::standard(12).unwrap(), sun_at(40.0, 0.0));
        let h = s.factor(DVec3::new(0.0, 1.0, 0.0));
        assert_eq!(s.factor(DVec3::new(0.0, 1.0, -0.3)), h);
    }
}
