//! Ego-motion from the Doppler of static points, moving/static segmentation and scan motion
//! compensation (physics.md §6.1, §6.2).
//!
//! A Doppler sensor (an FMCW LiDAR, a radar) measures the range rate `ṙ` of every point. For a
//! **static** point seen along the unit direction `d` (sensor frame) from a sensor whose origin
//! moves with the velocity `v_s` (sensor frame), `ṙ = −d · v_s` (negative when approaching; the
//! sensor's rotation does not change ranges). One scan of static points is thus a linear system
//! in `v_s` (Kellner, Barjenbruch, Klappstein, Dickmann, Dietmayer, "Instantaneous ego-motion
//! estimation using Doppler radar", IEEE ITSC 2013; for an FMCW LiDAR the same relation,
//! Hexsel, Vhavle & Chen, "DICP: Doppler Iterative Closest Point", RSS 2022).
//!
//! # Estimation ([`estimate_sensor_velocity`])
//!
//! 1. **Checks**: every rate, direction and weight finite, directions non-zero (normalised here),
//!    weights positive; at least `k + 1` points (`k` = 3 unknowns for [`EgoMotionModel::Full3d`],
//!    2 for [`EgoMotionModel::Planar`]: one more than the minimal set, so that the residual variance
//!    exists); the smallest eigenvalue of the weighted mean `Σ wᵢ dᵢ dᵢᵀ / Σ wᵢ` at least
//!    `min_direction_spread` (else every direction lies on one line, or for the 3-D model in one
//!    plane, and a velocity component is unobservable).
//! 2. **RANSAC** (Fischler & Bolles, "Random sample consensus", CACM 24(6), 1981): the exact
//!    solution of `k` random points (samples whose direction matrix has `|det| <`
//!    [`MIN_SAMPLE_VOLUME`] are skipped), scored by the number of points with
//!    `|ṙᵢ + dᵢ · v| ≤ inlier_threshold_m_s` (ties: the smaller sum of inlier residuals).
//!    Moving objects are the outliers (Kellner et al. 2013).
//! 3. **Weighted least squares** on the inliers: `N = Σ wᵢ dᵢ dᵢᵀ`, `v̂ = −N⁻¹ Σ wᵢ dᵢ ṙᵢ`,
//!    re-classifying the inliers with `v̂` and refitting until the set is stable (at most
//!    [`MAX_REFITS`] times). Covariance `Σ_v = σ̂² N⁻¹` with `σ̂² = Σ wᵢ rᵢ² / (n − k)` (the weights
//!    are relative inverse variances; residuals `rᵢ = ṙᵢ + dᵢ · v̂`). The inlier gate truncates the
//!    noise distribution, so with a gate of 3σ the variance is underestimated by ≈ 3 %.
//!
//! # Vehicle motion ([`vehicle_motion_from_sensor_velocity`])
//!
//! Under the planar nonholonomic model (no side slip, no vertical motion, no roll or pitch rate:
//! `v_vehicle = (v, 0, 0)`, `ω = (0, 0, ψ̇)` in the vehicle frame), a sensor mounted at
//! `r = (r_x, r_y, r_z)` moves with `v_s = v_vehicle + ω × r = (v − ψ̇ r_y, ψ̇ r_x, 0)`, so
//! `ψ̇ = v_s,y / r_x` and `v = v_s,x + ψ̇ r_y` (Kellner et al. 2013, with the Ackermann
//! condition at the rear axle; Kellner, Barjenbruch, Klappstein, Dickmann, Dietmayer,
//! "Instantaneous ego-motion estimation using multiple Doppler radars", IEEE ICRA 2014).
//! `r` is relative to the point of the vehicle without lateral velocity (the rear-axle centre for
//! a car with front steering); the yaw rate needs `r_x ≠ 0` and its standard deviation is
//! `σ(v_s,y) / |r_x|`.
//!
//! # Segmentation ([`segment`])
//!
//! A point is **moving** when `|ṙ + d · v_s| > threshold`: the ego-compensated range rate
//! ([`object_radial_velocity_compensated`]) is the object's own velocity along the line of sight
//! (Kellner et al. 2013; physics.md §6.2). An object moving perpendicular to the line of
//! sight stays "static" (its compensated range rate is zero).
//!
//! # Scan motion compensation ([`motion_compensate`])
//!
//! With a constant body twist `(v_s, ω_s)` of the sensor (sensor frame; constant for a vehicle
//! with constant speed and yaw rate), the sensor frame at `t_ref + Δt` has, in the frame at
//! `t_ref`, the pose `exp(Δt ξ^)`: rotation `R = exp([φ]×)`, `φ = ω_s Δt`, and translation
//! `V(φ) v_s Δt` with `V = I + (1 − cos θ)/θ² [φ]× + (θ − sin θ)/θ³ [φ]×²`, `θ = |φ|` (the SE(3)
//! exponential map: Barfoot, "State Estimation for Robotics", Cambridge 2017, ch. 7). A
//! point `p` measured at `t_ref + Δt` lies at `R p + V v_s Δt` in the reference frame.

use glam::{DMat2, DMat3, DVec2, DVec3};
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};
use serde::{Deserialize, Serialize};

use crate::frames::Pose;

/// A minimal sample is skipped when the absolute determinant of its direction matrix (the volume
/// spanned by its 3 directions, or the area of its 2 horizontal directions) is below this.
pub const MIN_SAMPLE_VOLUME: f64 = 1e-3;
/// At most this many re-classifications and refits after RANSAC.
pub const MAX_REFITS: usize = 5;
/// The yaw rate is unobservable when the sensor's longitudinal lever arm is shorter than this, m.
pub const MIN_LEVER_ARM_M: f64 = 1e-3;

/// One point of a Doppler scan.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DopplerPoint {
    /// Direction of the point, sensor frame (normalised by the estimator).
    pub direction: DVec3,
    /// Measured range rate, m/s, positive away from the sensor.
    pub range_rate_m_s: f64,
    /// Relative inverse variance of the range rate (1 for equal noise), > 0.
    pub weight: f64,
}

impl DopplerPoint {
    /// A point of weight 1.
    pub fn new(direction: DVec3, range_rate_m_s: f64) -> DopplerPoint {
        DopplerPoint {
            direction,
            range_rate_m_s,
            weight: 1.0,
        }
    }
}

