//! `cargo xtask fleet DIR --out OUT`: the user's loop (`cargo xtask loop`) on every campaign
//! folder of DIR, one unit per campaign (a lab re-identifying its robots every night), sharded
//! like the suite (docs/src/scale-out.md). A campaign that cannot be read is a failed unit
//! with the reader's error (file, line, field); the other campaigns are not affected.

use crate::loop_cmd::{run_loop, LoopArgs};
use crate::scale::run_options;
use anyhow::{bail, Context, Result};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use zmp_shard::cli::{finish_part, run_part};
use zmp_shard::{Collected, Job, JobKind, Shard, UnitSpec};

/// `cargo xtask fleet`.
#[derive(clap::Args)]
pub struct FleetArgs {
    /// Folder of campaign folders: every folder directly inside it (hidden ones aside) is one
    /// robot's campaign, its name the unit's id.
    pub campaigns: PathBuf,
    /// Job folder: job.json, units/<id>.json, each loop's output under loops/<id>/, and after
    /// the merge table.md, report.md and result.json. Shards of one job share it.
    #[arg(long)]
    pub out: PathBuf,
    /// Run only part i of n of the campaigns (balanced by the campaigns' sizes).
    #[arg(long, value_name = "i/n", conflicts_with = "unit")]
    pub shard: Option<Shard>,
    /// Re-run one campaign alone (its unit id: the folder name, characters other than
    /// letters, digits, '.', '_', '-' replaced by '_').
    #[arg(long, value_name = "ID")]
    pub unit: Option<String>,
    /// With --shard: when its part is done, take the units of the other parts that no shard
    /// has begun (each unit still runs once; the shards must share OUT, as on a cluster's
    /// shared file system: the Ray driver and the Slurm script pass it).
    #[arg(long, requires = "shard")]
    pub steal: bool,
    /// Wall-clock limit of each loop, in seconds (0: none), as `cargo xtask loop`.
    #[arg(long, value_name = "SECONDS", default_value_t = 900)]
    pub time_limit: u64,
    /// Print the merged result (or, for a shard, what it ran) as JSON.
    #[arg(long)]
    pub json: bool,
}

/// A campaign folder's unit id.
pub fn unit_id(name: &str) -> String {
    let id: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-') {
                c
            } else {
                '_'
            }
        })
        .collect();
    if id.starts_with('.') {
        format!("_{id}")
    } else {
        id
    }
}

/// Bytes of the files in a folder and its subfolders: a campaign's expected cost (the loop's
/// work grows with its records' samples).
fn size(dir: &Path) -> f64 {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return 0.0;
    };
    entries
        .filter_map(|e| e.ok())
        .map(|e| match e.file_type() {
            Ok(t) if t.is_dir() => size(&e.path()),
            Ok(t) if t.is_file() => e.metadata().map_or(0.0, |m| m.len() as f64),
            _ => 0.0,
        })
        .sum()
}

/// The fleet's job: one unit per campaign folder of `dir`, in name order.
pub fn job(dir: &Path, time_limit: u64) -> Result<(Job, Vec<(String, PathBuf)>)> {
    let entries =
        std::fs::read_dir(dir).with_context(|| format!("reading the fleet {}", dir.display()))?;
    let mut folders: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_dir())
        .filter(|p| {
            !p.file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with('.'))
        })
        .collect();
    folders.sort();
    if folders.is_empty() {
        bail!("{}: no campaign folders in it", dir.display());
    }
    let mut campaigns: Vec<(String, PathBuf)> = Vec::new();
    for f in folders {
        let name = f.file_name().map(|n| n.to_string_lossy().into_owned());
        let id = unit_id(&name.unwrap_or_default());
        if let Some((_, other)) = campaigns.iter().find(|(i, _)| *i == id) {
            bail!(
                "{} and {} have the same unit id {id}: rename one",
                other.display(),
                f.display()
            );
        }
        campaigns.push((id, f));
    }
    let abs = std::path::absolute(dir).unwrap_or_else(|_| dir.to_path_buf());
    let units = campaigns
        .iter()
        .map(|(id, p)| UnitSpec::new(id.clone(), size(p)))
        .collect();
    let params = json!({"campaigns": abs, "time_limit_s": time_limit});
    Ok((Job::new(JobKind::Fleet, params, units)?, campaigns))
}

