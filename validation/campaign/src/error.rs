//! The one error type of the campaign reader and writer.

use std::borrow::Cow;
use std::fmt::Write as _;
use std::io;
use std::path::{Path, PathBuf};

/// Which file kind an [`CampaignError::Invalid`] is about; it decides how the field is shown.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Part {
    /// `campaign.toml`: the field is a key, shown as `records[3].omega` (or `format`).
    Manifest,
    /// A record CSV: the field is a column name, shown as `column zmp_x`.
    Data,
    /// The destination folder of [`write_campaign`](super::write_campaign).
    Destination,
}

/// Everything that can go wrong reading or writing a campaign.
///
/// Every variant names the file it is about; [`CampaignError::Invalid`] also carries the 1-based
/// line (when known), the record index and the key or column, so that the message alone tells the
/// user where to look:
///
/// ```text
/// campaign/records/r003.csv:17: column zmp_x: not a number: "abc"
/// campaign/campaign.toml: records[3].omega: must be a positive number, got -1
/// ```
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CampaignError {
    /// The content of a file (or of an in-memory campaign about to be written) breaks the format.
    #[error("{}", render_invalid(.file, *.line, *.record, .field.as_deref(), .message, *.part))]
    Invalid {
        /// The file the problem is in (`<dir>/campaign.toml` or `<dir>/<record file>`).
        file: PathBuf,
        /// 1-based line in `file`, when it is known.
        line: Option<usize>,
        /// Index of the record in `[[records]]` (0-based, as in `records[3]`).
        record: Option<usize>,
        /// The key (`omega`, `operating_point.x`, `format`) or the CSV column (`zmp_x`).
        field: Option<String>,
        /// What is wrong, including what was expected.
        message: String,
        /// Whether `field` is a manifest key or a CSV column.
        part: Part,
    },
    /// A file or folder could not be read, written, created or renamed.
    #[error("{}", render_io(.path, *.record, .action, .source))]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The record whose file this is, if any (a missing record CSV names its index).
        record: Option<usize>,
        /// "read", "write", "create directory", "rename", ...
        action: &'static str,
        /// The operating system's error.
        #[source]
        source: io::Error,
    },
    /// [`write_campaign`](super::write_campaign) found a non-empty folder and was not allowed to replace it.
    #[error("{}: exists, pass --force to overwrite", .path.display())]
    AlreadyExists {
        /// The folder.
        path: PathBuf,
    },
}

impl From<zmp_files::FileError> for CampaignError {
    /// A refusal or failure of the one output path, as the campaign writer reports it.
    fn from(e: zmp_files::FileError) -> CampaignError {
        use zmp_files::FileError as F;
        match e {
            F::Exists { path } => CampaignError::AlreadyExists { path },
            F::Io {
                path,
                action,
                source,
            } => CampaignError::Io {
                path,
                record: None,
                action,
                source,
            },
            other => CampaignError::invalid(
                Part::Destination,
                other.path(),
                None,
                None,
                None,
                other
                    .to_string()
                    .strip_prefix(&format!("{}: ", other.path().display()))
                    .map(str::to_owned)
                    .unwrap_or_else(|| other.to_string()),
            ),
        }
    }
}

impl CampaignError {
    pub(crate) fn invalid(
        part: Part,
        file: &Path,
        line: Option<usize>,
        record: Option<usize>,
        field: Option<&str>,
        message: impl Into<String>,
    ) -> CampaignError {
        CampaignError::Invalid {
            file: file.to_path_buf(),
            line,
            record,
            field: field.map(str::to_owned),
            message: message.into(),
            part,
        }
    }

    pub(crate) fn io(
        path: &Path,
        record: Option<usize>,
        action: &'static str,
        source: io::Error,
    ) -> CampaignError {
        CampaignError::Io {
            path: path.to_path_buf(),
            record,
            action,
            source,
        }
    }

    /// The file (or folder) the error is about.
    pub fn file(&self) -> &Path {
        match self {
            CampaignError::Invalid { file, .. } => file,
            CampaignError::Io { path, .. } | CampaignError::AlreadyExists { path } => path,
        }
    }

    /// 1-based line number in [`file`](Self::file), when known.
    pub fn line(&self) -> Option<usize> {
        match self {
            CampaignError::Invalid { line, .. } => *line,
            _ => None,
        }
    }

    /// Index of the record concerned, when the error is about one record.
    pub fn record(&self) -> Option<usize> {
        match self {
            CampaignError::Invalid { record, .. } | CampaignError::Io { record, .. } => *record,
            CampaignError::AlreadyExists { .. } => None,
        }
    }

    /// The manifest key (`omega`, `operating_point.x`) or CSV column (`zmp_x`) concerned.
    pub fn field(&self) -> Option<&str> {
        match self {
            CampaignError::Invalid { field, .. } => field.as_deref(),
            CampaignError::Io {
                record: Some(_), ..
            } => Some("file"),
            _ => None,
        }
    }

    /// What went wrong, without the location prefix.
    pub fn message(&self) -> Cow<'_, str> {
        match self {
            CampaignError::Invalid { message, .. } => Cow::Borrowed(message),
            CampaignError::Io { action, source, .. } => {
                Cow::Owned(format!("cannot {action}: {source}"))
            }
            CampaignError::AlreadyExists { .. } => {
                Cow::Borrowed("exists, pass --force to overwrite")
            }
        }
    }

    /// The part of the campaign an [`Invalid`](CampaignError::Invalid) error is about.
    pub fn part(&self) -> Option<Part> {
        match self {
            CampaignError::Invalid { part, .. } => Some(*part),
            _ => None,
        }
    }
}

fn render_invalid(
    file: &Path,
    line: Option<usize>,
    record: Option<usize>,
    field: Option<&str>,
    message: &str,
    part: Part,
) -> String {
    let mut s = file.display().to_string();
    if let Some(line) = line {
        let _ = write!(s, ":{line}");
    }
    match (part, record, field) {
        (Part::Data, _, Some(column)) => {
            let _ = write!(s, ": column {column}");
        }
        (Part::Data, _, None) | (Part::Destination, _, None) => {}
        (_, Some(i), Some(key)) => {
            let _ = write!(s, ": records[{i}].{key}");
        }
        (_, Some(i), None) => {
            let _ = write!(s, ": records[{i}]");
        }
        (_, None, Some(key)) => {
            let _ = write!(s, ": {key}");
        }
        (_, None, None) => {}
    }
    let _ = write!(s, ": {message}");
    s
}

fn render_io(path: &Path, record: Option<usize>, action: &str, source: &io::Error) -> String {
    match record {
        Some(i) => format!(
            "{}: records[{i}].file: cannot {action}: {source}",
            path.display()
        ),
        None => format!("{}: cannot {action}: {source}", path.display()),
    }
}
