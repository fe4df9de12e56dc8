//! The book's numbers of the SILO2 twin (`docs/src/twin-silo2.md`), written by the run that
//! measures them: `validate --readme docs/src/twin-silo2.md` (full runs only) replaces the
//! text between `<!-- twin-silo2:TAG -->` and `<!-- /twin-silo2:TAG -->` for each section
//! below, so the page never quotes a stale or hand-copied run.

use super::summary::{ParameterRow, Summary};
use std::fmt::Write as _;
use std::path::Path;

/// The README's markers this module writes, in order.
pub const TAGS: [&str; 3] = [
    "twin-silo2:identified",
    "twin-silo2:closed-loop",
    "twin-silo2:diagnosis",
];

/// The sections of the README this module writes: `(tag, text)`.
pub fn sections(s: &Summary) -> Vec<(&'static str, String)> {
    vec![
        (TAGS[0], identified(s)),
        (TAGS[1], closed_loop(s)),
        (TAGS[2], diagnosis(s)),
    ]
}

fn row<'a>(s: &'a Summary, name: &str) -> Option<&'a ParameterRow> {
    s.parameters.iter().find(|p| p.name == name)
}

fn pct(a: f64, b: f64) -> String {
    let v = 100.0 * (a / b - 1.0);
    format!("{}{:.1} %", if v < 0.0 { "−" } else { "+" }, v.abs())
}

fn signed(v: f64, digits: usize) -> String {
    format!("{}{:.*}", if v < 0.0 { "−" } else { "+" }, digits, v.abs())
}

fn identified(s: &Summary) -> String {
    let mut t = String::new();
    let c = &s.campaign;
    let _ = writeln!(
        t,
        "Run of `cargo xtask validate silo2`: {} records, {} rows, {:.0} s simulated in {:.0} s; \
         {} record(s) left out of the linear fit.\n",
        c.records,
        c.rows,
        c.simulated_s,
        c.wall_s,
        s.excluded_records.len()
    );
    let _ = writeln!(
        t,
        "| | seed eqs. 6-15 | multibody | + servo gravity | identified ± s.e. | identified vs \
         servo | after the diagnosis loop | after the loop vs servo |"
    );
    let _ = writeln!(t, "| --- | --- | --- | --- | --- | --- | --- | --- |");
    let single = |t: &mut String, label: &str, name: &str, d: usize| {
        let Some(r) = row(s, name) else { return };
        let after = r.after_loop.map_or(("".to_string(), "".to_string()), |a| {
            (format!("{a:.d$}"), pct(a, r.servo))
        });
        let _ = writeln!(
            t,
            "| {label} | {:.d$} | {:.d$} | {:.d$} | {:.d$} ± {:.d$} | {} | {} | {} |",
            r.seed,
            r.multibody,
            r.servo,
            r.identified,
            r.identified_stderr,
            pct(r.identified, r.servo),
            after.0,
            after.1,
        );
    };
    let pair = |t: &mut String, label: &str, a: &str, b: &str, d: usize| {
        let (Some(x), Some(y)) = (row(s, a), row(s, b)) else {
            return;
        };
        let after = match (x.after_loop, y.after_loop) {
            (Some(p), Some(q)) => format!("{}, {}", signed(p, d), signed(q, d)),
            _ => String::new(),
        };
        let _ = writeln!(
            t,
            "| {label} | {}, {} | {}, {} | {}, {} | {}, {} (± {:.d$}) | | {after} | |",
            signed(x.seed, d),
            signed(y.seed, d),
            signed(x.multibody, d),
            signed(y.multibody, d),
            signed(x.servo, d),
            signed(y.servo, d),
            signed(x.identified, d),
            signed(y.identified, d),
            x.identified_stderr.max(y.identified_stderr),
        );
    };
    single(&mut t, "`a11`", "a11", 4);
    single(&mut t, "`a22`", "a22", 4);
    pair(&mut t, "`a12`, `a21`", "a12", "a21", 4);
    single(&mut t, "`b11` (s²)", "b11", 5);
    single(&mut t, "`b22` (s²)", "b22", 5);
    pair(&mut t, "`b12`, `b21` (s²)", "b12", "b21", 5);
    single(&mut t, "`omega_n` (rad/s)", "omega_n", 2);
    single(&mut t, "`zeta`", "zeta", 3);
    t
}

fn closed_loop(s: &Summary) -> String {
    let c = &s.closed_loop.comparison;
    let e = &s.closed_loop.experiment;
    let step_mm = 1e3 * (e.zmp_ref_after[0] - e.zmp_ref_before[0]);
    let mut t = String::new();
    let _ = writeln!(
        t,
        "| | reaches {step_mm:.1} mm | within 2 % from | overshoot | {:.0} kg: peak error | \
         recovered (2 %) in | error, last 10 s | trunk angle at the end |",
        e.load_mass
    );
    let _ = writeln!(t, "| --- | --- | --- | --- | --- | --- | --- | --- |");
    for (label, m, theta) in [
        ("twin (true ZMP)", &c.twin, c.final_theta_twin),
        ("identified model", &c.model, c.final_theta_model),
    ] {
        let _ = writeln!(
            t,
            "| {label} | {:.1} s | {:.1} s | {:.1} % | {:.1} mm | {:.1} s | {:.2} mm | {:.3} rad |",
            m.reach_time_s,
            m.settling_time_2pct_s,
            m.overshoot_pct,
            1e3 * m.load_peak_error_m,
            m.load_recovery_time_s,
            1e3 * m.final_error_m,
            theta
        );
    }
    let _ = writeln!(
        t,
        "\nTwin against model (the project's error measure on the lateral ZMP): NRMSE {:.4}, \
         noise floor {:.4}.",
        c.nrmse_x, c.noise_floor_x
    );
    t
}

fn diagnosis(s: &Summary) -> String {
    let d = &s.diagnosis;
    let mut t = String::new();
    let ratio = |e: f64| e / d.noise_floor;
    let _ = write!(
        t,
        "**Verdict: `{}`.** The identified model scores {:.2}× the noise floor ({:.4})",
        d.verdict,
        ratio(d.baseline_error),
        d.noise_floor
    );
    if d.selected.is_empty() {
        let _ = writeln!(t, "; no catalogued effect removes a significant error.");
    } else {
        let steps: Vec<String> = d
            .selected
            .iter()
            .map(|(e, err)| format!("`{e}` → {:.2}×", ratio(*err)))
            .collect();
        let _ = writeln!(
            t,
            "; the loop adds {} (held-out error after each) and ends at {:.2}× the floor.",
            steps.join(", "),
            ratio(d.final_error)
        );
    }
    if !d.parameters.is_empty() {
        let ps: Vec<String> = d
            .parameters
            .iter()
            .map(|(n, v)| format!("`{n}` = {v:.4}"))
            .collect();
        let _ = writeln!(
            t,
            "\nFitted parameters of the added effects: {}.",
            ps.join(", ")
        );
    }
    t
}

/// Replaces each section's text in the page at `path` (see `zmp_files::sections`): every
/// section's markers must be there, and a failure leaves the page as it was.
pub fn write(path: &Path, sections: &[(&str, String)]) -> Result<(), String> {
    zmp_files::sections::replace_sections(path, sections)
}
