//! Multi-bounce propagation paths: specular and sampled diffuse bounces, path length and Doppler.
//!
//! A path starts at a ray origin `p_0` (the transmitter or camera) and visits surface points
//! `p_1 … p_n`. Its length is `L = Σ_i |p_i − p_{i−1}|`. When every point moves (`v_i`, the velocity of
//! the material point hit, `v_0` the sensor's), the length changes at
//!
//! ```text
//! dL/dt = Σ_i û_i · (v_i − v_{i−1}),   û_i = (p_i − p_{i−1}) / |p_i − p_{i−1}|
//! ```
//!
//! and the received wave is Doppler-shifted by `f_D = −(1/λ) dL/dt` ([`doppler_shift_hz`]): positive
//! when the path shortens (approaching target). For a monostatic single bounce off a surface moving
//! with `v` (sensor at rest, normal incidence, `n` the surface normal facing the sensor) this is
//! `f_D = 2 v·n / λ = −2 v_r / λ` with `v_r` the radial (range-rate) velocity. Using the material
//! point's velocity at a specular point is exact to first order: the path length is stationary with
//! respect to sliding the specular point along the surface (Fermat), so only the normal motion counts.

use glam::DVec3;
use rayon::prelude::*;

use super::query::surface_epsilon;
use super::{Hit, Ray, Space};

/// How the segment arriving at a path vertex was generated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Segment {
    /// The initial ray.
    Primary,
    /// Mirror reflection at the previous vertex, `r = d − 2 (d·n) n`.
    Specular,
    /// Cosine-weighted sample of the hemisphere at the previous vertex (pdf `cos θ / π`).
    Diffuse,
}

/// One surface interaction of a path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathVertex {
    pub hit: Hit,
    /// How the ray reached this vertex.
    pub arrival: Segment,
    /// Path length from the origin to this vertex, m.
    pub path_length_m: f64,
}

/// A propagation path from `origin` through surface vertices.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Path {
    pub origin: DVec3,
    pub vertices: Vec<PathVertex>,
    /// Direction in which the path left the scene after its last vertex (or from the origin if it has
    /// none), if it did before reaching the bounce limit (sky / background for cameras).
    pub escape: Option<DVec3>,
}

/// What [`Space::trace_path`] follows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathPolicy {
    /// Surface interactions to follow (1: first hit only). Without `space.multipath`: at most 1.
    pub max_bounces: u32,
    /// Probability that a bounce is a cosine-weighted diffuse sample rather than the mirror direction.
    /// Without `space.diffuse_bounces`: 0 (all specular).
    pub diffuse_probability: f64,
    /// Maximum length of each segment, m.
    pub segment_t_max: f64,
    /// Seed of the per-path random sequence (path `i` of a batch uses stream `i`: deterministic for any
    /// thread count).
    pub seed: u64,
}

impl Default for PathPolicy {
    fn default() -> Self {
        PathPolicy {
            max_bounces: 3,
            diffuse_probability: 0.0,
            segment_t_max: f64::INFINITY,
            seed: 0,
        }
    }
}

impl Path {
    /// Path length from the origin to the last vertex, m (0 without vertices).
    pub fn length_m(&self) -> f64 {
        self.vertices.last().map_or(0.0, |v| v.path_length_m)
    }

    /// Length and length rate (m, m/s) of the closed path transmitter (`origin`, moving with
    /// `tx_velocity`) → vertices → receiver (`receiver`, moving with `rx_velocity`). The return leg is
    /// not checked for occlusion (see [`Space::segment_clear`]).
    pub fn closed_length_and_rate(
        &self,
        tx_velocity: DVec3,
        receiver: DVec3,
        rx_velocity: DVec3,
    ) -> (f64, f64) {
        let points = std::iter::once(self.origin)
            .chain(self.vertices.iter().map(|v| v.hit.point))
            .chain(std::iter::once(receiver));
        let velocities = std::iter::once(tx_velocity)
            .chain(self.vertices.iter().map(|v| v.hit.velocity_m_s))
            .chain(std::iter::once(rx_velocity));
        polyline_length_and_rate(points, velocities)
    }

    /// Monostatic radar/LiDAR: the receiver is the transmitter (the path returns to `origin`).
    pub fn monostatic_length_and_rate(&self, sensor_velocity: DVec3) -> (f64, f64) {
        self.closed_length_and_rate(sensor_velocity, self.origin, sensor_velocity)
    }

