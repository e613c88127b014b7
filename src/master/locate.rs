//! [`locate_fmu_library`]: find, or build with cargo, the cdylib of an osiris FMU for the current profile.
//!
//! The FMU crates are `fmu/<kind>` (package `osiris-<kind>-fmu`, library `osiris_<kind>`), producing
//! `target/<profile>/libosiris_<kind>.so`. The "current profile" is the one this crate was built with
//! (`build.rs` exports `OSIRIS_PROFILE_DIR`): tests and a `cargo run` debug binary use `target/debug`, a
//! release binary `target/release`.
//!
//! Running cargo from inside `cargo test` does not deadlock: cargo releases the build-directory lock before
//! it runs the test binaries (checked with cargo 1.95). A concurrent `cargo build` elsewhere only makes the
//! nested cargo wait ("Blocking waiting for file lock"). Builds are serialised within the process.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::{Mutex, OnceLock};

use super::{MasterError, Result};

/// When [`locate_fmu_library_with`] runs `cargo build`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BuildPolicy {
    /// Never build; the library must exist.
    Never,
    /// Build only if the library does not exist.
    IfMissing,
    /// Always run `cargo build` (a no-op when up to date, so the library is never stale); if cargo or the
    /// workspace is unavailable, fall back to an existing library.
    #[default]
    Always,
}

/// Options of [`locate_fmu_library_with`]; `Default` gives the current profile and [`BuildPolicy::Always`].
#[derive(Debug, Clone, Default)]
pub struct LocateOptions {
    pub build: BuildPolicy,
    /// Cargo profile name (`dev`, `release`, …). Default: the profile this crate was built with.
    pub profile: Option<String>,
    /// `--target-dir` for the build. Default: the workspace's target directory.
    pub target_dir: Option<PathBuf>,
    /// The workspace root. Default: this crate's manifest directory (the workspace root).
    pub workspace: Option<PathBuf>,
    /// The cargo executable. Default: `$CARGO`, else the cargo that built this crate, else `cargo`.
    pub cargo: Option<PathBuf>,
    /// Let cargo's progress and diagnostics through to stderr (default: captured, shown on failure).
    pub verbose: bool,
}

/// The profile directory this crate was built into (`…/target/debug`), from `build.rs`.
fn build_profile_dir() -> Option<PathBuf> {
    option_env!("OSIRIS_PROFILE_DIR").map(PathBuf::from)
}

/// The cargo profile for a profile directory name (`debug` is the `dev` profile).
fn profile_for_dir(dir_name: &str) -> String {
    match dir_name {
        "debug" => "dev".to_owned(),
        other => other.to_owned(),
    }
}

/// The profile directory name for a cargo profile (`dev` and `test` build into `debug`, `bench` into
/// `release`).
fn dir_for_profile(profile: &str) -> &str {
    match profile {
        "dev" | "test" => "debug",
        "bench" => "release",
        other => other,
    }
}

/// File name of the cdylib of `kind` on this platform, e.g. `libosiris_radar.so`.
pub fn fmu_library_file_name(kind: &str) -> String {
    format!(
        "{}osiris_{kind}{}",
        std::env::consts::DLL_PREFIX,
        std::env::consts::DLL_SUFFIX
    )
}

/// [`locate_fmu_library_with`] with default options: the current profile, building with cargo as needed.
///
/// `kind` is `camera`, `radar` or `lidar` (any `[a-z0-9_]+` is accepted: package `osiris-<kind>-fmu`).
pub fn locate_fmu_library(kind: &str) -> Result<PathBuf> {
    locate_fmu_library_with(kind, &LocateOptions::default())
}

