//! Multi-exposure / split-pixel HDR: capture sequence, merge to linear 20–24 bit, PWL companding.
//!
//! * **Captures** ([`HdrPipeline::captures`]): `single` — one capture; `dol` (digital overlap,
//!   ISX019 class) — exposures `t, t/r, t/r², …` read one after the other (start offsets
//!   consecutive); `split_pixel` (IMX490 class) — large PD at high and at low conversion gain and
//!   the small PD, all over the same window ([`PixelModel::split_pixel_captures`]).
//! * **Merge** ([`HdrPipeline::merge`]): inverse-variance weighted mean of the unsaturated
//!   captures (Granados et al., CVPR 2010; Debevec & Malik, SIGGRAPH 1997; physics.md §3.3):
//!   `Ê = Σ_j w_j (y_j − b_j)/G_j / Σ_j w_j`, `G_j = K_j g_j t_j s_j` [DN per e⁻/s],
//!   `w_j = G_j² / σ_j²`, `σ_j² = (K_j g_j)² (Ê_ref t_j s_j + σ_r,j²) + 1/12` with Ê_ref the
//!   estimate of the most sensitive unsaturated capture; written on the DN scale of capture 0:
//!   `y = b_0 + Ê·G_0`, clipped to `bit_depth` bits.
//! * **Companding** ([`HdrPipeline::compand`], `camera.hdr_companding`): piecewise-linear
//!   `y = y_k + (x − x_k)(y_{k+1} − y_k)/(x_{k+1} − x_k)` between knees (physics.md §3.3); the
//!   real knees are register settings under NDA, so they are configurable; [`HdrPipeline::decompand`]
//!   inverts it (the centre of the input interval of a code).

use std::sync::Mutex;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::RawImage;
use super::pixel::{ExposureSpec, PixelModel};
use crate::effects::{EffectInfo, Effects};
use crate::error::ModelError;

/// PWL companding of the merged linear RAW.
pub const HDR_COMPANDING: EffectInfo = EffectInfo {
    name: "camera.hdr_companding",
    default_on: true,
    summary: "PWL companding of the 20–24 bit merged RAW to 12–16 bit: y = y_k + (x − x_k)·Δy_k/Δx_k between knees (off: the linear RAW is passed on)",
    source: "PWL companding y = y_k + (x − x_k)/2^m_k (physics.md §3.3; Sony IMX490 24-bit → 12-bit output, knees register-specific)",
    requires: None,
};

/// HDR effects (`camera.hdr_companding`).
pub const EFFECTS: &[EffectInfo] = &[HDR_COMPANDING];

/// A capture is used by the merge only below this fraction of its clipping range (full well or
/// ADC top), so that noise around the clipping point does not bias the merge.
pub const SATURATION_MARGIN: f64 = 0.9;

/// How the captures of one frame are made.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum HdrMode {
    /// One capture; merge = copy; no companding.
    Single,
    /// Digital-overlap multi-exposure (ISX019 class).
    #[default]
    Dol,
    /// Split pixel: large PD at HCG and LCG, small PD (IMX490 class).
    SplitPixel,
}

/// HDR parameters (`"hdr"` key of the camera config). `Default` is the ISX019-class preset.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct HdrConfig {
    /// `"single"`, `"dol"` or `"split_pixel"`.
    pub mode: HdrMode,
    /// DOL: number of exposures (1–4).
    pub dol_exposures: u32,
    /// DOL: ratio of consecutive exposure times (> 1; default 16, guessed).
    pub exposure_ratio: f64,
    /// Bits of the merged linear RAW (20–24).
    pub bit_depth: u32,
    /// Bits of the companded RAW (12–16).
    pub companded_bits: u32,
    /// PWL knees `[[input_dn, output_dn], …]`, strictly increasing in both, starting at `[0, 0]`
    /// (absent: [`default_knees`] of `bit_depth` → `companded_bits`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub knees: Option<Vec<[f64; 2]>>,
}

impl Default for HdrConfig {
    fn default() -> Self {
        HdrConfig {
            mode: HdrMode::Dol,
            dol_exposures: 3,
            exposure_ratio: 16.0,
            bit_depth: 20,
            companded_bits: 12,
            knees: None,
        }
    }
}

fn cfg_err(key: &str, what: &str, got: impl std::fmt::Display) -> ModelError {
    ModelError::Config(format!("`camera.hdr.{key}` must be {what}, got {got}"))
}

