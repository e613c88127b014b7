//! The two-level acceleration structure: BLAS per static world / unique mesh, TLAS over instances.

use std::time::{Duration, Instant};

use glam::{Affine3A, DMat3, DVec3, Mat3, Vec3, Vec3A};
use obvhs::{
    BvhBuildParams,
    aabb::Aabb,
    bvh2::{Bvh2, builder::build_bvh2_from_tris},
    cwbvh::{CwBvh, builder::build_cwbvh_from_tris},
    ploc::{PlocBuilder, PlocSearchDistance, SortPrecision},
    ray::RayHit,
    rt_triangle::RtTriangle,
    triangle::Triangle,
};
use rayon::prelude::*;

use super::SpaceEffects;
use super::packet::{self, Lanes, Packet};
use super::traverse;
use crate::environment::{material::MaterialId, mesh::Mesh};
use crate::frames::Pose;

/// Which obvhs BVH layout the bottom level uses (the top level is always a BVH2: it is small).
///
/// `osiris bench space` (≈1 M triangles, 500 instances, 2-core EPYC VM): BVH2 traces the coherent
/// LiDAR pattern ≈3× faster (it has the 8- and 4-ray packet paths, CWBVH traces single rays), CWBVH
/// traces incoherent random rays ≈1.4× faster (as in `physics.md` §5.3). Choose BVH2 for LiDAR and camera
/// primary rays, CWBVH for incoherent work (multi-bounce radar) if that dominates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BvhKind {
    /// obvhs `Bvh2`: binary, up to 8 triangles per leaf.
    #[default]
    Bvh2,
    /// obvhs `CwBvh`: compressed 8-wide BVH (Ylitie et al. 2017), up to 3 triangles per leaf.
    CwBvh,
}

/// Errors of scene construction.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SpaceError {
    #[error("mesh has {parts} parts but {materials} part materials were given")]
    PartMaterials { parts: usize, materials: usize },
    #[error("triangle {triangle} references part {part}, but the mesh has {parts} parts")]
    TrianglePart {
        triangle: usize,
        part: u16,
        parts: usize,
    },
    #[error("mesh has {triangles} triangles but {parts} triangle part indices")]
    TrianglePartCount { triangles: usize, parts: usize },
    #[error("too many static parts ({0}; at most 65536)")]
    TooManyParts(usize),
    #[error("instance {instance} references unknown mesh {mesh} ({meshes} meshes)")]
    UnknownMesh {
        instance: usize,
        mesh: u32,
        meshes: usize,
    },
    #[error("instance {instance} has a non-finite pose or velocity")]
    NonFinite { instance: usize },
    #[error("instance {instance}: the rotation is not orthonormal (poses must be rigid)")]
    NotRigid { instance: usize },
}

/// A unique object mesh added with [`SpaceBuilder::add_mesh`]; instances refer to it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct MeshHandle(pub u32);

/// Where a mesh passed to [`SpaceBuilder::add_static`] landed in the static world: its triangle `i`
/// is static triangle `first_triangle + i`, its part `j` static part `first_part + j` (the numbers
/// [`super::Hit::triangle`] and [`super::Hit::part`] report for static hits).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StaticRange {
    pub first_triangle: u32,
    pub first_part: u16,
}

/// One placed object: a mesh under a rigid pose, with its motion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InstanceDesc {
    /// Ground-truth object id reported in hits.
    pub object_id: u64,
    pub mesh: MeshHandle,
    /// Mesh frame → scene frame (`p_scene = position + rotation · p_mesh`; rigid, no scaling).
    pub pose: Pose,
    /// Velocity of the mesh-frame origin (`pose.position`), scene frame, m/s.
    pub linear_velocity: DVec3,
    /// Angular velocity, scene frame, rad/s; a point `p` moves with `v + ω × (p − position)`.
    pub angular_velocity: DVec3,
}

impl InstanceDesc {
    /// Velocity of the material point at scene position `p`.
    pub fn point_velocity(&self, p: DVec3) -> DVec3 {
        self.linear_velocity + self.angular_velocity.cross(p - self.pose.position)
    }
}

