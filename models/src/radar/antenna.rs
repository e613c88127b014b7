//! Antenna gain patterns and the RF front end: transmit power, Tx/Rx gain patterns (parametric or
//! tabulated), receiver noise figure, system losses, polarisation.
//!
//! Directions are in the sensor frame: azimuth about +z from +x (positive left), elevation positive
//! up (`crate::frames::Spherical`). Gains are power gains over isotropic (dBi).

use serde::{Deserialize, Serialize};

use crate::constants::BOLTZMANN_J_PER_K;
use crate::effects::{EffectInfo, Effects};
use crate::environment::material::Polarisation as PlanePolarisation;
use crate::error::ModelError;

/// `radar.antenna_pattern`: direction-dependent Tx and Rx gains.
pub const ANTENNA_PATTERN: EffectInfo = EffectInfo {
    name: "radar.antenna_pattern",
    default_on: true,
    summary: "Tx/Rx power gain patterns G(az, el): parametric Gaussian G = G₀·exp(−4 ln2 (az²/θ_az² + \
              el²/θ_el²)) or cosⁿ with n from the 3 dB beamwidth (cos^n(θ_3dB/2) = 1/2), or a bilinear table \
              in dBi; P_r ∝ G_t(DoD)·G_r(DoA); off: every direction gets the peak gain G₀ (isotropic shape)",
    source: "Balanis, Antenna Theory 4th ed. (2016) §2.5 (beamwidth, directivity), §2.11; Gaussian beam \
             approximation: Skolnik, Radar Handbook 3rd ed. ch. 13",
    requires: None,
};

/// Effects declared by this module.
pub const EFFECTS: &[EffectInfo] = &[ANTENNA_PATTERN];

/// Linear polarisation of the radar's Tx and Rx antennas (co-polarised).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Polarisation {
    /// Horizontal: E along the sensor's y axis (TE for a ground bounce).
    #[default]
    #[serde(alias = "h", alias = "horizontal")]
    H,
    /// Vertical: E along the sensor's z axis (TM for a ground bounce).
    #[serde(alias = "v", alias = "vertical")]
    V,
}

impl Polarisation {
    /// The plane-of-incidence polarisation of a bounce off a horizontal surface (road).
    pub fn for_ground(self) -> PlanePolarisation {
        match self {
            Polarisation::H => PlanePolarisation::Te,
            Polarisation::V => PlanePolarisation::Tm,
        }
    }
}

/// Shape of a parametric beam.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BeamShape {
    /// `G = G₀ exp(−4 ln 2 (az/θ_az)² − 4 ln 2 (el/θ_el)²)` (−3 dB at half the beamwidth).
    #[default]
    Gaussian,
    /// `G = G₀ cos^{n_az}(az) cos^{n_el}(el)` with `n = ln ½ / ln cos(θ_3dB/2)` (0 beyond ±90°).
    CosPower,
}

/// A gain pattern, either parametric or a table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename_all = "snake_case", tag = "type")]
pub enum AntennaPattern {
    /// Separable parametric beam.
    Parametric {
        /// Shape of the beam.
        #[serde(default)]
        shape: BeamShape,
        /// Peak (boresight) gain, dBi.
        peak_gain_dbi: f64,
        /// Full azimuth beamwidth between the −3 dB points, deg.
        azimuth_beamwidth_deg: f64,
        /// Full elevation beamwidth between the −3 dB points, deg.
        elevation_beamwidth_deg: f64,
    },
    /// Gain table `gain_dbi[i_el][i_az]` at the (strictly increasing) grid angles, bilinearly
    /// interpolated in dB, clamped at the grid's edges.
    Table {
        /// Azimuth grid, deg.
        azimuth_deg: Vec<f64>,
        /// Elevation grid, deg.
        elevation_deg: Vec<f64>,
        /// Gain, dBi, one row per elevation.
        gain_dbi: Vec<Vec<f64>>,
    },
}

impl Default for AntennaPattern {
    /// A typical long-range automotive front-radar patch array (guessed, order of magnitude of
    /// published sensors: ±10° … ±60° azimuth FOV): Gaussian, 12 dBi, 60° × 12°.
    fn default() -> Self {
        AntennaPattern::Parametric {
            shape: BeamShape::Gaussian,
            peak_gain_dbi: 12.0,
            azimuth_beamwidth_deg: 60.0,
            elevation_beamwidth_deg: 12.0,
        }
    }
}

