//! The held-out split of a campaign ([`Holdout`]): the rows that judge the closed loop and that
//! the attribution never fits. It sits between the pairing (the rows) and the attribution.

use std::collections::BTreeMap;

use super::campaign::Campaign;
use super::metrics;
use super::{Row, TARGET_VARS, V_RANGE};

/// Fewest targets the training split keeps when whole targets are held out; with fewer targets
/// in the campaign, stations are held out instead (every target stays in the training split).
pub const MIN_TRAINING_TARGETS: usize = 3;

/// The held-out split of a campaign (`[split] holdout_fraction`, seeded): the rows that judge the
/// closed loop and that the attribution never fits.
///
/// Whole targets are held out (seeded order) while the training split keeps at least
/// [`MIN_TRAINING_TARGETS`] targets and each held-out target lies inside the training targets'
/// span of every target-level variable (area, edge, reflectivity, height, width). Where that holds for no target
/// (one target, three sizes of one each), stations are held out instead: per target, every
/// ⌈1/fraction⌉-th station in range order from a seeded phase, so the held-out stations span the
/// range of every target and the training split is never empty.
#[derive(Debug, Clone, Default, PartialEq, Eq, serde::Serialize)]
pub struct Holdout {
    /// `target`, `station` or `none` (fraction 0 or nothing to hold out).
    pub by: String,
    pub targets: Vec<u64>,
    pub stations: Vec<u64>,
}

impl Holdout {
    /// Whether a row is held out.
    pub fn contains(&self, r: &Row) -> bool {
        self.targets.binary_search(&r.target).is_ok()
            || self.stations.binary_search(&r.station).is_ok()
    }
}

/// The held-out split ([`Holdout`]).
pub fn holdout(campaign: &Campaign, rows: &[Row]) -> Holdout {
    let frac = campaign.split.holdout_fraction;
    let none = Holdout {
        by: "none".into(),
        ..Holdout::default()
    };
    if frac <= 0.0 {
        return none;
    }
    let mut first: BTreeMap<u64, &Row> = BTreeMap::new();
    for r in rows.iter().filter(|r| r.target != 0) {
        first.entry(r.target).or_insert(r);
    }
    let targets: Vec<u64> = first.keys().copied().collect();
    let seed = campaign.split.seed.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    let key = |t: u64| metrics::SplitMix(t ^ seed).next_u64();
    let mut ranked: Vec<(u64, u64)> = targets.iter().map(|&t| (key(t), t)).collect();
    ranked.sort_unstable();
    let want = ((frac * targets.len() as f64).round() as usize).max(1);
    let mut held: Vec<u64> = Vec::new();
    for &(_, t) in &ranked {
        if held.len() >= want || targets.len() - held.len() - 1 < MIN_TRAINING_TARGETS {
            break;
        }
        let value = |t: u64, v: usize| first[&t].x[v];
        // The held-out target must sit inside the training targets' span of every target-level
        // variable (interpolation, never extrapolation).
        let inside = TARGET_VARS.iter().all(|&v| {
            let rest = targets
                .iter()
                .filter(|&&o| o != t && !held.contains(&o))
                .map(|&o| value(o, v));
            let (lo, hi) = rest.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
                (lo.min(x), hi.max(x))
            });
            let x = value(t, v);
            let eps = 1e-6 * x.abs().max(1e-9);
            x >= lo - eps && x <= hi + eps
        });
        if inside {
            held.push(t);
        }
    }
    if !held.is_empty() {
        held.sort_unstable();
        return Holdout {
            by: "target".into(),
            targets: held,
            stations: Vec::new(),
        };
    }
    // Station hold-out, stratified over range within each target.
    let step = (1.0 / frac).ceil().max(2.0) as usize;
    let mut by_target: BTreeMap<u64, BTreeMap<u64, f64>> = BTreeMap::new();
    for r in rows.iter().filter(|r| r.target != 0) {
        by_target
            .entry(r.target)
            .or_default()
            .insert(r.station, r.x[V_RANGE]);
    }
    let mut stations = Vec::new();
    for (t, st) in by_target {
        if st.len() < 2 {
            continue;
        }
        let mut order: Vec<(f64, u64)> = st.into_iter().map(|(s, r)| (r, s)).collect();
        order.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let phase = (key(t) % step.min(order.len()) as u64) as usize;
        stations.extend(
            order
                .iter()
                .enumerate()
                .filter(|(i, _)| i % step == phase)
                .map(|(_, (_, s))| *s),
        );
    }
    if stations.is_empty() {
        return none;
    }
    stations.sort_unstable();
    Holdout {
        by: "station".into(),
        targets: Vec::new(),
        stations,
    }
}
