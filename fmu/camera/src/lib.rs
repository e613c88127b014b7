//! The camera FMU binary: the shared shell's 34 FMI 2.0 exports over the camera sensor. To be written.
