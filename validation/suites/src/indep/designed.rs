//! One designed experiment on a draw whose loop ended `ambiguous` (issue 55, items 5 and 7):
//! the set's structures as the loop fitted them are the rivals of the design, run in two
//! stages (`design_staged`: a pilot, then the rest designed on the campaign with the pilot's
//! records); each stage is written as a design file, the independent simulator reads that file
//! and runs its records on the same drawn robot (the robot's own sensor, a noise seed of its
//! own per stage), the records are appended to the campaign
//! (`zmp_campaign::append_campaign`) and the loop runs again on the extended campaign. What
//! the second loop concludes is the case's second verdict.

use super::verdict::{LoopVerdict, MAX_SET};
use std::path::Path;
use zmp_campaign::{append_campaign, read_campaign, Campaign};
use zmp_diagnose::design::{design_staged, to_toml, DesignOptions, Designed, Rival};
use zmp_diagnose::iterate::{run_loop, LoopResult};
use zmp_diagnose::DiagnoseOptions;
use zmp_identify::IdentifyOptions;
use zmp_indep_sim::{write_campaign, Design, Robot};

/// What the loop concluded after one designed experiment.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct AfterDesign {
    /// Records the design proposed (0 when it stopped on an error).
    pub records: usize,
    /// Their total recording time, s.
    pub recording_s: f64,
    /// The smallest predicted separation over the pairs records can separate, noise standard
    /// deviations, with the designed records (the second stage's prediction, made on the
    /// campaign with the pilot's records).
    pub predicted_sigma: f64,
    /// The second loop's effects, in order.
    pub found: Vec<String>,
    /// Whether the second loop's last model explains the data.
    pub explained: bool,
    /// When the second loop ended `ambiguous` again: its set.
    #[serde(default)]
    pub ambiguous_set: Option<Vec<Vec<String>>>,
    /// The design's or the second loop's error, when one stopped the draw.
    pub error: Option<String>,
    /// Whether the second loop reached its time limit (it is scored on what it reached).
    pub time_limit_reached: bool,
}

impl AfterDesign {
    fn failed(e: impl std::fmt::Display) -> AfterDesign {
        AfterDesign {
            records: 0,
            recording_s: 0.0,
            predicted_sigma: 0.0,
            found: Vec::new(),
            explained: false,
            ambiguous_set: None,
            error: Some(e.to_string()),
            time_limit_reached: false,
        }
    }
}

/// The noise seed of the designed records (the pilot's; the rest's is the next one): one the
/// campaign's own records (drawn with the
/// design's `seed`) do not use, so that their noise is a new realisation.
pub fn design_seed(campaign_design: &Design) -> u64 {
    campaign_design.seed + 1
}

/// The rivals of the set, best first (at most [`MAX_SET`]): each structure as the loop fitted
/// it, named by its effects.
pub fn rivals(r: &LoopResult) -> Vec<Rival> {
    let labels = r.set.iter().map(|s| {
        if s.is_empty() {
            "identified".to_string()
        } else {
            s.join("+")
        }
    });
    r.ambiguous_models()
        .into_iter()
        .zip(labels)
        .take(MAX_SET)
        .map(|(spec, label)| Rival {
            label,
            spec: spec.clone(),
        })
        .collect()
}

/// A drawn robot and the campaign the independent simulator wrote of it.
pub struct DrawnCampaign<'a> {
    /// The drawn robot the designed records are simulated on.
    pub robot: &'a Robot,
    /// The campaign's design (its noise seed).
    pub design: &'a Design,
    /// The campaign as read back from its folder.
    pub campaign: &'a Campaign,
    /// Its folder (the designed records are appended after its records).
    pub dir: &'a Path,
}

/// The experiment that decides `r`'s set, run on the drawn robot: designed on its campaign,
/// written to `dir/design-next.toml`, simulated into `dir/designed`, appended,
/// and the loop run again on the extended campaign with `opts` and `iopts`.
pub fn after_design(
    drawn: &DrawnCampaign,
    r: &LoopResult,
    dir: &Path,
    opts: &DiagnoseOptions,
    iopts: &IdentifyOptions,
) -> AfterDesign {
    let (robot, campaign, camp_dir) = (drawn.robot, drawn.campaign, drawn.dir);
    let dopts = DesignOptions {
        campaign_path: camp_dir.display().to_string(),
        threads: opts.threads,
        seed: design_seed(drawn.design),
        decision: r.decision(),
        ..DesignOptions::default()
    };
    // Each stage's records: written as a design file, read by the simulator itself, run on
    // the same robot with its own sensor (the file's white stand-in is for the virtual robot)
    // and a noise seed of their own, appended.
    let mut stage = 0u64;
    let mut run = |base: &Campaign, d: &Designed| -> Result<Campaign, String> {
        let here = dir.join(format!("stage-{stage}"));
        let seed = dopts.seed + stage;
        stage += 1;
        let go = || -> anyhow::Result<Campaign> {
            std::fs::create_dir_all(&here)?;
            let file = here.join("design-next.toml");
            zmp_files::write_file(&file, zmp_files::Kind::Design, to_toml(d).as_bytes(), true)?;
            let next = Design {
                zmp_noise_std: None,
                seed,
                ..Design::from_toml_file(&file)?
            };
            let added_dir = here.join("designed");
            write_campaign(robot, &next, &added_dir, true)?;
            let added = read_campaign(&added_dir)?;
            Ok(append_campaign(base, camp_dir, &added, &added_dir)?)
        };
        go().map_err(|e| format!("{e:#}"))
    };
    // A panic of the design is the draw's error, not the suite's end (one draw is one unit).
    let designed = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        design_staged(
            campaign,
            &r.observations,
            &rivals(r),
            &dopts,
            &mut run,
            &|_| {},
        )
    }));
    let st = match designed {
        Ok(Ok(st)) => st,
        Ok(Err(e)) => return AfterDesign::failed(format!("design-next: {e}")),
        Err(p) => {
            return AfterDesign::failed(format!("design-next panicked: {}", panic_text(p.as_ref())))
        }
    };
    if st.pilot.records.is_empty() {
        return AfterDesign::failed(if st.pilot.decided() {
            "design-next: the campaign separates the set already"
        } else {
            "design-next: no record within the limits helps"
        });
    }
    let extended = st.extended.clone();
    let opts = DiagnoseOptions {
        campaign_path: format!("{} with the designed records", camp_dir.display()),
        ..opts.clone()
    };
    let base = AfterDesign {
        records: st.records().len(),
        recording_s: st.pilot.total_time_s() + st.rest.as_ref().map_or(0.0, |d| d.total_time_s()),
        predicted_sigma: st.last().min_sigma(),
        ..AfterDesign::failed("")
    };
    match run_loop(&extended, None, iopts, &opts, &|_| {}) {
        Ok(r2) => AfterDesign {
            found: r2.found(),
            explained: r2.explained(),
            ambiguous_set: r2.ambiguous_set(),
            error: None,
            time_limit_reached: r2.time_limit_reached,
            ..base
        },
        Err(e) => AfterDesign {
            error: Some(format!("the second loop: {e}")),
            ..base
        },
    }
}

/// The message of a caught panic.
pub fn panic_text(p: &(dyn std::any::Any + Send)) -> String {
    p.downcast_ref::<String>()
        .cloned()
        .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
        .unwrap_or_else(|| "(no message)".into())
}
