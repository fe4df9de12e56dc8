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
use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;

use anyhow::{anyhow, bail, Context, Result};

use crate::env::{prereqs, Prereqs, MUJOCO_VERSION};

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
    // Transitive dependencies (from `pip freeze` of the packages above).
    "absl-py==2.5.1",
    "attrs==26.1.0",
    "cmake==4.4.4",
    "contourpy==1.3.3",
    "colorama==0.4.6",
    "cycler==0.12.1",
    "elementpath==5.1.4",
    "etils==1.15.0",
    "fastjsonschema==2.22.3",
    "fonttools==4.68.0",
    "fsspec==2026.9.0",
    "glfw==2.11.0",
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
    "pyopengl==3.1.10",
    "pyparsing==3.3.3",
    "python-dateutil==4.0.0",
    "referencing==0.37.0",
    "rpds-py==2026.9.1",
    "traitlets==5.16.1",
    "typing-extensions==4.16.0",
    "tzdata==2026.6",
    "xmlschema==4.3.2",
    "websockets==17.4",
    "zipp==4.1.2",
];

/// Minimum Python version of the interpreter the venv is created from (numpy 2.4 needs 3.11).
const MIN_PYTHON: (u32, u32) = (3, 11);

/// Name of the marker file written after a complete setup. Bump the suffix when
/// the layout of the deps dir changes incompatibly.
const MARKER: &str = "setup-ok-v1";

/// Member of the MuJoCo wheel holding the shared library.
fn mujoco_wheel_member() -> String {
    format!("mujoco/libmujoco.so.{MUJOCO_VERSION}")
}

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
// a) apt packages

fn ensure_apt_packages(log: &Log) -> Result<()> {
    let out = match Command::new("dpkg-query")
        .args(["-W", "-f=${Package} ${Status}\\n"])
        .args(APT_PACKAGES)
        .stdin(Stdio::null())
        .stderr(Stdio::null())
        .output()
    {
        Ok(out) => out,
        Err(e) if e.kind() == io::ErrorKind::NotFound => {
            log.action(format_args!(
                "system packages: no dpkg-query (not Debian/Ubuntu?); make sure the equivalents \
                 of {} are installed",
                APT_PACKAGES.join(" ")
            ));
            return Ok(());
        }
        Err(e) => return Err(e).context("running dpkg-query"),
    };
    // dpkg-query exits non-zero when some package is unknown; parse what it printed.
    let listing = String::from_utf8_lossy(&out.stdout);
    let missing = missing_packages(&listing);
    if missing.is_empty() {
        log.step(format_args!(
            "system packages: all {} installed",
            APT_PACKAGES.len()
        ));
        return Ok(());
    }

    let install_args = format!(
        "apt-get install -y --no-install-recommends {}",
        missing.join(" ")
    );
    if !is_root() {
        bail!(
            "missing system packages: {}\nInstall them with:\n  sudo apt-get update && sudo \
             DEBIAN_FRONTEND=noninteractive {install_args}\nthen run `cargo xtask setup` again.",
            missing.join(" ")
        );
    }

    log.action(format_args!(
        "system packages: installing {}",
        missing.join(" ")
    ));
    let apt = |args: &[&str]| {
        let mut cmd = Command::new("apt-get");
        cmd.env("DEBIAN_FRONTEND", "noninteractive")
            // Wait for another apt/dpkg instead of failing at once.
            .args(["-o", "DPkg::Lock::Timeout=600"]);
        if log.quiet {
            cmd.arg("-qq");
        }
        cmd.args(args);
        cmd
    };
    log.run(&mut apt(&["update"]))?;
    let mut install = apt(&["install", "-y", "--no-install-recommends"]);
    install.args(&missing);
    log.run(&mut install)?;

    let out = Command::new("dpkg-query")
        .args(["-W", "-f=${Package} ${Status}\\n"])
        .args(APT_PACKAGES)
        .stderr(Stdio::null())
        .output()
        .context("running dpkg-query")?;
    let still = missing_packages(&String::from_utf8_lossy(&out.stdout));
    if !still.is_empty() {
        bail!("apt-get install succeeded but these are still not installed: {still:?}");
    }
    Ok(())
}

/// The packages of [`APT_PACKAGES`] that `listing` (lines "PKG STATUS...")
/// does not show as "install ok installed".
fn missing_packages(listing: &str) -> Vec<&'static str> {
    APT_PACKAGES
        .iter()
        .copied()
        .filter(|pkg| {
            !listing.lines().any(|line| {
                line.split_once(' ')
                    .is_some_and(|(name, status)| name == *pkg && status == "install ok installed")
            })
        })
        .collect()
}

