//! `campaign.toml`: parsing with hand-written validation, and rendering.

use super::error::{CampaignError, Part};
use super::{Campaign, Manifest, RecordMeta, FORMAT};
use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use toml::Value;
use zmp_models::Axis;

/// Parses the text of a `campaign.toml`; `file` is only used to name the file in errors.
///
/// Unknown keys (top level and per record) are ignored. Every error names `file`, the record
/// index and the key, and says what was expected.
pub fn parse_manifest(text: &str, file: &Path) -> Result<Manifest, CampaignError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let table = parse_toml(text, file)?;
    let err = |field: &str, message: String| invalid(file, None, field, message);
    check_format(&table, file)?;
    let opt_string = |key: &str| -> Result<Option<String>, CampaignError> {
        match table.get(key) {
            None => Ok(None),
            Some(Value::String(s)) => Ok(Some(s.clone())),
            Some(v) => Err(err(key, format!("must be a string, got {}", show(v)))),
        }
    };
    let name = opt_string("name")?;
    let robot = opt_string("robot")?;
    let sample_rate_hz = match table.get("sample_rate_hz") {
        None => None,
        Some(v) => Some(positive(v).map_err(|m| err("sample_rate_hz", m))?),
    };
    let records = records_array(&table, file)?;
    let mut metas = Vec::with_capacity(records.len());
    // Each record's file, normalised: a record listed twice would be counted twice.
    let mut files: HashMap<PathBuf, usize> = HashMap::with_capacity(records.len());
    for (i, value) in records.iter().enumerate() {
        metas.push(parse_record(i, value, file, &mut files)?);
    }
    Ok(Manifest {
        name,
        robot,
        sample_rate_hz,
        records: metas,
    })
}

/// A manifest error in `file` at record `record` (if any) and key `field`.
fn invalid(file: &Path, record: Option<usize>, field: &str, message: String) -> CampaignError {
    CampaignError::invalid(Part::Manifest, file, None, record, Some(field), message)
}

/// The TOML table of the manifest, or the syntax error with its line and column.
fn parse_toml(text: &str, file: &Path) -> Result<toml::Table, CampaignError> {
    toml::from_str(text).map_err(|e| {
        let (line, col) = match e.span() {
            Some(span) => line_col(text, span.start),
            None => (None, None),
        };
        let at = col.map(|c| format!(" at column {c}")).unwrap_or_default();
        CampaignError::invalid(
            Part::Manifest,
            file,
            line,
            None,
            None,
            format!("TOML syntax error{at}: {}", e.message().trim_end()),
        )
    })
}

/// `format` must be present and exactly this reader's [`FORMAT`].
fn check_format(table: &toml::Table, file: &Path) -> Result<(), CampaignError> {
    let err = |message: String| Err(invalid(file, None, "format", message));
    match table.get("format") {
        None => err(format!(
            "missing required key (expected format = \"{FORMAT}\" as the first line)"
        )),
        Some(Value::String(s)) if s == FORMAT => Ok(()),
        Some(Value::String(s)) => err(format!(
            "unsupported format {s:?}: this reader reads exactly \"{FORMAT}\""
        )),
        Some(v) => err(format!("must be the string \"{FORMAT}\", got {}", show(v))),
    }
}

/// The `[[records]]` array: present, an array, not empty.
fn records_array<'t>(table: &'t toml::Table, file: &Path) -> Result<&'t Vec<Value>, CampaignError> {
    let err = |message: String| invalid(file, None, "records", message);
    let records = match table.get("records") {
        None => {
            return Err(err(
                "missing: expected at least one [[records]] table".into()
            ))
        }
        Some(Value::Array(a)) => a,
        Some(v) => {
            return Err(err(format!(
                "must be an array of tables ([[records]]), got {}",
                show(v)
            )))
        }
    };
    if records.is_empty() {
        return Err(err(
            "is empty: expected at least one [[records]] table".into()
        ));
    }
    Ok(records)
}

