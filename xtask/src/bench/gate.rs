//! The instruction-count gate: the committed baseline (`bench/baseline.toml`) with the
//! fingerprint of the machine that measured it, and the comparison of a run against it.
//!
//! Instruction counts under callgrind are exact and repeatable for a fixed binary, so the gate
//! can be tight where wall-clock timing on a shared 2-core runner cannot: more than 2 % more
//! instructions in a real-time loop (5 % elsewhere) fails. Counts only compare when the
//! compiler, the locked dependencies, the C library and valgrind are the ones the baseline was
//! measured with; otherwise the gate is an error, not a pass. A missing bench, a zero count or
//! an improvement beyond the threshold (the baseline is stale: refresh it) is an error too.

use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::Path;

/// Format tag of the baseline file.
pub const FORMAT: &str = "zmp-bench-baseline/1";

/// What the counts depend on besides our own code.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Fingerprint {
    /// `rustc -V` of the toolchain that built the count binaries.
    pub rustc: String,
    /// SHA-256 of the third-party crates (name, version, source) compiled into the count
    /// binaries and the FMU (normal and build dependencies, from `cargo metadata`): a test-only
    /// dependency or a new workspace member does not change it.
    pub cargo_lock: String,
    /// `getconf GNU_LIBC_VERSION`.
    pub glibc: String,
    /// `valgrind --version`.
    pub valgrind: String,
}

impl Fingerprint {
    /// One line per field that differs: `field: baseline "a", this machine "b"`.
    pub fn differences(&self, now: &Fingerprint) -> Vec<String> {
        let fields = [
            ("rustc", &self.rustc, &now.rustc),
            ("cargo_lock", &self.cargo_lock, &now.cargo_lock),
            ("glibc", &self.glibc, &now.glibc),
            ("valgrind", &self.valgrind, &now.valgrind),
        ];
        fields
            .iter()
            .filter(|(_, a, b)| a != b)
            .map(|(name, a, b)| format!("{name}: baseline {a:?}, this machine {b:?}"))
            .collect()
    }
}

/// One bench of the baseline file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BaselineBench {
    pub name: String,
    /// Instructions executed by the counted function (callgrind's `Collected`), in total.
    pub instructions: u64,
    /// How many steps (or runs) the total covers.
    pub repetitions: u64,
}

/// The committed baseline file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Baseline {
    pub format: String,
    /// Commit the counts were measured on (with `+dirty` when the tree had changes).
    pub commit: String,
    pub fingerprint: Fingerprint,
    #[serde(rename = "bench")]
    pub benches: Vec<BaselineBench>,
}

impl Baseline {
    pub fn read(path: &Path) -> Result<Baseline> {
        let text = std::fs::read_to_string(path).with_context(|| {
            format!(
                "reading the instruction-count baseline {} (create it with \
                 `cargo xtask bench --counts-only --save-baseline`)",
                path.display()
            )
        })?;
        let b: Baseline =
            toml::from_str(&text).with_context(|| format!("parsing {}", path.display()))?;
        if b.format != FORMAT {
            bail!(
                "{}: field `format` is {:?}, expected {FORMAT:?}",
                path.display(),
                b.format
            );
        }
        Ok(b)
    }

    pub fn to_toml(&self) -> Result<String> {
        let mut out = String::from(
            "# Instruction counts of the hot paths under callgrind, the reference of the gate of\n\
             # `cargo xtask bench` and `cargo xtask ci` (see bench/README.md). Written by\n\
             # `cargo xtask bench --counts-only --save-baseline`; do not edit by hand.\n",
        );
        out.push_str(&toml::to_string(self)?);
        Ok(out)
    }
}

/// One measured count.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Measured {
    pub name: String,
    pub instructions: u64,
    pub repetitions: u64,
}

impl Measured {
    pub fn per_repetition(&self) -> f64 {
        self.instructions as f64 / self.repetitions.max(1) as f64
    }
}