    /// Monostatic Doppler shift, Hz (positive for a shortening path).
    pub fn monostatic_doppler_hz(&self, sensor_velocity: DVec3, wavelength_m: f64) -> f64 {
        doppler_shift_hz(
            self.monostatic_length_and_rate(sensor_velocity).1,
            wavelength_m,
        )
    }
}

fn polyline_length_and_rate(
    points: impl Iterator<Item = DVec3>,
    velocities: impl Iterator<Item = DVec3>,
) -> (f64, f64) {
    let mut prev: Option<(DVec3, DVec3)> = None;
    let (mut length, mut rate) = (0.0, 0.0);
    for (p, v) in points.zip(velocities) {
        if let Some((p0, v0)) = prev {
            let d = p - p0;
            let l = d.length();
            length += l;
            if l > 0.0 {
                rate += d.dot(v - v0) / l;
            }
        }
        prev = Some((p, v));
    }
    (length, rate)
}

/// `dL/dt` of the polyline `points[0] → … → points[n]` whose points move with `velocities`:
/// `Σ_i û_i · (v_i − v_{i−1})`, m/s. Panics if the lengths differ.
pub fn path_length_rate(points: &[DVec3], velocities: &[DVec3]) -> f64 {
    assert_eq!(points.len(), velocities.len(), "one velocity per point");
    polyline_length_and_rate(points.iter().copied(), velocities.iter().copied()).1
}

/// Doppler shift of a path whose length changes at `length_rate_m_s`: `f_D = −(dL/dt) / λ`, Hz.
pub fn doppler_shift_hz(length_rate_m_s: f64, wavelength_m: f64) -> f64 {
    -length_rate_m_s / wavelength_m
}

impl Space {
    /// Follow one path from `ray` (see [`PathPolicy`]); `index` selects the random stream.
    pub fn trace_path(&self, ray: &Ray, policy: &PathPolicy, index: u64) -> Path {
        let mut path = Path::default();
        self.trace_path_into(ray, policy, index, &mut path);
        path
    }

    /// [`Space::trace_path`] into an existing path (its vertex buffer is reused).
    pub fn trace_path_into(&self, ray: &Ray, policy: &PathPolicy, index: u64, path: &mut Path) {
        path.origin = ray.origin;
        path.vertices.clear();
        path.escape = None;
        let max_bounces = self.effects.path_interactions(policy.max_bounces);
        let p_diffuse = if self.effects.diffuse_bounces {
            policy.diffuse_probability
        } else {
            0.0
        };
        let mut rng = Pcg32::new(policy.seed, index);
        let mut r = *ray;
        let mut arrival = Segment::Primary;
        let mut previous = ray.origin;
        let mut length = 0.0;
        for bounce in 0..max_bounces {
            let Some(hit) = self.closest_hit(&r) else {
                path.escape = Some(r.direction);
                return;
            };
            length += (hit.point - previous).length();
            previous = hit.point;
            path.vertices.push(PathVertex {
                hit,
                arrival,
                path_length_m: length,
            });
            if bounce + 1 == max_bounces {
                return;
            }
            let n = hit.facing_normal();
            let (direction, kind) = if p_diffuse > 0.0 && rng.next_f64() < p_diffuse {
                (
                    cosine_hemisphere(n, rng.next_f64(), rng.next_f64()),
                    Segment::Diffuse,
                )
            } else {
                (
                    r.direction - 2.0 * r.direction.dot(n) * n,
                    Segment::Specular,
                )
            };
            let eps = surface_epsilon(hit.point, hit.distance_m);
            r = Ray {
                origin: hit.point + n * eps,
                direction: direction.normalize(),
                t_min: 0.0,
                t_max: policy.segment_t_max,
                time_s: r.time_s,
            };
            arrival = kind;
        }
    }

    /// [`Space::trace_path`] for every ray in parallel; path `i` uses random stream `i`.
    pub fn trace_paths(&self, rays: &[Ray], policy: &PathPolicy) -> Vec<Path> {
        rays.par_iter()
            .enumerate()
            .map(|(i, r)| self.trace_path(r, policy, i as u64))
            .collect()
    }
}

