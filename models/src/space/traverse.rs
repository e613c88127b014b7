//! Stack traversal of obvhs BVH2 node arrays, tuned for the ray queries of this module.
//!
//! Differences from `Bvh2::ray_traverse`: the ray's `tmin` clips node intervals, the stack holds
//! each deferred node with its entry distance so that nodes behind a hit found meanwhile are
//! dropped without being touched.
//! The slab test uses `(bound − origin) · (1/d)` (as obvhs does), which keeps the sign of each
//! term exact for axis-parallel rays.

use glam::Vec3A;
use obvhs::bvh2::{Bvh2, node::Bvh2Node};
use obvhs::ray::Ray;

/// Deferred nodes a traversal can hold; deeper trees use obvhs's own traversal.
pub(crate) const STACK: usize = 64;

/// `1 + 4ε`: widens each node's far distance against rounding (Ize 2013, "Robust BVH ray
/// traversal"), so that a ray through a shared face or edge of two boxes is never lost between them.
pub(crate) const FAR_SCALE: f32 = 1.0 + 4.0 * f32::EPSILON;

/// Entry distance of the ray into the node's box within `[tmin, tmax]`, or ∞.
#[inline(always)]
fn slab(node: &Bvh2Node, origin: Vec3A, inv: Vec3A, tmin: f32, tmax: f32) -> f32 {
    let t0 = (node.aabb().min - origin) * inv;
    let t1 = (node.aabb().max - origin) * inv;
    let near = t0.min(t1).max_element().max(tmin);
    let far = t0.max(t1).min_element() * FAR_SCALE;
    if near <= far.min(tmax) {
        near
    } else {
        f32::INFINITY
    }
}

/// Depth of the deepest leaf (root = 0).
pub(crate) fn depth(bvh: &Bvh2) -> usize {
    if bvh.nodes.is_empty() {
        return 0;
    }
    let mut deepest = 0;
    let mut stack = vec![(0usize, 0usize)];
    while let Some((i, d)) = stack.pop() {
        let n = &bvh.nodes[i];
        deepest = deepest.max(d);
        if !n.is_leaf() {
            stack.push((n.first_index as usize, d + 1));
            stack.push((n.first_index as usize + 1, d + 1));
        }
    }
    deepest
}

/// Visit the leaves the ray reaches, nearest first. `leaf(first, count, ray)` handles the primitives
/// `first .. first + count` (BVH order); it may lower `ray.tmax` (closest hit) and returns `false` to
/// stop the traversal (any hit). The tree's depth must be below [`STACK`].
#[inline(always)]
pub(crate) fn traverse<F>(nodes: &[Bvh2Node], ray: &mut Ray, mut leaf: F)
where
    F: FnMut(u32, u32, &mut Ray) -> bool,
{
    let Some(root) = nodes.first() else { return };
    let (origin, inv) = (ray.origin, ray.inv_direction);
    if slab(root, origin, inv, ray.tmin, ray.tmax) == f32::INFINITY {
        return;
    }
    let mut stack = [(0u32, 0f32); STACK];
    let mut top = 0;
    let mut node = root;
    loop {
        if node.prim_count > 0 {
            if !leaf(node.first_index, node.prim_count, ray) {
                return;
            }
        } else {
            let i = node.first_index as usize;
            let (a, b) = (&nodes[i], &nodes[i + 1]);
            let ta = slab(a, origin, inv, ray.tmin, ray.tmax);
            let tb = slab(b, origin, inv, ray.tmin, ray.tmax);
            // Nearest child first. Two written-out branches rather than a select of indices: a
            // predicted branch lets the CPU fetch the next node before the box test resolves,
            // which is worth ~30 % on coherent rays.
            if ta <= tb {
                if ta != f32::INFINITY {
                    if tb != f32::INFINITY {
                        stack[top] = (i as u32 + 1, tb);
                        top += 1;
                    }
                    node = a;
                    continue;
                }
            } else if tb != f32::INFINITY {
                if ta != f32::INFINITY {
                    stack[top] = (i as u32, ta);
                    top += 1;
                }
                node = b;
                continue;
            }
        }
        // Pop the nearest deferred node still in front of the closest hit.
        loop {
            if top == 0 {
                return;
            }
            top -= 1;
            let (i, t) = stack[top];
            if t <= ray.tmax {
                node = &nodes[i as usize];
                break;
            }
        }
    }
}
