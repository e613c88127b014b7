//! The physical camera as a [`SensorModel`]: configuration, one step of the chain, OSI output.

use glam::{DMat3, DVec3};
use osiris_proto::{osi3, perception};
use prost::Message as _;
use serde::{Deserialize, Serialize};

use super::hdr::{HdrConfig, HdrPipeline};
use super::isp::{Isp, IspConfig};
use super::lens::{Lens, LensConfig};
use super::pixel::{PixelConfig, PixelModel};
use super::render::{RenderConfig, RenderInput, RenderOutput, Renderer};
use super::spectral::SpectralConfig;
use super::{Cfa, RawImage, RgbImage, ShutterTiming, SpectralResponse};
use crate::effects::Effects;
use crate::physical::{Cycle, PhysicalSensor, Physics};
use crate::recognition::camera::{
    CameraRecognition, CameraRecognitionConfig, CameraRecognitionInput,
};
use crate::recognition::traffic::{TrafficOutput, TrafficRecognition};
use crate::sensor::{CommonConfig, ModelError, SensorKind, StepOutput};
use crate::space::Ray;
use crate::world::WorldFrame;

/// Sensor presets (array size and pixel pitch; the pixel and HDR defaults follow the preset).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum CameraPreset {
    /// Sony ISX019-class: 1280 × 960, 2.9 µm pixels, DOL (multi-exposure) HDR (DIVP reference
    /// sensor, FY2019 report).
    #[default]
    Isx019,
    /// Sony IMX490-class: 2880 × 1860, 3.0 µm pixels, split-pixel HDR (LUCID tech brief;
    /// ISETCam `sensorCreateIMX490.m`).
    Imx490,
}

impl CameraPreset {
    /// (width px, height px, pixel pitch m).
    pub fn geometry(self) -> (usize, usize, f64) {
        match self {
            CameraPreset::Isx019 => (1280, 960, 2.9e-6),
            CameraPreset::Imx490 => (2880, 1860, 3.0e-6),
        }
    }
}

/// Which images a step writes into `PerceptionData.camera.image`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EmitConfig {
    /// One RAW mosaic per capture of the HDR sequence (u16).
    pub raw_exposures: bool,
    /// The HDR-merged linear RAW (u32, 20–24 bit).
    pub raw_hdr_linear: bool,
    /// The PWL-companded RAW (u16, 12–16 bit).
    pub raw_companded: bool,
    /// The ISP's 8-bit sRGB image.
    pub isp: bool,
}

impl Default for EmitConfig {
    fn default() -> Self {
        EmitConfig {
            raw_exposures: false,
            raw_hdr_linear: false,
            raw_companded: true,
            isp: true,
        }
    }
}

/// Camera-specific configuration (`"camera"` key of the sensor configuration JSON).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraConfig {
    #[serde(default)]
    pub preset: CameraPreset,
    /// Image width, px (absent: the preset's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub width_px: Option<usize>,
    /// Image height, px (absent: the preset's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub height_px: Option<usize>,
    /// Pixel pitch, m (absent: the preset's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pixel_pitch_m: Option<f64>,
    /// Fixed exposure time of the longest capture, s; absent: auto exposure.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exposure_s: Option<f64>,
    /// Die temperature for the dark signal, °C (absent: 40 °C, a guessed in-vehicle value).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub temperature_c: Option<f64>,
    #[serde(default)]
    pub spectral: SpectralConfig,
    #[serde(default)]
    pub lens: LensConfig,
    /// Pixel parameters (absent: the preset's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pixel: Option<PixelConfig>,
    /// HDR parameters (absent: the preset's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hdr: Option<HdrConfig>,
    #[serde(default)]
    pub isp: IspConfig,
    #[serde(default)]
    pub render: RenderConfig,
    #[serde(default)]
    pub recognition: CameraRecognitionConfig,
    #[serde(default)]
    pub emit: EmitConfig,
    /// The windshield in front of the lens (absent: none; `camera.windshield_*` and
    /// `camera.dashboard_reflection` then do nothing).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub windshield: Option<super::windshield::WindshieldConfig>,
}

