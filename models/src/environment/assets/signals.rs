//! Traffic-sign plates, sign posts, traffic-signal lenses and housings: the geometry the scene builds
//! from OSI `TrafficSign` and `TrafficLight` messages (`super::super::traffic`). They are not
//! `model_reference` assets: OSI gives their size and kind, and the scene places them.
//!
//! Frames follow the asset convention (`super`): origin at the OSI box centre, +x the facing
//! direction (a sign's view normal, a signal's optical axis: OSI's `base.orientation` x-axis for
//! signs and lights), +y left, +z up (the plate's "top"); metres; counter-clockwise triangles seen
//! from outside.
//!
//! * **Sign plate** ([`sign_plate`]): a closed prism of the plate outline ([`SignShape::outline`],
//!   fitted to OSI width × height) and thickness `t` (centred on x = 0). The front cap (x = +t/2) is
//!   part [`SIGN_FACE_PART`] (the retroreflective sheeting), the back cap and the rim part
//!   [`SIGN_BODY_PART`] (aluminium).
//! * **Sign post** ([`sign_post`]): a closed vertical cylinder (16 sides), part [`SIGN_POST_PART`],
//!   material `steel`.
//! * **Signal lens** ([`signal_lens`]): a flat disc (32 sides) in the plane x = 0 facing +x, part
//!   [`SIGNAL_LENS_PART`], material `signal_lens_off` (the renderer makes lit lenses emit); open
//!   surface, closed behind by the housing.
//! * **Signal housing** ([`signal_housing`]): a box behind the lenses, part [`SIGNAL_HOUSING_PART`],
//!   material `plastic_black`.

use glam::{DVec2, DVec3};

use super::geometry::{Builder, ear_clip, polygon_area};
use crate::environment::mesh::Mesh;

/// Part of a sign plate's front face (material: the sheeting).
pub const SIGN_FACE_PART: &str = "sign_face";
/// Part of a sign plate's back and rim.
pub const SIGN_BODY_PART: &str = "sign_plate";
/// Part of a sign post.
pub const SIGN_POST_PART: &str = "sign_post";
/// Part of a traffic-signal lens (the renderer finds lit lenses by this part name).
pub const SIGNAL_LENS_PART: &str = "signal_lens";
/// Part of a traffic-signal housing.
pub const SIGNAL_HOUSING_PART: &str = "signal_housing";

/// Material of sign backs and rims.
pub const SIGN_BODY_MATERIAL: &str = "aluminium";
/// Material of sign posts.
pub const SIGN_POST_MATERIAL: &str = "steel";
/// Material of unlit signal lenses.
pub const SIGNAL_LENS_MATERIAL: &str = "signal_lens_off";
/// Material of signal housings.
pub const SIGNAL_HOUSING_MATERIAL: &str = "plastic_black";

/// Segments of a lens disc (its area is `(N/2) sin(2π/N)` of the circle's: 0.6 % less for 32).
pub const LENS_SEGMENTS: usize = 32;

/// Outline of a sign plate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SignShape {
    /// Ellipse filling width × height (round signs: prohibitions, mandatory signs, speed limits).
    Circle,
    /// Triangle, apex up (warning signs).
    Triangle,
    /// Triangle, apex down (give way).
    InvertedTriangle,
    /// Regular octagon stretched to width × height (stop).
    Octagon,
    /// Square standing on a corner (priority road).
    Diamond,
    /// Rectangle (information, direction, supplementary signs).
    Rectangle,
}

impl SignShape {
    /// The outline in the plate's (y, z) plane, counter-clockwise seen from +x, centred, spanning
    /// exactly `width_m` × `height_m`.
    pub fn outline(self, width_m: f64, height_m: f64) -> Vec<DVec2> {
        let (a, b) = (0.5 * width_m, 0.5 * height_m);
        match self {
            SignShape::Circle => (0..32)
                .map(|k| {
                    let p = 2.0 * std::f64::consts::PI * k as f64 / 32.0;
                    DVec2::new(a * p.cos(), b * p.sin())
                })
                .collect(),
            SignShape::Triangle => vec![DVec2::new(-a, -b), DVec2::new(a, -b), DVec2::new(0.0, b)],
            SignShape::InvertedTriangle => {
                vec![DVec2::new(a, b), DVec2::new(-a, b), DVec2::new(0.0, -b)]
            }
            SignShape::Octagon => {
                // Corners at 22.5° + k·45° of a regular octagon, scaled to the box.
                let r = 1.0 / (std::f64::consts::PI / 8.0).cos();
                (0..8)
                    .map(|k| {
                        let p = std::f64::consts::PI / 8.0 + k as f64 * std::f64::consts::PI / 4.0;
                        DVec2::new(a * r * p.cos(), b * r * p.sin())
                    })
                    .collect()
            }
            SignShape::Diamond => vec![
                DVec2::new(0.0, -b),
                DVec2::new(a, 0.0),
                DVec2::new(0.0, b),
                DVec2::new(-a, 0.0),
            ],
            SignShape::Rectangle => vec![
                DVec2::new(-a, -b),
                DVec2::new(a, -b),
                DVec2::new(a, b),
                DVec2::new(-a, b),
            ],
        }
    }

    /// Area of the outline at `width_m` × `height_m`, m².
    pub fn area_m2(self, width_m: f64, height_m: f64) -> f64 {
        polygon_area(&self.outline(width_m, height_m)).abs()
    }
}

