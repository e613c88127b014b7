//! Physics-based camera (DIVP decomposition): light sources → spectral propagation and reflection
//! (ray tracing) → lens → pixel photoelectric conversion → HDR / companding → ISP → recognition.
//!
//! * [`spectral`]: spectral bands, colour-filter × quantum-efficiency responses ([`SpectralResponse`]).
//! * [`render`]: spectral ray-traced scene radiance per pixel (sun, sky, lamps, shadows, diffuse
//!   bounces, glass, fog), rolling shutter and motion blur; per-pixel object ids for recognition.
//! * [`lens`]: intrinsics, Brown–Conrady distortion, vignetting, PSF blur, sun flare and ghosts.
//! * [`pixel`]: EMVA 1288 pixel model (shot, read, dark current, DSNU, PRNU, full well, ADC), LED
//!   flicker, auto exposure.
//! * [`hdr`]: multi-exposure / split-pixel HDR merge and PWL companding.
//! * [`isp`]: black level, demosaic, white balance, colour correction to sRGB, tone mapping, 8 bit.
//! * [`bench`]: `osiris bench camera`.
//!
//! # Data flow of one step ([`CameraSensor`])
//!
//! 1. [`render::Renderer`] traces one ray per pixel (directions from [`lens::Lens`]) and writes the
//!    *photo-electron radiance* of each CFA channel, `L_c = Σ_k L_λ(λ_k) · w_c(λ_k)`
//!    [e⁻ s⁻¹ m⁻² sr⁻¹] ([`ChannelImage`], weights from [`SpectralResponse`]), plus [`RenderAux`].
//! 2. [`lens::Lens::radiance_to_rate`] turns radiance into the electron generation rate of each
//!    pixel [e⁻/s] (E = π L T cos⁴θ / 4N², × pixel area), then PSF blur and flare.
//! 3. [`pixel::PixelModel::expose`] makes one RAW mosaic per exposure ([`RawImage`]).
//! 4. [`hdr::HdrPipeline`] merges them to a linear HDR RAW and compands it.
//! 5. [`isp::Isp`] makes the 8-bit sRGB image; [`crate::recognition::camera`] the objects.

pub mod bench;
pub mod hdr;
pub mod isp;
pub mod lens;
pub mod light;
pub mod pixel;
pub mod render;
pub mod spectral;
pub mod windshield;

mod sensor;

pub use sensor::{CameraChain, CameraConfig, CameraPreset, CameraSensor, EmitConfig, StageTimes};
pub use spectral::{SpectralBands, SpectralResponse};

use crate::effects::EffectInfo;

/// Number of colour channels of the spectral response (R, G, B filters of the RGGB mosaic).
pub const CHANNELS: usize = 3;
/// Channel index of the red, green and blue filters.
pub const RED: usize = 0;
pub const GREEN: usize = 1;
pub const BLUE: usize = 2;

/// Every camera effect (for the registry's catalogue, `crate::registry::catalogue`).
pub fn effects() -> Vec<EffectInfo> {
    [
        render::EFFECTS,
        lens::EFFECTS,
        pixel::EFFECTS,
        hdr::EFFECTS,
        isp::EFFECTS,
        windshield::EFFECTS,
    ]
    .concat()
}

/// One value per pixel and channel, rows top to bottom, pixels left to right (index `y·width + x`).
/// What the values mean depends on the stage: after rendering, photo-electron radiance
/// [e⁻ s⁻¹ m⁻² sr⁻¹]; after the lens, electron generation rate per pixel [e⁻/s].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ChannelImage {
    pub width: usize,
    pub height: usize,
    pub planes: [Vec<f32>; CHANNELS],
}

impl ChannelImage {
    pub fn new(width: usize, height: usize) -> ChannelImage {
        let mut img = ChannelImage::default();
        img.resize(width, height);
        img
    }

    /// Resize and zero (keeps the allocations).
    pub fn resize(&mut self, width: usize, height: usize) {
        self.width = width;
        self.height = height;
        for p in &mut self.planes {
            p.clear();
            p.resize(width * height, 0.0);
        }
    }

    pub fn index(&self, x: usize, y: usize) -> usize {
        y * self.width + x
    }

    pub fn len(&self) -> usize {
        self.width * self.height
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// No object at this pixel (sky, road, lane markings): recognition's input contract.
pub use crate::recognition::camera::NO_OBJECT;

/// The sun when it is in front of the camera (the renderer finds it, the lens draws its flare).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SunInView {
    /// Unit vector towards the sun in the sensor frame.
    pub direction_sensor: glam::DVec3,
    /// Photo-electron radiance of the solar disk per channel, e⁻ s⁻¹ m⁻² sr⁻¹.
    pub radiance: [f64; CHANNELS],
    /// Solid angle of the disk, sr.
    pub solid_angle_sr: f64,
}

/// Per-pixel by-products of the render, for recognition.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RenderAux {
    /// Index into `object_ids` of the object the pixel's primary ray hit, or [`NO_OBJECT`].
    pub object_index: Vec<u32>,
    /// Distance along the primary ray to the first hit, m (`f32::INFINITY` for sky).
    pub depth_m: Vec<f32>,
    /// Ground-truth ids referenced by `object_index`: moving and stationary objects, traffic signs
    /// (main and supplementary plates), traffic-light bulbs (lenses) and road markings
    /// (`environment::scene::StaticElement::ground_truth_id`).
    pub object_ids: Vec<u64>,
}

