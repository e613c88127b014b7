//! Traffic signs, traffic lights and road markings from OSI (`environment::traffic`, the camera's
//! signal lamps in `camera::light`) against closed forms written here:
//!
//! * a lit signal lens seen by the camera has the radiance `L = I(θ)/(A cos θ) · s(λ)` with the
//!   EN 12368-like distribution `I = I₀ exp(−(h/15°)²) exp(−(v/8°)²)` (physics.md §3.7) and the LED
//!   line `s(λ)` normalised to one lumen; an unlit (OFF, or FLASHING in its off-phase) lens is dark;
//! * with `camera.led_flicker` and an exposure shorter than the PWM period the lens rows of the
//!   pixel model follow the PWM on-fraction (some rows dark), without the effect or with an exposure
//!   of whole periods they do not;
//! * a retroreflective sign in the host's low beams has the luminance `Σ R(γ_j) E_j`, the lobe
//!   `R(γ) = R₀ exp(−γ²/σ²)` fitted here to the EN 12899-1 RA2 white coefficients (physics.md §3.6);
//! * a road-marking polygon covers exactly the pixels whose rays meet it;
//! * the OSI ids of sign plates, bulbs and markings are in the camera's object mask; LiDAR and radar
//!   see the sign plate.

mod common;
use common::{dim, rpy, sun, v3};

use std::f64::consts::PI;

use glam::{DVec3, Vec3};
use osiris_models::camera::light::HostLamps;
use osiris_models::camera::pixel::{PixelConfig, PixelModel};
use osiris_models::camera::render::{RenderConfig, RenderInput, RenderOutput, Renderer};
use osiris_models::camera::{NO_OBJECT, RawImage, ShutterTiming, SpectralBands, SpectralResponse};
use osiris_models::effects::Effects;
use osiris_models::environment::lamps::{
    LightDistribution, Spectrum, photopic_v, planck_radiance_w_m2_sr_nm,
};
use osiris_models::environment::material::MaterialDb;
use osiris_models::environment::scene::{Scene, SceneBuilder, StaticElement};
use osiris_models::registry::catalogue;
use osiris_models::world::SensorWorld;
use osiris_models::{ModelMode, Mounting, SensorConfig, SensorKind};
use osiris_proto::{id, osi3};

// ---------------------------------------------------------------------------------------------
// OSI builders

type Mode = osi3::traffic_light::classification::Mode;
type Colour = osi3::traffic_light::classification::Color;

/// A traffic-light bulb: lens centre `pos`, facing yaw `yaw` (π: towards −x), lens diameter `d`.
fn bulb(
    oid: u64,
    pos: [f64; 3],
    yaw: f64,
    d: f64,
    colour: Colour,
    mode: Mode,
) -> osi3::TrafficLight {
    osi3::TrafficLight {
        id: Some(id(oid)),
        base: Some(osi3::BaseStationary {
            dimension: Some(dim([0.05, d, d])),
            position: Some(v3(pos)),
            orientation: Some(rpy(0.0, 0.0, yaw)),
            ..Default::default()
        }),
        classification: Some(osi3::traffic_light::Classification {
            color: Some(colour as i32),
            mode: Some(mode as i32),
            ..Default::default()
        }),
        ..Default::default()
    }
}

type SignType = osi3::traffic_sign::main_sign::classification::Type;

/// A traffic sign whose plate centre is `pos`, view normal at yaw `yaw`, plate `w` × `h`.
fn sign(oid: u64, ty: SignType, pos: [f64; 3], yaw: f64, w: f64, h: f64) -> osi3::TrafficSign {
    osi3::TrafficSign {
        id: Some(id(oid)),
        main_sign: Some(osi3::traffic_sign::MainSign {
            base: Some(osi3::BaseStationary {
                dimension: Some(dim([0.002, w, h])),
                position: Some(v3(pos)),
                orientation: Some(rpy(0.0, 0.0, yaw)),
                ..Default::default()
            }),
            classification: Some(osi3::traffic_sign::main_sign::Classification {
                r#type: Some(ty as i32),
                ..Default::default()
            }),
            ..Default::default()
        }),
        ..Default::default()
    }
}

/// The ground truth of a SensorView at `t_s` with traffic elements (no lanes: a road plane at the
/// host's wheel contact height, else z = 0).
#[allow(clippy::too_many_arguments)]
fn view(
    t_s: f64,
    lights: Vec<osi3::TrafficLight>,
    signs: Vec<osi3::TrafficSign>,
    markings: Vec<osi3::RoadMarking>,
    moving: Vec<osi3::MovingObject>,
    host: Option<u64>,
    env: osi3::EnvironmentalConditions,
) -> osi3::SensorView {
    let ts = osi3::Timestamp {
        seconds: Some(t_s.floor() as i64),
        nanos: Some(((t_s - t_s.floor()) * 1e9).round() as u32),
    };
    osi3::SensorView {
        timestamp: Some(ts),
        host_vehicle_id: host.map(id),
        global_ground_truth: Some(osi3::GroundTruth {
            timestamp: Some(ts),
            host_vehicle_id: host.map(id),
            traffic_light: lights,
            traffic_sign: signs,
            road_marking: markings,
            moving_object: moving,
            environmental_conditions: Some(env),
            ..Default::default()
        }),
        ..Default::default()
    }
}

