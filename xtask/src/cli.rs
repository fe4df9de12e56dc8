//! The command line: the verbs and their documentation (`cargo xtask --help`), each verb
//! handed to its command module by one line. The arguments of the larger verbs live by group:
//! [`project`] (the project's own tasks), [`model`] (identify, compare, diagnose, augment,
//! loop, history) and [`robot`] (simulate, calibrate-com, robust, validate).

mod model;
mod project;
mod robot;

use std::path::PathBuf;

use anyhow::Result;
use clap::{Parser, Subcommand};

use crate::{ci, demo, design_next, env, fleet, fmu, links, scale, setup};
use model::{AugmentCmd, CompareCmd, DiagnoseCmd, HistoryCmd, IdentifyCmd, LoopCmd};
use project::BenchCmd;
use robot::{CalibrateComCmd, RobustCmd, SimulateCmd, ValidateRobot};

#[derive(Parser)]
#[command(name = "cargo xtask", about = "ZMP biped identification toolkit tasks")]
pub struct Cli {
    #[command(subcommand)]
    pub command: Cmd,
    /// Worker threads for reading, identification and diagnosis (identify, compare, diagnose,
    /// augment, loop). Default: every core. Results do not depend on it.
    #[arg(long, global = true, value_name = "N", value_parser = clap::value_parser!(u16).range(1..))]
    pub threads: Option<u16>,
}

#[derive(Subcommand)]
pub enum Cmd {
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
    Bench(BenchCmd),
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
    CalibrateCom(CalibrateComCmd),
    /// The out-of-sample suite (robots of zmp-indep-sim through the user's loop), one unit per
    /// draw, in one process or as shards on many machines (docs/src/scale-out.md); a whole run
    /// merges at the end: table.md, report.md and result.json in OUT.
    Suite(scale::SuiteArgs),
    /// Combine a job folder's unit files (suite, fleet, calibrate-com --shard) into the
    /// table, report and JSON the one-process run writes (replacing the merge's own earlier
    /// files there); name failed and missing units (then exit non-zero); print the critical
    /// path and the predicted wall time on 1, 2, 8, 64 and 256 workers.
    Merge(scale::MergeArgs),
    /// The user's loop on every campaign folder under DIR (one robot each), one unit per
    /// campaign, in one process or sharded; a campaign that cannot be read fails alone.
    Fleet(fleet::FleetArgs),
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
    /// min_steady_s, zmp_noise_std, quantisation, seed, internal_step, record_com), or lists
    /// its records instead of the grid ([[records]] with excited, omega, amplitude,
    /// operating_point: what design-next writes). docs/src/spec/design-format.md.
    Simulate(SimulateCmd),
    /// Design the records that separate two or three rival models (T-optimal: each taken as
    /// true, the others refitted to it with every parameter) within the robot's limits; writes
    /// a design file that `simulate --design` and zmp-indep-sim run, prints the predicted
    /// separations (noise standard deviations), recording time and limits (design-next.md).
    DesignNext(design_next::DesignArgs),
    /// Identify the seed's ZMP model from a stepped-sine campaign (zmp-campaign/1): steady
    /// state, FFT + harmonic regression per record, weighted pendulum + low-pass fit with
    /// standard errors, acceleration saturation, uncertainty weights (first seed, section 5).
    Identify(IdentifyCmd),
    /// Compare a model with a campaign: one error measure per record and channel against its
    /// noise floor, where the model fails (channel, frequency band, amplitude, operating
    /// point), and an HTML report (Bode and time overlays, residual spectrum, harmonics,
    /// error against frequency, amplitude and operating point).
    Compare(CompareCmd),
    /// Name the physical effects the model is missing: one search over structures (the model
    /// plus up to four catalogued effects: time_delay, backlash, coulomb_friction,
    /// acceleration_saturation, structural_mode, sensor_lowpass, operating_point_dependence,
    /// sensor_drift, cross_coupling), each fitted with the pendulum and servo on half of the
    /// frequencies and scored on the other half against the records' period-to-period noise,
    /// compared by one test at 1 % shared over the comparisons (docs/src/diagnosis.md).
    /// Verdict: the effects, `none` (the model explains the data), `parameter_refit`,
    /// `ambiguous` (the structures the records cannot separate; `loop` then designs the
    /// records that will) or `unexplained` (the residual described in words).
    Diagnose(DiagnoseCmd),
    /// Add a catalogued effect to a model, fitted with the pendulum and bandwidth on every
    /// record of a campaign; writes the new model (default <model>+<effect>.toml beside it)
    /// and records both versions and their errors in the ledger beside them.
    Augment(AugmentCmd),
    /// The whole loop in one command: identify the seed's model (with the acceleration limit
    /// when the data show one), diagnose it once (one search over structures of up to four
    /// effects), and write what the search concludes as model versions, one effect added at a
    /// time along the best structure (each version beside the others and recorded in the
    /// ledger; every structure of the set when the records cannot decide, with the records
    /// that will: design-next.toml); prints the error waterfall and writes it (history.svg)
    /// with the diagnosis report.
    Loop(LoopCmd),
    /// Robust stability of the cascade ZMP controller against a model's multiplicative
    /// uncertainty (first seed, sections 6.4-6.6): the closed loop's complementary sensitivity
    /// T of each channel against its weight W (`||W T||_inf < 1`: stable for every perturbation
    /// of that channel inside its weight), the structured margin of all four channels at once
    /// (an upper bound of mu: the D-scaled largest singular value over a frequency grid) and
    /// where it is tightest, the nominal closed loop's stability, and the smallest perturbation
    /// that puts a closed-loop pole on the imaginary axis. The plant is the model's small-signal
    /// frequency response (its nonlinear effects left out); see docs/src/robust-stability.md.
    Robust(RobustCmd),
    /// Validate the seed's model on a MuJoCo twin (physics the project did not write): campaign,
    /// identification, closed loop and diagnosis on the twin, with an HTML report.
    Validate {
        #[command(subcommand)]
        robot: ValidateRobot,
    },
    /// The versions that led to a model (from the ledger beside it: identify and augment
    /// write it) with their errors, as a table and an error waterfall (SVG).
    History(HistoryCmd),
}

impl Cmd {
    /// Runs the verb.
    pub fn run(self) -> Result<()> {
        match self {
            Cmd::Setup { quiet } => setup::setup(quiet).map(|_| ()),
            Cmd::Ci { long } => ci::ci(long),
            Cmd::Links => links::check_repository(&env::repo_root()),
            Cmd::Bench(a) => a.run(),
            Cmd::Demo { out, force, json } => demo::demo(&out, force, json),
            Cmd::Suite(a) => scale::suite(a),
            Cmd::Merge(a) => scale::merge(&a.dir, a.json),
            Cmd::Fleet(a) => fleet::fleet(a),
            Cmd::CalibrateCom(a) => a.run(),
            Cmd::Identify(a) => a.run(),
            Cmd::Compare(a) => a.run(),
            Cmd::Diagnose(a) => a.run(),
            Cmd::Augment(a) => a.run(),
            Cmd::Loop(a) => a.run(),
            Cmd::Validate { robot } => robot.run(),
            Cmd::Robust(a) => a.run(),
            Cmd::History(a) => a.run(),
            Cmd::Fmu { model, out, force } => fmu::build_fmus(&model, &out, force).map(|files| {
                for f in files {
                    println!("{}", f.display());
                }
            }),
            Cmd::Simulate(a) => a.run(),
            Cmd::DesignNext(args) => design_next::design_next_cmd(&args).map(|_| ()),
        }
    }
}
