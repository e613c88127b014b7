//! Vehicles: car (saloon), van, truck, bus.
//!
//! Built directly at the target size: proportions are fractions of the box (length `L` along x,
//! width `W` along y, height `H` along z, ground at `z = −H/2`), a few items have physical sizes
//! (licence plates 520 × 110 mm as in the German FZV Anlage 4 / EU format, clamped to the vehicle).
//! Licence plates are retroreflective: German plates must be reflective to DIN 74069 (FZV § 10 (2));
//! other EU states require retroreflective plates likewise. The final mesh is fitted exactly to the
//! box ([`Builder::fit`]).

use glam::{DVec2, DVec3};

use super::AssetRef;
use super::geometry::{Builder, Face};
use crate::environment::mesh::Mesh;

/// Plate size (width, height), m: the 520 × 110 mm EU format.
const PLATE: (f64, f64) = (0.52, 0.11);
/// Facets around a wheel.
const WHEEL_SEGMENTS: usize = 16;

pub(super) fn material(asset: &AssetRef, key: &str) -> String {
    asset
        .text(key)
        .map(|c| c.into_owned())
        .unwrap_or_else(|| "lambertian_50".into())
}

/// Maps box fractions to coordinates: x ∈ [−½, ½]·L, y ∈ [−½, ½]·W, z ∈ [0, 1] above the ground.
#[derive(Clone, Copy)]
struct Frac {
    d: DVec3,
}

