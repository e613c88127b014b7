//! Kalman-filter multi-object tracker shared by the LiDAR and radar recognition.
//!
//! # State and motion model
//!
//! Each track holds the planar state `x = (p_x, p_y, v_x, v_y)` (m, m/s) in a **fixed** frame (the
//! frame `EgoState::sensor_pose` maps to) and its 4×4 covariance `P`. Prediction over `dt` uses the
//! constant-velocity model with the discrete white-noise-acceleration process noise
//! (Bar-Shalom, Li, Kirubarajan, "Estimation with Applications to Tracking and Navigation", Wiley
//! 2001, §6.3.3): per axis `F = [[1, dt], [0, 1]]`, `Q = σ_a²·[[dt⁴/4, dt³/2], [dt³/2, dt²]]`.
//!
//! # Measurements
//!
//! * Position `z = (p_x, p_y)` with covariance `R` (linear, `H = [I₂ 0]`).
//! * Optionally an ego-motion-compensated radial velocity `z_v = v · u` along the unit line of sight
//!   `u` (horizontal part, fixed frame). `h(x) = v_x·u_x + v_y·u_y` is nonlinear in the full state
//!   (`u` depends on the position); the update linearises it with `u` taken from the measured
//!   position (an EKF whose Jacobian drops the small `∂u/∂p` terms, which are of order `|v|/r`).
//!
//! # Association
//!
//! Squared Mahalanobis distance `d² = yᵀ S⁻¹ y` of the innovation, gated at the χ² 99 % quantile
//! (9.21 for the 2-D position, 11.34 when the radial velocity is used as well), cost
//! `d² + ln det S` (the negative log-likelihood up to a constant), and a global-nearest-neighbour
//! assignment solved exactly by the Hungarian method (Kuhn 1955, Munkres 1957; the O(n³) potential
//! variant of Jonker & Volgenant / Edmonds–Karp).
//!
//! # Track management
//!
//! `Tentative` → `Confirmed` when at least `confirm_m` of the last `confirm_n` cycles had a hit
//! (M-of-N confirmation, Blackman & Popoli, "Design and Analysis of Modern Tracking Systems", 1999,
//! §6.2); a tentative track that cannot reach M of N any more is deleted. A confirmed track without
//! a hit becomes `Coasting` (reported as PREDICTED); a hit brings it back; it is deleted after more
//! than `max_coast_cycles` consecutive misses or when its existence probability drops below
//! `delete_existence`.
//!
//! # Existence probability
//!
//! A binary Bayes filter in the spirit of IPDA (Mušicki, Evans, Stanković, "Integrated probabilistic
//! data association", IEEE TAC 39(6), 1994): prediction `p⁻ = p_s · p` (survival probability),
//! update with a hit `p = P_D·p⁻ / (P_D·p⁻ + P_FA·(1 − p⁻))`, with a miss
//! `p = (1 − P_D)·p⁻ / ((1 − P_D)·p⁻ + (1 − P_FA)·(1 − p⁻))`, where `P_D` is the detection
//! probability of a real object and `P_FA` the probability that a gate holds a false alarm. Unlike
//! full IPDA the measurement likelihood ratio is not used (a hit counts the same wherever it falls
//! in the gate).

use serde::{Deserialize, Serialize};

use crate::error::ModelError;

/// χ² 99 % quantile with 2 degrees of freedom.
pub const CHI2_99_2DOF: f64 = 9.210;
/// χ² 99 % quantile with 3 degrees of freedom.
pub const CHI2_99_3DOF: f64 = 11.345;