/// Values in effect after the preset defaults.
#[derive(Debug, Clone, PartialEq)]
pub struct Resolved {
    pub width: usize,
    pub height: usize,
    pub pixel_pitch_m: f64,
    pub temperature_c: f64,
    pub pixel: PixelConfig,
    pub hdr: HdrConfig,
}

impl CameraConfig {
    /// Apply the preset defaults and check every value; errors name the key.
    pub fn resolve(&self) -> Result<Resolved, ModelError> {
        let (w, h, pitch) = self.preset.geometry();
        let width = self.width_px.unwrap_or(w);
        let height = self.height_px.unwrap_or(h);
        for (key, v) in [("width_px", width), ("height_px", height)] {
            if !(2..=16_384).contains(&v) || v % 2 != 0 {
                return Err(ModelError::Config(format!(
                    "`camera.{key}` must be an even number in 2..=16384 (the CFA repeats every 2 \
                     pixels), got {v}"
                )));
            }
        }
        let pixel_pitch_m = self.pixel_pitch_m.unwrap_or(pitch);
        if !(pixel_pitch_m.is_finite() && pixel_pitch_m > 0.0 && pixel_pitch_m < 1e-3) {
            return Err(ModelError::Config(format!(
                "`camera.pixel_pitch_m` must be in (0, 1e-3) m, got {pixel_pitch_m}"
            )));
        }
        if let Some(t) = self.exposure_s
            && !(t.is_finite() && t > 0.0 && t <= 1.0)
        {
            return Err(ModelError::Config(format!(
                "`camera.exposure_s` must be in (0, 1] s, got {t}"
            )));
        }
        let temperature_c = self.temperature_c.unwrap_or(40.0);
        if !(temperature_c.is_finite() && (-60.0..=150.0).contains(&temperature_c)) {
            return Err(ModelError::Config(format!(
                "`camera.temperature_c` must be in −60…150 °C, got {temperature_c}"
            )));
        }
        let pixel = match &self.pixel {
            Some(p) => p.clone(),
            None => PixelConfig::for_preset(self.preset),
        };
        let hdr = match &self.hdr {
            Some(p) => p.clone(),
            None => HdrConfig::for_preset(self.preset),
        };
        self.spectral.validate()?;
        self.lens.validate()?;
        pixel.validate()?;
        hdr.validate()?;
        self.isp.validate()?;
        self.render.validate()?;
        self.recognition.validate()?;
        if let Some(w) = &self.windshield {
            w.validate()?;
        }
        Ok(Resolved {
            width,
            height,
            pixel_pitch_m,
            temperature_c,
            pixel,
            hdr,
        })
    }
}

/// The planned chain of one camera (everything that does not change between frames).
pub struct CameraChain {
    pub resolved: Resolved,
    pub renderer: Renderer,
    pub response: SpectralResponse,
    pub lens: Lens,
    pub pixel: PixelModel,
    pub hdr: HdrPipeline,
    pub isp: Isp,
    pub cfa: Cfa,
    /// The windshield's per-pixel plan (`None`: no windshield configured).
    pub windshield: Option<super::windshield::WindshieldPlan>,
}

impl CameraChain {
    /// Plan the chain for a sensor configuration (`fov_horizontal_rad` gives the focal length when
    /// the lens config has none).
    pub fn plan(
        config: &CommonConfig,
        camera: &CameraConfig,
        effects: &Effects,
    ) -> Result<CameraChain, ModelError> {
        let resolved = camera.resolve()?;
        let renderer = Renderer::new(&camera.render, effects)?;
        let response = camera.spectral.response(renderer.bands())?;
        let lens = Lens::new(
            &camera.lens,
            resolved.width,
            resolved.height,
            resolved.pixel_pitch_m,
            config.fov_horizontal_rad,
            effects,
        )?;
        let seed = config.seed.unwrap_or(0);
        let pixel = PixelModel::new(
            &resolved.pixel,
            resolved.width,
            resolved.height,
            effects,
            seed,
        )?;
        let hdr = HdrPipeline::new(&resolved.hdr, effects)?;
        let cfa = pixel.cfa();
        let isp = Isp::new(&camera.isp, cfa, &response)?;
        let windshield = camera.windshield.as_ref().map(|w| {
            use super::windshield::{
                DASHBOARD_REFLECTION, WINDSHIELD_REFRACTION, WINDSHIELD_TRANSMISSION,
                WindshieldPlan,
            };
            WindshieldPlan::new(
                w,
                lens.ray_directions(),
                effects.is_on(&WINDSHIELD_TRANSMISSION),
                effects.is_on(&WINDSHIELD_REFRACTION),
                effects.is_on(&DASHBOARD_REFLECTION),
            )
        });
        Ok(CameraChain {
            resolved,
            renderer,
            response,
            lens,
            pixel,
            hdr,
            isp,
            cfa,
            windshield,
        })
    }

