//! Signal-processing parameters and the pieces of the chain that do not touch the cube: FFT
//! windows, CFAR thresholds (CA / OS / GO / SO) for square-law detection with non-coherent
//! integration over the virtual channels, peak interpolation.
//!
//! The detection side of [`RadarChain`](super::baseband::RadarChain) that runs on the
//! range-Doppler map lives in the submodules, as further `impl RadarChain` blocks: `cfar.rs` (the
//! 2-D CFAR that uses these thresholds) and `angle.rs` (per hit: interpolation, TDM velocity
//! disambiguation, angle estimation, angle gate, power and object id).
//!
//! CFAR (Richards, *Fundamentals of Radar Signal Processing* 2nd ed. §6.5; physics.md §1.7): the
//! cell under test `X` is compared with `T = α ẑ`, `ẑ` an estimate of the noise level from the
//! reference cells around it (guard cells excluded). The range-Doppler power map sums `|X_k|²`
//! over the `L` virtual channels, so in noise a cell is Gamma(L, σ²) distributed (exponential for
//! L = 1). The false-alarm probabilities used to solve for `α`:
//! * CA (ẑ = mean of N cells, their sum Y ~ Gamma(N L)):
//!   `P_FA = Σ_{i<L} C(NL+i−1, i) cⁱ / (1+c)^{NL+i}`, `c = α/N` (for L = 1 this is
//!   `(1 + α/N)^−N`, i.e. `α = N(P_FA^{−1/N} − 1)`, Richards eq. 6.145);
//! * OS (ẑ = k-th smallest of N, Richards eq. 6.168 for L = 1; Rohling 1983),
//!   GO / SO (ẑ = larger / smaller of the two half-window means; Hansen & Sawyers 1980,
//!   Trunk 1978): `P_FA = E[Q_L(α ẑ)]` with `Q_L(x) = e^{−x} Σ_{i<L} xⁱ/i!`, integrated numerically
//!   over the density of ẑ.

use serde::{Deserialize, Serialize};

use crate::error::ModelError;

// The detection side of `RadarChain` (second `impl` blocks; the waveform side is in `baseband.rs`).
mod angle;
mod cfar;

pub(super) use angle::SteerPlan;

/// Upper bound of `ProcessingConfig::max_angle_peaks_per_cell`.
pub const MAX_ANGLE_PEAKS: usize = 8;

/// FFT window.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Window {
    /// No taper (3 dB main-lobe width 0.89 bins, first sidelobe −13 dB).
    Rectangular,
    /// Hann, DFT-even (1.44 bins, −31.5 dB; Harris 1978 Table 1).
    #[default]
    Hann,
    /// Hamming (1.30 bins, −43 dB).
    Hamming,
    /// Blackman (1.68 bins, −58 dB).
    Blackman,
}

impl Window {
    /// The DFT-even window of length `n` (Harris, "On the use of windows for harmonic analysis with
    /// the discrete Fourier transform", Proc. IEEE 66(1), 1978).
    pub fn coefficients(self, n: usize) -> Vec<f32> {
        (0..n)
            .map(|i| {
                let x = 2.0 * std::f64::consts::PI * i as f64 / n as f64;
                (match self {
                    Window::Rectangular => 1.0,
                    Window::Hann => 0.5 - 0.5 * x.cos(),
                    Window::Hamming => 0.54 - 0.46 * x.cos(),
                    Window::Blackman => 0.42 - 0.5 * x.cos() + 0.08 * (2.0 * x).cos(),
                }) as f32
            })
            .collect()
    }

    /// Main-lobe half width (peak to first null) in resolution cells (one cell = one bin of the
    /// un-padded DFT, `2/N` in sin-space for an `N`-element λ/2 array): 1 for the rectangular
    /// window, 2 for Hann and Hamming (raised cosines), 3 for Blackman (Harris 1978 §IV, Table 1).
    pub fn main_lobe_half_width_bins(self) -> f64 {
        match self {
            Window::Rectangular => 1.0,
            Window::Hann | Window::Hamming => 2.0,
            Window::Blackman => 3.0,
        }
    }

    /// 3 dB main-lobe width in bins (Harris 1978 Table 1).
    pub fn half_power_width_bins(self) -> f64 {
        match self {
            Window::Rectangular => 0.89,
            Window::Hann => 1.44,
            Window::Hamming => 1.30,
            Window::Blackman => 1.68,
        }
    }
}