/// One campaign's loop, quiet, into `OUT/loops/<id>`; its summary as the unit's outcome.
fn run_unit(campaign: &Path, out: &Path, time_limit: u64) -> Result<Value> {
    let camp = crate::diagnose::read(campaign, true)?;
    let summary = run_loop(
        &camp,
        &LoopArgs {
            campaign,
            model: None,
            out,
            force: true,
            json: true,
            time_limit: (time_limit > 0).then(|| std::time::Duration::from_secs(time_limit)),
        },
        true,
    )?;
    Ok(serde_json::to_value(summary)?)
}

/// `cargo xtask fleet`.
pub fn fleet(a: FleetArgs) -> Result<()> {
    let (job, campaigns) = job(&a.campaigns, a.time_limit)?;
    let whole = a.shard.is_none() && a.unit.is_none();
    let opts = run_options(a.shard, a.unit, false, a.steal);
    let loops = a.out.join("loops");
    let r = run_part(&a.out, &job, &opts, a.json, |spec| {
        let (_, path) = campaigns
            .iter()
            .find(|(id, _)| *id == spec.id)
            .ok_or_else(|| anyhow::anyhow!("no campaign for unit {}", spec.id))?;
        run_unit(path, &loops.join(&spec.id), a.time_limit)
    })?;
    if whole {
        crate::scale::merge(&a.out, a.json)
    } else {
        finish_part(&a.out, &r, a.json)
    }
}

/// The fleet's table, report and JSON (the same bytes however the campaigns were sharded).
pub fn render(c: &Collected) -> Result<zmp_shard::Merged> {
    let mut table = String::from(
        "| campaign | outcome | effects added | identified / floor | final / floor | time limit |\n\
         |---|---|---|---|---|---|\n",
    );
    let mut rows = Vec::new();
    for d in &c.done {
        let o = &d.outcome;
        let floor = o["noise_floor"].as_f64().unwrap_or(f64::NAN);
        let versions = o["versions"].as_array().cloned().unwrap_or_default();
        let err = |v: Option<&Value>| v.and_then(|v| v["error"].as_f64()).unwrap_or(f64::NAN);
        let (first, last) = (err(versions.first()), err(versions.last()));
        let found: Vec<&str> = o["found"]
            .as_array()
            .map(|a| a.iter().filter_map(|v| v.as_str()).collect())
            .unwrap_or_default();
        let limited = o["time_limit_reached"].as_bool().unwrap_or(false);
        table.push_str(&format!(
            "| {} | {} | {} | {:.2} | {:.2} | {} |\n",
            d.spec.id,
            o["outcome"].as_str().unwrap_or("?"),
            if found.is_empty() {
                "-".into()
            } else {
                found.join(", ")
            },
            first / floor,
            last / floor,
            if limited { "reached" } else { "-" },
        ));
        rows.push(json!({"campaign": d.spec.id, "loop": o}));
    }
    for f in &c.failed {
        table.push_str(&format!(
            "| {} | failed | {} | | | |\n",
            f.unit,
            f.error.replace('|', "\\|").replace('\n', " ")
        ));
    }
    for m in &c.missing {
        table.push_str(&format!("| {m} | missing | | | | |\n"));
    }
    let result = json!({
        "format": "zmp-fleet/1",
        "campaigns": c.job.params["campaigns"],
        "loops": rows,
        "failed": c.failed.iter().map(|f| json!({"campaign": f.unit, "error": f.error})).collect::<Vec<_>>(),
        "missing": c.missing,
    });
    let mut json_text = serde_json::to_string_pretty(&result)?;
    json_text.push('\n');
    let report = format!(
        "**Fleet {}: {} campaigns, {} loops, {} failed, {} missing**\n\n{table}",
        c.job.params["campaigns"].as_str().unwrap_or("?"),
        c.job.units.len(),
        c.done.len(),
        c.failed.len(),
        c.missing.len()
    );
    Ok(zmp_shard::Merged {
        files: vec![
            ("table.md".into(), table.clone().into_bytes()),
            ("report.md".into(), report.clone().into_bytes()),
            ("result.json".into(), json_text.into_bytes()),
        ],
        json: result,
        text: report,
    })
}
