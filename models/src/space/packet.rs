//! Ray packets for coherent rays (LiDAR columns, camera rows, sun shadow rays).
//!
//! A packet of 4 or 8 rays with (nearly) the same origin and direction traverses the BVH2 together
//! (Wald et al. 2001, "Interactive rendering with coherent ray tracing"): each node box and each
//! triangle is tested against all rays at once in structure-of-arrays form (one SIMD lane per ray:
//! glam `Vec4` on SSE, or one AVX register for eight rays where the CPU has AVX2), and a node is
//! entered when any ray reaches it. The per-lane arithmetic is the single-ray arithmetic,
//! operation for operation, so a ray finds the same surface whether traced alone or in a packet.

use glam::{Affine3A, BVec4A, Vec4};
use obvhs::bvh2::node::Bvh2Node;
use obvhs::ray::Ray;
use obvhs::rt_triangle::RtTriangle;

use super::traverse::{FAR_SCALE, STACK};

/// One f32 per ray of a packet, with the SSE semantics glam uses (`min`/`max` as `minps`/`maxps`).
pub(crate) trait Lanes:
    Copy + std::ops::Sub<Output = Self> + std::ops::Mul<Output = Self>
{
    /// Lanes (rays) per packet.
    const N: usize;
    /// Per-lane comparison results.
    type Mask: Copy + std::ops::BitAnd<Output = Self::Mask>;
    fn splat(v: f32) -> Self;
    fn from_fn(f: impl FnMut(usize) -> f32) -> Self;
    fn lane(&self, i: usize) -> f32;
    fn set_lane(&mut self, i: usize, v: f32);
    fn div(self, rhs: Self) -> Self;
    fn add(self, rhs: Self) -> Self;
    fn min(self, rhs: Self) -> Self;
    fn max(self, rhs: Self) -> Self;
    fn abs(self) -> Self;
    fn copysign(self, sign: Self) -> Self;
    fn lt(self, rhs: Self) -> Self::Mask;
    fn le(self, rhs: Self) -> Self::Mask;
    fn ge(self, rhs: Self) -> Self::Mask;
    fn select(mask: Self::Mask, a: Self, b: Self) -> Self;
    /// Bit `i` set where lane `i` of the mask is.
    fn bitmask(mask: Self::Mask) -> u32;
    fn min_element(self) -> f32;
    fn max_element(self) -> f32;
}

impl Lanes for Vec4 {
    const N: usize = 4;
    type Mask = BVec4A;
    #[inline(always)]
    fn splat(v: f32) -> Self {
        Vec4::splat(v)
    }
    #[inline(always)]
    fn from_fn(mut f: impl FnMut(usize) -> f32) -> Self {
        Vec4::new(f(0), f(1), f(2), f(3))
    }
    #[inline(always)]
    fn lane(&self, i: usize) -> f32 {
        self[i]
    }
    #[inline(always)]
    fn set_lane(&mut self, i: usize, v: f32) {
        self[i] = v;
    }
    #[inline(always)]
    fn div(self, rhs: Self) -> Self {
        self / rhs
    }
    #[inline(always)]
    fn add(self, rhs: Self) -> Self {
        self + rhs
    }
    #[inline(always)]
    fn min(self, rhs: Self) -> Self {
        Vec4::min(self, rhs)
    }
    #[inline(always)]
    fn max(self, rhs: Self) -> Self {
        Vec4::max(self, rhs)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        Vec4::abs(self)
    }
    #[inline(always)]
    fn copysign(self, sign: Self) -> Self {
        Vec4::copysign(self, sign)
    }
    #[inline(always)]
    fn lt(self, rhs: Self) -> BVec4A {
        self.cmplt(rhs)
    }
    #[inline(always)]
    fn le(self, rhs: Self) -> BVec4A {
        self.cmple(rhs)
    }
    #[inline(always)]
    fn ge(self, rhs: Self) -> BVec4A {
        self.cmpge(rhs)
    }
    #[inline(always)]
    fn select(mask: BVec4A, a: Self, b: Self) -> Self {
        Vec4::select(mask, a, b)
    }
    #[inline(always)]
    fn bitmask(mask: BVec4A) -> u32 {
        mask.bitmask()
    }
    #[inline(always)]
    fn min_element(self) -> f32 {
        Vec4::min_element(self)
    }
    #[inline(always)]
    fn max_element(self) -> f32 {
        Vec4::max_element(self)
    }
}

