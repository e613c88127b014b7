//! Loading an FMU: unzip, parse `modelDescription.xml`, `dlopen` the binary and resolve the 34 functions.

use std::ffi::{CStr, c_char, c_double, c_int, c_uint, c_void};
use std::fs::File;
use std::path::{Component as PathComponent, Path, PathBuf};
use std::sync::Arc;

use super::instance::{Instance, InstanceOptions};
use super::{MasterError, ModelDescription, Result};

/// `fmi2Component`: the FMU's opaque instance pointer.
pub type Fmi2Component = *mut c_void;
type Component = Fmi2Component;
type Env = *mut c_void;
type FmuState = *mut c_void;
type Vr = c_uint;
type Status = c_int;
type CStrPtr = *const c_char;

/// `fmi2CallbackFunctions` (FMI 2.0 §2.1.5); a plain C struct.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct Fmi2CallbackFunctions {
    /// C-variadic: `void logger(env, instanceName, status, category, message, ...)`.
    pub logger: Option<unsafe extern "C" fn(Env, CStrPtr, Status, CStrPtr, CStrPtr, ...)>,
    pub allocate_memory: Option<unsafe extern "C" fn(usize, usize) -> *mut c_void>,
    pub free_memory: Option<unsafe extern "C" fn(*mut c_void)>,
    pub step_finished: Option<unsafe extern "C" fn(Env, Status)>,
    pub component_environment: Env,
}

macro_rules! fmi2_functions {
    ($($field:ident: $symbol:literal => fn($($arg:ty),*) $(-> $ret:ty)?;)+) => {
        /// The 34 FMI 2.0 co-simulation functions of one loaded binary, resolved eagerly.
        ///
        /// Calling them is `unsafe`: the caller must respect the FMI 2.0 calling conventions (valid
        /// component, argument arrays of the stated lengths). [`Instance`] wraps them safely.
        #[allow(missing_docs)]
        #[derive(Clone, Copy)]
        pub struct Fmi2Functions {
            $(pub $field: unsafe extern "C" fn($($arg),*) $(-> $ret)?,)+
        }

        impl Fmi2Functions {
            /// Names of all resolved symbols, in the order of FMI 2.0 §2.3.
            pub const SYMBOLS: &'static [&'static str] = &[$($symbol),+];

            /// Resolves every symbol; the first missing one is an error naming it.
            ///
            /// # Safety
            /// `lib` must be an FMI 2.0 binary whose exports have the FMI 2.0 signatures. The returned
            /// pointers are valid only while `lib` stays loaded.
            unsafe fn resolve(lib: &libloading::Library, path: &Path) -> Result<Fmi2Functions> {
                Ok(Fmi2Functions {
                    $($field: unsafe {
                        *lib.get::<unsafe extern "C" fn($($arg),*) $(-> $ret)?>(
                            concat!($symbol, "\0").as_bytes(),
                        )
                        .map_err(|source| MasterError::MissingSymbol {
                            path: path.to_owned(),
                            symbol: $symbol,
                            source,
                        })?
                    },)+
                })
            }
        }
    };
}

