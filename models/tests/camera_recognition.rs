//! Tests of the camera recognition (`osiris_models::recognition::camera`) on synthetic renders: the
//! object mask, depth and luminance are made here by intersecting the lens's pixel rays with the
//! ground-truth boxes and a flat road (no renderer), so the expectations are closed-form pinhole /
//! ground-plane geometry.

mod common;
use common::v3;
use glam::DVec3;
use osiris_models::camera::lens::{Lens, LensConfig};
use osiris_models::camera::{NO_OBJECT, RenderAux};
use osiris_models::effects::Effects;
use osiris_models::frames::{Pose, SensorFrame};
use osiris_models::recognition::camera::{
    CameraRecognition, CameraRecognitionConfig, CameraRecognitionInput, divp_type_code,
};
use osiris_models::registry::catalogue;
use osiris_proto::{id, osi3, perception};

const W: usize = 640;
const H: usize = 480;
/// Horizontal field of view, rad (50°).
const HFOV: f64 = 50.0 * std::f64::consts::PI / 180.0;
/// Camera height above the road, m.
const CAM_H: f64 = 1.3;
const CAR: [f64; 3] = [4.5, 1.8, 1.5];
const LUM_CAR: f32 = 30.0;
const LUM_ROAD: f32 = 10.0;
const LUM_SKY: f32 = 100.0;

fn lens() -> Lens {
    let effects = Effects::new(&catalogue());
    Lens::new(&LensConfig::default(), W, H, 3e-6, HFOV, &effects).unwrap()
}

fn vehicle(oid: u64, centre: [f64; 3], d: [f64; 3]) -> osi3::MovingObject {
    use osi3::moving_object::vehicle_classification::Type as V;
    osi3::MovingObject {
        id: Some(id(oid)),
        base: Some(osi3::BaseMoving {
            dimension: Some(osi3::Dimension3d {
                length: Some(d[0]),
                width: Some(d[1]),
                height: Some(d[2]),
            }),
            position: Some(v3([centre[0], centre[1], centre[2]])),
            orientation: Some(osi3::Orientation3d {
                roll: Some(0.0),
                pitch: Some(0.0),
                yaw: Some(0.0),
            }),
            ..Default::default()
        }),
        r#type: Some(osi3::moving_object::Type::Vehicle as i32),
        vehicle_classification: Some(osi3::moving_object::VehicleClassification {
            r#type: Some(V::Car as i32),
            ..Default::default()
        }),
        ..Default::default()
    }
}

/// A car whose rear face is `d` m ahead of the camera (global = sensor axes, camera at
/// (0, 0, CAM_H)), on the road (bottom at z = 0).
fn car_at(oid: u64, d: f64, y: f64) -> osi3::MovingObject {
    vehicle(oid, [d + 0.5 * CAR[0], y, 0.5 * CAR[2]], CAR)
}

fn frame() -> SensorFrame {
    SensorFrame::at_rest(Pose::new(
        DVec3::new(0.0, 0.0, CAM_H),
        glam::DMat3::IDENTITY,
    ))
}

/// Distance along `dir` from `origin` to an axis-aligned box, if hit.
fn hit_box(origin: DVec3, dir: DVec3, centre: DVec3, half: DVec3) -> Option<f64> {
    let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
    for k in 0..3 {
        if dir[k].abs() < 1e-12 {
            if (origin[k] - centre[k]).abs() > half[k] {
                return None;
            }
            continue;
        }
        let a = (centre[k] - half[k] - origin[k]) / dir[k];
        let b = (centre[k] + half[k] - origin[k]) / dir[k];
        t0 = t0.max(a.min(b));
        t1 = t1.min(a.max(b));
    }
    (t0 <= t1).then_some(t0)
}

