//! Small closed-mesh generators (tests, the benchmark scene, placeholder assets). All emit
//! counter-clockwise triangles seen from outside (outward geometric normals).

use glam::Vec3;

use crate::environment::mesh::Mesh;

/// A planar (or bilinear) quad `a b c d` (counter-clockwise seen from the side its normal points to),
/// subdivided into `nu × nv` cells of two triangles each.
pub fn quad(mesh: &mut Mesh, [a, b, c, d]: [Vec3; 4], nu: u32, nv: u32, part: u16) {
    let (nu, nv) = (nu.max(1), nv.max(1));
    // Nested lerps keep a coordinate that is equal at all four corners exact (planar axis-aligned faces
    // stay exactly planar in f32).
    let lerp = |x: Vec3, y: Vec3, t: f32| x + (y - x) * t;
    let p = |i: u32, j: u32| {
        let (u, v) = (i as f32 / nu as f32, j as f32 / nv as f32);
        lerp(lerp(a, b, u), lerp(d, c, u), v)
    };
    for j in 0..nv {
        for i in 0..nu {
            let (p00, p10, p11, p01) = (p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1));
            mesh.push_triangle(p00, p10, p11, part);
            mesh.push_triangle(p00, p11, p01, part);
        }
    }
}

/// A closed hexahedron from 8 corners indexed by bits (`x = i & 1`, `y = (i >> 1) & 1`,
/// `z = (i >> 2) & 1` select the low/high side), each face subdivided `n × n`: `12 n²` triangles.
pub fn hexahedron(mesh: &mut Mesh, c: [Vec3; 8], n: u32, part: u16) {
    const FACES: [[usize; 4]; 6] = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    for f in FACES {
        quad(mesh, f.map(|i| c[i]), n, n, part);
    }
}

/// An axis-aligned closed box, faces subdivided `n × n`.
pub fn subdivided_box(mesh: &mut Mesh, min: Vec3, max: Vec3, n: u32, part: u16) {
    let corners = std::array::from_fn(|i| {
        Vec3::new(
            if i & 1 == 0 { min.x } else { max.x },
            if i & 2 == 0 { min.y } else { max.y },
            if i & 4 == 0 { min.z } else { max.z },
        )
    });
    hexahedron(mesh, corners, n, part);
}

/// A closed cylinder around `axis` (unit) through `center`, `segments` facets: `4 · segments` triangles.
pub fn cylinder(
    mesh: &mut Mesh,
    center: Vec3,
    axis: Vec3,
    radius: f32,
    length: f32,
    segments: u32,
    part: u16,
) {
    let axis = axis.normalize();
    let helper = if axis.x.abs() < 0.9 { Vec3::X } else { Vec3::Y };
    let u = helper.cross(axis).normalize();
    let w = axis.cross(u);
    let segments = segments.max(3);
    let h = axis * (0.5 * length);
    let ring = |k: u32| {
        let phi = std::f32::consts::TAU * (k % segments) as f32 / segments as f32;
        center + radius * (phi.cos() * u + phi.sin() * w)
    };
    for k in 0..segments {
        let (p0, p1) = (ring(k), ring(k + 1));
        let (a, b, c, d) = (p0 - h, p1 - h, p1 + h, p0 + h);
        mesh.push_triangle(a, b, c, part);
        mesh.push_triangle(a, c, d, part);
        mesh.push_triangle(center + h, p0 + h, p1 + h, part);
        mesh.push_triangle(center - h, p1 - h, p0 - h, part);
    }
}
