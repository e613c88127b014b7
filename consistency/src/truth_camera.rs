//! The INDEPENDENT camera truth generator of the hidden-effect protocol (validation.md §8).
//!
//! It writes camera campaigns — a flat-field scenario SensorView trace, measured RAW frames (16-bit
//! PNG), "model" RAW frames for `--simulated` and `consistency.toml` — from the EMVA 1288 linear
//! camera model (EMVA Standard 1288 Release 4.0, §4: μ_y = K(μ_e + μ_d) + black, σ_y² = K²(σ_d² +
//! μ_e) + σ_q²) written out here again. It shares no code with `osiris_models::camera` nor with the
//! effect catalogue: its own Poisson (Knuth 1969 product method below λ = 40, rounded normal above)
//! and Gaussian noise (SplitMix64 + Box–Muller), its own fixed-pattern maps (Gaussian PRNU gain and
//! DSNU offset maps), dark current doubling every T_d kelvin, a relative-illumination polynomial
//! 1 − a₂ρ² − a₄ρ⁴ in the normalised image radius ρ (not cos⁴θ), full-well clipping, 12-bit ADC,
//! and an unknown black-level offset and gain of the measured camera (nuisances). The scene is a
//! flat field of 80 % reflectance, or (`chart`) a grey chart: each ROI a patch of its own
//! reflectance on the 80 % field.
//!
//! Hidden effects are *measurement physics the model lacks*: the measured frames have the effect at
//! a magnitude scaled to `magnitude` × the tolerance (its largest centred contribution to the
//! attribution quantity over the design), the model frames have it switched off.

use std::f64::consts::PI;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::Result;
use osiris_proto::{id, osi3};

use super::camera::{RawFrame, write_raw_png};
use super::metrics::SplitMix;
use osiris_proto::trace::OsiTraceWriter;

/// Hidden effects of the camera truth.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CameraHidden {
    /// Photon and dark shot noise (the model frames have none).
    ShotNoise,
    /// Temporal read noise.
    ReadNoise,
    /// Dark signal non-uniformity (fixed offset pattern).
    Dsnu,
    /// Photo-response non-uniformity (fixed gain pattern).
    Prnu,
    /// Dark current (doubling with temperature).
    DarkCurrent,
    /// Extra relative-illumination fall-off 1 − vρ² (polynomial, not cos⁴).
    Vignetting,
    /// A lower full well: the brightest ROIs clip.
    Saturation,
    /// A veiling luminance over the lit frames (a sunlit dashboard mirrored in the windshield): the
    /// dashboard's luminance, a fraction of a 100 % white's, times the windshield's reflectance at
    /// each pixel's incidence (a 28° rake, n = 1.52), the same on every patch; none with the lens
    /// capped. Needs a `chart` design to be told from a gain error.
    DashboardVeil,
    /// Not in the catalogue: rolling-shutter flicker banding, the illumination modulated along the
    /// rows as 1 + b·sin(2πy/(2.5·height) + φ) with a phase that changes every frame.
    FlickerBanding,
}

impl CameraHidden {
    /// The catalogue id expected to explain it (None: out of catalogue).
    pub fn expected(self) -> Option<&'static str> {
        Some(match self {
            CameraHidden::ShotNoise => "camera.shot_noise",
            CameraHidden::ReadNoise => "camera.read_noise",
            CameraHidden::Dsnu => "camera.dsnu",
            CameraHidden::Prnu => "camera.prnu",
            CameraHidden::DarkCurrent => "camera.dark_current",
            CameraHidden::Vignetting => "camera.vignetting",
            CameraHidden::Saturation => "camera.saturation",
            CameraHidden::DashboardVeil => "camera.dashboard_reflection",
            CameraHidden::FlickerBanding => return None,
        })
    }

    /// Whether it shows in the mean (else in the variance).
    pub fn in_mean(self) -> bool {
        matches!(
            self,
            CameraHidden::DarkCurrent
                | CameraHidden::Vignetting
                | CameraHidden::Saturation
                | CameraHidden::DashboardVeil
                | CameraHidden::FlickerBanding
        )
    }

    pub const ALL_IN_CATALOGUE: [CameraHidden; 7] = [
        CameraHidden::ShotNoise,
        CameraHidden::ReadNoise,
        CameraHidden::Dsnu,
        CameraHidden::Prnu,
        CameraHidden::DarkCurrent,
        CameraHidden::Vignetting,
        CameraHidden::Saturation,
    ];
}