impl RenderAux {
    /// The per-pixel objects as recognition reads them.
    pub fn objects(&self) -> crate::recognition::camera::PixelObjects<'_> {
        crate::recognition::camera::PixelObjects {
            object_index: &self.object_index,
            depth_m: &self.depth_m,
            object_ids: &self.object_ids,
        }
    }
}

/// A pixel that sees a pulse-width-modulated (LED) light source directly, kept apart from the
/// steady image so that the pixel model can integrate the PWM over each row's exposure window
/// (`camera.led_flicker`). Units as the [`ChannelImage`] of the same stage; the value is the
/// *time-averaged* radiance/rate (the on-state value is this divided by the duty cycle).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlickerSample {
    pub pixel: u32,
    pub value: [f32; CHANNELS],
    /// Index into [`Flicker::sources`].
    pub source: u16,
}

/// A PWM light source: on for `duty · period` starting at `phase_s + n·period`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PwmSource {
    pub frequency_hz: f64,
    /// On fraction of the period (0, 1].
    pub duty: f64,
    /// Start of an on-interval, s (simulation time).
    pub phase_s: f64,
}

impl PwmSource {
    /// Fraction of `[t0_s, t0_s + exposure_s]` during which the source is on.
    pub fn on_fraction(&self, t0_s: f64, exposure_s: f64) -> f64 {
        if self.frequency_hz.is_nan() || self.frequency_hz <= 0.0 || self.duty >= 1.0 {
            return 1.0;
        }
        let period = 1.0 / self.frequency_hz;
        let on = self.duty.clamp(0.0, 1.0) * period;
        // Integral of the on-indicator from phase to t: floor(n)·on + min(frac·period, on).
        let cum = |t: f64| {
            let x = (t - self.phase_s) / period;
            let n = x.floor();
            n * on + ((x - n) * period).min(on)
        };
        if exposure_s <= 0.0 {
            let x = (t0_s - self.phase_s) / period;
            return if (x - x.floor()) * period < on {
                1.0
            } else {
                0.0
            };
        }
        ((cum(t0_s + exposure_s) - cum(t0_s)) / exposure_s).clamp(0.0, 1.0)
    }
}

/// Pixels that see PWM sources directly, and the sources.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Flicker {
    pub samples: Vec<FlickerSample>,
    pub sources: Vec<PwmSource>,
}

impl Flicker {
    pub fn clear(&mut self) {
        self.samples.clear();
        self.sources.clear();
    }
}

/// When each row is exposed. Row `r` of exposure `j` integrates light over
/// `[frame_time_s + start_offset_s(j) + r·row_time_s, … + exposure_s(j)]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShutterTiming {
    /// Simulation time of the frame (the SensorView's), s.
    pub frame_time_s: f64,
    /// Line time of the rolling shutter, s (0: global shutter or `camera.rolling_shutter` off).
    pub row_time_s: f64,
    /// Start of the longest exposure of row 0 relative to `frame_time_s`, s.
    pub start_offset_s: f64,
    /// Length of the longest exposure, s (the window the renderer integrates motion blur over).
    pub exposure_s: f64,
}

impl ShutterTiming {
    /// Mid-exposure time of a row relative to `frame_time_s`, s.
    pub fn row_mid_s(&self, row: usize) -> f64 {
        self.start_offset_s + row as f64 * self.row_time_s + 0.5 * self.exposure_s
    }
}

/// One RAW image: a CFA mosaic (or a single channel), digital numbers.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RawImage {
    pub width: usize,
    pub height: usize,
    /// DN per pixel, row-major.
    pub data: Vec<u32>,
    /// Significant bits per sample.
    pub bit_depth: u32,
    /// Black level (offset added before the ADC), DN.
    pub black_level_dn: f64,
    /// System gain K including the analog gain, DN/e⁻.
    pub conversion_gain_dn_per_e: f64,
    /// Exposure time, s.
    pub exposure_time_s: f64,
    /// Analog gain (linear).
    pub analog_gain: f64,
    /// Rolling-shutter line time, s.
    pub row_time_s: f64,
    /// Index of the exposure (0 = longest) for single exposures.
    pub exposure_index: u32,
}

impl RawImage {
    /// The largest code of the bit depth.
    pub fn max_dn(&self) -> u32 {
        if self.bit_depth >= 32 {
            u32::MAX
        } else {
            (1u32 << self.bit_depth) - 1
        }
    }
}

/// An 8-bit RGB image (ISP output), rows top to bottom, `RGBRGB…`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RgbImage {
    pub width: usize,
    pub height: usize,
    pub data: Vec<u8>,
}

/// Colour-filter array layout of the mosaic: the channel of pixel (x, y).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Cfa {
    #[default]
    Rggb,
    Bggr,
    Grbg,
    Gbrg,
}

impl Cfa {
    /// Channel ([`RED`], [`GREEN`], [`BLUE`]) of pixel (x, y).
    pub fn channel(self, x: usize, y: usize) -> usize {
        let (a, b, c, d) = match self {
            Cfa::Rggb => (RED, GREEN, GREEN, BLUE),
            Cfa::Bggr => (BLUE, GREEN, GREEN, RED),
            Cfa::Grbg => (GREEN, RED, BLUE, GREEN),
            Cfa::Gbrg => (GREEN, BLUE, RED, GREEN),
        };
        match (y & 1, x & 1) {
            (0, 0) => a,
            (0, 1) => b,
            (1, 0) => c,
            _ => d,
        }
    }
}
