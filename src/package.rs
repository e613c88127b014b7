//! `osiris package`: builds `camera.fmu`, `radar.fmu`, `lidar.fmu` (the selected sensors) and
//! `scenario.fmu` (the scenario player, an OSMP SensorView source; always written).
//!
//! An FMU is a zip archive (FMI 2.0 §2.3) holding
//! * `modelDescription.xml`: rendered from the shell's variable table (identical to the checked-in
//!   `modelDescription/<name>.xml`; a test fails if they drift),
//! * `binaries/linux64/<modelIdentifier>.so`: the FMU's cdylib (`fmu/<name>/`),
//! * `resources/`: a sensor's `config.json` (its built-in configuration, the default of the
//!   `config` parameter), the scenario player's `scenario.json` (the built-in scenario, the default
//!   of the `scenario` parameter),
//! * `documentation/index.html` and `documentation/externalDependencies.txt`.
//!
//! Entries are deflated with default options (zip version 2.0, no zip64, no data descriptors), as FMI
//! requires.

use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};

use osiris_fmu::FmuDescriptor;
use osiris_models::SensorKind;
use zip::CompressionMethod;

use crate::master::{LocateOptions, fmu_library_file_name, locate_fmu_library_with};
use zip::write::SimpleFileOptions;

/// Errors of the packaging step.
#[derive(Debug, thiserror::Error)]
pub enum PackageError {
    #[error("building the FMU libraries failed: {0}")]
    Build(String),
    #[error("the FMU library {path} is missing: {hint}")]
    MissingLibrary { path: PathBuf, hint: String },
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: zip: {source}")]
    Zip {
        path: PathBuf,
        source: zip::result::ZipError,
    },
}

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> PackageError + '_ {
    move |source| PackageError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Root of the source workspace this executable was built from.
pub fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The cargo target directory of the workspace (honours `CARGO_TARGET_DIR`).
pub fn target_dir() -> PathBuf {
    match std::env::var_os("CARGO_TARGET_DIR") {
        Some(d) => {
            let d = PathBuf::from(d);
            if d.is_absolute() {
                d
            } else {
                workspace_root().join(d)
            }
        }
        None => workspace_root().join("target"),
    }
}

/// Default output folder of `osiris package`: `target/fmu/`.
pub fn default_fmu_dir() -> PathBuf {
    target_dir().join("fmu")
}

/// Cargo package name of a sensor's FMU crate.
pub fn fmu_crate(kind: SensorKind) -> String {
    fmu_crate_named(kind.name())
}

/// Cargo package name of an FMU crate by the FMU's short name ([`FmuDescriptor::name`]:
/// `radar`, `scenario`).
pub fn fmu_crate_named(name: &str) -> String {
    format!("osiris-{name}-fmu")
}

/// The compiled library of a sensor FMU: from `lib_dir` when given, else located (and built with
/// cargo when stale) by [`crate::master::locate_fmu_library_with`] for `profile` (`None`: the profile
/// of this executable).
pub fn fmu_library(
    kind: SensorKind,
    lib_dir: Option<&Path>,
    profile: Option<&str>,
) -> Result<PathBuf, PackageError> {
    fmu_library_named(kind.name(), lib_dir, profile)
}

/// [`fmu_library`] by the FMU's short name ([`FmuDescriptor::name`]: `radar`, `scenario`).
pub fn fmu_library_named(
    name: &str,
    lib_dir: Option<&Path>,
    profile: Option<&str>,
) -> Result<PathBuf, PackageError> {
    match lib_dir {
        Some(dir) => Ok(dir.join(fmu_library_file_name(name))),
        None => {
            let opts = LocateOptions {
                profile: profile.map(str::to_owned),
                ..LocateOptions::default()
            };
            locate_fmu_library_with(name, &opts).map_err(|e| PackageError::Build(e.to_string()))
        }
    }
}

/// What to package.
#[derive(Debug, Clone)]
pub struct PackageOptions {
    /// Output folder for the `.fmu` files.
    pub out_dir: PathBuf,
    /// Folder with prebuilt `libosiris_<name>.so`; `None` builds them with cargo first.
    pub lib_dir: Option<PathBuf>,
    /// Cargo profile used when building (`dev`, `release`; `None`: the profile of this executable).
    pub profile: Option<String>,
    /// Sensors to package (`scenario.fmu` is always packaged too).
    pub sensors: Vec<SensorKind>,
}

impl Default for PackageOptions {
    fn default() -> Self {
        PackageOptions {
            out_dir: default_fmu_dir(),
            lib_dir: None,
            profile: None,
            sensors: SensorKind::ALL.to_vec(),
        }
    }
}

