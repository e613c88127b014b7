//! Space design: ray-traced propagation through the scene, one ray-query API for all sensors.
//!
//! # Structure
//!
//! A two-level BVH (obvhs, see `docs/physics.md` §5):
//!
//! * one bottom-level BVH (BLAS) for the **static world** (road, markings, buildings), built once;
//! * one BLAS per **unique object mesh** (a car model is built once, however many cars use it);
//! * a top-level BVH (TLAS) over the world-space boxes of the **instances** (object id, mesh, pose,
//!   velocity), rebuilt by [`Space::set_instances`] every step. It holds only a few hundred boxes, so a
//!   rebuild costs well under a millisecond; the static world and the BLASes are never rebuilt per step
//!   ([`Space::stats`] counts the builds).
//!
//! Traversal: static BLAS first (its hit bounds the ray), then TLAS → ray transformed into the
//! instance's local frame (rigid f32 affine, so distances are unchanged) → BLAS.
//!
//! Rays at their own times (rolling shutter, motion blur) go through a [`Sweep`]: a second TLAS over
//! the instance boxes swept by their velocities over a time window, in which each moving instance
//! is met at `position + v·Ray::time_s` (`sweep.rs`).
//!
//! * BVH2 trees are traversed by this module's stack traversal (`traverse.rs`: `tmin`-aware, the
//!   stack keeps entry distances so nodes behind a closer hit are dropped unopened) over obvhs's
//!   nodes; CWBVH trees by obvhs.
//! * Batches group consecutive coherent rays (common origin, directions within ≈ 8°) into SIMD
//!   packets (`packet.rs`, Wald et al. 2001): eight rays per packet (one AVX register per component)
//!   where the CPU has AVX2 + FMA, else four (glam `Vec4`; also under `OSIRIS_SIMD=portable`, see
//!   [`crate::cpu`]); the rest of a batch goes in fours or one by one. One box or triangle test serves
//!   the whole packet. Each ray gets what it would get alone (same per-lane arithmetic).
//! * The batch loops are compiled twice, for baseline x86-64 and for AVX2 + FMA, and picked at run
//!   time (the workspace builds for baseline x86-64).
//! * Triangles are tested with Möller–Trumbore accepting both signs of zero barycentrics (no holes
//!   along shared edges for axis-parallel rays).
//!
//! # Frames and precision
//!
//! Everything in this module is in the **scene frame**: a local, right-handed metric frame whose
//! origin is the scene origin ([`SpaceBuilder::origin`], e.g. the ego position at scene creation,
//! given in the global frame), so that all coordinates stay within a few km of zero. Traversal is in
//! f32 (0.1 mm resolution at 1 km); the returned hit distance and point are recomputed in f64 from
//! the hit triangle's plane, so they are exact for the stored (f32) geometry.
//!
//! # Performance (`osiris bench space`, see [`mod@bench`])
//!
//! Street of 1.04 M triangles (326 k static, 450 cars + 50 pedestrians instanced). Targets: ≥ 8
//! Mrays/s for the coherent LiDAR pattern (128 × 1800, closest hit) on 2 threads, top-level update
//! < 5 ms for 500 moving objects. With the 8-ray AVX2 packets on a quiet 2-vCPU VM: BVH build
//! 0.13 s (2 threads) to 0.21 s (1), top-level update ≈ 0.12 ms, LiDAR pattern 9.0–9.4 Mrays/s on 1
//! thread and 16.6–17.2 on 2, random rays 1.6 / 3.2 Mrays/s; CWBVH is faster on random rays but far
//! slower on the coherent pattern, so BVH2 is the default. `docs/benchmarks.md` has the latest run
//! with its machine.
//!
//! # Queries
//!
//! * [`Space::closest_hit`] / [`Space::trace_batch`]: closest surface with distance, point,
//!   geometric normal, material, part, object id and the point's velocity `v + ω × r`;
//! * [`Space::any_hit`] / [`Space::occluded_batch`] / [`Space::segment_clear`]: occlusion (early exit);
//! * [`Space::closest_hit_through`] / [`Space::transmittance_along`]: transmission through glass
//!   ([`TransmissionModel`]);
//! * [`Space::trace_path`] / [`Space::trace_paths`]: multi-bounce paths (specular and sampled
//!   diffuse) with path length and Doppler ([`path`]).
//!
//! # Effects
//!
//! [`MULTIPATH`] (`space.multipath`), [`DIFFUSE_BOUNCES`] (`space.diffuse_bounces`),
//! [`TRANSMISSION`] (`space.transmission`); see [`SpaceEffects`].

