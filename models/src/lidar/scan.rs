//! Scan model: which pulses a LiDAR fires in one sensor cycle, in which direction and when.
//!
//! A [`ScanPattern`] (a Velodyne preset or a generic spinning / MEMS raster / flash pattern from
//! the configuration JSON) is planned once into a list of [`Firing`]s (time offset from the
//! measurement time in ns, channel, azimuth, elevation in the sensor frame). The sensor model
//! traces every firing of the plan each step; with [`SCAN_MOTION`] on, each firing sees the sensor
//! pose (and the moving objects) at its own time, so a moving platform produces the rolling-shutter
//! distortion of a real spinning LiDAR.
//!
//! Conventions: azimuth about +z from +x (counter-clockwise seen from above, `frames::Spherical`),
//! elevation positive up. Velodyne sensors spin clockwise seen from above (VLP-16 manual 63-9243
//! Rev D §9.3.2, VLS-128 manual 63-9483 Rev A), so their azimuth *decreases* with time here.

use serde::{Deserialize, Serialize};

use crate::effects::EffectInfo;
use crate::error::ModelError;

/// `lidar.scan_motion`: every firing is traced at its own time within the cycle.
pub const SCAN_MOTION: EffectInfo = EffectInfo {
    name: "lidar.scan_motion",
    default_on: true,
    summary: "rolling scan distortion: firing k is traced from the sensor pose at t_k (constant linear and \
              angular velocity: p(t) = p₀ + v·t, R(t) = exp([ω]× t)·R₀), and a moving object's hit is \
              re-intersected with its tangent plane shifted by v_obj·t_k (first order: Δt_hit = \
              (v_obj·t_k)·n / (d·n)); points are then expressed in the sensor frame of the measurement \
              time (ego motion compensated); off: the whole cycle is traced at the measurement time",
    source: "Velodyne VLS-128 manual 63-9483 Rev A (per-firing timing); rigid-body kinematics",
    requires: None,
};

/// Effects declared by this module.
pub const EFFECTS: &[EffectInfo] = &[SCAN_MOTION];

/// VLS-128 per-laser elevation (`vert_correction`, rad) by laser id (firing order), from
/// ros-drivers/velodyne `velodyne_pointcloud/params/VLS128.yaml` (commit 1893a0e).
pub const VLS128_VERT_CORRECTION_RAD: [f64; 128] = VLS128_TABLE;

/// VLS-128 per-laser azimuth offset (`rot_correction`, rad) by `laser_id % 8` (the same file; the
/// eight lasers of a firing group sit at eight horizontal offsets).
pub const VLS128_ROT_CORRECTION_RAD: [f64; 8] = [
    -0.1108982206717197,
    -0.07937757438070212,
    -0.04768239516448509,
    -0.015899949485668342,
    0.015899949485668342,
    0.04768239516448509,
    0.07937757438070212,
    0.1108982206717197,
];

/// VLS-128 firing group duration, s (2.665 µs; 8 lasers fire together), and the firing sequence
/// (53.3 µs = 20 group slots: 16 groups, one maintenance slot after group 7, recharge) — VLS-128
/// manual 63-9483 Rev A; the same constants in ros-drivers/velodyne `rawdata.h`
/// (`VLS128_CHANNEL_TDURATION`, `VLS128_SEQ_TDURATION`).
pub const VLS128_GROUP_S: f64 = 2.665e-6;
/// VLS-128 firing sequence, s.
pub const VLS128_SEQUENCE_S: f64 = 53.3e-6;

