//! Free space from radar: an occupancy grid accumulated over the cycles from the recognition's
//! detections, and the free-space boundary per azimuth sector (physics.md §6.4).
//!
//! # Occupancy grid (log-odds, inverse sensor model)
//!
//! A square grid of `extent_m`² with cells of `cell_size_m`, axis-aligned in the recognition's
//! fixed frame and re-centred on the sensor by whole cells when the sensor has moved a quarter of
//! the extent from its centre (cells leaving the grid are forgotten, cells entering it are
//! unknown). Each cell holds the log-odds `L = ln(p / (1 − p))` of being occupied, prior `L = 0`
//! (p = ½). Per cycle, every detection the recognition keeps (not a below-ground ghost, not part
//! of a mirror cluster behind a guardrail: the rejection of [`super::radar`], steps 2 and 4) casts
//! its ray in x-y from the sensor to its position (Thrun, Burgard & Fox, *Probabilistic Robotics*,
//! MIT Press 2005, §9.2, Table 9.2 `inverse_range_sensor_model`; Werber, Rapp, Klappstein, Hahn,
//! Dickmann, Dietmayer, Waldschmidt, "Automotive radar gridmap representations", IEEE ICMIM 2015):
//!
//! * cells whose ray sample lies more than one cell short of the detection: **free**,
//!   `L += log_odds_free` (< 0);
//! * the cell of the detection: **occupied**, `L += log_odds_occupied` (> 0) — only for a
//!   **stationary** detection (ego-compensated |ṙ| ≤ `moving_threshold_m_s`): a moving target
//!   leaves its cells, so it frees the cells before it but occupies none;
//! * cells behind the detection: unchanged (unknown).
//!
//! A cell is updated at most once per cycle (occupied wins over free), so many detections along
//! one ray do not count as many scans. `L` is clamped to `[log_odds_min, log_odds_max]` so that a
//! cell can change its state again within a few cycles.
//!
//! # Free-space boundary
//!
//! The field of view is cut into sectors of `sector_width_rad` (sensor-frame azimuth, from
//! −fov/2). A sector's boundary is the horizontal distance from the sensor to the nearest of
//! (a) the centres of the cells with `L ≥ occupied_log_odds` whose azimuth falls in the sector and
//! (b) the cycle's kept **moving** detections in the sector (dynamic obstacles: not in the grid);
//! the sensor's range when there is none (free or unknown up to the range).

use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};

use super::EgoState;
use super::common::FrameJump;
use crate::error::ModelError;

/// Free-space parameters (`radar.recognition.free_space`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FreeSpaceConfig {
    /// Whether the grid and the boundary are computed (and reported).
    pub enabled: bool,
    /// Cell edge, m (guessed: about the default waveform's range resolution, 0.3–0.6 m; Werber et
    /// al. 2015 use 0.2–0.5 m).
    pub cell_size_m: f64,
    /// Edge of the square grid around the sensor, m (default: twice the default radar range).
    pub extent_m: f64,
    /// Log-odds increment of an occupied cell (guessed: p = 0.7 per hit, ln(0.7/0.3) = 0.85; the
    /// value of Thrun et al.'s examples).
    pub log_odds_occupied: f64,
    /// Log-odds increment of a free cell (guessed: p = 0.4 per pass, ln(0.4/0.6) = −0.41).
    pub log_odds_free: f64,
    /// Lower clamp of a cell's log-odds (p = 0.05).
    pub log_odds_min: f64,
    /// Upper clamp of a cell's log-odds (p = 0.97).
    pub log_odds_max: f64,
    /// Log-odds from which a cell counts as occupied for the boundary (1.5 = p 0.82: two hits
    /// without a pass in between, so that a single-cycle false alarm does not close a sector).
    pub occupied_log_odds: f64,
    /// Width of one boundary sector, rad (1°).
    pub sector_width_rad: f64,
    /// Put the grid (occupancy probabilities) into the perception output (large).
    pub emit_grid: bool,
}

impl Default for FreeSpaceConfig {
    fn default() -> Self {
        FreeSpaceConfig {
            enabled: true,
            cell_size_m: 0.5,
            extent_m: 200.0,
            log_odds_occupied: 0.85,
            log_odds_free: -0.4,
            log_odds_min: -3.0,
            log_odds_max: 3.5,
            occupied_log_odds: 1.5,
            sector_width_rad: 1f64.to_radians(),
            emit_grid: false,
        }
    }
}

/// Most cells per grid edge (a 4096² grid is 64 MiB of log-odds).
const MAX_CELLS_PER_EDGE: f64 = 4096.0;

