//! Finite inputs never produce NaN or infinity, including standstill, reversing, locked and
//! spinning wheels and large steering angles — for every model, both integrators and the
//! Jacobians.

use vehicle_models::driver_input::DriverInputVector;
use vehicle_models::rear_axle::{RearAxleInput, RearAxleState};
use vehicle_models::two_track_lateral::{TwoTrackLateralInput, TwoTrackLateralState};
use vehicle_models::tyre::{LinearTyre, MagicFormulaTyre, TyreModel};
use vehicle_models::{
    Integrator, RearAxleModel, SingleTrackHsri, SingleTrackModel, SingleTrackParams,
    SingleTrackState, TwoTrackLateralMagicFormula, TwoTrackMagicFormula, TwoTrackState,
};

const LONGITUDINAL: [f64; 5] = [-5.0, 0.0, 0.3, 5.0, 40.0];
const LATERAL: [f64; 3] = [-3.0, 0.0, 2.0];
const YAW: [f64; 3] = [-1.0, 0.0, 0.7];
const WHEEL: [(f64, f64); 4] = [(0.0, 0.0), (-10.0, 5.0), (60.0, 60.0), (300.0, 20.0)];
const STEER: [f64; 3] = [-0.6, 0.0, 0.45];
const TORQUE: [(f64, f64); 3] = [(0.0, 0.0), (800.0, 0.0), (0.0, 4000.0)];
const STEPS: [f64; 2] = [1e-3, 0.05];
const INTEGRATORS: [Integrator; 2] = [Integrator::SemiImplicitEuler, Integrator::RungeKutta4];

fn finite(values: impl IntoIterator<Item = f64>) -> bool {
    values.into_iter().all(f64::is_finite)
}

fn check_single_track<T: TyreModel>(model: &SingleTrackModel<T>) {
    for vx in LONGITUDINAL {
        for vy in LATERAL {
            for r in YAW {
                for (omega_front, omega_rear) in WHEEL {
                    for steer in STEER {
                        for (drive, brake) in TORQUE {
                            let x = SingleTrackState::new(vx, vy, r, omega_front, omega_rear);
                            let u = DriverInputVector::new(steer, drive, brake);
                            assert!(finite(model.measurement(&x, &u).iter().copied()), "{x} {u}");
                            assert!(finite(
                                model.measurement_jacobians(&x, &u).0.iter().copied()
                            ));
                            let o = model.outputs(&x, &u);
                            assert!(o.lateral_acceleration.is_finite() && o.slip_front.is_finite());
                            for dt in STEPS {
                                for integrator in INTEGRATORS {
                                    let next = model.step(&x, &u, dt, integrator);
                                    assert!(finite(next.iter().copied()), "{x} {u} {dt}");
                                    let (a, b) = model.step_jacobians(&x, &u, dt, integrator);
                                    assert!(finite(a.iter().chain(b.iter()).copied()), "{x} {u}");
                                }
                            }
                        }
                    }
                }
            }
        }
    }
}

#[test]
fn model_a_is_finite_everywhere_with_every_tyre() {
    check_single_track(&SingleTrackHsri::default());
    check_single_track(&SingleTrackModel::new(
        SingleTrackParams::default(),
        LinearTyre::default(),
    ));
    check_single_track(&SingleTrackModel::new(
        SingleTrackParams::default(),
        MagicFormulaTyre::default(),
    ));
}

#[test]
fn model_b_is_finite_everywhere() {
    let full = TwoTrackMagicFormula::default();
    let lateral = TwoTrackLateralMagicFormula::default();
    for vx in LONGITUDINAL {
        for vy in LATERAL {
            for r in YAW {
                for (omega_front, omega_rear) in WHEEL {
                    for steer in STEER {
                        for (drive, brake) in TORQUE {
                            let x = TwoTrackState::from([
                                vx,
                                vy,
                                r,
                                omega_front,
                                omega_rear,
                                omega_rear,
                                omega_front,
                            ]);
                            let u = DriverInputVector::new(steer, drive, brake);
                            let truth = full.truth(&x, &u);
                            assert!(
                                truth.lateral_acceleration.is_finite()
                                    && truth.sideslip.is_finite()
                            );
                            for integrator in INTEGRATORS {
                                let next = full.step(&x, &u, 1e-3, integrator);
                                assert!(finite(next.iter().copied()), "{x} {u}");
                            }
                        }
                    }
                }
                for steer in STEER {
                    for ay in [-9.0, 0.0, 9.0] {
                        let x = TwoTrackLateralState::new(vy.atan2(vx.abs().max(1.0)), r, ay);
                        // braking, free rolling and accelerating hard, one per ay
                        let u = TwoTrackLateralInput::new(steer, vx, -1.5 * ay);
                        for dt in STEPS {
                            for integrator in INTEGRATORS {
                                assert!(finite(
                                    lateral.step(&x, &u, dt, integrator).iter().copied()
                                ));
                                let (a, b) = lateral.step_jacobians(&x, &u, dt, integrator);
                                assert!(finite(a.iter().chain(b.iter()).copied()), "{x} {u}");
                            }
                        }
                    }
                }
            }
        }
    }
}

#[test]
fn model_c_is_finite_everywhere() {
    let model = RearAxleModel::default();
    for vx in LONGITUDINAL {
        for vy in LATERAL {
            for r in YAW {
                for steer in STEER {
                    for ax in [-8.0, 0.0, 3.0] {
                        let x = RearAxleState::new(vy, r, 0.3);
                        let u = RearAxleInput::new(ax, steer, vx);
                        for dt in [1e-3, 1e-2] {
                            for integrator in INTEGRATORS {
                                assert!(finite(model.step(&x, &u, dt, integrator).iter().copied()));
                                let (a, b) = model.step_jacobians(&x, &u, dt, integrator);
                                assert!(finite(a.iter().chain(b.iter()).copied()), "{x} {u}");
                            }
                        }
                    }
                }
            }
        }
    }
}
