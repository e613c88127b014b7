//! User meshes: Wavefront OBJ (crate `tobj`) and glTF 2.0 / GLB (crate `gltf`).
//!
//! Every material of the file becomes one part named after it ("default" for faces without one).
//! A part's osiris material is the file material's name if that is an osiris material (compared after
//! lower-casing and turning every character outside `[a-z0-9_.]` into `_`; `lambertian_<NN>` counts),
//! else the fallback material (`material=`, default `lambertian_50`).
//!
//! Axes: `up=z` takes the file's coordinates as osiris object coordinates (x forward, y left, z up);
//! `up=y` converts from the glTF convention (+y up, +z forward, +x left): `(x, y, z)_osiris =
//! (z, x, y)_file`. glTF files default to `up=y`, OBJ files to `up=z`. Then `yaw_deg` rotates about
//! +z, `scale` scales (to metres), and `fit` places the result (see [`Fit`]).
//!
//! glTF: the default scene (else the first, else every root node) is flattened with its node
//! transforms; triangle lists, strips and fans are read; points and lines are ignored. Buffers come
//! from the GLB binary chunk, `data:` URIs (base64) or files next to the `.gltf`.

use std::path::{Path, PathBuf};

use glam::{DMat3, DMat4, DVec3};

use super::geometry::Builder;
use super::{AssetContext, AssetError, AssetRef};
use crate::environment::material::MaterialDb;
use crate::environment::mesh::Mesh;

/// Axis convention of a mesh file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Up {
    /// osiris: x forward, y left, z up.
    Z,
    /// glTF: +y up, +z forward, +x left.
    Y,
}

/// How a loaded mesh is placed in the object frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fit {
    /// Move the bounding-box centre to the origin (the OSI `base.position` is the box centre).
    Center,
    /// Centre, then scale each axis so the bounds equal the OSI dimension.
    Stretch,
    /// Centre, then scale uniformly so the mesh fits inside the OSI dimension.
    Uniform,
    /// Keep the file's origin.
    None,
}

/// Options of [`load_user_mesh_with`].
#[derive(Debug, Clone)]
pub struct UserMeshOptions<'a> {
    /// Material of file materials that are not osiris materials.
    pub material: String,
    /// File axes (`None`: by format, glTF `Y`, OBJ `Z`).
    pub up: Option<Up>,
    /// Rotation about +z after the axis conversion, rad.
    pub yaw_rad: f64,
    /// Uniform scale to metres.
    pub scale: f64,
    pub fit: Fit,
    /// Box for [`Fit::Stretch`] / [`Fit::Uniform`] (ignored by the others; `None`: no scaling).
    pub dimensions: Option<DVec3>,
    /// Materials the file's material names are matched against (`None`: [`MaterialDb::builtin`]).
    pub materials: Option<&'a MaterialDb>,
}

impl Default for UserMeshOptions<'_> {
    fn default() -> Self {
        UserMeshOptions {
            material: "lambertian_50".into(),
            up: None,
            yaw_rad: 0.0,
            scale: 1.0,
            fit: Fit::Center,
            dimensions: None,
            materials: None,
        }
    }
}

/// Load an OBJ / glTF / GLB file with the default options (bounding-box centre at the origin).
pub fn load_user_mesh(path: impl AsRef<Path>) -> Result<Mesh, AssetError> {
    load_user_mesh_with(path.as_ref(), &UserMeshOptions::default())
}

fn file_error(path: &Path, message: impl Into<String>) -> AssetError {
    AssetError::MeshFile {
        path: path.to_path_buf(),
        message: message.into(),
    }
}

/// Raw triangles of a file: positions, triangles and the material name of each triangle.
struct Raw {
    positions: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
    material: Vec<usize>,
    material_names: Vec<String>,
}

impl Raw {
    fn material_index(&mut self, name: &str) -> usize {
        if let Some(i) = self.material_names.iter().position(|n| n == name) {
            return i;
        }
        self.material_names.push(name.to_string());
        self.material_names.len() - 1
    }
}

