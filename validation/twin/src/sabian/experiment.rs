//! The whole second-seed experiment on the twin: calibrate the CoM (the seed's design and ours,
//! repeated over noise draws), build the virtual models n, r, s, v (and e), plan and walk each
//! several times, and collect the seed's tables.

use super::calibrate::*;
use super::compare::{mean, metrics, RunMetrics};
use super::robot::{PointMass, Sabian, Variant};
use super::walk::{execute, plan, Perturbation, Plan, Run, VirtualModel};
use crate::mj::TwinError;
use zmp_models::com::{Mat3, Vec3};
use zmp_models::walking::Gait;

/// What to run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Options {
    /// Walking runs per virtual model (the seed: 5).
    pub runs: usize,
    /// Noise draws of each calibration (for its error statistics).
    pub draws: usize,
    /// Postures of the designed set.
    pub designed_postures: usize,
    /// Seed of every random draw.
    pub seed: u64,
    /// Worker threads.
    pub threads: usize,
}

impl Options {
    pub fn full() -> Options {
        Options {
            runs: 5,
            draws: 200,
            designed_postures: 12,
            seed: 2013,
            threads: std::thread::available_parallelism().map_or(1, |n| n.get()),
        }
    }

    /// A short version for the demo and CI.
    pub fn quick() -> Options {
        Options {
            runs: 1,
            draws: 40,
            ..Options::full()
        }
    }
}

/// One design's calibration over the noise draws.
#[derive(Debug, Clone, serde::Serialize)]
pub struct DesignOutcome {
    pub name: String,
    pub postures: Vec<String>,
    pub draws: Vec<ComResult>,
    /// RMS over draws of the horizontal and vertical error (m).
    pub rms_horizontal_m: f64,
    pub rms_vertical_m: f64,
    /// RMS over draws of the reported standard deviations, horizontal and vertical (m).
    pub reported_horizontal_m: f64,
    pub reported_vertical_m: f64,
    /// Fraction of |z| <= 2 over draws and axes.
    pub z_within_2: f64,
}

fn summarise(name: &str, postures: Vec<String>, draws: Vec<ComResult>) -> DesignOutcome {
    let n = draws.len() as f64;
    let h = (draws
        .iter()
        .map(|d| d.error[0].powi(2) + d.error[1].powi(2))
        .sum::<f64>()
        / n)
        .sqrt();
    let v = (draws.iter().map(|d| d.error[2].powi(2)).sum::<f64>() / n).sqrt();
    let rh = (draws
        .iter()
        .map(|d| d.std[0].powi(2) + d.std[1].powi(2))
        .sum::<f64>()
        / n)
        .sqrt();
    let rv = (draws.iter().map(|d| d.std[2].powi(2)).sum::<f64>() / n).sqrt();
    let z = draws
        .iter()
        .flat_map(|d| (0..3).map(move |k| (d.error[k] / d.std[k]).abs() <= 2.0))
        .filter(|&b| b)
        .count() as f64
        / (3.0 * n);
    DesignOutcome {
        name: name.into(),
        postures,
        draws,
        rms_horizontal_m: h,
        rms_vertical_m: v,
        reported_horizontal_m: rh,
        reported_vertical_m: rv,
        z_within_2: z,
    }
}

/// The calibration part.
#[derive(Debug, Clone, serde::Serialize)]
pub struct CalibrationOutcome {
    pub noise: SensorNoise,
    pub true_mass_kg: f64,
    pub true_com: [f64; 3],
    pub cad_com: [f64; 3],
    pub true_error_mass_kg: f64,
    /// In the trunk frame (m).
    pub true_error_mass_position: [f64; 3],
    pub seed: DesignOutcome,
    /// The seed's design with perfectly zeroed sensors (what the offsets cost it).
    pub seed_zeroed: DesignOutcome,
    pub designed: DesignOutcome,
    pub designed_condition_number: f64,
    /// The first draw of our design: estimated error mass (kg), its position in the trunk frame
    /// (m), and the total CoM (m) the virtual models use.
    pub estimated_error_mass_kg: f64,
    pub estimated_error_mass_position: [f64; 3],
    pub estimated_com: [f64; 3],
    /// Trunk pose at the calibration's upright posture.
    #[serde(skip)]
    pub trunk: (Vec3, Mat3),
}