fmi2_functions! {
    // Common (25).
    get_types_platform: "fmi2GetTypesPlatform" => fn() -> CStrPtr;
    get_version: "fmi2GetVersion" => fn() -> CStrPtr;
    set_debug_logging: "fmi2SetDebugLogging" => fn(Component, c_int, usize, *const CStrPtr) -> Status;
    instantiate: "fmi2Instantiate" =>
        fn(CStrPtr, c_int, CStrPtr, CStrPtr, *const Fmi2CallbackFunctions, c_int, c_int) -> Component;
    free_instance: "fmi2FreeInstance" => fn(Component);
    setup_experiment: "fmi2SetupExperiment" =>
        fn(Component, c_int, c_double, c_double, c_int, c_double) -> Status;
    enter_initialization_mode: "fmi2EnterInitializationMode" => fn(Component) -> Status;
    exit_initialization_mode: "fmi2ExitInitializationMode" => fn(Component) -> Status;
    terminate: "fmi2Terminate" => fn(Component) -> Status;
    reset: "fmi2Reset" => fn(Component) -> Status;
    get_real: "fmi2GetReal" => fn(Component, *const Vr, usize, *mut c_double) -> Status;
    get_integer: "fmi2GetInteger" => fn(Component, *const Vr, usize, *mut c_int) -> Status;
    get_boolean: "fmi2GetBoolean" => fn(Component, *const Vr, usize, *mut c_int) -> Status;
    get_string: "fmi2GetString" => fn(Component, *const Vr, usize, *mut CStrPtr) -> Status;
    set_real: "fmi2SetReal" => fn(Component, *const Vr, usize, *const c_double) -> Status;
    set_integer: "fmi2SetInteger" => fn(Component, *const Vr, usize, *const c_int) -> Status;
    set_boolean: "fmi2SetBoolean" => fn(Component, *const Vr, usize, *const c_int) -> Status;
    set_string: "fmi2SetString" => fn(Component, *const Vr, usize, *const CStrPtr) -> Status;
    get_fmu_state: "fmi2GetFMUstate" => fn(Component, *mut FmuState) -> Status;
    set_fmu_state: "fmi2SetFMUstate" => fn(Component, FmuState) -> Status;
    free_fmu_state: "fmi2FreeFMUstate" => fn(Component, *mut FmuState) -> Status;
    serialized_fmu_state_size: "fmi2SerializedFMUstateSize" => fn(Component, FmuState, *mut usize) -> Status;
    serialize_fmu_state: "fmi2SerializeFMUstate" => fn(Component, FmuState, *mut c_char, usize) -> Status;
    deserialize_fmu_state: "fmi2DeSerializeFMUstate" =>
        fn(Component, *const c_char, usize, *mut FmuState) -> Status;
    get_directional_derivative: "fmi2GetDirectionalDerivative" =>
        fn(Component, *const Vr, usize, *const Vr, usize, *const c_double, *mut c_double) -> Status;
    // Co-simulation (9).
    set_real_input_derivatives: "fmi2SetRealInputDerivatives" =>
        fn(Component, *const Vr, usize, *const c_int, *const c_double) -> Status;
    get_real_output_derivatives: "fmi2GetRealOutputDerivatives" =>
        fn(Component, *const Vr, usize, *const c_int, *mut c_double) -> Status;
    do_step: "fmi2DoStep" => fn(Component, c_double, c_double, c_int) -> Status;
    cancel_step: "fmi2CancelStep" => fn(Component) -> Status;
    get_status: "fmi2GetStatus" => fn(Component, c_int, *mut Status) -> Status;
    get_real_status: "fmi2GetRealStatus" => fn(Component, c_int, *mut c_double) -> Status;
    get_integer_status: "fmi2GetIntegerStatus" => fn(Component, c_int, *mut c_int) -> Status;
    get_boolean_status: "fmi2GetBooleanStatus" => fn(Component, c_int, *mut c_int) -> Status;
    get_string_status: "fmi2GetStringStatus" => fn(Component, c_int, *mut CStrPtr) -> Status;
}

impl std::fmt::Debug for Fmi2Functions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Fmi2Functions").finish_non_exhaustive()
    }
}

/// Everything instances share: kept alive by an `Arc` until the last instance is dropped, so an
/// [`Instance`] may outlive the [`Fmu`] it came from.
pub(crate) struct FmuShared {
    pub(crate) functions: Fmi2Functions,
    pub(crate) model: ModelDescription,
    /// The unpacked FMU directory (absolute).
    pub(crate) dir: PathBuf,
    /// `file:` URI of `<dir>/resources/` passed as `fmuResourceLocation`.
    pub(crate) resource_location: String,
    pub(crate) binary: PathBuf,
    // Field order = drop order: unload the library before deleting the unzip directory.
    _library: libloading::Library,
    _temp_dir: Option<tempfile::TempDir>,
}

/// A loaded FMI 2.0 co-simulation FMU: its model description and its binary with all 34 functions.
///
/// Cheap to clone (shared). Instances keep the binary and the unzip directory alive.
#[derive(Clone)]
pub struct Fmu {
    pub(crate) shared: Arc<FmuShared>,
}