/// A cosine-weighted direction on the hemisphere around unit `n` (Malley's method) from two uniform
/// numbers in [0, 1).
pub(crate) fn cosine_hemisphere(n: DVec3, u1: f64, u2: f64) -> DVec3 {
    let r = u1.sqrt();
    let phi = std::f64::consts::TAU * u2;
    let (t, b) = orthonormal_basis(n);
    (t * (r * phi.cos()) + b * (r * phi.sin()) + n * (1.0 - u1).max(0.0).sqrt()).normalize()
}

/// Two unit vectors completing unit `n` to a right-handed orthonormal basis (Duff et al. 2017).
fn orthonormal_basis(n: DVec3) -> (DVec3, DVec3) {
    let sign = 1f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        DVec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// PCG32 (O'Neill 2014, XSH-RR): small, fast, statistically good, one stream per path.
#[derive(Debug, Clone)]
pub(crate) struct Pcg32 {
    state: u64,
    inc: u64,
}

impl Pcg32 {
    const MUL: u64 = 6364136223846793005;

    pub(crate) fn new(seed: u64, stream: u64) -> Pcg32 {
        let mut rng = Pcg32 {
            state: 0,
            inc: (stream << 1) | 1,
        };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(seed);
        rng.next_u32();
        rng
    }

    pub(crate) fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(Self::MUL).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        xorshifted.rotate_right((old >> 59) as u32)
    }

    /// Uniform in [0, 1) with 53 random bits.
    pub(crate) fn next_f64(&mut self) -> f64 {
        let hi = u64::from(self.next_u32()) << 21;
        let lo = u64::from(self.next_u32()) >> 11;
        ((hi | lo) as f64) * (1.0 / (1u64 << 53) as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pcg_is_uniform_and_deterministic() {
        let mut a = Pcg32::new(42, 7);
        let mut b = Pcg32::new(42, 7);
        let mut c = Pcg32::new(42, 8);
        let xs: Vec<f64> = (0..10_000).map(|_| a.next_f64()).collect();
        assert!(xs.iter().all(|&x| (0.0..1.0).contains(&x)));
        assert!((0..100).all(|i| b.next_f64() == xs[i]));
        assert!((0..100).any(|i| c.next_f64() != xs[i]));
        let mean = xs.iter().sum::<f64>() / xs.len() as f64;
        assert!((mean - 0.5).abs() < 0.01, "mean {mean}");
    }

    #[test]
    fn cosine_hemisphere_has_mean_cosine_two_thirds() {
        // E[cos θ] under p = cos θ / π is 2/3.
        let n = DVec3::new(0.3, -0.5, 0.8).normalize();
        let mut rng = Pcg32::new(1, 0);
        let k = 20_000;
        let mut sum = 0.0;
        for _ in 0..k {
            let d = cosine_hemisphere(n, rng.next_f64(), rng.next_f64());
            assert!((d.length() - 1.0).abs() < 1e-12);
            let c = d.dot(n);
            assert!(c >= 0.0);
            sum += c;
        }
        assert!((sum / k as f64 - 2.0 / 3.0).abs() < 0.01);
        let (t, b) = orthonormal_basis(n);
        assert!(t.dot(n).abs() < 1e-12 && b.dot(n).abs() < 1e-12 && t.dot(b).abs() < 1e-12);
        assert!((t.cross(b) - n).length() < 1e-12);
    }

    #[test]
    fn polyline_rate_matches_finite_difference() {
        let p = [
            DVec3::ZERO,
            DVec3::new(10.0, 2.0, 0.5),
            DVec3::new(3.0, 8.0, 1.0),
            DVec3::new(0.0, 0.0, 0.2),
        ];
        let v = [
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(-3.0, 1.0, 0.0),
            DVec3::new(0.0, 2.0, -1.0),
            DVec3::ZERO,
        ];
        let len = |dt: f64| {
            let q: Vec<DVec3> = p.iter().zip(&v).map(|(p, v)| *p + *v * dt).collect();
            q.windows(2).map(|w| (w[1] - w[0]).length()).sum::<f64>()
        };
        let h = 1e-6;
        let fd = (len(h) - len(-h)) / (2.0 * h);
        assert!((path_length_rate(&p, &v) - fd).abs() < 1e-6);
    }
}
