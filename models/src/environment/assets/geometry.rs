//! Mesh construction primitives (closed, outward-oriented solids) and mesh checks.
//!
//! The builders work in f64 and write an indexed [`Mesh`] at the end. Every solid primitive is one
//! closed, 2-manifold, consistently oriented component whose vertices are shared between its
//! triangles; after building it the component's signed volume is checked and the winding flipped if
//! it came out inward, so every primitive ends up with outward (counter-clockwise seen from outside)
//! triangles whatever the handedness of the frame it was given in.
//!
//! The checks ([`signed_volume`], [`is_closed`], [`euler_characteristic`], ...) are public: tests and
//! other modules use them to verify meshes.

use std::collections::HashMap;

use glam::{DMat3, DVec2, DVec3, Vec3};

use crate::environment::mesh::{Mesh, Part};

/// How one quad face of a [`Builder::hexahedron`] is made.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Face {
    /// One quad of the solid's part.
    Plain,
    /// One quad of another part.
    Part(u16),
    /// A frame of the solid's part around an inner quad (a window) of another part. The inner quad
    /// spans `u ∈ [u.0, u.1]`, `v ∈ [v.0, v.1]` of the face's bilinear parameters (see
    /// [`Builder::hexahedron`] for the direction of `u` and `v` on each face).
    Inset {
        u: (f64, f64),
        v: (f64, f64),
        part: u16,
    },
}

/// An indexed triangle mesh under construction (f64 positions).
#[derive(Debug, Clone, Default)]
pub(crate) struct Builder {
    pub positions: Vec<DVec3>,
    pub triangles: Vec<[u32; 3]>,
    pub triangle_part: Vec<u16>,
    pub parts: Vec<Part>,
}

/// Unit vector perpendicular to `d` used as the first cross-section axis of swept primitives:
/// the component of +x (for near-vertical axes) or of +z (otherwise) orthogonal to `d`.
fn section_axes(d: DVec3) -> (DVec3, DVec3) {
    let reference = if d.z.abs() > 0.9 { DVec3::X } else { DVec3::Z };
    let e1 = (reference - d * d.dot(reference)).normalize();
    let e2 = d.cross(e1);
    (e1, e2)
}

impl Builder {
    pub fn new() -> Builder {
        Builder::default()
    }

    /// Index of the part `name` (added with `material` if new).
    pub fn part(&mut self, name: &str, material: &str) -> u16 {
        if let Some(i) = self.parts.iter().position(|p| p.name == name) {
            return i as u16;
        }
        self.parts.push(Part {
            name: name.to_owned(),
            material: material.to_owned(),
        });
        (self.parts.len() - 1) as u16
    }

    pub fn vertex(&mut self, p: DVec3) -> u32 {
        self.positions.push(p);
        (self.positions.len() - 1) as u32
    }

    pub fn tri(&mut self, a: u32, b: u32, c: u32, part: u16) {
        self.triangles.push([a, b, c]);
        self.triangle_part.push(part);
    }

    /// Quad `a b c d` (counter-clockwise seen from the side its normal points to).
    pub fn quad(&mut self, a: u32, b: u32, c: u32, d: u32, part: u16) {
        self.tri(a, b, c, part);
        self.tri(a, c, d, part);
    }