impl Frac {
    fn p(&self, fx: f64, fy: f64, fz: f64) -> DVec3 {
        DVec3::new(fx * self.d.x, fy * self.d.y, (fz - 0.5) * self.d.z)
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum CarShape {
    Saloon,
    Van,
}

/// Common vehicle parts.
struct VehicleParts {
    body: u16,
    glass: u16,
    interior: u16,
    wheels: u16,
    bumpers: u16,
    head: u16,
    tail: u16,
    plate: u16,
}

fn vehicle_parts(b: &mut Builder, body_name: &str, paint: &str) -> VehicleParts {
    VehicleParts {
        body: b.part(body_name, paint),
        glass: b.part("glass", "glass"),
        interior: b.part("interior", "plastic_black"),
        wheels: b.part("wheels", "rubber"),
        bumpers: b.part("bumpers", "plastic_black"),
        head: b.part("head_lamps", "polycarbonate"),
        tail: b.part("tail_lamps", "polycarbonate"),
        plate: b.part("licence_plates", "retroreflective_sheeting"),
    }
}

/// A pair of wheels (left and right) on an axle at `x`, radius `r`, tyre width `w`, outer faces at
/// `±W/2`, touching the ground.
fn axle(b: &mut Builder, d: DVec3, x: f64, r: f64, w: f64, part: u16) {
    let zc = -0.5 * d.z + r;
    for s in [-1.0, 1.0] {
        let outer = s * 0.5 * d.y;
        let inner = s * (0.5 * d.y - w);
        b.cylinder(
            DVec3::new(x, inner, zc),
            DVec3::new(x, outer, zc),
            r,
            WHEEL_SEGMENTS,
            part,
        );
    }
}

/// A pair of lamps (boxes) mirrored in y: x range, |y| range, z range (absolute coordinates).
fn lamp_pair(b: &mut Builder, x: (f64, f64), y: (f64, f64), z: (f64, f64), part: u16) {
    for s in [-1.0, 1.0] {
        let (y0, y1) = if s > 0.0 { (y.0, y.1) } else { (-y.1, -y.0) };
        b.cuboid(DVec3::new(x.0, y0, z.0), DVec3::new(x.1, y1, z.1), part);
    }
}

/// A licence plate: a box `x0..x1` (its outer face is the plate), centred at `(0, zc)`.
fn plate(b: &mut Builder, d: DVec3, x: (f64, f64), zc: f64, part: u16) {
    let w = PLATE.0.min(0.6 * d.y);
    let h = PLATE.1.min(0.1 * d.z);
    b.cuboid(
        DVec3::new(x.0, -0.5 * w, zc - 0.5 * h),
        DVec3::new(x.1, 0.5 * w, zc + 0.5 * h),
        part,
    );
}

/// The window faces of a greenhouse hexahedron: rear, windscreen, right and left side.
fn greenhouse_faces(
    glass: u16,
    rear: ((f64, f64), (f64, f64)),
    front: ((f64, f64), (f64, f64)),
    side: ((f64, f64), (f64, f64)),
) -> [Face; 6] {
    let inset = |(u, v): ((f64, f64), (f64, f64))| Face::Inset { u, v, part: glass };
    // −y: u towards +x; +y: u towards −x (mirror the u range).
    let (su, sv) = side;
    [
        inset(rear),
        inset(front),
        inset((su, sv)),
        inset(((1.0 - su.1, 1.0 - su.0), sv)),
        Face::Plain,
        Face::Plain,
    ]
}

/// Corners of a hexahedron from its bottom and top rectangles: x ranges (back, front), half widths,
/// z levels (absolute).
fn hexa(
    bottom_x: (f64, f64),
    bottom_hw: f64,
    z0: f64,
    top_x: (f64, f64),
    top_hw: f64,
    z1: f64,
) -> [DVec3; 8] {
    std::array::from_fn(|i| {
        let top = i & 1 != 0;
        let left = i & 2 != 0;
        let front = i & 4 != 0;
        let (xr, hw, z) = if top {
            (top_x, top_hw, z1)
        } else {
            (bottom_x, bottom_hw, z0)
        };
        DVec3::new(
            if front { xr.1 } else { xr.0 },
            if left { hw } else { -hw },
            z,
        )
    })
}

/// The hexahedron shrunk towards its centroid (an interior block that stays inside it).
fn shrink(c: [DVec3; 8], k: f64) -> [DVec3; 8] {
    let m = c.iter().copied().sum::<DVec3>() / 8.0;
    c.map(|p| m + (p - m) * k)
}

/// Car (saloon) or van.
pub(super) fn car(asset: &AssetRef, d: DVec3, shape: CarShape) -> Mesh {
    let paint = material(asset, "paint");
    let mut b = Builder::new();
    let p = vehicle_parts(&mut b, "body", &paint);
    let f = Frac { d };
    let (l, w, h) = (d.x, d.y, d.z);

    // Lower body: side profile (x/L, z/H above ground) extruded across the width.
    let profile: &[(f64, f64)] = match shape {
        CarShape::Saloon => &[
            (-0.49, 0.12),
            (0.49, 0.12),
            (0.49, 0.30),
            (0.46, 0.45),
            (0.12, 0.53),
            (-0.38, 0.53),
            (-0.48, 0.47),
            (-0.49, 0.30),
        ],
        CarShape::Van => &[
            (-0.49, 0.12),
            (0.49, 0.12),
            (0.49, 0.30),
            (0.45, 0.47),
            (0.30, 0.53),
            (-0.49, 0.53),
        ],
    };
    let prof: Vec<DVec2> = profile
        .iter()
        .map(|&(x, z)| DVec2::new(x * l, (z - 0.5) * h))
        .collect();
    let hw = 0.485 * w;
    b.prism(&prof, DVec3::ZERO, DVec3::X, DVec3::Z, &[-hw, hw], p.body);

    // Greenhouse: roof/pillars in body paint, windows as inset faces, dark interior inside.
    let (gh, faces) = match shape {
        CarShape::Saloon => (
            hexa(
                (-0.36 * l, 0.14 * l),
                0.46 * w,
                f.p(0.0, 0.0, 0.52).z,
                (-0.25 * l, -0.04 * l),
                0.40 * w,
                0.5 * h,
            ),
            greenhouse_faces(
                p.glass,
                ((0.08, 0.92), (0.12, 0.85)),
                ((0.05, 0.95), (0.08, 0.92)),
                ((0.06, 0.94), (0.12, 0.85)),
            ),
        ),
        CarShape::Van => (
            hexa(
                (-0.49 * l, 0.30 * l),
                0.47 * w,
                f.p(0.0, 0.0, 0.52).z,
                (-0.49 * l, 0.05 * l),
                0.44 * w,
                0.5 * h,
            ),
            greenhouse_faces(
                p.glass,
                ((0.1, 0.9), (0.40, 0.88)),
                ((0.05, 0.95), (0.08, 0.92)),
                ((0.62, 0.96), (0.12, 0.85)),
            ),
        ),
    };
    b.hexahedron(gh, faces, p.body);
    b.hexahedron(shrink(gh, 0.92), [Face::Plain; 6], p.interior);

    // Wheels.
    let r = (0.21 * h).min(0.07 * l);
    let (front_axle, rear_axle) = match shape {
        CarShape::Saloon => (0.30, -0.30),
        CarShape::Van => (0.33, -0.30),
    };
    for x in [front_axle, rear_axle] {
        axle(&mut b, d, x * l, r, 0.12 * w, p.wheels);
    }

    // Bumpers (the plates protrude 4 mm beyond them).
    let zb = (f.p(0.0, 0.0, 0.12).z, f.p(0.0, 0.0, 0.30).z);
    b.cuboid(
        DVec3::new(0.46 * l, -0.47 * w, zb.0),
        DVec3::new(0.5 * l - 0.004, 0.47 * w, zb.1),
        p.bumpers,
    );
    b.cuboid(
        DVec3::new(-0.5 * l + 0.004, -0.47 * w, zb.0),
        DVec3::new(-0.46 * l, 0.47 * w, zb.1),
        p.bumpers,
    );

    // Plates: front on the bumper, rear above it.
    plate(
        &mut b,
        d,
        (0.48 * l, 0.5 * l),
        f.p(0.0, 0.0, 0.21).z,
        p.plate,
    );
    plate(
        &mut b,
        d,
        (-0.5 * l, -0.475 * l),
        f.p(0.0, 0.0, 0.335).z,
        p.plate,
    );

    // Lamps: patches protruding from the body's front and rear faces.
    let z = |a: f64, c: f64| (f.p(0.0, 0.0, a).z, f.p(0.0, 0.0, c).z);
    lamp_pair(
        &mut b,
        (0.45 * l, 0.49 * l),
        (0.28 * w, 0.44 * w),
        z(0.33, 0.42),
        p.head,
    );
    lamp_pair(
        &mut b,
        (-0.495 * l, -0.45 * l),
        (0.28 * w, 0.45 * w),
        z(0.38, 0.46),
        p.tail,
    );

    b.fit(d);
    b.into_mesh()
}

/// Rigid truck: cab, box body, chassis, one front and two rear axles.
pub(super) fn truck(asset: &AssetRef, d: DVec3) -> Mesh {
    let paint = material(asset, "paint");
    let cargo_material = material(asset, "cargo");
    let mut b = Builder::new();
    let p = vehicle_parts(&mut b, "cab", &paint);
    let cargo = b.part("cargo_box", &cargo_material);
    let chassis = b.part("chassis", "steel");
    let (l, w, h) = (d.x, d.y, d.z);
    let g = -0.5 * h;
    // Physical proportions of a 10 m × 2.55 m × 3.6 m rigid truck, scaled with the box.
    let sx = l / 10.0;
    let sz = h / 3.6;
    let cab_len = (2.3 * sx).clamp(0.15 * l, 0.4 * l);
    let cab_front = 0.5 * l - 0.06 * sx;
    let cab_back = cab_front - cab_len;
    let cab = hexa(
        (cab_back, cab_front),
        0.49 * w,
        g + 0.55 * sz,
        (cab_back, cab_front - 0.1 * sx),
        0.47 * w,
        g + 3.0 * sz,
    );
    let glass_faces = [
        Face::Plain,
        Face::Inset {
            u: (0.06, 0.94),
            v: (0.52, 0.92),
            part: p.glass,
        },
        Face::Inset {
            u: (0.5, 0.92),
            v: (0.52, 0.9),
            part: p.glass,
        },
        Face::Inset {
            u: (0.08, 0.5),
            v: (0.52, 0.9),
            part: p.glass,
        },
        Face::Plain,
        Face::Plain,
    ];
    b.hexahedron(cab, glass_faces, p.body);
    b.hexahedron(shrink(cab, 0.92), [Face::Plain; 6], p.interior);
    // Box body: full width and height behind the cab.
    b.cuboid(
        DVec3::new(-0.5 * l, -0.5 * w, g + 1.1 * sz),
        DVec3::new(cab_back - 0.2 * sx, 0.5 * w, 0.5 * h),
        cargo,
    );
    // Chassis rails and rear under-run bar.
    b.cuboid(
        DVec3::new(-0.5 * l + 0.3 * sx, -0.4 * w, g + 0.75 * sz),
        DVec3::new(cab_front - 0.2 * sx, 0.4 * w, g + 1.12 * sz),
        chassis,
    );
    b.cuboid(
        DVec3::new(-0.5 * l, -0.45 * w, g + 0.45 * sz),
        DVec3::new(-0.5 * l + 0.1 * sx, 0.45 * w, g + 0.6 * sz),
        chassis,
    );
    // Wheels: front axle under the cab, tandem rear axles.
    let r = 0.5 * sz.min(sx);
    axle(&mut b, d, cab_back + 0.45 * cab_len, r, 0.12 * w, p.wheels);
    for x in [-0.25 * l - 0.65 * sx, -0.25 * l + 0.65 * sx] {
        axle(&mut b, d, x, r, 0.12 * w, p.wheels);
    }
    // Front bumper with lamps and plate; rear lamps and plate on the under-run bar level.
    b.cuboid(
        DVec3::new(0.5 * l - 0.12 * sx, -0.48 * w, g + 0.35 * sz),
        DVec3::new(0.5 * l - 0.01 * sx, 0.48 * w, g + 0.75 * sz),
        p.bumpers,
    );
    lamp_pair(
        &mut b,
        (0.5 * l - 0.1 * sx, 0.5 * l),
        (0.3 * w, 0.46 * w),
        (g + 0.55 * sz, g + 0.7 * sz),
        p.head,
    );
    plate(
        &mut b,
        d,
        (0.5 * l - 0.1 * sx, 0.5 * l),
        g + 0.45 * sz,
        p.plate,
    );
    lamp_pair(
        &mut b,
        (-0.5 * l, -0.5 * l + 0.15 * sx),
        (0.3 * w, 0.48 * w),
        (g + 0.8 * sz, g + 0.95 * sz),
        p.tail,
    );
    plate(
        &mut b,
        d,
        (-0.5 * l, -0.5 * l + 0.12 * sx),
        g + 0.8 * sz,
        p.plate,
    );
    b.fit(d);
    b.into_mesh()
}

/// Bus: one body with windscreen, side window bands and rear window; two axles.
pub(super) fn bus(asset: &AssetRef, d: DVec3) -> Mesh {
    let paint = material(asset, "paint");
    let mut b = Builder::new();
    let p = vehicle_parts(&mut b, "body", &paint);
    let (l, w, h) = (d.x, d.y, d.z);
    let g = -0.5 * h;
    let sz = h / 3.2;
    let sx = l / 12.0;
    let body = hexa(
        (-0.5 * l + 0.02 * sx, 0.5 * l - 0.02 * sx),
        0.49 * w,
        g + 0.3 * sz,
        (-0.5 * l + 0.05 * sx, 0.5 * l - 0.08 * sx),
        0.47 * w,
        0.5 * h,
    );
    let band = ((0.03, 0.97), (0.45, 0.9));
    let faces = [
        Face::Inset {
            u: (0.1, 0.9),
            v: (0.55, 0.9),
            part: p.glass,
        },
        Face::Inset {
            u: (0.05, 0.95),
            v: (0.3, 0.93),
            part: p.glass,
        },
        Face::Inset {
            u: band.0,
            v: band.1,
            part: p.glass,
        },
        Face::Inset {
            u: band.0,
            v: band.1,
            part: p.glass,
        },
        Face::Plain,
        Face::Plain,
    ];
    b.hexahedron(body, faces, p.body);
    b.hexahedron(shrink(body, 0.95), [Face::Plain; 6], p.interior);
    let r = 0.5 * sz.min(sx);
    for x in [0.25 * l, -0.25 * l] {
        axle(&mut b, d, x, r, 0.1 * w, p.wheels);
    }
    let zb = (g + 0.3 * sz, g + 0.6 * sz);
    b.cuboid(
        DVec3::new(0.5 * l - 0.12 * sx, -0.49 * w, zb.0),
        DVec3::new(0.5 * l - 0.004, 0.49 * w, zb.1),
        p.bumpers,
    );
    b.cuboid(
        DVec3::new(-0.5 * l + 0.004, -0.49 * w, zb.0),
        DVec3::new(-0.5 * l + 0.12 * sx, 0.49 * w, zb.1),
        p.bumpers,
    );
    plate(
        &mut b,
        d,
        (0.5 * l - 0.05 * sx, 0.5 * l),
        g + 0.45 * sz,
        p.plate,
    );
    plate(
        &mut b,
        d,
        (-0.5 * l, -0.5 * l + 0.05 * sx),
        g + 0.45 * sz,
        p.plate,
    );
    lamp_pair(
        &mut b,
        (0.5 * l - 0.1 * sx, 0.5 * l - 0.002),
        (0.3 * w, 0.46 * w),
        (g + 0.65 * sz, g + 0.8 * sz),
        p.head,
    );
    lamp_pair(
        &mut b,
        (-0.5 * l + 0.002, -0.5 * l + 0.1 * sx),
        (0.3 * w, 0.47 * w),
        (g + 0.7 * sz, g + 1.0 * sz),
        p.tail,
    );
    b.fit(d);
    b.into_mesh()
}