/// CFAR variant.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CfarKind {
    /// Cell averaging.
    #[default]
    Ca,
    /// Ordered statistic (k-th smallest reference cell, `os_rank` · N).
    Os,
    /// Greatest-of the two half windows (range-leading / range-lagging): robust at clutter edges.
    Go,
    /// Smallest-of the two half windows: resolves close targets, higher loss.
    So,
}

/// 2-D CFAR over the range-Doppler map.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CfarConfig {
    /// Variant.
    pub kind: CfarKind,
    /// Configured false-alarm probability per tested cell.
    pub p_fa: f64,
    /// Guard cells on each side in range.
    pub guard_range: usize,
    /// Guard cells on each side in Doppler.
    pub guard_doppler: usize,
    /// Training cells on each side (beyond the guard cells) in range.
    pub train_range: usize,
    /// Training cells on each side (beyond the guard cells) in Doppler.
    pub train_doppler: usize,
    /// OS-CFAR rank as a fraction of the reference cells (0.75: Rohling 1983).
    pub os_rank: f64,
}

impl Default for CfarConfig {
    fn default() -> Self {
        CfarConfig {
            kind: CfarKind::Ca,
            p_fa: 1e-6,
            guard_range: 2,
            guard_doppler: 2,
            train_range: 4,
            train_doppler: 4,
            os_rank: 0.75,
        }
    }
}

/// Signal-processing parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ProcessingConfig {
    /// Window of the range FFT.
    pub range_window: Window,
    /// Window of the Doppler FFT.
    pub doppler_window: Window,
    /// Window over the virtual array before the angle FFT (rows and columns of the λ/2 grid).
    pub angle_window: Window,
    /// CFAR detector.
    pub cfar: CfarConfig,
    /// Keep only CFAR cells that are local maxima of the map (8 neighbours); `false` reports every
    /// threshold crossing.
    pub peak_grouping: bool,
    /// With `peak_grouping`: group in range per direction instead of on the channel-summed map.
    /// The CFAR keeps the cells that are local maxima along Doppler only; after the angle fit, a
    /// detection is kept when the beam power in its direction, `|Σ_k w_k x_k e_k*|²`, is at least
    /// that of the range cells on either side (same Doppler bin, same direction). On the summed
    /// map a car's scattering centres in adjacent range cells at different azimuths are one
    /// maximum (the strongest hides the rest: a car at 50 m gave 1–2 cells); an array that
    /// resolves them in angle keeps them, while the range main lobe of each one (Hann: ±1 cell)
    /// still gives a single detection. The cost is the angle fit of every range cell of an
    /// extended target instead of its local maxima.
    pub peak_grouping_per_angle: bool,
    /// Azimuth angle FFT length (zero-padded; ≥ the horizontal aperture in λ/2).
    pub angle_fft_azimuth: usize,
    /// Elevation search resolution: with three or more occupied rows the elevation is the maximum
    /// of the row beam over `8 ·` this many points in sin-space (two rows: closed form).
    pub angle_fft_elevation: usize,
    /// Compensate the TDM-MIMO Doppler phase of each Tx slot before the angle FFT.
    pub tdm_doppler_compensation: bool,
    /// Resolve the TDM-MIMO Doppler ambiguity (with `tdm_doppler_compensation` and TDM-MIMO): a
    /// range rate beyond the unambiguous ±v_max = λ/(4 N_tx T_c) folds into the Doppler spectrum
    /// with an unknown multiple of 2 v_max, which leaves Tx slot t a phase error of 2π m t / N_tx
    /// after the compensation; each of the N_tx hypotheses m is compensated and the one whose
    /// beam (inside the angle gate) is strongest is kept (TI TIDUD31B "Angle estimation with
    /// TDM-MIMO and velocity ambiguity"; Rao et al., US 2018/0011170 A1). The range rate is
    /// reported unfolded, within ±N_tx v_max. `false`: the folded range rate compensates the slots.
    pub velocity_disambiguation: bool,
    /// Report only detections whose estimated direction lies inside the angle gate: the declared
    /// field of view (`fov_horizontal_rad` × `fov_vertical_rad`, symmetric) ∩ the two-way main
    /// lobe of the Tx and Rx patterns (`radar::antenna::Antennas::main_lobe_rad`). Outside it a
    /// radar cannot tell a target from a sidelobe, grating-lobe or multipath-corrupted angle
    /// estimate, and its antenna gain (the RCS estimate divides by it) is not the main lobe's;
    /// production chains drop such points (TI mmWave SDK: the `aoaFovCfg` command,
    /// `DPU_Aoa2dProc_AoaFovCfg` — minimum / maximum azimuth and elevation of the points exported
    /// to the host). Sparse arrays: angle
    /// estimates are folded into the array's unambiguous sine interval first (a grating-lobe peak
    /// of an in-range target is reported at the target).
    pub field_of_view_gate: bool,
    /// Detections below this processed SNR are dropped, dB.
    pub min_snr_db: f64,
    /// Several targets in one range-Doppler cell: an angle peak is reported when its beam power is
    /// within this many dB of the cell's strongest angle peak (it must also clear the noise-referred
    /// threshold and be at least one angular resolution cell from every stronger peak), dB.
    pub angle_peak_dynamic_range_db: f64,
    /// At most this many angle peaks (detections) per range-Doppler cell (1 ..= 8; 1: one angle
    /// per cell).
    pub max_angle_peaks_per_cell: usize,
    /// At most this many detections per frame (the strongest are kept).
    pub max_detections: usize,
}

