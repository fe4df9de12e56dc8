//! What the toolkit writes, and how an existing file or folder is recognised as one of them.
//!
//! The rules are stated once, in [`Kind::rule`], and quoted by the user documentation
//! (`docs/src/files-and-safety.md`). A file is recognised from its first
//! [`HEAD_BYTES`] bytes and its name, a folder from its marker file or its `campaign.toml`.

use std::path::Path;

/// How much of an existing file is read to recognise it.
pub const HEAD_BYTES: usize = 64 * 1024;

/// The marker file of a report folder (`identify --report`, `compare`, `diagnose --report`).
pub const REPORT_MARKER: &str = ".zmp-report";
/// The marker file of a `loop` output folder.
pub const LOOP_MARKER: &str = ".zmp-loop-output";
/// The marker file of a `demo` output folder.
pub const DEMO_MARKER: &str = ".zmp-demo-output";
/// The marker file of a `validate silo2` output folder.
pub const TWIN_SILO2_MARKER: &str = ".zmp-twin-silo2";
/// The marker file of a sharded job's folder (`suite`, `fleet`, `calibrate-com --shard`).
pub const JOB_MARKER: &str = ".zmp-job";
/// The file name of the model ledger.
pub const LEDGER_FILE: &str = "zmp-ledger.jsonl";

/// Every kind of file and folder the toolkit writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Kind {
    /// A model file (`zmp-model/1`).
    Model,
    /// The model ledger (`zmp-ledger.jsonl`), appended to, never replaced.
    Ledger,
    /// A campaign's `campaign.toml` (`zmp-campaign/1`).
    Manifest,
    /// A record CSV of a campaign.
    Record,
    /// A plot (SVG).
    Svg,
    /// A report page (HTML).
    Html,
    /// An FMU archive.
    Fmu,
    /// Machine-readable JSON: a summary, a robot's truth, saved states.
    Json,
    /// The effective-CoM calibration (`zmp-com-calibration/1`).
    Calibration,
    /// An experiment design (`design-next`'s records, read by `simulate --design`).
    Design,
    /// The instruction-count baseline of `cargo xtask bench` (`zmp-bench-baseline/1`).
    Baseline,
    /// The bench history (`history.jsonl`), appended to.
    BenchHistory,
    /// The record of the held-out suite's ranges (`held-out-ranges.csv`), one row per range.
    HeldOutRanges,
    /// A Markdown page whose marked sections are regenerated (a README).
    Markdown,
    /// The marker file of an output folder.
    Marker,
    /// A campaign folder written by `simulate` (or the library's campaign writer).
    Campaign,
    /// A campaign folder written by the independent simulator (`zmp-indep-sim`).
    IndepCampaign,
    /// A report folder.
    Report,
    /// The output folder of `loop`.
    LoopOutput,
    /// The output folder of `demo`.
    DemoOutput,
    /// The output folder of `validate silo2`.
    TwinSilo2,
    /// The folder of a sharded job: its description, one result file per unit, the merge.
    Job,
}

/// What a recogniser decided about an existing folder.
pub(crate) enum DirMatch {
    Yes,
    No(String),
}

impl Kind {
    /// Every kind, in the order of the documentation's table.
    pub const ALL: [Kind; 22] = [
        Kind::Model,
        Kind::Ledger,
        Kind::Manifest,
        Kind::Record,
        Kind::Svg,
        Kind::Html,
        Kind::Fmu,
        Kind::Json,
        Kind::Calibration,
        Kind::Design,
        Kind::Baseline,
        Kind::BenchHistory,
        Kind::HeldOutRanges,
        Kind::Markdown,
        Kind::Marker,
        Kind::Campaign,
        Kind::IndepCampaign,
        Kind::Report,
        Kind::LoopOutput,
        Kind::DemoOutput,
        Kind::TwinSilo2,
        Kind::Job,
    ];

