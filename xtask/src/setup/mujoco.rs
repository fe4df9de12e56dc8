//! `cargo xtask setup`, step b): the MuJoCo shared library, extracted from the official PyPI
//! wheel (cached in the deps dir), symlinked and checked by loading it.

use std::fs;
use std::io::{self, Read};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use anyhow::{anyhow, bail, Context, Result};

use super::venv::bootstrap_python;
use super::{symlink_atomically, write_atomically_with, Log};
use crate::env::{Prereqs, MUJOCO_VERSION};

/// Member of the MuJoCo wheel holding the shared library.
fn mujoco_wheel_member() -> String {
    format!("mujoco/libmujoco.so.{MUJOCO_VERSION}")
}

pub(super) fn ensure_mujoco(p: &Prereqs, log: &Log) -> Result<()> {
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
pub(super) fn mujoco_lib_looks_ok(lib: &Path) -> Result<()> {
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

pub(super) fn symlinks_ok(p: &Prereqs) -> bool {
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
