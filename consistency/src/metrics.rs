//! Residual metrics: bias/scatter split, RMS/MAE/max with tolerances, bootstrap CIs, binned metrics,
//! and distribution metrics where pairing is impossible: AVM (= Wasserstein-1 in 1-D, Ferson &
//! Oberkampf 2009) and the DVM pair (bias = difference of the means, CAVM = area between the ECDFs
//! after removing that bias; Rosenberger et al. 2019 — we fix the bias as the mean, see
//! validation.md §3).

use serde::Serialize;

use super::campaign::Campaign;
use super::{Row, quantity, tolerance_of};

/// A small deterministic PRNG (SplitMix64, Steele et al. 2014) for bootstrap resampling.
#[derive(Debug, Clone)]
pub struct SplitMix(pub u64);

impl SplitMix {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, n).
    pub fn below(&mut self, n: usize) -> usize {
        ((self.next_u64() >> 11) as f64 / (1u64 << 53) as f64 * n as f64) as usize % n.max(1)
    }
    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Standard normal (Box–Muller).
    pub fn normal(&mut self) -> f64 {
        let u1 = self.unit().max(1e-300);
        let u2 = self.unit();
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }
}

/// Statistics of paired residuals (meas − sim) in the quantity's unit.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct ResidualStats {
    pub n: usize,
    pub bias: f64,
    pub sd: f64,
    pub rms: f64,
    pub mae: f64,
    pub max_abs: f64,
    pub p95_abs: f64,
    /// Fraction of residuals within ±tolerance.
    pub within_tolerance: f64,
    /// 95 % bootstrap CI of the RMS.
    pub rms_ci: [f64; 2],
    /// 95 % bootstrap CI of the bias.
    pub bias_ci: [f64; 2],
}

/// Residual statistics with a 95 % percentile bootstrap (200 resamples, seeded).
pub fn residual_stats(r: &[f64], tol: f64, seed: u64) -> ResidualStats {
    let n = r.len();
    if n == 0 {
        return ResidualStats::default();
    }
    let nf = n as f64;
    let bias = r.iter().sum::<f64>() / nf;
    let rms = (r.iter().map(|v| v * v).sum::<f64>() / nf).sqrt();
    let sd = if n > 1 {
        (r.iter().map(|v| (v - bias).powi(2)).sum::<f64>() / (nf - 1.0)).sqrt()
    } else {
        0.0
    };
    let mut abs: Vec<f64> = r.iter().map(|v| v.abs()).collect();
    abs.sort_by(f64::total_cmp);
    let p95 = abs[((0.95 * (nf - 1.0)).round() as usize).min(n - 1)];
    let mut rng = SplitMix(seed ^ 0x5eed);
    let (mut rmss, mut biases) = (Vec::with_capacity(200), Vec::with_capacity(200));
    for _ in 0..200 {
        let (mut s, mut s2) = (0.0, 0.0);
        for _ in 0..n {
            let v = r[rng.below(n)];
            s += v;
            s2 += v * v;
        }
        biases.push(s / nf);
        rmss.push((s2 / nf).sqrt());
    }
    ResidualStats {
        n,
        bias,
        sd,
        rms,
        mae: abs.iter().sum::<f64>() / nf,
        max_abs: abs[n - 1],
        p95_abs: p95,
        within_tolerance: abs.iter().filter(|v| **v <= tol).count() as f64 / nf,
        rms_ci: percentile_ci(&mut rmss),
        bias_ci: percentile_ci(&mut biases),
    }
}

fn percentile_ci(v: &mut [f64]) -> [f64; 2] {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        return [f64::NAN; 2];
    }
    [
        v[(0.025 * (n - 1) as f64) as usize],
        v[(0.975 * (n - 1) as f64).ceil() as usize],
    ]
}