    /// A short name for messages ("a model file", "a report folder").
    pub fn describe(self) -> &'static str {
        match self {
            Kind::Model => "a model file (zmp-model/1)",
            Kind::Ledger => "a model ledger",
            Kind::Manifest => "a campaign.toml",
            Kind::Record => "a record CSV",
            Kind::Svg => "an SVG plot",
            Kind::Html => "an HTML report page",
            Kind::Fmu => "an FMU",
            Kind::Json => "a JSON file",
            Kind::Calibration => "a CoM calibration (zmp-com-calibration/1)",
            Kind::Design => "an experiment design",
            Kind::Baseline => "a bench baseline (zmp-bench-baseline/1)",
            Kind::BenchHistory => "a bench history",
            Kind::HeldOutRanges => "the held-out suite's record of ranges",
            Kind::Markdown => "a Markdown page",
            Kind::Marker => "a marker file",
            Kind::Campaign => "a campaign folder",
            Kind::IndepCampaign => "a campaign written by zmp-indep-sim",
            Kind::Report => "a report folder",
            Kind::LoopOutput => "a loop output folder",
            Kind::DemoOutput => "a demo output folder",
            Kind::TwinSilo2 => "a `validate silo2` output folder",
            Kind::Job => "a sharded job's folder",
        }
    }

    /// How an existing file or folder is recognised as this kind (for the documentation).
    pub fn rule(self) -> &'static str {
        match self {
            Kind::Model => "text with a top-level `format = \"zmp-model/1\"`",
            Kind::Ledger => {
                "named `zmp-ledger.jsonl`; empty, or with a line that starts `{\"model\":`"
            }
            Kind::Manifest => "text with a top-level `format = \"zmp-campaign/1\"`",
            Kind::Record => "a CSV whose first line names the columns `t` and `zmp_x`",
            Kind::Svg => "starts (after an optional XML declaration) with an `<svg` element",
            Kind::Html => "starts with `<!doctype html` or `<html`",
            Kind::Fmu => "named `*.fmu` and a zip archive (`PK\\x03\\x04`)",
            Kind::Json => "named `*.json`; its first non-blank character is `{` or `[`",
            Kind::Calibration => "text with a top-level `format = \"zmp-com-calibration/1\"`",
            Kind::Design => "named `*.toml`; a line that starts `[[records]]` or `omegas =`",
            Kind::Baseline => "text with a top-level `format = \"zmp-bench-baseline/1\"`",
            Kind::BenchHistory => "named `*.jsonl`; empty, or its first character is `{`",
            Kind::HeldOutRanges => "named `held-out-ranges.csv`",
            Kind::Markdown => "named `*.md`",
            Kind::Marker => "named `.zmp-*`, under 64 KiB of text",
            Kind::Campaign => {
                "a folder whose `campaign.toml` is `zmp-campaign/1` without a \
                 `generator = \"zmp-indep-sim …\"`"
            }
            Kind::IndepCampaign => {
                "a folder whose `campaign.toml` has `generator = \"zmp-indep-sim …\"` and that \
                 holds nothing but it and `records/r*.csv`"
            }
            Kind::Report => "a folder holding the marker `.zmp-report`",
            Kind::LoopOutput => "a folder holding the marker `.zmp-loop-output`",
            Kind::DemoOutput => "a folder holding the marker `.zmp-demo-output`",
            Kind::TwinSilo2 => "a folder holding the marker `.zmp-twin-silo2`",
            Kind::Job => "a folder holding the marker `.zmp-job`",
        }
    }

    /// Whether this kind is a folder.
    pub fn is_dir(self) -> bool {
        matches!(
            self,
            Kind::Campaign
                | Kind::IndepCampaign
                | Kind::Report
                | Kind::LoopOutput
                | Kind::DemoOutput
                | Kind::TwinSilo2
                | Kind::Job
        )
    }

    /// The marker file of a folder kind that has one.
    pub fn marker(self) -> Option<&'static str> {
        match self {
            Kind::Report => Some(REPORT_MARKER),
            Kind::LoopOutput => Some(LOOP_MARKER),
            Kind::DemoOutput => Some(DEMO_MARKER),
            Kind::TwinSilo2 => Some(TWIN_SILO2_MARKER),
            Kind::Job => Some(JOB_MARKER),
            _ => None,
        }
    }

    /// Whether the existing file `path`, which starts with `head`, is of this (file) kind.
    pub fn matches_file(self, path: &Path, head: &[u8]) -> bool {
        let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
        let text = text_start(head);
        match self {
            Kind::Model => format_tag(head).as_deref() == Some("zmp-model/1"),
            Kind::Manifest => format_tag(head).as_deref() == Some("zmp-campaign/1"),
            Kind::Calibration => format_tag(head).as_deref() == Some("zmp-com-calibration/1"),
            Kind::Baseline => format_tag(head).as_deref() == Some("zmp-bench-baseline/1"),
            Kind::Design => {
                name.ends_with(".toml")
                    && head.split(|b| *b == b'\n').any(|l| {
                        let l = l.trim_ascii_start();
                        l.starts_with(b"[[records]]") || l.starts_with(b"omegas")
                    })
            }
            Kind::Ledger => {
                name == LEDGER_FILE
                    && (head.iter().all(u8::is_ascii_whitespace)
                        || head
                            .split(|b| *b == b'\n')
                            .any(|l| l.starts_with(b"{\"model\":")))
            }
            Kind::BenchHistory => {
                name.ends_with(".jsonl")
                    && (text.is_empty() || text.starts_with(b"{"))
                    && name != LEDGER_FILE
            }
            Kind::Record => {
                let first = head.split(|b| *b == b'\n').next().unwrap_or(b"");
                let cells: Vec<&[u8]> = first
                    .split(|b| *b == b',')
                    .map(<[u8]>::trim_ascii)
                    .collect();
                cells.contains(&&b"t"[..]) && cells.contains(&&b"zmp_x"[..])
            }
            Kind::Svg => {
                let mut t = text;
                if t.starts_with(b"<?xml") {
                    let end = t
                        .windows(2)
                        .position(|w| w == b"?>")
                        .map_or(t.len(), |k| k + 2);
                    t = text_start(&t[end..]);
                }
                t.starts_with(b"<svg")
            }
            Kind::Html => {
                let lower: Vec<u8> = text.iter().take(16).map(u8::to_ascii_lowercase).collect();
                lower.starts_with(b"<!doctype html") || lower.starts_with(b"<html")
            }
            Kind::Fmu => name.ends_with(".fmu") && head.starts_with(b"PK\x03\x04"),
            Kind::Json => {
                name.ends_with(".json") && (text.starts_with(b"{") || text.starts_with(b"["))
            }
            Kind::HeldOutRanges => name == "held-out-ranges.csv",
            Kind::Markdown => name.ends_with(".md"),
            Kind::Marker => name.starts_with(".zmp-") && head.len() < HEAD_BYTES,
            Kind::Campaign
            | Kind::IndepCampaign
            | Kind::Report
            | Kind::LoopOutput
            | Kind::DemoOutput
            | Kind::TwinSilo2
            | Kind::Job => false,
        }
    }

    /// Whether the existing non-empty folder `dir` is of this (folder) kind; if not, why.
    pub(crate) fn matches_dir(self, dir: &Path) -> DirMatch {
        let not = |what: String| DirMatch::No(what);
        if let Some(marker) = self.marker() {
            return if dir.join(marker).is_file() {
                DirMatch::Yes
            } else {
                not(format!(
                    "exists and is not {} (it has no {marker} marker), so it was not written by \
                     zmp-toolkit",
                    self.describe()
                ))
            };
        }
        let manifest = crate::read::head(&dir.join("campaign.toml")).unwrap_or_default();
        let is_campaign = Kind::Manifest.matches_file(Path::new("campaign.toml"), &manifest);
        let indep =
            is_campaign && generator(&manifest).is_some_and(|g| g.starts_with("zmp-indep-sim"));
        match self {
            Kind::Campaign if is_campaign && !indep => DirMatch::Yes,
            Kind::Campaign if indep => {
                not("holds a campaign written by zmp-indep-sim, not by this writer".to_owned())
            }
            Kind::Campaign => not(
                "exists and holds no zmp-campaign/1 campaign.toml, so it does not look like a \
                 campaign written by zmp-toolkit"
                    .to_owned(),
            ),
            Kind::IndepCampaign if indep && only_manifest_and_records(dir) => DirMatch::Yes,
            Kind::IndepCampaign => not(
                "exists and is not a campaign written by zmp-indep-sim (campaign.toml with \
                 generator = \"zmp-indep-sim …\" and records/r*.csv only)"
                    .to_owned(),
            ),
            _ => not(format!("is a folder, not {}", self.describe())),
        }
    }
}

