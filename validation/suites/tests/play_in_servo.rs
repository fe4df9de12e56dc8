//! A backlash inside a force-limited servo (`backlash.in_servo = 1`), on data this project did
//! not make: draws of the independent simulator (`zmp-indep-sim`, no physics code shared with
//! `zmp-models`) whose drive pushes the trunk through a stiff transmission with play while the
//! seed's acceleration limit acts on the fast, large records.
//!
//! The model is written from the drawn robot's own parameters (pendulum, servo, limit, play,
//! transmission, drive, drag), nothing fitted, once with each law. Inside the servo it must
//! reproduce every record to about its noise; as a play on the CoM command before a clamped
//! rigid servo (`in_servo = 0`, the catalogue's first law) it must be off on the saturated
//! records of some draw, or the test would not tell the laws apart. The saturated records are
//! checked on their own, so the test cannot pass on the many linear records alone.

use num_complex::Complex64;
use zmp_campaign::read_campaign;
use zmp_diagnose::measure::{aggregate, predict, score};
use zmp_diagnose::run::observe_campaign;
use zmp_files::sections::check_page as doc_section;
use zmp_indep_sim::{draw_with, write_campaign, CouplingForm, Design, DrawOptions, Robot};
use zmp_models::ModelSpec;

/// Single backlash draws: development seeds 2, 11 and 20 (the suite's three), and held-out
/// seeds 1020001 and 1020019 (examined after the one run of the 1020000 range, where the
/// loop called them unexplained with their saturated records 3.5-4x off: where the command
/// law was found wanting).
const DRAWS: [u64; 5] = [2, 11, 20, 1_020_001, 1_020_019];
const SCENARIO: &str = "single:backlash";

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

/// The model file of the drawn robot, from its parameters, its play inside the servo or not.
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
            a.friction.is_none()
                && a.command_delay == 0.0
                && a.servo.velocity_limit.is_none()
                && a.modes.is_empty(),
            "the model below holds a servo, a limit and a play per axis"
        );
        t += &format!(
            "[tracking_lowpass.{name}]\nomega_n = {:?}\nzeta = {:?}\n\
             [acceleration_saturation.{name}]\nlimit = {:?}\n",
            a.servo.omega_n, a.servo.zeta, a.servo.accel_limit
        );
        if let Some(tr) = &a.transmission {
            assert!(tr.hardening_deflection.is_none());
            t += &format!(
                "[backlash.{name}]\nwidth = {:?}\nin_servo = {}\ntransmission_omega = {:?}\n\
                 transmission_zeta = {:?}\ndrive = {:?}\nload_drag = {:?}\n",
                tr.play,
                u8::from(in_servo),
                tr.omega,
                tr.zeta,
                a.drive_mass_fraction,
                tr.load_drag_time.map_or(0.0, |tau| 1.0 / tau),
            );
        }
    }
    assert!(
        r.cross_coupling.is_none()
            && r.op_dependence.is_none()
            && r.sensor.lowpass_cutoff.is_none()
            && r.sensor.drift_rate == [0.0, 0.0],
        "a single backlash draw has nothing else hidden"
    );
    ModelSpec::parse(&t, "truth.toml").unwrap_or_else(|e| panic!("{e}\n{t}"))
}

#[test]
fn a_force_limited_servo_driving_its_trunk_through_a_play_matches_the_independent_robot() {
    let design = Design::default();
    let mut played_and_saturated = 0;
    let mut command_worst: f64 = 0.0;
    let mut summary = String::new();
    for seed in DRAWS {
        let robot = draw(seed);
        let dir = tempfile::tempdir().unwrap();
        let camp_dir = dir.path().join("campaign");
        write_campaign(&robot, &design, &camp_dir, true).unwrap();
        let camp = read_campaign(&camp_dir).unwrap();
        let (obs, _) = observe_campaign(&camp, 2);
        let refs: Vec<_> = obs.iter().collect();
        // The records where the limit acts: the rigid linear servo would demand a larger force.
        let saturated: Vec<usize> = obs
            .iter()
            .filter(|o| {
                let a = &robot.axes[o.excited.index()];
                let (wn, z) = (a.servo.omega_n, a.servo.zeta);
                let s = Complex64::new(0.0, o.omega);
                let h = wn * wn / (s * s + 2.0 * z * wn * s + wn * wn);
                (s * s * h).norm() * o.nominal_amplitude > a.servo.accel_limit
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
        let t = std::time::Instant::now();
        let (ratio, worst) = judge(true);
        let took = t.elapsed().as_secs_f64();
        let (command_ratio, command_worst_here) = judge(false);
        command_worst = command_worst.max(command_worst_here);
        let plays: Vec<String> = robot
            .axes
            .iter()
            .filter_map(|a| a.transmission.as_ref())
            .map(|t| format!("{:.2}", t.play * 1e3))
            .collect();
        let line = if saturated.is_empty() {
            format!(
                "- {} seed {seed}: play {} mm, the limit acting on no record: the drawn \
                 robot's own model, its play inside the servo, is {ratio:.2}x the noise floor \
                 over the campaign; as a play on the command, {command_ratio:.2}x.\n",
                range(seed),
                plays.join(" and "),
            )
        } else {
            format!(
                "- {} seed {seed}: play {} mm, the limit acting on {} records: the drawn \
                 robot's own model, its play inside the servo, is {ratio:.2}x the noise floor \
                 over the campaign and {worst:.2}x at the worst saturated record; as a play on \
                 the command, {command_ratio:.2}x and {command_worst_here:.2}x.\n",
                range(seed),
                plays.join(" and "),
                saturated.len()
            )
        };
        eprintln!("{}  ({took:.1} s to predict)", line.trim_end());
        summary.push_str(&line);
        if !plays.is_empty() && !saturated.is_empty() {
            played_and_saturated += 1;
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
        played_and_saturated >= 2,
        "the draws must exercise the limit with a play ({played_and_saturated})"
    );
    assert!(
        command_worst > 3.0,
        "the command law should miss the saturated records somewhere (worst {command_worst:.2}x)"
    );
    doc_section("docs/src/effect-laws.md", "play-in-servo", &summary);
}

fn range(seed: u64) -> &'static str {
    if seed < 900_000 {
        "development"
    } else {
        "held-out"
    }
}
