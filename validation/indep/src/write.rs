//! Writing a campaign folder (`zmp-campaign/1`) with a plain writer of our own, through the
//! one output path (`zmp_files`, a file-output crate: it shares no physics with `zmp-models`).
//!
//! The folder is built aside (a hidden sibling `.NAME.zmp-tmp-…`) and swapped into place, so a
//! reader never sees half a campaign. An existing folder is replaced only with `force`, and
//! only if it is a campaign this tool wrote (its `campaign.toml` names `generator =
//! "zmp-indep-sim …"` and it holds nothing but `campaign.toml` and `records/r*.csv`).
//! The truth is never written into the folder.

use crate::design::Design;
use crate::integrate::{try_simulate, RecordData};
use crate::robot::Robot;
use anyhow::{anyhow, Context, Result};
use serde::Serialize;
use std::io::{BufWriter, Write};
use std::path::Path;
use zmp_files::Kind;

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
    zmp_files::check_dir(out_dir, Kind::IndepCampaign, force)?;
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
    zmp_files::write_dir(
        out_dir,
        Kind::IndepCampaign,
        force,
        |staging| -> Result<()> {
            for rec in records {
                let file = rec.meta.file();
                let f = staging.create(Path::new(&file))?;
                write_csv(rec, f).with_context(|| format!("{file}: cannot write"))?;
            }
            staging.write(Path::new("campaign.toml"), text.as_bytes())?;
            Ok(())
        },
    )?;
    Ok(())
}

fn write_csv(rec: &RecordData, file: std::fs::File) -> std::io::Result<()> {
    let mut w = BufWriter::with_capacity(1 << 16, file);
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

/// Writes `text` to `path` (a truth file, JSON) through the one output path: atomically; an
/// existing file only with `force`, and only if it is JSON.
pub fn write_file_atomic(path: &Path, text: &str, force: bool) -> Result<()> {
    zmp_files::write_file(path, Kind::Json, text.as_bytes(), force)?;
    Ok(())
}