/// The unknowns solved for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EgoMotionModel {
    /// The full sensor velocity `(v_x, v_y, v_z)` (3 unknowns; directions must span 3-D, e.g. a
    /// LiDAR with an elevation field of view).
    #[default]
    Full3d,
    /// `(v_x, v_y)` with `v_z = 0` (2 unknowns; a planar radar, directions of elevation ≈ 0). The
    /// z component of the directions is ignored.
    Planar,
}

impl EgoMotionModel {
    /// Number of unknowns.
    pub fn unknowns(self) -> usize {
        match self {
            EgoMotionModel::Full3d => 3,
            EgoMotionModel::Planar => 2,
        }
    }

    fn name(self) -> &'static str {
        match self {
            EgoMotionModel::Full3d => "3-D",
            EgoMotionModel::Planar => "planar",
        }
    }

    /// The regressor of a direction (z dropped for the planar model).
    fn row(self, d: DVec3) -> DVec3 {
        match self {
            EgoMotionModel::Full3d => d,
            EgoMotionModel::Planar => DVec3::new(d.x, d.y, 0.0),
        }
    }
}

/// Ego-motion estimation parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EgoMotionConfig {
    /// Unknowns: full 3-D sensor velocity or planar.
    pub model: EgoMotionModel,
    /// RANSAC hypotheses. With an outlier fraction ε, `N = ln(1 − p) / ln(1 − (1 − ε)^k)` draws
    /// find an all-inlier sample with probability p (Fischler & Bolles 1981): 200 draws give
    /// p > 0.999 999 for ε = 50 % and k = 3.
    pub ransac_iterations: u32,
    /// A point is an inlier when `|ṙ + d · v| ≤` this, m/s. Set it to ≈ 3× the range-rate noise σ
    /// or to the sensor's velocity resolution, whichever is larger (0.2 m/s: guessed, for a
    /// range-rate σ ≈ 0.05 m/s).
    pub inlier_threshold_m_s: f64,
    /// Smallest fraction of the points that must be inliers (static), (0, 1].
    pub min_inlier_fraction: f64,
    /// Smallest eigenvalue of the weighted mean `d dᵀ` (of the model's regressors) accepted; a
    /// velocity component along an eigenvector of eigenvalue λ has σ ≈ σ_ṙ / √(n λ).
    pub min_direction_spread: f64,
    /// RNG seed of RANSAC ([`estimate_sensor_velocity`]).
    pub seed: u64,
}

impl Default for EgoMotionConfig {
    fn default() -> Self {
        EgoMotionConfig {
            model: EgoMotionModel::Full3d,
            ransac_iterations: 200,
            inlier_threshold_m_s: 0.2,
            min_inlier_fraction: 0.3,
            min_direction_spread: 1e-4,
            seed: 0xD0_99_1E_12,
        }
    }
}

impl EgoMotionConfig {
    /// Checks the values.
    pub fn validate(&self) -> Result<(), EgoMotionError> {
        let bad = |m: String| Err(EgoMotionError::Config(m));
        if self.ransac_iterations == 0 {
            return bad("ransac_iterations must be at least 1".into());
        }
        let t = self.inlier_threshold_m_s;
        if !(t.is_finite() && t > 0.0) {
            return bad(format!(
                "inlier_threshold_m_s must be a positive number (got {t})"
            ));
        }
        let f = self.min_inlier_fraction;
        if !(f.is_finite() && f > 0.0 && f <= 1.0) {
            return bad(format!("min_inlier_fraction must be in (0, 1] (got {f})"));
        }
        let s = self.min_direction_spread;
        if !(s.is_finite() && s > 0.0 && s < 1.0) {
            return bad(format!("min_direction_spread must be in (0, 1) (got {s})"));
        }
        Ok(())
    }
}

/// Why an estimate failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EgoMotionError {
    #[error("invalid ego-motion configuration: {0}")]
    Config(String),
    #[error("too few points: {got}, the {model} model needs at least {needed}")]
    TooFewPoints {
        got: usize,
        needed: usize,
        model: &'static str,
    },
    #[error("point {index}: non-finite {what}")]
    NonFinite { index: usize, what: &'static str },
    #[error("point {index}: zero direction vector")]
    ZeroDirection { index: usize },
    #[error("point {index}: weight must be positive and finite (got {weight})")]
    InvalidWeight { index: usize, weight: f64 },
    #[error(
        "degenerate geometry of the {model} model ({which}): smallest eigenvalue {smallest:.3e} of the mean d·dᵀ is below {needed:.1e}; the directions lie along one line{plane_hint}, so a velocity component is unobservable"
    )]
    DegenerateGeometry {
        which: &'static str,
        smallest: f64,
        needed: f64,
        model: &'static str,
        plane_hint: &'static str,
    },
    #[error("degenerate geometry: no non-degenerate minimal sample in {iterations} RANSAC draws")]
    NoValidSample { iterations: u32 },
    #[error(
        "too few static points: {inliers} of {total} inliers, below the minimum fraction {min_fraction}"
    )]
    TooFewInliers {
        inliers: usize,
        total: usize,
        min_fraction: f64,
    },
    #[error(
        "yaw rate unobservable: the sensor's longitudinal lever arm r_x = {r_x_m} m is shorter than {MIN_LEVER_ARM_M} m"
    )]
    NoLeverArm { r_x_m: f64 },
    #[error("{points} points but {times} timestamps")]
    LengthMismatch { points: usize, times: usize },
}

/// The estimated velocity of the sensor origin.
#[derive(Debug, Clone, PartialEq)]
pub struct EgoVelocity {
    /// The model solved for.
    pub model: EgoMotionModel,
    /// Velocity of the sensor origin, sensor frame, m/s (z = 0 for the planar model).
    pub velocity_m_s: DVec3,
    /// Its covariance, m²/s² (z row and column zero for the planar model).
    pub covariance: DMat3,
    /// `inliers[i]`: point i is consistent with a static world (same order as the input).
    pub inliers: Vec<bool>,
    /// Number of inliers.
    pub inlier_count: usize,
    /// RMS of the inliers' (unweighted) residuals `ṙ + d · v`, m/s.
    pub residual_rms_m_s: f64,
}

/// [`estimate_sensor_velocity_with_rng`] with `SmallRng::seed_from_u64(config.seed)`: the result
/// depends only on the input.
pub fn estimate_sensor_velocity(
    points: &[DopplerPoint],
    config: &EgoMotionConfig,
) -> Result<EgoVelocity, EgoMotionError> {
    let mut rng = SmallRng::seed_from_u64(config.seed);
    estimate_sensor_velocity_with_rng(points, config, &mut rng)
}

