//! `summary.json` (schema `osiris.consistency/1`) and the self-contained `report.html` (inline SVG,
//! no JavaScript, no external CSS): header; verdict table (first failing metric outlined); where it
//! fails (residual vs each `[bins] explanatory` variable of the campaign with the ± tolerance band
//! and the bin means — bins from `[bins]` for range / azimuth / incidence (aspect) / reflectivity,
//! eight equal bins otherwise; unknown names are listed and skipped, an empty list plots range —
//! and heat maps of the mean residual with empty bins shown as coverage holes); distributions
//! (ECDF overlay with AVM/DVM); attribution (ranked effects, identifiability heat map, tie groups,
//! what-if before/after per station); before / after against the previous run of `--history`; the
//! trend of the headline errors over the run registry, annotated with the effects enabled or
//! accepted at each run; appendix.
//!
//! Checked by eye in headless Chromium (`chromium --headless --screenshot --window-size=1400,4000
//! file://…/report.html`); the charts use "nice" 1-2-5 ticks, legends on a white background, and
//! titles sized to their text.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use serde::Serialize;

use super::attribution::{EffectResult, QuantityAttribution, TieGroup};
use super::campaign::{Campaign, RunMeta, Tolerances};
use super::history::HistoryEntry;
use super::metrics::{BinnedMetric, DistributionMetrics, Metric, ResidualStats};
use super::pairing::DetectionCounts;

/// Where the simulated data came from.
#[derive(Debug, Clone, Serialize)]
pub struct ModelInfo {
    /// `simulated-trace` or `re-simulated`.
    pub source: String,
    /// Trace path or model configuration description.
    pub detail: String,
    pub enabled: Vec<String>,
    pub disabled: Vec<String>,
    pub osiris_version: String,
}

/// Pairing bookkeeping.
#[derive(Debug, Clone, Serialize)]
pub struct PairingInfo {
    pub views: usize,
    pub paired_frames: usize,
    pub missing_meas_frames: usize,
    pub missing_sim_frames: usize,
    pub rows: usize,
    pub counts: DetectionCounts,
}

/// What to do about one accepted effect (the top of `summary.json` and `report.html`).
#[derive(Debug, Clone, Serialize)]
pub struct Action {
    /// The effect id (for a model effect, also its switch).
    pub effect: String,
    /// The quantities it was accepted on.
    pub quantities: Vec<String>,
    /// `model`, `missing_physics` or `measurement` ([`super::catalogue::EffectKind`]).
    pub kind: super::catalogue::EffectKind,
    /// The model switch to turn on (model effects only).
    pub switch: Option<String>,
    /// The exact command that re-runs this campaign with the switch on (model effects only).
    pub command: Option<String>,
    /// One sentence: what to do.
    pub advice: String,
    /// Fitted parameters, `name = value`.
    pub params: Vec<(String, f64)>,
    /// RMS residual per attributed quantity now (calibration offset fitted on the training split
    /// removed), natural units.
    pub error_now: BTreeMap<String, f64>,
    /// Predicted headline error per quantity once the effect is in the model: the residual minus
    /// the effect's fitted signature (calibration offset refitted), natural units.
    pub predicted_error: BTreeMap<String, f64>,
}

/// The machine-readable result.
#[derive(Debug, Clone, Serialize)]
pub struct Summary {
    pub schema: &'static str,
    pub run: RunMeta,
    pub sensor: String,
    pub quantity_semantics: BTreeMap<String, String>,
    pub model: ModelInfo,
    pub status: String,
    /// Per accepted effect: the switch, the command to re-run with it, the predicted error.
    pub actions: Vec<Action>,
    pub metrics: Vec<Metric>,
    /// Headline RMS residual per quantity (natural units) after removing the fitted calibration
    /// offset (a reported nuisance).
    pub error: BTreeMap<String, f64>,
    /// Raw RMS residual per quantity (what the tolerances judge).
    pub error_raw: BTreeMap<String, f64>,
    /// Targets of the held-out split (`[split] holdout_fraction`, seeded; empty when stations are
    /// held out, see `holdout`).
    pub holdout_targets: Vec<u64>,
    /// The held-out split: by target or by station ([`super::split::Holdout`]).
    pub holdout: super::split::Holdout,
    /// RMS residual per quantity over the held-out rows only (calibration offset removed).
    pub holdout_error: BTreeMap<String, f64>,
    pub residual_stats: BTreeMap<String, ResidualStats>,
    pub distributions: BTreeMap<String, DistributionMetrics>,
    /// All effects, ranked best first (accepted first, then by ΔBIC).
    pub effects: Vec<EffectResult>,
    pub tie_groups: Vec<TieGroup>,
    pub attribution: Vec<QuantityAttribution>,
    pub binned: Vec<BinnedMetric>,
    pub pairing: PairingInfo,
    pub tolerance: Tolerances,
    /// Previous runs (with `--history`).
    pub history: Vec<HistoryEntry>,
    pub warnings: Vec<String>,
    pub catalogue_version: String,
}