/// Tracker parameters (nested as `tracker` in the recognition configurations).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TrackerConfig {
    /// Standard deviation of the white-noise acceleration of the CV model, m/s² (guessed: typical
    /// road-vehicle manoeuvres).
    pub process_noise_accel_m_s2: f64,
    /// M of M-of-N confirmation.
    pub confirm_m: u32,
    /// N of M-of-N confirmation (≤ 32).
    pub confirm_n: u32,
    /// Consecutive misses after which a confirmed/coasting track is deleted.
    pub max_coast_cycles: u32,
    /// Detection probability of a real object per cycle (existence filter; guessed).
    pub detection_probability: f64,
    /// Probability that a gate holds a false alarm (existence filter; guessed).
    pub false_alarm_probability: f64,
    /// Probability that an object survives one cycle (existence prediction; guessed).
    pub survival_probability: f64,
    /// Existence probability of a new track.
    pub initial_existence: f64,
    /// Tracks whose existence probability falls below this are deleted.
    pub delete_existence: f64,
    /// Standard deviation of the unobserved velocity of a new track, m/s.
    pub initial_velocity_std_m_s: f64,
}

impl Default for TrackerConfig {
    fn default() -> Self {
        TrackerConfig {
            process_noise_accel_m_s2: 2.0,
            confirm_m: 3,
            confirm_n: 5,
            max_coast_cycles: 5,
            detection_probability: 0.9,
            false_alarm_probability: 0.05,
            survival_probability: 0.98,
            initial_existence: 0.2,
            delete_existence: 0.02,
            initial_velocity_std_m_s: 10.0,
        }
    }
}

fn prob_ok(v: f64, open: bool) -> bool {
    v.is_finite() && v > 0.0 && (v < 1.0 || (!open && v <= 1.0))
}

impl TrackerConfig {
    /// Checks the values; `prefix` names the configuration path (e.g. `lidar.recognition.tracker`).
    pub fn validate(&self, prefix: &str) -> Result<(), ModelError> {
        let err = |key: &str, what: &str, v: String| {
            Err(ModelError::Config(format!(
                "{prefix}.{key} must be {what} (got {v})"
            )))
        };
        let a = self.process_noise_accel_m_s2;
        if !(a.is_finite() && a > 0.0) {
            return err(
                "process_noise_accel_m_s2",
                "a positive number",
                a.to_string(),
            );
        }
        if self.confirm_n == 0 || self.confirm_n > 32 {
            return err("confirm_n", "in 1..=32", self.confirm_n.to_string());
        }
        if self.confirm_m == 0 || self.confirm_m > self.confirm_n {
            return err("confirm_m", "in 1..=confirm_n", self.confirm_m.to_string());
        }
        for (key, v, open) in [
            ("detection_probability", self.detection_probability, true),
            (
                "false_alarm_probability",
                self.false_alarm_probability,
                true,
            ),
            ("survival_probability", self.survival_probability, false),
            ("initial_existence", self.initial_existence, true),
            ("delete_existence", self.delete_existence, true),
        ] {
            if !prob_ok(v, open) {
                return err(key, "a probability in (0, 1)", v.to_string());
            }
        }
        if self.false_alarm_probability >= self.detection_probability {
            return err(
                "false_alarm_probability",
                "smaller than detection_probability",
                self.false_alarm_probability.to_string(),
            );
        }
        let s = self.initial_velocity_std_m_s;
        if !(s.is_finite() && s > 0.0) {
            return err(
                "initial_velocity_std_m_s",
                "a positive number",
                s.to_string(),
            );
        }
        Ok(())
    }
}

/// Life-cycle state of a track.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TrackStatus {
    /// Not yet confirmed (not reported).
    Tentative,
    /// Confirmed and updated in the last cycle.
    Confirmed,
    /// Confirmed but missed in the last cycle(s): reported as predicted.
    Coasting,
}

/// Ego-compensated radial-velocity measurement.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RadialVelocity {
    /// `v_object · u`, m/s (positive away from the sensor).
    pub value_m_s: f64,
    /// Unit line of sight `u` (fixed frame, horizontal components; normalised by the tracker).
    pub direction: [f64; 2],
    /// Variance, m²/s².
    pub variance_m2_s2: f64,
}

/// Ego-compensated velocity measured in one cycle (an FMCW LiDAR object's velocity from the Doppler
/// of its points).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VelocityMeasurement {
    /// Horizontal velocity, fixed frame, m/s.
    pub value_m_s: [f64; 2],
    /// Its covariance, m²/s² (ill-determined across the line of sight when the object spans a
    /// small angle).
    pub cov_m2_s2: [[f64; 2]; 2],
}

