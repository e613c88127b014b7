//! Attribution (validation.md §5): noise model → nuisance baseline → identifiability / tie check →
//! forward selection with bounded multi-start fits → four gates → status, plus out-of-catalogue
//! diagnostics when the catalogue does not explain the misfit.
//!
//! Residual rows are first aggregated per station (a target at one geometry; its frames are
//! replicates): r̄_i with σ_i² = s_p²/n_i + σ_GT,i², where s_p² is the pooled within-station variance
//! of the quantity and σ_GT the propagated ground-truth uncertainty (power: (40/ln 10)·σ_R/R dB;
//! range: σ_R). The model of the residual is `offset + Σ_k s_k(x_i; θ_k)`; the offset (calibration
//! nuisance) is fitted in closed form and reported, never silently absorbed into an effect.

use std::collections::BTreeMap;
use std::sync::Arc;

use rayon::prelude::*;
use serde::Serialize;

use super::campaign::Campaign;
use super::catalogue::{Catalogue, EffectSignature, MAX_PARAMS, Param};
use super::{NVARS, Row, V_RANGE, quantity, tolerance_of};

/// |cos| between centred signatures above which two effects are not separable on the design.
pub const TIE_COS: f64 = 0.95;
/// Gate 1: ΔBIC ≥ 10 (Kass & Raftery 1995, "very strong").
pub const GATE_DELTA_BIC: f64 = 10.0;
/// Gate 3: share of the remaining excess χ² an effect must explain.
pub const GATE_EXPLAINED: f64 = 0.2;
/// Candidates within this ΔBIC of the winner join its tie group.
pub const TIE_DELTA_BIC: f64 = 2.0;
/// At most this many effects are added per quantity (greedy forward selection).
pub const MAX_EFFECTS: usize = 3;
/// Golden-section tolerance of the fits, relative to a parameter's bound span.
pub const FIT_XTOL: f64 = 1e-5;
/// Cross-validation folds at most: up to this many groups, leave-one-group-out; beyond, grouped
/// K-fold with K = this (the cost of gate 2 stays bounded for large campaigns).
pub const MAX_CV_FOLDS: usize = 10;

/// A station-aggregated residual.
#[derive(Debug, Clone, Copy)]
pub struct Obs {
    pub station: u64,
    pub target: u64,
    /// Cross-validation group.
    pub group: u64,
    pub n: usize,
    /// Mean residual meas − sim.
    pub r: f64,
    pub sigma: f64,
    pub x: [f64; NVARS],
}

/// The noise model of one quantity.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct NoiseModel {
    /// Pooled within-station standard deviation of a single residual.
    pub pooled_sd: f64,
    /// Degrees of freedom of the pooled estimate.
    pub dof: usize,
    /// RMS of the propagated ground-truth uncertainty.
    pub gt_sigma_rms: f64,
    /// √(χ²/dof) of the final model when > 1: the factor σ would need to be inflated by
    /// (used for the parameter CIs, reported, not hidden).
    pub inflation: f64,
}

/// Whether a quantity gets a fitted calibration offset (nuisance). Azimuth and elevation get none:
/// a constant angle offset is the sensor's yaw or pitch misalignment, a named effect
/// (`<sensor>.extrinsic_error`, physics.md §7.1), not a nuisance to absorb.
pub fn has_offset(q: &str) -> bool {
    !matches!(
        q,
        quantity::AZIMUTH_DEG
            | quantity::ELEVATION_DEG
            | quantity::POINTS_LOG_RATIO
            | quantity::GAP_POINTS
            | quantity::CLUTTER_COUNT
            | quantity::INTENSITY_SD_DB
            | quantity::RANGE_SD_M
    )
}

/// Whether a quantity's stations keep their own replicate variance instead of the pooled one
/// (counts per frame: the radar's clutter detections per range band).
pub fn per_station_variance(q: &str) -> bool {
    q == quantity::CLUTTER_COUNT
}

fn hash2(a: u64, b: u64) -> u64 {
    a.wrapping_mul(0x9E37_79B9_7F4A_7C15).rotate_left(17) ^ b
}

/// Aggregates the rows of quantity `q` per station.
pub fn aggregate(rows: &[Row], q: &str, campaign: &Campaign) -> (Vec<Obs>, NoiseModel) {
    let mut by: BTreeMap<u64, Vec<&Row>> = BTreeMap::new();
    for r in rows.iter().filter(|r| r.quantity == q) {
        by.entry(r.station).or_default().push(r);
    }
    let (mut ss, mut dof) = (0.0, 0usize);
    let mut all = Vec::new();
    for list in by.values() {
        let n = list.len() as f64;
        let m = list.iter().map(|r| r.resid()).sum::<f64>() / n;
        ss += list.iter().map(|r| (r.resid() - m).powi(2)).sum::<f64>();
        dof += list.len() - 1;
        all.push(m);
    }
    // Camera ROI rows carry their own standard error (`super::carries_row_sigma`).
    let own_sigma = super::carries_row_sigma(q);
    let pooled_sd = if own_sigma {
        0.0
    } else if dof >= 3 {
        (ss / dof as f64).sqrt()
    } else if all.len() > 2 {
        // No replicates: the scatter of the station means about their mean (conservative).
        let m = all.iter().sum::<f64>() / all.len() as f64;
        (all.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (all.len() - 1) as f64).sqrt()
    } else {
        1.0
    };
    // Floor: a residual cannot be known better than 1e-3 of the tolerance.
    let floor = 1e-3 * tolerance_of(q, &campaign.tolerance).min(1e6);
    let sig_r = campaign.uncertainty.gt_position_sigma_m;
    let mut obs = Vec::with_capacity(by.len());
    let mut gt2 = 0.0;
    for (station, list) in &by {
        let n = list.len();
        let nf = n as f64;
        let r = list.iter().map(|r| r.resid()).sum::<f64>() / nf;
        let mut x = [0.0; NVARS];
        for row in list {
            for (a, b) in x.iter_mut().zip(row.x.iter()) {
                *a += b / nf;
            }
        }
        let range = x[V_RANGE].max(0.1);
        // Propagated GT uncertainty (validation.md §1) and, for LiDAR intensity, the quantisation
        // of the logged value (1 % steps, Velodyne-like; its station-level bias does not average out).
        let gt = match q {
            quantity::POWER_DB => 40.0 / std::f64::consts::LN_10 * sig_r / range,
            quantity::RANGE_M => sig_r,
            quantity::AZIMUTH_DEG | quantity::ELEVATION_DEG => (sig_r / range).to_degrees(),
            quantity::INTENSITY_DB => {
                // Measured level = simulated level × the mean ratio.
                let level = x[super::V_SIM] * 10f64.powf(r / 10.0);
                10.0 / std::f64::consts::LN_10 * (1.0 / 12f64.sqrt()) / level.max(1.0)
            }
            quantity::POINTS_LOG_RATIO => points_gt_sigma(&x, sig_r),
            _ if own_sigma => x[super::V_PRX] / nf.sqrt(),
            _ => 0.0,
        };
        gt2 += gt * gt;
        // Counts per frame and range band (radar clutter) are far from homoscedastic: a band of
        // 25 clutter detections scatters by ±5 per frame, an empty one by 0. Each station keeps its
        // own replicate variance, at least that of one count in its n frames (1/n: a band empty in
        // every frame is still compatible with a mean of ~1/n).
        let scatter2 = if per_station_variance(q) && n > 1 {
            let m = r;
            let s2 = list
                .iter()
                .map(|row| (row.resid() - m).powi(2))
                .sum::<f64>()
                / (nf - 1.0);
            s2.max(1.0 / nf)
        } else {
            pooled_sd * pooled_sd
        };
        let sigma = (scatter2 / nf + gt * gt).sqrt().max(floor);
        let target = list[0].target;
        let mut group = 0u64;
        for g in &campaign.split.cv_group_by {
            group = hash2(group, if g == "target" { target } else { *station });
        }
        if campaign.split.cv_group_by.is_empty() {
            group = target;
        }
        obs.push(Obs {
            station: *station,
            target,
            group,
            n,
            r,
            sigma,
            x,
        });
    }
    // Folds that can identify what they test: leave-one-target-out only where every fold keeps at
    // least two distinct values of each target-level variable that varies (a size law fitted on one
    // size cannot tell itself from the calibration offset); otherwise stations are the groups, so
    // every fold trains on every target.
    if campaign.split.cv_group_by.iter().all(|g| g == "target")
        && obs.iter().any(|o| o.target != 0)
        && !target_folds_identify(&obs)
    {
        for o in &mut obs {
            o.group = o.station;
        }
    }
    let noise = NoiseModel {
        pooled_sd,
        dof,
        gt_sigma_rms: if obs.is_empty() {
            0.0
        } else {
            (gt2 / obs.len() as f64).sqrt()
        },
        inflation: 1.0,
    };
    (obs, noise)
}

