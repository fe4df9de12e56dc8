//! The second seed's walking comparison on the twin: a pattern planned from a virtual model
//! (n, r, s, v: where the error mass is put) by ZMP preview control and whole-body IK, then
//! executed by the servos of the twin with the true masses, the ZMP measured by the two ankle
//! force/torque sensors; open loop, or corrected online by the seed's Torso Position Control
//! ([`zmp_models::walking::torso`], applied through [`TorsoMap`]).

use super::calibrate::{FOOT_SPACING, SOLE_CENTRE_X};
use super::ik::{solve, IkTarget};
use super::robot::{mat3, vec3, PointMass, Sabian, Variant};
use super::tpc::TorsoMap;
use crate::mj::TwinError;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use zmp_models::com::{Mat3, Vec3, Wrench};
use zmp_models::walking::{
    Effort, EffortMeter, Gait, PreviewController, PreviewParams, TorsoControl, TorsoParams,
};

/// Pelvis height while walking (m).
pub const WALK_PELVIS_HEIGHT: f64 = 0.60;
/// The planner's sample time (s).
pub const PLAN_STEP: f64 = 0.01;

/// A virtual model: the CAD model with the error mass put somewhere on the trunk.
#[derive(Debug, Clone, PartialEq)]
pub struct VirtualModel {
    /// The seed's letter (n, r, s, v) or ours (e).
    pub name: String,
    pub description: String,
    /// The error mass on the trunk (none for n).
    pub error_mass: Option<PointMass>,
}

/// A planned walk: joint targets and the ideal ZMP at [`PLAN_STEP`].
#[derive(Debug, Clone)]
pub struct Plan {
    pub model: String,
    /// Full qpos per sample (free joint included).
    pub qpos: Vec<Vec<f64>>,
    /// The planner's (cart-table) ZMP, (m).
    pub zmp: Vec<[f64; 2]>,
    /// The reference ZMP (m).
    pub zmp_ref: Vec<[f64; 2]>,
    /// The planned CoM (m).
    pub com: Vec<[f64; 2]>,
    pub com_height_m: f64,
    /// The planning model's CoM at the first sample (m).
    pub com_at_start: Vec3,
    /// How a torso shift moves the joints, per sample (the planning model's kinematics).
    pub torso: TorsoMap,
}

impl Plan {
    /// The plan's ZMP at time `t` (s), linear between samples (m).
    pub fn zmp_at(&self, t: f64) -> [f64; 2] {
        let kp = (t / PLAN_STEP).max(0.0);
        let i = (kp.floor() as usize).min(self.zmp.len() - 2);
        let w = (kp - i as f64).min(1.0);
        std::array::from_fn(|c| self.zmp[i][c] * (1.0 - w) + self.zmp[i + 1][c] * w)
    }

    /// The Torso Position Control's gains for this plan (the planning model's CoM height and
    /// CoM shift per torso shift) at the control period `step_s`.
    pub fn tpc_params(&self, step_s: f64) -> TorsoParams {
        TorsoParams::design(self.com_height_m, self.torso.com_per_shift, step_s)
    }
}