impl Summary {
    /// Effects accepted in any quantity.
    pub fn accepted(&self) -> Vec<String> {
        self.effects
            .iter()
            .filter(|e| e.accepted)
            .map(|e| e.id.clone())
            .collect()
    }

    /// The effect result of an id (first quantity it appears in).
    pub fn effect(&self, id: &str) -> Option<&EffectResult> {
        self.effects.iter().find(|e| e.id == id)
    }
}

/// Axis tick label: integers without decimals, otherwise three significant decimals.
fn fmt_tick(v: f64) -> String {
    if v.is_finite() && (v - v.round()).abs() < 1e-9 * v.abs().max(1.0) && v.abs() < 1e9 {
        format!("{:.0}", v.round())
    } else {
        fmt(v)
    }
}

fn or_none(v: &[String]) -> String {
    if v.is_empty() {
        "none".into()
    } else {
        v.join(", ")
    }
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn fmt(v: f64) -> String {
    if !v.is_finite() {
        return format!("{v}");
    }
    let a = v.abs();
    if a != 0.0 && !(1e-3..1e5).contains(&a) {
        format!("{v:.3e}")
    } else {
        format!("{v:.3}")
    }
}

/// A simple SVG plot frame with linear axes and "nice" ticks (1, 2, 5 × 10ᵏ steps).
struct Plot {
    w: f64,
    h: f64,
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
    /// Integer ticks on x only (run index).
    int_x: bool,
    svg: String,
}

/// Plot area: left, top, right and bottom margins, px.
const PL: f64 = 62.0;
const PT: f64 = 30.0;
const PR: f64 = 20.0;
const PB: f64 = 40.0;

/// A "nice" tick step near `span / n` (1, 2 or 5 × 10ᵏ).
fn nice_step(span: f64, n: f64) -> f64 {
    let raw = (span / n).max(1e-300);
    let k = 10f64.powf(raw.log10().floor());
    let m = raw / k;
    k * if m <= 1.0 {
        1.0
    } else if m <= 2.0 {
        2.0
    } else if m <= 5.0 {
        5.0
    } else {
        10.0
    }
}

fn ticks(a: f64, b: f64, step: f64) -> Vec<f64> {
    let mut out = Vec::new();
    let mut t = (a / step).ceil() * step;
    while t <= b + 1e-9 * step && out.len() < 50 {
        out.push(if t.abs() < 1e-12 * step { 0.0 } else { t });
        t += step;
    }
    out
}

impl Plot {
    fn new(
        title: &str,
        xlabel: &str,
        ylabel: &str,
        (x0, x1): (f64, f64),
        (y0, y1): (f64, f64),
    ) -> Plot {
        let (x1, y1) = (
            if x1 > x0 { x1 } else { x0 + 1.0 },
            if y1 > y0 { y1 } else { y0 + 1.0 },
        );
        let mut p = Plot {
            w: 520.0,
            h: 310.0,
            x0,
            x1,
            y0,
            y1,
            int_x: false,
            svg: String::new(),
        };
        let _ = write!(
            p.svg,
            r##"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" class="plot"><rect x="{PL}" y="{PT}" width="{pw}" height="{ph}" fill="#fafafa" stroke="#999"/><text x="{cx}" y="16" text-anchor="middle" font-size="12">{t}</text><text x="{cx}" y="{xl}" text-anchor="middle" font-size="11">{xlab}</text><text x="12" y="{cy}" font-size="11" transform="rotate(-90 12 {cy})" text-anchor="middle">{ylab}</text>"##,
            w = p.w,
            h = p.h,
            pw = p.w - PL - PR,
            ph = p.h - PT - PB,
            cx = (PL + p.w - PR) / 2.0,
            cy = (PT + p.h - PB) / 2.0,
            xl = p.h - 6.0,
            t = esc(title),
            xlab = esc(xlabel),
            ylab = esc(ylabel),
        );
        p
    }
    /// Tick labels and grid lines (drawn by `finish`).
    fn axes(&mut self) {
        let xs = if self.int_x {
            ticks(self.x0, self.x1, nice_step(self.x1 - self.x0, 5.0).max(1.0))
        } else {
            ticks(self.x0, self.x1, nice_step(self.x1 - self.x0, 5.0))
        };
        let ys = ticks(self.y0, self.y1, nice_step(self.y1 - self.y0, 5.0));
        for x in xs {
            let px = self.px(x);
            let _ = write!(
                self.svg,
                r##"<line x1="{px:.1}" y1="{b:.1}" x2="{px:.1}" y2="{b2:.1}" stroke="#999"/><text x="{px:.1}" y="{ty}" font-size="10" text-anchor="middle">{l}</text>"##,
                b = self.h - PB,
                b2 = self.h - PB + 4.0,
                ty = self.h - PB + 14.0,
                l = fmt_tick(x),
            );
        }
        for y in ys {
            let py = self.py(y);
            let _ = write!(
                self.svg,
                r##"<line x1="{a}" y1="{py:.1}" x2="{b}" y2="{py:.1}" stroke="#e4e4e4"/><text x="{tx}" y="{ly:.1}" font-size="10" text-anchor="end">{l}</text>"##,
                a = PL,
                b = self.w - PR,
                tx = PL - 4.0,
                ly = py + 3.5,
                l = fmt_tick(y),
            );
        }
    }
    fn px(&self, x: f64) -> f64 {
        PL + (x - self.x0) / (self.x1 - self.x0) * (self.w - PL - PR)
    }
    fn py(&self, y: f64) -> f64 {
        let y = y.clamp(self.y0, self.y1);
        PT + (1.0 - (y - self.y0) / (self.y1 - self.y0)) * (self.h - PT - PB)
    }
    fn band(&mut self, lo: f64, hi: f64) {
        let (a, b) = (self.py(hi), self.py(lo));
        let _ = write!(
            self.svg,
            r##"<rect x="{PL}" y="{a}" width="{w}" height="{hh}" fill="#cfe8cf" opacity="0.6"/>"##,
            w = self.w - PL - PR,
            hh = (b - a).max(0.0)
        );
    }
    /// Hollow markers (a series drawn under another one stays visible).
    fn rings(&mut self, pts: &[(f64, f64)], color: &str) {
        for &(x, y) in pts {
            let _ = write!(
                self.svg,
                r##"<circle cx="{:.1}" cy="{:.1}" r="3.5" fill="none" stroke="{color}" stroke-width="1"/>"##,
                self.px(x),
                self.py(y)
            );
        }
    }
    fn points(&mut self, pts: &[(f64, f64)], color: &str) {
        for &(x, y) in pts {
            let _ = write!(
                self.svg,
                r##"<circle cx="{:.1}" cy="{:.1}" r="2" fill="{color}" opacity="0.7"/>"##,
                self.px(x),
                self.py(y)
            );
        }
    }
    fn line(&mut self, pts: &[(f64, f64)], color: &str) {
        if pts.is_empty() {
            return;
        }
        let d: Vec<String> = pts
            .iter()
            .map(|&(x, y)| format!("{:.1},{:.1}", self.px(x), self.py(y)))
            .collect();
        let _ = write!(
            self.svg,
            r##"<polyline points="{}" fill="none" stroke="{color}" stroke-width="1.5"/>"##,
            d.join(" ")
        );
    }
    fn legend(&mut self, items: &[(&str, &str)]) {
        let longest = items.iter().map(|i| i.0.chars().count()).max().unwrap_or(0) as f64;
        let _ = write!(
            self.svg,
            r##"<rect x="{x}" y="{y}" width="{w}" height="{h}" fill="#fff" opacity="0.85" stroke="#ccc"/>"##,
            x = self.w - 154.0,
            y = PT + 4.0,
            w = (22.0 + 5.6 * longest).min(150.0),
            h = 14.0 * items.len() as f64 + 6.0
        );
        for (i, (label, color)) in items.iter().enumerate() {
            let y = PT + 18.0 + 14.0 * i as f64;
            let _ = write!(
                self.svg,
                r##"<rect x="{x}" y="{y0}" width="10" height="10" fill="{color}"/><text x="{tx}" y="{ty}" font-size="10">{l}</text>"##,
                x = self.w - 150.0,
                y0 = y - 9.0,
                tx = self.w - 136.0,
                ty = y,
                l = esc(label)
            );
        }
    }
    /// A vertical annotation at `x` (reads bottom-up, inside the plot area).
    fn note(&mut self, x: f64, text: &str) {
        let px = self.px(x) + if x <= self.x0 { 10.0 } else { -4.0 };
        let py = self.h - PB - 4.0;
        let _ = write!(
            self.svg,
            r##"<text x="{px:.1}" y="{py:.1}" font-size="10" fill="#555" transform="rotate(-90 {px:.1} {py:.1})">{t}</text>"##,
            t = esc(text)
        );
    }
    fn finish(mut self) -> String {
        self.axes();
        self.svg.push_str("</svg>");
        self.svg
    }
}

fn range_of(v: impl Iterator<Item = f64>) -> (f64, f64) {
    v.filter(|x| x.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(x), b.max(x))
        })
}