/// The variable to stratify an effect's CV folds over: its first explanatory variable when none of
/// them describes the target itself (area, edge, reflectivity, height, width), else None.
fn stratified_variable(e: &dyn EffectSignature) -> Option<usize> {
    let idx: Vec<usize> = e
        .explanatory()
        .iter()
        .filter_map(|v| super::VAR_NAMES.iter().position(|n| n == v))
        .collect();
    let target_level = idx.iter().any(|i| super::TARGET_VARS.contains(i));
    (!target_level).then(|| idx.first().copied()).flatten()
}

/// Whether leave-one-target-out folds keep, in every fold, two or more distinct values of each
/// target-level variable that varies across the targets (and two or more targets at all).
fn target_folds_identify(obs: &[Obs]) -> bool {
    let mut targets: BTreeMap<u64, [f64; NVARS]> = BTreeMap::new();
    for o in obs {
        targets.entry(o.target).or_insert(o.x);
    }
    if targets.len() < 3 {
        return false;
    }
    super::TARGET_VARS.iter().all(|&v| {
        let distinct = |skip: Option<u64>| {
            let mut vals: Vec<f64> = targets
                .iter()
                .filter(|(t, _)| Some(**t) != skip)
                .map(|(_, x)| x[v])
                .collect();
            vals.sort_by(f64::total_cmp);
            vals.dedup_by(|a, b| (*a - *b).abs() <= 1e-6 * b.abs().max(1e-9));
            vals.len()
        };
        distinct(None) < 2 || targets.keys().all(|&t| distinct(Some(t)) >= 2)
    })
}

/// Ground-truth uncertainty of a station's points-on-target log ratio (ln units): the measured and
/// the simulated scans sample the target's silhouette on the beam lattice with offsets that differ
/// by the ground-truth error δ (σ per axis), so a beam column (row) flips on or off at each vertical
/// (horizontal) edge with probability E|δ|/spacing = σ·√(2/π)/spacing (at most ½); plus the range
/// error, n ∝ 1/R².
///
/// A W × H target at range R on a lattice of angular spacings Δaz × Δel (the simulated points'
/// own, `beam_az` / `beam_el`) spans a = W/(R·Δaz) columns of b = H/(R·Δel) beams: Var(Δn) =
/// 2·b²·p_v(1 − p_v) + 2·a²·p_h(1 − p_h), σ_ln² = Var(Δn)/n² + (2σ/R)², n = a·b. Without a
/// known lattice only the range term is used.
fn points_gt_sigma(x: &[f64; NVARS], sigma_m: f64) -> f64 {
    let (w, h, r) = (x[super::V_WIDTH], x[super::V_HEIGHT], x[V_RANGE].max(0.1));
    let range_term = 2.0 * sigma_m / r;
    let (daz, del) = (
        x[super::V_BEAM_AZ].to_radians(),
        x[super::V_BEAM_EL].to_radians(),
    );
    if !(w > 0.0 && h > 0.0 && daz > 0.0 && del > 0.0) || sigma_m <= 0.0 {
        return range_term;
    }
    let (sx, sz) = (r * daz, r * del);
    let a = (w / sx).max(1.0);
    let b = (h / sz).max(1.0);
    let mean_shift = sigma_m * (2.0 / std::f64::consts::PI).sqrt();
    let flip = |p: f64| {
        let p = p.min(0.5);
        p * (1.0 - p)
    };
    let var = 2.0 * b * b * flip(mean_shift / sx) + 2.0 * a * a * flip(mean_shift / sz);
    let n = a * b;
    (var / (n * n) + range_term * range_term).sqrt()
}

/// A fitted set of effects.
#[derive(Debug, Clone)]
struct Fit {
    params: Vec<Vec<f64>>,
    chi2: f64,
    offset: f64,
}

struct Design<'a> {
    obs: &'a [Obs],
    offset: bool,
}

