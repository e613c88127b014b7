//! The lidar FMU binary: the shared shell's 34 FMI 2.0 exports over the lidar sensor. To be written.