/// Record `i` of the manifest: its file (relative, not listed before: `files` holds the
/// normalised files seen so far), excited axis, frequency (rad/s), amplitude (m) and
/// operating point (m).
fn parse_record(
    i: usize,
    value: &Value,
    file: &Path,
    files: &mut HashMap<PathBuf, usize>,
) -> Result<RecordMeta, CampaignError> {
    let Value::Table(rec) = value else {
        return Err(CampaignError::invalid(
            Part::Manifest,
            file,
            None,
            Some(i),
            None,
            format!(
                "must be a table (write it as [[records]]), got {}",
                show(value)
            ),
        ));
    };
    let err = |field: &str, message: String| invalid(file, Some(i), field, message);
    let required = |key: &str| {
        rec.get(key)
            .ok_or_else(|| err(key, "missing required key".to_owned()))
    };

    let file_value = required("file")?;
    let Value::String(file_str) = file_value else {
        return Err(err(
            "file",
            format!(
                "must be a string (a path relative to the campaign folder), got {}",
                show(file_value)
            ),
        ));
    };
    let normalised = check_relative_path(file_str).map_err(|m| err("file", m))?;
    if let Some(j) = files.insert(normalised, i) {
        return Err(err(
            "file",
            format!(
                "{file_str:?} is also the file of records[{j}]: a record listed twice would \
                 be counted twice (its data would weigh double in every fit)"
            ),
        ));
    }

    let excited_value = required("excited")?;
    let excited = match excited_value {
        Value::String(s) => Axis::parse(s),
        _ => None,
    }
    .ok_or_else(|| {
        err(
            "excited",
            format!("must be \"x\" or \"y\", got {}", show(excited_value)),
        )
    })?;

    let omega = positive(required("omega")?).map_err(|m| err("omega", m))?;
    let amplitude = positive(required("amplitude")?).map_err(|m| err("amplitude", m))?;
    let operating_point = parse_operating_point(required("operating_point")?, &err)?;
    Ok(RecordMeta {
        file: PathBuf::from(file_str),
        excited,
        omega,
        amplitude,
        operating_point,
    })
}

/// A record's `operating_point = { x = ..., y = ... }`, m; `err` names the record and key.
fn parse_operating_point(
    op_value: &Value,
    err: &impl Fn(&str, String) -> CampaignError,
) -> Result<[f64; 2], CampaignError> {
    let Value::Table(op) = op_value else {
        return Err(err(
            "operating_point",
            format!(
                "must be an inline table {{ x = ..., y = ... }} in m, got {}",
                show(op_value)
            ),
        ));
    };
    let mut operating_point = [0.0; 2];
    for axis in Axis::BOTH {
        let key = format!("operating_point.{}", axis.name());
        let v = op
            .get(axis.name())
            .ok_or_else(|| err(&key, "missing required key".to_owned()))?;
        operating_point[axis.index()] = finite(v).map_err(|m| err(&key, m))?;
    }
    Ok(operating_point)
}

/// 1-based line and column of byte `offset` in `text`.
fn line_col(text: &str, offset: usize) -> (Option<usize>, Option<usize>) {
    let offset = offset.min(text.len());
    let before = &text.as_bytes()[..offset];
    let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
    let line_start = before
        .iter()
        .rposition(|&b| b == b'\n')
        .map_or(0, |p| p + 1);
    let col = String::from_utf8_lossy(&before[line_start..])
        .chars()
        .count()
        + 1;
    (Some(line), Some(col))
}

/// A short rendering of a TOML value for error messages.
fn show(v: &Value) -> String {
    match v {
        Value::Table(_) => "a table".to_owned(),
        Value::Array(_) => "an array".to_owned(),
        other => {
            let s = other.to_string();
            if s.chars().count() > 60 {
                let cut: String = s.chars().take(57).collect();
                format!("{cut}...")
            } else {
                s
            }
        }
    }
}

fn number(v: &Value) -> Option<f64> {
    match v {
        Value::Float(f) => Some(*f),
        Value::Integer(i) => Some(*i as f64),
        _ => None,
    }
}

fn positive(v: &Value) -> Result<f64, String> {
    match number(v) {
        Some(x) if check_positive(x).is_ok() => Ok(x),
        _ => Err(format!("must be a positive number, got {}", show(v))),
    }
}

fn finite(v: &Value) -> Result<f64, String> {
    match number(v) {
        Some(x) if x.is_finite() => Ok(x),
        Some(_) => Err(format!("must be a finite number, got {}", show(v))),
        None => Err(format!("must be a number, got {}", show(v))),
    }
}

pub(crate) fn check_positive(x: f64) -> Result<f64, String> {
    if x.is_finite() && x > 0.0 {
        Ok(x)
    } else {
        Err(format!("must be a positive number, got {x}"))
    }
}