impl Design<'_> {
    /// χ² and the offset for the summed signature `s` under weights `w`.
    fn chi2(&self, w: &[f64], s: &[f64]) -> (f64, f64) {
        let off = if self.offset {
            let (mut a, mut b) = (0.0, 0.0);
            for ((o, wi), si) in self.obs.iter().zip(w).zip(s) {
                a += wi * (o.r - si);
                b += wi;
            }
            if b > 0.0 { a / b } else { 0.0 }
        } else {
            0.0
        };
        let c = self
            .obs
            .iter()
            .zip(w)
            .zip(s)
            .map(|((o, wi), si)| wi * (o.r - si - off).powi(2))
            .sum();
        (c, off)
    }

    fn sig(&self, e: &dyn EffectSignature, p: &[f64], out: &mut [f64]) {
        for (o, v) in self.obs.iter().zip(out.iter_mut()) {
            let s = e.eval(&o.x, p);
            *v = if s.is_finite() { s } else { 0.0 };
        }
    }

    /// Bounded coordinate-descent fit: per parameter a 25-point grid (multi-start) then golden-section
    /// refinement inside the best bracket; `sweeps` passes over all parameters.
    fn fit(
        &self,
        w: &[f64],
        effs: &[&dyn EffectSignature],
        init: &[Vec<f64>],
        sweeps: usize,
    ) -> Fit {
        let n = self.obs.len();
        let mut params: Vec<Vec<f64>> = init.to_vec();
        let mut sigs: Vec<Vec<f64>> = effs
            .iter()
            .zip(&params)
            .map(|(e, p)| {
                let mut v = vec![0.0; n];
                self.sig(*e, p, &mut v);
                v
            })
            .collect();
        let mut others = vec![0.0; n];
        let mut trial = vec![0.0; n];
        let mut total = vec![0.0; n];
        for sweep in 0..sweeps {
            // Largest parameter move of this sweep, relative to its bounds.
            let mut moved: f64 = 0.0;
            for k in 0..effs.len() {
                others.iter_mut().for_each(|v| *v = 0.0);
                for (j, s) in sigs.iter().enumerate() {
                    if j != k {
                        for (o, v) in others.iter_mut().zip(s) {
                            *o += v;
                        }
                    }
                }
                for pi in 0..params[k].len().min(effs[k].params().len()) {
                    let [lo, hi] = effs[k].params()[pi].bounds;
                    let mut p = params[k].clone();
                    let mut f = |v: f64, p: &mut Vec<f64>| -> f64 {
                        p[pi] = v;
                        self.sig(effs[k], p, &mut trial);
                        for ((t, o), s) in total.iter_mut().zip(&others).zip(&trial) {
                            *t = o + s;
                        }
                        self.chi2(w, &total).0
                    };
                    let g = if sweep == 0 { 25 } else { 13 };
                    let (a0, b0) = if sweep == 0 {
                        (lo, hi)
                    } else {
                        let span = (hi - lo) * 0.25;
                        (
                            (params[k][pi] - span).max(lo),
                            (params[k][pi] + span).min(hi),
                        )
                    };
                    let step = (b0 - a0) / (g - 1) as f64;
                    let mut best = (f64::INFINITY, params[k][pi]);
                    let mut best_i: usize = 0;
                    for i in 0..g {
                        let v = a0 + step * i as f64;
                        let c = f(v, &mut p);
                        if c < best.0 {
                            best = (c, v);
                            best_i = i;
                        }
                    }
                    let cur = f(params[k][pi], &mut p);
                    if cur < best.0 {
                        best = (cur, params[k][pi]);
                    }
                    // Golden section in the bracket around the best grid point.
                    let (mut a, mut b) = (
                        (a0 + step * best_i.saturating_sub(1) as f64).max(lo),
                        (a0 + step * (best_i + 1) as f64).min(hi),
                    );
                    let gr = 0.618_033_988_749_895;
                    let mut c = b - gr * (b - a);
                    let mut d = a + gr * (b - a);
                    let (mut fc, mut fd) = (f(c, &mut p), f(d, &mut p));
                    for _ in 0..40 {
                        if fc < fd {
                            b = d;
                            d = c;
                            fd = fc;
                            c = b - gr * (b - a);
                            fc = f(c, &mut p);
                        } else {
                            a = c;
                            c = d;
                            fc = fd;
                            d = a + gr * (b - a);
                            fd = f(d, &mut p);
                        }
                        if (b - a).abs() < FIT_XTOL * (hi - lo) {
                            break;
                        }
                    }
                    for (v, fv) in [(c, fc), (d, fd)] {
                        if fv < best.0 {
                            best = (fv, v);
                        }
                    }
                    moved = moved.max((best.1 - params[k][pi]).abs() / (hi - lo));
                    params[k][pi] = best.1;
                    let pk = params[k].clone();
                    self.sig(effs[k], &pk, &mut sigs[k]);
                }
            }
            // Converged: another coordinate sweep would not move any parameter.
            if sweep > 0 && moved < 10.0 * FIT_XTOL {
                break;
            }
        }
        self.polish(w, effs, &mut params);
        let mut total = vec![0.0; n];
        let mut s = vec![0.0; n];
        for (e, p) in effs.iter().zip(&params) {
            self.sig(*e, p, &mut s);
            for (t, v) in total.iter_mut().zip(&s) {
                *t += v;
            }
        }
        let (chi2, offset) = self.chi2(w, &total);
        Fit {
            params,
            chi2,
            offset,
        }
    }

    /// Joint Levenberg–Marquardt refinement of every parameter after the coordinate sweeps
    /// (Madsen, Nielsen & Tingleff, "Methods for non-linear least squares problems", 2004, §3.2):
    /// coordinate descent crawls along the valley of correlated parameters (a yaw and a lateral
    /// offset both shift the azimuth), a joint step follows it. Numeric Jacobian (central
    /// differences) of the summed signature, the calibration offset profiled out (weighted centring
    /// of the residuals and the Jacobian columns), steps clamped to the bounds; a step is taken only
    /// when it lowers χ², so the result is never worse than the sweeps'.
    fn polish(&self, w: &[f64], effs: &[&dyn EffectSignature], params: &mut [Vec<f64>]) {
        let n = self.obs.len();
        let idx: Vec<(usize, usize)> = effs
            .iter()
            .enumerate()
            .flat_map(|(k, e)| (0..params[k].len().min(e.params().len())).map(move |pi| (k, pi)))
            .collect();
        let m = idx.len();
        if m == 0 || n <= m {
            return;
        }
        let bounds = |&(k, pi): &(usize, usize)| effs[k].params()[pi].bounds;
        let total = |params: &[Vec<f64>], out: &mut Vec<f64>| {
            out.iter_mut().for_each(|v| *v = 0.0);
            let mut s = vec![0.0; n];
            for (e, p) in effs.iter().zip(params) {
                self.sig(*e, p, &mut s);
                for (t, v) in out.iter_mut().zip(&s) {
                    *t += v;
                }
            }
        };
        let wsum: f64 = w.iter().sum();
        if wsum <= 0.0 {
            return;
        }
        // Profiled (offset-free) version of a column: subtract its weighted mean.
        let centre = |v: &mut [f64]| {
            if self.offset {
                let mean = v.iter().zip(w).map(|(a, b)| a * b).sum::<f64>() / wsum;
                v.iter_mut().for_each(|x| *x -= mean);
            }
        };
        let mut cur = vec![0.0; n];
        total(params, &mut cur);
        let mut chi2 = self.chi2(w, &cur).0;
        let mut lambda = 1e-3;
        let mut jac = vec![vec![0.0; n]; m];
        let mut plus = vec![0.0; n];
        let mut minus = vec![0.0; n];
        for _ in 0..30 {
            // Jacobian of the summed signature, one column per parameter.
            for (j, id) in idx.iter().enumerate() {
                let [lo, hi] = bounds(id);
                let h = 1e-6 * (hi - lo).max(1e-12);
                let v0 = params[id.0][id.1];
                params[id.0][id.1] = (v0 + h).min(hi);
                total(params, &mut plus);
                params[id.0][id.1] = (v0 - h).max(lo);
                total(params, &mut minus);
                let span = (v0 + h).min(hi) - (v0 - h).max(lo);
                params[id.0][id.1] = v0;
                for ((c, a), b) in jac[j].iter_mut().zip(&plus).zip(&minus) {
                    *c = (a - b) / span;
                }
                centre(&mut jac[j]);
            }
            let mut res: Vec<f64> = self.obs.iter().zip(&cur).map(|(o, s)| o.r - s).collect();
            centre(&mut res);
            // Normal equations JᵀWJ δ = JᵀW r.
            let mut a = vec![vec![0.0; m]; m];
            let mut g = vec![0.0; m];
            for i in 0..m {
                g[i] = (0..n).map(|t| w[t] * jac[i][t] * res[t]).sum();
                for k in i..m {
                    let v: f64 = (0..n).map(|t| w[t] * jac[i][t] * jac[k][t]).sum();
                    a[i][k] = v;
                    a[k][i] = v;
                }
            }
            let mut improved = false;
            for _ in 0..8 {
                let mut damped = a.clone();
                for (i, row) in damped.iter_mut().enumerate() {
                    row[i] += lambda * a[i][i].max(1e-300);
                }
                let Some(delta) = solve_spd(damped, g.clone()) else {
                    lambda *= 10.0;
                    continue;
                };
                let mut trial: Vec<Vec<f64>> = params.to_vec();
                for (id, d) in idx.iter().zip(&delta) {
                    let [lo, hi] = bounds(id);
                    trial[id.0][id.1] = (trial[id.0][id.1] + d).clamp(lo, hi);
                }
                total(&trial, &mut plus);
                let c = self.chi2(w, &plus).0;
                if c < chi2 {
                    let gain = (chi2 - c) / chi2.max(1e-300);
                    params.clone_from_slice(&trial);
                    cur.clone_from(&plus);
                    chi2 = c;
                    lambda = (lambda * 0.3).max(1e-9);
                    improved = gain > 1e-12;
                    break;
                }
                lambda *= 10.0;
            }
            if !improved {
                break;
            }
        }
    }

    /// Leave-one-group-out CV error Σ w (r − prediction)² over the held-out groups. With more than
    /// [`MAX_CV_FOLDS`] groups, the groups are dealt round-robin (sorted by id) into that many
    /// folds (grouped K-fold: a group is never split between training and validation). Folds are
    /// fitted in parallel and summed in fold order (deterministic).
    fn cv(&self, w: &[f64], effs: &[&dyn EffectSignature], init: &[Vec<f64>]) -> f64 {
        let mut groups: Vec<u64> = self.obs.iter().map(|o| o.group).collect();
        groups.sort_unstable();
        groups.dedup();
        if groups.len() < 2 {
            return f64::NAN;
        }
        let folds = groups.len().min(MAX_CV_FOLDS);
        let fold_of: Vec<usize> = self
            .obs
            .iter()
            .map(|o| groups.binary_search(&o.group).unwrap_or(0) % folds)
            .collect();
        self.cv_folds(w, effs, init, &fold_of, folds)
    }

    /// Station folds stratified over the explanatory variable `v`: the stations sorted by it (ties
    /// by station id) and dealt round-robin into [`MAX_CV_FOLDS`] folds, so every fold spans the
    /// variable's range and no fold asks the effect to extrapolate beyond what it was fitted on.
    fn stratified_folds(&self, v: usize) -> (Vec<usize>, usize) {
        let mut order: Vec<usize> = (0..self.obs.len()).collect();
        order.sort_by(|&a, &b| {
            self.obs[a].x[v]
                .total_cmp(&self.obs[b].x[v])
                .then(self.obs[a].station.cmp(&self.obs[b].station))
        });
        let folds = self.obs.len().min(MAX_CV_FOLDS);
        let mut fold_of = vec![0; self.obs.len()];
        for (rank, &i) in order.iter().enumerate() {
            fold_of[i] = rank % folds.max(1);
        }
        (fold_of, folds)
    }

    /// The CV error over given folds (see [`Design::cv`]).
    fn cv_folds(
        &self,
        w: &[f64],
        effs: &[&dyn EffectSignature],
        init: &[Vec<f64>],
        fold_of: &[usize],
        folds: usize,
    ) -> f64 {
        if folds < 2 {
            return f64::NAN;
        }
        let n = self.obs.len();
        let parts: Vec<f64> = (0..folds)
            .into_par_iter()
            .map(|g| {
                let wt: Vec<f64> = w
                    .iter()
                    .zip(fold_of)
                    .map(|(wi, f)| if *f == g { 0.0 } else { *wi })
                    .collect();
                let fit = if effs.is_empty() {
                    Fit {
                        params: vec![],
                        chi2: 0.0,
                        offset: self.chi2(&wt, &vec![0.0; n]).1,
                    }
                } else {
                    self.fit(&wt, effs, init, 1)
                };
                let mut s = vec![0.0; n];
                let mut sum = vec![0.0; n];
                for (e, p) in effs.iter().zip(&fit.params) {
                    self.sig(*e, p, &mut s);
                    for (a, b) in sum.iter_mut().zip(&s) {
                        *a += b;
                    }
                }
                self.obs
                    .iter()
                    .zip(w)
                    .zip(&sum)
                    .zip(fold_of)
                    .filter(|(_, f)| **f == g)
                    .map(|(((o, wi), si), _)| wi * (o.r - si - fit.offset).powi(2))
                    .sum::<f64>()
            })
            .collect();
        parts.iter().sum()
    }
}

