//! FMI 2.0 CS shell. To be written.
