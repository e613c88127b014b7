//! `osiris bench space`: BVH build, top-level update and ray throughput on a synthetic ≈1 M-triangle
//! street (road, 450 cars, 50 pedestrians, 80 buildings), on 1 and 2 threads.
//!
//! Timings: wall clock on a dedicated rayon pool per thread count. Ray throughputs are the best of
//! the repetitions (the run least disturbed by other load on a shared machine), with their median
//! and the rays per CPU-second of the process alongside.

use std::time::Instant;

use glam::{DMat3, DVec3, Vec3};
use serde_json::{Map, Value, json};

use super::{
    BvhKind, InstanceDesc, MeshHandle, Ray, Space, SpaceBuilder, cylinder, hexahedron, quad,
    subdivided_box,
};
use crate::environment::{material::MaterialId, mesh::Mesh};
use crate::frames::Pose;

/// Targets of the issue on the 2-core reference machine.
pub const TARGET_COHERENT_MRAYS_PER_S_2T: f64 = 8.0;
/// Top-level update budget for 500 moving objects, ms.
pub const TARGET_TLAS_UPDATE_MS: f64 = 5.0;

/// Size of the synthetic scene.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BenchScene {
    pub cars: usize,
    pub pedestrians: usize,
    pub buildings_per_side: usize,
    /// Faces of each building are subdivided `n × n` (12 n² triangles per building).
    pub building_subdivision: u32,
    /// Road grid cells along x and y (2 triangles each).
    pub road_cells: (u32, u32),
    /// Car body / cabin subdivision and wheel segments (1 584 triangles at (8, 6, 24)).
    pub car_detail: (u32, u32, u32),
}

impl BenchScene {
    /// The ≈1 M-triangle street of the issue.
    pub const STREET: BenchScene = BenchScene {
        cars: 450,
        pedestrians: 50,
        buildings_per_side: 40,
        building_subdivision: 16,
        road_cells: (800, 50),
        car_detail: (8, 6, 24),
    };
    /// A small version for smoke tests.
    pub const SMALL: BenchScene = BenchScene {
        cars: 20,
        pedestrians: 5,
        buildings_per_side: 4,
        building_subdivision: 2,
        road_cells: (20, 4),
        car_detail: (2, 1, 8),
    };
}

/// What to run.
#[derive(Debug, Clone, PartialEq)]
pub struct BenchConfig {
    pub scene: BenchScene,
    /// Thread counts (the last one gives the headline keys).
    pub threads: Vec<usize>,
    /// BVH layouts; the first gives the headline keys, the others go under `"comparison"`.
    pub kinds: Vec<BvhKind>,
    /// LiDAR pattern: channels × azimuth steps.
    pub lidar: (usize, usize),
    /// Repetitions of the LiDAR frame (median taken).
    pub lidar_repetitions: usize,
    pub random_rays: usize,
    pub random_repetitions: usize,
    /// Top-level updates averaged.
    pub tlas_steps: usize,
}

impl Default for BenchConfig {
    fn default() -> Self {
        BenchConfig {
            scene: BenchScene::STREET,
            threads: vec![1, 2],
            kinds: vec![BvhKind::Bvh2, BvhKind::CwBvh],
            lidar: (128, 1800),
            lidar_repetitions: 7,
            random_rays: 500_000,
            random_repetitions: 5,
            tlas_steps: 100,
        }
    }
}

/// The benchmark with default settings on the given thread counts (`osiris bench space`).
pub fn bench_space(threads: &[usize]) -> Value {
    bench_space_with(&BenchConfig {
        threads: threads.to_vec(),
        ..BenchConfig::default()
    })
}

