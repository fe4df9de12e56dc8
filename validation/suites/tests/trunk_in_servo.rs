//! A flexible trunk inside a force-limited servo (`flexible_trunk.in_servo = 1`), on data
//! this project did not make: draws of the independent simulator (`zmp-indep-sim`, no physics
//! code shared with `zmp-models`) whose trunk rings on a flexible link while the seed's
//! acceleration limit acts on the fast, large records.
//!
//! The model is written from the drawn robot's own parameters (pendulum, servo, limit, link),
//! nothing fitted, once with each law. Stepped inside the servo (the motor's limit clamps the
//! force that drives the joint against the link) it must reproduce every record to its
//! noise; as a filter of the CoM reference before a clamped rigid servo (`in_servo = 0`, the
//! small-signal law, under which the limit clamps the CoM's acceleration) it must be off on
//! the saturated records of some draw, or the test would not tell the laws apart. The
//! saturated records are checked on their own, so the test cannot pass on the many linear
//! records alone.

use num_complex::Complex64;
use zmp_campaign::read_campaign;
use zmp_diagnose::measure::{aggregate, predict, score};
use zmp_diagnose::run::observe_campaign;
use zmp_files::sections::check_page as doc_section;
use zmp_indep_sim::{draw_with, write_campaign, CouplingForm, Design, DrawOptions, Robot};
use zmp_models::effects::servo_link::{joint_response, TrunkLink};
use zmp_models::ModelSpec;

/// Single structural-mode draws: development seeds 5, 14, 23 (the suite's three), and
/// held-out seed 980004 (examined after the one run of the 980000 range: the loop ended at
/// 21x the noise floor with the mode unnamed; it is where the law was found wanting).
const DRAWS: [u64; 4] = [5, 14, 23, 980_004];
const SCENARIO: &str = "single:structural_mode";

fn draw(seed: u64) -> Robot {
    draw_with(
        seed,
        &SCENARIO.parse().unwrap(),
        &Design::default(),
        &DrawOptions {
            coupling_form: Some(CouplingForm::Pendulum),
        },
    )
}

/// The model file of the drawn robot, from its parameters, its trunk `in_servo` or not.
fn truth_model(r: &Robot, in_servo: bool) -> ModelSpec {
    let p = &r.pendulum;
    let mut t = format!(
        "format = \"zmp-model/1\"\nname = \"draw {:?}\"\n[pendulum]\n\
         a11 = {:?}\na12 = {:?}\na21 = {:?}\na22 = {:?}\n\
         b11 = {:?}\nb12 = {:?}\nb21 = {:?}\nb22 = {:?}\n",
        r.seed,
        p.a[0][0],
        p.a[0][1],
        p.a[1][0],
        p.a[1][1],
        p.b[0][0],
        p.b[0][1],
        p.b[1][0],
        p.b[1][1]
    );
    for (k, name) in ["x", "y"].iter().enumerate() {
        let a = &r.axes[k];
        assert!(
            a.transmission.is_none()
                && a.friction.is_none()
                && a.command_delay == 0.0
                && a.servo.velocity_limit.is_none()
                && a.modes.len() <= 1,
            "the model below holds a rigid drive and at most one link per axis"
        );
        t += &format!(
            "[tracking_lowpass.{name}]\nomega_n = {:?}\nzeta = {:?}\n\
             [acceleration_saturation.{name}]\nlimit = {:?}\n",
            a.servo.omega_n, a.servo.zeta, a.servo.accel_limit
        );
        if let Some(m) = a.modes.first() {
            t += &format!(
                "[flexible_trunk.{name}]\nomega_n = {:?}\nzeta = {:?}\nshare = {:?}\n\
                 drive = {:?}\nin_servo = {}\n",
                m.omega,
                m.zeta,
                m.mass_fraction,
                a.drive_mass_fraction,
                u8::from(in_servo)
            );
        }
    }
    assert!(
        r.cross_coupling.is_none()
            && r.op_dependence.is_none()
            && r.sensor.lowpass_cutoff.is_none()
            && r.sensor.drift_rate == [0.0, 0.0],
        "a single mode draw has nothing else hidden"
    );
    ModelSpec::parse(&t, "truth.toml").unwrap()
}

