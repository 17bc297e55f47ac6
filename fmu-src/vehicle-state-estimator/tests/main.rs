//! The crate's integration tests, one module per file, in one test binary: the crate and its
//! dependencies are compiled and linked once instead of once per file.
//! `cargo test -p vehicle-state-estimator --test integration <module>::` runs one file's tests.

mod adaptive_noise;
mod c_api;
mod car;
mod gate_model_error;
mod lateral_accelerometer;
mod learned_noise;
mod load_unload;
mod low_speed_kinematics;
mod model_b;
mod model_grip;
mod observer_scaling;
mod parameter_bounds;
mod rear_drive;
mod registry;
mod robustness;
mod rolling_radius;
mod sliding_wheels;
mod speed_filter;
mod stiffness_consider;
mod tunable;
mod unconnected_sensors;
mod wheel_lift;
mod yaw_rate_offset;
