//! Unit tests of the materials: Fresnel and stack closed forms, BRDF reciprocity and energy, the
//! retro lobe, wet variants, slab optics, the starter set and JSON errors. Most go through
//! [`Material`](super::Material) and the JSON loader, so they stay together here.

use super::*;
use crate::constants::SPEED_OF_LIGHT_M_S;

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
            assert!((m.eval_brdf(band, wi, dir(20.0, 200.0), DVec3::Z) - 0.37 / PI).abs() < 1e-15);
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
        (paint_wet.nir905.retro.unwrap().peak_sr - f * paint.nir905.retro.unwrap().peak_sr).abs()
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
    let (msg, e) = parse_err("{\n  \"schema\": \"osiris-materials/1\",\n  \"materials\": {,}\n}");
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
    let dup =
        format!(r#"{{"schema": "osiris-materials/1", "materials": {{"a": {body}, "a": {body}}}}}"#);
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