/// Finds `lib osiris_<kind>.so` for the requested profile, running
/// `cargo build -p osiris -p osiris-<kind>-fmu --lib --profile <profile>` as `options.build` says, and returns the path of
/// the cdylib cargo reports (or the expected path).
pub fn locate_fmu_library_with(kind: &str, options: &LocateOptions) -> Result<PathBuf> {
    let fail = |reason: String| MasterError::Locate {
        kind: kind.to_owned(),
        reason,
    };
    if kind.is_empty()
        || !kind
            .bytes()
            .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'_')
    {
        return Err(fail(
            "expected a kind like `camera`, `radar` or `lidar`".to_owned(),
        ));
    }
    let built_dir = build_profile_dir();
    let profile = options
        .profile
        .clone()
        .or_else(|| {
            built_dir
                .as_ref()
                .and_then(|d| d.file_name())
                .map(|n| profile_for_dir(&n.to_string_lossy()))
        })
        .unwrap_or_else(|| {
            if cfg!(debug_assertions) {
                "dev".to_owned()
            } else {
                "release".to_owned()
            }
        });
    let workspace = options
        .workspace
        .clone()
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")));
    let target_root = options
        .target_dir
        .clone()
        .or_else(|| {
            built_dir
                .as_ref()
                .and_then(|d| d.parent())
                .map(Path::to_path_buf)
        })
        .or_else(|| std::env::var_os("CARGO_TARGET_DIR").map(|d| workspace.join(d)))
        .unwrap_or_else(|| workspace.join("target"));
    let expected = target_root
        .join(dir_for_profile(&profile))
        .join(fmu_library_file_name(kind));

    let must_build = match options.build {
        BuildPolicy::Never => false,
        BuildPolicy::IfMissing => !expected.is_file(),
        BuildPolicy::Always => true,
    };
    if !must_build {
        return if expected.is_file() {
            Ok(expected)
        } else {
            Err(fail(format!(
                "`{}` does not exist (build it with `cargo build -p osiris-{kind}-fmu --profile {profile}`)",
                expected.display()
            )))
        };
    }
    if !workspace.join("Cargo.toml").is_file()
        || !workspace
            .join("fmu")
            .join(kind)
            .join("Cargo.toml")
            .is_file()
    {
        return if options.build == BuildPolicy::Always && expected.is_file() {
            Ok(expected)
        } else {
            Err(fail(format!(
                "`{}` does not exist and `{}` holds no osiris workspace with fmu/{kind} to build it from",
                expected.display(),
                workspace.display()
            )))
        };
    }

    // One build per (kind, profile, target dir) and process; concurrent callers wait for it.
    type BuiltKey = (String, String, PathBuf);
    static BUILT: OnceLock<Mutex<HashMap<BuiltKey, PathBuf>>> = OnceLock::new();
    let mut built = BUILT
        .get_or_init(Default::default)
        .lock()
        .unwrap_or_else(|e| e.into_inner());
    let key = (kind.to_owned(), profile.clone(), target_root.clone());
    if let Some(path) = built.get(&key)
        && path.is_file()
    {
        return Ok(path.clone());
    }
    match cargo_build(kind, &profile, &workspace, options) {
        Ok(Some(path)) => {
            built.insert(key, path.clone());
            Ok(path)
        }
        Ok(None) if expected.is_file() => {
            built.insert(key, expected.clone());
            Ok(expected)
        }
        Ok(None) => Err(fail(format!(
            "cargo reported no cdylib and `{}` does not exist",
            expected.display()
        ))),
        Err(CargoError::Spawn(e)) if options.build == BuildPolicy::Always && expected.is_file() => {
            eprintln!(
                "warning: cannot run cargo ({e}); using the existing `{}`",
                expected.display()
            );
            Ok(expected)
        }
        Err(CargoError::Spawn(e)) => Err(fail(format!("cannot run cargo: {e}"))),
        Err(CargoError::Failed(msg)) => Err(fail(msg)),
    }
}

enum CargoError {
    Spawn(std::io::Error),
    Failed(String),
}

fn cargo_executable(options: &LocateOptions) -> PathBuf {
    options
        .cargo
        .clone()
        .or_else(|| std::env::var_os("CARGO").map(PathBuf::from))
        .or_else(|| {
            option_env!("CARGO")
                .map(PathBuf::from)
                .filter(|p| p.is_file())
        })
        .unwrap_or_else(|| PathBuf::from("cargo"))
}