/// VLP-16 laser elevations by laser id (firing order), deg (VLP-16 manual 63-9243 Rev D, Table 9-1).
pub const VLP16_ELEVATION_DEG: [f64; 16] = [
    -15.0, 1.0, -13.0, 3.0, -11.0, 5.0, -9.0, 7.0, -7.0, 9.0, -5.0, 11.0, -3.0, 13.0, -1.0, 15.0,
];
/// VLP-16 time between two laser firings, s (VLP-16 manual §9.5: 2.304 µs).
pub const VLP16_LASER_S: f64 = 2.304e-6;
/// VLP-16 firing cycle, s (VLP-16 manual §9.5: 55.296 µs = 16 firings + 18.43 µs recharge).
pub const VLP16_SEQUENCE_S: f64 = 55.296e-6;

/// Built-in sensors.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Preset {
    /// Velodyne Alpha Prime VLS-128 (128 channels, −25°…+15°, 600 RPM).
    #[default]
    Vls128,
    /// Velodyne Puck VLP-16 (16 channels, ±15° in 2° steps, 600 RPM).
    Vlp16,
    /// A 1550 nm FMCW (coherent) LiDAR, 128-channel equivalent: the VLS-128's beam layout and
    /// timing with the FMCW detection chain (`super::fmcw`, parameters `lidar.fmcw`). No
    /// automotive FMCW sensor publishes its scan; the layout is a stand-in (guessed), the
    /// wavelength the telecom C band every announced FMCW LiDAR uses (physics.md §2.8).
    Fmcw,
}

/// What a preset sets besides its scan pattern (each value overridable in [`super::LidarConfig`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PresetSpec {
    /// Laser wavelength, nm.
    pub wavelength_nm: f64,
    /// Nominal maximum range, m (the sensor configuration's `range_m` limits the rays).
    pub max_range_m: f64,
    /// Range accuracy (1σ-ish manufacturer figure), m.
    pub range_accuracy_m: f64,
    /// Range granularity of the output, m.
    pub range_resolution_m: f64,
    /// 1/e² full-angle divergence, horizontal, rad.
    pub divergence_h_rad: f64,
    /// 1/e² full-angle divergence, vertical, rad.
    pub divergence_v_rad: f64,
    /// Rotation rate, RPM.
    pub rpm: f64,
}

impl Preset {
    /// The preset's parameters (physics.md §2.7: Velodyne manuals; values marked UNVERIFIED there
    /// are UNVERIFIED here too: VLP-16 divergence and range granularity, VLS-128 range/accuracy).
    pub fn spec(self) -> PresetSpec {
        match self {
            Preset::Vls128 => PresetSpec {
                wavelength_nm: 903.0,
                max_range_m: 245.0,
                range_accuracy_m: 0.03,
                range_resolution_m: 0.004,
                divergence_h_rad: 3.0e-3,
                divergence_v_rad: 1.5e-3,
                rpm: 600.0,
            },
            Preset::Vlp16 => PresetSpec {
                wavelength_nm: 903.0,
                max_range_m: 100.0,
                range_accuracy_m: 0.03,
                range_resolution_m: 0.002,
                divergence_h_rad: 3.0e-3,
                divergence_v_rad: 3.0e-3,
                rpm: 600.0,
            },
            // Guessed: 300 m (Aeva Aeries II data sheet: "up to 500 m"), the range resolution of
            // the default chirp (c/2B_w with B_w the swept band in the sampling window, §2.8),
            // 1 mrad single-mode-fibre beams.
            Preset::Fmcw => PresetSpec {
                wavelength_nm: 1550.0,
                max_range_m: 300.0,
                range_accuracy_m: 0.02,
                range_resolution_m: 0.59,
                divergence_h_rad: 1.0e-3,
                divergence_v_rad: 1.0e-3,
                rpm: 600.0,
            },
        }
    }

