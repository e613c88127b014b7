//! Camera campaigns of the consistency workflow (issue 7, camera part): RAW frames (16-bit grey
//! PNG) with ROIs and exposures in `consistency.toml`, per-ROI EMVA 1288 statistics (mean [DN],
//! variance [DN²], validation.md §2), residual rows for the attribution, and the re-simulation of
//! the frames through `osiris_models::build_sensor`.
//!
//! # `consistency.toml` additions (`sensor.kind = "camera"`)
//!
//! ```toml
//! [sensor]
//! kind = "camera"
//! width_px = 64            # required: RAW size
//! height_px = 48
//! cfa = "rggb"             # rggb | bggr | grbg | gbrg | mono (default rggb)
//! bit_depth = 12           # significant bits of the RAW (default 16)
//! black_level_dn = 64      # optional: measured black level (else a fitted nuisance offset)
//! hfov_deg = 60            # optional: horizontal field of view for the ROI field angles
//!                          # (default: the model configuration's, else 60°)
//!
//! [traces]
//! sensor_view = "sv.osi"   # the scenario (re-simulation); `sensor_data` is not needed
//!
//! [[frame]]                # one RAW exposure
//! file = "frames/f000.png" # 16-bit (or 8-bit) grey PNG, relative to the TOML
//! timestamp_s = 0.0        # pairs with the SensorView of that time (default: frame index × 0.1 s)
//! exposure_s = 0.004       # required
//! analog_gain = 1.0        # default 1
//! temperature_c = 40.0     # die temperature (default: [environment] temperature_c)
//! dark = false             # a dark frame (lens capped)
//!
//! [[roi]]
//! id = 1                   # required, > 0: the row's `target` (CV group, held-out split)
//! rect_px = [x, y, w, h]   # required
//! channel = "rgb"          # r | g | b | all | rgb (default: rgb = one row per CFA colour; mono: all)
//! target = "flat field"    # optional description (sky, asphalt, rear panel, ...)
//! reflectance_pct = 80     # optional
//!
//! [tolerance]
//! roi_mean_pct = 5         # ROI mean vs the simulated signal above black, %
//! roi_variance_pct = 20    # ROI variance vs the simulated variance, %
//! roi_mean_dn = 40         # optional: the attribution tolerance of the mean in DN
//!                          # (default: roi_mean_pct × the median simulated signal of the lit rows)
//! ```
//!
//! Frames missing on disk are skipped with a warning. Frames at identical settings (exposure, gain,
//! temperature, dark) pair in file order into temporal pairs: var(A − B)/2 holds no fixed pattern.
//!
//! # Rows
//!
//! Per frame × ROI × channel: a `roi_mean_dn` row (meas and sim ROI means, DN) and a
//! `roi_variance_pct` row, 100·ln(s²_meas/s²_sim) ("log-%", ≈ % for small differences), of the
//! plane-detrended spatial variance (EMVA 1288 removes the illumination gradient before the
//! non-uniformities); per temporal pair × ROI × channel a `roi_variance_pct` row of the temporal
//! variance var(A − B)/2 (`height` = 0). The log ratio is variance-stabilised: its standard error
//! depends on the pixel count and kurtosis only, not on the noisy value (weights that followed the
//! measured variance would bias the fit low). Each row carries its standard error in `x[V_PRX]`:
//! √((s²_m + s²_s)/n) for a mean; for a log variance √(Σ_sides ψ′(ν/2)), ν = n − 3 (Gaussian
//! sampling distribution of a detrended sample variance). Metric rows: `roi_mean_pct`
//! (lit rows only: the relative mean error) and `roi_variance_per_roi_pct` (per ROI × channel ×
//! kind, the frames pooled with inverse-variance weights, back to %: a per-frame variance of
//! ~100 pixels is too noisy to judge against a 20 % tolerance row by row).
//!
//! The explanatory variables reuse the common names ([`super::VAR_NAMES`]):
//! `range` = field angle of the ROI centre [deg], `azimuth` = its position angle [deg],
//! `elevation` = channel (0 R, 1 G, 2 B, 3 all), `aspect` = die temperature [°C], `area` = pixels,
//! `edge` = exposure [s], `reflectivity` = target reflectance [%], `height` = 1 spatial / 0
//! temporal, `width` = analog gain, `sim` = simulated mean signal above black [DN], `rain` = 1 for
//! a lit frame, 0 for a dark one (lens capped), `prx` = the row's standard error, `mount_h` =
//! simulated variance [DN²].

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, anyhow, bail};
use osiris_models::camera::Cfa;
use osiris_models::{SensorConfig, SensorModel, StepInput, StepOutput, build_sensor};
use osiris_proto::osi3;

use super::campaign::{Campaign, TVal, parse_toml};
use super::pairing::{Paired, read_trace, ts_ns};
use super::report::{ModelInfo, Summary};
use super::simulate::SimulateError;
use super::{ConsistencyArgs, NVARS, Row, V_PRX, V_SIM, quantity};

/// `[sensor]` keys read here (campaign.rs leaves them to this module).
pub const SENSOR_KEYS: &[&str] = &[
    "width_px",
    "height_px",
    "cfa",
    "bit_depth",
    "black_level_dn",
    "hfov_deg",
];
/// Root tables read here.
pub const ROOT_KEYS: &[&str] = &["frame", "roi"];

/// Variable slots of a camera row (see the module doc).
pub mod var {
    pub const FIELD_ANGLE_DEG: usize = 0;
    pub const POSITION_ANGLE_DEG: usize = 1;
    pub const CHANNEL: usize = 2;
    pub const TEMPERATURE_C: usize = 3;
    pub const PIXELS: usize = 4;
    pub const EXPOSURE_S: usize = 5;
    pub const REFLECTANCE_PCT: usize = 6;
    pub const SPATIAL: usize = 7;
    pub const ANALOG_GAIN: usize = 8;
    pub const SIM_SIGNAL_DN: usize = super::V_SIM;
    /// 1 for a lit frame, 0 for a dark one (the `rain` slot).
    pub const LIT: usize = 10;
    pub const SIGMA: usize = super::V_PRX;
    pub const SIM_VARIANCE_DN2: usize = 13;
}

/// Colour layout of the RAW.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum Layout {
    Mono,
    Bayer(#[serde(skip)] Cfa),
}