/// Synthetic render: each pixel's ray against the boxes of `gt` (index into `object_ids` = order
/// in `gt.moving_object`) and the road plane z = 0; luminance from `lum_of(object index)`,
/// road and sky constants.
fn render(
    lens: &Lens,
    gt: &osi3::GroundTruth,
    lum_of: &dyn Fn(usize) -> f32,
    lum_road: f32,
    lum_sky: f32,
) -> (RenderAux, Vec<f32>) {
    let parts: Vec<(usize, DVec3, DVec3)> = gt
        .moving_object
        .iter()
        .enumerate()
        .map(|(k, o)| {
            let b = o.base.as_ref().unwrap();
            let p = b.position.as_ref().unwrap();
            let d = b.dimension.as_ref().unwrap();
            (
                k,
                DVec3::new(p.x.unwrap(), p.y.unwrap(), p.z.unwrap()),
                0.5 * DVec3::new(d.length.unwrap(), d.width.unwrap(), d.height.unwrap()),
            )
        })
        .collect();
    render_parts(lens, gt, &parts, lum_of, lum_road, lum_sky)
}

/// As [`render`], with the objects made of axis-aligned boxes `(object index, centre, half size)`.
fn render_parts(
    lens: &Lens,
    gt: &osi3::GroundTruth,
    parts: &[(usize, DVec3, DVec3)],
    lum_of: &dyn Fn(usize) -> f32,
    lum_road: f32,
    lum_sky: f32,
) -> (RenderAux, Vec<f32>) {
    let origin = DVec3::new(0.0, 0.0, CAM_H);
    let mut aux = RenderAux {
        object_index: vec![NO_OBJECT; W * H],
        depth_m: vec![f32::INFINITY; W * H],
        object_ids: gt
            .moving_object
            .iter()
            .map(|o| o.id.unwrap().value.unwrap())
            .collect(),
    };
    let mut lum = vec![lum_sky; W * H];
    for (i, r) in lens.ray_directions().iter().enumerate() {
        let d: DVec3 = r.as_dvec3();
        let mut best: Option<(f64, usize)> = None;
        for &(k, c, h) in parts {
            if let Some(t) = hit_box(origin, d, c, h)
                && best.is_none_or(|(b, _)| t < b)
            {
                best = Some((t, k));
            }
        }
        if let Some((t, k)) = best {
            aux.object_index[i] = k as u32;
            aux.depth_m[i] = t as f32;
            lum[i] = lum_of(k);
        } else if d.z < 0.0 {
            aux.depth_m[i] = (CAM_H / -d.z) as f32;
            lum[i] = lum_road;
        }
    }
    (aux, lum)
}

fn deterministic() -> CameraRecognitionConfig {
    CameraRecognitionConfig {
        random_draw: false,
        ..Default::default()
    }
}

struct Run {
    objects: Vec<osi3::DetectedMovingObject>,
    divp: Vec<perception::CameraObject>,
    rec: CameraRecognition,
}

fn run(
    config: &CameraRecognitionConfig,
    gt: &osi3::GroundTruth,
    aux: &RenderAux,
    lum: &[f32],
    lens: &Lens,
    cycle: u64,
) -> Run {
    let mut rec = CameraRecognition::new(config).unwrap();
    let frame = frame();
    let input = CameraRecognitionInput {
        aux: aux.objects(),
        luminance: lum,
        lens,
        ground_truth: gt,
        frame: &frame,
        reported_rotation: frame.pose.rotation,
        camera_height_m: CAM_H,
        time_s: 0.0,
        seed: 7,
        cycle,
    };
    let mut objects = Vec::new();
    let mut divp = Vec::new();
    rec.step(&input, &mut objects, &mut divp);
    Run { objects, divp, rec }
}

fn gt_with(objs: Vec<osi3::MovingObject>) -> osi3::GroundTruth {
    osi3::GroundTruth {
        moving_object: objs,
        ..Default::default()
    }
}