impl Default for ProcessingConfig {
    fn default() -> Self {
        ProcessingConfig {
            range_window: Window::Hann,
            doppler_window: Window::Hann,
            angle_window: Window::Rectangular,
            cfar: CfarConfig::default(),
            peak_grouping: true,
            peak_grouping_per_angle: false,
            angle_fft_azimuth: 64,
            angle_fft_elevation: 16,
            tdm_doppler_compensation: true,
            velocity_disambiguation: true,
            field_of_view_gate: true,
            min_snr_db: f64::NEG_INFINITY,
            angle_peak_dynamic_range_db: 15.0,
            max_angle_peaks_per_cell: 4,
            max_detections: 1024,
        }
    }
}

impl ProcessingConfig {
    /// Check the values; errors name the key (`radar.processing.<key>`).
    pub fn validate(&self) -> Result<(), ModelError> {
        let err =
            |k: &str, m: String| Err(ModelError::Config(format!("`radar.processing.{k}` {m}")));
        let c = &self.cfar;
        if !(c.p_fa > 0.0 && c.p_fa < 0.5) {
            return err("cfar.p_fa", format!("must be in (0, 0.5), got {}", c.p_fa));
        }
        if c.train_range + c.train_doppler == 0 {
            return err(
                "cfar.train_range",
                "and `cfar.train_doppler` cannot both be 0".into(),
            );
        }
        if c.guard_range + c.train_range > 64 || c.guard_doppler + c.train_doppler > 64 {
            return err(
                "cfar.guard_range",
                "guard + training cells must be ≤ 64 per side".into(),
            );
        }
        if !(c.os_rank > 0.0 && c.os_rank <= 1.0) {
            return err(
                "cfar.os_rank",
                format!("must be in (0, 1], got {}", c.os_rank),
            );
        }
        for (k, v) in [
            ("angle_fft_azimuth", self.angle_fft_azimuth),
            ("angle_fft_elevation", self.angle_fft_elevation),
        ] {
            if !(2..=4096).contains(&v) {
                return err(k, format!("must be in 2..=4096, got {v}"));
            }
        }
        if self.min_snr_db.is_nan() {
            return err("min_snr_db", "must be a number".into());
        }
        if !(self.angle_peak_dynamic_range_db.is_finite()
            && self.angle_peak_dynamic_range_db >= 0.0)
        {
            return err(
                "angle_peak_dynamic_range_db",
                format!(
                    "must be finite and ≥ 0, got {}",
                    self.angle_peak_dynamic_range_db
                ),
            );
        }
        if !(1..=MAX_ANGLE_PEAKS).contains(&self.max_angle_peaks_per_cell) {
            return err(
                "max_angle_peaks_per_cell",
                format!(
                    "must be in 1..={MAX_ANGLE_PEAKS}, got {}",
                    self.max_angle_peaks_per_cell
                ),
            );
        }
        Ok(())
    }
}

/// `Q_L(x) = P(Gamma(L, 1) > x) = e^{−x} Σ_{i<L} xⁱ/i!` (integer shape).
pub fn gamma_survival(shape: usize, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    // Terms e^{−x} xⁱ/i! in the log domain (no overflow for large shapes).
    let lx = x.ln();
    let mut lt = -x;
    let mut sum = lt.exp();
    for i in 1..shape {
        lt += lx - (i as f64).ln();
        sum += lt.exp();
    }
    sum.min(1.0)
}

