//! Atomic writing of a campaign folder.

use super::data::render_record;
use super::error::{CampaignError, Part};
use super::manifest::{check_positive, check_relative_path, render_manifest};
use super::{for_each_parallel, Campaign, MANIFEST_FILE};
use std::collections::HashMap;
use std::fs;
use std::io::{self, Write as _};
use std::path::{Path, PathBuf};

/// Writes `campaign` as a `zmp-campaign/1` folder at `dir`, atomically.
///
/// Everything is validated and written into a temporary sibling folder first (`.campaign-tmp*`
/// next to `dir`), which is then renamed into place, so `dir` either holds the complete new
/// campaign or is left as it was. Parent folders are created as needed.
///
/// If `dir` exists and is not empty, it is replaced only when `overwrite` is true and it holds a
/// `campaign.toml` (it looks like a campaign); otherwise [`CampaignError::AlreadyExists`] (or an
/// [`Invalid`](CampaignError::Invalid) error) is returned and nothing is touched. The old folder
/// is renamed aside, the new one renamed in, and only then is the old one deleted.
///
/// The written campaign reads back bit-exactly with [`read_campaign`](super::read_campaign):
/// floats are written in their shortest round-trip form.
pub fn write_campaign(
    dir: &Path,
    campaign: &Campaign,
    overwrite: bool,
) -> Result<(), CampaignError> {
    // 1. What is at the destination? Decide before doing anything.
    let existing = inspect_destination(dir, overwrite)?;
    let parent = match dir.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };

    // 2. Validate the manifest part (cheap) before creating anything.
    let manifest_path = dir.join(MANIFEST_FILE);
    let files = check_manifest(campaign, &manifest_path)?;

    // 3. Build the new folder next to the destination.
    fs::create_dir_all(parent)
        .map_err(|e| CampaignError::io(parent, None, "create directory", e))?;
    let mut builder = tempfile::Builder::new();
    builder.prefix(".campaign-tmp");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        // Like a plain mkdir: 0777 minus the umask (tempfile's default is 0700).
        builder.permissions(fs::Permissions::from_mode(0o777));
    }
    let tmp = builder
        .tempdir_in(parent)
        .map_err(|e| CampaignError::io(parent, None, "create a temporary folder in", e))?;
    let tmp_path = tmp.path().to_path_buf();

    let rate = campaign.sample_rate_hz;
    for_each_parallel(campaign.records.len(), |i| {
        let record = &campaign.records[i];
        let shown = dir.join(&files[i]);
        let text = render_record(record, &shown, i, rate)?;
        let target = tmp_path.join(check_relative_path(&files[i]).expect("checked"));
        write_file(&target, text.as_bytes())
    })?;
    write_file(
        &tmp_path.join(MANIFEST_FILE),
        render_manifest(campaign, &files).as_bytes(),
    )?;

    // 4. Move into place.
    if existing == Destination::Campaign {
        let aside = tempfile::Builder::new()
            .prefix(".campaign-old")
            .tempdir_in(parent)
            .map_err(|e| CampaignError::io(parent, None, "create a temporary folder in", e))?;
        let old = aside.path().join("old");
        fs::rename(dir, &old).map_err(|e| CampaignError::io(dir, None, "move aside", e))?;
        if let Err(e) = fs::rename(&tmp_path, dir) {
            // Put the old campaign back; the new one is deleted with `tmp`.
            let _ = fs::rename(&old, dir);
            return Err(CampaignError::io(dir, None, "rename into place", e));
        }
        let _ = tmp.keep();
        // Deleting the old campaign: a failure leaves a `.campaign-old*` folder behind but the
        // new campaign is complete, so it is not an error.
        let _ = aside.close();
    } else {
        // A rename replaces a missing or empty folder and refuses a non-empty one, atomically:
        // of two writers that both found the destination free, exactly one gets it.
        match fs::rename(&tmp_path, dir) {
            Ok(()) => {
                let _ = tmp.keep();
            }
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::DirectoryNotEmpty | io::ErrorKind::AlreadyExists
                ) =>
            {
                return Err(CampaignError::AlreadyExists {
                    path: dir.to_path_buf(),
                });
            }
            Err(e) => return Err(CampaignError::io(dir, None, "rename into place", e)),
        }
    }
    Ok(())
}

/// What a campaign destination holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Destination {
    /// Nothing, or an empty folder: free.
    Free,
    /// A campaign (it has a `campaign.toml`) that `overwrite` allows to replace.
    Campaign,
}