    /// Where the camera believes a lens ray looks: `calibration · ray` (a camera calibrated
    /// through its windshield, `WindshieldPlan::calibration`; the identity otherwise).
    fn calibration(&self) -> DMat3 {
        self.windshield
            .as_ref()
            .map_or(DMat3::IDENTITY, |p| p.calibration)
    }
}

/// Buffers reused across steps.
#[derive(Default)]
struct Buffers {
    render: RenderOutput,
    captures: Vec<RawImage>,
    linear: RawImage,
    companded: RawImage,
    rgb: RgbImage,
    luminance: Vec<f32>,
    divp: Vec<perception::CameraObject>,
}

/// Wall-clock cost of the stages of the last step, s.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StageTimes {
    pub render_s: f64,
    /// The renderer's own split of `render_s`.
    pub render: super::render::RenderStats,
    pub lens_s: f64,
    pub pixel_s: f64,
    pub isp_s: f64,
    pub recognition_s: f64,
}

/// The physical camera model: the shared loop of [`PhysicalSensor`] around the camera's physics
/// ([`CameraPhysics`]).
pub type CameraSensor = PhysicalSensor<CameraPhysics>;

/// The camera's physics: spectral rendering → lens → pixel exposures → HDR merge → ISP →
/// recognition.
pub struct CameraPhysics {
    camera: CameraConfig,
    effects: Effects,
    chain: CameraChain,
    recognition: CameraRecognition,
    /// Traffic lights, signs, road markings and lane boundaries (`crate::recognition::traffic`).
    traffic: TrafficRecognition,
    /// What `traffic` recognised this cycle.
    traffic_out: TrafficOutput,
    /// Exposure of the previous frame (auto exposure), s.
    last_exposure_s: Option<f64>,
    /// Row readout time of the cycle (rolling shutter), s.
    row_time_s: f64,
    /// The recognised moving objects of the cycle (swapped into the output by `emit`).
    moving: Vec<osi3::DetectedMovingObject>,
    buffers: Buffers,
    /// Cost split of the last step.
    pub times: StageTimes,
}

impl CameraSensor {
    /// The planned chain (lens, pixel, HDR, ISP).
    pub fn chain(&self) -> &CameraChain {
        &self.physics().chain
    }

    /// The effects in force.
    pub fn effects(&self) -> &Effects {
        &self.physics().effects
    }

    /// Cost split of the last step.
    pub fn times(&self) -> StageTimes {
        self.physics().times
    }

    /// The recognition's measurements of the last step (every object seen, detected or not).
    pub fn last_measurements(&self) -> &[crate::recognition::camera::Measurement] {
        self.physics().recognition.measurements()
    }
}

