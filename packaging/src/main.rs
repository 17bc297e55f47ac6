//! `cargo run --release -p packaging [-- --check]`: writes `<target dir>/fmu/ReferenceVehicle.fmu`,
//! `VehicleStateEstimator.fmu` (FMI 2.0), `ReferenceVehicle-fmi3.fmu`,
//! `VehicleStateEstimator-fmi3.fmu` (FMI 3.0, the same libraries) and `VehicleWithEstimator.ssp`;
//! the Linux libraries are built for glibc 2.17 with cargo zigbuild unless `--host-glibc` (see
//! `packaging::binaries`).

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Parser;

use packaging::archive::WriteOutcome;
use packaging::binaries::LinuxBuild;
use packaging::cargo::{BuildScope, Workspace};

#[derive(Parser, Debug)]
#[command(
    about = "Builds the FMI 2.0 and FMI 3.0 Co-Simulation FMUs and the SSP system of this workspace"
)]
struct Arguments {
    /// Only check the model descriptions and the SSP connection plan; build and write nothing.
    #[arg(long)]
    check: bool,
    /// Root Cargo.toml of the workspace (default: the workspace this tool was built in).
    #[arg(long, value_name = "PATH")]
    manifest_path: Option<PathBuf>,
    /// Build the FMU libraries as part of every workspace target that `cargo test --workspace
    /// --release` compiles, so that test run compiles nothing again (tests/run.sh uses this; the
    /// default builds only the two FMU packages).
    #[arg(long)]
    with_workspace_targets: bool,
    /// Build the Linux libraries with a plain `cargo build` for this machine's glibc instead of
    /// `cargo zigbuild` for glibc 2.17 (the default, which needs packaging/setup.sh's zig).
    #[arg(long)]
    host_glibc: bool,
    /// Also place libraries for other platforms, built elsewhere, found as
    /// `<DIR>/<platform>/<modelIdentifier>.<dll|dylib|so>` (platform: win64, win32, darwin64,
    /// linux32, aarch64-linux, or linux64 to replace the one built here).
    #[arg(long, value_name = "DIR")]
    binaries_from: Option<PathBuf>,
}

fn run(arguments: Arguments) -> anyhow::Result<()> {
    let manifest = arguments.manifest_path.unwrap_or_else(|| {
        PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("..")
            .join("Cargo.toml")
    });
    let mut workspace = Workspace::locate(&manifest)?;
    if arguments.with_workspace_targets {
        workspace.build_scope = BuildScope::Workspace;
    }
    if arguments.host_glibc {
        workspace.linux_build = LinuxBuild::Host;
    }
    workspace.prebuilt_binaries = arguments.binaries_from;
    if arguments.check {
        let checked = packaging::check_descriptions(&workspace.root)?;
        for c in &checked {
            println!(
                "ok  {}  ({} variables, GUID {})",
                packaging::description_path(&workspace.root, c.spec).display(),
                c.description.variables.len(),
                c.description.guid
            );
        }
        let plan = packaging::ssp::plan(&checked[0].description, &checked[1].description)?;
        println!(
            "ok  {}: {} connections",
            packaging::SSP_FILE_NAME,
            plan.connections.len()
        );
        return Ok(());
    }
    let (written, plan) = packaging::package(&workspace)?;
    for item in &written {
        let what = match item.outcome {
            WriteOutcome::Written => "wrote    ",
            WriteOutcome::Unchanged => "unchanged",
        };
        println!("{what} {} ({} bytes)", item.path.display(), item.bytes);
    }
    println!(
        "{}: {} connections {} -> {}; driver inputs of both from resources/{}",
        packaging::SSP_FILE_NAME,
        plan.connections.len(),
        plan.vehicle,
        plan.estimator,
        packaging::ssp::DRIVER_FILE
    );
    if !plan.unconnected_estimator_inputs.is_empty() {
        println!(
            "note: {} inputs with no {} output of the same name keep their start values in the \
             SSP: {}",
            plan.estimator,
            plan.vehicle,
            plan.unconnected_estimator_inputs.join(", ")
        );
    }
    Ok(())
}

fn main() -> ExitCode {
    match run(Arguments::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("packaging: error: {error:#}");
            ExitCode::FAILURE
        }
    }
}
