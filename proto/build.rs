//! Compiles `proto/osi3/*.proto` and `proto/osiris/*.proto` with the pure-Rust `protox` compiler
//! (no system `protoc`) and generates Rust types with `prost-build`.
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let root = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR")?);
    let mut files = Vec::new();
    for dir in ["osi3", "osiris"] {
        let mut entries: Vec<PathBuf> = std::fs::read_dir(root.join(dir))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x == "proto"))
            .collect();
        entries.sort();
        files.extend(entries);
    }
    for f in &files {
        println!("cargo:rerun-if-changed={}", f.display());
    }
    // `protox::compile`, but also keeping the encoded FileDescriptorSet (with imports and extension
    // options such as `osi3.current_interface_version`) for `osiris_proto::FILE_DESCRIPTOR_SET`.
    let mut compiler = protox::Compiler::new([&root])?;
    compiler
        .include_source_info(true)
        .include_imports(true)
        .open_files(&files)?;
    let out_dir = PathBuf::from(std::env::var("OUT_DIR")?);
    std::fs::write(
        out_dir.join("file_descriptor_set.bin"),
        compiler.encode_file_descriptor_set(),
    )?;
    let fds = compiler.file_descriptor_set();
    let mut config = prost_build::Config::new();
    config.enable_type_names();
    config.compile_fds(fds)?;
    Ok(())
}