/// One measurement (a LiDAR box centre, a radar cluster) in the fixed frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measurement {
    /// Position, m.
    pub position_m: [f64; 2],
    /// Position covariance, m².
    pub position_cov_m2: [[f64; 2]; 2],
    /// Radial velocity (radar).
    pub radial: Option<RadialVelocity>,
    /// Velocity (FMCW LiDAR).
    pub velocity: Option<VelocityMeasurement>,
}

/// 4×4 matrix, row-major.
pub type Mat4 = [[f64; 4]; 4];

/// One track.
#[derive(Debug, Clone)]
pub struct Track<A> {
    /// Track id (unique within a tracker's life, reset by [`Tracker::reset`]).
    pub id: u64,
    /// State `(p_x, p_y, v_x, v_y)`, fixed frame, m and m/s.
    pub x: [f64; 4],
    /// State covariance.
    pub p: Mat4,
    pub status: TrackStatus,
    /// Hit history, bit 0 = latest cycle.
    pub hits: u32,
    /// Cycles since birth (including the birth cycle).
    pub cycles: u32,
    pub consecutive_misses: u32,
    /// Existence probability.
    pub existence: f64,
    /// Birth time, s.
    pub birth_time_s: f64,
    /// Time the state refers to, s.
    pub time_s: f64,
    /// Updated with a measurement in the current cycle.
    pub updated: bool,
    /// Sensor-specific attributes (box size, class, …).
    pub attr: A,
}

impl<A> Track<A> {
    /// Speed, m/s.
    pub fn speed_m_s(&self) -> f64 {
        self.x[2].hypot(self.x[3])
    }
    /// Whether the track is reported (confirmed or coasting).
    pub fn is_reported(&self) -> bool {
        self.status != TrackStatus::Tentative
    }
}

/// The multi-object tracker (see the module documentation).
#[derive(Debug, Clone)]
pub struct Tracker<A> {
    config: TrackerConfig,
    tracks: Vec<Track<A>>,
    next_id: u64,
    cost: Vec<f64>,
    assign_scratch: HungarianScratch,
}

impl<A> Tracker<A> {
    pub fn new(config: TrackerConfig) -> Tracker<A> {
        Tracker {
            config,
            tracks: Vec::new(),
            next_id: 1,
            cost: Vec::new(),
            assign_scratch: HungarianScratch::default(),
        }
    }

    pub fn config(&self) -> &TrackerConfig {
        &self.config
    }

    pub fn tracks(&self) -> &[Track<A>] {
        &self.tracks
    }

    pub fn tracks_mut(&mut self) -> &mut [Track<A>] {
        &mut self.tracks
    }

    /// Forget all tracks (ids restart at 1).
    pub fn reset(&mut self) {
        self.tracks.clear();
        self.next_id = 1;
    }

    /// Shifts every track by `d` (m): the fixed frame was re-based.
    pub fn shift(&mut self, d: [f64; 2]) {
        for t in &mut self.tracks {
            t.x[0] += d[0];
            t.x[1] += d[1];
        }
    }

    /// Start of a cycle: predict every track to `time_s` (CV model) and its existence probability.
    pub fn predict(&mut self, time_s: f64) {
        let q = self.config.process_noise_accel_m_s2.powi(2);
        let ps = self.config.survival_probability;
        for t in &mut self.tracks {
            let dt = time_s - t.time_s;
            if dt.is_finite() && dt > 0.0 {
                predict_cv(&mut t.x, &mut t.p, dt, q);
            }
            t.time_s = time_s;
            t.updated = false;
            t.existence *= ps;
        }
    }