#[test]
fn recognition_finds_a_car_at_20_m_and_its_distance_within_5_percent() {
    let lens = lens();
    for d in [10.0, 20.0, 40.0] {
        let gt = gt_with(vec![car_at(5, d, 0.0)]);
        let (aux, lum) = render(&lens, &gt, &|_| LUM_CAR, LUM_ROAD, LUM_SKY);
        let r = run(&deterministic(), &gt, &aux, &lum, &lens, 0);
        assert_eq!(r.divp.len(), 1, "car at {d} m not detected");
        let o = &r.divp[0];
        let m = &r.rec.measurements()[0];
        assert!(m.from_ground_contact);
        let long = o.longitudinal_distance_m.unwrap();
        let err = (long - d).abs() / d;
        println!(
            "d = {d} m: estimate {long:.3} m ({:.2} %), lateral {:.3} m, box h {} px, height \
             {:.2} m, p_d {:.3}, contrast {:.3}",
            100.0 * err,
            o.lateral_distance_m.unwrap(),
            o.screen_height_px.unwrap(),
            o.height_m.unwrap(),
            o.detection_probability.unwrap(),
            o.contrast.unwrap()
        );
        assert!(err < 0.05, "distance {long} m vs {d} m");
        assert!(o.lateral_distance_m.unwrap().abs() < 0.05 * d);
        assert!((o.vertical_position_m.unwrap() + CAM_H).abs() < 1e-9);
        // Estimated height from the box: the car's 1.5 m within 10 %.
        assert!((o.height_m.unwrap() - CAR[2]).abs() < 0.1 * CAR[2]);
        assert_eq!(o.type_code, Some(2));
        assert_eq!(o.object_id, Some(5));
        // Weber contrast of the car against the side of its surroundings it stands out from
        // most: the road below (car 30 vs road 10 → +2), not the sky above (−0.7).
        let c = o.contrast.unwrap();
        let c_road = (LUM_CAR / LUM_ROAD - 1.0) as f64;
        assert!((c - c_road).abs() < 0.05 * c_road, "contrast {c}");
        // OSI: sensor frame, box centre = rear face + half the typical car length (= the truth).
        let obj = &r.objects[0];
        let p = obj.base.as_ref().unwrap().position.as_ref().unwrap();
        let x_truth = d + 0.5 * CAR[0];
        assert!((p.x.unwrap() - x_truth).abs() < 0.05 * x_truth);
        assert!(p.y.unwrap().abs() < 0.05 * d);
        assert!(
            (p.z.unwrap() - (0.5 * CAR[2] - CAM_H)).abs() < 0.05,
            "z {}",
            p.z.unwrap()
        );
        let header = obj.header.as_ref().unwrap();
        assert_eq!(header.ground_truth_id[0].value, Some(5));
        assert!(header.existence_probability.unwrap() > 0.5);
        assert_eq!(
            obj.candidate[0].r#type,
            Some(osi3::moving_object::Type::Vehicle as i32)
        );
    }
}

#[test]
fn lateral_offset_is_recovered() {
    let lens = lens();
    // A car in the left lane: rear face at 25 m, 3.5 m to the left.
    let gt = gt_with(vec![car_at(5, 25.0, 3.5)]);
    let (aux, lum) = render(&lens, &gt, &|_| LUM_CAR, LUM_ROAD, LUM_SKY);
    let r = run(&deterministic(), &gt, &aux, &lum, &lens, 0);
    let o = &r.divp[0];
    println!(
        "long {:.3} lat {:.3}",
        o.longitudinal_distance_m.unwrap(),
        o.lateral_distance_m.unwrap()
    );
    assert!((o.longitudinal_distance_m.unwrap() - 25.0).abs() < 0.05 * 25.0);
    assert!((o.lateral_distance_m.unwrap() - 3.5).abs() < 0.05 * 3.5 + 0.1);
}

