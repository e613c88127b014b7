//! Special functions shared by the models and the consistency workflow.

/// Complementary error function, fractional error < 1.2·10⁻⁷ everywhere (Chebyshev fit `erfcc`,
/// Press et al., *Numerical Recipes*, 2nd ed., §6.2).
pub fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let ans = t
        * (-z * z - 1.265_512_23
            + t * (1.000_023_68
                + t * (0.374_091_96
                    + t * (0.096_784_18
                        + t * (-0.186_288_06
                            + t * (0.278_868_07
                                + t * (-1.135_203_98
                                    + t * (1.488_515_87
                                        + t * (-0.822_152_23 + t * 0.170_872_77)))))))))
            .exp();
    if x >= 0.0 { ans } else { 2.0 - ans }
}

/// Exponential integral E₁(x) = ∫ₓ^∞ e^{−t}/t dt: the power series
/// −γ − ln x − Σ_{k≥1} (−x)^k/(k·k!) for x ≤ 1, the continued fraction
/// e^{−x}/(x + 1 − 1/(x + 3 − 4/(x + 5 − …))) (modified Lentz) beyond (Abramowitz & Stegun
/// 5.1.11 and 5.1.22; Press et al., *Numerical Recipes*, 3rd ed., §6.3). Relative error < 1e-14;
/// +∞ at 0, NaN below.
pub fn exp_integral_e1(x: f64) -> f64 {
    const EULER_GAMMA: f64 = 0.577_215_664_901_532_9;
    if x.is_nan() || x < 0.0 {
        return f64::NAN;
    }
    if x == 0.0 {
        return f64::INFINITY;
    }
    if x <= 1.0 {
        let (mut sum, mut term) = (0.0, 1.0);
        for k in 1..60 {
            term *= -x / k as f64;
            let add = term / k as f64;
            sum += add;
            if add.abs() < 1e-17 * sum.abs() {
                break;
            }
        }
        return -EULER_GAMMA - x.ln() - sum;
    }
    if x > 745.0 {
        return 0.0;
    }
    let tiny = 1e-300;
    let mut b = x + 1.0;
    let mut c = 1.0 / tiny;
    let mut d = 1.0 / b;
    let mut h = d;
    for i in 1..200 {
        let a = -((i * i) as f64);
        b += 2.0;
        d = 1.0 / (a * d + b);
        c = b + a / c;
        let del = c * d;
        h *= del;
        if (del - 1.0).abs() < 1e-16 {
            break;
        }
    }
    h * (-x).exp()
}

#[cfg(test)]
mod tests {
    use super::{erfc, exp_integral_e1 as e1};

    /// Tabulated values (Abramowitz & Stegun, Table 7.1: erf 0.5 = 0.520 499 877 8,
    /// erf 1 = 0.842 700 792 9, erf 2 = 0.995 322 265 0).
    #[test]
    fn erfc_matches_tables() {
        for (x, erf) in [
            (0.5, 0.520_499_877_8),
            (1.0, 0.842_700_792_9),
            (2.0, 0.995_322_265_0),
        ] {
            assert!(
                (erfc(x) - (1.0 - erf)).abs() < 1.2e-7 * (1.0 - erf),
                "erfc({x})"
            );
            assert!((erfc(-x) - (1.0 + erf)).abs() < 1e-7, "erfc(−{x})");
        }
        assert!((erfc(0.0) - 1.0).abs() < 1.2e-7);
    }

    #[test]
    fn exponential_integral_against_tabulated_values() {
        // Abramowitz & Stegun, Table 5.1 (E₁(x) and x·e^x·E₁(x)), both branches and their seam.
        for (x, want) in [
            (0.01, 4.037_929_576_538),
            (0.1, 1.822_923_958_419),
            (0.5, 0.559_773_594_776),
            (1.0, 0.219_383_934_395),
            (2.0, 0.048_900_510_708),
            (5.0, 0.001_148_295_591),
            (10.0, 4.156_968_929e-6),
        ] {
            let got = e1(x);
            assert!(
                (got / want - 1.0).abs() < 1e-9,
                "E1({x}) = {got}, want {want}"
            );
        }
        assert_eq!(e1(0.0), f64::INFINITY);
        assert!(e1(-1.0).is_nan());
        assert_eq!(e1(1e6), 0.0);
    }
}