/// Runs both calibrations.
pub fn calibrate(opt: &Options) -> Result<CalibrationOutcome, TwinError> {
    let noise = SensorNoise::stated();
    let mut cad = Sabian::load(&Variant::default(), "CAD")?;
    let home_x = home_pelvis_x(&mut cad)?;
    let sol = soles(&cad);
    let real = Variant {
        trunk_masses: vec![TRUE_ERROR_MASS],
        ..Default::default()
    };
    let (specs, cond) = design(opt.designed_postures, &noise, home_x)?;
    let held = hold_postures(&specs, &real, home_x)?;
    let seed_held = hold_postures(&seed_design(), &real, home_x)?;
    let err = |e: zmp_models::com::ComError| TwinError::Model {
        path: "calibration".into(),
        message: e.to_string(),
    };
    let mut r = rng(opt.seed);
    let mut ours = Vec::new();
    let mut seed = Vec::new();
    let mut zeroed = Vec::new();
    let mut first = None;
    for _ in 0..opt.draws {
        let offsets = draw_offsets(&noise, &mut r);
        let tilts = draw_tilts(held.len(), &noise, &mut r);
        let (res, est) = regressor_calibration(&held, &offsets, &tilts, 1.0, &noise, sol, &mut r)
            .map_err(err)?;
        if first.is_none() {
            first = Some((res, est));
        }
        ours.push(res);
        let (a, b) = seed_calibration(&[seed_held[0], seed_held[1]], sol, &offsets, &noise, &mut r)
            .map_err(err)?;
        seed.push(a);
        zeroed.push(b);
    }
    let (res0, est0) = first.ok_or_else(|| TwinError::Model {
        path: "calibration".into(),
        message: "no noise draws requested".into(),
    })?;
    let k0 = &held[0].kinematics;
    let labels = |s: &[PostureSpec]| s.iter().map(|p| p.label()).collect::<Vec<_>>();
    let m_e = est0.error_mass_kg();
    Ok(CalibrationOutcome {
        noise,
        true_mass_kg: held[0].true_body.0 + sol[0].mass_kg + sol[1].mass_kg,
        true_com: held[0].true_com.into(),
        cad_com: k0.cad_com.into(),
        true_error_mass_kg: TRUE_ERROR_MASS.mass_kg,
        true_error_mass_position: TRUE_ERROR_MASS.position.into(),
        seed: summarise("seed: upright + 1 deg", labels(&seed_design()), seed),
        seed_zeroed: summarise("seed, sensors zeroed", labels(&seed_design()), zeroed),
        designed: summarise("ours: D-optimal", labels(&specs), ours),
        designed_condition_number: cond,
        estimated_error_mass_kg: m_e,
        estimated_error_mass_position: (est0.error_first_moment() / m_e).into(),
        estimated_com: res0.com,
        trunk: k0.trunk,
    })
}

