//! Writing a campaign folder (`zmp-campaign/1`) with a plain writer of our own.
//!
//! The folder is written aside (a hidden sibling `.NAME.tmp-…`) and renamed into place, so a
//! reader never sees half a campaign. An existing folder is replaced only with `force`, and
//! only if it is a campaign this tool wrote (its `campaign.toml` names `generator =
//! "zmp-indep-sim …"` and it holds nothing but `campaign.toml` and `records/r*.csv`).
//! The truth is never written into the folder.

use crate::design::Design;
use crate::integrate::{try_simulate, RecordData};
use crate::robot::Robot;
use anyhow::{anyhow, bail, Context, Result};
use serde::Serialize;
use std::fs;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// The `generator` key of every `campaign.toml` this crate writes.
pub const GENERATOR: &str = concat!("zmp-indep-sim ", env!("CARGO_PKG_VERSION"));

#[derive(Serialize)]
struct CampaignToml<'a> {
    format: &'a str,
    name: &'a str,
    robot: &'a str,
    sample_rate_hz: f64,
    generator: &'a str,
    records: Vec<RecordToml>,
}

#[derive(Serialize)]
struct RecordToml {
    file: String,
    excited: &'static str,
    omega: f64,
    amplitude: f64,
    operating_point: OpToml,
}

#[derive(Serialize)]
struct OpToml {
    x: f64,
    y: f64,
}

/// Simulates the design on the robot and writes the campaign to `out_dir`.
pub fn write_campaign(robot: &Robot, design: &Design, out_dir: &Path, force: bool) -> Result<()> {
    check_target(out_dir, force)?;
    let records = try_simulate(robot, design).map_err(|e| anyhow!(e))?;
    write_records(&records, design, out_dir, force)
}

/// Writes already simulated records (of `design`) as a campaign to `out_dir`.
pub fn write_records(
    records: &[RecordData],
    design: &Design,
    out_dir: &Path,
    force: bool,
) -> Result<()> {
    check_target(out_dir, force)?;
    let parent = match out_dir.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    fs::create_dir_all(&parent).with_context(|| format!("{}: cannot create", parent.display()))?;
    let name = out_dir
        .file_name()
        .ok_or_else(|| anyhow!("{}: not a folder name", out_dir.display()))?
        .to_string_lossy()
        .into_owned();
    let tmp = TempDir(parent.join(format!(".{name}.tmp-{}", unique())));
    fs::create_dir_all(tmp.0.join("records"))
        .with_context(|| format!("{}: cannot create", tmp.0.display()))?;
    for rec in records {
        let path = tmp.0.join(rec.meta.file());
        write_csv(rec, &path).with_context(|| format!("{}: cannot write", path.display()))?;
    }
    let doc = CampaignToml {
        format: "zmp-campaign/1",
        name: &design.name,
        robot: "zmp-indep-sim virtual biped (parameters hidden)",
        sample_rate_hz: design.sample_rate_hz,
        generator: GENERATOR,
        records: records
            .iter()
            .map(|r| RecordToml {
                file: r.meta.file(),
                excited: r.meta.excited.name(),
                omega: r.meta.omega,
                amplitude: r.meta.amplitude,
                operating_point: OpToml {
                    x: r.meta.operating_point[0],
                    y: r.meta.operating_point[1],
                },
            })
            .collect(),
    };
    let text = toml::to_string(&doc).context("campaign.toml: cannot serialise")?;
    fs::write(tmp.0.join("campaign.toml"), text).context("campaign.toml: cannot write")?;
    if out_dir.exists() {
        // Checked again: another run may have written it meanwhile.
        check_target(out_dir, force)?;
        let old = parent.join(format!(".{name}.old-{}", unique()));
        fs::rename(out_dir, &old)
            .with_context(|| format!("{}: cannot move aside", out_dir.display()))?;
        if let Err(e) = fs::rename(&tmp.0, out_dir) {
            let _ = fs::rename(&old, out_dir);
            bail!(
                "{}: cannot move the new campaign into place: {e}",
                out_dir.display()
            );
        }
        fs::remove_dir_all(&old).with_context(|| format!("{}: cannot remove", old.display()))?;
    } else {
        fs::rename(&tmp.0, out_dir).with_context(|| {
            format!(
                "{}: cannot move the new campaign into place (written concurrently?)",
                out_dir.display()
            )
        })?;
    }
    Ok(())
}