    /// The preset's spinning pattern at `rpm`.
    pub fn pattern(self, rpm: f64) -> SpinningPattern {
        match self {
            Preset::Vls128 | Preset::Fmcw => {
                let elevation_rad = VLS128_VERT_CORRECTION_RAD.to_vec();
                let azimuth_offset_rad =
                    (0..128).map(|i| VLS128_ROT_CORRECTION_RAD[i % 8]).collect();
                let firing_delay_s = (0..128)
                    .map(|i| {
                        let g = i / 8;
                        VLS128_GROUP_S * (g + g / 8) as f64
                    })
                    .collect();
                SpinningPattern {
                    elevation_rad,
                    azimuth_offset_rad,
                    firing_delay_s,
                    firing_period_s: Some(VLS128_SEQUENCE_S),
                    azimuth_step_rad: None,
                    rpm,
                    clockwise: true,
                    start_azimuth_rad: 0.0,
                }
            }
            Preset::Vlp16 => SpinningPattern {
                elevation_rad: VLP16_ELEVATION_DEG.iter().map(|d| d.to_radians()).collect(),
                azimuth_offset_rad: vec![0.0; 16],
                firing_delay_s: (0..16).map(|i| VLP16_LASER_S * i as f64).collect(),
                firing_period_s: Some(VLP16_SEQUENCE_S),
                azimuth_step_rad: None,
                rpm,
                clockwise: true,
                start_azimuth_rad: 0.0,
            },
        }
    }
}

/// A spinning multi-channel pattern: all channels fire once per firing sequence while the head
/// rotates at `rpm`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpinningPattern {
    /// Elevation of each laser (firing order), rad.
    pub elevation_rad: Vec<f64>,
    /// Azimuth offset of each laser relative to the head azimuth, rad (absent: 0).
    #[serde(default)]
    pub azimuth_offset_rad: Vec<f64>,
    /// Firing delay of each laser within a sequence, s (absent: all at the sequence start).
    #[serde(default)]
    pub firing_delay_s: Vec<f64>,
    /// Firing sequence period, s (one of `firing_period_s` and `azimuth_step_rad`).
    #[serde(default)]
    pub firing_period_s: Option<f64>,
    /// Head rotation between two sequences, rad (alternative to `firing_period_s`).
    #[serde(default)]
    pub azimuth_step_rad: Option<f64>,
    /// Rotation rate, revolutions per minute.
    pub rpm: f64,
    /// Spin direction seen from above (Velodyne: clockwise).
    #[serde(default)]
    pub clockwise: bool,
    /// Head azimuth at the measurement time, rad.
    #[serde(default)]
    pub start_azimuth_rad: f64,
}

/// A MEMS raster: `lines` scan lines over the vertical field of view, `points_per_line` pulses per
/// line over the horizontal one, one frame in `frame_time_s`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MemsPattern {
    pub fov_horizontal_rad: f64,
    pub fov_vertical_rad: f64,
    pub lines: usize,
    pub points_per_line: usize,
    pub frame_time_s: f64,
    /// Alternate lines are scanned right-to-left (resonant mirror).
    #[serde(default)]
    pub bidirectional: bool,
    /// Centre of the raster (azimuth, elevation), rad.
    #[serde(default)]
    pub centre_rad: [f64; 2],
}

/// A flash LiDAR: a `rows × cols` grid of pixels over the field of view, all at one instant.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FlashPattern {
    pub rows: usize,
    pub cols: usize,
    pub fov_horizontal_rad: f64,
    pub fov_vertical_rad: f64,
    /// Centre of the grid (azimuth, elevation), rad.
    #[serde(default)]
    pub centre_rad: [f64; 2],
}

/// A scan pattern from the configuration (`"scan": {"spinning": {...}}` etc.).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum ScanPattern {
    Spinning(SpinningPattern),
    Mems(MemsPattern),
    Flash(FlashPattern),
}

/// One pulse of the plan.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Firing {
    /// Time after the measurement time, ns.
    pub t_ns: i64,
    /// Channel (0 = lowest elevation for spinning patterns, line / row index otherwise).
    pub channel: u32,
    /// Azimuth in the sensor frame, rad.
    pub azimuth_rad: f64,
    /// Elevation in the sensor frame, rad.
    pub elevation_rad: f64,
}

