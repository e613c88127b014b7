//! Vulnerable road users: pedestrian, cyclist, motorcycle (with riders).
//!
//! Built at physical size (ground at z = 0, +x forward) and then fitted to the OSI box. Body segment
//! positions are fractions of the stature `S` from Drillis & Contini (1966), as reproduced in
//! D. A. Winter, *Biomechanics and Motor Control of Human Movement*, 4th ed., Fig. 4.1: hip (greater
//! trochanter) 0.530 S, knee 0.285 S, ankle 0.039 S, shoulder 0.818 S, elbow 0.630 S, wrist 0.485 S,
//! chin 0.870 S, shoulder width 0.259 S, hip width 0.191 S, foot length 0.152 S.

use glam::{DVec2, DVec3};

use super::AssetRef;
use super::geometry::Builder;
use super::vehicles::material;
use crate::environment::mesh::Mesh;

const LIMB_SEGMENTS: usize = 10;

fn v(x: f64, y: f64, z: f64) -> DVec3 {
    DVec3::new(x, y, z)
}

fn limb(b: &mut Builder, p0: DVec3, r0: f64, p1: DVec3, r1: f64, part: u16) {
    b.frustum(
        p0,
        DVec2::splat(r0),
        p1,
        DVec2::splat(r1),
        LIMB_SEGMENTS,
        part,
    );
}

struct PersonParts {
    torso: u16,
    arms: u16,
    legs: u16,
    head: u16,
    hands: u16,
    shoes: u16,
}

/// Parts of a person; `head` is (part name, material), `hands` the material of the hands.
fn person_parts(b: &mut Builder, clothing: &str, head: (&str, &str), hands: &str) -> PersonParts {
    PersonParts {
        torso: b.part("torso", clothing),
        arms: b.part("arms", clothing),
        legs: b.part("legs", clothing),
        head: b.part(head.0, head.1),
        hands: b.part("hands", hands),
        shoes: b.part("shoes", "clothing_black_leather"),
    }
}

/// Pedestrian of stature `d.z`, facing +x; walking: mid-stride, left leg and right arm forward.
pub(super) fn pedestrian(asset: &AssetRef, d: DVec3) -> Mesh {
    let clothing = material(asset, "clothing");
    let walking = asset.text("pose").as_deref() != Some("standing");
    let s = d.z;
    let mut b = Builder::new();
    let p = person_parts(&mut b, &clothing, ("head", "skin"), "skin");
    let stride = if walking { 0.08 * s } else { 0.0 };
    let (hip_z, knee_z, ankle_z) = (0.53 * s, 0.285 * s, 0.039 * s);
    for side in [1.0, -1.0] {
        // Left leg (side +1) forward, right leg back.
        let y = side * 0.055 * s;
        let ankle = v(side * stride, y, ankle_z);
        let knee = v(
            side * 0.5 * stride + if walking { 0.015 * s } else { 0.0 },
            y,
            knee_z,
        );
        limb(&mut b, v(0.0, y, hip_z), 0.045 * s, knee, 0.033 * s, p.legs);
        limb(&mut b, knee, 0.032 * s, ankle, 0.022 * s, p.legs);
        b.cuboid(
            v(ankle.x - 0.035 * s, y - 0.028 * s, 0.0),
            v(ankle.x + 0.117 * s, y + 0.028 * s, 0.055 * s),
            p.shoes,
        );
        // Arms swing opposite to the legs.
        let swing = if walking { -side } else { 0.0 };
        let shoulder = v(0.0, side * 0.125 * s, 0.80 * s);
        let elbow = v(0.045 * s * swing, side * 0.135 * s, 0.63 * s);
        let wrist = v(0.085 * s * swing, side * 0.14 * s, 0.485 * s);
        limb(&mut b, shoulder, 0.024 * s, elbow, 0.019 * s, p.arms);
        limb(&mut b, elbow, 0.019 * s, wrist, 0.015 * s, p.arms);
        let hand = wrist + (wrist - elbow).normalize() * 0.045 * s;
        b.ellipsoid(hand, v(0.02 * s, 0.012 * s, 0.045 * s), 10, 6, p.hands);
    }
    b.frustum(
        v(0.0, 0.0, 0.50 * s),
        DVec2::new(0.07 * s, 0.10 * s),
        v(0.0, 0.0, 0.805 * s),
        DVec2::new(0.065 * s, 0.125 * s),
        12,
        p.torso,
    );
    b.cylinder(
        v(0.0, 0.0, 0.79 * s),
        v(0.0, 0.0, 0.885 * s),
        0.028 * s,
        LIMB_SEGMENTS,
        p.head,
    );
    b.ellipsoid(
        v(0.01 * s, 0.0, 0.935 * s),
        v(0.055 * s, 0.043 * s, 0.065 * s),
        12,
        8,
        p.head,
    );
    b.fit(d);
    b.into_mesh()
}

