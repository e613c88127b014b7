//! Beam footprint: the divergent Gaussian beam of one pulse sampled by weighted sub-rays.
//!
//! The beam has a 1/e² full-angle divergence β_H × β_V and exit diameter D₀, so its footprint at
//! range R is D(R) = D₀ + Rβ (physics.md §2.6; Hebert & Krotkov 1992). It is sampled by
//! `1 + Σ_{r=1}^{Q−1} 6r` sub-rays on Q concentric hexagonal rings (HELIOS++, Winiwarter et al.,
//! RSE 269:112772, 2022: 1, 7, 19, 37, 61 …). Ring r sits at normalised radius r/(Q − ½) of the 1/e²
//! radius and carries the Gaussian energy of the annulus [(r − ½), (r + ½)]/(Q − ½) (the centre ray
//! the disc of radius ½/(Q − ½)), shared equally by its 6r rays; the weights are renormalised to sum
//! to 1 (energy outside the 1/e² radius, 13.5 %, is dropped). Elliptical beams scale the horizontal
//! and vertical offsets by β_H/2 and β_V/2.
//!
//! With one sub-ray the beam is a pencil (weight 1): every pulse sees an extended target.

use serde::{Deserialize, Serialize};

use crate::effects::EffectInfo;
use crate::error::ModelError;

/// `lidar.vertical_divergence`: the beam also diverges vertically.
pub const VERTICAL_DIVERGENCE: EffectInfo = EffectInfo {
    name: "lidar.vertical_divergence",
    default_on: true,
    summary: "elliptical Gaussian footprint D_V(R) = D₀ + Rβ_V in addition to D_H(R) = D₀ + Rβ_H; sub-rays are \
              offset vertically by up to β_V/2; off: β_V = 0 (sub-rays spread horizontally only)",
    source: "physics.md §2.6; Velodyne VLS-128 manual 63-9483 Rev A (3.0 × 1.5 mrad)",
    requires: None,
};

/// `lidar.mixed_pixels`: the returns of all sub-rays of a pulse superpose in one waveform.
pub const MIXED_PIXELS: EffectInfo = EffectInfo {
    name: "lidar.mixed_pixels",
    default_on: true,
    summary: "mixed pixels: the detector sees one waveform Σ_i w_i P_i p(t − 2R_i/c) of all sub-ray returns \
              of a pulse, so surfaces closer than cτ_p/2 blend into one range between them (false points \
              in depth gaps, partial hits at edges); off: the sub-ray returns are grouped per surface \
              (object and part / static element) and each group is detected alone (no blending)",
    source: "Hebert & Krotkov, Image Vis. Comput. 10(3):170, 1992; Tuley et al., ICRA 2005; \
             Winiwarter et al., RSE 269:112772, 2022",
    requires: None,
};

/// Effects declared by this module.
pub const EFFECTS: &[EffectInfo] = &[VERTICAL_DIVERGENCE, MIXED_PIXELS];

/// Beam parameters (`"lidar": {"beam": {...}}`); absent values come from the preset.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BeamConfig {
    /// 1/e² full-angle divergence, horizontal, rad.
    #[serde(default)]
    pub divergence_h_rad: Option<f64>,
    /// 1/e² full-angle divergence, vertical, rad.
    #[serde(default)]
    pub divergence_v_rad: Option<f64>,
    /// Exit beam diameter D₀, m (default 5 mm, GUESSED; r_t0 = 2.5 mm of the physics.md §2.3 example).
    #[serde(default)]
    pub exit_diameter_m: Option<f64>,
    /// Sub-rays per pulse: 1, 7, 19, 37, 61, … (1 + 3Q(Q − 1)).
    #[serde(default)]
    pub sub_rays: Option<usize>,
}

/// Default exit beam diameter, m (GUESSED).
pub const DEFAULT_EXIT_DIAMETER_M: f64 = 5e-3;

/// One sub-ray of the beam: angular offsets from the beam axis and its energy fraction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SubRay {
    /// Horizontal offset (towards +azimuth), rad.
    pub dh_rad: f64,
    /// Vertical offset (towards +elevation), rad.
    pub dv_rad: f64,
    /// Fraction of the pulse energy, Σ = 1.
    pub weight: f64,
}