fn heatmap(b: &BinnedMetric) -> String {
    let (nx, ny) = (b.x_edges.len() - 1, b.y_edges.len() - 1);
    let (cw, ch) = (64.0, 22.0);
    let title = format!(
        "mean residual {} over {} × {}",
        b.quantity, b.x_var, b.y_var
    );
    let (w, h) = (
        (90.0 + cw * nx as f64).max(7.0 * title.chars().count() as f64),
        64.0 + ch * ny as f64,
    );
    let mut s = format!(
        r##"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" class="plot"><text x="4" y="12" font-size="12">{t}</text><text x="4" y="{ny}" font-size="10" fill="#555">grey = empty bin (coverage hole); colour = mean / tolerance ({tol})</text>"##,
        t = esc(&title),
        ny = h - 4.0,
        tol = fmt(b.tolerance),
    );
    for iy in 0..ny {
        for ix in 0..nx {
            let (x, y) = (80.0 + cw * ix as f64, 20.0 + ch * (ny - 1 - iy) as f64);
            let (fill, label) = match b.mean[iy][ix] {
                None => ("#ddd".to_owned(), String::new()),
                Some(m) => {
                    let t = (m / b.tolerance).clamp(-1.0, 1.0);
                    let (r, g, bl) = if t >= 0.0 {
                        (255.0, 255.0 * (1.0 - t), 255.0 * (1.0 - t))
                    } else {
                        (255.0 * (1.0 + t), 255.0 * (1.0 + t), 255.0)
                    };
                    (format!("rgb({:.0},{:.0},{:.0})", r, g, bl), fmt(m))
                }
            };
            let _ = write!(
                s,
                r##"<rect x="{x}" y="{y}" width="{cw}" height="{ch}" fill="{fill}" stroke="#fff"/><text x="{tx}" y="{ty}" font-size="9" text-anchor="middle">{label}</text>"##,
                tx = x + cw / 2.0,
                ty = y + 14.0
            );
        }
        let _ = write!(
            s,
            r##"<text x="76" y="{}" font-size="9" text-anchor="end">{}–{}</text>"##,
            20.0 + ch * (ny - 1 - iy) as f64 + 14.0,
            fmt_tick(b.y_edges[iy]),
            fmt_tick(b.y_edges[iy + 1])
        );
    }
    for ix in 0..nx {
        let _ = write!(
            s,
            r##"<text x="{}" y="{}" font-size="9" text-anchor="middle">{}–{}</text>"##,
            80.0 + cw * (ix as f64 + 0.5),
            20.0 + ch * ny as f64 + 12.0,
            fmt_tick(b.x_edges[ix]),
            fmt_tick(b.x_edges[ix + 1])
        );
    }
    s.push_str("</svg>");
    s
}

