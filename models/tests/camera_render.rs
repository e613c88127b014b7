//! Tests of the spectral renderer (`osiris_models::camera::render`) against independent
//! expectations: a Lambertian board in the sun, `L_c = Σ_k w_c,k ρ_k/π (E_dni,k cos θ + E_dhi,k
//! (1 + n_z)/2)` with SPCTRAL2 (physics.md §4.2) and the material table; shadows; the sun disk
//! `E_dni/Ω_sun`; Koschmieder fog; glass transmittance; a head lamp `E = I(θ)/d²`; rolling-shutter
//! slant `v·Δt_row`; motion blur; LED flicker routing.
//!
//! Scenes are small ground truths (boards, a pole, cars; no lanes → a road plane at z = 0) seen by
//! a pinhole camera of a few dozen pixels. The spectral response is a test-made one (three
//! Gaussian channels) so that the expectations do not depend on the sensor's response model.

mod common;
use common::{dim, rpy, sun, v3};

use std::f64::consts::PI;

use glam::{DVec3, Vec3};
use osiris_models::camera::bench::{CameraBenchScene, bench_camera_on};
use osiris_models::camera::light::HostLamps;
use osiris_models::camera::render::{
    RenderConfig, RenderInput, RenderOutput, Renderer, sun_solid_angle_sr,
};
use osiris_models::camera::{NO_OBJECT, ShutterTiming, SpectralBands, SpectralResponse};
use osiris_models::effects::Effects;
use osiris_models::environment::lamps::{LightDistribution, Spectrum};
use osiris_models::environment::material::{Band, MaterialDb};
use osiris_models::environment::sky::{ClearSkyInput, spectrl2};
use osiris_models::environment::weather::{self, Weather};
use osiris_models::registry::catalogue;
use osiris_models::world::SensorWorld;
use osiris_models::{ModelError, ModelMode, Mounting, SensorConfig, SensorKind};
use osiris_proto::{id, osi3};

/// A board with its face centre at `pos`, oriented by (pitch, yaw) (yaw = π faces a sensor on −x).
fn board(
    oid: u64,
    pos: [f64; 3],
    size: f64,
    material: &str,
    pitch: f64,
    yaw: f64,
) -> osi3::StationaryObject {
    osi3::StationaryObject {
        id: Some(id(oid)),
        base: Some(osi3::BaseStationary {
            dimension: Some(dim([0.01, size, size])),
            position: Some(v3([pos[0], pos[1], pos[2]])),
            orientation: Some(rpy(0.0, pitch, yaw)),
            ..Default::default()
        }),
        model_reference: Some(format!(
            "osiris:board?width_m={size}&height_m={size}&thickness_m=0&mount=none&material={material}"
        )),
        ..Default::default()
    }
}

fn moving(
    oid: u64,
    reference: &str,
    pos: [f64; 3],
    d: [f64; 3],
    yaw: f64,
    velocity: [f64; 3],
) -> osi3::MovingObject {
    osi3::MovingObject {
        id: Some(id(oid)),
        base: Some(osi3::BaseMoving {
            dimension: Some(dim([d[0], d[1], d[2]])),
            position: Some(v3([pos[0], pos[1], pos[2]])),
            orientation: Some(rpy(0.0, 0.0, yaw)),
            velocity: Some(v3([velocity[0], velocity[1], velocity[2]])),
            orientation_rate: Some(rpy(0.0, 0.0, 0.0)),
            ..Default::default()
        }),
        r#type: Some(osi3::moving_object::Type::Vehicle as i32),
        model_reference: Some(reference.into()),
        ..Default::default()
    }
}

fn view(
    stationary: Vec<osi3::StationaryObject>,
    moving: Vec<osi3::MovingObject>,
    env: osi3::EnvironmentalConditions,
    host: Option<u64>,
) -> osi3::SensorView {
    let ts = osi3::Timestamp {
        seconds: Some(1),
        nanos: Some(0),
    };
    osi3::SensorView {
        timestamp: Some(ts),
        host_vehicle_id: host.map(id),
        global_ground_truth: Some(osi3::GroundTruth {
            timestamp: Some(ts),
            host_vehicle_id: host.map(id),
            stationary_object: stationary,
            moving_object: moving,
            environmental_conditions: Some(env),
            ..Default::default()
        }),
        ..Default::default()
    }
}

