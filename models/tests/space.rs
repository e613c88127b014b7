//! Space design: analytic checks of the ray queries, paths, Doppler and transmission.

use glam::{DMat3, DVec3, Vec3};
use osiris_models::effects::Effects;
use osiris_models::environment::material::MaterialId;
use osiris_models::environment::mesh::Mesh;
use osiris_models::frames::Pose;
use osiris_models::space::{
    self, BvhKind, Hit, InstanceDesc, MeshHandle, PathPolicy, Ray, Segment, Space, SpaceBuilder,
    SpaceEffects, SpaceError, Sweep, doppler_shift_hz, quad, subdivided_box,
};

const KINDS: [BvhKind; 2] = [BvhKind::Bvh2, BvhKind::CwBvh];
const GROUND: MaterialId = MaterialId(10);
const WALL: MaterialId = MaterialId(11);
const PAINT: MaterialId = MaterialId(12);

/// A deterministic uniform generator for test inputs (SplitMix64).
struct Rng(u64);
impl Rng {
    fn f(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e3779b97f4a7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58476d1ce4e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d049bb133111eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.f()
    }
    fn unit(&mut self) -> DVec3 {
        let z = self.range(-1.0, 1.0);
        let phi = self.range(0.0, std::f64::consts::TAU);
        let r = (1.0 - z * z).sqrt();
        DVec3::new(r * phi.cos(), r * phi.sin(), z)
    }
}

/// A single-part mesh.
fn mesh_with(part: &str, f: impl FnOnce(&mut Mesh, u16)) -> Mesh {
    let mut m = Mesh::default();
    let p = m.part(part, part);
    f(&mut m, p);
    m
}

/// Horizontal ground plane z = 0 over ±half (m), `n × n` cells.
fn ground(half: f32, n: u32) -> Mesh {
    mesh_with("ground", |m, p| {
        quad(
            m,
            [
                Vec3::new(-half, -half, 0.0),
                Vec3::new(half, -half, 0.0),
                Vec3::new(half, half, 0.0),
                Vec3::new(-half, half, 0.0),
            ],
            n,
            n,
            p,
        )
    })
}

/// A vertical wall x = x0 facing −x (towards the origin), y ∈ ±half_y, z ∈ [0, height].
fn wall(x0: f32, half_y: f32, height: f32) -> Mesh {
    mesh_with("wall", |m, p| {
        quad(
            m,
            [
                Vec3::new(x0, -half_y, 0.0),
                Vec3::new(x0, -half_y, height),
                Vec3::new(x0, half_y, height),
                Vec3::new(x0, half_y, 0.0),
            ],
            4,
            4,
            p,
        )
    })
}

fn unit_box(n: u32) -> Mesh {
    mesh_with("body", |m, p| {
        subdivided_box(m, Vec3::splat(-1.0), Vec3::splat(1.0), n, p)
    })
}