/// Build bookkeeping: how often each level was built, and how long it took.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct BuildStats {
    /// Builds of the static-world BLAS (1 after [`SpaceBuilder::build`]; never changed by updates).
    pub static_builds: u32,
    /// Builds of object-mesh BLASes (one per unique mesh; never changed by updates).
    pub mesh_builds: u32,
    /// Builds of the top level (one per [`Space::set_instances`]).
    pub tlas_builds: u32,
    /// Wall time of [`SpaceBuilder::build`] (static world + meshes), s.
    pub blas_build_s: f64,
    /// Wall time of the last top-level update (instance transforms + TLAS rebuild), s.
    pub last_tlas_update_s: f64,
}

// ------------------------------------------------------------------------------------------------
// Bottom level

pub(crate) enum Accel {
    Empty,
    /// `shallow`: the tree fits [`traverse::traverse`]'s stack (else obvhs's traversal is used).
    Bvh2 {
        bvh: Bvh2,
        shallow: bool,
    },
    Cw(CwBvh),
}

/// One bottom-level BVH with its triangles in BVH order.
pub(crate) struct Blas {
    accel: Accel,
    /// Triangles in BVH primitive order (reordered once after the build: no index indirection).
    pub(crate) tris: Vec<RtTriangle>,
    /// BVH order → source triangle index.
    source: Vec<u32>,
    /// Part of each source triangle.
    triangle_part: Vec<u16>,
    /// Material of each part.
    part_materials: Vec<MaterialId>,
    /// Bounds of all triangles (local frame).
    pub(crate) bounds: Aabb,
}

impl Blas {
    fn build(
        triangles: &[Triangle],
        triangle_part: Vec<u16>,
        part_materials: Vec<MaterialId>,
        kind: BvhKind,
        params: BvhBuildParams,
    ) -> Blas {
        let mut bounds = Aabb::empty();
        for t in triangles {
            bounds = bounds.union(&t.aabb());
        }
        let mut core_time = Duration::ZERO;
        let (accel, order) = if triangles.is_empty() {
            (Accel::Empty, Vec::new())
        } else {
            match kind {
                BvhKind::Bvh2 => {
                    let bvh = build_bvh2_from_tris(triangles, params, &mut core_time);
                    let order = bvh.primitive_indices.clone();
                    let shallow = traverse::depth(&bvh) < traverse::STACK;
                    (Accel::Bvh2 { bvh, shallow }, order)
                }
                BvhKind::CwBvh => {
                    let bvh = build_cwbvh_from_tris(triangles, params, &mut core_time);
                    let order = bvh.primitive_indices.clone();
                    (Accel::Cw(bvh), order)
                }
            }
        };
        let tris = order
            .iter()
            .map(|&i| RtTriangle::from(&triangles[i as usize]))
            .collect();
        Blas {
            accel,
            tris,
            source: order,
            triangle_part,
            part_materials,
            bounds,
        }
    }

    /// Closest triangle along `ray` with `t < ray.tmax`: (t, BVH-order triangle index).
    #[inline(always)]
    pub(crate) fn closest(&self, ray: &obvhs::ray::Ray) -> Option<(f32, u32)> {
        let tris = &self.tris;
        match &self.accel {
            Accel::Empty => None,
            Accel::Bvh2 { bvh, shallow: true } => {
                let mut r = *ray;
                let mut best = u32::MAX;
                traverse::traverse(&bvh.nodes, &mut r, |first, count, r| {
                    for p in first..first + count {
                        let t = intersect(&tris[p as usize], r);
                        if t < r.tmax {
                            r.tmax = t;
                            best = p;
                        }
                    }
                    true
                });
                (best != u32::MAX).then_some((r.tmax, best))
            }
            Accel::Bvh2 {
                bvh,
                shallow: false,
            } => {
                let mut hit = RayHit::none();
                let found = bvh.ray_traverse(*ray, &mut hit, |r, id| intersect(&tris[id], r));
                found.then_some((hit.t, hit.primitive_id))
            }
            Accel::Cw(bvh) => {
                let mut hit = RayHit::none();
                let found = bvh.ray_traverse(*ray, &mut hit, |r, id| intersect(&tris[id], r));
                found.then_some((hit.t, hit.primitive_id))
            }
        }
    }

