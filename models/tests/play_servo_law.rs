//! A backlash inside the servo (`backlash.in_servo = 1`): the play sits between the servoed
//! drive and the trunk (`effects::servo_link` with a dead band). The describing response the
//! diagnosis uses must be the first harmonic of the plant's own time steps, with and without
//! the seed's force limit acting; the plant's steps must follow the two-body equations with
//! play integrated independently here; and the play must act as one: a sine inside the play
//! barely moves the trunk, a large one is the engaged loop's linear response. Whether the law
//! is the physical one is tested against an independently written simulator in
//! `validation/suites/tests/play_in_servo.rs`.

use std::f64::consts::PI;
use zmp_models::{Axis, Channel, ModelSpec, Plant};

const H: f64 = 1e-3;
const WIDTH: f64 = 0.002;

const BASE: &str = r#"
format = "zmp-model/1"
name = "play"
[pendulum]
a11 = 0.8293
a12 = 0.07455
a21 = 0.1895
a22 = 1.245
b11 = 0.2767
b12 = 0.005428
b21 = 0.09979
b22 = 0.1012
[tracking_lowpass]
omega_n = 25.0
zeta = 0.9
[backlash.x]
width = 0.002
in_servo = 1
transmission_omega = 160.0
transmission_zeta = 0.2
drive = 0.3
load_drag = 25.0
"#;

fn plant(extra: &str) -> Plant {
    plant_at(extra, H)
}

fn plant_at(extra: &str, h: f64) -> Plant {
    let text = format!("{BASE}\n{extra}");
    let spec = ModelSpec::parse(&text, "play.toml").unwrap_or_else(|e| panic!("{e}\n{text}"));
    Plant::new(&spec, h).unwrap()
}

/// The frequency nearest `w` whose period is a whole number of steps.
fn on_grid(w: f64) -> f64 {
    2.0 * PI / ((2.0 * PI / (w * H)).round() * H)
}

/// The plant's ZMP samples the CoM's acceleration, which jumps where the flanks meet: at
/// 1 ms its first harmonic aliases by up to 2e-3 of the response (the describing function
/// takes the position's harmonic and the pendulum's `b w^2` exactly; the describing function
/// moves by 1e-6 between a 1 ms and a 25 us step, the sampled plant by 1e-2). So the plant is
/// stepped at 25 us here.
#[test]
fn the_describing_response_is_the_first_harmonic_of_the_plants_steps() {
    for extra in ["", "[acceleration_saturation.x]\nlimit = 0.6\n"] {
        let mut p = plant_at(extra, 2.5e-5);
        let d = plant(extra);
        for (w, amp) in [(1.0, 0.004), (6.0, 0.003), (12.0, 0.006), (20.0, 0.0025)] {
            let w = on_grid(w);
            let sim = p.simulated_response(Axis::X, w, amp)[0];
            let df = d.describing_response(Channel::ALL[0], w, amp);
            assert!(
                (df - sim).norm() <= 1e-3 * sim.norm(),
                "{extra:?} {w:.2} rad/s, {amp} m: describing {df}, simulated {sim}"
            );
        }
    }
}

#[test]
fn inside_the_play_the_trunk_barely_moves_and_far_beyond_it_the_loop_is_linear() {
    let p = plant("");
    let w = on_grid(3.0);
    let lin = p.frequency_response(w)[0][0];
    let small = p.describing_response(Channel::ALL[0], w, 0.3 * WIDTH);
    let large = p.describing_response(Channel::ALL[0], w, 200.0 * WIDTH);
    assert!(
        small.norm() < 0.05 * lin.norm(),
        "a sine inside the play: {small} against the linear {lin}"
    );
    assert!(
        (large - lin).norm() < 0.02 * lin.norm(),
        "a sine 200x the play: {large} against the linear {lin}"
    );
    // The play delays: the first harmonic lags the linear loop's at a moderate amplitude.
    let mid = p.describing_response(Channel::ALL[0], w, 2.0 * WIDTH);
    assert!(
        mid.norm() < lin.norm() && (mid / lin).arg() < -0.02,
        "{mid} against {lin}"
    );
}

#[test]
fn a_play_and_a_flexible_trunk_cannot_share_a_servo() {
    let text = format!(
        "{BASE}\n[flexible_trunk.x]\nomega_n = 14.0\nzeta = 0.1\nshare = 0.3\nin_servo = 1\n"
    );
    let err = Plant::new(&ModelSpec::parse(&text, "both.toml").unwrap(), H).unwrap_err();
    assert!(err.to_string().contains("backlash.x.in_servo"), "{err}");
    let bad = BASE.replace("in_servo = 1", "in_servo = 0.5");
    let err = ModelSpec::parse(&bad, "bad.toml")
        .and_then(|s| s.validate("bad.toml").map(|_| s))
        .unwrap_err();
    assert!(err.to_string().contains("in_servo"), "{err}");
}

