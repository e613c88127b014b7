//! Camera lens: intrinsics, Brown–Conrady distortion, vignetting, PSF blur, sun flare and ghosts.
//!
//! (Contract stub: the lens helper replaces the body; the signatures are fixed.)

use glam::{DVec2, DVec3, Vec3};
use serde::{Deserialize, Serialize};

use super::render::SunInView;
use super::{ChannelImage, Flicker};
use crate::effects::{EffectInfo, Effects};
use crate::sensor::ModelError;

/// Lens effects (`camera.vignetting`, `camera.distortion`, `camera.psf_blur`, `camera.flare`).
pub const EFFECTS: &[EffectInfo] = &[];

/// Lens parameters (`"lens"` key of the camera config).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LensConfig {}

impl LensConfig {
    pub fn validate(&self) -> Result<(), ModelError> {
        Ok(())
    }
}

/// A planned lens for one image size.
pub struct Lens {
    width: usize,
    height: usize,
    fx: f64,
    rays: Vec<Vec3>,
}

impl Lens {
    /// Plan the lens: `fov_horizontal_rad` gives the focal length when the config has none.
    pub fn new(
        config: &LensConfig,
        width: usize,
        height: usize,
        pixel_pitch_m: f64,
        fov_horizontal_rad: f64,
        effects: &Effects,
    ) -> Result<Lens, ModelError> {
        let _ = (config, pixel_pitch_m, effects);
        let fx = 0.5 * width as f64 / (0.5 * fov_horizontal_rad).tan();
        let (cx, cy) = (0.5 * width as f64, 0.5 * height as f64);
        let mut rays = Vec::with_capacity(width * height);
        for y in 0..height {
            for x in 0..width {
                let d = DVec3::new(
                    1.0,
                    -(x as f64 + 0.5 - cx) / fx,
                    -(y as f64 + 0.5 - cy) / fx,
                );
                rays.push(d.normalize().as_vec3());
            }
        }
        Ok(Lens {
            width,
            height,
            fx,
            rays,
        })
    }

    pub fn width(&self) -> usize {
        self.width
    }

    pub fn height(&self) -> usize {
        self.height
    }

    /// Focal lengths (f_x, f_y) in pixels.
    pub fn focal_length_px(&self) -> (f64, f64) {
        (self.fx, self.fx)
    }

    /// Principal point (c_x, c_y) in pixels (pixel centres at +0.5).
    pub fn principal_point_px(&self) -> (f64, f64) {
        (0.5 * self.width as f64, 0.5 * self.height as f64)
    }

    /// Unit primary-ray direction of every pixel centre in the sensor frame, row-major.
    pub fn ray_directions(&self) -> &[Vec3] {
        &self.rays
    }

    /// Image position (u right, v down, px) of a sensor-frame direction; None behind the camera
    /// or outside the image.
    pub fn project(&self, dir_sensor: DVec3) -> Option<DVec2> {
        if dir_sensor.x <= 0.0 {
            return None;
        }
        let (cx, cy) = self.principal_point_px();
        let u = cx - self.fx * dir_sensor.y / dir_sensor.x;
        let v = cy - self.fx * dir_sensor.z / dir_sensor.x;
        (u >= 0.0 && v >= 0.0 && u < self.width as f64 && v < self.height as f64)
            .then_some(DVec2::new(u, v))
    }

    /// Radiance [e⁻ s⁻¹ m⁻² sr⁻¹] → electron generation rate per pixel [e⁻/s], in place (also the
    /// flicker samples), then PSF blur and flare from `sun`.
    pub fn apply(&self, img: &mut ChannelImage, flicker: &mut Flicker, sun: Option<&SunInView>) {
        let _ = (img, flicker, sun);
    }
}
