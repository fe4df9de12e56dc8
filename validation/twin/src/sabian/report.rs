//! The calibration and walking report: `com-calibration.toml` (every number), `report.html`
//! (the seed's tables beside ours) and SVG figures (error ellipses; the seed's figures 5-8).

use super::experiment::{CalibrationOutcome, DesignOutcome, ModelOutcome};
pub use super::figures::figures;
use anyhow::Result;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use zmp_files::{check_file, write_file, Kind};

/// The seed's tables 2-4 (models n, r, s, v), as printed.
pub mod seed_tables {
    /// Table 2: correlation, rows X, Y, XY position then X, Y, XY velocity.
    pub const CORRELATION: [[f64; 4]; 6] = [
        [0.8418, 0.8709, 0.7370, 0.8357],
        [0.6959, 0.7799, 0.4432, 0.6710],
        [0.7073, 0.7337, 0.5748, 0.6768],
        [0.4389, 0.5212, 0.2401, 0.4293],
        [0.3069, 0.4118, 0.1306, 0.2992],
        [0.4950, 0.5232, 0.4639, 0.4910],
    ];
    /// Table 3: RMS, rows X, Y, XY of position (m), velocity (m/s), acceleration (m/s^2).
    pub const RMS: [[f64; 4]; 9] = [
        [0.0164, 0.0179, 0.0142, 0.0171],
        [0.0161, 0.0142, 0.0224, 0.0169],
        [0.0230, 0.0229, 0.0265, 0.0240],
        [0.2885, 0.2611, 0.3369, 0.2866],
        [0.4228, 0.3651, 0.5070, 0.4181],
        [0.5199, 0.4492, 0.6088, 0.5071],
        [12.5505, 11.2278, 14.0172, 12.4586],
        [17.8598, 15.7074, 19.8534, 17.8414],
        [21.8301, 19.3339, 24.3073, 21.7749],
    ];
    /// Table 4: roll joints' RMS, rows left ankle pos, vel, acc, left hip ..., right ankle ...,
    /// right hip ... (units as printed by the seed, which labels them m, m/s, m/s^2).
    pub const ROLL: [[f64; 4]; 12] = [
        [0.2513, 0.2443, 0.3708, 0.2877],
        [2.2847, 1.8386, 2.7547, 2.2713],
        [61.322, 48.665, 66.7449, 60.417],
        [0.8048, 0.7636, 0.8849, 0.8170],
        [4.2046, 3.5794, 4.9478, 4.1973],
        [102.33, 82.286, 114.668, 101.31],
        [0.2475, 0.2385, 0.3711, 0.2835],
        [2.2640, 1.8252, 2.7682, 2.2466],
        [60.817, 48.334, 67.5456, 59.624],
        [0.7464, 0.7364, 0.9155, 0.7611],
        [4.0059, 3.4111, 4.7636, 3.9885],
        [99.672, 80.903, 111.693, 98.377],
    ];
}

/// Everything the report shows.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Outcome {
    pub format: String,
    pub command: String,
    pub runs_per_model: usize,
    pub calibration: CalibrationOutcome,
    pub walking: Vec<ModelOutcome>,
}

