//! Running the `xtask` binary from the command-line tests.

use std::path::Path;
use std::process::{Command, Output};

/// Runs `xtask ARGS` in `dir`.
pub fn xtask(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_xtask"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("xtask runs")
}

/// Its standard output, after asserting that it succeeded (`what` names it in the failure).
pub fn ok(out: Output, what: &str) -> String {
    assert!(
        out.status.success(),
        "{what} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).expect("utf-8")
}
