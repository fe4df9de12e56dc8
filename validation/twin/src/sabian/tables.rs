//! The report's tables as Markdown: the seed's tables 2-4 as printed (typed in from the seed's
//! text and marked as the seed's) beside ours, with the "XY" rows both ways; the 256-phase
//! variant; and the calibration accuracy with the seed's eq. 7 variant. The Torso Position
//! Control's effort table is [`super::effort`].

use super::compare::RunMetrics;
use super::experiment::{CalibrationOutcome, ModelOutcome};
use std::fmt::Write as _;

/// The seed's tables 2-4 (models n, r, s, v), as printed in its text.
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

/// The seed's four models, in its tables' column order.
pub const SEED_MODELS: [&str; 4] = ["n", "r", "s", "v"];

/// Relative agreement (of the printed XY) within which the seed's XY entry is taken to be the
/// root-sum-square of its X and Y entries: rounding the printed 3-5 digit values moves the
/// root-sum-square by up to 0.3 %, and averaging it per run instead of taking it of the runs'
/// means moves it by a similar amount.
pub const XY_MATCH: f64 = 0.005;

/// How the seed's table 3 "XY" entries relate to its X and Y entries.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct XyCheck {
    /// Per quantity (position, velocity, acceleration) and model: printed XY, sqrt(X^2 + Y^2)
    /// of the printed X and Y, and their relative difference.
    pub entries: Vec<(String, String, f64, f64, f64)>,
    /// Entries within [`XY_MATCH`].
    pub matching: usize,
}

impl XyCheck {
    /// Whether the root-sum-square reading is the seed's (most entries match).
    pub fn seed_is_rss(&self) -> bool {
        2 * self.matching > self.entries.len()
    }
}

/// Checks the seed's table 3: is "XY" the root-sum-square of the X and Y rows?
pub fn seed_xy_check() -> XyCheck {
    let mut entries = Vec::new();
    for (g, what) in ["position", "velocity", "acceleration"].iter().enumerate() {
        for (m, model) in SEED_MODELS.iter().enumerate() {
            let x = seed_tables::RMS[3 * g][m];
            let y = seed_tables::RMS[3 * g + 1][m];
            let xy = seed_tables::RMS[3 * g + 2][m];
            let rss = x.hypot(y);
            entries.push((what.to_string(), model.to_string(), xy, rss, rss / xy - 1.0));
        }
    }
    let matching = entries.iter().filter(|e| e.4.abs() <= XY_MATCH).count();
    XyCheck { entries, matching }
}

/// The seed's tables, by the row labels of [`rows`].
pub fn seed_value(label: &str, model: &str) -> Option<f64> {
    let col = SEED_MODELS.iter().position(|m| *m == model)?;
    let rss = seed_xy_check().seed_is_rss();
    let xy = |rho: &'static str, sum: &'static str| if rss { sum } else { rho };
    let corr = [
        "corr X pos",
        "corr Y pos",
        "corr XY pos (rho)",
        "corr X vel",
        "corr Y vel",
        "corr XY vel (rho)",
    ];
    if let Some(r) = corr.iter().position(|l| *l == label) {
        return Some(seed_tables::CORRELATION[r][col]);
    }
    let rms = [
        "RMS X pos [m]",
        "RMS Y pos [m]",
        xy(RHO[0], RSS[0]),
        "RMS X vel [m/s]",
        "RMS Y vel [m/s]",
        xy(RHO[1], RSS[1]),
        "RMS X acc [m/s2]",
        "RMS Y acc [m/s2]",
        xy(RHO[2], RSS[2]),
    ];
    if let Some(r) = rms.iter().position(|l| *l == label) {
        return Some(seed_tables::RMS[r][col]);
    }
    ROLL_LABELS
        .iter()
        .flatten()
        .position(|l| *l == label)
        .map(|r| seed_tables::ROLL[r][col])
}

const RHO: [&str; 3] = [
    "RMS XY pos [m], rho (eq. 8)",
    "RMS XY vel [m/s], rho (eq. 8)",
    "RMS XY acc [m/s2], rho (eq. 8)",
];
const RSS: [&str; 3] = [
    "RMS XY pos [m], sqrt(X²+Y²)",
    "RMS XY vel [m/s], sqrt(X²+Y²)",
    "RMS XY acc [m/s2], sqrt(X²+Y²)",
];
const ROLL_LABELS: [[&str; 3]; 4] = [
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

/// Which of the seed's tables a row belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SeedTable {
    /// Table 2: correlation of the ZMP.
    Correlation,
    /// Table 3: RMS of the ZMP (with the bias rows the seed does not have).
    ZmpRms,
    /// Table 4: RMS of the roll joints.
    Roll,
}

