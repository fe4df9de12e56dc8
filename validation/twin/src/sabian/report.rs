//! The calibration and walking report: `com-calibration.toml` (every number), `report.html`
//! (the seed's tables beside ours) and SVG figures (error ellipses; the seed's figures 5-8).

use super::effort::effort_table;
use super::experiment::{CalibrationOutcome, ModelOutcome};
pub use super::figures::figures;
use super::tables::{calibration_table, walking_tables, xy_check_table};
use anyhow::Result;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use zmp_files::atomic_write;

/// Everything the report shows.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Outcome {
    pub format: String,
    pub command: String,
    pub runs_per_model: usize,
    pub calibration: CalibrationOutcome,
    pub walking: Vec<ModelOutcome>,
}

/// The docs page's sections this report writes: `(tag, Markdown)`, the tags of the
/// `<!-- TAG -->` markers in `docs/src/com-calibration.md`.
pub fn sections(o: &Outcome) -> Vec<(&'static str, String)> {
    let w = &o.walking;
    vec![
        ("com:calibration", calibration_table(&o.calibration)),
        ("com:xy-rows", xy_check_table()),
        ("com:tpc-effort", effort_table(w)),
        (
            "com:walk-tpc",
            walking_tables(w, &|m| &m.with_tpc.mean, true),
        ),
        (
            "com:walk-tpc-256",
            walking_tables(w, &|m| &m.with_tpc.mean_motion, false),
        ),
        (
            "com:walk-open",
            walking_tables(w, &|m| &m.open_loop.mean, true),
        ),
    ]
}

/// Headings of [`sections`] in the report and in `--markdown`.
fn heading(tag: &str) -> &'static str {
    match tag {
        "com:calibration" => "Calibration accuracy (the seed's eq. 7 variant beside ours)",
        "com:xy-rows" => "The seed's XY rows: which definition its table 3 holds",
        "com:tpc-effort" => "Torso Position Control: how much it acts, per model",
        "com:walk-tpc" => "Walking with Torso Position Control (as the seed walked), 512 phases",
        "com:walk-tpc-256" => {
            "Walking with Torso Position Control, the 256 phases of the motion (the seed's \
             other variant; it printed only the 512)"
        }
        "com:walk-open" => "Walking open loop (no torso correction), 512 phases",
        _ => "",
    }
}

/// All tables as Markdown (for `--markdown`): each section under its heading.
pub fn markdown(o: &Outcome) -> String {
    let mut s = String::new();
    for (tag, text) in sections(o) {
        let _ = writeln!(s, "### {}\n\n{text}", heading(tag));
    }
    s
}

/// The files [`write`] puts into its folder (and nothing else).
pub const FILES: [&str; 8] = [
    "com-calibration.toml",
    "report.html",
    "com-error-ellipses.svg",
    "walk-zmp-y.svg",
    "walk-zmp-xy.svg",
    "walk-zmp-xy-error.svg",
    "walk-zmp-contact.svg",
    "walk-torso-shift.svg",
];

/// Fails if `out` holds one of our files and `force` is off (checked before the long run).
pub fn check_out(out: &Path, force: bool) -> Result<()> {
    if force {
        return Ok(());
    }
    for f in FILES {
        let p = out.join(f);
        if p.exists() {
            anyhow::bail!("{} exists; pass --force to overwrite it", p.display());
        }
    }
    Ok(())
}

/// Writes the TOML, the HTML and the figures into `out`; returns the files written.
pub fn write(o: &Outcome, out: &Path, force: bool) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(out)?;
    let mut files = Vec::new();
    let toml_path = out.join("com-calibration.toml");
    atomic_write(&toml_path, toml::to_string_pretty(o)?.as_bytes(), force)?;
    files.push(toml_path);
    files.extend(figures(o, out, force)?);
    let html_path = out.join("report.html");
    atomic_write(&html_path, html(o, &files).as_bytes(), force)?;
    files.push(html_path);
    Ok(files)
}