impl FreeSpaceConfig {
    /// Checks the values; errors name the key under `prefix`.
    pub fn validate(&self, prefix: &str) -> Result<(), ModelError> {
        let err = |key: &str, what: &str, v: f64| {
            Err(ModelError::Config(format!(
                "{prefix}.{key} must be {what} (got {v})"
            )))
        };
        for (key, v) in [
            ("cell_size_m", self.cell_size_m),
            ("extent_m", self.extent_m),
            ("log_odds_occupied", self.log_odds_occupied),
            ("log_odds_max", self.log_odds_max),
            ("occupied_log_odds", self.occupied_log_odds),
            ("sector_width_rad", self.sector_width_rad),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return err(key, "a positive number", v);
            }
        }
        for (key, v) in [
            ("log_odds_free", self.log_odds_free),
            ("log_odds_min", self.log_odds_min),
        ] {
            if !(v.is_finite() && v < 0.0) {
                return err(key, "a negative number", v);
            }
        }
        if self.extent_m / self.cell_size_m > MAX_CELLS_PER_EDGE {
            return err(
                "extent_m",
                &format!("at most {MAX_CELLS_PER_EDGE} cells (extent_m / cell_size_m)"),
                self.extent_m,
            );
        }
        if self.extent_m < 4.0 * self.cell_size_m {
            return err(
                "extent_m",
                "at least 4 cells (4 · cell_size_m)",
                self.extent_m,
            );
        }
        if self.occupied_log_odds > self.log_odds_max {
            return err(
                "occupied_log_odds",
                "at most log_odds_max",
                self.occupied_log_odds,
            );
        }
        if self.sector_width_rad > std::f64::consts::PI {
            return err("sector_width_rad", "at most π", self.sector_width_rad);
        }
        Ok(())
    }
}

/// One detection as the free-space estimate takes it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FreeSpaceDetection {
    /// Position, fixed frame, m.
    pub position_m: DVec3,
    /// Moving (ego-compensated): frees its ray, occupies nothing, bounds its sector this cycle.
    pub moving: bool,
    /// Road clutter (stationary, weaker than `clutter_max_rcs_dbsm`): frees its ray, occupies
    /// nothing.
    pub clutter: bool,
}

/// The occupancy grid and the boundary (state kept across cycles, buffers reused).
#[derive(Debug, Clone)]
pub struct FreeSpace {
    config: FreeSpaceConfig,
    /// Cells per edge.
    n: usize,
    /// Lattice index (fixed frame, cells of `cell_size_m` from the frame origin) of cell (0, 0);
    /// `None` before the first cycle.
    origin: Option<[i64; 2]>,
    /// Sum of the fixed frame's re-basing displacements: grid coordinates = fixed − shift.
    shift_m: DVec2,
    frame_jump: FrameJump,
    log_odds: Vec<f32>,
    scratch: Vec<f32>,
    /// Per cell this cycle: 0 untouched, 1 free, 2 occupied.
    marks: Vec<u8>,
    touched: Vec<u32>,
    /// Sensor-frame azimuth of the first sector's lower edge, rad.
    azimuth_start_rad: f64,
    sector_width_rad: f64,
    range_m: f64,
    boundary_m: Vec<f32>,
    /// Sensor position (fixed frame) of the last cycle.
    sensor_m: DVec3,
}

impl FreeSpace {
    pub fn new(config: &FreeSpaceConfig) -> Result<FreeSpace, ModelError> {
        config.validate("radar.recognition.free_space")?;
        let n = (config.extent_m / config.cell_size_m).ceil() as usize;
        Ok(FreeSpace {
            config: config.clone(),
            n,
            origin: None,
            shift_m: DVec2::ZERO,
            frame_jump: FrameJump::default(),
            log_odds: vec![0.0; n * n],
            scratch: vec![0.0; n * n],
            marks: vec![0; n * n],
            touched: Vec::new(),
            azimuth_start_rad: 0.0,
            sector_width_rad: config.sector_width_rad,
            range_m: 0.0,
            boundary_m: Vec::new(),
            sensor_m: DVec3::ZERO,
        })
    }

    /// The parameters.
    pub fn config(&self) -> &FreeSpaceConfig {
        &self.config
    }

    /// Cells per grid edge.
    pub fn cells_per_edge(&self) -> usize {
        self.n
    }

    /// Sensor-frame azimuth of the first sector's lower edge, rad.
    pub fn azimuth_start_rad(&self) -> f64 {
        self.azimuth_start_rad
    }

    /// Sector width, rad.
    pub fn sector_width_rad(&self) -> f64 {
        self.sector_width_rad
    }

    /// Boundary distance per sector of the last cycle (horizontal, from the sensor), m.
    pub fn boundary_m(&self) -> &[f32] {
        &self.boundary_m
    }