/// Plans the seed's gait with a virtual model.
pub fn plan(model: &VirtualModel, gait: &Gait) -> Result<Plan, TwinError> {
    let variant = Variant {
        trunk_masses: model.error_mass.into_iter().collect(),
        ..Default::default()
    };
    let mut robot = Sabian::load(&variant, &format!("model {}", model.name))?;
    let n = (gait.duration_s() / PLAN_STEP).round() as usize + 1;
    let samples: Vec<_> = (0..n).map(|k| gait.sample(k as f64 * PLAN_STEP)).collect();
    let zmp_ref: Vec<[f64; 2]> = samples
        .iter()
        .map(|s| [s.zmp_ref[0] + SOLE_CENTRE_X, s.zmp_ref[1]])
        .collect();
    let target = |k: usize, com_xy: [f64; 2]| IkTarget {
        feet: samples[k].feet.map(|f| Vec3::new(f.x, f.y, f.z)),
        pelvis_position: Vec3::new(0.0, 0.0, WALK_PELVIS_HEIGHT),
        pelvis_rotation: Mat3::identity(),
        com_xy: Some(com_xy),
        waist: [0.0, 0.0],
    };
    // The CoM height of the model's standing posture sets the cart-table's height.
    solve(&mut robot, &target(0, zmp_ref[0]))?;
    let com_height_m = robot.com().z;
    let ctrl = PreviewController::new(PreviewParams {
        step_s: PLAN_STEP,
        ..PreviewParams::kajita(com_height_m)
    });
    // Kajita's two-stage planning: the cart-table plan, then the multibody ZMP of the planned
    // motion, and a second preview pass on the difference that moves the CoM to cancel it.
    let ref_x: Vec<f64> = zmp_ref.iter().map(|p| p[0]).collect();
    let ref_y: Vec<f64> = zmp_ref.iter().map(|p| p[1]).collect();
    let xs = ctrl.run(&ref_x, ref_x[0]);
    let ys = ctrl.run(&ref_y, ref_y[0]);
    let mut com: Vec<[f64; 2]> = xs.iter().zip(&ys).map(|(x, y)| [x[0], y[0]]).collect();
    let mut qpos = Vec::with_capacity(n);
    let mut zmp = Vec::new();
    for pass in 0..3 {
        qpos.clear();
        let mut positions = Vec::with_capacity(n);
        for k in 0..n {
            solve(&mut robot, &target(k, com[k]))?;
            qpos.push(robot.data.qpos().to_vec());
            positions.push(body_positions(&robot));
        }
        let masses: Vec<f64> = robot.model().body_mass().to_vec();
        zmp = multibody_zmp(&positions, &masses, PLAN_STEP);
        if pass == 2 {
            break;
        }
        let dx: Vec<f64> = (0..n).map(|k| ref_x[k] - zmp[k][0]).collect();
        let dy: Vec<f64> = (0..n).map(|k| ref_y[k] - zmp[k][1]).collect();
        let cx = ctrl.run(&dx, 0.0);
        let cy = ctrl.run(&dy, 0.0);
        for k in 0..n {
            com[k][0] += cx[k][0];
            com[k][1] += cy[k][0];
        }
    }
    robot.data.qpos_mut().copy_from_slice(&qpos[0]);
    robot.kinematics();
    let com_at_start = robot.com();
    let torso = TorsoMap::of(&mut robot, &qpos)?;
    Ok(Plan {
        com_at_start,
        model: model.name.clone(),
        qpos,
        zmp,
        zmp_ref,
        com,
        com_height_m,
        torso,
    })
}

fn body_positions(robot: &Sabian) -> Vec<Vec3> {
    robot.data.xipos().iter().map(vec3).collect()
}

/// The multibody ZMP of a motion sampled every `dt` (point masses at the bodies' centres; the
/// bodies' rotational inertia is left out, as in a multi-mass pattern generator): accelerations
/// by central differences, the ends held.
pub fn multibody_zmp(positions: &[Vec<Vec3>], masses: &[f64], dt: f64) -> Vec<[f64; 2]> {
    let n = positions.len();
    let g = 9.81;
    (0..n)
        .map(|k| {
            let (a, b) = (k.saturating_sub(1), (k + 1).min(n - 1));
            let (mut num_x, mut num_y, mut den) = (0.0, 0.0, 0.0);
            for (i, &m) in masses.iter().enumerate() {
                if m == 0.0 {
                    continue;
                }
                let p = positions[k][i];
                let acc = if a < k && b > k {
                    (positions[b][i] - p * 2.0 + positions[a][i]) / (dt * dt)
                } else {
                    Vec3::zeros()
                };
                let fz = m * (acc.z + g);
                num_x += fz * p.x - m * p.z * acc.x;
                num_y += fz * p.y - m * p.z * acc.y;
                den += fz;
            }
            [num_x / den, num_y / den]
        })
        .collect()
}

/// The small differences between runs.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Perturbation {
    pub friction_scale: f64,
    pub servo_gain_scale: f64,
    /// Initial pelvis offset (m).
    pub initial_offset: [f64; 2],
    /// White noise of the sensors per sample (N, N m).
    pub force_noise_n: f64,
    pub moment_noise_nm: f64,
    pub seed: u64,
}

