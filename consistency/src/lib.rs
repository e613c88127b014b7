//! The consistency workflow: compare a sensor model with measurements, show where it fails, name
//! the missing physical effect, add it and watch the error fall (`docs/consistency.md`; method after
//! the DIVP FY2019 consistency verification and Sensors 25(24):7642).
//!
//! One pipeline, each stage a module that only calls the ones after it:
//! [`cli`] (arguments, the run) → [`campaign`] (the `consistency.toml` contract) → [`simulate`]
//! (re-simulation through `osiris_models::build_sensor`, the FMU's code path) → [`pairing`]
//! (timestamp pairing, association, residual rows with their explanatory variables; [`camera`] for
//! camera RAW campaigns) → [`metrics`] (residual statistics with tolerances, binned metrics,
//! AVM/DVM/W1) → [`split`] (the held-out rows) → [`attribution`] (noise model, nuisance baseline, tie check, forward selection over
//! the [`catalogue`] with four gates, joint signatures across quantities) → [`report`]
//! (`summary.json`, `report.html`) and [`history`] (`--history`).
//!
//! * [`catalogue`] + `consistency/catalogue/{radar,lidar,camera}.toml`: effect signatures; a
//!   catalogue is passed to the workflow as a value ([`cli::run_with_catalogue`]).
//! * [`expr`]: the signature expressions; [`bench`]: `osiris bench consistency`.
//! * With the `truth` feature (dev-only: tests, examples, `osiris bench consistency-protocol`):
//!   `truth` and `truth_camera`, the first truth generators (closed-form physics, hidden effects),
//!   and `protocol`, the hidden-effect protocol.

pub mod attribution;
pub mod bench;
pub mod camera;
pub mod campaign;
pub mod catalogue;
pub mod cli;
pub mod expr;
pub mod history;
pub mod metrics;
pub mod pairing;
#[cfg(feature = "truth")]
pub mod protocol;
pub mod report;
pub mod simulate;
pub mod split;
#[cfg(feature = "truth")]
pub mod truth;
#[cfg(feature = "truth")]
pub mod truth_camera;

/// Names of the explanatory variables of a residual row (index = position in [`Row::x`]); the
/// catalogue's signature expressions use these names.
pub const VAR_NAMES: [&str; NVARS] = [
    "range",        // m, GT sensor→target centre
    "azimuth",      // deg, sensor frame
    "elevation",    // deg
    "aspect",       // deg, angle between the target's facing axis (+x) and the line of sight
    "area",         // m², face area (trihedral a², board w·h)
    "edge",         // m, trihedral edge (0 if none)
    "reflectivity", // %, diffuse reflectivity (0 if unknown)
    "height",       // m, target height
    "width",        // m, target width
    "sim",          // simulated value of the quantity (dB / % / count)
    "rain",         // mm/h
    "fog_vis",      // m (1e9 when clear)
    "prx",          // dB, received-power proxy of the simulation (SNR, or RCS − 40·log10 R)
    "mount_h",      // m, sensor height above the road below it
    "pc_h",         // m, the target's phase centre above the road below it (models/ASSETS.md)
    "wavelength",   // m, the sensor's carrier / laser wavelength (campaign [sensor])
    "beam_az",      // deg, LiDAR: azimuth spacing of the simulated scan's beams (0 unknown)
    "beam_el",      // deg, LiDAR: elevation spacing of the simulated scan's beams (0 unknown)
    "ground_dr", // m, two-ray path difference via the road, √(r_h² + (h_t+h_s)²) − √(r_h² + (h_t−h_s)²)
    "elev_dir",  // deg, elevation of the direct path to the phase centre, atan((h_t − h_s)/r_h)
    "elev_img",  // deg, elevation of the road image, atan(−(h_t + h_s)/r_h)
    "range_rate", // m/s, ground truth: rate of the sensor → target-centre range (positive receding)
    "azimuth_rate", // deg/s, ground truth: rate of the target centre's azimuth in the sensor frame
    "cal_w", // (m/s)²/rad², radar: Doppler information on the azimuth misalignment so far (physics.md §7.4)
    "clutter_db", // dB, radar clutter rows: constant-γ road clutter power of the band vs 10 m (physics.md §1.10)
];
/// Number of explanatory variables.
pub const NVARS: usize = 25;
/// Index of `prx`.
pub const V_PRX: usize = 12;
/// Index of `range` in [`VAR_NAMES`].
pub const V_RANGE: usize = 0;
/// Index of `azimuth`.
pub const V_AZIMUTH: usize = 1;
/// Index of `aspect`.
pub const V_ASPECT: usize = 3;
/// Index of `area`.
pub const V_AREA: usize = 4;
/// Index of `edge`.
pub const V_EDGE: usize = 5;
/// Index of `reflectivity`.
pub const V_REFLECTIVITY: usize = 6;
/// Index of `height`.
pub const V_HEIGHT: usize = 7;
/// Index of `width`.
pub const V_WIDTH: usize = 8;
/// Index of `sim`.
pub const V_SIM: usize = 9;
/// Explanatory variables that describe a target itself (not the geometry of a frame): a held-out
/// target must lie inside the training split's span of each (a size law learnt on the small
/// reflectors cannot be judged on the only large one).
pub const TARGET_VARS: [usize; 5] = [V_AREA, V_EDGE, V_REFLECTIVITY, V_HEIGHT, V_WIDTH];