/// The benchmark. Keys (headline kind, last thread count unless suffixed `_<n>t`): `triangles`,
/// `build_s`, `tlas_update_ms`, `coherent_mrays_per_s`, `random_mrays_per_s`, `threads`,
/// `hit_fraction`, plus per-thread variants, occlusion throughput and `comparison.<kind>`.
pub fn bench_space_with(cfg: &BenchConfig) -> Value {
    let mut kinds = cfg.kinds.iter();
    let headline = kinds.next().copied().unwrap_or_default();
    let mut out = bench_kind(cfg, headline);
    let comparison: Map<String, Value> = kinds
        .map(|&k| (kind_name(k).to_owned(), bench_kind(cfg, k)))
        .collect();
    if let Value::Object(map) = &mut out {
        let coherent = map.get("coherent_mrays_per_s_2t").and_then(Value::as_f64);
        let tlas = map.get("tlas_update_ms").and_then(Value::as_f64);
        map.insert(
            "target".into(),
            json!({
                "coherent_mrays_per_s_2t": TARGET_COHERENT_MRAYS_PER_S_2T,
                "tlas_update_ms": TARGET_TLAS_UPDATE_MS,
                "met": coherent.is_some_and(|c| c >= TARGET_COHERENT_MRAYS_PER_S_2T)
                    && tlas.is_some_and(|t| t < TARGET_TLAS_UPDATE_MS),
            }),
        );
        if !comparison.is_empty() {
            map.insert("comparison".into(), Value::Object(comparison));
        }
        map.insert(
            "cpus".into(),
            json!(
                std::thread::available_parallelism()
                    .map(|n| n.get())
                    .unwrap_or(1)
            ),
        );
    }
    out
}

fn kind_name(kind: BvhKind) -> &'static str {
    match kind {
        BvhKind::Bvh2 => "bvh2",
        BvhKind::CwBvh => "cwbvh",
    }
}

fn bench_kind(cfg: &BenchConfig, kind: BvhKind) -> Value {
    let mut m = Map::new();
    m.insert("bvh".into(), json!(kind_name(kind)));
    m.insert("threads".into(), json!(cfg.threads));
    m.insert(
        "timing".into(),
        json!(
            "wall clock; *_mrays_per_s: best of the repetitions, *_median: their median, \
               *_per_cpu_s: rays per CPU-second of the process (independent of other load)"
        ),
    );
    let lidar_origin = DVec3::new(0.0, -6.0, 2.0);
    let coherent = lidar_rays(lidar_origin, cfg.lidar.0, cfg.lidar.1, 200.0);
    let mut headline = Map::new();
    for &n in &cfg.threads {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(n.max(1))
            .build()
            .expect("rayon pool");
        let sfx = format!("_{n}t");
        pool.install(|| {
            // Scene: meshes generated, BVHs built (static world + unique meshes), first top level.
            let start = Instant::now();
            let (mut space, mut instances) = street_scene(&cfg.scene, kind);
            let setup_s = start.elapsed().as_secs_f64();
            let stats = space.stats();
            let build_s = stats.blas_build_s + stats.last_tlas_update_s;
            // Top-level updates: move every instance, rebuild the TLAS.
            let mut updates = Vec::with_capacity(cfg.tlas_steps);
            for _ in 0..cfg.tlas_steps {
                advance(&mut instances, 0.05);
                let t = Instant::now();
                space.set_instances(&instances).expect("valid instances");
                updates.push(t.elapsed().as_secs_f64() * 1e3);
            }
            let tlas_ms = updates.iter().sum::<f64>() / updates.len().max(1) as f64;
            let tlas_max_ms = updates.iter().copied().fold(0.0, f64::max);
            // Rays.
            let mut hits = vec![None; coherent.len()];
            let coh = time_runs(cfg.lidar_repetitions, || {
                space.trace_batch(&coherent, &mut hits)
            });
            let hit_fraction = fraction(&hits);
            let mut occluded = vec![false; coherent.len()];
            let occ = time_runs(cfg.lidar_repetitions, || {
                space.occluded_batch(&coherent, &mut occluded)
            });
            let random = random_rays(
                space.bounds().expect("non-empty scene"),
                cfg.random_rays,
                0x5eed,
            );
            let mut hits = vec![None; random.len()];
            let rnd = time_runs(cfg.random_repetitions, || {
                space.trace_batch(&random, &mut hits)
            });
            let random_hit_fraction = fraction(&hits);
            let mut entries: Vec<(String, Value)> = vec![
                ("scene_setup_s".into(), json!(setup_s)),
                ("build_s".into(), json!(build_s)),
                ("blas_build_s".into(), json!(stats.blas_build_s)),
                ("tlas_update_ms".into(), json!(tlas_ms)),
                ("tlas_update_max_ms".into(), json!(tlas_max_ms)),
            ];
            for (name, rays, t) in [
                ("coherent", coherent.len(), coh),
                ("coherent_occlusion", coherent.len(), occ),
                ("random", random.len(), rnd),
            ] {
                let mrays = |s: f64| rays as f64 / s / 1e6;
                entries.push((format!("{name}_mrays_per_s"), json!(mrays(t.best))));
                entries.push((format!("{name}_mrays_per_s_median"), json!(mrays(t.median))));
                entries.push((format!("{name}_mrays_per_cpu_s"), json!(t.cpu.map(mrays))));
            }
            for (k, v) in entries {
                m.insert(format!("{k}{sfx}"), v.clone());
                headline.insert(k, v);
            }
            headline.insert("hit_fraction".into(), json!(hit_fraction));
            headline.insert("random_hit_fraction".into(), json!(random_hit_fraction));
            headline.insert("triangles".into(), json!(space.instanced_triangle_count()));
            headline.insert(
                "static_triangles".into(),
                json!(space.static_triangle_count()),
            );
            headline.insert(
                "unique_mesh_triangles".into(),
                json!(space.mesh_triangle_count()),
            );
            headline.insert("instances".into(), json!(instances.len()));
            headline.insert("moving_instances".into(), json!(instances.len()));
            let stats = space.stats();
            headline.insert("static_builds".into(), json!(stats.static_builds));
            headline.insert("tlas_builds".into(), json!(stats.tlas_builds));
        });
    }
    m.insert("coherent_rays".into(), json!(coherent.len()));
    m.insert("random_rays".into(), json!(cfg.random_rays));
    m.extend(headline);
    Value::Object(m)
}