impl Layout {
    /// Channel of pixel (x, y): 0 R, 1 G, 2 B (mono: 3).
    pub fn channel(self, x: usize, y: usize) -> usize {
        match self {
            Layout::Mono => 3,
            Layout::Bayer(c) => c.channel(x, y),
        }
    }
}

/// The camera part of `[sensor]`.
#[derive(Debug, Clone, serde::Serialize)]
pub struct CameraSensorMeta {
    pub width_px: usize,
    pub height_px: usize,
    pub layout: Layout,
    pub bit_depth: u32,
    pub black_level_dn: Option<f64>,
    pub hfov_deg: Option<f64>,
}

/// One `[[frame]]`.
#[derive(Debug, Clone, serde::Serialize)]
pub struct FrameMeta {
    pub file: PathBuf,
    pub timestamp_s: f64,
    pub exposure_s: f64,
    pub analog_gain: f64,
    pub temperature_c: f64,
    pub dark: bool,
}

impl FrameMeta {
    /// Frames with equal keys are repeats (temporal pairs, one re-simulated model).
    fn setting_key(&self) -> (u64, u64, u64, bool) {
        (
            self.exposure_s.to_bits(),
            self.analog_gain.to_bits(),
            self.temperature_c.to_bits(),
            self.dark,
        )
    }
}

/// Which pixels of a ROI a row averages.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum RoiChannel {
    R,
    G,
    B,
    All,
    /// One row per CFA colour.
    Rgb,
}

/// One `[[roi]]`.
#[derive(Debug, Clone, serde::Serialize)]
pub struct RoiMeta {
    pub id: u64,
    /// [x, y, w, h], px.
    pub rect_px: [usize; 4],
    pub channel: RoiChannel,
    pub target: String,
    pub reflectance_pct: Option<f64>,
}

/// The camera part of a campaign.
#[derive(Debug, Clone, serde::Serialize)]
pub struct CameraCampaign {
    pub sensor: CameraSensorMeta,
    pub frames: Vec<FrameMeta>,
    pub rois: Vec<RoiMeta>,
    pub warnings: Vec<String>,
}

fn entry<'a>(t: &'a [(String, TVal)], k: &str) -> Option<&'a TVal> {
    t.iter().find(|(n, _)| n == k).map(|(_, v)| v)
}

fn num(t: &[(String, TVal)], path: &str, k: &str) -> Result<Option<f64>> {
    match entry(t, k) {
        None => Ok(None),
        Some(TVal::Num(v)) if v.is_finite() => Ok(Some(*v)),
        Some(_) => bail!("consistency.toml: `{path}.{k}` must be a finite number"),
    }
}

fn req_num(t: &[(String, TVal)], path: &str, k: &str) -> Result<f64> {
    num(t, path, k)?.ok_or_else(|| anyhow!("consistency.toml: missing required key `{path}.{k}`"))
}

fn string(t: &[(String, TVal)], path: &str, k: &str) -> Result<Option<String>> {
    match entry(t, k) {
        None => Ok(None),
        Some(TVal::Str(s)) => Ok(Some(s.clone())),
        Some(_) => bail!("consistency.toml: `{path}.{k}` must be a string"),
    }
}

fn unknown(t: &[(String, TVal)], path: &str, known: &[&str], warnings: &mut Vec<String>) {
    for (k, _) in t {
        if !known.contains(&k.as_str()) {
            warnings.push(format!(
                "consistency.toml: unknown key `{path}.{k}` ignored"
            ));
        }
    }
}

fn tables<'a>(root: &'a [(String, TVal)], k: &str) -> Result<Vec<&'a [(String, TVal)]>> {
    match entry(root, k) {
        None => Ok(Vec::new()),
        Some(TVal::Arr(a)) => a
            .iter()
            .enumerate()
            .map(|(i, v)| match v {
                TVal::Table(t) => Ok(t.as_slice()),
                _ => Err(anyhow!("consistency.toml: `{k}[{i}]` must be a table")),
            })
            .collect(),
        Some(_) => bail!("consistency.toml: `{k}` must be an array of tables ([[{k}]])"),
    }
}

impl CameraCampaign {
    /// Reads the camera tables of a campaign's TOML (the common tables are in [`Campaign`]).
    pub fn load(campaign: &Campaign, toml_path: &Path) -> Result<CameraCampaign> {
        let text = std::fs::read_to_string(toml_path)
            .with_context(|| format!("cannot read campaign `{}`", toml_path.display()))?;
        CameraCampaign::parse(&text, &campaign.dir, campaign.environment.temperature_c)
    }

