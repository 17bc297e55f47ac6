//! Writes the example logs of `harness replay` / `harness fit` (see `harness::replay::record`),
//! ReferenceVehicle drives as a data logger would record them. Needs the packaged FMUs.
//! * harness/logs/ford_escort_sis.csv and .mf4: harness/logs/record_ford_escort.toml;
//! * harness/logs/ford_escort_limit.csv: harness/logs/record_ford_escort_limit.toml, the drive
//!   past the limit (for the peak friction fit; CSV only, the MF4 reader is tested on the first).
//!
//! `cargo run --release -p harness --example record_example_log [sis|limit]` writes one of them
//! (default both).

use anyhow::{bail, Result};
use fmi_master::runner::{default_fmu_dir, workspace_root};
use harness::replay::record;

fn main() -> Result<()> {
    let which = std::env::args().nth(1);
    let (sis, limit) = match which.as_deref() {
        None => (true, true),
        Some("sis") => (true, false),
        Some("limit") => (false, true),
        Some(other) => bail!("{other:?}: expected sis or limit"),
    };
    let dir = workspace_root().join("harness/logs");
    let scratch = std::env::temp_dir().join(format!("record-example-log-{}", std::process::id()));
    if sis {
        let run = record::record_drive(&default_fmu_dir(), &scratch)?;
        println!(
            "{}",
            record::write_csv(&run, &dir, "ford_escort_sis")?.display()
        );
        println!(
            "{}",
            record::write_mf4(&run, &dir, "ford_escort_sis")?.display()
        );
    }
    if limit {
        let run = record::record_scenario(
            &default_fmu_dir(),
            "record_ford_escort_limit.toml",
            &scratch,
            &[],
        )?;
        println!(
            "{}",
            record::write_csv(&run, &dir, "ford_escort_limit")?.display()
        );
    }
    let _ = std::fs::remove_dir_all(&scratch);
    Ok(())
}