/// A RAW image as a `CameraImage`: little-endian u16 samples (clipped to the image's largest code)
/// or, `wide`, u32 samples (the 20–24 bit merged HDR). `exposure_index` only for per-capture RAW.
fn raw_image(
    raw: &RawImage,
    kind: perception::camera_image::Kind,
    cfa: perception::camera_image::ColorFilterArray,
    wide: bool,
) -> perception::CameraImage {
    use perception::camera_image::{Kind, SampleFormat};
    let (format, bit_depth, data) = if wide {
        let mut data = Vec::with_capacity(raw.data.len() * 4);
        for &v in &raw.data {
            data.extend_from_slice(&v.to_le_bytes());
        }
        (SampleFormat::U32Le, raw.bit_depth, data)
    } else {
        let mut data = Vec::with_capacity(raw.data.len() * 2);
        let max = raw.max_dn().min(u32::from(u16::MAX));
        for &v in &raw.data {
            data.extend_from_slice(&(v.min(max) as u16).to_le_bytes());
        }
        (SampleFormat::U16Le, raw.bit_depth.min(16), data)
    };
    perception::CameraImage {
        kind: Some(kind as i32),
        exposure_index: (kind == Kind::RawExposure).then_some(raw.exposure_index),
        width_px: Some(raw.width as u32),
        height_px: Some(raw.height as u32),
        cfa: Some(cfa as i32),
        sample_format: Some(format as i32),
        channels: Some(1),
        bit_depth: Some(bit_depth),
        data: Some(data),
        exposure_time_s: Some(raw.exposure_time_s),
        analog_gain: Some(raw.analog_gain),
        conversion_gain_dn_per_e: Some(raw.conversion_gain_dn_per_e),
        black_level_dn: Some(raw.black_level_dn),
        row_time_s: Some(raw.row_time_s),
        ..Default::default()
    }
}

impl Physics for CameraPhysics {
    const KIND: SensorKind = SensorKind::Camera;
    type Params = CameraConfig;

    fn plan(
        config: &CommonConfig,
        camera: CameraConfig,
        effects: Effects,
    ) -> Result<CameraPhysics, ModelError> {
        let chain = CameraChain::plan(config, &camera, &effects)?;
        let recognition = CameraRecognition::new(&camera.recognition)?;
        let traffic = TrafficRecognition::new(&camera.recognition.traffic)?;
        Ok(CameraPhysics {
            camera,
            effects,
            chain,
            recognition,
            traffic,
            traffic_out: TrafficOutput::default(),
            last_exposure_s: None,
            row_time_s: 0.0,
            moving: Vec::new(),
            buffers: Buffers::default(),
            times: StageTimes::default(),
        })
    }

    /// The focal length follows the horizontal field of view when the lens configuration has none.
    fn replan(&mut self, config: &CommonConfig) -> Result<(), ModelError> {
        self.chain = CameraChain::plan(config, &self.camera, &self.effects)?;
        Ok(())
    }