/// The nuisance calibration the attribution fitted (validation.md §5, step 2): per quantity the
/// offset in its unit. The verdict judges the residuals after removing it; the raw RMS is reported
/// beside. LiDAR intensity in % takes the gain of the dB offset fitted on `intensity_db`.
#[derive(Debug, Clone, Default)]
pub struct Calibration {
    offset: std::collections::BTreeMap<String, f64>,
}

impl Calibration {
    /// From the fitted offsets, quantity → offset in its unit.
    pub fn new(offsets: impl IntoIterator<Item = (String, f64)>) -> Calibration {
        Calibration {
            offset: offsets.into_iter().collect(),
        }
    }

    /// The calibration removed from quantity `q`: an offset in `q`'s unit, or for `intensity_pct`
    /// the gain in dB; `None` when the quantity has none.
    pub fn of(&self, q: &str) -> Option<f64> {
        let from = if q == quantity::INTENSITY_PCT {
            quantity::INTENSITY_DB
        } else {
            q
        };
        self.offset.get(from).copied()
    }

    /// The row's residual after removing the calibration: meas − sim − offset, or for intensity
    /// in % meas − sim·10^(gain/10).
    pub fn residual(&self, r: &Row) -> f64 {
        match self.of(r.quantity) {
            Some(g) if r.quantity == quantity::INTENSITY_PCT => {
                r.meas - r.sim * 10f64.powf(g / 10.0)
            }
            Some(o) => r.resid() - o,
            None => r.resid(),
        }
    }
}

/// One verdict-table metric.
#[derive(Debug, Clone, Serialize)]
pub struct Metric {
    /// `<quantity>.rms`, `<quantity>.abs_bias`, `detection_rate.delta`, ...
    pub id: String,
    /// The value the tolerance judges (for a residual RMS: after removing the fitted calibration,
    /// [`Calibration`]).
    pub value: f64,
    /// The RMS of the raw residuals (before the calibration), where `value` is one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub raw_value: Option<f64>,
    /// The calibration removed before judging (offset in the unit; for `intensity_pct` a gain in
    /// dB).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub calibration: Option<f64>,
    pub tolerance: f64,
    pub pass: bool,
    /// 95 % CI of the value.
    pub ci: [f64; 2],
    pub n: usize,
    pub unit: &'static str,
}

/// Unit of a quantity id.
pub fn unit_of(q: &str) -> &'static str {
    match q {
        super::quantity::RANGE_M | super::quantity::RANGE_SD_M => "m",
        super::quantity::RADIAL_VELOCITY_KMH => "km/h",
        super::quantity::AZIMUTH_DEG | super::quantity::ELEVATION_DEG => "deg",
        super::quantity::POWER_DB
        | super::quantity::INTENSITY_DB
        | super::quantity::INTENSITY_SD_DB => "dB",
        super::quantity::INTENSITY_PCT
        | super::quantity::POINTS_ON_TARGET_PCT
        | super::quantity::SCREEN_WIDTH_PCT
        | super::quantity::SCREEN_HEIGHT_PCT
        | super::quantity::RECOGNITION_DISTANCE_PCT => "%",
        super::quantity::GAP_POINTS => "points/frame",
        super::quantity::CLUTTER_COUNT => "detections/band/frame",
        super::quantity::POINTS_LOG_RATIO => "ln ratio",
        _ => "",
    }
}

/// Residuals of one quantity.
pub fn residuals(rows: &[Row], q: &str) -> Vec<f64> {
    rows.iter()
        .filter(|r| r.quantity == q)
        .map(Row::resid)
        .collect()
}