/// Velocity of the sensor origin (sensor frame) from the range rates of a scan whose static
/// points are at least `min_inlier_fraction` of it: RANSAC and weighted least squares (module
/// documentation; physics.md §6.1).
pub fn estimate_sensor_velocity_with_rng<R: Rng + ?Sized>(
    points: &[DopplerPoint],
    config: &EgoMotionConfig,
    rng: &mut R,
) -> Result<EgoVelocity, EgoMotionError> {
    config.validate()?;
    let model = config.model;
    let k = model.unknowns();
    // Checks and normalised regressors.
    let mut rows = Vec::with_capacity(points.len());
    for (index, p) in points.iter().enumerate() {
        if !p.range_rate_m_s.is_finite() {
            return Err(EgoMotionError::NonFinite {
                index,
                what: "range rate",
            });
        }
        if !p.direction.is_finite() {
            return Err(EgoMotionError::NonFinite {
                index,
                what: "direction",
            });
        }
        if !(p.weight.is_finite() && p.weight > 0.0) {
            return Err(EgoMotionError::InvalidWeight {
                index,
                weight: p.weight,
            });
        }
        let len = p.direction.length();
        if len == 0.0 {
            return Err(EgoMotionError::ZeroDirection { index });
        }
        rows.push(model.row(p.direction / len));
    }
    let n = points.len();
    if n < k + 1 {
        return Err(EgoMotionError::TooFewPoints {
            got: n,
            needed: k + 1,
            model: model.name(),
        });
    }
    let all = vec![true; n];
    check_spread(model, &rows, points, &all, config, "all points")?;

    // RANSAC over minimal sets.
    let thr = config.inlier_threshold_m_s;
    let mut best: Option<(usize, f64, DVec3)> = None;
    let mut idx = [0usize; 3];
    for _ in 0..config.ransac_iterations {
        for j in 0..k {
            idx[j] = loop {
                let c = rng.random_range(0..n);
                if !idx[..j].contains(&c) {
                    break c;
                }
            };
        }
        let Some(v) = solve_minimal(model, &rows, points, &idx[..k]) else {
            continue;
        };
        let (mut count, mut sum) = (0usize, 0.0);
        for (row, p) in rows.iter().zip(points) {
            let r = (p.range_rate_m_s + row.dot(v)).abs();
            if r <= thr {
                count += 1;
                sum += r;
            }
        }
        let better = match best {
            None => true,
            Some((c, s, _)) => count > c || (count == c && sum < s),
        };
        if better {
            best = Some((count, sum, v));
        }
    }
    let Some((_, _, v0)) = best else {
        return Err(EgoMotionError::NoValidSample {
            iterations: config.ransac_iterations,
        });
    };

    // Weighted least-squares refit on the inliers until the inlier set is stable.
    let classify = |v: DVec3| -> Vec<bool> {
        rows.iter()
            .zip(points)
            .map(|(row, p)| (p.range_rate_m_s + row.dot(v)).abs() <= thr)
            .collect()
    };
    let mut inliers = classify(v0);
    let mut fit;
    let mut refits = 0;
    loop {
        let count = inliers.iter().filter(|&&b| b).count();
        let needed = ((config.min_inlier_fraction * n as f64).ceil() as usize).max(k + 1);
        if count < needed {
            return Err(EgoMotionError::TooFewInliers {
                inliers: count,
                total: n,
                min_fraction: config.min_inlier_fraction,
            });
        }
        check_spread(model, &rows, points, &inliers, config, "static inliers")?;
        fit = weighted_least_squares(model, &rows, points, &inliers);
        refits += 1;
        let next = classify(fit.0);
        if next == inliers || refits >= MAX_REFITS {
            break;
        }
        inliers = next;
    }
    let (velocity_m_s, n_inv) = fit;
    let (mut sum_w_r2, mut sum_r2, mut count) = (0.0, 0.0, 0usize);
    for ((row, p), _) in rows
        .iter()
        .zip(points)
        .zip(&inliers)
        .filter(|&(_, &inl)| inl)
    {
        let r = p.range_rate_m_s + row.dot(velocity_m_s);
        sum_w_r2 += p.weight * r * r;
        sum_r2 += r * r;
        count += 1;
    }
    let sigma2 = sum_w_r2 / (count - k) as f64;
    Ok(EgoVelocity {
        model,
        velocity_m_s,
        covariance: n_inv * sigma2,
        inliers,
        inlier_count: count,
        residual_rms_m_s: (sum_r2 / count as f64).sqrt(),
    })
}

/// Errors unless the smallest eigenvalue of the weighted mean `d dᵀ` of the selected points
/// reaches `min_direction_spread`.
fn check_spread(
    model: EgoMotionModel,
    rows: &[DVec3],
    points: &[DopplerPoint],
    mask: &[bool],
    config: &EgoMotionConfig,
    which: &'static str,
) -> Result<(), EgoMotionError> {
    let (m, w) = normal_matrix(rows, points, mask);
    let m = m * (1.0 / w);
    let smallest = match model {
        EgoMotionModel::Full3d => sym3_eigenvalues(&m)[0],
        EgoMotionModel::Planar => sym2_eigenvalues(m.x_axis.x, m.y_axis.x, m.y_axis.y)[0],
    };
    if smallest >= config.min_direction_spread {
        Ok(())
    } else {
        Err(EgoMotionError::DegenerateGeometry {
            which,
            smallest,
            needed: config.min_direction_spread,
            model: model.name(),
            plane_hint: match model {
                EgoMotionModel::Full3d => {
                    " or in one plane (a planar sensor: use the planar model)"
                }
                EgoMotionModel::Planar => "",
            },
        })
    }
}

/// `(Σ wᵢ dᵢ dᵢᵀ, Σ wᵢ)` over the selected points.
fn normal_matrix(rows: &[DVec3], points: &[DopplerPoint], mask: &[bool]) -> (DMat3, f64) {
    let mut m = DMat3::ZERO;
    let mut w = 0.0;
    for ((d, p), _) in rows.iter().zip(points).zip(mask).filter(|&(_, &s)| s) {
        m += outer(*d, *d) * p.weight;
        w += p.weight;
    }
    (m, w)
}