/// What the gate says about one bench.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "verdict", rename_all = "snake_case")]
pub enum Verdict {
    /// Within the tolerance of the baseline.
    Pass { change: f64 },
    /// More instructions than the tolerance allows.
    Regressed { change: f64 },
    /// Fewer instructions than the tolerance: the baseline is stale.
    Improved { change: f64 },
    /// In the baseline, expected, but not measured.
    Missing,
    /// Measured zero instructions (the counted function did not run, or was not found).
    Zero,
    /// Measured but absent from the baseline.
    NoBaseline,
    /// Baseline count of zero, or a different number of repetitions.
    BadBaseline { reason: String },
}

/// One row of the gate's report.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Row {
    pub name: String,
    pub tolerance: f64,
    pub old: Option<u64>,
    pub new: Option<u64>,
    pub repetitions: u64,
    #[serde(flatten)]
    pub verdict: Verdict,
}

impl Row {
    pub fn ok(&self) -> bool {
        matches!(self.verdict, Verdict::Pass { .. })
    }

    /// One line naming the bench, the old and new count and what is wrong.
    pub fn describe(&self) -> String {
        let per = |n: Option<u64>| match n {
            Some(n) => format!(
                "{n} instructions ({:.1} per repetition)",
                n as f64 / self.repetitions.max(1) as f64
            ),
            None => "none".into(),
        };
        let (old, new) = (per(self.old), per(self.new));
        let tol = 100.0 * self.tolerance;
        match &self.verdict {
            Verdict::Pass { change } => format!(
                "ok        {}: old {old}, new {new}, {:+.2} % (limit ±{tol:.0} %)",
                self.name,
                100.0 * change
            ),
            Verdict::Regressed { change } => format!(
                "REGRESSED {}: old {old}, new {new}, {:+.2} % > +{tol:.0} %",
                self.name,
                100.0 * change
            ),
            Verdict::Improved { change } => format!(
                "IMPROVED  {}: old {old}, new {new}, {:+.2} % < -{tol:.0} %: refresh the \
                 baseline with `cargo xtask bench --counts-only --save-baseline` and commit it",
                self.name,
                100.0 * change
            ),
            Verdict::Missing => format!(
                "MISSING   {}: in the baseline (old {old}) but not measured",
                self.name
            ),
            Verdict::Zero => format!(
                "ZERO      {}: measured 0 instructions (old {old}): the counted function did \
                 not run",
                self.name
            ),
            Verdict::NoBaseline => format!(
                "NEW       {}: new {new} has no baseline: add it with `cargo xtask bench \
                 --counts-only --save-baseline`",
                self.name
            ),
            Verdict::BadBaseline { reason } => {
                format!("BASELINE  {}: {reason} (old {old}, new {new})", self.name)
            }
        }
    }
}

/// The gate's whole verdict.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Report {
    /// Fields of the fingerprint that differ from the baseline's.
    pub fingerprint_differences: Vec<String>,
    pub rows: Vec<Row>,
}

impl Report {
    pub fn ok(&self) -> bool {
        self.fingerprint_differences.is_empty() && self.rows.iter().all(Row::ok)
    }

    pub fn to_text(&self) -> String {
        let mut s = String::new();
        for r in &self.rows {
            let _ = writeln!(s, "  {}", r.describe());
        }
        if !self.fingerprint_differences.is_empty() {
            let _ = writeln!(
                s,
                "  FINGERPRINT: the baseline was measured with another toolchain or machine, so \
                 its counts do not compare:"
            );
            for d in &self.fingerprint_differences {
                let _ = writeln!(s, "    {d}");
            }
            let _ = writeln!(
                s,
                "    re-measure on the reference machine with `cargo xtask bench --counts-only \
                 --save-baseline` and commit bench/baseline.toml"
            );
        }
        s
    }
}