mod accel;
pub mod bench;
mod geometry;
mod packet;
pub mod path;
mod query;
pub(crate) use query::surface_epsilon;
mod scene;
mod sweep;
mod traverse;

use glam::DVec3;

pub use accel::{
    BuildStats, BvhKind, InstanceDesc, MeshHandle, Space, SpaceBuilder, SpaceError, StaticRange,
};
pub use geometry::{cylinder, hexahedron, quad, subdivided_box};
pub use path::{Path, PathPolicy, PathVertex, Segment, doppler_shift_hz, path_length_rate};
pub use query::{TransmissionModel, Transmitted};
pub use sweep::{Sweep, Swept};

use crate::effects::{EffectInfo, Effects};
use crate::environment::material::MaterialId;

/// `space.multipath`: paths may bounce more than once (radar multipath, camera indirect light).
pub const MULTIPATH: EffectInfo = EffectInfo {
    name: "space.multipath",
    default_on: true,
    summary: "multi-bounce propagation paths: specular reflection r = d − 2(d·n)n at every surface up to \
              the policy's bounce count; off: only the first surface is found",
    source: "geometric optics; image method for plane mirrors",
    requires: None,
};

/// `space.diffuse_bounces`: bounces may be sampled diffusely (cosine-weighted hemisphere).
pub const DIFFUSE_BOUNCES: EffectInfo = EffectInfo {
    name: "space.diffuse_bounces",
    default_on: true,
    summary: "sampled diffuse bounces: with the policy's probability a bounce leaves in a cosine-weighted \
              direction p(ω) = cos θ / π instead of the mirror direction; off: all bounces specular",
    source: "Pharr, Jakob, Humphreys: PBRT 4th ed. §13.6 (Malley's method)",
    requires: Some("space.multipath"),
};

/// `space.transmission`: transmissive surfaces (glass) pass rays on, weighted by their transmittance.
pub const TRANSMISSION: EffectInfo = EffectInfo {
    name: "space.transmission",
    default_on: true,
    summary: "transmission through transmissive surfaces: the ray continues, T = Π τ_i over the crossed \
              surfaces (τ from the materials database); off: every surface is opaque",
    source: "Beer–Lambert / Fresnel transmittance per surface from the materials database",
    requires: None,
};

/// All effects of the space-design layer.
pub const EFFECTS: &[EffectInfo] = &[MULTIPATH, DIFFUSE_BOUNCES, TRANSMISSION];

/// The space-design switches a [`Space`] applies to its queries (from an [`Effects`] set).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SpaceEffects {
    pub multipath: bool,
    pub diffuse_bounces: bool,
    pub transmission: bool,
}

impl Default for SpaceEffects {
    fn default() -> Self {
        SpaceEffects {
            multipath: MULTIPATH.default_on,
            diffuse_bounces: DIFFUSE_BOUNCES.default_on,
            transmission: TRANSMISSION.default_on,
        }
    }
}

impl SpaceEffects {
    /// The switches from an effect set that declares [`EFFECTS`] (panics if it does not).
    pub fn from_effects(effects: &Effects) -> SpaceEffects {
        SpaceEffects {
            multipath: effects.is_on(&MULTIPATH),
            diffuse_bounces: effects.is_on(&DIFFUSE_BOUNCES),
            transmission: effects.is_on(&TRANSMISSION),
        }
    }

