//! Ray queries: closest hit, any hit, batches, transmission.

use glam::{DVec3, Vec3A};
use obvhs::bvh2::Bvh2;
use obvhs::ray::RayHit;

use super::accel::{Instance, Space};
#[cfg(target_arch = "x86_64")]
use super::packet::Avx8;
use super::packet::{self, Lanes, Packet};
use super::traverse::traverse;
use super::{Hit, Ray};
use crate::environment::material::MaterialId;
use glam::Vec4;

/// Instance index of a static-world hit.
const STATIC: u32 = u32::MAX;

/// A hit before its attributes are looked up: f32 distance, instance (`STATIC` for the world) and
/// the BVH-order triangle index in that instance's BLAS.
#[derive(Debug, Clone, Copy)]
pub(crate) struct RawHit {
    pub(crate) t: f32,
    pub(crate) instance: u32,
    pub(crate) prim: u32,
}

/// How much of the power reaching a surface passes through it (0 opaque … 1 invisible).
/// Implemented for any `Fn(MaterialId) -> f64` (the materials database's transmittance per
/// material); implement it on a type to use the incidence angle (Fresnel).
pub trait TransmissionModel: Sync {
    /// Transmittance of the surface at `hit` for a ray travelling along `direction`.
    fn transmittance(&self, hit: &Hit, direction: DVec3) -> f64;
}

impl<F: Fn(MaterialId) -> f64 + Sync> TransmissionModel for F {
    fn transmittance(&self, hit: &Hit, _direction: DVec3) -> f64 {
        self(hit.material)
    }
}

/// Result of [`Space::closest_hit_through`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transmitted {
    /// The first surface that stopped the ray (opaque, or the one after `max_crossings`); `None` if
    /// the ray left the scene.
    pub hit: Option<Hit>,
    /// Product of the transmittances of the crossed surfaces, `T = Π τ_i`.
    pub transmittance: f64,
    /// Number of transmissive surfaces crossed.
    pub crossed: u32,
}

/// Offset (m) that separates a new ray from the surface it leaves, above the f32 rounding of
/// scene coordinates of magnitude `scale` (≈ 1 mm at 1 km, 20 µm near the origin).
pub(crate) fn surface_epsilon(p: DVec3, scale: f64) -> f64 {
    1e-5 + 8.0 * f64::from(f32::EPSILON) * (p.abs().max_element() + scale)
}

/// Whether rays are worth tracing as a packet: a common origin (within 1 mm) and directions
/// within ≈ 8° of the first one (a LiDAR column, a camera row).
#[inline(always)]
fn coherent(rays: &[Ray]) -> bool {
    let (o, d) = (rays[0].origin, rays[0].direction);
    rays[1..]
        .iter()
        .all(|r| (r.origin - o).abs().max_element() <= 1e-3 && r.direction.dot(d) >= 0.99)
}

/// Whether occlusion rays are worth tracing as a packet: [`coherent`], or (nearly) parallel
/// rays from nearby points (shadow rays towards the sun from neighbouring pixels' surface points:
/// origins within 0.5 m, directions within ≈ 8°).
#[inline(always)]
fn coherent_occlusion(rays: &[Ray]) -> bool {
    let (o, d) = (rays[0].origin, rays[0].direction);
    rays[1..]
        .iter()
        .all(|r| (r.origin - o).abs().max_element() <= 0.5 && r.direction.dot(d) >= 0.99)
}

/// The batch queries' one packing loop, over rays `0..out.len()` in order: `eight(j, &mut out[j..j +
/// 8])` where `fits(j, 8)` (AVX paths only), else `four(j, …)` where `fits(j, 4)`, else `one(j,
/// &mut out[j])`. `fits(j, n)` is only asked with `j + n ≤ out.len()`. The queries' `body`s inline
/// it into their AVX2 paths, so the closures must inline too.
#[inline(always)]
fn in_packets<const AVX: bool, T>(
    out: &mut [T],
    fits: impl Fn(usize, usize) -> bool,
    eight: impl Fn(usize, &mut [T]),
    four: impl Fn(usize, &mut [T]),
    one: impl Fn(usize, &mut T),
) {
    let len = out.len();
    let mut j = 0;
    while j < len {
        let rest = len - j;
        if AVX && rest >= 8 && fits(j, 8) {
            eight(j, &mut out[j..j + 8]);
            j += 8;
        } else if rest >= 4 && fits(j, 4) {
            four(j, &mut out[j..j + 4]);
            j += 4;
        } else {
            one(j, &mut out[j]);
            j += 1;
        }
    }
}