/// A fitted parameter with its 68 % conditional profile-likelihood interval (Δχ² = inflation²).
#[derive(Debug, Clone, Serialize)]
pub struct ParamEstimate {
    pub name: String,
    pub value: f64,
    /// Half-width of the 68 % interval.
    pub sigma: f64,
    pub ci68: [f64; 2],
    pub bounds: [f64; 2],
    /// The estimate sits on a bound.
    pub at_bound: bool,
}

/// The four gates of one candidate.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct Gates {
    pub delta_bic: bool,
    pub cv: bool,
    pub explained: bool,
    pub max_contribution: bool,
}

/// One effect's result.
#[derive(Debug, Clone, Serialize)]
pub struct EffectResult {
    pub id: String,
    pub quantity: String,
    pub accepted: bool,
    /// BIC(current model) − BIC(current + this effect) at the step it was last evaluated (> 0 = better).
    pub delta_bic: f64,
    /// BIC weight among the candidates of that step.
    pub bic_weight: f64,
    /// Relative decrease of the leave-one-group-out CV error (winner of a step only).
    pub cv_gain: Option<f64>,
    /// Share of the remaining excess χ² explained.
    pub explained_share: f64,
    /// max |s − mean s| over the design, in the quantity's unit.
    pub max_contribution: f64,
    /// The fitted parameters: for an accepted effect those of the final joint fit of every
    /// accepted effect of the quantity, else those of the step it was last evaluated at.
    pub params: Vec<ParamEstimate>,
    pub tie_group: Option<String>,
    pub gates: Gates,
    /// Selection step (1-based) the values refer to.
    pub step: usize,
    pub model_switch: Option<String>,
    pub discriminating_experiment: String,
}

/// Effects not separable on this design.
#[derive(Debug, Clone, Serialize)]
pub struct TieGroup {
    pub id: String,
    pub quantity: String,
    pub members: Vec<String>,
    /// Largest |cos| between centred, weighted signatures of members.
    pub max_abs_cos: f64,
    /// `signature` (before any fit) or `delta_bic` (fits within ΔBIC < 2).
    pub reason: String,
    pub discriminating_experiment: String,
}

/// Residual structure when the catalogue does not explain the misfit.
#[derive(Debug, Clone, Serialize)]
pub struct Diagnostics {
    /// Mean weighted residual (after the accepted effects) per range bin: (lo, hi, mean, n).
    pub binned_range: Vec<(f64, f64, f64, usize)>,
    /// Wald–Wolfowitz runs test of the residual signs ordered by range: z (≪ −2 = structure).
    pub runs_z: f64,
    /// Lomb–Scargle periodogram along range: best period, m, and its normalised power.
    pub lomb_scargle_period_m: f64,
    pub lomb_scargle_power: f64,
    /// False-alarm probability of that peak (Scargle 1982, independent-frequency approximation).
    pub lomb_scargle_fap: f64,
}

/// Status of a quantity or a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum Status {
    Consistent,
    Explained,
    PartiallyExplained,
    Unexplained,
}

impl Status {
    pub fn name(self) -> &'static str {
        match self {
            Status::Consistent => "CONSISTENT",
            Status::Explained => "EXPLAINED",
            Status::PartiallyExplained => "PARTIALLY_EXPLAINED",
            Status::Unexplained => "UNEXPLAINED",
        }
    }
}

/// Attribution of one quantity.
#[derive(Debug, Clone, Serialize)]
pub struct QuantityAttribution {
    pub quantity: String,
    pub rows: usize,
    pub stations: usize,
    pub tolerance: f64,
    pub noise: NoiseModel,
    /// Nuisance baseline: fitted calibration offset ± standard error (None: no offset for counts).
    pub calibration_offset: Option<[f64; 2]>,
    pub baseline_chi2: f64,
    pub baseline_dof: usize,
    pub baseline_bic: f64,
    pub final_chi2: f64,
    pub final_dof: usize,
    pub final_chi2_per_dof: f64,
    /// Threshold χ²/dof under which the residual is noise: max(1.2, 1 + 3√(2/dof)).
    pub consistent_threshold: f64,
    /// RMS of the raw residual rows ≤ tolerance.
    pub tolerance_pass: bool,
    pub status: Status,
    pub accepted: Vec<String>,
    pub effects: Vec<EffectResult>,
    pub tie_groups: Vec<TieGroup>,
    /// Identifiability on this design: the candidates and |cos| between their centred, weighted
    /// signatures at the nominal parameters (`abs_cos[i][j]`; NaN = no variation on this design).
    pub candidates: Vec<String>,
    pub abs_cos: Vec<Vec<f64>>,
    pub diagnostics: Option<Diagnostics>,
    /// Residual of each station after the accepted effects: (range, azimuth, before, after, σ).
    #[serde(skip)]
    pub what_if: Vec<[f64; 5]>,
}

