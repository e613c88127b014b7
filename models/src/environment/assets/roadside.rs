//! Road furniture: guardrail, pole, traffic cone.
//!
//! Guardrail: a W-beam rail (the AASHTO M180 / EN 1317 "A-profile" family: ≈ 311 mm (12¼ in) tall,
//! 83 mm (3¼ in) deep, ≈ 3 mm steel), approximated by a folded strip of that section swept along the
//! length, on posts with spacers. Posts every `post_spacing_m` (default 2 m; US strong-post W-beam
//! uses 6 ft 3 in = 1.905 m, FHWA W-beam guardrail guide). The beam's top edge is the top of the OSI
//! box (German guardrails: 0.75 m).

use glam::{DVec2, DVec3};

use super::AssetRef;
use super::geometry::Builder;
use super::vehicles::material;
use crate::environment::mesh::Mesh;

/// W-beam section as (depth behind the front plane, depth below the top edge), m: top flange, upper
/// peak, central valley, lower peak, bottom flange.
const W_BEAM: [(f64, f64); 10] = [
    (0.075, 0.0),
    (0.06, 0.02),
    (0.0, 0.07),
    (0.0, 0.10),
    (0.083, 0.14),
    (0.083, 0.171),
    (0.0, 0.211),
    (0.0, 0.241),
    (0.06, 0.291),
    (0.075, 0.311),
];
/// Steel thickness of the beam, m.
const BEAM_THICKNESS: f64 = 0.003;

/// Guardrail along x; the beam faces +y (`face=left`), −y (`right`) or both sides (`both`).
pub(super) fn guardrail(asset: &AssetRef, d: DVec3) -> Mesh {
    let m = material(asset, "material");
    let spacing = asset.number("post_spacing_m").unwrap_or(2.0);
    let face = asset
        .text("face")
        .map(|c| c.into_owned())
        .unwrap_or_else(|| "left".into());
    let (l, w, h) = (d.x, d.y, d.z);
    // Nominal cross-section (fitted to the box at the end).
    let wn = w.max(0.25);
    let hn = h.max(0.4);
    let top = 0.5 * hn;
    let mut b = Builder::new();
    let beam = b.part("beam", &m);
    let posts = b.part("posts", &m);
    let steps = (l / (0.5 * spacing)).ceil().max(1.0) as usize;
    let stations: Vec<f64> = (0..=steps)
        .map(|i| -0.5 * l + l * i as f64 / steps as f64)
        .collect();
    let post_depth = 0.1_f64.min(0.35 * wn);
    let post_width = 0.1_f64.min(0.5 * spacing);
    let n_posts = (l / spacing).round().max(1.0) as usize;
    let post_x: Vec<f64> = (0..n_posts)
        .map(|k| -0.5 * l + (k as f64 + 0.5) * l / n_posts as f64)
        .collect();
    let beam_depth = W_BEAM[4].0 + BEAM_THICKNESS;

    // One side: beam with its front plane at y = sign·wn/2, spacers back to the post face at `post_y`.
    let side = |b: &mut Builder, sign: f64, post_y: f64| {
        let y_front = sign * 0.5 * wn;
        let mut poly: Vec<DVec2> = W_BEAM
            .iter()
            .map(|&(dd, zt)| DVec2::new(y_front - sign * dd, top - zt))
            .collect();
        poly.extend(
            W_BEAM
                .iter()
                .rev()
                .map(|&(dd, zt)| DVec2::new(y_front - sign * (dd + BEAM_THICKNESS), top - zt)),
        );
        b.prism(&poly, DVec3::ZERO, DVec3::Y, DVec3::Z, &stations, beam);
        let beam_back = y_front - sign * (beam_depth - 0.002);
        if (beam_back - post_y) * sign > 0.0 {
            for &x in &post_x {
                let (y0, y1) = if sign > 0.0 {
                    (post_y, beam_back)
                } else {
                    (beam_back, post_y)
                };
                b.cuboid(
                    DVec3::new(x - 0.04, y0, top - 0.2),
                    DVec3::new(x + 0.04, y1, top - 0.11),
                    posts,
                );
            }
        }
    };
    let post_range = match face.as_str() {
        "both" => (-0.5 * post_depth, 0.5 * post_depth),
        _ => (-0.5 * wn, -0.5 * wn + post_depth),
    };
    for &x in &post_x {
        b.cuboid(
            DVec3::new(x - 0.5 * post_width, post_range.0, -0.5 * hn),
            DVec3::new(x + 0.5 * post_width, post_range.1, top - 0.03),
            posts,
        );
    }
    match face.as_str() {
        "both" => {
            side(&mut b, 1.0, post_range.1);
            side(&mut b, -1.0, post_range.0);
        }
        _ => side(&mut b, 1.0, post_range.1),
    }
    if face == "right" {
        b.map_positions(|p| DVec3::new(p.x, -p.y, p.z));
        b.flip_all();
    }
    b.fit(d);
    b.into_mesh()
}

/// Vertical cylindrical pole filling the box.
pub(super) fn pole(asset: &AssetRef, d: DVec3) -> Mesh {
    let m = material(asset, "material");
    let segments = asset.number("segments").unwrap_or(16.0) as usize;
    let mut b = Builder::new();
    let part = b.part("pole", &m);
    let r = 0.5 * d.x.min(d.y);
    b.cylinder(
        DVec3::new(0.0, 0.0, -0.5 * d.z),
        DVec3::new(0.0, 0.0, 0.5 * d.z),
        r,
        segments,
        part,
    );
    b.fit(d);
    b.into_mesh()
}

/// Traffic cone: square base plate, conical body, retroreflective sleeve band(s).
pub(super) fn cone(asset: &AssetRef, d: DVec3) -> Mesh {
    let m = material(asset, "material");
    let bands = asset
        .number("bands")
        .map_or(if d.z < 0.6 { 1 } else { 2 }, |n| n as usize);
    let mut b = Builder::new();
    let base = b.part("base", "plastic_black");
    let body = b.part("body", &m);
    let band = b.part("bands", "retroreflective_sheeting");
    let side = d.x.min(d.y);
    let h = d.z;
    let hb = 0.07 * h;
    b.cuboid(
        DVec3::new(-0.5 * side, -0.5 * side, -0.5 * h),
        DVec3::new(0.5 * side, 0.5 * side, -0.5 * h + hb),
        base,
    );
    let (r0, r1) = (0.43 * side, 0.08 * side);
    let (z0, z1) = (-0.5 * h + hb - 0.002, 0.5 * h);
    b.frustum(
        DVec3::new(0.0, 0.0, z0),
        DVec2::splat(r0),
        DVec3::new(0.0, 0.0, z1),
        DVec2::splat(r1),
        16,
        body,
    );
    let ranges: &[(f64, f64)] = match bands {
        0 => &[],
        1 => &[(0.55, 0.75)],
        2 => &[(0.40, 0.52), (0.65, 0.77)],
        _ => &[(0.30, 0.40), (0.50, 0.60), (0.70, 0.80)],
    };
    let radius = |f: f64| r0 + (r1 - r0) * f + 0.003;
    let z = |f: f64| z0 + (z1 - z0) * f;
    for &(f0, f1) in ranges {
        b.frustum(
            DVec3::new(0.0, 0.0, z(f0)),
            DVec2::splat(radius(f0)),
            DVec3::new(0.0, 0.0, z(f1)),
            DVec2::splat(radius(f1)),
            16,
            band,
        );
    }
    b.fit(d);
    b.into_mesh()
}
