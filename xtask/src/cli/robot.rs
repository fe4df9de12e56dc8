//! The arguments of the verbs that simulate or validate a robot: simulate, calibrate-com,
//! robust, validate.

use std::path::PathBuf;

use anyhow::Result;
use clap::{Args, Subcommand};

use crate::{calibrate, robust, simulate, twin};

#[derive(Args)]
pub struct CalibrateComCmd {
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
    /// Run only part i of n of the units (blocks of noise draws, one walk pair per model
    /// and run) into the job folder OUT; `cargo xtask merge OUT` then writes what the
    /// one-process run writes, and tables.md (docs/src/scale-out.md).
    #[arg(long, value_name = "i/n", conflicts_with_all = ["unit", "figures", "markdown"])]
    shard: Option<zmp_shard::Shard>,
    /// Run one unit alone into the job folder OUT (one merge named as failed or missing).
    #[arg(long, value_name = "ID", conflicts_with_all = ["figures", "markdown"])]
    unit: Option<String>,
    /// With --shard: when its part is done, take the units of the other parts that no shard
    /// has begun (each unit still runs once; the shards must share OUT, as on a cluster's
    /// shared file system: the Ray driver and the Slurm script pass it).
    #[arg(long, requires = "shard")]
    steal: bool,
}

impl CalibrateComCmd {
    /// Calibrates the centre of mass and walks the models (or one shard or unit of it).
    pub fn run(self) -> Result<()> {
        let CalibrateComCmd {
            out,
            quick,
            runs,
            draws,
            figures,
            markdown,
            json,
            force,
            shard,
            unit,
            steal,
        } = self;
        calibrate::calibrate_com(&calibrate::CalibrateArgs {
            out,
            quick,
            runs,
            draws,
            figures,
            markdown,
            json,
            force,
            shard,
            unit,
            steal,
        })
    }
}

#[derive(Args)]
pub struct SimulateCmd {
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
    /// Write this campaign with the design's records after its own (their noise drawn
    /// after its records'): the campaign a designed experiment extends.
    #[arg(long, value_name = "CAMPAIGN")]
    append: Option<PathBuf>,
    /// Replace an existing campaign folder.
    #[arg(long)]
    force: bool,
    /// Print a machine-readable summary.
    #[arg(long)]
    json: bool,
}

impl SimulateCmd {
    /// Simulates the campaign and writes it.
    pub fn run(self) -> Result<()> {
        simulate::simulate_cmd(
            &self.model,
            self.design.as_deref(),
            self.seed,
            &self.out,
            self.append.as_deref(),
            self.force,
            self.json,
        )
    }
}

#[derive(Args)]
pub struct RobustCmd {
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
}

impl RobustCmd {
    /// Analyses the robust stability of the cascade against the model's uncertainty.
    pub fn run(self) -> Result<()> {
        robust::robust(&robust::RobustArgs {
            model: &self.model,
            gains: self.gains.as_deref().map(robust::parse_gains).transpose()?,
            trunk_gain: self.trunk_gain,
            period: self.period,
            plot: self.plot.as_deref(),
            force: self.force,
            json: self.json,
        })
        .map(|_| ())
    }
}

#[derive(Subcommand)]
pub enum ValidateRobot {
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

impl ValidateRobot {
    /// Validates the seed's model on the twin.
    pub fn run(self) -> Result<()> {
        match self {
            ValidateRobot::Silo2 {
                out,
                short,
                extended,
                force,
                json,
                readme,
            } => twin::validate_silo2(&twin::Silo2Args {
                out: out.as_deref(),
                short,
                extended,
                force,
                json,
                readme: readme.as_deref(),
            }),
        }
    }
}
