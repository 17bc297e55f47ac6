//! Loads the built shared library, instantiates, runs, frees and unloads it 1,000 times in one
//! process, as fmpy does for every instance. Afterwards the library must really be gone from the
//! process (a thread-local destructor registered by it would pin it in memory or crash at exit).

use fmi_export::ffi::Fmi2Status;
use fmi_export::testing::{built_library_path, Fmi2Api, Slave};
use VehicleStateEstimator::model_description::{vr, EstimatorKind, GUID, MODEL_IDENTIFIER};

fn mapped(path: &std::path::Path) -> bool {
    let maps = std::fs::read_to_string("/proc/self/maps").expect("/proc/self/maps");
    let canonical = std::fs::canonicalize(path).expect("library path");
    maps.contains(canonical.to_str().unwrap())
}

#[test]
fn load_run_free_unload_a_thousand_times() {
    let path = built_library_path(MODEL_IDENTIFIER).unwrap_or_else(|e| panic!("{e}"));
    for iteration in 0..1000 {
        // SAFETY: the library is this FMU's binary; the table and the slave die before it.
        let library = unsafe { libloading::Library::new(&path) }.expect("dlopen");
        {
            let api = unsafe { Fmi2Api::load(&library) }.expect("all FMI symbols");
            let mut slave = Slave::instantiate(api, "load-unload", GUID).expect("instantiate");
            // Alternate the estimators so that every one is loaded and run repeatedly.
            let estimator = [
                EstimatorKind::Ekf as i32,
                EstimatorKind::Ukf as i32,
                EstimatorKind::Lkf as i32,
                EstimatorKind::Luenberger as i32,
            ][iteration % 4];
            assert_eq!(slave.set_integer(vr::ESTIMATOR, estimator), Fmi2Status::Ok);
            assert_eq!(slave.initialize(0.0), Fmi2Status::Ok);
            for k in 0..10 {
                slave.set_reals(
                    &[
                        vr::YAW_RATE_MEAS,
                        vr::AY_MEAS,
                        vr::OMEGA_FRONT_MEAS,
                        vr::OMEGA_REAR_MEAS,
                    ],
                    &[0.01, 0.18, 60.0, 60.0],
                );
                assert_eq!(slave.do_step(k as f64 * 0.001, 0.001), Fmi2Status::Ok);
            }
            let (status, yaw_rate) = slave.get_real(vr::YAW_RATE_EST);
            assert_eq!(status, Fmi2Status::Ok);
            assert!(
                yaw_rate > 0.0,
                "iteration {iteration}: the measured left turn is seen"
            );
            // A misuse on the way, so that the error path (logging) runs in every cycle too.
            assert_eq!(slave.do_step(5.0, 0.001), Fmi2Status::Error);
        }
        library.close().expect("dlclose");
        assert!(
            !mapped(&path),
            "iteration {iteration}: the library stayed mapped after dlclose"
        );
    }
}