/// A camera campaign design (a 12-bit RGGB sensor looking at a flat field).
#[derive(Debug, Clone)]
pub struct CameraTruth {
    pub seed: u64,
    pub width: usize,
    pub height: usize,
    /// Exposures of the lit frames, s (at the first temperature).
    pub exposures_s: Vec<f64>,
    /// Exposures of the dark frames, s (at every temperature).
    pub dark_exposures_s: Vec<f64>,
    /// Die temperatures, °C.
    pub temperatures_c: Vec<f64>,
    /// Frames per setting (≥ 2 gives temporal pairs).
    pub frames_per_setting: usize,
    /// ROI grid (columns, rows) and ROI size (w, h), px.
    pub roi_grid: [usize; 2],
    pub roi_size: [usize; 2],
    pub hidden: Option<CameraHidden>,
    /// A second hidden effect, present together with `hidden` (each scaled alone to `magnitude`).
    pub hidden2: Option<CameraHidden>,
    /// Magnitude of the hidden effect in tolerances.
    pub magnitude: f64,
    /// Unknown black-level offset of the measured camera, DN.
    pub black_offset_dn: f64,
    /// Unknown relative gain error of the measured camera.
    pub gain_error: f64,
    /// Measured frames dropped (indices).
    pub missing_frames: Vec<usize>,
    pub roi_mean_pct: f64,
    pub roi_variance_pct: f64,
    pub holdout_fraction: f64,
    /// A grey chart instead of the flat field: ROI k is a patch of `CHART_PCT[k % 9]` reflectance.
    pub chart: bool,
}

impl Default for CameraTruth {
    fn default() -> Self {
        CameraTruth {
            seed: 1,
            width: 128,
            height: 96,
            exposures_s: vec![0.001, 0.002, 0.004, 0.006, 0.008, 0.010],
            dark_exposures_s: vec![0.002, 0.02],
            temperatures_c: vec![40.0, 55.0],
            frames_per_setting: 2,
            roi_grid: [3, 3],
            roi_size: [32, 24],
            hidden: None,
            hidden2: None,
            magnitude: 1.0,
            black_offset_dn: 2.5,
            gain_error: 0.0,
            missing_frames: vec![3],
            roi_mean_pct: 5.0,
            roi_variance_pct: 20.0,
            holdout_fraction: 0.25,
            chart: false,
        }
    }
}

impl CameraTruth {
    /// The grey-chart scene (a patch of its own reflectance in each ROI), exposed 4–10 ms so that
    /// the darkest patch stays ≥ 100 DN in every channel (the unknown black offset is then ≤ 2.5 %
    /// of it, as on the flat field at 1 ms).
    pub fn with_chart(mut self) -> Self {
        self.chart = true;
        self.exposures_s = vec![0.004, 0.006, 0.008, 0.010];
        self
    }

    /// Reflectance of ROI `k`, %.
    fn roi_reflectance_pct(&self, k: usize) -> f64 {
        if self.chart {
            CHART_PCT[k % CHART_PCT.len()]
        } else {
            FIELD_PCT
        }
    }

    /// Reflectance of every pixel, % (the field outside the ROIs).
    fn reflectance_map(&self) -> Vec<f64> {
        let mut m = vec![FIELD_PCT; self.width * self.height];
        for (k, r) in rois(self).iter().enumerate() {
            for y in r[1]..(r[1] + r[3]).min(self.height) {
                for x in r[0]..(r[0] + r[2]).min(self.width) {
                    m[y * self.width + x] = self.roi_reflectance_pct(k);
                }
            }
        }
        m
    }
    /// A single-exposure design without temporal pairs or dark frames (look-alikes tie there).
    pub fn single_exposure(mut self) -> Self {
        self.exposures_s = vec![0.006];
        self.dark_exposures_s = vec![];
        self.temperatures_c = vec![40.0];
        self.missing_frames = vec![];
        self.frames_per_setting = 1;
        self.roi_grid = [4, 3];
        self
    }
}

