//! Memory: 10,000 instantiate/free cycles without RSS growth, and valgrind's leak checker on a
//! child run of `leak_cycles_child`.

use crate::{resources, Fixture};
use zmp_fmu::*;
use zmp_fmu_core::Kind;

fn rss_kib() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap();
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        .expect("VmRSS")
}

/// `n` instantiate / initialise / step / free cycles of each of `kinds`.
fn cycles(kinds: &[Kind], n: usize) {
    let fixtures: Vec<Fixture> = kinds.iter().map(|&k| Fixture::new(k)).collect();
    for _ in 0..n {
        for f in &fixtures {
            let c = f.running();
            // SAFETY: a live instance, freed right after.
            unsafe {
                assert_eq!(fmi2DoStep(c, 0.0, 0.01, 1), fmi2OK);
                fmi2FreeInstance(c);
            }
        }
    }
    for f in &fixtures {
        assert!(f.messages().is_empty(), "{:?}", f.messages());
    }
}

#[test]
fn ten_thousand_instantiate_free_cycles_do_not_grow_memory() {
    cycles(&Kind::ALL, 1_000);
    let before = rss_kib();
    cycles(&Kind::ALL, 10_000);
    let after = rss_kib();
    assert!(
        after < before + 1024,
        "RSS grew from {before} kB to {after} kB over 10,000 cycles"
    );
}

/// Runs in the valgrind child of [`valgrind_finds_no_leak`] only.
#[test]
fn leak_cycles_child() {
    if std::env::var_os("ZMP_FMU_LEAK_CHILD").is_some() {
        // 10,000 plant cycles (the largest instance) and 1,000 of the others, to keep the
        // valgrind run to about a minute.
        cycles(&[Kind::Plant], 10_000);
        cycles(&[Kind::Controller, Kind::Passthrough], 1_000);
    }
}

#[test]
fn valgrind_finds_no_leak() {
    let valgrind = std::process::Command::new("valgrind")
        .arg("--version")
        .output();
    assert!(
        valgrind.map(|o| o.status.success()).unwrap_or(false),
        "valgrind is missing: run `cargo xtask setup`"
    );
    // Make sure the resources directory exists before the child starts.
    resources();
    let exe = std::env::current_exe().unwrap();
    let out = std::process::Command::new("valgrind")
        .args([
            "--leak-check=full",
            "--errors-for-leak-kinds=definite,indirect",
            "--show-leak-kinds=definite,indirect",
            "--error-exitcode=99",
            "--quiet",
        ])
        .arg(&exe)
        .args([
            "--exact",
            "memory::leak_cycles_child",
            "--test-threads=1",
            "--nocapture",
        ])
        .env("ZMP_FMU_LEAK_CHILD", "1")
        .output()
        .expect("running valgrind");
    assert!(
        out.status.success(),
        "valgrind reports errors or leaks ({}):\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stdout).contains("1 passed"));
}
