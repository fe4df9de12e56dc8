//! The arguments of the verbs over a model and a campaign: identify, compare, diagnose,
//! augment, loop, history.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;

use crate::{diagnose, identify, loop_cmd};

#[derive(Args)]
pub struct IdentifyCmd {
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
    /// Overwrite an existing model file / report files (only files of the same kind: a
    /// model over a model, never over another file).
    #[arg(long)]
    force: bool,
    /// Print a machine-readable summary (parameters, standard errors, excluded records,
    /// warnings).
    #[arg(long)]
    json: bool,
    /// Write the model without an entry in the ledger beside it. Without it, a ledger
    /// entry that cannot be written fails the run (the model is kept and named).
    #[arg(long)]
    no_ledger: bool,
}

impl IdentifyCmd {
    /// Identifies the campaign and writes the model (and the report).
    pub fn run(self) -> Result<()> {
        let bw = self
            .bandwidth
            .as_deref()
            .map(identify::parse_bandwidth)
            .transpose()?;
        identify::identify(&identify::IdentifyArgs {
            campaign: &self.campaign,
            out: self.out.as_deref(),
            report: self.report.as_deref(),
            model: self.model.as_deref(),
            bandwidth: bw,
            include_saturation: self.include_saturation,
            force: self.force,
            json: self.json,
            no_ledger: self.no_ledger,
        })
        .map(|_| ())
    }
}

#[derive(Args)]
pub struct CompareCmd {
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
}

impl CompareCmd {
    /// Compares the model with the campaign and writes the report.
    pub fn run(self) -> Result<()> {
        diagnose::compare(
            &self.campaign,
            &self.model,
            &self.report,
            &self.records,
            self.force,
            self.json,
        )
    }
}

#[derive(Args)]
pub struct DiagnoseCmd {
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
}

impl DiagnoseCmd {
    /// Diagnoses the model on the campaign (and writes the report).
    pub fn run(self) -> Result<()> {
        diagnose::diagnose_cmd(
            &self.campaign,
            &self.model,
            self.report.as_deref(),
            self.force,
            self.json,
        )
        .map(|_| ())
    }
}

#[derive(Args)]
pub struct AugmentCmd {
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
    /// Overwrite an existing output file (a model file only).
    #[arg(long)]
    force: bool,
    /// Print the result as JSON.
    #[arg(long)]
    json: bool,
    /// Write the model without ledger entries. Without it, a ledger entry that cannot be
    /// written fails the run (the model is kept and named).
    #[arg(long)]
    no_ledger: bool,
}

impl AugmentCmd {
    /// Adds the effect, fitted on the campaign, and writes the new model.
    pub fn run(self) -> Result<()> {
        diagnose::augment_cmd(&diagnose::AugmentArgs {
            model: &self.model,
            effect: &self.add,
            campaign: &self.campaign,
            out: self.out.as_deref(),
            force: self.force,
            json: self.json,
            no_ledger: self.no_ledger,
        })
        .map(|_| ())
    }
}

#[derive(Args)]
pub struct LoopCmd {
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
    /// Wall-clock limit of the whole loop, reading and identification included: seconds
    /// (900) or a duration (90s, 15min, 2h), at most 7 days; 0: none. Past it every fit
    /// ends with its best parameters so far (records not yet analysed are left out), the
    /// loop stops, writes what it reached and says so (`time_limit_reached` in --json).
    /// Most campaigns take seconds to a minute or two; a friction beside a play and a
    /// mode, whose describing functions are simulated at every evaluation, can take far
    /// longer.
    #[arg(long, value_name = "SECONDS", default_value = "900", value_parser = loop_cmd::parse_time_limit)]
    time_limit: loop_cmd::TimeLimit,
}

impl LoopCmd {
    /// Runs the loop into `--out` (default `<campaign>-loop` beside the campaign folder).
    pub fn run(self) -> Result<()> {
        let campaign = self.campaign;
        let out = self.out.unwrap_or_else(|| {
            let name = campaign
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_else(|| "campaign".into());
            campaign.with_file_name(format!("{name}-loop"))
        });
        loop_cmd::loop_cmd(&loop_cmd::LoopArgs {
            campaign: &campaign,
            model: self.model.as_deref(),
            out: &out,
            force: self.force,
            json: self.json,
            time_limit: self.time_limit.0,
        })
        .map(|_| ())
    }
}

#[derive(Args)]
pub struct HistoryCmd {
    /// Model file.
    model: PathBuf,
    /// Waterfall plot (default <model>.history.svg beside it).
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Replace an existing plot (an SVG only: never the ledger, a model or another file).
    #[arg(long)]
    force: bool,
    /// Print the versions as JSON.
    #[arg(long)]
    json: bool,
}

impl HistoryCmd {
    /// Prints the model's versions and draws the waterfall.
    pub fn run(self) -> Result<()> {
        diagnose::history_cmd(&self.model, self.plot.as_deref(), self.force, self.json)
    }
}