/// Eight lanes in one AVX register. Only for code that runs after a positive AVX2 check (the
/// `avx2` paths of `query`, which inline everything down to these intrinsics).
#[cfg(target_arch = "x86_64")]
#[derive(Debug, Clone, Copy)]
pub(crate) struct Avx8(std::arch::x86_64::__m256);

/// The mask of an [`Avx8`] (all bits of a lane set or clear).
#[cfg(target_arch = "x86_64")]
#[derive(Debug, Clone, Copy)]
pub(crate) struct Avx8Mask(std::arch::x86_64::__m256);

#[cfg(target_arch = "x86_64")]
mod avx8 {
    // SAFETY (every `unsafe` block below): `Avx8` values exist only on paths that checked for
    // AVX2 at run time (`crate::cpu::avx2_fma`); the intrinsics need AVX.
    use super::{Avx8, Avx8Mask, Lanes};
    use std::arch::x86_64::*;

    impl std::ops::BitAnd for Avx8Mask {
        type Output = Avx8Mask;
        #[inline(always)]
        fn bitand(self, rhs: Avx8Mask) -> Avx8Mask {
            Avx8Mask(unsafe { _mm256_and_ps(self.0, rhs.0) })
        }
    }

    impl std::ops::Sub for Avx8 {
        type Output = Avx8;
        #[inline(always)]
        fn sub(self, rhs: Avx8) -> Avx8 {
            Avx8(unsafe { _mm256_sub_ps(self.0, rhs.0) })
        }
    }

    impl std::ops::Mul for Avx8 {
        type Output = Avx8;
        #[inline(always)]
        fn mul(self, rhs: Avx8) -> Avx8 {
            Avx8(unsafe { _mm256_mul_ps(self.0, rhs.0) })
        }
    }

    impl Avx8 {
        #[inline(always)]
        fn to_array(self) -> [f32; 8] {
            // SAFETY: both are 32 bytes of plain f32 data.
            unsafe { std::mem::transmute::<__m256, [f32; 8]>(self.0) }
        }

        #[inline(always)]
        fn halves(self) -> (__m128, __m128) {
            unsafe {
                (
                    _mm256_castps256_ps128(self.0),
                    _mm256_extractf128_ps::<1>(self.0),
                )
            }
        }
    }

    impl Lanes for Avx8 {
        const N: usize = 8;
        type Mask = Avx8Mask;
        #[inline(always)]
        fn splat(v: f32) -> Self {
            Avx8(unsafe { _mm256_set1_ps(v) })
        }
        #[inline(always)]
        fn from_fn(mut f: impl FnMut(usize) -> f32) -> Self {
            let a = [f(0), f(1), f(2), f(3), f(4), f(5), f(6), f(7)];
            // SAFETY: `loadu` reads 32 bytes from a `[f32; 8]`.
            Avx8(unsafe { _mm256_loadu_ps(a.as_ptr()) })
        }
        #[inline(always)]
        fn lane(&self, i: usize) -> f32 {
            self.to_array()[i]
        }
        #[inline(always)]
        fn set_lane(&mut self, i: usize, v: f32) {
            let mut a = self.to_array();
            a[i] = v;
            *self = Avx8(unsafe { _mm256_loadu_ps(a.as_ptr()) });
        }
        #[inline(always)]
        fn div(self, rhs: Self) -> Self {
            Avx8(unsafe { _mm256_div_ps(self.0, rhs.0) })
        }
        #[inline(always)]
        fn add(self, rhs: Self) -> Self {
            Avx8(unsafe { _mm256_add_ps(self.0, rhs.0) })
        }
        #[inline(always)]
        fn min(self, rhs: Self) -> Self {
            // `vminps`: the second operand when either is NaN, as SSE `minps`.
            Avx8(unsafe { _mm256_min_ps(self.0, rhs.0) })
        }
        #[inline(always)]
        fn max(self, rhs: Self) -> Self {
            Avx8(unsafe { _mm256_max_ps(self.0, rhs.0) })
        }
        #[inline(always)]
        fn abs(self) -> Self {
            Avx8(unsafe { _mm256_andnot_ps(_mm256_set1_ps(-0.0), self.0) })
        }
        #[inline(always)]
        fn copysign(self, sign: Self) -> Self {
            unsafe {
                let m = _mm256_set1_ps(-0.0);
                Avx8(_mm256_or_ps(
                    _mm256_and_ps(sign.0, m),
                    _mm256_andnot_ps(m, self.0),
                ))
            }
        }
        #[inline(always)]
        fn lt(self, rhs: Self) -> Avx8Mask {
            Avx8Mask(unsafe { _mm256_cmp_ps::<_CMP_LT_OQ>(self.0, rhs.0) })
        }
        #[inline(always)]
        fn le(self, rhs: Self) -> Avx8Mask {
            Avx8Mask(unsafe { _mm256_cmp_ps::<_CMP_LE_OQ>(self.0, rhs.0) })
        }
        #[inline(always)]
        fn ge(self, rhs: Self) -> Avx8Mask {
            Avx8Mask(unsafe { _mm256_cmp_ps::<_CMP_GE_OQ>(self.0, rhs.0) })
        }
        #[inline(always)]
        fn select(mask: Avx8Mask, a: Self, b: Self) -> Self {
            Avx8(unsafe { _mm256_blendv_ps(b.0, a.0, mask.0) })
        }
        #[inline(always)]
        fn bitmask(mask: Avx8Mask) -> u32 {
            (unsafe { _mm256_movemask_ps(mask.0) }) as u32
        }
        #[inline(always)]
        fn min_element(self) -> f32 {
            let (lo, hi) = self.halves();
            glam::Vec4::from(unsafe { _mm_min_ps(lo, hi) }).min_element()
        }
        #[inline(always)]
        fn max_element(self) -> f32 {
            let (lo, hi) = self.halves();
            glam::Vec4::from(unsafe { _mm_max_ps(lo, hi) }).max_element()
        }
    }
}

