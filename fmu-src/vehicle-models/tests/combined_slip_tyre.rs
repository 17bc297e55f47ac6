//! The combined-slip MF 5.2 tyre of the full vehicle: limiting cases, symmetry, stiffness,
//! friction scaling and the combined-slip reduction (Pacejka 2012, Sect. 4.3.2).

use vehicle_models::tyre::combined_slip::{CombinedSlipParams, CombinedSlipTyre};

const LOAD: f64 = 3500.0;

fn tyre() -> CombinedSlipTyre {
    CombinedSlipTyre::new(CombinedSlipParams::seed_car())
}

#[test]
fn no_slip_gives_no_force_and_no_load_gives_no_force() {
    let force = tyre().force(0.0, 0.0, LOAD, 1.0).force;
    assert_eq!((force.longitudinal, force.lateral), (0.0, 0.0));
    let lifted = tyre().force(0.1, 0.1, 0.0, 1.0);
    assert_eq!(lifted.force.longitudinal, 0.0);
    assert_eq!(lifted.force.lateral, 0.0);
    assert_eq!(lifted.peak_lateral, 0.0);
}

#[test]
fn forces_are_odd_in_their_slips() {
    let t = tyre();
    for (slip, tan_alpha) in [(0.02, 0.05), (0.2, 0.01), (-0.5, 0.3), (0.05, -0.15)] {
        let f = t.force(slip, tan_alpha, LOAD, 1.0).force;
        let mirrored = t.force(slip, -tan_alpha, LOAD, 1.0).force;
        let reversed = t.force(-slip, tan_alpha, LOAD, 1.0).force;
        assert_eq!(mirrored.longitudinal, f.longitudinal);
        assert_eq!(mirrored.lateral, -f.lateral);
        assert_eq!(reversed.longitudinal, -f.longitudinal);
        assert_eq!(reversed.lateral, f.lateral);
    }
}

#[test]
fn small_slip_slopes_are_the_stiffnesses() {
    let t = tyre();
    let h = 1e-7;
    let lateral_slope = t.force(0.0, h, LOAD, 1.0).force.lateral / h;
    let longitudinal_slope = t.force(h, 0.0, LOAD, 1.0).force.longitudinal / h;
    let cornering = t.cornering_stiffness(LOAD);
    let longitudinal = t.longitudinal_stiffness(LOAD);
    assert!((lateral_slope / cornering - 1.0).abs() < 1e-5);
    assert!((longitudinal_slope / longitudinal - 1.0).abs() < 1e-5);
    // matched to the seed's HSRI stiffness Cs = (10 + 20 Fz/3000) Fz (000: 5.71) exactly
    let seed_longitudinal = (10.0 + 20.0 * LOAD / 3000.0) * LOAD;
    assert!((longitudinal / seed_longitudinal - 1.0).abs() < 1e-12);
    // and the cornering stiffness within 7 % of Cα = (25.6 − 5.73 Fz/3000) Fz (000: 5.70)
    let seed_cornering = (25.6 - 5.73 * LOAD / 3000.0) * LOAD;
    assert!((cornering / seed_cornering - 1.0).abs() < 0.07);
}

/// Largest force over a sweep of one slip, the other zero.
fn peak_over_sweep(t: &CombinedSlipTyre, load: f64, friction: f64, lateral: bool) -> f64 {
    (1..20_000)
        .map(|i| {
            let s = i as f64 * 5e-5;
            let f = if lateral {
                t.force(0.0, s, load, friction).force.lateral
            } else {
                t.force(s, 0.0, load, friction).force.longitudinal
            };
            f.abs()
        })
        .fold(0.0, f64::max)
}

#[test]
fn peak_is_road_friction_times_load_dependent_mu() {
    let t = tyre();
    for friction in [1.0, 0.5, 0.1] {
        for load in [1500.0, 3000.0, 6000.0] {
            // seed 000's f0 = 1.35 − 0.15 Fz/3000 (5.67), scaled by the road
            let expected = friction * (1.35 - 0.15 * load / 3000.0) * load;
            let lateral = peak_over_sweep(&t, load, friction, true);
            let longitudinal = peak_over_sweep(&t, load, friction, false);
            assert!(
                (lateral / expected - 1.0).abs() < 1e-3,
                "{lateral} vs {expected}"
            );
            assert!((longitudinal / expected - 1.0).abs() < 1e-3);
        }
    }
}

#[test]
fn combined_slip_reduces_each_force() {
    let t = tyre();
    let pure_lateral = t.force(0.0, 0.08, LOAD, 1.0).force.lateral;
    let pure_longitudinal = t.force(0.08, 0.0, LOAD, 1.0).force.longitudinal;
    let combined = t.force(0.08, 0.08, LOAD, 1.0).force;
    assert!(combined.lateral > 0.0 && combined.lateral < 0.95 * pure_lateral);
    assert!(combined.longitudinal > 0.0 && combined.longitudinal < 0.95 * pure_longitudinal);
    // a locked wheel sliding sideways never gets a force against its slip (clamped weights)
    for tan_alpha in [0.5, 2.0, 20.0] {
        let f = t.force(-1.0, tan_alpha, LOAD, 1.0).force;
        assert!(f.longitudinal <= 0.0 && f.lateral >= 0.0, "{f:?}");
    }
}