fn sensor_config(
    position: [f64; 3],
    orientation: [f64; 3],
    weather: Option<Weather>,
) -> SensorConfig {
    SensorConfig {
        kind: SensorKind::Camera,
        mode: ModelMode::Physical,
        range_m: 200.0,
        fov_horizontal_rad: 0.5,
        fov_vertical_rad: 0.4,
        update_cycle_s: 0.1,
        mounting: Mounting {
            position_m: position,
            orientation_rad: orientation,
        },
        calibration: Default::default(),
        min_visible_fraction: 0.2,
        effects: Default::default(),
        weather,
        seed: Some(3),
        lidar: None,
        radar: None,
        camera: None,
        include_sensor_view: false,
    }
}

/// A test response: three Gaussian channels (600, 540, 460 nm; σ 40 nm), 1e12 e⁻ nm J⁻¹ peak.
fn response(bands: &SpectralBands) -> SpectralResponse {
    let g = |l: f64, c: f64| 1e12 * (-0.5 * ((l - c) / 40.0).powi(2)).exp();
    let w = |c: f64| {
        bands
            .centres_nm
            .iter()
            .map(|&l| g(l, c))
            .collect::<Vec<_>>()
    };
    SpectralResponse {
        bands: bands.clone(),
        weights: [w(600.0), w(540.0), w(460.0)],
    }
}

/// Pinhole ray directions (x forward, y left, z up), horizontal FoV `fov_deg`.
fn pinhole(w: usize, h: usize, fov_deg: f64) -> (Vec<Vec3>, f64) {
    let f = 0.5 * w as f64 / (0.5 * fov_deg.to_radians()).tan();
    let (cx, cy) = (0.5 * w as f64, 0.5 * h as f64);
    let mut rays = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            rays.push(
                DVec3::new(1.0, -(x as f64 + 0.5 - cx) / f, -(y as f64 + 0.5 - cy) / f)
                    .normalize()
                    .as_vec3(),
            );
        }
    }
    (rays, f)
}