    /// Closest triangles for a packet: lowers the lanes of `p.tmax` that hit and records their
    /// BVH-order triangle in `prim` (as f32 bit patterns: blends copy bits unchanged).
    #[inline(always)]
    pub(crate) fn closest_packet<V: Lanes>(&self, p: &mut Packet<V>, prim: &mut V) {
        match &self.accel {
            Accel::Empty => {}
            Accel::Bvh2 { bvh, shallow: true } => {
                let tris = &self.tris;
                packet::traverse(
                    &bvh.nodes,
                    p,
                    #[inline(always)]
                    |first, count, p| {
                        for q in first..first + count {
                            let t = packet::intersect(&tris[q as usize], p);
                            let better = t.lt(p.tmax);
                            p.tmax = V::select(better, t, p.tmax);
                            *prim = V::select(better, V::splat(f32::from_bits(q)), *prim);
                        }
                        true
                    },
                );
            }
            _ => {
                for l in 0..V::N {
                    if let Some((t, q)) = self.closest(&p.lane(l)) {
                        p.tmax.set_lane(l, t);
                        prim.set_lane(l, f32::from_bits(q));
                    }
                }
            }
        }
    }

    /// Occlusion for a packet: the lanes with a triangle within `[tmin, tmax)` get `tmax = −∞`
    /// (finished); returns their mask.
    #[inline(always)]
    pub(crate) fn occluded_packet<V: Lanes>(&self, p: &mut Packet<V>) -> u32 {
        let all = (1u32 << V::N) - 1;
        let mut done = 0;
        match &self.accel {
            Accel::Empty => {}
            Accel::Bvh2 { bvh, shallow: true } => {
                let tris = &self.tris;
                packet::traverse(
                    &bvh.nodes,
                    p,
                    #[inline(always)]
                    |first, count, p| {
                        for q in first..first + count {
                            let hit = packet::intersect(&tris[q as usize], p).lt(p.tmax);
                            p.tmax = V::select(hit, V::splat(f32::NEG_INFINITY), p.tmax);
                            done |= V::bitmask(hit);
                        }
                        done != all
                    },
                );
            }
            _ => {
                for l in 0..V::N {
                    if p.tmax.lane(l) >= p.tmin.lane(l) && self.occluded(&p.lane(l)) {
                        p.tmax.set_lane(l, f32::NEG_INFINITY);
                        done |= 1 << l;
                    }
                }
            }
        }
        done
    }

    /// Whether any triangle lies on `ray` within `[tmin, tmax)`.
    #[inline(always)]
    pub(crate) fn occluded(&self, ray: &obvhs::ray::Ray) -> bool {
        let tris = &self.tris;
        match &self.accel {
            Accel::Empty => false,
            Accel::Bvh2 { bvh, shallow: true } => {
                let mut r = *ray;
                let mut hit = false;
                traverse::traverse(&bvh.nodes, &mut r, |first, count, r| {
                    hit = (first..first + count).any(|p| intersect(&tris[p as usize], r) < r.tmax);
                    !hit
                });
                hit
            }
            Accel::Bvh2 {
                bvh,
                shallow: false,
            } => !bvh.ray_traverse_miss(*ray, |r, id| intersect(&tris[id], r)),
            Accel::Cw(bvh) => !bvh.ray_traverse_miss(*ray, |r, id| intersect(&tris[id], r)),
        }
    }

    /// Material, part and source index of BVH-order triangle `prim`.
    #[inline(always)]
    pub(crate) fn attributes(&self, prim: u32) -> (MaterialId, u16, u32) {
        let source = self.source[prim as usize];
        let part = self.triangle_part[source as usize];
        (self.part_materials[part as usize], part, source)
    }
}