    /// Signed volume of the triangles from index `start` on (divergence theorem).
    fn volume_from(&self, start: usize) -> f64 {
        self.triangles[start..]
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| self.positions[i as usize]);
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }

    /// Make the closed component made of the triangles from `start` on face outwards.
    fn close_component(&mut self, start: usize) {
        if self.volume_from(start) < 0.0 {
            for t in &mut self.triangles[start..] {
                t.swap(1, 2);
            }
        }
    }

    /// Axis-aligned box `lo..hi`.
    pub fn cuboid(&mut self, lo: DVec3, hi: DVec3, part: u16) {
        let c = std::array::from_fn(|i| {
            DVec3::new(
                if i & 4 != 0 { hi.x } else { lo.x },
                if i & 2 != 0 { hi.y } else { lo.y },
                if i & 1 != 0 { hi.z } else { lo.z },
            )
        });
        self.hexahedron(c, [Face::Plain; 6], part);
    }

    /// Oriented box: centre, axes (columns of `axes`, unit) and half extents.
    pub fn oriented_box(&mut self, centre: DVec3, axes: DMat3, half: DVec3, part: u16) {
        let c = std::array::from_fn(|i| {
            let s = DVec3::new(
                if i & 4 != 0 { 1.0 } else { -1.0 },
                if i & 2 != 0 { 1.0 } else { -1.0 },
                if i & 1 != 0 { 1.0 } else { -1.0 },
            );
            centre + axes * (s * half)
        });
        self.hexahedron(c, [Face::Plain; 6], part);
    }

    /// A thin box along the segment `p0 → p1` with cross-section `w × h` (`w` horizontal).
    pub fn bar(&mut self, p0: DVec3, p1: DVec3, w: f64, h: f64, part: u16) {
        let d = p1 - p0;
        let len = d.length();
        if len <= 0.0 {
            return;
        }
        let x = d / len;
        let (e1, e2) = section_axes(x);
        self.oriented_box(
            (p0 + p1) * 0.5,
            DMat3::from_cols(x, e2, e1),
            DVec3::new(len * 0.5, w * 0.5, h * 0.5),
            part,
        );
    }

    /// Hexahedron with corners `c[4·ix + 2·iy + iz]` (`ix`, `iy`, `iz` ∈ {0, 1}: back/front, right/left,
    /// bottom/top in the solid's logical frame; planar faces expected). `faces` in the order
    /// `[−x, +x, −y, +y, −z, +z]`; the bilinear face parameters run: −x: `u` towards −y, `v` up;
    /// +x: `u` towards +y, `v` up; −y: `u` towards +x, `v` up; +y: `u` towards −x, `v` up;
    /// −z, +z: unspecified.
    pub fn hexahedron(&mut self, c: [DVec3; 8], faces: [Face; 6], part: u16) {
        let start = self.triangles.len();
        let v: Vec<u32> = c.iter().map(|&p| self.vertex(p)).collect();
        const QUADS: [[usize; 4]; 6] = [
            [2, 0, 1, 3],
            [4, 6, 7, 5],
            [0, 4, 5, 1],
            [6, 2, 3, 7],
            [0, 2, 6, 4],
            [1, 5, 7, 3],
        ];
        for (q, face) in QUADS.iter().zip(faces) {
            let [a, b, cc, d] = q.map(|i| v[i]);
            match face {
                Face::Plain => self.quad(a, b, cc, d, part),
                Face::Part(other) => self.quad(a, b, cc, d, other),
                Face::Inset {
                    u,
                    v: vv,
                    part: inner,
                } => {
                    let [p0, p1, p2, p3] = q.map(|i| c[i]);
                    let at = |s: f64, t: f64| {
                        p0 * ((1.0 - s) * (1.0 - t))
                            + p1 * (s * (1.0 - t))
                            + p2 * (s * t)
                            + p3 * ((1.0 - s) * t)
                    };
                    let w = [at(u.0, vv.0), at(u.1, vv.0), at(u.1, vv.1), at(u.0, vv.1)]
                        .map(|p| self.vertex(p));
                    let outer = [a, b, cc, d];
                    for k in 0..4 {
                        let n = (k + 1) % 4;
                        self.quad(outer[k], outer[n], w[n], w[k], part);
                    }
                    self.quad(w[0], w[1], w[2], w[3], inner);
                }
            }
        }
        self.close_component(start);
    }

    /// Closed frustum along `p0 → p1` with elliptical cross-sections (radii `(r_a, r_b)` along the
    /// section axes: for near-vertical axes `a` = x (depth) and `b` = y (width)). A zero radius at
    /// either end makes a cone apex. The first segment vertex lies along the first section axis
    /// (−z direction included for horizontal axes when `segments` is a multiple of 4).
    pub fn frustum(
        &mut self,
        p0: DVec3,
        r0: DVec2,
        p1: DVec3,
        r1: DVec2,
        segments: usize,
        part: u16,
    ) {
        let d = p1 - p0;
        if d.length() <= 0.0 {
            return;
        }
        let (e1, e2) = section_axes(d.normalize());
        let n = segments.max(3);
        let start = self.triangles.len();
        let ring = |b: &mut Builder, c: DVec3, r: DVec2| -> Vec<u32> {
            if r.x <= 0.0 && r.y <= 0.0 {
                vec![b.vertex(c)]
            } else {
                (0..n)
                    .map(|k| {
                        let t = std::f64::consts::TAU * k as f64 / n as f64;
                        b.vertex(c + e1 * (r.x * t.cos()) + e2 * (r.y * t.sin()))
                    })
                    .collect()
            }
        };
        let bottom = ring(self, p0, r0);
        let top = ring(self, p1, r1);
        for k in 0..n {
            let k1 = (k + 1) % n;
            match (bottom.len(), top.len()) {
                (1, 1) => return,
                (1, _) => self.tri(bottom[0], top[k1], top[k], part),
                (_, 1) => self.tri(bottom[k], bottom[k1], top[0], part),
                _ => self.quad(bottom[k], bottom[k1], top[k1], top[k], part),
            }
        }
        if bottom.len() > 1 {
            let c = self.vertex(p0);
            for k in 0..n {
                self.tri(c, bottom[(k + 1) % n], bottom[k], part);
            }
        }
        if top.len() > 1 {
            let c = self.vertex(p1);
            for k in 0..n {
                self.tri(c, top[k], top[(k + 1) % n], part);
            }
        }
        self.close_component(start);
    }

    /// Closed circular cylinder along `p0 → p1`.
    pub fn cylinder(&mut self, p0: DVec3, p1: DVec3, r: f64, segments: usize, part: u16) {
        self.frustum(p0, DVec2::splat(r), p1, DVec2::splat(r), segments, part);
    }

    /// Closed ellipsoid (UV sphere) with semi-axes `radii` along x, y, z.
    pub fn ellipsoid(
        &mut self,
        centre: DVec3,
        radii: DVec3,
        segments: usize,
        rings: usize,
        part: u16,
    ) {
        let n = segments.max(3);
        let m = rings.max(2);
        let start = self.triangles.len();
        let bottom = self.vertex(centre - DVec3::Z * radii.z);
        let top = self.vertex(centre + DVec3::Z * radii.z);
        let mut rows: Vec<Vec<u32>> = Vec::with_capacity(m - 1);
        for j in 1..m {
            let phi = std::f64::consts::PI * j as f64 / m as f64; // from the bottom pole
            let (s, c) = phi.sin_cos();
            let row = (0..n)
                .map(|k| {
                    let t = std::f64::consts::TAU * k as f64 / n as f64;
                    self.vertex(
                        centre
                            + DVec3::new(
                                radii.x * s * t.cos(),
                                radii.y * s * t.sin(),
                                -radii.z * c,
                            ),
                    )
                })
                .collect();
            rows.push(row);
        }
        for k in 0..n {
            let k1 = (k + 1) % n;
            self.tri(bottom, rows[0][k1], rows[0][k], part);
            for j in 0..rows.len() - 1 {
                self.quad(
                    rows[j][k],
                    rows[j][k1],
                    rows[j + 1][k1],
                    rows[j + 1][k],
                    part,
                );
            }
            let last = &rows[rows.len() - 1];
            let (a, b) = (last[k], last[k1]);
            self.tri(a, b, top, part);
        }
        self.close_component(start);
    }

    /// Closed torus (genus 1) around `axis` through `centre`: the tube's centre circle has radius
    /// `major_r`, its cross-section is an ellipse of semi-axes `(r_radial, r_axial)` (e.g. a tyre:
    /// half the section height, half the section width). Every vertex is shared, so the surface is
    /// smooth where a radar interpolates its normals (`radar::propagation`).
    pub fn torus(
        &mut self,
        centre: DVec3,
        axis: DVec3,
        major_r: f64,
        (r_radial, r_axial): (f64, f64),
        (segments, section_segments): (usize, usize),
        part: u16,
    ) {
        let d = axis.normalize();
        let (e1, e2) = section_axes(d);
        let n = segments.max(3);
        let m = section_segments.max(3);
        let start = self.triangles.len();
        let rows: Vec<Vec<u32>> = (0..n)
            .map(|k| {
                let t = std::f64::consts::TAU * k as f64 / n as f64;
                let radial = e1 * t.cos() + e2 * t.sin();
                (0..m)
                    .map(|j| {
                        let s = std::f64::consts::TAU * j as f64 / m as f64;
                        self.vertex(
                            centre
                                + radial * (major_r + r_radial * s.cos())
                                + d * (r_axial * s.sin()),
                        )
                    })
                    .collect()
            })
            .collect();
        for k in 0..n {
            let (a, b) = (&rows[k], &rows[(k + 1) % n]);
            for j in 0..m {
                let j1 = (j + 1) % m;
                let q = [a[j], b[j], b[j1], a[j1]];
                self.quad(q[0], q[1], q[2], q[3], part);
            }
        }
        self.close_component(start);
    }

    /// Closed loft through `rings` (closed loops of equal length, consecutive rings stitched with
    /// quads); the first and the last ring are closed by fans from their centroids (flat caps when
    /// the rings are planar). Vertices are shared, so the lofted surface is smooth where a radar
    /// interpolates its normals.
    pub fn loft(&mut self, rings: &[Vec<DVec3>], part: u16) {
        let Some(n) = rings.first().map(Vec::len) else {
            return;
        };
        if n < 3 || rings.len() < 2 || rings.iter().any(|r| r.len() != n) {
            return;
        }
        let start = self.triangles.len();
        let ids: Vec<Vec<u32>> = rings
            .iter()
            .map(|r| r.iter().map(|&p| self.vertex(p)).collect())
            .collect();
        for w in ids.windows(2) {
            for k in 0..n {
                let k1 = (k + 1) % n;
                self.quad(w[0][k], w[0][k1], w[1][k1], w[1][k], part);
            }
        }
        for (ring, ids, flip) in [
            (&rings[0], &ids[0], true),
            (&rings[rings.len() - 1], &ids[ids.len() - 1], false),
        ] {
            let c = self.vertex(ring.iter().copied().sum::<DVec3>() / n as f64);
            for k in 0..n {
                let k1 = (k + 1) % n;
                if flip {
                    self.tri(c, ids[k1], ids[k], part);
                } else {
                    self.tri(c, ids[k], ids[k1], part);
                }
            }
        }
        self.close_component(start);
    }

    /// Closed prism: the simple polygon `profile` (in the plane spanned by `ea`, `eb` through
    /// `origin`) swept along `ea × eb` through the `stations` (increasing offsets, at least two).
    /// The caps are ear-clipped; the sides are split at every station.
    pub fn prism(
        &mut self,
        profile: &[DVec2],
        origin: DVec3,
        ea: DVec3,
        eb: DVec3,
        stations: &[f64],
        part: u16,
    ) {
        if profile.len() < 3 || stations.len() < 2 {
            return;
        }
        let mut poly = profile.to_vec();
        if polygon_area(&poly) < 0.0 {
            poly.reverse();
        }
        let ew = ea.cross(eb);
        let start = self.triangles.len();
        let rows: Vec<Vec<u32>> = stations
            .iter()
            .map(|&w| {
                poly.iter()
                    .map(|q| self.vertex(origin + ea * q.x + eb * q.y + ew * w))
                    .collect()
            })
            .collect();
        let n = poly.len();
        for s in 0..rows.len() - 1 {
            for i in 0..n {
                let i1 = (i + 1) % n;
                self.quad(
                    rows[s][i],
                    rows[s][i1],
                    rows[s + 1][i1],
                    rows[s + 1][i],
                    part,
                );
            }
        }
        let caps = ear_clip(&poly);
        let (first, last) = (&rows[0], &rows[rows.len() - 1]);
        for [a, b, c] in caps {
            self.tri(last[a], last[b], last[c], part);
            self.tri(first[a], first[c], first[b], part);
        }
        self.close_component(start);
    }

    /// Apply `f` to every position; a mirroring `f` must be followed by [`Builder::flip_all`].
    pub fn map_positions(&mut self, f: impl Fn(DVec3) -> DVec3) {
        for p in &mut self.positions {
            *p = f(*p);
        }
    }

    /// Reverse the winding of every triangle.
    pub fn flip_all(&mut self) {
        for t in &mut self.triangles {
            t.swap(1, 2);
        }
    }

    /// Axis-aligned bounds.
    pub fn bounds(&self) -> Option<(DVec3, DVec3)> {
        let first = *self.positions.first()?;
        Some(
            self.positions
                .iter()
                .fold((first, first), |(lo, hi), p| (lo.min(*p), hi.max(*p))),
        )
    }

    /// Translate so that the bounding-box centre is the origin.
    pub fn centre(&mut self) {
        if let Some((lo, hi)) = self.bounds() {
            let c = (lo + hi) * 0.5;
            self.map_positions(|p| p - c);
        }
    }

    /// Centre the bounding box at the origin and scale each axis so the bounds are exactly `dims`
    /// (axes with zero extent stay flat).
    pub fn fit(&mut self, dims: DVec3) {
        let Some((lo, hi)) = self.bounds() else {
            return;
        };
        let c = (lo + hi) * 0.5;
        let ext = hi - lo;
        let s = DVec3::new(
            if ext.x > 0.0 { dims.x / ext.x } else { 1.0 },
            if ext.y > 0.0 { dims.y / ext.y } else { 1.0 },
            if ext.z > 0.0 { dims.z / ext.z } else { 1.0 },
        );
        self.map_positions(|p| (p - c) * s);
    }

    /// The mesh (positions rounded to f32).
    pub fn into_mesh(self) -> Mesh {
        Mesh {
            positions: self.positions.iter().map(|p| p.as_vec3()).collect(),
            triangles: self.triangles,
            triangle_part: self.triangle_part,
            parts: self.parts,
        }
    }
}

