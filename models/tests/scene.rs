//! Tests of the scene from OSI (`osiris_models::environment::scene`) on a ground truth shaped like the
//! built-in scenario (`scenario/src/lib.rs`): 3 lanes of 3.5 m plus a 2.5 m shoulder, 400 m long, solid
//! outer lines, dashed inner lines with dash flags (6 m / 12 m), a road edge, a guardrail, a trihedral,
//! a board, a cone and six road users (host id 1).

mod common;
use common::{dim, rpy, v3};
use std::collections::BTreeSet;

use glam::{DMat3, DVec3};
use osiris_models::environment::assets::geometry::triangle_area;
use osiris_models::environment::material::MaterialDb;
use osiris_models::environment::mesh::Mesh;
use osiris_models::environment::scene::{
    Scene, SceneBuilder, SceneError, SceneOptions, StaticElement,
};
use osiris_proto::{id, osi3};

const HOST: u64 = 1;
const LANE_WIDTH: f64 = 3.5;
const SHOULDER: f64 = 2.5;
const LENGTH: f64 = 400.0;
const MARKING: f64 = 0.15;

fn moving(oid: u64, reference: &str, pos: [f64; 3], d: [f64; 3], speed: f64) -> osi3::MovingObject {
    osi3::MovingObject {
        id: Some(id(oid)),
        base: Some(osi3::BaseMoving {
            dimension: Some(dim(d)),
            position: Some(v3([pos[0], pos[1], pos[2]])),
            orientation: Some(rpy(0.0, 0.0, 0.0)),
            velocity: Some(v3([speed, 0.0, 0.0])),
            orientation_rate: Some(rpy(0.0, 0.0, 0.0)),
            ..Default::default()
        }),
        r#type: Some(osi3::moving_object::Type::Vehicle as i32),
        model_reference: Some(reference.into()),
        ..Default::default()
    }
}

fn stationary(oid: u64, reference: &str, pos: [f64; 3], d: [f64; 3]) -> osi3::StationaryObject {
    osi3::StationaryObject {
        id: Some(id(oid)),
        base: Some(osi3::BaseStationary {
            dimension: Some(dim(d)),
            position: Some(v3([pos[0], pos[1], pos[2]])),
            orientation: Some(rpy(0.0, 0.0, 0.0)),
            ..Default::default()
        }),
        model_reference: Some(reference.into()),
        ..Default::default()
    }
}

fn boundary_y(j: u32) -> f64 {
    (f64::from(j) - 1.5) * LANE_WIDTH
}

