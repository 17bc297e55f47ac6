//! FMU VehicleStateEstimator