    /// Surface interactions a path may have when `configured` are asked for: all of them with
    /// `space.multipath`, else at most one (only the first surface is found).
    pub fn path_interactions(&self, configured: u32) -> u32 {
        if self.multipath {
            configured
        } else {
            configured.min(1)
        }
    }

    /// Sampled diffuse bounce rays per primary ray when `configured` are asked for: all of them with
    /// `space.multipath` and `space.diffuse_bounces`, else none (a bounce ray meets a second surface,
    /// which `space.multipath` off excludes; `space.diffuse_bounces` off excludes diffuse sampling).
    pub fn diffuse_bounce_rays(&self, configured: u32) -> u32 {
        if self.multipath && self.diffuse_bounces {
            configured
        } else {
            0
        }
    }
}

/// A ray in the scene frame: points `origin + t·direction` for `t ∈ [t_min, t_max]`.
/// `direction` must be a unit vector (so `t` is the distance in m); [`Ray::new`] normalises.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    pub origin: DVec3,
    pub direction: DVec3,
    pub t_min: f64,
    pub t_max: f64,
    /// When the ray travels, relative to the instances' poses, s (the ray time of PBRT 4th ed.
    /// §2.6). Only queries through a [`Sweep`] use it (each instance displaced by `v·time_s`);
    /// [`Space`]'s own queries see the instances at their poses.
    pub time_s: f64,
}

impl Ray {
    /// A ray from `origin` along `direction` (normalised here), `t ∈ [0, ∞)`.
    pub fn new(origin: DVec3, direction: DVec3) -> Ray {
        Ray {
            origin,
            direction: direction.normalize(),
            t_min: 0.0,
            t_max: f64::INFINITY,
            time_s: 0.0,
        }
    }

    /// The same ray at time `time_s` (see [`Ray::time_s`]).
    pub fn at_time(self, time_s: f64) -> Ray {
        Ray { time_s, ..self }
    }

    /// The same ray limited to `t ≤ t_max`.
    pub fn with_t_max(self, t_max: f64) -> Ray {
        Ray { t_max, ..self }
    }

    /// The same ray starting at `t ≥ t_min`.
    pub fn with_t_min(self, t_min: f64) -> Ray {
        Ray { t_min, ..self }
    }

    /// The point at distance `t`.
    pub fn at(&self, t: f64) -> DVec3 {
        self.origin + self.direction * t
    }
}

/// A ray-surface intersection, in the scene frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Distance from the ray origin along the (unit) direction, m.
    pub distance_m: f64,
    /// Hit point, m.
    pub point: DVec3,
    /// Unit geometric normal of the hit triangle, outward (`(b − a) × (c − a)` of its counter-clockwise
    /// corners), whichever side the ray came from; see `front_face` and [`Hit::facing_normal`].
    pub geometric_normal: DVec3,
    /// Whether the ray hit the outer side (`direction · geometric_normal < 0`).
    pub front_face: bool,
    /// Material of the hit part.
    pub material: MaterialId,
    /// Part index in the hit mesh (`Mesh::parts`).
    pub part: u16,
    /// Ground-truth id of the hit object; `None` for the static world.
    pub object_id: Option<u64>,
    /// Index of the hit instance in the last [`Space::set_instances`] call; `None` for the static world.
    pub instance: Option<u32>,
    /// Index of the hit triangle in its source mesh (for the static world: in the concatenation of the
    /// meshes passed to [`SpaceBuilder::add_static`], in call order).
    pub triangle: u32,
    /// Velocity of the material point hit, `v + ω × (p − position)`, m/s (zero for the static world).
    pub velocity_m_s: DVec3,
}

impl Hit {
    /// The geometric normal turned against the incoming ray (the side the ray is on).
    pub fn facing_normal(&self) -> DVec3 {
        if self.front_face {
            self.geometric_normal
        } else {
            -self.geometric_normal
        }
    }

    /// Cosine of the incidence angle (between the reversed ray and the facing normal), in [0, 1].
    pub fn cos_incidence(&self, direction: DVec3) -> f64 {
        (-direction.dot(self.facing_normal())).clamp(0.0, 1.0)
    }
}