/// Files of a generated camera campaign.
#[derive(Debug, Clone)]
pub struct CameraFiles {
    pub toml: PathBuf,
    pub sensor_view: PathBuf,
    /// Folder of the "model" RAW frames (for `--simulated`).
    pub simulated: PathBuf,
}

/// Parameters of one side (measured camera or model), EMVA 1288 terms.
#[derive(Debug, Clone, Copy)]
struct Side {
    /// System gain K, DN/e⁻.
    k_dn_per_e: f64,
    black_dn: f64,
    /// Read noise, DN rms.
    read_dn: f64,
    /// DSNU, DN rms.
    dsnu_dn: f64,
    /// PRNU, fraction rms.
    prnu: f64,
    /// Dark current at 25 °C, e⁻/s.
    dark_e_s: f64,
    /// Doubling temperature, K.
    doubling_k: f64,
    /// Scale of the shot-noise variance (1 = Poisson, 0 = none).
    shot: f64,
    full_well_e: f64,
    /// Extra relative-illumination coefficient v (1 − vρ²).
    vignetting: f64,
    /// Flicker banding amplitude b.
    banding: f64,
    /// Luminance of the dashboard mirrored in the windshield, as a fraction of a 100 % white's
    /// (the veil is this times the glass's reflectance, [`glass_reflectance`]).
    veil: f64,
}

/// The sensor (guessed automotive 12-bit values, EMVA-1288-style datasheet magnitudes).
const BASE: Side = Side {
    k_dn_per_e: 0.3,
    black_dn: 64.0,
    read_dn: 1.2,
    dsnu_dn: 0.6,
    prnu: 0.005,
    dark_e_s: 30.0,
    doubling_k: 6.5,
    shot: 1.0,
    full_well_e: 12_000.0,
    vignetting: 0.0,
    banding: 0.0,
    veil: 0.0,
};
/// Reflectance of the flat field, % (`RATE_E_S` is its signal).
const FIELD_PCT: f64 = 80.0;
/// Patch reflectances of the grey chart, %.
const CHART_PCT: [f64; 9] = [20.0, 60.0, 30.0, 80.0, 40.0, 90.0, 25.0, 50.0, 70.0];
const ADC_MAX: f64 = 4095.0;
/// Electron generation rate at the image centre per channel (R, G, B), e⁻/s.
const RATE_E_S: [f64; 3] = [0.7 * 840_000.0, 840_000.0, 0.5 * 840_000.0];

/// Relative illumination of both sides: 1 − 0.15ρ² − 0.05ρ⁴ (polynomial in the normalised radius).
fn ri_base(rho: f64) -> f64 {
    1.0 - 0.15 * rho * rho - 0.05 * rho.powi(4)
}

fn dark_rate(s: &Side, t_c: f64) -> f64 {
    s.dark_e_s * 2f64.powf((t_c - 25.0) / s.doubling_k)
}

/// Poisson variate (Knuth's product method below λ = 40, rounded normal above).
fn poisson(rng: &mut SplitMix, lambda: f64) -> f64 {
    if lambda <= 0.0 {
        return 0.0;
    }
    if lambda < 40.0 {
        let l = (-lambda).exp();
        let (mut k, mut p) = (0.0, 1.0);
        loop {
            p *= rng.unit();
            if p <= l {
                return k;
            }
            k += 1.0;
        }
    }
    (lambda + lambda.sqrt() * rng.normal()).round().max(0.0)
}

#[derive(Debug, Clone, Copy)]
struct FrameSpec {
    exposure_s: f64,
    temperature_c: f64,
    dark: bool,
}

/// CFA channel of an RGGB mosaic.
fn rggb(x: usize, y: usize) -> usize {
    match (y & 1, x & 1) {
        (0, 0) => 0,
        (1, 1) => 2,
        _ => 1,
    }
}

fn rois(spec: &CameraTruth) -> Vec<[usize; 4]> {
    let [nx, ny] = spec.roi_grid;
    let [rw, rh] = spec.roi_size;
    let mut out = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            let cx = (2 * i + 1) * spec.width / (2 * nx);
            let cy = (2 * j + 1) * spec.height / (2 * ny);
            let x = cx.saturating_sub(rw / 2).min(spec.width - rw) & !1;
            let y = cy.saturating_sub(rh / 2).min(spec.height - rh) & !1;
            out.push([x, y, rw, rh]);
        }
    }
    out
}