/// A packet of rays, structure of arrays: component `k` of ray `i` is lane `i` of `o[k]`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Packet<V: Lanes> {
    pub(crate) o: [V; 3],
    pub(crate) d: [V; 3],
    pub(crate) inv: [V; 3],
    pub(crate) tmin: V,
    pub(crate) tmax: V,
}

/// obvhs's `safe_inverse` per lane: `1/x`, or `±1/ε` where `|x| ≤ ε`.
#[inline(always)]
fn safe_inverse<V: Lanes>(x: V) -> V {
    let tiny = x.abs().le(V::splat(f32::EPSILON));
    let big = V::splat(1.0 / f32::EPSILON).copysign(x);
    V::select(tiny, big, V::splat(1.0).div(x))
}

impl<V: Lanes> Packet<V> {
    /// The packet of `V::N` obvhs rays (`r.len() == V::N`).
    #[inline(always)]
    pub(crate) fn new(r: &[Ray]) -> Packet<V> {
        debug_assert_eq!(r.len(), V::N);
        let v = |f: fn(&Ray) -> f32| V::from_fn(|i| f(&r[i]));
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
        let v = |a: &[V; 3]| glam::Vec3A::new(a[0].lane(l), a[1].lane(l), a[2].lane(l));
        Ray {
            origin: v(&self.o),
            direction: v(&self.d),
            inv_direction: v(&self.inv),
            tmin: self.tmin.lane(l),
            tmax: self.tmax.lane(l),
        }
    }

    /// The packet with its origins moved by `−v·dt` (lane `l`: `dt` lane `l`), i.e. seen from a
    /// frame that moves with velocity `v` (m/s) for `dt` seconds: an instance at its place at time
    /// `dt`, which the ray meets where the unmoved instance meets this packet.
    #[inline(always)]
    pub(crate) fn shifted(&self, v: glam::Vec3A, dt: V) -> Packet<V> {
        let s = V::splat;
        Packet {
            o: [
                self.o[0] - s(v.x) * dt,
                self.o[1] - s(v.y) * dt,
                self.o[2] - s(v.z) * dt,
            ],
            ..*self
        }
    }