/// Load a mesh file with options (see the module documentation).
pub fn load_user_mesh_with(path: &Path, opts: &UserMeshOptions<'_>) -> Result<Mesh, AssetError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let (raw, default_up) = match ext.as_deref() {
        Some("obj") => (load_obj(path)?, Up::Z),
        Some("gltf" | "glb") => (load_gltf(path)?, Up::Y),
        _ => {
            return Err(AssetError::UnsupportedFormat {
                path: path.to_path_buf(),
            });
        }
    };
    if raw.triangles.is_empty() {
        return Err(file_error(path, "contains no triangles"));
    }
    let builtin;
    let db = match opts.materials {
        Some(db) => db,
        None => {
            builtin = MaterialDb::builtin();
            &builtin
        }
    };
    let mut b = Builder::new();
    let parts: Vec<u16> = raw
        .material_names
        .iter()
        .map(|n| b.part(n, &osiris_material(n, db, &opts.material)))
        .collect();
    let axes = match opts.up.unwrap_or(default_up) {
        Up::Z => DMat3::IDENTITY,
        // Columns: images of the file's x, y, z axes: file x (left) → +y, file y (up) → +z,
        // file z (forward) → +x.
        Up::Y => DMat3::from_cols(DVec3::Y, DVec3::Z, DVec3::X),
    };
    let r = DMat3::from_rotation_z(opts.yaw_rad) * axes * opts.scale;
    b.positions = raw.positions.iter().map(|&p| r * p).collect();
    for (t, &m) in raw.triangles.iter().zip(&raw.material) {
        b.tri(t[0], t[1], t[2], parts[m]);
    }
    match opts.fit {
        Fit::None => {}
        Fit::Center => b.centre(),
        Fit::Stretch => match opts.dimensions {
            Some(d) => b.fit(d),
            None => b.centre(),
        },
        Fit::Uniform => {
            b.centre();
            if let (Some(d), Some((lo, hi))) = (opts.dimensions, b.bounds()) {
                let ext = hi - lo;
                let k = [0, 1, 2]
                    .into_iter()
                    .filter(|&i| ext[i] > 0.0 && d[i] > 0.0)
                    .map(|i| d[i] / ext[i])
                    .fold(f64::INFINITY, f64::min);
                if k.is_finite() {
                    b.map_positions(|p| p * k);
                }
            }
        }
    }
    Ok(b.into_mesh())
}

/// The osiris material of a file material name (see the module documentation).
fn osiris_material(name: &str, db: &MaterialDb, fallback: &str) -> String {
    let norm: String = name
        .chars()
        .map(|c| {
            let c = c.to_ascii_lowercase();
            if c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_' || c == '.' {
                c
            } else {
                '_'
            }
        })
        .collect();
    let lambertian = norm
        .strip_prefix("lambertian_")
        .and_then(|v| v.parse::<f64>().ok())
        .is_some_and(|v| (0.0..=100.0).contains(&v));
    if !norm.is_empty() && (lambertian || db.id(&norm).is_some()) {
        norm
    } else {
        fallback.to_string()
    }
}

