//! The radar FMU (`osiris_radar`).

use osiris_models::SensorKind;

use crate::descriptor::FmuDescriptor;

/// Descriptor of the radar FMU: modelIdentifier `osiris_radar`, default step = the built-in
/// configuration's `update_cycle_s`.
pub static DESCRIPTOR: FmuDescriptor = FmuDescriptor::new(
    SensorKind::Radar,
    "osiris radar",
    "osiris_radar",
    "osiris radar sensor model (OSI 3.8.0 SensorView in, SensorData out, OSMP 1.6.0; raw perception \
     output in PerceptionDataOut). mode=physical (default): 76-81 GHz FMCW radar: ray-traced \
     propagation (shooting and bouncing rays with physical optics, Fresnel reflection, ground \
     multipath, rain and gas attenuation, antenna patterns), IF-cube synthesis with thermal and \
     phase noise, range/Doppler FFTs, CFAR, angle estimation, then clustering and tracking into \
     detected objects. mode=ideal: the ideal object-level reference model.",
);