/// Fraction of rays that hit something.
fn fraction(hits: &[Option<super::Hit>]) -> f64 {
    hits.iter().filter(|h| h.is_some()).count() as f64 / hits.len().max(1) as f64
}

/// CPU time of all threads of this process so far, s (Linux `/proc/self/task/*/schedstat`, ns
/// resolution); `None` elsewhere. Rays per CPU-second are independent of other load on the machine.
pub fn process_cpu_s() -> Option<f64> {
    let mut ns = 0u64;
    for task in std::fs::read_dir("/proc/self/task").ok()? {
        let stat = std::fs::read_to_string(task.ok()?.path().join("schedstat")).ok()?;
        ns += stat.split_whitespace().next()?.parse::<u64>().ok()?;
    }
    Some(ns as f64 * 1e-9)
}

/// Wall times of repeated runs (after one warm-up run), s, and the CPU time per run.
#[derive(Debug, Clone, Copy)]
struct Timing {
    best: f64,
    median: f64,
    cpu: Option<f64>,
}

fn time_runs(repetitions: usize, mut run: impl FnMut()) -> Timing {
    run();
    let n = repetitions.max(1);
    let cpu0 = process_cpu_s();
    let mut times: Vec<f64> = (0..n)
        .map(|_| {
            let t = Instant::now();
            run();
            t.elapsed().as_secs_f64()
        })
        .collect();
    let cpu = cpu0.zip(process_cpu_s()).map(|(a, b)| (b - a) / n as f64);
    times.sort_by(f64::total_cmp);
    Timing {
        best: times[0],
        median: times[n / 2],
        cpu,
    }
}

/// A VLS-128-like pattern: `channels` elevations from −25° to +15°, `steps` azimuths over 360°,
/// issued column by column (all channels of one azimuth, then the next), range `t_max`.
pub fn lidar_rays(origin: DVec3, channels: usize, steps: usize, t_max: f64) -> Vec<Ray> {
    let mut rays = Vec::with_capacity(channels * steps);
    for a in 0..steps {
        let az = std::f64::consts::TAU * a as f64 / steps as f64;
        for c in 0..channels {
            let el = (-25.0 + 40.0 * c as f64 / (channels.max(2) - 1) as f64).to_radians();
            let d = DVec3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin());
            rays.push(Ray {
                origin,
                direction: d,
                t_min: 0.0,
                t_max,
                time_s: 0.0,
            });
        }
    }
    rays
}

/// `n` rays with origins uniform in the box and directions uniform on the sphere.
pub fn random_rays((lo, hi): (DVec3, DVec3), n: usize, seed: u64) -> Vec<Ray> {
    let mut rng = super::path::Pcg32::new(seed, 0);
    (0..n)
        .map(|_| {
            let o = lo + (hi - lo) * DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64());
            let z = 2.0 * rng.next_f64() - 1.0;
            let phi = std::f64::consts::TAU * rng.next_f64();
            let r = (1.0 - z * z).max(0.0).sqrt();
            Ray {
                origin: o,
                direction: DVec3::new(r * phi.cos(), r * phi.sin(), z),
                t_min: 0.0,
                t_max: f64::INFINITY,
                time_s: 0.0,
            }
        })
        .collect()
}