/// Index of `mount_h`.
pub const V_MOUNT_H: usize = 13;
/// Index of `pc_h`.
pub const V_PC_H: usize = 14;
/// Index of `wavelength`.
pub const V_WAVELENGTH: usize = 15;
/// Index of `beam_az`.
pub const V_BEAM_AZ: usize = 16;
/// Index of `beam_el`.
pub const V_BEAM_EL: usize = 17;
/// Index of `ground_dr`.
pub const V_GROUND_DR: usize = 18;
/// Index of `elev_dir`.
pub const V_ELEV_DIR: usize = 19;
/// Index of `elev_img`.
pub const V_ELEV_IMG: usize = 20;
/// Index of `range_rate`.
pub const V_RANGE_RATE: usize = 21;
/// Index of `azimuth_rate`.
pub const V_AZIMUTH_RATE: usize = 22;
/// Index of `cal_w`.
pub const V_CAL_W: usize = 23;
/// Index of `clutter_db`.
pub const V_CLUTTER_DB: usize = 24;

/// The two-ray geometry over the road of a target whose phase centre is `pc_h` above the road at
/// slant range `range_m` from a sensor `mount_h` above it: (path difference via the road's image,
/// m; elevation of the direct path, deg; elevation of the image, deg), with the horizontal distance
/// r_h = √(R² − (h_t − h_s)²) (Skolnik, Introduction to Radar Systems, §2.11).
pub fn two_ray_geometry(range_m: f64, mount_h: f64, pc_h: f64) -> (f64, f64, f64) {
    let rh = (range_m * range_m - (pc_h - mount_h).powi(2))
        .max(0.01)
        .sqrt();
    let dr = rh.hypot(pc_h + mount_h) - rh.hypot(pc_h - mount_h);
    (
        dr,
        ((pc_h - mount_h) / rh).atan().to_degrees(),
        (-(pc_h + mount_h) / rh).atan().to_degrees(),
    )
}

