//! The radar FMU binary (`osiris_radar.so`): the shared shell's 34 FMI 2.0 co-simulation exports over
//! the radar sensor. All logic lives in `osiris_fmu`; see `modelDescription/radar.xml`.

osiris_fmu::export_fmi2!(&osiris_fmu::sensors::radar::DESCRIPTOR);