/// CA-CFAR false-alarm probability for threshold `c · Y` with Y the sum of `n` reference cells,
/// each Gamma(`l`), and the cell under test Gamma(`l`).
pub fn pfa_ca(c: f64, n: usize, l: usize) -> f64 {
    let nl = (n * l) as f64;
    let r = c / (1.0 + c);
    let mut term = (-(nl) * (1.0 + c).ln()).exp();
    let mut sum = term;
    for i in 0..l.saturating_sub(1) {
        term *= (nl + i as f64) / (i as f64 + 1.0) * r;
        sum += term;
    }
    sum
}

/// Solve a decreasing `pfa(c) = target` for c > 0 by bisection in log c.
fn solve_decreasing(target: f64, pfa: impl Fn(f64) -> f64) -> f64 {
    let (mut lo, mut hi) = (1e-9f64.ln(), 1e6f64.ln());
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        if pfa(mid.exp()) > target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    (0.5 * (lo + hi)).exp()
}

/// Quadrature of the density of a reference statistic: nodes z and weights w (Σ w ≈ 1).
struct Density {
    z: Vec<f64>,
    w: Vec<f64>,
}

impl Density {
    /// On a grid over [0, hi] from a log-density.
    fn from_log_pdf(hi: f64, log_pdf: impl Fn(f64) -> f64) -> Density {
        const N: usize = 4000;
        let h = hi / N as f64;
        let z: Vec<f64> = (1..=N).map(|i| (i as f64 - 0.5) * h).collect();
        let mut w: Vec<f64> = z.iter().map(|&z| log_pdf(z).exp() * h).collect();
        let s: f64 = w.iter().sum();
        w.iter_mut().for_each(|w| *w /= s);
        Density { z, w }
    }

    fn pfa(&self, c: f64, l: usize) -> f64 {
        self.z
            .iter()
            .zip(&self.w)
            .map(|(z, w)| w * gamma_survival(l, c * z))
            .sum()
    }
}

fn ln_factorial(n: usize) -> f64 {
    (2..=n).map(|i| (i as f64).ln()).sum()
}

/// ln of the Gamma(s, 1) pdf and ln of its CDF / survival at z (integer s).
fn ln_gamma_pdf(s: usize, z: f64) -> f64 {
    (s as f64 - 1.0) * z.ln() - z - ln_factorial(s - 1)
}

/// Gamma(s,1) CDF for integer s, accurate in both tails (series in the lower tail).
fn gamma_cdf(s: usize, z: f64) -> f64 {
    if z <= 0.0 {
        return 0.0;
    }
    if z < s as f64 {
        // P(s, z) = z^s e^{−z} / s! · Σ_k z^k / ((s+1)…(s+k)).
        let mut term = 1.0;
        let mut sum = 1.0;
        for k in 1..2000 {
            term *= z / (s + k) as f64;
            sum += term;
            if term < 1e-17 * sum {
                break;
            }
        }
        (s as f64 * z.ln() - z - ln_factorial(s) + sum.ln())
            .exp()
            .min(1.0)
    } else {
        1.0 - gamma_survival(s, z)
    }
}

/// Threshold multiplier of a CFAR with `n` reference cells over a map whose cells are
/// Gamma(`l`) in noise: detection when `X > α ẑ`, where ẑ is the reference mean (CA), the
/// `rank`-th smallest cell (OS, 1-based) or the larger / smaller half-window mean (GO / SO).
pub fn cfar_alpha(kind: CfarKind, n: usize, l: usize, p_fa: f64, os_rank: f64) -> f64 {
    let n = n.max(1);
    match kind {
        CfarKind::Ca => solve_decreasing(p_fa, |c| pfa_ca(c, n, l)) * n as f64,
        CfarKind::Os => {
            let k = os_rank_index(n, os_rank) + 1;
            let sl = l as f64;
            let hi = sl + 16.0 * sl.sqrt() + 40.0;
            let lnc = ln_factorial(n) - ln_factorial(k - 1) - ln_factorial(n - k);
            let d = Density::from_log_pdf(hi, |z| {
                let f = gamma_cdf(l, z).clamp(1e-300, 1.0);
                let sf = gamma_survival(l, z).max(1e-300);
                lnc + (k - 1) as f64 * f.ln() + (n - k) as f64 * sf.ln() + ln_gamma_pdf(l, z)
            });
            solve_decreasing(p_fa, |c| d.pfa(c, l))
        }
        CfarKind::Go | CfarKind::So => {
            // Half-window sums Y1, Y2 ~ Gamma(M L); ẑ = max or min of the means Y/M.
            let m = (n / 2).max(1);
            let s = m * l;
            let sf = s as f64;
            let hi = sf + 16.0 * sf.sqrt() + 40.0;
            let go = kind == CfarKind::Go;
            let d = Density::from_log_pdf(hi, |y| {
                let f = gamma_cdf(s, y).clamp(1e-300, 1.0);
                let other = if go { f } else { (1.0 - f).max(1e-300) };
                std::f64::consts::LN_2 + other.ln() + ln_gamma_pdf(s, y)
            });
            // Threshold on the sum: X > c·Y; on the mean: α = c·M.
            solve_decreasing(p_fa, |c| d.pfa(c, l)) * m as f64
        }
    }
}