/// A bicycle-style wheel, axle along y: the tyre a torus of elliptical section (`tyre` = section
/// height, width), the rim a torus of elliptical section inside it (`rim` = depth, width: a box rim's
/// rounded section rather than a flat annulus), an ellipsoidal hub and, optionally, 16 round spokes
/// (2 mm wires) per side from the hub flanges (±30 mm, the dish of a real wheel, so they are not all
/// perpendicular to a broadside view) to the rim.
fn spoked_wheel(
    b: &mut Builder,
    centre: DVec3,
    r: f64,
    tyre: (f64, f64),
    rim: (f64, f64),
    parts: (u16, u16, Option<u16>),
) {
    let (wheels, rims, spokes) = parts;
    b.torus(
        centre,
        DVec3::Y,
        r - 0.5 * tyre.0,
        (0.5 * tyre.0, 0.5 * tyre.1),
        (48, 10),
        wheels,
    );
    let rim_r = r - tyre.0 - 0.5 * rim.0;
    b.torus(
        centre,
        DVec3::Y,
        rim_r,
        (0.5 * rim.0, 0.5 * rim.1),
        (48, 10),
        rims,
    );
    b.ellipsoid(centre, v(0.025, 0.05, 0.025), 10, 6, rims);
    if let Some(sp) = spokes {
        let inner = rim_r - 0.5 * rim.0;
        for k in 0..32 {
            let a = std::f64::consts::TAU * (k as f64 + 0.25 * (k % 2) as f64) / 32.0;
            let dir = v(a.cos(), 0.0, a.sin());
            let side = if k % 2 == 0 { 1.0 } else { -1.0 };
            b.cylinder(
                centre + dir * 0.02 + DVec3::Y * (0.03 * side),
                centre + dir * inner,
                0.001,
                8,
                sp,
            );
        }
    }
}

/// Rider limbs from joints: hips, knees, feet (per side +y/−y), shoulders, elbows, hands.
struct RiderPose {
    hip: [DVec3; 2],
    knee: [DVec3; 2],
    foot: [DVec3; 2],
    shoulder: [DVec3; 2],
    elbow: [DVec3; 2],
    hand: [DVec3; 2],
    pelvis: DVec3,
    neck: DVec3,
    head: DVec3,
}

fn rider(b: &mut Builder, r: &RiderPose, p: &PersonParts, hands_radii: DVec3, head_radii: DVec3) {
    for i in 0..2 {
        limb(b, r.hip[i], 0.08, r.knee[i], 0.06, p.legs);
        limb(b, r.knee[i], 0.058, r.foot[i], 0.04, p.legs);
        let f = r.foot[i];
        b.cuboid(f - v(0.08, 0.045, 0.04), f + v(0.14, 0.045, 0.06), p.shoes);
        limb(b, r.shoulder[i], 0.045, r.elbow[i], 0.035, p.arms);
        limb(b, r.elbow[i], 0.035, r.hand[i], 0.028, p.arms);
        b.ellipsoid(r.hand[i], hands_radii, 8, 6, p.hands);
    }
    b.frustum(
        r.pelvis,
        DVec2::new(0.11, 0.17),
        r.neck,
        DVec2::new(0.09, 0.19),
        12,
        p.torso,
    );
    b.ellipsoid(r.head, head_radii, 12, 8, p.head);
}

