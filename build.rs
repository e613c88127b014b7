//! Build script of the `osiris` root crate.
//!
//! * Compiles `src/master/logger.c`, the C shim that implements the C-variadic FMI 2.0 logger callback for
//!   the co-simulation master (Rust cannot define C-variadic functions on stable).
//! * Exports `OSIRIS_PROFILE_DIR` (the `target/<profile>` directory this crate is built into) so that
//!   `osiris::master::locate_fmu_library` finds the FMU cdylibs of the same profile.

use std::path::PathBuf;

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-changed=src/master/logger.c");

    cc::Build::new()
        .file("src/master/logger.c")
        .warnings(true)
        .extra_warnings(true)
        .compile("osiris_master_logger");

    // OUT_DIR = <target>/<profile>/build/osiris-<hash>/out (with `--target <triple>`:
    // <target>/<triple>/<profile>/build/...): three levels up is the profile directory holding the cdylibs.
    let out_dir = PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    if let Some(profile_dir) = out_dir.ancestors().nth(3) {
        println!(
            "cargo:rustc-env=OSIRIS_PROFILE_DIR={}",
            profile_dir.display()
        );
    }
}