/// Weighted least squares `v̂ = −N⁻¹ Σ wᵢ dᵢ ṙᵢ`; returns `(v̂, N⁻¹)` (planar: z row/column 0).
/// The caller has checked that N is well conditioned.
fn weighted_least_squares(
    model: EgoMotionModel,
    rows: &[DVec3],
    points: &[DopplerPoint],
    mask: &[bool],
) -> (DVec3, DMat3) {
    let (mut n, _) = normal_matrix(rows, points, mask);
    let mut b = DVec3::ZERO;
    for ((d, p), _) in rows.iter().zip(points).zip(mask).filter(|&(_, &s)| s) {
        b -= *d * (p.weight * p.range_rate_m_s);
    }
    match model {
        EgoMotionModel::Full3d => {
            let inv = n.inverse();
            (inv * b, inv)
        }
        EgoMotionModel::Planar => {
            // The z row and column of N are zero: invert the 2×2 block.
            n.z_axis = DVec3::Z;
            let mut inv = n.inverse();
            inv.z_axis = DVec3::ZERO;
            (inv * b, inv)
        }
    }
}

/// The exact solution of a minimal sample, or `None` when its directions are (nearly) dependent.
fn solve_minimal(
    model: EgoMotionModel,
    rows: &[DVec3],
    points: &[DopplerPoint],
    idx: &[usize],
) -> Option<DVec3> {
    match model {
        EgoMotionModel::Full3d => {
            // Rows dᵢᵀ v = −ṙᵢ.
            let a = DMat3::from_cols(rows[idx[0]], rows[idx[1]], rows[idx[2]]).transpose();
            if a.determinant().abs() < MIN_SAMPLE_VOLUME {
                return None;
            }
            let b = -DVec3::new(
                points[idx[0]].range_rate_m_s,
                points[idx[1]].range_rate_m_s,
                points[idx[2]].range_rate_m_s,
            );
            Some(a.inverse() * b)
        }
        EgoMotionModel::Planar => {
            let (d0, d1) = (rows[idx[0]], rows[idx[1]]);
            let a = DMat2::from_cols(DVec2::new(d0.x, d1.x), DVec2::new(d0.y, d1.y));
            if a.determinant().abs() < MIN_SAMPLE_VOLUME {
                return None;
            }
            let b = -DVec2::new(points[idx[0]].range_rate_m_s, points[idx[1]].range_rate_m_s);
            Some((a.inverse() * b).extend(0.0))
        }
    }
}

fn outer(a: DVec3, b: DVec3) -> DMat3 {
    DMat3::from_cols(a * b.x, a * b.y, a * b.z)
}

/// Eigenvalues of a symmetric 2×2 matrix `[[a, b], [b, c]]`, ascending.
fn sym2_eigenvalues(a: f64, b: f64, c: f64) -> [f64; 2] {
    let m = 0.5 * (a + c);
    let r = (0.25 * (a - c) * (a - c) + b * b).sqrt();
    [m - r, m + r]
}

/// Eigenvalues of a symmetric 3×3 matrix, ascending (the trigonometric closed form: O. K. Smith,
/// "Eigenvalues of a symmetric 3 × 3 matrix", CACM 4(4), 1961).
fn sym3_eigenvalues(m: &DMat3) -> [f64; 3] {
    let (a11, a22, a33) = (m.x_axis.x, m.y_axis.y, m.z_axis.z);
    let (a12, a13, a23) = (m.y_axis.x, m.z_axis.x, m.z_axis.y);
    let p1 = a12 * a12 + a13 * a13 + a23 * a23;
    if p1 == 0.0 {
        let mut e = [a11, a22, a33];
        e.sort_by(f64::total_cmp);
        return e;
    }
    let q = (a11 + a22 + a33) / 3.0;
    let p2 = (a11 - q).powi(2) + (a22 - q).powi(2) + (a33 - q).powi(2) + 2.0 * p1;
    let p = (p2 / 6.0).sqrt();
    let b = (*m - DMat3::IDENTITY * q) * (1.0 / p);
    let r = (0.5 * b.determinant()).clamp(-1.0, 1.0);
    let phi = r.acos() / 3.0;
    let largest = q + 2.0 * p * phi.cos();
    let smallest = q + 2.0 * p * (phi + 2.0 * std::f64::consts::FRAC_PI_3).cos();
    [smallest, 3.0 * q - largest - smallest, largest]
}

/// Speed and yaw rate of the vehicle under the planar nonholonomic model (module documentation;
/// physics.md §6.1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VehicleMotion {
    /// Longitudinal speed of the reference point (no lateral velocity there), m/s.
    pub speed_m_s: f64,
    /// Yaw rate, rad/s (positive counter-clockwise seen from above).
    pub yaw_rate_rad_s: f64,
    /// Covariance of `(speed, yaw rate)` propagated from the sensor velocity's (first order).
    pub covariance: DMat2,
}

/// `(v, ψ̇)` from the sensor-origin velocity `v_s` **in the vehicle frame** and the sensor's
/// mounting position `r` (vehicle frame, relative to the point without lateral velocity):
/// `ψ̇ = v_s,y / r_x`, `v = v_s,x + ψ̇ r_y` (Kellner et al. 2013; physics.md §6.1). The
/// vertical component of `v_s` is not used (the model has none).
pub fn vehicle_motion_from_sensor_velocity(
    v_sensor_in_vehicle_frame: DVec3,
    mounting_position_m: DVec3,
) -> Result<(f64, f64), EgoMotionError> {
    let r = mounting_position_m;
    if r.x.is_nan() || r.x.abs() < MIN_LEVER_ARM_M {
        return Err(EgoMotionError::NoLeverArm { r_x_m: r.x });
    }
    let yaw_rate = v_sensor_in_vehicle_frame.y / r.x;
    Ok((v_sensor_in_vehicle_frame.x + yaw_rate * r.y, yaw_rate))
}

