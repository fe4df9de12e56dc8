//! The whole second-seed experiment on the twin: calibrate the CoM (the seed's design and ours,
//! repeated over noise draws), build the virtual models n, r, s, v (and e), plan and walk each
//! several times open loop and with the seed's Torso Position Control, and collect the seed's
//! tables and the control's effort.

use super::calibrate::*;
use super::compare::{mean, metrics, metrics_over, RunMetrics};
use super::robot::{PointMass, Sabian, Variant};
use super::tpc::TorsoMap;
use super::walk::{execute, plan, Perturbation, Plan, Run, VirtualModel};
use crate::mj::TwinError;
use zmp_models::com::{Mat3, Vec3};
use zmp_models::walking::{Effort, Gait, TorsoParams};

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
    /// The seed's eq. 7 (`M_2` from simulated motor currents, both signs) with zeroed sensors:
    /// what feeding the internal joint moments in costs (ours passes `M_2 = 0`).
    pub motors: MotorModel,
    /// The seed's `M_2` (roll, pitch, yaw sums of the servos' torques, N m) in its two
    /// postures, without current noise.
    pub seed_m2_nm: [[f64; 3]; 2],
    pub seed_eq7_plus: DesignOutcome,
    pub seed_eq7_minus: DesignOutcome,
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
    // The eq. 7 variant's current noise: its own generator, so the other draws stay as they are.
    let mut current_rng = rng(opt.seed ^ 0xe97);
    let motors = MotorModel::twin();
    let mut ours = Vec::new();
    let mut seed = Vec::new();
    let mut zeroed = Vec::new();
    let (mut eq7_plus, mut eq7_minus) = (Vec::new(), Vec::new());
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
        let sc = seed_calibration(
            &[seed_held[0], seed_held[1]],
            sol,
            &offsets,
            &noise,
            &mut r,
            &motors,
            &mut current_rng,
        )
        .map_err(err)?;
        seed.push(sc.with_offsets);
        zeroed.push(sc.zeroed);
        eq7_plus.push(sc.eq7_plus);
        eq7_minus.push(sc.eq7_minus);
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
        motors,
        seed_m2_nm: [0, 1].map(|k| {
            let exact = MotorModel {
                current_std_a: 0.0,
                ..motors
            };
            exact
                .m2(&seed_held[k], &mut rng(0))
                .map_or([f64::NAN; 3], |m| m.into())
        }),
        seed_eq7_plus: summarise(
            "seed, sensors zeroed, eq. 7: M_2 = +sum K I",
            labels(&seed_design()),
            eq7_plus,
        ),
        seed_eq7_minus: summarise(
            "seed, sensors zeroed, eq. 7: M_2 = -sum K I",
            labels(&seed_design()),
            eq7_minus,
        ),
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

/// One model's walks under one control (open loop or with Torso Position Control).
#[derive(Debug, Clone, serde::Serialize)]
pub struct Walks {
    /// Mean over the runs that did not fall, over the seed's 512 phases and over the 256
    /// phases of the motion.
    pub mean: RunMetrics,
    pub mean_motion: RunMetrics,
    pub runs: Vec<RunMetrics>,
    pub falls: usize,
    /// Runs that ended standing at the gait's end ([`Run::finished_standing`]).
    pub finished_standing: usize,
    /// Smallest over runs of the largest sole height reached (m): the feet lift.
    pub min_clearance_m: f64,
    /// Simulated time over wall time, mean over runs (one thread per run).
    pub real_time_factor: f64,
    /// With Torso Position Control: the mean effort over the runs, and each run's.
    pub effort: Option<Effort>,
    pub efforts: Vec<Effort>,
    #[serde(skip)]
    pub traces: Vec<Run>,
}

/// The seed's moving phases: after the 128 still ones, 256.
pub fn motion_phases(gait: &Gait) -> std::ops::Range<usize> {
    let a = gait.still_phases;
    a..a + gait.phases_per_step * gait.strides_m.len()
}