    /// Parses the camera tables; relative paths resolve against `dir`.
    pub fn parse(text: &str, dir: &Path, default_temperature_c: f64) -> Result<CameraCampaign> {
        let root = parse_toml(text, "consistency.toml")?;
        let mut warnings = Vec::new();
        let Some(TVal::Table(s)) = entry(&root, "sensor") else {
            bail!("consistency.toml: missing required table `[sensor]`");
        };
        let dim = |k: &str| -> Result<usize> {
            let v = req_num(s, "sensor", k)?;
            if !((2.0..=65_536.0).contains(&v) && v.fract() == 0.0) {
                bail!("consistency.toml: `sensor.{k}` must be an integer in 2..=65536, got {v}");
            }
            Ok(v as usize)
        };
        let (width_px, height_px) = (dim("width_px")?, dim("height_px")?);
        let layout = match string(s, "sensor", "cfa")?.as_deref() {
            None | Some("rggb") => Layout::Bayer(Cfa::Rggb),
            Some("bggr") => Layout::Bayer(Cfa::Bggr),
            Some("grbg") => Layout::Bayer(Cfa::Grbg),
            Some("gbrg") => Layout::Bayer(Cfa::Gbrg),
            Some("mono") => Layout::Mono,
            Some(o) => bail!(
                "consistency.toml: `sensor.cfa` must be rggb, bggr, grbg, gbrg or mono, got `{o}`"
            ),
        };
        let bit_depth = match num(s, "sensor", "bit_depth")? {
            None => 16,
            Some(b) if (1.0..=16.0).contains(&b) && b.fract() == 0.0 => b as u32,
            Some(b) => bail!("consistency.toml: `sensor.bit_depth` must be 1..=16, got {b}"),
        };
        let black_level_dn = num(s, "sensor", "black_level_dn")?;
        if black_level_dn.is_some_and(|b| b < 0.0) {
            bail!("consistency.toml: `sensor.black_level_dn` must be >= 0");
        }
        let hfov_deg = num(s, "sensor", "hfov_deg")?;
        if hfov_deg.is_some_and(|h| !(h > 0.0 && h < 179.0)) {
            bail!("consistency.toml: `sensor.hfov_deg` must be in (0, 179)");
        }
        let mut frames = Vec::new();
        for (i, t) in tables(&root, "frame")?.into_iter().enumerate() {
            let p = format!("frame[{i}]");
            let file = string(t, &p, "file")?
                .ok_or_else(|| anyhow!("consistency.toml: missing required key `{p}.file`"))?;
            let exposure_s = req_num(t, &p, "exposure_s")?;
            if !(exposure_s > 0.0 && exposure_s <= 10.0) {
                bail!("consistency.toml: `{p}.exposure_s` must be in (0, 10] s, got {exposure_s}");
            }
            let analog_gain = num(t, &p, "analog_gain")?.unwrap_or(1.0);
            if analog_gain.is_nan() || analog_gain <= 0.0 {
                bail!("consistency.toml: `{p}.analog_gain` must be > 0");
            }
            let dark = match entry(t, "dark") {
                None => false,
                Some(TVal::Bool(b)) => *b,
                Some(_) => bail!("consistency.toml: `{p}.dark` must be a boolean"),
            };
            frames.push(FrameMeta {
                file: dir.join(file),
                timestamp_s: num(t, &p, "timestamp_s")?.unwrap_or(0.1 * i as f64),
                exposure_s,
                analog_gain,
                temperature_c: num(t, &p, "temperature_c")?.unwrap_or(default_temperature_c),
                dark,
            });
            unknown(
                t,
                &p,
                &[
                    "file",
                    "timestamp_s",
                    "exposure_s",
                    "analog_gain",
                    "temperature_c",
                    "dark",
                ],
                &mut warnings,
            );
        }
        if frames.is_empty() {
            bail!("consistency.toml: a camera campaign needs at least one [[frame]]");
        }
        let mut rois = Vec::new();
        for (i, t) in tables(&root, "roi")?.into_iter().enumerate() {
            let p = format!("roi[{i}]");
            let id = req_num(t, &p, "id")?;
            if !(id >= 1.0 && id.fract() == 0.0) {
                bail!("consistency.toml: `{p}.id` must be an integer >= 1");
            }
            let rect = match entry(t, "rect_px") {
                Some(TVal::Arr(a)) if a.len() == 4 => {
                    let mut r = [0usize; 4];
                    for (k, v) in a.iter().enumerate() {
                        match v {
                            TVal::Num(x) if *x >= 0.0 && x.fract() == 0.0 => r[k] = *x as usize,
                            _ => bail!(
                                "consistency.toml: `{p}.rect_px` must be 4 non-negative integers"
                            ),
                        }
                    }
                    r
                }
                None => bail!("consistency.toml: missing required key `{p}.rect_px`"),
                _ => bail!("consistency.toml: `{p}.rect_px` must be [x, y, w, h]"),
            };
            if rect[2] < 2
                || rect[3] < 2
                || rect[0] + rect[2] > width_px
                || rect[1] + rect[3] > height_px
            {
                bail!(
                    "consistency.toml: `{p}.rect_px` {rect:?} must be at least 2×2 and inside the \
                     {width_px}×{height_px} image"
                );
            }
            let channel = match string(t, &p, "channel")?.as_deref() {
                None if layout == Layout::Mono => RoiChannel::All,
                None | Some("rgb") => RoiChannel::Rgb,
                Some("r") => RoiChannel::R,
                Some("g") => RoiChannel::G,
                Some("b") => RoiChannel::B,
                Some("all") => RoiChannel::All,
                Some(o) => {
                    bail!("consistency.toml: `{p}.channel` must be r, g, b, all or rgb, got `{o}`")
                }
            };
            if layout == Layout::Mono && channel != RoiChannel::All {
                bail!("consistency.toml: `{p}.channel` must be \"all\" for a mono sensor");
            }
            rois.push(RoiMeta {
                id: id as u64,
                rect_px: rect,
                channel,
                target: string(t, &p, "target")?
                    .or(string(t, &p, "description")?)
                    .unwrap_or_default(),
                reflectance_pct: num(t, &p, "reflectance_pct")?,
            });
            unknown(
                t,
                &p,
                &[
                    "id",
                    "rect_px",
                    "channel",
                    "target",
                    "description",
                    "reflectance_pct",
                ],
                &mut warnings,
            );
        }
        if rois.is_empty() {
            bail!("consistency.toml: a camera campaign needs at least one [[roi]]");
        }
        Ok(CameraCampaign {
            sensor: CameraSensorMeta {
                width_px,
                height_px,
                layout,
                bit_depth,
                black_level_dn,
                hfov_deg,
            },
            frames,
            rois,
            warnings,
        })
    }
}

/// One RAW frame in DN.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RawFrame {
    pub width: usize,
    pub height: usize,
    pub data: Vec<u16>,
    /// Black level of this frame, DN, when known (PNG text `black_level_dn`, model metadata).
    pub black_level_dn: Option<f64>,
}

/// Reads a 16-bit (or 8-bit) greyscale PNG; the tEXt `black_level_dn` is honoured.
pub fn read_raw_png(path: &Path) -> Result<RawFrame> {
    let file =
        std::fs::File::open(path).with_context(|| format!("cannot open `{}`", path.display()))?;
    let mut dec = png::Decoder::new(std::io::BufReader::new(file));
    dec.set_transformations(png::Transformations::IDENTITY);
    let mut reader = dec
        .read_info()
        .with_context(|| format!("`{}` is not a PNG", path.display()))?;
    let info = reader.info();
    let (w, h) = (info.width as usize, info.height as usize);
    if info.color_type != png::ColorType::Grayscale {
        bail!(
            "`{}`: RAW frames must be greyscale PNGs, got {:?}",
            path.display(),
            info.color_type
        );
    }
    let depth = info.bit_depth;
    let black_level_dn = info
        .uncompressed_latin1_text
        .iter()
        .find(|t| t.keyword == "black_level_dn")
        .and_then(|t| t.text.trim().parse::<f64>().ok());
    let mut buf = vec![0u8; reader.output_buffer_size()];
    reader
        .next_frame(&mut buf)
        .with_context(|| format!("cannot decode `{}`", path.display()))?;
    let data: Vec<u16> = match depth {
        png::BitDepth::Sixteen => buf
            .chunks_exact(2)
            .take(w * h)
            .map(|c| u16::from_be_bytes([c[0], c[1]]))
            .collect(),
        png::BitDepth::Eight => buf.iter().take(w * h).map(|&v| u16::from(v)).collect(),
        d => bail!(
            "`{}`: RAW frames must be 8- or 16-bit, got {d:?}",
            path.display()
        ),
    };
    Ok(RawFrame {
        width: w,
        height: h,
        data,
        black_level_dn,
    })
}