fn night() -> osi3::EnvironmentalConditions {
    sun(0.0, -10f64.to_radians())
}

fn camera_config(position: [f64; 3], orientation: [f64; 3]) -> SensorConfig {
    SensorConfig {
        kind: SensorKind::Camera,
        mode: ModelMode::Physical,
        range_m: 300.0,
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
        weather: None,
        seed: Some(3),
        lidar: None,
        radar: None,
        camera: None,
        include_sensor_view: false,
    }
}

// ---------------------------------------------------------------------------------------------
// Rendering

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

struct Setup {
    width: usize,
    height: usize,
    fov_deg: f64,
    config: RenderConfig,
    switches: Vec<(&'static str, bool)>,
    /// Row time and exposure, s (the frame starts at the SensorView's time).
    row_time_s: f64,
    exposure_s: f64,
}

impl Default for Setup {
    fn default() -> Self {
        Setup {
            width: 64,
            height: 48,
            fov_deg: 2.0,
            config: RenderConfig::default(),
            switches: vec![("env.sky_distribution", false)],
            row_time_s: 0.0,
            exposure_s: 0.0,
        }
    }
}

struct Rendered {
    out: RenderOutput,
    response: SpectralResponse,
    rays: Vec<DVec3>,
    origin: DVec3,
    width: usize,
    timing: ShutterTiming,
}

impl Rendered {
    fn px(&self, i: usize) -> [f64; 3] {
        [0, 1, 2].map(|c| f64::from(self.out.radiance.planes[c][i]))
    }
    /// Scene-frame point the primary ray of pixel `i` hits.
    fn point(&self, i: usize) -> DVec3 {
        self.origin + self.rays[i] * f64::from(self.out.aux.depth_m[i])
    }
    /// Pixels whose mask shows ground-truth id `oid`.
    fn pixels_of(&self, oid: u64) -> Vec<usize> {
        let Some(k) = self.out.aux.object_ids.iter().position(|&o| o == oid) else {
            return Vec::new();
        };
        (0..self.out.aux.object_index.len())
            .filter(|&i| self.out.aux.object_index[i] == k as u32)
            .collect()
    }
}

/// Pinhole ray directions (x forward, y left, z up), horizontal FoV `fov_deg`.
fn pinhole(w: usize, h: usize, fov_deg: f64) -> Vec<Vec3> {
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
    rays
}

fn render(setup: &Setup, sv: &osi3::SensorView, cfg: &SensorConfig) -> Rendered {
    let mut effects = Effects::new(&catalogue());
    for (k, v) in &setup.switches {
        effects.set(k, *v).unwrap();
    }
    let mut renderer = Renderer::new(&setup.config, &effects).unwrap();
    let response = response(renderer.bands());
    let rays = pinhole(setup.width, setup.height, setup.fov_deg);
    let mut world = SensorWorld::new();
    let frame = world.update(sv, &cfg.common(), 1.0, None).unwrap();
    let timing = ShutterTiming {
        frame_time_s: frame.time_s,
        row_time_s: setup.row_time_s,
        start_offset_s: 0.0,
        exposure_s: setup.exposure_s,
    };
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
        rays: rays
            .iter()
            .map(|r| frame.sensor_pose.rotation * r.as_dvec3())
            .collect(),
        origin: frame.sensor_pose.position,
        width: setup.width,
        timing,
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

/// A Gaussian LED line (peak, FWHM in nm) normalised to one lumen: `G(λ) / (683 ∫ G V dλ)`,
/// W nm⁻¹ lm⁻¹ (trapezoid, 0.25 nm).
fn led_per_lumen(peak_nm: f64, fwhm_nm: f64) -> impl Fn(f64) -> f64 {
    let sigma = fwhm_nm / (2.0 * (2.0 * 2f64.ln()).sqrt());
    let g = move |l: f64| (-0.5 * ((l - peak_nm) / sigma).powi(2)).exp();
    let n = 1600;
    let h = 400.0 / n as f64;
    let lm: f64 = 683.0
        * (0..=n)
            .map(|k| {
                let l = 380.0 + k as f64 * h;
                let wt = if k == 0 || k == n { 0.5 } else { 1.0 };
                wt * g(l) * photopic_v(l)
            })
            .sum::<f64>()
        * h;
    move |l| g(l) / lm
}

/// The pixels of a bulb's lens whose rays pass within `frac` of its radius of the lens centre.
fn lens_core(r: &Rendered, centre: DVec3, axis: DVec3, radius: f64, frac: f64) -> Vec<usize> {
    (0..r.rays.len())
        .filter(|&i| {
            let d = r.rays[i];
            let t = (centre - r.origin).dot(axis) / d.dot(axis);
            let p = r.origin + d * t;
            p.distance(centre) < frac * radius
        })
        .collect()
}

// ---------------------------------------------------------------------------------------------
// Signal lamps

/// Bulb 30 m ahead, 1 m above the camera, facing it: 300 mm red, CONSTANT.
fn signal_scene(t_s: f64, mode: Mode) -> osi3::SensorView {
    view(
        t_s,
        vec![bulb(7, [30.0, 0.0, 2.5], PI, 0.3, Colour::Red, mode)],
        vec![],
        vec![],
        vec![],
        None,
        night(),
    )
}

/// The camera at (0, 0, 1.5) looking at the bulb (pitched up by atan(1/30)).
fn signal_camera() -> SensorConfig {
    camera_config([0.0, 0.0, 1.5], [0.0, -(1f64 / 30.0).atan(), 0.0])
}

#[test]
fn lit_signal_lens_radiance_is_intensity_over_projected_area() {
    let setup = Setup {
        switches: vec![
            ("env.sky_distribution", false),
            ("camera.led_flicker", false),
        ],
        ..Setup::default()
    };
    let r = render(&setup, &signal_scene(1.0, Mode::Constant), &signal_camera());
    // The scene frame is the global one here (origin rounded to 100 m from z = 0).
    assert!(r.origin.distance(DVec3::new(0.0, 0.0, 1.5)) < 1e-9);
    let centre = DVec3::new(30.0, 0.0, 2.5);
    let core = lens_core(&r, centre, DVec3::X, 0.15, 0.6);
    assert!(core.len() >= 20, "{} lens pixels", core.len());
    // Closed form: θ between the lamp axis (−x) and the direction to the camera; the lamp frame's
    // h (left of the axis) and v (up).
    let to_cam = (r.origin - centre).normalize();
    let cos = to_cam.dot(-DVec3::X);
    let h = (-to_cam.y).atan2(-to_cam.x).to_degrees();
    let v = to_cam.z.asin().to_degrees();
    let i_cd = 800.0 * (-(h / 15.0).powi(2)).exp() * (-(v / 8.0).powi(2)).exp();
    let area = PI * 0.15 * 0.15;
    let lv = i_cd / (area * cos);
    let s = led_per_lumen(630.0, 20.0);
    let want = fold(&r.response, |l| lv * s(l));
    for &i in &core {
        assert_close(r.px(i), want, 0.01, "lit lens");
        assert_eq!(
            r.out.aux.object_ids[r.out.aux.object_index[i] as usize], 7,
            "lens pixel {i} carries the bulb id"
        );
    }
    // The housing around the lens is dark and not in the mask.
    let housing: Vec<usize> = (0..r.rays.len())
        .filter(|&i| {
            let p = r.point(i);
            r.out.aux.depth_m[i].is_finite()
                && (p - centre).truncate().length() < 0.25
                && (p.z - centre.z).abs() > 0.17
                && (p.z - centre.z).abs() < 0.19
        })
        .collect();
    assert!(!housing.is_empty());
    for &i in &housing {
        assert_eq!(r.out.aux.object_index[i], NO_OBJECT);
        assert!(r.px(i)[0] < 1e-6 * want[0]);
    }
}

#[test]
fn unlit_and_flashing_off_lenses_are_dark() {
    let setup = Setup {
        switches: vec![
            ("env.sky_distribution", false),
            ("camera.led_flicker", false),
        ],
        ..Setup::default()
    };
    let cam = signal_camera();
    let lit = render(&setup, &signal_scene(1.0, Mode::Constant), &cam);
    let centre = DVec3::new(30.0, 0.0, 2.5);
    let core = lens_core(&lit, centre, DVec3::X, 0.15, 0.6);
    // OFF, and FLASHING (1 Hz, 50 %, phase 0) at t = 1.7 s (off-phase) are dark; FLASHING at
    // t = 1.2 s is lit like CONSTANT. Every case keeps the id in the mask.
    for (t, mode, on) in [
        (1.0, Mode::Off, false),
        (1.7, Mode::Flashing, false),
        (1.2, Mode::Flashing, true),
        (1.0, Mode::Counting, true),
    ] {
        let r = render(&setup, &signal_scene(t, mode), &cam);
        for &i in &core {
            let v = r.px(i)[0];
            let bright = lit.px(i)[0];
            if on {
                assert!((v - bright).abs() < 1e-4 * bright, "{mode:?} at {t} s: {v}");
            } else {
                assert!(v < 1e-6 * bright, "{mode:?} at {t} s: {v} vs lit {bright}");
            }
            assert_eq!(r.out.aux.object_ids[r.out.aux.object_index[i] as usize], 7);
        }
    }
}

/// LED flicker: the lens rows integrate the 100 Hz, 50 % PWM over 1 ms windows.
#[test]
fn signal_lens_flickers_with_short_exposures() {
    let row_time = 1e-3;
    let setup = |flicker: bool, exposure: f64| Setup {
        switches: vec![
            ("env.sky_distribution", false),
            ("camera.led_flicker", flicker),
            ("camera.motion_blur", false),
        ],
        row_time_s: row_time,
        exposure_s: exposure,
        ..Setup::default()
    };
    let cam = signal_camera();
    let sv = signal_scene(1.0, Mode::Constant);
    let r = render(&setup(true, 1e-3), &sv, &cam);
    let (w, h) = (64, 48);
    let centre = DVec3::new(30.0, 0.0, 2.5);
    let core = lens_core(&r, centre, DVec3::X, 0.15, 0.6);
    // Every core pixel went to the flicker list, with the configured source.
    let fl = &r.out.flicker;
    for &i in &core {
        let s = fl
            .samples
            .iter()
            .find(|s| s.pixel as usize == i)
            .unwrap_or_else(|| panic!("lens pixel {i} not in the flicker list"));
        let src = fl.sources[s.source as usize];
        assert_eq!((src.frequency_hz, src.duty, src.phase_s), (100.0, 0.5, 0.0));
        // Not in the steady image.
        assert!(r.px(i)[0] < 1e-6 * f64::from(s.value[0]));
    }
    // The pixel model: noise off, the flicker samples as rates (e⁻/s), dark elsewhere.
    let mut fx = Effects::new(&catalogue());
    for n in [
        "camera.shot_noise",
        "camera.read_noise",
        "camera.dark_current",
        "camera.dsnu",
        "camera.prnu",
        "camera.saturation",
    ] {
        fx.set(n, false).unwrap();
    }
    let pcfg = PixelConfig::default();
    let model = PixelModel::new(&pcfg, w, h, &fx, 1).unwrap();
    let dark = osiris_models::camera::ChannelImage::new(w, h);
    let scale = 1e7 / f64::from(fl.samples[0].value[0].max(1e-30));
    let mut flicker = fl.clone();
    for s in &mut flicker.samples {
        for v in &mut s.value {
            *v = (f64::from(*v) * scale) as f32;
        }
    }
    let expose = |t: f64| {
        let mut raw = RawImage::default();
        let timing = ShutterTiming {
            exposure_s: t,
            ..r.timing
        };
        model.expose(
            &dark,
            &flicker,
            &model.base_exposure(t),
            &timing,
            25.0,
            1,
            &mut raw,
        );
        raw
    };
    let k = pcfg.conversion_gain_dn_per_e;
    let black = pcfg.black_level_dn;
    // Closed form of the on-fraction of [t0, t0 + t] for a 100 Hz, 50 % square wave from phase 0.
    let on_fraction = |t0: f64, t: f64| {
        let p = 0.01;
        let on = 0.005;
        let cum = |x: f64| (x / p).floor() * on + ((x / p).fract() * p).min(on);
        (cum(t0 + t) - cum(t0)) / t
    };
    let raw = expose(1e-3);
    let (mut dark_rows, mut lit_rows) = (0, 0);
    for &i in &core {
        let y = i / w;
        let t0 = r.timing.frame_time_s + y as f64 * row_time;
        let s = flicker
            .samples
            .iter()
            .find(|s| s.pixel as usize == i)
            .unwrap();
        let ch = pcfg.cfa.channel(i % w, y);
        let electrons = f64::from(s.value[ch]) / 0.5 * on_fraction(t0, 1e-3) * 1e-3;
        let want = k * electrons + black;
        let got = f64::from(raw.data[i]);
        assert!(
            (got - want).abs() <= 1.0 + 1e-3 * want,
            "row {y}: {got} vs {want}"
        );
        if on_fraction(t0, 1e-3) == 0.0 {
            dark_rows += 1;
        } else {
            lit_rows += 1;
        }
    }
    assert!(
        dark_rows > 0 && lit_rows > 0,
        "dark {dark_rows}, lit {lit_rows}"
    );
    // Exposure of two whole periods: every lens pixel sees the average v·t.
    let raw = expose(0.02);
    for &i in &core {
        let s = flicker
            .samples
            .iter()
            .find(|s| s.pixel as usize == i)
            .unwrap();
        let ch = pcfg.cfa.channel(i % w, i / w);
        let want = k * f64::from(s.value[ch]) * 0.02 + black;
        assert!((f64::from(raw.data[i]) - want).abs() <= 1.0 + 1e-3 * want);
    }
    // Effect off: no flicker samples; every lens pixel is in the image at its time average (the
    // flicker sample's value), whatever its row.
    let off = render(&setup(false, 1e-3), &sv, &cam);
    assert!(off.out.flicker.samples.is_empty());
    for &i in &core {
        let s = fl.samples.iter().find(|s| s.pixel as usize == i).unwrap();
        let want = [0, 1, 2].map(|c| r.px(i)[c] + f64::from(s.value[c]));
        assert_close(off.px(i), want, 1e-4, "steady lens");
    }
}

// ---------------------------------------------------------------------------------------------
// Retroreflective sign in the head lamps

/// RA2 white sheeting at 40 m under the host's low beams: L ≈ Σ_j R(γ_j) E_j.
#[test]
fn retroreflective_sign_returns_ra_times_illuminance() {
    let host = osi3::MovingObject {
        id: Some(id(1)),
        base: Some(osi3::BaseMoving {
            dimension: Some(dim([4.5, 1.8, 1.5])),
            position: Some(v3([0.0, 0.0, 0.75])),
            orientation: Some(rpy(0.0, 0.0, 0.0)),
            ..Default::default()
        }),
        r#type: Some(osi3::moving_object::Type::Vehicle as i32),
        ..Default::default()
    };
    // A speed-limit sign (white RA2) 40 m ahead, 2 m to the right, 0.4 m high, turned 5° away from
    // facing the host (as signs are set, to keep the film's mirror glare out of the drivers' eyes).
    let yaw = PI + 5f64.to_radians();
    let pos = [42.25, -2.0, 0.4];
    let sv = view(
        1.0,
        vec![],
        vec![sign(20, SignType::SpeedLimitBegin, pos, yaw, 0.6, 0.6)],
        vec![],
        vec![host],
        Some(1),
        night(),
    );
    let mut setup = Setup {
        fov_deg: 2.0,
        ..Setup::default()
    };
    setup.config.lamps.host = HostLamps::On;
    // Camera 2 cm ahead of and 3 cm above the left lamp (box front 2.25 m, 0.36·1.8 m left,
    // 0.65 m above the ground = −0.1 m from the box centre), aimed at the sign.
    let mount = [2.27, 0.648, -0.07];
    let cam_global = DVec3::new(2.27, 0.648, 0.68);
    let d = DVec3::from(pos) - cam_global;
    let cfg = camera_config(
        mount,
        [0.0, -(d.z / d.truncate().length()).atan(), d.y.atan2(d.x)],
    );
    let r = render(&setup, &sv, &cfg);
    assert!(
        r.origin.distance(cam_global) < 1e-9,
        "camera at {}",
        r.origin
    );
    let plate = r.pixels_of(20);
    assert!(plate.len() > 100, "{} plate pixels", plate.len());
    let i = (setup.height / 2) * r.width + setup.width / 2;
    assert!(plate.contains(&i), "the centre pixel sees the plate");
    let pg = r.point(i);
    let n = DVec3::new(yaw.cos(), yaw.sin(), 0.0);
    let wo = (cam_global - pg).normalize();
    // The EN 12899-1 RA2 white minima: 250 at 0.2°, 180 cd lx⁻¹ m⁻² at 0.33° (entrance 5°):
    // R(γ) = R₀ exp(−γ²/σ²) through both.
    let (a1, a2) = (0.2f64.to_radians(), (1.0f64 / 3.0).to_radians());
    let s2 = (a2 * a2 - a1 * a1) / (250.0f64 / 180.0).ln();
    let r0 = 250.0 * (a1 * a1 / s2).exp();
    let low = LightDistribution::ece_low_beam();
    let (mut lv_retro, mut e_sum) = (0.0, 0.0);
    for ly in [0.648, -0.648] {
        let lamp = DVec3::new(2.25, ly, 0.65);
        let dl = pg - lamp;
        let r2 = dl.length_squared();
        let wi = -dl.normalize();
        let e = low.intensity_cd_dir(dl) * wi.dot(n) / r2;
        let gamma = wi.angle_between(wo);
        lv_retro += r0 * (-gamma * gamma / s2).exp() * e;
        e_sum += e;
    }
    assert!(e_sum > 1.0, "the low beams light the sign ({e_sum:.2} lx)");
    // The sheeting's colour: ρ(λ) / ρ̄_A with ρ̄_A its luminous mean under illuminant A.
    let db = MaterialDb::builtin();
    let m = db.by_name("sign_sheeting_ra2_white").unwrap();
    let (mut num, mut den) = (0.0, 0.0);
    for k in 0..=800 {
        let l = 380.0 + 0.5 * k as f64;
        let wgt = planck_radiance_w_m2_sr_nm(l, 2856.0) * photopic_v(l);
        num += m.reflectance_visible(l) * wgt;
        den += wgt;
    }
    let rho_a = num / den;
    let led = Spectrum::white_led();
    // Diffuse part (ρ/π E, < 0.1 % here) included for completeness.
    let want = fold(&r.response, |l| {
        let rho = m.reflectance_visible(l);
        (lv_retro * rho / rho_a + rho / PI * e_sum) * led.w_per_nm_per_lm(l)
    });
    assert_close(r.px(i), want, 0.03, "retroreflected luminance");
    // The retro term dominates: ≥ 100× the diffuse one.
    assert!(lv_retro > 100.0 * 0.45 / PI * e_sum);
    // `env.retroreflection` off: only the diffuse light, ≥ 100× darker.
    setup.switches.push(("env.retroreflection", false));
    let off = render(&setup, &sv, &cfg);
    assert!(off.px(i)[1] < 0.01 * r.px(i)[1]);
}

// ---------------------------------------------------------------------------------------------
// Road markings

/// An arrow-like (concave) marking polygon, OSI convention frame (x up, z forward along +x of
/// the world), seen from 12 m straight above: the mask covers exactly the pixels whose rays meet
/// the polygon.
#[test]
fn road_marking_polygon_covers_its_pixels() {
    // Footprint (forward, left), m: a 5 m arrow, shaft 0.3 m wide, head 1.2 m wide.
    let poly = [
        (-2.5, -0.15),
        (1.0, -0.15),
        (1.0, -0.6),
        (2.5, 0.0),
        (1.0, 0.6),
        (1.0, 0.15),
        (-2.5, 0.15),
    ];
    // OSI's road-marking frame: x-axis up (roll π, pitch −90°: x = +Z, y = −Y, z = +X), so the
    // image's "up" (z) is +x of the world.
    let marking = osi3::RoadMarking {
        id: Some(id(30)),
        base: Some(osi3::BaseStationary {
            dimension: Some(dim([0.0, 1.2, 5.0])),
            position: Some(v3([1.0, 0.5, 0.0])),
            orientation: Some(rpy(PI, -PI / 2.0, 0.0)),
            base_polygon: poly
                .iter()
                .map(|&(x, y)| osi3::Vector2d {
                    x: Some(x),
                    y: Some(y),
                })
                .collect(),
            ..Default::default()
        }),
        classification: Some(osi3::road_marking::Classification {
            r#type: Some(osi3::road_marking::classification::Type::SymbolicTrafficSign as i32),
            monochrome_color: Some(osi3::road_marking::classification::Color::Yellow as i32),
            ..Default::default()
        }),
        ..Default::default()
    };
    let sv = view(
        1.0,
        vec![],
        vec![],
        vec![marking],
        vec![],
        None,
        sun(0.0, 0.6),
    );
    // The scene record: area, material, frame.
    let gt = sv.global_ground_truth.as_ref().unwrap();
    let scene = Scene::from_ground_truth(gt, None, MaterialDb::builtin()).unwrap();
    let rm = &scene.road_markings[0];
    let area: f64 = 0.5
        * (0..poly.len())
            .map(|k| {
                let (a, b) = (poly[k], poly[(k + 1) % poly.len()]);
                a.0 * b.1 - b.0 * a.1
            })
            .sum::<f64>()
            .abs();
    assert!((rm.area_m2 - area).abs() < 1e-9, "{} vs {area}", rm.area_m2);
    assert_eq!(rm.material, "lane_paint_yellow");
    assert!(rm.normal.distance(DVec3::Z) < 1e-9);
    let owned: f64 = scene
        .static_owners
        .iter()
        .filter(|o| o.element == StaticElement::RoadMarking(30))
        .map(|o| o.triangle_count as f64)
        .sum();
    assert_eq!(owned as usize, poly.len() - 2);

    // Camera 12 m above the marking centre looking straight down, image up = +x.
    let setup = Setup {
        width: 96,
        height: 96,
        fov_deg: 30.0,
        ..Setup::default()
    };
    let r = render(
        &setup,
        &sv,
        &camera_config([1.0, 0.5, 12.0], [0.0, PI / 2.0, 0.0]),
    );
    assert!(r.origin.distance(DVec3::new(1.0, 0.5, 12.0)) < 1e-9);
    let z_paint = 0.001;
    let inside = |x: f64, y: f64| {
        // Crossing number on the world-frame polygon (centre (1, 0.5), forward +x, left +y).
        let mut c = false;
        let n = poly.len();
        for k in 0..n {
            let (a, b) = (poly[k], poly[(k + 1) % n]);
            let (ax, ay, bx, by) = (a.0 + 1.0, a.1 + 0.5, b.0 + 1.0, b.1 + 0.5);
            if (ay > y) != (by > y) && x < ax + (y - ay) * (bx - ax) / (by - ay) {
                c = !c;
            }
        }
        c
    };
    let mask = r.pixels_of(30);
    let mut expected = 0;
    let mut mismatched = 0;
    for i in 0..r.rays.len() {
        let d = r.rays[i];
        let t = (z_paint - r.origin.z) / d.z;
        let p = r.origin + d * t;
        let want = inside(p.x, p.y);
        expected += usize::from(want);
        if want != mask.contains(&i) {
            mismatched += 1;
        }
    }
    assert!(expected > 300, "{expected} pixels expected");
    // Only rays grazing the outline (f32 vertices) may disagree.
    assert!(
        mismatched <= 2,
        "{mismatched} pixels differ from the closed form"
    );
}

// ---------------------------------------------------------------------------------------------
// Scene

#[test]
fn scene_builds_signs_lights_and_rebuilds_on_change() {
    let mut s = sign(40, SignType::Stop, [20.0, -3.0, 2.0], PI, 0.6, 0.6);
    s.supplementary_sign
        .push(osi3::traffic_sign::SupplementarySign {
            base: Some(osi3::BaseStationary {
                dimension: Some(dim([0.002, 0.6, 0.3])),
                position: Some(v3([20.0, -3.0, 1.5])),
                orientation: Some(rpy(0.0, 0.0, PI)),
                ..Default::default()
            }),
            ..Default::default()
        });
    let lights = vec![
        bulb(50, [30.0, 3.0, 5.0], PI, 0.3, Colour::Red, Mode::Constant),
        bulb(51, [30.0, 3.0, 4.65], PI, 0.3, Colour::Yellow, Mode::Off),
        bulb(52, [30.0, 3.0, 4.3], PI, 0.3, Colour::Green, Mode::Off),
        bulb(53, [30.0, 8.0, 5.0], PI, 0.2, Colour::Red, Mode::Constant),
    ];
    let sv = view(1.0, lights, vec![s], vec![], vec![], None, night());
    let gt = sv.global_ground_truth.clone().unwrap();
    let mut scene = SceneBuilder::new(MaterialDb::builtin()).build(&gt).unwrap();
    let ts = &scene.traffic_signs[0];
    assert_eq!(ts.plates.len(), 2);
    assert_eq!(ts.plates[0].face_material, "sign_sheeting_ra2_red");
    assert_eq!(ts.plates[1].face_material, "sign_sheeting_ra2_white");
    // Post from the road (z = 0) up to the main plate centre, 60.3 mm, touching the plate's back.
    let (bottom, top, d) = ts.post.unwrap();
    assert!((scene.to_global(bottom).z - 0.0).abs() < 1e-6);
    assert!((scene.to_global(top).z - 2.0).abs() < 1e-6);
    assert!((d - 0.0603).abs() < 1e-12);
    assert!((scene.to_global(bottom).x - (20.0 + 0.001 + 0.03015)).abs() < 1e-6);
    // Bulbs: the three stacked ones share a housing, the fourth has its own.
    let h: Vec<usize> = scene.signal_bulbs.iter().map(|b| b.housing).collect();
    assert_eq!(h[0], h[1]);
    assert_eq!(h[1], h[2]);
    assert_ne!(h[0], h[3]);
    let kinds = |sc: &Scene, e: StaticElement| sc.static_owners.iter().any(|o| o.element == e);
    for e in [
        StaticElement::TrafficSign(40),
        StaticElement::SignPost(40),
        StaticElement::TrafficLight(50),
        StaticElement::TrafficLight(53),
        StaticElement::SignalHousing(50),
        StaticElement::SignalHousing(53),
    ] {
        assert!(kinds(&scene, e), "{e:?}");
    }
    assert_eq!(StaticElement::SignPost(40).ground_truth_id(), None);
    assert_eq!(StaticElement::TrafficLight(50).ground_truth_id(), Some(50));
    // Switching a light does not rebuild the static world; moving a sign does.
    let mut gt2 = gt.clone();
    gt2.traffic_light[0].classification.as_mut().unwrap().mode = Some(Mode::Off as i32);
    assert!(!scene.update(&gt2).unwrap().static_rebuilt);
    gt2.traffic_sign[0]
        .main_sign
        .as_mut()
        .unwrap()
        .base
        .as_mut()
        .unwrap()
        .position = Some(v3([21.0, -3.0, 2.0]));
    assert!(scene.update(&gt2).unwrap().static_rebuilt);
}

// ---------------------------------------------------------------------------------------------
// LiDAR and radar see the same static world

/// A LiDAR flash grid at 1 m height, 20 m in front of an RA2 white sign plate (1 m high) and a
/// 50 % Lambertian board of the same size beside it: points on the plate carry the sign's id and
/// are brighter by the BRDF ratio (retroreflection R₀ ≈ 300 sr⁻¹ against ρ/π = 0.16 sr⁻¹).
#[test]
fn lidar_sees_the_sign_plate_bright() {
    use osiris_models::lidar::LidarConfig;
    use osiris_models::lidar::detection::{DetectorConfig, IntensityMode};
    use osiris_models::lidar::scan::{FlashPattern, ScanPattern};
    let board = osi3::StationaryObject {
        id: Some(id(61)),
        base: Some(osi3::BaseStationary {
            dimension: Some(dim([0.01, 0.6, 0.6])),
            position: Some(v3([20.0, 1.0, 1.0])),
            orientation: Some(rpy(0.0, 0.0, PI)),
            ..Default::default()
        }),
        model_reference: Some(
            "osiris:board?width_m=0.6&height_m=0.6&thickness_m=0&mount=none&material=lambertian_50"
                .into(),
        ),
        ..Default::default()
    };
    let mut sv = view(
        1.0,
        vec![],
        vec![sign(
            60,
            SignType::TownBegin,
            [20.0, -1.0, 1.0],
            PI,
            0.6,
            0.6,
        )],
        vec![],
        vec![],
        None,
        night(),
    );
    sv.global_ground_truth
        .as_mut()
        .unwrap()
        .stationary_object
        .push(board);
    let effects = common::quiet_lidar();
    let lidar = LidarConfig {
        scan: Some(ScanPattern::Flash(FlashPattern {
            rows: 16,
            cols: 64,
            fov_horizontal_rad: 0.2,
            fov_vertical_rad: 0.05,
            centre_rad: [0.0, 0.0],
        })),
        detector: DetectorConfig {
            intensity_mode: IntensityMode::Power,
            power_full_scale_w: Some(1.0),
            ..DetectorConfig::default()
        },
        ..Default::default()
    };
    let cfg = SensorConfig {
        kind: SensorKind::Lidar,
        range_m: 200.0,
        fov_horizontal_rad: 2.0 * PI,
        fov_vertical_rad: PI,
        mounting: Mounting {
            position_m: [0.0, 0.0, 1.0],
            orientation_rad: [0.0; 3],
        },
        effects,
        seed: Some(7),
        lidar: Some(lidar),
        ..camera_config([0.0; 3], [0.0; 3])
    };
    let (out, _) = common::lidar_step(cfg, &sv);
    let c = out.perception.lidar.as_ref().expect("lidar perception");
    let mean_on = |oid: u64| {
        let v: Vec<f64> = (0..c.x_m.len())
            .filter(|&i| c.object_id[i] == oid)
            .map(|i| f64::from(c.intensity[i]))
            .collect();
        (v.iter().sum::<f64>() / v.len().max(1) as f64, v.len())
    };
    let (sign_i, n_sign) = mean_on(60);
    let (board_i, n_board) = mean_on(61);
    assert!(n_sign > 10 && n_board > 10, "{n_sign} / {n_board} points");
    // Both are extended targets at the same range and incidence: the intensity ratio is the BRDF
    // ratio, R₀/(ρ/π) with the RA2 white lobe through 250 (0.2°) and 180 cd lx⁻¹ m⁻² (0.33°)
    // (the lobe peak, as γ ≪ σ here), against ρ = 0.5. 25 %: the film's specular lobe (+3 %) and
    // the transmitter–receiver offset.
    let (a1, a2) = (0.2f64.to_radians(), (1.0f64 / 3.0).to_radians());
    let s2 = (a2 * a2 - a1 * a1) / (250.0f64 / 180.0).ln();
    let r0 = 250.0 * (a1 * a1 / s2).exp();
    let want = r0 / (0.5 / PI);
    let got = sign_i / board_i;
    assert!(
        (got / want - 1.0).abs() < 0.25,
        "sign / board intensity {got:.0}, want {want:.0}"
    );
}

/// The radar's tubes reach the sign plate (an aluminium plate, 0.28 m² face: far-field specular
/// RCS σ = 4πA²/λ² ≈ 48 dBm², but at 25 m it is in its near field, 2D²/λ ≈ 180 m; the model
/// returns ≈ 26 dBm²): a strong detection at its range, only road clutter without it.
#[test]
fn radar_sees_the_sign_plate() {
    use osiris_models::radar::RadarSensor;
    let radar = || {
        let mut c = SensorConfig::default_for(SensorKind::Radar);
        c.mode = ModelMode::Physical;
        c.mounting = Mounting {
            position_m: [0.0, 0.0, 1.0],
            orientation_rad: [0.0; 3],
        };
        c.seed = Some(1);
        c.effects.insert("radar.ground_multipath".into(), false);
        RadarSensor::new(c).expect("radar")
    };
    let with = |signs: Vec<osi3::TrafficSign>| {
        let mut sv = view(0.0, vec![], signs, vec![], vec![], None, night());
        sv.version = Some(osiris_proto::interface_version());
        let mut s = radar();
        common::radar_detections(&common::step_at(&mut s, &sv, 0.0, 0.05))
            .iter()
            .map(|d| {
                (
                    d.rcs.unwrap(),
                    d.position.as_ref().and_then(|p| p.distance).unwrap(),
                )
            })
            .collect::<Vec<_>>()
    };
    let near = |d: &[(f64, f64)]| {
        d.iter()
            .filter(|(_, r)| (r - 25.0).abs() < 1.0)
            .map(|x| x.0)
            .fold(f64::NEG_INFINITY, f64::max)
    };
    let plate = with(vec![sign(
        70,
        SignType::SpeedLimitBegin,
        [25.0, 0.0, 1.0],
        PI,
        0.6,
        0.6,
    )]);
    let empty = with(vec![]);
    assert!(near(&plate) > 20.0, "sign plate RCS {} dBm²", near(&plate));
    // Without it only the road clutter (well below 0 dBm²) is there.
    assert!(near(&empty) < 0.0, "{:?}", empty);
}