/// [`vehicle_motion_from_sensor_velocity`] from an estimate in the sensor frame and the sensor's
/// mounting pose (sensor frame → vehicle frame), with the covariance propagated through the
/// Jacobian `∂(v, ψ̇)/∂v_s = [[1, r_y/r_x, 0], [0, 1/r_x, 0]]`.
pub fn vehicle_motion_from_ego(
    ego: &EgoVelocity,
    mounting: &Pose,
) -> Result<VehicleMotion, EgoMotionError> {
    let v = mounting.transform_vector(ego.velocity_m_s);
    let r = mounting.position;
    let (speed_m_s, yaw_rate_rad_s) = vehicle_motion_from_sensor_velocity(v, r)?;
    let cov_v = mounting.rotation * ego.covariance * mounting.rotation.transpose();
    // J (2×3) rows.
    let j_speed = DVec3::new(1.0, r.y / r.x, 0.0);
    let j_yaw = DVec3::new(0.0, 1.0 / r.x, 0.0);
    let c = |a: DVec3, b: DVec3| a.dot(cov_v * b);
    let cross = c(j_speed, j_yaw);
    Ok(VehicleMotion {
        speed_m_s,
        yaw_rate_rad_s,
        covariance: DMat2::from_cols(
            DVec2::new(c(j_speed, j_speed), cross),
            DVec2::new(cross, c(j_yaw, j_yaw)),
        ),
    })
}

/// The range rate a static point along `direction` would have: `−d̂ · v_s` (`d̂` = the direction
/// normalised), m/s.
pub fn static_range_rate(direction: DVec3, sensor_velocity_m_s: DVec3) -> f64 {
    -direction.normalize_or_zero().dot(sensor_velocity_m_s)
}

/// The object's own radial velocity: measured minus the static prediction, `ṙ + d̂ · v_s`, m/s
/// (physics.md §6.2).
pub fn object_radial_velocity_compensated(point: &DopplerPoint, sensor_velocity_m_s: DVec3) -> f64 {
    point.range_rate_m_s - static_range_rate(point.direction, sensor_velocity_m_s)
}

/// Moving mask: `true` where `|ṙ + d̂ · v_s| > threshold_m_s` (physics.md §6.2). `v_s` is the
/// sensor-origin velocity in the sensor frame (e.g. [`EgoVelocity::velocity_m_s`], or from
/// odometry). A non-finite range rate is not classified as moving.
pub fn segment(
    points: &[DopplerPoint],
    sensor_velocity_m_s: DVec3,
    threshold_m_s: f64,
) -> Vec<bool> {
    points
        .iter()
        .map(|p| object_radial_velocity_compensated(p, sensor_velocity_m_s).abs() > threshold_m_s)
        .collect()
}

/// Body twist of the sensor frame: the velocity of its origin and its angular velocity, both in
/// the sensor frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorTwist {
    pub velocity_m_s: DVec3,
    pub angular_velocity_rad_s: DVec3,
}

impl SensorTwist {
    /// The twist of a sensor mounted with `mounting` (sensor → vehicle frame) on a vehicle of the
    /// planar nonholonomic model: `v_s = Rᵀ((v, 0, 0) + ω × r)`, `ω_s = Rᵀ (0, 0, ψ̇)`.
    pub fn from_vehicle_motion(speed_m_s: f64, yaw_rate_rad_s: f64, mounting: &Pose) -> Self {
        let omega = DVec3::new(0.0, 0.0, yaw_rate_rad_s);
        let v = DVec3::new(speed_m_s, 0.0, 0.0) + omega.cross(mounting.position);
        SensorTwist {
            velocity_m_s: mounting.inverse_transform_vector(v),
            angular_velocity_rad_s: mounting.inverse_transform_vector(omega),
        }
    }

    /// Pose of the sensor frame at `t_ref + dt` in the sensor frame at `t_ref` for a constant
    /// twist: the SE(3) exponential (module documentation).
    pub fn pose_change(&self, dt_s: f64) -> Pose {
        let phi = self.angular_velocity_rad_s * dt_s;
        let theta2 = phi.length_squared();
        let k = skew(phi);
        let k2 = k * k;
        // sin θ / θ, (1 − cos θ)/θ², (θ − sin θ)/θ³ (Taylor series near 0).
        let (s, a, b) = if theta2 < 1e-8 {
            (
                1.0 - theta2 / 6.0,
                0.5 - theta2 / 24.0,
                1.0 / 6.0 - theta2 / 120.0,
            )
        } else {
            let t = theta2.sqrt();
            (
                t.sin() / t,
                (1.0 - t.cos()) / theta2,
                (t - t.sin()) / (theta2 * t),
            )
        };
        let rotation = DMat3::IDENTITY + k * s + k2 * a;
        let v = DMat3::IDENTITY + k * a + k2 * b;
        Pose::new(v * (self.velocity_m_s * dt_s), rotation)
    }
}

/// `[φ]×`: `skew(φ) x = φ × x`.
fn skew(p: DVec3) -> DMat3 {
    DMat3::from_cols(
        DVec3::new(0.0, p.z, -p.y),
        DVec3::new(-p.z, 0.0, p.x),
        DVec3::new(p.y, -p.x, 0.0),
    )
}

