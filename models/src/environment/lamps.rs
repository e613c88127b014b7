//! Vehicle lamps: luminous-intensity distributions I(h, v) and spectral power distributions.
//!
//! # Angles and frames
//!
//! A lamp has its own frame (ISO 8855 axes: x = optical axis / forward, y = left, z = up) placed in
//! the vehicle frame by [`Lamp::pose`]. A direction `d` in the lamp frame has
//! `h = atan2(d_y, d_x)` (horizontal angle, **positive to the left**, "L" in ECE notation) and
//! `v = asin(d_z/|d|)` (vertical angle, **positive up**, "U"; "D" = negative), the same
//! azimuth/elevation convention as [`crate::frames::Spherical`]. A tail lamp looks backwards: give
//! it a pose with yaw = π.
//!
//! # Photometry → radiometry
//!
//! Luminous intensity in cd = lm/sr. A lamp spectrum `S(λ)` is normalised to one lumen:
//! `s(λ) = S(λ) / (K_m ∫ S(λ) V(λ) dλ)` in W nm⁻¹ lm⁻¹, with K_m = 683 lm/W and V(λ) the CIE 1924
//! photopic luminous efficiency function ([`V_LAMBDA`]). Spectral radiant intensity is then
//! `I_e,λ(h, v, λ) = I_v(h, v) · s(λ)` in W sr⁻¹ nm⁻¹ ([`Lamp::spectral_intensity`]).
//!
//! # Built-in data
//!
//! The built-in distributions ([`LightDistribution::ece_low_beam`], [`LightDistribution::ece_high_beam`],
//! [`LightDistribution::ece_tail_lamp`]) are **representative shapes, not a specific product**:
//! smooth analytic functions sampled on a grid, with parameters chosen so that the tables meet the
//! UN ECE photometric test-point limits listed at each function. Those limits are recalled from
//! UN ECE R112 (headlamps, class B passing beam, right-hand traffic) and R7 (rear position lamps)
//! and are **UNVERIFIED** against the Regulations' current texts. The spectral shapes
//! ([`SpectrumShape::white_led`], [`SpectrumShape::red_led`]) are likewise representative. The
//! traffic-signal distribution ([`LightDistribution::en12368_signal`]) and the signal LED lines
//! ([`Spectrum::signal_red`], …) are representative of EN 12368 signal heads (physics.md §3.7), not
//! checked against the standard.

use crate::constants::{BOLTZMANN_J_PER_K, PLANCK_J_S, SPEED_OF_LIGHT_M_S};
use glam::DVec3;
use serde::{Deserialize, Serialize};

use crate::frames::Pose;

/// Maximum luminous efficacy for photopic vision, lm/W (CIE; SI definition of the candela fixes
/// 683 lm/W at 540 × 10¹² Hz ≈ 555 nm).
pub const K_M_LM_PER_W: f64 = 683.0;

/// First wavelength of [`V_LAMBDA`], nm.
pub const V_LAMBDA_START_NM: f64 = 380.0;
/// Step of [`V_LAMBDA`], nm.
pub const V_LAMBDA_STEP_NM: f64 = 5.0;

/// CIE 1924 photopic luminous efficiency function V(λ), 380–780 nm in 5 nm steps (CIE 018:2019 /
/// ISO 23539:2005(E)/CIE S 010/E:2004; values as tabulated by CVRL, <http://cvrl.ucl.ac.uk>,
/// transcribed from colour-science `colour/colorimetry/datasets/lefs.py`,
/// "CIE 1924 Photopic Standard Observer"). V(555 nm) = 1.
pub const V_LAMBDA: [f64; 81] = [
    0.000039, 0.000064, 0.00012, 0.000217, 0.000396, 0.00064, 0.00121, 0.00218, 0.004,
    0.0073, // 380–425
    0.0116, 0.01684, 0.023, 0.0298, 0.038, 0.048, 0.06, 0.0739, 0.09098, 0.1126, // 430–475
    0.13902, 0.1693, 0.20802, 0.2586, 0.323, 0.4073, 0.503, 0.6082, 0.71, 0.7932, // 480–525
    0.862, 0.9148501, 0.954, 0.9803, 0.9949501, 1.0, 0.995, 0.9786, 0.952,
    0.9154, // 530–575
    0.87, 0.8163, 0.757, 0.6949, 0.631, 0.5668, 0.503, 0.4412, 0.381, 0.321, // 580–625
    0.265, 0.217, 0.175, 0.1382, 0.107, 0.0816, 0.061, 0.04458, 0.032, 0.0232, // 630–675
    0.017, 0.01192, 0.00821, 0.005723, 0.004102, 0.002929, 0.002091, 0.001484, 0.001047,
    0.00074, // 680–725
    0.00052, 0.0003611, 0.0002492, 0.0001719, 0.00012, 0.0000848, 0.00006, 0.0000424, 0.00003,
    0.0000212,  // 730–775
    0.00001499, // 780
];

/// V(λ) at any wavelength (linear interpolation of [`V_LAMBDA`]; 0 outside 380–780 nm).
pub fn photopic_v(lambda_nm: f64) -> f64 {
    let x = (lambda_nm - V_LAMBDA_START_NM) / V_LAMBDA_STEP_NM;
    if !(0.0..=(V_LAMBDA.len() - 1) as f64).contains(&x) {
        return 0.0;
    }
    let i = (x.floor() as usize).min(V_LAMBDA.len() - 2);
    let t = x - i as f64;
    V_LAMBDA[i] + t * (V_LAMBDA[i + 1] - V_LAMBDA[i])
}