#[test]
fn box_centre_and_size_match_the_projected_rear_face() {
    let lens = lens();
    let d = 20.0;
    let gt = gt_with(vec![car_at(5, d, 0.0)]);
    let (aux, lum) = render(&lens, &gt, &|_| LUM_CAR, LUM_ROAD, LUM_SKY);
    let r = run(&deterministic(), &gt, &aux, &lum, &lens, 0);
    let o = &r.divp[0];
    // Rear-face corners in the sensor frame (camera at height CAM_H).
    let left_top = lens
        .project(DVec3::new(d, 0.5 * CAR[1], CAR[2] - CAM_H))
        .unwrap();
    let right_bottom = lens.project(DVec3::new(d, -0.5 * CAR[1], -CAM_H)).unwrap();
    let exp_w = right_bottom.x - left_top.x;
    let exp_h = right_bottom.y - left_top.y;
    println!(
        "box {}×{} px at ({}, {}); projected {exp_w:.1}×{exp_h:.1} at ({:.1}, {:.1})",
        o.screen_width_px.unwrap(),
        o.screen_height_px.unwrap(),
        o.centre_u_px.unwrap(),
        o.centre_v_px.unwrap(),
        0.5 * (left_top.x + right_bottom.x),
        0.5 * (left_top.y + right_bottom.y)
    );
    assert!((o.screen_width_px.unwrap() as f64 - exp_w).abs() <= 1.0);
    assert!((o.screen_height_px.unwrap() as f64 - exp_h).abs() <= 1.0);
    assert!((o.centre_u_px.unwrap() as f64 - 0.5 * (left_top.x + right_bottom.x)).abs() <= 1.0);
    assert!((o.centre_v_px.unwrap() as f64 - 0.5 * (left_top.y + right_bottom.y)).abs() <= 1.0);
    assert!((o.box_u_min_px.unwrap() - left_top.x).abs() <= 1.0);
    assert!((o.box_v_max_px.unwrap() - right_bottom.y).abs() <= 1.0);
    // Unoccluded: visible fraction 1 (pixel-centre sampling: exact up to rounding).
    assert!(o.visible_fraction.unwrap() > 0.99);
}

#[test]
fn half_occluded_car_has_visible_fraction_one_half() {
    let lens = lens();
    // The occluder's right edge lies on the optical axis plane (y = 0), so it hides exactly the
    // left half (y > 0) of the car's rear face at 20 m.
    let mut occluder = vehicle(9, [10.0, 1.5, 2.0], [0.5, 3.0, 4.0]);
    occluder.r#type = Some(osi3::moving_object::Type::Other as i32);
    occluder.vehicle_classification = None;
    let gt = gt_with(vec![car_at(5, 20.0, 0.0), occluder]);
    let (aux, lum) = render(
        &lens,
        &gt,
        &|k| if k == 0 { LUM_CAR } else { 50.0 },
        LUM_ROAD,
        LUM_SKY,
    );
    let r = run(&deterministic(), &gt, &aux, &lum, &lens, 0);
    let m = r
        .rec
        .measurements()
        .iter()
        .find(|m| m.ground_truth_id == 5)
        .unwrap();
    println!(
        "visible {} of {} px: fraction {:.3}, p_d {:.3}",
        m.visible_px, m.expected_px, m.visible_fraction, m.detection_probability
    );
    assert!((m.visible_fraction - 0.5).abs() < 0.03);
    // Still detected, with the distance from the visible half's ground contact.
    let o = r.divp.iter().find(|o| o.object_id == Some(5)).unwrap();
    assert!((o.longitudinal_distance_m.unwrap() - 20.0).abs() < 1.0);
    assert!(o.screen_width_px.unwrap() < 40);
    // The occluder is "other" (204).
    if let Some(occ) = r.divp.iter().find(|o| o.object_id == Some(9)) {
        assert_eq!(occ.type_code, Some(204));
    }
}