/// What an existing file is, for messages: the first kind it matches, else "a file zmp-toolkit
/// did not write".
pub fn describe_file(path: &Path, head: &[u8]) -> String {
    Kind::ALL
        .iter()
        .find(|k| !k.is_dir() && k.matches_file(path, head))
        .map_or_else(
            || "a file zmp-toolkit did not write (or one it does not recognise)".to_owned(),
            |k| k.describe().to_owned(),
        )
}

/// `head` without a UTF-8 byte-order mark and leading ASCII whitespace.
fn text_start(head: &[u8]) -> &[u8] {
    head.strip_prefix(b"\xEF\xBB\xBF")
        .unwrap_or(head)
        .trim_ascii_start()
}

/// The value of a top-level string key `key = "..."` in TOML text (before any `[table]`), or
/// of a JSON member `"key": "..."`.
fn top_level_string(head: &[u8], key: &str) -> Option<String> {
    let text = String::from_utf8_lossy(text_start(head));
    if text.starts_with('{') {
        let pat = format!("\"{key}\"");
        let at = text.find(&pat)? + pat.len();
        let rest = text[at..].trim_start().strip_prefix(':')?.trim_start();
        let rest = rest.strip_prefix('"')?;
        return Some(rest[..rest.find('"')?].to_owned());
    }
    for line in text.lines() {
        let l = line.trim();
        if l.starts_with('[') {
            return None;
        }
        let Some(rest) = l.strip_prefix(key) else {
            continue;
        };
        let Some(rest) = rest.trim_start().strip_prefix('=') else {
            continue;
        };
        let rest = rest.trim_start().strip_prefix('"')?;
        return Some(rest[..rest.find('"')?].to_owned());
    }
    None
}