    /// Squared Mahalanobis distance and `ln det S` of a measurement against a track, or `None`
    /// outside the χ² 99 % gate.
    pub fn gate(&self, track: usize, m: &Measurement) -> Option<(f64, f64)> {
        let t = &self.tracks[track];
        let (d2, ln_det, dof) = innovation_distance(&t.x, &t.p, m);
        let limit = if dof == 3 { CHI2_99_3DOF } else { CHI2_99_2DOF };
        (d2.is_finite() && d2 <= limit).then_some((d2, ln_det))
    }

    /// Global-nearest-neighbour association: `assignment[j]` = the track index measurement `j` is
    /// assigned to (Hungarian method on gated `d² + ln det S` costs), `None` when unassigned.
    /// `allowed(track, measurement)` may veto pairs.
    pub fn associate(
        &mut self,
        measurements: &[Measurement],
        allowed: impl Fn(&Track<A>, usize) -> bool,
        assignment: &mut Vec<Option<usize>>,
    ) {
        assignment.clear();
        assignment.resize(measurements.len(), None);
        let nt = self.tracks.len();
        let nm = measurements.len();
        if nt == 0 || nm == 0 {
            return;
        }
        const FORBIDDEN: f64 = 1e12;
        self.cost.clear();
        self.cost.resize(nt * nm, FORBIDDEN);
        let mut any = false;
        for i in 0..nt {
            for (j, m) in measurements.iter().enumerate() {
                if !allowed(&self.tracks[i], j) {
                    continue;
                }
                if let Some((d2, ln_det)) = self.gate(i, m) {
                    // Shift so that every gated cost is positive and far below FORBIDDEN.
                    self.cost[i * nm + j] = d2 + ln_det + 100.0;
                    any = true;
                }
            }
        }
        if !any {
            return;
        }
        let rows = hungarian(&self.cost, nt, nm, &mut self.assign_scratch);
        for (i, col) in rows.iter().enumerate() {
            if let Some(j) = *col
                && self.cost[i * nm + j] < FORBIDDEN
            {
                assignment[j] = Some(i);
            }
        }
    }

    /// Kalman update of track `track` with measurement `m` (a hit in this cycle).
    pub fn update(&mut self, track: usize, m: &Measurement) {
        let t = &mut self.tracks[track];
        update_position(&mut t.x, &mut t.p, m.position_m, m.position_cov_m2);
        if let Some(rv) = m.radial {
            update_radial(&mut t.x, &mut t.p, &rv);
        }
        if let Some(v) = m.velocity {
            update_velocity(&mut t.x, &mut t.p, v.value_m_s, v.cov_m2_s2);
        }
        t.updated = true;
    }

    /// A new tentative track at `m`'s position with velocity `velocity_m_s` (covariance
    /// `velocity_cov`, fixed frame). Returns its index.
    pub fn spawn(
        &mut self,
        m: &Measurement,
        velocity_m_s: [f64; 2],
        velocity_cov: [[f64; 2]; 2],
        time_s: f64,
        attr: A,
    ) -> usize {
        let mut p = [[0.0; 4]; 4];
        for a in 0..2 {
            for b in 0..2 {
                p[a][b] = m.position_cov_m2[a][b];
                p[2 + a][2 + b] = velocity_cov[a][b];
            }
        }
        let id = self.next_id;
        self.next_id += 1;
        self.tracks.push(Track {
            id,
            x: [
                m.position_m[0],
                m.position_m[1],
                velocity_m_s[0],
                velocity_m_s[1],
            ],
            p,
            status: TrackStatus::Tentative,
            hits: 0,
            cycles: 0,
            consecutive_misses: 0,
            existence: self.config.initial_existence,
            birth_time_s: time_s,
            time_s,
            updated: true,
            attr,
        });
        self.tracks.len() - 1
    }