/// Moves each point, measured in the sensor frame at `times_s[i]`, into the sensor frame at
/// `reference_time_s` under a constant twist (de-skewing a rotating scan; module documentation).
pub fn motion_compensate(
    positions_m: &mut [DVec3],
    times_s: &[f64],
    reference_time_s: f64,
    twist: &SensorTwist,
) -> Result<(), EgoMotionError> {
    if positions_m.len() != times_s.len() {
        return Err(EgoMotionError::LengthMismatch {
            points: positions_m.len(),
            times: times_s.len(),
        });
    }
    for (p, &t) in positions_m.iter_mut().zip(times_s) {
        *p = twist.pose_change(t - reference_time_s).transform_point(*p);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use std::f64::consts::PI;

    use rand_distr::StandardNormal;

    use super::*;

    const SPEED: f64 = 20.0;
    const YAW_RATE: f64 = 0.2;

    /// The sensor frame at time `t` in the world frame (= the vehicle frame at t = 0) for a vehicle
    /// driving on a circle of radius `v / ψ̇` from the origin, heading +x at t = 0.
    fn sensor_pose_at(t: f64, speed: f64, yaw_rate: f64, mounting: &Pose) -> Pose {
        let psi = yaw_rate * t;
        let centre = DVec3::new(
            speed / yaw_rate * psi.sin(),
            speed / yaw_rate * (1.0 - psi.cos()),
            0.0,
        );
        Pose::new(centre, DMat3::from_rotation_z(psi)).compose(mounting)
    }

    /// Range rate of a static world point at t = 0 by a central difference of its range along the
    /// vehicle's exact trajectory.
    fn range_rate(world: DVec3, mounting: &Pose) -> f64 {
        let h = 1e-4;
        let r = |t: f64| (world - sensor_pose_at(t, SPEED, YAW_RATE, mounting).position).length();
        (r(h) - r(-h)) / (2.0 * h)
    }

    struct Scene {
        points: Vec<DopplerPoint>,
        moving: Vec<bool>,
    }

    /// Adds noise `σ` and, for a fraction of the points, an own radial velocity of 2–15 m/s.
    fn contaminate(rng: &mut SmallRng, rate: f64, sigma: f64, moving_fraction: f64) -> (f64, bool) {
        let noisy = rate + sigma * rng.sample::<f64, _>(StandardNormal);
        if rng.random_bool(moving_fraction) {
            let sign = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
            (noisy + sign * rng.random_range(2.0..15.0), true)
        } else {
            (noisy, false)
        }
    }

    fn lidar_mounting() -> Pose {
        Pose::new(DVec3::new(1.4, 0.0, 1.9), DMat3::IDENTITY)
    }

    /// A LiDAR scan: 360° azimuth, elevation −25…15°, a quarter of the points on the ground
    /// (1.9 m below the sensor), noise 0.05 m/s, 20 % moving.
    fn lidar_scene(n: usize, seed: u64) -> Scene {
        let mounting = lidar_mounting();
        let mut rng = SmallRng::seed_from_u64(seed);
        let (mut points, mut moving) = (Vec::new(), Vec::new());
        for _ in 0..n {
            let az = rng.random_range(-PI..PI);
            let p = if rng.random_bool(0.25) {
                let rho = rng.random_range(4.0..60.0);
                DVec3::new(rho * az.cos(), rho * az.sin(), -1.9)
            } else {
                let el = rng.random_range(-25f64..15.0).to_radians();
                let r = rng.random_range(5.0..100.0);
                r * DVec3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin())
            };
            let rate = range_rate(mounting.transform_point(p), &mounting);
            let (rate, m) = contaminate(&mut rng, rate, 0.05, 0.2);
            points.push(DopplerPoint::new(p.normalize(), rate));
            moving.push(m);
        }
        Scene { points, moving }
    }

    fn lidar_config() -> EgoMotionConfig {
        EgoMotionConfig {
            inlier_threshold_m_s: 0.15,
            ..EgoMotionConfig::default()
        }
    }

    /// Every moving point is an outlier and at least `min_recall` of the static ones inliers.
    fn check_inliers(scene: &Scene, ego: &EgoVelocity, min_recall: f64) {
        let statics = scene.moving.iter().filter(|&&m| !m).count();
        let mut found = 0;
        for (&m, &inl) in scene.moving.iter().zip(&ego.inliers) {
            assert!(!(m && inl), "a moving point is an inlier");
            found += usize::from(inl);
        }
        assert_eq!(found, ego.inlier_count);
        assert!(
            found as f64 >= min_recall * statics as f64,
            "{found} of {statics}"
        );
    }

    #[test]
    fn ego_motion_lidar_scene_few_hundred_points() {
        let scene = lidar_scene(400, 1);
        let ego = estimate_sensor_velocity(&scene.points, &lidar_config()).unwrap();
        let m = vehicle_motion_from_ego(&ego, &lidar_mounting()).unwrap();
        assert!((m.speed_m_s - SPEED).abs() < 0.2, "{m:?}");
        // With 400 points the yaw rate is limited by the noise: σ(ψ̇) = σ(v_s,y) / r_x.
        let sigma_yaw = m.covariance.y_axis.y.sqrt();
        assert!(sigma_yaw < 0.01, "{sigma_yaw}");
        assert!(
            (m.yaw_rate_rad_s - YAW_RATE).abs() < 4.0 * sigma_yaw,
            "{m:?}"
        );
        check_inliers(&scene, &ego, 0.98);
        assert!(
            (ego.residual_rms_m_s - 0.05).abs() < 0.01,
            "{}",
            ego.residual_rms_m_s
        );
    }

    #[test]
    fn ego_motion_lidar_scene_dense_yaw_rate_within_one_percent() {
        let scene = lidar_scene(10_000, 2);
        let ego = estimate_sensor_velocity(&scene.points, &lidar_config()).unwrap();
        // Truth in the sensor frame: v_s = (v, 0, 0) + ψ̇ ẑ × r = (20, 0.28, 0).
        let truth = DVec3::new(SPEED, YAW_RATE * 1.4, 0.0);
        assert!(
            (ego.velocity_m_s - truth).length() < 0.02,
            "{:?}",
            ego.velocity_m_s
        );
        let m = vehicle_motion_from_ego(&ego, &lidar_mounting()).unwrap();
        assert!((m.speed_m_s - SPEED).abs() < 0.2, "{m:?}");
        assert!((m.yaw_rate_rad_s - YAW_RATE).abs() < 0.002, "{m:?}");
        check_inliers(&scene, &ego, 0.99);
        // The covariance against the textbook σ² (Σ dᵢ dᵢᵀ)⁻¹ with the noise σ = 0.05 m/s (the
        // 3σ gate shrinks the residual variance by ≈ 3 %).
        let mut n = DMat3::ZERO;
        for (p, _) in scene.points.iter().zip(&ego.inliers).filter(|&(_, &i)| i) {
            n += outer(p.direction, p.direction);
        }
        let expected = n.inverse() * 0.05f64.powi(2);
        for (e, c) in [
            (expected.x_axis.x, ego.covariance.x_axis.x),
            (expected.y_axis.y, ego.covariance.y_axis.y),
            (expected.z_axis.z, ego.covariance.z_axis.z),
        ] {
            assert!((c / e - 1.0).abs() < 0.15, "{c} vs {e}");
        }
    }

    #[test]
    fn ego_motion_planar_radar() {
        // A front-left corner radar: at (3.6, 0.8, 0.5) m, yawed +45°, ±60° field of view,
        // elevation 0, noise 0.1 m/s, 20 % moving.
        let mounting = Pose::new(
            DVec3::new(3.6, 0.8, 0.5),
            DMat3::from_rotation_z(45f64.to_radians()),
        );
        let mut rng = SmallRng::seed_from_u64(3);
        let (mut points, mut moving) = (Vec::new(), Vec::new());
        for _ in 0..200 {
            let az = rng.random_range(-60f64..60.0).to_radians();
            let p = rng.random_range(5.0..80.0) * DVec3::new(az.cos(), az.sin(), 0.0);
            let rate = range_rate(mounting.transform_point(p), &mounting);
            let (rate, m) = contaminate(&mut rng, rate, 0.1, 0.2);
            points.push(DopplerPoint::new(p.normalize(), rate));
            moving.push(m);
        }
        let scene = Scene { points, moving };
        let config = EgoMotionConfig {
            model: EgoMotionModel::Planar,
            inlier_threshold_m_s: 0.3,
            ..EgoMotionConfig::default()
        };
        let ego = estimate_sensor_velocity(&scene.points, &config).unwrap();
        assert_eq!(ego.velocity_m_s.z, 0.0);
        assert_eq!(ego.covariance.z_axis, DVec3::ZERO);
        // Truth: (20, 0, 0) + ψ̇ ẑ × (3.6, 0.8, 0) = (20 − 0.16, 0.72, 0), rotated by −45°.
        let (c, s) = (45f64.to_radians().cos(), 45f64.to_radians().sin());
        let (vx, vy) = (SPEED - YAW_RATE * 0.8, YAW_RATE * 3.6);
        let truth = DVec3::new(c * vx + s * vy, -s * vx + c * vy, 0.0);
        assert!(
            (ego.velocity_m_s - truth).length() < 0.1,
            "{:?}",
            ego.velocity_m_s
        );
        check_inliers(&scene, &ego, 0.98);
        let m = vehicle_motion_from_ego(&ego, &mounting).unwrap();
        assert!((m.speed_m_s - SPEED).abs() < 0.2, "{m:?}");
        let sigma_yaw = m.covariance.y_axis.y.sqrt();
        assert!(sigma_yaw < 0.02, "{sigma_yaw}");
        assert!(
            (m.yaw_rate_rad_s - YAW_RATE).abs() < 4.0 * sigma_yaw,
            "{m:?}"
        );

        // The 3-D model cannot solve a planar scan.
        let err = estimate_sensor_velocity(&scene.points, &EgoMotionConfig::default()).unwrap_err();
        assert!(
            matches!(err, EgoMotionError::DegenerateGeometry { .. }),
            "{err}"
        );
        assert!(err.to_string().contains("use the planar model"), "{err}");
    }

    #[test]
    fn ego_motion_degenerate_inputs_are_errors() {
        let config = EgoMotionConfig::default();
        let p = |d: DVec3, r: f64| DopplerPoint::new(d, r);
        let good = [
            p(DVec3::X, -1.0),
            p(DVec3::Y, 0.0),
            p(DVec3::Z, 0.0),
            p(DVec3::ONE, -1.0 / 3f64.sqrt()),
        ];
        for n in 0..3 {
            let err = estimate_sensor_velocity(&good[..n], &config).unwrap_err();
            assert_eq!(
                err,
                EgoMotionError::TooFewPoints {
                    got: n,
                    needed: 4,
                    model: "3-D"
                }
            );
            assert!(err.to_string().contains("too few points"));
        }
        let planar = EgoMotionConfig {
            model: EgoMotionModel::Planar,
            ..EgoMotionConfig::default()
        };
        assert!(matches!(
            estimate_sensor_velocity(&good[..2], &planar),
            Err(EgoMotionError::TooFewPoints { needed: 3, .. })
        ));
        // All along one direction (both models).
        let line: Vec<_> = (0..20)
            .map(|i| p(DVec3::new(1.0, 1.0, 0.2), i as f64))
            .collect();
        for c in [&config, &planar] {
            let err = estimate_sensor_velocity(&line, c).unwrap_err();
            assert!(matches!(err, EgoMotionError::DegenerateGeometry { .. }));
            assert!(err.to_string().contains("along one line"), "{err}");
        }
        // Non-finite and invalid inputs name the point.
        let mut bad = good.to_vec();
        bad[2].range_rate_m_s = f64::NAN;
        let err = estimate_sensor_velocity(&bad, &config).unwrap_err();
        assert_eq!(
            err,
            EgoMotionError::NonFinite {
                index: 2,
                what: "range rate"
            }
        );
        assert!(err.to_string().contains("non-finite range rate"));
        let mut bad = good.to_vec();
        bad[1].direction.x = f64::INFINITY;
        assert!(matches!(
            estimate_sensor_velocity(&bad, &config),
            Err(EgoMotionError::NonFinite {
                index: 1,
                what: "direction"
            })
        ));
        let mut bad = good.to_vec();
        bad[3].direction = DVec3::ZERO;
        assert!(matches!(
            estimate_sensor_velocity(&bad, &config),
            Err(EgoMotionError::ZeroDirection { index: 3 })
        ));
        let mut bad = good.to_vec();
        bad[0].weight = 0.0;
        assert!(matches!(
            estimate_sensor_velocity(&bad, &config),
            Err(EgoMotionError::InvalidWeight { index: 0, .. })
        ));
        // The four good points give the exact velocity (1, 0, 0) with zero residual.
        let ego = estimate_sensor_velocity(&good, &config).unwrap();
        assert!((ego.velocity_m_s - DVec3::new(1.0, 0.0, 0.0)).length() < 1e-12);
        assert!(ego.residual_rms_m_s < 1e-12 && ego.velocity_m_s.is_finite());
    }

    #[test]
    fn ego_motion_no_static_majority_is_an_error() {
        let mut rng = SmallRng::seed_from_u64(4);
        let points: Vec<_> = (0..300)
            .map(|_| {
                let d = DVec3::new(
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                );
                DopplerPoint::new(d, rng.random_range(-20.0..20.0))
            })
            .collect();
        let err = estimate_sensor_velocity(&points, &lidar_config()).unwrap_err();
        assert!(
            matches!(err, EgoMotionError::TooFewInliers { total: 300, .. }),
            "{err}"
        );
    }

    #[test]
    fn ego_motion_segmentation_precision_recall() {
        let scene = lidar_scene(2000, 5);
        let ego = estimate_sensor_velocity(&scene.points, &lidar_config()).unwrap();
        let mask = segment(&scene.points, ego.velocity_m_s, 0.15);
        let tp = mask.iter().zip(&scene.moving).filter(|&(&a, &b)| a && b);
        let tp = tp.count() as f64;
        let predicted = mask.iter().filter(|&&m| m).count() as f64;
        let actual = scene.moving.iter().filter(|&&m| m).count() as f64;
        assert!(
            tp / predicted > 0.95 && tp / actual > 0.95,
            "{tp} {predicted} {actual}"
        );
        // The compensated radial velocity of a static point is its noise; a point moving at 5 m/s
        // towards the sensor along its line of sight has −5.
        let v_s = DVec3::new(10.0, 1.0, 0.0);
        let d = DVec3::new(3.0, 4.0, 0.0);
        let static_rate = -(3.0 * 10.0 + 4.0) / 5.0;
        let p = DopplerPoint::new(d, static_rate - 5.0);
        assert!((object_radial_velocity_compensated(&p, v_s) + 5.0).abs() < 1e-12);
        assert!((static_range_rate(d, v_s) - static_rate).abs() < 1e-12);
        assert_eq!(segment(&[p], v_s, 4.9), vec![true]);
        assert_eq!(segment(&[p], v_s, 5.1), vec![false]);
    }

    #[test]
    fn ego_motion_deterministic_for_a_seed() {
        let scene = lidar_scene(500, 6);
        let config = lidar_config();
        let a = estimate_sensor_velocity(&scene.points, &config).unwrap();
        let b = estimate_sensor_velocity(&scene.points, &config).unwrap();
        assert_eq!(a, b);
        let mut rng = SmallRng::seed_from_u64(config.seed);
        let c = estimate_sensor_velocity_with_rng(&scene.points, &config, &mut rng).unwrap();
        assert_eq!(a, c);
        let other = EgoMotionConfig { seed: 99, ..config };
        let d = estimate_sensor_velocity(&scene.points, &other).unwrap();
        assert!((a.velocity_m_s - d.velocity_m_s).length() < 1e-9);
    }

    #[test]
    fn ego_motion_vehicle_motion_closed_form() {
        // v_s = (v − ψ̇ r_y, ψ̇ r_x, 0) for v = 15, ψ̇ = −0.3, r = (2, −0.5, 1).
        let r = DVec3::new(2.0, -0.5, 1.0);
        let v_s = DVec3::new(15.0 - 0.15, -0.6, 0.0);
        let (v, w) = vehicle_motion_from_sensor_velocity(v_s, r).unwrap();
        assert!((v - 15.0).abs() < 1e-12 && (w + 0.3).abs() < 1e-12);
        assert_eq!(
            vehicle_motion_from_sensor_velocity(v_s, DVec3::new(0.0, 1.0, 1.0)),
            Err(EgoMotionError::NoLeverArm { r_x_m: 0.0 })
        );
        // SensorTwist from the same motion and a yawed mount: the velocity rotates into the sensor.
        let mounting = Pose::new(r, DMat3::from_rotation_z(0.5));
        let tw = SensorTwist::from_vehicle_motion(15.0, -0.3, &mounting);
        assert!((mounting.transform_vector(tw.velocity_m_s) - v_s).length() < 1e-12);
        assert!((tw.angular_velocity_rad_s - DVec3::new(0.0, 0.0, -0.3)).length() < 1e-12);
    }

    #[test]
    fn ego_motion_scan_compensation_matches_the_circle() {
        let mounting = Pose::new(
            DVec3::new(1.2, 0.3, 1.8),
            DMat3::from_rotation_z(0.4) * DMat3::from_rotation_y(0.05),
        );
        let twist = SensorTwist::from_vehicle_motion(SPEED, YAW_RATE, &mounting);
        let (t_ref, mut rng) = (0.05, SmallRng::seed_from_u64(7));
        let (mut measured, mut times, mut expected) = (Vec::new(), Vec::new(), Vec::new());
        for _ in 0..50 {
            let world = DVec3::new(
                rng.random_range(-50.0..50.0),
                rng.random_range(-50.0..50.0),
                rng.random_range(-2.0..5.0),
            );
            let t = rng.random_range(0.0..0.1);
            measured
                .push(sensor_pose_at(t, SPEED, YAW_RATE, &mounting).inverse_transform_point(world));
            times.push(t);
            expected.push(
                sensor_pose_at(t_ref, SPEED, YAW_RATE, &mounting).inverse_transform_point(world),
            );
        }
        motion_compensate(&mut measured, &times, t_ref, &twist).unwrap();
        for (m, e) in measured.iter().zip(&expected) {
            assert!((*m - *e).length() < 1e-9, "{m} vs {e}");
        }
        assert_eq!(
            motion_compensate(&mut measured, &times[1..], t_ref, &twist),
            Err(EgoMotionError::LengthMismatch {
                points: 50,
                times: 49
            })
        );
        // No rotation: a pure translation v Δt.
        let straight = SensorTwist {
            velocity_m_s: DVec3::new(10.0, 0.0, 0.0),
            angular_velocity_rad_s: DVec3::ZERO,
        };
        let pose = straight.pose_change(0.1);
        assert_eq!(pose.rotation, DMat3::IDENTITY);
        assert!((pose.position - DVec3::new(1.0, 0.0, 0.0)).length() < 1e-15);
    }

    #[test]
    fn ego_motion_symmetric_eigenvalues() {
        let r = DMat3::from_rotation_z(0.7) * DMat3::from_rotation_x(-0.3);
        let m = r * DMat3::from_diagonal(DVec3::new(0.1, 2.0, 0.5)) * r.transpose();
        let e = sym3_eigenvalues(&m);
        for (a, b) in e.iter().zip([0.1, 0.5, 2.0]) {
            assert!((a - b).abs() < 1e-12, "{e:?}");
        }
        assert_eq!(sym2_eigenvalues(2.0, 1.0, 2.0), [1.0, 3.0]);
    }

    #[test]
    fn ego_motion_config_serde_and_validation() {
        let c: EgoMotionConfig =
            serde_json::from_str(r#"{"model": "planar", "inlier_threshold_m_s": 0.1}"#).unwrap();
        assert_eq!(c.model, EgoMotionModel::Planar);
        assert_eq!(
            c.ransac_iterations,
            EgoMotionConfig::default().ransac_iterations
        );
        assert!(serde_json::from_str::<EgoMotionConfig>(r#"{"treshold": 1}"#).is_err());
        let bad = EgoMotionConfig {
            min_inlier_fraction: 0.0,
            ..EgoMotionConfig::default()
        };
        let err = bad.validate().unwrap_err();
        assert!(err.to_string().contains("min_inlier_fraction"), "{err}");
    }
}