/// The rows of our tables, per model: (label, unit, value).
pub fn table_rows(m: &ModelOutcome) -> Vec<(&'static str, f64)> {
    let a = &m.mean;
    let mut v = vec![
        ("corr X pos", a.corr_pos[0]),
        ("corr Y pos", a.corr_pos[1]),
        ("corr XY pos", a.corr_pos[2]),
        ("corr X vel", a.corr_vel[0]),
        ("corr Y vel", a.corr_vel[1]),
        ("corr XY vel", a.corr_vel[2]),
        ("RMS X pos [m]", a.rms_pos[0]),
        ("RMS Y pos [m]", a.rms_pos[1]),
        ("RMS XY pos [m]", a.rms_pos[2]),
        ("RMS X vel [m/s]", a.rms_vel[0]),
        ("RMS Y vel [m/s]", a.rms_vel[1]),
        ("RMS XY vel [m/s]", a.rms_vel[2]),
        ("RMS X acc [m/s2]", a.rms_acc[0]),
        ("RMS Y acc [m/s2]", a.rms_acc[1]),
        ("RMS XY acc [m/s2]", a.rms_acc[2]),
    ];
    let labels: [[&'static str; 3]; 4] = [
        [
            "L ankle roll pos [deg]",
            "L ankle roll vel [deg/s]",
            "L ankle roll acc [deg/s2]",
        ],
        [
            "L hip roll pos [deg]",
            "L hip roll vel [deg/s]",
            "L hip roll acc [deg/s2]",
        ],
        [
            "R ankle roll pos [deg]",
            "R ankle roll vel [deg/s]",
            "R ankle roll acc [deg/s2]",
        ],
        [
            "R hip roll pos [deg]",
            "R hip roll vel [deg/s]",
            "R hip roll acc [deg/s2]",
        ],
    ];
    for j in 0..4 {
        v.push((labels[j][0], a.roll_pos[j]));
        v.push((labels[j][1], a.roll_vel[j]));
        v.push((labels[j][2], a.roll_acc[j]));
    }
    v.push(("bias X [m]", a.bias[0]));
    v.push(("bias Y [m]", a.bias[1]));
    v.push(("bias magnitude [m]", a.bias[0].hypot(a.bias[1])));
    v
}

/// The seed's value for a row label, by model letter.
pub fn seed_value(label: &str, model: &str) -> Option<f64> {
    let col = ["n", "r", "s", "v"].iter().position(|m| *m == model)?;
    let corr = [
        "corr X pos",
        "corr Y pos",
        "corr XY pos",
        "corr X vel",
        "corr Y vel",
        "corr XY vel",
    ];
    if let Some(r) = corr.iter().position(|l| *l == label) {
        return Some(seed_tables::CORRELATION[r][col]);
    }
    let rms = [
        "RMS X pos [m]",
        "RMS Y pos [m]",
        "RMS XY pos [m]",
        "RMS X vel [m/s]",
        "RMS Y vel [m/s]",
        "RMS XY vel [m/s]",
        "RMS X acc [m/s2]",
        "RMS Y acc [m/s2]",
        "RMS XY acc [m/s2]",
    ];
    if let Some(r) = rms.iter().position(|l| *l == label) {
        return Some(seed_tables::RMS[r][col]);
    }
    let roll = [
        "L ankle roll pos [deg]",
        "L ankle roll vel [deg/s]",
        "L ankle roll acc [deg/s2]",
        "L hip roll pos [deg]",
        "L hip roll vel [deg/s]",
        "L hip roll acc [deg/s2]",
        "R ankle roll pos [deg]",
        "R ankle roll vel [deg/s]",
        "R ankle roll acc [deg/s2]",
        "R hip roll pos [deg]",
        "R hip roll vel [deg/s]",
        "R hip roll acc [deg/s2]",
    ];
    roll.iter()
        .position(|l| *l == label)
        .map(|r| seed_tables::ROLL[r][col])
}

fn calibration_rows(c: &CalibrationOutcome) -> Vec<(&DesignOutcome, usize)> {
    vec![
        (&c.seed, c.seed.postures.len()),
        (&c.seed_zeroed, c.seed_zeroed.postures.len()),
        (&c.designed, c.designed.postures.len()),
    ]
}

/// Markdown tables (for the README): calibration accuracy and walking, ours beside the seed's.
pub fn markdown(o: &Outcome) -> String {
    let c = &o.calibration;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "| design | postures | RMS error horizontal (mm) | RMS error vertical (mm) | reported std h / v (mm) | \\|z\\| <= 2 |\n|---|---|---|---|---|---|"
    );
    for (d, n) in calibration_rows(c) {
        let _ = writeln!(
            s,
            "| {} | {} | {:.2} | {:.2} | {:.2} / {:.2} | {:.0} % |",
            d.name,
            n,
            d.rms_horizontal_m * 1e3,
            d.rms_vertical_m * 1e3,
            d.reported_horizontal_m * 1e3,
            d.reported_vertical_m * 1e3,
            100.0 * d.z_within_2
        );
    }
    let _ = writeln!(s);
    let models: Vec<&ModelOutcome> = o.walking.iter().collect();
    let _ = write!(s, "| quantity |");
    for m in &models {
        let _ = write!(s, " ours {} |", m.name);
    }
    for m in ["n", "r", "s", "v"] {
        let _ = write!(s, " seed {m} |");
    }
    let _ = writeln!(s);
    let _ = writeln!(s, "|---|{}", "---|".repeat(models.len() + 4));
    let rows = table_rows(models[0]);
    for (i, (label, _)) in rows.iter().enumerate() {
        let _ = write!(s, "| {label} |");
        let vals: Vec<f64> = models.iter().map(|m| table_rows(m)[i].1).collect();
        // Best of n, r, s, v in bold (highest correlation, lowest RMS / |bias|).
        let nrsv: Vec<usize> = (0..models.len())
            .filter(|&k| ["n", "r", "s", "v"].contains(&models[k].name.as_str()))
            .collect();
        let higher = label.starts_with("corr");
        let best = nrsv.iter().copied().min_by(|&a, &b| {
            let (x, y) = if higher {
                (-vals[a], -vals[b])
            } else {
                (vals[a].abs(), vals[b].abs())
            };
            x.total_cmp(&y)
        });
        for (k, v) in vals.iter().enumerate() {
            let txt = fmt_num(*v);
            if Some(k) == best {
                let _ = write!(s, " **{txt}** |");
            } else {
                let _ = write!(s, " {txt} |");
            }
        }
        for m in ["n", "r", "s", "v"] {
            let _ = write!(s, " {} |", seed_value(label, m).map_or("".into(), fmt_num));
        }
        let _ = writeln!(s);
    }
    s
}

