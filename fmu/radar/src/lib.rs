//! The radar FMU binary: the shared shell's 34 FMI 2.0 exports over the radar sensor. To be written.