/// Runs the build; `Ok(Some(path))` is the cdylib cargo reported.
fn cargo_build(
    kind: &str,
    profile: &str,
    workspace: &Path,
    options: &LocateOptions,
) -> Result<Option<PathBuf>, CargoError> {
    let package = format!("osiris-{kind}-fmu");
    let mut cmd = Command::new(cargo_executable(options));
    cmd.current_dir(workspace)
        // `-p osiris --lib` beside the FMU crate: cargo unifies the features of the packages it
        // builds together, so the FMU crate's dependencies resolve to the same features as the
        // `osiris` binary's (a superset of the FMU crates' own) and reuse the artifacts the
        // README's `cargo run --release` already built, instead of a second build of the models
        // with other features. `--lib` leaves the running `osiris` binary alone.
        .args([
            "build",
            "-p",
            "osiris",
            "-p",
            &package,
            "--lib",
            "--profile",
            profile,
            "--message-format=json-render-diagnostics",
        ])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(if options.verbose {
            Stdio::inherit()
        } else {
            Stdio::piped()
        });
    if let Some(dir) = &options.target_dir {
        cmd.arg("--target-dir").arg(dir);
    }
    let output = cmd.output().map_err(CargoError::Spawn)?;
    if !output.status.success() {
        let stderr = String::from_utf8_lossy(&output.stderr);
        let tail: Vec<&str> = stderr
            .lines()
            .rev()
            .take(40)
            .collect::<Vec<_>>()
            .into_iter()
            .rev()
            .collect();
        return Err(CargoError::Failed(format!(
            "`cargo build -p osiris -p {package} --lib --profile {profile}` in `{}` failed ({}){}",
            workspace.display(),
            output.status,
            if tail.is_empty() {
                String::new()
            } else {
                format!(":\n{}", tail.join("\n"))
            }
        )));
    }
    let lib_name = format!("osiris_{kind}");
    let stdout = String::from_utf8_lossy(&output.stdout);
    for line in stdout.lines() {
        let Ok(msg) = serde_json::from_str::<serde_json::Value>(line) else {
            continue;
        };
        if msg["reason"] != "compiler-artifact" || msg["target"]["name"] != lib_name.as_str() {
            continue;
        }
        let is_cdylib = msg["target"]["kind"]
            .as_array()
            .is_some_and(|k| k.iter().any(|k| k == "cdylib"));
        if !is_cdylib {
            continue;
        }
        let dll_suffix = std::env::consts::DLL_SUFFIX;
        if let Some(path) = msg["filenames"]
            .as_array()
            .into_iter()
            .flatten()
            .filter_map(|f| f.as_str())
            .find(|f| f.ends_with(dll_suffix))
        {
            return Ok(Some(PathBuf::from(path)));
        }
    }
    Ok(None)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn profile_directory_mapping() {
        assert_eq!(profile_for_dir("debug"), "dev");
        assert_eq!(profile_for_dir("release"), "release");
        assert_eq!(dir_for_profile("dev"), "debug");
        assert_eq!(dir_for_profile("test"), "debug");
        assert_eq!(dir_for_profile("bench"), "release");
        assert_eq!(dir_for_profile("dist"), "dist");
        assert_eq!(fmu_library_file_name("radar"), "libosiris_radar.so");
        assert!(build_profile_dir().is_some());
    }

    #[test]
    fn rejects_bad_kind_and_missing_library() {
        let err = locate_fmu_library("../x").unwrap_err();
        assert!(err.to_string().contains("expected a kind like"), "{err}");
        let opts = LocateOptions {
            build: BuildPolicy::Never,
            ..LocateOptions::default()
        };
        let err = locate_fmu_library_with("nonexistent_kind", &opts).unwrap_err();
        assert!(
            err.to_string()
                .contains("libosiris_nonexistent_kind.so` does not exist"),
            "{err}"
        );
    }
}