/// Möller–Trumbore on obvhs's precomputed layout (`e1 = v0 − v1`, `e2 = v2 − v0`, `ng = e1 × e2`):
/// the distance `t ∈ [tmin, tmax)` or ∞. Unlike `RtTriangle::intersect` (which rejects barycentrics of
/// −0.0) both signs of zero count as inside, so a ray through a shared edge hits one of its triangles
/// whatever its direction.
#[inline(always)]
fn intersect(tri: &RtTriangle, ray: &obvhs::ray::Ray) -> f32 {
    let c = tri.v0 - ray.origin;
    let r = ray.direction.cross(c);
    let inv_det = 1.0 / tri.ng.dot(ray.direction);
    let u = r.dot(tri.e2) * inv_det;
    let v = r.dot(tri.e1) * inv_det;
    let t = tri.ng.dot(c) * inv_det;
    // Non-short-circuit `&`: one branch; NaN (parallel ray) fails every comparison.
    if (u >= 0.0) & (v >= 0.0) & (u + v <= 1.0) & (t >= ray.tmin) & (t < ray.tmax) {
        t
    } else {
        f32::INFINITY
    }
}

fn mesh_triangles(mesh: &Mesh, part_materials: &[MaterialId]) -> Result<Vec<Triangle>, SpaceError> {
    if part_materials.len() < mesh.parts.len() {
        return Err(SpaceError::PartMaterials {
            parts: mesh.parts.len(),
            materials: part_materials.len(),
        });
    }
    if mesh.triangle_part.len() != mesh.triangles.len() {
        return Err(SpaceError::TrianglePartCount {
            triangles: mesh.triangles.len(),
            parts: mesh.triangle_part.len(),
        });
    }
    if let Some((i, &p)) = mesh
        .triangle_part
        .iter()
        .enumerate()
        .find(|&(_, &p)| p as usize >= part_materials.len())
    {
        return Err(SpaceError::TrianglePart {
            triangle: i,
            part: p,
            parts: part_materials.len(),
        });
    }
    Ok((0..mesh.triangle_count())
        .map(|i| {
            let [a, b, c] = mesh.triangle(i);
            Triangle {
                v0: a.into(),
                v1: b.into(),
                v2: c.into(),
            }
        })
        .collect())
}

// ------------------------------------------------------------------------------------------------
// Builder

struct PendingMesh {
    triangles: Vec<Triangle>,
    triangle_part: Vec<u16>,
    part_materials: Vec<MaterialId>,
}

/// Collects the static world and the unique object meshes, then builds their BVHs once.
pub struct SpaceBuilder {
    kind: BvhKind,
    params: BvhBuildParams,
    origin: DVec3,
    static_world: PendingMesh,
    meshes: Vec<PendingMesh>,
}

impl Default for SpaceBuilder {
    fn default() -> Self {
        SpaceBuilder::new()
    }
}

impl SpaceBuilder {
    /// An empty scene; BVH2 bottom level built with obvhs `medium_build` and
    /// `search_depth_threshold: 1` (PLOC's wide search on all levels but the first: on the bench
    /// street 18 instead of 30 node visits per LiDAR ray, at the same build time).
    pub fn new() -> SpaceBuilder {
        SpaceBuilder {
            kind: BvhKind::default(),
            params: BvhBuildParams {
                search_depth_threshold: 1,
                ..BvhBuildParams::medium_build()
            },
            origin: DVec3::ZERO,
            static_world: PendingMesh {
                triangles: Vec::new(),
                triangle_part: Vec::new(),
                part_materials: Vec::new(),
            },
            meshes: Vec::new(),
        }
    }

    /// The bottom-level BVH layout.
    pub fn bvh_kind(mut self, kind: BvhKind) -> SpaceBuilder {
        self.kind = kind;
        self
    }

    /// The obvhs build parameters of the bottom level (default: see [`SpaceBuilder::new`]).
    pub fn build_params(mut self, params: BvhBuildParams) -> SpaceBuilder {
        self.params = params;
        self
    }

    /// The scene origin in the global frame (only recorded: every coordinate given to and returned by
    /// the space is relative to it).
    pub fn origin(mut self, origin_global: DVec3) -> SpaceBuilder {
        self.origin = origin_global;
        self
    }