fn ground_truth() -> osi3::GroundTruth {
    use osi3::lane::classification::Type as LaneType;
    use osi3::lane_boundary::boundary_point::Dash;
    use osi3::lane_boundary::classification::{Color, Type as BType};
    let xs: Vec<f64> = (0..=40).map(|i| f64::from(i) * 10.0).collect();
    let solid = |y: f64, w: f64| -> Vec<osi3::lane_boundary::BoundaryPoint> {
        xs.iter()
            .map(|&x| osi3::lane_boundary::BoundaryPoint {
                position: Some(v3([x, y, 0.0])),
                width: Some(w),
                height: Some(0.0),
                dash: None,
            })
            .collect()
    };
    let dashed = |y: f64| -> Vec<osi3::lane_boundary::BoundaryPoint> {
        let mut pts = Vec::new();
        let mut x = 0.0;
        while x < LENGTH {
            let end = (x + 6.0f64).min(LENGTH);
            for (px, d) in [(x, Dash::Start), (end, Dash::End)] {
                pts.push(osi3::lane_boundary::BoundaryPoint {
                    position: Some(v3([px, y, 0.0])),
                    width: Some(MARKING),
                    height: Some(0.0),
                    dash: Some(d as i32),
                });
            }
            x += 18.0;
        }
        pts
    };
    let boundary = |j: u64, ty: BType, color: Color, pts| osi3::LaneBoundary {
        id: Some(id(2000 + j)),
        boundary_line: pts,
        classification: Some(osi3::lane_boundary::Classification {
            r#type: Some(ty as i32),
            color: Some(color as i32),
            ..Default::default()
        }),
        ..Default::default()
    };
    let lane_boundary = vec![
        boundary(
            0,
            BType::SolidLine,
            Color::White,
            solid(boundary_y(0), MARKING),
        ),
        boundary(1, BType::DashedLine, Color::White, dashed(boundary_y(1))),
        boundary(2, BType::DashedLine, Color::White, dashed(boundary_y(2))),
        boundary(
            3,
            BType::SolidLine,
            Color::White,
            solid(boundary_y(3), MARKING),
        ),
        boundary(
            4,
            BType::RoadEdge,
            Color::None,
            solid(boundary_y(0) - SHOULDER, 0.0),
        ),
    ];
    let lane = |i: u64, right: u64, left: u64, ty: LaneType| osi3::Lane {
        id: Some(id(1000 + i)),
        classification: Some(osi3::lane::Classification {
            r#type: Some(ty as i32),
            is_host_vehicle_lane: Some(i == 1),
            right_lane_boundary_id: vec![id(2000 + right)],
            left_lane_boundary_id: vec![id(2000 + left)],
            ..Default::default()
        }),
        ..Default::default()
    };
    let lanes = vec![
        lane(0, 0, 1, LaneType::Driving),
        lane(1, 1, 2, LaneType::Driving),
        lane(2, 2, 3, LaneType::Driving),
        lane(3, 4, 0, LaneType::Nondriving),
    ];
    let car = [4.5, 1.8, 1.5];
    let mut pedestrian = moving(
        104,
        "osiris:pedestrian",
        [160.0, -6.5, 0.9],
        [0.5, 0.6, 1.8],
        1.4,
    );
    pedestrian.r#type = Some(osi3::moving_object::Type::Pedestrian as i32);
    osi3::GroundTruth {
        host_vehicle_id: Some(id(HOST)),
        moving_object: vec![
            moving(HOST, "osiris:car?paint=white", [50.0, 0.0, 0.75], car, 25.0),
            moving(100, "osiris:car?paint=black", [90.0, 0.0, 0.75], car, 20.0),
            moving(
                101,
                "osiris:truck",
                [75.0, 3.5, 1.8],
                [10.0, 2.55, 3.6],
                22.0,
            ),
            moving(102, "osiris:car", [25.0, 0.0, 0.75], car, 25.0),
            moving(
                103,
                "osiris:cyclist",
                [130.0, -6.5, 0.875],
                [1.8, 0.6, 1.75],
                5.0,
            ),
            pedestrian,
        ],
        stationary_object: vec![
            stationary(
                500,
                "osiris:trihedral?edge_m=0.1",
                [150.0, -6.0, 0.575],
                [0.15, 0.15, 1.15],
            ),
            stationary(
                501,
                "osiris:board?width_m=1&height_m=1&material=lambertian_50",
                [180.0, -6.5, 1.0],
                [0.05, 1.0, 1.0],
            ),
            stationary(502, "osiris:cone", [120.0, -5.7, 0.25], [0.3, 0.3, 0.5]),
            stationary(
                900,
                "osiris:guardrail",
                [200.0, boundary_y(0) - SHOULDER - 0.5 - 0.15, 0.375],
                [LENGTH, 0.3, 0.75],
            ),
        ],
        lane: lanes,
        lane_boundary,
        ..Default::default()
    }
}

fn scene(gt: &osi3::GroundTruth) -> Scene {
    Scene::from_ground_truth(gt, None, MaterialDb::builtin()).unwrap()
}

/// Area and global bounds of the static triangles owned by `e`.
fn owned(s: &Scene, e: StaticElement) -> (f64, Option<(DVec3, DVec3)>) {
    let m = &s.static_world.mesh;
    let mut area = 0.0;
    let mut b: Option<(DVec3, DVec3)> = None;
    for o in s.static_owners.iter().filter(|o| o.element == e) {
        for t in o.first_triangle..o.first_triangle + o.triangle_count {
            area += triangle_area(m, t as usize);
            for p in m.triangle(t as usize) {
                let g = s.to_global(p.as_dvec3());
                b = Some(b.map_or((g, g), |(lo, hi)| (lo.min(g), hi.max(g))));
            }
        }
    }
    (area, b)
}

