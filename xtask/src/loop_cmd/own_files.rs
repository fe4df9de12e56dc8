//! The files a loop run writes into its folder and the marker that lists them.

use anyhow::Result;
use std::path::{Path, PathBuf};

/// The files a loop run writes into its folder, listed in the folder's marker (its name
/// before the file is written, its SHA-256 after), so that `loop --force` removes exactly the
/// earlier run's own versions, and only while they are as it wrote them.
pub(super) struct OwnFiles {
    marker: PathBuf,
    lines: Vec<String>,
}

impl OwnFiles {
    /// The marker's header line (what any marker of this folder kind starts with).
    fn header(&self) -> String {
        format!(
            "This folder holds {} written by zmp-toolkit; `--force` may replace its files.",
            zmp_files::Kind::LoopOutput.describe()
        )
    }

    /// Removes what an earlier run listed: a model still as written (its hash matches) or
    /// whose write was cut short (no hash yet, and still a model file), a report folder that
    /// holds its marker, the waterfall if it is an SVG. Anything else stays.
    pub(super) fn remove_earlier(out: &Path) -> Result<Vec<PathBuf>> {
        let marker = out.join(zmp_files::LOOP_MARKER);
        let text = zmp_files::read_limited_text(&marker, 1 << 20, "a marker file")?;
        let mut hashes = std::collections::HashMap::new();
        let mut listed = Vec::new();
        for line in text.lines() {
            let mut w = line.splitn(3, ' ');
            match (w.next(), w.next(), w.next()) {
                (Some("file"), Some(kind), Some(name)) => {
                    listed.push((kind.to_string(), name.to_string()))
                }
                (Some("sha256"), Some(hash), Some(name)) => {
                    hashes.insert(name.to_string(), hash.to_string());
                }
                _ => {}
            }
        }
        let mut removed = Vec::new();
        for (kind, name) in listed {
            if name.contains('/') || name.starts_with('.') {
                continue;
            }
            let p = out.join(&name);
            // A model or a design only while it is as the run wrote it (its hash), or, cut short
            // before its hash was listed, while it is of its kind; each only if of the kind
            // listed.
            let as_written = || {
                hashes.get(&name).is_none_or(|h| {
                    zmp_files::read_limited(&p, zmp_files::limits::MODEL_BYTES, "a loop's file")
                        .is_ok_and(|b| zmp_files::sha256_hex(&b) == *h)
                })
            };
            let (kind, unchanged) = match kind.as_str() {
                "model" => (zmp_files::Kind::Model, as_written()),
                "design" => (zmp_files::Kind::Design, as_written()),
                "svg" => (zmp_files::Kind::Svg, true),
                "report" => (zmp_files::Kind::Report, true),
                _ => continue,
            };
            if unchanged && zmp_files::remove(&p, kind)? {
                removed.push(p);
            }
        }
        Ok(removed)
    }

    pub(super) fn new(out: &Path) -> OwnFiles {
        OwnFiles {
            marker: out.join(zmp_files::LOOP_MARKER),
            lines: Vec::new(),
        }
    }

    /// Adds a line to the marker (rewritten atomically).
    pub(super) fn note(&mut self, line: String) -> Result<()> {
        self.lines.push(line);
        let text = format!("{}\n{}\n", self.header(), self.lines.join("\n"));
        zmp_files::write_file(&self.marker, zmp_files::Kind::Marker, text.as_bytes(), true)?;
        Ok(())
    }

    /// Writes a model version: listed first, then written, then its hash listed.
    pub(super) fn write_model(&mut self, path: &Path, text: &str) -> Result<()> {
        let name = file_name(path);
        self.note(format!("file model {name}"))?;
        zmp_files::write_file(path, zmp_files::Kind::Model, text.as_bytes(), true)?;
        self.note(format!(
            "sha256 {} {name}",
            zmp_files::sha256_hex(text.as_bytes())
        ))
    }
}

impl OwnFiles {
    /// Writes the designed experiment: listed first, then written (never over a file without
    /// `force`), then its hash listed.
    pub(super) fn write_design(&mut self, path: &Path, text: &str, force: bool) -> Result<()> {
        let name = file_name(path);
        self.note(format!("file design {name}"))?;
        zmp_files::write_file(path, zmp_files::Kind::Design, text.as_bytes(), force)?;
        self.note(format!(
            "sha256 {} {name}",
            zmp_files::sha256_hex(text.as_bytes())
        ))
    }
}

pub(super) fn file_name(p: &Path) -> String {
    p.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}