fn is_root() -> bool {
    Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| o.status.success() && String::from_utf8_lossy(&o.stdout).trim() == "0")
}

// ---------------------------------------------------------------------------
// b) MuJoCo shared library

fn ensure_mujoco(p: &Prereqs, log: &Log) -> Result<()> {
    let lib = p.mujoco_lib();
    fs::create_dir_all(&p.mujoco_lib_dir)
        .with_context(|| format!("creating {}", p.mujoco_lib_dir.display()))?;

    let extracting = mujoco_lib_looks_ok(&lib).is_err();
    if extracting {
        let wheels = p.deps_dir.join("wheels");
        let wheel = match find_mujoco_wheel(&wheels)? {
            Some(w) => {
                log.step(format_args!(
                    "mujoco {MUJOCO_VERSION}: using cached {}",
                    w.display()
                ));
                w
            }
            None => download_mujoco_wheel(&wheels, log)?,
        };
        log.action(format_args!(
            "mujoco {MUJOCO_VERSION}: extracting {} to {}",
            mujoco_wheel_member(),
            p.mujoco_lib_dir.display()
        ));
        if let Err(e) = extract_member(&wheel, &mujoco_wheel_member(), &lib) {
            // A truncated/corrupt cached wheel: drop it so the next run downloads again.
            let _ = fs::remove_file(&wheel);
            return Err(e.context(format!(
                "extracting {} from {} (removed the wheel; run setup again to re-download)",
                mujoco_wheel_member(),
                wheel.display()
            )));
        }
        mujoco_lib_looks_ok(&lib)?;
    }

    let target = lib.file_name().expect("lib path has a file name");
    for link in ["libmujoco.so", "libmujoco.so.3"] {
        symlink_atomically(Path::new(target), &p.mujoco_lib_dir.join(link))?;
    }

    // Prove that it loads and is the version we expect.
    let version = mujoco_version_via_dlopen(&p.mujoco_lib_dir.join("libmujoco.so"))?;
    if version != MUJOCO_VERSION {
        bail!(
            "{} reports version {version}, expected {MUJOCO_VERSION}",
            lib.display()
        );
    }
    let msg = format_args!(
        "mujoco {MUJOCO_VERSION}: {} {} (dlopen ok, mj_versionString() = {version})",
        if extracting {
            "installed in"
        } else {
            "present in"
        },
        p.mujoco_lib_dir.display()
    );
    if extracting {
        log.action(msg);
    } else {
        log.step(msg);
    }
    Ok(())
}

/// Cheap sanity check: an ELF shared object of this machine's architecture, > 1 MB.
fn mujoco_lib_looks_ok(lib: &Path) -> Result<()> {
    let meta = fs::metadata(lib).with_context(|| format!("{} is missing", lib.display()))?;
    if meta.len() < 1 << 20 {
        bail!("{} is only {} bytes", lib.display(), meta.len());
    }
    let mut header = [0u8; 20];
    fs::File::open(lib)
        .and_then(|mut f| f.read_exact(&mut header))
        .with_context(|| format!("reading {}", lib.display()))?;
    if &header[..4] != b"\x7fELF" {
        bail!("{} is not an ELF file", lib.display());
    }
    let machine = u16::from_le_bytes([header[18], header[19]]);
    let expected = match std::env::consts::ARCH {
        "x86_64" => Some(62),
        "aarch64" => Some(183),
        _ => None,
    };
    if expected.is_some_and(|m| m != machine) {
        bail!(
            "{} is for ELF machine {machine}, not {}",
            lib.display(),
            std::env::consts::ARCH
        );
    }
    Ok(())
}

fn symlinks_ok(p: &Prereqs) -> bool {
    let target = p.mujoco_lib();
    let target = target.file_name().expect("lib path has a file name");
    ["libmujoco.so", "libmujoco.so.3"]
        .iter()
        .all(|l| fs::read_link(p.mujoco_lib_dir.join(l)).is_ok_and(|t| t.as_os_str() == target))
}

/// A cached `mujoco-<version>-*.whl` for this machine's architecture, if any.
fn find_mujoco_wheel(wheels: &Path) -> Result<Option<PathBuf>> {
    let prefix = format!("mujoco-{MUJOCO_VERSION}-");
    let arch = format!("_{}.", std::env::consts::ARCH);
    let entries = match fs::read_dir(wheels) {
        Ok(e) => e,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(e).with_context(|| format!("reading {}", wheels.display())),
    };
    for entry in entries {
        let path = entry?.path();
        let name = path.file_name().unwrap_or_default().to_string_lossy();
        if name.starts_with(&prefix)
            && name.ends_with(".whl")
            && name.contains("linux")
            && name.contains(&arch)
        {
            return Ok(Some(path));
        }
    }
    Ok(None)
}

