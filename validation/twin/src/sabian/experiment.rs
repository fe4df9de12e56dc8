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
use zmp_models::com::{Mat3, SoleCad, Vec3};
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
    /// The full experiment: the seed's 5 runs per model and control, 200 noise draws.
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
    /// The design's name.
    pub name: String,
    /// Its postures' labels.
    pub postures: Vec<String>,
    /// The estimate of each noise draw.
    pub draws: Vec<ComResult>,
    /// RMS over draws of the horizontal and vertical error (m).
    pub rms_horizontal_m: f64,
    /// RMS over draws of the vertical error (m).
    pub rms_vertical_m: f64,
    /// RMS over draws of the reported standard deviations, horizontal and vertical (m).
    pub reported_horizontal_m: f64,
    /// RMS over draws of the reported vertical standard deviation (m).
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
    /// The sensors' noise the draws use.
    pub noise: SensorNoise,
    /// The real twin's mass (kg).
    pub true_mass_kg: f64,
    /// The real twin's whole-robot CoM (m).
    pub true_com: [f64; 3],
    /// The CAD model's whole-robot CoM (m).
    pub cad_com: [f64; 3],
    /// The real twin's mass minus the CAD model's: the error mass (kg).
    pub true_error_mass_kg: f64,
    /// In the trunk frame (m).
    pub true_error_mass_position: [f64; 3],
    /// The seed's two-posture design (upright and 1 degree) with the sensors' offsets.
    pub seed: DesignOutcome,
    /// The seed's design with perfectly zeroed sensors (what the offsets cost it).
    pub seed_zeroed: DesignOutcome,
    /// The seed's eq. 7 (`M_2` from simulated motor currents, both signs) with zeroed sensors:
    /// what feeding the internal joint moments in costs (ours passes `M_2 = 0`).
    pub motors: MotorModel,
    /// The seed's `M_2` (roll, pitch, yaw sums of the servos' torques, N m) in its two
    /// postures, without current noise.
    pub seed_m2_nm: [[f64; 3]; 2],
    /// The seed's eq. 7 with `M_2 = + sum K I`.
    pub seed_eq7_plus: DesignOutcome,
    /// The seed's eq. 7 with `M_2 = - sum K I`.
    pub seed_eq7_minus: DesignOutcome,
    /// Our D-optimal design, offsets estimated.
    pub designed: DesignOutcome,
    /// Condition number of our design's whitened stacked system.
    pub designed_condition_number: f64,
    /// The first draw of our design: estimated error mass (kg), its position in the trunk frame
    /// (m), and the total CoM (m) the virtual models use.
    pub estimated_error_mass_kg: f64,
    /// Position of the estimated error mass in the trunk frame (m).
    pub estimated_error_mass_position: [f64; 3],
    /// The estimated whole-robot CoM (m).
    pub estimated_com: [f64; 3],
    /// Trunk pose at the calibration's upright posture.
    #[serde(skip)]
    pub trunk: (Vec3, Mat3),
}

/// What every noise draw of the calibration uses: the designed postures and the seed's two,
/// held on the twin with the true masses (deterministic: the same on every machine).
pub struct CalibrationSetup {
    /// The force plate's and encoders' stated noise each draw samples.
    pub noise: SensorNoise,
    /// The soles' CAD geometry (left, right).
    pub soles: [SoleCad; 2],
    /// Our designed postures.
    pub specs: Vec<PostureSpec>,
    /// Condition number of the designed postures' regression matrix.
    pub condition_number: f64,
    /// Our postures held on the twin with the true masses.
    pub held: Vec<HeldPosture>,
    /// The seed's postures held on the twin with the true masses.
    pub seed_held: Vec<HeldPosture>,
    /// The motor model of eq. 7 (torque constant per motor).
    pub motors: MotorModel,
}

