//! The FMI 2.0 co-simulation shell shared by every osiris FMU, with OSMP 1.6.0 packaging.
//!
//! Model code never sees FMI: an instance of a sensor FMU drives a
//! `Box<dyn osiris_models::SensorModel>` (SensorView in, SensorData out), an instance of a source
//! FMU a `Box<dyn ViewSource>` (nothing in, SensorView out), each built from its parameters; the
//! descriptor's [`descriptor::Role`] says which. This crate is a normal rlib without exported
//! symbols; each cdylib crate (`fmu/camera`, `fmu/radar`, `fmu/lidar`, `fmu/scenario`) invokes
//! [`export_fmi2!`] once to generate the 34 `fmi2*` C entry points over the generic functions of
//! [`abi`].
//!
//! * [`abi`]: the 34 functions as `unsafe fn`s over raw C types (callable in-process by tests).
//! * [`ffi`]: the FMI 2.0 C types.
//! * [`variables`]: the variable table (value references are a contract, see there).
//! * [`descriptor`]: [`FmuDescriptor`], what distinguishes one FMU from another (its role: sensor
//!   or SensorView source).
//! * [`sensors`]: the camera, radar and LiDAR descriptors.
//! * [`sources`]: the scenario player's descriptor (`scenario.fmu`).
//! * [`model_description`]: renders `modelDescription.xml` (deterministic GUID).
//! * [`logging`]: log categories and the `"%s"`-only logger call.
//! * [`osmp`]: OSMP address packing.

pub mod abi;
pub mod descriptor;
pub mod ffi;
mod instance;
pub mod logging;
pub mod model_description;
pub mod osmp;
pub mod sensors;
pub mod sources;
pub mod variables;

pub use descriptor::{FmuDescriptor, Role, ViewSource};
pub use instance::State;