fn download_mujoco_wheel(wheels: &Path, log: &Log) -> Result<PathBuf> {
    let python = bootstrap_python()?;
    // Download into a private directory, then move into place: a concurrent or
    // interrupted run never sees a partial wheel.
    let tmp = wheels.join(format!(".download-{}", std::process::id()));
    let _ = fs::remove_dir_all(&tmp);
    fs::create_dir_all(&tmp).with_context(|| format!("creating {}", tmp.display()))?;
    log.action(format_args!(
        "mujoco {MUJOCO_VERSION}: downloading the wheel from PyPI with {}",
        python.display()
    ));
    let mut cmd = Command::new(&python);
    cmd.args([
        "-m",
        "pip",
        "download",
        "--disable-pip-version-check",
        "--no-input",
    ])
    .args(["--no-deps", "--only-binary=:all:"])
    .arg(format!("mujoco=={MUJOCO_VERSION}"))
    .arg("-d")
    .arg(&tmp);
    if log.quiet {
        cmd.arg("-q");
    }
    let result = log.run(&mut cmd).and_then(|()| {
        let wheel = find_mujoco_wheel(&tmp)?.ok_or_else(|| {
            anyhow!(
                "pip download left no mujoco-{MUJOCO_VERSION}-*linux_{}.whl in {}",
                std::env::consts::ARCH,
                tmp.display()
            )
        })?;
        let dest = wheels.join(wheel.file_name().expect("wheel has a file name"));
        fs::rename(&wheel, &dest)
            .with_context(|| format!("moving {} to {}", wheel.display(), dest.display()))?;
        Ok(dest)
    });
    let _ = fs::remove_dir_all(&tmp);
    result
}

/// Copy `member` of the zip archive `archive` to `dest` (via a temp file in the
/// same directory and a rename, so `dest` is either absent or complete).
fn extract_member(archive: &Path, member: &str, dest: &Path) -> Result<()> {
    let file = fs::File::open(archive).with_context(|| format!("opening {}", archive.display()))?;
    let mut zip = zip::ZipArchive::new(io::BufReader::new(file))
        .with_context(|| format!("{} is not a valid zip/wheel", archive.display()))?;
    let mut entry = zip
        .by_name(member)
        .with_context(|| format!("{} has no member {member}", archive.display()))?;
    write_atomically_with(dest, |out| {
        // Reading the entry to its end also verifies its CRC-32.
        io::copy(&mut entry, out)?;
        Ok(())
    })?;
    {
        use std::os::unix::fs::PermissionsExt;
        fs::set_permissions(dest, fs::Permissions::from_mode(0o755))
            .with_context(|| format!("chmod {}", dest.display()))?;
    }
    Ok(())
}

/// `dlopen` the library with the system Python's ctypes and return `mj_versionString()`.
fn mujoco_version_via_dlopen(lib: &Path) -> Result<String> {
    let python = bootstrap_python()?;
    let out = Command::new(&python)
        .args([
            "-c",
            "import ctypes, sys\n\
             lib = ctypes.CDLL(sys.argv[1])\n\
             lib.mj_versionString.restype = ctypes.c_char_p\n\
             print(lib.mj_versionString().decode())",
        ])
        .arg(lib)
        .stdin(Stdio::null())
        .output()
        .with_context(|| format!("running {}", python.display()))?;
    if !out.status.success() {
        bail!(
            "{} does not load (dlopen via python ctypes):\n{}",
            lib.display(),
            String::from_utf8_lossy(&out.stderr)
        );
    }
    Ok(String::from_utf8_lossy(&out.stdout).trim().to_string())
}

// ---------------------------------------------------------------------------
// c) Python venv with FMPy

fn ensure_venv(p: &Prereqs, log: &Log) -> Result<()> {
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
fn bootstrap_python() -> Result<PathBuf> {
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
    fn parses_dpkg_listing() {
        let listing = "libegl1 install ok installed\nlibegl1 install ok installed\n\
                       libegl-mesa0 deinstall ok config-files\nvalgrind install ok installed\n\
                       libgl1-mesa-dri install ok installed\n";
        assert_eq!(
            missing_packages(listing),
            vec!["libclang-dev", "libegl-mesa0"]
        );
    }

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
