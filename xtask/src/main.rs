//! `cargo xtask <verb>`: the command line for users and CI.

mod bench;
mod calibrate;
mod ci;
mod demo;
mod demo_com;
mod diagnose;
mod env;
mod fmu;
mod identify;
mod links;
mod loop_cmd;
mod robust;
mod setup;
mod simulate;
mod twin;

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Result;
use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(name = "cargo xtask", about = "ZMP biped identification toolkit tasks")]
struct Cli {
    #[command(subcommand)]
    command: Cmd,
    /// Worker threads for reading, identification and diagnosis (identify, compare, diagnose,
    /// augment, loop). Default: every core. Results do not depend on it.
    #[arg(long, global = true, value_name = "N", value_parser = clap::value_parser!(u16).range(1..))]
    threads: Option<u16>,
}

#[derive(Subcommand)]
enum Cmd {
    /// Install the prerequisites (system packages, MuJoCo library, Python venv with FMPy).
    Setup {
        /// Only report steps that install something; hide apt/pip output unless they fail.
        #[arg(long)]
        quiet: bool,
    },
    /// The link check CI runs: every relative link and anchor of README.md, CHANGELOG.md, the
    /// book (docs/) and the crates' READMEs must resolve in the clone.
    Links,
    /// What CI runs: setup, then cargo fmt --check, clippy -D warnings, test (release), the
    /// book's link check and the instruction-count gate (`bench --counts-only`).
    ///
    /// With --long, afterwards also the long suites CI leaves out (`#[ignore = "long: ..."]`:
    /// the loop on single draws of the independent simulator, about 40 minutes on 2 cores);
    /// the held-out and development blind suites are never run by it (run by hand, once).
    Ci {
        /// Also run the long suites (`cargo test --workspace --release -- --ignored`, without
        /// the held-out and development blind suites).
        #[arg(long)]
        long: bool,
    },
    /// Speed of the hot paths and the commands, tracked (bench/README.md).
    ///
    /// Counts the instructions (callgrind, one thread) of the plant step, the controller step,
    /// the plant FMU's doStep through the Rust importer, and the identification and diagnosis
    /// of a small campaign, and gates them against bench/baseline.toml: more than 2 % more
    /// instructions in a real-time loop (5 % elsewhere) fails, naming the bench and both
    /// counts; a missing bench, a zero count, a baseline measured with another rustc, locked
    /// dependencies, glibc or valgrind, or an improvement beyond the threshold (refresh the
    /// baseline) is an error. Then runs the criterion benches (real-time steps, FMU, library
    /// identification and diagnosis, and the identify/compare/diagnose commands as a user runs
    /// them on the 168-record campaign) with their peers in the same run (numpy/pyarrow
    /// identification, FMPy per-step cost), appends the results to bench/history.jsonl with the
    /// commit, draws bench/trends/*.svg and regenerates the table of bench/README.md.
    Bench {
        /// Only the instruction counts and the gate (what `cargo xtask ci` runs; about half a
        /// minute after `cargo test --workspace --release`): no criterion, no history.
        #[arg(long)]
        counts_only: bool,
        /// Write this run's counts, with this machine's fingerprint, as the new baseline
        /// instead of gating (after a deliberate change of speed, toolchain or dependencies;
        /// implies --counts-only).
        #[arg(long)]
        save_baseline: bool,
        /// Only this bench (repeatable): plant_step/all_effects, plant_step/paper_nominal,
        /// controller_step, fmu_do_step/plant_fmi2, identify/small_campaign,
        /// diagnose/small_campaign.
        #[arg(long = "only", value_name = "BENCH")]
        only: Vec<String>,
        /// Baseline file (default bench/baseline.toml).
        #[arg(long)]
        baseline: Option<PathBuf>,
        /// Test of the gate itself: build the real-time count binary with the test-only
        /// feature that adds about 6 % instructions to the plant step (the gate must fail).
        #[arg(long)]
        planted_regression: bool,
        /// Print the counts, the gate's verdicts and the wall-clock results as JSON.
        #[arg(long)]
        json: bool,
    },
    /// The main job on built-in data: a virtual SILO2 campaign, the model's Bode diagrams, the
    /// seed's closed-loop experiment, identification, the diagnosis loop and a short
    /// validation on the MuJoCo twin of SILO2, written to OUT (default out/demo).
    Demo {
        /// Output folder. An earlier demo output there (it holds the marker file
        /// .zmp-demo-output) is replaced; any other non-empty folder is refused.
        #[arg(long, default_value = "out/demo")]
        out: PathBuf,
        /// Accepted for scripts; changes nothing: the demo replaces its own earlier output
        /// without it and never replaces a folder it did not write, even with it.
        #[arg(long)]
        force: bool,
        /// Print a machine-readable summary on standard output.
        #[arg(long)]
        json: bool,
    },
    /// The second seed on the SABIAN MuJoCo twin: calibrate the effective centre of mass from
    /// the two ankle force/torque sensors (the seed's upright + 1 degree design, with and
    /// without its eq. 7 joint moments, and a D-optimal design, each over noise draws, against
    /// MuJoCo's true CoM), build the virtual models n, r, s, v (and e: the error mass where the
    /// calibration puts it), walk the seed's 8-step gait with each on the twin with the true
    /// masses, open loop and with the seed's Torso Position Control (its effort per model), and
    /// write com-calibration.toml, report.html (the seed's tables 2-4 beside ours) and SVG
    /// figures into OUT.
    CalibrateCom {
        /// Output folder.
        #[arg(long, default_value = "out/com-calibration")]
        out: PathBuf,
        /// The short version (1 walk per model and control, 40 noise draws), as in the demo.
        #[arg(long)]
        quick: bool,
        /// Walking runs per model and control (default 5, the seed's).
        #[arg(long)]
        runs: Option<usize>,
        /// Noise draws of each calibration (default 200).
        #[arg(long)]
        draws: Option<usize>,
        /// Also write the SVG figures into this folder (e.g. docs/figures); files of the same
        /// names there are replaced.
        #[arg(long)]
        figures: Option<PathBuf>,
        /// Print the tables as Markdown.
        #[arg(long)]
        markdown: bool,
        /// Print everything as JSON.
        #[arg(long)]
        json: bool,
        /// Overwrite the files an earlier run wrote in OUT.
        #[arg(long)]
        force: bool,
    },
    /// Build the FMI 2.0 and FMI 3.0 co-simulation FMUs of a model file: zmp_plant.fmu,
    /// zmp_controller.fmu and their _fmi3 versions (Linux 64-bit). Parameter start values are
    /// the model file's; the GUID changes with the model's content.
    Fmu {
        /// Model file (zmp-model/1).
        #[arg(long, default_value = "models/params/silo2-paper.toml")]
        model: PathBuf,
        /// Output folder.
        #[arg(long, default_value = "target/fmu")]
        out: PathBuf,
        /// Overwrite existing .fmu files.
        #[arg(long)]
        force: bool,
    },
    /// Simulate a stepped-sine campaign (zmp-campaign/1) on the virtual robot.
    ///
    /// Without --design, the reference design: 3 operating points x 2 amplitudes (3, 8 mm) x
    /// 14 frequencies (0.5-15 rad/s) x 2 excited channels at 200 Hz, 0.5 mm ZMP noise,
    /// 0.1 mm quantisation. A design file is TOML with the fields of that design
    /// (operating_points, amplitudes, omegas, excited, sample_rate_hz, transient_s, periods,
    /// min_steady_s, zmp_noise_std, quantisation, seed, internal_step, record_com).
    Simulate {
        /// Model file (zmp-model/1).
        #[arg(long, default_value = "models/params/silo2-paper.toml")]
        model: PathBuf,
        /// Experiment design (TOML).
        #[arg(long)]
        design: Option<PathBuf>,
        /// Override the design's noise seed.
        #[arg(long)]
        seed: Option<u64>,
        /// Campaign folder to write.
        #[arg(long)]
        out: PathBuf,
        /// Replace an existing campaign folder.
        #[arg(long)]
        force: bool,
        /// Print a machine-readable summary.
        #[arg(long)]
        json: bool,
    },
    /// Identify the seed's ZMP model from a stepped-sine campaign (zmp-campaign/1): steady
    /// state, FFT + harmonic regression per record, weighted pendulum + low-pass fit with
    /// standard errors, acceleration saturation, uncertainty weights (first seed, section 5).
    Identify {
        /// Campaign folder (with campaign.toml).
        campaign: PathBuf,
        /// Model file to write (zmp-model/1). Default: next to the campaign folder,
        /// <campaign>/../<campaign-folder-name>-identified.toml.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Write an HTML report with Bode figures (SVG) into this folder.
        #[arg(long)]
        report: Option<PathBuf>,
        /// Tracking low-pass WN,ZETA (rad/s, 1) used when the data do not determine it
        /// (default 30,1, the seed's).
        #[arg(long)]
        bandwidth: Option<String>,
        /// A model file whose structure is refitted: its pendulum, low-pass and uncertainty
        /// are identified, its other effects kept (default: the seed's structure).
        #[arg(long)]
        model: Option<PathBuf>,
        /// Also put a detected acceleration limit into the model file (by default it is
        /// reported, and the model stays the seed's linear one).
        #[arg(long)]
        include_saturation: bool,
        /// Overwrite an existing model file / report files.
        #[arg(long)]
        force: bool,
        /// Print a machine-readable summary (parameters, standard errors, excluded records,
        /// warnings).
        #[arg(long)]
        json: bool,
    },
    /// Compare a model with a campaign: one error measure per record and channel against its
    /// noise floor, where the model fails (channel, frequency band, amplitude, operating
    /// point), and an HTML report (Bode and time overlays, residual spectrum, harmonics,
    /// error against frequency, amplitude and operating point).
    Compare {
        /// Campaign folder (with campaign.toml).
        campaign: PathBuf,
        /// Model file (zmp-model/1).
        #[arg(long)]
        model: PathBuf,
        /// Report folder.
        #[arg(long, default_value = "out/compare")]
        report: PathBuf,
        /// Record (number in campaign.toml order, from 0) whose steady-state time overlay and
        /// residual spectrum the report shows; repeatable. Default: the worst record.
        #[arg(long = "record")]
        records: Vec<usize>,
        /// Overwrite existing report files.
        #[arg(long)]
        force: bool,
        /// Print the errors and failing cells as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Name the physical effect the model is missing: every catalogued effect (time_delay,
    /// backlash, coulomb_friction, acceleration_saturation, structural_mode, sensor_lowpass,
    /// operating_point_dependence, sensor_drift, cross_coupling) is added, fitted with the
    /// pendulum and bandwidth, and scored on held-out records; effects are added forward
    /// while they remove a significant part of the error. Verdict: an effect, `none` (the
    /// model explains the data to the noise floor) or `unexplained`.
    Diagnose {
        /// Campaign folder (with campaign.toml).
        campaign: PathBuf,
        /// Model file (zmp-model/1).
        #[arg(long)]
        model: PathBuf,
        /// Also write an HTML report into this folder.
        #[arg(long)]
        report: Option<PathBuf>,
        /// Overwrite existing report files.
        #[arg(long)]
        force: bool,
        /// Print the findings as JSON (zmp-diagnosis/1).
        #[arg(long)]
        json: bool,
    },
    /// Add a catalogued effect to a model, fitted with the pendulum and bandwidth on every
    /// record of a campaign; writes the new model (default <model>+<effect>.toml beside it)
    /// and records both versions and their errors in the ledger beside them.
    Augment {
        /// Model file (zmp-model/1).
        model: PathBuf,
        /// Effect to add (a name from `cargo xtask diagnose`).
        #[arg(long)]
        add: String,
        /// Campaign folder the effect is fitted on.
        #[arg(long)]
        campaign: PathBuf,
        /// Model file to write.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Overwrite an existing output file.
        #[arg(long)]
        force: bool,
        /// Print the result as JSON.
        #[arg(long)]
        json: bool,
    },
    /// The whole loop in one command: identify the seed's model (with the acceleration limit
    /// when the data show one), diagnose it, add what the diagnosis finds one effect at a time
    /// (each version written beside the others and recorded in the ledger), diagnose again,
    /// until the model explains the data or nothing significant is left; prints the error
    /// waterfall and writes it (history.svg) with the diagnosis report.
    Loop {
        /// Campaign folder (with campaign.toml).
        campaign: PathBuf,
        /// A model file whose structure is identified instead of the seed's (its effects are
        /// refitted).
        #[arg(long)]
        model: Option<PathBuf>,
        /// Output folder for the model versions, reports and waterfall (default:
        /// <campaign>-loop beside the campaign folder).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Replace the loop's earlier output in that folder.
        #[arg(long)]
        force: bool,
        /// Print a machine-readable summary (versions, errors, effects found, outcome).
        #[arg(long)]
        json: bool,
        /// Wall-clock limit of the whole loop, in seconds (0: none). Past it every fit ends
        /// with its best parameters so far, the loop stops, writes what it reached and says
        /// so (`time_limit_reached` in --json). Most campaigns take seconds to a minute or
        /// two; a friction beside a play and a mode, whose describing functions are simulated
        /// at every evaluation, can take far longer.
        #[arg(long, value_name = "SECONDS", default_value_t = 900)]
        time_limit: u64,
    },
    /// Robust stability of the cascade ZMP controller against a model's multiplicative
    /// uncertainty (first seed, sections 6.4-6.6): the closed loop's complementary sensitivity
    /// T of each channel against its weight W (`||W T||_inf < 1`: stable for every perturbation
    /// of that channel inside its weight), the structured margin of all four channels at once
    /// (an upper bound of mu: the D-scaled largest singular value over a frequency grid) and
    /// where it is tightest, the nominal closed loop's stability, and the smallest perturbation
    /// that puts a closed-loop pole on the imaginary axis. The plant is the model's small-signal
    /// frequency response (its nonlinear effects left out); see docs/src/robust-stability.md.
    Robust {
        /// Model file (zmp-model/1) with `uncertainty` weights (identify writes them).
        #[arg(long)]
        model: PathBuf,
        /// The cascade's gains K1,K2 (default the seed's 0.014,0.2).
        #[arg(long, value_name = "K1,K2")]
        gains: Option<String>,
        /// CoM displacement per radian of trunk, (m_t/m_r) l_t, m/rad (default 0.1105, the
        /// seed's convention with the ZMP error in cm; only its product with the error scale
        /// matters).
        #[arg(long, value_name = "M_PER_RAD", allow_negative_numbers = true)]
        trunk_gain: Option<f64>,
        /// Controller sample period, s (default 0.01; 0 for the continuous controller). Enters
        /// as the zero-order hold's delay.
        #[arg(long, value_name = "S", allow_negative_numbers = true)]
        period: Option<f64>,
        /// Write |T| against 1/|W| per channel and the structured bound (SVG).
        #[arg(long, value_name = "FILE.svg")]
        plot: Option<PathBuf>,
        /// Overwrite an existing plot file.
        #[arg(long)]
        force: bool,
        /// Print the result as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Validate the seed's model on a MuJoCo twin (physics the project did not write): campaign,
    /// identification, closed loop and diagnosis on the twin, with an HTML report.
    Validate {
        #[command(subcommand)]
        robot: ValidateRobot,
    },
    /// The versions that led to a model (from the ledger beside it: identify and augment
    /// write it) with their errors, as a table and an error waterfall (SVG).
    History {
        /// Model file.
        model: PathBuf,
        /// Waterfall plot (default <model>.history.svg beside it).
        #[arg(long)]
        plot: Option<PathBuf>,
        /// Print the versions as JSON.
        #[arg(long)]
        json: bool,
    },
}

#[derive(Subcommand)]
enum ValidateRobot {
    /// The SILO2 twin (models/mjcf/silo2.xml, first seed): mass-property predictions of the
    /// seed's a and b, ZMP cross-checks and contact-softness budget, a stepped-sine campaign
    /// and its identification, the cascade controller's step and 4 kg load against the
    /// identified model, the diagnosis, frames; OUT/report.html and OUT/summary.json.
    Silo2 {
        /// Output folder (default out/twin-silo2); replaced only with --force and only if an
        /// earlier validation wrote it.
        #[arg(long)]
        out: Option<PathBuf>,
        /// The short version (what CI and the demo run): 10 campaign records instead of 144.
        #[arg(long)]
        short: bool,
        /// The campaign extended to 50 rad/s (240 records: 0.1 and 0.2 mm of CoM from 14 to
        /// 50 rad/s added), to tell the stance resonance from an in-band surrogate.
        #[arg(long, conflicts_with = "short")]
        extended: bool,
        /// Replace OUT if it holds an earlier validation.
        #[arg(long)]
        force: bool,
        /// Print the summary (summary.json) on standard output.
        #[arg(long)]
        json: bool,
        /// Also write this run's numbers into the book page at PATH (docs/src/twin-silo2.md),
        /// between its `<!-- twin-silo2:... -->` markers (full run only): how the book's twin
        /// tables are made.
        #[arg(long, value_name = "PATH", conflicts_with_all = ["short", "extended"])]
        readme: Option<PathBuf>,
    },
}

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // The error chain only; no backtrace dump even with RUST_BACKTRACE set.
            eprintln!("error: {e}");
            for cause in e.chain().skip(1) {
                eprintln!("  caused by: {cause}");
            }
            ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.threads {
        Some(n) => zmp_campaign::par::with_threads(usize::from(n), || dispatch(cli.command)),
        None => dispatch(cli.command),
    }
}

fn dispatch(command: Cmd) -> Result<()> {
    match command {
        Cmd::Setup { quiet } => setup::setup(quiet).map(|_| ()),
        Cmd::Ci { long } => ci::ci(long),
        Cmd::Links => links::check_repository(&env::repo_root()),
        Cmd::Bench {
            counts_only,
            save_baseline,
            only,
            baseline,
            planted_regression,
            json,
        } => bench::bench(&bench::BenchArgs {
            counts_only: counts_only || save_baseline,
            save_baseline,
            only,
            baseline,
            planted_regression,
            json,
        }),
        Cmd::Demo { out, force, json } => demo::demo(&out, force, json),
        Cmd::CalibrateCom {
            out,
            quick,
            runs,
            draws,
            figures,
            markdown,
            json,
            force,
        } => calibrate::calibrate_com(&calibrate::CalibrateArgs {
            out,
            quick,
            runs,
            draws,
            figures,
            markdown,
            json,
            force,
        }),
        Cmd::Identify {
            campaign,
            out,
            report,
            bandwidth,
            model,
            include_saturation,
            force,
            json,
        } => {
            let bw = bandwidth
                .as_deref()
                .map(identify::parse_bandwidth)
                .transpose()?;
            identify::identify(&identify::IdentifyArgs {
                campaign: &campaign,
                out: out.as_deref(),
                report: report.as_deref(),
                model: model.as_deref(),
                bandwidth: bw,
                include_saturation,
                force,
                json,
            })
            .map(|_| ())
        }
        Cmd::Compare {
            campaign,
            model,
            report,
            records,
            force,
            json,
        } => diagnose::compare(&campaign, &model, &report, &records, force, json),
        Cmd::Diagnose {
            campaign,
            model,
            report,
            force,
            json,
        } => diagnose::diagnose_cmd(&campaign, &model, report.as_deref(), force, json).map(|_| ()),
        Cmd::Augment {
            model,
            add,
            campaign,
            out,
            force,
            json,
        } => {
            diagnose::augment_cmd(&model, &add, &campaign, out.as_deref(), force, json).map(|_| ())
        }
        Cmd::Loop {
            campaign,
            model,
            out,
            force,
            json,
            time_limit,
        } => {
            let out = out.unwrap_or_else(|| {
                let name = campaign
                    .file_name()
                    .map(|n| n.to_string_lossy().into_owned())
                    .unwrap_or_else(|| "campaign".into());
                campaign.with_file_name(format!("{name}-loop"))
            });
            loop_cmd::loop_cmd(&loop_cmd::LoopArgs {
                campaign: &campaign,
                model: model.as_deref(),
                out: &out,
                force,
                json,
                time_limit: (time_limit > 0).then(|| std::time::Duration::from_secs(time_limit)),
            })
            .map(|_| ())
        }
        Cmd::Validate {
            robot:
                ValidateRobot::Silo2 {
                    out,
                    short,
                    extended,
                    force,
                    json,
                    readme,
                },
        } => twin::validate_silo2(&twin::Silo2Args {
            out: out.as_deref(),
            short,
            extended,
            force,
            json,
            readme: readme.as_deref(),
        }),
        Cmd::Robust {
            model,
            gains,
            trunk_gain,
            period,
            plot,
            force,
            json,
        } => robust::robust(&robust::RobustArgs {
            model: &model,
            gains: gains.as_deref().map(robust::parse_gains).transpose()?,
            trunk_gain,
            period,
            plot: plot.as_deref(),
            force,
            json,
        })
        .map(|_| ()),
        Cmd::History { model, plot, json } => {
            diagnose::history_cmd(&model, plot.as_deref(), true, json)
        }
        Cmd::Fmu { model, out, force } => fmu::build_fmus(&model, &out, force).map(|files| {
            for f in files {
                println!("{}", f.display());
            }
        }),
        Cmd::Simulate {
            model,
            design,
            seed,
            out,
            force,
            json,
        } => {
            let spec = simulate::load_model(&model)?;
            let mut d = simulate::load_design(design.as_deref())?;
            if let Some(s) = seed {
                d.seed = s;
            }
            let camp = simulate::simulate(&spec, &d, &out, force, json)?;
            let rows: usize = camp.records.iter().map(|r| r.len()).sum();
            if json {
                println!(
                    "{}",
                    serde_json::json!({"campaign": out, "records": camp.records.len(), "rows": rows, "seed": d.seed})
                );
            } else {
                println!(
                    "wrote {} records ({rows} rows) to {}",
                    camp.records.len(),
                    out.display()
                );
            }
            Ok(())
        }
    }
}
