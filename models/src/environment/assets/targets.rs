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

/// Whether a target of height `target_z` gets a post in the OSI box `osi` (`mount=auto`).
fn mounted(osi: Option<DVec3>, mount: bool, target_z: f64) -> bool {
    matches!(osi, Some(d) if mount && d.z.is_finite() && d.z > target_z + MOUNT_MARGIN)
}

/// Place a target built around the origin: centred in the box, or at the top of a taller OSI box with
/// a vertical post behind `post_x` (the target's back) down to the box bottom. Returns the
/// translation applied to the target (where its construction origin ends up).
fn place_with_mount(
    b: &mut Builder,
    osi: Option<DVec3>,
    mount: bool,
    post_x: impl Fn(DVec3) -> f64,
    part_mount: impl FnOnce(&mut Builder) -> u16,
) -> DVec3 {
    let Some((lo, hi)) = b.bounds() else {
        return DVec3::ZERO;
    };
    let size = hi - lo;
    match osi {
        Some(d) if mounted(osi, mount, size.z) => {
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
            match b.bounds() {
                Some((l3, h3)) => {
                    let c = DVec3::new((l3.x + h3.x) * 0.5, (l3.y + h3.y) * 0.5, 0.0);
                    b.map_positions(|p| p - c);
                    shift - c
                }
                None => shift,
            }
        }
        _ => {
            b.centre();
            -(lo + hi) * 0.5
        }
    }
}

/// Triangular trihedral: three mutually orthogonal triangular plates with inner edge `edge_m`, the
/// inner corner at the back and the aperture facing +x.
pub(super) fn trihedral(asset: &AssetRef, osi: Option<DVec3>) -> Mesh {
    trihedral_and_apex(asset, osi).0
}

/// Phase centre of the trihedral in the object frame: its apex (inner corner), where every
/// triple-bounce path has the length of the path to the apex and back. With `a` = `edge_m`,
/// `t` = `thickness_m` the reflecting faces span x ∈ [0, a/√3], z ∈ [−a/√6, 2a/√6] and the plates'
/// backs reach `t/√3` behind the apex, `(2a + t)/√6` above and `(a + 2t)/√6` below it, so:
/// * centred in the box: apex = (−(a − t)/(2√3), 0, −(a − t)/(2√6));
/// * on a post (OSI height `h` > `3(a + t)/√6` + 5 cm): the target's top at the box top and the
///   target + post (radius `r` = 2 cm, its front `t` behind the apex) centred in x:
///   apex = ((t + 2r − a/√3)/2, 0, h/2 − (2a + t)/√6).
pub(super) fn trihedral_apex(asset: &AssetRef, osi: Option<DVec3>) -> DVec3 {
    let a = asset.number("edge_m").unwrap_or(0.1);
    let t = asset.number("thickness_m").unwrap_or(0.002);
    let mount = asset.text("mount").as_deref() != Some("none");
    let (s3, s6) = (3f64.sqrt(), 6f64.sqrt());
    match osi {
        Some(d) if mounted(osi, mount, 3.0 * (a + t) / s6) => DVec3::new(
            0.5 * (t + 2.0 * POST_RADIUS - a / s3),
            0.0,
            0.5 * d.z - (2.0 * a + t) / s6,
        ),
        _ => DVec3::new(-(a - t) / (2.0 * s3), 0.0, -(a - t) / (2.0 * s6)),
    }
}

/// The trihedral's mesh and where its apex (the construction origin) ends up.
fn trihedral_and_apex(asset: &AssetRef, osi: Option<DVec3>) -> (Mesh, DVec3) {
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
    let apex = place_with_mount(
        &mut b,
        osi,
        mount,
        |shift| shift.x - t,
        |b| b.part("mount", "steel"),
    );
    (b.into_mesh(), apex)
}

/// The board's face width, height and thickness (parameter, else OSI dimension, else default).
fn board_size(asset: &AssetRef, osi: Option<DVec3>) -> (f64, f64, f64) {
    let osi_axis = |i: usize| osi.map(|d| d[i]).filter(|v| v.is_finite() && *v > 0.0);
    let w = given(asset, "width_m").or(osi_axis(1)).unwrap_or(1.0);
    let h = given(asset, "height_m").or(osi_axis(2)).unwrap_or(1.0);
    let t = given(asset, "thickness_m").or(osi_axis(0)).unwrap_or(0.01);
    (w, h, t)
}