impl std::fmt::Debug for Fmu {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Fmu")
            .field("model", &self.shared.model.model_name)
            .field("dir", &self.shared.dir)
            .field("binary", &self.shared.binary)
            .finish_non_exhaustive()
    }
}

impl Fmu {
    /// Unzips the `.fmu` at `path` into a temporary directory owned by the returned value (deleted when it
    /// and all its instances are dropped) and loads it as [`Fmu::from_dir`] does.
    ///
    /// Entries with `..`, absolute paths, `\`, or links are refused.
    pub fn load(path: impl AsRef<Path>) -> Result<Fmu> {
        let path = path.as_ref();
        let temp = tempfile::Builder::new()
            .prefix("osiris-fmu-")
            .tempdir()
            .map_err(|source| MasterError::Io {
                action: "create a temporary directory for",
                path: path.to_owned(),
                source,
            })?;
        unzip(path, temp.path())?;
        let dir = temp.path().to_owned();
        Self::open(&dir, Some(temp), path)
    }

    /// Loads an unpacked FMU directory (`modelDescription.xml`, `binaries/linux64/<modelIdentifier>.so`,
    /// optional `resources/`). The directory must outlive the returned value and its instances.
    pub fn from_dir(dir: impl AsRef<Path>) -> Result<Fmu> {
        let dir = dir.as_ref();
        Self::open(dir, None, dir)
    }

    fn open(dir: &Path, temp: Option<tempfile::TempDir>, origin: &Path) -> Result<Fmu> {
        let dir = std::path::absolute(dir).map_err(|source| MasterError::Io {
            action: "resolve the FMU directory",
            path: dir.to_owned(),
            source,
        })?;
        let md_path = dir.join("modelDescription.xml");
        if !md_path.is_file() {
            return Err(MasterError::MissingFile {
                fmu: origin.to_owned(),
                expected: "modelDescription.xml".into(),
                what: "the model description at the FMU root",
            });
        }
        let xml = std::fs::read_to_string(&md_path).map_err(|source| MasterError::Io {
            action: "read",
            path: md_path.clone(),
            source,
        })?;
        let file_label = if temp.is_some() {
            format!("{}!/modelDescription.xml", origin.display())
        } else {
            md_path.display().to_string()
        };
        let model = ModelDescription::parse_named(&xml, &file_label)?;

        let rel_binary = PathBuf::from("binaries")
            .join(platform_folder())
            .join(format!("{}.so", model.co_simulation.model_identifier));
        let binary = dir.join(&rel_binary);
        if !binary.is_file() {
            return Err(MasterError::MissingFile {
                fmu: origin.to_owned(),
                expected: rel_binary,
                what: "the binary for this platform, named after the CoSimulation modelIdentifier",
            });
        }
        let resources = dir.join("resources");
        let resource_location = url::Url::from_directory_path(&resources)
            .map_err(|()| MasterError::Io {
                action: "build a file: URI for",
                path: resources.clone(),
                source: std::io::Error::new(
                    std::io::ErrorKind::InvalidInput,
                    "not an absolute path",
                ),
            })?
            .to_string();

        // SAFETY: loading runs the library's initialisers; an FMU binary is trusted code by nature.
        let library = unsafe { libloading::Library::new(&binary) }.map_err(|source| {
            MasterError::LoadLibrary {
                path: binary.clone(),
                source,
            }
        })?;
        // SAFETY: the binary claims to be an FMI 2.0 FMU (modelDescription.xml), so its exports have the
        // FMI 2.0 signatures; the pointers live as long as `library`, which `FmuShared` owns.
        let functions = unsafe { Fmi2Functions::resolve(&library, &binary)? };
        check_static_string(
            &binary,
            "fmi2GetVersion",
            unsafe { (functions.get_version)() },
            "2.0",
        )?;
        check_static_string(
            &binary,
            "fmi2GetTypesPlatform",
            unsafe { (functions.get_types_platform)() },
            "default",
        )?;

        Ok(Fmu {
            shared: Arc::new(FmuShared {
                functions,
                model,
                dir,
                resource_location,
                binary,
                _library: library,
                _temp_dir: temp,
            }),
        })
    }

