//! Four-ray packets for coherent rays (LiDAR columns, camera tiles).
//!
//! Four rays with (nearly) the same origin and direction traverse the BVH2 together (Wald et al.
//! 2001, "Interactive rendering with coherent ray tracing"): each node box and each triangle is tested
//! against all four rays at once in structure-of-arrays form (glam `Vec4`, one SIMD lane per ray), and
//! a node is entered when any ray reaches it. The per-lane arithmetic is the single-ray arithmetic,
//! operation for operation, so a ray finds the same surface whether traced alone or in a packet.

use glam::{Affine3A, BVec4A, Vec4};
use obvhs::bvh2::node::Bvh2Node;
use obvhs::ray::Ray;
use obvhs::rt_triangle::RtTriangle;

use super::traverse::{FAR_SCALE, STACK};

/// Four rays, structure of arrays: component `k` of ray `i` is `o[k][i]`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Packet {
    pub(crate) o: [Vec4; 3],
    pub(crate) d: [Vec4; 3],
    pub(crate) inv: [Vec4; 3],
    pub(crate) tmin: Vec4,
    pub(crate) tmax: Vec4,
}

/// obvhs's `safe_inverse` on four lanes: `1/x`, or `±1/ε` where `|x| ≤ ε`.
#[inline(always)]
fn safe_inverse(x: Vec4) -> Vec4 {
    let tiny = x.abs().cmple(Vec4::splat(f32::EPSILON));
    let big = Vec4::splat(1.0 / f32::EPSILON).copysign(x);
    Vec4::select(tiny, big, Vec4::ONE / x)
}

impl Packet {
    /// The packet of four obvhs rays.
    #[inline(always)]
    pub(crate) fn new(r: &[Ray; 4]) -> Packet {
        let v = |f: fn(&Ray) -> f32| Vec4::new(f(&r[0]), f(&r[1]), f(&r[2]), f(&r[3]));
        Packet {
            o: [v(|r| r.origin.x), v(|r| r.origin.y), v(|r| r.origin.z)],
            d: [
                v(|r| r.direction.x),
                v(|r| r.direction.y),
                v(|r| r.direction.z),
            ],
            inv: [
                v(|r| r.inv_direction.x),
                v(|r| r.inv_direction.y),
                v(|r| r.inv_direction.z),
            ],
            tmin: v(|r| r.tmin),
            tmax: v(|r| r.tmax),
        }
    }

    /// Lane `l` as a single ray.
    #[inline(always)]
    pub(crate) fn lane(&self, l: usize) -> Ray {
        let v = |a: &[Vec4; 3]| glam::Vec3A::new(a[0][l], a[1][l], a[2][l]);
        Ray {
            origin: v(&self.o),
            direction: v(&self.d),
            inv_direction: v(&self.inv),
            tmin: self.tmin[l],
            tmax: self.tmax[l],
        }
    }

    /// The packet in another frame (rigid `m`: distances unchanged). Directions get `+0.0` like
    /// single rays (no −0.0 components).
    #[inline(always)]
    pub(crate) fn transformed(&self, m: &Affine3A) -> Packet {
        let (a, b, c, t) = (
            m.matrix3.x_axis,
            m.matrix3.y_axis,
            m.matrix3.z_axis,
            m.translation,
        );
        let s = Vec4::splat;
        let [ox, oy, oz] = self.o;
        let [dx, dy, dz] = self.d;
        // Same operation order as `Affine3A::transform_point3a` / `transform_vector3a` per lane.
        let o = [
            ox * s(a.x) + oy * s(b.x) + oz * s(c.x) + s(t.x),
            ox * s(a.y) + oy * s(b.y) + oz * s(c.y) + s(t.y),
            ox * s(a.z) + oy * s(b.z) + oz * s(c.z) + s(t.z),
        ];
        let d = [
            dx * s(a.x) + dy * s(b.x) + dz * s(c.x) + Vec4::ZERO,
            dx * s(a.y) + dy * s(b.y) + dz * s(c.y) + Vec4::ZERO,
            dx * s(a.z) + dy * s(b.z) + dz * s(c.z) + Vec4::ZERO,
        ];
        Packet {
            o,
            d,
            inv: [safe_inverse(d[0]), safe_inverse(d[1]), safe_inverse(d[2])],
            tmin: self.tmin,
            tmax: self.tmax,
        }
    }
}