struct Setup {
    width: usize,
    height: usize,
    fov_deg: f64,
    config: RenderConfig,
    switches: Vec<(&'static str, bool)>,
    timing: Option<ShutterTiming>,
}

impl Default for Setup {
    fn default() -> Self {
        Setup {
            width: 64,
            height: 48,
            fov_deg: 10.0,
            config: RenderConfig::default(),
            switches: Vec::new(),
            timing: None,
        }
    }
}

struct Rendered {
    out: RenderOutput,
    response: SpectralResponse,
    rays: Vec<Vec3>,
    focal_px: f64,
    origin: DVec3,
    rotation: glam::DMat3,
    width: usize,
    effects: Effects,
    weather: Weather,
}

impl Rendered {
    fn px(&self, x: usize, y: usize) -> [f64; 3] {
        let i = y * self.width + x;
        [0, 1, 2].map(|c| f64::from(self.out.radiance.planes[c][i]))
    }
}

fn render(setup: &Setup, sv: &osi3::SensorView, cfg: &SensorConfig) -> Rendered {
    let mut effects = Effects::new(&catalogue());
    // The closed forms below are those of the isotropic sky E_dhi/π unless a test switches the
    // sky distribution on (`sky_distribution_shapes_the_sky_radiance`).
    effects.set("env.sky_distribution", false).unwrap();
    for (k, v) in &setup.switches {
        effects.set(k, *v).unwrap();
    }
    let mut renderer = Renderer::new(&setup.config, &effects).unwrap();
    let response = response(renderer.bands());
    let (rays, focal_px) = pinhole(setup.width, setup.height, setup.fov_deg);
    let mut world = SensorWorld::new();
    let frame = world.update(sv, &cfg.common(), 1.0, None).unwrap();
    let timing = setup.timing.unwrap_or(ShutterTiming {
        frame_time_s: frame.time_s,
        row_time_s: 0.0,
        start_offset_s: 0.0,
        exposure_s: 0.0,
    });
    let input = RenderInput {
        frame: &frame,
        rays: &rays,
        ray_origins: None,
        width: setup.width,
        height: setup.height,
        response: &response,
        timing,
        ground_truth: sv.global_ground_truth.as_ref().unwrap(),
        seed: 5,
        cycle: 0,
    };
    let mut out = RenderOutput::default();
    renderer.render(&input, &mut out);
    Rendered {
        out,
        response,
        rays: rays.clone(),
        focal_px,
        origin: frame.sensor_pose.position,
        rotation: frame.sensor_pose.rotation,
        width: setup.width,
        effects,
        weather: frame.weather,
    }
}

/// `Σ_k w_c,k f(λ_k)` per channel.
fn fold(resp: &SpectralResponse, f: impl Fn(f64) -> f64) -> [f64; 3] {
    [0, 1, 2].map(|c| {
        resp.bands
            .centres_nm
            .iter()
            .zip(&resp.weights[c])
            .map(|(&l, w)| w * f(l))
            .sum()
    })
}

fn assert_close(got: [f64; 3], want: [f64; 3], tol: f64, what: &str) {
    for c in 0..3 {
        let rel = (got[c] - want[c]).abs() / want[c].abs().max(1e-30);
        assert!(
            rel <= tol,
            "{what}: channel {c}: got {:.6e}, want {:.6e} (rel {rel:.4})",
            got[c],
            want[c]
        );
    }
}

fn clear_sky(zenith_deg: f64) -> osiris_models::environment::sky::ClearSkySpectrum {
    spectrl2(&ClearSkyInput {
        zenith_deg,
        day_of_year: 172,
        ..ClearSkyInput::default()
    })
}

fn reflectance(material: &str, l: f64) -> f64 {
    MaterialDb::builtin()
        .by_name(material)
        .map(|m| m.reflectance_visible(l))
        .unwrap_or_else(|| {
            let mut db = MaterialDb::builtin();
            let id = db.resolve(material).unwrap();
            db.get(id).reflectance_visible(l)
        })
}

/// Board facing the sun at normal incidence: sun 30° high behind the camera, board pitched to face it.
#[test]
fn lambertian_board_in_sun_normal_incidence() {
    for material in ["lambertian_90", "lambertian_50"] {
        let sv = view(
            vec![board(
                10,
                [20.0, 0.0, 3.0],
                4.0,
                material,
                -30f64.to_radians(),
                PI,
            )],
            vec![],
            sun(PI / 2.0, 30f64.to_radians()),
            None,
        );
        let r = render(
            &Setup::default(),
            &sv,
            &sensor_config([0.0, 0.0, 3.0], [0.0; 3], None),
        );
        let sky = clear_sky(60.0);
        // n = sun direction: cos θ = 1, n_z = sin 30° → view factor 0.75.
        let want = fold(&r.response, |l| {
            reflectance(material, l) / PI * (sky.dni_at(l) * 1.0 + sky.dhi_at(l) * 0.75)
        });
        for (x, y) in [(32, 24), (31, 23), (20, 30)] {
            assert_close(r.px(x, y), want, 0.01, material);
        }
        // The board is an object of the aux output.
        let i = 24 * 64 + 32;
        assert_ne!(r.out.aux.object_index[i], NO_OBJECT);
        assert_eq!(r.out.aux.object_ids[r.out.aux.object_index[i] as usize], 10);
        assert!((f64::from(r.out.aux.depth_m[i]) - 20.0).abs() < 0.1);
    }
}

/// Vertical board, sun 60° high behind the camera: 60° incidence, n_z = 0.
#[test]
fn lambertian_board_at_60_degrees_incidence() {
    let sv = view(
        vec![board(10, [20.0, 0.0, 3.0], 4.0, "lambertian_90", 0.0, PI)],
        vec![],
        sun(PI / 2.0, 60f64.to_radians()),
        None,
    );
    let r = render(
        &Setup::default(),
        &sv,
        &sensor_config([0.0, 0.0, 3.0], [0.0; 3], None),
    );
    let sky = clear_sky(30.0);
    let want = fold(&r.response, |l| {
        0.9 / PI * (sky.dni_at(l) * 0.5 + sky.dhi_at(l) * 0.5)
    });
    assert_close(r.px(32, 24), want, 0.01, "60° incidence");
}

/// Sun behind the board (own shadow) or blocked by an occluder: only the sky term.
#[test]
fn shadowed_board_gets_only_sky() {
    let sky60 = clear_sky(60.0);
    // Own shadow: sun 30° high in front of the camera, behind the vertical board.
    let sv = view(
        vec![board(10, [20.0, 0.0, 3.0], 4.0, "lambertian_90", 0.0, PI)],
        vec![],
        sun(-PI / 2.0, 30f64.to_radians()),
        None,
    );
    let r = render(
        &Setup::default(),
        &sv,
        &sensor_config([0.0, 0.0, 3.0], [0.0; 3], None),
    );
    let want = fold(&r.response, |l| 0.9 / PI * sky60.dhi_at(l) * 0.5);
    assert_close(r.px(32, 24), want, 0.01, "own shadow");

    // Occluder: the sun (60° high, behind the camera) is blocked by a 6 m board 5 m towards it.
    let s = DVec3::new(-(60f64.to_radians().cos()), 0.0, 60f64.to_radians().sin());
    let c = DVec3::new(20.0, 0.0, 3.0) + 5.0 * s;
    let sv = view(
        vec![
            board(10, [20.0, 0.0, 3.0], 4.0, "lambertian_90", 0.0, PI),
            board(
                11,
                [c.x, c.y, c.z],
                6.0,
                "lambertian_50",
                -60f64.to_radians(),
                PI,
            ),
        ],
        vec![],
        sun(PI / 2.0, 60f64.to_radians()),
        None,
    );
    let r = render(
        &Setup::default(),
        &sv,
        &sensor_config([0.0, 0.0, 3.0], [0.0; 3], None),
    );
    let sky30 = clear_sky(30.0);
    let want = fold(&r.response, |l| 0.9 / PI * sky30.dhi_at(l) * 0.5);
    assert_close(r.px(32, 24), want, 0.01, "occluder");
}

/// Looking into the sun: disk pixels = E_dni/Ω_sun + sky, sky pixels = E_dhi/π, `sun` filled.
#[test]
fn sun_disk_radiance() {
    let el = 10f64.to_radians();
    let sv = view(vec![], vec![], sun(-PI / 2.0, el), None);
    let setup = Setup {
        fov_deg: 2.0,
        ..Setup::default()
    };
    // Camera pitched up by 10° (positive pitch is nose down).
    let r = render(
        &setup,
        &sv,
        &sensor_config([0.0, 0.0, 2.0], [0.0, -el, 0.0], None),
    );
    let sky = clear_sky(80.0);
    let omega = 2.0 * PI * (1.0 - 0.26667f64.to_radians().cos());
    assert!((sun_solid_angle_sr() - omega).abs() < 1e-12);
    let disk = fold(&r.response, |l| sky.dni_at(l) / omega + sky.dhi_at(l) / PI);
    assert_close(r.px(32, 24), disk, 0.01, "sun disk");
    assert_close(r.px(31, 23), disk, 0.01, "sun disk");
    let sky_only = fold(&r.response, |l| sky.dhi_at(l) / PI);
    assert_close(r.px(0, 0), sky_only, 0.01, "sky");
    let s = r.out.sun.expect("sun in view");
    assert!(s.direction_sensor.x > 0.999);
    let want = fold(&r.response, |l| sky.dni_at(l) / omega);
    assert_close(s.radiance, want, 1e-6, "SunInView radiance");
    // Disk pixels far exceed the sky (backlit scene saturates where the sun is).
    assert!(r.px(32, 24)[1] > 1e4 * r.px(0, 0)[1]);
}

/// `env.sky_distribution`: each sky pixel is the isotropic E_dhi/π times the CIE clear sky's
/// k(ω) = π·ℓ(ω)/∫ℓ cos Z dΩ, with ℓ = f(χ)φ(Z)/(f(Z_s)φ(0)) of CIE S 011 type 12 written out here
/// and its normalisation integrated here (midpoint rule, ¼° cells); off, the isotropic sky.
#[test]
fn sky_distribution_shapes_the_sky_radiance() {
    let (sun_az, sun_el) = (-PI / 2.0, 35f64.to_radians());
    let sv = view(vec![], vec![], sun(sun_az, sun_el), None);
    let setup = |on: bool| Setup {
        fov_deg: 60.0,
        switches: vec![("env.sky_distribution", on)],
        ..Setup::default()
    };
    // Pitched up 35° (positive pitch is nose down), so that the whole image is sky.
    let cfg = sensor_config([0.0, 0.0, 2.0], [0.0, -35f64.to_radians(), 0.0], None);
    let on = render(&setup(true), &sv, &cfg);
    let off = render(&setup(false), &sv, &cfg);
    let sun_dir = osiris_models::environment::sun::sun_direction(
        sv.global_ground_truth
            .as_ref()
            .unwrap()
            .environmental_conditions
            .as_ref(),
    );
    let f =
        |x: f64| 1.0 + 10.0 * ((-3.0 * x).exp() - (-3.0 * PI / 2.0).exp()) + 0.45 * x.cos().powi(2);
    let phi = |z: f64| 1.0 - (-0.32 / z.cos().max(1e-12)).exp();
    let zs = PI / 2.0 - sun_el;
    let ell = |d: DVec3| {
        let z = d.z.clamp(0.0, 1.0).acos();
        let chi = d.dot(sun_dir).clamp(-1.0, 1.0).acos();
        f(chi) * phi(z) / (f(zs) * phi(0.0))
    };
    let (nz, na) = (360usize, 1440usize);
    let (dz, da) = (PI / 2.0 / nz as f64, 2.0 * PI / na as f64);
    let mut integral = 0.0;
    for i in 0..nz {
        let z = (i as f64 + 0.5) * dz;
        for j in 0..na {
            let a = (j as f64 + 0.5) * da;
            let d = DVec3::new(z.sin() * a.cos(), z.sin() * a.sin(), z.cos());
            integral += ell(d) * z.cos() * z.sin() * dz * da;
        }
    }
    let mut ratios = Vec::new();
    for (x, y) in [(32, 24), (0, 0), (63, 47), (5, 40), (60, 3)] {
        let d = (on.rotation * on.rays[y * on.width + x].as_dvec3()).normalize();
        let want = PI * ell(d) / integral;
        let got = on.px(x, y)[1] / off.px(x, y)[1];
        assert!(
            (got / want - 1.0).abs() < 0.01,
            "pixel ({x}, {y}), direction {d:?}: on/off {got:.4}, CIE k {want:.4}"
        );
        ratios.push(got);
    }
    // Off: every sky pixel the same E_dhi/π.
    assert!((off.px(0, 0)[1] / off.px(63, 47)[1] - 1.0).abs() < 1e-6);
    // On: the image is not flat.
    let (lo, hi) = ratios
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &r| (a.min(r), b.max(r)));
    assert!(hi > 1.3 * lo, "sky factors {ratios:?}");
}

