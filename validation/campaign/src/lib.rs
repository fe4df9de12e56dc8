//! Campaign folders in the `zmp-campaign/1` format: a `campaign.toml` listing stepped-sine
//! records (excited axis, ω, amplitude, operating point) plus one CSV per record with columns
//! `t, x_cr, y_cr, zmp_x, zmp_y` (extra columns allowed). The exact format is specified in
//! `docs/src/spec/campaign-format.md`; this crate reads it (in parallel, with errors that name
//! file, line, record and key/column) and writes it atomically and bit-exactly.
//!
//! Beside the format: the model [`ledger`] (which model came from which, with its error) and
//! the toolkit's one thread pool ([`par`]), which the reading, the identification and the
//! diagnosis share.
#![warn(missing_docs)]

pub mod ledger;
pub mod par;

mod append;
mod data;
mod error;
mod manifest;
mod omega;
mod write;

pub use append::append_campaign;
pub use data::{parse_record, MAX_COLUMNS, REQUIRED_COLUMNS, STEP_TOLERANCE};
pub use error::{CampaignError, Part};
pub use manifest::parse_manifest;
pub use omega::{dominant_line, windowed_dtft, LINE_SHARE, MIN_PERIODS, MIN_SAMPLES};
pub use write::{check_destination, write_campaign};
/// The size limits of a campaign's files (`campaign.toml`, a record) and of a record's header.
pub use zmp_files::limits::{
    MANIFEST_BYTES as MAX_MANIFEST_BYTES, RECORD_BYTES as MAX_RECORD_BYTES,
};

use std::path::{Path, PathBuf};
use zmp_models::Axis;

/// The value of the `format` key this module reads and writes.
pub const FORMAT: &str = "zmp-campaign/1";

/// The name of the manifest inside a campaign folder.
pub const MANIFEST_FILE: &str = "campaign.toml";

/// A whole campaign: header fields of `campaign.toml` and every record with its data.
#[derive(Debug, Clone, PartialEq)]
pub struct Campaign {
    /// The campaign's name (`name`).
    pub name: Option<String>,
    /// The robot it was measured on (`robot`).
    pub robot: Option<String>,
    /// If given, every record's time step must agree with it within 1 %.
    pub sample_rate_hz: Option<f64>,
    /// Every record, in `campaign.toml`'s order.
    pub records: Vec<Record>,
}

/// The content of `campaign.toml` alone: a campaign without its data.
#[derive(Debug, Clone, PartialEq)]
pub struct Manifest {
    /// The campaign's name (`name`).
    pub name: Option<String>,
    /// The robot it was measured on (`robot`).
    pub robot: Option<String>,
    /// The stated sample rate, Hz (`sample_rate_hz`).
    pub sample_rate_hz: Option<f64>,
    /// Every `[[records]]` table, in file order.
    pub records: Vec<RecordMeta>,
}

/// One `[[records]]` table of `campaign.toml`.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordMeta {
    /// The record CSV, relative to the campaign folder, as written in `campaign.toml`.
    pub file: PathBuf,
    /// The reference channel that carries the sine.
    pub excited: Axis,
    /// Excitation frequency, rad/s.
    pub omega: f64,
    /// Sine amplitude of the excited reference, m.
    pub amplitude: f64,
    /// The constant references `[x, y]` the excitation oscillates around, m.
    pub operating_point: [f64; 2],
}

/// One record: its metadata and its columns (all the same length, SI units).
#[derive(Debug, Clone, PartialEq)]
pub struct Record {
    /// What `campaign.toml` says of the record.
    pub meta: RecordMeta,
    /// Time, s: strictly increasing, uniform step.
    pub t: Vec<f64>,
    /// CoM reference, x (lateral), absolute (includes the operating point), m.
    pub x_cr: Vec<f64>,
    /// CoM reference, y (sagittal), absolute, m.
    pub y_cr: Vec<f64>,
    /// Measured ZMP, x, m.
    pub zmp_x: Vec<f64>,
    /// Measured ZMP, y, m.
    pub zmp_y: Vec<f64>,
    /// Extra numeric columns in file order, by name (e.g. measured CoM `x_c`, `y_c`).
    pub extra: Vec<(String, Vec<f64>)>,
}

impl Record {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// Whether the record has no samples.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Mean time step, s (NaN with fewer than 2 samples).
    pub fn dt(&self) -> f64 {
        match self.t.len() {
            0 | 1 => f64::NAN,
            n => (self.t[n - 1] - self.t[0]) / (n - 1) as f64,
        }
    }

    /// The CoM reference of `axis` (`x_cr` or `y_cr`).
    pub fn input(&self, axis: Axis) -> &[f64] {
        match axis {
            Axis::X => &self.x_cr,
            Axis::Y => &self.y_cr,
        }
    }

    /// The measured ZMP of `axis` (`zmp_x` or `zmp_y`).
    pub fn output(&self, axis: Axis) -> &[f64] {
        match axis {
            Axis::X => &self.zmp_x,
            Axis::Y => &self.zmp_y,
        }
    }

    /// The reference that carries the sine (`input(meta.excited)`).
    pub fn excitation(&self) -> &[f64] {
        self.input(self.meta.excited)
    }

    /// Any column by name: a required one or an extra one.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        match name {
            "t" => Some(&self.t),
            "x_cr" => Some(&self.x_cr),
            "y_cr" => Some(&self.y_cr),
            "zmp_x" => Some(&self.zmp_x),
            "zmp_y" => Some(&self.zmp_y),
            _ => self
                .extra
                .iter()
                .find(|(n, _)| n == name)
                .map(|(_, v)| v.as_slice()),
        }
    }
}