#[test]
fn road_strips_have_lane_width_times_length() {
    let s = scene(&ground_truth());
    for (lane, width) in [
        (1000, LANE_WIDTH),
        (1001, LANE_WIDTH),
        (1002, LANE_WIDTH),
        (1003, SHOULDER),
    ] {
        let (area, b) = owned(&s, StaticElement::Lane(lane));
        assert!(
            (area - width * LENGTH).abs() < 1e-3 * width * LENGTH,
            "lane {lane}: {area}"
        );
        let (lo, hi) = b.unwrap();
        assert!((hi.x - lo.x - LENGTH).abs() < 1e-3 && lo.z.abs() < 1e-4 && hi.z.abs() < 1e-4);
    }
    // Normals up; no triangle longer than the 10 m resampling along the road.
    let m = &s.static_world.mesh;
    let road = m.parts.iter().position(|p| p.name == "road").unwrap() as u16;
    for i in (0..m.triangle_count()).filter(|&i| m.triangle_part[i] == road) {
        let [a, b, c] = m.triangle(i).map(|p| p.as_dvec3());
        assert!((b - a).cross(c - a).z > 0.0);
        assert!(a.distance(b).max(b.distance(c)).max(c.distance(a)) < 10.0 + 7.0);
    }
    assert_eq!(s.static_world.part_material.len(), m.parts.len());
    let db = MaterialDb::builtin();
    assert_eq!(
        s.static_world.part_material[road as usize],
        db.id("asphalt_dry").unwrap()
    );
}

#[test]
fn markings_on_painted_boundaries() {
    let s = scene(&ground_truth());
    // Solid: the whole length; dashed (dash flags): 22 dashes of 6 m and a last one of 4 m.
    for (b, len) in [
        (2000, LENGTH),
        (2003, LENGTH),
        (2001, 22.0 * 6.0 + 4.0),
        (2002, 136.0),
    ] {
        let (area, bounds) = owned(&s, StaticElement::Marking(b));
        assert!(
            (area - MARKING * len).abs() < 1e-3,
            "boundary {b}: area {area}"
        );
        let (lo, hi) = bounds.unwrap();
        assert!(
            (lo.z - 0.001).abs() < 1e-5 && (hi.z - 0.001).abs() < 1e-5,
            "raised by 1 mm"
        );
        let y = boundary_y((b - 2000) as u32);
        assert!(
            (lo.y - (y - 0.5 * MARKING)).abs() < 1e-4 && (hi.y - (y + 0.5 * MARKING)).abs() < 1e-4
        );
    }
    // The road edge (type ROAD_EDGE, colour NONE) is not painted.
    assert_eq!(owned(&s, StaticElement::Marking(2004)).0, 0.0);
    // Marking triangles carry the paint material.
    let db = MaterialDb::builtin();
    let o = s
        .static_owners
        .iter()
        .find(|o| o.element == StaticElement::Marking(2000))
        .unwrap();
    assert_eq!(
        s.static_world.triangle_material(o.first_triangle as usize),
        db.id("lane_paint_white").unwrap()
    );
    assert_eq!(
        s.static_element(o.first_triangle),
        Some(StaticElement::Marking(2000))
    );

    // Without dash flags the configured pattern is used; without widths the default width.
    let mut gt = ground_truth();
    for p in &mut gt.lane_boundary[1].boundary_line {
        p.dash = None;
        p.width = None;
    }
    let opts = SceneOptions {
        dash_length_m: 3.0,
        dash_gap_m: 9.0,
        ..Default::default()
    };
    let s = SceneBuilder::new(MaterialDb::builtin())
        .options(opts)
        .build(&gt)
        .unwrap();
    // The boundary line runs 0 → 400 m: dashes start every 12 m, the last at 396 m (34 dashes of 3 m).
    let dashes = (LENGTH / 12.0).ceil();
    assert_eq!(dashes, 34.0);
    let (area, _) = owned(&s, StaticElement::Marking(2001));
    assert!((area - 0.12 * 3.0 * dashes).abs() < 1e-3, "area {area}");
}