/// The displacement times of a packet's rays under `top`, one lane each.
#[inline(always)]
fn lane_times<V: Lanes, const N: usize>(top: Top<'_>, rays: &[Ray; N]) -> V {
    if top.window.is_some() {
        V::from_fn(|l| top.dt(rays[l].time_s) as f32)
    } else {
        V::splat(0.0)
    }
}

/// An obvhs ray. Direction components of −0.0 are turned into +0.0 (`x + 0.0`): the CWBVH node test
/// picks slab sides from `direction < 0` but divides by the signed zero (1/−0 < 0), which would
/// miss every node along axis-parallel directions.
#[inline(always)]
fn obvhs_ray(origin: Vec3A, direction: Vec3A, t_min: f32, t_max: f32) -> obvhs::ray::Ray {
    obvhs::ray::Ray::new(origin, direction + Vec3A::ZERO, t_min, t_max)
}

#[inline(always)]
fn f32_ray(ray: &Ray) -> obvhs::ray::Ray {
    obvhs_ray(
        ray.origin.as_vec3a(),
        ray.direction.as_vec3a(),
        ray.t_min as f32,
        ray.t_max as f32,
    )
}

/// The ray in the instance's mesh frame; the instance displaced by `v·dt` first (`dt` in s, 0:
/// at its pose).
#[inline(always)]
fn mesh_ray(inst: &Instance, r: &obvhs::ray::Ray, dt: f32) -> obvhs::ray::Ray {
    let origin = if dt != 0.0 && inst.moving {
        r.origin - inst.velocity * dt
    } else {
        r.origin
    };
    let o = inst.scene_to_mesh.transform_point3a(origin);
    let d = inst.scene_to_mesh.transform_vector3a(r.direction);
    obvhs_ray(o, d, r.tmin, r.tmax)
}

/// [`mesh_ray`] for a packet: lane `l` displaced by `dt` lane `l` where `timed`.
#[inline(always)]
fn mesh_packet<V: Lanes>(inst: &Instance, p: &Packet<V>, timed: bool, dt: V) -> Packet<V> {
    if timed && inst.moving {
        p.shifted(inst.velocity, dt)
            .transformed(&inst.scene_to_mesh)
    } else {
        p.transformed(&inst.scene_to_mesh)
    }
}

/// The top level a query traverses: the space's own (instances at their poses) or a
/// [`super::Sweep`]'s (boxes swept over a time window; each ray sees the instances displaced by
/// `v·time` at its own time).
#[derive(Clone, Copy)]
pub(crate) struct Top<'a> {
    pub(crate) tlas: &'a Bvh2,
    /// The TLAS fits [`traverse`]'s stack.
    pub(crate) shallow: bool,
    /// The sweep's time window, s (ray times are clamped into it); `None`: ray times are ignored.
    pub(crate) window: Option<(f64, f64)>,
}

impl Top<'_> {
    /// The displacement time of a ray at `time_s`, s.
    #[inline(always)]
    pub(crate) fn dt(&self, time_s: f64) -> f64 {
        match self.window {
            // `max` first: a NaN time goes to the window's start.
            Some((lo, hi)) => time_s.max(lo).min(hi),
            None => 0.0,
        }
    }
}