/// IMX490-like default PWL curve (**guessed**: the real register values are under NDA): slopes
/// 1, 1/8, 1/64, 1/512 up to input 2¹⁸ (outputs 512, 960, 1408, 1856), then one segment to the
/// full scale of both bit depths. Knees at or beyond `2^in_bits / 4` are dropped.
pub fn default_knees(in_bits: u32, out_bits: u32) -> Vec<Knee> {
    let in_max = ((1u64 << in_bits) - 1) as f64;
    let out_max = ((1u64 << out_bits) - 1) as f64;
    let mut knees = vec![Knee {
        input_dn: 0.0,
        output_dn: 0.0,
    }];
    for (x, y) in [
        (512.0, 512.0),
        (4096.0, 960.0),
        (32768.0, 1408.0),
        (262_144.0, 1856.0),
    ] {
        if x < in_max / 4.0 && y < out_max / 2.0 {
            knees.push(Knee {
                input_dn: x,
                output_dn: y,
            });
        }
    }
    knees.push(Knee {
        input_dn: in_max,
        output_dn: out_max,
    });
    knees
}

impl HdrConfig {
    /// The defaults of a sensor preset: ISX019 DOL 3 × ratio 16 → 20 bit; IMX490 split pixel →
    /// 24 bit (LUCID tech brief); both companded to 12 bit.
    pub fn for_preset(preset: super::CameraPreset) -> HdrConfig {
        match preset {
            super::CameraPreset::Isx019 => HdrConfig::default(),
            super::CameraPreset::Imx490 => HdrConfig {
                mode: HdrMode::SplitPixel,
                bit_depth: 24,
                ..HdrConfig::default()
            },
        }
    }

    pub fn validate(&self) -> Result<(), ModelError> {
        if !(1..=4).contains(&self.dol_exposures) {
            return Err(cfg_err("dol_exposures", "in 1..=4", self.dol_exposures));
        }
        if !(self.exposure_ratio.is_finite()
            && self.exposure_ratio > 1.0
            && self.exposure_ratio <= 1024.0)
        {
            return Err(cfg_err(
                "exposure_ratio",
                "in (1, 1024]",
                self.exposure_ratio,
            ));
        }
        if !(20..=24).contains(&self.bit_depth) {
            return Err(cfg_err("bit_depth", "in 20..=24", self.bit_depth));
        }
        if !(12..=16).contains(&self.companded_bits) {
            return Err(cfg_err("companded_bits", "in 12..=16", self.companded_bits));
        }
        if let Some(k) = &self.knees {
            let out_max = ((1u64 << self.companded_bits) - 1) as f64;
            if k.len() < 2 {
                return Err(cfg_err("knees", "at least 2 knees", k.len()));
            }
            if k[0] != [0.0, 0.0] {
                return Err(cfg_err(
                    "knees",
                    "starting at [0, 0]",
                    format!("{:?}", k[0]),
                ));
            }
            for (i, pair) in k.windows(2).enumerate() {
                let (a, b) = (pair[0], pair[1]);
                if !(b[0].is_finite() && b[1].is_finite() && b[0] > a[0] && b[1] > a[1]) {
                    return Err(cfg_err(
                        "knees",
                        "strictly increasing in input and output",
                        format!("knee {} = {:?}", i + 1, b),
                    ));
                }
                if b[1] > out_max {
                    return Err(cfg_err(
                        "knees",
                        &format!("outputs ≤ {out_max} (companded_bits)"),
                        format!("knee {} = {:?}", i + 1, b),
                    ));
                }
            }
        }
        Ok(())
    }

    /// The knees in force.
    pub fn knees_or_default(&self) -> Vec<Knee> {
        match &self.knees {
            Some(k) => k
                .iter()
                .map(|&[input_dn, output_dn]| Knee {
                    input_dn,
                    output_dn,
                })
                .collect(),
            None => default_knees(self.bit_depth, self.companded_bits),
        }
    }
}

/// A PWL knee: linear input DN → companded output DN.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Knee {
    pub input_dn: f64,
    pub output_dn: f64,
}

/// Per-capture constants of the merge.
#[derive(Debug, Clone, Copy)]
struct MergeCapture {
    black: f64,
    /// K·g·t·s, DN per (e⁻/s).
    g: f64,
    /// t·s, s.
    ts: f64,
    /// 1/G, (e⁻/s) per DN.
    inv_g: f64,
    /// K², G².
    k2: f64,
    g2: f64,
    read_var_e2: f64,
    /// Largest usable DN.
    usable_dn: f64,
}

/// The planned HDR pipeline.
pub struct HdrPipeline {
    config: HdrConfig,
    companding: bool,
    knees: Vec<Knee>,
    /// The specs of the last [`Self::captures`] call (relative sensitivity, full well and read
    /// noise per capture index, which the RAW metadata does not carry).
    last_specs: Mutex<Vec<ExposureSpec>>,
}