/// Heat map of |cos| between the candidates' signatures on this design (red ≥ 0.95 = tie).
fn identifiability(a: &QuantityAttribution) -> String {
    let n = a.candidates.len();
    let c = 26.0;
    let left = 210.0;
    let (w, h) = ((left + c * n as f64 + 10.0).max(560.0), 58.0 + c * n as f64);
    let mut s = format!(
        r##"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" class="plot"><text x="4" y="14" font-size="12">identifiability ({q}): |cos| of centred signatures on this design</text><text x="4" y="{ny}" font-size="10" fill="#555">red ≥ 0.95 = not separable; grey = no variation at the nominal parameters</text>"##,
        q = esc(&a.quantity),
        ny = h - 4.0,
    );
    for (i, name) in a.candidates.iter().enumerate() {
        let y = 30.0 + c * i as f64;
        let _ = write!(
            s,
            r##"<text x="{x}" y="{ty}" font-size="10" text-anchor="end">{i}: {n}</text>"##,
            x = left - 4.0,
            ty = y + 16.0,
            n = esc(name)
        );
        for j in 0..n {
            let v = a.abs_cos[i][j];
            let fill = if v.is_nan() {
                "#ddd".to_owned()
            } else if v >= super::attribution::TIE_COS {
                "#c62828".to_owned()
            } else {
                let g = (255.0 * (1.0 - v)).round();
                format!("rgb(255,{g},{g})")
            };
            let _ = write!(
                s,
                r##"<rect x="{x}" y="{y}" width="{c}" height="{c}" fill="{fill}" stroke="#fff"><title>{a} vs {b}: {v:.3}</title></rect>"##,
                x = left + c * j as f64,
                a = esc(name),
                b = esc(&a.candidates[j]),
            );
        }
    }
    s.push_str("</svg>");
    s
}

/// The `[bins] explanatory` variables the report plots residuals against: (index in
/// [`super::VAR_NAMES`], name); unknown names are skipped (and listed in the report), an empty
/// list falls back to `range`.
pub fn explanatory_vars(campaign: &Campaign) -> Vec<(usize, &'static str)> {
    let mut out: Vec<(usize, &'static str)> = Vec::new();
    for v in &campaign.bins.explanatory {
        if let Some(i) = super::VAR_NAMES.iter().position(|n| n == v)
            && !out.iter().any(|(j, _)| *j == i)
        {
            out.push((i, super::VAR_NAMES[i]));
        }
    }
    if out.is_empty() {
        out.push((super::V_RANGE, "range"));
    }
    out
}

fn var_unit(name: &str) -> &'static str {
    match name {
        "range" | "edge" | "height" | "width" | "fog_vis" | "mount_h" => "m",
        "azimuth" | "elevation" | "aspect" => "deg",
        "area" => "m²",
        "reflectivity" => "%",
        "rain" => "mm/h",
        "prx" => "dB",
        _ => "-",
    }
}

/// Bin edges of a variable: the campaign's `[bins]` edges where it has them, else 8 equal bins.
fn bin_edges(campaign: &Campaign, name: &str, x0: f64, x1: f64) -> Vec<f64> {
    let b = &campaign.bins;
    match name {
        "range" => b.range_m.clone(),
        "azimuth" => b.azimuth_deg.clone(),
        "aspect" => b.incidence_deg.clone(),
        "reflectivity" => b.reflectivity_pct.clone(),
        _ if x1 > x0 => (0..=8)
            .map(|i| x0 + (x1 - x0) * f64::from(i) / 8.0)
            .collect(),
        _ => vec![x0 - 0.5, x0 + 0.5],
    }
}