    /// Add geometry to the static world (already in the scene frame). `part_materials[j]` is the
    /// material of `mesh.parts[j]`.
    pub fn add_static(
        &mut self,
        mesh: &Mesh,
        part_materials: &[MaterialId],
    ) -> Result<StaticRange, SpaceError> {
        let tris = mesh_triangles(mesh, part_materials)?;
        let s = &mut self.static_world;
        let first_part = s.part_materials.len();
        let parts = first_part + part_materials.len();
        if parts > usize::from(u16::MAX) + 1 {
            return Err(SpaceError::TooManyParts(parts));
        }
        let range = StaticRange {
            first_triangle: s.triangles.len() as u32,
            first_part: first_part as u16,
        };
        s.triangles.extend(tris);
        s.triangle_part
            .extend(mesh.triangle_part.iter().map(|&p| p + first_part as u16));
        s.part_materials.extend_from_slice(part_materials);
        Ok(range)
    }

    /// Add a unique object mesh (in its own frame); instances place it.
    pub fn add_mesh(
        &mut self,
        mesh: &Mesh,
        part_materials: &[MaterialId],
    ) -> Result<MeshHandle, SpaceError> {
        let triangles = mesh_triangles(mesh, part_materials)?;
        self.meshes.push(PendingMesh {
            triangles,
            triangle_part: mesh.triangle_part.clone(),
            part_materials: part_materials.to_vec(),
        });
        Ok(MeshHandle(self.meshes.len() as u32 - 1))
    }

    /// Meshes added so far.
    pub fn mesh_count(&self) -> u32 {
        self.meshes.len() as u32
    }

    /// Build the static-world BVH and one BVH per mesh (in parallel on the current rayon pool). The
    /// result has no instances until [`Space::set_instances`].
    pub fn build(self) -> Space {
        let start = Instant::now();
        let (kind, params) = (self.kind, self.params);
        let s = self.static_world;
        let (static_blas, meshes) = rayon::join(
            move || {
                Blas::build(
                    &s.triangles,
                    s.triangle_part,
                    s.part_materials,
                    kind,
                    params,
                )
            },
            move || {
                self.meshes
                    .into_par_iter()
                    .map(|m| {
                        Blas::build(
                            &m.triangles,
                            m.triangle_part,
                            m.part_materials,
                            kind,
                            params,
                        )
                    })
                    .collect::<Vec<_>>()
            },
        );
        let stats = BuildStats {
            static_builds: 1,
            mesh_builds: meshes.len() as u32,
            blas_build_s: start.elapsed().as_secs_f64(),
            ..BuildStats::default()
        };
        Space {
            kind,
            params,
            scene_revision: None,
            scene_mesh_base: 0,
            origin: self.origin,
            static_blas,
            meshes,
            instances: Vec::new(),
            tlas: Bvh2::default(),
            tlas_shallow: true,
            tlas_builder: PlocBuilder::new(),
            tlas_aabbs: Vec::new(),
            stats,
            effects: SpaceEffects::default(),
        }
    }
}

// ------------------------------------------------------------------------------------------------
// The space

/// An instance as traversal needs it.
pub(crate) struct Instance {
    pub(crate) desc: InstanceDesc,
    /// Scene → mesh frame, f32 (rigid: distances are preserved).
    pub(crate) scene_to_mesh: Affine3A,
    /// `desc.linear_velocity` in f32, m/s (a swept query displaces the instance by `v·dt`).
    pub(crate) velocity: Vec3A,
    /// The linear velocity is not zero.
    pub(crate) moving: bool,
}

/// The traceable scene: static world, object meshes and their instances. `Sync`: query from many
/// threads; [`Space::set_instances`] needs `&mut`.
pub struct Space {
    kind: BvhKind,
    params: BvhBuildParams,
    /// `Scene::static_revision` of the scene this space was built from ([`SpaceBuilder::build_scene`]).
    pub(crate) scene_revision: Option<u64>,
    /// Handle of the first scene mesh (meshes added to the builder before the scene come first).
    pub(crate) scene_mesh_base: u32,
    origin: DVec3,
    pub(crate) static_blas: Blas,
    pub(crate) meshes: Vec<Blas>,
    pub(crate) instances: Vec<Instance>,
    pub(crate) tlas: Bvh2,
    /// The TLAS fits [`traverse::traverse`]'s stack.
    pub(crate) tlas_shallow: bool,
    tlas_builder: PlocBuilder,
    tlas_aabbs: Vec<Aabb>,
    stats: BuildStats,
    /// The effect switches the queries apply.
    pub effects: SpaceEffects,
}