impl AntennaPattern {
    fn validate(&self, key: &str) -> Result<(), ModelError> {
        let err = |m: String| Err(ModelError::Config(format!("`{key}`: {m}")));
        match self {
            AntennaPattern::Parametric {
                peak_gain_dbi,
                azimuth_beamwidth_deg,
                elevation_beamwidth_deg,
                ..
            } => {
                if !peak_gain_dbi.is_finite() {
                    return err("`peak_gain_dbi` must be finite".into());
                }
                for (name, v) in [
                    ("azimuth_beamwidth_deg", azimuth_beamwidth_deg),
                    ("elevation_beamwidth_deg", elevation_beamwidth_deg),
                ] {
                    if !(v.is_finite() && *v > 0.0 && *v < 360.0) {
                        return err(format!("`{name}` must be in (0, 360) deg, got {v}"));
                    }
                }
            }
            AntennaPattern::Table {
                azimuth_deg,
                elevation_deg,
                gain_dbi,
            } => {
                for (name, g) in [
                    ("azimuth_deg", azimuth_deg),
                    ("elevation_deg", elevation_deg),
                ] {
                    if g.is_empty() || g.iter().any(|v| !v.is_finite()) {
                        return err(format!(
                            "`{name}` must be a non-empty list of finite angles"
                        ));
                    }
                    if g.windows(2).any(|w| w[1] <= w[0]) {
                        return err(format!("`{name}` must be strictly increasing"));
                    }
                }
                if gain_dbi.len() != elevation_deg.len()
                    || gain_dbi.iter().any(|r| r.len() != azimuth_deg.len())
                {
                    return err(format!(
                        "`gain_dbi` must have {} rows (elevations) of {} values (azimuths)",
                        elevation_deg.len(),
                        azimuth_deg.len()
                    ));
                }
                if gain_dbi.iter().flatten().any(|v| !v.is_finite()) {
                    return err("`gain_dbi` values must be finite".into());
                }
            }
        }
        Ok(())
    }

    /// Peak gain, dBi (the table's maximum).
    pub fn peak_gain_dbi(&self) -> f64 {
        match self {
            AntennaPattern::Parametric { peak_gain_dbi, .. } => *peak_gain_dbi,
            AntennaPattern::Table { gain_dbi, .. } => gain_dbi
                .iter()
                .flatten()
                .copied()
                .fold(f64::NEG_INFINITY, f64::max),
        }
    }

    /// The main lobe in the principal planes, `[az_min, az_max, el_min, el_max]` rad: the angles
    /// out to the first null (first minimum) either side of the peak.
    ///
    /// * Gaussian: the Gaussian stands for the main lobe of an aperture; its edge is the first
    ///   null of the uniform aperture with the same 3 dB beamwidth θ₃. Uniform broadside
    ///   aperture / array of length D (Balanis, *Antenna Theory* 4th ed. §6.3, Table 6.1):
    ///   field `sin u / u`, `u = π (D/λ) sin θ`; half-power points at `u = 1.39156` (Balanis
    ///   rounds to 1.391), first nulls at `u = π`, so `sin θ_n = π/1.39156 · sin(θ₃/2)` (capped
    ///   at 90°).
    /// * cosⁿ: its first zero, ±90°.
    /// * Table: walking from the table's peak along its row (azimuth) and column (elevation)
    ///   while the gain does not rise; the first minimum (or the grid's end: the pattern is not
    ///   known beyond it) bounds the lobe; an axis with a single grid angle (a pattern constant
    ///   along it) does not bound it (±90°).
    pub fn main_lobe_rad(&self) -> [f64; 4] {
        let half_pi = 0.5 * std::f64::consts::PI;
        match self {
            AntennaPattern::Parametric {
                shape,
                azimuth_beamwidth_deg,
                elevation_beamwidth_deg,
                ..
            } => {
                let edge = |th3_deg: f64| match shape {
                    BeamShape::Gaussian => {
                        let s = std::f64::consts::PI / 1.39156 * (0.5 * th3_deg.to_radians()).sin();
                        if s >= 1.0 { half_pi } else { s.asin() }
                    }
                    BeamShape::CosPower => half_pi,
                };
                let (a, e) = (edge(*azimuth_beamwidth_deg), edge(*elevation_beamwidth_deg));
                [-a, a, -e, e]
            }
            AntennaPattern::Table {
                azimuth_deg,
                elevation_deg,
                gain_dbi,
            } => {
                // Peak cell (first maximum).
                let (mut ie, mut ia, mut best) = (0, 0, f64::NEG_INFINITY);
                for (i, row) in gain_dbi.iter().enumerate() {
                    for (j, &g) in row.iter().enumerate() {
                        if g > best {
                            (ie, ia, best) = (i, j, g);
                        }
                    }
                }
                // Index range around `peak` over which `g(i)` keeps falling away from it.
                let walk = |grid: &[f64], peak: usize, g: &dyn Fn(usize) -> f64| {
                    if grid.len() < 2 {
                        return (-half_pi, half_pi);
                    }
                    let mut lo = peak;
                    while lo > 0 && g(lo - 1) <= g(lo) {
                        lo -= 1;
                    }
                    let mut hi = peak;
                    while hi + 1 < grid.len() && g(hi + 1) <= g(hi) {
                        hi += 1;
                    }
                    (
                        grid[lo].to_radians().max(-half_pi),
                        grid[hi].to_radians().min(half_pi),
                    )
                };
                let (a0, a1) = walk(azimuth_deg, ia, &|j| gain_dbi[ie][j]);
                let (e0, e1) = walk(elevation_deg, ie, &|i| gain_dbi[i][ia]);
                [a0, a1, e0, e1]
            }
        }
    }