fn frames(spec: &CameraTruth) -> Vec<FrameSpec> {
    let t0 = spec.temperatures_c.first().copied().unwrap_or(40.0);
    let mut f = Vec::new();
    for &e in &spec.exposures_s {
        for _ in 0..spec.frames_per_setting {
            f.push(FrameSpec {
                exposure_s: e,
                temperature_c: t0,
                dark: false,
            });
        }
    }
    for &t in &spec.temperatures_c {
        for &e in &spec.dark_exposures_s {
            for _ in 0..spec.frames_per_setting {
                f.push(FrameSpec {
                    exposure_s: e,
                    temperature_c: t,
                    dark: true,
                });
            }
        }
    }
    f
}

/// Reflectance of a windshield (28° rake, index 1.52, two faces, no absorption, incoherent) for
/// the pinhole ray (60° horizontal field of view) through pixel position (x, y): per
/// polarisation the interface's r (Fresnel) and the slab's 2r/(1 + r), averaged.
fn glass_reflectance(spec: &CameraTruth, x: f64, y: f64) -> f64 {
    let f = 0.5 * spec.width as f64 / 30f64.to_radians().tan();
    let (dx, dy, dz) = (
        1.0,
        -(x - 0.5 * spec.width as f64) / f,
        -(y - 0.5 * spec.height as f64) / f,
    );
    let rake = 28f64.to_radians();
    let c = (dx * rake.sin() + dz * rake.cos()) / (dx * dx + dy * dy + dz * dz).sqrt();
    let n = 1.52;
    let ct = (1.0 - (1.0 - c * c) / (n * n)).sqrt();
    let rs = ((c - n * ct) / (c + n * ct)).powi(2);
    let rp = ((n * c - ct) / (n * c + ct)).powi(2);
    0.5 * (2.0 * rs / (1.0 + rs) + 2.0 * rp / (1.0 + rp))
}

/// Normalised radius of a pixel position (1 at the image corner).
fn rho(spec: &CameraTruth, x: f64, y: f64) -> f64 {
    let (cx, cy) = (0.5 * spec.width as f64, 0.5 * spec.height as f64);
    (x - cx).hypot(y - cy) / cx.hypot(cy)
}

fn banding(spec: &CameraTruth, y: f64, frame: usize) -> f64 {
    (2.0 * PI * y / (2.5 * spec.height as f64) + 2.399_963 * frame as f64).sin()
}

/// Expected (noise-free) ROI-channel statistics of one side: (signal above black DN, spatial
/// variance DN², temporal variance DN², dark?) per frame setting × ROI × channel.
fn expected(
    spec: &CameraTruth,
    s: &Side,
    frame_i: usize,
    f: &FrameSpec,
    (roi, refl_pct): ([usize; 4], f64),
    ch: usize,
) -> (f64, f64, f64) {
    let (x, y) = (
        roi[0] as f64 + 0.5 * roi[2] as f64,
        roi[1] as f64 + 0.5 * roi[3] as f64,
    );
    let r = rho(spec, x, y);
    let (light, veil) = if f.dark {
        (0.0, 0.0)
    } else {
        let lens = RATE_E_S[ch] * ri_base(r) * (1.0 - s.vignetting * r * r) * f.exposure_s;
        (
            lens * (1.0 + s.banding * banding(spec, y, frame_i)) * refl_pct / FIELD_PCT,
            lens * s.veil * glass_reflectance(spec, x, y) * 100.0 / FIELD_PCT,
        )
    };
    let e = (light + veil + dark_rate(s, f.temperature_c) * f.exposure_s).min(s.full_well_e);
    let k = s.k_dn_per_e;
    let temporal = k * k * s.shot * e + s.read_dn.powi(2) + 1.0 / 12.0;
    let spatial = temporal + s.dsnu_dn.powi(2) + (k * s.prnu * light).powi(2);
    (k * e, spatial, temporal)
}