/// Writes a 16-bit greyscale PNG with tEXt metadata (`black_level_dn` when known).
pub fn write_raw_png(path: &Path, frame: &RawFrame) -> Result<()> {
    if let Some(d) = path.parent() {
        std::fs::create_dir_all(d)?;
    }
    let file = std::fs::File::create(path)
        .with_context(|| format!("cannot create `{}`", path.display()))?;
    let mut enc = png::Encoder::new(
        std::io::BufWriter::new(file),
        frame.width as u32,
        frame.height as u32,
    );
    enc.set_color(png::ColorType::Grayscale);
    enc.set_depth(png::BitDepth::Sixteen);
    if let Some(b) = frame.black_level_dn {
        enc.add_text_chunk("black_level_dn".into(), format!("{b}"))?;
    }
    let mut w = enc.write_header()?;
    let bytes: Vec<u8> = frame.data.iter().flat_map(|v| v.to_be_bytes()).collect();
    w.write_image_data(&bytes)?;
    w.finish()?;
    Ok(())
}

/// Statistics of the pixels of one ROI channel in one frame.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RoiStat {
    pub n: usize,
    pub mean: f64,
    /// Variance about the least-squares plane a + b·x + c·y (dof n − 3), DN².
    pub variance: f64,
    /// Fourth central moment about the plane, DN⁴.
    pub m4: f64,
}

/// Channel index selection of a [`RoiChannel`] (3 = all pixels).
fn wanted(layout: Layout, x: usize, y: usize, ch: usize) -> bool {
    ch == 3 || layout.channel(x, y) == ch
}

/// Mean and plane-detrended variance of the pixels of channel `ch` in `rect` of `values(x, y)`.
fn plane_stats(
    layout: Layout,
    rect: [usize; 4],
    ch: usize,
    value: impl Fn(usize, usize) -> f64,
) -> RoiStat {
    let [x0, y0, w, h] = rect;
    let cx = x0 as f64 + 0.5 * w as f64;
    let cy = y0 as f64 + 0.5 * h as f64;
    // Normal equations of z = a + b·u + c·v.
    let mut m = [[0.0f64; 3]; 3];
    let mut rhs = [0.0f64; 3];
    let mut n = 0usize;
    let mut sum = 0.0;
    for y in y0..y0 + h {
        for x in x0..x0 + w {
            if !wanted(layout, x, y, ch) {
                continue;
            }
            let z = value(x, y);
            let f = [1.0, x as f64 - cx, y as f64 - cy];
            for i in 0..3 {
                for j in 0..3 {
                    m[i][j] += f[i] * f[j];
                }
                rhs[i] += f[i] * z;
            }
            n += 1;
            sum += z;
        }
    }
    if n < 4 {
        return RoiStat {
            n,
            mean: if n > 0 { sum / n as f64 } else { f64::NAN },
            ..Default::default()
        };
    }
    let coef = solve3(m, rhs).unwrap_or([sum / n as f64, 0.0, 0.0]);
    let (mut s2, mut s4) = (0.0, 0.0);
    for y in y0..y0 + h {
        for x in x0..x0 + w {
            if !wanted(layout, x, y, ch) {
                continue;
            }
            let r = value(x, y) - coef[0] - coef[1] * (x as f64 - cx) - coef[2] * (y as f64 - cy);
            s2 += r * r;
            s4 += r * r * r * r;
        }
    }
    RoiStat {
        n,
        mean: sum / n as f64,
        variance: s2 / (n - 3) as f64,
        m4: s4 / n as f64,
    }
}

fn solve3(mut a: [[f64; 3]; 3], mut b: [f64; 3]) -> Option<[f64; 3]> {
    for c in 0..3 {
        let p = (c..3).max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs()))?;
        if a[p][c].abs() < 1e-12 {
            return None;
        }
        a.swap(c, p);
        b.swap(c, p);
        for r in 0..3 {
            if r != c {
                let f = a[r][c] / a[c][c];
                let pivot = a[c];
                for (v, pv) in a[r].iter_mut().zip(pivot) {
                    *v -= f * pv;
                }
                b[r] -= f * b[c];
            }
        }
    }
    Some([b[0] / a[0][0], b[1] / a[1][1], b[2] / a[2][2]])
}

/// The channels one ROI yields rows for.
fn channels(roi: &RoiMeta) -> &'static [usize] {
    match roi.channel {
        RoiChannel::R => &[0],
        RoiChannel::G => &[1],
        RoiChannel::B => &[2],
        RoiChannel::All => &[3],
        RoiChannel::Rgb => &[0, 1, 2],
    }
}

/// Quantisation floor of a variance, DN² (uniform rounding, 1/12).
const QUANT_VAR_DN2: f64 = 1.0 / 12.0;

/// A simulated or measured frame set aligned with the campaign's `[[frame]]` list.
pub type FrameSet = Vec<Option<RawFrame>>;

/// Loads the measured frames (missing files → `None` with a warning).
pub fn load_measured(cc: &CameraCampaign, warnings: &mut Vec<String>) -> Result<FrameSet> {
    let mut out = Vec::with_capacity(cc.frames.len());
    for f in &cc.frames {
        if !f.file.exists() {
            warnings.push(format!(
                "measured frame `{}` is missing (skipped)",
                f.file.display()
            ));
            out.push(None);
            continue;
        }
        let fr = read_raw_png(&f.file)?;
        check_size(cc, &fr, &f.file)?;
        out.push(Some(fr));
    }
    Ok(out)
}

fn check_size(cc: &CameraCampaign, fr: &RawFrame, what: &Path) -> Result<()> {
    if fr.width != cc.sensor.width_px || fr.height != cc.sensor.height_px {
        bail!(
            "`{}` is {}×{}, the campaign says {}×{} (sensor.width_px/height_px)",
            what.display(),
            fr.width,
            fr.height,
            cc.sensor.width_px,
            cc.sensor.height_px
        );
    }
    Ok(())
}