#[test]
fn zero_contrast_or_few_pixels_is_not_detected() {
    let lens = lens();
    // Same luminance everywhere: Weber contrast 0.
    let gt = gt_with(vec![car_at(5, 20.0, 0.0)]);
    let (aux, lum) = render(&lens, &gt, &|_| 20.0, 20.0, 20.0);
    let r = run(&deterministic(), &gt, &aux, &lum, &lens, 0);
    assert!(r.divp.is_empty() && r.objects.is_empty());
    let m = &r.rec.measurements()[0];
    assert!(m.contrast.abs() < 1e-6);
    assert_eq!(m.detection_probability, 0.0);

    // A car at 250 m: 1.5 m · 686 px / 250 m ≈ 4 px high, below the 8 px threshold.
    let gt = gt_with(vec![car_at(5, 250.0, 0.0)]);
    let (aux, lum) = render(&lens, &gt, &|_| LUM_CAR, LUM_ROAD, LUM_SKY);
    let r = run(&deterministic(), &gt, &aux, &lum, &lens, 0);
    let m = &r.rec.measurements()[0];
    println!("car at 250 m: {} px high", m.box_px[3] - m.box_px[1]);
    assert!(m.box_px[3] - m.box_px[1] < 8.0);
    assert!(r.divp.is_empty());
}

#[test]
fn detection_probability_model() {
    let c = CameraRecognitionConfig::default();
    // Factors at their 50 % points multiply to p_max / 8.
    let p = c.detection_probability(c.visible_fraction_50, c.height_50_px, c.contrast_50);
    assert!((p - c.max_probability / 8.0).abs() < 1e-12);
    // Monotonic in each argument.
    let mut last = 0.0;
    for h in [8.0, 10.0, 20.0, 40.0, 80.0, 200.0] {
        let p = c.detection_probability(1.0, h, 0.5);
        assert!(p >= last);
        last = p;
    }
    assert!(last > 0.95 * c.max_probability);
    assert_eq!(c.detection_probability(1.0, 7.9, 0.5), 0.0);
    assert_eq!(c.detection_probability(0.05, 100.0, 0.5), 0.0);
    assert_eq!(c.detection_probability(1.0, 100.0, 0.01), 0.0);
    // Negative contrast (dark object on bright background) counts by magnitude.
    assert_eq!(
        c.detection_probability(1.0, 100.0, -0.3),
        c.detection_probability(1.0, 100.0, 0.3)
    );
}

#[test]
fn bernoulli_draw_is_seeded_and_follows_p_d() {
    let lens = lens();
    let gt = gt_with(vec![car_at(5, 20.0, 0.0)]);
    let (aux, lum) = render(&lens, &gt, &|_| LUM_CAR, LUM_ROAD, LUM_SKY);
    // Move the 50 % height point to the car's box height so that p_d ≈ 0.5.
    let probe = run(&deterministic(), &gt, &aux, &lum, &lens, 0);
    let h = probe.rec.measurements()[0].box_px[3] - probe.rec.measurements()[0].box_px[1];
    let config = CameraRecognitionConfig {
        height_50_px: h,
        max_probability: 1.0,
        visible_fraction_50: 0.0,
        contrast_50: 1e-3,
        ..Default::default()
    };
    let p = run(&config, &gt, &aux, &lum, &lens, 0).rec.measurements()[0].detection_probability;
    let n = 400;
    let hits = (0..n)
        .filter(|&cycle| !run(&config, &gt, &aux, &lum, &lens, cycle).divp.is_empty())
        .count();
    let rate = hits as f64 / n as f64;
    // Binomial standard deviation at n = 400 is 0.025: allow 4σ.
    println!("p_d {p:.3}, detection rate {rate:.3}");
    assert!((rate - p).abs() < 0.1);
    // Same seed and cycle → same outcome.
    for cycle in 0..20 {
        let a = run(&config, &gt, &aux, &lum, &lens, cycle).divp.len();
        let b = run(&config, &gt, &aux, &lum, &lens, cycle).divp.len();
        assert_eq!(a, b);
    }
}