impl HdrPipeline {
    pub fn new(config: &HdrConfig, effects: &Effects) -> Result<HdrPipeline, ModelError> {
        config.validate()?;
        Ok(HdrPipeline {
            config: config.clone(),
            companding: effects.is_on(&HDR_COMPANDING) && config.mode != HdrMode::Single,
            knees: config.knees_or_default(),
            last_specs: Mutex::new(Vec::new()),
        })
    }

    /// The configuration the pipeline was planned with.
    pub fn config(&self) -> &HdrConfig {
        &self.config
    }

    /// The captures of one frame, most sensitive first, for a base (longest) exposure time.
    pub fn captures(&self, pixel: &PixelModel, base_exposure_s: f64) -> Vec<ExposureSpec> {
        let specs = match self.config.mode {
            HdrMode::Single => vec![pixel.base_exposure(base_exposure_s)],
            HdrMode::Dol => {
                let mut start = 0.0;
                let mut t = base_exposure_s;
                (0..self.config.dol_exposures)
                    .map(|j| {
                        let spec = ExposureSpec {
                            time_s: t,
                            start_offset_s: start,
                            index: j,
                            ..pixel.base_exposure(t)
                        };
                        start += t;
                        t /= self.config.exposure_ratio;
                        spec
                    })
                    .collect()
            }
            HdrMode::SplitPixel => pixel.split_pixel_captures(base_exposure_s).to_vec(),
        };
        if let Ok(mut last) = self.last_specs.lock() {
            last.clone_from(&specs);
        }
        specs
    }

    /// Merge the captures (same order as [`Self::captures`]) into one linear RAW on the scale of
    /// the first capture (DN of capture 0, extended above its saturation), `out.bit_depth` 20–24.
    /// In `single` mode (or with one capture) the capture is copied.
    pub fn merge(&self, captures: &[RawImage], out: &mut RawImage) {
        self.merge_into(captures, out, None);
    }

    /// [`Self::merge`] then [`Self::compand`] of the result, in one pass over the rows.
    pub fn merge_and_compand(
        &self,
        captures: &[RawImage],
        linear: &mut RawImage,
        companded: &mut RawImage,
    ) {
        if !self.merge_into(captures, linear, Some(companded)) {
            self.compand(linear, companded);
        }
    }

    /// [`Self::merge`]; with `companded`, its rows companded in the same pass where companding is
    /// on and the captures merge. Returns whether `companded` was written.
    fn merge_into(
        &self,
        captures: &[RawImage],
        out: &mut RawImage,
        companded: Option<&mut RawImage>,
    ) -> bool {
        let Some(first) = captures.first() else {
            out.data.clear();
            out.width = 0;
            out.height = 0;
            return false;
        };
        if self.config.mode == HdrMode::Single || captures.len() == 1 {
            out.clone_from(first);
            return false;
        }
        let specs = self
            .last_specs
            .lock()
            .map(|s| s.clone())
            .unwrap_or_default();
        let mut plan = [MergeCapture {
            black: 0.0,
            g: 1.0,
            ts: 1.0,
            inv_g: 1.0,
            k2: 1.0,
            g2: 1.0,
            read_var_e2: 0.0,
            usable_dn: 0.0,
        }; 8];
        let n = captures.len().min(plan.len());
        for (j, raw) in captures.iter().take(n).enumerate() {
            let spec = specs.iter().find(|s| s.index == raw.exposure_index);
            let s = spec.map_or(1.0, |s| s.relative_sensitivity);
            let read = spec.map_or(0.0, |s| s.read_noise_e);
            let k = raw.conversion_gain_dn_per_e.max(1e-30);
            let ts = (raw.exposure_time_s * s).max(1e-30);
            let top = f64::from(raw.max_dn());
            let full = spec.map_or(f64::INFINITY, |s| raw.black_level_dn + k * s.full_well_e);
            let clip = top.min(full);
            plan[j] = MergeCapture {
                black: raw.black_level_dn,
                g: k * ts,
                ts,
                inv_g: 1.0 / (k * ts),
                k2: k * k,
                g2: (k * ts) * (k * ts),
                read_var_e2: read * read,
                usable_dn: raw.black_level_dn + SATURATION_MARGIN * (clip - raw.black_level_dn),
            };
        }
        let plan = &plan[..n];
        let (w, h) = (first.width, first.height);
        let out_max = ((1u64 << self.config.bit_depth) - 1) as f64;
        let g0 = plan[0].g;
        let b0 = plan[0].black;
        out.width = w;
        out.height = h;
        out.bit_depth = self.config.bit_depth;
        out.black_level_dn = first.black_level_dn;
        out.conversion_gain_dn_per_e = first.conversion_gain_dn_per_e;
        out.exposure_time_s = first.exposure_time_s;
        out.analog_gain = first.analog_gain;
        out.row_time_s = first.row_time_s;
        out.exposure_index = 0;
        // Every sample is written below (or zeroed where the captures do not match).
        out.data.resize(w * h, 0);
        if captures.iter().take(n).any(|c| c.data.len() != w * h) {
            out.data.fill(0);
            return false;
        }
        // The companded image: header now, rows in the merge pass.
        let mut companded = companded;
        let curve = match companded.as_deref_mut() {
            Some(c) if self.companding => {
                self.compand_header(out, c);
                Some(Pwl::new(&self.knees, self.config.companded_bits))
            }
            _ => None,
        };
        let captures = &captures[..n];
        let merge_row = |m: &mut MergeRow, y: usize, row: &mut [u32]| {
            let mut rows: [&[u32]; 8] = [&[]; 8];
            for (r, c) in rows.iter_mut().zip(captures) {
                *r = &c.data[y * w..(y + 1) * w];
            }
            m.merge(plan, &rows[..captures.len()]);
            for (o, &e) in row.iter_mut().zip(&m.num) {
                // Round half up within [0, out_max] (`as` truncates).
                *o = ((b0 + e * g0).clamp(0.0, out_max) + 0.5) as u32;
            }
        };
        let fused = curve.is_some();
        match (companded, curve) {
            (Some(c), Some(curve)) => out
                .data
                .par_chunks_mut(w.max(1))
                .zip(c.data.par_chunks_mut(w.max(1)))
                .enumerate()
                .for_each_init(MergeRow::default, |m, (y, (row, crow))| {
                    merge_row(m, y, row);
                    curve.apply(row, crow);
                }),
            _ => out
                .data
                .par_chunks_mut(w.max(1))
                .enumerate()
                .for_each_init(MergeRow::default, |m, (y, row)| merge_row(m, y, row)),
        }
        fused
    }