    fn perceive(&mut self, cycle: &Cycle<'_>, frame: &WorldFrame<'_>) -> Result<(), ModelError> {
        let gt =
            cycle.view.global_ground_truth.as_ref().ok_or_else(|| {
                ModelError::Input("SensorView without global_ground_truth".into())
            })?;
        let seed = cycle.seed;
        self.moving.clear();
        let chain = &mut self.chain;
        let b = &mut self.buffers;
        let (w, h) = (chain.resolved.width, chain.resolved.height);

        // Exposure of the longest capture: fixed, or where auto exposure converged last frame.
        let exposure_s = self
            .camera
            .exposure_s
            .or(self.last_exposure_s)
            .unwrap_or(0.01);
        let captures = chain.hdr.captures(&chain.pixel, exposure_s);
        let longest = captures
            .iter()
            .map(|c| c.start_offset_s + c.time_s)
            .fold(0.0, f64::max);
        let rolling = self.effects.is_on(&super::render::ROLLING_SHUTTER);
        let row_time_s = if rolling {
            chain
                .resolved
                .pixel
                .row_time_s(h, cycle.config.update_cycle_s)
        } else {
            0.0
        };
        let timing = ShutterTiming {
            frame_time_s: frame.time_s,
            row_time_s,
            start_offset_s: 0.0,
            exposure_s: longest.max(exposure_s),
        };

        let t = std::time::Instant::now();
        let rin = RenderInput {
            frame,
            // The windshield's refraction turns the rays where its faces are not parallel.
            rays: chain
                .windshield
                .as_ref()
                .map(|p| p.directions.as_slice())
                .filter(|d| d.len() == chain.lens.ray_directions().len())
                .unwrap_or(chain.lens.ray_directions()),
            ray_origins: chain
                .windshield
                .as_ref()
                .map(|p| p.origins.as_slice())
                .filter(|o| !o.is_empty()),
            width: w,
            height: h,
            response: &chain.response,
            timing,
            ground_truth: gt,
            seed,
            cycle: cycle.index,
        };
        chain.renderer.render(&rin, &mut b.render);
        if let Some(ws) = &chain.windshield {
            apply_windshield(ws, chain, frame, gt, &mut b.render.radiance);
        }
        self.times.render_s = t.elapsed().as_secs_f64();
        self.times.render = b.render.stats;

        let t = std::time::Instant::now();
        chain.lens.apply(
            &mut b.render.radiance,
            &mut b.render.flicker,
            b.render.sun.as_ref(),
        );
        self.times.lens_s = t.elapsed().as_secs_f64();

        let t = std::time::Instant::now();
        let captures = if self.camera.exposure_s.is_none() {
            let auto = chain.pixel.auto_exposure_s(&b.render.radiance);
            self.last_exposure_s = Some(auto);
            chain.hdr.captures(&chain.pixel, auto)
        } else {
            captures
        };
        b.captures.resize_with(captures.len(), RawImage::default);
        let temperature_c = chain.resolved.temperature_c;
        for (k, (spec, raw)) in captures.iter().zip(b.captures.iter_mut()).enumerate() {
            let noise_seed =
                seed ^ (cycle.index.wrapping_mul(0x9E37_79B9_7F4A_7C15)) ^ ((k as u64 + 1) << 56);
            chain.pixel.expose(
                &b.render.radiance,
                &b.render.flicker,
                spec,
                &timing,
                temperature_c,
                noise_seed,
                raw,
            );
            raw.row_time_s = row_time_s;
        }
        chain
            .hdr
            .merge_and_compand(&b.captures, &mut b.linear, &mut b.companded);
        self.times.pixel_s = t.elapsed().as_secs_f64();

        let t = std::time::Instant::now();
        chain.isp.process(&b.linear, &mut b.rgb, &mut b.luminance);
        self.times.isp_s = t.elapsed().as_secs_f64();

        // Camera height above the road: straight down from the optical centre where the camera
        // believes it is (its nominal mounting; its calibration).
        let origin = frame.nominal_pose.position;
        let camera_height_m = frame
            .space
            .closest_hit(&Ray::new(origin, DVec3::NEG_Z).with_t_max(50.0))
            .map(|hit| hit.distance_m)
            .unwrap_or_else(|| origin.z.max(0.1));
        // A camera calibrated through its windshield believes each lens ray looks where the glass
        // turned its optical axis (`WindshieldPlan::calibration`; the identity otherwise).
        let calibration = chain.calibration();
        let t = std::time::Instant::now();
        let rec_in = CameraRecognitionInput {
            aux: b.render.aux.objects(),
            luminance: &b.luminance,
            lens: &chain.lens,
            ground_truth: gt,
            frame: &frame.frame,
            reported_rotation: frame.nominal_frame.pose.rotation * calibration,
            camera_height_m,
            time_s: frame.time_s,
            seed,
            cycle: cycle.index,
        };
        self.recognition
            .step(&rec_in, &mut self.moving, &mut b.divp);
        self.traffic.step(
            &rec_in,
            self.recognition.pixel_stats(),
            &mut self.traffic_out,
        );
        // The configured maximum detection range (`range_m`) bounds what recognition reports.
        let range_m = cycle.config.range_m;
        b.divp.retain(|o| {
            o.longitudinal_distance_m
                .unwrap_or(0.0)
                .hypot(o.lateral_distance_m.unwrap_or(0.0))
                <= range_m
        });
        self.moving.retain(|m| {
            let gid = m
                .header
                .as_ref()
                .and_then(|h| h.ground_truth_id.first())
                .and_then(|i| i.value);
            b.divp.iter().any(|o| o.object_id == gid)
        });
        self.times.recognition_s = t.elapsed().as_secs_f64();

        self.row_time_s = row_time_s;
        Ok(())
    }