#[test]
fn divp_type_codes() {
    use osi3::moving_object::Type;
    use osi3::moving_object::vehicle_classification::Type as V;
    let veh = |v: V| {
        let mut o = car_at(1, 10.0, 0.0);
        o.vehicle_classification = Some(osi3::moving_object::VehicleClassification {
            r#type: Some(v as i32),
            ..Default::default()
        });
        divp_type_code(&o)
    };
    assert_eq!(veh(V::SmallCar), 1);
    assert_eq!(veh(V::Car), 2);
    assert_eq!(veh(V::CompactCar), 2);
    assert_eq!(veh(V::HeavyTruck), 3);
    assert_eq!(veh(V::Semitrailer), 3);
    assert_eq!(veh(V::Bus), 4);
    assert_eq!(veh(V::Motorbike), 5);
    assert_eq!(veh(V::Bicycle), 6);
    assert_eq!(veh(V::StandupScooter), 10);
    let typed = |t: Type, height: f64| {
        let mut o = vehicle(1, [10.0, 0.0, 0.5 * height], [0.5, 0.5, height]);
        o.r#type = Some(t as i32);
        o.vehicle_classification = None;
        divp_type_code(&o)
    };
    assert_eq!(typed(Type::Pedestrian, 1.75), 101);
    assert_eq!(typed(Type::Pedestrian, 1.1), 102);
    assert_eq!(typed(Type::Animal, 0.8), 203);
    assert_eq!(typed(Type::Other, 1.0), 204);
    assert_eq!(typed(Type::Unknown, 1.0), 204);
}

#[test]
fn bad_config_names_the_key() {
    let c = CameraRecognitionConfig {
        min_visible_fraction: 1.5,
        ..Default::default()
    };
    let e = CameraRecognition::new(&c).err().unwrap().to_string();
    assert!(e.contains("camera.recognition.min_visible_fraction"), "{e}");
    let e = serde_json::from_str::<CameraRecognitionConfig>(r#"{"min_heigth_px": 3}"#)
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("min_heigth_px"), "{e}");
}

#[test]
fn car_on_tyres_distance_is_to_its_rear_face() {
    // A car like the `osiris:car` asset seen from behind: body from 0.18 m above the road, tyres
    // (radius 0.315 m, 0.22 m wide, at the outer sides) on axles 0.9 m from either end. The
    // lowest pixels are the rear tyres' contact 0.9 m behind the rear face.
    let lens = lens();
    for d in [10.0, 20.0, 40.0] {
        let gt = gt_with(vec![car_at(5, d, 0.0)]);
        let body_z = (0.18, CAR[2]);
        let mut parts = vec![(
            0usize,
            DVec3::new(d + 0.5 * CAR[0], 0.0, 0.5 * (body_z.0 + body_z.1)),
            DVec3::new(0.5 * CAR[0], 0.5 * CAR[1], 0.5 * (body_z.1 - body_z.0)),
        )];
        for axle_x in [d + 0.9, d + CAR[0] - 0.9] {
            for y in [-0.79, 0.79] {
                parts.push((
                    0,
                    DVec3::new(axle_x, y, 0.315),
                    DVec3::new(0.315, 0.11, 0.315),
                ));
            }
        }
        let (aux, lum) = render_parts(&lens, &gt, &parts, &|_| LUM_CAR, LUM_ROAD, LUM_SKY);
        let r = run(&deterministic(), &gt, &aux, &lum, &lens, 0);
        let m = &r.rec.measurements()[0];
        let long = r.divp[0].longitudinal_distance_m.unwrap();
        println!(
            "tyres, rear face at {d} m: estimate {long:.3} m ({:+.2} %), overhang {:.2} m",
            100.0 * (long / d - 1.0),
            m.overhang_m
        );
        assert!(m.from_ground_contact && m.overhang_m > 0.8);
        assert!((long / d - 1.0).abs() < 0.05, "{long} vs {d}");
        let p = r.objects[0]
            .base
            .as_ref()
            .unwrap()
            .position
            .as_ref()
            .unwrap();
        let x_truth = d + 0.5 * CAR[0];
        assert!((p.x.unwrap() - x_truth).abs() < 0.05 * x_truth);
    }
    // A box reaching the road is not corrected.
    let gt = gt_with(vec![car_at(5, 20.0, 0.0)]);
    let (aux, lum) = render(&lens, &gt, &|_| LUM_CAR, LUM_ROAD, LUM_SKY);
    let r = run(&deterministic(), &gt, &aux, &lum, &lens, 0);
    assert_eq!(r.rec.measurements()[0].overhang_m, 0.0);
}