/// Fog: L = L_0 e^{−σd} + L_air (1 − e^{−σd}), σ per band, L_air = E_dhi/π.
#[test]
fn fog_attenuates_and_veils() {
    let d = 30.0;
    let fog = Weather {
        fog_visibility_m: 200.0,
        ..Weather::CLEAR
    };
    let sv = view(
        vec![board(
            10,
            [d, 0.0, 3.0],
            6.0,
            "lambertian_50",
            -30f64.to_radians(),
            PI,
        )],
        vec![],
        sun(PI / 2.0, 30f64.to_radians()),
        None,
    );
    let r = render(
        &Setup::default(),
        &sv,
        &sensor_config([0.0, 0.0, 3.0], [0.0; 3], Some(fog)),
    );
    let sky = clear_sky(60.0);
    let sigma = |l: f64| {
        weather::extinction_per_m_with(&r.weather, weather::Band::Visible { nm: l }, &r.effects)
    };
    assert!(sigma(550.0) > 0.01);
    let want = fold(&r.response, |l| {
        let l0 = 0.5 / PI * (sky.dni_at(l) + sky.dhi_at(l) * 0.75);
        let t = (-sigma(l) * d).exp();
        l0 * t + sky.dhi_at(l) / PI * (1.0 - t)
    });
    assert_close(r.px(32, 24), want, 0.01, "fog");
    // Without fog extinction the board is brighter.
    let setup = Setup {
        switches: vec![("env.fog_extinction", false)],
        ..Setup::default()
    };
    let clear = render(
        &setup,
        &sv,
        &sensor_config([0.0, 0.0, 3.0], [0.0; 3], Some(fog)),
    );
    let l0 = fold(&r.response, |l| {
        0.5 / PI * (sky.dni_at(l) + sky.dhi_at(l) * 0.75)
    });
    assert_close(clear.px(32, 24), l0, 0.01, "fog switched off");
}

