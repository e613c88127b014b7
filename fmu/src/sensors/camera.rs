//! The camera FMU (`osiris_camera`).

use osiris_models::SensorKind;

use crate::descriptor::FmuDescriptor;

/// Descriptor of the camera FMU: modelIdentifier `osiris_camera`, default step = the built-in
/// configuration's `update_cycle_s`.
pub static DESCRIPTOR: FmuDescriptor = FmuDescriptor::new(
    SensorKind::Camera,
    "osiris camera",
    "osiris_camera",
    "osiris camera sensor model (OSI 3.8.0 SensorView in, SensorData out, OSMP 1.6.0; raw perception \
     output in PerceptionDataOut). mode=physical (default): spectral ray-traced rendering (SPCTRAL2 \
     sun and sky, vehicle lamps with light-distribution tables, shadows, glass, fog), lens \
     (Brown-Conrady distortion, vignetting, PSF, sun flare), EMVA 1288 pixel model with \
     multi-exposure HDR and PWL companding, rolling shutter, motion blur, LED flicker, ISP to 8-bit \
     sRGB, and recognition of objects from the rendered view. mode=ideal: the ideal object-level \
     reference model.",
);