/// A closed car-like mesh (body, cabin, four wheels), x forward, z up, origin on the ground under
/// the centre. Parts: 0 `body`, 1 `glass`, 2 `tyre`.
pub fn car_mesh((body_n, cabin_n, wheel_segments): (u32, u32, u32)) -> Mesh {
    let mut m = Mesh::default();
    let body = m.part("body", "car_paint");
    let glass = m.part("glass", "glass");
    let tyre = m.part("tyre", "rubber");
    subdivided_box(
        &mut m,
        Vec3::new(-2.25, -0.9, 0.3),
        Vec3::new(2.25, 0.9, 1.05),
        body_n,
        body,
    );
    let (z0, z1) = (1.05, 1.5);
    let cabin = [
        Vec3::new(-1.3, -0.85, z0),
        Vec3::new(1.0, -0.85, z0),
        Vec3::new(-1.3, 0.85, z0),
        Vec3::new(1.0, 0.85, z0),
        Vec3::new(-1.0, -0.72, z1),
        Vec3::new(0.5, -0.72, z1),
        Vec3::new(-1.0, 0.72, z1),
        Vec3::new(0.5, 0.72, z1),
    ];
    hexahedron(&mut m, cabin, cabin_n, glass);
    for (x, y) in [(1.4, 0.8), (1.4, -0.8), (-1.4, 0.8), (-1.4, -0.8)] {
        cylinder(
            &mut m,
            Vec3::new(x, y, 0.33),
            Vec3::Y,
            0.33,
            0.22,
            wheel_segments,
            tyre,
        );
    }
    m
}

/// The synthetic street with its instances placed (static world, car and pedestrian meshes built).
pub fn street_scene(scene: &BenchScene, kind: BvhKind) -> (Space, Vec<InstanceDesc>) {
    street_scene_with(scene, SpaceBuilder::new().bvh_kind(kind))
}

/// [`street_scene`] built by a configured builder (BVH layout and build preset).
pub fn street_scene_with(scene: &BenchScene, mut b: SpaceBuilder) -> (Space, Vec<InstanceDesc>) {
    let (road_mat, wall_mat, paint, glass, rubber, cloth) = (
        MaterialId(0),
        MaterialId(1),
        MaterialId(2),
        MaterialId(3),
        MaterialId(4),
        MaterialId(5),
    );
    // Static world: ground (road and sidewalks) and buildings on both sides.
    let mut world = Mesh::default();
    let ground = world.part("road", "asphalt");
    let wall = world.part("building", "concrete");
    let (nx, ny) = scene.road_cells;
    let (x0, x1, y_side) = (-500.0f32, 500.0f32, 25.0f32);
    quad(
        &mut world,
        [
            Vec3::new(x0, -y_side, 0.0),
            Vec3::new(x1, -y_side, 0.0),
            Vec3::new(x1, y_side, 0.0),
            Vec3::new(x0, y_side, 0.0),
        ],
        nx,
        ny,
        ground,
    );
    let spacing = (x1 - x0) / scene.buildings_per_side.max(1) as f32;
    let mut rng = super::path::Pcg32::new(7, 1);
    for side in [-1.0f32, 1.0] {
        for k in 0..scene.buildings_per_side {
            let cx = x0 + spacing * (k as f32 + 0.5);
            let h = 10.0 + 30.0 * rng.next_f64() as f32;
            let (ya, yb) = (side * y_side, side * (y_side + 15.0));
            let lo = Vec3::new(cx - 0.4 * spacing, ya.min(yb), 0.0);
            let hi = Vec3::new(cx + 0.4 * spacing, ya.max(yb), h);
            subdivided_box(&mut world, lo, hi, scene.building_subdivision, wall);
        }
    }
    b.add_static(&world, &[road_mat, wall_mat])
        .expect("static world");
    let car = b
        .add_mesh(&car_mesh(scene.car_detail), &[paint, glass, rubber])
        .expect("car mesh");
    let mut ped_mesh = Mesh::default();
    let p = ped_mesh.part("body", "cloth");
    subdivided_box(
        &mut ped_mesh,
        Vec3::new(-0.25, -0.2, 0.0),
        Vec3::new(0.25, 0.2, 1.8),
        3,
        p,
    );
    let ped = b.add_mesh(&ped_mesh, &[cloth]).expect("pedestrian mesh");
    let mut space = b.build();
    let instances = street_instances(scene, car, ped);
    space.set_instances(&instances).expect("valid instances");
    (space, instances)
}