fn cfg_err(key: &str, msg: impl std::fmt::Display) -> ModelError {
    ModelError::Config(format!("`lidar.scan.{key}`: {msg}"))
}

fn positive(key: &str, v: f64) -> Result<(), ModelError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(cfg_err(
            key,
            format!("must be a finite number > 0, got {v}"),
        ))
    }
}

fn wrap(a: f64) -> f64 {
    crate::frames::wrap_angle(a)
}

/// Whether a direction lies inside a symmetric field of view (full angles, rad).
fn in_fov(az: f64, el: f64, fov_h: f64, fov_v: f64) -> bool {
    (fov_h >= std::f64::consts::TAU - 1e-9 || wrap(az).abs() <= 0.5 * fov_h + 1e-12)
        && el.abs() <= 0.5 * fov_v + 1e-12
}

impl ScanPattern {
    /// Check the pattern's values; errors name the key.
    pub fn validate(&self) -> Result<(), ModelError> {
        match self {
            ScanPattern::Spinning(s) => {
                let n = s.elevation_rad.len();
                if n == 0 {
                    return Err(cfg_err(
                        "spinning.elevation_rad",
                        "needs at least one channel",
                    ));
                }
                if s.elevation_rad
                    .iter()
                    .any(|e| !e.is_finite() || e.abs() > std::f64::consts::FRAC_PI_2)
                {
                    return Err(cfg_err(
                        "spinning.elevation_rad",
                        "values must be finite, |e| ≤ π/2",
                    ));
                }
                for (key, v) in [
                    ("spinning.azimuth_offset_rad", &s.azimuth_offset_rad),
                    ("spinning.firing_delay_s", &s.firing_delay_s),
                ] {
                    if !v.is_empty() && v.len() != n {
                        return Err(cfg_err(
                            key,
                            format!("needs {n} values (one per channel), got {}", v.len()),
                        ));
                    }
                    if v.iter().any(|x| !x.is_finite()) {
                        return Err(cfg_err(key, "values must be finite"));
                    }
                }
                if s.firing_delay_s.iter().any(|d| *d < 0.0) {
                    return Err(cfg_err("spinning.firing_delay_s", "delays must be ≥ 0"));
                }
                positive("spinning.rpm", s.rpm)?;
                match (s.firing_period_s, s.azimuth_step_rad) {
                    (Some(p), None) => positive("spinning.firing_period_s", p)?,
                    (None, Some(a)) => positive("spinning.azimuth_step_rad", a)?,
                    _ => {
                        return Err(cfg_err(
                            "spinning",
                            "give exactly one of `firing_period_s` and `azimuth_step_rad`",
                        ));
                    }
                }
                if !s.start_azimuth_rad.is_finite() {
                    return Err(cfg_err("spinning.start_azimuth_rad", "must be finite"));
                }
            }
            ScanPattern::Mems(m) => {
                positive("mems.fov_horizontal_rad", m.fov_horizontal_rad)?;
                positive("mems.fov_vertical_rad", m.fov_vertical_rad)?;
                positive("mems.frame_time_s", m.frame_time_s)?;
                if m.lines == 0 || m.points_per_line == 0 {
                    return Err(cfg_err(
                        "mems.lines",
                        "`lines` and `points_per_line` must be ≥ 1",
                    ));
                }
                if m.lines.saturating_mul(m.points_per_line) > 20_000_000 {
                    return Err(cfg_err("mems.lines", "more than 2·10⁷ pulses per frame"));
                }
                if m.centre_rad.iter().any(|x| !x.is_finite()) {
                    return Err(cfg_err("mems.centre_rad", "must be finite"));
                }
            }
            ScanPattern::Flash(f) => {
                positive("flash.fov_horizontal_rad", f.fov_horizontal_rad)?;
                positive("flash.fov_vertical_rad", f.fov_vertical_rad)?;
                if f.rows == 0 || f.cols == 0 {
                    return Err(cfg_err("flash.rows", "`rows` and `cols` must be ≥ 1"));
                }
                if f.rows.saturating_mul(f.cols) > 20_000_000 {
                    return Err(cfg_err("flash.rows", "more than 2·10⁷ pixels"));
                }
                if f.centre_rad.iter().any(|x| !x.is_finite()) {
                    return Err(cfg_err("flash.centre_rad", "must be finite"));
                }
            }
        }
        Ok(())
    }