/// Errors of lamp data.
#[derive(Debug, thiserror::Error)]
pub enum LampError {
    #[error("light distribution: {0}")]
    Invalid(String),
    #[error("light distribution JSON: {0}")]
    Json(#[from] serde_json::Error),
}

// ---------------------------------------------------------------------------------------------
// Light distribution
// ---------------------------------------------------------------------------------------------

/// Luminous intensity I(h, v) in cd on a rectilinear grid of horizontal angles `h_deg` (positive
/// left) and vertical angles `v_deg` (positive up), both strictly increasing, possibly
/// non-uniform. Bilinear interpolation inside the grid, **zero outside**.
///
/// JSON: `{"h_deg": [..], "v_deg": [..], "cd": [[..], ..]}` with one row of `cd` per vertical angle
/// (`cd[i][j] = I(h_deg[j], v_deg[i])`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "DistributionJson", into = "DistributionJson")]
pub struct LightDistribution {
    h_deg: Vec<f64>,
    v_deg: Vec<f64>,
    /// Row-major, `cd[i * h_deg.len() + j]` = I(h_deg[j], v_deg[i]).
    cd: Vec<f64>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct DistributionJson {
    h_deg: Vec<f64>,
    v_deg: Vec<f64>,
    cd: Vec<Vec<f64>>,
}

impl TryFrom<DistributionJson> for LightDistribution {
    type Error = LampError;
    fn try_from(j: DistributionJson) -> Result<Self, LampError> {
        LightDistribution::new(j.h_deg, j.v_deg, j.cd)
    }
}

impl From<LightDistribution> for DistributionJson {
    fn from(d: LightDistribution) -> Self {
        let cd = d.cd.chunks(d.h_deg.len()).map(<[f64]>::to_vec).collect();
        DistributionJson {
            h_deg: d.h_deg,
            v_deg: d.v_deg,
            cd,
        }
    }
}

fn check_axis(name: &str, a: &[f64]) -> Result<(), LampError> {
    if a.len() < 2 {
        return Err(LampError::Invalid(format!(
            "{name} needs at least 2 angles"
        )));
    }
    if a.iter().any(|x| !x.is_finite() || x.abs() > 180.0) {
        return Err(LampError::Invalid(format!(
            "{name} must be finite angles within ±180°"
        )));
    }
    if a.windows(2).any(|w| w[1] <= w[0]) {
        return Err(LampError::Invalid(format!(
            "{name} must be strictly increasing"
        )));
    }
    Ok(())
}

/// Index `i` with `a[i] ≤ x ≤ a[i+1]` and the fraction `t`, or `None` outside.
fn bracket(a: &[f64], x: f64) -> Option<(usize, f64)> {
    if !(a[0]..=a[a.len() - 1]).contains(&x) {
        return None;
    }
    let i = a.partition_point(|&g| g <= x).clamp(1, a.len() - 1) - 1;
    Some((i, (x - a[i]) / (a[i + 1] - a[i])))
}

/// Horizontal and vertical angle (deg) of a lamp-frame direction (need not be normalised).
pub fn direction_to_hv_deg(dir: DVec3) -> (f64, f64) {
    let r = dir.length();
    if r == 0.0 {
        return (f64::NAN, f64::NAN);
    }
    (
        dir.y.atan2(dir.x).to_degrees(),
        (dir.z / r).clamp(-1.0, 1.0).asin().to_degrees(),
    )
}

/// Unit lamp-frame direction for horizontal/vertical angles (deg).
pub fn hv_deg_to_direction(h_deg: f64, v_deg: f64) -> DVec3 {
    let (h, v) = (h_deg.to_radians(), v_deg.to_radians());
    DVec3::new(v.cos() * h.cos(), v.cos() * h.sin(), v.sin())
}

impl LightDistribution {
    /// A distribution from axes and rows (`rows[i][j]` = I(h[j], v[i]), cd ≥ 0).
    pub fn new(h_deg: Vec<f64>, v_deg: Vec<f64>, rows: Vec<Vec<f64>>) -> Result<Self, LampError> {
        check_axis("h_deg", &h_deg)?;
        check_axis("v_deg", &v_deg)?;
        if rows.len() != v_deg.len() || rows.iter().any(|r| r.len() != h_deg.len()) {
            return Err(LampError::Invalid(format!(
                "cd must have {} rows (v_deg) of {} values (h_deg)",
                v_deg.len(),
                h_deg.len()
            )));
        }
        let cd: Vec<f64> = rows.into_iter().flatten().collect();
        if cd.iter().any(|x| !x.is_finite() || *x < 0.0) {
            return Err(LampError::Invalid(
                "cd values must be finite and ≥ 0".into(),
            ));
        }
        Ok(LightDistribution { h_deg, v_deg, cd })
    }

    /// Parse the JSON form.
    pub fn from_json(json: &str) -> Result<Self, LampError> {
        Ok(serde_json::from_str(json)?)
    }

    /// Sample `f(h, v)` (cd) on the given axes.
    pub fn from_fn(
        h_deg: Vec<f64>,
        v_deg: Vec<f64>,
        f: impl Fn(f64, f64) -> f64,
    ) -> Result<Self, LampError> {
        let rows = v_deg
            .iter()
            .map(|&v| h_deg.iter().map(|&h| f(h, v)).collect())
            .collect();
        LightDistribution::new(h_deg, v_deg, rows)
    }

    /// Horizontal angles, deg.
    pub fn h_deg(&self) -> &[f64] {
        &self.h_deg
    }

    /// Vertical angles, deg.
    pub fn v_deg(&self) -> &[f64] {
        &self.v_deg
    }

    /// Table value at grid node (`h_deg[j]`, `v_deg[i]`), cd.
    pub fn node(&self, j: usize, i: usize) -> f64 {
        self.cd[i * self.h_deg.len() + j]
    }

    /// Luminous intensity at (h, v) in deg, cd: bilinear in the grid cell, 0 outside the grid.
    pub fn intensity_cd(&self, h_deg: f64, v_deg: f64) -> f64 {
        let (Some((j, s)), Some((i, t))) =
            (bracket(&self.h_deg, h_deg), bracket(&self.v_deg, v_deg))
        else {
            return 0.0;
        };
        let (a, b) = (self.node(j, i), self.node(j + 1, i));
        let (c, d) = (self.node(j, i + 1), self.node(j + 1, i + 1));
        (1.0 - t) * ((1.0 - s) * a + s * b) + t * ((1.0 - s) * c + s * d)
    }

    /// Luminous intensity towards a lamp-frame direction, cd.
    pub fn intensity_cd_dir(&self, dir_lamp: DVec3) -> f64 {
        let (h, v) = direction_to_hv_deg(dir_lamp);
        if h.is_nan() {
            0.0
        } else {
            self.intensity_cd(h, v)
        }
    }