/// Loads simulated frames from a folder holding PNGs named like the measured ones.
pub fn load_simulated_dir(
    cc: &CameraCampaign,
    dir: &Path,
    warnings: &mut Vec<String>,
) -> Result<FrameSet> {
    if !dir.is_dir() {
        bail!(
            "--simulated `{}`: a camera campaign takes a folder of simulated RAW PNGs named like \
             the measured frames",
            dir.display()
        );
    }
    let mut out = Vec::with_capacity(cc.frames.len());
    for f in &cc.frames {
        let name = f
            .file
            .file_name()
            .ok_or_else(|| anyhow!("frame file `{}` has no name", f.file.display()))?;
        let p = dir.join(name);
        if !p.exists() {
            warnings.push(format!("simulated frame `{}` is missing", p.display()));
            out.push(None);
            continue;
        }
        let fr = read_raw_png(&p)?;
        check_size(cc, &fr, &p)?;
        out.push(Some(fr));
    }
    Ok(out)
}

/// Focal length in px of the pinhole the field angles use.
fn focal_px(cc: &CameraCampaign, fallback_hfov_rad: f64) -> f64 {
    let hfov = cc
        .sensor
        .hfov_deg
        .map(f64::to_radians)
        .unwrap_or(fallback_hfov_rad);
    0.5 * cc.sensor.width_px as f64 / (0.5 * hfov).tan()
}

fn station(frame: usize, roi: u64, ch: usize, kind: u64) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for v in [frame as u64, roi, ch as u64, kind] {
        h ^= v;
        h = h.wrapping_mul(0x0000_0100_0000_01B3).rotate_left(29);
    }
    h
}