fn load_obj(path: &Path) -> Result<Raw, AssetError> {
    // `..Default::default()` covers fields of optional tobj features another crate may enable.
    #[allow(clippy::needless_update)]
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
        ..Default::default()
    };
    let (models, materials) = tobj::load_obj(path, &opts)
        .map_err(|e| file_error(path, format!("cannot read OBJ: {e}")))?;
    let materials = materials.unwrap_or_default();
    let mut raw = Raw {
        positions: Vec::new(),
        triangles: Vec::new(),
        material: Vec::new(),
        material_names: Vec::new(),
    };
    for model in &models {
        let m = &model.mesh;
        let name = m
            .material_id
            .and_then(|i| materials.get(i))
            .map_or("default", |mat| mat.name.as_str());
        let mi = raw.material_index(name);
        let base = raw.positions.len() as u32;
        raw.positions.extend(
            m.positions
                .chunks_exact(3)
                .map(|c| DVec3::new(f64::from(c[0]), f64::from(c[1]), f64::from(c[2]))),
        );
        let n = (m.positions.len() / 3) as u32;
        for t in m.indices.chunks_exact(3) {
            if t.iter().any(|&i| i >= n) {
                return Err(file_error(
                    path,
                    format!("object `{}`: vertex index out of range", model.name),
                ));
            }
            raw.triangles.push([base + t[0], base + t[1], base + t[2]]);
            raw.material.push(mi);
        }
    }
    Ok(raw)
}

/// Decode standard base64 (with or without padding).
fn base64_decode(s: &str) -> Option<Vec<u8>> {
    let mut out = Vec::with_capacity(s.len() * 3 / 4);
    let (mut acc, mut bits) = (0u32, 0u32);
    for c in s.bytes() {
        let v = match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' | b'-' => 62,
            b'/' | b'_' => 63,
            b'=' => break,
            b' ' | b'\n' | b'\r' | b'\t' => continue,
            _ => return None,
        };
        acc = (acc << 6) | u32::from(v);
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
        }
    }
    Some(out)
}

fn load_gltf(path: &Path) -> Result<Raw, AssetError> {
    use gltf::mesh::Mode;
    let bytes = std::fs::read(path).map_err(|e| file_error(path, format!("cannot read: {e}")))?;
    let g = gltf::Gltf::from_slice(&bytes)
        .map_err(|e| file_error(path, format!("invalid glTF: {e}")))?;
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut buffers: Vec<Vec<u8>> = Vec::new();
    for buffer in g.buffers() {
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => g
                .blob
                .clone()
                .ok_or_else(|| file_error(path, "buffer refers to a missing GLB binary chunk"))?,
            gltf::buffer::Source::Uri(uri) => {
                if let Some(rest) = uri.strip_prefix("data:") {
                    let (_, payload) = rest
                        .split_once(";base64,")
                        .ok_or_else(|| file_error(path, "unsupported data URI (not base64)"))?;
                    base64_decode(payload)
                        .ok_or_else(|| file_error(path, "invalid base64 in a data URI"))?
                } else {
                    let rel = super::percent_decode(uri)
                        .map_err(|m| file_error(path, format!("buffer URI `{uri}`: {m}")))?;
                    let file: PathBuf = dir.join(rel.as_ref());
                    std::fs::read(&file).map_err(|e| {
                        file_error(path, format!("buffer `{}`: {e}", file.display()))
                    })?
                }
            }
        };
        if data.len() < buffer.length() {
            return Err(file_error(
                path,
                format!("buffer {} is shorter than declared", buffer.index()),
            ));
        }
        buffers.push(data);
    }
    let mut raw = Raw {
        positions: Vec::new(),
        triangles: Vec::new(),
        material: Vec::new(),
        material_names: Vec::new(),
    };
    let roots: Vec<gltf::Node<'_>> = match g.default_scene().or_else(|| g.scenes().next()) {
        Some(scene) => scene.nodes().collect(),
        None => {
            let children: std::collections::HashSet<usize> = g
                .nodes()
                .flat_map(|n| n.children().map(|c| c.index()).collect::<Vec<_>>())
                .collect();
            g.nodes()
                .filter(|n| !children.contains(&n.index()))
                .collect()
        }
    };
    let mut stack: Vec<(gltf::Node<'_>, DMat4, usize)> =
        roots.into_iter().map(|n| (n, DMat4::IDENTITY, 0)).collect();
    while let Some((node, parent, depth)) = stack.pop() {
        if depth > 64 {
            return Err(file_error(
                path,
                "node hierarchy deeper than 64 levels (cycle?)",
            ));
        }
        let local = DMat4::from_cols_array_2d(&node.transform().matrix().map(|c| c.map(f64::from)));
        let world = parent * local;
        if let Some(mesh) = node.mesh() {
            let flip = world.determinant() < 0.0;
            for prim in mesh.primitives() {
                let mode = prim.mode();
                if !matches!(
                    mode,
                    Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
                ) {
                    continue;
                }
                let reader = prim.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
                let Some(pos) = reader.read_positions() else {
                    continue;
                };
                let base = raw.positions.len() as u32;
                raw.positions.extend(pos.map(|p| {
                    world.transform_point3(DVec3::new(
                        f64::from(p[0]),
                        f64::from(p[1]),
                        f64::from(p[2]),
                    ))
                }));
                let n = raw.positions.len() as u32 - base;
                let idx: Vec<u32> = match reader.read_indices() {
                    Some(i) => i.into_u32().collect(),
                    None => (0..n).collect(),
                };
                if idx.iter().any(|&i| i >= n) {
                    return Err(file_error(
                        path,
                        format!("mesh {}: index out of range", mesh.index()),
                    ));
                }
                let name = prim.material().name().unwrap_or("default").to_string();
                let mi = raw.material_index(&name);
                let mut push = |a: u32, b: u32, c: u32| {
                    if a != b && b != c && a != c {
                        let t = if flip {
                            [base + a, base + c, base + b]
                        } else {
                            [base + a, base + b, base + c]
                        };
                        raw.triangles.push(t);
                        raw.material.push(mi);
                    }
                };
                match mode {
                    Mode::Triangles => idx.chunks_exact(3).for_each(|t| push(t[0], t[1], t[2])),
                    Mode::TriangleStrip => {
                        for k in 2..idx.len() {
                            if k % 2 == 0 {
                                push(idx[k - 2], idx[k - 1], idx[k]);
                            } else {
                                push(idx[k - 1], idx[k - 2], idx[k]);
                            }
                        }
                    }
                    _ => {
                        for k in 2..idx.len() {
                            push(idx[0], idx[k - 1], idx[k]);
                        }
                    }
                }
            }
        }
        for child in node.children() {
            stack.push((child, world, depth + 1));
        }
    }
    Ok(raw)
}