/// Designs the postures and holds them (and the seed's) on the twin.
pub fn calibration_setup(opt: &Options) -> Result<CalibrationSetup, TwinError> {
    let noise = SensorNoise::stated();
    let mut cad = Sabian::load(&Variant::default(), "CAD")?;
    let home_x = home_pelvis_x(&mut cad)?;
    let real = Variant {
        trunk_masses: vec![TRUE_ERROR_MASS],
        ..Default::default()
    };
    let (specs, condition_number) = design(opt.designed_postures, &noise, home_x)?;
    Ok(CalibrationSetup {
        noise,
        soles: soles(&cad),
        held: hold_postures(&specs, &real, home_x)?,
        seed_held: hold_postures(&seed_design(), &real, home_x)?,
        specs,
        condition_number,
        motors: MotorModel::twin(),
    })
}

/// One noise draw of every calibration: ours (the designed postures) and the seed's four.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DrawSet {
    /// Our calibration (designed postures, `M_2 = 0`).
    pub ours: ComResult,
    /// The seed's two postures, sensors' offsets as stated, `M_2 = 0`.
    pub seed: ComResult,
    /// The seed's two postures, perfectly zeroed sensors, `M_2 = 0`.
    pub zeroed: ComResult,
    /// Zeroed sensors, `M_2 = + sum K I` (the seed's eq. 7).
    pub eq7_plus: ComResult,
    /// Zeroed sensors, `M_2 = - sum K I`.
    pub eq7_minus: ComResult,
    /// Our estimate's error mass (kg) and its position in the trunk frame (m).
    pub error_mass_kg: f64,
    /// Position of the error mass in the trunk frame (m).
    pub error_mass_position: [f64; 3],
}

fn model_error(e: zmp_models::com::ComError) -> TwinError {
    TwinError::Model {
        path: "calibration".into(),
        message: e.to_string(),
    }
}

/// Noise draws `0..upto`. One random stream runs through the draws (draw k's numbers follow
/// draw k-1's), so a block of draws of a sharded run replays the stream from draw 0: a draw
/// costs well under a millisecond beside the setup's seconds.
pub fn calibration_draws(
    setup: &CalibrationSetup,
    opt: &Options,
    upto: usize,
) -> Result<Vec<DrawSet>, TwinError> {
    let (noise, sol) = (&setup.noise, setup.soles);
    let mut r = rng(opt.seed);
    // The eq. 7 variant's current noise: its own generator, so the other draws stay as they are.
    let mut current_rng = rng(opt.seed ^ 0xe97);
    let mut out = Vec::with_capacity(upto);
    for _ in 0..upto {
        let offsets = draw_offsets(noise, &mut r);
        let tilts = draw_tilts(setup.held.len(), noise, &mut r);
        let (ours, est) =
            regressor_calibration(&setup.held, &offsets, &tilts, 1.0, noise, sol, &mut r)
                .map_err(model_error)?;
        let sc = seed_calibration(
            &[setup.seed_held[0], setup.seed_held[1]],
            sol,
            &offsets,
            noise,
            &mut r,
            &setup.motors,
            &mut current_rng,
        )
        .map_err(model_error)?;
        let m_e = est.error_mass_kg();
        out.push(DrawSet {
            ours,
            seed: sc.with_offsets,
            zeroed: sc.zeroed,
            eq7_plus: sc.eq7_plus,
            eq7_minus: sc.eq7_minus,
            error_mass_kg: m_e,
            error_mass_position: (est.error_first_moment() / m_e).into(),
        });
    }
    Ok(out)
}