    /// PWL-compand a linear RAW (the knees are [`Self::knees`]); identity when
    /// `camera.hdr_companding` is off (or in `single` mode).
    pub fn compand(&self, linear: &RawImage, out: &mut RawImage) {
        if !self.companding {
            out.clone_from(linear);
            return;
        }
        self.compand_header(linear, out);
        let curve = Pwl::new(&self.knees, self.config.companded_bits);
        out.data
            .par_chunks_mut(4096)
            .zip(linear.data.par_chunks(4096))
            .for_each(|(o, l)| curve.apply(l, o));
    }

    /// Size and metadata of the companded image of `linear` (its samples sized, for the caller to
    /// write).
    fn compand_header(&self, linear: &RawImage, out: &mut RawImage) {
        out.width = linear.width;
        out.height = linear.height;
        out.bit_depth = self.config.companded_bits;
        out.black_level_dn = self.compand_value(linear.black_level_dn);
        out.conversion_gain_dn_per_e = linear.conversion_gain_dn_per_e;
        out.exposure_time_s = linear.exposure_time_s;
        out.analog_gain = linear.analog_gain;
        out.row_time_s = linear.row_time_s;
        out.exposure_index = linear.exposure_index;
        // Every sample is written by the caller.
        out.data.resize(linear.data.len(), 0);
    }

    /// The PWL curve (before the output rounding): linear DN → companded DN (continuous).
    pub fn compand_value(&self, x: f64) -> f64 {
        pwl_value(&self.knees, x)
    }

    /// Invert the companding (decompanding LUT), for tools reading companded RAW: the centre of
    /// the linear interval that maps to `companded_dn` (identity when companding is off).
    pub fn decompand(&self, companded_dn: u32) -> f64 {
        if !self.companding {
            return f64::from(companded_dn);
        }
        let k = &self.knees;
        if k.len() < 2 {
            return f64::from(companded_dn);
        }
        // Code y covers the outputs [y, y + 1) before flooring.
        let inv = |y: f64| -> f64 {
            if y <= k[0].output_dn {
                return k[0].input_dn;
            }
            let i = k.partition_point(|kn| kn.output_dn <= y).min(k.len() - 1);
            let (a, b) = (k[i - 1], k[i]);
            let x = a.input_dn
                + (y - a.output_dn) * (b.input_dn - a.input_dn) / (b.output_dn - a.output_dn);
            x.min(k[k.len() - 1].input_dn)
        };
        let y = f64::from(companded_dn);
        let lo = inv(y).ceil();
        let hi = (inv(y + 1.0).ceil() - 1.0).max(lo);
        0.5 * (lo + hi)
    }