/// Residual quantities (natural units in the id).
pub mod quantity {
    /// Radar/LiDAR range, m.
    pub const RANGE_M: &str = "range_m";
    /// Radar and FMCW LiDAR radial velocity, km/h (OSI sign: positive towards the sensor; a
    /// LiDAR point's `LidarDetection.radial_velocity`).
    pub const RADIAL_VELOCITY_KMH: &str = "radial_velocity_kmh";
    /// Radar azimuth, deg; LiDAR target centroid azimuth; camera: azimuth of the centre of a
    /// detection's angular box.
    pub const AZIMUTH_DEG: &str = "azimuth_deg";
    /// Camera: elevation of the centre of a detection's angular box, deg (positive up).
    pub const ELEVATION_DEG: &str = "elevation_deg";
    /// Radar power quantity (RCS estimate dBsm or SNR dB per `quantity_semantics`), dB.
    pub const POWER_DB: &str = "power_db";
    /// LiDAR intensity, % (metrics).
    pub const INTENSITY_PCT: &str = "intensity_pct";
    /// LiDAR intensity ratio meas/sim, dB (attribution of multiplicative effects).
    pub const INTENSITY_DB: &str = "intensity_db";
    /// LiDAR points on target per target and frame, ln((meas+½)/(sim+½)).
    pub const POINTS_LOG_RATIO: &str = "points_log_ratio";
    /// LiDAR points on target per target and frame, relative error % (metrics).
    pub const POINTS_ON_TARGET_PCT: &str = "points_on_target_pct";
    /// FMCW LiDAR: spread of the intensity over a target's points in one frame, the standard
    /// deviation of 10·log10(I), dB; meas − sim (speckle; no offset is fitted).
    pub const INTENSITY_SD_DB: &str = "intensity_sd_db";
    /// FMCW LiDAR: spread of a target's points in depth (along the target box's x axis, the normal
    /// of a board) in one frame, standard deviation, m; meas − sim (range smear; no offset).
    pub const RANGE_SD_M: &str = "range_sd_m";
    /// LiDAR points in depth gaps (no target id) per frame, count.
    pub const GAP_POINTS: &str = "gap_points";
    /// Radar detections of no ground-truth object (outside every target's gate, no ground-truth
    /// id) with the Doppler of a stationary point, per frame and 2 m range band, count, meas − sim
    /// (road clutter; no offset is fitted). See `pairing.rs`, `clutter_rows`.
    pub const CLUTTER_COUNT: &str = "clutter_count";
    /// Camera ROI mean, meas − sim, DN (attribution; a black-level offset is fitted). Rows carry
    /// their standard error in `x[V_PRX]` ([`super::carries_row_sigma`]); see `camera.rs`.
    pub const CAMERA_MEAN_DN: &str = "roi_mean_dn";
    /// Camera ROI mean relative to the simulated signal above black, % (metrics; lit rows only).
    pub const CAMERA_MEAN_PCT: &str = "roi_mean_pct";
    /// Camera ROI variance (spatial per frame, temporal per frame pair), 100·ln(meas/sim)
    /// ("log-percent", ≈ % for small differences; variance-stabilised).
    pub const CAMERA_VARIANCE_PCT: &str = "roi_variance_pct";
    /// Camera detections: the screen width (azimuth span) of a detection's box, meas vs sim,
    /// 100·(meas − sim)/sim, % (metrics).
    pub const SCREEN_WIDTH_PCT: &str = "screen_width_pct";
    /// Camera detections: the screen height (elevation span), as the width, % (metrics).
    pub const SCREEN_HEIGHT_PCT: &str = "screen_height_pct";
    /// Camera detections: the recognition's distance (the mean distance of the box's points),
    /// 100·(meas − sim)/sim, % (metrics).
    pub const RECOGNITION_DISTANCE_PCT: &str = "recognition_distance_pct";
    /// Camera ROI variance per ROI × channel × kind (spatial / temporal), the frames pooled,
    /// 100·(meas/sim − 1), % (metrics).
    pub const CAMERA_VARIANCE_ROI_PCT: &str = "roi_variance_per_roi_pct";
}

/// Quantities whose rows carry their own standard error in `x[V_PRX]` (camera ROI statistics:
/// no pooling of replicate scatter across ROIs of very different signal level).
pub fn carries_row_sigma(q: &str) -> bool {
    matches!(q, quantity::CAMERA_MEAN_DN | quantity::CAMERA_VARIANCE_PCT)
}

/// One paired residual: measured and simulated value of a quantity for one target in one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Row {
    /// Quantity id ([`quantity`]).
    pub quantity: &'static str,
    /// Index of the frame pair.
    pub frame: usize,
    /// Timestamp, s.
    pub time_s: f64,
    /// Ground-truth target id (0 for frame-level quantities).
    pub target: u64,
    /// Station: target × (quantised) geometry; repeated frames of one station are replicates.
    pub station: u64,
    pub meas: f64,
    pub sim: f64,
    /// Explanatory variables ([`VAR_NAMES`]).
    pub x: [f64; NVARS],
}