/// The verdict metrics: per quantity the RMS residual after removing the fitted calibration
/// against the tolerance (the raw RMS beside it), plus the detection-rate difference; and per
/// quantity the statistics of the raw residuals (bias and scatter).
pub fn verdict_metrics(
    campaign: &Campaign,
    rows: &[Row],
    counts: &super::pairing::DetectionCounts,
    calibration: &Calibration,
) -> (Vec<Metric>, Vec<(String, ResidualStats)>) {
    let mut metrics = Vec::new();
    let mut stats = Vec::new();
    for (k, q) in super::metric_quantities(campaign.sensor.kind)
        .iter()
        .enumerate()
    {
        let r = residuals(rows, q);
        let tol = tolerance_of(q, &campaign.tolerance);
        if r.is_empty() {
            continue;
        }
        let seed = campaign.split.seed.wrapping_add(k as u64);
        let s = residual_stats(&r, tol, seed);
        let cal = calibration.of(q);
        let judged = match cal {
            Some(_) => {
                let rc: Vec<f64> = rows
                    .iter()
                    .filter(|r| r.quantity == *q)
                    .map(|r| calibration.residual(r))
                    .collect();
                residual_stats(&rc, tol, seed)
            }
            None => s,
        };
        metrics.push(Metric {
            id: format!("{q}.rms"),
            value: judged.rms,
            raw_value: Some(s.rms),
            calibration: cal,
            tolerance: tol,
            pass: judged.rms <= tol,
            ci: judged.rms_ci,
            n: s.n,
            unit: unit_of(q),
        });
        stats.push((q.to_string(), s));
    }
    if counts.opportunities > 0 {
        let pm = counts.meas_detected as f64 / counts.opportunities as f64;
        let ps = counts.sim_detected as f64 / counts.opportunities as f64;
        // Binomial standard error of the difference (independent proportions, normal approx.).
        let n = counts.opportunities as f64;
        let se = ((pm * (1.0 - pm) + ps * (1.0 - ps)) / n).sqrt();
        let d = pm - ps;
        metrics.push(Metric {
            id: "detection_rate.delta".into(),
            value: d,
            raw_value: None,
            calibration: None,
            // osiris default (guess): detection probabilities agree within 0.1.
            tolerance: 0.1,
            pass: d.abs() <= 0.1,
            ci: [d - 1.96 * se, d + 1.96 * se],
            n: counts.opportunities,
            unit: "",
        });
    }
    (metrics, stats)
}

/// Wasserstein-1 distance (= AVM for ECDFs) between two samples, in their unit.
pub fn wasserstein1(a: &[f64], b: &[f64]) -> f64 {
    if a.is_empty() || b.is_empty() {
        return f64::NAN;
    }
    let mut a: Vec<f64> = a.to_vec();
    let mut b: Vec<f64> = b.to_vec();
    a.sort_by(f64::total_cmp);
    b.sort_by(f64::total_cmp);
    let mut all: Vec<f64> = a.iter().chain(&b).copied().collect();
    all.sort_by(f64::total_cmp);
    let (na, nb) = (a.len() as f64, b.len() as f64);
    let (mut ia, mut ib) = (0usize, 0usize);
    let mut area = 0.0;
    for w in all.windows(2) {
        while ia < a.len() && a[ia] <= w[0] {
            ia += 1;
        }
        while ib < b.len() && b[ib] <= w[0] {
            ib += 1;
        }
        area += (ia as f64 / na - ib as f64 / nb).abs() * (w[1] - w[0]);
    }
    area
}

/// Distribution metrics of one quantity.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct DistributionMetrics {
    /// AVM = W1 between the measured and simulated ECDFs.
    pub avm: f64,
    /// DVM bias: mean(meas) − mean(sim).
    pub dvm_bias: f64,
    /// DVM CAVM: W1 after shifting the simulation by the bias (scatter mismatch).
    pub dvm_cavm: f64,
    pub n_meas: usize,
    pub n_sim: usize,
}