impl Space {
    /// Replace all instances (poses and velocities of this step) and rebuild the top level only.
    pub fn set_instances(&mut self, instances: &[InstanceDesc]) -> Result<(), SpaceError> {
        let start = Instant::now();
        for (i, d) in instances.iter().enumerate() {
            if d.mesh.0 as usize >= self.meshes.len() {
                return Err(SpaceError::UnknownMesh {
                    instance: i,
                    mesh: d.mesh.0,
                    meshes: self.meshes.len(),
                });
            }
            let finite = d.pose.position.is_finite()
                && d.pose.rotation.is_finite()
                && d.linear_velocity.is_finite()
                && d.angular_velocity.is_finite();
            if !finite {
                return Err(SpaceError::NonFinite { instance: i });
            }
            let r = d.pose.rotation;
            if !(r.transpose() * r).abs_diff_eq(DMat3::IDENTITY, 1e-6) || r.determinant() < 0.0 {
                return Err(SpaceError::NotRigid { instance: i });
            }
        }
        self.instances.clear();
        self.tlas_aabbs.clear();
        for d in instances {
            let blas = &self.meshes[d.mesh.0 as usize];
            self.tlas_aabbs.push(world_aabb(&blas.bounds, &d.pose));
            self.instances.push(Instance {
                desc: *d,
                scene_to_mesh: scene_to_mesh(&d.pose),
                velocity: d.linear_velocity.as_vec3a(),
                moving: d.linear_velocity != DVec3::ZERO,
            });
        }
        build_tlas(&mut self.tlas_builder, &mut self.tlas, &mut self.tlas_aabbs);
        self.tlas_shallow = traverse::depth(&self.tlas) < traverse::STACK;
        self.stats.tlas_builds += 1;
        self.stats.last_tlas_update_s = start.elapsed().as_secs_f64();
        Ok(())
    }

    /// Add a unique object mesh after the build (builds its BLAS only; the static world and the
    /// other meshes are untouched). Instances may use it from the next [`Space::set_instances`].
    pub fn add_mesh(
        &mut self,
        mesh: &Mesh,
        part_materials: &[MaterialId],
    ) -> Result<MeshHandle, SpaceError> {
        let start = Instant::now();
        let triangles = mesh_triangles(mesh, part_materials)?;
        let blas = Blas::build(
            &triangles,
            mesh.triangle_part.clone(),
            part_materials.to_vec(),
            self.kind,
            self.params,
        );
        self.meshes.push(blas);
        self.stats.mesh_builds += 1;
        self.stats.blas_build_s += start.elapsed().as_secs_f64();
        Ok(MeshHandle(self.meshes.len() as u32 - 1))
    }

    /// The instances of the last [`Space::set_instances`] call.
    pub fn instances(&self) -> impl ExactSizeIterator<Item = &InstanceDesc> {
        self.instances.iter().map(|i| &i.desc)
    }

    /// Build bookkeeping.
    pub fn stats(&self) -> BuildStats {
        self.stats
    }

    /// The bottom-level BVH layout.
    pub fn bvh_kind(&self) -> BvhKind {
        self.kind
    }

    /// The scene origin in the global frame.
    pub fn origin(&self) -> DVec3 {
        self.origin
    }

    /// Triangles of the static world.
    pub fn static_triangle_count(&self) -> usize {
        self.static_blas.tris.len()
    }

    /// Triangles of the unique object meshes (each counted once).
    pub fn mesh_triangle_count(&self) -> usize {
        self.meshes.iter().map(|m| m.tris.len()).sum()
    }

    /// Triangles in the scene as placed: static world + every instance's mesh.
    pub fn instanced_triangle_count(&self) -> usize {
        self.static_triangle_count()
            + self
                .instances
                .iter()
                .map(|i| self.meshes[i.desc.mesh.0 as usize].tris.len())
                .sum::<usize>()
    }