/// The descriptors `opts` packages: the selected sensors, then the scenario player.
pub fn descriptors(opts: &PackageOptions) -> Vec<&'static FmuDescriptor> {
    opts.sensors
        .iter()
        .map(|&kind| osiris_fmu::sensors::descriptor(kind))
        .chain([&osiris_fmu::sources::scenario::DESCRIPTOR])
        .collect()
}

/// Build (if needed) and package the FMUs; returns the paths of the written `.fmu` files (the
/// sensors in `opts.sensors` order, then `scenario.fmu`).
pub fn package(opts: &PackageOptions) -> Result<Vec<PathBuf>, PackageError> {
    std::fs::create_dir_all(&opts.out_dir).map_err(io_err(&opts.out_dir))?;
    let mut written = Vec::new();
    for descriptor in descriptors(opts) {
        let lib = fmu_library_named(
            descriptor.name(),
            opts.lib_dir.as_deref(),
            opts.profile.as_deref(),
        )?;
        let out = opts.out_dir.join(format!("{}.fmu", descriptor.name()));
        write_fmu(descriptor, &lib, &out)?;
        written.push(out);
    }
    Ok(written)
}

/// True when `fmu` exists and is at least as new as `lib` (used by `osiris run` to skip repackaging).
pub fn is_up_to_date(fmu: &Path, lib: &Path) -> bool {
    match (
        fmu.metadata().and_then(|m| m.modified()),
        lib.metadata().and_then(|m| m.modified()),
    ) {
        (Ok(f), Ok(l)) => f >= l,
        _ => false,
    }
}

/// Write one FMU archive from a descriptor and its compiled library.
pub fn write_fmu(descriptor: &FmuDescriptor, lib: &Path, out: &Path) -> Result<(), PackageError> {
    if !lib.is_file() {
        return Err(PackageError::MissingLibrary {
            path: lib.to_path_buf(),
            hint: format!(
                "build it with `cargo build --release -p {}` or run `osiris package` without --lib-dir",
                fmu_crate_named(descriptor.name())
            ),
        });
    }
    let so = std::fs::read(lib).map_err(io_err(lib))?;
    let xml = osiris_fmu::model_description::render(descriptor);
    let docs = documentation_html(descriptor);

    let tmp = out.with_extension("fmu.partial");
    let file = File::create(&tmp).map_err(io_err(&tmp))?;
    let mut zip = zip::ZipWriter::new(file);
    let zerr = |source| PackageError::Zip {
        path: out.to_path_buf(),
        source,
    };
    let deflate = SimpleFileOptions::default().compression_method(CompressionMethod::Deflated);
    let mut add = |name: &str, bytes: &[u8], mode: u32| -> Result<(), PackageError> {
        zip.start_file(name, deflate.unix_permissions(mode))
            .map_err(zerr)?;
        zip.write_all(bytes).map_err(io_err(out))
    };
    add("modelDescription.xml", xml.as_bytes(), 0o644)?;
    add(
        &format!("binaries/linux64/{}.so", descriptor.model_identifier),
        &so,
        0o755,
    )?;
    for (name, content) in descriptor.resource_files() {
        add(&format!("resources/{name}"), content.as_bytes(), 0o644)?;
    }
    add("documentation/index.html", docs.as_bytes(), 0o644)?;
    add(
        "documentation/externalDependencies.txt",
        EXTERNAL_DEPENDENCIES.as_bytes(),
        0o644,
    )?;
    zip.finish().map_err(zerr)?;
    std::fs::rename(&tmp, out).map_err(io_err(out))?;
    Ok(())
}

const EXTERNAL_DEPENDENCIES: &str = "\
The binary links only the C runtime of the build host (glibc, libgcc_s; built on Debian 12, so it
needs GLIBC 2.34 or newer). Everything else is statically linked Rust code.
";