    /// The firings of one cycle of `cycle_s` seconds starting at the measurement time, restricted to
    /// the field of view (full angles, rad), in tracing order: spinning patterns sequence by
    /// sequence, within a sequence by azimuth offset then elevation (coherent ray packets; each
    /// firing carries its own time); rasters and grids line by line.
    pub fn plan(&self, cycle_s: f64, fov_h_rad: f64, fov_v_rad: f64) -> Vec<Firing> {
        let mut out = Vec::new();
        let ns = |t: f64| (t * 1e9).round() as i64;
        match self {
            ScanPattern::Spinning(s) => {
                let n = s.elevation_rad.len();
                // Channel numbers: rank of the elevation (0 = lowest), ties by laser id.
                let mut order: Vec<usize> = (0..n).collect();
                order.sort_by(|&a, &b| {
                    s.elevation_rad[a]
                        .total_cmp(&s.elevation_rad[b])
                        .then(a.cmp(&b))
                });
                let mut channel = vec![0u32; n];
                for (rank, &laser) in order.iter().enumerate() {
                    channel[laser] = rank as u32;
                }
                let omega = s.rpm / 60.0 * std::f64::consts::TAU; // rad/s
                let period = s
                    .firing_period_s
                    .unwrap_or_else(|| s.azimuth_step_rad.unwrap_or(0.0) / omega);
                let sign = if s.clockwise { -1.0 } else { 1.0 };
                let sequences = ((cycle_s / period) + 1e-9).floor().max(1.0) as usize;
                // Lasers within a sequence in tracing order: by azimuth offset, then elevation, so
                // that consecutive rays form coherent packets (a column of one azimuth offset).
                let delay = |i: usize| s.firing_delay_s.get(i).copied().unwrap_or(0.0);
                let offset = |i: usize| s.azimuth_offset_rad.get(i).copied().unwrap_or(0.0);
                let mut fire_order: Vec<usize> = (0..n).collect();
                fire_order.sort_by(|&a, &b| {
                    offset(a)
                        .total_cmp(&offset(b))
                        .then(s.elevation_rad[a].total_cmp(&s.elevation_rad[b]))
                        .then(a.cmp(&b))
                });
                out.reserve(sequences * n);
                for k in 0..sequences {
                    for &i in &fire_order {
                        let t = k as f64 * period + delay(i);
                        let az = s.start_azimuth_rad
                            + sign * omega * t
                            + s.azimuth_offset_rad.get(i).copied().unwrap_or(0.0);
                        let el = s.elevation_rad[i];
                        if in_fov(az, el, fov_h_rad, fov_v_rad) {
                            out.push(Firing {
                                t_ns: ns(t),
                                channel: channel[i],
                                azimuth_rad: wrap(az),
                                elevation_rad: el,
                            });
                        }
                    }
                }
            }
            ScanPattern::Mems(m) => {
                let dt = m.frame_time_s / (m.lines * m.points_per_line) as f64;
                out.reserve(m.lines * m.points_per_line);
                for line in 0..m.lines {
                    let v = if m.lines == 1 {
                        0.5
                    } else {
                        line as f64 / (m.lines - 1) as f64
                    };
                    // Line 0 at the top, as a raster.
                    let el = m.centre_rad[1] + m.fov_vertical_rad * (0.5 - v);
                    for p in 0..m.points_per_line {
                        let mut u = if m.points_per_line == 1 {
                            0.5
                        } else {
                            p as f64 / (m.points_per_line - 1) as f64
                        };
                        if m.bidirectional && line % 2 == 1 {
                            u = 1.0 - u;
                        }
                        // Left to right = decreasing azimuth.
                        let az = m.centre_rad[0] + m.fov_horizontal_rad * (0.5 - u);
                        let t = (line * m.points_per_line + p) as f64 * dt;
                        if in_fov(az, el, fov_h_rad, fov_v_rad) {
                            out.push(Firing {
                                t_ns: ns(t),
                                channel: line as u32,
                                azimuth_rad: wrap(az),
                                elevation_rad: el,
                            });
                        }
                    }
                }
            }
            ScanPattern::Flash(f) => {
                out.reserve(f.rows * f.cols);
                for r in 0..f.rows {
                    // Pixel centres; row 0 at the bottom so channel 0 is the lowest.
                    let el = f.centre_rad[1]
                        + f.fov_vertical_rad * ((r as f64 + 0.5) / f.rows as f64 - 0.5);
                    for c in 0..f.cols {
                        let az = f.centre_rad[0]
                            + f.fov_horizontal_rad * (0.5 - (c as f64 + 0.5) / f.cols as f64);
                        if in_fov(az, el, fov_h_rad, fov_v_rad) {
                            out.push(Firing {
                                t_ns: 0,
                                channel: r as u32,
                                azimuth_rad: wrap(az),
                                elevation_rad: el,
                            });
                        }
                    }
                }
            }
        }
        out
    }
}