/// Mean residual per bin at the bin's mean x (empty bins skipped).
fn bin_means(pts: &[(f64, f64)], edges: &[f64]) -> Vec<(f64, f64)> {
    let last = edges.len().saturating_sub(2);
    edges
        .windows(2)
        .enumerate()
        .filter_map(|(i, w)| {
            let sel: Vec<&(f64, f64)> = pts
                .iter()
                .filter(|p| p.0 >= w[0] && (p.0 < w[1] || (i == last && p.0 <= w[1])))
                .collect();
            (!sel.is_empty()).then(|| {
                let n = sel.len() as f64;
                (
                    sel.iter().map(|p| p.0).sum::<f64>() / n,
                    sel.iter().map(|p| p.1).sum::<f64>() / n,
                )
            })
        })
        .collect()
}

/// Renders the self-contained HTML report.
pub fn html(
    summary: &Summary,
    campaign: &Campaign,
    rows: &[super::Row],
    meas_values: &BTreeMap<&'static str, Vec<f64>>,
    sim_values: &BTreeMap<&'static str, Vec<f64>>,
) -> String {
    let mut h = String::new();
    let status_color = match summary.status.as_str() {
        "CONSISTENT" => "#2e7d32",
        "EXPLAINED" => "#1565c0",
        "PARTIALLY_EXPLAINED" => "#ef6c00",
        _ => "#c62828",
    };
    let _ = write!(
        h,
        r##"<!DOCTYPE html><html><head><meta charset="utf-8"><title>osiris consistency: {id}</title><style>body{{font-family:sans-serif;margin:20px;max-width:1200px}}table{{border-collapse:collapse;margin:8px 0}}td,th{{border:1px solid #ccc;padding:3px 8px;font-size:13px}}th{{background:#eee}}.pass{{color:#2e7d32}}.fail{{color:#c62828;font-weight:bold}}.badge{{display:inline-block;padding:4px 10px;color:#fff;border-radius:4px;background:{status_color}}}.plot{{margin:6px;border:1px solid #eee}}</style></head><body>"##,
        id = esc(&summary.run.id)
    );
    let _ = write!(
        h,
        "<h1>Consistency: {} <span class=\"badge\">{}</span></h1><p>{}</p><table><tr><th>sensor</th><td>{}</td></tr><tr><th>provenance</th><td>{}</td></tr><tr><th>licence</th><td>{}</td></tr><tr><th>model</th><td>{} ({}) osiris {}</td></tr><tr><th>enabled / disabled</th><td>{} / {}</td></tr><tr><th>quantity semantics</th><td>{}</td></tr><tr><th>frames</th><td>{} views, {} paired, {} missing from the measurement</td></tr></table>",
        esc(&summary.run.id),
        summary.status,
        esc(&summary.run.description),
        summary.sensor,
        esc(&summary.run.provenance),
        esc(&summary.run.licence),
        esc(&summary.model.source),
        esc(&summary.model.detail),
        esc(&summary.model.osiris_version),
        esc(&summary.model.enabled.join(", ")),
        esc(&summary.model.disabled.join(", ")),
        esc(&format!("{:?}", summary.quantity_semantics)),
        summary.pairing.views,
        summary.pairing.paired_frames,
        summary.pairing.missing_meas_frames,
    );
    // What to do: the accepted effects, their switches and the predicted fall of the error.
    if !summary.actions.is_empty() {
        h.push_str("<h2>What to do</h2><table><tr><th>effect</th><th>kind</th><th>fitted</th><th>error now</th><th>predicted with the effect</th><th>next step</th></tr>");
        for a in &summary.actions {
            let errs = |m: &BTreeMap<String, f64>| {
                m.iter()
                    .map(|(q, v)| format!("{q} {}", fmt(*v)))
                    .collect::<Vec<_>>()
                    .join("<br>")
            };
            let _ = write!(
                h,
                "<tr><td><b>{}</b></td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}{}</td></tr>",
                esc(&a.effect),
                a.kind.name(),
                esc(&a
                    .params
                    .iter()
                    .map(|(n, v)| format!("{n} = {}", fmt(*v)))
                    .collect::<Vec<_>>()
                    .join(", ")),
                errs(&a.error_now),
                errs(&a.predicted_error),
                esc(&a.advice),
                a.command
                    .as_deref()
                    .map(|c| format!("<br><code>{}</code>", esc(c)))
                    .unwrap_or_default()
            );
        }
        h.push_str("</table>");
    }
    // Verdict table.
    h.push_str("<h2>Verdict</h2><p>Residual RMS after removing the fitted calibration (a nuisance; the raw RMS and the calibration beside it).</p><table><tr><th>metric</th><th>value</th><th>95 % CI</th><th>tolerance</th><th>raw RMS</th><th>calibration removed</th><th>n</th><th>status</th></tr>");
    let first_fail = summary.metrics.iter().position(|m| !m.pass);
    for (i, m) in summary.metrics.iter().enumerate() {
        let _ = write!(
            h,
            "<tr{}><td>{}</td><td>{} {}</td><td>[{}, {}]</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td class=\"{}\">{}</td></tr>",
            if Some(i) == first_fail {
                " style=\"outline:2px solid #c62828\""
            } else {
                ""
            },
            esc(&m.id),
            fmt(m.value),
            m.unit,
            fmt(m.ci[0]),
            fmt(m.ci[1]),
            fmt(m.tolerance),
            m.raw_value.map(fmt).unwrap_or_else(|| "–".into()),
            match m.calibration {
                Some(c) if m.id.starts_with("intensity_pct") => format!("{} dB gain", fmt(c)),
                Some(c) => format!("{} {}", fmt(c), m.unit),
                None => "–".into(),
            },
            m.n,
            if m.pass { "pass" } else { "fail" },
            if m.pass { "pass" } else { "fail" }
        );
    }
    h.push_str("</table>");
    // Where it fails: residual vs each `[bins] explanatory` variable, tolerance band, bin means.
    h.push_str("<h2>Where it fails</h2>");
    let vars = explanatory_vars(campaign);
    let unknown: Vec<&String> = campaign
        .bins
        .explanatory
        .iter()
        .filter(|v| !super::VAR_NAMES.contains(&v.as_str()))
        .collect();
    if !unknown.is_empty() {
        let _ = write!(
            h,
            "<p>[bins] explanatory: unknown variable(s) {} ignored (known: {}).</p>",
            esc(&format!("{unknown:?}")),
            esc(&super::VAR_NAMES.join(", "))
        );
    }
    for q in super::metric_quantities(campaign.sensor.kind) {
        let tol = super::tolerance_of(q, &campaign.tolerance);
        for &(vi, name) in &vars {
            let pts: Vec<(f64, f64)> = rows
                .iter()
                .filter(|r| r.quantity == *q)
                .map(|r| (r.x[vi], r.resid()))
                .filter(|p| p.0.is_finite() && p.1.is_finite())
                .collect();
            if pts.is_empty() {
                continue;
            }
            let (x0, x1) = range_of(pts.iter().map(|p| p.0));
            let (y0, y1) = range_of(pts.iter().map(|p| p.1));
            let ym = y0.abs().max(y1.abs()).max(tol * 1.2);
            let lo = if vi == super::V_RANGE {
                0.0f64.min(x0)
            } else {
                x0
            };
            let mut p = Plot::new(
                &format!("residual {q} vs {name}"),
                &format!("{name} [{}]", var_unit(name)),
                &format!("meas − sim [{}]", super::metrics::unit_of(q)),
                (lo, x1),
                (-ym, ym),
            );
            p.band(-tol, tol);
            p.points(&pts, "#1565c0");
            let means = bin_means(&pts, &bin_edges(campaign, name, x0, x1));
            p.line(&means, "#c62828");
            p.legend(&[
                ("residual", "#1565c0"),
                ("bin mean", "#c62828"),
                ("± tolerance", "#cfe8cf"),
            ]);
            h.push_str(&p.finish());
        }
    }
    for b in &summary.binned {
        h.push_str(&heatmap(b));
    }
    // Distributions.
    h.push_str("<h2>Distributions</h2>");
    for (q, dm) in &summary.distributions {
        let (Some(m), Some(s)) = (meas_values.get(q.as_str()), sim_values.get(q.as_str())) else {
            continue;
        };
        let ecdf = |v: &[f64]| -> Vec<(f64, f64)> {
            let mut v = v.to_vec();
            v.sort_by(f64::total_cmp);
            let n = v.len() as f64;
            v.iter()
                .enumerate()
                .flat_map(|(i, x)| [(*x, i as f64 / n), (*x, (i + 1) as f64 / n)])
                .collect()
        };
        let (x0, x1) = range_of(m.iter().chain(s.iter()).copied());
        let mut p = Plot::new(
            &format!(
                "ECDF {q}: AVM {} , DVM bias {} , CAVM {}",
                fmt(dm.avm),
                fmt(dm.dvm_bias),
                fmt(dm.dvm_cavm)
            ),
            q,
            "F",
            (x0, x1),
            (0.0, 1.0),
        );
        p.line(&ecdf(m), "#c62828");
        p.line(&ecdf(s), "#1565c0");
        p.legend(&[("measured", "#c62828"), ("simulated", "#1565c0")]);
        h.push_str(&p.finish());
    }
    // Attribution.
    h.push_str("<h2>Attribution</h2>");
    for a in &summary.attribution {
        let _ = write!(
            h,
            "<h3>{} — {}</h3><p>{} rows in {} stations; pooled σ {} ; calibration offset {} ; χ²/dof {} → {} (threshold {}); σ inflation {}</p>",
            esc(&a.quantity),
            a.status.name(),
            a.rows,
            a.stations,
            fmt(a.noise.pooled_sd),
            a.calibration_offset
                .map(|c| format!("{} ± {}", fmt(c[0]), fmt(c[1])))
                .unwrap_or_else(|| "—".into()),
            fmt(a.baseline_chi2 / a.baseline_dof.max(1) as f64),
            fmt(a.final_chi2_per_dof),
            fmt(a.consistent_threshold),
            fmt(a.noise.inflation),
        );
        if a.effects.is_empty() {
            h.push_str("<p>No catalogue effect acts on this quantity.</p>");
        } else {
            h.push_str("<table><tr><th>effect</th><th>accepted</th><th>ΔBIC</th><th>weight</th><th>CV gain</th><th>explained</th><th>max contribution</th><th>θ ± σ</th><th>tie group</th><th>model switch</th></tr>");
            for e in &a.effects {
                let params: Vec<String> = e
                    .params
                    .iter()
                    .map(|p| {
                        format!(
                            "{} = {} ± {}{}",
                            p.name,
                            fmt(p.value),
                            fmt(p.sigma),
                            if p.at_bound { " (bound)" } else { "" }
                        )
                    })
                    .collect();
                let _ = write!(
                    h,
                    "<tr><td>{}</td><td class=\"{}\">{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
                    esc(&e.id),
                    if e.accepted { "pass" } else { "" },
                    e.accepted,
                    fmt(e.delta_bic),
                    fmt(e.bic_weight),
                    e.cv_gain.map(fmt).unwrap_or_else(|| "—".into()),
                    fmt(e.explained_share),
                    fmt(e.max_contribution),
                    esc(&params.join(", ")),
                    esc(e.tie_group.as_deref().unwrap_or("")),
                    esc(e.model_switch.as_deref().unwrap_or("—")),
                );
            }
            h.push_str("</table>");
        }
        if a.candidates.len() > 1 {
            h.push_str(&identifiability(a));
        }
        if !a.tie_groups.is_empty() {
            h.push_str("<p><b>Not separable on this design:</b></p><ul>");
            for t in &a.tie_groups {
                let _ = write!(
                    h,
                    "<li>{}: {} (|cos| {}, {}) — discriminating experiment: {}</li>",
                    esc(&t.id),
                    esc(&t.members.join(" ≈ ")),
                    fmt(t.max_abs_cos),
                    esc(&t.reason),
                    esc(&t.discriminating_experiment)
                );
            }
            h.push_str("</ul>");
        }
        if !a.what_if.is_empty() {
            let before: Vec<(f64, f64)> = a.what_if.iter().map(|r| (r[0], r[2])).collect();
            let after: Vec<(f64, f64)> = a.what_if.iter().map(|r| (r[0], r[3])).collect();
            let (x0, x1) = range_of(before.iter().map(|p| p.0));
            let (y0, y1) = range_of(before.iter().chain(&after).map(|p| p.1));
            let ym = y0.abs().max(y1.abs()).max(a.tolerance * 0.2);
            let mut p = Plot::new(
                &format!(
                    "what-if {}: station residual before / after {}",
                    a.quantity,
                    if a.accepted.is_empty() {
                        "(no effect accepted)".to_owned()
                    } else {
                        a.accepted.join(" + ")
                    }
                ),
                "range [m]",
                &format!(
                    "residual − offset [{}]",
                    super::metrics::unit_of(&a.quantity)
                ),
                (0.0f64.min(x0), x1),
                (-ym, ym),
            );
            if a.tolerance.is_finite() {
                p.band(-a.tolerance, a.tolerance);
            }
            p.rings(&before, "#c62828");
            p.points(&after, "#2e7d32");
            p.legend(&[("before (ring)", "#c62828"), ("after (dot)", "#2e7d32")]);
            h.push_str(&p.finish());
        }
        if let Some(d) = &a.diagnostics {
            let _ = write!(
                h,
                "<p><b>Residual structure not explained by the catalogue:</b> runs test z = {} ; Lomb–Scargle peak at period {} m (power {}, false-alarm probability {}).</p><table><tr><th>range bin [m]</th><th>mean residual</th><th>n</th></tr>",
                fmt(d.runs_z),
                fmt(d.lomb_scargle_period_m),
                fmt(d.lomb_scargle_power),
                fmt(d.lomb_scargle_fap)
            );
            for (lo, hi, m, n) in &d.binned_range {
                let _ = write!(
                    h,
                    "<tr><td>{}–{}</td><td>{}</td><td>{}</td></tr>",
                    fmt(*lo),
                    fmt(*hi),
                    fmt(*m),
                    n
                );
            }
            h.push_str("</table>");
        }
    }
    // Before / after: this run against the previous one of the registry.
    if let Some(prev) = summary.history.last() {
        let _ = write!(
            h,
            "<h2>Before / after</h2><p>previous run <b>{}</b> ({}; enabled: {}; accepted: {}) → this run <b>{}</b> ({}; enabled: {}; accepted: {})</p><table><tr><th>quantity</th><th>before</th><th>after</th><th>Δ</th><th>after / tolerance</th></tr>",
            esc(&prev.run_id),
            esc(&prev.status),
            esc(&or_none(&prev.enabled)),
            esc(&or_none(&prev.accepted)),
            esc(&summary.run.id),
            esc(&summary.status),
            esc(&or_none(&summary.model.enabled)),
            esc(&or_none(&summary.accepted())),
        );
        for (q, after) in &summary.error {
            let tol = super::tolerance_of(q, &campaign.tolerance);
            let before = prev.error.get(q).copied();
            let delta = before.map(|b| after - b);
            let _ = write!(
                h,
                "<tr><td>{}</td><td>{}</td><td>{}</td><td class=\"{}\">{}</td><td>{}</td></tr>",
                esc(q),
                before.map(fmt).unwrap_or_else(|| "—".into()),
                fmt(*after),
                match delta {
                    Some(d) if d < 0.0 => "pass",
                    Some(d) if d > 0.0 => "fail",
                    _ => "",
                },
                delta
                    .map(|d| format!("{}{}", if d > 0.0 { "+" } else { "" }, fmt(d)))
                    .unwrap_or_else(|| "—".into()),
                fmt(after / tol),
            );
        }
        h.push_str("</table>");
    }
    // History.
    if !summary.history.is_empty() {
        h.push_str("<h2>Trend</h2><table><tr><th>run</th><th>status</th><th>enabled</th><th>accepted</th><th>errors</th></tr>");
        for e in &summary.history {
            let errs: Vec<String> = e
                .error
                .iter()
                .map(|(k, v)| format!("{k} {}", fmt(*v)))
                .collect();
            let _ = write!(
                h,
                "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
                esc(&e.run_id),
                esc(&e.status),
                esc(&e.enabled.join(", ")),
                esc(&e.accepted.join(", ")),
                esc(&errs.join("; "))
            );
        }
        let errs: Vec<String> = summary
            .error
            .iter()
            .map(|(k, v)| format!("{k} {}", fmt(*v)))
            .collect();
        let _ = write!(
            h,
            "<tr style=\"font-weight:bold\"><td>{} (this run)</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr></table>",
            esc(&summary.run.id),
            esc(&summary.status),
            esc(&summary.model.enabled.join(", ")),
            esc(&summary.accepted().join(", ")),
            esc(&errs.join("; "))
        );
        let keys: Vec<String> = summary.error.keys().cloned().collect();
        let colors = ["#1565c0", "#c62828", "#2e7d32", "#6a1b9a", "#ef6c00"];
        // Previous runs, then this one.
        let runs: Vec<&BTreeMap<String, f64>> = summary
            .history
            .iter()
            .map(|e| &e.error)
            .chain([&summary.error])
            .collect();
        let n = runs.len() as f64;
        let series: Vec<(String, Vec<(f64, f64)>)> = keys
            .iter()
            .map(|k| {
                let tol = super::tolerance_of(k, &campaign.tolerance);
                (
                    k.clone(),
                    runs.iter()
                        .enumerate()
                        .filter_map(|(i, e)| e.get(k).map(|v| (i as f64, v / tol)))
                        .collect(),
                )
            })
            .collect();
        let ymax = series
            .iter()
            .flat_map(|s| s.1.iter().map(|p| p.1))
            .fold(1.2, f64::max);
        let mut p = Plot::new(
            "headline RMS / tolerance per run",
            "run (0 = oldest; annotations: effects enabled or accepted since the run before)",
            "RMS / tolerance",
            (0.0, (n - 1.0).max(1.0)),
            (0.0, ymax),
        );
        p.int_x = true;
        p.band(0.0, 1.0);
        let mut legend = Vec::new();
        for (i, (k, pts)) in series.iter().enumerate() {
            p.line(pts, colors[i % colors.len()]);
            p.points(pts, colors[i % colors.len()]);
            legend.push((k.as_str(), colors[i % colors.len()]));
        }
        // Annotate each run with what changed: effects enabled / accepted since the run before.
        let mut prev_set: Vec<String> = Vec::new();
        let all: Vec<(String, Vec<String>)> = summary
            .history
            .iter()
            .map(|e| {
                (
                    e.run_id.clone(),
                    e.enabled.iter().chain(&e.accepted).cloned().collect(),
                )
            })
            .chain([(
                summary.run.id.clone(),
                summary
                    .model
                    .enabled
                    .iter()
                    .cloned()
                    .chain(summary.accepted())
                    .collect(),
            )])
            .collect();
        for (i, (_, set)) in all.iter().enumerate() {
            let new: Vec<&String> = set.iter().filter(|e| !prev_set.contains(e)).collect();
            if !new.is_empty() {
                let txt: Vec<&str> = new.iter().map(|s| s.as_str()).collect();
                p.note(i as f64, &format!("+{}", txt.join(", +")));
            }
            prev_set = set.clone();
        }
        p.legend(&legend);
        h.push_str(&p.finish());
    }
    // Appendix.
    let _ = write!(
        h,
        "<h2>Appendix</h2><p>catalogue version {}; tolerances <code style=\"word-break:break-all\">{}</code></p>",
        esc(&summary.catalogue_version),
        esc(&serde_json::to_string(&summary.tolerance).unwrap_or_default())
    );
    if !summary.warnings.is_empty() {
        h.push_str("<h3>Warnings</h3><ul>");
        for w in &summary.warnings {
            let _ = write!(h, "<li>{}</li>", esc(w));
        }
        h.push_str("</ul>");
    }
    h.push_str("</body></html>");
    h
}
