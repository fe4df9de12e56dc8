//! `cargo xtask setup`, step c): the Python venv with FMPy and the other pinned packages,
//! created from a bootstrap CPython >= 3.11.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use anyhow::{anyhow, bail, Context, Result};

use super::{Log, PYTHON_PINS};
use crate::env::Prereqs;

/// Minimum Python version of the interpreter the venv is created from (numpy 2.4 needs 3.11).
const MIN_PYTHON: (u32, u32) = (3, 11);

pub(super) fn ensure_venv(p: &Prereqs, log: &Log) -> Result<()> {
    if !python_runs(&p.python) {
        let python = bootstrap_python()?;
        log.action(format_args!(
            "python venv: creating {} with {}",
            p.venv_dir.display(),
            python.display()
        ));
        fs::create_dir_all(&p.deps_dir)
            .with_context(|| format!("creating {}", p.deps_dir.display()))?;
        // --clear: a venv whose interpreter has gone away is rebuilt from scratch.
        log.run(
            Command::new(&python)
                .args(["-m", "venv", "--clear"])
                .arg(&p.venv_dir),
        )?;
    }

    if let Err(why) = check_python_pins(&p.python) {
        log.action(format_args!(
            "python venv: installing {} packages ({})",
            PYTHON_PINS.len(),
            why.lines().next().unwrap_or("not installed")
        ));
        let mut cmd = Command::new(&p.python);
        cmd.args([
            "-m",
            "pip",
            "install",
            "--disable-pip-version-check",
            "--no-input",
        ])
        .args(PYTHON_PINS);
        // The MuJoCo wheel downloaded for the shared library serves pip too.
        let wheels = p.deps_dir.join("wheels");
        if wheels.is_dir() {
            cmd.arg("--find-links").arg(&wheels);
        }
        if log.quiet {
            cmd.arg("-q");
        }
        log.run(&mut cmd)?;
        check_python_pins(&p.python).map_err(|why| {
            anyhow!("the venv still does not match the pins after pip install:\n{why}")
        })?;
    }

    // The `fmpy` console script is what the tests and users run (`fmpy validate x.fmu`).
    let fmpy = p.venv_bin().join("fmpy");
    let out = Command::new(&fmpy)
        .arg("--help")
        .stdin(Stdio::null())
        .output()
        .with_context(|| format!("running {}", fmpy.display()))?;
    if !out.status.success() || !String::from_utf8_lossy(&out.stdout).contains("validate") {
        bail!(
            "`{} --help` does not work:\n{}",
            fmpy.display(),
            String::from_utf8_lossy(&out.stderr)
        );
    }
    log.step(format_args!(
        "python venv: ready in {} (fmpy, numpy, matplotlib, mujoco importable)",
        p.venv_dir.display()
    ));
    Ok(())
}

fn python_runs(python: &Path) -> bool {
    Command::new(python)
        .args(["-c", "import sys"])
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// Ok if every pin is installed at exactly its version and the three direct
/// packages import; else a description of what is wrong.
fn check_python_pins(python: &Path) -> std::result::Result<(), String> {
    const SCRIPT: &str = "\
import sys
from importlib.metadata import version, PackageNotFoundError
bad = []
for spec in sys.argv[1:]:
    name, want = spec.split('==')
    try:
        have = version(name)
    except PackageNotFoundError:
        have = None
    if have != want:
        bad.append(f'{name}: want {want}, have {have}')
if bad:
    print('\\n'.join(bad))
    sys.exit(1)
import fmpy, numpy, matplotlib, mujoco
";
    let out = Command::new(python)
        .args(["-c", SCRIPT])
        .args(PYTHON_PINS)
        .stdin(Stdio::null())
        .output()
        .map_err(|e| format!("cannot run {}: {e}", python.display()))?;
    if out.status.success() {
        Ok(())
    } else {
        Err(format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        ))
    }
}

/// The interpreter used to download the MuJoCo wheel and create the venv:
/// `$ZMP_BOOTSTRAP_PYTHON` or `python3` on PATH; must be CPython >= 3.11.
pub(super) fn bootstrap_python() -> Result<PathBuf> {
    let python = std::env::var_os("ZMP_BOOTSTRAP_PYTHON")
        .filter(|p| !p.is_empty())
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("python3"));
    let out = Command::new(&python)
        .args(["-c", "import sys; print('%d %d' % sys.version_info[:2])"])
        .stdin(Stdio::null())
        .output()
        .with_context(|| {
            format!(
                "cannot run `{}`: install Python >= {}.{} with venv and pip (Debian: apt-get \
                 install python3 python3-venv python3-pip), or point ZMP_BOOTSTRAP_PYTHON at one",
                python.display(),
                MIN_PYTHON.0,
                MIN_PYTHON.1
            )
        })?;
    let text = String::from_utf8_lossy(&out.stdout);
    let version: Option<(u32, u32)> = text
        .split_once(' ')
        .and_then(|(a, b)| Some((a.trim().parse().ok()?, b.trim().parse().ok()?)));
    match version {
        Some(v) if out.status.success() && v >= MIN_PYTHON => Ok(python),
        _ => bail!(
            "`{}` is Python {:?}, need >= {}.{} (set ZMP_BOOTSTRAP_PYTHON to a newer one)",
            python.display(),
            text.trim(),
            MIN_PYTHON.0,
            MIN_PYTHON.1
        ),
    }
}