/// Our rows of one set of walks (label, value), in the seed's tables' order, each XY RMS both
/// ways, then the mean bias.
pub fn rows(a: &RunMetrics, table: SeedTable) -> Vec<(&'static str, f64)> {
    match table {
        SeedTable::Correlation => vec![
            ("corr X pos", a.corr_pos[0]),
            ("corr Y pos", a.corr_pos[1]),
            ("corr XY pos (rho)", a.corr_pos[2]),
            ("corr X vel", a.corr_vel[0]),
            ("corr Y vel", a.corr_vel[1]),
            ("corr XY vel (rho)", a.corr_vel[2]),
        ],
        SeedTable::ZmpRms => {
            let mut v = Vec::new();
            let x = ["RMS X pos [m]", "RMS X vel [m/s]", "RMS X acc [m/s2]"];
            let y = ["RMS Y pos [m]", "RMS Y vel [m/s]", "RMS Y acc [m/s2]"];
            for (g, r) in [a.rms_pos, a.rms_vel, a.rms_acc].iter().enumerate() {
                v.push((x[g], r[0]));
                v.push((y[g], r[1]));
                v.push((RHO[g], r[2]));
                v.push((RSS[g], r[0].hypot(r[1])));
            }
            v.push(("bias X [m]", a.bias[0]));
            v.push(("bias Y [m]", a.bias[1]));
            v.push(("bias magnitude [m]", a.bias[0].hypot(a.bias[1])));
            v
        }
        SeedTable::Roll => {
            let mut v = Vec::new();
            for (j, l) in ROLL_LABELS.iter().enumerate() {
                v.push((l[0], a.roll_pos[j]));
                v.push((l[1], a.roll_vel[j]));
                v.push((l[2], a.roll_acc[j]));
            }
            v
        }
    }
}

/// A number in the tables' format.
pub fn fmt_num(v: f64) -> String {
    if v.abs() >= 100.0 {
        format!("{v:.1}")
    } else if v.abs() >= 1.0 {
        format!("{v:.3}")
    } else {
        format!("{v:.4}")
    }
}

/// One of the seed's tables for our walks (`pick` chooses the control and the window), with the
/// seed's printed columns if `with_seed`. Bold: the best of n, r, s, v (highest correlation,
/// lowest RMS or |bias|).
pub fn walking_table(
    models: &[ModelOutcome],
    pick: &dyn Fn(&ModelOutcome) -> &RunMetrics,
    table: SeedTable,
    with_seed: bool,
) -> String {
    let mut s = String::new();
    let _ = write!(s, "| quantity |");
    for m in models {
        let _ = write!(s, " ours {} |", m.name);
    }
    if with_seed {
        for m in SEED_MODELS {
            let _ = write!(s, " seed {m} (printed) |");
        }
    }
    let seed_cols = if with_seed { SEED_MODELS.len() } else { 0 };
    let _ = writeln!(s, "\n|---|{}", "---|".repeat(models.len() + seed_cols));
    let all: Vec<Vec<(&str, f64)>> = models.iter().map(|m| rows(pick(m), table)).collect();
    let Some(first) = all.first() else {
        return s;
    };
    let nrsv: Vec<usize> = (0..models.len())
        .filter(|&k| SEED_MODELS.contains(&models[k].name.as_str()))
        .collect();
    for (i, (label, _)) in first.iter().enumerate() {
        let _ = write!(s, "| {label} |");
        let vals: Vec<f64> = all.iter().map(|r| r[i].1).collect();
        let higher = label.starts_with("corr");
        let best = nrsv.iter().copied().min_by(|&a, &b| {
            let key = |k: usize| if higher { -vals[k] } else { vals[k].abs() };
            key(a).total_cmp(&key(b))
        });
        for (k, v) in vals.iter().enumerate() {
            let txt = fmt_num(*v);
            if Some(k) == best {
                let _ = write!(s, " **{txt}** |");
            } else {
                let _ = write!(s, " {txt} |");
            }
        }
        if with_seed {
            for m in SEED_MODELS {
                let _ = write!(s, " {} |", seed_value(label, m).map_or("".into(), fmt_num));
            }
        }
        let _ = writeln!(s);
    }
    s
}

/// The seed's tables 2-4 in turn for one set of walks.
pub fn walking_tables(
    models: &[ModelOutcome],
    pick: &dyn Fn(&ModelOutcome) -> &RunMetrics,
    with_seed: bool,
) -> String {
    let mut s = String::new();
    for (t, title) in [
        (SeedTable::Correlation, "Table 2: correlation (ZMP)"),
        (SeedTable::ZmpRms, "Table 3: RMS (ZMP), and the mean bias"),
        (SeedTable::Roll, "Table 4: RMS (roll joints)"),
    ] {
        let _ = writeln!(s, "{title}:\n");
        s.push_str(&walking_table(models, pick, t, with_seed));
        s.push('\n');
    }
    s
}