fn fmt_num(v: f64) -> String {
    if v.abs() >= 100.0 {
        format!("{v:.1}")
    } else if v.abs() >= 1.0 {
        format!("{v:.3}")
    } else {
        format!("{v:.4}")
    }
}

/// The files [`write`] puts into its folder (and nothing else).
pub const FILES: [&str; 7] = [
    "com-calibration.toml",
    "report.html",
    "com-error-ellipses.svg",
    "walk-zmp-y.svg",
    "walk-zmp-xy.svg",
    "walk-zmp-xy-error.svg",
    "walk-zmp-contact.svg",
];

/// The kind of each of [`FILES`].
fn kind_of(file: &str) -> Kind {
    if file.ends_with(".toml") {
        Kind::Calibration
    } else if file.ends_with(".html") {
        Kind::Html
    } else {
        Kind::Svg
    }
}

/// Fails if `out` holds one of our files and `force` is off, or a file of another kind under
/// one of their names (checked before the long run).
pub fn check_out(out: &Path, force: bool) -> Result<()> {
    for f in FILES {
        check_file(&out.join(f), kind_of(f), force)?;
    }
    Ok(())
}

/// Writes the TOML, the HTML and the figures into `out` through the one output path; returns
/// the files written.
pub fn write(o: &Outcome, out: &Path, force: bool) -> Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    let toml_path = out.join("com-calibration.toml");
    write_file(
        &toml_path,
        Kind::Calibration,
        toml::to_string_pretty(o)?.as_bytes(),
        force,
    )?;
    files.push(toml_path);
    files.extend(figures(o, out, force)?);
    let html_path = out.join("report.html");
    write_file(&html_path, Kind::Html, html(o, &files).as_bytes(), force)?;
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

fn markdown_to_html(md: &str) -> String {
    let mut s = String::new();
    let mut in_table = false;
    for line in md.lines() {
        if line.starts_with('|') {
            if line.contains("---") {
                continue;
            }
            if !in_table {
                s.push_str("<table>");
                in_table = true;
            }
            s.push_str("<tr>");
            for cell in line.trim_matches('|').split(" | ") {
                let cell = cell
                    .trim()
                    .replace("\\|", "|")
                    .replace('&', "&amp;")
                    .replace('<', "&lt;")
                    .replace('>', "&gt;");
                if let Some(b) = cell.strip_prefix("**").and_then(|c| c.strip_suffix("**")) {
                    let _ = write!(s, "<td><b>{b}</b></td>");
                } else {
                    let _ = write!(s, "<td>{cell}</td>");
                }
            }
            s.push_str("</tr>");
        } else if in_table {
            s.push_str("</table><br>");
            in_table = false;
        }
    }
    if in_table {
        s.push_str("</table>");
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_seeds_tables_are_found_by_our_row_labels() {
        assert_eq!(seed_value("corr Y pos", "r"), Some(0.7799));
        assert_eq!(seed_value("RMS XY acc [m/s2]", "r"), Some(19.3339));
        assert_eq!(seed_value("R hip roll acc [deg/s2]", "s"), Some(111.693));
        assert_eq!(seed_value("bias X [m]", "n"), None);
        assert_eq!(seed_value("corr X pos", "e"), None);
    }

    #[test]
    fn table_cells_are_escaped_in_html() {
        let h = markdown_to_html("| a \\| b | <= 2 |\n|---|---|\n| **x** | y & z |\n");
        assert!(h.contains("<td>a | b</td><td>&lt;= 2</td>"), "{h}");
        assert!(h.contains("<td><b>x</b></td><td>y &amp; z</td>"), "{h}");
    }
}