fn street_instances(scene: &BenchScene, car: MeshHandle, ped: MeshHandle) -> Vec<InstanceDesc> {
    let mut rng = super::path::Pcg32::new(11, 2);
    let lanes = [-10.0, -6.0, -2.0, 2.0, 6.0, 10.0];
    let per_lane = scene.cars.div_ceil(lanes.len()) + 1;
    let spacing = 990.0 / per_lane as f64;
    let mut out = Vec::with_capacity(scene.cars + scene.pedestrians);
    'cars: for k in 0..per_lane {
        for &y in &lanes {
            if out.len() == scene.cars {
                break 'cars;
            }
            let x = -495.0 + spacing * (k as f64 + 0.5) + 2.0 * (rng.next_f64() - 0.5);
            if y == -6.0 && x.abs() < 8.0 {
                continue; // the LiDAR's own gap
            }
            let forward = if y < 0.0 { 1.0 } else { -1.0 };
            let yaw = if forward > 0.0 {
                0.0
            } else {
                std::f64::consts::PI
            } + 0.02 * (rng.next_f64() - 0.5);
            let speed = 20.0 + 10.0 * rng.next_f64();
            out.push(InstanceDesc {
                object_id: 1000 + out.len() as u64,
                mesh: car,
                pose: Pose::new(DVec3::new(x, y, 0.0), DMat3::from_rotation_z(yaw)),
                linear_velocity: DVec3::new(forward * speed, 0.0, 0.0),
                angular_velocity: DVec3::new(0.0, 0.0, 0.02 * (rng.next_f64() - 0.5)),
            });
        }
    }
    for k in 0..scene.pedestrians {
        let side = if k % 2 == 0 { -1.0 } else { 1.0 };
        let x = -490.0 + 980.0 * rng.next_f64();
        let vx = 1.4 * side;
        out.push(InstanceDesc {
            object_id: 5000 + k as u64,
            mesh: ped,
            pose: Pose::new(DVec3::new(x, side * 20.0, 0.0), DMat3::from_rotation_z(0.0)),
            linear_velocity: DVec3::new(vx, 0.0, 0.0),
            angular_velocity: DVec3::ZERO,
        });
    }
    out
}

/// Move every instance by one step (constant velocity and yaw rate), wrapping along the street.
fn advance(instances: &mut [InstanceDesc], dt: f64) {
    for i in instances {
        let mut p = i.pose.position + i.linear_velocity * dt;
        if p.x > 495.0 {
            p.x -= 990.0;
        } else if p.x < -495.0 {
            p.x += 990.0;
        }
        i.pose.position = p;
        i.pose.rotation = DMat3::from_rotation_z(i.angular_velocity.z * dt) * i.pose.rotation;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_bench_reports_all_keys() {
        let cfg = BenchConfig {
            scene: BenchScene::SMALL,
            threads: vec![1, 2],
            kinds: vec![BvhKind::Bvh2, BvhKind::CwBvh],
            lidar: (8, 30),
            lidar_repetitions: 1,
            random_rays: 500,
            random_repetitions: 1,
            tlas_steps: 3,
        };
        let v = bench_space_with(&cfg);
        for key in [
            "triangles",
            "build_s",
            "tlas_update_ms",
            "coherent_mrays_per_s",
            "random_mrays_per_s",
            "threads",
            "hit_fraction",
            "coherent_mrays_per_s_1t",
            "coherent_mrays_per_s_2t",
            "random_mrays_per_s_1t",
            "random_mrays_per_s_2t",
        ] {
            assert!(v.get(key).is_some(), "missing {key}: {v}");
        }
        assert!(
            v["comparison"]["cwbvh"]["coherent_mrays_per_s"]
                .as_f64()
                .unwrap()
                > 0.0
        );
        assert_eq!(v["static_builds"], 1);
        assert_eq!(v["tlas_builds"], 4);
        let car = car_mesh(BenchScene::STREET.car_detail).triangle_count();
        assert_eq!(car, 1584);
        assert!(v["hit_fraction"].as_f64().unwrap() > 0.3);
    }
}
