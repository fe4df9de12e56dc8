//! `cargo xtask ci`: what CI runs (via `.ci/run`), and what to run locally
//! before pushing. Installs the prerequisites, then format check, clippy,
//! the test suite, the book's link check and the instruction-count gate of
//! `cargo xtask bench`, failing fast. `--long` adds the long suites CI leaves
//! out (tests ignored with a reason starting `long:`).

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};

use crate::env::{apply_env, repo_root};
use crate::setup::setup;

/// One CI step: a name and the cargo arguments.
const STEPS: &[(&str, &[&str])] = &[
    ("fmt", &["fmt", "--all", "--", "--check"]),
    (
        "clippy",
        &[
            "clippy",
            "--workspace",
            "--all-targets",
            "--release",
            "--",
            "-D",
            "warnings",
        ],
    ),
    // --release: shares build artifacts with the release-built xtask, and the
    // simulation-heavy tests run fast.
    ("test", &["test", "--workspace", "--release"]),
];

/// The long suites (`cargo xtask ci --long`): every ignored test but the blind suites' held-out
/// and development ranges, which are run by hand (a held-out range is run once).
const LONG: (&str, &[&str]) = (
    "long",
    &[
        "test",
        "--workspace",
        "--release",
        "--",
        "--ignored",
        "--skip",
        "held_out_blind_suite",
        "--skip",
        "development_blind_suite",
    ],
);

/// Run setup, then `cargo fmt --check`, `cargo clippy -D warnings`, `cargo test`, the link
/// check and the instruction-count gate, in that order, with the prerequisites' environment
/// (and with `long` the long suites last); stop at the first failing step. Prints the elapsed
/// time of each step at the end.
pub fn ci(long: bool) -> Result<()> {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let root = repo_root();
    let mut timings: Vec<(&str, Duration, bool)> = Vec::new();

    let start = Instant::now();
    let setup_result = setup(false);
    timings.push(("setup", start.elapsed(), setup_result.is_ok()));
    let prereqs = match setup_result {
        Ok(p) => p,
        Err(e) => {
            print_timings(&timings);
            return Err(e.context("ci: step `setup` failed"));
        }
    };

    for &(name, args) in STEPS {
        run_step(&cargo, &root, &prereqs, name, args, &mut timings)?;
    }

    eprintln!("\nci: ==> links: relative links and anchors of README.md and docs/");
    let start = Instant::now();
    let links = crate::links::check_repository(&root);
    timings.push(("links", start.elapsed(), links.is_ok()));
    if let Err(e) = links {
        print_timings(&timings);
        return Err(e.context("ci: step `links` failed"));
    }

    // The instruction-count gate (`cargo xtask bench --counts-only`): after the tests, whose
    // release build it reuses.
    eprintln!("\nci: ==> bench-gate: cargo xtask bench --counts-only");
    let start = Instant::now();
    let gate = crate::bench::bench(&crate::bench::BenchArgs {
        counts_only: true,
        ..Default::default()
    });
    timings.push(("bench-gate", start.elapsed(), gate.is_ok()));
    if let Err(e) = gate {
        print_timings(&timings);
        return Err(e.context("ci: step `bench-gate` failed"));
    }

    if long {
        run_step(&cargo, &root, &prereqs, LONG.0, LONG.1, &mut timings)?;
    }

    print_timings(&timings);
    eprintln!("ci: all steps passed");
    Ok(())
}

/// One cargo step with the prerequisites' environment; its time goes into `timings`, and a
/// failure prints them and names the step.
fn run_step(
    cargo: &std::ffi::OsStr,
    root: &std::path::Path,
    prereqs: &crate::env::Prereqs,
    name: &'static str,
    args: &[&str],
    timings: &mut Vec<(&'static str, Duration, bool)>,
) -> Result<()> {
    eprintln!("\nci: ==> {name}: cargo {}", args.join(" "));
    let mut cmd = Command::new(cargo);
    cmd.args(args).current_dir(root).stdin(Stdio::null());
    strip_cargo_run_env(&mut cmd);
    apply_env(&mut cmd, prereqs);
    let start = Instant::now();
    let status = cmd
        .status()
        .with_context(|| format!("ci: could not start cargo for step `{name}`"));
    let ok = matches!(&status, Ok(s) if s.success());
    timings.push((name, start.elapsed(), ok));
    if !ok {
        print_timings(timings);
        let status = status?;
        bail!(
            "ci: step `{name}` failed ({status}): cargo {}",
            args.join(" ")
        );
    }
    Ok(())
}

/// `cargo run` (which started us via the `cargo xtask` alias) exports the
/// xtask package's CARGO_PKG_*, CARGO_MANIFEST_*, CARGO_PRIMARY_PACKAGE, ...
/// Don't leak them into the nested cargo: clippy-driver, for one, reads
/// CARGO_PRIMARY_PACKAGE to decide which crates to lint.
pub(crate) fn strip_cargo_run_env(cmd: &mut Command) {
    const PREFIXES: &[&str] = &["CARGO_PKG_", "CARGO_MANIFEST_"];
    const NAMES: &[&str] = &[
        "CARGO_CRATE_NAME",
        "CARGO_BIN_NAME",
        "CARGO_PRIMARY_PACKAGE",
    ];
    for (key, _) in std::env::vars_os() {
        let Some(key) = key.to_str() else { continue };
        if NAMES.contains(&key) || PREFIXES.iter().any(|p| key.starts_with(p)) {
            cmd.env_remove(key);
        }
    }
}

fn print_timings(timings: &[(&str, Duration, bool)]) {
    eprintln!("\nci: step timings");
    let mut total = Duration::ZERO;
    for (name, elapsed, ok) in timings {
        total += *elapsed;
        let verdict = if *ok { "ok" } else { "FAILED" };
        eprintln!("  {name:<10} {:>9.1}s  {verdict}", elapsed.as_secs_f64());
    }
    eprintln!("  {:<10} {:>9.1}s", "total", total.as_secs_f64());
}