/// Signed area of a 2-D polygon (positive: counter-clockwise).
pub(crate) fn polygon_area(p: &[DVec2]) -> f64 {
    let n = p.len();
    (0..n).map(|i| p[i].perp_dot(p[(i + 1) % n])).sum::<f64>() * 0.5
}

/// Ear-clipping triangulation of a simple counter-clockwise polygon (indices into `p`).
pub(crate) fn ear_clip(p: &[DVec2]) -> Vec<[usize; 3]> {
    let mut idx: Vec<usize> = (0..p.len()).collect();
    let mut out = Vec::with_capacity(p.len().saturating_sub(2));
    let inside = |a: DVec2, b: DVec2, c: DVec2, q: DVec2| {
        let d1 = (b - a).perp_dot(q - a);
        let d2 = (c - b).perp_dot(q - b);
        let d3 = (a - c).perp_dot(q - c);
        d1 >= 0.0 && d2 >= 0.0 && d3 >= 0.0
    };
    let mut guard = 0;
    while idx.len() > 3 && guard < 10_000 {
        guard += 1;
        let n = idx.len();
        let mut clipped = false;
        for i in 0..n {
            let (ia, ib, ic) = (idx[(i + n - 1) % n], idx[i], idx[(i + 1) % n]);
            let (a, b, c) = (p[ia], p[ib], p[ic]);
            if (b - a).perp_dot(c - b) <= 0.0 {
                continue; // reflex or degenerate corner
            }
            let blocked = idx
                .iter()
                .any(|&j| j != ia && j != ib && j != ic && inside(a, b, c, p[j]));
            if !blocked {
                out.push([ia, ib, ic]);
                idx.remove(i);
                clipped = true;
                break;
            }
        }
        if !clipped {
            // Numerically degenerate remainder: fan it.
            break;
        }
    }
    for k in 1..idx.len().saturating_sub(1) {
        out.push([idx[0], idx[k], idx[k + 1]]);
    }
    out
}

