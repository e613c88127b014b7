fn main() {
    println!("cargo:rerun-if-changed=c/logger.c");
    cc::Build::new()
        .file("c/logger.c")
        .warnings(true)
        .compile("osiris_fmu_testlog");
}
