//! Triangle meshes: the geometry every asset produces and the space-design layer traces.

use glam::Vec3;

/// One part of a mesh (e.g. a car's `body`, `glass`, `wheels`): a name and a material name from the
/// materials database (`material::MaterialDb::id`).
#[derive(Debug, Clone, PartialEq)]
pub struct Part {
    pub name: String,
    pub material: String,
}

/// An indexed triangle mesh in its local frame (m; the asset convention: +x is the direction the
/// asset faces, +z up). Triangles are counter-clockwise seen from the outside (the geometric normal
/// `(b - a) × (c - a)` points outwards).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions, m (f32: meshes are local and small).
    pub positions: Vec<Vec3>,
    /// Vertex indices, three per triangle.
    pub triangles: Vec<[u32; 3]>,
    /// Part index of each triangle (same length as `triangles`).
    pub triangle_part: Vec<u16>,
    /// Parts referenced by `triangle_part`.
    pub parts: Vec<Part>,
}

impl Mesh {
    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// Corner positions of triangle `i`.
    pub fn triangle(&self, i: usize) -> [Vec3; 3] {
        let [a, b, c] = self.triangles[i];
        [
            self.positions[a as usize],
            self.positions[b as usize],
            self.positions[c as usize],
        ]
    }

    /// Index of the part named `name`, adding it with `material` if new.
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

    /// Append a triangle of part `part`.
    pub fn push_triangle(&mut self, a: Vec3, b: Vec3, c: Vec3, part: u16) {
        let base = self.positions.len() as u32;
        self.positions.extend([a, b, c]);
        self.triangles.push([base, base + 1, base + 2]);
        self.triangle_part.push(part);
    }

    /// Append another mesh (its parts are merged by name).
    pub fn append(&mut self, other: &Mesh) {
        let base = self.positions.len() as u32;
        self.positions.extend_from_slice(&other.positions);
        let remap: Vec<u16> = other
            .parts
            .iter()
            .map(|p| self.part(&p.name, &p.material))
            .collect();
        self.triangles
            .extend(other.triangles.iter().map(|t| t.map(|i| i + base)));
        self.triangle_part
            .extend(other.triangle_part.iter().map(|&p| remap[p as usize]));
    }

    /// Axis-aligned bounds (min, max); `None` for an empty mesh.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        let first = *self.positions.first()?;
        Some(
            self.positions
                .iter()
                .fold((first, first), |(lo, hi), p| (lo.min(*p), hi.max(*p))),
        )
    }
}