    /// Largest table value, cd.
    pub fn max_cd(&self) -> f64 {
        self.cd.iter().copied().fold(0.0, f64::max)
    }

    /// All intensities multiplied by `factor` (e.g. dimming, ageing, or scaling to a measured Imax).
    pub fn scaled(mut self, factor: f64) -> Self {
        self.cd.iter_mut().for_each(|x| *x *= factor.max(0.0));
        self
    }

    /// Mirror left/right (h → −h): a right-hand-traffic beam becomes a left-hand-traffic one.
    pub fn mirrored(&self) -> Self {
        let nh = self.h_deg.len();
        let h_deg = self.h_deg.iter().rev().map(|h| -h).collect();
        let cd = self
            .cd
            .chunks(nh)
            .flat_map(|row| row.iter().rev().copied())
            .collect();
        LightDistribution {
            h_deg,
            v_deg: self.v_deg.clone(),
            cd,
        }
    }

    /// Luminous flux inside the grid, lm: `∫∫ I(h, v) cos v dh dv` (h, v as azimuth/elevation),
    /// midpoint rule on a 0.1° sub-grid.
    pub fn luminous_flux_lm(&self) -> f64 {
        let (h0, h1) = (self.h_deg[0], self.h_deg[self.h_deg.len() - 1]);
        let (v0, v1) = (self.v_deg[0], self.v_deg[self.v_deg.len() - 1]);
        let step = 0.1_f64;
        let (nh, nv) = (
            ((h1 - h0) / step).ceil() as usize,
            ((v1 - v0) / step).ceil() as usize,
        );
        let (dh, dv) = ((h1 - h0) / nh as f64, (v1 - v0) / nv as f64);
        let mut sum = 0.0;
        for i in 0..nv {
            let v = v0 + (i as f64 + 0.5) * dv;
            let row: f64 = (0..nh)
                .map(|j| self.intensity_cd(h0 + (j as f64 + 0.5) * dh, v))
                .sum();
            sum += row * v.to_radians().cos();
        }
        sum * dh.to_radians() * dv.to_radians()
    }

    /// Representative **passing beam (low beam), right-hand traffic**, ECE R112 class B shape.
    ///
    /// Shape (documented choice, not a product): `I = [I_hot·g((h+1.5°)/6°)·g((v+1.5°)/2°) +
    /// I_wide·g(h/20°)·g((v+2°)/4°)]·S(c(h) − v) + I_floor`, with `g(x) = exp(−x²)`, I_hot = 20 000 cd,
    /// I_wide = 3000 cd, I_floor = 150 cd, a logistic cut-off step `S(x) = 1/(1 + exp(−x/0.1°))`, and
    /// the cut-off line `c(h)`: horizontal at 0.57° D on the left (oncoming) side, rising at 15° from
    /// the elbow (h = 0) on the right (kerb) side up to the h-h line.
    ///
    /// ECE R112 class B test points (angles from the 25 m screen; limits **UNVERIFIED**) met by
    /// this table (see tests): B50L (3.43°L, 0.57°U) ≤ 350 cd; 75R (1.15°R, 0.57°D) ≥ 10 100 cd;
    /// 75L (3.43°L, 0.57°D) ≤ 10 600 cd; 50L (3.43°L, 0.86°D) ≤ 13 200 cd; 50R (1.72°R, 0.86°D)
    /// ≥ 10 100 cd; 50V (0°, 0.86°D) ≥ 5100 cd; 25L (9°L, 1.72°D) and 25R (9°R, 1.72°D) ≥ 1700 cd;
    /// zone III (above the cut-off) ≤ 625 cd.
    pub fn ece_low_beam() -> Self {
        let g = |x: f64| (-x * x).exp();
        let cutoff = |h: f64| {
            if h >= 0.0 {
                -0.57
            } else {
                (-0.57 + (-h) * 15f64.to_radians().tan()).min(0.0)
            }
        };
        let f = move |h: f64, v: f64| {
            let lobe = 20_000.0 * g((h + 1.5) / 6.0) * g((v + 1.5) / 2.0)
                + 3000.0 * g(h / 20.0) * g((v + 2.0) / 4.0);
            let step = 1.0 / (1.0 + (-(cutoff(h) - v) / 0.1).exp());
            lobe * step + 150.0
        };
        let mut h: Vec<f64> = vec![
            -90.0, -75.0, -60.0, -45.0, -35.0, -30.0, -25.0, -20.0, -15.0, -12.0, -10.0,
        ];
        h.extend((-36..=36).map(|k| k as f64 * 0.25));
        h.extend([
            10.0, 12.0, 15.0, 20.0, 25.0, 30.0, 35.0, 45.0, 60.0, 75.0, 90.0,
        ]);
        let mut v: Vec<f64> = vec![
            -30.0, -20.0, -15.0, -10.0, -8.0, -6.0, -5.0, -4.0, -3.5, -3.0, -2.5, -2.0, -1.6,
        ];
        v.extend((-30..=20).map(|k| k as f64 * 0.05));
        v.extend([1.2, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 10.0, 15.0, 20.0, 30.0]);
        LightDistribution::from_fn(h, v, f).expect("built-in low beam grid is valid")
    }

    /// Representative **driving beam (high beam)**: `I = 60 000 cd · g(h/8°) · g(v/3°)`,
    /// `g(x) = exp(−x²)` (documented choice, not a product).
    ///
    /// ECE R112 class B driving-beam requirements met by this table (values recalled from R112,
    /// **UNVERIFIED**): 40 500 cd ≤ I_max ≤ 215 000 cd; I(HV) ≥ 0.8 I_max; H-5L/R ≥ 16 200 cd;
    /// H-9L/R ≥ 5100 cd.
    pub fn ece_high_beam() -> Self {
        let g = |x: f64| (-x * x).exp();
        let h: Vec<f64> = (-90..=90).map(|k| k as f64).collect();
        let v: Vec<f64> = (-60..=40).map(|k| k as f64 * 0.5).collect();
        LightDistribution::from_fn(h, v, |h, v| 60_000.0 * g(h / 8.0) * g(v / 3.0))
            .expect("valid grid")
    }