    /// Gain in a direction, dBi.
    pub fn gain_dbi(&self, azimuth_rad: f64, elevation_rad: f64) -> f64 {
        match self {
            AntennaPattern::Parametric {
                shape,
                peak_gain_dbi,
                azimuth_beamwidth_deg,
                elevation_beamwidth_deg,
            } => {
                let th_az = azimuth_beamwidth_deg.to_radians();
                let th_el = elevation_beamwidth_deg.to_radians();
                match shape {
                    BeamShape::Gaussian => {
                        // 10 log10(exp(−4 ln2 x²)) = −4 ln2 · 10/ln10 · x² = −12.04 x² dB.
                        let k = 40.0 * std::f64::consts::LN_2 / std::f64::consts::LN_10;
                        peak_gain_dbi
                            - k * ((azimuth_rad / th_az).powi(2) + (elevation_rad / th_el).powi(2))
                    }
                    BeamShape::CosPower => {
                        let term = |a: f64, th: f64| {
                            let c = a.cos();
                            if c <= 1e-12 {
                                return -300.0;
                            }
                            let n = 0.5f64.ln() / (0.5 * th).min(3.1).cos().ln();
                            10.0 * n * c.log10()
                        };
                        peak_gain_dbi + term(azimuth_rad, th_az) + term(elevation_rad, th_el)
                    }
                }
            }
            AntennaPattern::Table {
                azimuth_deg,
                elevation_deg,
                gain_dbi,
            } => {
                let (ia, fa) = bracket(azimuth_deg, azimuth_rad.to_degrees());
                let (ie, fe) = bracket(elevation_deg, elevation_rad.to_degrees());
                let ia1 = (ia + 1).min(azimuth_deg.len() - 1);
                let ie1 = (ie + 1).min(elevation_deg.len() - 1);
                let g0 = gain_dbi[ie][ia] * (1.0 - fa) + gain_dbi[ie][ia1] * fa;
                let g1 = gain_dbi[ie1][ia] * (1.0 - fa) + gain_dbi[ie1][ia1] * fa;
                g0 * (1.0 - fe) + g1 * fe
            }
        }
    }
}

/// Index `i` and fraction `f` with `x ≈ grid[i]·(1−f) + grid[i+1]·f`, clamped to the grid.
fn bracket(grid: &[f64], x: f64) -> (usize, f64) {
    let n = grid.len();
    if n == 1 || x <= grid[0] {
        return (0, 0.0);
    }
    if x >= grid[n - 1] {
        return (n - 1, 0.0);
    }
    let i = grid.partition_point(|&g| g <= x) - 1;
    (i, (x - grid[i]) / (grid[i + 1] - grid[i]))
}

