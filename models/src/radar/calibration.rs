//! The radar's online azimuth calibration (`radar.mounting_misalignment`): the radar estimates its
//! own azimuth misalignment from the Doppler of stationary targets while the host drives, as
//! ARS-class automotive radars do, and corrects every reported azimuth by the estimate.
//!
//! # Method (physics.md §7.3)
//!
//! A stationary scatterer seen in the direction `u(θ, φ)` (nominal sensor frame) by a sensor moving
//! at `v` (nominal sensor axes) has the range rate `ṙ = −v·u(θ, φ)`. A radar turned by δ about its
//! z axis measures the azimuth `θ_m = θ − δ` in its own frame, so its stationary detections obey
//!
//! `r(δ) = ṙ + cos φ·(v_x cos(θ_m + δ) + v_y sin(θ_m + δ)) + v_z sin φ = 0`,
//!
//! with `∂r/∂δ = g = cos φ·(v_y cos(θ_m + δ) − v_x sin(θ_m + δ))`: at speed v a detection at
//! azimuth θ carries `v·sin θ` m/s of range rate per radian of misalignment, none at boresight
//! (the relation behind radar auto-alignment while driving, EP 3279683 A1, reviewed with the other
//! published methods in Burza, "Overview of radar alignment methods …", Sensors 24(15):4913,
//! 2024; Kellner et al., IEEE ITSC 2013, solve the same relation for the ego motion, physics.md
//! §6.1; here the ego motion is known from the vehicle and the angle offset is solved for).
//!
//! Per cycle, while the sensor moves faster than [`MIN_SPEED_M_S`]:
//!
//! 1. the stationary detections are not known beforehand: δ is searched on a grid over
//!    ±[`MAX_MISALIGNMENT_RAD`] for the value with the most Doppler-consistent detections
//!    (`|r(δ)| <` [`GATE_M_S`]; moving targets fall outside the gate) among those at least
//!    [`MIN_AZIMUTH_RAD`] off boresight;
//! 2. Gauss–Newton refines δ on those detections (`δ ← δ − Σ g·r / Σ g²`, three steps);
//! 3. the cycle's estimate enters the running estimate with its weight `Σ g²` (the inverse
//!    variance of the cycle's estimate for equal Doppler noise), so cycles with many detections
//!    far off boresight count most.
//!
//! A cycle needs at least [`MIN_DETECTIONS`] consistent detections and a weight of at least
//! [`MIN_WEIGHT`]. The estimate starts at 0 (no correction) and is kept until [`reset`](
//! MisalignmentEstimator::reset).

use glam::DVec3;

use crate::effects::EffectInfo;
use crate::recognition::RadarDetection;

/// `radar.mounting_misalignment`: the online azimuth calibration (module documentation).
pub const MOUNTING_MISALIGNMENT: EffectInfo = EffectInfo {
    name: "radar.mounting_misalignment",
    default_on: false,
    summary: "online azimuth calibration from stationary targets (ARS-class radars): for \
              stationary detections ṙ = −v·u(θ_m + δ); δ is fitted per cycle by a gated grid \
              search and Gauss–Newton over the Doppler-consistent detections, averaged over \
              cycles with the weights Σ(∂ṙ/∂δ)², and added to every reported azimuth; off: \
              the radar reports its raw azimuths",
    source: "stationary-target Doppler vs azimuth (physics.md §7.3; EP 3279683 A1, radar \
             auto-alignment from range rate, azimuth and host speed; Burza, Sensors 24(15):4913, \
             2024, review)",
    requires: None,
};

/// The radar's calibration effects.
pub const EFFECTS: &[EffectInfo] = &[MOUNTING_MISALIGNMENT];

/// Slowest sensor speed at which a cycle is used, m/s (below it `g` is too small to see a
/// misalignment of a tenth of a degree; guessed).
pub const MIN_SPEED_M_S: f64 = 2.0;
/// Largest misalignment searched, rad (5°: the `calibration` block allows 10°, but a radar's
/// self-calibration window is a few degrees; beyond it the radar reports a blocked calibration).
pub const MAX_MISALIGNMENT_RAD: f64 = 5.0 * std::f64::consts::PI / 180.0;
/// Grid step of the search, rad (0.1°).
const GRID_STEP_RAD: f64 = 0.1 * std::f64::consts::PI / 180.0;
/// Doppler consistency gate, m/s: about ten times the range-rate error of an interpolated
/// high-SNR peak of the default waveform (a few mm/s), so that two stationary targets merged into
/// one detection at a wrong angle (same range and Doppler cell) mostly fall outside (guessed).
pub const GATE_M_S: f64 = 0.05;
/// Smallest |azimuth| of a detection used, rad (5°): near boresight `g ≈ v·θ` carries almost no
/// information, and symmetric pairs of targets merge there.
pub const MIN_AZIMUTH_RAD: f64 = 5.0 * std::f64::consts::PI / 180.0;
/// Fewest consistent detections a cycle needs.
pub const MIN_DETECTIONS: usize = 3;
/// Smallest `Σ g²` a cycle needs, (m/s)² per rad² (e.g. three detections at 15 m/s and 20°
/// azimuth give 79).
pub const MIN_WEIGHT: f64 = 10.0;

/// Running estimate of the azimuth misalignment (module documentation).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct MisalignmentEstimator {
    sum_w: f64,
    sum_w_delta: f64,
    /// Stationary detections used so far.
    pub detections_used: u64,
    /// Cycles that contributed.
    pub cycles_used: u64,
}

