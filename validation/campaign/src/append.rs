//! Appending one campaign's records to another's: the records a designed experiment adds
//! (`cargo xtask design-next`, then `simulate --append` or any recorder) join the campaign
//! they complete.

use super::error::{CampaignError, Part};
use super::{Campaign, Record, MANIFEST_FILE};
use std::path::{Path, PathBuf};

/// `base` with `extra`'s records after its own, `extra`'s files renamed `records/rNNN.csv`
/// after the highest such number of `base` (or its record count) so that no file name
/// repeats. `base_dir` and `extra_dir` only name the campaigns in errors.
///
/// Refused, naming the record of `extra` and the one of `base` it repeats: a record with the
/// same excitation (axis, frequency, amplitude, operating point) and the same samples as one
/// of `base`'s, which is the same record appended twice (a repeated experiment has noise of
/// its own). Also refused: sample rates that differ, and an empty `extra`.
pub fn append_campaign(
    base: &Campaign,
    base_dir: &Path,
    extra: &Campaign,
    extra_dir: &Path,
) -> Result<Campaign, CampaignError> {
    let manifest = extra_dir.join(MANIFEST_FILE);
    let err = |record: Option<usize>, field: &str, message: String| {
        CampaignError::invalid(
            Part::Manifest,
            &manifest,
            None,
            record,
            Some(field),
            message,
        )
    };
    if extra.records.is_empty() {
        return Err(err(None, "records", "is empty: nothing to append".into()));
    }
    if let (Some(a), Some(b)) = (base.sample_rate_hz, extra.sample_rate_hz) {
        if a != b {
            return Err(err(
                None,
                "sample_rate_hz",
                format!(
                    "{b} Hz differs from {} Hz of {}: records of one campaign share a sample \
                     rate",
                    a,
                    base_dir.display()
                ),
            ));
        }
    }
    for (i, r) in extra.records.iter().enumerate() {
        if let Some(j) = base.records.iter().position(|b| same_record(b, r)) {
            return Err(err(
                Some(i),
                "file",
                format!(
                    "{} repeats records[{j}] of {} (same excitation and samples): the same \
                     record appended twice",
                    r.meta.file.display(),
                    base_dir.display()
                ),
            ));
        }
    }
    let first = base
        .records
        .iter()
        .filter_map(|r| file_number(&r.meta.file))
        .max()
        .map_or(base.records.len(), |n| (n + 1).max(base.records.len()));
    let mut records = base.records.clone();
    for (k, r) in extra.records.iter().enumerate() {
        let mut r = r.clone();
        r.meta.file = PathBuf::from(format!("records/r{:03}.csv", first + k));
        records.push(r);
    }
    Ok(Campaign {
        records,
        sample_rate_hz: base.sample_rate_hz.or(extra.sample_rate_hz),
        ..base.clone()
    })
}

/// Whether two records hold the same experiment and the same samples.
fn same_record(a: &Record, b: &Record) -> bool {
    let (m, n) = (&a.meta, &b.meta);
    m.excited == n.excited
        && m.omega == n.omega
        && m.amplitude == n.amplitude
        && m.operating_point == n.operating_point
        && a.t == b.t
        && a.zmp_x == b.zmp_x
        && a.zmp_y == b.zmp_y
}

/// `N` of a file `records/rN.csv`.
fn file_number(file: &Path) -> Option<usize> {
    let name = file
        .to_str()?
        .strip_prefix("records/r")?
        .strip_suffix(".csv")?;
    name.parse().ok()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::RecordMeta;
    use zmp_models::Axis;

    fn record(file: &str, omega: f64, level: f64) -> Record {
        Record {
            meta: RecordMeta {
                file: PathBuf::from(file),
                excited: Axis::X,
                omega,
                amplitude: 0.003,
                operating_point: [0.0, 0.0],
            },
            t: vec![0.0, 0.005, 0.01],
            x_cr: vec![0.0; 3],
            y_cr: vec![0.0; 3],
            zmp_x: vec![level; 3],
            zmp_y: vec![0.0; 3],
            extra: Vec::new(),
        }
    }

    fn campaign(records: Vec<Record>) -> Campaign {
        Campaign {
            name: Some("c".into()),
            robot: None,
            sample_rate_hz: Some(200.0),
            records,
        }
    }

    #[test]
    fn appended_records_are_renumbered_after_the_campaigns() {
        let base = campaign(vec![
            record("records/r000.csv", 1.0, 0.0),
            record("records/r007.csv", 2.0, 0.0),
        ]);
        let extra = campaign(vec![
            record("records/r000.csv", 20.0, 0.1),
            record("records/r001.csv", 1.0, 0.2),
        ]);
        let c = append_campaign(&base, Path::new("a"), &extra, Path::new("b")).unwrap();
        let files: Vec<_> = c.records.iter().map(|r| r.meta.file.clone()).collect();
        assert_eq!(
            files,
            [
                "records/r000.csv",
                "records/r007.csv",
                "records/r008.csv",
                "records/r009.csv"
            ]
            .map(PathBuf::from)
        );
        assert_eq!(c.records[2].meta.omega, 20.0);
        assert_eq!(c.records[3].zmp_x, vec![0.2; 3]);
        assert_eq!(c.name.as_deref(), Some("c"));
    }

    #[test]
    fn a_record_appended_twice_and_another_rate_are_refused() {
        let base = campaign(vec![record("records/r000.csv", 1.0, 0.0)]);
        // The same experiment with other samples (a repetition) is welcome.
        let again = campaign(vec![record("x.csv", 1.0, 0.5)]);
        assert!(append_campaign(&base, Path::new("a"), &again, Path::new("b")).is_ok());
        let twice = campaign(vec![
            record("records/r000.csv", 3.0, 0.5),
            record("records/r001.csv", 1.0, 0.0),
        ]);
        let e = append_campaign(&base, Path::new("a"), &twice, Path::new("b"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("b/campaign.toml")
                && e.contains("records[1]")
                && e.contains("records[0] of a"),
            "{e}"
        );
        let mut other = campaign(vec![record("records/r000.csv", 3.0, 0.5)]);
        other.sample_rate_hz = Some(100.0);
        let e = append_campaign(&base, Path::new("a"), &other, Path::new("b"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("sample_rate_hz") && e.contains("100"), "{e}");
        let e = append_campaign(&base, Path::new("a"), &campaign(vec![]), Path::new("b"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("nothing to append"), "{e}");
    }
}