/// Transmit power, antenna patterns, receiver noise figure.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FrontEndConfig {
    /// Transmit power per Tx antenna at the antenna port, dBm (TI AWR1843: 12 dBm).
    pub tx_power_dbm: f64,
    /// Gain pattern of every Tx antenna.
    pub tx_pattern: AntennaPattern,
    /// Gain pattern of every Rx antenna.
    pub rx_pattern: AntennaPattern,
    /// Receiver noise figure, dB (automotive 10–15 dB, physics.md §1.1; 12 dB guessed typical).
    pub noise_figure_db: f64,
    /// Lumped system losses L_sys (radome, feed lines, processing), dB (3 dB guessed, as the worked
    /// example of physics.md §1.1).
    pub system_losses_db: f64,
    /// Noise reference temperature T₀, K (290 K: IEEE standard noise-figure reference).
    pub noise_temperature_k: f64,
    /// Polarisation of the Tx and Rx antennas.
    pub polarisation: Polarisation,
    /// Receiver input 1 dB compression point, dBm (`radar.receiver_compression`). Guessed typical
    /// value: −5 dBm, the order of magnitude of integrated 77 GHz receivers (TI AWR1843 datasheet,
    /// SWRS222, lists an in-band P1dB of about −5 dBm at the RX input).
    pub input_p1db_dbm: f64,
    /// Smoothness p of the Rapp AM/AM model `g = 1/(1+(A/A_sat)^{2p})^{1/2p}` (Rapp, "Effects of HPA
    /// nonlinearity on a 4-DPSK/OFDM signal", ECSC 1991). Guessed typical value 2 (solid-state
    /// amplifiers: p ≈ 2–3).
    pub rapp_smoothness: f64,
    /// ADC full scale referred to the receiver input: a sine of this power reaches full scale on I
    /// and Q, dBm. Guessed typical value −3 dBm (IF gain set so that full scale sits 2 dB above the
    /// default P1dB).
    pub adc_full_scale_dbm: f64,
}

impl Default for FrontEndConfig {
    fn default() -> Self {
        FrontEndConfig {
            tx_power_dbm: 12.0,
            tx_pattern: AntennaPattern::default(),
            rx_pattern: AntennaPattern::default(),
            noise_figure_db: 12.0,
            system_losses_db: 3.0,
            noise_temperature_k: 290.0,
            polarisation: Polarisation::H,
            input_p1db_dbm: -5.0,
            rapp_smoothness: 2.0,
            adc_full_scale_dbm: -3.0,
        }
    }
}

impl FrontEndConfig {
    /// Check the values; errors name the key (`radar.front_end.<key>`).
    pub fn validate(&self) -> Result<(), ModelError> {
        for (k, v) in [
            ("tx_power_dbm", self.tx_power_dbm),
            ("noise_figure_db", self.noise_figure_db),
            ("system_losses_db", self.system_losses_db),
            ("input_p1db_dbm", self.input_p1db_dbm),
            ("adc_full_scale_dbm", self.adc_full_scale_dbm),
        ] {
            if !v.is_finite() {
                return Err(ModelError::Config(format!(
                    "`radar.front_end.{k}` must be finite, got {v}"
                )));
            }
        }
        if self.noise_figure_db < 0.0 {
            return Err(ModelError::Config(format!(
                "`radar.front_end.noise_figure_db` must be ≥ 0 dB, got {}",
                self.noise_figure_db
            )));
        }
        if !(self.noise_temperature_k.is_finite() && self.noise_temperature_k > 0.0) {
            return Err(ModelError::Config(format!(
                "`radar.front_end.noise_temperature_k` must be > 0 K, got {}",
                self.noise_temperature_k
            )));
        }
        if !(self.rapp_smoothness.is_finite() && (0.1..=100.0).contains(&self.rapp_smoothness)) {
            return Err(ModelError::Config(format!(
                "`radar.front_end.rapp_smoothness` must be in [0.1, 100], got {}",
                self.rapp_smoothness
            )));
        }
        self.tx_pattern.validate("radar.front_end.tx_pattern")?;
        self.rx_pattern.validate("radar.front_end.rx_pattern")?;
        Ok(())
    }

    /// Transmit power, W.
    pub fn tx_power_w(&self) -> f64 {
        1e-3 * 10f64.powf(self.tx_power_dbm / 10.0)
    }