/// A sign plate (see the module docs): outline `shape` at `width_m` × `height_m` in the (y, z)
/// plane, thickness `thickness_m` along x, face material `face_material`.
pub fn sign_plate(
    shape: SignShape,
    width_m: f64,
    height_m: f64,
    thickness_m: f64,
    face_material: &str,
) -> Mesh {
    let mut b = Builder::new();
    let face = b.part(SIGN_FACE_PART, face_material);
    let body = b.part(SIGN_BODY_PART, SIGN_BODY_MATERIAL);
    let mut poly = shape.outline(width_m, height_m);
    if polygon_area(&poly) < 0.0 {
        poly.reverse();
    }
    let h = 0.5 * thickness_m;
    let at = |q: DVec2, x: f64| DVec3::new(x, q.x, q.y);
    let front: Vec<u32> = poly.iter().map(|&q| b.vertex(at(q, h))).collect();
    let back: Vec<u32> = poly.iter().map(|&q| b.vertex(at(q, -h))).collect();
    // (y, z) counter-clockwise seen from +x: the front cap keeps the order, the back reverses it.
    for [i, j, k] in ear_clip(&poly) {
        b.tri(front[i], front[j], front[k], face);
        b.tri(back[i], back[k], back[j], body);
    }
    let n = poly.len();
    for i in 0..n {
        let i1 = (i + 1) % n;
        // Rim quad: outward normal = edge × (+x) for a counter-clockwise (y, z) outline.
        b.quad(back[i], back[i1], front[i1], front[i], body);
    }
    b.into_mesh()
}

/// A vertical sign post: a closed cylinder of diameter `diameter_m` from `bottom` to `top` (object
/// frame).
pub fn sign_post(bottom: DVec3, top: DVec3, diameter_m: f64) -> Mesh {
    let mut b = Builder::new();
    let part = b.part(SIGN_POST_PART, SIGN_POST_MATERIAL);
    b.cylinder(bottom, top, 0.5 * diameter_m, 16, part);
    b.into_mesh()
}

/// A signal lens: a disc of diameter `diameter_m` in the plane x = 0, facing +x (open surface).
pub fn signal_lens(diameter_m: f64) -> Mesh {
    let mut b = Builder::new();
    let part = b.part(SIGNAL_LENS_PART, SIGNAL_LENS_MATERIAL);
    let r = 0.5 * diameter_m;
    let c = b.vertex(DVec3::ZERO);
    let ring: Vec<u32> = (0..LENS_SEGMENTS)
        .map(|k| {
            let p = 2.0 * std::f64::consts::PI * k as f64 / LENS_SEGMENTS as f64;
            b.vertex(DVec3::new(0.0, r * p.cos(), r * p.sin()))
        })
        .collect();
    for k in 0..LENS_SEGMENTS {
        // (y, z) counter-clockwise seen from +x: normal +x.
        b.tri(c, ring[k], ring[(k + 1) % LENS_SEGMENTS], part);
    }
    b.into_mesh()
}

/// A signal housing: the box `lo..hi` (object frame).
pub fn signal_housing(lo: DVec3, hi: DVec3) -> Mesh {
    let mut b = Builder::new();
    let part = b.part(SIGNAL_HOUSING_PART, SIGNAL_HOUSING_MATERIAL);
    b.cuboid(lo, hi, part);
    b.into_mesh()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::environment::assets::geometry::{
        is_closed, part_area, signed_volume, triangle_normal,
    };

    #[test]
    fn plates_are_closed_and_face_forward() {
        for shape in [
            SignShape::Circle,
            SignShape::Triangle,
            SignShape::InvertedTriangle,
            SignShape::Octagon,
            SignShape::Diamond,
            SignShape::Rectangle,
        ] {
            let m = sign_plate(shape, 0.84, 0.6, 0.002, "sign_sheeting_ra2_white");
            assert!(is_closed(&m), "{shape:?}");
            let area = shape.area_m2(0.84, 0.6);
            assert!((signed_volume(&m) - area * 0.002).abs() < 1e-6, "{shape:?}");
            assert!((part_area(&m, SIGN_FACE_PART) - area).abs() < 1e-6);
            for t in 0..m.triangle_count() {
                if m.parts[m.triangle_part[t] as usize].name == SIGN_FACE_PART {
                    assert!(triangle_normal(&m, t).x > 0.999);
                }
            }
        }
        // Closed forms of the areas: ellipse π a b (32-gon: (32/2) sin(2π/32) a b), triangle
        // w h / 2, diamond w h / 2, octagon 2√2 r² scaled: 8 tan(π/8) a b.
        let (w, h) = (0.8f64, 0.6f64);
        let (a, b) = (w / 2.0, h / 2.0);
        let poly32 = 16.0 * (2.0 * std::f64::consts::PI / 32.0).sin() * a * b;
        assert!((SignShape::Circle.area_m2(w, h) - poly32).abs() < 1e-12);
        assert!((SignShape::Triangle.area_m2(w, h) - w * h / 2.0).abs() < 1e-12);
        assert!((SignShape::Diamond.area_m2(w, h) - w * h / 2.0).abs() < 1e-12);
        let oct = 8.0 * (std::f64::consts::PI / 8.0).tan() * a * b;
        assert!((SignShape::Octagon.area_m2(w, h) - oct).abs() < 1e-12);
    }

    #[test]
    fn lens_faces_forward() {
        let m = signal_lens(0.2);
        for t in 0..m.triangle_count() {
            assert!(triangle_normal(&m, t).x > 0.999);
        }
        let want = 16.0 * (2.0 * std::f64::consts::PI / 32.0).sin() * 0.01;
        assert!((part_area(&m, SIGNAL_LENS_PART) - want).abs() < 1e-6);
    }
}