/// The plant's steps against the two-body equations with play written out here (RK4 at
/// 10 us) through the clamp: the same CoM to a few micrometres (of a 6 mm sine); without the
/// play the same equations are far off (the play acts).
#[test]
fn the_steps_follow_the_two_body_equations_with_play() {
    let (wn, z, limit) = (25.0, 0.9, 0.6);
    let (wt, zt, drive, drag, hp) = (160.0, 0.2, 0.3, 25.0, 0.5 * WIDTH);
    let (wt2, ct) = (wt * wt, 2.0 * zt * wt);
    let u = 1.0 - drive;
    let deriv = |s: [f64; 4], r: f64, play: f64| {
        let force = (wn * wn * (r - s[0]) - 2.0 * z * wn * s[1]).clamp(-limit, limit);
        let d = s[0] - s[2];
        let e = if d > play {
            d - play
        } else if d < -play {
            d + play
        } else {
            0.0
        };
        let mut f = if e == 0.0 {
            0.0
        } else {
            wt2 * e + ct * (s[1] - s[3])
        };
        if f * e <= 0.0 {
            f = 0.0;
        }
        [s[1], (force - u * f) / drive, s[3], f - drag * s[3]]
    };
    let run = |play: f64, h: f64| {
        let mut p = plant_at("[acceleration_saturation.x]\nlimit = 0.6\n", h);
        p.reset([0.0, 0.0]);
        let (amp, w) = (0.006, 9.0);
        let fine = (h / 1e-5).round() as usize;
        let hs = h / fine as f64;
        let mut s = [0.0; 4];
        let mut worst: f64 = 0.0;
        for k in 1..=(3.0 / h).round() as usize {
            for q in 0..fine {
                let t = (k - 1) as f64 * h + q as f64 * hs;
                let r = |t: f64| amp * (w * t).sin();
                let add = |y: [f64; 4], d: [f64; 4], c: f64| [0, 1, 2, 3].map(|i| y[i] + c * d[i]);
                let k1 = deriv(s, r(t), play);
                let k2 = deriv(add(s, k1, 0.5 * hs), r(t + 0.5 * hs), play);
                let k3 = deriv(add(s, k2, 0.5 * hs), r(t + 0.5 * hs), play);
                let k4 = deriv(add(s, k3, hs), r(t + hs), play);
                s = [0, 1, 2, 3]
                    .map(|i| s[i] + hs / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]));
            }
            let out = p.step([amp * (w * k as f64 * h).sin(), 0.0]);
            worst = worst.max((out.com[0] - s[2]).abs());
        }
        worst
    };
    // RK4 is first order across the flanks' contact: a few micrometres at the plant's 1 ms
    // (0.25 ms sub-steps), converging with the step.
    let worst = run(hp, H);
    assert!(worst < 5e-6, "plant and the equations differ by {worst} m");
    let finer = run(hp, H / 4.0);
    assert!(
        finer < 0.5 * worst,
        "at a quarter of the step: {finer} m against {worst} m"
    );
    let gap = run(0.0, H);
    assert!(
        gap > 1e-4,
        "without the play the equations differ by {gap} m only"
    );
}

/// Without an amplitude (the linear response) the play is engaged: the loop's small-signal
/// response is what the plant's steps give for a sine 1000 times the play (the flanks still
/// part where the transmission's force turns, by a part in `play w_t^2 / (a w^2)`), and the
/// transmission and the trunk's drag make it differ from the rigid servo's low-pass.
#[test]
fn its_small_signal_response_is_the_engaged_loop() {
    let mut p = plant_at("", 2.5e-5);
    let rigid_text = BASE.replace("in_servo = 1\n", "in_servo = 0\n");
    let rigid = Plant::new(&ModelSpec::parse(&rigid_text, "rigid.toml").unwrap(), H).unwrap();
    for w in [1.0, 8.0, 30.0] {
        let w = on_grid(w);
        let lin = p.frequency_response(w)[0][0];
        let sim = p.simulated_response(Axis::X, w, 1000.0 * WIDTH)[0];
        assert!(
            (sim - lin).norm() < 5e-3 * lin.norm(),
            "{w:.2} rad/s: {sim} against {lin}"
        );
        let r = rigid.frequency_response(w)[0][0];
        assert!(
            (r - lin).norm() > 0.01 * lin.norm(),
            "{w:.2} rad/s: {r} against {lin}"
        );
    }
}