impl Perturbation {
    /// Run `k`'s perturbation: friction +/-20 %, servo gains +/-5 %, 1 mm initial offset.
    pub fn draw(seed: u64) -> Perturbation {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        Perturbation {
            friction_scale: rng.gen_range(0.8..1.2),
            servo_gain_scale: rng.gen_range(0.95..1.05),
            initial_offset: [rng.gen_range(-1e-3..1e-3), rng.gen_range(-1e-3..1e-3)],
            force_noise_n: 0.5,
            moment_noise_nm: 0.05,
            seed,
        }
    }
}

/// What one run recorded, per phase (the seed's 0.03 s samples; measured values are the
/// phase's means).
#[derive(Debug, Clone, serde::Serialize)]
pub struct Run {
    pub model: String,
    pub fell: bool,
    /// Time of the fall (s), if any.
    pub fall_time_s: Option<f64>,
    /// Measured ZMP (m) from the ankle sensors.
    pub zmp: Vec<[f64; 2]>,
    /// The plan's ZMP at the same phases (m).
    pub zmp_plan: Vec<[f64; 2]>,
    /// MuJoCo's whole-robot CoM, x and y, at each phase's end (m): the truth the sensors do not
    /// give.
    pub com: Vec<[f64; 2]>,
    /// Roll joints (rad), measured and planned: left ankle, left hip, right ankle, right hip.
    pub roll: Vec<[f64; 4]>,
    pub roll_plan: Vec<[f64; 4]>,
    /// Largest sole height reached (m).
    pub max_clearance_m: f64,
    /// Where the pelvis ended (m).
    pub final_pelvis: [f64; 2],
    /// Pelvis height (m) and its tilt from the vertical (deg) at the end.
    pub final_pelvis_height_m: f64,
    pub final_tilt_deg: f64,
    /// Height of each sole's bottom centre at the end (m).
    pub final_sole_heights_m: [f64; 2],
    /// With Torso Position Control: its gains, its torso shift at each phase's end (m) and its
    /// effort.
    pub tpc: Option<TorsoParams>,
    pub torso_shift: Vec<[f64; 2]>,
    pub effort: Option<Effort>,
    /// Wall time of the simulation (s) and simulated time (s).
    pub wall_s: f64,
    pub sim_s: f64,
}

impl Run {
    fn new(model: &str, phases: usize) -> Run {
        Run {
            model: model.to_string(),
            fell: false,
            fall_time_s: None,
            zmp: Vec::with_capacity(phases),
            zmp_plan: Vec::with_capacity(phases),
            com: Vec::with_capacity(phases),
            roll: Vec::with_capacity(phases),
            roll_plan: Vec::with_capacity(phases),
            max_clearance_m: 0.0,
            final_pelvis: [0.0; 2],
            final_pelvis_height_m: 0.0,
            final_tilt_deg: 0.0,
            final_sole_heights_m: [0.0; 2],
            tpc: None,
            torso_shift: Vec::new(),
            effort: None,
            wall_s: 0.0,
            sim_s: 0.0,
        }
    }

    /// The run ended standing where the gait ends: no fall, the pelvis within 3 cm of its
    /// walking height and tilted less than 5 degrees, both soles on the floor (within 5 mm) and
    /// the pelvis within 10 cm of `end_x` along x.
    pub fn finished_standing(&self, end_x: f64) -> bool {
        !self.fell
            && (self.final_pelvis_height_m - WALK_PELVIS_HEIGHT).abs() < 0.03
            && self.final_tilt_deg < 5.0
            && self.final_sole_heights_m.iter().all(|z| z.abs() < 0.005)
            && (self.final_pelvis[0] - end_x).abs() < 0.1
    }
}

/// The ZMP measured by the two ankle sensors (the seed's way): each sensor's wrench, corrected
/// for its sole's weight, summed about the world origin; feet with less than 10 N ignored.
pub fn measured_zmp(robot: &Sabian, noise: &mut impl FnMut() -> Wrench) -> Option<[f64; 2]> {
    let mut f = Vec3::zeros();
    let mut m = Vec3::zeros();
    let g = Vec3::new(0.0, 0.0, -9.81);
    for s in 0..2 {
        let (p, r) = robot.sensor_pose(s);
        let (ms, cs) = robot.sole_cad(s);
        let w = robot.ft_reading(s) + noise();
        // The ground's wrench on the sole: the sole's balance (static), sensor frame.
        let gs = r.transpose() * g * ms;
        let fg = w.force - gs;
        let mg = w.moment - cs.cross(&gs);
        let fw = r * fg;
        if fw.z < 10.0 {
            continue;
        }
        f += fw;
        m += r * mg + p.cross(&fw);
    }
    (f.z > 10.0).then(|| [-m.y / f.z, m.x / f.z])
}