    /// The images asked for (`emit`), the recognised objects (DIVP object list in PerceptionData,
    /// OSI moving objects, one box-shaped camera detection per object). The lists of the previous
    /// cycle are reused.
    fn emit(&mut self, _cycle: &Cycle<'_>, _frame: &WorldFrame<'_>, out: &mut StepOutput) {
        use perception::camera_image::{ColorFilterArray, Kind};
        let mut camera_out = out.perception.camera.take().unwrap_or_default();
        // The recognised objects go out; the previous output's list comes back for the next cycle.
        let mut moving = std::mem::take(&mut out.sensor_data.moving_object);
        std::mem::swap(&mut moving, &mut self.moving);
        out.sensor_data.clear();
        out.perception.clear();
        camera_out.image.clear();
        camera_out.object.clear();
        camera_out.band_centre_nm.clear();
        let chain = &self.chain;
        let b = &mut self.buffers;
        let row_time_s = self.row_time_s;
        let temperature_c = chain.resolved.temperature_c;
        let calibration = chain.calibration();
        // Outputs.
        let cfa = match chain.cfa {
            Cfa::Rggb => ColorFilterArray::CfaRggb,
            Cfa::Bggr => ColorFilterArray::CfaBggr,
            Cfa::Grbg => ColorFilterArray::CfaGrbg,
            Cfa::Gbrg => ColorFilterArray::CfaGbrg,
        };
        let emit = self.camera.emit;
        if emit.raw_exposures {
            for raw in &b.captures {
                camera_out
                    .image
                    .push(raw_image(raw, Kind::RawExposure, cfa, false));
            }
        }
        if emit.raw_hdr_linear {
            camera_out
                .image
                .push(raw_image(&b.linear, Kind::RawHdrLinear, cfa, true));
        }
        if emit.raw_companded {
            let mut img = raw_image(&b.companded, Kind::RawHdrCompanded, cfa, false);
            img.companding_knee = chain
                .hdr
                .knees()
                .iter()
                .map(|k| perception::PwlKnee {
                    input_dn: Some(k.input_dn),
                    output_dn: Some(k.output_dn),
                })
                .collect();
            camera_out.image.push(img);
        }
        if emit.isp {
            use perception::camera_image::SampleFormat;
            camera_out.image.push(perception::CameraImage {
                kind: Some(Kind::Isp as i32),
                width_px: Some(b.rgb.width as u32),
                height_px: Some(b.rgb.height as u32),
                cfa: Some(ColorFilterArray::CfaRgb as i32),
                sample_format: Some(SampleFormat::U8 as i32),
                channels: Some(3),
                bit_depth: Some(8),
                data: Some(b.rgb.data.clone()),
                exposure_time_s: Some(b.linear.exposure_time_s),
                row_time_s: Some(row_time_s),
                ..Default::default()
            });
        }
        // Feature data: one box-shaped CameraDetection per recognised object with OSI's two points
        // (first and third corner of an axis-aligned box): the smallest azimuth–elevation box
        // containing the directions of the image box's four corners, at the estimated distance
        // (`crate::semantics::box_corners`).
        let mut dets = Vec::with_capacity(b.divp.len());
        let mut points = Vec::with_capacity(2 * b.divp.len());
        for o in &b.divp {
            let (Some(u0), Some(v0), Some(u1), Some(v1)) = (
                o.box_u_min_px,
                o.box_v_min_px,
                o.box_u_max_px,
                o.box_v_max_px,
            ) else {
                continue;
            };
            let range_m = o
                .longitudinal_distance_m
                .unwrap_or(0.0)
                .hypot(o.lateral_distance_m.unwrap_or(0.0));
            let first = points.len();
            let corners = [(u0, v0), (u1, v0), (u1, v1), (u0, v1)]
                .into_iter()
                .filter_map(|(u, v)| chain.lens.unproject(glam::DVec2::new(u, v)))
                .map(|d| calibration * d);
            let Some(corners) = crate::semantics::box_corners(corners, range_m) else {
                continue;
            };
            for c in corners {
                points.push(osi3::CameraPoint {
                    existence_probability: o.detection_probability,
                    point: Some(c.to_osi()),
                    point_rmse: None,
                });
            }
            let is_vehicle = o.type_code.is_some_and(|t| t <= 10);
            let is_pedestrian = o.type_code.is_some_and(|t| (101..=103).contains(&t));
            dets.push(osi3::CameraDetection {
                existence_probability: o.detection_probability,
                object_id: o.object_id.map(osiris_proto::id),
                image_shape_type: Some(osi3::camera_detection::ImageShapeType::Box as i32),
                shape_classification_moving_object: Some(true),
                shape_classification_vehicle: Some(is_vehicle),
                shape_classification_pedestrian: Some(is_pedestrian),
                shape_classification_animal: Some(o.type_code == Some(203)),
                first_point_index: Some(first as u32),
                number_of_points: Some((points.len() - first) as u32),
                ..Default::default()
            });
        }
        let feature_data = osi3::FeatureData {
            camera_sensor: vec![osi3::CameraDetectionData {
                header: None,
                detection: dets,
                point: points,
                ..Default::default()
            }],
            ..Default::default()
        };
        camera_out.object.append(&mut b.divp);
        camera_out.temperature_c = Some(temperature_c);
        camera_out
            .band_centre_nm
            .extend_from_slice(&chain.response.bands.centres_nm);

        let t = &mut self.traffic_out;
        camera_out.traffic_light.append(&mut t.light_records);
        camera_out.traffic_sign.append(&mut t.sign_records);
        camera_out.lane_boundary.append(&mut t.lane_records);
        camera_out.traffic_light_state_misreads = Some(t.state_misreads);

        let sd = &mut out.sensor_data;
        sd.moving_object = moving;
        sd.traffic_light.append(&mut t.traffic_light);
        sd.traffic_sign.append(&mut t.traffic_sign);
        sd.road_marking.append(&mut t.road_marking);
        sd.lane_boundary.append(&mut t.lane_boundary);
        sd.feature_data = Some(feature_data);
        out.perception.camera = Some(camera_out);
    }