#[test]
fn host_is_excluded_and_instances_carry_the_osi_pose() {
    let mut gt = ground_truth();
    // A tilted, turning object: yaw 0.3, pitch 0.05, roll −0.02, yaw rate 0.1 rad/s.
    let b = gt.moving_object[1].base.as_mut().unwrap();
    b.orientation = Some(rpy(-0.02, 0.05, 0.3));
    b.orientation_rate = Some(rpy(0.0, 0.0, 0.1));
    let s = scene(&gt);
    let ids: BTreeSet<u64> = s.instances.iter().map(|i| i.object_id).collect();
    assert_eq!(ids, BTreeSet::from([100, 101, 102, 103, 104]));
    assert!(s.instance(HOST).is_none());
    // The origin is the host position rounded to 100 m.
    assert_eq!(s.origin, DVec3::new(100.0, 0.0, 0.0));
    let inst = s.instance(100).unwrap();
    let mesh: &Mesh = &s.meshes[inst.mesh].mesh;
    // Hand-computed R = Rz(ψ)·Ry(θ)·Rx(φ).
    let (r, p, y) = (-0.02f64, 0.05f64, 0.3f64);
    let (sr, cr, sp, cp, sy, cy) = (r.sin(), r.cos(), p.sin(), p.cos(), y.sin(), y.cos());
    let rot = DMat3::from_cols(
        DVec3::new(cy * cp, sy * cp, -sp),
        DVec3::new(cy * sp * sr - sy * cr, sy * sp * sr + cy * cr, cp * sr),
        DVec3::new(cy * sp * cr + sy * sr, sy * sp * cr - cy * sr, cp * cr),
    );
    for k in [0, mesh.positions.len() / 2, mesh.positions.len() - 1] {
        let v = mesh.positions[k].as_dvec3();
        let expected = DVec3::new(90.0, 0.0, 0.75) + rot * v;
        let got = s.to_global(inst.pose_local.transform_point(v));
        assert!(got.distance(expected) < 1e-9, "{got} vs {expected}");
    }
    assert!((inst.pose_local.position - DVec3::new(-10.0, 0.0, 0.75)).length() < 1e-12);
    assert_eq!(inst.velocity_m_s, DVec3::new(20.0, 0.0, 0.0));
    assert!((inst.angular_velocity_rad_s - DVec3::new(0.0, 0.0, 0.1)).length() < 1e-12);
    // The mesh frame is the OSI box: bounds = dimension, centred.
    let (lo, hi) = mesh.bounds().unwrap();
    assert!(
        (hi.as_dvec3() - DVec3::new(2.25, 0.9, 0.75))
            .abs()
            .max_element()
            < 1e-3
    );
    assert!(
        (lo.as_dvec3() + DVec3::new(2.25, 0.9, 0.75))
            .abs()
            .max_element()
            < 1e-3
    );
    // An explicit host id overrides the ground truth's.
    let s = SceneBuilder::new(MaterialDb::builtin())
        .host_id(Some(100))
        .build(&gt)
        .unwrap();
    assert!(s.instance(100).is_none() && s.instance(HOST).is_some());
}

#[test]
fn stationary_objects_are_placed_in_the_static_world() {
    let s = scene(&ground_truth());
    // Trihedral on its post: exactly its OSI box in z, post down to the ground.
    let (_, b) = owned(&s, StaticElement::Object(500));
    let (lo, hi) = b.unwrap();
    assert!(lo.z.abs() < 1e-5 && (hi.z - 1.15).abs() < 1e-5, "{lo} {hi}");
    assert!((0.5 * (lo.x + hi.x) - 150.0).abs() < 1e-4 && (0.5 * (lo.y + hi.y) + 6.0).abs() < 1e-4);
    // Board: exactly its box; face towards +x (yaw 0), area 1 m².
    let (_, b) = owned(&s, StaticElement::Object(501));
    let (lo, hi) = b.unwrap();
    assert!((lo - DVec3::new(179.975, -7.0, 0.5)).abs().max_element() < 1e-4);
    assert!((hi - DVec3::new(180.025, -6.0, 1.5)).abs().max_element() < 1e-4);
    // Guardrail: 400 m along the road.
    let (_, b) = owned(&s, StaticElement::Object(900));
    let (lo, hi) = b.unwrap();
    assert!((lo.x - 0.0).abs() < 1e-3 && (hi.x - 400.0).abs() < 1e-3 && (hi.z - 0.75).abs() < 1e-4);
    // Part materials resolve to the database's ids (lambertian_50 created on use).
    let m = &s.static_world.mesh;
    for (p, &mid) in m.parts.iter().zip(&s.static_world.part_material) {
        assert_eq!(s.materials.name(mid), p.material);
    }
    assert!(s.materials.id("lambertian_50").is_some());
    // Every static triangle has exactly one owner.
    let covered: u32 = s.static_owners.iter().map(|o| o.triangle_count).sum();
    assert_eq!(covered as usize, m.triangle_count());
}

