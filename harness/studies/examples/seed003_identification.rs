//! Seed 003 §3.2 in simulation: table 3.1 (particle filter vs smoother RMSE) and table 3.2 (EM
//! identification of `p = [Csf, Csr, m/J, lf]` from the wrong start), over several noise seeds.
//!
//! `cargo run --release -p harness --example seed003_identification [noise seeds...]`

use harness::seed003::{reproduce_seed003, Seed003Config};

fn main() {
    let mut config = Seed003Config::default();
    let seeds: Vec<u64> = std::env::args()
        .skip(1)
        .map(|arg| {
            arg.parse()
                .unwrap_or_else(|_| panic!("noise seeds must be unsigned integers, got {arg:?}"))
        })
        .collect();
    if !seeds.is_empty() {
        config.noise_seeds = seeds;
    }
    match reproduce_seed003(&config) {
        Ok(report) => print!("{}", report.tables()),
        Err(error) => {
            eprintln!("seed-003 reproduction failed: {error}");
            std::process::exit(1);
        }
    }
}