fn walks(runs: Vec<Run>, gait: &Gait) -> Walks {
    let end_x = gait.strides_m.iter().sum::<f64>() / 2.0;
    let ok: Vec<&Run> = runs.iter().filter(|r| !r.fell).collect();
    let ms: Vec<RunMetrics> = ok.iter().map(|r| metrics(r, gait.phase_s)).collect();
    let motion: Vec<RunMetrics> = ok
        .iter()
        .map(|r| metrics_over(r, gait.phase_s, motion_phases(gait)))
        .collect();
    let efforts: Vec<Effort> = runs.iter().filter_map(|r| r.effort).collect();
    Walks {
        mean: if ms.is_empty() {
            metrics(&runs[0], gait.phase_s)
        } else {
            mean(&ms)
        },
        mean_motion: if motion.is_empty() {
            metrics_over(&runs[0], gait.phase_s, motion_phases(gait))
        } else {
            mean(&motion)
        },
        runs: ms,
        falls: runs.len() - ok.len(),
        finished_standing: runs.iter().filter(|r| r.finished_standing(end_x)).count(),
        min_clearance_m: runs
            .iter()
            .map(|r| r.max_clearance_m)
            .fold(f64::INFINITY, f64::min),
        real_time_factor: runs.iter().map(|r| r.sim_s / r.wall_s).sum::<f64>() / runs.len() as f64,
        effort: (!efforts.is_empty()).then(|| Effort::mean(&efforts)),
        efforts,
        traces: runs,
    }
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
    /// The model's CoM minus the real robot's at the plan's first posture (m): what the model
    /// gets wrong.
    pub com_error_m: [f64; 3],
    /// The real robot's CoM shift per unit torso shift there (x, y), for the check of the
    /// control's steady state.
    pub real_com_per_shift: [f64; 2],
    /// The Torso Position Control's gains for this model's plan (none if no run was made).
    pub tpc: Option<TorsoParams>,
    pub open_loop: Walks,
    pub with_tpc: Walks,
    #[serde(skip)]
    pub plan: Option<Plan>,
}

/// The model's CoM error and the real robot's CoM shift per torso shift at the plan's start.
fn model_against_real(plan: &Plan, real: &Variant) -> Result<([f64; 3], [f64; 2]), TwinError> {
    let mut r = Sabian::load(real, "real")?;
    let map = TorsoMap::of(&mut r, &plan.qpos[..1])?;
    r.data.qpos_mut().copy_from_slice(&plan.qpos[0]);
    r.kinematics();
    let real_com = r.com();
    let model_com = plan.com_at_start;
    Ok(((model_com - real_com).into(), map.com_per_shift))
}

/// Plans with each model and walks `runs` times on the twin with the true masses, open loop and
/// with Torso Position Control (the same perturbations for both and for every model).
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
    let jobs: Vec<(usize, usize, bool)> = (0..models.len())
        .flat_map(|m| {
            (0..opt.runs).flat_map(move |r| [false, true].into_iter().map(move |t| (m, r, t)))
        })
        .collect();
    let runs = zmp_campaign::par::try_parallel_map(jobs.len(), opt.threads, |j| {
        let (m, r, tpc) = jobs[j];
        // Run r of each model meets the same robot.
        execute(
            &plans[m],
            &real,
            gait,
            &Perturbation::draw(opt.seed + r as u64),
            tpc,
        )
    })?;
    let mut out = Vec::new();
    for (m, model) in models.iter().enumerate() {
        let pick = |tpc: bool| -> Vec<Run> {
            jobs.iter()
                .zip(&runs)
                .filter(|((mm, _, t), _)| *mm == m && *t == tpc)
                .map(|(_, r)| r.clone())
                .collect()
        };
        let (com_error_m, real_com_per_shift) = model_against_real(&plans[m], &real)?;
        let with_tpc = pick(true);
        out.push(ModelOutcome {
            tpc: with_tpc.first().and_then(|r| r.tpc),
            name: model.name.clone(),
            description: model.description.clone(),
            error_mass_position: model.error_mass.map(|p| p.position.into()),
            error_mass_kg: model.error_mass.map_or(0.0, |p| p.mass_kg),
            com_height_m: plans[m].com_height_m,
            com_error_m,
            real_com_per_shift,
            open_loop: walks(pick(false), gait),
            with_tpc: walks(with_tpc, gait),
            plan: Some(plans[m].clone()),
        });
    }
    Ok(out)
}