    /// The parsed model description.
    pub fn model_description(&self) -> &ModelDescription {
        &self.shared.model
    }

    /// The unpacked FMU directory (absolute).
    pub fn dir(&self) -> &Path {
        &self.shared.dir
    }

    /// The loaded binary.
    pub fn binary_path(&self) -> &Path {
        &self.shared.binary
    }

    /// The `fmuResourceLocation` URI passed to `fmi2Instantiate` (`file:///…/resources/`).
    pub fn resource_location(&self) -> &str {
        &self.shared.resource_location
    }

    /// The raw function table, for calls the safe wrapper does not cover.
    pub fn functions(&self) -> &Fmi2Functions {
        &self.shared.functions
    }

    /// `fmi2Instantiate` as a co-simulation slave; see [`Instance`].
    pub fn instantiate(&self, name: &str, options: InstanceOptions) -> Result<Instance> {
        Instance::new(self, name, options)
    }
}

fn platform_folder() -> &'static str {
    match (std::env::consts::OS, std::env::consts::ARCH) {
        ("linux", "x86") => "linux32",
        ("macos", _) => "darwin64",
        ("windows", "x86_64") => "win64",
        _ => "linux64",
    }
}

fn check_static_string(
    path: &Path,
    function: &'static str,
    ptr: *const c_char,
    expected: &'static str,
) -> Result<()> {
    let found = if ptr.is_null() {
        "NULL".to_owned()
    } else {
        // SAFETY: FMI 2.0 requires a pointer to a static NUL-terminated string.
        unsafe { CStr::from_ptr(ptr) }
            .to_string_lossy()
            .into_owned()
    };
    if found == expected {
        Ok(())
    } else {
        Err(MasterError::BinaryMismatch {
            path: path.to_owned(),
            function,
            found,
            expected,
        })
    }
}

/// Extracts `fmu` into `dest`, refusing entries that would escape it or that FMI 2.0 forbids.
fn unzip(fmu: &Path, dest: &Path) -> Result<()> {
    let file = File::open(fmu).map_err(|source| MasterError::Io {
        action: "open FMU",
        path: fmu.to_owned(),
        source,
    })?;
    let zip_err = |source| MasterError::Zip {
        path: fmu.to_owned(),
        source,
    };
    let mut archive = zip::ZipArchive::new(std::io::BufReader::new(file)).map_err(zip_err)?;
    for i in 0..archive.len() {
        let mut entry = archive.by_index(i).map_err(zip_err)?;
        let name = entry.name().to_owned();
        let unsafe_entry = |reason| MasterError::UnsafeZipEntry {
            path: fmu.to_owned(),
            entry: name.clone(),
            reason,
        };
        if name.contains('\\') {
            return Err(unsafe_entry(
                "backslash in path (FMI 2.0 §2.3 requires `/`)",
            ));
        }
        let rel = Path::new(&name);
        if rel.is_absolute() || name.starts_with('/') {
            return Err(unsafe_entry("absolute path"));
        }
        if rel
            .components()
            .any(|c| !matches!(c, PathComponent::Normal(_) | PathComponent::CurDir))
        {
            return Err(unsafe_entry(
                "path component `..` escapes the extraction directory",
            ));
        }
        if entry.enclosed_name().is_none() {
            return Err(unsafe_entry("path escapes the extraction directory"));
        }
        if entry.is_symlink() {
            return Err(unsafe_entry("links are not allowed in an FMU"));
        }
        if entry.encrypted() {
            return Err(unsafe_entry("encrypted entries are not allowed in an FMU"));
        }
        let target = dest.join(rel);
        let io_err = |action, path: &Path| {
            let path = path.to_owned();
            move |source| MasterError::Io {
                action,
                path,
                source,
            }
        };
        if entry.is_dir() {
            std::fs::create_dir_all(&target).map_err(io_err("create directory", &target))?;
            continue;
        }
        if let Some(parent) = target.parent() {
            std::fs::create_dir_all(parent).map_err(io_err("create directory", parent))?;
        }
        let mut out = File::create(&target).map_err(io_err("create", &target))?;
        std::io::copy(&mut entry, &mut out).map_err(io_err("extract", &target))?;
    }
    Ok(())
}
