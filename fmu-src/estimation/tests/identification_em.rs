//! EM identification: the minimisers, and recovery of model C's parameters on a short run.

use estimation::identification::seed003::{
    identify_from_arrays, identify_seed003, simulate, Seed003Config,
};
use estimation::identification::{minimise_powell, minimise_scalar, EmSchedule, LineSearchConfig};
use nalgebra::SVector;

#[test]
fn scalar_minimiser_finds_the_minimum_of_a_parabola_and_respects_invalid_regions() {
    let config = LineSearchConfig::default();
    let (x, fx, evaluations) = minimise_scalar(|x| (x - 3.7).powi(2) + 1.0, 3.0, &config);
    assert!((x - 3.7).abs() < 1e-6, "x = {x}");
    assert!((fx - 1.0).abs() < 1e-10);
    assert!(evaluations < 40, "{evaluations} evaluations");
    // A region where the model is invalid (infinite objective) is never chosen.
    let (x, _, _) = minimise_scalar(
        |x| {
            if x < 1.0 {
                f64::INFINITY
            } else {
                (x - 0.5).powi(2)
            }
        },
        1.2,
        &config,
    );
    assert!((1.0..1.01).contains(&x), "x = {x}");
}

#[test]
fn powell_minimises_a_correlated_quadratic_in_few_sweeps() {
    let target = SVector::<f64, 4>::new(8.36, 7.78, 0.62, 1.014);
    let objective = |p: &SVector<f64, 4>| {
        let d = p - target;
        // Strongly correlated: the ridge that makes coordinate search zig-zag.
        d[0].powi(2) + d[1].powi(2) + 50.0 * (d[2] - d[3]).powi(2) + (d[2] + d[3]).powi(2) * 0.5
    };
    let start = SVector::<f64, 4>::new(7.942, 7.386, 0.56, 0.91);
    let (x, _, evaluations) =
        minimise_powell(objective, start, 30, 1e-10, &LineSearchConfig::default());
    assert!((x - target).amax() < 1e-5, "{x:?}");
    assert!(evaluations < 1500, "{evaluations} evaluations");
}

#[test]
fn em_moves_model_c_parameters_towards_the_truth_on_a_short_run() {
    // 300 samples and two of the seed's parameter-wise iterations: small enough for a
    // debug-build test; the full reproduction is the seed003_identification example.
    let config = Seed003Config {
        samples: 300,
        noise_seeds: vec![1],
        tolerance: 1e-6,
        max_iterations: 2,
        schedule: EmSchedule::ParameterWise,
        ..Seed003Config::default()
    };
    let simulated = simulate(&config, 1).unwrap();
    let result = identify_seed003(&config, &simulated).unwrap();
    let truth = config.true_parameters;
    let start = config.start_parameters;
    assert_eq!(result.iterations[0], start);
    assert_eq!(result.iterations.len(), 3);
    assert_eq!(result.updates.len(), 8);
    for update in &result.updates {
        // Every M-step maximises Q(θ, θ_m): it never ends worse than it started.
        assert!(update.objective_after <= update.objective_before);
        assert!(
            update.mean_smoothed_ess > 10.0,
            "optimal proposal keeps the ESS high"
        );
    }
    // Csf, Csr and m/J close at least 40 % of the start's error within two iterations; lf, the
    // weakest-determined parameter, must at least not get worse.
    for j in 0..4 {
        let start_error = (start[j] - truth[j]).abs() / truth[j];
        let error = (result.parameters[j] - truth[j]).abs() / truth[j];
        let factor = if j == 3 { 1.0 } else { 0.6 };
        assert!(
            error < factor * start_error,
            "{}: identified {} (truth {}, start {})",
            result.parameter_names[j],
            result.parameters[j],
            truth[j],
            start[j]
        );
    }
    // Deterministic: the same data and seed give the same bits.
    let again = identify_seed003(&config, &simulated).unwrap();
    assert_eq!(result.parameters, again.parameters);
}

#[test]
fn identification_from_plain_arrays_matches_the_simulated_run_and_rejects_bad_data() {
    let config = Seed003Config {
        samples: 120,
        noise_seeds: vec![1],
        tolerance: 1e-3,
        max_iterations: 2,
        ..Seed003Config::default()
    };
    let simulated = simulate(&config, 5).unwrap();
    let inputs: Vec<[f64; 3]> = simulated
        .run
        .inputs
        .iter()
        .map(|u| [u[0], u[1], u[2]])
        .collect();
    let measurements: Vec<[f64; 3]> = simulated
        .run
        .measurements
        .iter()
        .map(|y| [y[0], y[1], y[2]])
        .collect();
    let from_arrays =
        identify_from_arrays(&inputs, &measurements, config.sample_time, &config).unwrap();
    let direct = identify_seed003(&config, &simulated).unwrap();
    assert_eq!(from_arrays.parameters, direct.parameters);
    assert_eq!(from_arrays.iterations, direct.iterations);
    assert!(
        from_arrays.iterations.len() >= 2,
        "history holds start and iterations"
    );

    let error = identify_from_arrays(&inputs[1..], &measurements, 0.01, &config).unwrap_err();
    assert!(error.to_string().contains("rows"), "{error}");
    let mut bad_inputs = inputs.clone();
    bad_inputs[3][1] = f64::NAN;
    let error = identify_from_arrays(&bad_inputs, &measurements, 0.01, &config).unwrap_err();
    assert!(error.to_string().contains("input row 3"), "{error}");
    let error = identify_from_arrays(&inputs, &measurements, -0.01, &config).unwrap_err();
    assert!(error.to_string().contains("sample_time"), "{error}");
}