impl Row {
    /// meas − sim.
    pub fn resid(&self) -> f64 {
        self.meas - self.sim
    }
}

/// The tolerance of a quantity in its natural unit.
pub fn tolerance_of(q: &str, t: &campaign::Tolerances) -> f64 {
    match q {
        quantity::RANGE_M => t.range_m,
        quantity::RADIAL_VELOCITY_KMH => t.radial_velocity_kmh,
        quantity::AZIMUTH_DEG => t.azimuth_deg,
        quantity::ELEVATION_DEG => t.elevation_deg,
        quantity::POWER_DB => t.power_db,
        quantity::INTENSITY_PCT => t.intensity_pct,
        quantity::INTENSITY_DB | quantity::INTENSITY_SD_DB => t.intensity_db,
        quantity::RANGE_SD_M => t.range_m,
        quantity::POINTS_ON_TARGET_PCT => t.points_on_target_pct,
        quantity::POINTS_LOG_RATIO => (1.0 + t.points_on_target_pct / 100.0).ln(),
        quantity::GAP_POINTS => t.gap_points,
        quantity::CLUTTER_COUNT => t.clutter_count,
        quantity::CAMERA_MEAN_DN => t.roi_mean_dn,
        quantity::CAMERA_MEAN_PCT => t.roi_mean_pct,
        quantity::CAMERA_VARIANCE_PCT | quantity::CAMERA_VARIANCE_ROI_PCT => t.roi_variance_pct,
        quantity::SCREEN_WIDTH_PCT | quantity::SCREEN_HEIGHT_PCT => t.screen_size_pct,
        quantity::RECOGNITION_DISTANCE_PCT => t.recognition_distance_pct,
        _ => f64::INFINITY,
    }
}

/// Quantities the attribution runs on, per sensor.
pub fn attribution_quantities(kind: campaign::CampaignSensor) -> &'static [&'static str] {
    match kind {
        campaign::CampaignSensor::Radar => &[
            quantity::POWER_DB,
            quantity::RANGE_M,
            quantity::AZIMUTH_DEG,
            quantity::RADIAL_VELOCITY_KMH,
            quantity::CLUTTER_COUNT,
        ],
        campaign::CampaignSensor::Lidar => &[
            quantity::INTENSITY_DB,
            quantity::RANGE_M,
            quantity::AZIMUTH_DEG,
            quantity::POINTS_LOG_RATIO,
            quantity::GAP_POINTS,
            quantity::RADIAL_VELOCITY_KMH,
            quantity::INTENSITY_SD_DB,
            quantity::RANGE_SD_M,
        ],
        campaign::CampaignSensor::Camera => &[
            quantity::CAMERA_MEAN_DN,
            quantity::CAMERA_VARIANCE_PCT,
            quantity::AZIMUTH_DEG,
            quantity::ELEVATION_DEG,
        ],
    }
}

/// Quantities with a tolerance check (the verdict table), per sensor.
pub fn metric_quantities(kind: campaign::CampaignSensor) -> &'static [&'static str] {
    match kind {
        campaign::CampaignSensor::Radar => &[
            quantity::RANGE_M,
            quantity::RADIAL_VELOCITY_KMH,
            quantity::AZIMUTH_DEG,
            quantity::POWER_DB,
            quantity::CLUTTER_COUNT,
        ],
        campaign::CampaignSensor::Lidar => &[
            quantity::RANGE_M,
            quantity::INTENSITY_PCT,
            quantity::POINTS_ON_TARGET_PCT,
            quantity::GAP_POINTS,
            quantity::RADIAL_VELOCITY_KMH,
            quantity::INTENSITY_SD_DB,
            quantity::RANGE_SD_M,
        ],
        campaign::CampaignSensor::Camera => &[
            quantity::CAMERA_MEAN_PCT,
            quantity::CAMERA_VARIANCE_ROI_PCT,
            quantity::AZIMUTH_DEG,
            quantity::ELEVATION_DEG,
            quantity::SCREEN_WIDTH_PCT,
            quantity::SCREEN_HEIGHT_PCT,
            quantity::RECOGNITION_DISTANCE_PCT,
        ],
    }
}

pub use cli::{ConsistencyArgs, run};