#[test]
fn update_rebuilds_the_static_world_only_when_it_changed() {
    let gt = ground_truth();
    let mut s = scene(&gt);
    assert_eq!(s.static_revision, 1);
    let static_before = s.static_world.clone();
    // Moving objects move, the host changes lane (is_host_vehicle_lane flips): no static rebuild.
    let mut gt2 = gt.clone();
    for o in &mut gt2.moving_object {
        let p = o.base.as_mut().unwrap().position.as_mut().unwrap();
        p.x = Some(p.x.unwrap() + 0.5);
    }
    for l in &mut gt2.lane {
        let c = l.classification.as_mut().unwrap();
        c.is_host_vehicle_lane = Some(!c.is_host_vehicle_lane.unwrap());
    }
    let u = s.update(&gt2).unwrap();
    assert!(!u.static_rebuilt && !u.rebased);
    assert_eq!(s.static_revision, 1);
    assert_eq!(s.static_world, static_before);
    assert!(u.new_meshes.is_empty() && u.added.is_empty() && u.removed.is_empty());
    assert!((s.instance(100).unwrap().pose_local.position.x - (-9.5)).abs() < 1e-12);
    // An object leaves, another appears.
    let mut gt3 = gt2.clone();
    gt3.moving_object
        .retain(|o| o.id.unwrap().value != Some(102));
    gt3.moving_object.push(moving(
        105,
        "osiris:van",
        [60.0, 3.5, 1.15],
        [5.4, 2.0, 2.3],
        20.0,
    ));
    let u = s.update(&gt3).unwrap();
    assert_eq!((u.added, u.removed), (vec![105], vec![102]));
    assert_eq!(u.new_meshes.len(), 1);
    assert!(!u.static_rebuilt);
    // A stationary object moves: rebuilt.
    let mut gt4 = gt3.clone();
    gt4.stationary_object[2]
        .base
        .as_mut()
        .unwrap()
        .position
        .as_mut()
        .unwrap()
        .x = Some(121.0);
    let u = s.update(&gt4).unwrap();
    assert!(u.static_rebuilt);
    assert_eq!(s.static_revision, 2);
    let (_, b) = owned(&s, StaticElement::Object(502));
    assert!((0.5 * (b.unwrap().0.x + b.unwrap().1.x) - 121.0).abs() < 1e-4);
    // A lane boundary changes: rebuilt.
    let mut gt5 = gt4.clone();
    gt5.lane_boundary[0].boundary_line[3].width = Some(0.3);
    assert!(s.update(&gt5).unwrap().static_rebuilt);
    // The same again: not rebuilt.
    assert!(!s.update(&gt5).unwrap().static_rebuilt);
    assert_eq!(s.static_revision, 3);
}

#[test]
fn identical_assets_share_one_mesh() {
    let mut gt = ground_truth();
    gt.moving_object.truncate(1); // the host only
    for i in 0..450 {
        let x = f64::from(i) * 8.0;
        gt.moving_object.push(moving(
            100 + i as u64,
            "osiris:car?paint=black",
            [x, 0.0, 0.75],
            [4.5, 1.8, 1.5],
            20.0,
        ));
    }
    let mut s = scene(&gt);
    assert_eq!(s.instances.len(), 450);
    assert_eq!(s.meshes.len(), 1);
    assert!(s.instances.iter().all(|i| i.mesh == 0));
    // Equivalent spellings share too (canonical reference).
    gt.moving_object.push(moving(
        600,
        "osiris:car?paint=car_paint_black&&",
        [0.0, 3.5, 0.75],
        [4.5, 1.8, 1.5],
        20.0,
    ));
    // Another paint or size gets its own mesh.
    gt.moving_object.push(moving(
        601,
        "osiris:car?paint=white",
        [0.0, 3.5, 0.75],
        [4.5, 1.8, 1.5],
        20.0,
    ));
    gt.moving_object.push(moving(
        602,
        "osiris:car?paint=black",
        [0.0, 3.5, 0.75],
        [4.2, 1.8, 1.5],
        20.0,
    ));
    let u = s.update(&gt).unwrap();
    assert_eq!(s.meshes.len(), 3);
    assert_eq!(u.new_meshes, 1..3);
    assert_eq!(s.instance(600).unwrap().mesh, 0);
    // Part materials of a shared mesh.
    let m = &s.meshes[0];
    assert_eq!(m.part_material.len(), m.mesh.parts.len());
    assert_eq!(s.materials.name(m.part_material[0]), "car_paint_black");
}