/// Entry distances of the four rays into the node's box (∞ for lanes that miss) and the hit mask.
#[inline(always)]
fn slab4(node: &Bvh2Node, p: &Packet) -> (Vec4, u32) {
    let b = node.aabb();
    let (lo, hi) = (b.min, b.max);
    let s = Vec4::splat;
    let (x0, x1) = ((s(lo.x) - p.o[0]) * p.inv[0], (s(hi.x) - p.o[0]) * p.inv[0]);
    let (y0, y1) = ((s(lo.y) - p.o[1]) * p.inv[1], (s(hi.y) - p.o[1]) * p.inv[1]);
    let (z0, z1) = ((s(lo.z) - p.o[2]) * p.inv[2], (s(hi.z) - p.o[2]) * p.inv[2]);
    let near = x0.min(x1).max(y0.min(y1)).max(z0.min(z1)).max(p.tmin);
    let far = x0.max(x1).min(y0.max(y1)).min(z0.max(z1)) * FAR_SCALE;
    let hit = near.cmple(far.min(p.tmax));
    (Vec4::select(hit, near, Vec4::INFINITY), hit.bitmask())
}

/// Möller–Trumbore on four rays; the same arithmetic as the single-ray `intersect`, per lane.
/// Distances of the lanes that hit within `[tmin, tmax)`, else ∞.
#[inline(always)]
pub(crate) fn intersect4(tri: &RtTriangle, p: &Packet) -> Vec4 {
    let s = Vec4::splat;
    let (c0, c1, c2) = (
        s(tri.v0.x) - p.o[0],
        s(tri.v0.y) - p.o[1],
        s(tri.v0.z) - p.o[2],
    );
    let (d0, d1, d2) = (p.d[0], p.d[1], p.d[2]);
    // r = d × c
    let (r0, r1, r2) = (d1 * c2 - d2 * c1, d2 * c0 - d0 * c2, d0 * c1 - d1 * c0);
    let (n, e1, e2) = (tri.ng, tri.e1, tri.e2);
    let inv_det = Vec4::ONE / (d0 * s(n.x) + d1 * s(n.y) + d2 * s(n.z));
    let u = (r0 * s(e2.x) + r1 * s(e2.y) + r2 * s(e2.z)) * inv_det;
    let v = (r0 * s(e1.x) + r1 * s(e1.y) + r2 * s(e1.z)) * inv_det;
    let t = (c0 * s(n.x) + c1 * s(n.y) + c2 * s(n.z)) * inv_det;
    let zero = Vec4::ZERO;
    let ok: BVec4A = u.cmpge(zero)
        & v.cmpge(zero)
        & (u + v).cmple(Vec4::ONE)
        & t.cmpge(p.tmin)
        & t.cmplt(p.tmax);
    Vec4::select(ok, t, Vec4::INFINITY)
}

/// Visit the leaves any of the four rays reaches. `leaf(first, count, packet)` handles primitives
/// `first .. first + count` for all lanes, may lower lanes of `packet.tmax` (a lane with
/// `tmax < tmin` is finished) and returns `false` to stop. The tree's depth must be below [`STACK`].
#[inline(always)]
pub(crate) fn traverse4<F>(nodes: &[Bvh2Node], p: &mut Packet, mut leaf: F)
where
    F: FnMut(u32, u32, &mut Packet) -> bool,
{
    let Some(root) = nodes.first() else { return };
    if slab4(root, p).1 == 0 {
        return;
    }
    // Deferred nodes with the smallest entry distance of their lanes.
    let mut stack = [(0u32, 0f32); STACK];
    let mut top = 0;
    let mut node = root;
    loop {
        if node.prim_count > 0 {
            if !leaf(node.first_index, node.prim_count, p) {
                return;
            }
        } else {
            let i = node.first_index as usize;
            let (a, b) = (&nodes[i], &nodes[i + 1]);
            let (na, ma) = slab4(a, p);
            let (nb, mb) = slab4(b, p);
            match (ma != 0, mb != 0) {
                (true, true) => {
                    let (da, db) = (na.min_element(), nb.min_element());
                    if da <= db {
                        stack[top] = (i as u32 + 1, db);
                        node = a;
                    } else {
                        stack[top] = (i as u32, da);
                        node = b;
                    }
                    top += 1;
                    continue;
                }
                (true, false) => {
                    node = a;
                    continue;
                }
                (false, true) => {
                    node = b;
                    continue;
                }
                (false, false) => {}
            }
        }
        // Pop the next deferred node some lane can still reach before its closest hit.
        let reach = p.tmax.max_element();
        loop {
            if top == 0 {
                return;
            }
            top -= 1;
            let (i, t) = stack[top];
            if t <= reach {
                node = &nodes[i as usize];
                break;
            }
        }
    }
}
