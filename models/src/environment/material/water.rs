//! Water optics for the wet derivation: the refractive index of liquid water (Segelstein 1981), the
//! diffuse albedo of a Lambertian surface under a water film (Lekner & Dorf 1988) and the
//! exponential integral `E₃` its diffuse film transmittance needs.

use std::f64::consts::PI;

use super::optical::SpecularLobe;

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
/// a slab of optical depth `x` for Lambertian light). Via `E₁` ([`crate::special::exp_integral_e1`])
/// and `E_{n+1} = (e^{−x} − x Eₙ)/n` (Abramowitz & Stegun 5.1.14).
pub fn exp_integral_e3(x: f64) -> f64 {
    if x <= 0.0 {
        return 0.5;
    }
    let e1 = crate::special::exp_integral_e1(x);
    let e2 = (-x).exp() - x * e1;
    0.5 * ((-x).exp() - x * e2)
}