fn html_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// `documentation/index.html`: what the FMU does and its variables.
pub fn documentation_html(descriptor: &FmuDescriptor) -> String {
    let xml = osiris_fmu::model_description::render(descriptor);
    let mut rows = String::new();
    if let Ok(doc) = roxmltree::Document::parse(&xml) {
        for var in doc
            .descendants()
            .filter(|n| n.has_tag_name("ScalarVariable"))
        {
            let ty = var
                .children()
                .find(|c| c.is_element() && c.tag_name().name() != "Annotations")
                .map(|c| c.tag_name().name().to_string())
                .unwrap_or_default();
            let start = var
                .children()
                .find(|c| c.is_element() && c.tag_name().name() == ty)
                .and_then(|c| c.attribute("start"))
                .unwrap_or("");
            rows.push_str(&format!(
                "<tr><td><code>{}</code></td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td><code>{}</code></td><td>{}</td></tr>\n",
                html_escape(var.attribute("name").unwrap_or("")),
                ty,
                var.attribute("valueReference").unwrap_or(""),
                var.attribute("causality").unwrap_or("local"),
                var.attribute("variability").unwrap_or("continuous"),
                html_escape(start),
                html_escape(var.attribute("description").unwrap_or("")),
            ));
        }
    }
    if descriptor.is_source() {
        return source_documentation_html(descriptor, &rows);
    }
    format!(
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>{name}</title></head><body>\n\
<h1>{name}</h1>\n<p>{desc}</p>\n\
<h2>Interface</h2>\n<p>OSMP 1.6.0 sensor model (OSI 3.8.0): reads <code>osi3.SensorView</code> from \
<code>OSMPSensorViewIn</code>, writes <code>osi3.SensorData</code> to <code>OSMPSensorDataOut</code> \
(recognised objects in <code>moving_object</code>/<code>stationary_object</code> in the sensor frame, raw \
detections in <code>feature_data</code>), and the raw perception output \
(<code>osiris.perception.PerceptionData</code>, MIME <code>{pmime}</code>) to <code>PerceptionDataOut</code>. \
The environment configuration handshake uses <code>OSMPSensorViewInConfigRequest</code> / \
<code>OSMPSensorViewInConfig</code>. Address 0 or size 0 on the input means no input this step.</p>\n\
<h2>Configuration</h2>\n<p>The <code>config</code> parameter names a JSON file in <code>resources/</code> \
(default <code>config.json</code>, the built-in defaults) or holds inline JSON. Real and String parameters \
set by the importer override the matching key of that JSON. <code>mode</code> selects the model: \
<code>ideal</code> is the object-level reference model (ground-truth objects inside the field of view and \
range, occluded by other objects' boxes, transformed into the sensor frame).</p>\n\
<h2>Variables</h2>\n<table border=\"1\"><tr><th>name</th><th>type</th><th>vr</th><th>causality</th>\
<th>variability</th><th>start</th><th>description</th></tr>\n{rows}</table>\n</body></html>\n",
        name = html_escape(descriptor.model_name),
        desc = html_escape(descriptor.description),
        pmime = html_escape(osiris_proto::MIME_PERCEPTION_DATA),
    )
}

/// `documentation/index.html` of a SensorView source (the scenario player).
fn source_documentation_html(descriptor: &FmuDescriptor, rows: &str) -> String {
    format!(
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>{name}</title></head><body>\n\
<h1>{name}</h1>\n<p>{desc}</p>\n\
<h2>Interface</h2>\n<p>OSMP 1.6.0 SensorView source (OSI 3.8.0): no inputs; writes \
<code>osi3.SensorView</code> to <code>OSMPSensorViewOut</code> (double-buffered: valid until the start of \
the second <code>fmi2DoStep</code> after the one that produced it). <code>fmi2ExitInitializationMode</code> \
publishes the view at the start time, <code>fmi2DoStep(t, h)</code> the view at <code>t + h</code>, so a \
sensor FMU stepped at <code>t</code> with the current output sees the world at <code>t</code>. To drive a \
sensor, copy the three Integers of <code>OSMPSensorViewOut</code> to its <code>OSMPSensorViewIn</code> \
before each of its steps. <code>valid</code> is false (and the triple 0/0/0) outside the recording.</p>\n\
<h2>Parameters</h2>\n<p><code>scenario</code> names a scenario JSON in <code>resources/</code> (default \
<code>scenario.json</code>, the built-in scenario) or an absolute path, holds inline JSON, or is empty for \
the built-in scenario; the FMI time is the scenario's own time. <code>sensor</code> names the scenario's \
sensor mount whose view is played (empty: the first); every view carries the global ground truth and \
that mount. <code>trace_path</code> plays a SensorView trace (<code>.osi</code>) instead, byte for byte, \
each message from its timestamp (relative to the first message, which plays at t = 0) to the next. A bad \
parameter (missing file, bad JSON, unknown sensor) fails initialization with <code>fmi2Error</code> \
naming it.</p>\n\
<h2>Variables</h2>\n<table border=\"1\"><tr><th>name</th><th>type</th><th>vr</th><th>causality</th>\
<th>variability</th><th>start</th><th>description</th></tr>\n{rows}</table>\n</body></html>\n",
        name = html_escape(descriptor.model_name),
        desc = html_escape(descriptor.description),
    )
}