fn instance(object_id: u64, mesh: MeshHandle, position: DVec3, yaw: f64) -> InstanceDesc {
    InstanceDesc {
        object_id,
        mesh,
        pose: Pose::new(position, DMat3::from_rotation_z(yaw)),
        linear_velocity: DVec3::ZERO,
        angular_velocity: DVec3::ZERO,
    }
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

#[test]
fn ray_plane_distance_is_h_over_cos_theta() {
    for kind in KINDS {
        let mut b = SpaceBuilder::new().bvh_kind(kind);
        b.add_static(&ground(200.0, 64), &[GROUND]).unwrap();
        let space = b.build();
        let h = 1.73;
        for (k, theta_deg) in [0.0, 10.0, 33.0, 60.0, 80.0, 85.0].into_iter().enumerate() {
            let theta = f64::to_radians(theta_deg);
            let az = 0.7 * k as f64;
            let d = DVec3::new(theta.sin() * az.cos(), theta.sin() * az.sin(), -theta.cos());
            let origin = DVec3::new(3.1, -2.2, h);
            let hit = space.closest_hit(&Ray::new(origin, d)).expect("ground hit");
            let expected = h / theta.cos();
            assert!(
                close(hit.distance_m, expected, 1e-9 * expected),
                "θ={theta_deg}: {} vs {expected}",
                hit.distance_m
            );
            assert!((hit.point - (origin + d * expected)).length() < 1e-8);
            assert!(hit.point.z.abs() < 1e-9);
            assert!((hit.geometric_normal - DVec3::Z).length() < 1e-12);
            assert!(hit.front_face);
            assert!(close(hit.cos_incidence(d), theta.cos(), 1e-12));
            assert_eq!(
                (hit.object_id, hit.instance, hit.material, hit.part),
                (None, None, GROUND, 0)
            );
            assert_eq!(hit.velocity_m_s, DVec3::ZERO);
            // From below the plane is seen from its back.
            let up = space
                .closest_hit(&Ray::new(DVec3::new(0.5, 0.5, -h), -d))
                .unwrap();
            assert!(!up.front_face && close(up.distance_m, expected, 1e-9 * expected));
            assert!((up.facing_normal() + DVec3::Z).length() < 1e-12);
            // t_max before the plane: no hit.
            assert!(
                space
                    .closest_hit(&Ray::new(origin, d).with_t_max(0.99 * expected))
                    .is_none()
            );
            assert!(!space.any_hit(&Ray::new(origin, d).with_t_max(0.99 * expected)));
            assert!(space.any_hit(&Ray::new(origin, d).with_t_max(1.01 * expected)));
        }
        // Parallel and upward rays miss.
        assert!(
            space
                .closest_hit(&Ray::new(DVec3::new(0.0, 0.0, 1.0), DVec3::X))
                .is_none()
        );
        assert!(
            space
                .closest_hit(&Ray::new(DVec3::new(0.0, 0.0, 1.0), DVec3::Z))
                .is_none()
        );
    }
}

/// Slab method: entry and exit distances of the ray through the axis-aligned box.
fn slab(o: DVec3, d: DVec3, lo: DVec3, hi: DVec3) -> Option<(f64, f64)> {
    let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
    for a in 0..3 {
        let (ta, tb) = ((lo[a] - o[a]) / d[a], (hi[a] - o[a]) / d[a]);
        t0 = t0.max(ta.min(tb));
        t1 = t1.min(ta.max(tb));
    }
    (t1 >= t0.max(0.0)).then_some((t0, t1))
}

#[test]
fn ray_box_distances_match_slab_closed_form() {
    let (lo, hi) = (DVec3::new(-1.0, -2.0, 0.5), DVec3::new(3.0, 1.0, 2.0));
    let boxed = mesh_with("box", |m, p| {
        subdivided_box(m, lo.as_vec3(), hi.as_vec3(), 3, p)
    });
    let mut rng = Rng(3);
    for kind in KINDS {
        // Once as static geometry, once as an identity instance.
        for as_instance in [false, true] {
            let mut b = SpaceBuilder::new().bvh_kind(kind);
            let mut space = if as_instance {
                let h = b.add_mesh(&boxed, &[WALL]).unwrap();
                let mut s = b.build();
                s.set_instances(&[instance(9, h, DVec3::ZERO, 0.0)])
                    .unwrap();
                s
            } else {
                b.add_static(&boxed, &[WALL]).unwrap();
                b.build()
            };
            space.effects = SpaceEffects::default();
            let mut checked = 0;
            for _ in 0..2000 {
                let o = DVec3::new(
                    rng.range(-6.0, 8.0),
                    rng.range(-7.0, 6.0),
                    rng.range(-4.0, 6.0),
                );
                // Aim at a point around the box so that most rays hit it (a quarter start inside).
                let o = if rng.f() < 0.25 {
                    lo + (hi - lo) * DVec3::new(rng.f(), rng.f(), rng.f())
                } else {
                    o
                };
                let target =
                    lo - 0.3 * (hi - lo) + 1.6 * (hi - lo) * DVec3::new(rng.f(), rng.f(), rng.f());
                let d = (target - o).try_normalize().unwrap_or(DVec3::X);
                let expected = slab(o, d, lo, hi);
                let hit = space.closest_hit(&Ray::new(o, d));
                match (expected, hit) {
                    (None, None) => {}
                    (Some((t0, t1)), Some(h)) => {
                        let inside = t0 < 0.0;
                        let t = if inside { t1 } else { t0 };
                        assert!(
                            close(h.distance_m, t, 1e-9 * (1.0 + t)),
                            "{kind:?} {o} {d}: {} vs {t}",
                            h.distance_m
                        );
                        assert_eq!(h.front_face, !inside);
                        // The outward normal is the axis of the face hit.
                        let p = h.point;
                        let face = (0..3)
                            .find(|&a| close(p[a], lo[a], 1e-9) || close(p[a], hi[a], 1e-9))
                            .unwrap();
                        let sign = if close(p[face], hi[face], 1e-9) {
                            1.0
                        } else {
                            -1.0
                        };
                        assert!(close(h.geometric_normal[face], sign, 1e-9));
                        assert_eq!(h.object_id, as_instance.then_some(9));
                        checked += 1;
                    }
                    // Grazing rays through an edge or corner may go either way in f32.
                    (Some((t0, t1)), None) => {
                        assert!(t1 - t0.max(0.0) < 1e-5, "{kind:?} missed {o} {d}")
                    }
                    (None, Some(h)) => {
                        let pad = DVec3::splat(1e-5);
                        assert!(
                            slab(o, d, lo - pad, hi + pad).is_some(),
                            "{kind:?}: hit {h:?} outside the box"
                        )
                    }
                }
            }
            assert!(checked > 1000, "{checked}");
        }
    }
}

#[test]
fn rotated_translated_instance_hit_matches_hand_computation() {
    for kind in KINDS {
        let mut b = SpaceBuilder::new().bvh_kind(kind);
        let h = b.add_mesh(&unit_box(2), &[PAINT]).unwrap();
        let mut space = b.build();
        let yaw = 30f64.to_radians();
        let position = DVec3::new(10.0, -4.0, 1.5);
        let mut inst = instance(77, h, position, yaw);
        inst.linear_velocity = DVec3::new(3.0, 1.0, 0.0);
        inst.angular_velocity = DVec3::new(0.0, 0.0, 0.5);
        space.set_instances(&[inst]).unwrap();
        let r = DMat3::from_rotation_z(yaw);
        let local_target = DVec3::new(1.0, 0.3, -0.2);
        let origin = position + r * DVec3::new(5.0, 0.3, -0.2);
        let dir = -(r * DVec3::X);
        let hit = space
            .closest_hit(&Ray::new(origin, dir))
            .expect("instance hit");
        let expected = position + r * local_target;
        assert!(close(hit.distance_m, 4.0, 1e-6), "{}", hit.distance_m);
        assert!(
            (hit.point - expected).length() < 1e-6,
            "{} vs {expected}",
            hit.point
        );
        assert!((hit.geometric_normal - r * DVec3::X).length() < 1e-6);
        assert!(hit.front_face);
        assert_eq!(
            (hit.object_id, hit.instance, hit.material),
            (Some(77), Some(0), PAINT)
        );
        let v = inst.linear_velocity + inst.angular_velocity.cross(expected - position);
        assert!((hit.velocity_m_s - v).length() < 1e-6);
        // The same local point seen from another side (local +z face from above).
        let top = space
            .closest_hit(&Ray::new(
                position + r * DVec3::new(0.2, -0.4, 9.0),
                -DVec3::Z,
            ))
            .unwrap();
        assert!((top.point - (position + r * DVec3::new(0.2, -0.4, 1.0))).length() < 1e-6);
        assert!((top.geometric_normal - DVec3::Z).length() < 1e-6);
    }
}

/// Ground, a wall and two object meshes with different materials.
fn small_scene(kind: BvhKind) -> (Space, Vec<InstanceDesc>) {
    let mut b = SpaceBuilder::new().bvh_kind(kind);
    let g = b.add_static(&ground(60.0, 16), &[GROUND]).unwrap();
    let w = b.add_static(&wall(40.0, 30.0, 8.0), &[WALL]).unwrap();
    assert_eq!((g.first_triangle, g.first_part, w.first_part), (0, 0, 1));
    let mut car = Mesh::default();
    let body = car.part("body", "paint");
    let glass = car.part("glass", "glass");
    subdivided_box(
        &mut car,
        Vec3::new(-2.0, -0.9, 0.2),
        Vec3::new(2.0, 0.9, 1.0),
        2,
        body,
    );
    subdivided_box(
        &mut car,
        Vec3::new(-1.0, -0.8, 1.0),
        Vec3::new(0.8, 0.8, 1.4),
        1,
        glass,
    );
    let car = b.add_mesh(&car, &[PAINT, MaterialId(13)]).unwrap();
    let ped = b.add_mesh(&unit_box(1), &[MaterialId(14)]).unwrap();
    let mut space = b.build();
    let mut rng = Rng(11);
    let instances: Vec<_> = (0..30)
        .map(|i| {
            let mesh = if i % 3 == 0 { ped } else { car };
            let p = DVec3::new(
                rng.range(-35.0, 35.0),
                rng.range(-25.0, 25.0),
                if i % 3 == 0 { 1.0 } else { 0.0 },
            );
            let mut d = instance(100 + i, mesh, p, rng.range(-3.0, 3.0));
            d.linear_velocity = DVec3::new(rng.range(-20.0, 20.0), rng.range(-2.0, 2.0), 0.0);
            d.angular_velocity = DVec3::new(0.0, 0.0, rng.range(-0.3, 0.3));
            d
        })
        .collect();
    space.set_instances(&instances).unwrap();
    (space, instances)
}

fn scene_rays(n: usize, seed: u64) -> Vec<Ray> {
    let mut rng = Rng(seed);
    (0..n)
        .map(|_| {
            let o = DVec3::new(
                rng.range(-45.0, 45.0),
                rng.range(-30.0, 30.0),
                rng.range(0.1, 6.0),
            );
            Ray::new(o, rng.unit()).with_t_max(rng.range(1.0, 80.0))
        })
        .collect()
}

#[test]
fn object_ids_materials_and_normals_of_hits() {
    let (space, instances) = small_scene(BvhKind::Bvh2);
    // Straight down onto each instance's top.
    for (i, inst) in instances.iter().enumerate() {
        let hit = space
            .closest_hit(&Ray::new(
                inst.pose.position + DVec3::new(0.0, 0.0, 20.0),
                -DVec3::Z,
            ))
            .unwrap();
        if hit.object_id != Some(inst.object_id) {
            // Another instance may overlap this one from above; it must then be the one hit.
            let other = hit.instance.expect("an instance");
            assert_ne!(other as usize, i);
            continue;
        }
        assert_eq!(hit.instance, Some(i as u32));
        let (mat, z_top) = if i % 3 == 0 {
            (MaterialId(14), 2.0)
        } else {
            (MaterialId(13), 1.4)
        };
        assert_eq!(hit.material, mat);
        assert_eq!(hit.part, if i % 3 == 0 { 0 } else { 1 });
        assert!(close(hit.point.z, z_top, 1e-6));
        assert!((hit.geometric_normal - DVec3::Z).length() < 1e-6);
        let v = inst.linear_velocity + inst.angular_velocity.cross(hit.point - inst.pose.position);
        assert!((hit.velocity_m_s - v).length() < 1e-9);
    }
    // The wall (second static mesh): part 1, its triangle numbers follow the ground's.
    let hit = space
        .closest_hit(&Ray::new(DVec3::new(30.0, 28.0, 7.0), DVec3::X))
        .unwrap();
    assert_eq!((hit.material, hit.part, hit.object_id), (WALL, 1, None));
    assert!(hit.triangle as usize >= 16 * 16 * 2);
    assert!((hit.geometric_normal + DVec3::X).length() < 1e-9 && hit.front_face);
}

#[test]
fn any_hit_agrees_with_closest_hit() {
    for kind in KINDS {
        let (space, _) = small_scene(kind);
        let mut disagreements = 0;
        for ray in scene_rays(4000, 5) {
            let closest = space.closest_hit(&ray);
            let any = space.any_hit(&ray);
            // Hits within f32 rounding of t_max may go either way.
            let borderline = closest.is_some_and(|h| (h.distance_m - ray.t_max).abs() < 1e-4);
            if any != closest.is_some() && !borderline {
                disagreements += 1;
            }
            if let Some(h) = closest {
                assert!(h.distance_m >= ray.t_min - 1e-9 && h.distance_m <= ray.t_max + 1e-4);
            }
        }
        assert_eq!(disagreements, 0, "{kind:?}");
    }
}

#[test]
fn batch_equals_sequential() {
    for kind in KINDS {
        let (space, _) = small_scene(kind);
        let rays = scene_rays(5000, 9);
        let batch = space.closest_hits(&rays);
        let mut occluded = vec![false; rays.len()];
        space.occluded_batch(&rays, &mut occluded);
        for (i, ray) in rays.iter().enumerate() {
            assert_eq!(batch[i], space.closest_hit(ray), "ray {i}");
            assert_eq!(occluded[i], space.any_hit(ray), "ray {i}");
        }
        assert!(batch.iter().filter(|h| h.is_some()).count() > 1000);
    }
}

#[test]
fn coherent_batches_match_single_rays() {
    // LiDAR-like columns are traced as 8-ray (AVX2) or 4-ray packets; each ray must find what it
    // finds alone.
    for kind in KINDS {
        let (space, _) = small_scene(kind);
        let origin = DVec3::new(-3.0, 1.0, 1.8);
        let rays = space::bench::lidar_rays(origin, 32, 360, 120.0);
        let batch = space.closest_hits(&rays);
        let mut hits = 0;
        for (i, ray) in rays.iter().enumerate() {
            let single = space.closest_hit(ray);
            match (batch[i], single) {
                (None, None) => {}
                (Some(a), Some(b)) => {
                    hits += 1;
                    assert!(
                        close(a.distance_m, b.distance_m, 1e-9 * (1.0 + b.distance_m)),
                        "ray {i}"
                    );
                    assert_eq!(
                        (a.object_id, a.material, a.part),
                        (b.object_id, b.material, b.part),
                        "ray {i}"
                    );
                    // Same triangle unless the ray runs exactly through a shared edge.
                    if a.triangle != b.triangle {
                        assert!((a.point - b.point).length() < 1e-6);
                    }
                }
                (a, b) => panic!("ray {i}: batch {a:?} vs single {b:?}"),
            }
        }
        assert!(hits > rays.len() / 2, "{hits}");
        // Occlusion packets, with ranges that end before, at and after the surfaces.
        let limited: Vec<Ray> = rays
            .iter()
            .enumerate()
            .map(|(i, r)| r.with_t_max(2.0 + (i % 37) as f64))
            .collect();
        let mut occluded = vec![false; limited.len()];
        space.occluded_batch(&limited, &mut occluded);
        for (i, ray) in limited.iter().enumerate() {
            assert_eq!(occluded[i], space.any_hit(ray), "ray {i}");
        }
        assert!(occluded.iter().any(|&o| o) && occluded.iter().any(|&o| !o));
    }
}

#[test]
fn mirror_floor_two_bounce_length_equals_image_method() {
    for kind in KINDS {
        let mut b = SpaceBuilder::new().bvh_kind(kind);
        b.add_static(&ground(100.0, 8), &[GROUND]).unwrap();
        b.add_static(&wall(20.0, 50.0, 30.0), &[WALL]).unwrap();
        let mut space = b.build();
        let h = 1.5;
        let source = DVec3::new(0.0, 0.0, h);
        let image = DVec3::new(0.0, 0.0, -h);
        let d = DVec3::new(6.0, 1.0, -h).normalize();
        let policy = PathPolicy {
            max_bounces: 2,
            ..PathPolicy::default()
        };
        let path = space.trace_path(&Ray::new(source, d), &policy, 0);
        assert_eq!(path.vertices.len(), 2);
        let (floor, target) = (&path.vertices[0], &path.vertices[1]);
        assert_eq!(
            (floor.hit.material, floor.arrival),
            (GROUND, Segment::Primary)
        );
        assert_eq!(
            (target.hit.material, target.arrival),
            (WALL, Segment::Specular)
        );
        // The floor point and the wall point on the straight line from the image source.
        assert!((floor.hit.point - DVec3::new(6.0, 1.0, 0.0)).length() < 1e-9);
        let mirrored = DVec3::new(d.x, d.y, -d.z);
        let s = (20.0 - image.x) / mirrored.x;
        let expected_point = image + mirrored * s;
        assert!(
            (target.hit.point - expected_point).length() < 1e-4,
            "{}",
            target.hit.point
        );
        let image_length = (target.hit.point - image).length();
        assert!(
            close(target.path_length_m, image_length, 1e-4),
            "{} vs {image_length}",
            target.path_length_m
        );
        assert!(close(
            floor.path_length_m,
            (floor.hit.point - source).length(),
            1e-12
        ));
        assert!(close(path.length_m(), s, 1e-4));
        // Without multipath only the first surface is found.
        space.effects.multipath = false;
        let single = space.trace_path(&Ray::new(source, d), &policy, 0);
        assert_eq!(single.vertices.len(), 1);
        // A path that leaves the scene records its escape direction.
        space.effects.multipath = true;
        let up = space.trace_path(&Ray::new(source, DVec3::new(-1.0, 0.0, 1.0)), &policy, 0);
        assert!(up.vertices.is_empty() && up.escape.is_some());
    }
}

#[test]
fn doppler_of_a_moving_plate_is_two_v_dot_n_over_lambda() {
    let lambda = 299_792_458.0 / 77e9;
    let plate = mesh_with("plate", |m, p| {
        // A 4 m × 4 m plate in the mesh y-z plane facing −x (towards a sensor on −x).
        quad(
            m,
            [
                Vec3::new(0.0, -2.0, -2.0),
                Vec3::new(0.0, -2.0, 2.0),
                Vec3::new(0.0, 2.0, 2.0),
                Vec3::new(0.0, 2.0, -2.0),
            ],
            2,
            2,
            p,
        )
    });
    let mut b = SpaceBuilder::new();
    let h = b.add_mesh(&plate, &[PAINT]).unwrap();
    let mut space = b.build();
    let sensor = DVec3::new(0.0, 0.0, 1.0);
    for (speed, label) in [(-12.0, "receding"), (15.0, "approaching")] {
        let n = -DVec3::X; // the plate's normal, facing the sensor
        let mut inst = instance(1, h, DVec3::new(30.0, 0.0, 1.0), 0.0);
        // Along its normal plus a tangential component, which does not change the path length.
        inst.linear_velocity = n * speed + DVec3::new(0.0, 4.0, -1.0);
        space.set_instances(&[inst]).unwrap();
        let path = space.trace_path(
            &Ray::new(sensor, DVec3::X),
            &PathPolicy {
                max_bounces: 1,
                ..Default::default()
            },
            0,
        );
        let f = path.monostatic_doppler_hz(DVec3::ZERO, lambda);
        let expected = 2.0 * inst.linear_velocity.dot(n) / lambda;
        assert!(
            close(f, expected, 1e-9 * expected.abs()),
            "{label}: {f} vs {expected}"
        );
        assert_eq!(
            f > 0.0,
            speed > 0.0,
            "approaching plates have positive Doppler"
        );
        let (length, rate) = path.monostatic_length_and_rate(DVec3::ZERO);
        assert!(close(length, 60.0, 1e-9) && close(rate, -2.0 * speed, 1e-9));
        // Off-axis: the radial velocity along the line of sight counts, −2 v·û / λ.
        let d = DVec3::new(30.0, 1.5, 0.8).normalize();
        let p = space.trace_path(
            &Ray::new(sensor, d),
            &PathPolicy {
                max_bounces: 1,
                ..Default::default()
            },
            0,
        );
        let f = p.monostatic_doppler_hz(DVec3::ZERO, lambda);
        let expected = -2.0 * inst.linear_velocity.dot(d) / lambda;
        assert!(
            close(f, expected, 1e-9 * expected.abs()),
            "{label} off-axis: {f} vs {expected}"
        );
        // A moving sensor: only the relative velocity matters.
        let vs = DVec3::new(5.0, 0.0, 0.0);
        let f = path.monostatic_doppler_hz(vs, lambda);
        assert!(close(
            f,
            2.0 * (inst.linear_velocity - vs).dot(n) / lambda,
            1e-6
        ));
    }
    assert_eq!(doppler_shift_hz(-1.0, 0.5), 2.0);
}

#[test]
fn transmission_through_two_glass_panes() {
    let glass_a = MaterialId(20);
    let glass_b = MaterialId(21);
    let pane = |x: f32| wall(x, 5.0, 5.0);
    let mut b = SpaceBuilder::new();
    b.add_static(&pane(5.0), &[glass_a]).unwrap();
    b.add_static(&pane(10.0), &[glass_b]).unwrap();
    b.add_static(&wall(20.0, 5.0, 5.0), &[WALL]).unwrap();
    let mut space = b.build();
    let tau = |m: MaterialId| match m {
        m if m == glass_a => 0.8,
        m if m == glass_b => 0.5,
        _ => 0.0,
    };
    let ray = Ray::new(DVec3::new(0.0, 0.3, 2.0), DVec3::X);
    let t = space.closest_hit_through(&ray, &tau, 8);
    let hit = t.hit.expect("the wall");
    assert_eq!((hit.material, t.crossed), (WALL, 2));
    assert!(close(hit.distance_m, 20.0, 1e-9));
    assert!(close(t.transmittance, 0.4, 1e-12));
    assert!(close(
        space.transmittance_along(&ray.with_t_max(15.0), &tau, 8),
        0.4,
        1e-12
    ));
    assert!(close(
        space.transmittance_along(&ray.with_t_max(7.0), &tau, 8),
        0.8,
        1e-12
    ));
    assert_eq!(
        space.transmittance_along(&ray.with_t_max(25.0), &tau, 8),
        0.0
    );
    // Limited crossings: the second pane stops the ray.
    let t1 = space.closest_hit_through(&ray, &tau, 1);
    assert_eq!((t1.hit.unwrap().material, t1.crossed), (glass_b, 1));
    assert!(close(t1.transmittance, 0.8, 1e-12));
    // Without the effect glass is opaque.
    space.effects.transmission = false;
    let t0 = space.closest_hit_through(&ray, &tau, 8);
    assert_eq!(
        (t0.hit.unwrap().material, t0.crossed, t0.transmittance),
        (glass_a, 0, 1.0)
    );
    assert_eq!(
        space.transmittance_along(&ray.with_t_max(7.0), &tau, 8),
        0.0
    );
}

#[test]
fn top_level_updates_never_rebuild_the_static_world() {
    let (mut space, mut instances) = small_scene(BvhKind::Bvh2);
    let before = space.stats();
    assert_eq!(
        (before.static_builds, before.mesh_builds, before.tlas_builds),
        (1, 2, 1)
    );
    let probe = instances[1];
    for step in 1..=10 {
        for i in &mut instances {
            i.pose.position += i.linear_velocity * 0.05;
        }
        space.set_instances(&instances).unwrap();
        let s = space.stats();
        assert_eq!(
            (s.static_builds, s.mesh_builds, s.tlas_builds),
            (1, 2, 1 + step)
        );
        assert_eq!(s.blas_build_s, before.blas_build_s);
    }
    // The moved instance is hit where it now is.
    let moved = instances[1];
    assert_ne!(moved.pose.position, probe.pose.position);
    let hit = space
        .closest_hit(&Ray::new(
            moved.pose.position + DVec3::new(0.0, 0.0, 30.0),
            -DVec3::Z,
        ))
        .unwrap();
    assert!(hit.object_id.is_some());
    assert_eq!(space.instances().len(), 30);
    // Removing every instance leaves the static world.
    space.set_instances(&[]).unwrap();
    let hit = space
        .closest_hit(&Ray::new(
            moved.pose.position + DVec3::new(0.0, 0.0, 30.0),
            -DVec3::Z,
        ))
        .unwrap();
    assert_eq!(hit.object_id, None);
}

#[test]
fn diffuse_paths_are_deterministic_and_switchable() {
    let (mut space, _) = small_scene(BvhKind::Bvh2);
    let rays: Vec<Ray> = scene_rays(300, 21)
        .into_iter()
        .map(|r| r.with_t_max(f64::INFINITY))
        .collect();
    let policy = PathPolicy {
        max_bounces: 4,
        diffuse_probability: 1.0,
        seed: 99,
        ..PathPolicy::default()
    };
    let paths = space.trace_paths(&rays, &policy);
    for (i, (ray, p)) in rays.iter().zip(&paths).enumerate() {
        assert_eq!(*p, space.trace_path(ray, &policy, i as u64));
        for w in p.vertices.windows(2) {
            assert_eq!(w[1].arrival, Segment::Diffuse);
            assert!(close(
                w[1].path_length_m - w[0].path_length_m,
                (w[1].hit.point - w[0].hit.point).length(),
                1e-9
            ));
            // Diffuse directions leave on the side the ray arrived from.
            let out = (w[1].hit.point - w[0].hit.point).normalize();
            assert!(out.dot(w[0].hit.facing_normal()) > 0.0);
        }
    }
    assert!(paths.iter().any(|p| p.vertices.len() >= 2));
    space.effects = SpaceEffects::from_effects(&{
        let mut e = Effects::new(space::EFFECTS);
        e.set("space.diffuse_bounces", false).unwrap();
        e
    });
    for p in space.trace_paths(&rays, &policy) {
        assert!(
            p.vertices
                .iter()
                .skip(1)
                .all(|v| v.arrival == Segment::Specular)
        );
    }
}

#[test]
fn space_is_shareable_between_threads() {
    fn shareable<T: Send + Sync>() {}
    shareable::<Space>();
    shareable::<SpaceBuilder>();
}

#[test]
fn construction_errors_are_reported() {
    let mut b = SpaceBuilder::new();
    let two_parts = {
        let mut m = unit_box(1);
        let q = m.part("other", "x");
        m.push_triangle(Vec3::ZERO, Vec3::X, Vec3::Y, q);
        m
    };
    assert_eq!(
        b.add_mesh(&two_parts, &[PAINT]),
        Err(SpaceError::PartMaterials {
            parts: 2,
            materials: 1
        })
    );
    let h = b.add_mesh(&unit_box(1), &[PAINT]).unwrap();
    let empty = b.add_mesh(&Mesh::default(), &[]).unwrap();
    let mut space = b.build();
    let bad = instance(1, MeshHandle(7), DVec3::ZERO, 0.0);
    assert!(matches!(
        space.set_instances(&[bad]),
        Err(SpaceError::UnknownMesh { mesh: 7, .. })
    ));
    let mut scaled = instance(1, h, DVec3::ZERO, 0.0);
    scaled.pose.rotation = DMat3::from_diagonal(DVec3::splat(2.0));
    assert_eq!(
        space.set_instances(&[scaled]),
        Err(SpaceError::NotRigid { instance: 0 })
    );
    // Empty meshes and an empty static world are fine.
    space
        .set_instances(&[
            instance(1, empty, DVec3::ZERO, 0.0),
            instance(2, h, DVec3::X * 5.0, 0.0),
        ])
        .unwrap();
    let hit: Hit = space
        .closest_hit(&Ray::new(DVec3::new(-10.0, 0.0, 0.0), DVec3::X))
        .unwrap();
    assert_eq!(hit.object_id, Some(2));
    assert!(close(hit.distance_m, 14.0, 1e-9));
    assert!(space.segment_clear(DVec3::new(-10.0, 0.0, 0.0), DVec3::new(3.0, 0.0, 0.0)));
    assert!(!space.segment_clear(DVec3::new(-10.0, 0.0, 0.0), DVec3::new(5.0, 0.0, 0.0)));
}

mod from_scene {
    use super::*;
    use osiris_models::environment::material::MaterialDb;
    use osiris_models::environment::scene::Scene;
    use osiris_proto::{id, osi3};

    fn v3(x: f64, y: f64, z: f64) -> osi3::Vector3d {
        osi3::Vector3d {
            x: Some(x),
            y: Some(y),
            z: Some(z),
        }
    }

    fn car(oid: u64, x: f64, speed: f64) -> osi3::MovingObject {
        osi3::MovingObject {
            id: Some(id(oid)),
            base: Some(osi3::BaseMoving {
                dimension: Some(osi3::Dimension3d {
                    length: Some(4.5),
                    width: Some(1.8),
                    height: Some(1.5),
                }),
                position: Some(v3(x, 0.0, 0.75)),
                orientation: Some(osi3::Orientation3d {
                    roll: Some(0.0),
                    pitch: Some(0.0),
                    yaw: Some(0.0),
                }),
                velocity: Some(v3(speed, 0.0, 0.0)),
                orientation_rate: Some(osi3::Orientation3d {
                    roll: Some(0.0),
                    pitch: Some(0.0),
                    yaw: Some(0.0),
                }),
                ..Default::default()
            }),
            r#type: Some(osi3::moving_object::Type::Vehicle as i32),
            model_reference: Some("osiris:car".into()),
            ..Default::default()
        }
    }

    fn ground_truth(x100: f64) -> osi3::GroundTruth {
        osi3::GroundTruth {
            host_vehicle_id: Some(id(1)),
            moving_object: vec![
                car(1, 50.0, 25.0),
                car(100, x100, 20.0),
                car(101, 130.0, 15.0),
            ],
            ..Default::default()
        }
    }

    /// The first surface straight below a global point.
    fn below(space: &Space, scene: &Scene, x: f64, y: f64) -> Hit {
        let o = scene.to_local(DVec3::new(x, y, 20.0));
        space
            .closest_hit(&Ray::new(o, -DVec3::Z))
            .expect("a surface below")
    }

    #[test]
    fn space_follows_the_scene() {
        let mut gt = ground_truth(90.0);
        let mut scene = Scene::from_ground_truth(&gt, None, MaterialDb::builtin()).unwrap();
        let mut space = SpaceBuilder::new().build_scene(&scene).unwrap();
        assert_eq!(space.origin(), scene.origin);
        assert_eq!(space.instances().len(), 2, "the host is not an instance");
        let hit = below(&space, &scene, 90.0, 0.0);
        assert_eq!(hit.object_id, Some(100));
        assert!((hit.velocity_m_s - DVec3::new(20.0, 0.0, 0.0)).length() < 1e-9);
        assert!(hit.geometric_normal.z > 0.5 && hit.front_face);
        let road = below(&space, &scene, 70.0, 0.0);
        assert_eq!(road.object_id, None);
        assert_eq!(
            Some(road.material),
            scene.materials.id(&scene.options().road_material)
        );
        assert_eq!(
            below(&space, &scene, 50.0, 0.0).object_id,
            None,
            "no hit on the host"
        );
        // Next step: car 100 moved on; only the top level changes.
        gt = ground_truth(100.0);
        scene.update(&gt).unwrap();
        assert!(space.sync_scene(&scene).unwrap());
        assert_eq!(below(&space, &scene, 90.0, 0.0).object_id, None);
        assert_eq!(below(&space, &scene, 100.0, 0.0).object_id, Some(100));
        let stats = space.stats();
        assert_eq!((stats.static_builds, stats.tlas_builds), (1, 2));
    }
}

/// Rays at their own times through a [`Sweep`] (rolling shutter): a moving box is met where it is
/// at the ray's time (window-clamped), the static ground stays put, a parked box does not move.
/// Closed forms: the slab distances of the rotated box displaced by `v·t` in its own frame, and the
/// ground plane `t = h/(−d_z)`. Single rays, 8- and 4-ray packets and occlusion all agree with them;
/// at time 0 the sweep equals the space's own queries.
#[test]
fn swept_queries_see_moving_instances_at_each_ray_time() {
    for kind in KINDS {
        let mut b = SpaceBuilder::new().bvh_kind(kind);
        b.add_static(&ground(60.0, 8), &[GROUND]).unwrap();
        let h = b.add_mesh(&unit_box(2), &[PAINT]).unwrap();
        let mut space = b.build();
        let (centre, yaw, v) = (DVec3::new(10.0, 0.5, 1.0), 0.3, DVec3::new(8.0, -30.0, 0.0));
        let parked = DVec3::new(10.0, -6.0, 1.0);
        let mut moving = instance(7, h, centre, yaw);
        moving.linear_velocity = v;
        space
            .set_instances(&[moving, instance(8, h, parked, 0.0)])
            .unwrap();
        let window = (-0.05, 0.1);
        let mut sweep = Sweep::new();
        let swept = sweep.update(&space, window);
        let rot = DMat3::from_rotation_z(yaw);
        let origin = DVec3::new(0.0, 0.0, 1.5);
        let mut rng = Rng(21);
        // Eight-ray groups of neighbouring directions (packets) at one time per group, some times
        // outside the window.
        let mut rays = Vec::new();
        for g in 0..300 {
            let time = if g % 10 == 0 {
                0.0
            } else {
                rng.range(-0.1, 0.15)
            };
            let c = if g % 3 == 0 {
                parked
            } else {
                centre + v * time.clamp(window.0, window.1)
            };
            let target = c + DVec3::new(
                rng.range(-2.0, 2.0),
                rng.range(-2.0, 2.0),
                rng.range(-2.0, 1.5),
            );
            let d = (target - origin).normalize();
            for k in 0..8 {
                let e = DVec3::new(0.0, 1e-3 * k as f64, -1e-3 * k as f64);
                rays.push(Ray::new(origin, d + e).with_t_max(100.0).at_time(time));
            }
        }
        let mut batch = vec![None; rays.len()];
        swept.trace_batch(&rays, &mut batch);
        // Four-ray packets: the same rays shifted by four.
        let mut batch4 = vec![None; rays.len() - 4];
        swept.trace_batch(&rays[4..], &mut batch4);
        let mut occluded = vec![false; rays.len()];
        swept.occluded_batch(&rays, &mut occluded);
        let (mut on_moving, mut on_parked, mut on_ground) = (0, 0, 0);
        for (i, ray) in rays.iter().enumerate() {
            let dt = ray.time_s.clamp(window.0, window.1);
            let hit_box = |c: DVec3, rot: DMat3, grow: f64| {
                let o_local = rot.transpose() * (ray.origin - c);
                let d_local = rot.transpose() * ray.direction;
                slab(
                    o_local,
                    d_local,
                    DVec3::splat(-1.0 - grow),
                    DVec3::splat(1.0 + grow),
                )
            };
            let boxes = [
                (hit_box(centre + v * dt, rot, 0.0), Some(7)),
                (hit_box(parked, DMat3::IDENTITY, 0.0), Some(8)),
            ];
            let t_ground = origin.z / -ray.direction.z;
            let p_ground = ray.at(t_ground);
            let ground_hit = ray.direction.z < 0.0
                && t_ground < ray.t_max
                && p_ground.x.abs() < 60.0
                && p_ground.y.abs() < 60.0;
            let mut expected: Option<(f64, Option<u64>)> = ground_hit.then_some((t_ground, None));
            for (b, id) in boxes {
                if let Some((t0, _)) = b.filter(|&(t0, _)| t0 > 0.0)
                    && expected.is_none_or(|(t, _)| t0 < t)
                {
                    expected = Some((t0, id));
                }
            }
            // Grazing rays along a box edge may go either way in f32.
            let graze = [(centre + v * dt, rot), (parked, DMat3::IDENTITY)]
                .iter()
                .any(|&(c, r)| hit_box(c, r, 1e-5).is_some_and(|(t0, t1)| t1 - t0 < 1e-4));
            let single = swept.closest_hit(ray);
            let four = (i >= 4).then(|| batch4[i - 4]);
            for (what, got) in [
                ("single", Some(single)),
                ("packet", Some(batch[i])),
                ("packet4", four),
            ] {
                let Some(got) = got else { continue };
                match (expected, got) {
                    (None, None) => {}
                    (Some((t, id)), Some(h)) if h.object_id == id => {
                        assert!(
                            close(h.distance_m, t, 1e-9 * (1.0 + t)),
                            "ray {i} {what}: {} vs {t}",
                            h.distance_m
                        );
                        assert!(
                            (h.point - ray.at(t)).length() < 1e-8 * (1.0 + t),
                            "ray {i} {what}"
                        );
                        let v_exp = if id == Some(7) { v } else { DVec3::ZERO };
                        assert!((h.velocity_m_s - v_exp).length() < 1e-12, "ray {i} {what}");
                    }
                    (e, g) => assert!(graze, "ray {i} {what}: expected {e:?}, got {g:?}"),
                }
            }
            assert!(
                occluded[i] == expected.is_some() || graze,
                "ray {i}: occluded {} vs {expected:?}",
                occluded[i]
            );
            assert_eq!(swept.any_hit(ray), occluded[i], "ray {i}");
            match expected.map(|e| e.1) {
                Some(Some(7)) => on_moving += 1,
                Some(Some(8)) => on_parked += 1,
                Some(None) => on_ground += 1,
                _ => {}
            }
            // At time 0 the sweep is the space at its poses.
            if ray.time_s == 0.0 {
                assert_eq!(single, space.closest_hit(ray), "ray {i}");
            }
        }
        assert!(
            on_moving > 600 && on_parked > 300 && on_ground > 300,
            "{on_moving} {on_parked} {on_ground}"
        );
        // Ray times are ignored by the space's own queries: the moving box at its pose.
        let ray = Ray::new(origin, centre - origin).at_time(0.1);
        let own = space.closest_hit(&ray).expect("the box at its pose");
        assert_eq!(own.object_id, Some(7));
        assert!(
            swept
                .closest_hit(&ray)
                .is_none_or(|h| h.distance_m > own.distance_m + 0.1)
        );
    }
}

/// Shadow rays: parallel rays from neighbouring surface points are traced as packets; each must
/// find what it finds alone.
#[test]
fn parallel_shadow_ray_packets_match_single_rays() {
    for kind in KINDS {
        let (space, _) = small_scene(kind);
        let sun = DVec3::new(-0.5, 0.3, 0.6).normalize();
        let mut rng = Rng(5);
        let rays: Vec<Ray> = (0..4000)
            .map(|i| {
                // Runs of neighbouring ground points (a few cm apart), as adjacent pixels give.
                let base = (i / 4) as f64;
                let o = DVec3::new(
                    -40.0 + 0.08 * base + 0.03 * (i % 4) as f64,
                    -25.0 + 50.0 * ((base * 0.618).fract()),
                    1e-3,
                );
                let d = sun + DVec3::new(0.0, 1e-3 * rng.f(), 0.0);
                Ray::new(o, d).with_t_max(200.0)
            })
            .collect();
        let mut occluded = vec![false; rays.len()];
        space.occluded_batch(&rays, &mut occluded);
        for (i, ray) in rays.iter().enumerate() {
            assert_eq!(occluded[i], space.any_hit(ray), "ray {i}");
        }
        let shadowed = occluded.iter().filter(|&&o| o).count();
        assert!(shadowed > 20 && shadowed < rays.len() - 20, "{shadowed}");
    }
}