/// The calibration outcome of the draws (draw 0's estimate is the one the virtual models use).
pub fn assemble_calibration(
    setup: &CalibrationSetup,
    draws: &[DrawSet],
) -> Result<CalibrationOutcome, TwinError> {
    let first = draws.first().ok_or_else(|| TwinError::Model {
        path: "calibration".into(),
        message: "no noise draws requested".into(),
    })?;
    let (held, sol) = (&setup.held, setup.soles);
    let k0 = &held[0].kinematics;
    let labels = |s: &[PostureSpec]| s.iter().map(|p| p.label()).collect::<Vec<_>>();
    let pick = |f: fn(&DrawSet) -> ComResult| draws.iter().map(f).collect::<Vec<_>>();
    let seed_labels = labels(&seed_design());
    Ok(CalibrationOutcome {
        noise: setup.noise,
        true_mass_kg: held[0].true_body.0 + sol[0].mass_kg + sol[1].mass_kg,
        true_com: held[0].true_com.into(),
        cad_com: k0.cad_com.into(),
        true_error_mass_kg: TRUE_ERROR_MASS.mass_kg,
        true_error_mass_position: TRUE_ERROR_MASS.position.into(),
        seed: summarise(
            "seed: upright + 1 deg",
            seed_labels.clone(),
            pick(|d| d.seed),
        ),
        seed_zeroed: summarise(
            "seed, sensors zeroed",
            seed_labels.clone(),
            pick(|d| d.zeroed),
        ),
        motors: setup.motors,
        seed_m2_nm: [0, 1].map(|k| {
            let exact = MotorModel {
                current_std_a: 0.0,
                ..setup.motors
            };
            exact
                .m2(&setup.seed_held[k], &mut rng(0))
                .map_or([f64::NAN; 3], |m| m.into())
        }),
        seed_eq7_plus: summarise(
            "seed, sensors zeroed, eq. 7: M_2 = +sum K I",
            seed_labels.clone(),
            pick(|d| d.eq7_plus),
        ),
        seed_eq7_minus: summarise(
            "seed, sensors zeroed, eq. 7: M_2 = -sum K I",
            seed_labels,
            pick(|d| d.eq7_minus),
        ),
        designed: summarise("ours: D-optimal", labels(&setup.specs), pick(|d| d.ours)),
        designed_condition_number: setup.condition_number,
        estimated_error_mass_kg: first.error_mass_kg,
        estimated_error_mass_position: first.error_mass_position,
        estimated_com: first.ours.com,
        trunk: k0.trunk,
    })
}

/// Runs both calibrations.
pub fn calibrate(opt: &Options) -> Result<CalibrationOutcome, TwinError> {
    let setup = calibration_setup(opt)?;
    let draws = calibration_draws(&setup, opt, opt.draws)?;
    assemble_calibration(&setup, &draws)
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
    /// The same mean over the 256 phases of the motion only.
    pub mean_motion: RunMetrics,
    /// Each run's figures (runs that did not fall).
    pub runs: Vec<RunMetrics>,
    /// Runs that fell.
    pub falls: usize,
    /// Runs that ended standing at the gait's end ([`Run::finished_standing`]).
    pub finished_standing: usize,
    /// Smallest over runs of the largest sole height reached (m): the feet lift.
    pub min_clearance_m: f64,
    /// Simulated time over wall time, mean over runs (one thread per run).
    pub real_time_factor: f64,
    /// With Torso Position Control: the mean effort over the runs, and each run's.
    pub effort: Option<Effort>,
    /// Each run's effort (with Torso Position Control).
    pub efforts: Vec<Effort>,
    /// Each run's recording (for the figures).
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
    /// The model's letter (n, r, s, v, e).
    pub name: String,
    /// What the model is.
    pub description: String,
    /// Trunk frame (m); none for n.
    pub error_mass_position: Option<[f64; 3]>,
    /// The error mass the model puts on the trunk (kg).
    pub error_mass_kg: f64,
    /// Height of the model's CoM (m).
    pub com_height_m: f64,
    /// The model's CoM minus the real robot's at the plan's first posture (m): what the model
    /// gets wrong.
    pub com_error_m: [f64; 3],
    /// The real robot's CoM shift per unit torso shift there (x, y), for the check of the
    /// control's steady state.
    pub real_com_per_shift: [f64; 2],
    /// The Torso Position Control's gains for this model's plan (none if no run was made).
    pub tpc: Option<TorsoParams>,
    /// The walks without control.
    pub open_loop: Walks,
    /// The walks with Torso Position Control.
    pub with_tpc: Walks,
    /// The model's planned walk.
    #[serde(skip)]
    pub plan: Option<Plan>,
}

/// The robot the models walk on: the twin with the true masses.
pub fn true_robot() -> Variant {
    Variant {
        trunk_masses: vec![TRUE_ERROR_MASS],
        ..Default::default()
    }
}