/// The `format` tag of TOML or JSON text.
pub(crate) fn format_tag(head: &[u8]) -> Option<String> {
    top_level_string(head, "format")
}

fn generator(head: &[u8]) -> Option<String> {
    top_level_string(head, "generator")
}

/// A folder holding only `campaign.toml` and `records/r*.csv`.
fn only_manifest_and_records(dir: &Path) -> bool {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return false;
    };
    for e in entries.flatten() {
        let n = e.file_name().to_string_lossy().into_owned();
        match n.as_str() {
            "campaign.toml" => {}
            "records" => {
                let Ok(inner) = std::fs::read_dir(e.path()) else {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn files_are_recognised_by_their_content() {
        let p = |n: &str| Path::new(n).to_path_buf();
        let model = b"# comment\nformat = \"zmp-model/1\"\n[pendulum]\na11 = 1\n";
        assert!(Kind::Model.matches_file(&p("m.toml"), model));
        assert!(!Kind::Manifest.matches_file(&p("m.toml"), model));
        // A key inside a table is not the top-level format.
        assert!(!Kind::Model.matches_file(&p("m.toml"), b"[x]\nformat = \"zmp-model/1\"\n"));
        let svg = b"<?xml version=\"1.0\"?>\n<svg xmlns=\"...\">";
        assert!(Kind::Svg.matches_file(&p("a.svg"), svg));
        assert!(Kind::Svg.matches_file(&p("a.svg"), b"  <svg width=\"3\">"));
        assert!(!Kind::Svg.matches_file(&p("zmp-ledger.jsonl"), b"{\"model\":\"a\"}\n"));
        assert!(Kind::Ledger.matches_file(&p("zmp-ledger.jsonl"), b"{\"model\":\"a\"}\n"));
        assert!(Kind::Ledger.matches_file(&p("zmp-ledger.jsonl"), b""));
        assert!(!Kind::Ledger.matches_file(&p("other.jsonl"), b"{\"model\":\"a\"}\n"));
        assert!(!Kind::Ledger.matches_file(&p("zmp-ledger.jsonl"), b"<svg>"));
        assert!(Kind::Html.matches_file(&p("r.html"), b"<!DOCTYPE html><html>"));
        assert!(Kind::Fmu.matches_file(&p("a.fmu"), b"PK\x03\x04rest"));
        assert!(!Kind::Fmu.matches_file(&p("a.zip"), b"PK\x03\x04rest"));
        assert!(Kind::Json.matches_file(&p("s.json"), b"\n {\"format\": \"x\"}"));
        let design = b"# Records designed by design-next\n[[records]]\nexcited = \"y\"\n";
        assert!(Kind::Design.matches_file(&p("d.toml"), design));
        assert!(Kind::Design.matches_file(&p("d.toml"), b"omegas = [1.0, 2.0]\n"));
        // A design-next --out over a model is refused: a model is no design.
        assert!(!Kind::Design.matches_file(&p("m.toml"), model));
        assert!(!Kind::Design.matches_file(&p("d.txt"), design));
        assert_eq!(
            format_tag(b"{\"format\": \"zmp-twin-silo2/1\"}").unwrap(),
            "zmp-twin-silo2/1"
        );
        assert_eq!(
            describe_file(&p("m.toml"), model),
            "a model file (zmp-model/1)"
        );
        assert!(describe_file(&p("thesis.tex"), b"\\documentclass").contains("did not write"));
    }
}