#[test]
fn a_force_limited_servo_driving_a_flexible_trunk_matches_the_independent_robot() {
    let design = Design::default();
    let mut linked_and_saturated = 0;
    let mut filter_worst: f64 = 0.0;
    let mut summary = String::new();
    for seed in DRAWS {
        let robot = draw(seed);
        let dir = tempfile::tempdir().unwrap();
        let camp_dir = dir.path().join("campaign");
        write_campaign(&robot, &design, &camp_dir, true).unwrap();
        let camp = read_campaign(&camp_dir).unwrap();
        let (obs, _) = observe_campaign(&camp, 2);
        let refs: Vec<_> = obs.iter().collect();
        // The records where the limit acts: the linear loop would demand a larger force.
        let saturated: Vec<usize> = obs
            .iter()
            .filter(|o| {
                let a = &robot.axes[o.excited.index()];
                let link = a.modes.first().map(|m| {
                    TrunkLink::flexible(m.omega, m.zeta, m.mass_fraction, a.drive_mass_fraction)
                });
                let (wn, z) = (a.servo.omega_n, a.servo.zeta);
                let xj = joint_response(link, wn, z, o.omega);
                let force = wn * wn * (1.0 - xj) - Complex64::new(0.0, o.omega * 2.0 * z * wn) * xj;
                force.norm() * o.nominal_amplitude > a.servo.accel_limit
            })
            .map(|o| o.index)
            .collect();
        // (campaign error over its floor, worst saturated record over its floor) of a law.
        let judge = |in_servo: bool| {
            let preds = predict(&truth_model(&robot, in_servo), &refs).unwrap();
            let scores: Vec<_> = refs.iter().zip(&preds).map(|(o, p)| score(o, p)).collect();
            let (error, floor) = aggregate(&scores);
            let worst = obs
                .iter()
                .zip(&scores)
                .filter(|(o, _)| saturated.contains(&o.index))
                .map(|(_, s)| s.error() / s.floor())
                .fold(0.0, f64::max);
            (error / floor, worst)
        };
        let (ratio, worst) = judge(true);
        let (filter_ratio, filter_worst_here) = judge(false);
        filter_worst = filter_worst.max(filter_worst_here);
        let linked = robot.axes.iter().filter(|a| !a.modes.is_empty()).count();
        let line = if saturated.is_empty() {
            format!(
                "- {} seed {seed}: a mode on {linked} axes, the limit acting on no record: the \
                 drawn robot's own model is {ratio:.2}x the noise floor over the campaign \
                 ({filter_ratio:.2}x as a filter).\n",
                range(seed)
            )
        } else {
            format!(
                "- {} seed {seed}: a mode on {linked} axes, the limit acting on {} records: the \
                 drawn robot's own model, its trunk inside the servo, is {ratio:.2}x the noise \
                 floor over the campaign and {worst:.2}x at the worst saturated record; as a \
                 filter before the clamped servo, {filter_ratio:.2}x and {filter_worst_here:.2}x.\n",
                range(seed),
                saturated.len()
            )
        };
        eprint!("{line}");
        summary.push_str(&line);
        if linked > 0 && !saturated.is_empty() {
            linked_and_saturated += 1;
        }
        assert!(
            ratio <= 1.5,
            "draw {seed}: the drawn robot's own model is {ratio:.2}x the noise floor off"
        );
        assert!(
            worst <= 3.0,
            "draw {seed}: a saturated record is {worst:.2}x its noise floor off"
        );
    }
    assert!(
        linked_and_saturated >= 2,
        "the draws must exercise the limit with a link ({linked_and_saturated})"
    );
    assert!(
        filter_worst > 3.0,
        "the filter law should miss the saturated records somewhere (worst {filter_worst:.2}x)"
    );
    doc_section("docs/src/effect-laws.md", "trunk-in-servo", &summary);
}

fn range(seed: u64) -> &'static str {
    if seed < 900_000 {
        "development"
    } else {
        "held-out"
    }
}