    /// The sector of a sensor-frame azimuth, if inside the field of view.
    pub fn sector_of(&self, azimuth_rad: f64) -> Option<usize> {
        let k = ((azimuth_rad - self.azimuth_start_rad) / self.sector_width_rad).floor();
        (k >= 0.0 && (k as usize) < self.boundary_m.len()).then_some(k as usize)
    }

    /// Log-odds of cells, row-major (`iy · n + ix`, ix along the fixed frame's +x).
    pub fn log_odds(&self) -> &[f32] {
        &self.log_odds
    }

    /// The log-odds of the cell holding a fixed-frame point (`None`: outside the grid).
    pub fn log_odds_at(&self, p_fixed: DVec3) -> Option<f32> {
        self.cell_index(p_fixed.truncate() - self.shift_m)
            .map(|i| self.log_odds[i])
    }

    /// The fixed-frame corner (minimum x, y) of cell (0, 0), m.
    pub fn grid_corner_m(&self) -> DVec2 {
        let o = self.origin.unwrap_or([0, 0]);
        DVec2::new(o[0] as f64, o[1] as f64) * self.config.cell_size_m + self.shift_m
    }

    /// The sensor position of the last cycle, fixed frame, m.
    pub fn sensor_position_m(&self) -> DVec3 {
        self.sensor_m
    }

    fn cell_index(&self, g: DVec2) -> Option<usize> {
        let o = self.origin?;
        let cs = self.config.cell_size_m;
        let ix = (g.x / cs).floor() as i64 - o[0];
        let iy = (g.y / cs).floor() as i64 - o[1];
        let n = self.n as i64;
        (ix >= 0 && iy >= 0 && ix < n && iy < n).then(|| (iy * n + ix) as usize)
    }

    /// Re-centres the grid on `s` (grid coordinates) by whole cells when `s` is more than a quarter
    /// of the extent from the centre (or on the first cycle).
    fn recentre(&mut self, s: DVec2) {
        let cs = self.config.cell_size_m;
        let half = (self.n / 2) as i64;
        let want = [
            (s.x / cs).floor() as i64 - half,
            (s.y / cs).floor() as i64 - half,
        ];
        let Some(old) = self.origin else {
            self.origin = Some(want);
            return;
        };
        let quarter = (self.n / 4).max(1) as i64;
        if (want[0] - old[0]).abs() < quarter && (want[1] - old[1]).abs() < quarter {
            return;
        }
        let n = self.n as i64;
        let (dx, dy) = (want[0] - old[0], want[1] - old[1]);
        self.scratch.fill(0.0);
        for iy in 0..n {
            let oy = iy + dy;
            if !(0..n).contains(&oy) {
                continue;
            }
            for ix in 0..n {
                let ox = ix + dx;
                if (0..n).contains(&ox) {
                    self.scratch[(iy * n + ix) as usize] = self.log_odds[(oy * n + ox) as usize];
                }
            }
        }
        std::mem::swap(&mut self.log_odds, &mut self.scratch);
        self.origin = Some(want);
    }

    fn mark(&mut self, g: DVec2, occupied: bool) {
        if let Some(i) = self.cell_index(g) {
            let m = &mut self.marks[i];
            if *m == 0 {
                self.touched.push(i as u32);
            }
            *m = (*m).max(if occupied { 2 } else { 1 });
        }
    }