/// Build the `mesh` asset: resolve the path, load it with the reference's options.
pub(super) fn build(
    asset: &AssetRef,
    dims: Option<DVec3>,
    ctx: &AssetContext<'_>,
) -> Result<Mesh, AssetError> {
    let path = asset.path().ok_or(AssetError::MissingParam {
        asset: "mesh",
        param: "path",
    })?;
    let full = match ctx.base_dir {
        Some(dir) if path.is_relative() => dir.join(path),
        _ => path.to_path_buf(),
    };
    let up = match asset.given("up") {
        Some(super::ParamValue::Text(u)) => Some(if u == "y" { Up::Y } else { Up::Z }),
        _ => None,
    };
    let fit = match asset.text("fit").as_deref() {
        Some("stretch") => Fit::Stretch,
        Some("uniform") => Fit::Uniform,
        Some("none") => Fit::None,
        _ => Fit::Center,
    };
    let opts = UserMeshOptions {
        material: asset
            .text("material")
            .map_or_else(|| "lambertian_50".into(), |m| m.into_owned()),
        up,
        yaw_rad: asset.number("yaw_deg").unwrap_or(0.0).to_radians(),
        scale: asset.number("scale").unwrap_or(1.0),
        fit,
        dimensions: dims.map(|d| asset.target_dimensions(Some(d))),
        materials: ctx.materials,
    };
    load_user_mesh_with(&full, &opts)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64() {
        assert_eq!(base64_decode("aGVsbG8=").unwrap(), b"hello");
        assert_eq!(base64_decode("aGVsbG8").unwrap(), b"hello");
        assert!(base64_decode("a*b").is_none());
    }
}