/// Solves the symmetric positive-definite system `a·x = b` (Cholesky, `a` m × m, m small);
/// `None` when `a` is not positive definite.
fn solve_spd(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Option<Vec<f64>> {
    let m = b.len();
    for j in 0..m {
        let d = a[j][j] - (0..j).map(|k| a[j][k] * a[j][k]).sum::<f64>();
        if d.is_nan() || d <= 0.0 || !d.is_finite() {
            return None;
        }
        let d = d.sqrt();
        a[j][j] = d;
        for i in j + 1..m {
            a[i][j] = (a[i][j] - (0..j).map(|k| a[i][k] * a[j][k]).sum::<f64>()) / d;
        }
    }
    for i in 0..m {
        b[i] = (b[i] - (0..i).map(|k| a[i][k] * b[k]).sum::<f64>()) / a[i][i];
    }
    for i in (0..m).rev() {
        b[i] = (b[i] - (i + 1..m).map(|k| a[k][i] * b[k]).sum::<f64>()) / a[i][i];
    }
    Some(b)
}

fn bic(chi2: f64, k: usize, n: usize) -> f64 {
    chi2 + k as f64 * (n.max(2) as f64).ln()
}

/// Weighted, centred (when an offset is fitted) and normalised signature vector.
fn unit_signature(d: &Design, w: &[f64], e: &dyn EffectSignature, p: &[f64]) -> Option<Vec<f64>> {
    let mut s = vec![0.0; d.obs.len()];
    d.sig(e, p, &mut s);
    if d.offset {
        let wsum: f64 = w.iter().sum();
        let m = s.iter().zip(w).map(|(a, b)| a * b).sum::<f64>() / wsum;
        s.iter_mut().for_each(|v| *v -= m);
    }
    for (v, wi) in s.iter_mut().zip(w) {
        *v *= wi.sqrt();
    }
    let norm = s.iter().map(|v| v * v).sum::<f64>().sqrt();
    (norm > 1e-12).then(|| s.into_iter().map(|v| v / norm).collect())
}

/// Runs the attribution for one quantity.
pub fn attribute_quantity(
    campaign: &Campaign,
    catalogue: &Catalogue,
    rows: &[Row],
    q: &str,
) -> Option<QuantityAttribution> {
    let (obs, mut noise) = aggregate(rows, q, campaign);
    let n = obs.len();
    if n < 3 {
        return None;
    }
    let tol = tolerance_of(q, &campaign.tolerance);
    let raw: Vec<f64> = rows
        .iter()
        .filter(|r| r.quantity == q)
        .map(Row::resid)
        .collect();
    let raw_rms = (raw.iter().map(|v| v * v).sum::<f64>() / raw.len().max(1) as f64).sqrt();
    let tolerance_pass = raw_rms <= tol;
    let d = Design {
        obs: &obs,
        offset: has_offset(q),
    };
    let w: Vec<f64> = obs.iter().map(|o| 1.0 / (o.sigma * o.sigma)).collect();
    let k0 = usize::from(d.offset);
    let cands: Vec<&dyn EffectSignature> = catalogue.for_quantity(q).collect();

    // 2. Nuisance baseline.
    let base = d.fit(&w, &[], &[], 0);
    let wsum: f64 = w.iter().sum();
    let calibration_offset = d.offset.then(|| [base.offset, 1.0 / wsum.sqrt()]);
    let baseline_bic = bic(base.chi2, k0, n);

    // 3. Identifiability on the design, before any fit.
    let units: Vec<Option<Vec<f64>>> = cands
        .iter()
        .map(|e| unit_signature(&d, &w, *e, &e.nominal()))
        .collect();
    let mut cos_pairs: Vec<(usize, usize, f64)> = Vec::new();
    for i in 0..cands.len() {
        for j in i + 1..cands.len() {
            if let (Some(a), Some(b)) = (&units[i], &units[j]) {
                let c: f64 = a.iter().zip(b).map(|(x, y)| x * y).sum();
                if c.abs() > TIE_COS {
                    cos_pairs.push((i, j, c.abs()));
                }
            }
        }
    }
    let cos_of = |i: usize, j: usize| -> f64 {
        match (&units[i], &units[j]) {
            (Some(a), Some(b)) => a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>().abs(),
            _ => 0.0,
        }
    };

    // 4./5. Forward selection with the four gates.
    let mut current: Vec<usize> = Vec::new();
    let mut cur_fit = base.clone();
    let mut cur_k = k0;
    let mut results: BTreeMap<usize, EffectResult> = BTreeMap::new();
    let mut tie_groups: Vec<TieGroup> = Vec::new();
    let mut tie_of: BTreeMap<usize, String> = BTreeMap::new();
    // CV error of the current model: the winner's CV error of the step that accepted it (same
    // effects, same start values, same weights), so each step computes one CV instead of two.
    let mut cv_current: Option<f64> = None;
    for step in 1..=MAX_EFFECTS {
        let cur_bic = bic(cur_fit.chi2, cur_k, n);
        // The candidates' fits are independent: one rayon task each (deterministic: every fit is
        // a pure function of its inputs, the order is restored by the sort below).
        let mut trials: Vec<(usize, Fit, f64)> = cands
            .par_iter()
            .enumerate()
            .filter(|(ci, _)| !current.contains(ci))
            .map(|(ci, e)| {
                let effs: Vec<&dyn EffectSignature> =
                    current.iter().map(|&i| cands[i]).chain([*e]).collect();
                let init: Vec<Vec<f64>> = cur_fit
                    .params
                    .iter()
                    .cloned()
                    .chain([e.nominal()])
                    .collect();
                let fit = d.fit(
                    &w,
                    &effs,
                    &init,
                    if effs.len() == 1 && e.params().len() == 1 {
                        1
                    } else {
                        3
                    },
                );
                let b = bic(fit.chi2, cur_k + e.params().len(), n);
                (ci, fit, b)
            })
            .collect();
        if trials.is_empty() {
            break;
        }
        trials.sort_by(|a, b| a.2.total_cmp(&b.2).then(a.0.cmp(&b.0)));
        let best_bic = trials[0].2;
        let wsum_b: f64 = trials.iter().map(|t| (-(t.2 - best_bic) / 2.0).exp()).sum();
        let dof_cur = n.saturating_sub(cur_k).max(1) as f64;
        let excess = cur_fit.chi2 - dof_cur;
        let step_results: Vec<(usize, EffectResult, Option<f64>)> = trials
            .par_iter()
            .enumerate()
            .map(|(rank, (ci, fit, b))| {
                let e = cands[*ci];
                let p_new = fit.params.last().cloned().unwrap_or_default();
                let mut s = vec![0.0; n];
                d.sig(e, &p_new, &mut s);
                let m = if d.offset {
                    s.iter().zip(&w).map(|(a, b)| a * b).sum::<f64>() / wsum
                } else {
                    0.0
                };
                let max_c = s.iter().map(|v| (v - m).abs()).fold(0.0, f64::max);
                let delta_bic = cur_bic - b;
                let explained = if excess > 0.0 {
                    (cur_fit.chi2 - fit.chi2) / excess
                } else {
                    0.0
                };
                let mut gates = Gates {
                    delta_bic: delta_bic >= GATE_DELTA_BIC,
                    cv: false,
                    explained: explained >= GATE_EXPLAINED,
                    max_contribution: max_c >= tol / 10.0,
                };
                let mut cv_gain = None;
                let mut cv_new = None;
                if rank == 0 && gates.delta_bic && gates.explained && gates.max_contribution {
                    let before_effs: Vec<&dyn EffectSignature> =
                        current.iter().map(|&i| cands[i]).collect();
                    let effs: Vec<&dyn EffectSignature> =
                        before_effs.iter().copied().chain([e]).collect();
                    // An effect of the geometry or the received power alone (no target-level
                    // variable) is cross-validated over station folds stratified by its first
                    // explanatory variable; a target-level law over the campaign's groups.
                    let stratify = stratified_variable(e);
                    let (cv0, cv1) = match stratify {
                        Some(v) => {
                            let (fold_of, folds) = d.stratified_folds(v);
                            rayon::join(
                                || d.cv_folds(&w, &before_effs, &cur_fit.params, &fold_of, folds),
                                || d.cv_folds(&w, &effs, &fit.params, &fold_of, folds),
                            )
                        }
                        None => rayon::join(
                            || {
                                cv_current
                                    .unwrap_or_else(|| d.cv(&w, &before_effs, &cur_fit.params))
                            },
                            || d.cv(&w, &effs, &fit.params),
                        ),
                    };
                    // The cache holds group-fold CV errors only.
                    cv_new = if stratify.is_none() { Some(cv1) } else { None };
                    gates.cv = cv0.is_nan() || cv1 < cv0;
                    cv_gain = Some(if cv0 > 0.0 { 1.0 - cv1 / cv0 } else { 0.0 });
                }
                // Parameter CIs (conditional profile: Δχ² = max(1, χ²/dof)).
                let dof_new = n.saturating_sub(cur_k + e.params().len()).max(1) as f64;
                let infl = (fit.chi2 / dof_new).max(1.0);
                let effs: Vec<&dyn EffectSignature> =
                    current.iter().map(|&i| cands[i]).chain([e]).collect();
                let params = profile(&d, &w, &effs, fit, infl);
                (
                    *ci,
                    EffectResult {
                        id: e.id().to_owned(),
                        quantity: q.to_owned(),
                        accepted: false,
                        delta_bic,
                        bic_weight: (-(b - best_bic) / 2.0).exp() / wsum_b,
                        cv_gain,
                        explained_share: explained,
                        max_contribution: max_c,
                        params,
                        tie_group: None,
                        gates,
                        step,
                        model_switch: e.model_switch().map(str::to_owned),
                        discriminating_experiment: e.discriminating_experiment().to_owned(),
                    },
                    cv_new,
                )
            })
            .collect();
        let mut cv_winner = None;
        for (ci, r, cv) in step_results {
            if cv.is_some() {
                cv_winner = cv;
            }
            if !results.get(&ci).is_some_and(|r| r.accepted) {
                results.insert(ci, r);
            }
        }
        let (wi, wfit, _) = &trials[0];
        let winner = &results[wi];
        let g = winner.gates;
        // Tie group of the winner: signature ties and fits within ΔBIC < 2.
        let mut members: Vec<usize> = vec![*wi];
        let mut reason = String::new();
        let gain_w = cur_fit.chi2 - wfit.chi2;
        for (ci, cfit, b) in trials.iter().skip(1) {
            // A signature tie counts when the candidate, within its bounds, reproduces at least half
            // of the winner's χ² reduction (a bound sign can separate identical shapes).
            let sig_tie = cos_of(*wi, *ci) > TIE_COS && cur_fit.chi2 - cfit.chi2 >= 0.5 * gain_w;
            if sig_tie || b - best_bic < TIE_DELTA_BIC {
                members.push(*ci);
                let r = if sig_tie { "signature" } else { "delta_bic" };
                if !reason.contains(r) {
                    if !reason.is_empty() {
                        reason.push('+');
                    }
                    reason.push_str(r);
                }
            }
        }
        let accept = g.delta_bic && g.cv && g.explained && g.max_contribution;
        if members.len() > 1 && (accept || g.delta_bic) {
            let id = format!("{q}#{}", tie_groups.len() + 1);
            let max_cos = members
                .iter()
                .skip(1)
                .map(|&m| cos_of(*wi, m))
                .fold(0.0, f64::max);
            let experiments: Vec<String> = members
                .iter()
                .map(|&m| cands[m].discriminating_experiment().to_owned())
                .filter(|s| !s.is_empty())
                .collect::<std::collections::BTreeSet<_>>()
                .into_iter()
                .collect();
            for &m in &members {
                tie_of.insert(m, id.clone());
            }
            tie_groups.push(TieGroup {
                id,
                quantity: q.to_owned(),
                members: members.iter().map(|&m| cands[m].id().to_owned()).collect(),
                max_abs_cos: max_cos,
                reason,
                discriminating_experiment: experiments.join("; "),
            });
        }
        if !accept {
            break;
        }
        results.get_mut(wi).expect("winner").accepted = true;
        current.push(*wi);
        cur_k += cands[*wi].params().len();
        cur_fit = wfit.clone();
        cv_current = cv_winner;
    }
    // Every accepted effect's parameters as the final joint fit has them: one accepted at an earlier
    // step was refitted together with each later one (a yaw fitted alone over a campaign whose
    // radar calibrates itself halfway is a fraction of the yaw it has beside the calibration).
    if current.len() > 1 {
        let dof = n.saturating_sub(cur_k).max(1) as f64;
        let infl = (cur_fit.chi2 / dof).max(1.0);
        for (j, ci) in current.iter().enumerate() {
            let order: Vec<usize> = (0..current.len()).filter(|&i| i != j).chain([j]).collect();
            let effs: Vec<&dyn EffectSignature> =
                order.iter().map(|&i| cands[current[i]]).collect();
            let fit = Fit {
                params: order.iter().map(|&i| cur_fit.params[i].clone()).collect(),
                chi2: cur_fit.chi2,
                offset: cur_fit.offset,
            };
            if let Some(r) = results.get_mut(ci) {
                r.params = profile(&d, &w, &effs, &fit, infl);
            }
        }
    }
    // Pre-fit signature ties not involving an accepted or already grouped effect are reported too
    // (design remarks: these effects could not be told apart here if they were needed).
    for (i, j, c) in &cos_pairs {
        if tie_of.contains_key(i)
            || tie_of.contains_key(j)
            || current.contains(i)
            || current.contains(j)
        {
            continue;
        }
        let id = format!("{q}#{}", tie_groups.len() + 1);
        tie_of.insert(*i, id.clone());
        tie_of.insert(*j, id.clone());
        tie_groups.push(TieGroup {
            id,
            quantity: q.to_owned(),
            members: vec![cands[*i].id().to_owned(), cands[*j].id().to_owned()],
            max_abs_cos: *c,
            reason: "signature".into(),
            discriminating_experiment: format!(
                "{}; {}",
                cands[*i].discriminating_experiment(),
                cands[*j].discriminating_experiment()
            ),
        });
    }
    for (ci, r) in results.iter_mut() {
        r.tie_group = tie_of.get(ci).cloned();
    }
    let accepted: Vec<String> = current.iter().map(|&i| cands[i].id().to_owned()).collect();
    let abs_cos: Vec<Vec<f64>> = (0..cands.len())
        .map(|i| {
            (0..cands.len())
                .map(|j| match (&units[i], &units[j]) {
                    (Some(_), Some(_)) => cos_of(i, j),
                    _ => f64::NAN,
                })
                .collect()
        })
        .collect();
    let final_dof = n.saturating_sub(cur_k).max(1);
    let final_chi2_per_dof = cur_fit.chi2 / final_dof as f64;
    noise.inflation = final_chi2_per_dof.max(1.0).sqrt();
    let consistent_threshold = (1.0 + 3.0 * (2.0 / final_dof as f64).sqrt()).max(1.2);
    let status = if accepted.is_empty() {
        if final_chi2_per_dof <= consistent_threshold {
            let off = calibration_offset.map(|c| c[0]).unwrap_or(0.0);
            let rms_cal = (raw.iter().map(|v| (v - off).powi(2)).sum::<f64>()
                / raw.len().max(1) as f64)
                .sqrt();
            // The tolerance judges the residuals after the calibration offset (a nuisance,
            // fitted and reported: validation.md §5, step 6).
            if tolerance_pass || rms_cal <= tol {
                Status::Consistent
            } else {
                Status::Unexplained
            }
        } else {
            Status::Unexplained
        }
    } else if final_chi2_per_dof <= consistent_threshold.max(1.5) {
        Status::Explained
    } else {
        Status::PartiallyExplained
    };
    // What-if residuals and diagnostics.
    let mut sum = vec![0.0; n];
    let mut s = vec![0.0; n];
    for (&i, p) in current.iter().zip(&cur_fit.params) {
        d.sig(cands[i], p, &mut s);
        for (a, b) in sum.iter_mut().zip(&s) {
            *a += b;
        }
    }
    let what_if: Vec<[f64; 5]> = obs
        .iter()
        .zip(&sum)
        .map(|(o, si)| {
            [
                o.x[V_RANGE],
                o.x[super::V_AZIMUTH],
                o.r - base.offset,
                o.r - si - cur_fit.offset,
                o.sigma,
            ]
        })
        .collect();
    let diagnostics = matches!(status, Status::Unexplained | Status::PartiallyExplained)
        .then(|| diagnose(&what_if, &campaign.bins.range_m));
    let mut effects: Vec<EffectResult> = results.into_values().collect();
    effects.sort_by(|a, b| {
        b.accepted
            .cmp(&a.accepted)
            .then(b.delta_bic.total_cmp(&a.delta_bic))
    });
    Some(QuantityAttribution {
        quantity: q.to_owned(),
        rows: raw.len(),
        stations: n,
        tolerance: tol,
        noise,
        calibration_offset,
        baseline_chi2: base.chi2,
        baseline_dof: n.saturating_sub(k0),
        baseline_bic,
        final_chi2: cur_fit.chi2,
        final_dof,
        final_chi2_per_dof,
        consistent_threshold,
        tolerance_pass,
        status,
        accepted,
        effects,
        tie_groups,
        candidates: cands.iter().map(|e| e.id().to_owned()).collect(),
        abs_cos,
        diagnostics,
        what_if,
    })
}

/// Conditional profile-likelihood intervals of the last effect's parameters.
fn profile(
    d: &Design,
    w: &[f64],
    effs: &[&dyn EffectSignature],
    fit: &Fit,
    infl: f64,
) -> Vec<ParamEstimate> {
    let n = d.obs.len();
    let k = effs.len() - 1;
    let e = effs[k];
    let mut others = vec![0.0; n];
    let mut s = vec![0.0; n];
    for (j, (ej, p)) in effs.iter().zip(&fit.params).enumerate() {
        if j != k {
            d.sig(*ej, p, &mut s);
            for (a, b) in others.iter_mut().zip(&s) {
                *a += b;
            }
        }
    }
    let p_hat = fit.params[k].clone();
    let mut total = vec![0.0; n];
    let mut chi = |p: &[f64]| -> f64 {
        d.sig(e, p, &mut s);
        for ((t, o), v) in total.iter_mut().zip(&others).zip(&s) {
            *t = o + v;
        }
        d.chi2(w, &total).0
    };
    let c0 = chi(&p_hat);
    let target = c0 + infl;
    e.params()
        .iter()
        .enumerate()
        .map(|(pi, par)| {
            let v = p_hat[pi];
            let [lo, hi] = par.bounds;
            let mut side = |to: f64| -> f64 {
                let mut p = p_hat.clone();
                p[pi] = to;
                if chi(&p) < target {
                    return to;
                }
                let (mut a, mut b) = (v, to);
                for _ in 0..50 {
                    let m = 0.5 * (a + b);
                    p[pi] = m;
                    if chi(&p) < target {
                        a = m;
                    } else {
                        b = m;
                    }
                }
                0.5 * (a + b)
            };
            let l = side(lo);
            let h = side(hi);
            let tol = 1e-6 * (hi - lo);
            ParamEstimate {
                name: par.name.clone(),
                value: v,
                sigma: 0.5 * (h - l),
                ci68: [l, h],
                bounds: par.bounds,
                at_bound: (v - lo).abs() < tol || (hi - v).abs() < tol,
            }
        })
        .collect()
}

/// Out-of-catalogue diagnostics on the what-if residuals (range, az, before, after, σ).
fn diagnose(what_if: &[[f64; 5]], range_edges: &[f64]) -> Diagnostics {
    let mut binned = Vec::new();
    for wdw in range_edges.windows(2) {
        let sel: Vec<&[f64; 5]> = what_if
            .iter()
            .filter(|r| r[0] >= wdw[0] && r[0] < wdw[1])
            .collect();
        if !sel.is_empty() {
            let m = sel.iter().map(|r| r[3]).sum::<f64>() / sel.len() as f64;
            binned.push((wdw[0], wdw[1], m, sel.len()));
        }
    }
    // Runs test along range.
    let mut sorted: Vec<&[f64; 5]> = what_if.iter().collect();
    sorted.sort_by(|a, b| a[0].total_cmp(&b[0]));
    let signs: Vec<bool> = sorted.iter().map(|r| r[3] >= 0.0).collect();
    let (n1, n2) = (
        signs.iter().filter(|s| **s).count() as f64,
        signs.iter().filter(|s| !**s).count() as f64,
    );
    let runs = 1 + signs.windows(2).filter(|w| w[0] != w[1]).count();
    let nn = n1 + n2;
    let mu = 2.0 * n1 * n2 / nn + 1.0;
    let var = 2.0 * n1 * n2 * (2.0 * n1 * n2 - nn) / (nn * nn * (nn - 1.0));
    let runs_z = if var > 0.0 {
        (runs as f64 - mu) / var.sqrt()
    } else {
        0.0
    };
    // Lomb–Scargle (Scargle 1982) of the normalised residuals along range.
    let t: Vec<f64> = sorted.iter().map(|r| r[0]).collect();
    let y: Vec<f64> = sorted.iter().map(|r| r[3]).collect();
    let ny = y.len() as f64;
    let my = y.iter().sum::<f64>() / ny;
    let vy = y.iter().map(|v| (v - my).powi(2)).sum::<f64>() / (ny - 1.0).max(1.0);
    let span = t.last().copied().unwrap_or(1.0) - t.first().copied().unwrap_or(0.0);
    let (mut best_p, mut best_pow) = (f64::NAN, 0.0);
    let nf = 4000;
    let (fmin, fmax) = (1.0 / span.max(1e-3), 1.0 / 0.1);
    if vy > 0.0 && t.len() >= 8 {
        for i in 0..nf {
            let f = fmin * (fmax / fmin).powf(i as f64 / (nf - 1) as f64);
            let om = 2.0 * std::f64::consts::PI * f;
            let (s2, c2) = t.iter().fold((0.0, 0.0), |(s, c), ti| {
                (s + (2.0 * om * ti).sin(), c + (2.0 * om * ti).cos())
            });
            let tau = s2.atan2(c2) / (2.0 * om);
            let (mut yc, mut yss, mut cc, mut ss) = (0.0, 0.0, 0.0, 0.0);
            for (ti, yi) in t.iter().zip(&y) {
                let a = om * (ti - tau);
                let (sa, ca) = a.sin_cos();
                yc += (yi - my) * ca;
                yss += (yi - my) * sa;
                cc += ca * ca;
                ss += sa * sa;
            }
            let p = (yc * yc / cc.max(1e-12) + yss * yss / ss.max(1e-12)) / (2.0 * vy);
            if p > best_pow {
                best_pow = p;
                best_p = 1.0 / f;
            }
        }
    }
    // Independent frequencies ≈ number of points (Horne & Baliunas 1986).
    let fap = 1.0 - (1.0 - (-best_pow).exp()).powf(ny);
    Diagnostics {
        binned_range: binned,
        runs_z,
        lomb_scargle_period_m: best_p,
        lomb_scargle_power: best_pow,
        lomb_scargle_fap: fap,
    }
}

/// Combines per-quantity statuses into the run's status.
pub fn combine(statuses: &[Status]) -> Status {
    if statuses.iter().all(|s| *s == Status::Consistent) {
        return Status::Consistent;
    }
    let bad: Vec<Status> = statuses
        .iter()
        .copied()
        .filter(|s| *s != Status::Consistent)
        .collect();
    if bad.iter().all(|s| *s == Status::Explained) {
        Status::Explained
    } else if bad
        .iter()
        .any(|s| matches!(s, Status::Explained | Status::PartiallyExplained))
    {
        Status::PartiallyExplained
    } else {
        Status::Unexplained
    }
}

/// Attribution of every quantity of the campaign's sensor.
pub fn attribute(
    campaign: &Campaign,
    catalogue: &Catalogue,
    rows: &[Row],
) -> Vec<QuantityAttribution> {
    // One effect, several quantities (joint signatures): the quantities are attributed in order;
    // an effect's entry on a later quantity shares the parameters of the same name with its entry
    // on an earlier one. Accepted there: those parameters are fixed at the fitted values here
    // (fog's α from the intensities sets the points it drops). Not accepted there: the shared
    // parameters that the earlier data pin down are fixed at their fit (α ≈ 0 from clean
    // intensities: fog cannot drop points), the others stay free; and where one of its
    // look-alikes (`confusable_with`) was accepted there in its place, all stay free (the later
    // quantity is then the discriminating evidence: a clip level collapses the variance, a
    // companding knee does not).
    let mut out: Vec<QuantityAttribution> = Vec::new();
    for q in super::attribution_quantities(campaign.sensor.kind) {
        let mut effects: Vec<Arc<dyn EffectSignature>> = Vec::new();
        for e in catalogue.effects.iter().filter(|e| e.quantity() == *q) {
            // (accepted there, a look-alike of it accepted there instead, its result)
            let earlier = out.iter().find_map(|a| {
                a.effects.iter().find(|r| r.id == e.id()).map(|r| {
                    let alikes = |x: &dyn EffectSignature| x.confusable_with().to_vec();
                    let mut alike = alikes(e.as_ref());
                    if let Some(first) = catalogue.get_for(e.id(), &a.quantity) {
                        alike.extend(alikes(first));
                    }
                    let look_alike = a.accepted.iter().any(|acc| alike.contains(acc));
                    (a.accepted.contains(&r.id), look_alike, r)
                })
            });
            match earlier {
                None => effects.push(e.clone()),
                // A look-alike won the earlier quantity: this one may tell them apart.
                Some((false, true, _)) => effects.push(e.clone()),
                Some((accepted, _, r)) => {
                    // Accepted there: every shared parameter at its fit. Not accepted: the
                    // shared parameters the earlier data pin down (68 % interval within a fifth
                    // of the bounds: fog's α ≈ 0 from clean intensities) at their fit, the others
                    // free (a clip level that the means never reached).
                    let fixed: Vec<Option<f64>> = e
                        .params()
                        .iter()
                        .map(|p| {
                            r.params
                                .iter()
                                .find(|f| f.name == p.name)
                                .filter(|f| {
                                    accepted
                                        || f.ci68[1] - f.ci68[0]
                                            <= 0.2 * (f.bounds[1] - f.bounds[0])
                                })
                                .map(|f| f.value.clamp(p.bounds[0], p.bounds[1]))
                        })
                        .collect();
                    if fixed.iter().all(Option::is_none) {
                        effects.push(e.clone());
                    } else {
                        effects.push(Arc::new(Conditioned::new(e.clone(), fixed)));
                    }
                }
            }
        }
        let view = Catalogue {
            sensor: catalogue.sensor.clone(),
            version: catalogue.version.clone(),
            effects,
        };
        if let Some(a) = attribute_quantity(campaign, &view, rows, q) {
            out.push(a);
        }
    }
    out
}

/// An effect entry with some parameters fixed at values fitted on another quantity (a joint
/// signature across quantities); the free parameters are fitted as usual.
struct Conditioned {
    inner: Arc<dyn EffectSignature>,
    /// Per parameter of `inner`: the fixed value, or None (free).
    fixed: Vec<Option<f64>>,
    free: Vec<Param>,
    physics: String,
}

impl Conditioned {
    fn new(inner: Arc<dyn EffectSignature>, fixed: Vec<Option<f64>>) -> Conditioned {
        let free = inner
            .params()
            .iter()
            .zip(&fixed)
            .filter(|(_, f)| f.is_none())
            .map(|(p, _)| p.clone())
            .collect();
        let shared: Vec<String> = inner
            .params()
            .iter()
            .zip(&fixed)
            .filter_map(|(p, f)| f.map(|v| format!("{} = {v:.4}", p.name)))
            .collect();
        let physics = format!(
            "{} [joint: {} fixed by this effect's fit on another quantity]",
            inner.physics(),
            shared.join(", ")
        );
        Conditioned {
            inner,
            fixed,
            free,
            physics,
        }
    }
}

impl EffectSignature for Conditioned {
    fn id(&self) -> &str {
        self.inner.id()
    }
    fn quantity(&self) -> &str {
        self.inner.quantity()
    }
    fn params(&self) -> &[Param] {
        &self.free
    }
    fn eval(&self, x: &[f64], p: &[f64]) -> f64 {
        let mut full = [0.0; MAX_PARAMS];
        let mut k = 0;
        for (slot, f) in full.iter_mut().zip(&self.fixed) {
            *slot = match f {
                Some(v) => *v,
                None => {
                    k += 1;
                    p.get(k - 1).copied().unwrap_or(0.0)
                }
            };
        }
        self.inner.eval(x, &full[..self.fixed.len()])
    }
    fn explanatory(&self) -> &[String] {
        self.inner.explanatory()
    }
    fn layer(&self) -> &[String] {
        self.inner.layer()
    }
    fn signature(&self) -> &str {
        self.inner.signature()
    }
    fn kind(&self) -> super::catalogue::EffectKind {
        self.inner.kind()
    }
    fn confusable_with(&self) -> &[String] {
        self.inner.confusable_with()
    }
    fn discriminating_experiment(&self) -> &str {
        self.inner.discriminating_experiment()
    }
    fn physics(&self) -> &str {
        &self.physics
    }
}