/// What a model's plan says beside its walks.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PlanFacts {
    /// Height of the model's CoM above the floor at the plan's start (m).
    pub com_height_m: f64,
    /// The model's CoM minus the real robot's at the plan's start (m).
    pub com_error_m: [f64; 3],
    /// The real robot's CoM shift per unit torso shift there (x, y).
    pub real_com_per_shift: [f64; 2],
}

/// The model's CoM error and the real robot's CoM shift per torso shift at the plan's start.
pub fn plan_facts(plan: &Plan) -> Result<PlanFacts, TwinError> {
    let mut r = Sabian::load(&true_robot(), "real")?;
    let map = TorsoMap::of(&mut r, &plan.qpos[..1])?;
    r.data.qpos_mut().copy_from_slice(&plan.qpos[0]);
    r.kinematics();
    let real_com = r.com();
    Ok(PlanFacts {
        com_height_m: plan.com_height_m,
        com_error_m: (plan.com_at_start - real_com).into(),
        real_com_per_shift: map.com_per_shift,
    })
}

/// One walk: (model, run, with Torso Position Control).
pub type WalkJob = (usize, usize, bool);

/// Every walk of `models` models and `runs` runs, open loop and with the control.
pub fn walk_jobs(models: usize, runs: usize) -> Vec<WalkJob> {
    (0..models)
        .flat_map(|m| {
            (0..runs).flat_map(move |r| [false, true].into_iter().map(move |t| (m, r, t)))
        })
        .collect()
}

/// Run `run` of a plan on the twin with the true masses (run r of each model meets the same
/// robot: the same perturbation).
pub fn walk_one(
    plan: &Plan,
    gait: &Gait,
    opt: &Options,
    run: usize,
    tpc: bool,
) -> Result<Run, TwinError> {
    execute(
        plan,
        &true_robot(),
        gait,
        &Perturbation::draw(opt.seed + run as u64),
        tpc,
    )
}

/// The models' outcomes from their plans' facts and the walks of `jobs` (`runs[k]` is job k's).
pub fn assemble_walks(
    models: &[VirtualModel],
    facts: &[PlanFacts],
    plans: Option<&[Plan]>,
    jobs: &[WalkJob],
    runs: &[Run],
    gait: &Gait,
) -> Vec<ModelOutcome> {
    let mut out = Vec::new();
    for (m, model) in models.iter().enumerate() {
        let pick = |tpc: bool| -> Vec<Run> {
            jobs.iter()
                .zip(runs)
                .filter(|((mm, _, t), _)| *mm == m && *t == tpc)
                .map(|(_, r)| r.clone())
                .collect()
        };
        let with_tpc = pick(true);
        out.push(ModelOutcome {
            tpc: with_tpc.first().and_then(|r| r.tpc),
            name: model.name.clone(),
            description: model.description.clone(),
            error_mass_position: model.error_mass.map(|p| p.position.into()),
            error_mass_kg: model.error_mass.map_or(0.0, |p| p.mass_kg),
            com_height_m: facts[m].com_height_m,
            com_error_m: facts[m].com_error_m,
            real_com_per_shift: facts[m].real_com_per_shift,
            open_loop: walks(pick(false), gait),
            with_tpc: walks(with_tpc, gait),
            plan: plans.map(|p| p[m].clone()),
        });
    }
    out
}

/// Plans with each model and walks `runs` times on the twin with the true masses, open loop and
/// with Torso Position Control (the same perturbations for both and for every model).
pub fn walk_models(
    models: &[VirtualModel],
    opt: &Options,
    gait: &Gait,
) -> Result<Vec<ModelOutcome>, TwinError> {
    let plans =
        zmp_campaign::par::try_parallel_map(models.len(), opt.threads, |k| plan(&models[k], gait))?;
    let jobs = walk_jobs(models.len(), opt.runs);
    let runs = zmp_campaign::par::try_parallel_map(jobs.len(), opt.threads, |j| {
        let (m, r, tpc) = jobs[j];
        walk_one(&plans[m], gait, opt, r, tpc)
    })?;
    let facts = plans
        .iter()
        .map(plan_facts)
        .collect::<Result<Vec<_>, _>>()?;
    Ok(assemble_walks(
        models,
        &facts,
        Some(&plans),
        &jobs,
        &runs,
        gait,
    ))
}
