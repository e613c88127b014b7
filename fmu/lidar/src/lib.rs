//! The LiDAR FMU binary (`osiris_lidar.so`): the shared shell's 34 FMI 2.0 co-simulation exports over
//! the LiDAR sensor. All logic lives in `osiris_fmu`; see `modelDescription/lidar.xml`.

osiris_fmu::export_fmi2!(&osiris_fmu::sensors::lidar::DESCRIPTOR);