/// Bicycle with rider.
pub(super) fn cyclist(asset: &AssetRef, d: DVec3) -> Mesh {
    let clothing = material(asset, "clothing");
    let frame_material = material(asset, "frame");
    let mut b = Builder::new();
    let frame = b.part("frame", &frame_material);
    let wheels = b.part("wheels", "rubber");
    let rims = b.part("rims", "aluminium");
    let spokes = b.part("spokes", "steel");
    let saddle = b.part("saddle", "plastic_black");
    let p = person_parts(&mut b, &clothing, ("head", "skin"), "skin");
    // 700c wheel (≈ 0.67 m diameter), 1.0 m wheelbase.
    let r = 0.335;
    let rear = v(-0.5, 0.0, r);
    let front = v(0.5, 0.0, r);
    for c in [rear, front] {
        spoked_wheel(
            &mut b,
            c,
            r,
            (0.028, 0.025),
            (0.025, 0.02),
            (wheels, rims, Some(spokes)),
        );
    }
    let tube = 0.018;
    let bb = v(-0.08, 0.0, 0.28);
    let seat_top = v(-0.22, 0.0, 0.80);
    let head_top = v(0.38, 0.0, 0.85);
    let head_bottom = v(0.42, 0.0, 0.66);
    for (a, c) in [
        (bb, seat_top),
        (seat_top, head_top),
        (head_top, head_bottom),
        (bb, head_bottom),
    ] {
        b.cylinder(a, c, tube, 8, frame);
    }
    for s in [-1.0, 1.0] {
        let hub = rear + v(0.0, s * 0.06, 0.0);
        b.cylinder(bb + v(0.0, s * 0.03, 0.0), hub, 0.011, 8, frame);
        b.cylinder(seat_top + v(0.0, s * 0.02, -0.03), hub, 0.009, 8, frame);
        b.cylinder(
            head_bottom + v(0.0, s * 0.03, 0.0),
            front + v(0.0, s * 0.05, 0.0),
            0.012,
            8,
            frame,
        );
    }
    b.cylinder(seat_top, v(-0.25, 0.0, 0.92), 0.014, 8, frame);
    b.cylinder(head_top, v(0.41, 0.0, 0.95), 0.016, 8, frame);
    b.cylinder(v(0.42, -0.23, 0.95), v(0.42, 0.23, 0.95), 0.012, 8, frame);
    b.cuboid(v(-0.37, -0.07, 0.92), v(-0.13, 0.07, 0.965), saddle);
    // Pedals: left forward, right back (matching the rider's legs).
    let pedal = [bb + v(0.17, 0.11, 0.0), bb + v(-0.17, -0.11, 0.0)];
    for q in pedal {
        b.cuboid(q - v(0.05, 0.04, 0.012), q + v(0.05, 0.04, 0.012), saddle);
        b.bar(bb, q, 0.02, 0.02, frame);
    }
    let pose = RiderPose {
        hip: [v(-0.22, 0.09, 0.98), v(-0.22, -0.09, 0.98)],
        knee: [v(0.10, 0.12, 0.68), v(-0.10, -0.11, 0.60)],
        foot: [pedal[0] + v(0.0, 0.0, 0.05), pedal[1] + v(0.0, 0.0, 0.05)],
        shoulder: [v(0.10, 0.19, 1.40), v(0.10, -0.19, 1.40)],
        elbow: [v(0.25, 0.22, 1.18), v(0.25, -0.22, 1.18)],
        hand: [v(0.42, 0.22, 0.97), v(0.42, -0.22, 0.97)],
        pelvis: v(-0.24, 0.0, 0.96),
        neck: v(0.10, 0.0, 1.43),
        head: v(0.22, 0.0, 1.58),
    };
    rider(
        &mut b,
        &pose,
        &p,
        v(0.045, 0.025, 0.04),
        v(0.11, 0.08, 0.12),
    );
    b.fit(d);
    b.into_mesh()
}