/// A glass pane in front of the board: τ(550 nm) · L_board + R_slab · L_sky.
#[test]
fn glass_pane_transmits() {
    let board_20 = board(
        10,
        [20.0, 0.0, 3.0],
        4.0,
        "lambertian_90",
        -30f64.to_radians(),
        PI,
    );
    let pane = board(11, [10.0, 0.0, 3.0], 3.0, "glass", 0.0, PI);
    let sv = view(
        vec![board_20, pane],
        vec![],
        sun(PI / 2.0, 30f64.to_radians()),
        None,
    );
    let r = render(
        &Setup::default(),
        &sv,
        &sensor_config([0.0, 0.0, 3.0], [0.0; 3], None),
    );
    let sky = clear_sky(60.0);
    let glass = MaterialDb::builtin();
    let glass = glass.by_name("glass").unwrap();
    let so = glass.slab_optics(Band::Visible(550.0), 1.0).unwrap();
    assert!(so.transmittance > 0.8 && so.transmittance < 0.95);
    let want = fold(&r.response, |l| {
        so.transmittance * 0.9 / PI * (sky.dni_at(l) + sky.dhi_at(l) * 0.75)
            + so.reflectance * sky.dhi_at(l) / PI
    });
    assert_close(r.px(32, 24), want, 0.01, "through glass");
    // The pane is the object seen (depth 10 m).
    let i = 24 * 64 + 32;
    assert!((f64::from(r.out.aux.depth_m[i]) - 10.0).abs() < 0.1);
}