    pub fn knees(&self) -> &[Knee] {
        &self.knees
    }
}

/// The PWL curve through `knees` (strictly increasing): `knees[0].output_dn` at and below the first
/// knee, linear between knees, at most the last knee's output.
#[inline]
fn pwl_value(k: &[Knee], x: f64) -> f64 {
    if k.len() < 2 {
        return x;
    }
    if x <= k[0].input_dn {
        return k[0].output_dn;
    }
    // The segment: the number of knees at or below x (≥ 1 here), counted without branches.
    let i = k
        .iter()
        .map(|kn| usize::from(kn.input_dn <= x))
        .sum::<usize>();
    let i = i.min(k.len() - 1);
    let (a, b) = (k[i - 1], k[i]);
    let y =
        a.output_dn + (x - a.input_dn) * (b.output_dn - a.output_dn) / (b.input_dn - a.input_dn);
    y.min(k[k.len() - 1].output_dn)
}

/// The companding curve applied to rows: [`pwl_value`], floored and clipped to the output range.
struct Pwl<'a> {
    knees: &'a [Knee],
    max: f64,
}

impl<'a> Pwl<'a> {
    fn new(knees: &'a [Knee], bits: u32) -> Pwl<'a> {
        Pwl {
            knees,
            max: ((1u64 << bits) - 1) as f64,
        }
    }

    fn apply(&self, linear: &[u32], out: &mut [u32]) {
        for (o, &v) in out.iter_mut().zip(linear) {
            // Floor of a non-negative value: `as` truncates.
            *o = pwl_value(self.knees, f64::from(v)).clamp(0.0, self.max) as u32;
        }
    }
}

/// Ê of a row of pixels, e⁻/s of large-PD-equivalent generation rate, in passes over the row
/// (branch-free per pixel: they vectorise).
///
/// The variances of the weights use the estimate of the most sensitive usable capture (the one
/// with the smallest relative error): in the shot-limited regime the weights then scale together
/// with it, so their ratios, and the merge, do not depend on that capture's noise. Where every
/// capture is saturated, the least sensitive capture's (clipped) value.
#[derive(Default)]
struct MergeRow {
    /// Σ w·Ê per pixel; after [`MergeRow::merge`], the merged Ê.
    num: Vec<f64>,
    /// The first usable capture's estimate per pixel (NaN: no usable capture).
    reference: Vec<f64>,
    /// Σ w per pixel.
    den: Vec<f64>,
}

impl MergeRow {
    /// Merge the rows of the captures (`rows[j]`: capture `j`, planned as `plan[j]`) into `num`.
    fn merge(&mut self, plan: &[MergeCapture], rows: &[&[u32]]) {
        let w = rows.first().map_or(0, |r| r.len());
        let (num, reference, den) = (&mut self.num, &mut self.reference, &mut self.den);
        num.clear();
        num.resize(w, 0.0);
        den.clear();
        den.resize(w, 0.0);
        reference.clear();
        reference.resize(w, f64::NAN);
        let est = |p: &MergeCapture, y: u32| (f64::from(y) - p.black) * p.inv_g;
        // The first usable capture's estimate: the captures from last to first, each usable one
        // replacing the reference.
        for (p, r) in plan.iter().zip(rows).rev() {
            for (re, &y) in reference.iter_mut().zip(r.iter()) {
                if f64::from(y) <= p.usable_dn {
                    *re = est(p, y).max(0.0);
                }
            }
        }
        // Inverse-variance weights of the usable captures, in capture order.
        for (p, r) in plan.iter().zip(rows) {
            for (((n, d), &re), &y) in num
                .iter_mut()
                .zip(den.iter_mut())
                .zip(&*reference)
                .zip(r.iter())
            {
                let var_dn = p.k2 * (re * p.ts + p.read_var_e2) + 1.0 / 12.0;
                let wgt = if f64::from(y) <= p.usable_dn {
                    p.g2 / var_dn
                } else {
                    0.0
                };
                *n += wgt * est(p, y);
                *d += wgt;
            }
        }
        let (last, r_last) = (plan.len() - 1, rows[rows.len() - 1]);
        for ((n, &d), (&re, &y)) in num.iter_mut().zip(&*den).zip(reference.iter().zip(r_last)) {
            *n = if re.is_nan() {
                est(&plan[last], y).max(0.0)
            } else {
                *n / d
            };
        }
    }
}
