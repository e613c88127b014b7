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
const WHEEL_SEGMENTS: usize = 32;

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
/// `±W/2`, touching the ground. Each tyre is a torus of elliptical section (section height 0.4 r,
/// the width `w`; the rim sits at 0.6 r), closed by a domed wheel disc (an oblate ellipsoid of radius
/// 0.62 r and 0.06 r deep, just inside the tyre's outer face): the sidewalls and the disc are curved,
/// so they return finite specular flashes (σ ≈ π·a₁·a₂) instead of a flat disc's mirror return.
fn axle(b: &mut Builder, d: DVec3, x: f64, r: f64, w: f64, part: u16) {
    let zc = -0.5 * d.z + r;
    let section = (0.2 * r, 0.5 * w);
    for s in [-1.0, 1.0] {
        let yc = s * (0.5 * d.y - 0.5 * w);
        b.torus(
            DVec3::new(x, yc, zc),
            DVec3::Y,
            r - section.0,
            section,
            (WHEEL_SEGMENTS, 12),
            part,
        );
        let depth = (0.06 * r).min(0.45 * w);
        b.ellipsoid(
            DVec3::new(x, s * (0.5 * d.y - 0.01 - depth), zc),
            DVec3::new(0.62 * r, depth, 0.62 * r),
            WHEEL_SEGMENTS,
            8,
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

/// A closed convex plan outline made of tangent-continuous circular arcs: the nose (front face, radius
/// `r_front`), the tail (`r_rear`), the two sides (`r_side`) and four corners (`r_corner`), spanning
/// `x ∈ [−x_rear, x_front]`, `y ∈ [−hw, hw]`. Points with their outward unit normals, counter-clockwise
/// from the front centre; every arc has at most `max_step_rad` of turn and `max_len_m` of length per
/// segment. Radii that do not fit fall back to smaller ones (never panics).
#[allow(clippy::too_many_arguments)]
fn arc_outline(
    x_front: f64,
    x_rear: f64,
    hw: f64,
    r_side: f64,
    r_front: f64,
    r_rear: f64,
    r_corner: f64,
    (max_step_rad, max_len_m): (f64, f64),
) -> Vec<(DVec2, DVec2)> {
    // One quadrant (x ≥ 0, y ≥ 0) with end radius `r_end` at `x_end`: points for normal angles 0 … π/2.
    let quadrant = |x_end: f64, r_end: f64| -> Vec<(DVec2, DVec2)> {
        let rc = r_corner.min(0.9 * hw).min(0.9 * x_end).max(1e-3);
        let re = r_end.max(rc * 1.01);
        let rs = r_side.max(rc * 1.01);
        let n_c = DVec2::new(x_end - re, 0.0);
        let s_c = DVec2::new(0.0, hw - rs);
        // Corner centre: |C − N| = re − rc, |C − S| = rs − rc (two-circle intersection, the one
        // towards the corner).
        let (d0, d1) = (re - rc, rs - rc);
        let dv = s_c - n_c;
        let l = dv.length();
        let corner = if l > 1e-9 && l <= d0 + d1 && l >= (d0 - d1).abs() {
            let a = (d0 * d0 - d1 * d1 + l * l) / (2.0 * l);
            let h = (d0 * d0 - a * a).max(0.0).sqrt();
            let m = n_c + dv * (a / l);
            let perp = DVec2::new(dv.y, -dv.x) / l;
            let c1 = m + perp * h;
            let c2 = m - perp * h;
            if c1.x + c1.y >= c2.x + c2.y { c1 } else { c2 }
        } else {
            DVec2::new(x_end - rc, hw - rc)
        };
        let phi1 = (corner - n_c)
            .to_angle()
            .clamp(0.0, 0.5 * std::f64::consts::PI);
        let phi2 = (corner - s_c)
            .to_angle()
            .clamp(phi1, 0.5 * std::f64::consts::PI);
        let mut out = Vec::new();
        let mut arc = |c: DVec2, r: f64, a0: f64, a1: f64, last: bool| {
            let span = a1 - a0;
            let n = ((span / max_step_rad)
                .ceil()
                .max((span * r / max_len_m).ceil()) as usize)
                .max(1);
            for k in 0..n + usize::from(last) {
                let a = a0 + span * k as f64 / n as f64;
                let nrm = DVec2::from_angle(a);
                out.push((c + nrm * r, nrm));
            }
        };
        arc(n_c, re, 0.0, phi1, false);
        arc(corner, rc, phi1, phi2, false);
        arc(s_c, rs, phi2, 0.5 * std::f64::consts::PI, true);
        out
    };
    let front = quadrant(x_front, r_front);
    let rear = quadrant(x_rear, r_rear);
    // Upper half (y ≥ 0) from the front centre to the rear centre.
    let mut upper: Vec<(DVec2, DVec2)> = front;
    upper.extend(
        rear.iter()
            .rev()
            .skip(1)
            .map(|&(p, n)| (DVec2::new(-p.x, p.y), DVec2::new(-n.x, n.y))),
    );
    let mut out = upper.clone();
    out.extend(
        upper[1..upper.len() - 1]
            .iter()
            .rev()
            .map(|&(p, n)| (DVec2::new(p.x, -p.y), DVec2::new(n.x, -n.y))),
    );
    out
}

/// Vertical section of a lofted body: (outward offset from the plan outline, height) from the bottom
/// to the top. A side arc of radius `a_side` (the doubly curved flank: `a_side` is the vertical radius
/// of curvature at the outline height `z_mid`) rolls into the flat underbody and the flat top over
/// arcs of radii `r_bottom` and `r_top`; `steps` segments per roll, 4 on the side.
fn body_section(
    z_bottom: f64,
    z_mid: f64,
    z_top: f64,
    a_side: f64,
    r_bottom: f64,
    r_top: f64,
    steps: usize,
) -> Vec<DVec2> {
    use std::f64::consts::FRAC_PI_2;
    let side = |t: f64| DVec2::new(-a_side + a_side * t.cos(), z_mid + a_side * t.sin());
    let tt = ((z_top - z_mid - r_top) / (a_side - r_top))
        .clamp(-1.0, 1.0)
        .asin()
        .max(0.0);
    let tb = -((z_mid - z_bottom - r_bottom) / (a_side - r_bottom))
        .clamp(-1.0, 1.0)
        .asin()
        .max(0.0);
    let cb = side(tb) - DVec2::from_angle(tb) * r_bottom;
    let ct = side(tt) - DVec2::from_angle(tt) * r_top;
    let mut out = Vec::new();
    for k in 0..steps {
        let t = -FRAC_PI_2 + (tb + FRAC_PI_2) * k as f64 / steps as f64;
        out.push(cb + DVec2::from_angle(t) * r_bottom);
    }
    for k in 0..4 {
        out.push(side(tb + (tt - tb) * k as f64 / 4.0));
    }
    for k in 0..=steps {
        let t = tt + (FRAC_PI_2 - tt) * k as f64 / steps as f64;
        out.push(ct + DVec2::from_angle(t) * r_top);
    }
    out
}

/// `x` of the outline's front (`front`) or rear face at `|y|` (linear between the samples).
fn outline_x(outline: &[(DVec2, DVec2)], y: f64, front: bool) -> f64 {
    let mut best: Option<f64> = None;
    for w in 0..outline.len() {
        let (a, b) = (outline[w].0, outline[(w + 1) % outline.len()].0);
        if (a.x > 0.0) != front || a.y < 0.0 || b.y < 0.0 {
            continue;
        }
        let (lo, hi) = (a.y.min(b.y), a.y.max(b.y));
        if y >= lo && y <= hi && hi > lo {
            let x = a.x + (b.x - a.x) * (y - a.y) / (b.y - a.y);
            best = Some(match best {
                Some(v) if front => v.max(x),
                Some(v) => v.min(x),
                None => x,
            });
        }
    }
    best.unwrap_or(0.0)
}

/// Car (saloon) or van.
///
/// Radar-relevant geometry (physics.md §1.8): the lower body is lofted from a plan outline of
/// circular arcs (sides of radius 10 m, front 2.5 m, rear 3 m, corners 0.35 m) and a vertical section
/// whose flank has a 1.5 m radius, so the flanks, the front and the rear are doubly curved (a car's
/// broadside flash is then π·a₁·a₂ ≈ 17 dBm² and does not grow with range); the bumpers are swept
/// elliptical sections (4 × 13 cm) along the outline's ends; tyres are tori with domed wheel discs;
/// door mirrors are ellipsoids. Plates and lamp lenses stay flat (as they are).
pub(super) fn car(asset: &AssetRef, d: DVec3, shape: CarShape) -> Mesh {
    let paint = material(asset, "paint");
    let mut b = Builder::new();
    let p = vehicle_parts(&mut b, "body", &paint);
    let f = Frac { d };
    let (l, w, h) = (d.x, d.y, d.z);

    // Plan outline of the lower body (physical radii, clamped to small boxes).
    let hw = 0.485 * w;
    let (r_front, r_rear) = match shape {
        CarShape::Saloon => (2.5, 3.0),
        CarShape::Van => (2.5, 6.0),
    };
    let r_corner: f64 = match shape {
        CarShape::Saloon => 0.35,
        CarShape::Van => 0.25,
    };
    let outline = arc_outline(
        0.49 * l,
        0.49 * l,
        hw,
        10.0,
        r_front,
        r_rear,
        r_corner.min(0.2 * l).min(0.3 * w),
        (6f64.to_radians(), 0.15),
    );
    // Vertical section: underbody at 0.12 H, flank radius 1.5 m centred at 0.30 H, top at 0.53 H.
    let z_bottom = f.p(0.0, 0.0, 0.12).z;
    let z_mid = f.p(0.0, 0.0, 0.30).z;
    let z_top = f.p(0.0, 0.0, 0.53).z;
    let span = z_top - z_bottom;
    let mut section = body_section(
        z_bottom,
        z_mid,
        z_top,
        1.5f64.max(span),
        (0.08f64).min(0.3 * span),
        (0.12f64).min(0.35 * span),
        6,
    );
    // The inward offsets must stay below the corner radius (else the offset outline folds over).
    let rc_eff = r_corner
        .min(0.2 * l)
        .min(0.3 * w)
        .min(0.9 * hw)
        .min(0.9 * 0.49 * l);
    let deepest = section.iter().map(|q| -q.x).fold(0.0, f64::max);
    if deepest > 0.8 * rc_eff && deepest > 0.0 {
        let k = 0.8 * rc_eff / deepest;
        section.iter_mut().for_each(|q| q.x *= k);
    }
    // Top height along x (bonnet and boot below the belt line): a smooth quadratic fall-off.
    let top_at = |x: f64| -> f64 {
        let fall = |t: f64, dz: f64| dz * t.clamp(0.0, 1.0).powi(2);
        let frac = match shape {
            CarShape::Saloon => {
                0.53 - fall((x / l - 0.12) / 0.37, 0.08) - fall((-0.38 - x / l) / 0.11, 0.06)
            }
            CarShape::Van => 0.53 - fall((x / l - 0.30) / 0.19, 0.06),
        };
        f.p(0.0, 0.0, frac).z
    };
    let rings: Vec<Vec<DVec3>> = section
        .iter()
        .map(|q| {
            outline
                .iter()
                .map(|&(pt, n)| {
                    let xy = pt + n * q.x;
                    let z = if q.y > z_mid {
                        z_mid + (q.y - z_mid) * (top_at(pt.x) - z_mid) / (z_top - z_mid)
                    } else {
                        q.y
                    };
                    DVec3::new(xy.x, xy.y, z)
                })
                .collect()
        })
        .collect();
    b.loft(&rings, p.body);

    // Greenhouse: roof/pillars in body paint, windows as inset faces, dark interior inside (its
    // bottom inside the lower body's rounded shoulder).
    let (gh, faces) = match shape {
        CarShape::Saloon => (
            hexa(
                (-0.36 * l, 0.14 * l),
                0.43 * w,
                f.p(0.0, 0.0, 0.52).z,
                (-0.25 * l, -0.04 * l),
                0.37 * w,
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
                (-0.47 * l, 0.30 * l),
                0.44 * w,
                f.p(0.0, 0.0, 0.52).z,
                (-0.47 * l, 0.05 * l),
                0.41 * w,
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

    // Door mirrors: ellipsoidal housings ahead of the greenhouse.
    let mirror_x = match shape {
        CarShape::Saloon => 0.12 * l,
        CarShape::Van => 0.28 * l,
    };
    let mirror = DVec3::new(0.09, 0.05f64.min(0.03 * w), 0.06);
    for s in [-1.0, 1.0] {
        b.ellipsoid(
            DVec3::new(
                mirror_x,
                s * (0.5 * w - mirror.y - 0.002),
                f.p(0.0, 0.0, 0.6).z,
            ),
            mirror,
            12,
            8,
            p.body,
        );
    }

    // Wheels.
    let r = (0.21 * h).min(0.07 * l);
    let (front_axle, rear_axle) = match shape {
        CarShape::Saloon => (0.30, -0.30),
        CarShape::Van => (0.33, -0.30),
    };
    for x in [front_axle, rear_axle] {
        axle(&mut b, d, x * l, r, 0.12 * w, p.wheels);
    }

    // Bumpers: elliptical sections (3.5 cm proud of the outline, 0.18 H tall) swept along the
    // outline where |x| > 0.40 L, centred at 0.21 H.
    let zb = f.p(0.0, 0.0, 0.21).z;
    let rb = DVec2::new(0.035f64.min(0.02 * l), 0.09 * h);
    for front in [true, false] {
        let idx: Vec<usize> = (0..outline.len())
            .filter(|&i| {
                let x = outline[i].0.x;
                if front { x > 0.40 * l } else { x < -0.40 * l }
            })
            .collect();
        if idx.len() < 2 {
            continue;
        }
        // Order along the outline (the front run wraps around index 0).
        let mut run = idx.clone();
        if front {
            let split = idx.iter().position(|&i| i > outline.len() / 2);
            if let Some(k) = split {
                run = idx[k..].iter().chain(idx[..k].iter()).copied().collect();
            }
        }
        let rings: Vec<Vec<DVec3>> = run
            .iter()
            .map(|&i| {
                let (pt, n) = outline[i];
                let c = DVec3::new(pt.x, pt.y, zb);
                let n3 = DVec3::new(n.x, n.y, 0.0);
                (0..16)
                    .map(|k| {
                        let t = std::f64::consts::TAU * k as f64 / 16.0;
                        c + n3 * (rb.x * t.cos()) + DVec3::Z * (rb.y * t.sin())
                    })
                    .collect()
            })
            .collect();
        b.loft(&rings, p.bumpers);
    }

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

    // Lamps: lens boxes whose outer faces stand 5 mm proud of the curved front and rear.
    let z = |a: f64, c: f64| (f.p(0.0, 0.0, a).z, f.p(0.0, 0.0, c).z);
    let (hy0, hy1) = (0.26 * w, 0.38 * w);
    let hx1 = outline_x(&outline, hy0, true) + 0.005;
    let hx0 = outline_x(&outline, hy1, true) - 0.03;
    lamp_pair(
        &mut b,
        (hx0.min(hx1 - 0.01), hx1),
        (hy0, hy1),
        z(0.33, 0.42),
        p.head,
    );
    let (ty0, ty1) = (0.26 * w, 0.38 * w);
    let tx0 = outline_x(&outline, ty0, false) - 0.005;
    let tx1 = outline_x(&outline, ty1, false) + 0.03;
    lamp_pair(
        &mut b,
        (tx0, tx1.max(tx0 + 0.01)),
        (ty0, ty1),
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
