//! Test targets: trihedral corner reflector, flat board, generic box.

use glam::{DVec2, DVec3};

use super::geometry::{Builder, Face};
use super::vehicles::material;
use super::{AssetRef, ParamValue};
use crate::environment::mesh::Mesh;

/// Mounting-post radius, m.
const POST_RADIUS: f64 = 0.02;
/// A box taller than the target by more than this gets a post (`mount=auto`), m.
const MOUNT_MARGIN: f64 = 0.05;

/// Axes of the trihedral's corner frame in the asset frame: `(u, v, w)`, right-handed, each at
/// `acos(1/√3)` from +x, so `u + v + w = √3·x̂` (the boresight); `w` is the inner edge in the x–z plane
/// pointing up, `u` and `v` point down to the right and left.
pub fn trihedral_axes() -> [DVec3; 3] {
    let (s2, s3, s6) = (2f64.sqrt(), 3f64.sqrt(), 6f64.sqrt());
    [
        DVec3::new(1.0 / s3, -1.0 / s2, -1.0 / s6),
        DVec3::new(1.0 / s3, 1.0 / s2, -1.0 / s6),
        DVec3::new(1.0 / s3, 0.0, 2.0 / s6),
    ]
}

fn given(asset: &AssetRef, key: &str) -> Option<f64> {
    match asset.given(key) {
        Some(ParamValue::Number(v)) => Some(*v),
        _ => None,
    }
}

/// Place a target built around the origin: centred in the box, or at the top of a taller OSI box with
/// a vertical post behind `post_x` (the target's back) down to the box bottom.
fn place_with_mount(
    b: &mut Builder,
    osi: Option<DVec3>,
    mount: bool,
    post_x: impl Fn(DVec3) -> f64,
    part_mount: impl FnOnce(&mut Builder) -> u16,
) {
    let Some((lo, hi)) = b.bounds() else { return };
    let size = hi - lo;
    match osi {
        Some(d) if mount && d.z.is_finite() && d.z > size.z + MOUNT_MARGIN => {
            // Top of the target at the box top.
            let shift = DVec3::new(-(lo.x + hi.x) * 0.5, -(lo.y + hi.y) * 0.5, 0.5 * d.z - hi.z);
            b.map_positions(|p| p + shift);
            let (lo2, _) = b.bounds().unwrap_or((lo, hi));
            let x = post_x(shift) - POST_RADIUS;
            let top = (lo2.z + 0.5 * size.z).min(0.5 * d.z);
            let part = part_mount(b);
            b.cylinder(
                DVec3::new(x, 0.0, -0.5 * d.z),
                DVec3::new(x, 0.0, top),
                POST_RADIUS,
                12,
                part,
            );
            // Centre the whole (target + post) in x and y.
            if let Some((l3, h3)) = b.bounds() {
                let c = DVec3::new((l3.x + h3.x) * 0.5, (l3.y + h3.y) * 0.5, 0.0);
                b.map_positions(|p| p - c);
            }
        }
        _ => b.centre(),
    }
}

/// Triangular trihedral: three mutually orthogonal triangular plates with inner edge `edge_m`, the
/// inner corner at the back and the aperture facing +x.
pub(super) fn trihedral(asset: &AssetRef, osi: Option<DVec3>) -> Mesh {
    let a = asset.number("edge_m").unwrap_or(0.1);
    let t = asset.number("thickness_m").unwrap_or(0.002);
    let m = material(asset, "material");
    let mount = asset.text("mount").as_deref() != Some("none");
    let mut b = Builder::new();
    let plates = b.part("plates", &m);
    let [u, v, w] = trihedral_axes();
    let tri = [DVec2::ZERO, DVec2::new(a, 0.0), DVec2::new(0.0, a)];
    // Plate spanned by (e1, e2); its reflecting face lies in the plane through the corner, the
    // thickness extends behind it (along −e1 × e2).
    for (e1, e2) in [(u, v), (v, w), (w, u)] {
        b.prism(&tri, DVec3::ZERO, e1, e2, &[-t, 0.0], plates);
    }
    // The corner (the origin before placement) is the back-most point of the reflecting faces; the
    // plates' backs reach t/√3 further back. The post stands behind that.
    place_with_mount(
        &mut b,
        osi,
        mount,
        |shift| shift.x - t,
        |b| b.part("mount", "steel"),
    );
    b.into_mesh()
}

/// Flat board: face (+x) `width × height`, thickness behind it; a zero thickness gives one open
/// rectangle facing +x.
pub(super) fn board(asset: &AssetRef, osi: Option<DVec3>) -> Mesh {
    let osi_axis = |i: usize| osi.map(|d| d[i]).filter(|v| v.is_finite() && *v > 0.0);
    let w = given(asset, "width_m").or(osi_axis(1)).unwrap_or(1.0);
    let h = given(asset, "height_m").or(osi_axis(2)).unwrap_or(1.0);
    let t = given(asset, "thickness_m").or(osi_axis(0)).unwrap_or(0.01);
    let face_material = material(asset, "material");
    let back_material = match asset.given("back") {
        Some(ParamValue::Text(s)) => s.clone(),
        _ => face_material.clone(),
    };
    let mount = asset.text("mount").as_deref() != Some("none");
    let mut b = Builder::new();
    let face = b.part("face", &face_material);
    if t > 0.0 {
        let back = b.part("back", &back_material);
        let c = std::array::from_fn(|i| {
            DVec3::new(
                if i & 4 != 0 { 0.5 * t } else { -0.5 * t },
                if i & 2 != 0 { 0.5 * w } else { -0.5 * w },
                if i & 1 != 0 { 0.5 * h } else { -0.5 * h },
            )
        });
        b.hexahedron(
            c,
            [
                Face::Plain,
                Face::Part(face),
                Face::Plain,
                Face::Plain,
                Face::Plain,
                Face::Plain,
            ],
            back,
        );
    } else {
        let q = [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)]
            .map(|(y, z)| b.vertex(DVec3::new(0.0, y * w, z * h)));
        b.quad(q[0], q[1], q[2], q[3], face);
    }
    place_with_mount(
        &mut b,
        osi,
        mount,
        |shift| shift.x - 0.5 * t,
        |b| b.part("mount", "steel"),
    );
    b.into_mesh()
}

/// Closed box filling the OSI box.
pub(super) fn solid_box(asset: &AssetRef, d: DVec3) -> Mesh {
    let m = material(asset, "material");
    let mut b = Builder::new();
    let part = b.part("box", &m);
    b.cuboid(-0.5 * d, 0.5 * d, part);
    b.into_mesh()
}
