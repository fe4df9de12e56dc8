//! `cargo xtask setup`: install everything the build and the tests need that
//! cargo does not fetch by itself.
//!
//! 1. Debian packages (libclang for the FMI 3.0 export, EGL/Mesa for headless
//!    MuJoCo rendering, valgrind).
//! 2. The MuJoCo shared library, extracted from the official PyPI wheel.
//! 3. A Python venv with FMPy (to validate and simulate exported FMUs),
//!    numpy, matplotlib and pyarrow (the benches' numpy peer), all pinned.
//!
//! Idempotent. A marker file in the deps dir records a completed setup; when it
//! matches the current pins, only cheap existence checks run (well under 1 s).

use std::ffi::OsStr;
use std::fs;
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;

use anyhow::{bail, Context, Result};

use crate::env::{prereqs, Prereqs, MUJOCO_VERSION};

mod apt;
mod mujoco;
mod venv;

use apt::ensure_apt_packages;
use mujoco::{ensure_mujoco, mujoco_lib_looks_ok, symlinks_ok};
use venv::ensure_venv;

/// Debian packages the project needs.
pub const APT_PACKAGES: &[&str] = &[
    // bindgen (FMI 3.0 export headers) needs libclang.
    "libclang-dev",
    // Headless (EGL) MuJoCo rendering.
    "libegl1",
    "libegl-mesa0",
    "libgl1-mesa-dri",
    // Memory checks of the FMU shared library.
    "valgrind",
];

/// Exact Python package pins for the venv (CPython >= 3.11). The first four
/// are what the project uses (MuJoCo's own Python bindings are the speed peer of
/// the twin's step, `bench/peers/mujoco_step.py`); the rest are their
/// dependencies, pinned too so that every machine gets the same environment.
pub const PYTHON_PINS: &[&str] = &[
    "fmpy==0.3.32",
    "numpy==2.4.6",
    "matplotlib==3.11.2",
    // FMU containers (`fmucontainer`) and `fmutool -check`: the second co-simulation master
    // and the schema checks of the FMU tests.
    "fmu-manipulation-toolbox==2.0",
    // MuJoCo's Python bindings: the speed peer of the twin step.
    "mujoco==3.17.0",
    // The numpy identification peer of the benches reads CSV with pyarrow (bench/peers).
    "pyarrow==26.0.1",
    // The Ray driver of the sharded commands (xtask/scale/ray_driver.py, docs/src/scale-out.md).
    "ray==2.60.0",
    // Transitive dependencies (from `pip freeze` of the packages above).
    "absl-py==2.5.1",
    "attrs==26.1.0",
    "certifi==2026.10.19.post1",
    "charset-normalizer==3.5.3",
    "click==8.5.1",
    "cmake==4.4.4",
    "contourpy==1.3.3",
    "colorama==0.4.6",
    "cycler==0.12.1",
    "elementpath==5.1.4",
    "etils==1.15.0",
    "fastjsonschema==2.22.3",
    "filelock==4.3.2",
    "fonttools==4.68.0",
    "fsspec==2026.9.0",
    "glfw==2.11.0",
    "idna==3.21",
    "jinja2==3.1.6",
    "jsonschema==4.26.0",
    "jsonschema-specifications==2025.9.1",
    "jupyter-core==5.9.1",
    "kiwisolver==1.5.1",
    "lark==1.3.1",
    "lxml==6.1.3",
    "markupsafe==3.0.4",
    "msgpack==1.2.4",
    "nbformat==5.11.1",
    "packaging==26.3",
    "pillow==13.0.0",
    "platformdirs==4.14.7",
    "protobuf==7.36.2",
    "pyopengl==3.1.10",
    "pyparsing==3.3.3",
    "python-dateutil==4.0.0",
    "pyyaml==6.0.4",
    "referencing==0.37.0",
    "requests==2.34.2",
    "rpds-py==2026.9.1",
    "traitlets==5.16.1",
    "typing-extensions==4.16.0",
    "tzdata==2026.6",
    "urllib3==2.8.0",
    "xmlschema==4.3.2",
    "websockets==17.4",
    "zipp==4.1.2",
];

/// Name of the marker file written after a complete setup. Bump the suffix when
/// the layout of the deps dir changes incompatibly.
const MARKER: &str = "setup-ok-v1";