/// Host head lamps at night on a board: E = Σ I(θ) cos θ / d², L = ρ/π E s(λ).
#[test]
fn host_headlamps_light_a_board_at_night() {
    let host = moving(
        1,
        "osiris:car",
        [0.0, 0.0, 0.75],
        [4.5, 1.8, 1.5],
        0.0,
        [0.0; 3],
    );
    let sv = view(
        vec![board(10, [17.25, 0.0, 1.0], 4.0, "lambertian_90", 0.0, PI)],
        vec![host],
        sun(0.0, -10f64.to_radians()),
        Some(1),
    );
    let mut setup = Setup::default();
    setup.config.lamps.host = HostLamps::On;
    // Camera 1 m ahead of the box centre, 1.25 m high, pitched 3° down.
    let pitch = 3f64.to_radians();
    let r = render(
        &setup,
        &sv,
        &sensor_config([1.0, 0.0, 0.5], [0.0, pitch, 0.0], None),
    );
    let (x, y) = (32, 24);
    let i = y * 64 + x;
    let depth = f64::from(r.out.aux.depth_m[i]);
    assert!(depth.is_finite());
    let dir = r.rotation * r.rays[i].as_dvec3();
    let p = r.origin + dir * depth;
    // Lamps: documented host layout (front face, ±0.36 w, 0.65 m above the ground).
    let low = LightDistribution::ece_low_beam();
    let mut e_lux = 0.0;
    for ly in [0.36 * 1.8, -0.36 * 1.8] {
        let lamp = DVec3::new(2.25, ly, 0.65);
        let d = p - lamp;
        let r2 = d.length_squared();
        let cos = d.x / r2.sqrt(); // board normal −x faces the lamp
        e_lux += low.intensity_cd_dir(d) * cos / r2;
    }
    assert!(e_lux > 1.0, "the low beam lights the board ({e_lux} lx)");
    let led = Spectrum::white_led();
    let want = fold(&r.response, |l| 0.9 / PI * e_lux * led.w_per_nm_per_lm(l));
    // f32 geometry and the interpolated distribution: 2 %.
    assert_close(r.px(x, y), want, 0.02, "head lamps");
    // Lamps off: black.
    let mut setup = Setup::default();
    setup.config.lamps.host = HostLamps::Off;
    let dark = render(
        &setup,
        &sv,
        &sensor_config([1.0, 0.0, 0.5], [0.0, pitch, 0.0], None),
    );
    assert!(dark.px(x, y)[1] < 1e-6 * r.px(x, y)[1].max(1.0));
}

/// Centroid column of the pole in each row, with the pole's object id.
fn pole_columns(r: &Rendered, w: usize, h: usize, oid: u64) -> Vec<(f64, f64)> {
    let Some(k) = r.out.aux.object_ids.iter().position(|&o| o == oid) else {
        return Vec::new();
    };
    (0..h)
        .filter_map(|y| {
            let xs: Vec<f64> = (0..w)
                .filter(|&x| r.out.aux.object_index[y * w + x] == k as u32)
                .map(|x| x as f64 + 0.5)
                .collect();
            (!xs.is_empty()).then(|| (y as f64, xs.iter().sum::<f64>() / xs.len() as f64))
        })
        .collect()
}