/// Compares `measured` with `baseline`. `expected` lists the benches this run was to measure,
/// with their tolerances (relative, e.g. 0.02): a bench of `expected` that is in the baseline
/// but was not measured is [`Verdict::Missing`]; baseline benches outside `expected` (a run of
/// selected benches) are not judged.
pub fn compare(
    baseline: &Baseline,
    now: &Fingerprint,
    expected: &[(&str, f64)],
    measured: &[Measured],
) -> Report {
    let mut rows = Vec::new();
    for &(name, tolerance) in expected {
        let old = baseline.benches.iter().find(|b| b.name == name);
        let new = measured.iter().find(|m| m.name == name);
        let repetitions = new
            .map(|m| m.repetitions)
            .or(old.map(|b| b.repetitions))
            .unwrap_or(1);
        let verdict = match (old, new) {
            (_, Some(m)) if m.instructions == 0 => Verdict::Zero,
            (None, Some(_)) => Verdict::NoBaseline,
            (_, None) => Verdict::Missing,
            (Some(b), Some(_)) if b.instructions == 0 => Verdict::BadBaseline {
                reason: "the baseline count is zero".into(),
            },
            (Some(b), Some(m)) if b.repetitions != m.repetitions => Verdict::BadBaseline {
                reason: format!(
                    "the baseline counted {} repetitions, this run {}",
                    b.repetitions, m.repetitions
                ),
            },
            (Some(b), Some(m)) => {
                let change = m.instructions as f64 / b.instructions as f64 - 1.0;
                if change > tolerance {
                    Verdict::Regressed { change }
                } else if change < -tolerance {
                    Verdict::Improved { change }
                } else {
                    Verdict::Pass { change }
                }
            }
        };
        rows.push(Row {
            name: name.to_string(),
            tolerance,
            old: old.map(|b| b.instructions),
            new: new.map(|m| m.instructions),
            repetitions,
            verdict,
        });
    }
    for m in measured {
        if !expected.iter().any(|(n, _)| *n == m.name) {
            rows.push(Row {
                name: m.name.clone(),
                tolerance: 0.0,
                old: None,
                new: Some(m.instructions),
                repetitions: m.repetitions,
                verdict: Verdict::BadBaseline {
                    reason: "measured but not a registered bench".into(),
                },
            });
        }
    }
    Report {
        fingerprint_differences: baseline.fingerprint.differences(now),
        rows,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fp() -> Fingerprint {
        Fingerprint {
            rustc: "rustc 1.95.0 (59807616e 2026-04-14)".into(),
            cargo_lock: "sha256:00".into(),
            glibc: "glibc 2.36".into(),
            valgrind: "valgrind-3.19.0".into(),
        }
    }

    fn baseline() -> Baseline {
        Baseline {
            format: FORMAT.into(),
            commit: "abc".into(),
            fingerprint: fp(),
            benches: vec![
                BaselineBench {
                    name: "plant".into(),
                    instructions: 100_000,
                    repetitions: 100,
                },
                BaselineBench {
                    name: "identify".into(),
                    instructions: 1_000_000,
                    repetitions: 1,
                },
            ],
        }
    }

    fn m(name: &str, instructions: u64, repetitions: u64) -> Measured {
        Measured {
            name: name.into(),
            instructions,
            repetitions,
        }
    }

    const EXPECTED: &[(&str, f64)] = &[("plant", 0.02), ("identify", 0.05)];

    fn verdicts(r: &Report) -> Vec<&Verdict> {
        r.rows.iter().map(|r| &r.verdict).collect()
    }

    #[test]
    fn within_tolerance_passes() {
        let r = compare(
            &baseline(),
            &fp(),
            EXPECTED,
            &[m("plant", 101_999, 100), m("identify", 960_000, 1)],
        );
        assert!(r.ok(), "{}", r.to_text());
    }

    #[test]
    fn regression_over_the_bench_tolerance_fails_naming_both_counts() {
        // +3 %: over the real-time loop's 2 %, under the pipeline's 5 %.
        let r = compare(
            &baseline(),
            &fp(),
            EXPECTED,
            &[m("plant", 103_000, 100), m("identify", 1_030_000, 1)],
        );
        assert!(!r.ok());
        assert!(matches!(r.rows[0].verdict, Verdict::Regressed { .. }));
        assert!(matches!(r.rows[1].verdict, Verdict::Pass { .. }));
        let text = r.to_text();
        assert!(
            text.contains("plant") && text.contains("100000") && text.contains("103000"),
            "{text}"
        );
        let r = compare(
            &baseline(),
            &fp(),
            EXPECTED,
            &[m("plant", 100_000, 100), m("identify", 1_051_000, 1)],
        );
        assert!(matches!(r.rows[1].verdict, Verdict::Regressed { .. }));
    }

    #[test]
    fn improvement_beyond_tolerance_asks_for_a_refresh() {
        let r = compare(
            &baseline(),
            &fp(),
            EXPECTED,
            &[m("plant", 97_000, 100), m("identify", 1_000_000, 1)],
        );
        assert!(!r.ok());
        assert!(matches!(r.rows[0].verdict, Verdict::Improved { .. }));
        assert!(r.to_text().contains("--save-baseline"));
    }

    #[test]
    fn missing_zero_new_and_changed_repetitions_are_errors() {
        let r = compare(&baseline(), &fp(), EXPECTED, &[m("plant", 100_000, 100)]);
        assert_eq!(verdicts(&r)[1], &Verdict::Missing);
        assert!(!r.ok());
        let r = compare(
            &baseline(),
            &fp(),
            EXPECTED,
            &[m("plant", 0, 100), m("identify", 1_000_000, 1)],
        );
        assert_eq!(verdicts(&r)[0], &Verdict::Zero);
        assert!(!r.ok());
        let r = compare(
            &baseline(),
            &fp(),
            &[("plant", 0.02), ("identify", 0.05), ("twin", 0.02)],
            &[
                m("plant", 100_000, 100),
                m("identify", 1_000_000, 1),
                m("twin", 5, 1),
            ],
        );
        assert_eq!(verdicts(&r)[2], &Verdict::NoBaseline);
        assert!(!r.ok());
        let r = compare(
            &baseline(),
            &fp(),
            EXPECTED,
            &[m("plant", 50_000, 50), m("identify", 1_000_000, 1)],
        );
        assert!(matches!(verdicts(&r)[0], Verdict::BadBaseline { .. }));
        assert!(!r.ok());
        let r = compare(
            &baseline(),
            &fp(),
            &[("plant", 0.02)],
            &[m("plant", 100_000, 100), m("stray", 1, 1)],
        );
        assert!(!r.ok(), "an unregistered measurement is an error");
    }

    #[test]
    fn a_selected_run_judges_only_its_benches() {
        let r = compare(
            &baseline(),
            &fp(),
            &[("plant", 0.02)],
            &[m("plant", 100_000, 100)],
        );
        assert!(r.ok(), "{}", r.to_text());
        assert_eq!(r.rows.len(), 1);
    }

    #[test]
    fn fingerprint_mismatch_is_an_error_naming_what_differs() {
        let mut now = fp();
        now.valgrind = "valgrind-3.22.0".into();
        now.rustc = "rustc 1.96.0".into();
        let r = compare(
            &baseline(),
            &now,
            EXPECTED,
            &[m("plant", 100_000, 100), m("identify", 1_000_000, 1)],
        );
        assert!(!r.ok());
        assert_eq!(r.fingerprint_differences.len(), 2);
        let text = r.to_text();
        assert!(
            text.contains("valgrind-3.19.0") && text.contains("valgrind-3.22.0"),
            "{text}"
        );
        assert!(text.contains("rustc 1.96.0"), "{text}");
    }

    #[test]
    fn baseline_file_round_trips_and_checks_its_format() {
        let dir = std::env::temp_dir().join(format!("zmp-gate-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("baseline.toml");
        std::fs::write(&path, baseline().to_toml().unwrap()).unwrap();
        assert_eq!(Baseline::read(&path).unwrap(), baseline());
        let bad = baseline().to_toml().unwrap().replace(FORMAT, "other/1");
        std::fs::write(&path, bad).unwrap();
        let e = Baseline::read(&path).unwrap_err().to_string();
        assert!(e.contains("format") && e.contains("baseline.toml"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