    /// Representative **rear position (tail) lamp**: `I = 8 cd · g(h/30°) · g(v/15°)` on
    /// |h| ≤ 80°, |v| ≤ 20° (documented choice, not a product).
    ///
    /// ECE R7 rear position lamp (single lamp, **UNVERIFIED**): on the reference axis at least 4 cd
    /// and at most 17 cd (12 cd is quoted for some categories; the representative 8 cd satisfies both).
    pub fn ece_tail_lamp() -> Self {
        let g = |x: f64| (-x * x).exp();
        let h: Vec<f64> = (-80..=80).step_by(2).map(|k| k as f64).collect();
        let v: Vec<f64> = (-20..=20).map(|k| k as f64).collect();
        LightDistribution::from_fn(h, v, |h, v| 8.0 * g(h / 30.0) * g(v / 15.0))
            .expect("valid grid")
    }

    /// Representative **traffic-signal light** (EN 12368 signal head roundel, physics.md §3.7):
    /// `I = I₀ · g(h/σ_h) · g(v/σ_v)` with `g(x) = exp(−x²)`, [`SIGNAL_WIDTH_H_DEG`] = 15° and
    /// [`SIGNAL_WIDTH_V_DEG`] = 8° (1/e half-widths) on |h| ≤ 60°, |v| ≤ 30° (documented choice,
    /// not a product: a medium-wide beam aimed along the reference axis). `on_axis_cd` is I₀:
    /// [`SIGNAL_200MM_CD`] / [`SIGNAL_300MM_CD`] for the two roundel sizes.
    ///
    /// EN 12368 grades the on-axis intensity in classes (recalled, **UNVERIFIED**: class 1
    /// 100–400 cd, class 2 200–800 cd, class 3 400–1000 cd) and the beam width in types (wide,
    /// medium, narrow) by the fraction of I₀ required at off-axis test points; the widths here
    /// are **not** checked against those points.
    pub fn en12368_signal(on_axis_cd: f64) -> Self {
        let g = |x: f64| (-x * x).exp();
        let h: Vec<f64> = (-60..=60).map(|k| k as f64).collect();
        let v: Vec<f64> = (-30..=30).map(|k| k as f64).collect();
        LightDistribution::from_fn(h, v, |h, v| {
            on_axis_cd * g(h / SIGNAL_WIDTH_H_DEG) * g(v / SIGNAL_WIDTH_V_DEG)
        })
        .expect("valid grid")
    }
}

/// On-axis luminous intensity of a 200 mm traffic-signal roundel, cd (**representative**: inside
/// the recalled EN 12368 class 1 / class 2 ranges, UNVERIFIED).
pub const SIGNAL_200MM_CD: f64 = 400.0;
/// On-axis luminous intensity of a 300 mm traffic-signal roundel, cd (**representative**: inside
/// the recalled EN 12368 class 2 / class 3 ranges, UNVERIFIED).
pub const SIGNAL_300MM_CD: f64 = 800.0;
/// Horizontal 1/e half-width of [`LightDistribution::en12368_signal`], deg (**representative**).
pub const SIGNAL_WIDTH_H_DEG: f64 = 15.0;
/// Vertical 1/e half-width of [`LightDistribution::en12368_signal`], deg (**representative**).
pub const SIGNAL_WIDTH_V_DEG: f64 = 8.0;

// ---------------------------------------------------------------------------------------------
// Spectra
// ---------------------------------------------------------------------------------------------

/// Planck spectral radiance of a black body, W m⁻² sr⁻¹ nm⁻¹:
/// `B(λ, T) = 2hc²/λ⁵ / (exp(hc/(λ k_B T)) − 1)` (λ in m inside, result per nm).
pub fn planck_radiance_w_m2_sr_nm(lambda_nm: f64, temperature_k: f64) -> f64 {
    if lambda_nm <= 0.0 || temperature_k <= 0.0 {
        return 0.0;
    }
    let l = lambda_nm * 1e-9;
    let x = PLANCK_J_S * SPEED_OF_LIGHT_M_S / (l * BOLTZMANN_J_PER_K * temperature_k);
    2.0 * PLANCK_J_S * SPEED_OF_LIGHT_M_S * SPEED_OF_LIGHT_M_S / l.powi(5) / x.exp_m1() * 1e-9
}

fn gaussian(lambda_nm: f64, peak_nm: f64, fwhm_nm: f64) -> f64 {
    let sigma = fwhm_nm / (2.0 * (2.0 * std::f64::consts::LN_2).sqrt());
    (-0.5 * ((lambda_nm - peak_nm) / sigma).powi(2)).exp()
}

/// Relative spectral power distribution of a lamp (arbitrary scale).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum SpectrumShape {
    /// Tungsten-halogen filament as a black body at `cct_k` (≈ 3200 K). The bulb's UV/IR
    /// transmission is not modelled; the shape is Planck's law at all wavelengths (it peaks near
    /// 905 nm at 3200 K, which matters for LiDAR).
    Blackbody { cct_k: f64 },
    /// Phosphor-converted white LED: a blue pump Gaussian plus a broad phosphor Gaussian;
    /// negligible emission in the NIR.
    WhiteLed {
        blue_peak_nm: f64,
        blue_fwhm_nm: f64,
        phosphor_peak_nm: f64,
        phosphor_fwhm_nm: f64,
        phosphor_to_blue: f64,
    },
    /// Single Gaussian emission line (coloured LED).
    Gaussian { peak_nm: f64, fwhm_nm: f64 },
    /// Tabulated relative SPD (`nm` strictly increasing), linear interpolation, 0 outside.
    Table { nm: Vec<f64>, relative: Vec<f64> },
}

impl SpectrumShape {
    /// Halogen headlamp: black body at 3200 K.
    pub fn halogen() -> Self {
        SpectrumShape::Blackbody { cct_k: 3200.0 }
    }