/// Scales the hidden effect so that its largest centred contribution to the attribution quantity
/// (ROI mean in DN, or ROI variance in % of the model's) is `magnitude` × the tolerance.
fn hidden_side(spec: &CameraTruth) -> (Side, Side) {
    let hidden: Vec<CameraHidden> = spec.hidden.into_iter().chain(spec.hidden2).collect();
    let mut model = BASE;
    for h in &hidden {
        match h {
            CameraHidden::ShotNoise => model.shot = 0.0,
            CameraHidden::ReadNoise => model.read_dn = 0.0,
            CameraHidden::Dsnu => model.dsnu_dn = 0.0,
            CameraHidden::Prnu => model.prnu = 0.0,
            CameraHidden::DarkCurrent => model.dark_e_s = 0.0,
            _ => {}
        }
    }
    // Each effect is scaled alone (on the model side) to its target contribution, then all are
    // applied together.
    let mut meas = model;
    for &h in &hidden {
        let m = hidden_magnitude(spec, &model, h);
        meas = apply(meas, h, m);
    }
    (meas, model)
}

/// The mirrored dashboard's luminance of the measured camera (fraction of a 100 % white's; the
/// veil is this times the glass's reflectance; 0 unless [`CameraHidden::DashboardVeil`] is hidden).
pub fn hidden_veil_fraction(spec: &CameraTruth) -> f64 {
    hidden_side(spec).0.veil
}

/// The magnitude parameter of `h` whose largest centred contribution (alone, over `model`) is
/// `magnitude` × the tolerance of its quantity.
fn hidden_magnitude(spec: &CameraTruth, model: &Side, h: CameraHidden) -> f64 {
    let model = *model;
    let fr = frames(spec);
    let rs: Vec<([usize; 4], f64)> = rois(spec)
        .into_iter()
        .enumerate()
        .map(|(k, r)| (r, spec.roi_reflectance_pct(k)))
        .collect();
    // Tolerances as camera.rs derives them.
    let mut lit: Vec<f64> = Vec::new();
    for (i, f) in fr.iter().enumerate() {
        for r in &rs {
            for ch in 0..3 {
                let (sig, _, _) = expected(spec, &model, i, f, *r, ch);
                if !f.dark {
                    lit.push(sig);
                }
            }
        }
    }
    lit.sort_by(f64::total_cmp);
    let tol = if h.in_mean() {
        spec.roi_mean_pct / 100.0 * lit.get(lit.len() / 2).copied().unwrap_or(100.0)
    } else {
        spec.roi_variance_pct
    };
    let target = spec.magnitude * tol;
    let contribution = |m: f64| -> f64 {
        let meas = apply(model, h, m);
        let mut c = Vec::new();
        for (i, f) in fr.iter().enumerate() {
            for r in &rs {
                for ch in 0..3 {
                    let (sm, vm, tm) = expected(spec, &meas, i, f, *r, ch);
                    let (ss, vs, ts) = expected(spec, &model, i, f, *r, ch);
                    if h.in_mean() {
                        c.push(sm - ss);
                    } else {
                        c.push(100.0 * (vm - vs) / vs);
                        if spec.frames_per_setting >= 2 {
                            c.push(100.0 * (tm - ts) / ts);
                        }
                    }
                }
            }
        }
        let mean = c.iter().sum::<f64>() / c.len().max(1) as f64;
        c.iter().map(|v| (v - mean).abs()).fold(0.0, f64::max)
    };
    // Bisection on the monotone magnitude parameter.
    let (mut lo, mut hi) = (0.0, 1.0);
    while contribution(hi) < target && hi < 1e9 {
        hi *= 2.0;
    }
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if contribution(mid) < target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The measured side with the hidden effect at magnitude parameter `m` (monotone: larger m, larger
/// contribution).
fn apply(model: Side, h: CameraHidden, m: f64) -> Side {
    let mut s = model;
    match h {
        CameraHidden::ShotNoise => s.shot = m,
        CameraHidden::ReadNoise => s.read_dn = m.sqrt(),
        CameraHidden::Dsnu => s.dsnu_dn = m.sqrt(),
        CameraHidden::Prnu => s.prnu = 0.01 * m,
        CameraHidden::DarkCurrent => s.dark_e_s = 1e4 * m,
        CameraHidden::Vignetting => s.vignetting = m.min(0.95),
        // m = 0: no clipping below the largest signal; m = 1: clipped at 0.
        CameraHidden::Saturation => {
            s.full_well_e = 8_400.0 * 1.2 * (1.0 - m.min(1.0));
        }
        CameraHidden::FlickerBanding => s.banding = m.min(0.9),
        CameraHidden::DashboardVeil => s.veil = 0.01 * m,
    }
    s
}

/// Renders one frame of one side. `maps` = (PRNU map, DSNU map) of the side (unit normal);
/// `(refl_pct, glass)` = per pixel the scene reflectance (%) and the windshield reflectance.
#[allow(clippy::too_many_arguments)]
fn render(
    spec: &CameraTruth,
    s: &Side,
    f: &FrameSpec,
    frame_i: usize,
    maps: &(Vec<f64>, Vec<f64>),
    (refl_pct, glass): (&[f64], &[f64]),
    rng: &mut SplitMix,
    black_dn: f64,
    gain: f64,
) -> RawFrame {
    let (w, h) = (spec.width, spec.height);
    let mut data = Vec::with_capacity(w * h);
    let d = dark_rate(s, f.temperature_c) * f.exposure_s;
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let r = rho(spec, x as f64 + 0.5, y as f64 + 0.5);
            let light = if f.dark {
                0.0
            } else {
                let lens = RATE_E_S[rggb(x, y)]
                    * ri_base(r)
                    * (1.0 - s.vignetting * r * r)
                    * f.exposure_s
                    * (1.0 + s.prnu * maps.0[i]);
                lens * (1.0 + s.banding * banding(spec, y as f64 + 0.5, frame_i)) * refl_pct[i]
                    / FIELD_PCT
                    + lens * s.veil * glass[i] * 100.0 / FIELD_PCT
            };
            let mean_e = light + d;
            let e = if s.shot > 0.0 {
                let p = poisson(rng, mean_e);
                mean_e + s.shot.sqrt() * (p - mean_e)
            } else {
                mean_e
            };
            let e = e.clamp(0.0, s.full_well_e);
            let dn = gain * s.k_dn_per_e * e
                + s.dsnu_dn * maps.1[i]
                + s.read_dn * rng.normal()
                + black_dn;
            data.push(dn.round().clamp(0.0, ADC_MAX) as u16);
        }
    }
    RawFrame {
        width: w,
        height: h,
        data,
        black_level_dn: None,
    }
}