/// Unit geometric normal `(b − a) × (c − a)` of triangle `i` (zero for a degenerate triangle).
pub fn triangle_normal(mesh: &Mesh, i: usize) -> DVec3 {
    let [a, b, c] = mesh.triangle(i).map(Vec3::as_dvec3);
    (b - a).cross(c - a).normalize_or_zero()
}

/// Area of triangle `i`, m².
pub fn triangle_area(mesh: &Mesh, i: usize) -> f64 {
    let [a, b, c] = mesh.triangle(i).map(Vec3::as_dvec3);
    0.5 * (b - a).cross(c - a).length()
}

/// Total area of the triangles of the part named `part`, m².
pub fn part_area(mesh: &Mesh, part: &str) -> f64 {
    let Some(p) = mesh.parts.iter().position(|q| q.name == part) else {
        return 0.0;
    };
    (0..mesh.triangle_count())
        .filter(|&i| mesh.triangle_part[i] as usize == p)
        .map(|i| triangle_area(mesh, i))
        .sum()
}

/// Signed volume enclosed by the mesh, m³ (positive when a closed mesh's triangles face outwards).
pub fn signed_volume(mesh: &Mesh) -> f64 {
    mesh.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| mesh.positions[i as usize].as_dvec3());
            a.dot(b.cross(c)) / 6.0
        })
        .sum()
}