    /// Covariance of an unknown velocity given an ego-compensated radial velocity along `u`:
    /// `σ_v²` along `u`, `σ_init²` across it.
    pub fn velocity_cov_from_radial(&self, u: [f64; 2], radial_variance: f64) -> [[f64; 2]; 2] {
        let n = u[0].hypot(u[1]).max(1e-12);
        let (ux, uy) = (u[0] / n, u[1] / n);
        let s_t = self.config.initial_velocity_std_m_s.powi(2);
        let s_r = radial_variance;
        // R · diag(s_r, s_t) · Rᵀ with R = [u, u⊥].
        [
            [s_r * ux * ux + s_t * uy * uy, (s_r - s_t) * ux * uy],
            [(s_r - s_t) * ux * uy, s_r * uy * uy + s_t * ux * ux],
        ]
    }

    /// Isotropic initial velocity covariance.
    pub fn velocity_cov_unknown(&self) -> [[f64; 2]; 2] {
        let s = self.config.initial_velocity_std_m_s.powi(2);
        [[s, 0.0], [0.0, s]]
    }

    /// End of a cycle: hit/miss bookkeeping, existence update, status transitions, deletion.
    pub fn finish_cycle(&mut self) {
        let c = &self.config;
        let pd = c.detection_probability;
        let pfa = c.false_alarm_probability;
        let window = if c.confirm_n >= 32 {
            u32::MAX
        } else {
            (1u32 << c.confirm_n) - 1
        };
        for t in &mut self.tracks {
            t.cycles = t.cycles.saturating_add(1);
            t.hits <<= 1;
            let p = t.existence;
            if t.updated {
                t.hits |= 1;
                t.consecutive_misses = 0;
                t.existence = pd * p / (pd * p + pfa * (1.0 - p));
            } else {
                t.consecutive_misses = t.consecutive_misses.saturating_add(1);
                t.existence = (1.0 - pd) * p / ((1.0 - pd) * p + (1.0 - pfa) * (1.0 - p));
            }
            t.status = match t.status {
                TrackStatus::Tentative => {
                    if (t.hits & window).count_ones() >= c.confirm_m {
                        TrackStatus::Confirmed
                    } else {
                        TrackStatus::Tentative
                    }
                }
                _ if t.updated => TrackStatus::Confirmed,
                _ => TrackStatus::Coasting,
            };
        }
        self.tracks.retain(|t| match t.status {
            TrackStatus::Tentative => {
                // Hits still possible in the remaining cycles of the first window.
                let hits = (t.hits & window).count_ones();
                let remaining = c.confirm_n.saturating_sub(t.cycles);
                hits + remaining >= c.confirm_m && t.existence >= c.delete_existence
            }
            _ => t.consecutive_misses <= c.max_coast_cycles && t.existence >= c.delete_existence,
        });
    }
}

/// CV prediction `x ← F x`, `P ← F P Fᵀ + Q` (see the module documentation).
pub fn predict_cv(x: &mut [f64; 4], p: &mut Mat4, dt: f64, q_accel_var: f64) {
    x[0] += dt * x[2];
    x[1] += dt * x[3];
    // F P Fᵀ with F = [[I, dt I], [0, I]].
    let mut fp = *p;
    for j in 0..4 {
        fp[0][j] += dt * p[2][j];
        fp[1][j] += dt * p[3][j];
    }
    let mut n = fp;
    for row in n.iter_mut() {
        row[0] += dt * row[2];
        row[1] += dt * row[3];
    }
    let q11 = q_accel_var * dt.powi(4) / 4.0;
    let q12 = q_accel_var * dt.powi(3) / 2.0;
    let q22 = q_accel_var * dt * dt;
    for a in 0..2 {
        n[a][a] += q11;
        n[a][a + 2] += q12;
        n[a + 2][a] += q12;
        n[a + 2][a + 2] += q22;
    }
    *p = n;
}

fn inv2(s: [[f64; 2]; 2]) -> Option<([[f64; 2]; 2], f64)> {
    let det = s[0][0] * s[1][1] - s[0][1] * s[1][0];
    if !(det.is_finite() && det > 0.0) {
        return None;
    }
    Some((
        [
            [s[1][1] / det, -s[0][1] / det],
            [-s[1][0] / det, s[0][0] / det],
        ],
        det,
    ))
}