fn v3(x: f64, y: f64, z: f64) -> osi3::Vector3d {
    osi3::Vector3d {
        x: Some(x),
        y: Some(y),
        z: Some(z),
    }
}

fn orient(yaw: f64) -> osi3::Orientation3d {
    osi3::Orientation3d {
        roll: Some(0.0),
        pitch: Some(0.0),
        yaw: Some(yaw),
    }
}

/// The flat-field scenario: the host at rest, a large 80 % Lambertian board 4 m ahead of the
/// camera (mounted at [1.9, 0, 1.3] m), filling the view.
pub fn flat_field_view(t: f64) -> osi3::SensorView {
    let ts = osiris_proto::timestamp_from_seconds(t);
    let host = osi3::MovingObject {
        id: Some(id(1)),
        base: Some(osi3::BaseMoving {
            dimension: Some(osi3::Dimension3d {
                length: Some(4.5),
                width: Some(1.8),
                height: Some(1.5),
            }),
            position: Some(v3(0.0, 0.0, 0.75)),
            orientation: Some(orient(0.0)),
            velocity: Some(v3(0.0, 0.0, 0.0)),
            ..Default::default()
        }),
        r#type: Some(osi3::moving_object::Type::Vehicle as i32),
        vehicle_attributes: Some(osi3::moving_object::VehicleAttributes {
            bbcenter_to_rear: Some(v3(0.0, 0.0, 0.0)),
            ..Default::default()
        }),
        ..Default::default()
    };
    let board = osi3::StationaryObject {
        id: Some(id(100)),
        base: Some(osi3::BaseStationary {
            dimension: Some(osi3::Dimension3d {
                length: Some(0.05),
                width: Some(12.0),
                height: Some(9.0),
            }),
            position: Some(v3(5.9, 0.0, 1.3)),
            orientation: Some(orient(PI)),
            ..Default::default()
        }),
        model_reference: Some(
            "osiris:board?width_m=12&height_m=9&material=lambertian_80".to_string(),
        ),
        ..Default::default()
    };
    osi3::SensorView {
        timestamp: Some(ts),
        sensor_id: Some(id(7)),
        host_vehicle_id: Some(id(1)),
        mounting_position: Some(osi3::MountingPosition {
            position: Some(v3(1.9, 0.0, 1.3)),
            orientation: Some(orient(0.0)),
        }),
        global_ground_truth: Some(osi3::GroundTruth {
            timestamp: Some(ts),
            host_vehicle_id: Some(id(1)),
            moving_object: vec![host],
            stationary_object: vec![board],
            ..Default::default()
        }),
        ..Default::default()
    }
}

