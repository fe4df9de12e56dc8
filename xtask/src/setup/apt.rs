//! `cargo xtask setup`, step a): the Debian packages, checked with dpkg-query and installed
//! with apt-get when missing (as root).

use std::io;
use std::process::{Command, Stdio};

use anyhow::{bail, Context, Result};

use super::{Log, APT_PACKAGES};

pub(super) fn ensure_apt_packages(log: &Log) -> Result<()> {
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
}