pub fn distribution_metrics(meas: &[f64], sim: &[f64]) -> Option<DistributionMetrics> {
    if meas.is_empty() || sim.is_empty() {
        return None;
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let bias = mean(meas) - mean(sim);
    let shifted: Vec<f64> = sim.iter().map(|v| v + bias).collect();
    Some(DistributionMetrics {
        avm: wasserstein1(meas, sim),
        dvm_bias: bias,
        dvm_cavm: wasserstein1(meas, &shifted),
        n_meas: meas.len(),
        n_sim: sim.len(),
    })
}

/// A 2-D binned metric: mean residual, RMS and out-of-tolerance fraction per cell.
#[derive(Debug, Clone, Serialize)]
pub struct BinnedMetric {
    pub quantity: String,
    pub x_var: String,
    pub y_var: String,
    pub x_edges: Vec<f64>,
    pub y_edges: Vec<f64>,
    /// `cells[iy][ix]`; `None` = empty bin (a coverage hole).
    pub mean: Vec<Vec<Option<f64>>>,
    pub rms: Vec<Vec<Option<f64>>>,
    pub out_of_tolerance: Vec<Vec<Option<f64>>>,
    pub count: Vec<Vec<usize>>,
    pub tolerance: f64,
}

fn bin_of(edges: &[f64], v: f64) -> Option<usize> {
    if !(v >= edges[0] && v <= edges[edges.len() - 1]) {
        return None;
    }
    Some(
        edges
            .windows(2)
            .position(|w| v >= w[0] && v <= w[1])
            .unwrap_or(0),
    )
}

/// Bins the residuals of `q` over (x_var, y_var).
pub fn binned(
    rows: &[Row],
    q: &str,
    tol: f64,
    (x_var, xi, x_edges): (&str, usize, &[f64]),
    (y_var, yi, y_edges): (&str, usize, &[f64]),
) -> BinnedMetric {
    let (nx, ny) = (x_edges.len() - 1, y_edges.len() - 1);
    let mut sum = vec![vec![0.0; nx]; ny];
    let mut sum2 = vec![vec![0.0; nx]; ny];
    let mut out = vec![vec![0usize; nx]; ny];
    let mut count = vec![vec![0usize; nx]; ny];
    for r in rows.iter().filter(|r| r.quantity == q) {
        let (Some(bx), Some(by)) = (bin_of(x_edges, r.x[xi]), bin_of(y_edges, r.x[yi])) else {
            continue;
        };
        let e = r.resid();
        sum[by][bx] += e;
        sum2[by][bx] += e * e;
        out[by][bx] += usize::from(e.abs() > tol);
        count[by][bx] += 1;
    }
    let cell = |f: &dyn Fn(usize, usize) -> f64| -> Vec<Vec<Option<f64>>> {
        (0..ny)
            .map(|y| {
                (0..nx)
                    .map(|x| (count[y][x] > 0).then(|| f(y, x)))
                    .collect()
            })
            .collect()
    };
    BinnedMetric {
        quantity: q.to_owned(),
        x_var: x_var.to_owned(),
        y_var: y_var.to_owned(),
        x_edges: x_edges.to_vec(),
        y_edges: y_edges.to_vec(),
        mean: cell(&|y, x| sum[y][x] / count[y][x] as f64),
        rms: cell(&|y, x| (sum2[y][x] / count[y][x] as f64).sqrt()),
        out_of_tolerance: cell(&|y, x| out[y][x] as f64 / count[y][x] as f64),
        count,
        tolerance: tol,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wasserstein_of_a_shift_is_the_shift() {
        let a: Vec<f64> = (0..100).map(f64::from).collect();
        let b: Vec<f64> = a.iter().map(|v| v + 2.5).collect();
        assert!((wasserstein1(&a, &b) - 2.5).abs() < 1e-9);
        let d = distribution_metrics(&b, &a).unwrap();
        assert!((d.dvm_bias - 2.5).abs() < 1e-9 && d.dvm_cavm < 1e-9);
    }

    #[test]
    fn residual_stats_split_bias_and_scatter() {
        let r = [1.0, 3.0, 1.0, 3.0];
        let s = residual_stats(&r, 2.5, 1);
        assert!((s.bias - 2.0).abs() < 1e-12);
        assert!((s.rms - 5f64.sqrt()).abs() < 1e-12);
        assert!((s.within_tolerance - 0.5).abs() < 1e-12);
    }
}
