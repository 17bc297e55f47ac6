//! Writes the example log of `harness replay` / `harness fit`: harness/logs/ford_escort_sis.csv
//! and .mf4, a ReferenceVehicle drive (harness/logs/record_ford_escort.toml) as a data logger
//! would record it (see `harness::replay::record`). Needs the packaged FMUs.

use anyhow::Result;
use fmi_master::runner::{default_fmu_dir, workspace_root};
use harness::replay::record;

fn main() -> Result<()> {
    let dir = workspace_root().join("harness/logs");
    let scratch = std::env::temp_dir().join(format!("record-example-log-{}", std::process::id()));
    let run = record::record_drive(&default_fmu_dir(), &scratch)?;
    let _ = std::fs::remove_dir_all(&scratch);
    println!(
        "{}",
        record::write_csv(&run, &dir, "ford_escort_sis")?.display()
    );
    println!(
        "{}",
        record::write_mf4(&run, &dir, "ford_escort_sis")?.display()
    );
    Ok(())
}