    /// Bounds of the static world and all instances (scene frame); `None` if empty.
    pub fn bounds(&self) -> Option<(DVec3, DVec3)> {
        let mut b = self.static_blas.bounds;
        for a in &self.tlas_aabbs {
            if a.min.x < 1e29 {
                b = b.union(a);
            }
        }
        b.valid().then(|| (b.min.as_dvec3(), b.max.as_dvec3()))
    }
}

/// Build a top level over instance boxes (`aabbs[i]`: instance `i`, scene frame).
///
/// Instances of empty meshes, and instances so far away that f32 cannot hold their box (beyond
/// ±1e7 m from the scene origin: garbage input), get distinct point boxes far outside any scene:
/// PLOC needs valid boxes, and identical boxes can trip its nearest-neighbour search. Rays never
/// reach them.
///
/// PLOC (medium search, one instance per leaf): ~0.15 ms for 500 boxes. Reinsertion passes did not
/// reduce traversal cost measurably on the bench street, so there are none.
pub(crate) fn build_tlas(builder: &mut PlocBuilder, tlas: &mut Bvh2, aabbs: &mut [Aabb]) {
    for (i, b) in aabbs.iter_mut().enumerate() {
        let usable = b.valid()
            && b.min.is_finite()
            && b.max.is_finite()
            && b.min.abs().max_element() < 1e7
            && b.max.abs().max_element() < 1e7;
        if !usable {
            let p = Vec3A::new(1e9 + 4096.0 * i as f32, 1e9, 1e9);
            *b = Aabb::new(p, p);
        }
    }
    if aabbs.is_empty() {
        *tlas = Bvh2::default();
    } else {
        let indices = (0..aabbs.len() as u32).collect();
        builder.build_with_bvh(
            tlas,
            PlocSearchDistance::Medium,
            aabbs,
            indices,
            SortPrecision::U64,
            0,
        );
    }
}

/// World box of instance `inst` (`local`: its mesh's box) over the displacements `v·dt` for `dt`
/// in `[lo, hi]` s (the union of the boxes at both ends, padded for the f32 shift).
pub(crate) fn swept_aabb(local: &Aabb, inst: &InstanceDesc, (lo, hi): (f64, f64)) -> Aabb {
    let b = world_aabb(local, &inst.pose);
    if !b.valid() || inst.linear_velocity == DVec3::ZERO {
        return b;
    }
    let (a, c) = (inst.linear_velocity * lo, inst.linear_velocity * hi);
    let pad = 1e-5 * (1.0 + a.abs().max(c.abs()).max_element());
    let min = (b.min.as_dvec3() + a.min(c) - DVec3::splat(pad)).as_vec3a();
    let max = (b.max.as_dvec3() + a.max(c) + DVec3::splat(pad)).as_vec3a();
    Aabb::new(min, max)
}

/// Scene → mesh transform `R^T (p − t)` as an f32 affine.
fn scene_to_mesh(pose: &Pose) -> Affine3A {
    let rt: DMat3 = pose.rotation.transpose();
    let t = -(rt * pose.position);
    Affine3A::from_mat3_translation(
        Mat3::from_cols(
            rt.x_axis.as_vec3(),
            rt.y_axis.as_vec3(),
            rt.z_axis.as_vec3(),
        ),
        t.as_vec3(),
    )
}

/// World box of a local box under a rigid pose (centre transformed, half extent through |R|), padded
/// for f32 rounding.
fn world_aabb(local: &Aabb, pose: &Pose) -> Aabb {
    if !local.valid() {
        return Aabb::empty();
    }
    let c = (local.min + local.max).as_dvec3() * 0.5;
    let h = (local.max - local.min).as_dvec3() * 0.5;
    let r = pose.rotation;
    let abs = DMat3::from_cols(r.x_axis.abs(), r.y_axis.abs(), r.z_axis.abs());
    let wc = pose.transform_point(c);
    let wh = abs * h;
    let pad = 1e-5 * (1.0 + wc.abs().max_element() + wh.max_element());
    let lo: Vec3 = (wc - wh - DVec3::splat(pad)).as_vec3();
    let hi: Vec3 = (wc + wh + DVec3::splat(pad)).as_vec3();
    Aabb::new(lo.into(), hi.into())
}