#[test]
fn default_assets_and_reference_fallbacks() {
    let mut gt = ground_truth();
    // No reference: the type decides (a pedestrian).
    gt.moving_object[5].model_reference = None;
    // A foreign reference that cannot be used: default with a warning.
    gt.moving_object[4].model_reference = Some("models/bike.osgb".into());
    gt.moving_object[3].model_reference = Some("mirror_L.glb".into());
    let s = scene(&gt);
    assert_eq!(s.warnings.len(), 2, "{:?}", s.warnings);
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("mirror_L.glb") && w.contains("moving object 102"))
    );
    let key = |oid: u64| s.meshes[s.instance(oid).unwrap().mesh].key.clone();
    assert!(key(104).starts_with("osiris:pedestrian"), "{}", key(104));
    assert!(key(102).starts_with("osiris:car @"), "{}", key(102));
    // Strict: an error naming the object.
    let opts = SceneOptions {
        strict_references: true,
        ..Default::default()
    };
    let e = SceneBuilder::new(MaterialDb::builtin())
        .options(opts)
        .build(&gt)
        .unwrap_err();
    assert!(matches!(e, SceneError::Asset { .. }));
    // A malformed osiris reference is always an error naming object, reference and parameter.
    let mut gt = ground_truth();
    gt.moving_object[2].model_reference = Some("osiris:truck?paint=Red!".into());
    let e = Scene::from_ground_truth(&gt, None, MaterialDb::builtin())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("moving object 101")
            && e.contains("paint")
            && e.contains("osiris:truck?paint=Red!"),
        "{e}"
    );
    // An unknown material name fails at resolution and names mesh, part and material.
    let mut gt = ground_truth();
    gt.stationary_object[1].model_reference = Some("osiris:board?material=unobtainium".into());
    let e = Scene::from_ground_truth(&gt, None, MaterialDb::builtin())
        .unwrap_err()
        .to_string();
    assert!(e.contains("unobtainium") && e.contains("face"), "{e}");
}

#[test]
fn fallback_road_plane_rebase_and_wetness() {
    let mut gt = ground_truth();
    gt.lane.clear();
    let s = scene(&gt);
    let (area, b) = owned(&s, StaticElement::RoadPlane);
    assert!((area - 1000.0 * 1000.0).abs() < 1.0);
    let (lo, hi) = b.unwrap();
    assert!(
        lo.z.abs() < 1e-6 && hi.z.abs() < 1e-6,
        "plane at the host's wheel contact (z = 0)"
    );
    assert!(owned(&s, StaticElement::Lane(1000)).1.is_none());

    // The host drives 5 km: the origin follows and the static world is rebuilt.
    let gt = ground_truth();
    let mut s = scene(&gt);
    let mut far = gt.clone();
    far.moving_object[0].base.as_mut().unwrap().position = Some(v3([5050.0, 0.0, 0.75]));
    let u = s.update(&far).unwrap();
    assert!(u.rebased && u.static_rebuilt);
    assert_eq!(s.origin, DVec3::new(5100.0, 0.0, 0.0));
    let inst = s.instance(100).unwrap();
    assert!((s.to_global(inst.pose_local.position) - DVec3::new(90.0, 0.0, 0.75)).length() < 1e-9);

    // Rain: wet; with wet materials the road uses asphalt_wet.
    let mut gt = ground_truth();
    gt.environmental_conditions = Some(osi3::EnvironmentalConditions {
        precipitation: Some(osi3::environmental_conditions::Precipitation::Moderate as i32),
        ..Default::default()
    });
    assert!(scene(&gt).wet && !scene(&ground_truth()).wet);
    let opts = SceneOptions {
        use_wet_materials: true,
        ..Default::default()
    };
    let s = SceneBuilder::new(MaterialDb::builtin())
        .options(opts)
        .build(&gt)
        .unwrap();
    let m = &s.static_world.mesh;
    assert!(
        m.parts
            .iter()
            .any(|p| p.name == "road" && p.material == "asphalt_wet")
    );
    assert!(
        m.parts
            .iter()
            .any(|p| p.name == "marking" && p.material == "lane_paint_white_wet")
    );
}