const VLS128_TABLE: [f64; 128] = [
    -0.2049365607691742,
    -0.034732052114687155,
    0.059341194567807204,
    -0.09232791743050003,
    -0.013613568165555772,
    0.0804596785169386,
    -0.07120943348136864,
    0.022863813201125717,
    -0.11344640137963143,
    -0.01937315469713706,
    0.0747000919853573,
    -0.07696902001294993,
    0.0017453292519943296,
    0.11309733552923257,
    -0.05585053606381855,
    0.03822271061867582,
    -0.06736970912698112,
    0.026703537555513242,
    -0.16133823605435582,
    -0.030892327760299633,
    0.04782202150464463,
    -0.10384709049366261,
    -0.009773843811168246,
    0.08429940287132612,
    -0.05201081170943102,
    0.04206243497306335,
    -0.1096066770252439,
    -0.015533430342749533,
    0.06318091892219473,
    -0.08848819307611251,
    0.005585053606381855,
    0.1322959573011702,
    -0.005934119456780721,
    0.09040805525330627,
    -0.0635299847725936,
    0.030543261909900768,
    -0.4363323129985824,
    -0.04241150082346221,
    0.05166174585903215,
    -0.10000736613927509,
    0.00942477796076938,
    0.16929693744344995,
    -0.04817108735504349,
    0.04590215932745086,
    -0.13351768777756623,
    -0.027052603405912107,
    0.06702064327658225,
    -0.08464846872172498,
    0.05550147021341968,
    -0.09616764178488756,
    -0.0020943951023931952,
    0.10000736613927509,
    -0.07504915783575616,
    0.019024088846738195,
    -0.2799857186049304,
    -0.038571776469074684,
    0.07086036763096977,
    -0.08080874436733745,
    0.013264502315156905,
    0.2617993877991494,
    -0.05969026041820607,
    0.03438298626428829,
    -0.11955505376161157,
    -0.023212879051524585,
    -0.09808750396208132,
    -0.004014257279586958,
    0.0947713783832921,
    -0.06161012259539983,
    0.01710422666954443,
    -0.34177037412552963,
    -0.040491638646268445,
    0.053581608036225914,
    -0.08272860654453122,
    0.011344640137963142,
    0.20507618710933373,
    -0.046251225177849735,
    0.03246312408709453,
    -0.12479104151759457,
    -0.025132741228718343,
    0.06894050545377602,
    -0.03665191429188092,
    0.05742133239061344,
    -0.0942477796076938,
    -0.00017453292519943296,
    0.07853981633974483,
    -0.07312929565856241,
    0.020943951023931952,
    -0.23675391303303078,
    -0.02129301687433082,
    0.07278022980816354,
    -0.07888888219014369,
    0.015184364492350668,
    0.10611601852125524,
    -0.05777039824101231,
    0.03630284844148206,
    -0.11606439525762292,
    0.024783675378319478,
    -0.18057176441133332,
    -0.032812189937493394,
    0.061261056745000965,
    -0.10576695267085637,
    -0.011693705988362009,
    0.08237954069413235,
    -0.06928957130417489,
    0.04014257279586958,
    -0.11152653920243766,
    -0.017453292519943295,
    0.07661995416255106,
    -0.09040805525330627,
    0.003665191429188092,
    0.12182398178920421,
    -0.05393067388662478,
    0.08691739674931762,
    -0.06544984694978735,
    0.028623399732707003,
    -0.1457698991265664,
    -0.044331363000655974,
    0.04974188368183839,
    -0.10192722831646885,
    -0.007853981633974483,
    0.14713125594312199,
    -0.05009094953223726,
    0.0439822971502571,
    -0.10768681484805014,
    -0.02897246558310587,
    0.0651007810993885,
    -0.08656833089891874,
    0.007504915783575617,
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vls128_table_spans_the_datasheet_fov() {
        let (lo, hi) = VLS128_VERT_CORRECTION_RAD
            .iter()
            .fold((f64::MAX, f64::MIN), |(a, b), &e| (a.min(e), b.max(e)));
        assert!((lo.to_degrees() + 25.0).abs() < 1e-6 && (hi.to_degrees() - 15.0).abs() < 1e-6);
        let mut s = VLS128_VERT_CORRECTION_RAD.to_vec();
        s.sort_by(f64::total_cmp);
        let finest = s.windows(2).map(|w| w[1] - w[0]).fold(f64::MAX, f64::min);
        assert!(
            (finest.to_degrees() - 0.11).abs() < 1e-3,
            "{}",
            finest.to_degrees()
        );
    }

    #[test]
    fn vls128_frame_has_the_datasheet_point_rate() {
        let p = ScanPattern::Spinning(Preset::Vls128.pattern(600.0));
        let f = p.plan(0.1, std::f64::consts::TAU, std::f64::consts::PI);
        // 2 401 497.6 points/s single return (physics.md §2.7) = 128 / 53.3 µs.
        let rate = f.len() as f64 / 0.1;
        assert!((rate - 2_401_497.6).abs() / 2_401_497.6 < 1e-3, "{rate}");
        // Azimuth step of one sequence at 600 RPM: 360°·10 Hz·53.3 µs = 0.19188°.
        let a0 = f.iter().find(|x| x.channel == 5).unwrap();
        let a1 = f.iter().filter(|x| x.channel == 5).nth(1).unwrap();
        let step = wrap(a0.azimuth_rad - a1.azimuth_rad).to_degrees();
        assert!((step - 0.19188).abs() < 1e-4, "{step}");
        assert_eq!(a1.t_ns - a0.t_ns, 53_300);
    }

    #[test]
    fn vlp16_timing() {
        let p = ScanPattern::Spinning(Preset::Vlp16.pattern(600.0));
        let f = p.plan(0.1, std::f64::consts::TAU, std::f64::consts::PI);
        // Tracing order is by elevation: the second firing is laser 2 (−13°), 2 × 2.304 µs later.
        assert_eq!(f[1].t_ns - f[0].t_ns, 4_608);
        assert_eq!(f[1].channel, 1);
        assert_eq!(f[16].t_ns - f[0].t_ns, 55_296);
        assert_eq!(f[0].channel, 0); // laser 0 is −15°, the lowest
        assert_eq!(f.len(), 16 * (0.1f64 / 55.296e-6) as usize);
    }
}