/// `(d², ln det S, dof)` of a measurement's innovation (position, plus radial velocity if given:
/// the joint 3-D innovation).
fn innovation_distance(x: &[f64; 4], p: &Mat4, m: &Measurement) -> (f64, f64, usize) {
    let y = [m.position_m[0] - x[0], m.position_m[1] - x[1]];
    let s = [
        [
            p[0][0] + m.position_cov_m2[0][0],
            p[0][1] + m.position_cov_m2[0][1],
        ],
        [
            p[1][0] + m.position_cov_m2[1][0],
            p[1][1] + m.position_cov_m2[1][1],
        ],
    ];
    match m.radial {
        None => match inv2(s) {
            Some((si, det)) => {
                let d2 = y[0] * (si[0][0] * y[0] + si[0][1] * y[1])
                    + y[1] * (si[1][0] * y[0] + si[1][1] * y[1]);
                (d2, det.ln(), 2)
            }
            None => (f64::INFINITY, 0.0, 2),
        },
        Some(rv) => {
            let h = unit(rv.direction);
            // H rows: [1 0 0 0], [0 1 0 0], [0 0 ux uy].
            let hv = [h[0], h[1]];
            let yv = rv.value_m_s - (hv[0] * x[2] + hv[1] * x[3]);
            // S = H P Hᵀ + R (3×3).
            let mut s3 = [[0.0; 3]; 3];
            for a in 0..2 {
                for b in 0..2 {
                    s3[a][b] = s[a][b];
                }
                let c = p[a][2] * hv[0] + p[a][3] * hv[1];
                s3[a][2] = c;
                s3[2][a] = c;
            }
            s3[2][2] = hv[0] * (p[2][2] * hv[0] + p[2][3] * hv[1])
                + hv[1] * (p[3][2] * hv[0] + p[3][3] * hv[1])
                + rv.variance_m2_s2;
            let yy = [y[0], y[1], yv];
            match solve3(&s3, &yy) {
                Some((sol, det)) => {
                    let d2 = yy[0] * sol[0] + yy[1] * sol[1] + yy[2] * sol[2];
                    (d2, det.ln(), 3)
                }
                None => (f64::INFINITY, 0.0, 3),
            }
        }
    }
}

fn unit(d: [f64; 2]) -> [f64; 2] {
    let n = d[0].hypot(d[1]);
    if n > 1e-12 {
        [d[0] / n, d[1] / n]
    } else {
        [0.0, 0.0]
    }
}