    fn reset(&mut self) {
        self.recognition.reset();
        self.traffic_out.clear();
        self.chain.isp.reset();
        self.last_exposure_s = None;
        self.moving.clear();
    }
}

/// The windshield on the rendered scene radiance: `L ← T·L + R·L_dash` per pixel and channel
/// (`super::windshield`), with the dashboard's luminance from the SPCTRAL2 sun and sky of the frame
/// folded with the channel responses.
fn apply_windshield(
    ws: &super::windshield::WindshieldPlan,
    chain: &CameraChain,
    frame: &crate::world::WorldFrame<'_>,
    gt: &osiris_proto::osi3::GroundTruth,
    radiance: &mut super::ChannelImage,
) {
    use crate::environment::sky::{ClearSkyInput, spectrl2};
    let sun_global =
        crate::environment::sun::sun_direction(gt.environmental_conditions.as_ref()).normalize();
    let veil = if ws.dashboard_reflectance.iter().any(|r| *r > 0.0) && sun_global.z > 0.0 {
        let cfg = chain.renderer.config();
        let sky = spectrl2(&ClearSkyInput {
            zenith_deg: 90.0 - sun_global.z.clamp(-1.0, 1.0).asin().to_degrees(),
            day_of_year: cfg.day_of_year,
            ..cfg.atmosphere
        });
        let sun_sensor = frame.sensor_pose.inverse_transform_vector(sun_global);
        let (k_sun, k_sky) = ws.dashboard_coefficients(sun_sensor);
        let centres = &chain.response.bands.centres_nm;
        let spectrum: Vec<f64> = centres
            .iter()
            .map(|&l| k_sun * sky.dni_at(l) + k_sky * sky.dhi_at(l))
            .collect();
        chain.response.apply(&spectrum)
    } else {
        [0.0; super::CHANNELS]
    };
    for (c, plane) in radiance.planes.iter_mut().enumerate() {
        let v = veil[c] as f32;
        for ((l, t), r) in plane
            .iter_mut()
            .zip(&ws.transmittance)
            .zip(&ws.dashboard_reflectance)
        {
            *l = *l * t + r * v;
        }
    }
}