/// The seed's four virtual models (and ours, e) from a calibration. The trunk frame is the one
/// the error masses ride in.
pub fn virtual_models(cal: &CalibrationOutcome) -> Vec<VirtualModel> {
    let (tp, tr) = cal.trunk;
    let in_trunk = |w: [f64; 3]| tr.transpose() * (Vec3::from(w) - tp);
    let m = cal.estimated_error_mass_kg;
    let at = |p: Vec3| {
        Some(PointMass {
            mass_kg: m,
            position: p,
        })
    };
    vec![
        VirtualModel {
            name: "n".into(),
            description: "CAD model, no error mass".into(),
            error_mass: None,
        },
        VirtualModel {
            name: "r".into(),
            description: "error mass at the calibrated total CoM (X_R, Y_R, Z_R), eq. 6".into(),
            error_mass: at(in_trunk(cal.estimated_com)),
        },
        VirtualModel {
            name: "s".into(),
            description: "error mass where it was put on WABIAN (by experience): trunk front, \
                          (0.05, 0, 0.35) m in the trunk frame"
                .into(),
            error_mass: at(Vec3::new(0.05, 0.0, 0.35)),
        },
        VirtualModel {
            name: "v".into(),
            description: "error mass at the CAD model's CoM (X_V, Y_V, Z_V)".into(),
            error_mass: at(in_trunk(cal.cad_com)),
        },
        VirtualModel {
            name: "e".into(),
            description: "ours: error mass where the regressor puts it (h_e / m_e), so the \
                          model's CoM is the calibrated one"
                .into(),
            error_mass: at(Vec3::from(cal.estimated_error_mass_position)),
        },
    ]
}

/// One model's walking.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ModelOutcome {
    pub name: String,
    pub description: String,
    /// Trunk frame (m); none for n.
    pub error_mass_position: Option<[f64; 3]>,
    pub error_mass_kg: f64,
    pub com_height_m: f64,
    pub mean: RunMetrics,
    pub runs: Vec<RunMetrics>,
    pub falls: usize,
    /// Smallest over runs of the largest sole height reached (m): the feet lift.
    pub min_clearance_m: f64,
    /// Simulated time over wall time, mean over runs (one thread per run).
    pub real_time_factor: f64,
    #[serde(skip)]
    pub traces: Vec<Run>,
    #[serde(skip)]
    pub plan: Option<Plan>,
}

/// Plans with each model and walks `runs` times on the twin with the true masses.
pub fn walk_models(
    models: &[VirtualModel],
    opt: &Options,
    gait: &Gait,
) -> Result<Vec<ModelOutcome>, TwinError> {
    let real = Variant {
        trunk_masses: vec![TRUE_ERROR_MASS],
        ..Default::default()
    };
    let plans =
        zmp_campaign::par::try_parallel_map(models.len(), opt.threads, |k| plan(&models[k], gait))?;
    let jobs: Vec<(usize, usize)> = (0..models.len())
        .flat_map(|m| (0..opt.runs).map(move |r| (m, r)))
        .collect();
    let runs = zmp_campaign::par::try_parallel_map(jobs.len(), opt.threads, |j| {
        let (m, r) = jobs[j];
        // The same perturbations for every model: run r of each model meets the same robot.
        execute(
            &plans[m],
            &real,
            gait,
            &Perturbation::draw(opt.seed + r as u64),
        )
    })?;
    let mut out = Vec::new();
    for (m, model) in models.iter().enumerate() {
        let mine: Vec<Run> = jobs
            .iter()
            .zip(&runs)
            .filter(|((mm, _), _)| *mm == m)
            .map(|(_, r)| r.clone())
            .collect();
        let ok: Vec<&Run> = mine.iter().filter(|r| !r.fell).collect();
        let ms: Vec<RunMetrics> = ok.iter().map(|r| metrics(r, gait.phase_s)).collect();
        out.push(ModelOutcome {
            name: model.name.clone(),
            description: model.description.clone(),
            error_mass_position: model.error_mass.map(|p| p.position.into()),
            error_mass_kg: model.error_mass.map_or(0.0, |p| p.mass_kg),
            com_height_m: plans[m].com_height_m,
            mean: if ms.is_empty() {
                metrics(&mine[0], gait.phase_s)
            } else {
                mean(&ms)
            },
            runs: ms,
            falls: mine.len() - ok.len(),
            min_clearance_m: mine
                .iter()
                .map(|r| r.max_clearance_m)
                .fold(f64::INFINITY, f64::min),
            real_time_factor: mine.iter().map(|r| r.sim_s / r.wall_s).sum::<f64>()
                / mine.len() as f64,
            traces: mine,
            plan: Some(plans[m].clone()),
        });
    }
    Ok(out)
}