    /// The packet in another frame (rigid `m`: distances unchanged). Directions get `+0.0` like
    /// single rays (no −0.0 components).
    #[inline(always)]
    pub(crate) fn transformed(&self, m: &Affine3A) -> Packet<V> {
        let (a, b, c, t) = (
            m.matrix3.x_axis,
            m.matrix3.y_axis,
            m.matrix3.z_axis,
            m.translation,
        );
        let s = V::splat;
        let [ox, oy, oz] = self.o;
        let [dx, dy, dz] = self.d;
        // Same operation order as `Affine3A::transform_point3a` / `transform_vector3a` per lane.
        let o = [
            (ox * s(a.x)).add(oy * s(b.x)).add(oz * s(c.x)).add(s(t.x)),
            (ox * s(a.y)).add(oy * s(b.y)).add(oz * s(c.y)).add(s(t.y)),
            (ox * s(a.z)).add(oy * s(b.z)).add(oz * s(c.z)).add(s(t.z)),
        ];
        let d = [
            (dx * s(a.x)).add(dy * s(b.x)).add(dz * s(c.x)).add(s(0.0)),
            (dx * s(a.y)).add(dy * s(b.y)).add(dz * s(c.y)).add(s(0.0)),
            (dx * s(a.z)).add(dy * s(b.z)).add(dz * s(c.z)).add(s(0.0)),
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

/// Entry distances of the rays into the node's box (∞ for lanes that miss) and the hit mask.
#[inline(always)]
fn slab<V: Lanes>(node: &Bvh2Node, p: &Packet<V>) -> (V, u32) {
    let b = node.aabb();
    let (lo, hi) = (b.min, b.max);
    let s = V::splat;
    let (x0, x1) = ((s(lo.x) - p.o[0]) * p.inv[0], (s(hi.x) - p.o[0]) * p.inv[0]);
    let (y0, y1) = ((s(lo.y) - p.o[1]) * p.inv[1], (s(hi.y) - p.o[1]) * p.inv[1]);
    let (z0, z1) = ((s(lo.z) - p.o[2]) * p.inv[2], (s(hi.z) - p.o[2]) * p.inv[2]);
    let near = x0.min(x1).max(y0.min(y1)).max(z0.min(z1)).max(p.tmin);
    let far = x0.max(x1).min(y0.max(y1)).min(z0.max(z1)) * s(FAR_SCALE);
    let hit = near.le(far.min(p.tmax));
    (V::select(hit, near, s(f32::INFINITY)), V::bitmask(hit))
}

/// Möller–Trumbore on a packet; the same arithmetic as the single-ray `intersect`, per lane.
/// Distances of the lanes that hit within `[tmin, tmax)`, else ∞.
#[inline(always)]
pub(crate) fn intersect<V: Lanes>(tri: &RtTriangle, p: &Packet<V>) -> V {
    let s = V::splat;
    let (c0, c1, c2) = (
        s(tri.v0.x) - p.o[0],
        s(tri.v0.y) - p.o[1],
        s(tri.v0.z) - p.o[2],
    );
    let (d0, d1, d2) = (p.d[0], p.d[1], p.d[2]);
    // r = d × c
    let (r0, r1, r2) = (d1 * c2 - d2 * c1, d2 * c0 - d0 * c2, d0 * c1 - d1 * c0);
    let (n, e1, e2) = (tri.ng, tri.e1, tri.e2);
    let inv_det = s(1.0).div((d0 * s(n.x)).add(d1 * s(n.y)).add(d2 * s(n.z)));
    let u = (r0 * s(e2.x)).add(r1 * s(e2.y)).add(r2 * s(e2.z)) * inv_det;
    let v = (r0 * s(e1.x)).add(r1 * s(e1.y)).add(r2 * s(e1.z)) * inv_det;
    let t = (c0 * s(n.x)).add(c1 * s(n.y)).add(c2 * s(n.z)) * inv_det;
    let zero = s(0.0);
    let ok = u.ge(zero) & v.ge(zero) & u.add(v).le(s(1.0)) & t.ge(p.tmin) & t.lt(p.tmax);
    V::select(ok, t, s(f32::INFINITY))
}

/// Visit the leaves any of the rays reaches. `leaf(first, count, packet)` handles primitives
/// `first .. first + count` for all lanes, may lower lanes of `packet.tmax` (a lane with
/// `tmax < tmin` is finished) and returns `false` to stop. The tree's depth must be below [`STACK`].
#[inline(always)]
pub(crate) fn traverse<V: Lanes, F>(nodes: &[Bvh2Node], p: &mut Packet<V>, mut leaf: F)
where
    F: FnMut(u32, u32, &mut Packet<V>) -> bool,
{
    let Some(root) = nodes.first() else { return };
    if slab(root, p).1 == 0 {
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
            let (na, ma) = slab(a, p);
            let (nb, mb) = slab(b, p);
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