/// Solves a symmetric positive-definite 3×3 system by Cramer's rule; returns the solution and det.
fn solve3(a: &[[f64; 3]; 3], b: &[f64; 3]) -> Option<([f64; 3], f64)> {
    let det3 = |m: &[[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let det = det3(a);
    if !(det.is_finite() && det > 0.0) {
        return None;
    }
    let mut out = [0.0; 3];
    for (k, o) in out.iter_mut().enumerate() {
        let mut m = *a;
        for r in 0..3 {
            m[r][k] = b[r];
        }
        *o = det3(&m) / det;
    }
    Some((out, det))
}

/// Linear KF update with a position measurement (`H = [I₂ 0]`), Joseph-free form with
/// symmetrisation.
pub fn update_position(x: &mut [f64; 4], p: &mut Mat4, z: [f64; 2], r: [[f64; 2]; 2]) {
    update_pair(x, p, 0, z, r);
}

/// Linear KF update with a velocity measurement (`H = [0 I₂]`).
pub fn update_velocity(x: &mut [f64; 4], p: &mut Mat4, z: [f64; 2], r: [[f64; 2]; 2]) {
    update_pair(x, p, 2, z, r);
}

/// Linear KF update with a measurement of the state pair `(x[o], x[o + 1])`.
fn update_pair(x: &mut [f64; 4], p: &mut Mat4, o: usize, z: [f64; 2], r: [[f64; 2]; 2]) {
    let s = [
        [p[o][o] + r[0][0], p[o][o + 1] + r[0][1]],
        [p[o + 1][o] + r[1][0], p[o + 1][o + 1] + r[1][1]],
    ];
    let Some((si, _)) = inv2(s) else { return };
    let y = [z[0] - x[o], z[1] - x[o + 1]];
    // K = P Hᵀ S⁻¹: 4×2.
    let mut k = [[0.0; 2]; 4];
    for (i, ki) in k.iter_mut().enumerate() {
        for j in 0..2 {
            ki[j] = p[i][o] * si[0][j] + p[i][o + 1] * si[1][j];
        }
    }
    for i in 0..4 {
        x[i] += k[i][0] * y[0] + k[i][1] * y[1];
    }
    // P ← P − K H P (H P = rows o and o + 1 of P).
    let hp = [p[o], p[o + 1]];
    for i in 0..4 {
        for j in 0..4 {
            p[i][j] -= k[i][0] * hp[0][j] + k[i][1] * hp[1][j];
        }
    }
    symmetrise(p);
}

/// Scalar EKF update with an ego-compensated radial velocity (`H = [0 0 u_x u_y]`).
pub fn update_radial(x: &mut [f64; 4], p: &mut Mat4, rv: &RadialVelocity) {
    let u = unit(rv.direction);
    let h = [0.0, 0.0, u[0], u[1]];
    let mut ph = [0.0; 4];
    for i in 0..4 {
        ph[i] = (0..4).map(|j| p[i][j] * h[j]).sum();
    }
    let s: f64 = (0..4).map(|i| h[i] * ph[i]).sum::<f64>() + rv.variance_m2_s2;
    if !(s.is_finite() && s > 0.0) {
        return;
    }
    let y = rv.value_m_s - (h[2] * x[2] + h[3] * x[3]);
    let k = ph.map(|v| v / s);
    for i in 0..4 {
        x[i] += k[i] * y;
    }
    for i in 0..4 {
        for j in 0..4 {
            p[i][j] -= k[i] * ph[j];
        }
    }
    symmetrise(p);
}

#[allow(clippy::needless_range_loop)]
fn symmetrise(p: &mut Mat4) {
    for i in 0..4 {
        for j in (i + 1)..4 {
            let m = 0.5 * (p[i][j] + p[j][i]);
            p[i][j] = m;
            p[j][i] = m;
        }
    }
}

/// Scratch buffers of [`hungarian`].
#[derive(Debug, Clone, Default)]
pub struct HungarianScratch {
    u: Vec<f64>,
    v: Vec<f64>,
    p: Vec<usize>,
    way: Vec<usize>,
    minv: Vec<f64>,
    used: Vec<bool>,
    result: Vec<Option<usize>>,
    transposed: Vec<f64>,
}

/// Minimum-cost assignment of a row-major `rows × cols` cost matrix (Hungarian method with
/// potentials, O(n²·m)). Returns, per row, the assigned column (`None` for rows left over when
/// `rows > cols`).
pub fn hungarian<'a>(
    cost: &[f64],
    rows: usize,
    cols: usize,
    s: &'a mut HungarianScratch,
) -> &'a [Option<usize>] {
    s.result.clear();
    s.result.resize(rows, None);
    if rows == 0 || cols == 0 {
        return &s.result;
    }
    // The algorithm needs n ≤ m: transpose if necessary.
    let transpose = rows > cols;
    let (n, m) = if transpose {
        (cols, rows)
    } else {
        (rows, cols)
    };
    if transpose {
        s.transposed.clear();
        s.transposed.resize(rows * cols, 0.0);
        for i in 0..rows {
            for j in 0..cols {
                s.transposed[j * rows + i] = cost[i * cols + j];
            }
        }
    }
    let c = |s: &HungarianScratch, i: usize, j: usize| -> f64 {
        if transpose {
            s.transposed[i * m + j]
        } else {
            cost[i * m + j]
        }
    };
    // 1-based arrays as in the classic formulation; p[j] = row matched to column j (0 = none).
    s.u.clear();
    s.u.resize(n + 1, 0.0);
    s.v.clear();
    s.v.resize(m + 1, 0.0);
    s.p.clear();
    s.p.resize(m + 1, 0);
    s.way.clear();
    s.way.resize(m + 1, 0);
    for i in 1..=n {
        s.p[0] = i;
        let mut j0 = 0usize;
        s.minv.clear();
        s.minv.resize(m + 1, f64::INFINITY);
        s.used.clear();
        s.used.resize(m + 1, false);
        loop {
            s.used[j0] = true;
            let i0 = s.p[j0];
            let mut delta = f64::INFINITY;
            let mut j1 = 0usize;
            for j in 1..=m {
                if !s.used[j] {
                    let cur = c(s, i0 - 1, j - 1) - s.u[i0] - s.v[j];
                    if cur < s.minv[j] {
                        s.minv[j] = cur;
                        s.way[j] = j0;
                    }
                    if s.minv[j] < delta {
                        delta = s.minv[j];
                        j1 = j;
                    }
                }
            }
            for j in 0..=m {
                if s.used[j] {
                    let pj = s.p[j];
                    s.u[pj] += delta;
                    s.v[j] -= delta;
                } else {
                    s.minv[j] -= delta;
                }
            }
            j0 = j1;
            if s.p[j0] == 0 {
                break;
            }
        }
        loop {
            let j1 = s.way[j0];
            s.p[j0] = s.p[j1];
            j0 = j1;
            if j0 == 0 {
                break;
            }
        }
    }
    for j in 1..=m {
        let i = s.p[j];
        if i != 0 {
            if transpose {
                s.result[j - 1] = Some(i - 1);
            } else {
                s.result[i - 1] = Some(j - 1);
            }
        }
    }
    &s.result
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hungarian_small_cases() {
        let mut s = HungarianScratch::default();
        // Classic 3×3: optimum 1 + 2 + 2 = 5? rows: [4 1 3],[2 0 5],[3 2 2] → (0,1),(1,0),(2,2) = 5.
        let c = [4.0, 1.0, 3.0, 2.0, 0.0, 5.0, 3.0, 2.0, 2.0];
        let r = hungarian(&c, 3, 3, &mut s).to_vec();
        assert_eq!(r, vec![Some(1), Some(0), Some(2)]);
        // Rectangular, more rows than columns.
        let c = [1.0, 10.0, 10.0, 1.0, 0.5, 0.5];
        let r = hungarian(&c, 3, 2, &mut s).to_vec();
        let total: f64 = r
            .iter()
            .enumerate()
            .filter_map(|(i, j)| j.map(|j| c[i * 2 + j]))
            .sum();
        assert_eq!(r.iter().filter(|x| x.is_some()).count(), 2);
        assert!((total - 1.5).abs() < 1e-12, "{r:?}");
    }

    #[test]
    fn cv_prediction_closed_form() {
        let mut x = [1.0, 2.0, 3.0, -1.0];
        let mut p = [[0.0; 4]; 4];
        predict_cv(&mut x, &mut p, 0.5, 4.0);
        assert_eq!(x, [2.5, 1.5, 3.0, -1.0]);
        // Q: σ²dt⁴/4 = 4·0.0625/4 = 0.0625, σ²dt³/2 = 0.25, σ²dt² = 1.
        assert!((p[0][0] - 0.0625).abs() < 1e-12);
        assert!((p[0][2] - 0.25).abs() < 1e-12);
        assert!((p[2][2] - 1.0).abs() < 1e-12);
    }

    #[test]
    fn scalar_update_matches_closed_form() {
        // 1-D check: prior var 4 on x, measurement var 1 → posterior var 0.8, gain 0.8.
        let mut x = [0.0; 4];
        let mut p = [[0.0; 4]; 4];
        p[0][0] = 4.0;
        p[1][1] = 4.0;
        update_position(&mut x, &mut p, [1.0, 0.0], [[1.0, 0.0], [0.0, 1.0]]);
        assert!((x[0] - 0.8).abs() < 1e-12 && (p[0][0] - 0.8).abs() < 1e-12);
    }
}