fn html(o: &Outcome, files: &[PathBuf]) -> String {
    let c = &o.calibration;
    let mut s = String::from(
        "<!doctype html><html><head><meta charset=\"utf-8\"><title>Effective CoM (SABIAN twin)</title>\
         <style>body{font-family:sans-serif;max-width:1100px;margin:auto}table{border-collapse:collapse}\
         td,th{border:1px solid #aaa;padding:3px 6px;text-align:right}th{background:#eee}</style></head><body>",
    );
    let _ = write!(
        s,
        "<h1>Effective centre of mass on the SABIAN twin</h1><p>Written by <code>{}</code>. True \
         CoM ({:.4}, {:.4}, {:.4}) m, true mass {:.2} kg; CAD CoM ({:.4}, {:.4}, {:.4}) m. Sensor \
         noise: force {} N, moment {} N m, tilt {} deg, offsets {} N / {} N m.</p>",
        o.command,
        c.true_com[0],
        c.true_com[1],
        c.true_com[2],
        c.true_mass_kg,
        c.cad_com[0],
        c.cad_com[1],
        c.cad_com[2],
        c.noise.force_std_n,
        c.noise.moment_std_nm,
        c.noise.tilt_std_deg,
        c.noise.force_offset_n,
        c.noise.moment_offset_nm
    );
    let md = markdown(o);
    s.push_str(&markdown_to_html(&md));
    let _ = write!(
        s,
        "<p>Designed postures ({}; condition number {:.2}): {}.</p>",
        c.designed.postures.len(),
        c.designed_condition_number,
        c.designed.postures.join("; ")
    );
    for f in files {
        if f.extension().is_some_and(|e| e == "svg") {
            let name = f.file_name().unwrap_or_default().to_string_lossy();
            let _ = write!(s, "<h3>{name}</h3><img src=\"{name}\" width=\"900\">");
        }
    }
    s.push_str("</body></html>\n");
    s
}

/// The Markdown subset the tables use: `###` headings, tables (first row the header),
/// paragraphs with `**bold**`.
fn markdown_to_html(md: &str) -> String {
    let esc = |t: &str| {
        t.replace("\\|", "|")
            .replace('&', "&amp;")
            .replace('<', "&lt;")
            .replace('>', "&gt;")
    };
    // `**bold**` and `code` spans.
    let spans = |t: &str, mark: &str, tag: &str| {
        let mut out = String::new();
        for (k, part) in t.split(mark).enumerate() {
            if k % 2 == 1 {
                let _ = write!(out, "<{tag}>{part}</{tag}>");
            } else {
                out.push_str(part);
            }
        }
        out
    };
    let bold = |t: String| spans(&spans(&t, "**", "b"), "`", "code");
    let mut s = String::new();
    let mut row = None;
    for line in md.lines() {
        if line.starts_with('|') {
            if line.starts_with("|---") {
                continue;
            }
            let r = row.get_or_insert(0usize);
            if *r == 0 {
                s.push_str("<table>");
            }
            let tag = if *r == 0 { "th" } else { "td" };
            *r += 1;
            s.push_str("<tr>");
            for cell in line.trim_matches('|').split(" | ") {
                let _ = write!(s, "<{tag}>{}</{tag}>", bold(esc(cell.trim())));
            }
            s.push_str("</tr>");
            continue;
        }
        if row.take().is_some() {
            s.push_str("</table>");
        }
        if let Some(h) = line.strip_prefix("### ") {
            let _ = write!(s, "<h3>{}</h3>", esc(h));
        } else if !line.trim().is_empty() {
            let _ = write!(s, "<p>{}</p>", bold(esc(line)));
        }
    }
    if row.is_some() {
        s.push_str("</table>");
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_cells_are_escaped_in_html() {
        let h = markdown_to_html(
            "### T <1>\n\n| h | k |\n|---|---|\n| a \\| b | <= 2 |\n| **x** | y & z |\n\nSo **it** `holds`.\n",
        );
        assert!(
            h.starts_with("<h3>T &lt;1&gt;</h3><table><tr><th>h</th><th>k</th></tr>"),
            "{h}"
        );
        assert!(h.contains("<td>a | b</td><td>&lt;= 2</td>"), "{h}");
        assert!(
            h.contains("<td><b>x</b></td><td>y &amp; z</td></tr></table>"),
            "{h}"
        );
        assert!(
            h.ends_with("<p>So <b>it</b> <code>holds</code>.</p>"),
            "{h}"
        );
    }
}