/// Executes a plan on the real twin (`real`: the CAD model with the true masses), open loop or
/// with Torso Position Control (`tpc`; the gains of [`Plan::tpc_params`]), updated every physics
/// step from the measured ZMP.
pub fn execute(
    plan: &Plan,
    real: &Variant,
    gait: &Gait,
    pert: &Perturbation,
    tpc: bool,
) -> Result<Run, TwinError> {
    let variant = Variant {
        friction_scale: Some(pert.friction_scale),
        servo_gain_scale: Some(pert.servo_gain_scale),
        ..real.clone()
    };
    let mut robot = Sabian::load(&variant, "real")?;
    let mut q0 = plan.qpos[0].clone();
    q0[0] += pert.initial_offset[0];
    q0[1] += pert.initial_offset[1];
    robot.data.qpos_mut().copy_from_slice(&q0);
    robot.hold_current_posture();
    let dt = robot.model().opt().timestep;
    let per_plan = (PLAN_STEP / dt).round() as usize;
    let per_phase = (gait.phase_s / dt).round() as usize;
    let phases = (gait.duration_s() / gait.phase_s).round() as usize;
    let servo = robot.idx.servo.clone();
    let roll_q = [
        robot.idx.leg_qpos[0][6],
        robot.idx.leg_qpos[0][1],
        robot.idx.leg_qpos[1][6],
        robot.idx.leg_qpos[1][1],
    ];
    let soles = robot.idx.sole_bottom_site;
    let mut noise = sensor_noise(pert);
    let mut torso = if tpc {
        Some(Torso::new(plan.tpc_params(dt), plan, &servo)?)
    } else {
        None
    };
    let mut run = Run::new(&plan.model, phases);
    run.tpc = torso.as_ref().map(|t| t.control.params);
    let started = std::time::Instant::now();
    let total_steps = phases * per_phase;
    let mut acc = [0.0; 2];
    let mut acc_n = 0usize;
    for step in 0..total_steps {
        // Servo targets: linear between the plan's samples, plus the torso correction.
        let k = step / per_plan;
        let a = (step % per_plan) as f64 / per_plan as f64;
        let q_a = &plan.qpos[k.min(plan.qpos.len() - 1)];
        let q_b = &plan.qpos[(k + 1).min(plan.qpos.len() - 1)];
        {
            let ctrl = robot.data.ctrl_mut();
            for &(act, adr) in &servo {
                ctrl[act] = q_a[adr] + (q_b[adr] - q_a[adr]) * a;
            }
            if let Some(t) = &torso {
                t.correct(&plan.torso, k, a, ctrl);
            }
        }
        robot.data.step();
        let zmp = measured_zmp(&robot, &mut noise);
        if let Some(z) = zmp {
            acc[0] += z[0];
            acc[1] += z[1];
            acc_n += 1;
        }
        if let Some(t) = &mut torso {
            t.update(plan.zmp_at((step + 1) as f64 * dt), zmp);
        }
        for &s in &soles {
            let z = robot.data.site_xpos()[s][2];
            run.max_clearance_m = run.max_clearance_m.max(z);
        }
        if (step + 1) % per_phase == 0 {
            let t = (step + 1) as f64 * dt;
            let qpos = robot.data.qpos();
            if qpos[2] < 0.45 {
                run.fell = true;
                run.fall_time_s = Some(t);
                break;
            }
            let n = acc_n.max(1) as f64;
            run.zmp.push([acc[0] / n, acc[1] / n]);
            acc = [0.0; 2];
            acc_n = 0;
            // The plan at the phase's middle, to match the phase mean.
            run.zmp_plan.push(plan.zmp_at(t - gait.phase_s / 2.0));
            let c = robot.com();
            run.com.push([c.x, c.y]);
            run.roll.push(roll_q.map(|adr| qpos[adr]));
            let kq = ((t / PLAN_STEP).round() as usize).min(plan.qpos.len() - 1);
            run.roll_plan.push(roll_q.map(|adr| plan.qpos[kq][adr]));
            if let Some(tc) = &torso {
                run.torso_shift.push(tc.control.shift());
            }
        }
    }
    run.wall_s = started.elapsed().as_secs_f64();
    let q = robot.data.qpos();
    run.final_pelvis = [q[0], q[1]];
    run.final_pelvis_height_m = q[2];
    // The pelvis's z axis against the vertical: cos(tilt) = 1 - 2 (qx^2 + qy^2).
    run.final_tilt_deg = (1.0 - 2.0 * (q[4] * q[4] + q[5] * q[5]))
        .clamp(-1.0, 1.0)
        .acos()
        .to_degrees();
    run.final_sole_heights_m = soles.map(|s| robot.data.site_xpos()[s][2]);
    run.effort = torso.map(|t| t.meter.effort());
    run.sim_s = robot.data.time();
    Ok(run)
}