fn slope(points: &[(f64, f64)]) -> f64 {
    let n = points.len() as f64;
    let (mx, my) = points
        .iter()
        .fold((0.0, 0.0), |a, p| (a.0 + p.0 / n, a.1 + p.1 / n));
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    sxy / sxx
}

fn pole_view(speed: f64) -> osi3::SensorView {
    view(
        vec![],
        vec![moving(
            20,
            "osiris:pole",
            [20.0, 0.0, 2.0],
            [0.15, 0.15, 4.0],
            0.0,
            [0.0, speed, 0.0],
        )],
        sun(PI / 2.0, 40f64.to_radians()),
        None,
    )
}

/// A pole passing sideways at 20 m/s is slanted by v·Δt_row per row.
#[test]
fn rolling_shutter_slants_a_moving_pole() {
    let (w, h) = (64, 48);
    let row_time = 1e-3;
    let setup = |on: bool| Setup {
        fov_deg: 20.0,
        switches: vec![
            ("camera.rolling_shutter", on),
            ("camera.motion_blur", false),
        ],
        timing: Some(ShutterTiming {
            frame_time_s: 1.0,
            row_time_s: row_time,
            start_offset_s: 0.0,
            exposure_s: 0.0,
        }),
        ..Setup::default()
    };
    let cfg = sensor_config([0.0, 0.0, 1.5], [0.0; 3], None);
    let r = render(&setup(true), &pole_view(20.0), &cfg);
    let cols = pole_columns(&r, w, h, 20);
    assert!(cols.len() > 30, "pole visible in {} rows", cols.len());
    // +y (left) motion: u decreases by f·v·Δt_row / d per row.
    let want = -r.focal_px * 20.0 * row_time / 20.0;
    let got = slope(&cols);
    assert!(
        (got - want).abs() < 0.1 * want.abs(),
        "slant {got} px/row, want {want}"
    );
    // Rolling shutter off: upright.
    let r = render(&setup(false), &pole_view(20.0), &cfg);
    let got = slope(&pole_columns(&r, w, h, 20));
    assert!(got.abs() < 0.02, "global shutter slant {got}");
}

/// Motion blur widens the pole's edge in the image by ≈ f·v·t_exp/d pixels.
#[test]
fn motion_blur_widens_the_edge() {
    let (w, y) = (64usize, 6usize);
    let exposure = 0.02;
    let setup = |on: bool| {
        let mut s = Setup {
            fov_deg: 20.0,
            switches: vec![
                ("camera.rolling_shutter", false),
                ("camera.motion_blur", on),
            ],
            timing: Some(ShutterTiming {
                frame_time_s: 1.0,
                row_time_s: 0.0,
                start_offset_s: 0.0,
                exposure_s: exposure,
            }),
            ..Setup::default()
        };
        s.config.motion_samples = 16;
        s
    };
    let cfg = sensor_config([0.0, 0.0, 1.5], [0.0; 3], None);
    let width = |r: &Rendered| {
        let bg = r.px(0, y)[1];
        (0..w)
            .filter(|&x| (r.px(x, y)[1] - bg).abs() > 0.05 * bg)
            .count()
    };
    let sharp = render(&setup(false), &pole_view(20.0), &cfg);
    let blurred = render(&setup(true), &pole_view(20.0), &cfg);
    let (ws, wb) = (width(&sharp), width(&blurred));
    let streak = sharp.focal_px * 20.0 * exposure / 20.0;
    assert!((1..=3).contains(&ws), "sharp pole {ws} px wide");
    assert!(
        wb as f64 >= ws as f64 + 0.6 * streak,
        "blurred {wb} px vs sharp {ws} px (streak {streak:.1} px)"
    );
}