/// Refuses an existing target without `force`, and any existing target this tool did not write.
fn check_target(out_dir: &Path, force: bool) -> Result<()> {
    if !out_dir.exists() {
        return Ok(());
    }
    if !force {
        bail!(
            "{}: already exists; pass --force (force = true) to replace it",
            out_dir.display()
        );
    }
    if !is_our_campaign(out_dir) {
        bail!(
            "{}: exists and is not a campaign written by zmp-indep-sim (campaign.toml with generator = \"zmp-indep-sim …\" and records/r*.csv only); refusing to replace it even with --force",
            out_dir.display()
        );
    }
    Ok(())
}

fn is_our_campaign(dir: &Path) -> bool {
    let Ok(text) = fs::read_to_string(dir.join("campaign.toml")) else {
        return false;
    };
    let Ok(value) = text.parse::<toml::Table>() else {
        return false;
    };
    let ours = value
        .get("generator")
        .and_then(|g| g.as_str())
        .is_some_and(|g| g.starts_with("zmp-indep-sim"));
    if !ours {
        return false;
    }
    let Ok(entries) = fs::read_dir(dir) else {
        return false;
    };
    for e in entries.flatten() {
        let n = e.file_name().to_string_lossy().into_owned();
        match n.as_str() {
            "campaign.toml" => {}
            "records" => {
                let Ok(inner) = fs::read_dir(e.path()) else {
                    return false;
                };
                for f in inner.flatten() {
                    let fname = f.file_name().to_string_lossy().into_owned();
                    if !(fname.starts_with('r') && fname.ends_with(".csv")) {
                        return false;
                    }
                }
            }
            _ => return false,
        }
    }
    true
}

fn write_csv(rec: &RecordData, path: &Path) -> std::io::Result<()> {
    let mut w = BufWriter::with_capacity(1 << 16, fs::File::create(path)?);
    writeln!(w, "t,x_cr,y_cr,zmp_x,zmp_y")?;
    for k in 0..rec.t.len() {
        writeln!(
            w,
            "{},{},{},{},{}",
            rec.t[k], rec.x_cr[k], rec.y_cr[k], rec.zmp_x[k], rec.zmp_y[k]
        )?;
    }
    w.flush()
}

/// A process-unique suffix: pid, time and a counter.
fn unique() -> String {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos());
    format!(
        "{}-{nanos}-{}",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    )
}

/// A folder removed on drop unless it was renamed away.
struct TempDir(PathBuf);

impl Drop for TempDir {
    fn drop(&mut self) {
        if self.0.exists() {
            let _ = fs::remove_dir_all(&self.0);
        }
    }
}

/// Writes `text` to `path` atomically (aside, then renamed); an existing file only with `force`.
pub fn write_file_atomic(path: &Path, text: &str, force: bool) -> Result<()> {
    if path.exists() && !force {
        bail!(
            "{}: already exists; pass --force to replace it",
            path.display()
        );
    }
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    fs::create_dir_all(&parent).with_context(|| format!("{}: cannot create", parent.display()))?;
    let name = path
        .file_name()
        .ok_or_else(|| anyhow!("{}: not a file name", path.display()))?;
    let tmp = parent.join(format!(".{}.tmp-{}", name.to_string_lossy(), unique()));
    fs::write(&tmp, text).with_context(|| format!("{}: cannot write", tmp.display()))?;
    fs::rename(&tmp, path).map_err(|e| {
        let _ = fs::remove_file(&tmp);
        anyhow!("{}: cannot move into place: {e}", path.display())
    })
}
