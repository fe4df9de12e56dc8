//! `zmp-indep-sim`: draw a robot with hidden effects and write its stepped-sine campaign.

use anyhow::{Context, Result};
use clap::Parser;
use std::path::PathBuf;
use zmp_indep_sim::{draw_with, write, CouplingForm, Design, DrawOptions, Scenario};

/// Independent simulator of the seed's full ZMP robot (Caballero et al. 2006) with hidden
/// physical effects, for out-of-sample tests of identification and diagnosis tools.
///
/// Draws a robot from --seed for the --scenario (every parameter within the documented
/// ranges, each hidden effect sized to be visible above the noise on the design), simulates
/// the stepped-sine design and writes a `zmp-campaign/1` folder. The truth (every parameter,
/// the names of the hidden effects and whether the project's catalogue knows them) goes only
/// to --truth, never into the campaign folder.
#[derive(Parser, Debug)]
#[command(name = "zmp-indep-sim", version, verbatim_doc_comment)]
struct Cli {
    /// Seed of the robot draw. Also the seed of the measurement noise unless --design gives
    /// one.
    #[arg(long)]
    seed: u64,

    /// Which hidden effects: `clean` (the seed's model with its acceleration saturation),
    /// `single:E`, `pair:E1,E2`, `triple:E1,E2,E3` (catalogue effects), `outside:E` or
    /// `outside:E,C` (an effect outside the catalogue, optionally with a catalogue one), or
    /// `random` (drawn from the seed). Catalogue: time_delay, backlash, coulomb_friction,
    /// acceleration_saturation, structural_mode, sensor_lowpass, operating_point_dependence,
    /// sensor_drift, cross_coupling. Outside: second_structural_mode, stribeck_friction,
    /// rate_limited_servo, cubic_stiffness.
    #[arg(long, default_value = "clean")]
    scenario: String,

    /// The campaign folder to write (written aside and renamed into place).
    #[arg(long)]
    out: PathBuf,

    /// Also write the robot's truth as JSON to this file (keep it outside the campaign).
    #[arg(long)]
    truth: Option<PathBuf>,

    /// Replace an existing campaign folder (only one this tool wrote) and truth file.
    #[arg(long)]
    force: bool,

    /// Design file (TOML): operating_points ([[x, y], ...] m), amplitudes (m), omegas
    /// (rad/s), excited (["x", "y"]), sample_rate_hz, transient_s, periods, min_steady_s,
    /// and optionally quantisation (m), seed, name, min_internal_rate_hz, a [noise] table
    /// (white_std, coloured_std m, coloured_tau s) or zmp_noise_std (m, white only) to
    /// override the robot's sensor noise. Default: 3 operating points x 2 axes x 2 amplitudes
    /// x 9 frequencies = 108 records at 200 Hz. Instead of the grid, a design may list its
    /// records ([[records]] with excited, omega, amplitude, operating_point = [x, y]): the
    /// list runs on the robot --seed and --scenario draw for the default design (or on
    /// --robot); give it a seed other than the campaign's so that its noise is its own.
    #[arg(long)]
    design: Option<PathBuf>,

    /// Run the design on this robot (a --truth file written earlier) instead of drawing one
    /// (--scenario is then not used).
    #[arg(long, value_name = "TRUTH.json")]
    robot: Option<PathBuf>,

    /// Form of a drawn cross_coupling effect: `pendulum` (extra off-diagonal a - b s² terms)
    /// or `inertial` (each joint loaded by the other axis's CoM acceleration). Default: drawn.
    #[arg(long)]
    coupling_form: Option<CouplingForm>,

    /// Print a JSON summary on standard output: campaign folder, record count, truth file,
    /// seconds spent simulating and writing (never the hidden effects: read --truth for them).
    #[arg(long)]
    json: bool,
}

fn main() -> std::process::ExitCode {
    match run(Cli::parse()) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> Result<()> {
    let scenario: Scenario = cli
        .scenario
        .parse()
        .map_err(|e| anyhow::anyhow!("--scenario: {e}"))?;
    let design = match &cli.design {
        Some(path) => Design::from_toml_file(path)?,
        None => Design {
            seed: cli.seed,
            ..Design::default()
        },
    };
    if let Some(truth) = &cli.truth {
        // Checked before the simulation: a file needs --force, and only a truth file of
        // this tool is replaced (the one output path refuses any other kind of file).
        zmp_files::check_file(truth, zmp_files::Kind::Json, cli.force)?;
        if truth.exists() {
            let text =
                zmp_files::read_limited_text(truth, zmp_files::limits::MODEL_BYTES, "a truth file")
                    .unwrap_or_default();
            if zmp_indep_sim::Robot::from_json(&text).is_err() {
                anyhow::bail!(
                    "{}: exists and is not a truth file of zmp-indep-sim; refusing to replace it even with --force",
                    truth.display()
                );
            }
        }
        if truth.starts_with(&cli.out) {
            anyhow::bail!(
                "{}: the truth must not be written inside the campaign folder",
                truth.display()
            );
        }
    }
    let options = DrawOptions {
        coupling_form: cli.coupling_form,
    };
    let robot = match &cli.robot {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("{}: cannot read", path.display()))?;
            zmp_indep_sim::Robot::from_json(&text).map_err(|e| {
                anyhow::anyhow!("{}: not a truth file of zmp-indep-sim: {e}", path.display())
            })?
        }
        None => draw_with(cli.seed, &scenario, &design, &options),
    };
    let started = std::time::Instant::now();
    write::write_campaign(&robot, &design, &cli.out, cli.force)?;
    let seconds = started.elapsed().as_secs_f64();
    if let Some(truth) = &cli.truth {
        write::write_file_atomic(truth, &robot.to_json(), cli.force)
            .with_context(|| format!("{}: truth not written", truth.display()))?;
    }
    let n = design.records().len();
    if cli.json {
        let summary = serde_json::json!({
            "campaign": cli.out,
            "records": n,
            "truth": cli.truth,
            "simulate_and_write_s": seconds,
        });
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        eprintln!(
            "wrote {} ({n} records, scenario {}) in {seconds:.2} s{}",
            cli.out.display(),
            cli.scenario,
            cli.truth
                .as_ref()
                .map(|t| format!("; truth in {}", t.display()))
                .unwrap_or_default()
        );
    }
    Ok(())
}