/// The sensors' white noise of a run (its own generator, so the draws do not depend on the
/// control).
fn sensor_noise(pert: &Perturbation) -> impl FnMut() -> Wrench + '_ {
    let mut rng = ChaCha8Rng::seed_from_u64(pert.seed ^ 0x5ab1a);
    let mut normal = move || {
        let u1: f64 = rng.gen_range(f64::EPSILON..1.0);
        let u2: f64 = rng.gen();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    };
    move || {
        Wrench::from_array(std::array::from_fn(|k| {
            if k < 3 {
                pert.force_noise_n * normal()
            } else {
                pert.moment_noise_nm * normal()
            }
        }))
    }
}

/// The Torso Position Control of a run: the law, its effort meter and which actuator drives
/// each joint of the plan's [`TorsoMap`].
struct Torso {
    control: TorsoControl,
    meter: EffortMeter,
    actuator: Vec<usize>,
}

impl Torso {
    fn new(p: TorsoParams, plan: &Plan, servo: &[(usize, usize)]) -> Result<Torso, TwinError> {
        let actuator = plan
            .torso
            .qpos
            .iter()
            .map(|q| {
                servo
                    .iter()
                    .find(|(_, adr)| adr == q)
                    .map(|(a, _)| *a)
                    .ok_or_else(|| TwinError::Model {
                        path: "sabian.xml".into(),
                        message: format!("the joint at qpos {q} has no servo"),
                    })
            })
            .collect::<Result<_, _>>()?;
        Ok(Torso {
            control: TorsoControl::new(p),
            meter: EffortMeter::new(p.step_s),
            actuator,
        })
    }

    fn correct(&self, map: &TorsoMap, k: usize, a: f64, ctrl: &mut [f64]) {
        let mut d = [0.0; 12];
        map.apply(k, a, self.control.shift(), &mut d);
        for (i, &act) in self.actuator.iter().enumerate() {
            ctrl[act] += d[i];
        }
    }

    fn update(&mut self, zmp_ref: [f64; 2], zmp: Option<[f64; 2]>) {
        let d = self.control.update(zmp_ref, zmp);
        self.meter.push(d, self.control.saturated());
    }
}

/// The pose of the trunk in the CAD model's standing posture (for placing error masses).
pub fn trunk_at_home() -> Result<(Vec3, Mat3), TwinError> {
    let mut cad = Sabian::load(&Variant::default(), "CAD")?;
    let y = FOOT_SPACING / 2.0;
    solve(
        &mut cad,
        &IkTarget {
            feet: [Vec3::new(0.0, y, 0.0), Vec3::new(0.0, -y, 0.0)],
            pelvis_position: Vec3::new(0.0, 0.0, WALK_PELVIS_HEIGHT),
            pelvis_rotation: Mat3::identity(),
            com_xy: Some([SOLE_CENTRE_X, 0.0]),
            waist: [0.0, 0.0],
        },
    )?;
    cad.kinematics();
    let b = cad.idx.trunk;
    Ok((vec3(&cad.data.xpos()[b]), mat3(&cad.data.xmat()[b])))
}