/// Builds the residual rows of a camera campaign from measured and simulated frames.
///
/// `fallback_hfov_rad`: field of view when `[sensor] hfov_deg` is absent. Returns the rows with the
/// bookkeeping of [`Paired`] (frames ↔ `views`, pooled ROI pixel values for W1).
pub fn pair_frames(
    cc: &CameraCampaign,
    meas: &FrameSet,
    sim: &FrameSet,
    fallback_hfov_rad: f64,
) -> Result<Paired> {
    let mut out = Paired {
        views: cc.frames.len(),
        ..Default::default()
    };
    let layout = cc.sensor.layout;
    let f_px = focal_px(cc, fallback_hfov_rad);
    let (w, h) = (cc.sensor.width_px as f64, cc.sensor.height_px as f64);
    let bl_meas_known = cc.sensor.black_level_dn;
    let sim_bl = |fr: &RawFrame| -> f64 {
        fr.black_level_dn
            .or(cc.sensor.black_level_dn)
            .unwrap_or(0.0)
    };
    if sim.iter().flatten().any(|f| f.black_level_dn.is_none()) && bl_meas_known.is_none() {
        out.warnings.push(
            "the simulated frames carry no black level and `sensor.black_level_dn` is absent: \
             signal levels assume a black level of 0 DN"
                .into(),
        );
    }
    // Per frame and ROI channel statistics.
    let mut stats: Vec<Option<Vec<(RoiStat, RoiStat)>>> = Vec::with_capacity(cc.frames.len());
    let mut frame = 0usize;
    for (i, fm) in cc.frames.iter().enumerate() {
        let (Some(m), Some(s)) = (&meas[i], &sim[i]) else {
            if meas[i].is_none() {
                out.missing_meas_frames += 1;
            } else {
                out.missing_sim_frames += 1;
            }
            stats.push(None);
            continue;
        };
        frame += 1;
        let bl_s = sim_bl(s);
        let bl_m = bl_meas_known.unwrap_or(bl_s);
        let mut per = Vec::new();
        for roi in &cc.rois {
            let [x0, y0, rw, rh] = roi.rect_px;
            let (rcx, rcy) = (
                x0 as f64 + 0.5 * rw as f64 - 0.5 * w,
                y0 as f64 + 0.5 * rh as f64 - 0.5 * h,
            );
            let field_deg = (rcx.hypot(rcy) / f_px).atan().to_degrees();
            let pos_deg = (-rcy).atan2(rcx).to_degrees();
            for &ch in channels(roi) {
                let sm = plane_stats(layout, roi.rect_px, ch, |x, y| {
                    f64::from(m.data[y * m.width + x])
                });
                let ss = plane_stats(layout, roi.rect_px, ch, |x, y| {
                    f64::from(s.data[y * s.width + x])
                });
                per.push((sm, ss));
                if sm.n < 4 {
                    continue;
                }
                let n = sm.n as f64;
                let signal = ss.mean - bl_s;
                let v_s = ss.variance.max(QUANT_VAR_DN2);
                let mut x = [0.0; NVARS];
                x[var::FIELD_ANGLE_DEG] = field_deg;
                x[var::POSITION_ANGLE_DEG] = pos_deg;
                x[var::CHANNEL] = ch as f64;
                x[var::TEMPERATURE_C] = fm.temperature_c;
                x[var::PIXELS] = n;
                x[var::EXPOSURE_S] = fm.exposure_s;
                x[var::REFLECTANCE_PCT] = roi.reflectance_pct.unwrap_or(0.0);
                x[var::SPATIAL] = 1.0;
                x[var::ANALOG_GAIN] = fm.analog_gain;
                x[var::SIM_SIGNAL_DN] = signal;
                x[var::LIT] = if fm.dark { 0.0 } else { 1.0 };
                x[var::SIM_VARIANCE_DN2] = v_s;
                let time_s = fm.timestamp_s;
                // Mean, DN.
                let mut xm = x;
                xm[V_PRX] = ((sm.variance.max(QUANT_VAR_DN2) + v_s) / n).sqrt();
                out.rows.push(Row {
                    quantity: quantity::CAMERA_MEAN_DN,
                    frame: i,
                    time_s,
                    target: roi.id,
                    station: station(i, roi.id, ch, 0),
                    meas: sm.mean,
                    sim: ss.mean,
                    x: xm,
                });
                // Mean relative to the signal (metric; lit rows well above the noise only).
                if !fm.dark && signal > 5.0 && signal > 10.0 * xm[V_PRX] {
                    let mut xp = xm;
                    xp[V_PRX] *= 100.0 / signal;
                    out.rows.push(Row {
                        quantity: quantity::CAMERA_MEAN_PCT,
                        frame: i,
                        time_s,
                        target: roi.id,
                        station: station(i, roi.id, ch, 1),
                        meas: 100.0 * ((sm.mean - bl_m) - signal) / signal,
                        sim: 0.0,
                        x: xp,
                    });
                }
                // Spatial variance, log-% of the simulated.
                let mut xv = x;
                let v_m = sm.variance.max(QUANT_VAR_DN2);
                xv[V_PRX] = log_ratio_sigma(&ss, sm.n, ss.n);
                out.rows.push(Row {
                    quantity: quantity::CAMERA_VARIANCE_PCT,
                    frame: i,
                    time_s,
                    target: roi.id,
                    station: station(i, roi.id, ch, 2),
                    meas: 100.0 * (v_m / v_s).ln(),
                    sim: 0.0,
                    x: xv,
                });
            }
        }
        stats.push(Some(per));
        // Pooled ROI pixel values (W1 of the ROI histograms, validation.md §2).
        for roi in &cc.rois {
            let [x0, y0, rw, rh] = roi.rect_px;
            for y in y0..y0 + rh {
                for x in x0..x0 + rw {
                    out.meas_values
                        .entry("roi_pixel_dn")
                        .or_default()
                        .push(f64::from(m.data[y * m.width + x]) - bl_m);
                    out.sim_values
                        .entry("roi_pixel_dn")
                        .or_default()
                        .push(f64::from(s.data[y * s.width + x]) - bl_s);
                }
            }
        }
    }
    out.paired_frames = frame;
    if frame == 0 {
        bail!("no camera frame has both a measured and a simulated RAW");
    }
    // Temporal pairs: consecutive frames of one setting, in file order.
    let mut open: BTreeMap<(u64, u64, u64, bool), usize> = BTreeMap::new();
    for (i, fm) in cc.frames.iter().enumerate() {
        if stats[i].is_none() {
            continue;
        }
        let key = fm.setting_key();
        let Some(a) = open.remove(&key) else {
            open.insert(key, i);
            continue;
        };
        let (ma, sa) = (
            meas[a].as_ref().expect("paired"),
            sim[a].as_ref().expect("paired"),
        );
        let (mb, sb) = (
            meas[i].as_ref().expect("paired"),
            sim[i].as_ref().expect("paired"),
        );
        let bl_s = 0.5 * (sim_bl(sa) + sim_bl(sb));
        for roi in &cc.rois {
            for &ch in channels(roi) {
                let base = out
                    .rows
                    .iter()
                    .find(|r| {
                        r.frame == i
                            && r.target == roi.id
                            && r.quantity == quantity::CAMERA_MEAN_DN
                            && r.x[var::CHANNEL] == ch as f64
                    })
                    .map(|r| r.x);
                let Some(mut x) = base else { continue };
                let diff = |p: &RawFrame, q: &RawFrame| {
                    plane_stats(layout, roi.rect_px, ch, |x, y| {
                        f64::from(p.data[y * p.width + x]) - f64::from(q.data[y * q.width + x])
                    })
                };
                let (dm, ds) = (diff(ma, mb), diff(sa, sb));
                if dm.n < 4 {
                    continue;
                }
                // var(A − B)/2.
                let (vm, vs) = (
                    (0.5 * dm.variance).max(QUANT_VAR_DN2),
                    (0.5 * ds.variance).max(QUANT_VAR_DN2),
                );
                let mean_s = 0.5
                    * (plane_stats(layout, roi.rect_px, ch, |x, y| {
                        f64::from(sa.data[y * sa.width + x])
                    })
                    .mean
                        + plane_stats(layout, roi.rect_px, ch, |x, y| {
                            f64::from(sb.data[y * sb.width + x])
                        })
                        .mean);
                x[var::SPATIAL] = 0.0;
                x[var::SIM_SIGNAL_DN] = mean_s - bl_s;
                x[var::SIM_VARIANCE_DN2] = vs;
                x[V_PRX] = log_ratio_sigma(&ds, dm.n, ds.n);
                out.rows.push(Row {
                    quantity: quantity::CAMERA_VARIANCE_PCT,
                    frame: i,
                    time_s: fm.timestamp_s,
                    target: roi.id,
                    station: station(i, roi.id, ch, 3 + ((a as u64) << 8)),
                    meas: 100.0 * (vm / vs).ln(),
                    sim: 0.0,
                    x,
                });
            }
        }
    }
    // The signatures' scale `mount_h` (the simulated variance) must not be the row's own noisy
    // value: its sampling error would enter residual and signature together (errors in variables:
    // a spurious positive fit of every additive term). It is the mean over the *other* ROIs of the
    // same frame, channel and kind (an approximation where the level varies over the field).
    let keys: Vec<(usize, u64, u64, u64, f64)> = out
        .rows
        .iter()
        .filter(|r| r.quantity == quantity::CAMERA_VARIANCE_PCT)
        .map(|r| {
            (
                r.frame,
                r.x[var::CHANNEL] as u64,
                r.x[var::SPATIAL] as u64,
                r.target,
                r.x[var::SIM_VARIANCE_DN2],
            )
        })
        .collect();
    for r in out
        .rows
        .iter_mut()
        .filter(|r| r.quantity == quantity::CAMERA_VARIANCE_PCT)
    {
        let (f, c, k, t) = (
            r.frame,
            r.x[var::CHANNEL] as u64,
            r.x[var::SPATIAL] as u64,
            r.target,
        );
        let (sum, n) = keys
            .iter()
            .filter(|e| e.0 == f && e.1 == c && e.2 == k && e.3 != t)
            .fold((0.0, 0usize), |(s, n), e| (s + e.4, n + 1));
        if n > 0 {
            r.x[var::SIM_VARIANCE_DN2] = sum / n as f64;
        }
    }
    // Known limitation: the spatial rows of one ROI channel share its fixed-pattern realisation
    // (another camera has another PRNU/DSNU map), a common error of ≈ 100·f·√(4/ν) log-% (f = the
    // fixed-pattern share of the spatial variance). The attribution treats rows as independent, so
    // a large fixed-pattern share over many frames overstates the evidence for small variance
    // effects; the temporal pairs carry no fixed pattern.
    // Metric rows: per ROI × channel × kind, the frames pooled (inverse-variance weights).
    type Pool = (f64, f64, [f64; NVARS]);
    let mut pooled: BTreeMap<(u64, u64, u64), Pool> = BTreeMap::new();
    for r in out
        .rows
        .iter()
        .filter(|r| r.quantity == quantity::CAMERA_VARIANCE_PCT)
    {
        let w = 1.0 / r.x[V_PRX].powi(2).max(1e-9);
        let e = pooled
            .entry((r.target, r.x[var::CHANNEL] as u64, r.x[var::SPATIAL] as u64))
            .or_insert((0.0, 0.0, r.x));
        e.0 += w * r.resid();
        e.1 += w;
    }
    for ((target, ch, kind), (sw, w, mut x)) in pooled {
        x[V_PRX] = 100.0 / w.sqrt();
        out.rows.push(Row {
            quantity: quantity::CAMERA_VARIANCE_ROI_PCT,
            frame: 0,
            time_s: 0.0,
            target,
            station: station(usize::MAX, target, ch as usize, 4 + kind),
            meas: 100.0 * ((sw / w / 100.0).exp() - 1.0),
            sim: 0.0,
            x,
        });
    }
    Ok(out)
}

