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

use zmp_models::EffectKind;
use zmp_suites::indep_loop;

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

/// The loop on development seeds 23 and 14 (a trunk mode on each plane, the limit acting on
/// the fast, large records). On seed 23 (12.5 and 27.2 rad/s) its rounds name the x mode but,
/// stepped as a filter, it stayed at 24.7x the noise floor. On seed 14 (30.3 and 24.8 rad/s,
/// damping 0.07) the filter fit ran to its damping bound (0.001) with the y link at 19 rad/s
/// and a tenth of the mass, and the law refitted from those values stayed there (the loop ended
/// unexplained at 1.56x); the law is now also fitted from typical links
/// (`candidates::trunk_law_starts`). In both the loop tries the modes inside the servo's loop,
/// every parameter refitted, keeps them only because they fit better, and diagnoses again. It
/// must end within 2x the floor with its modes inside the servo, and seed 14, whose filter was
/// already close, explained. Thresholds fixed before the runs (seed 23: a first version, with
/// no round after the law, ended at 2.13x, the y mode unnamed; seed 14: the suite's closure
/// rule, 2x and explained, against 1.11x measured when the starts were added). Since the mode
/// candidate is itself fitted inside the servo when that fits better (`engine::score_candidate`,
/// held-out draw 1080004 below), a mode can enter the model inside the servo directly
/// (`+structural_mode`) instead of by the loop's `trunk-in-servo` version: the version that
/// first puts a link inside the servo is judged, whichever it is.
#[test]
#[ignore = "long: a loop on one draw of the independent simulator (minutes); `cargo xtask ci --long` runs it"]
fn the_loop_moves_a_mode_the_filter_cannot_explain_inside_the_servo() {
    let mut summary = String::new();
    for seed in [23, 14] {
        let r = indep_loop::loop_on(seed, SCENARIO);
        let changes: Vec<&str> = r.versions.iter().map(|(_, a)| a.change.as_str()).collect();
        eprintln!(
            "seed {seed}: versions {changes:?}; found {:?}; {:.2}x the floor at the end",
            r.found,
            r.final_error / r.noise_floor
        );
        let first = &r
            .versions
            .iter()
            .find(|(_, a)| {
                trunks(&a.spec)
                    .iter()
                    .any(|e| e.value("in_servo") == Some(1.0))
            })
            .unwrap_or_else(|| panic!("seed {seed}: no link inside the servo: {changes:?}"))
            .1;
        if seed == 23 {
            assert!(
                first.error_before > 3.0 * r.noise_floor,
                "the filter law was already close: {:.2}x the floor",
                first.error_before / r.noise_floor
            );
            assert!(
                first.error_after < 0.5 * first.error_before,
                "the law removed little: {:.4} -> {:.4}",
                first.error_before,
                first.error_after
            );
        } else {
            assert!(
                r.explained,
                "seed {seed}: unexplained at {:.2}x the floor",
                r.final_error / r.noise_floor
            );
        }
        let trunks = trunks(&r.final_model);
        assert!(
            !trunks.is_empty() && !r.final_model.has(EffectKind::StructuralMode),
            "seed {seed}: {}",
            r.final_model.to_toml()
        );
        assert!(
            trunks.iter().all(|e| e.value("in_servo") == Some(1.0)),
            "seed {seed}: {}",
            r.final_model.to_toml()
        );
        assert!(
            r.final_error < 2.0 * r.noise_floor,
            "seed {seed}: after the law: {:.2}x the floor",
            r.final_error / r.noise_floor
        );
        summary.push_str(&format!(
            "- development seed {seed}: versions {}; the version that put a link inside the \
             servo ({}) took the error from {:.2}x the noise floor to {:.2}x; at the end {:.2}x \
             ({}), effects found: {}.\n",
            changes.join(", "),
            first.change,
            first.error_before / r.noise_floor,
            first.error_after / r.noise_floor,
            r.final_error / r.noise_floor,
            if r.explained {
                "explained"
            } else {
                "unexplained"
            },
            r.found.join(", ")
        ));
    }
    doc_section("docs/src/effect-laws.md", "trunk-in-servo-loop", &summary);
}