    /// Representative cool-white phosphor-converted LED (**UNVERIFIED**, not from a datasheet):
    /// blue pump 450 nm (FWHM 20 nm), phosphor 560 nm (FWHM 110 nm) at half the blue peak height.
    pub fn white_led() -> Self {
        SpectrumShape::WhiteLed {
            blue_peak_nm: 450.0,
            blue_fwhm_nm: 20.0,
            phosphor_peak_nm: 560.0,
            phosphor_fwhm_nm: 110.0,
            phosphor_to_blue: 0.5,
        }
    }

    /// Representative red LED tail lamp: Gaussian at 625 nm, FWHM 20 nm (**UNVERIFIED** width).
    pub fn red_led() -> Self {
        SpectrumShape::Gaussian {
            peak_nm: 625.0,
            fwhm_nm: 20.0,
        }
    }

    /// Representative traffic-signal LED line of a signal colour (Gaussian; peaks and widths typical
    /// of AlInGaP red 630 nm / amber 590 nm and InGaN green 505 nm / blue 470 nm signal LEDs,
    /// **representative, UNVERIFIED**, not from a datasheet; FWHM 20 / 15 / 30 / 25 nm). White
    /// signals use [`SpectrumShape::white_led`].
    pub fn signal_led(peak_nm: f64, fwhm_nm: f64) -> Self {
        SpectrumShape::Gaussian { peak_nm, fwhm_nm }
    }

    /// Relative spectral power at `lambda_nm` (arbitrary units, ≥ 0).
    pub fn relative(&self, lambda_nm: f64) -> f64 {
        match self {
            SpectrumShape::Blackbody { cct_k } => planck_radiance_w_m2_sr_nm(lambda_nm, *cct_k),
            SpectrumShape::WhiteLed {
                blue_peak_nm,
                blue_fwhm_nm,
                phosphor_peak_nm,
                phosphor_fwhm_nm,
                phosphor_to_blue,
            } => {
                gaussian(lambda_nm, *blue_peak_nm, *blue_fwhm_nm)
                    + phosphor_to_blue * gaussian(lambda_nm, *phosphor_peak_nm, *phosphor_fwhm_nm)
            }
            SpectrumShape::Gaussian { peak_nm, fwhm_nm } => gaussian(lambda_nm, *peak_nm, *fwhm_nm),
            SpectrumShape::Table { nm, relative } => match bracket(nm, lambda_nm) {
                Some((i, t)) => relative[i] + t * (relative[i + 1] - relative[i]),
                None => 0.0,
            },
        }
    }
}

/// Step of the photometric integrals, nm.
const INTEGRATION_STEP_NM: f64 = 0.5;

/// ∫ f(λ) dλ over [a, b] nm by the trapezoidal rule at [`INTEGRATION_STEP_NM`].
fn integrate_nm(a: f64, b: f64, f: impl Fn(f64) -> f64) -> f64 {
    if b <= a {
        return 0.0;
    }
    let n = ((b - a) / INTEGRATION_STEP_NM).ceil().max(1.0) as usize;
    let h = (b - a) / n as f64;
    let inner: f64 = (1..n).map(|k| f(a + k as f64 * h)).sum();
    h * (0.5 * (f(a) + f(b)) + inner)
}

/// A lamp spectrum normalised to one lumen: [`Spectrum::w_per_nm_per_lm`] = `s(λ)`.
#[derive(Debug, Clone, PartialEq)]
pub struct Spectrum {
    shape: SpectrumShape,
    /// 1 / (K_m ∫ S V dλ), lm⁻¹ per unit of `shape.relative`.
    norm: f64,
}

impl Spectrum {
    /// Normalise a shape to one lumen. Errors if it has no visible content.
    pub fn new(shape: SpectrumShape) -> Result<Spectrum, LampError> {
        if let SpectrumShape::Table { nm, relative } = &shape {
            check_axis_nm(nm)?;
            if relative.len() != nm.len() || relative.iter().any(|r| !r.is_finite() || *r < 0.0) {
                return Err(LampError::Invalid(
                    "spectrum table: relative must match nm, finite ≥ 0".into(),
                ));
            }
        }
        let lm = K_M_LM_PER_W * integrate_nm(380.0, 780.0, |l| shape.relative(l) * photopic_v(l));
        if !(lm.is_finite() && lm > 0.0) {
            return Err(LampError::Invalid(
                "spectrum has no luminous (380–780 nm) content".into(),
            ));
        }
        Ok(Spectrum {
            shape,
            norm: 1.0 / lm,
        })
    }

    /// Halogen (black body 3200 K), normalised.
    pub fn halogen() -> Spectrum {
        Spectrum::new(SpectrumShape::halogen()).expect("halogen spectrum is luminous")
    }

    /// Representative white LED, normalised.
    pub fn white_led() -> Spectrum {
        Spectrum::new(SpectrumShape::white_led()).expect("LED spectrum is luminous")
    }

    /// Representative red LED, normalised.
    pub fn red_led() -> Spectrum {
        Spectrum::new(SpectrumShape::red_led()).expect("red LED spectrum is luminous")
    }

    /// Representative red signal LED (630 nm, FWHM 20 nm), normalised.
    pub fn signal_red() -> Spectrum {
        Spectrum::new(SpectrumShape::signal_led(630.0, 20.0)).expect("luminous")
    }

    /// Representative amber (yellow) signal LED (590 nm, FWHM 15 nm), normalised.
    pub fn signal_yellow() -> Spectrum {
        Spectrum::new(SpectrumShape::signal_led(590.0, 15.0)).expect("luminous")
    }

    /// Representative green (cyan-green) signal LED (505 nm, FWHM 30 nm), normalised.
    pub fn signal_green() -> Spectrum {
        Spectrum::new(SpectrumShape::signal_led(505.0, 30.0)).expect("luminous")
    }

    /// Representative blue signal LED (470 nm, FWHM 25 nm), normalised.
    pub fn signal_blue() -> Spectrum {
        Spectrum::new(SpectrumShape::signal_led(470.0, 25.0)).expect("luminous")
    }

    /// The underlying shape.
    pub fn shape(&self) -> &SpectrumShape {
        &self.shape
    }

    /// Spectral radiant power per lumen of luminous flux, W nm⁻¹ lm⁻¹.
    pub fn w_per_nm_per_lm(&self, lambda_nm: f64) -> f64 {
        self.shape.relative(lambda_nm) * self.norm
    }

