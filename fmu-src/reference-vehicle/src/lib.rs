//! FMU ReferenceVehicle