/// Seed 1030030 of the spent held-out range: a mode on each trunk plane (12.1 and 18.6 rad/s)
/// and an 18 ms delay. The loop named both modes as filters and the limit, and ended at 0.90x
/// the noise floor but unexplained: the fastest 8 mm records' cells 4.7x their floor, the
/// delay absorbed into a slower servo (23 rad/s against the drawn 33). Inside the servo, with
/// the links' values alone refitted from each start, the law stayed above the filter
/// (chi-square 16.7 against 1.9 per component): the force limit acts on another force under
/// the new law and its value was not refitted. With it refitted the law is 1.4 per component,
/// no cell significant, at 1.13x the floor; the error had to fall too, so it was not taken.
/// It is now refitted from every start, and a law that explains the data where the filter
/// does not is taken. Since the loop ends with the refit from typical values
/// (`iterate::typical`), the filter law refitted from the seed's servo and typical links
/// explains this draw at 0.84x, lower than the law inside the servo, which is then tried and
/// not taken: either route must end explained with both planes' links. Thresholds are the
/// suite's closure rule (explained, within 2x).
#[test]
#[ignore = "long: a loop on one draw of the independent simulator (minutes); `cargo xtask ci --long` runs it"]
fn a_mode_the_filter_fit_left_unexplained_ends_explained_with_both_links() {
    let r = indep_loop::loop_on(1_030_030, "pair:structural_mode,time_delay");
    let changes: Vec<&str> = r.versions.iter().map(|(_, a)| a.change.as_str()).collect();
    use zmp_diagnose::iterate::{TRUNK_IN_SERVO, TYPICAL_REFIT};
    assert!(
        changes.contains(&TRUNK_IN_SERVO) || changes.contains(&TYPICAL_REFIT),
        "versions {changes:?}"
    );
    assert!(
        r.explained,
        "unexplained at {:.2}x the floor; versions {changes:?}",
        r.final_error / r.noise_floor
    );
    assert!(r.final_error < 2.0 * r.noise_floor);
    let trunks = trunks(&r.final_model);
    assert!(trunks.len() == 2, "{}", r.final_model.to_toml());
}

/// The flexible trunks of a model.
fn trunks(m: &ModelSpec) -> Vec<&zmp_models::EffectInstance> {
    m.effects
        .iter()
        .filter(|e| e.info.kind == EffectKind::FlexibleTrunk)
        .collect()
}

fn range(seed: u64) -> &'static str {
    if seed < 900_000 {
        "development"
    } else {
        "held-out"
    }
}

/// Seed 1080004 of the spent held-out range (examined after its one run): a mode on each
/// trunk plane, x at 20 rad/s above the sweep's highest 15 and y at 15, the limit (1.69 m/s2)
/// clipping six records. As a filter of the CoM reference the best mode fit left a
/// chi-square of 72 000 (the drawn robot's own values: 1 170) and a held-out error above the
/// model's without it, so the loop added nothing and ended unexplained at 11.5x the noise
/// floor: it tries the law inside the servo only for a mode it has added. The mode candidate
/// is now also fitted inside the servo from its filter fit (`engine::score_candidate`).
/// Thresholds fixed before the run: the mode named first, no other effect, the suite's
/// closure rule (explained, within 2x), the links inside the servo.
#[test]
#[ignore = "long: a loop on one draw of the independent simulator (minutes); `cargo xtask ci --long` runs it"]
fn a_mode_the_force_limit_hides_from_the_filter_law_is_named_inside_the_servo() {
    let r = indep_loop::loop_on(1_080_004, SCENARIO);
    assert_eq!(r.found, [EffectKind::StructuralMode], "found {:?}", r.found);
    assert!(
        r.explained && r.final_error < 2.0 * r.noise_floor,
        "{} at {:.2}x the floor",
        if r.explained {
            "explained"
        } else {
            "unexplained"
        },
        r.final_error / r.noise_floor
    );
    let trunks = trunks(&r.final_model);
    assert!(
        trunks.len() == 2 && trunks.iter().all(|e| e.value("in_servo") == Some(1.0)),
        "{}",
        r.final_model.to_toml()
    );
}