impl Space {
    /// The space's own top level: instances at their poses.
    #[inline(always)]
    pub(crate) fn top(&self) -> Top<'_> {
        Top {
            tlas: &self.tlas,
            shallow: self.tlas_shallow,
            window: None,
        }
    }

    /// Closest surface on the ray (static world first, then the instances it could still hit),
    /// the instances displaced to time `dt` (s; see [`Top`]).
    #[inline(always)]
    pub(crate) fn closest_raw(
        &self,
        top: Top<'_>,
        ray: &obvhs::ray::Ray,
        dt: f32,
    ) -> Option<RawHit> {
        let mut r = *ray;
        let mut best = None;
        if let Some((t, prim)) = self.static_blas.closest(&r) {
            r.tmax = t;
            best = Some(RawHit {
                t,
                instance: STATIC,
                prim,
            });
        }
        if top.tlas.nodes.is_empty() {
            return best;
        }
        // Into the instance's mesh frame, then its BLAS; `t` is unchanged by the rigid transform.
        let blas_hit = |i: u32, tr: &obvhs::ray::Ray| {
            let inst = &self.instances[i as usize];
            self.meshes[inst.desc.mesh.0 as usize].closest(&mesh_ray(inst, tr, dt))
        };
        if top.shallow {
            traverse(&top.tlas.nodes, &mut r, |first, count, tr| {
                for p in first..first + count {
                    let i = top.tlas.primitive_indices[p as usize];
                    if let Some((t, prim)) = blas_hit(i, tr) {
                        tr.tmax = t;
                        best = Some(RawHit {
                            t,
                            instance: i,
                            prim,
                        });
                    }
                }
                true
            });
        } else {
            let mut found = (STATIC, 0);
            let mut hit_top = RayHit::none();
            let hit = top.tlas.ray_traverse(r, &mut hit_top, |tr, id| {
                let i = top.tlas.primitive_indices[id];
                match blas_hit(i, tr) {
                    Some((t, prim)) => {
                        found = (i, prim);
                        t
                    }
                    None => f32::INFINITY,
                }
            });
            if hit {
                best = Some(RawHit {
                    t: hit_top.t,
                    instance: found.0,
                    prim: found.1,
                });
            }
        }
        best
    }

    /// [`Space::closest_raw`] for a packet of `N` coherent rays (same results per ray), in lanes
    /// `V` (`V::N == N`); lane `l` at time `dt` lane `l`.
    #[inline(always)]
    pub(crate) fn closest_raw_packet<V: Lanes, const N: usize>(
        &self,
        top: Top<'_>,
        rays: &[obvhs::ray::Ray; N],
        dt: V,
    ) -> [Option<RawHit>; N] {
        debug_assert_eq!(V::N, N);
        if !top.shallow {
            return std::array::from_fn(|l| self.closest_raw(top, &rays[l], dt.lane(l)));
        }
        let mut p = Packet::<V>::new(rays);
        let none = V::splat(f32::from_bits(u32::MAX));
        let mut prim = none;
        let mut instance = [STATIC; N];
        self.static_blas.closest_packet(&mut p, &mut prim);
        if !top.tlas.nodes.is_empty() {
            let timed = top.window.is_some();
            packet::traverse(
                &top.tlas.nodes,
                &mut p,
                #[inline(always)]
                |first, count, p| {
                    for q in first..first + count {
                        let i = top.tlas.primitive_indices[q as usize];
                        let inst = &self.instances[i as usize];
                        let mut local = mesh_packet(inst, p, timed, dt);
                        let mut local_prim = none;
                        self.meshes[inst.desc.mesh.0 as usize]
                            .closest_packet(&mut local, &mut local_prim);
                        let better = local.tmax.lt(p.tmax);
                        let m = V::bitmask(better);
                        if m != 0 {
                            p.tmax = V::select(better, local.tmax, p.tmax);
                            prim = V::select(better, local_prim, prim);
                            for (l, slot) in instance.iter_mut().enumerate() {
                                if m & (1 << l) != 0 {
                                    *slot = i;
                                }
                            }
                        }
                    }
                    true
                },
            );
        }
        std::array::from_fn(|l| {
            let prim = prim.lane(l).to_bits();
            (prim != u32::MAX).then(|| RawHit {
                t: p.tmax.lane(l),
                instance: instance[l],
                prim,
            })
        })
    }

    /// Whether any surface lies on the ray (early exit on the first one found), the instances at
    /// time `dt`.
    #[inline(always)]
    pub(crate) fn occluded_raw(&self, top: Top<'_>, ray: &obvhs::ray::Ray, dt: f32) -> bool {
        if self.static_blas.occluded(ray) {
            return true;
        }
        if top.tlas.nodes.is_empty() {
            return false;
        }
        let blas_occluded = |i: u32, tr: &obvhs::ray::Ray| {
            let inst = &self.instances[i as usize];
            self.meshes[inst.desc.mesh.0 as usize].occluded(&mesh_ray(inst, tr, dt))
        };
        if top.shallow {
            let mut r = *ray;
            let mut hit = false;
            traverse(&top.tlas.nodes, &mut r, |first, count, tr| {
                hit = (first..first + count)
                    .any(|p| blas_occluded(top.tlas.primitive_indices[p as usize], tr));
                !hit
            });
            hit
        } else {
            !top.tlas.ray_traverse_miss(*ray, |tr, id| {
                if blas_occluded(top.tlas.primitive_indices[id], tr) {
                    f32::NEG_INFINITY
                } else {
                    f32::INFINITY
                }
            })
        }
    }

    /// [`Space::occluded_raw`] for a packet of `N` coherent rays, in lanes `V` (`V::N == N`);
    /// lane `l` at time `dt` lane `l`.
    #[inline(always)]
    pub(crate) fn occluded_raw_packet<V: Lanes, const N: usize>(
        &self,
        top: Top<'_>,
        rays: &[obvhs::ray::Ray; N],
        dt: V,
    ) -> [bool; N] {
        debug_assert_eq!(V::N, N);
        if !top.shallow {
            return std::array::from_fn(|l| self.occluded_raw(top, &rays[l], dt.lane(l)));
        }
        let all = (1u32 << N) - 1;
        let mut p = Packet::<V>::new(rays);
        let mut done = self.static_blas.occluded_packet(&mut p);
        if done != all && !top.tlas.nodes.is_empty() {
            let timed = top.window.is_some();
            packet::traverse(
                &top.tlas.nodes,
                &mut p,
                #[inline(always)]
                |first, count, p| {
                    for q in first..first + count {
                        let inst = &self.instances[top.tlas.primitive_indices[q as usize] as usize];
                        let mut local = mesh_packet(inst, p, timed, dt);
                        let hit =
                            self.meshes[inst.desc.mesh.0 as usize].occluded_packet(&mut local);
                        for l in 0..N {
                            if hit & (1 << l) != 0 {
                                p.tmax.set_lane(l, f32::NEG_INFINITY);
                            }
                        }
                        done |= hit;
                    }
                    done != all
                },
            );
        }
        std::array::from_fn(|l| done & (1 << l) != 0)
    }

    /// The full hit record: distance and point recomputed in f64 from the hit triangle's plane,
    /// normal, material, object and point velocity (an instance displaced to the ray's time under
    /// `top`).
    #[inline(always)]
    pub(crate) fn finish_hit(&self, top: Top<'_>, ray: &Ray, raw: RawHit) -> Hit {
        let inst = (raw.instance != STATIC).then(|| &self.instances[raw.instance as usize]);
        let blas = match inst {
            None => &self.static_blas,
            Some(i) => &self.meshes[i.desc.mesh.0 as usize],
        };
        let tri = &blas.tris[raw.prim as usize];
        // RtTriangle stores e1 = v0 − v1, e2 = v2 − v0: the outward normal is (v1 − v0) × (v2 − v0).
        let n_mesh = (-tri.e1.as_dvec3())
            .cross(tri.e2.as_dvec3())
            .normalize_or_zero();
        let v0_mesh = tri.v0.as_dvec3();
        // The instance's displacement at the ray's time, m.
        let shift = match inst {
            Some(i) if top.window.is_some() && i.moving => {
                i.desc.linear_velocity * top.dt(ray.time_s)
            }
            _ => DVec3::ZERO,
        };
        let (v0, n) = match inst {
            None => (v0_mesh, n_mesh),
            Some(i) => (
                i.desc.pose.transform_point(v0_mesh) + shift,
                i.desc.pose.rotation * n_mesh,
            ),
        };
        let cos = n.dot(ray.direction);
        let t32 = f64::from(raw.t);
        let t = if cos.abs() > 1e-9 {
            let t64 = n.dot(v0 - ray.origin) / cos;
            if (t64 - t32).abs() <= 1e-3 * (1.0 + t32) {
                t64
            } else {
                t32
            }
        } else {
            t32
        };
        let point = ray.at(t);
        let (material, part, triangle) = blas.attributes(raw.prim);
        Hit {
            distance_m: t,
            point,
            geometric_normal: n,
            front_face: cos < 0.0,
            material,
            part,
            object_id: inst.map(|i| i.desc.object_id),
            instance: inst.map(|_| raw.instance),
            triangle,
            // v + ω × (p − position), the position displaced with the instance.
            velocity_m_s: inst.map_or(DVec3::ZERO, |i| i.desc.point_velocity(point - shift)),
        }
    }
    /// The closest surface on the ray within `[t_min, t_max]`.
    #[inline]
    pub fn closest_hit(&self, ray: &Ray) -> Option<Hit> {
        self.at_poses().closest_hit(ray)
    }

    /// Whether any surface lies on the ray within `[t_min, t_max]` (occlusion, shadow rays; stops at the
    /// first surface found, so it is cheaper than [`Space::closest_hit`]).
    #[inline]
    pub fn any_hit(&self, ray: &Ray) -> bool {
        self.at_poses().any_hit(ray)
    }

    /// Closest hits of a run of rays through `top`, with the traversal compiled for AVX2 + FMA
    /// where the CPU has them (run-time detection; the workspace builds for baseline x86-64). Both
    /// paths perform the same IEEE operations (no FMA contraction), so results do not depend on
    /// the path.
    pub(crate) fn trace_chunk(&self, top: Top<'_>, rays: &[Ray], out: &mut [Option<Hit>]) {
        #[inline(always)]
        fn body<const AVX: bool>(
            space: &Space,
            top: Top<'_>,
            rays: &[Ray],
            out: &mut [Option<Hit>],
        ) {
            // Eight coherent rays as one packet (AVX), else four, else one by one.
            #[inline(always)]
            fn group<V: Lanes, const N: usize>(
                space: &Space,
                top: Top<'_>,
                rays: &[Ray],
                out: &mut [Option<Hit>],
            ) {
                let group: &[Ray; N] = rays.try_into().expect("a group of N rays");
                let raw = space.closest_raw_packet::<V, N>(
                    top,
                    &std::array::from_fn(|l| f32_ray(&group[l])),
                    lane_times(top, group),
                );
                for ((ray, raw), hit) in group.iter().zip(raw).zip(out) {
                    *hit = raw.map(|raw| space.finish_hit(top, ray, raw));
                }
            }
            in_packets::<AVX, _>(
                out,
                #[inline(always)]
                |j, n| coherent(&rays[j..j + n]),
                #[inline(always)]
                |j, o| {
                    #[cfg(target_arch = "x86_64")]
                    group::<Avx8, 8>(space, top, &rays[j..j + 8], o);
                },
                #[inline(always)]
                |j, o| group::<Vec4, 4>(space, top, &rays[j..j + 4], o),
                #[inline(always)]
                |j, o| {
                    let ray = &rays[j];
                    *o = space
                        .closest_raw(top, &f32_ray(ray), top.dt(ray.time_s) as f32)
                        .map(|raw| space.finish_hit(top, ray, raw))
                },
            );
        }
        #[cfg(target_arch = "x86_64")]
        {
            #[target_feature(enable = "avx2,fma")]
            fn avx2(space: &Space, top: Top<'_>, rays: &[Ray], out: &mut [Option<Hit>]) {
                body::<true>(space, top, rays, out)
            }
            if crate::cpu::avx2_fma() {
                // SAFETY: the CPU supports AVX2 and FMA (checked at run time just above).
                return unsafe { avx2(self, top, rays, out) };
            }
        }
        body::<false>(self, top, rays, out)
    }

    /// [`Space::trace_chunk`] for occlusion.
    pub(crate) fn occluded_chunk(&self, top: Top<'_>, rays: &[Ray], out: &mut [bool]) {
        #[inline(always)]
        fn body<const AVX: bool>(space: &Space, top: Top<'_>, rays: &[Ray], out: &mut [bool]) {
            // Eight coherent rays as one packet (AVX), else four, else one by one.
            #[inline(always)]
            fn group<V: Lanes, const N: usize>(
                space: &Space,
                top: Top<'_>,
                rays: &[Ray],
                out: &mut [bool],
            ) {
                let group: &[Ray; N] = rays.try_into().expect("a group of N rays");
                out.copy_from_slice(&space.occluded_raw_packet::<V, N>(
                    top,
                    &std::array::from_fn(|l| f32_ray(&group[l])),
                    lane_times(top, group),
                ));
            }
            in_packets::<AVX, _>(
                out,
                #[inline(always)]
                |j, n| coherent_occlusion(&rays[j..j + n]),
                #[inline(always)]
                |j, o| {
                    #[cfg(target_arch = "x86_64")]
                    group::<Avx8, 8>(space, top, &rays[j..j + 8], o);
                },
                #[inline(always)]
                |j, o| group::<Vec4, 4>(space, top, &rays[j..j + 4], o),
                #[inline(always)]
                |j, o| {
                    let ray = &rays[j];
                    *o = space.occluded_raw(top, &f32_ray(ray), top.dt(ray.time_s) as f32)
                },
            );
        }
        #[cfg(target_arch = "x86_64")]
        {
            #[target_feature(enable = "avx2,fma")]
            fn avx2(space: &Space, top: Top<'_>, rays: &[Ray], out: &mut [bool]) {
                body::<true>(space, top, rays, out)
            }
            if crate::cpu::avx2_fma() {
                // SAFETY: the CPU supports AVX2 and FMA (checked at run time just above).
                return unsafe { avx2(self, top, rays, out) };
            }
        }
        body::<false>(self, top, rays, out)
    }

    /// Whether the straight segment between two points (typically on surfaces) is free of surfaces,
    /// ignoring a small offset at both ends (20 µm near the origin, ≈ 1 mm at 1 km).
    pub fn segment_clear(&self, from: DVec3, to: DVec3) -> bool {
        let d = to - from;
        let len = d.length();
        if len == 0.0 {
            return true;
        }
        let eps = surface_epsilon(from.abs().max(to.abs()), len);
        if len <= 2.0 * eps {
            return true;
        }
        let ray = Ray {
            origin: from,
            direction: d / len,
            t_min: eps,
            t_max: len - eps,
            time_s: 0.0,
        };
        !self.any_hit(&ray)
    }

    /// [`Space::closest_hit`] for every ray, in parallel on the current rayon pool (`out[i]` for
    /// `rays[i]`, chunks of 512 rays per task). Runs of eight (where the CPU has AVX2) or four
    /// consecutive rays with a common origin and directions within ≈ 8° (LiDAR columns, camera rows)
    /// are traced as SIMD packets: issue coherent rays next to each other. Panics if the lengths differ.
    pub fn trace_batch(&self, rays: &[Ray], out: &mut [Option<Hit>]) {
        self.at_poses().trace_batch(rays, out)
    }

    /// [`Space::trace_batch`] into a new vector.
    pub fn closest_hits(&self, rays: &[Ray]) -> Vec<Option<Hit>> {
        let mut out = vec![None; rays.len()];
        self.trace_batch(rays, &mut out);
        out
    }

    /// [`Space::any_hit`] for every ray, in parallel (`out[i]` for `rays[i]`). Runs of four
    /// consecutive rays with directions within ≈ 8° and origins within 0.5 m (a LiDAR column, the
    /// sun shadow rays of neighbouring pixels) are traced as SIMD packets.
    pub fn occluded_batch(&self, rays: &[Ray], out: &mut [bool]) {
        self.at_poses().occluded_batch(rays, out)
    }

    /// The closest surface that stops the ray, passing through up to `max_crossings` transmissive
    /// surfaces (τ > 0 under `model`) and multiplying their transmittances. The ray is not bent (thin
    /// panes); `hit.distance_m` is measured from the ray origin. Without `space.transmission` every
    /// surface stops the ray (`transmittance` 1, `crossed` 0).
    pub fn closest_hit_through(
        &self,
        ray: &Ray,
        model: &dyn TransmissionModel,
        max_crossings: u32,
    ) -> Transmitted {
        let mut r = *ray;
        let mut transmittance = 1.0;
        let mut crossed = 0;
        loop {
            let Some(hit) = self.closest_hit(&r) else {
                return Transmitted {
                    hit: None,
                    transmittance,
                    crossed,
                };
            };
            if !self.effects.transmission || crossed >= max_crossings {
                return Transmitted {
                    hit: Some(hit),
                    transmittance,
                    crossed,
                };
            }
            let tau = model.transmittance(&hit, ray.direction).clamp(0.0, 1.0);
            if tau <= 0.0 {
                return Transmitted {
                    hit: Some(hit),
                    transmittance,
                    crossed,
                };
            }
            transmittance *= tau;
            crossed += 1;
            r.t_min = hit.distance_m + surface_epsilon(hit.point, hit.distance_m);
            if r.t_min >= r.t_max {
                return Transmitted {
                    hit: None,
                    transmittance,
                    crossed,
                };
            }
        }
    }

    /// Fraction of power that gets along the ray to `t_max` (visibility through glass): the product
    /// of the crossed surfaces' transmittances, 0 if an opaque surface (or more than `max_crossings`
    /// transmissive ones) is in the way. Without `space.transmission`: 0 or 1 ([`Space::any_hit`]).
    pub fn transmittance_along(
        &self,
        ray: &Ray,
        model: &dyn TransmissionModel,
        max_crossings: u32,
    ) -> f64 {
        if !self.effects.transmission {
            return if self.any_hit(ray) { 0.0 } else { 1.0 };
        }
        let t = self.closest_hit_through(ray, model, max_crossings);
        if t.hit.is_some() {
            0.0
        } else {
            t.transmittance
        }
    }
}
