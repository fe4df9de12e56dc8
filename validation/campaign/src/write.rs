//! Atomic writing of a campaign folder, through the one output path (`zmp_files`).

use super::data::render_record;
use super::error::{CampaignError, Part};
use super::manifest::{check_positive, check_relative_path, render_manifest};
use super::{for_each_parallel, Campaign, MANIFEST_FILE};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use zmp_files::Kind;

/// Writes `campaign` as a `zmp-campaign/1` folder at `dir`, atomically.
///
/// Everything is validated and written into a temporary sibling folder first (a hidden
/// `.NAME.zmp-tmp-*` next to `dir`, removed on error and, after a killed run, by the next
/// write beside it), which then takes `dir`'s place in one step, so `dir` either holds the
/// complete new campaign or is left as it was. Parent folders are created as needed.
///
/// If `dir` exists and is not empty, it is replaced only when `overwrite` is true and it is a
/// campaign (its `campaign.toml` is `zmp-campaign/1`); otherwise
/// [`CampaignError::AlreadyExists`] (or an [`Invalid`](CampaignError::Invalid) error) is
/// returned and nothing is touched. A symbolic link is followed and its target judged.
///
/// The written campaign reads back bit-exactly with [`read_campaign`](super::read_campaign):
/// floats are written in their shortest round-trip form.
pub fn write_campaign(
    dir: &Path,
    campaign: &Campaign,
    overwrite: bool,
) -> Result<(), CampaignError> {
    // 1. What is at the destination? Decide before doing anything.
    check_destination(dir, overwrite)?;
    // 2. Validate the manifest part (cheap) before creating anything.
    let manifest_path = dir.join(MANIFEST_FILE);
    let files = check_manifest(campaign, &manifest_path)?;
    // 3. Build the new folder aside and swap it in.
    let rate = campaign.sample_rate_hz;
    zmp_files::write_dir(dir, Kind::Campaign, overwrite, |staging| {
        for_each_parallel(campaign.records.len(), |i| {
            let record = &campaign.records[i];
            let shown = dir.join(&files[i]);
            let text = render_record(record, &shown, i, rate)?;
            let rel = check_relative_path(&files[i]).expect("checked");
            Ok(staging.write(&rel, text.as_bytes())?)
        })?;
        staging.write(
            Path::new(MANIFEST_FILE),
            render_manifest(campaign, &files).as_bytes(),
        )?;
        Ok::<_, CampaignError>(())
    })?;
    Ok(())
}

/// Checks, before any work, that a campaign can be written at `dir` (the checks
/// [`write_campaign`] makes first): it must be missing or an empty folder, or hold a campaign
/// and `overwrite` be given. A folder that does not look like a campaign is never replaced.
pub fn check_destination(dir: &Path, overwrite: bool) -> Result<(), CampaignError> {
    if dir.file_name().is_none() {
        return Err(CampaignError::invalid(
            Part::Destination,
            dir,
            None,
            None,
            None,
            "is not usable as a campaign folder (it must end in a folder name)",
        ));
    }
    Ok(zmp_files::check_dir(dir, Kind::Campaign, overwrite)?)
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