/// The seed's table 3 check as a Markdown table.
pub fn xy_check_table() -> String {
    let c = seed_xy_check();
    let mut s = String::from(
        "| quantity | model | printed XY | sqrt(X²+Y²) of the printed X, Y | difference |\n\
         |---|---|---|---|---|\n",
    );
    for (what, model, xy, rss, rel) in &c.entries {
        let _ = writeln!(
            s,
            "| {what} | {model} | {} | {} | {:+.2} % |",
            fmt_num(*xy),
            fmt_num(*rss),
            100.0 * rel
        );
    }
    let _ = writeln!(
        s,
        "\n{} of {} printed XY entries are sqrt(X² + Y²) of the printed X and Y within {:.1} %: \
         the seed's XY rows are {}.",
        c.matching,
        c.entries.len(),
        100.0 * XY_MATCH,
        if c.seed_is_rss() {
            "the root-sum-square of the per-axis RMS, not the RMS of the change of rho"
        } else {
            "not the root-sum-square of the per-axis RMS"
        }
    );
    s
}

/// The calibration accuracy table, the seed's eq. 7 variant included.
pub fn calibration_table(c: &CalibrationOutcome) -> String {
    let mut s = String::from(
        "| design | postures | M_2 | RMS error horizontal (mm) | RMS error vertical (mm) | \
         reported std h / v (mm) | \\|z\\| <= 2 |\n|---|---|---|---|---|---|---|\n",
    );
    for (d, m2) in [
        (&c.seed, "0 (ours)"),
        (&c.seed_zeroed, "0 (ours)"),
        (&c.seed_eq7_plus, "+ sum K I (seed eq. 7)"),
        (&c.seed_eq7_minus, "- sum K I (seed eq. 7)"),
        (&c.designed, "0 (ours)"),
    ] {
        let _ = writeln!(
            s,
            "| {} | {} | {m2} | {:.2} | {:.2} | {:.2} / {:.2} | {:.0} % |",
            d.name,
            d.postures.len(),
            d.rms_horizontal_m * 1e3,
            d.rms_vertical_m * 1e3,
            d.reported_horizontal_m * 1e3,
            d.reported_vertical_m * 1e3,
            100.0 * d.z_within_2
        );
    }
    let m = &c.seed_m2_nm;
    let z = &c.seed_zeroed;
    let worst = [&c.seed_eq7_plus, &c.seed_eq7_minus]
        .into_iter()
        .min_by(|a, b| a.rms_horizontal_m.total_cmp(&b.rms_horizontal_m));
    if let Some(w) = worst {
        let _ = writeln!(
            s,
            "\nThe seed's eq. 7 sums the servos' moments (from their currents, `M = K I`): \
             M_2 = ({:.1}, {:.1}, {:.1}) N m (roll, pitch, yaw) upright and ({:.1}, {:.1}, {:.1}) \
             N m tilted. Fed into the balance, the better of its two signs moves the \
             zeroed-sensor CoM error from {:.2} to {:.2} mm horizontally and from {:.0} to {:.0} mm \
             vertically: those moments act between the body's own links, not on the body from \
             outside, so the balance of the body above the sensors has M_2 = 0 (ours).",
            m[0][0],
            m[0][1],
            m[0][2],
            m[1][0],
            m[1][1],
            m[1][2],
            z.rms_horizontal_m * 1e3,
            w.rms_horizontal_m * 1e3,
            z.rms_vertical_m * 1e3,
            w.rms_vertical_m * 1e3,
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_seeds_xy_rows_are_the_root_sum_square_of_its_x_and_y_rows() {
        // Hand values: position n sqrt(0.0164^2 + 0.0161^2) = 0.022982 against 0.0230; velocity
        // n 0.51185 against 0.5199 (the one entry off, by 1.5 %).
        let c = seed_xy_check();
        assert_eq!(c.entries.len(), 12);
        assert!((c.entries[0].3 - 0.022982).abs() < 1e-6);
        assert!(
            (c.entries[4].4 + 0.01548).abs() < 1e-4,
            "{:?}",
            c.entries[4]
        );
        assert_eq!(c.matching, 11);
        assert!(c.seed_is_rss());
        // So the seed's printed XY values go to the root-sum-square rows.
        assert_eq!(seed_value(RSS[0], "r"), Some(0.0229));
        assert_eq!(seed_value(RHO[0], "r"), None);
    }

    #[test]
    fn the_seeds_tables_are_found_by_our_row_labels() {
        assert_eq!(seed_value("corr Y pos", "r"), Some(0.7799));
        assert_eq!(seed_value("corr XY pos (rho)", "s"), Some(0.5748));
        assert_eq!(seed_value(RSS[2], "r"), Some(19.3339));
        assert_eq!(seed_value("R hip roll acc [deg/s2]", "s"), Some(111.693));
        assert_eq!(seed_value("bias X [m]", "n"), None);
        assert_eq!(seed_value("corr X pos", "e"), None);
    }
}
