//! [`crate::export_fmi3!`]: the FMI 3.0 symbols of an FMU's cdylib.

/// Defines every FMI 3.0 function a Co-Simulation FMU exports for `$model` as a C symbol of the
/// crate that expands it, beside [`crate::export_fmi2!`]'s (the prefixes differ, so one library
/// serves an FMI 2 and an FMI 3 archive). Every function of `fmi3Functions.h` is exported, since
/// importers such as fmpy bind them all when they load the library: the Model Exchange and
/// Scheduled Execution instantiation functions refuse with a log line and return NULL; functions
/// of capabilities the model description does not declare answer `fmi3Error`
/// ([`crate::api3::not_declared`]).
#[macro_export]
macro_rules! export_fmi3 {
    ($model:ty) => {
        /// FMI 3.0 `fmi3GetVersion`.
        #[no_mangle]
        pub extern "C" fn fmi3GetVersion() -> *const ::std::ffi::c_char {
            $crate::api3::get_version()
        }

        /// FMI 3.0 `fmi3SetDebugLogging`.
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3SetDebugLogging(
            instance: $crate::ffi3::Fmi3Instance,
            logging_on: $crate::ffi3::Fmi3Boolean,
            n_categories: usize,
            categories: *const $crate::ffi3::Fmi3String,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                $crate::api::set_debug_logging_as::<$model>(
                    "fmi3SetDebugLogging",
                    instance,
                    logging_on != 0,
                    n_categories,
                    categories,
                )
            }
        }

        /// FMI 3.0 `fmi3InstantiateCoSimulation`.
        ///
        /// # Safety
        /// The strings are null or NUL-terminated; the callbacks are null or the master's.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3InstantiateCoSimulation(
            instance_name: $crate::ffi3::Fmi3String,
            instantiation_token: $crate::ffi3::Fmi3String,
            resource_path: $crate::ffi3::Fmi3String,
            visible: $crate::ffi3::Fmi3Boolean,
            logging_on: $crate::ffi3::Fmi3Boolean,
            event_mode_used: $crate::ffi3::Fmi3Boolean,
            early_return_allowed: $crate::ffi3::Fmi3Boolean,
            required_intermediate_variables: *const $crate::ffi3::Fmi3ValueReference,
            n_required_intermediate_variables: usize,
            instance_environment: $crate::ffi3::Fmi3InstanceEnvironment,
            log_message: $crate::ffi3::Fmi3LogMessageCallback,
            intermediate_update: $crate::ffi3::Fmi3IntermediateUpdateCallback,
        ) -> $crate::ffi3::Fmi3Instance {
            unsafe {
                let _ = (
                    visible,
                    early_return_allowed,
                    required_intermediate_variables,
                    n_required_intermediate_variables,
                    intermediate_update,
                );
                $crate::api3::instantiate_co_simulation::<$model>(
                    instance_name,
                    instantiation_token,
                    resource_path,
                    logging_on,
                    event_mode_used,
                    instance_environment,
                    log_message,
                )
            }
        }

        /// FMI 3.0 `fmi3InstantiateModelExchange` (Co-Simulation only: logs and returns NULL).
        ///
        /// # Safety
        /// The strings are null or NUL-terminated; the callback is null or the master's.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3InstantiateModelExchange(
            instance_name: $crate::ffi3::Fmi3String,
            instantiation_token: $crate::ffi3::Fmi3String,
            resource_path: $crate::ffi3::Fmi3String,
            visible: $crate::ffi3::Fmi3Boolean,
            logging_on: $crate::ffi3::Fmi3Boolean,
            instance_environment: $crate::ffi3::Fmi3InstanceEnvironment,
            log_message: $crate::ffi3::Fmi3LogMessageCallback,
        ) -> $crate::ffi3::Fmi3Instance {
            unsafe {
                let _ = (instantiation_token, resource_path, visible, logging_on);
                $crate::api3::instantiate_other::<$model>(
                    "fmi3InstantiateModelExchange",
                    instance_name,
                    instance_environment,
                    log_message,
                )
            }
        }

        /// FMI 3.0 `fmi3InstantiateScheduledExecution` (Co-Simulation only: logs and returns NULL).
        ///
        /// # Safety
        /// The strings are null or NUL-terminated; the callback is null or the master's.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3InstantiateScheduledExecution(
            instance_name: $crate::ffi3::Fmi3String,
            instantiation_token: $crate::ffi3::Fmi3String,
            resource_path: $crate::ffi3::Fmi3String,
            visible: $crate::ffi3::Fmi3Boolean,
            logging_on: $crate::ffi3::Fmi3Boolean,
            instance_environment: $crate::ffi3::Fmi3InstanceEnvironment,
            log_message: $crate::ffi3::Fmi3LogMessageCallback,
            clock_update: $crate::ffi3::Fmi3ClockUpdateCallback,
            lock_preemption: $crate::ffi3::Fmi3PreemptionCallback,
            unlock_preemption: $crate::ffi3::Fmi3PreemptionCallback,
        ) -> $crate::ffi3::Fmi3Instance {
            unsafe {
                let _ = (
                    instantiation_token,
                    resource_path,
                    visible,
                    logging_on,
                    clock_update,
                    lock_preemption,
                    unlock_preemption,
                );
                $crate::api3::instantiate_other::<$model>(
                    "fmi3InstantiateScheduledExecution",
                    instance_name,
                    instance_environment,
                    log_message,
                )
            }
        }

        /// FMI 3.0 `fmi3FreeInstance`.
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU, not used afterwards.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3FreeInstance(instance: $crate::ffi3::Fmi3Instance) {
            unsafe { $crate::api::free_instance_as::<$model>("fmi3FreeInstance", instance) }
        }

        /// FMI 3.0 `fmi3EnterInitializationMode`.
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3EnterInitializationMode(
            instance: $crate::ffi3::Fmi3Instance,
            tolerance_defined: $crate::ffi3::Fmi3Boolean,
            tolerance: f64,
            start_time: f64,
            stop_time_defined: $crate::ffi3::Fmi3Boolean,
            stop_time: f64,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = (tolerance_defined, tolerance);
                $crate::api3::enter_initialization_mode::<$model>(
                    instance,
                    start_time,
                    stop_time_defined,
                    stop_time,
                )
            }
        }

        /// FMI 3.0 `fmi3ExitInitializationMode`.
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3ExitInitializationMode(
            instance: $crate::ffi3::Fmi3Instance,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe { $crate::api3::exit_initialization_mode::<$model>(instance) }
        }

        /// FMI 3.0 `fmi3Terminate`.
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3Terminate(
            instance: $crate::ffi3::Fmi3Instance,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe { $crate::api3::terminate::<$model>(instance) }
        }

        /// FMI 3.0 `fmi3Reset`.
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3Reset(
            instance: $crate::ffi3::Fmi3Instance,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe { $crate::api3::reset::<$model>(instance) }
        }

        /// FMI 3.0 `fmi3GetFloat64`.
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3GetFloat64(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            values: *mut f64,
            n_values: usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe { $crate::api3::get_float64::<$model>(instance, vr, nvr, values, n_values) }
        }

        /// FMI 3.0 `fmi3SetFloat64`.
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3SetFloat64(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            values: *const f64,
            n_values: usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe { $crate::api3::set_float64::<$model>(instance, vr, nvr, values, n_values) }
        }

        /// FMI 3.0 `fmi3GetInt32`.
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3GetInt32(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            values: *mut i32,
            n_values: usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe { $crate::api3::get_int32::<$model>(instance, vr, nvr, values, n_values) }
        }

        /// FMI 3.0 `fmi3SetInt32`.
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3SetInt32(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            values: *const i32,
            n_values: usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe { $crate::api3::set_int32::<$model>(instance, vr, nvr, values, n_values) }
        }

        /// FMI 3.0 `fmi3GetInt64`.
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3GetInt64(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            values: *mut i64,
            n_values: usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe { $crate::api3::get_int64::<$model>(instance, vr, nvr, values, n_values) }
        }

        /// FMI 3.0 `fmi3SetInt64`.
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3SetInt64(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            values: *const i64,
            n_values: usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe { $crate::api3::set_int64::<$model>(instance, vr, nvr, values, n_values) }
        }

        /// FMI 3.0 `fmi3GetBoolean`.
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3GetBoolean(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            values: *mut $crate::ffi3::Fmi3Boolean,
            n_values: usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe { $crate::api3::get_boolean::<$model>(instance, vr, nvr, values, n_values) }
        }

        /// FMI 3.0 `fmi3SetBoolean`.
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3SetBoolean(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            values: *const $crate::ffi3::Fmi3Boolean,
            n_values: usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe { $crate::api3::set_boolean::<$model>(instance, vr, nvr, values, n_values) }
        }

        /// FMI 3.0 `fmi3GetFloat32` (no variable of this type).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3GetFloat32(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            values: *mut f32,
            n_values: usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = n_values;
                $crate::api3::no_variables_of_type::<$model>(
                    instance,
                    "fmi3GetFloat32",
                    $crate::api3::Fmi3Type::Float32,
                    false,
                    vr,
                    nvr,
                    values.is_null(),
                )
            }
        }

        /// FMI 3.0 `fmi3SetFloat32` (no variable of this type).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3SetFloat32(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            values: *const f32,
            n_values: usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = n_values;
                $crate::api3::no_variables_of_type::<$model>(
                    instance,
                    "fmi3SetFloat32",
                    $crate::api3::Fmi3Type::Float32,
                    true,
                    vr,
                    nvr,
                    values.is_null(),
                )
            }
        }

        /// FMI 3.0 `fmi3GetInt8` (no variable of this type).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3GetInt8(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            values: *mut i8,
            n_values: usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = n_values;
                $crate::api3::no_variables_of_type::<$model>(
                    instance,
                    "fmi3GetInt8",
                    $crate::api3::Fmi3Type::Int8,
                    false,
                    vr,
                    nvr,
                    values.is_null(),
                )
            }
        }

        /// FMI 3.0 `fmi3SetInt8` (no variable of this type).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3SetInt8(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            values: *const i8,
            n_values: usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = n_values;
                $crate::api3::no_variables_of_type::<$model>(
                    instance,
                    "fmi3SetInt8",
                    $crate::api3::Fmi3Type::Int8,
                    true,
                    vr,
                    nvr,
                    values.is_null(),
                )
            }
        }

        /// FMI 3.0 `fmi3GetUInt8` (no variable of this type).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3GetUInt8(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            values: *mut u8,
            n_values: usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = n_values;
                $crate::api3::no_variables_of_type::<$model>(
                    instance,
                    "fmi3GetUInt8",
                    $crate::api3::Fmi3Type::UInt8,
                    false,
                    vr,
                    nvr,
                    values.is_null(),
                )
            }
        }

        /// FMI 3.0 `fmi3SetUInt8` (no variable of this type).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3SetUInt8(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            values: *const u8,
            n_values: usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = n_values;
                $crate::api3::no_variables_of_type::<$model>(
                    instance,
                    "fmi3SetUInt8",
                    $crate::api3::Fmi3Type::UInt8,
                    true,
                    vr,
                    nvr,
                    values.is_null(),
                )
            }
        }

        /// FMI 3.0 `fmi3GetInt16` (no variable of this type).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3GetInt16(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            values: *mut i16,
            n_values: usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = n_values;
                $crate::api3::no_variables_of_type::<$model>(
                    instance,
                    "fmi3GetInt16",
                    $crate::api3::Fmi3Type::Int16,
                    false,
                    vr,
                    nvr,
                    values.is_null(),
                )
            }
        }

        /// FMI 3.0 `fmi3SetInt16` (no variable of this type).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3SetInt16(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            values: *const i16,
            n_values: usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = n_values;
                $crate::api3::no_variables_of_type::<$model>(
                    instance,
                    "fmi3SetInt16",
                    $crate::api3::Fmi3Type::Int16,
                    true,
                    vr,
                    nvr,
                    values.is_null(),
                )
            }
        }

        /// FMI 3.0 `fmi3GetUInt16` (no variable of this type).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3GetUInt16(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            values: *mut u16,
            n_values: usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = n_values;
                $crate::api3::no_variables_of_type::<$model>(
                    instance,
                    "fmi3GetUInt16",
                    $crate::api3::Fmi3Type::UInt16,
                    false,
                    vr,
                    nvr,
                    values.is_null(),
                )
            }
        }

        /// FMI 3.0 `fmi3SetUInt16` (no variable of this type).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3SetUInt16(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            values: *const u16,
            n_values: usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = n_values;
                $crate::api3::no_variables_of_type::<$model>(
                    instance,
                    "fmi3SetUInt16",
                    $crate::api3::Fmi3Type::UInt16,
                    true,
                    vr,
                    nvr,
                    values.is_null(),
                )
            }
        }

        /// FMI 3.0 `fmi3GetUInt32` (no variable of this type).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3GetUInt32(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            values: *mut u32,
            n_values: usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = n_values;
                $crate::api3::no_variables_of_type::<$model>(
                    instance,
                    "fmi3GetUInt32",
                    $crate::api3::Fmi3Type::UInt32,
                    false,
                    vr,
                    nvr,
                    values.is_null(),
                )
            }
        }

        /// FMI 3.0 `fmi3SetUInt32` (no variable of this type).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3SetUInt32(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            values: *const u32,
            n_values: usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = n_values;
                $crate::api3::no_variables_of_type::<$model>(
                    instance,
                    "fmi3SetUInt32",
                    $crate::api3::Fmi3Type::UInt32,
                    true,
                    vr,
                    nvr,
                    values.is_null(),
                )
            }
        }

        /// FMI 3.0 `fmi3GetUInt64` (no variable of this type).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3GetUInt64(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            values: *mut u64,
            n_values: usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = n_values;
                $crate::api3::no_variables_of_type::<$model>(
                    instance,
                    "fmi3GetUInt64",
                    $crate::api3::Fmi3Type::UInt64,
                    false,
                    vr,
                    nvr,
                    values.is_null(),
                )
            }
        }

        /// FMI 3.0 `fmi3SetUInt64` (no variable of this type).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3SetUInt64(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            values: *const u64,
            n_values: usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = n_values;
                $crate::api3::no_variables_of_type::<$model>(
                    instance,
                    "fmi3SetUInt64",
                    $crate::api3::Fmi3Type::UInt64,
                    true,
                    vr,
                    nvr,
                    values.is_null(),
                )
            }
        }

        /// FMI 3.0 `fmi3GetString` (no variable of this type).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3GetString(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            values: *mut $crate::ffi3::Fmi3String,
            n_values: usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = n_values;
                $crate::api3::no_variables_of_type::<$model>(
                    instance,
                    "fmi3GetString",
                    $crate::api3::Fmi3Type::String,
                    false,
                    vr,
                    nvr,
                    values.is_null(),
                )
            }
        }

        /// FMI 3.0 `fmi3SetString` (no variable of this type).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3SetString(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            values: *const $crate::ffi3::Fmi3String,
            n_values: usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = n_values;
                $crate::api3::no_variables_of_type::<$model>(
                    instance,
                    "fmi3SetString",
                    $crate::api3::Fmi3Type::String,
                    true,
                    vr,
                    nvr,
                    values.is_null(),
                )
            }
        }

        /// FMI 3.0 `fmi3GetBinary` (no variable of this type).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3GetBinary(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            value_sizes: *mut usize,
            values: *mut $crate::ffi3::Fmi3Binary,
            n_values: usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = (value_sizes, n_values);
                $crate::api3::no_variables_of_type::<$model>(
                    instance,
                    "fmi3GetBinary",
                    $crate::api3::Fmi3Type::Binary,
                    false,
                    vr,
                    nvr,
                    values.is_null(),
                )
            }
        }

        /// FMI 3.0 `fmi3SetBinary` (no variable of this type).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3SetBinary(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            value_sizes: *const usize,
            values: *const $crate::ffi3::Fmi3Binary,
            n_values: usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = (value_sizes, n_values);
                $crate::api3::no_variables_of_type::<$model>(
                    instance,
                    "fmi3SetBinary",
                    $crate::api3::Fmi3Type::Binary,
                    true,
                    vr,
                    nvr,
                    values.is_null(),
                )
            }
        }

        /// FMI 3.0 `fmi3GetClock` (no clocks).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3GetClock(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            values: *mut $crate::ffi3::Fmi3Clock,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                $crate::api3::no_variables_of_type::<$model>(
                    instance,
                    "fmi3GetClock",
                    $crate::api3::Fmi3Type::Clock,
                    false,
                    vr,
                    nvr,
                    values.is_null(),
                )
            }
        }

        /// FMI 3.0 `fmi3SetClock` (no clocks).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3SetClock(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            values: *const $crate::ffi3::Fmi3Clock,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                $crate::api3::no_variables_of_type::<$model>(
                    instance,
                    "fmi3SetClock",
                    $crate::api3::Fmi3Type::Clock,
                    true,
                    vr,
                    nvr,
                    values.is_null(),
                )
            }
        }

        /// FMI 3.0 `fmi3GetNumberOfVariableDependencies`.
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3GetNumberOfVariableDependencies(
            instance: $crate::ffi3::Fmi3Instance,
            vr: $crate::ffi3::Fmi3ValueReference,
            n_dependencies: *mut usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                $crate::api3::get_number_of_variable_dependencies::<$model>(
                    instance,
                    vr,
                    n_dependencies,
                )
            }
        }

        /// FMI 3.0 `fmi3GetVariableDependencies`.
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3GetVariableDependencies(
            instance: $crate::ffi3::Fmi3Instance,
            dependent: $crate::ffi3::Fmi3ValueReference,
            element_indices_of_dependent: *mut usize,
            independents: *mut $crate::ffi3::Fmi3ValueReference,
            element_indices_of_independents: *mut usize,
            dependency_kinds: *mut $crate::ffi3::Fmi3DependencyKind,
            n_dependencies: usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                $crate::api3::get_variable_dependencies::<$model>(
                    instance,
                    dependent,
                    element_indices_of_dependent,
                    independents,
                    element_indices_of_independents,
                    dependency_kinds,
                    n_dependencies,
                )
            }
        }

        /// FMI 3.0 `fmi3GetFMUState`.
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3GetFMUState(
            instance: $crate::ffi3::Fmi3Instance,
            state: *mut $crate::ffi3::Fmi3FmuState,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe { $crate::api3::get_fmu_state::<$model>(instance, state) }
        }

        /// FMI 3.0 `fmi3SetFMUState`.
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3SetFMUState(
            instance: $crate::ffi3::Fmi3Instance,
            state: $crate::ffi3::Fmi3FmuState,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe { $crate::api3::set_fmu_state::<$model>(instance, state) }
        }

        /// FMI 3.0 `fmi3FreeFMUState`.
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3FreeFMUState(
            instance: $crate::ffi3::Fmi3Instance,
            state: *mut $crate::ffi3::Fmi3FmuState,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe { $crate::api3::free_fmu_state::<$model>(instance, state) }
        }

        /// FMI 3.0 `fmi3SerializedFMUStateSize`.
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3SerializedFMUStateSize(
            instance: $crate::ffi3::Fmi3Instance,
            state: $crate::ffi3::Fmi3FmuState,
            size: *mut usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe { $crate::api3::serialized_fmu_state_size::<$model>(instance, state, size) }
        }

        /// FMI 3.0 `fmi3SerializeFMUState`.
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3SerializeFMUState(
            instance: $crate::ffi3::Fmi3Instance,
            state: $crate::ffi3::Fmi3FmuState,
            bytes: *mut $crate::ffi3::Fmi3Byte,
            size: usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe { $crate::api3::serialize_fmu_state::<$model>(instance, state, bytes, size) }
        }

        /// FMI 3.0 `fmi3DeserializeFMUState`.
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3DeserializeFMUState(
            instance: $crate::ffi3::Fmi3Instance,
            bytes: *const $crate::ffi3::Fmi3Byte,
            size: usize,
            state: *mut $crate::ffi3::Fmi3FmuState,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe { $crate::api3::deserialize_fmu_state::<$model>(instance, bytes, size, state) }
        }

        /// FMI 3.0 `fmi3GetDirectionalDerivative` (not declared: fmi3Error).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3GetDirectionalDerivative(
            instance: $crate::ffi3::Fmi3Instance,
            unknowns: *const $crate::ffi3::Fmi3ValueReference,
            n_unknowns: usize,
            knowns: *const $crate::ffi3::Fmi3ValueReference,
            n_knowns: usize,
            seed: *const f64,
            n_seed: usize,
            sensitivity: *mut f64,
            n_sensitivity: usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = (
                    unknowns,
                    n_unknowns,
                    knowns,
                    n_knowns,
                    seed,
                    n_seed,
                    sensitivity,
                    n_sensitivity,
                );
                $crate::api3::not_declared::<$model>(
                    instance,
                    "fmi3GetDirectionalDerivative",
                    "providesDirectionalDerivatives",
                )
            }
        }

        /// FMI 3.0 `fmi3GetAdjointDerivative` (not declared: fmi3Error).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3GetAdjointDerivative(
            instance: $crate::ffi3::Fmi3Instance,
            unknowns: *const $crate::ffi3::Fmi3ValueReference,
            n_unknowns: usize,
            knowns: *const $crate::ffi3::Fmi3ValueReference,
            n_knowns: usize,
            seed: *const f64,
            n_seed: usize,
            sensitivity: *mut f64,
            n_sensitivity: usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = (
                    unknowns,
                    n_unknowns,
                    knowns,
                    n_knowns,
                    seed,
                    n_seed,
                    sensitivity,
                    n_sensitivity,
                );
                $crate::api3::not_declared::<$model>(
                    instance,
                    "fmi3GetAdjointDerivative",
                    "providesAdjointDerivatives",
                )
            }
        }

        /// FMI 3.0 `fmi3EnterConfigurationMode` (not declared: fmi3Error).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3EnterConfigurationMode(
            instance: $crate::ffi3::Fmi3Instance,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                $crate::api3::not_declared::<$model>(
                    instance,
                    "fmi3EnterConfigurationMode",
                    "structural parameters",
                )
            }
        }

        /// FMI 3.0 `fmi3ExitConfigurationMode` (not declared: fmi3Error).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3ExitConfigurationMode(
            instance: $crate::ffi3::Fmi3Instance,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                $crate::api3::not_declared::<$model>(
                    instance,
                    "fmi3ExitConfigurationMode",
                    "structural parameters",
                )
            }
        }

        /// FMI 3.0 `fmi3EnterEventMode` (not declared: fmi3Error).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3EnterEventMode(
            instance: $crate::ffi3::Fmi3Instance,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                $crate::api3::not_declared::<$model>(instance, "fmi3EnterEventMode", "hasEventMode")
            }
        }

        /// FMI 3.0 `fmi3EnterStepMode` (not declared: fmi3Error).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3EnterStepMode(
            instance: $crate::ffi3::Fmi3Instance,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                $crate::api3::not_declared::<$model>(instance, "fmi3EnterStepMode", "hasEventMode")
            }
        }

        /// FMI 3.0 `fmi3EvaluateDiscreteStates` (not declared: fmi3Error).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3EvaluateDiscreteStates(
            instance: $crate::ffi3::Fmi3Instance,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                $crate::api3::not_declared::<$model>(
                    instance,
                    "fmi3EvaluateDiscreteStates",
                    "hasEventMode",
                )
            }
        }

        /// FMI 3.0 `fmi3UpdateDiscreteStates` (not declared: fmi3Error).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3UpdateDiscreteStates(
            instance: $crate::ffi3::Fmi3Instance,
            discrete_states_need_update: *mut $crate::ffi3::Fmi3Boolean,
            terminate_simulation: *mut $crate::ffi3::Fmi3Boolean,
            nominals_changed: *mut $crate::ffi3::Fmi3Boolean,
            values_changed: *mut $crate::ffi3::Fmi3Boolean,
            next_event_time_defined: *mut $crate::ffi3::Fmi3Boolean,
            next_event_time: *mut f64,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = (
                    discrete_states_need_update,
                    terminate_simulation,
                    nominals_changed,
                    values_changed,
                    next_event_time_defined,
                    next_event_time,
                );
                $crate::api3::not_declared::<$model>(
                    instance,
                    "fmi3UpdateDiscreteStates",
                    "hasEventMode",
                )
            }
        }

        /// FMI 3.0 `fmi3GetOutputDerivatives` (maxOutputDerivativeOrder is 0: fmi3Error).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3GetOutputDerivatives(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            orders: *const i32,
            values: *mut f64,
            n_values: usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = (vr, nvr, orders, values, n_values);
                $crate::api3::not_declared::<$model>(
                    instance,
                    "fmi3GetOutputDerivatives",
                    "maxOutputDerivativeOrder > 0",
                )
            }
        }

        /// FMI 3.0 `fmi3GetIntervalDecimal` (no clocks: fmi3Error).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3GetIntervalDecimal(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            intervals: *mut f64,
            qualifiers: *mut $crate::ffi3::Fmi3IntervalQualifier,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = (vr, nvr, intervals, qualifiers);
                $crate::api3::not_declared::<$model>(instance, "fmi3GetIntervalDecimal", "clocks")
            }
        }

        /// FMI 3.0 `fmi3GetIntervalFraction` (no clocks: fmi3Error).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3GetIntervalFraction(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            counters: *mut u64,
            resolutions: *mut u64,
            qualifiers: *mut $crate::ffi3::Fmi3IntervalQualifier,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = (vr, nvr, counters, resolutions, qualifiers);
                $crate::api3::not_declared::<$model>(instance, "fmi3GetIntervalFraction", "clocks")
            }
        }

        /// FMI 3.0 `fmi3GetShiftDecimal` (no clocks: fmi3Error).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3GetShiftDecimal(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            shifts: *mut f64,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = (vr, nvr, shifts);
                $crate::api3::not_declared::<$model>(instance, "fmi3GetShiftDecimal", "clocks")
            }
        }

        /// FMI 3.0 `fmi3GetShiftFraction` (no clocks: fmi3Error).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3GetShiftFraction(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            counters: *mut u64,
            resolutions: *mut u64,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = (vr, nvr, counters, resolutions);
                $crate::api3::not_declared::<$model>(instance, "fmi3GetShiftFraction", "clocks")
            }
        }

        /// FMI 3.0 `fmi3SetIntervalDecimal` (no clocks: fmi3Error).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3SetIntervalDecimal(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            intervals: *const f64,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = (vr, nvr, intervals);
                $crate::api3::not_declared::<$model>(instance, "fmi3SetIntervalDecimal", "clocks")
            }
        }

        /// FMI 3.0 `fmi3SetIntervalFraction` (no clocks: fmi3Error).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3SetIntervalFraction(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            counters: *const u64,
            resolutions: *const u64,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = (vr, nvr, counters, resolutions);
                $crate::api3::not_declared::<$model>(instance, "fmi3SetIntervalFraction", "clocks")
            }
        }

        /// FMI 3.0 `fmi3SetShiftDecimal` (no clocks: fmi3Error).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3SetShiftDecimal(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            shifts: *const f64,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = (vr, nvr, shifts);
                $crate::api3::not_declared::<$model>(instance, "fmi3SetShiftDecimal", "clocks")
            }
        }

        /// FMI 3.0 `fmi3SetShiftFraction` (no clocks: fmi3Error).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3SetShiftFraction(
            instance: $crate::ffi3::Fmi3Instance,
            vr: *const $crate::ffi3::Fmi3ValueReference,
            nvr: usize,
            counters: *const u64,
            resolutions: *const u64,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = (vr, nvr, counters, resolutions);
                $crate::api3::not_declared::<$model>(instance, "fmi3SetShiftFraction", "clocks")
            }
        }

        /// FMI 3.0 `fmi3DoStep`.
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU; the arrays hold the counts given.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3DoStep(
            instance: $crate::ffi3::Fmi3Instance,
            current_communication_point: f64,
            communication_step_size: f64,
            no_set_fmu_state_prior_to_current_point: $crate::ffi3::Fmi3Boolean,
            event_handling_needed: *mut $crate::ffi3::Fmi3Boolean,
            terminate_simulation: *mut $crate::ffi3::Fmi3Boolean,
            early_return: *mut $crate::ffi3::Fmi3Boolean,
            last_successful_time: *mut f64,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = no_set_fmu_state_prior_to_current_point;
                $crate::api3::do_step::<$model>(
                    instance,
                    current_communication_point,
                    communication_step_size,
                    event_handling_needed,
                    terminate_simulation,
                    early_return,
                    last_successful_time,
                )
            }
        }
        /// FMI 3.0 `fmi3EnterContinuousTimeMode` (Model Exchange only: fmi3Error).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3EnterContinuousTimeMode(
            instance: $crate::ffi3::Fmi3Instance,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                $crate::api3::not_declared::<$model>(
                    instance,
                    "fmi3EnterContinuousTimeMode",
                    "Model Exchange",
                )
            }
        }

        /// FMI 3.0 `fmi3CompletedIntegratorStep` (Model Exchange only: fmi3Error).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3CompletedIntegratorStep(
            instance: $crate::ffi3::Fmi3Instance,
            no_set_fmu_state_prior_to_current_point: $crate::ffi3::Fmi3Boolean,
            enter_event_mode: *mut $crate::ffi3::Fmi3Boolean,
            terminate_simulation: *mut $crate::ffi3::Fmi3Boolean,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = (
                    no_set_fmu_state_prior_to_current_point,
                    enter_event_mode,
                    terminate_simulation,
                );
                $crate::api3::not_declared::<$model>(
                    instance,
                    "fmi3CompletedIntegratorStep",
                    "Model Exchange",
                )
            }
        }

        /// FMI 3.0 `fmi3SetTime` (Model Exchange only: fmi3Error).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3SetTime(
            instance: $crate::ffi3::Fmi3Instance,
            time: f64,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = time;
                $crate::api3::not_declared::<$model>(instance, "fmi3SetTime", "Model Exchange")
            }
        }

        /// FMI 3.0 `fmi3SetContinuousStates` (Model Exchange only: fmi3Error).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3SetContinuousStates(
            instance: $crate::ffi3::Fmi3Instance,
            states: *const f64,
            n_states: usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = (states, n_states);
                $crate::api3::not_declared::<$model>(
                    instance,
                    "fmi3SetContinuousStates",
                    "Model Exchange",
                )
            }
        }

        /// FMI 3.0 `fmi3GetContinuousStateDerivatives` (Model Exchange only: fmi3Error).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3GetContinuousStateDerivatives(
            instance: $crate::ffi3::Fmi3Instance,
            derivatives: *mut f64,
            n_states: usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = (derivatives, n_states);
                $crate::api3::not_declared::<$model>(
                    instance,
                    "fmi3GetContinuousStateDerivatives",
                    "Model Exchange",
                )
            }
        }

        /// FMI 3.0 `fmi3GetEventIndicators` (Model Exchange only: fmi3Error).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3GetEventIndicators(
            instance: $crate::ffi3::Fmi3Instance,
            indicators: *mut f64,
            n_indicators: usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = (indicators, n_indicators);
                $crate::api3::not_declared::<$model>(
                    instance,
                    "fmi3GetEventIndicators",
                    "Model Exchange",
                )
            }
        }

        /// FMI 3.0 `fmi3GetContinuousStates` (Model Exchange only: fmi3Error).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3GetContinuousStates(
            instance: $crate::ffi3::Fmi3Instance,
            states: *mut f64,
            n_states: usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = (states, n_states);
                $crate::api3::not_declared::<$model>(
                    instance,
                    "fmi3GetContinuousStates",
                    "Model Exchange",
                )
            }
        }

        /// FMI 3.0 `fmi3GetNominalsOfContinuousStates` (Model Exchange only: fmi3Error).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3GetNominalsOfContinuousStates(
            instance: $crate::ffi3::Fmi3Instance,
            nominals: *mut f64,
            n_states: usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = (nominals, n_states);
                $crate::api3::not_declared::<$model>(
                    instance,
                    "fmi3GetNominalsOfContinuousStates",
                    "Model Exchange",
                )
            }
        }

        /// FMI 3.0 `fmi3GetNumberOfEventIndicators` (Model Exchange only: fmi3Error).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3GetNumberOfEventIndicators(
            instance: $crate::ffi3::Fmi3Instance,
            n_indicators: *mut usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = n_indicators;
                $crate::api3::not_declared::<$model>(
                    instance,
                    "fmi3GetNumberOfEventIndicators",
                    "Model Exchange",
                )
            }
        }

        /// FMI 3.0 `fmi3GetNumberOfContinuousStates` (Model Exchange only: fmi3Error).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3GetNumberOfContinuousStates(
            instance: $crate::ffi3::Fmi3Instance,
            n_states: *mut usize,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = n_states;
                $crate::api3::not_declared::<$model>(
                    instance,
                    "fmi3GetNumberOfContinuousStates",
                    "Model Exchange",
                )
            }
        }

        /// FMI 3.0 `fmi3ActivateModelPartition` (Scheduled Execution only: fmi3Error).
        ///
        /// # Safety
        /// `instance` is null or an instance handle of this FMU.
        #[no_mangle]
        pub unsafe extern "C" fn fmi3ActivateModelPartition(
            instance: $crate::ffi3::Fmi3Instance,
            clock_reference: $crate::ffi3::Fmi3ValueReference,
            activation_time: f64,
        ) -> $crate::ffi3::Fmi3Status {
            unsafe {
                let _ = (clock_reference, activation_time);
                $crate::api3::not_declared::<$model>(
                    instance,
                    "fmi3ActivateModelPartition",
                    "Scheduled Execution",
                )
            }
        }
    };
}
