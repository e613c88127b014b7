//! The LiDAR FMU (`osiris_lidar`).

use osiris_models::SensorKind;

use crate::descriptor::FmuDescriptor;

/// Descriptor of the LiDAR FMU: modelIdentifier `osiris_lidar`, default step = the built-in
/// configuration's `update_cycle_s`.
pub static DESCRIPTOR: FmuDescriptor = FmuDescriptor::new(
    SensorKind::Lidar,
    "osiris lidar",
    "osiris_lidar",
    "osiris LiDAR sensor model (OSI 3.8.0 SensorView in, SensorData out, OSMP 1.6.0; raw perception \
     output in PerceptionDataOut). mode=physical (default): pulsed time-of-flight LiDAR (Velodyne \
     VLS-128 / VLP-16 presets or a configured pattern): per-firing ray tracing with beam sub-rays, \
     the LiDAR equation with material BRDFs, overlap, fog/rain extinction and solar background, an \
     APD receiver with noise, multi-echo detection, range walk and saturation, then ground removal, \
     clustering, boxes and tracking into detected objects. mode=ideal: the ideal object-level \
     reference model.",
);