/// The residual `r(δ)` of a detection under the stationary hypothesis and its derivative `g`.
fn residual(v: DVec3, d: &RadarDetection, delta: f64) -> (f64, f64) {
    let th = d.azimuth_rad + delta;
    let (ce, se) = (d.elevation_rad.cos(), d.elevation_rad.sin());
    let (s, c) = th.sin_cos();
    (
        d.range_rate_m_s + ce * (v.x * c + v.y * s) + v.z * se,
        ce * (v.y * c - v.x * s),
    )
}

impl MisalignmentEstimator {
    /// The current estimate δ̂ (rad; the radar's frame is turned by δ̂ to the left of its nominal
    /// one: a reported azimuth is corrected to `θ_m + δ̂`). 0 before any usable cycle.
    pub fn estimate_rad(&self) -> f64 {
        if self.sum_w > 0.0 {
            self.sum_w_delta / self.sum_w
        } else {
            0.0
        }
    }

    /// One cycle: `v_sensor` the sensor's velocity in its nominal axes (m/s; from the vehicle's
    /// odometry and the nominal mounting), `detections` the cycle's raw detections. Returns the
    /// cycle's own estimate when it was usable.
    pub fn update(&mut self, v_sensor: DVec3, detections: &[RadarDetection]) -> Option<f64> {
        if !(v_sensor.is_finite() && v_sensor.truncate().length() >= MIN_SPEED_M_S) {
            return None;
        }
        let usable = |d: &&RadarDetection| {
            d.azimuth_rad.is_finite()
                && d.elevation_rad.is_finite()
                && d.range_rate_m_s.is_finite()
                && d.azimuth_rad.abs() >= MIN_AZIMUTH_RAD
        };
        // 1. Grid search for the most Doppler-consistent δ (ties: the smallest |δ|).
        let steps = (MAX_MISALIGNMENT_RAD / GRID_STEP_RAD).round() as i64;
        let mut best: Option<(usize, f64)> = None;
        for k in 0..=2 * steps {
            // 0, +1, −1, +2, −2, …: the first of equal counts is the smallest |δ|.
            let j = if k % 2 == 0 { -(k / 2) } else { (k + 1) / 2 };
            let delta = j as f64 * GRID_STEP_RAD;
            let n = detections
                .iter()
                .filter(usable)
                .filter(|d| residual(v_sensor, d, delta).0.abs() < GATE_M_S)
                .count();
            if best.is_none_or(|(b, _)| n > b) {
                best = Some((n, delta));
            }
        }
        let (_, mut delta) = best?;
        // 2. Gauss–Newton on the consistent detections.
        let mut weight = 0.0;
        let mut used = 0;
        for _ in 0..3 {
            let (mut sgr, mut sgg, mut n) = (0.0, 0.0, 0usize);
            for d in detections.iter().filter(usable) {
                let (r, g) = residual(v_sensor, d, delta);
                if r.abs() < GATE_M_S {
                    sgr += g * r;
                    sgg += g * g;
                    n += 1;
                }
            }
            if n < MIN_DETECTIONS || sgg < MIN_WEIGHT {
                return None;
            }
            delta = (delta - sgr / sgg).clamp(-MAX_MISALIGNMENT_RAD, MAX_MISALIGNMENT_RAD);
            weight = sgg;
            used = n;
        }
        // 3. Into the running estimate.
        self.sum_w += weight;
        self.sum_w_delta += weight * delta;
        self.detections_used += used as u64;
        self.cycles_used += 1;
        Some(delta)
    }

    /// Forget every cycle (the estimate is 0 again).
    pub fn reset(&mut self) {
        *self = MisalignmentEstimator::default();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn det(az_deg: f64, v: DVec3, delta_deg: f64, moving_m_s: f64) -> RadarDetection {
        // True direction in the nominal frame: θ = θ_m + δ.
        let th = (az_deg + delta_deg).to_radians();
        RadarDetection {
            range_m: 20.0,
            azimuth_rad: az_deg.to_radians(),
            elevation_rad: 0.0,
            range_rate_m_s: -(v.x * th.cos() + v.y * th.sin()) + moving_m_s,
            snr_db: 20.0,
            rcs_dbsm: 10.0,
            object_id: 0,
        }
    }

    #[test]
    fn recovers_the_yaw_of_noise_free_stationary_detections_among_movers() {
        let v = DVec3::new(15.0, 0.0, 0.0);
        for delta in [-2.0, -0.4, 0.0, 1.0, 3.3] {
            let mut dets: Vec<_> = [-50.0, -35.0, -20.0, -8.0, 12.0, 25.0, 40.0, 55.0]
                .iter()
                .map(|&a| det(a, v, delta, 0.0))
                .collect();
            // Two movers: their Doppler is off by metres per second.
            dets.push(det(5.0, v, delta, 4.0));
            dets.push(det(-30.0, v, delta, -7.0));
            let mut e = MisalignmentEstimator::default();
            let cycle = e.update(v, &dets).expect("a usable cycle");
            assert!(
                (cycle.to_degrees() - delta).abs() < 1e-6,
                "{delta}: {cycle}"
            );
            assert!((e.estimate_rad().to_degrees() - delta).abs() < 1e-6);
            assert_eq!(e.detections_used, 8);
        }
    }

    #[test]
    fn standing_still_tells_nothing() {
        let mut e = MisalignmentEstimator::default();
        let dets: Vec<_> = [-30.0, 0.0, 30.0]
            .iter()
            .map(|&a| det(a, DVec3::ZERO, 1.0, 0.0))
            .collect();
        assert_eq!(e.update(DVec3::new(0.5, 0.0, 0.0), &dets), None);
        assert_eq!(e.estimate_rad(), 0.0);
    }
}