    /// Noise power spectral density at the receiver input `k T₀ F_n`, W/Hz.
    pub fn noise_psd_w_per_hz(&self) -> f64 {
        BOLTZMANN_J_PER_K * self.noise_temperature_k * 10f64.powf(self.noise_figure_db / 10.0)
    }
}

/// The gains a model applies (patterns under the `radar.antenna_pattern` switch).
#[derive(Debug, Clone, PartialEq)]
pub struct Antennas {
    tx: AntennaPattern,
    rx: AntennaPattern,
    patterned: bool,
}

impl Antennas {
    /// From a front end and the effect switches (declares [`ANTENNA_PATTERN`]).
    pub fn new(front_end: &FrontEndConfig, effects: &Effects) -> Antennas {
        Antennas {
            tx: front_end.tx_pattern.clone(),
            rx: front_end.rx_pattern.clone(),
            patterned: effects.is_on(&ANTENNA_PATTERN),
        }
    }

    /// Tx gain towards (az, el), dBi (peak gain with the pattern switched off).
    pub fn tx_gain_dbi(&self, azimuth_rad: f64, elevation_rad: f64) -> f64 {
        if self.patterned {
            self.tx.gain_dbi(azimuth_rad, elevation_rad)
        } else {
            self.tx.peak_gain_dbi()
        }
    }

    /// Rx gain from (az, el), dBi.
    pub fn rx_gain_dbi(&self, azimuth_rad: f64, elevation_rad: f64) -> f64 {
        if self.patterned {
            self.rx.gain_dbi(azimuth_rad, elevation_rad)
        } else {
            self.rx.peak_gain_dbi()
        }
    }