/// Motorcycle with rider (helmet, leathers).
pub(super) fn motorcycle(asset: &AssetRef, d: DVec3) -> Mesh {
    let paint = material(asset, "paint");
    let clothing = material(asset, "clothing");
    let helmet_material = material(asset, "helmet");
    let mut b = Builder::new();
    let body = b.part("body", &paint);
    let engine = b.part("engine", "aluminium");
    let frame = b.part("frame", "steel");
    let wheels = b.part("wheels", "rubber");
    let rims = b.part("rims", "aluminium");
    let saddle = b.part("saddle", "plastic_black");
    let head_lamp = b.part("head_lamps", "polycarbonate");
    let tail_lamp = b.part("tail_lamps", "polycarbonate");
    let plate = b.part("licence_plates", "retroreflective_sheeting");
    let p = person_parts(&mut b, &clothing, ("helmet", &helmet_material), &clothing);
    let r = 0.31;
    let rear = v(-0.725, 0.0, r);
    let front = v(0.725, 0.0, r);
    for c in [rear, front] {
        spoked_wheel(&mut b, c, r, (0.1, 0.16), (0.03, 0.1), (wheels, rims, None));
    }
    b.ellipsoid(v(0.15, 0.0, 0.85), v(0.25, 0.16, 0.12), 12, 8, body);
    b.cuboid(v(-0.2, -0.17, 0.28), v(0.3, 0.17, 0.62), engine);
    b.cylinder(v(0.48, 0.0, 0.95), v(-0.25, 0.0, 0.45), 0.03, 8, frame);
    for s in [-1.0, 1.0] {
        b.cylinder(
            v(-0.25, s * 0.1, 0.42),
            rear + v(0.0, s * 0.1, 0.0),
            0.025,
            8,
            frame,
        );
        b.cylinder(
            v(0.5, s * 0.09, 1.0),
            front + v(0.0, s * 0.09, 0.0),
            0.022,
            8,
            frame,
        );
    }
    b.cylinder(v(0.45, -0.38, 1.05), v(0.45, 0.38, 1.05), 0.014, 8, frame);
    b.cuboid(v(-0.6, -0.14, 0.75), v(0.0, 0.14, 0.86), saddle);
    b.cuboid(v(-0.86, -0.1, 0.70), v(-0.55, 0.1, 0.82), body);
    b.ellipsoid(v(0.72, 0.0, 0.92), v(0.06, 0.09, 0.08), 10, 6, head_lamp);
    b.cuboid(v(-0.9, -0.06, 0.74), v(-0.84, 0.06, 0.80), tail_lamp);
    b.cuboid(v(-0.88, -0.1275, 0.52), v(-0.86, 0.1275, 0.65), plate);
    let pose = RiderPose {
        hip: [v(-0.3, 0.12, 0.92), v(-0.3, -0.12, 0.92)],
        knee: [v(0.1, 0.2, 0.78), v(0.1, -0.2, 0.78)],
        foot: [v(-0.15, 0.18, 0.38), v(-0.15, -0.18, 0.38)],
        shoulder: [v(0.0, 0.2, 1.35), v(0.0, -0.2, 1.35)],
        elbow: [v(0.2, 0.3, 1.15), v(0.2, -0.3, 1.15)],
        hand: [v(0.42, 0.36, 1.05), v(0.42, -0.36, 1.05)],
        pelvis: v(-0.32, 0.0, 0.9),
        neck: v(-0.02, 0.0, 1.38),
        head: v(0.05, 0.0, 1.52),
    };
    rider(
        &mut b,
        &pose,
        &p,
        v(0.05, 0.035, 0.045),
        v(0.14, 0.12, 0.14),
    );
    b.fit(d);
    b.into_mesh()
}