    /// One cycle: the kept detections (fixed frame), the sensor's field of view (horizontal, rad)
    /// and range (m).
    pub fn update(
        &mut self,
        ego: &EgoState,
        detections: impl Iterator<Item = FreeSpaceDetection> + Clone,
        fov_horizontal_rad: f64,
        range_m: f64,
    ) {
        let c = self.config.clone();
        if let Some(d) = self.frame_jump.check(ego) {
            self.shift_m += d.truncate();
        }
        let pose = &ego.sensor_pose;
        self.sensor_m = pose.position;
        let s = pose.position.truncate() - self.shift_m;
        self.recentre(s);
        // Inverse sensor model along each ray; each cell once per cycle.
        let step = 0.5 * c.cell_size_m;
        for d in detections.clone() {
            let g = d.position_m.truncate() - self.shift_m;
            let rel = g - s;
            let r = rel.length();
            if !r.is_finite() || r <= 0.0 {
                continue;
            }
            let u = rel / r;
            let free_to = r - c.cell_size_m;
            let mut t = 0.0;
            while t < free_to {
                self.mark(s + u * t, false);
                t += step;
            }
            if !d.moving && !d.clutter {
                self.mark(g, true);
            }
        }
        for k in 0..self.touched.len() {
            let i = self.touched[k] as usize;
            let inc = if self.marks[i] == 2 {
                c.log_odds_occupied
            } else {
                c.log_odds_free
            };
            self.log_odds[i] =
                (self.log_odds[i] as f64 + inc).clamp(c.log_odds_min, c.log_odds_max) as f32;
            self.marks[i] = 0;
        }
        self.touched.clear();
        // Boundary per sector.
        let fov = fov_horizontal_rad.clamp(0.0, 2.0 * std::f64::consts::PI);
        let sectors = ((fov / c.sector_width_rad).ceil() as usize).max(1);
        self.sector_width_rad = fov / sectors as f64;
        self.azimuth_start_rad = -0.5 * fov;
        self.range_m = range_m;
        self.boundary_m.clear();
        self.boundary_m.resize(sectors, range_m as f32);
        let corner = self.grid_corner_m() - self.shift_m;
        let (n, cs) = (self.n, c.cell_size_m);
        let thr = c.occupied_log_odds as f32;
        for iy in 0..n {
            for ix in 0..n {
                if self.log_odds[iy * n + ix] < thr {
                    continue;
                }
                let centre = corner + DVec2::new(ix as f64 + 0.5, iy as f64 + 0.5) * cs;
                let rel = centre - s;
                let r = rel.length();
                if r > range_m {
                    continue;
                }
                let v = pose.inverse_transform_vector(rel.extend(0.0));
                self.bound(v.y.atan2(v.x), r);
            }
        }
        for d in detections.filter(|d| d.moving) {
            let v = pose.inverse_transform_point(d.position_m);
            self.bound(v.y.atan2(v.x), v.truncate().length());
        }
    }

    fn bound(&mut self, azimuth_rad: f64, r_m: f64) {
        if let Some(k) = self.sector_of(azimuth_rad) {
            let b = &mut self.boundary_m[k];
            *b = b.min(r_m as f32);
        }
    }

    /// Occupancy probabilities `p = 1 − 1 / (1 + e^L)` of the cells (row-major, as
    /// [`FreeSpace::log_odds`]) into `out` (cleared first).
    pub fn probabilities_into(&self, out: &mut Vec<f32>) {
        out.clear();
        out.extend(self.log_odds.iter().map(|&l| 1.0 - 1.0 / (1.0 + l.exp())));
    }

    /// Forget the grid.
    pub fn reset(&mut self) {
        self.origin = None;
        self.shift_m = DVec2::ZERO;
        self.frame_jump.reset();
        self.log_odds.fill(0.0);
        self.marks.fill(0);
        self.touched.clear();
        self.boundary_m.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frames::Pose;

    fn ego(x: f64) -> EgoState {
        EgoState {
            time_s: x / 10.0,
            sensor_pose: Pose::new(DVec3::new(x, 0.0, 0.5), glam::DMat3::IDENTITY),
            sensor_velocity_m_s: DVec3::new(10.0, 0.0, 0.0),
            sensor_angular_velocity_rad_s: DVec3::ZERO,
        }
    }

    #[test]
    fn ray_frees_then_occupies_and_boundary_follows() {
        let mut f = FreeSpace::new(&FreeSpaceConfig::default()).unwrap();
        let wall = FreeSpaceDetection {
            position_m: DVec3::new(30.0, 0.0, 0.5),
            moving: false,
            clutter: false,
        };
        for k in 0..3 {
            f.update(&ego(0.1 * k as f64), [wall].into_iter(), 1.0, 100.0);
        }
        let occ = f.log_odds_at(DVec3::new(30.0, 0.0, 0.0)).unwrap();
        assert!((occ - 3.0 * 0.85).abs() < 1e-5, "{occ}");
        let free = f.log_odds_at(DVec3::new(15.0, 0.0, 0.0)).unwrap();
        assert!((free + 3.0 * 0.4).abs() < 1e-5, "{free}");
        assert_eq!(f.log_odds_at(DVec3::new(40.0, 0.0, 0.0)), Some(0.0));
        let k = f.sector_of(0.0).unwrap();
        let b = f.boundary_m()[k] as f64;
        // The cell [30, 30.5) × [0, 0.5) m: centre (30.25, 0.25), the sensor at x = 0.2.
        assert!((b - 30.051).abs() < 0.01, "{b}");
        assert_eq!(f.boundary_m()[0], 100.0);
    }

    #[test]
    fn config_errors_name_the_key() {
        let c = FreeSpaceConfig {
            cell_size_m: 0.0,
            ..Default::default()
        };
        let e = c.validate("radar.recognition.free_space").unwrap_err();
        assert!(e.to_string().contains("free_space.cell_size_m"), "{e}");
        let c = FreeSpaceConfig {
            log_odds_free: 0.2,
            ..Default::default()
        };
        assert!(
            c.validate("x")
                .unwrap_err()
                .to_string()
                .contains("log_odds_free")
        );
    }
}
