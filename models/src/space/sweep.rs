//! Instances in motion: rays at their own times (rolling shutter, motion blur).
//!
//! A [`Sweep`] is a second top level over the instances of a [`Space`], each box swept over a time
//! window by the instance's linear velocity (Embree's linear motion blur; PBRT 4th ed. §2.6 for
//! the ray time). Through it ([`Swept`]) a ray at time `Ray::time_s` meets every moving instance
//! where it is at that time, `pose.position + v·time_s`, while the static world stays where it is:
//! the ray is traced in the instance's frame from the origin shifted by `−v·time_s`, the same
//! relative geometry. Translation only: the rotation over the window (`ω·dt`) is neglected,
//! as in [`super::InstanceDesc::point_velocity`]'s first-order motion.
//!
//! The space's own queries ([`Space::trace_batch`] …) ignore ray times; the sweep costs one extra
//! top-level build (well under a millisecond for a few hundred instances) per window.

use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;
use obvhs::ploc::PlocBuilder;
use rayon::prelude::*;

use super::accel::{Space, build_tlas, swept_aabb};
use super::query::Top;
use super::traverse;
use super::{Hit, Ray};

/// Rays per rayon task in the batch queries (large enough to amortise scheduling, small enough to
/// balance 2–16 threads on a LiDAR frame; consecutive rays stay on one thread, keeping coherence).
const CHUNK: usize = 512;

/// The swept top level of a space's instances (see the module documentation). Plan once, update
/// per window: [`Sweep::update`] rebuilds it for the space's current instances and returns the
/// view to query.
#[derive(Default)]
pub struct Sweep {
    tlas: Bvh2,
    shallow: bool,
    aabbs: Vec<Aabb>,
    builder: PlocBuilder,
}

impl Sweep {
    /// An empty sweep (nothing built yet).
    pub fn new() -> Sweep {
        Sweep::default()
    }

    /// Sweep `space`'s current instances over times `window_s` (s relative to their poses; the
    /// ends in either order, non-finite ends read as 0) and return the view that traces rays at
    /// their times. Ray times outside the window are clamped into it. When no instance moves, or
    /// the window is a single instant, the view uses the space's own top level.
    pub fn update<'a>(&'a mut self, space: &'a Space, window_s: (f64, f64)) -> Swept<'a> {
        let finite = |t: f64| if t.is_finite() { t } else { 0.0 };
        let (a, b) = (finite(window_s.0), finite(window_s.1));
        let window = (a.min(b), a.max(b));
        let moving = space.instances.iter().any(|i| i.moving);
        if !moving || window.0 == window.1 && window.0 == 0.0 {
            return space.at_poses();
        }
        self.aabbs.clear();
        self.aabbs.extend(space.instances.iter().map(|i| {
            swept_aabb(
                &space.meshes[i.desc.mesh.0 as usize].bounds,
                &i.desc,
                window,
            )
        }));
        build_tlas(&mut self.builder, &mut self.tlas, &mut self.aabbs);
        self.shallow = traverse::depth(&self.tlas) < traverse::STACK;
        Swept {
            space,
            top: Top {
                tlas: &self.tlas,
                shallow: self.shallow,
                window: Some(window),
            },
        }
    }
}

/// A [`Space`] whose queries see each moving instance at the ray's time ([`Ray::time_s`], within
/// the window of the [`Sweep`] that made it). Same queries, packets and results per ray as the
/// space's own, which it equals for rays at time 0 (the space's own queries are this view over
/// its own top level, [`Space::at_poses`]).
#[derive(Clone, Copy)]
pub struct Swept<'a> {
    space: &'a Space,
    top: Top<'a>,
}

impl Space {
    /// The space with its instances at their poses (its own top level; ray times ignored).
    pub(crate) fn at_poses(&self) -> Swept<'_> {
        Swept {
            space: self,
            top: self.top(),
        }
    }
}

impl Swept<'_> {
    /// The space (static world, meshes, effect switches).
    pub fn space(&self) -> &Space {
        self.space
    }

    /// [`Space::closest_hit`] at the ray's time.
    pub fn closest_hit(&self, ray: &Ray) -> Option<Hit> {
        let mut out = [None];
        self.space
            .trace_chunk(self.top, std::slice::from_ref(ray), &mut out);
        out[0]
    }

    /// [`Space::any_hit`] at the ray's time.
    pub fn any_hit(&self, ray: &Ray) -> bool {
        let mut out = [false];
        self.space
            .occluded_chunk(self.top, std::slice::from_ref(ray), &mut out);
        out[0]
    }

    /// [`Space::trace_batch`] (parallel, packets), each ray at its time. Panics if the lengths
    /// differ.
    pub fn trace_batch(&self, rays: &[Ray], out: &mut [Option<Hit>]) {
        assert_eq!(
            rays.len(),
            out.len(),
            "trace_batch: {} rays but {} outputs",
            rays.len(),
            out.len()
        );
        rays.par_chunks(CHUNK)
            .zip(out.par_chunks_mut(CHUNK))
            .for_each(|(rays, out)| self.space.trace_chunk(self.top, rays, out));
    }

    /// [`Space::occluded_batch`] (parallel, packets), each ray at its time. Panics if the lengths
    /// differ.
    pub fn occluded_batch(&self, rays: &[Ray], out: &mut [bool]) {
        assert_eq!(
            rays.len(),
            out.len(),
            "occluded_batch: {} rays but {} outputs",
            rays.len(),
            out.len()
        );
        rays.par_chunks(CHUNK)
            .zip(out.par_chunks_mut(CHUNK))
            .for_each(|(rays, out)| self.space.occluded_chunk(self.top, rays, out));
    }
}