/// Generate the 34 FMI 2.0 co-simulation exports (`#[unsafe(no_mangle)] extern "C" fn fmi2...`)
/// of one FMU binary. `$desc` is an expression of type `&'static FmuDescriptor`, evaluated on each
/// `fmi2Instantiate`. Invoke it exactly once, in a `cdylib` crate:
///
/// ```ignore
/// osiris_fmu::export_fmi2!(&osiris_fmu::sensors::radar::DESCRIPTOR);
/// ```
#[macro_export]
macro_rules! export_fmi2 {
    ($desc:expr) => {
        #[doc(hidden)]
        fn __osiris_fmu_descriptor() -> &'static $crate::FmuDescriptor {
            $desc
        }

        #[doc(hidden)]
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        pub mod __osiris_fmi2_exports {
            use ::std::ffi::c_char;
            use $crate::abi;
            use $crate::ffi::*;

            #[unsafe(no_mangle)]
            pub extern "C" fn fmi2GetTypesPlatform() -> *const c_char {
                abi::get_types_platform()
            }

            #[unsafe(no_mangle)]
            pub extern "C" fn fmi2GetVersion() -> *const c_char {
                abi::get_version()
            }

            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2SetDebugLogging(
                c: Fmi2Component,
                logging_on: Fmi2Boolean,
                n_categories: usize,
                categories: *const Fmi2String,
            ) -> Fmi2Status {
                unsafe { abi::set_debug_logging(c, logging_on, n_categories, categories) }
            }

            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2Instantiate(
                instance_name: Fmi2String,
                fmu_type: Fmi2Type,
                fmu_guid: Fmi2String,
                fmu_resource_location: Fmi2String,
                functions: *const Fmi2CallbackFunctions,
                visible: Fmi2Boolean,
                logging_on: Fmi2Boolean,
            ) -> Fmi2Component {
                // A panic in the descriptor expression must not unwind into C.
                let desc = match ::std::panic::catch_unwind(super::__osiris_fmu_descriptor) {
                    Ok(desc) => desc,
                    Err(_) => return ::std::ptr::null_mut(),
                };
                unsafe {
                    abi::instantiate(
                        desc,
                        instance_name,
                        fmu_type,
                        fmu_guid,
                        fmu_resource_location,
                        functions,
                        visible,
                        logging_on,
                    )
                }
            }

            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2FreeInstance(c: Fmi2Component) {
                unsafe { abi::free_instance(c) }
            }

            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2SetupExperiment(
                c: Fmi2Component,
                tolerance_defined: Fmi2Boolean,
                tolerance: Fmi2Real,
                start_time: Fmi2Real,
                stop_time_defined: Fmi2Boolean,
                stop_time: Fmi2Real,
            ) -> Fmi2Status {
                unsafe {
                    abi::setup_experiment(
                        c,
                        tolerance_defined,
                        tolerance,
                        start_time,
                        stop_time_defined,
                        stop_time,
                    )
                }
            }

            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2EnterInitializationMode(c: Fmi2Component) -> Fmi2Status {
                unsafe { abi::enter_initialization_mode(c) }
            }

            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2ExitInitializationMode(c: Fmi2Component) -> Fmi2Status {
                unsafe { abi::exit_initialization_mode(c) }
            }

            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2Terminate(c: Fmi2Component) -> Fmi2Status {
                unsafe { abi::terminate(c) }
            }

            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2Reset(c: Fmi2Component) -> Fmi2Status {
                unsafe { abi::reset(c) }
            }

            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2GetReal(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                nvr: usize,
                value: *mut Fmi2Real,
            ) -> Fmi2Status {
                unsafe { abi::get_real(c, vr, nvr, value) }
            }

            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2GetInteger(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                nvr: usize,
                value: *mut Fmi2Integer,
            ) -> Fmi2Status {
                unsafe { abi::get_integer(c, vr, nvr, value) }
            }

            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2GetBoolean(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                nvr: usize,
                value: *mut Fmi2Boolean,
            ) -> Fmi2Status {
                unsafe { abi::get_boolean(c, vr, nvr, value) }
            }

            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2GetString(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                nvr: usize,
                value: *mut Fmi2String,
            ) -> Fmi2Status {
                unsafe { abi::get_string(c, vr, nvr, value) }
            }

            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2SetReal(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                nvr: usize,
                value: *const Fmi2Real,
            ) -> Fmi2Status {
                unsafe { abi::set_real(c, vr, nvr, value) }
            }

            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2SetInteger(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                nvr: usize,
                value: *const Fmi2Integer,
            ) -> Fmi2Status {
                unsafe { abi::set_integer(c, vr, nvr, value) }
            }

            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2SetBoolean(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                nvr: usize,
                value: *const Fmi2Boolean,
            ) -> Fmi2Status {
                unsafe { abi::set_boolean(c, vr, nvr, value) }
            }

            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2SetString(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                nvr: usize,
                value: *const Fmi2String,
            ) -> Fmi2Status {
                unsafe { abi::set_string(c, vr, nvr, value) }
            }

            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2GetFMUstate(
                c: Fmi2Component,
                fmu_state: *mut Fmi2FmuState,
            ) -> Fmi2Status {
                unsafe { abi::get_fmu_state(c, fmu_state) }
            }

            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2SetFMUstate(
                c: Fmi2Component,
                fmu_state: Fmi2FmuState,
            ) -> Fmi2Status {
                unsafe { abi::set_fmu_state(c, fmu_state) }
            }

            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2FreeFMUstate(
                c: Fmi2Component,
                fmu_state: *mut Fmi2FmuState,
            ) -> Fmi2Status {
                unsafe { abi::free_fmu_state(c, fmu_state) }
            }

            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2SerializedFMUstateSize(
                c: Fmi2Component,
                fmu_state: Fmi2FmuState,
                size: *mut usize,
            ) -> Fmi2Status {
                unsafe { abi::serialized_fmu_state_size(c, fmu_state, size) }
            }

            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2SerializeFMUstate(
                c: Fmi2Component,
                fmu_state: Fmi2FmuState,
                serialized_state: *mut Fmi2Byte,
                size: usize,
            ) -> Fmi2Status {
                unsafe { abi::serialize_fmu_state(c, fmu_state, serialized_state, size) }
            }

            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2DeSerializeFMUstate(
                c: Fmi2Component,
                serialized_state: *const Fmi2Byte,
                size: usize,
                fmu_state: *mut Fmi2FmuState,
            ) -> Fmi2Status {
                unsafe { abi::deserialize_fmu_state(c, serialized_state, size, fmu_state) }
            }

            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2GetDirectionalDerivative(
                c: Fmi2Component,
                v_unknown_ref: *const Fmi2ValueReference,
                n_unknown: usize,
                v_known_ref: *const Fmi2ValueReference,
                n_known: usize,
                dv_known: *const Fmi2Real,
                dv_unknown: *mut Fmi2Real,
            ) -> Fmi2Status {
                unsafe {
                    abi::get_directional_derivative(
                        c,
                        v_unknown_ref,
                        n_unknown,
                        v_known_ref,
                        n_known,
                        dv_known,
                        dv_unknown,
                    )
                }
            }

            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2SetRealInputDerivatives(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                nvr: usize,
                order: *const Fmi2Integer,
                value: *const Fmi2Real,
            ) -> Fmi2Status {
                unsafe { abi::set_real_input_derivatives(c, vr, nvr, order, value) }
            }

            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2GetRealOutputDerivatives(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                nvr: usize,
                order: *const Fmi2Integer,
                value: *mut Fmi2Real,
            ) -> Fmi2Status {
                unsafe { abi::get_real_output_derivatives(c, vr, nvr, order, value) }
            }

            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2DoStep(
                c: Fmi2Component,
                current_communication_point: Fmi2Real,
                communication_step_size: Fmi2Real,
                no_set_fmu_state_prior_to_current_point: Fmi2Boolean,
            ) -> Fmi2Status {
                unsafe {
                    abi::do_step(
                        c,
                        current_communication_point,
                        communication_step_size,
                        no_set_fmu_state_prior_to_current_point,
                    )
                }
            }

            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2CancelStep(c: Fmi2Component) -> Fmi2Status {
                unsafe { abi::cancel_step(c) }
            }

            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2GetStatus(
                c: Fmi2Component,
                s: Fmi2StatusKind,
                value: *mut Fmi2Status,
            ) -> Fmi2Status {
                unsafe { abi::get_status(c, s, value) }
            }

            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2GetRealStatus(
                c: Fmi2Component,
                s: Fmi2StatusKind,
                value: *mut Fmi2Real,
            ) -> Fmi2Status {
                unsafe { abi::get_real_status(c, s, value) }
            }

            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2GetIntegerStatus(
                c: Fmi2Component,
                s: Fmi2StatusKind,
                value: *mut Fmi2Integer,
            ) -> Fmi2Status {
                unsafe { abi::get_integer_status(c, s, value) }
            }

            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2GetBooleanStatus(
                c: Fmi2Component,
                s: Fmi2StatusKind,
                value: *mut Fmi2Boolean,
            ) -> Fmi2Status {
                unsafe { abi::get_boolean_status(c, s, value) }
            }

            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2GetStringStatus(
                c: Fmi2Component,
                s: Fmi2StatusKind,
                value: *mut Fmi2String,
            ) -> Fmi2Status {
                unsafe { abi::get_string_status(c, s, value) }
            }
        }
    };
}