/// Make sure all prerequisites are installed; return where they are.
///
/// Prints one line per step to stderr (unless `quiet`, in which case only
/// steps that actually install something are reported and the output of
/// apt-get/pip is captured, shown only if they fail).
pub fn setup(quiet: bool) -> Result<Prereqs> {
    let start = Instant::now();
    let p = prereqs();
    let log = Log { quiet };

    // Fast path: marker matches and the key files are still there.
    let marker = p.deps_dir.join(MARKER);
    let expected_marker = marker_contents(&p);
    let marker_ok = fs::read_to_string(&marker).is_ok_and(|m| m == expected_marker);

    ensure_apt_packages(&log)?;

    if marker_ok && mujoco_lib_looks_ok(&p.mujoco_lib()).is_ok() && symlinks_ok(&p) {
        log.step(format_args!(
            "mujoco {MUJOCO_VERSION}: present in {}",
            p.mujoco_lib_dir.display()
        ));
    } else {
        ensure_mujoco(&p, &log)?;
    }

    if marker_ok && p.python.exists() && p.venv_bin().join("fmpy").exists() {
        log.step(format_args!(
            "python venv: present in {}",
            p.venv_dir.display()
        ));
    } else {
        ensure_venv(&p, &log)?;
    }

    if !marker_ok {
        write_atomically(&marker, expected_marker.as_bytes())
            .with_context(|| format!("writing {}", marker.display()))?;
    }

    if !quiet {
        eprintln!(
            "setup: done in {:.2?}\n  deps dir:      {}\n  MuJoCo lib:    {}\n  python (venv): {}\n  \
             marker:        {}",
            start.elapsed(),
            p.deps_dir.display(),
            p.mujoco_lib_dir.display(),
            p.python.display(),
            marker.display(),
        );
    }
    Ok(p)
}

struct Log {
    quiet: bool,
}

impl Log {
    /// A step that found everything in place.
    fn step(&self, msg: std::fmt::Arguments) {
        if !self.quiet {
            eprintln!("setup: {msg}");
        }
    }

    /// A step that changes something (always shown: it may take a while).
    fn action(&self, msg: std::fmt::Arguments) {
        eprintln!("setup: {msg}");
    }

    /// Run `cmd`; with `quiet`, capture its output and show it only on failure.
    fn run(&self, cmd: &mut Command) -> Result<()> {
        let desc = describe(cmd);
        cmd.stdin(Stdio::null());
        if self.quiet {
            let out = cmd
                .output()
                .with_context(|| format!("could not start `{desc}`"))?;
            if !out.status.success() {
                bail!(
                    "`{desc}` failed ({}):\n{}{}",
                    out.status,
                    String::from_utf8_lossy(&out.stdout),
                    String::from_utf8_lossy(&out.stderr)
                );
            }
        } else {
            // Keep our stdout for the child: pip and apt print progress there.
            let status = cmd
                .status()
                .with_context(|| format!("could not start `{desc}`"))?;
            if !status.success() {
                bail!("`{desc}` failed ({status})");
            }
        }
        Ok(())
    }
}

fn describe(cmd: &Command) -> String {
    std::iter::once(cmd.get_program())
        .chain(cmd.get_args())
        .map(OsStr::to_string_lossy)
        .collect::<Vec<_>>()
        .join(" ")
}

fn marker_contents(p: &Prereqs) -> String {
    format!(
        "# Written by `cargo xtask setup` after a complete setup; delete to force a full re-check.\n\
         apt: {}\nmujoco: {MUJOCO_VERSION} {}\nvenv: {}\npython-packages: {}\n",
        APT_PACKAGES.join(" "),
        p.mujoco_lib().display(),
        p.venv_dir.display(),
        PYTHON_PINS.join(" "),
    )
}

// ---------------------------------------------------------------------------
// file helpers

fn tmp_sibling(dest: &Path) -> PathBuf {
    let name = dest.file_name().unwrap_or_default().to_string_lossy();
    dest.with_file_name(format!(".{name}.tmp-{}", std::process::id()))
}

fn write_atomically_with(
    dest: &Path,
    fill: impl FnOnce(&mut fs::File) -> io::Result<()>,
) -> Result<()> {
    let tmp = tmp_sibling(dest);
    let result = (|| {
        let mut f = fs::File::create(&tmp)?;
        fill(&mut f)?;
        f.sync_all()?;
        fs::rename(&tmp, dest)
    })();
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    result.with_context(|| format!("writing {}", dest.display()))
}

fn write_atomically(dest: &Path, contents: &[u8]) -> Result<()> {
    write_atomically_with(dest, |f| f.write_all(contents))
}

fn symlink_atomically(target: &Path, link: &Path) -> Result<()> {
    if fs::read_link(link).is_ok_and(|t| t == target) {
        return Ok(());
    }
    let tmp = tmp_sibling(link);
    let _ = fs::remove_file(&tmp);
    std::os::unix::fs::symlink(target, &tmp)
        .and_then(|()| fs::rename(&tmp, link))
        .with_context(|| format!("symlinking {} -> {}", link.display(), target.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pins_are_exact_and_unique() {
        let mut names: Vec<&str> = PYTHON_PINS
            .iter()
            .map(|p| p.split_once("==").expect("pin uses ==").0)
            .collect();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), PYTHON_PINS.len());
    }
}