/// Whether the mesh is closed and consistently oriented: every directed edge `a → b` occurs exactly
/// once and its reverse `b → a` exactly once.
pub fn is_closed(mesh: &Mesh) -> bool {
    let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
    for t in &mesh.triangles {
        for k in 0..3 {
            *edges.entry((t[k], t[(k + 1) % 3])).or_default() += 1;
        }
    }
    edges
        .iter()
        .all(|(&(a, b), &n)| n == 1 && edges.get(&(b, a)) == Some(&1))
}

/// Euler characteristic `V − E + F` over the referenced vertices (2 per closed genus-0 component).
pub fn euler_characteristic(mesh: &Mesh) -> i64 {
    let mut vertices = std::collections::HashSet::new();
    let mut edges = std::collections::HashSet::new();
    for t in &mesh.triangles {
        for k in 0..3 {
            vertices.insert(t[k]);
            let (a, b) = (t[k], t[(k + 1) % 3]);
            edges.insert((a.min(b), a.max(b)));
        }
    }
    vertices.len() as i64 - edges.len() as i64 + mesh.triangles.len() as i64
}

/// Connected components (triangles sharing a vertex index), each as a list of triangle indices.
pub fn components(mesh: &Mesh) -> Vec<Vec<usize>> {
    let n = mesh.positions.len();
    let mut parent: Vec<usize> = (0..n).collect();
    fn find(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    for t in &mesh.triangles {
        let a = find(&mut parent, t[0] as usize);
        for &v in &t[1..] {
            let b = find(&mut parent, v as usize);
            parent[b] = a;
        }
    }
    let mut groups: HashMap<usize, Vec<usize>> = HashMap::new();
    for (i, t) in mesh.triangles.iter().enumerate() {
        let r = find(&mut parent, t[0] as usize);
        groups.entry(r).or_default().push(i);
    }
    let mut out: Vec<Vec<usize>> = groups.into_values().collect();
    out.sort();
    out
}

/// The sub-mesh made of the given triangles (all parts kept, vertices re-indexed).
pub fn submesh(mesh: &Mesh, triangles: &[usize]) -> Mesh {
    let mut map: HashMap<u32, u32> = HashMap::new();
    let mut out = Mesh {
        parts: mesh.parts.clone(),
        ..Mesh::default()
    };
    for &i in triangles {
        let t = mesh.triangles[i].map(|v| {
            *map.entry(v).or_insert_with(|| {
                out.positions.push(mesh.positions[v as usize]);
                (out.positions.len() - 1) as u32
            })
        });
        out.triangles.push(t);
        out.triangle_part.push(mesh.triangle_part[i]);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check_closed_outward(b: Builder, expected_volume: Option<f64>) {
        let m = b.into_mesh();
        assert!(is_closed(&m));
        let v = signed_volume(&m);
        assert!(v > 0.0, "volume {v}");
        if let Some(e) = expected_volume {
            assert!((v - e).abs() < 1e-3 * e, "volume {v}, expected {e}");
        }
    }

    #[test]
    fn primitives_are_closed_and_outward() {
        let mut b = Builder::new();
        let p = b.part("p", "steel");
        b.cuboid(DVec3::ZERO, DVec3::new(1.0, 2.0, 3.0), p);
        let m = b.clone().into_mesh();
        assert_eq!(euler_characteristic(&m), 2);
        check_closed_outward(b, Some(6.0));

        let mut b = Builder::new();
        b.cylinder(DVec3::ZERO, DVec3::new(0.0, 2.0, 0.0), 1.0, 64, p);
        // Inscribed 64-gon area: (n/2) sin(2π/n).
        let a = 32.0 * (std::f64::consts::TAU / 64.0).sin();
        check_closed_outward(b, Some(2.0 * a));

        let mut b = Builder::new();
        b.frustum(DVec3::ZERO, DVec2::splat(1.0), DVec3::Z, DVec2::ZERO, 16, p);
        let m = b.clone().into_mesh();
        assert_eq!(euler_characteristic(&m), 2);
        check_closed_outward(b, None);

        let mut b = Builder::new();
        b.ellipsoid(DVec3::ONE, DVec3::new(1.0, 2.0, 3.0), 24, 12, p);
        let m = b.clone().into_mesh();
        assert_eq!(euler_characteristic(&m), 2);
        check_closed_outward(b, None);

        let mut b = Builder::new();
        b.torus(DVec3::ZERO, DVec3::Y, 0.5, (0.1, 0.05), (48, 16), p);
        let m = b.clone().into_mesh();
        assert_eq!(euler_characteristic(&m), 0);
        // Pappus: V = 2πR·(area of the section), the 48 × 16 polygons slightly less.
        let v = signed_volume(&m);
        let exact = std::f64::consts::TAU * 0.5 * std::f64::consts::PI * 0.1 * 0.05;
        assert!(v > 0.95 * exact && v < exact, "torus volume {v} vs {exact}");
        check_closed_outward(b, None);

        // A loft of three squares (a closed box with a waist): genus 0, outward.
        let sq = |h: f64, z: f64| {
            vec![
                DVec3::new(-h, -h, z),
                DVec3::new(h, -h, z),
                DVec3::new(h, h, z),
                DVec3::new(-h, h, z),
            ]
        };
        let mut b = Builder::new();
        b.loft(&[sq(1.0, 0.0), sq(0.5, 1.0), sq(1.0, 2.0)], p);
        let m = b.clone().into_mesh();
        assert_eq!(euler_characteristic(&m), 2);
        // Two frusta of square section: 2 · (h/3)(A1 + A2 + √(A1 A2)) = 2 · (4 + 1 + 2)/3.
        check_closed_outward(b, Some(14.0 / 3.0));

        // An L-shaped (non-convex) prism, swept in a left-handed way: still outward.
        let l = [
            DVec2::new(0.0, 0.0),
            DVec2::new(2.0, 0.0),
            DVec2::new(2.0, 1.0),
            DVec2::new(1.0, 1.0),
            DVec2::new(1.0, 2.0),
            DVec2::new(0.0, 2.0),
        ];
        let mut b = Builder::new();
        b.prism(&l, DVec3::ZERO, DVec3::X, DVec3::Z, &[0.0, 0.5, 1.0], p);
        check_closed_outward(b, Some(3.0));
    }

    #[test]
    fn inset_faces_keep_the_solid_closed() {
        let mut b = Builder::new();
        let body = b.part("body", "steel");
        let glass = b.part("glass", "glass");
        let c = std::array::from_fn(|i| {
            DVec3::new(
                (i & 4 != 0) as u8 as f64,
                (i & 2 != 0) as u8 as f64,
                (i & 1 != 0) as u8 as f64,
            )
        });
        let w = Face::Inset {
            u: (0.1, 0.9),
            v: (0.2, 0.8),
            part: glass,
        };
        b.hexahedron(c, [w, w, w, w, Face::Plain, Face::Plain], body);
        let m = b.into_mesh();
        assert!(is_closed(&m));
        assert_eq!(euler_characteristic(&m), 2);
        assert!((signed_volume(&m) - 1.0).abs() < 1e-9);
        assert!((part_area(&m, "glass") - 4.0 * 0.8 * 0.6).abs() < 1e-6);
    }
}