/// Number of rings Q for a sub-ray count (1 + 3Q(Q − 1)), or an error naming the key.
pub fn rings_for(sub_rays: usize) -> Result<usize, ModelError> {
    (1..=64usize)
        .find(|&q| 1 + 3 * q * (q - 1) == sub_rays)
        .ok_or_else(|| {
            ModelError::Config(format!(
                "`lidar.beam.sub_rays` must be 1 + 3Q(Q−1) (1, 7, 19, 37, 61, …), got {sub_rays}"
            ))
        })
}

/// The sub-rays of a beam with 1/e² full divergences `beta_h_rad`, `beta_v_rad` on `rings` rings.
pub fn sub_rays(rings: usize, beta_h_rad: f64, beta_v_rad: f64) -> Vec<SubRay> {
    let q = rings.max(1);
    if q == 1 {
        return vec![SubRay {
            dh_rad: 0.0,
            dv_rad: 0.0,
            weight: 1.0,
        }];
    }
    // Normalised radius u = ρ / w (w = 1/e² radius); intensity ∝ exp(−2u²); energy inside u:
    // 1 − exp(−2u²).
    let step = 1.0 / (q as f64 - 0.5);
    let energy = |u: f64| 1.0 - (-2.0 * u * u).exp();
    let mut out = Vec::with_capacity(1 + 3 * q * (q - 1));
    out.push(SubRay {
        dh_rad: 0.0,
        dv_rad: 0.0,
        weight: energy(0.5 * step),
    });
    for r in 1..q {
        let (a, b) = ((r as f64 - 0.5) * step, (r as f64 + 0.5) * step);
        let n = 6 * r;
        let w = (energy(b) - energy(a)) / n as f64;
        let u = r as f64 * step;
        for k in 0..n {
            let phi = std::f64::consts::TAU * k as f64 / n as f64;
            out.push(SubRay {
                dh_rad: u * phi.cos() * 0.5 * beta_h_rad,
                dv_rad: u * phi.sin() * 0.5 * beta_v_rad,
                weight: w,
            });
        }
    }
    let total: f64 = out.iter().map(|s| s.weight).sum();
    for s in &mut out {
        s.weight /= total;
    }
    out
}

/// Footprint diameter at range `range_m` for exit diameter `d0_m` and full divergence `beta_rad`:
/// D(R) = D₀ + Rβ (physics.md §2.6).
pub fn footprint_m(d0_m: f64, beta_rad: f64, range_m: f64) -> f64 {
    d0_m + range_m * beta_rad
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ring_counts_and_weights() {
        for (n, q) in [(1, 1), (7, 2), (19, 3), (37, 4), (61, 5)] {
            assert_eq!(rings_for(n).unwrap(), q);
            let s = sub_rays(q, 3e-3, 1.5e-3);
            assert_eq!(s.len(), n);
            let sum: f64 = s.iter().map(|x| x.weight).sum();
            assert!((sum - 1.0).abs() < 1e-12);
            // Symmetric: mean offset zero; outermost offset = β/2 · (Q−1)/(Q−½).
            let mh: f64 = s.iter().map(|x| x.weight * x.dh_rad).sum();
            assert!(mh.abs() < 1e-15);
            let maxh = s.iter().map(|x| x.dh_rad.abs()).fold(0.0, f64::max);
            let expect = if q == 1 {
                0.0
            } else {
                1.5e-3 * (q as f64 - 1.0) / (q as f64 - 0.5)
            };
            assert!((maxh - expect).abs() < 1e-12, "{maxh} {expect}");
        }
        assert!(rings_for(8).is_err());
        // 7 rays: the centre carries (1 − e^{−2/9}) / (1 − e^{−2}) of the energy.
        let s = sub_rays(2, 3e-3, 3e-3);
        let c = (1.0 - (-2.0f64 / 9.0).exp()) / (1.0 - (-2.0f64).exp());
        assert!((s[0].weight - c).abs() < 1e-12);
        // VLS-128 footprint at 100 m: 0.30 × 0.15 m (physics.md §2.6).
        assert!((footprint_m(0.0, 3e-3, 100.0) - 0.30).abs() < 1e-12);
    }
}