    /// Radiant power per lumen in the band [a, b] nm, W lm⁻¹.
    pub fn w_per_lm_in_band(&self, a_nm: f64, b_nm: f64) -> f64 {
        integrate_nm(a_nm, b_nm, |l| self.w_per_nm_per_lm(l))
    }

    /// Luminous efficacy of the radiation within [a, b] nm, lm/W (1 / [`Self::w_per_lm_in_band`]).
    pub fn luminous_efficacy_lm_per_w(&self, a_nm: f64, b_nm: f64) -> f64 {
        1.0 / self.w_per_lm_in_band(a_nm, b_nm)
    }
}

fn check_axis_nm(nm: &[f64]) -> Result<(), LampError> {
    if nm.len() < 2
        || nm.iter().any(|x| !x.is_finite() || *x <= 0.0)
        || nm.windows(2).any(|w| w[1] <= w[0])
    {
        return Err(LampError::Invalid(
            "spectrum table: nm must be ≥ 2 positive, strictly increasing values".into(),
        ));
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// Lamp
// ---------------------------------------------------------------------------------------------

/// A vehicle lamp: where it sits, how its light is distributed, and what colour it is.
#[derive(Debug, Clone, PartialEq)]
pub struct Lamp {
    /// Lamp frame in the vehicle frame (x = optical axis, y = left, z = up).
    pub pose: Pose,
    /// Luminous intensity distribution in the lamp frame.
    pub distribution: LightDistribution,
    /// Spectrum normalised to one lumen.
    pub spectrum: Spectrum,
}

impl Lamp {
    pub fn new(pose: Pose, distribution: LightDistribution, spectrum: Spectrum) -> Lamp {
        Lamp {
            pose,
            distribution,
            spectrum,
        }
    }

    /// Halogen low beam (built-in ECE-like distribution).
    pub fn halogen_low_beam(pose: Pose) -> Lamp {
        Lamp::new(pose, LightDistribution::ece_low_beam(), Spectrum::halogen())
    }

    /// White-LED low beam.
    pub fn led_low_beam(pose: Pose) -> Lamp {
        Lamp::new(
            pose,
            LightDistribution::ece_low_beam(),
            Spectrum::white_led(),
        )
    }

    /// White-LED high beam.
    pub fn led_high_beam(pose: Pose) -> Lamp {
        Lamp::new(
            pose,
            LightDistribution::ece_high_beam(),
            Spectrum::white_led(),
        )
    }

    /// Red-LED tail lamp (give a pose looking backwards, yaw = π).
    pub fn led_tail_lamp(pose: Pose) -> Lamp {
        Lamp::new(
            pose,
            LightDistribution::ece_tail_lamp(),
            Spectrum::red_led(),
        )
    }

    /// Luminous intensity towards a lamp-frame direction, cd.
    pub fn luminous_intensity_cd(&self, direction_in_lamp_frame: DVec3) -> f64 {
        self.distribution.intensity_cd_dir(direction_in_lamp_frame)
    }

    /// Spectral radiant intensity towards a lamp-frame direction, W sr⁻¹ nm⁻¹:
    /// `I_v(h, v) [lm sr⁻¹] · s(λ) [W nm⁻¹ lm⁻¹]`.
    pub fn spectral_intensity(&self, direction_in_lamp_frame: DVec3, lambda_nm: f64) -> f64 {
        self.luminous_intensity_cd(direction_in_lamp_frame)
            * self.spectrum.w_per_nm_per_lm(lambda_nm)
    }

    /// Radiant intensity in the band [a, b] nm towards a lamp-frame direction, W sr⁻¹.
    pub fn band_intensity_w_sr(&self, direction_in_lamp_frame: DVec3, a_nm: f64, b_nm: f64) -> f64 {
        self.luminous_intensity_cd(direction_in_lamp_frame)
            * self.spectrum.w_per_lm_in_band(a_nm, b_nm)
    }

    /// Illuminance on a surface facing the lamp at `distance_m` along a lamp-frame direction, lx:
    /// inverse-square law `E = I/d²` (far field; the lamp is a point source).
    pub fn illuminance_lux(&self, distance_m: f64, direction_in_lamp_frame: DVec3) -> f64 {
        if distance_m <= 0.0 {
            return 0.0;
        }
        self.luminous_intensity_cd(direction_in_lamp_frame) / (distance_m * distance_m)
    }

    /// Illuminance at a vehicle-frame point on a surface with vehicle-frame normal `normal`, lx:
    /// `E = I(d̂)·max(0, −d̂·n̂)/d²` with `d` the vector from the lamp to the point.
    pub fn illuminance_at_lux(&self, point_vehicle: DVec3, normal_vehicle: DVec3) -> f64 {
        let d = point_vehicle - self.pose.position;
        let r2 = d.length_squared();
        if r2 == 0.0 {
            return 0.0;
        }
        let dir = d / r2.sqrt();
        let cos_inc = (-dir.dot(normal_vehicle.normalize_or_zero())).max(0.0);
        self.luminous_intensity_cd(self.pose.inverse_transform_vector(dir)) * cos_inc / r2
    }

    /// Spectral irradiance at a vehicle-frame point and normal, W m⁻² nm⁻¹.
    pub fn spectral_irradiance_at(
        &self,
        point_vehicle: DVec3,
        normal_vehicle: DVec3,
        lambda_nm: f64,
    ) -> f64 {
        self.illuminance_at_lux(point_vehicle, normal_vehicle)
            * self.spectrum.w_per_nm_per_lm(lambda_nm)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DMat3;

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs()
    }

    #[test]
    fn v_lambda_table_and_efficacy() {
        assert_eq!(V_LAMBDA.len(), 81);
        assert_eq!(photopic_v(555.0), 1.0);
        assert_eq!(photopic_v(380.0), 0.000039);
        assert_eq!(photopic_v(780.0), 0.00001499);
        assert_eq!(photopic_v(379.0), 0.0);
        assert_eq!(photopic_v(905.0), 0.0);
        assert!((photopic_v(552.5) - 0.5 * (0.9949501 + 1.0)).abs() < 1e-12);
        // Unimodal with the maximum at 555 nm.
        let imax = V_LAMBDA
            .iter()
            .enumerate()
            .fold(0, |m, (i, v)| if *v > V_LAMBDA[m] { i } else { m });
        assert_eq!(V_LAMBDA_START_NM + imax as f64 * V_LAMBDA_STEP_NM, 555.0);
        // 683 lm/W at 555 nm: a narrow line at 555 nm needs 1/683 W per lumen.
        let line = Spectrum::new(SpectrumShape::Gaussian {
            peak_nm: 555.0,
            fwhm_nm: 1.0,
        })
        .unwrap();
        let lm_per_w = line.luminous_efficacy_lm_per_w(540.0, 570.0);
        assert!(rel(lm_per_w, 683.0) < 1e-3, "{lm_per_w}");
        // Normalisation: K_m ∫ s V dλ = 1 lm for every shape.
        for s in [
            Spectrum::halogen(),
            Spectrum::white_led(),
            Spectrum::red_led(),
        ] {
            let lm =
                K_M_LM_PER_W * integrate_nm(380.0, 780.0, |l| s.w_per_nm_per_lm(l) * photopic_v(l));
            assert!((lm - 1.0).abs() < 1e-12);
        }
        // A 625 nm red line is far less efficacious: V(625) = 0.321.
        let red = Spectrum::new(SpectrumShape::Gaussian {
            peak_nm: 625.0,
            fwhm_nm: 1.0,
        })
        .unwrap();
        assert!(rel(red.luminous_efficacy_lm_per_w(600.0, 650.0), 683.0 * 0.321) < 2e-3);
    }

    #[test]
    fn planck_law() {
        // Wien displacement: λ_max T = 2.897 771 955 × 10⁻³ m K (CODATA 2018) → 905.6 nm at 3200 K.
        let t = 3200.0;
        let (mut best, mut arg) = (0.0, 0.0);
        for k in 0..20_000 {
            let l = 500.0 + k as f64 * 0.1;
            let b = planck_radiance_w_m2_sr_nm(l, t);
            if b > best {
                (best, arg) = (b, l);
            }
        }
        assert!((arg - 2.897_771_955e6 / t).abs() < 0.1, "{arg}");
        // Stefan–Boltzmann: π ∫ B dλ = σ T⁴ (σ = 5.670 374 419 × 10⁻⁸ W m⁻² K⁻⁴).
        let total = std::f64::consts::PI
            * integrate_nm(50.0, 200_000.0, |l| planck_radiance_w_m2_sr_nm(l, t));
        assert!(rel(total, 5.670_374_419e-8 * t.powi(4)) < 1e-3, "{total}");
        // Halogen emits at 905 nm, the LEDs essentially not.
        assert!(
            Spectrum::halogen().w_per_nm_per_lm(905.0)
                > 1e3 * Spectrum::white_led().w_per_nm_per_lm(905.0)
        );
    }

    #[test]
    fn bilinear_interpolation_and_outside() {
        let d = LightDistribution::new(
            vec![-10.0, 0.0, 10.0],
            vec![-5.0, 5.0],
            vec![vec![0.0, 100.0, 200.0], vec![400.0, 500.0, 600.0]],
        )
        .unwrap();
        // Table points.
        assert_eq!(d.intensity_cd(0.0, -5.0), 100.0);
        assert_eq!(d.intensity_cd(10.0, 5.0), 600.0);
        assert_eq!(d.intensity_cd(-10.0, -5.0), 0.0);
        // Cell centre = mean of the four corners; edges are linear.
        assert!((d.intensity_cd(5.0, 0.0) - (100.0 + 200.0 + 500.0 + 600.0) / 4.0).abs() < 1e-12);
        assert!((d.intensity_cd(-5.0, -5.0) - 50.0).abs() < 1e-12);
        // Zero outside the grid and behind the lamp.
        assert_eq!(d.intensity_cd(10.001, 0.0), 0.0);
        assert_eq!(d.intensity_cd(0.0, -5.001), 0.0);
        assert_eq!(d.intensity_cd_dir(DVec3::new(-1.0, 0.0, 0.0)), 0.0);
        // Direction form: 5° left, 0° up.
        assert!((d.intensity_cd_dir(hv_deg_to_direction(5.0, 0.0)) - 350.0).abs() < 1e-9);
        // Mirror.
        let m = d.mirrored();
        assert!((m.intensity_cd(-5.0, 0.0) - d.intensity_cd(5.0, 0.0)).abs() < 1e-12);
        // Errors.
        assert!(
            LightDistribution::new(vec![0.0, 0.0], vec![0.0, 1.0], vec![vec![1.0, 1.0]; 2])
                .is_err()
        );
        assert!(
            LightDistribution::new(vec![0.0, 1.0], vec![0.0, 1.0], vec![vec![1.0, 1.0]]).is_err()
        );
        assert!(
            LightDistribution::new(vec![0.0, 1.0], vec![0.0, 1.0], vec![vec![1.0, -1.0]; 2])
                .is_err()
        );
    }

    #[test]
    fn json_round_trip() {
        let json = r#"{"h_deg": [-10, 0, 10], "v_deg": [-2, 0, 2],
                       "cd": [[100, 1000, 100], [200, 2000, 200], [10, 20, 10]]}"#;
        let d = LightDistribution::from_json(json).unwrap();
        assert_eq!(d.intensity_cd(0.0, 0.0), 2000.0);
        assert_eq!(d.intensity_cd(-10.0, -2.0), 100.0);
        let back: LightDistribution =
            serde_json::from_str(&serde_json::to_string(&d).unwrap()).unwrap();
        assert_eq!(back, d);
        assert!(
            LightDistribution::from_json(r#"{"h_deg": [0, 1], "v_deg": [0, 1], "cd": [[1, 1]]}"#)
                .is_err()
        );
        let shape: SpectrumShape =
            serde_json::from_str(r#"{"kind": "blackbody", "cct_k": 3200}"#).unwrap();
        assert_eq!(shape, SpectrumShape::halogen());
    }

    #[test]
    fn low_beam_ece_test_points_and_cutoff() {
        let d = LightDistribution::ece_low_beam();
        // (name, h [deg, + = left], v [deg, + = up], min, max) — ECE R112 class B (UNVERIFIED limits).
        let points = [
            ("B50L", 3.43, 0.57, 0.0, 350.0),
            ("75R", -1.15, -0.57, 10_100.0, f64::INFINITY),
            ("75L", 3.43, -0.57, 0.0, 10_600.0),
            ("50L", 3.43, -0.86, 0.0, 13_200.0),
            ("50R", -1.72, -0.86, 10_100.0, f64::INFINITY),
            ("50V", 0.0, -0.86, 5100.0, f64::INFINITY),
            ("25L", 9.0, -1.72, 1700.0, f64::INFINITY),
            ("25R", -9.0, -1.72, 1700.0, f64::INFINITY),
        ];
        for (name, h, v, lo, hi) in points {
            let i = d.intensity_cd(h, v);
            assert!(i >= lo && i <= hi, "{name}: {i} cd not in [{lo}, {hi}]");
        }
        // Zone III (above the cut-off on the oncoming side) ≤ 625 cd.
        for (h, v) in [(1.0, 0.5), (3.0, 1.0), (8.0, 2.0), (-1.0, 1.0), (-6.0, 2.0)] {
            assert!(d.intensity_cd(h, v) <= 625.0, "({h}, {v})");
        }
        // Cut-off: well above the line much dimmer than well below it, on both sides.
        for h in [-8.0, -4.0, -2.0, 0.0, 2.0, 4.0, 8.0] {
            let c: f64 = if h >= 0.0 {
                -0.57
            } else {
                (-0.57 - h * 15f64.to_radians().tan()).min(0.0)
            };
            let (above, below) = (d.intensity_cd(h, c + 0.5), d.intensity_cd(h, c - 0.5));
            assert!(above < 0.1 * below, "h {h}: above {above}, below {below}");
        }
        // Right-hand traffic: more light on the kerb side (right, h < 0) just above 0.57° D.
        assert!(d.intensity_cd(-3.0, -0.3) > 5.0 * d.intensity_cd(3.0, -0.3));
        let lht = d.mirrored();
        assert!((lht.intensity_cd(1.15, -0.57) - d.intensity_cd(-1.15, -0.57)).abs() < 1e-9);
        // Luminous flux inside the grid: order of 10³ lm for a low-beam module.
        let flux = d.luminous_flux_lm();
        assert!(flux > 300.0 && flux < 3000.0, "{flux}");
    }

    #[test]
    fn high_beam_and_tail_lamp() {
        let hb = LightDistribution::ece_high_beam();
        let imax = hb.max_cd();
        assert!((40_500.0..=215_000.0).contains(&imax));
        assert!(hb.intensity_cd(0.0, 0.0) >= 0.8 * imax);
        for h in [5.0, -5.0] {
            assert!(hb.intensity_cd(h, 0.0) >= 16_200.0);
        }
        for h in [9.0, -9.0] {
            assert!(hb.intensity_cd(h, 0.0) >= 5100.0);
        }
        let tail = LightDistribution::ece_tail_lamp();
        let i0 = tail.intensity_cd(0.0, 0.0);
        assert!((4.0..=17.0).contains(&i0), "{i0}");
        assert!(tail.intensity_cd(20.0, 0.0) < i0 && tail.intensity_cd(0.0, 10.0) < i0);
    }

    #[test]
    fn lamp_inverse_square_and_spectral_intensity() {
        let lamp = Lamp::led_low_beam(Pose::new(DVec3::new(3.7, 0.7, 0.65), DMat3::IDENTITY));
        let dir = hv_deg_to_direction(-1.72, -0.86); // 50R
        let i = lamp.luminous_intensity_cd(dir);
        // Inverse square: E(d) d² = I, E(2d) = E(d)/4.
        let e25 = lamp.illuminance_lux(25.0, dir);
        assert!(rel(e25 * 625.0, i) < 1e-12);
        assert!(rel(lamp.illuminance_lux(50.0, dir), e25 / 4.0) < 1e-12);
        // Point form agrees for a surface facing the lamp, and includes cos(incidence).
        let p = lamp.pose.position + dir * 25.0;
        assert!(rel(lamp.illuminance_at_lux(p, -dir), e25) < 1e-9);
        let tilted =
            DMat3::from_axis_angle(dir.any_orthonormal_vector(), 60f64.to_radians()) * -dir;
        assert!(rel(lamp.illuminance_at_lux(p, tilted), 0.5 * e25) < 1e-9);
        assert_eq!(lamp.illuminance_at_lux(p, dir), 0.0); // back face
        // Spectral intensity integrates back to the luminous intensity through 683·V(λ).
        let lum = K_M_LM_PER_W
            * integrate_nm(380.0, 780.0, |l| {
                lamp.spectral_intensity(dir, l) * photopic_v(l)
            });
        assert!(rel(lum, i) < 1e-9, "{lum} vs {i}");
        // Units: W sr⁻¹ nm⁻¹ of order I/(683·100 nm) at the blue peak.
        let s450 = lamp.spectral_intensity(dir, 450.0);
        assert!(s450 > 0.0 && s450 < i / 683.0);
        // A tail lamp looking backwards (yaw = π) lights points behind the car only.
        let tail = Lamp::led_tail_lamp(Pose::new(
            DVec3::new(-0.9, 0.7, 0.8),
            DMat3::from_rotation_z(std::f64::consts::PI),
        ));
        let behind = DVec3::new(-10.9, 0.7, 0.8);
        assert!(
            rel(
                tail.illuminance_at_lux(behind, DVec3::X),
                tail.distribution.intensity_cd(0.0, 0.0) / 100.0
            ) < 1e-9
        );
        assert_eq!(
            tail.illuminance_at_lux(DVec3::new(9.1, 0.7, 0.8), -DVec3::X),
            0.0
        );
        assert!(
            tail.spectral_intensity(DVec3::X, 625.0)
                > 10.0 * tail.spectral_intensity(DVec3::X, 550.0)
        );
    }
}