/// A car ahead with its tail lamps on: LED pixels go to the flicker list only with the effect on.
#[test]
fn led_flicker_samples_only_with_the_effect() {
    let mut car = moving(
        30,
        "osiris:car",
        [12.0, 0.0, 0.75],
        [4.5, 1.8, 1.5],
        0.0,
        [0.0; 3],
    );
    car.vehicle_classification = Some(osi3::moving_object::VehicleClassification {
        light_state: Some(osi3::moving_object::vehicle_classification::LightState {
            tail_light: Some(
                osi3::moving_object::vehicle_classification::light_state::GenericLightState::On
                    as i32,
            ),
            ..Default::default()
        }),
        ..Default::default()
    });
    let sv = view(vec![], vec![car], sun(0.0, -10f64.to_radians()), None);
    let cfg = sensor_config([0.0, 0.0, 1.0], [0.0; 3], None);
    let setup = |on: bool| Setup {
        width: 160,
        height: 120,
        fov_deg: 20.0,
        switches: vec![("camera.led_flicker", on)],
        ..Setup::default()
    };
    let on = render(&setup(true), &sv, &cfg);
    let off = render(&setup(false), &sv, &cfg);
    assert!(
        on.out.flicker.samples.len() >= 4,
        "{} flicker samples",
        on.out.flicker.samples.len()
    );
    assert!(off.out.flicker.samples.is_empty());
    for f in &on.out.flicker.samples {
        let src = on.out.flicker.sources[f.source as usize];
        assert!(src.frequency_hz > 0.0 && src.duty < 1.0);
        // Red lamp: the red channel dominates.
        assert!(f.value[0] > f.value[2]);
        // Off: the same light is in the image at its average.
        let i = f.pixel as usize;
        for c in 0..3 {
            let img_on = f64::from(on.out.radiance.planes[c][i]);
            let img_off = f64::from(off.out.radiance.planes[c][i]);
            let want = img_on + f64::from(f.value[c]);
            assert!((img_off - want).abs() <= 1e-4 * want.abs() + 1e-3);
        }
    }
}

#[test]
fn bad_config_names_the_key() {
    let effects = Effects::new(&catalogue());
    let cfg = RenderConfig {
        bands: 0,
        ..RenderConfig::default()
    };
    match Renderer::new(&cfg, &effects) {
        Err(ModelError::Config(m)) => assert!(m.contains("camera.render.bands"), "{m}"),
        _ => panic!("bands = 0 accepted"),
    }
    let mut cfg = RenderConfig::default();
    cfg.lamps.tail_duty = 1.5;
    match Renderer::new(&cfg, &effects) {
        Err(ModelError::Config(m)) => assert!(m.contains("camera.render.lamps.tail_duty"), "{m}"),
        _ => panic!("duty 1.5 accepted"),
    }
    let json = r#"{"bands": 8, "nonsense": 1}"#;
    assert!(serde_json::from_str::<RenderConfig>(json).is_err());
}

#[test]
fn render_is_deterministic_with_bounces() {
    let sv = view(
        vec![board(10, [20.0, 0.0, 3.0], 4.0, "lambertian_90", 0.0, PI)],
        vec![],
        sun(PI / 2.0, 45f64.to_radians()),
        None,
    );
    let mut setup = Setup::default();
    setup.config.diffuse_bounces = 2;
    let cfg = sensor_config([0.0, 0.0, 3.0], [0.0; 3], None);
    let a = render(&setup, &sv, &cfg);
    let b = render(&setup, &sv, &cfg);
    assert_eq!(a.out.radiance, b.out.radiance);
    // With bounces the board gets sky light from above and sun light reflected by the road: on
    // average of the same order as the ambient model.
    let ambient = render(&Setup::default(), &sv, &cfg);
    let mean = |r: &Rendered| {
        (20..44)
            .flat_map(|x| (16..32).map(move |y| (x, y)))
            .map(|(x, y)| r.px(x, y)[1])
            .sum::<f64>()
    };
    let ratio = mean(&a) / mean(&ambient);
    assert!((0.7..1.3).contains(&ratio), "bounce / ambient = {ratio}");
}

#[test]
fn bench_small_reports_the_keys() {
    let v = bench_camera_on(&CameraBenchScene::SMALL, Some(1), 1);
    assert!(v.get("error").is_none(), "{v}");
    for k in [
        "frames_per_s",
        "width",
        "height",
        "threads",
        "frames",
        "render_s",
        "trace_s",
        "shading_s",
        "lens_s",
        "pixel_s",
        "isp_s",
        "recognition_s",
    ] {
        assert!(v.get(k).is_some(), "missing {k}: {v}");
    }
    assert_eq!(v["width"], 160);
    assert!(v["frames_per_s"].as_f64().unwrap() > 0.0);
}