impl Campaign {
    /// The metadata part of the campaign (what `campaign.toml` holds).
    pub fn manifest(&self) -> Manifest {
        Manifest {
            name: self.name.clone(),
            robot: self.robot.clone(),
            sample_rate_hz: self.sample_rate_hz,
            records: self.records.iter().map(|r| r.meta.clone()).collect(),
        }
    }
}

/// Reads `dir/campaign.toml` only (no CSV is opened).
pub fn read_manifest(dir: &Path) -> Result<Manifest, CampaignError> {
    let path = dir.join(MANIFEST_FILE);
    let bytes = zmp_files::read_limited(&path, MAX_MANIFEST_BYTES, "campaign.toml")
        .map_err(|e| read_error(e, Part::Manifest, &path, None))?;
    let text = std::str::from_utf8(&bytes).map_err(|e| {
        let at = e.valid_up_to();
        let line = bytes[..at].iter().filter(|&&b| b == b'\n').count() + 1;
        CampaignError::invalid(
            Part::Manifest,
            &path,
            Some(line),
            None,
            None,
            format!("not valid UTF-8 text (bad byte at offset {at}); campaign.toml must be UTF-8"),
        )
    })?;
    parse_manifest(text, &path)
}

/// A failed bounded read of `path` as a campaign error: one too large names the limit, the
/// rest is an I/O error.
fn read_error(
    e: zmp_files::FileError,
    part: Part,
    path: &Path,
    record: Option<usize>,
) -> CampaignError {
    match e {
        zmp_files::FileError::TooLarge { limit, .. } => CampaignError::invalid(
            part,
            path,
            None,
            record,
            None,
            format!(
                "larger than {limit} bytes, the limit for {}",
                if part == Part::Manifest {
                    "campaign.toml"
                } else {
                    "a record"
                }
            ),
        ),
        zmp_files::FileError::Io { source, .. } => CampaignError::io(path, record, "read", source),
        other => CampaignError::io(
            path,
            record,
            "read",
            std::io::Error::other(other.to_string()),
        ),
    }
}

/// Reads the CSV of record `index` (described by `meta`) of the campaign in `dir`.
pub fn read_record(
    dir: &Path,
    index: usize,
    meta: &RecordMeta,
    sample_rate_hz: Option<f64>,
) -> Result<Record, CampaignError> {
    let shown = dir.join(&meta.file);
    let relative = meta
        .file
        .to_str()
        .ok_or_else(|| "is not valid UTF-8".to_owned())
        .and_then(manifest::check_relative_path)
        .map_err(|m| {
            CampaignError::invalid(
                Part::Manifest,
                &dir.join(MANIFEST_FILE),
                None,
                Some(index),
                Some("file"),
                m,
            )
        })?;
    let path = dir.join(relative);
    // The file's bytes go into this thread's buffer, kept from record to record: a campaign
    // read in parallel touches fresh memory for its columns only, not again for its text.
    thread_local! {
        static BYTES: std::cell::RefCell<Vec<u8>> = const { std::cell::RefCell::new(Vec::new()) };
    }
    BYTES.with(|cell| {
        let mut borrowed = cell.try_borrow_mut();
        let mut own = Vec::new();
        let bytes = match borrowed.as_deref_mut() {
            Ok(buf) => buf,
            Err(_) => &mut own, // re-entered on this thread (not done today): a buffer of its own
        };
        zmp_files::read_limited_into(&path, MAX_RECORD_BYTES, "a record", bytes)
            .map_err(|e| read_error(e, Part::Data, &shown, Some(index)))?;
        let record =
            parse_record(bytes, &shown, index, meta.clone(), sample_rate_hz).and_then(|r| {
                omega::check_omega(&r, &dir.join(MANIFEST_FILE), &shown, index)?;
                Ok(r)
            });
        // A buffer grown for an unusually large file is not kept.
        if bytes.capacity() > 64 << 20 {
            *bytes = Vec::new();
        }
        record
    })
}

/// Reads a whole campaign folder: `campaign.toml` and every record CSV, in parallel.
///
/// On failure returns the first error in record order (deterministically, whatever the thread
/// scheduling).
pub fn read_campaign(dir: &Path) -> Result<Campaign, CampaignError> {
    let manifest = read_manifest(dir)?;
    let records = map_records(dir, &manifest, crate::par::budget(), |_, r| r)?;
    Ok(Campaign {
        name: manifest.name,
        robot: manifest.robot,
        sample_rate_hz: manifest.sample_rate_hz,
        records,
    })
}

/// Reads every record of `manifest` (the manifest of the campaign in `dir`) on up to
/// `threads` threads and hands each to `job(index, record)` on the thread that read it, while
/// its data is still in that core's cache; returns the results in record order, or the first
/// read error in record order. What `job` drops is freed at once: the identification (`zmp-identify`) keeps
/// each record's analysis, not its columns, so a campaign of any size is identified in the
/// memory of a few records.
pub fn map_records<T: Send>(
    dir: &Path,
    manifest: &Manifest,
    threads: usize,
    job: impl Fn(usize, Record) -> T + Sync,
) -> Result<Vec<T>, CampaignError> {
    let rate = manifest.sample_rate_hz;
    crate::par::try_parallel_map(manifest.records.len(), threads, |i| {
        read_record(dir, i, &manifest.records[i], rate).map(|r| job(i, r))
    })
}

/// Runs `job(0..n)` on the thread budget ([`crate::par::budget`]: the available cores unless a
/// caller set it) and collects the results in index order; on failure the error of the
/// smallest failing index.
pub(crate) fn for_each_parallel<T: Send>(
    n: usize,
    job: impl Fn(usize) -> Result<T, CampaignError> + Sync,
) -> Result<Vec<T>, CampaignError> {
    crate::par::try_parallel_map(n, crate::par::budget(), job)
}