/// Writes the SensorView trace of `n` frames at 0.1 s spacing.
pub fn write_views(path: &Path, n: usize) -> Result<()> {
    write_views_of(path, n, &[])
}

/// [`write_views`] with `patches` (a grey chart) in front of the field.
fn write_views_of(path: &Path, n: usize, patches: &[osi3::StationaryObject]) -> Result<()> {
    let mut w = OsiTraceWriter::create(path)?;
    for i in 0..n {
        let mut v = flat_field_view(0.1 * i as f64);
        if let Some(gt) = v.global_ground_truth.as_mut() {
            gt.stationary_object.extend_from_slice(patches);
        }
        w.write_message(&v)?;
    }
    w.finish()?;
    Ok(())
}

/// Camera position of [`flat_field_view`] in global coordinates: the mounting (1.9, 0, 1.3) from
/// the host's reference point, its box centre (0, 0, 0.75) (`bbcenter_to_rear` = 0).
const FIELD_CAMERA: [f64; 3] = [1.9, 0.0, 2.05];
/// Global x of the field board's face towards the camera (centre 5.9, 5 cm thick).
const FIELD_FACE_X: f64 = 5.875;

/// The grey chart of a design for the scene of [`flat_field_view`]: one 1 cm board per ROI of
/// the ROI's reflectance (`lambertian_<pct>`), 2 cm in front of the field, centred on the ROI's
/// pinhole ray (the campaign's 60° horizontal field of view) and 20 % larger than its footprint.
pub fn chart_patches(spec: &CameraTruth) -> Vec<osi3::StationaryObject> {
    if !spec.chart {
        return Vec::new();
    }
    let f_px = 0.5 * spec.width as f64 / 30f64.to_radians().tan();
    let (cx, cy) = (0.5 * spec.width as f64, 0.5 * spec.height as f64);
    let x = FIELD_FACE_X - 0.02;
    let d = x - FIELD_CAMERA[0];
    rois(spec)
        .iter()
        .enumerate()
        .map(|(k, r)| {
            let (u, v) = (
                r[0] as f64 + 0.5 * r[2] as f64,
                r[1] as f64 + 0.5 * r[3] as f64,
            );
            let (w_m, h_m) = (1.2 * r[2] as f64 * d / f_px, 1.2 * r[3] as f64 * d / f_px);
            let pct = spec.roi_reflectance_pct(k).round() as i64;
            osi3::StationaryObject {
                id: Some(id(200 + k as u64)),
                base: Some(osi3::BaseStationary {
                    dimension: Some(osi3::Dimension3d {
                        length: Some(0.01),
                        width: Some(w_m),
                        height: Some(h_m),
                    }),
                    position: Some(v3(
                        x,
                        FIELD_CAMERA[1] - (u - cx) * d / f_px,
                        FIELD_CAMERA[2] - (v - cy) * d / f_px,
                    )),
                    orientation: Some(orient(PI)),
                    ..Default::default()
                }),
                model_reference: Some(format!(
                    "osiris:board?width_m={w_m:.4}&height_m={h_m:.4}&material=lambertian_{pct}"
                )),
                ..Default::default()
            }
        })
        .collect()
}