/// Standard error of 100·ln(s²_m/s²_s), log-%: per side Var(ln s²) = ψ′(ν/2) ≈ 2/ν + 2/ν² + 4/(3ν³)
/// for a Gaussian sample variance with ν = n − 3 degrees of freedom (plane-detrended; Bartlett &
/// Kendall 1946). The Gaussian value is used on purpose: a kurtosis estimated from ~40 pixels is so
/// noisy that weights built on it bias the fit (and a Poisson sample is Gaussian-kurtic to O(1/λ)).
fn log_ratio_sigma(_sim: &RoiStat, n_m: usize, n_s: usize) -> f64 {
    let rel = |n: usize| {
        let nu = n.saturating_sub(3).max(2) as f64;
        2.0 / nu + 2.0 / (nu * nu) + 4.0 / (3.0 * nu * nu * nu)
    };
    100.0 * (rel(n_m) + rel(n_s)).sqrt()
}

/// The attribution tolerance of the ROI mean in DN: `tolerance.roi_mean_dn` when given, else
/// `roi_mean_pct` × the median simulated signal of the lit rows (floor 1 DN).
pub fn mean_tolerance_dn(campaign: &Campaign, rows: &[Row]) -> f64 {
    let t = campaign.tolerance.roi_mean_dn;
    if t.is_finite() && t > 0.0 {
        return t;
    }
    let mut lit: Vec<f64> = rows
        .iter()
        .filter(|r| r.quantity == quantity::CAMERA_MEAN_PCT)
        .map(|r| r.x[V_SIM])
        .collect();
    if lit.is_empty() {
        return (campaign.tolerance.roi_mean_pct / 100.0 * 100.0).max(1.0);
    }
    lit.sort_by(f64::total_cmp);
    (campaign.tolerance.roi_mean_pct / 100.0 * lit[lit.len() / 2]).max(1.0)
}

/// The model configuration of one frame setting: the campaign's (or `--model`) camera
/// configuration with the frame's exposure, temperature and size, one RAW exposure emitted, HDR
/// mode `single` (when the HDR config knows it) and the analog gain (when the pixel config knows
/// it). Remarks go to `warnings`.
pub fn frame_config(
    base: &SensorConfig,
    cc: &CameraCampaign,
    fm: &FrameMeta,
    warnings: &mut Vec<String>,
) -> SensorConfig {
    use osiris_models::camera::{CameraConfig, EmitConfig};
    let mut cfg = base.clone();
    let mut cam: CameraConfig = cfg.camera.clone().unwrap_or_default();
    cam.width_px = Some(cc.sensor.width_px);
    cam.height_px = Some(cc.sensor.height_px);
    cam.exposure_s = Some(fm.exposure_s);
    cam.temperature_c = Some(fm.temperature_c);
    cam.emit = EmitConfig {
        raw_exposures: true,
        raw_hdr_linear: false,
        raw_companded: false,
        isp: false,
    };
    if cam.hdr.is_none() {
        match serde_json::from_value(serde_json::json!({ "mode": "single" })) {
            Ok(h) => cam.hdr = Some(h),
            Err(_) => push_once(
                warnings,
                "the camera HDR config has no `mode = \"single\"`: the preset's HDR captures are \
                 used (the first RAW exposure is compared)",
            ),
        }
    }
    if fm.analog_gain != 1.0 {
        let pixel = cam
            .pixel
            .clone()
            .unwrap_or_else(|| osiris_models::camera::pixel::PixelConfig::for_preset(cam.preset));
        let mut v = serde_json::to_value(&pixel).unwrap_or_default();
        let set = v
            .as_object_mut()
            .filter(|o| o.contains_key("analog_gain"))
            .map(|o| o.insert("analog_gain".into(), serde_json::json!(fm.analog_gain)))
            .is_some();
        match serde_json::from_value(v) {
            Ok(p) if set => cam.pixel = Some(p),
            _ => push_once(
                warnings,
                "the camera pixel config has no `analog_gain`: frames are simulated at unity gain",
            ),
        }
    }
    if fm.dark {
        push_once(
            warnings,
            "dark frames are simulated with the scene as given (cap the lens in the scenario: no \
             light source, or a black target)",
        );
    }
    cfg.camera = Some(cam);
    cfg
}

fn push_once(warnings: &mut Vec<String>, w: &str) {
    if !warnings.iter().any(|x| x == w) {
        warnings.push(w.to_owned());
    }
}

/// Decodes the first RAW exposure (index 0) of a camera step.
pub fn raw_of_step(out: &StepOutput) -> Option<RawFrame> {
    use osiris_proto::perception::camera_image::Kind;
    let cam = out.perception.camera.as_ref()?;
    let img = cam
        .image
        .iter()
        .filter(|i| i.kind == Some(Kind::RawExposure as i32))
        .min_by_key(|i| i.exposure_index.unwrap_or(0))?;
    let data = img.data.as_ref()?;
    Some(RawFrame {
        width: img.width_px? as usize,
        height: img.height_px? as usize,
        data: data
            .chunks_exact(2)
            .map(|c| u16::from_le_bytes([c[0], c[1]]))
            .collect(),
        black_level_dn: img.black_level_dn,
    })
}