/// Checks a record path from `campaign.toml` and returns it normalised (components joined by the
/// platform separator, `.` dropped, `a/..` resolved). Both `/` and `\` separate components.
///
/// Rejects empty paths, absolute paths (`/x`, `\x`, `C:\x`, `C:x`) and paths that leave the
/// campaign folder through `..`.
pub(crate) fn check_relative_path(s: &str) -> Result<PathBuf, String> {
    if s.is_empty() {
        return Err("must not be empty: expected a path relative to the campaign folder".into());
    }
    if s.contains('\0') {
        return Err(format!("contains a NUL character: {s:?}"));
    }
    let b = s.as_bytes();
    let drive = b.len() >= 2 && b[0].is_ascii_alphabetic() && b[1] == b':';
    if s.starts_with('/') || s.starts_with('\\') || drive || Path::new(s).is_absolute() {
        return Err(format!(
            "must be a path relative to the campaign folder, got the absolute path {s:?}"
        ));
    }
    let mut parts: Vec<&str> = Vec::new();
    for part in s.split(['/', '\\']) {
        match part {
            "" | "." => {}
            ".." => {
                if parts.pop().is_none() {
                    return Err(format!(
                        "must stay inside the campaign folder, but {s:?} leaves it through \"..\""
                    ));
                }
            }
            p => parts.push(p),
        }
    }
    if parts.is_empty() {
        return Err(format!(
            "does not name a file inside the campaign folder: {s:?}"
        ));
    }
    Ok(parts.iter().collect())
}

/// `campaign.toml` text for `campaign`; the values must have been validated.
pub(crate) fn render_manifest(campaign: &Campaign, files: &[String]) -> String {
    let mut s = String::with_capacity(128 + 160 * campaign.records.len());
    let _ = writeln!(s, "format = {}", toml_string(FORMAT));
    if let Some(name) = &campaign.name {
        let _ = writeln!(s, "name = {}", toml_string(name));
    }
    if let Some(robot) = &campaign.robot {
        let _ = writeln!(s, "robot = {}", toml_string(robot));
    }
    if let Some(rate) = campaign.sample_rate_hz {
        let _ = writeln!(s, "sample_rate_hz = {}", toml_float(rate));
    }
    for (rec, file) in campaign.records.iter().zip(files) {
        let m = &rec.meta;
        let _ = write!(
            s,
            "\n[[records]]\nfile = {}\nexcited = {}\nomega = {}\namplitude = {}\noperating_point = {{ x = {}, y = {} }}\n",
            toml_string(file),
            toml_string(m.excited.name()),
            toml_float(m.omega),
            toml_float(m.amplitude),
            toml_float(m.operating_point[0]),
            toml_float(m.operating_point[1]),
        );
    }
    s
}

/// A finite float as a TOML float literal that parses back to the same bits
/// (`Debug` is the shortest round-trip form and always has a `.` or an exponent).
fn toml_float(x: f64) -> String {
    debug_assert!(x.is_finite());
    format!("{x:?}")
}

/// A TOML basic string.
fn toml_string(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 2);
    out.push('"');
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\t' => out.push_str("\\t"),
            '\r' => out.push_str("\\r"),
            '\u{8}' => out.push_str("\\b"),
            '\u{c}' => out.push_str("\\f"),
            c if c.is_control() => {
                let _ = write!(out, "\\u{:04X}", c as u32);
            }
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relative_paths() {
        assert!(check_relative_path("records/r000.csv").is_ok());
        assert!(check_relative_path("./a/../b.csv").is_ok());
        assert!(check_relative_path("a\\b.csv").is_ok());
        assert!(check_relative_path("/etc/passwd").is_err());
        assert!(check_relative_path("\\x").is_err());
        assert!(check_relative_path("C:\\x").is_err());
        assert!(check_relative_path("../x.csv").is_err());
        assert!(check_relative_path("a/../../x.csv").is_err());
        assert!(check_relative_path("").is_err());
        assert!(check_relative_path("a/..").is_err());
    }

    #[test]
    fn toml_literals_round_trip() {
        for x in [0.0, -0.0, 1.0, 1e16, 1e-7, -2.5e300, 0.1, 123456.789] {
            let text = format!("v = {}", toml_float(x));
            let t: toml::Table = toml::from_str(&text).unwrap();
            assert_eq!(t["v"].as_float().unwrap().to_bits(), x.to_bits(), "{text}");
        }
        let s = "a\"b\\c\nd\te\u{1}\u{7f}é";
        let text = format!("v = {}", toml_string(s));
        let t: toml::Table = toml::from_str(&text).unwrap();
        assert_eq!(t["v"].as_str().unwrap(), s);
    }
}