/// 0-based index of the OS-CFAR order statistic among `n` cells.
pub fn os_rank_index(n: usize, os_rank: f64) -> usize {
    ((os_rank * n as f64).ceil() as usize).clamp(1, n) - 1
}

/// Offset of the vertex of the parabola through (−1, a), (0, b), (1, c), in (−0.5, 0.5), and the
/// vertex value.
pub fn parabolic_peak(a: f64, b: f64, c: f64) -> (f64, f64) {
    let den = a - 2.0 * b + c;
    if den >= 0.0 || !den.is_finite() {
        return (0.0, b);
    }
    let d = (0.5 * (a - c) / den).clamp(-0.5, 0.5);
    (d, b - 0.25 * (a - c) * d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ca_alpha_matches_richards_table() {
        // physics.md §1.7: N = 16: α = 12.45 at 1e-4, 21.94 at 1e-6; N = 32: 10.67 / 17.28.
        for (n, p, a) in [
            (16, 1e-4, 12.45),
            (16, 1e-6, 21.94),
            (24, 1e-4, 11.23),
            (32, 1e-6, 17.28),
        ] {
            let got = cfar_alpha(CfarKind::Ca, n, 1, p, 0.75);
            assert!((got - a).abs() < 0.01, "N={n} P_FA={p}: {got} vs {a}");
            let closed = n as f64 * (p.powf(-1.0 / n as f64) - 1.0);
            assert!((got - closed).abs() < 1e-6);
        }
    }

    #[test]
    fn os_alpha_matches_richards_eq_6_168() {
        // L = 1: P_FA = Π_{i=0}^{k−1} (N − i)/(N − i + α).
        let (n, p) = (24usize, 1e-4);
        let k = os_rank_index(n, 0.75) + 1;
        let alpha = cfar_alpha(CfarKind::Os, n, 1, p, 0.75);
        let pfa: f64 = (0..k)
            .map(|i| (n - i) as f64 / ((n - i) as f64 + alpha))
            .product();
        assert!((pfa / p - 1.0).abs() < 0.02, "{pfa}");
    }

    #[test]
    fn go_so_and_noncoherent_alphas_are_ordered() {
        let (n, l, p) = (40, 12, 1e-4);
        let ca = cfar_alpha(CfarKind::Ca, n, l, p, 0.75);
        let go = cfar_alpha(CfarKind::Go, n, l, p, 0.75);
        let so = cfar_alpha(CfarKind::So, n, l, p, 0.75);
        assert!(so > ca && ca > go, "{so} {ca} {go}");
        // Non-coherent integration of L = 12 channels: the threshold over the mean is far lower
        // than for L = 1 (Gamma(12) is concentrated around its mean); large-N limit: the Gamma(12)
        // survival at α·12/12.
        assert!(ca < cfar_alpha(CfarKind::Ca, n, 1, p, 0.75));
        let asymptotic = solve_decreasing(p, |x| gamma_survival(l, x)) / l as f64;
        assert!(
            ca > asymptotic && ca < 1.25 * asymptotic,
            "{ca} {asymptotic}"
        );
    }

    #[test]
    fn parabola_vertex() {
        let f = |x: f64| 3.0 - (x - 0.3) * (x - 0.3);
        let (d, v) = parabolic_peak(f(-1.0), f(0.0), f(1.0));
        assert!((d - 0.3).abs() < 1e-12 && (v - 3.0).abs() < 1e-12);
    }
}