    /// The two-way main lobe, `[az_min, az_max, el_min, el_max]` rad: the intersection of the Tx
    /// and Rx main lobes ([`AntennaPattern::main_lobe_rad`]); the whole front half-space (±90°)
    /// with the pattern switched off (every direction gets the peak gain).
    pub fn main_lobe_rad(&self) -> [f64; 4] {
        let h = 0.5 * std::f64::consts::PI;
        if !self.patterned {
            return [-h, h, -h, h];
        }
        let (t, r) = (self.tx.main_lobe_rad(), self.rx.main_lobe_rad());
        [
            t[0].max(r[0]),
            t[1].min(r[1]),
            t[2].max(r[2]),
            t[3].min(r[3]),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gaussian_and_cos_power_are_3db_down_at_half_beamwidth() {
        for shape in [BeamShape::Gaussian, BeamShape::CosPower] {
            let p = AntennaPattern::Parametric {
                shape,
                peak_gain_dbi: 10.0,
                azimuth_beamwidth_deg: 40.0,
                elevation_beamwidth_deg: 10.0,
            };
            assert!((p.gain_dbi(0.0, 0.0) - 10.0).abs() < 1e-9);
            let g = p.gain_dbi(20f64.to_radians(), 0.0);
            assert!(
                (g - (10.0 - 10.0 * 2f64.log10())).abs() < 1e-6,
                "{shape:?}: {g}"
            );
            let g = p.gain_dbi(0.0, (-5f64).to_radians());
            assert!(
                (g - (10.0 - 10.0 * 2f64.log10())).abs() < 1e-6,
                "{shape:?}: {g}"
            );
        }
    }

    #[test]
    fn gaussian_main_lobe_ends_at_the_first_null_of_the_equivalent_uniform_aperture() {
        // Independent closed form: a uniform aperture of length D has the field pattern
        // sin(u)/u, u = π (D/λ) sin θ (Balanis §6.3). Choose D/λ so that its half-power point
        // (sinc² = ½, u = 1.39156) sits at θ₃/2; its first null (u = π) is the lobe's edge.
        for (th3_deg, az) in [(12.0f64, true), (30.0, false), (8.0, true)] {
            let p = AntennaPattern::Parametric {
                shape: BeamShape::Gaussian,
                peak_gain_dbi: 10.0,
                azimuth_beamwidth_deg: if az { th3_deg } else { 50.0 },
                elevation_beamwidth_deg: if az { 50.0 } else { th3_deg },
            };
            let d_over_lambda =
                1.39156 / (std::f64::consts::PI * (0.5 * th3_deg.to_radians()).sin());
            let field = |th: f64| {
                let u = std::f64::consts::PI * d_over_lambda * th.sin();
                u.sin() / u
            };
            let lobe = p.main_lobe_rad();
            let edge = if az { lobe[1] } else { lobe[3] };
            assert!((field(0.5 * th3_deg.to_radians()).powi(2) - 0.5).abs() < 1e-4);
            assert!(
                field(edge).abs() < 2e-3,
                "{th3_deg}°: edge {}°",
                edge.to_degrees()
            );
            assert!(field(0.98 * edge) > 0.0);
            let lo = if az { lobe[0] } else { lobe[2] };
            assert_eq!(lo, -edge);
        }
        // A beam wider than the uniform aperture's widest main lobe: the whole front half-space.
        let wide = AntennaPattern::default().main_lobe_rad();
        assert_eq!(wide[1], 0.5 * std::f64::consts::PI);
        let cos = AntennaPattern::Parametric {
            shape: BeamShape::CosPower,
            peak_gain_dbi: 10.0,
            azimuth_beamwidth_deg: 20.0,
            elevation_beamwidth_deg: 20.0,
        };
        assert_eq!(cos.main_lobe_rad()[3], 0.5 * std::f64::consts::PI);
    }

    #[test]
    fn table_main_lobe_runs_to_the_first_minimum() {
        // Peak at 0°, nulls at ±20° (azimuth) and −10° / +10° (elevation), sidelobes beyond.
        let p = AntennaPattern::Table {
            azimuth_deg: vec![-40.0, -20.0, -10.0, 0.0, 10.0, 20.0, 40.0],
            elevation_deg: vec![-20.0, -10.0, 0.0, 10.0, 20.0],
            gain_dbi: vec![
                vec![-5.0; 7],
                vec![-20.0; 7],
                vec![-5.0, -30.0, 7.0, 10.0, 7.0, -30.0, -5.0],
                vec![-20.0; 7],
                vec![-5.0; 7],
            ],
        };
        let l = p.main_lobe_rad();
        let deg = |x: f64| x.to_degrees();
        assert!((deg(l[0]) + 20.0).abs() < 1e-9 && (deg(l[1]) - 20.0).abs() < 1e-9);
        assert!((deg(l[2]) + 10.0).abs() < 1e-9 && (deg(l[3]) - 10.0).abs() < 1e-9);
        let fe = FrontEndConfig {
            rx_pattern: p,
            ..FrontEndConfig::default()
        };
        let mut e = Effects::new(&[crate::world::effects(), crate::radar::effects()].concat());
        let two_way = Antennas::new(&fe, &e).main_lobe_rad();
        // Intersection with the default Tx (Gaussian 60° × 12°: ±90°, ±13.6°).
        assert!((deg(two_way[3]) - 10.0).abs() < 1e-9 && (deg(two_way[1]) - 20.0).abs() < 1e-9);
        e.set(ANTENNA_PATTERN.name, false).unwrap();
        assert_eq!(
            Antennas::new(&fe, &e).main_lobe_rad()[3],
            0.5 * std::f64::consts::PI
        );
    }

    #[test]
    fn table_interpolates_bilinearly_and_clamps() {
        let p = AntennaPattern::Table {
            azimuth_deg: vec![-10.0, 0.0, 10.0],
            elevation_deg: vec![0.0, 10.0],
            gain_dbi: vec![vec![0.0, 10.0, 0.0], vec![-10.0, 0.0, -10.0]],
        };
        p.validate("t").unwrap();
        assert!((p.gain_dbi(5f64.to_radians(), 0.0) - 5.0).abs() < 1e-9);
        assert!((p.gain_dbi(0.0, 5f64.to_radians()) - 5.0).abs() < 1e-9);
        assert!((p.gain_dbi(0.0, 50f64.to_radians()) - 0.0).abs() < 1e-9);
        assert_eq!(p.peak_gain_dbi(), 10.0);
        let bad = AntennaPattern::Table {
            azimuth_deg: vec![0.0, 0.0],
            elevation_deg: vec![0.0],
            gain_dbi: vec![vec![0.0, 0.0]],
        };
        assert!(
            bad.validate("k")
                .unwrap_err()
                .to_string()
                .contains("azimuth_deg")
        );
    }
}
