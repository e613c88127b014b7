//! The camera FMU binary (`osiris_camera.so`): the shared shell's 34 FMI 2.0 co-simulation exports over
//! the camera sensor. All logic lives in `osiris_fmu`; see `modelDescription/camera.xml`.

osiris_fmu::export_fmi2!(&osiris_fmu::sensors::camera::DESCRIPTOR);