/// Checks, before any work, that a campaign can be written at `dir` (the checks
/// [`write_campaign`] makes first): it must be missing or an empty folder, or hold a campaign
/// and `overwrite` be given. A folder that does not look like a campaign is never replaced.
pub fn check_destination(dir: &Path, overwrite: bool) -> Result<(), CampaignError> {
    inspect_destination(dir, overwrite).map(|_| ())
}

fn inspect_destination(dir: &Path, overwrite: bool) -> Result<Destination, CampaignError> {
    let dest_err =
        |message: String| CampaignError::invalid(Part::Destination, dir, None, None, None, message);
    if dir.file_name().is_none() {
        return Err(dest_err(
            "is not usable as a campaign folder (it must end in a folder name)".to_owned(),
        ));
    }
    let meta = match fs::symlink_metadata(dir) {
        Ok(meta) => meta,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(Destination::Free),
        Err(e) => return Err(CampaignError::io(dir, None, "inspect", e)),
    };
    if meta.file_type().is_symlink() {
        return Err(dest_err(
            "is a symbolic link; refusing to replace it (write to its target instead)".to_owned(),
        ));
    }
    if !meta.is_dir() {
        return Err(dest_err(
            "exists and is not a folder; refusing to replace it".to_owned(),
        ));
    }
    let empty = fs::read_dir(dir)
        .map_err(|e| CampaignError::io(dir, None, "read", e))?
        .next()
        .is_none();
    if empty {
        Ok(Destination::Free)
    } else if !overwrite {
        Err(CampaignError::AlreadyExists {
            path: dir.to_path_buf(),
        })
    } else if !dir.join(MANIFEST_FILE).is_file() {
        Err(dest_err(format!(
            "exists and holds no {MANIFEST_FILE}, so it does not look like a campaign; \
             refusing to replace it even with --force"
        )))
    } else {
        Ok(Destination::Campaign)
    }
}

/// Validates the header and record metadata; returns each record's file path as written in
/// `campaign.toml` (UTF-8, `/`-separated on every platform).
fn check_manifest(campaign: &Campaign, manifest: &Path) -> Result<Vec<String>, CampaignError> {
    let err = |record: Option<usize>, field: &str, message: String| {
        CampaignError::invalid(Part::Manifest, manifest, None, record, Some(field), message)
    };
    if let Some(rate) = campaign.sample_rate_hz {
        check_positive(rate).map_err(|m| err(None, "sample_rate_hz", m))?;
    }
    if campaign.records.is_empty() {
        return Err(err(
            None,
            "records",
            "is empty: a campaign needs at least one record".to_owned(),
        ));
    }
    let mut files = Vec::with_capacity(campaign.records.len());
    let mut normalized: HashMap<PathBuf, usize> = HashMap::with_capacity(campaign.records.len());
    for (i, record) in campaign.records.iter().enumerate() {
        let m = &record.meta;
        let Some(file) = m.file.to_str() else {
            return Err(err(
                Some(i),
                "file",
                format!("is not valid UTF-8: {:?}", m.file),
            ));
        };
        let file = if cfg!(windows) {
            file.replace('\\', "/")
        } else {
            file.to_owned()
        };
        let norm = check_relative_path(&file).map_err(|msg| err(Some(i), "file", msg))?;
        if norm == Path::new(MANIFEST_FILE) {
            return Err(err(Some(i), "file", format!("must not be {MANIFEST_FILE}")));
        }
        if let Some(j) = normalized.get(&norm) {
            return Err(err(
                Some(i),
                "file",
                format!("{file:?} is also the file of records[{j}]"),
            ));
        }
        normalized.insert(norm, i);
        check_positive(m.omega).map_err(|msg| err(Some(i), "omega", msg))?;
        check_positive(m.amplitude).map_err(|msg| err(Some(i), "amplitude", msg))?;
        for (k, axis) in ["x", "y"].iter().enumerate() {
            let v = m.operating_point[k];
            if !v.is_finite() {
                return Err(err(
                    Some(i),
                    &format!("operating_point.{axis}"),
                    format!("must be a finite number, got {v}"),
                ));
            }
        }
        files.push(file);
    }
    Ok(files)
}

fn write_file(path: &Path, bytes: &[u8]) -> Result<(), CampaignError> {
    if let Some(dir) = path.parent() {
        fs::create_dir_all(dir).map_err(|e| CampaignError::io(dir, None, "create directory", e))?;
    }
    let mut f = fs::File::create(path).map_err(|e| CampaignError::io(path, None, "create", e))?;
    f.write_all(bytes)
        .and_then(|()| f.sync_all())
        .map_err(|e| CampaignError::io(path, None, "write", e))
}