/// Reference point of the board in the object frame: the centre of its face, the phase centre of
/// its specular return in the far field (R > 2D²/λ, D the face diagonal). With face height `h`,
/// thickness `t`: centred in the box (t/2, 0, 0); on a post (OSI height `H` > h + 5 cm, post radius
/// `r` = 2 cm behind the board) (t/2 + r, 0, H/2 − h/2).
pub(super) fn board_face_centre(asset: &AssetRef, osi: Option<DVec3>) -> DVec3 {
    let (_, h, t) = board_size(asset, osi);
    let mount = asset.text("mount").as_deref() != Some("none");
    match osi {
        Some(d) if mounted(osi, mount, h) => {
            DVec3::new(0.5 * t + POST_RADIUS, 0.0, 0.5 * d.z - 0.5 * h)
        }
        _ => DVec3::new(0.5 * t, 0.0, 0.0),
    }
}

/// Flat board: face (+x) `width × height`, thickness behind it; a zero thickness gives one open
/// rectangle facing +x.
pub(super) fn board(asset: &AssetRef, osi: Option<DVec3>) -> Mesh {
    board_and_face_centre(asset, osi).0
}

/// The board's mesh and where its face centre ends up.
fn board_and_face_centre(asset: &AssetRef, osi: Option<DVec3>) -> (Mesh, DVec3) {
    let (w, h, t) = board_size(asset, osi);
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
    let shift = place_with_mount(
        &mut b,
        osi,
        mount,
        |shift| shift.x - 0.5 * t,
        |b| b.part("mount", "steel"),
    );
    (b.into_mesh(), shift + DVec3::new(0.5 * t, 0.0, 0.0))
}

/// Closed box filling the OSI box.
pub(super) fn solid_box(asset: &AssetRef, d: DVec3) -> Mesh {
    let m = material(asset, "material");
    let mut b = Builder::new();
    let part = b.part("box", &m);
    b.cuboid(-0.5 * d, 0.5 * d, part);
    b.into_mesh()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The closed forms of the phase centres are where the mesh construction puts the apex / face
    /// centre, centred and on a post, and the apex is the corner of the reflecting faces.
    #[test]
    fn phase_centres_match_the_meshes() {
        let boxes = [
            None,
            Some(DVec3::new(0.09, 0.15, 0.15)),
            Some(DVec3::new(0.2, 0.2, 1.0)),
            Some(DVec3::new(0.0, f64::NAN, 2.5)),
        ];
        for r in [
            "osiris:trihedral",
            "osiris:trihedral?edge_m=0.3&thickness_m=0.01",
            "osiris:trihedral?edge_m=0.3&mount=none",
        ] {
            let asset = AssetRef::parse(r).unwrap();
            for osi in boxes {
                let (mesh, tracked) = trihedral_and_apex(&asset, osi);
                let apex = trihedral_apex(&asset, osi);
                assert!(
                    apex.distance(tracked) < 1e-12,
                    "{r} {osi:?}: {apex} vs {tracked}"
                );
                // The apex is a mesh vertex where the three reflecting faces meet.
                let at_apex = mesh
                    .positions
                    .iter()
                    .filter(|p| p.as_dvec3().distance(apex) < 1e-6)
                    .count();
                assert!(at_apex >= 3, "{r} {osi:?}: {at_apex} vertices at the apex");
            }
        }
        for r in [
            "osiris:board",
            "osiris:board?width_m=0.5&height_m=0.5&thickness_m=0",
            "osiris:board?height_m=0.4&thickness_m=0.03&mount=none",
        ] {
            let asset = AssetRef::parse(r).unwrap();
            for osi in boxes {
                let (_, tracked) = board_and_face_centre(&asset, osi);
                let c = board_face_centre(&asset, osi);
                assert!(c.distance(tracked) < 1e-12, "{r} {osi:?}: {c} vs {tracked}");
            }
        }
        // The documented closed form for the tip-up trihedral centred in its box.
        let a = 0.1;
        let apex = trihedral_apex(
            &AssetRef::parse("osiris:trihedral?edge_m=0.1&thickness_m=0.0005").unwrap(),
            Some(DVec3::splat(0.15)),
        );
        let t = 0.0005;
        let expected = DVec3::new(
            -(a - t) / (2.0 * 3f64.sqrt()),
            0.0,
            -(a - t) * (2.0f64 / 3.0).sqrt() / 4.0,
        );
        assert!(apex.distance(expected) < 1e-12);
    }
}