/// Re-simulates every frame through `build_sensor`: one model per frame setting (the same seed,
/// so the same fixed pattern; repeats are successive steps, so fresh temporal noise), the frame's
/// SensorView by timestamp (±0.5 ms; else the view of the same index).
///
/// An error when the model cannot be built or stepped, or when every simulated RAW is zero (no
/// light reached the model: nothing to compare).
pub fn simulate_frames(
    base: &SensorConfig,
    cc: &CameraCampaign,
    views: &[osi3::SensorView],
    warnings: &mut Vec<String>,
) -> Result<FrameSet, SimulateError> {
    type Setting = (u64, u64, u64, bool);
    let mut models: Vec<(Setting, Box<dyn SensorModel>)> = Vec::new();
    let mut out = Vec::with_capacity(cc.frames.len());
    let mut step = StepOutput::default();
    let view_ts: Vec<Option<i128>> = views
        .iter()
        .map(|v| {
            ts_ns(
                v.timestamp.as_ref().or(v
                    .global_ground_truth
                    .as_ref()
                    .and_then(|g| g.timestamp.as_ref())),
            )
        })
        .collect();
    for (i, fm) in cc.frames.iter().enumerate() {
        let t_ns = (fm.timestamp_s * 1e9).round() as i128;
        let vi = view_ts
            .iter()
            .enumerate()
            .filter_map(|(k, t)| t.map(|t| (k, (t - t_ns).abs())))
            .filter(|(_, d)| *d <= 500_000)
            .min_by_key(|(_, d)| *d)
            .map(|(k, _)| k)
            .or((i < views.len()).then_some(i));
        let Some(vi) = vi else {
            warnings.push(format!(
                "frame {i} (t = {:.6} s) has no SensorView: not simulated",
                fm.timestamp_s
            ));
            out.push(None);
            continue;
        };
        let key = fm.setting_key();
        let pos = match models.iter().position(|(k, _)| *k == key) {
            Some(p) => p,
            None => {
                let cfg = frame_config(base, cc, fm, warnings);
                let mut m = match build_sensor(cfg) {
                    Ok(m) => m,
                    Err(e) => return Err(SimulateError::Other(anyhow!("{e}"))),
                };
                let req = m.view_configuration_request();
                m.apply_view_configuration(&req)
                    .map_err(|e| anyhow!("view configuration: {e}"))?;
                models.push((key, m));
                models.len() - 1
            }
        };
        let model = &mut models[pos].1;
        let stepped = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            model.step(
                &StepInput {
                    view: &views[vi],
                    time_s: fm.timestamp_s,
                    step_s: base.update_cycle_s,
                },
                &mut step,
            )
        }));
        match stepped {
            Ok(r) => r.map_err(|e| anyhow!("frame {i}: {e}"))?,
            Err(_) => {
                return Err(SimulateError::Other(anyhow!(
                    "the camera model panicked at frame {i}"
                )));
            }
        }
        let raw = raw_of_step(&step).ok_or_else(|| {
            anyhow!("frame {i}: the camera model emitted no RAW exposure (emit.raw_exposures)")
        })?;
        if raw.width != cc.sensor.width_px || raw.height != cc.sensor.height_px {
            return Err(SimulateError::Other(anyhow!(
                "frame {i}: the model's RAW is {}×{}, the campaign's {}×{}",
                raw.width,
                raw.height,
                cc.sensor.width_px,
                cc.sensor.height_px
            )));
        }
        out.push(Some(raw));
    }
    if out.iter().flatten().all(|f| f.data.iter().all(|&v| v == 0)) {
        return Err(SimulateError::Other(anyhow!(
            "every simulated camera RAW is all zero (not even a black level): nothing to compare"
        )));
    }
    Ok(out)
}

/// The camera branch of `osiris consistency`: loads the frames, re-simulates them (or reads
/// `--simulated <dir>`), builds the rows and hands them to the common analysis.
pub fn run_with(
    args: &ConsistencyArgs,
    campaign: &Campaign,
    catalogue: &super::catalogue::Catalogue,
) -> Result<Summary> {
    let cc = CameraCampaign::load(campaign, &args.meta)?;
    let mut warnings = campaign.warnings.clone();
    for w in &cc.warnings {
        eprintln!("warning: {w}");
    }
    warnings.extend(cc.warnings.iter().cloned());
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create `{}`", args.out.display()))?;
    let meas = load_measured(&cc, &mut warnings)?;
    let default_cfg = SensorConfig::default_for(osiris_models::sensor::SensorKind::Camera);
    let (sim, model, hfov) = match &args.simulated {
        Some(dir) => {
            if !args.enable.is_empty() || !args.disable.is_empty() || args.model.is_some() {
                warnings.push(
                    "--enable/--disable/--model do not apply to --simulated frames; ignored".into(),
                );
            }
            (
                load_simulated_dir(&cc, dir, &mut warnings)?,
                ModelInfo {
                    source: "simulated-trace".into(),
                    detail: dir.display().to_string(),
                    enabled: vec![],
                    disabled: vec![],
                    osiris_version: env!("CARGO_PKG_VERSION").into(),
                },
                default_cfg.fov_horizontal_rad,
            )
        }
        None => {
            let sw = super::cli::switches(args)?;
            let cfg = super::simulate::model_config(
                campaign,
                args.model.as_deref(),
                &sw,
                campaign.split.seed,
            )?;
            let views: Vec<osi3::SensorView> = read_trace(&campaign.sensor_view, "SensorView")?;
            eprintln!(
                "consistency: re-simulating {} camera frames with the physical camera model",
                cc.frames.len()
            );
            let sim = match simulate_frames(&cfg, &cc, &views, &mut warnings) {
                Ok(s) => s,
                Err(SimulateError::Other(e)) => {
                    return Err(e.context(
                        "re-simulation failed (to attribute frames made elsewhere, pass --simulated <folder of RAW PNGs>)",
                    ));
                }
            };
            let dir = args.out.join("simulated");
            for (f, s) in cc.frames.iter().zip(&sim) {
                if let (Some(s), Some(name)) = (s, f.file.file_name()) {
                    write_raw_png(&dir.join(name), s)?;
                }
            }
            (
                sim,
                ModelInfo {
                    source: "re-simulated".into(),
                    detail: format!(
                        "mode physical, seed {}, frames {}",
                        campaign.split.seed,
                        dir.display()
                    ),
                    enabled: args.enable.clone(),
                    disabled: args.disable.clone(),
                    osiris_version: env!("CARGO_PKG_VERSION").into(),
                },
                cfg.fov_horizontal_rad,
            )
        }
    };
    let paired = pair_frames(&cc, &meas, &sim, hfov)?;
    let mut campaign = campaign.clone();
    campaign.tolerance.roi_mean_dn = mean_tolerance_dn(&campaign, &paired.rows);
    let summary = super::cli::analyse_paired(&campaign, catalogue, paired, model, args, warnings)?;
    eprintln!("consistency: {}", summary.status);
    Ok(summary)
}