/// The `consistency.toml` text of a design (frames `frames/fNNN.png`).
pub fn campaign_toml(spec: &CameraTruth, run_id: &str) -> String {
    let mut t = String::new();
    let _ = writeln!(
        t,
        "schema = \"osiris.consistency/1\"\n\n[run]\nid = \"{run_id}\"\ndescription = \"camera \
         truth generator, flat field\"\nprovenance = \"osiris::consistency::truth_camera\"\n\n\
         [sensor]\nkind = \"camera\"\nwidth_px = {}\nheight_px = {}\ncfa = \"rggb\"\nbit_depth = \
         12\nhfov_deg = 60.0\nmounting_position_m = [1.9, 0.0, 1.3]\n\n[environment]\n\
         temperature_c = {}\n\n[traces]\nsensor_view = \"sv.osi\"\n\n[tolerance]\nroi_mean_pct = \
         {}\nroi_variance_pct = {}\n\n[split]\nholdout_fraction = {}\nseed = {}\n",
        spec.width,
        spec.height,
        spec.temperatures_c.first().copied().unwrap_or(40.0),
        spec.roi_mean_pct,
        spec.roi_variance_pct,
        spec.holdout_fraction,
        spec.seed
    );
    for (i, f) in frames(spec).iter().enumerate() {
        let _ = writeln!(
            t,
            "[[frame]]\nfile = \"frames/f{i:03}.png\"\ntimestamp_s = {:.1}\nexposure_s = {}\n\
             temperature_c = {}\ndark = {}\n",
            0.1 * i as f64,
            f.exposure_s,
            f.temperature_c,
            f.dark
        );
    }
    for (i, r) in rois(spec).iter().enumerate() {
        let _ = writeln!(
            t,
            "[[roi]]\nid = {}\nrect_px = [{}, {}, {}, {}]\ntarget = \"{}\"\n\
             reflectance_pct = {}\n",
            i + 1,
            r[0],
            r[1],
            r[2],
            r[3],
            if spec.chart {
                "grey chart patch"
            } else {
                "flat field"
            },
            spec.roi_reflectance_pct(i)
        );
    }
    t
}

/// Writes a camera campaign into `dir`: `consistency.toml`, `sv.osi`, `frames/` (measured) and
/// `model/` (the model's frames, the hidden effect switched off).
pub fn write_camera(dir: &Path, spec: &CameraTruth) -> Result<CameraFiles> {
    std::fs::create_dir_all(dir)?;
    let files = CameraFiles {
        toml: dir.join("consistency.toml"),
        sensor_view: dir.join("sv.osi"),
        simulated: dir.join("model"),
    };
    let (meas_side, model_side) = hidden_side(spec);
    let fr = frames(spec);
    let n = spec.width * spec.height;
    let mut rng_m = SplitMix(spec.seed.wrapping_mul(0x2545_F491_4F6C_DD1D) ^ 0xCA4E);
    let mut rng_s = SplitMix(spec.seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0x5151);
    let map = |rng: &mut SplitMix| -> (Vec<f64>, Vec<f64>) {
        (
            (0..n).map(|_| rng.normal()).collect(),
            (0..n).map(|_| rng.normal()).collect(),
        )
    };
    let maps_m = map(&mut rng_m);
    let maps_s = map(&mut rng_s);
    let refl = spec.reflectance_map();
    // The windshield's reflectance per pixel (the veil's shape), the same in every frame.
    let glass: Vec<f64> = (0..n)
        .map(|i| {
            let (x, y) = (i % spec.width, i / spec.width);
            glass_reflectance(spec, x as f64 + 0.5, y as f64 + 0.5)
        })
        .collect();
    for (i, f) in fr.iter().enumerate() {
        let name = format!("f{i:03}.png");
        let m = render(
            spec,
            &meas_side,
            f,
            i,
            &maps_m,
            (&refl, &glass),
            &mut rng_m,
            BASE.black_dn + spec.black_offset_dn,
            1.0 + spec.gain_error,
        );
        if !spec.missing_frames.contains(&i) {
            write_raw_png(&dir.join("frames").join(&name), &m)?;
        }
        let mut s = render(
            spec,
            &model_side,
            f,
            i,
            &maps_s,
            (&refl, &glass),
            &mut rng_s,
            BASE.black_dn,
            1.0,
        );
        s.black_level_dn = Some(BASE.black_dn);
        write_raw_png(&files.simulated.join(&name), &s)?;
    }
    write_views_of(&files.sensor_view, fr.len(), &chart_patches(spec))?;
    let run_id = format!(
        "camera-truth-{}-{}",
        match (spec.hidden, spec.hidden2) {
            (None, None) => "null".to_string(),
            (a, b) => a
                .into_iter()
                .chain(b)
                .map(|h| format!("{h:?}"))
                .collect::<Vec<_>>()
                .join("+"),
        },
        spec.seed
    );
    std::fs::write(&files.toml, campaign_toml(spec, &run_id))?;
    Ok(files)
}
