//! A flexible trunk inside a limited servo (`in_servo = 1`, `effects::servo_link`): in the
//! linear range the stepped two-body loop is the flexible trunk's filter before the rigid servo
//! (`in_servo = 0`); where the
//! limit acts, the describing response (the two-body loop's periodic first harmonic) is what
//! the plant's own time steps give. Whether the law is the physical one is tested against an
//! independently written simulator in `validation/suites/tests/trunk_in_servo.rs`.

use num_complex::Complex64;
use std::f64::consts::PI;
use zmp_models::{Axis, Channel, ModelSpec, Plant};

const H: f64 = 1e-3;

const BASE: &str = r#"
format = "zmp-model/1"
name = "base"
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
[flexible_trunk.x]
omega_n = 14.0
zeta = 0.08
share = 0.35
drive = 0.29
in_servo = 1
"#;

fn plant(extra: &str) -> Plant {
    let text = format!("{BASE}\n{extra}");
    let spec = ModelSpec::parse(&text, "law.toml").unwrap_or_else(|e| panic!("{e}\n{text}"));
    Plant::new(&spec, H).unwrap()
}

fn saturated(limit: f64) -> Plant {
    plant(&format!("[acceleration_saturation.x]\nlimit = {limit}\n"))
}

/// The stepped loop is right: its periodic response to a sine (the plant's own steps) is the
/// flexible trunk's filter times the tracking low-pass, near and away from the mode, as close
/// as the rigid servo's steps are to its low-pass (the plant's steps differ from its
/// frequency response by 1e-5 to 2e-4, the pendulum's acceleration term sampled); and a limit
/// far above the force demanded changes no step at all.
#[test]
fn in_the_linear_range_the_stepped_loop_is_the_trunk_filter() {
    let mut linked = plant("");
    let filter_text = BASE.replace("in_servo = 1\n", "in_servo = 0\n");
    let filter = Plant::new(&ModelSpec::parse(&filter_text, "filter.toml").unwrap(), H).unwrap();
    for w in [0.5, 5.0, 14.0, 40.0] {
        assert_eq!(
            linked.frequency_response(w),
            filter.frequency_response(w),
            "{w} rad/s"
        );
    }
    let rigid_text = BASE.replace(
        "[flexible_trunk.x]\nomega_n = 14.0\nzeta = 0.08\nshare = 0.35\ndrive = 0.29\nin_servo = 1\n",
        "",
    );
    assert!(!rigid_text.contains("flexible_trunk"));
    let mut rigid = Plant::new(&ModelSpec::parse(&rigid_text, "rigid.toml").unwrap(), H).unwrap();
    for w_req in [0.5, 5.0, 13.0, 14.0, 15.0, 40.0] {
        let n = (2.0 * PI / (w_req * H)).round();
        let w = 2.0 * PI / (n * H);
        let (sim, lin) = (
            linked.simulated_response(Axis::X, w, 0.005),
            linked.frequency_response(w),
        );
        let (rsim, rlin) = (
            rigid.simulated_response(Axis::X, w, 0.005),
            rigid.frequency_response(w),
        );
        for i in 0..2 {
            let err = (sim[i] - lin[i][0]).norm() / lin[i][0].norm();
            let rigid_err = (rsim[i] - rlin[i][0]).norm() / rlin[i][0].norm();
            assert!(
                err <= 2.0 * rigid_err.max(1e-6),
                "G{}1 at {w:.3} rad/s: stepped {} against the filter's {} ({err:e}; the rigid \
                 servo's steps {rigid_err:e})",
                i + 1,
                sim[i],
                lin[i][0]
            );
        }
    }
    let (mut free, mut far) = (plant(""), saturated(1e3));
    for k in 1..=3000 {
        let r = [0.005 * (14.0 * k as f64 * H).sin(), 0.0];
        assert_eq!(free.step(r), far.step(r), "step {k}");
    }
}

/// The servo force's linear demand, per unit reference, at `omega` for the axis above.
fn force_gain(omega: f64) -> f64 {
    let link = zmp_models::effects::servo_link::TrunkLink::flexible(14.0, 0.08, 0.35, 0.29);
    let (wn, z) = (25.0, 0.9);
    let xj = zmp_models::effects::servo_link::joint_response(Some(link), wn, z, omega);
    (wn * wn * (1.0 - xj) - Complex64::new(0.0, omega * 2.0 * z * wn) * xj).norm()
}

/// Where the limit acts (1.5 and 3 times the linear force), near and at the mode, with either
/// law: the describing response equals the first harmonic of the plant's own steps, and the
/// limit compresses the gain.
#[test]
fn where_the_limit_acts_the_describing_response_is_the_simulated_one() {
    let limit = 1.0;
    for (law, w_req, demand) in [1, 0]
        .into_iter()
        .flat_map(|l| [9.0, 14.0].map(move |w| (l, w)))
        .flat_map(|(l, w)| [1.5, 3.0].map(move |d| (l, w, d)))
    {
        let n = (2.0 * PI / (w_req * H)).round();
        let w = 2.0 * PI / (n * H);
        let amp = demand * limit / force_gain(w);
        // With the filter law (in_servo = 0) the clamp sees the filter's output, whose
        // amplitude the describing response must carry into the limit's.
        let mut p = Plant::new(
            &ModelSpec::parse(
                &format!("{BASE}\n[acceleration_saturation.x]\nlimit = {limit}\n")
                    .replace("in_servo = 1\n", &format!("in_servo = {law}\n")),
                "law.toml",
            )
            .unwrap(),
            H,
        )
        .unwrap();
        let sim = p.simulated_response(Axis::X, w, amp)[0];
        let df = p.describing_response(Channel::ALL[0], w, amp);
        let lin = p.frequency_response(w)[0][0];
        assert!(
            (df - sim).norm() <= 1e-3 * sim.norm(),
            "in_servo {law}, {w:.2} rad/s, {demand}x: describing {df}, simulated {sim}"
        );
        assert!(
            sim.norm() < 0.95 * lin.norm(),
            "in_servo {law}, {w:.2} rad/s, {demand}x: no compression ({} against linear {})",
            sim.norm(),
            lin.norm()
        );
    }
}

/// The plant's steps (exact linear steps, exact steps under a held force, RK4 where the
/// clamp switches or friction turns) against the two-body equations integrated here by RK4
/// at 10 us, deep in saturation at the mode and through friction's stick-slip: the same CoM
/// to 1 um.
#[test]
fn the_steps_follow_the_two_body_equations_through_the_clamp_and_friction() {
    let (limit, level, v_s) = (0.5, 0.3, 1e-4);
    let clamp = move |d: f64, _v: f64| d.clamp(-limit, limit);
    let friction = move |d: f64, v: f64| d - level * (v / v_s).tanh();
    let cases: [(&str, &ForceLaw, f64, f64); 2] = [
        (
            "[acceleration_saturation.x]\nlimit = 0.5\n",
            &clamp,
            0.008,
            12.0,
        ),
        (
            "[coulomb_friction.x]\nlevel = 0.3\nv_s = 0.0001\n",
            &friction,
            0.003,
            3.0,
        ),
    ];
    for (extra, law, amp, w) in cases {
        let worst = against_fine_rk4(&mut plant(extra), law, amp, w, LINK);
        assert!(
            worst < 1e-6,
            "{extra}: plant and fine RK4 differ by {worst} m"
        );
        // The effect acts: the plant without it is far off the same equations.
        let gap = against_fine_rk4(&mut plant(""), law, amp, w, LINK);
        assert!(
            gap > 1e-4,
            "{extra}: the effect changes the CoM by {gap} m only"
        );
    }
}

/// A stiff link (400 and 2000 rad/s, the second where a fit drove it on a development draw),
/// stepped with the sub-steps its eigenvalues need (`h |lambda| <= 1/4`, far fewer than the
/// row sums' bound gave), through friction's stick-slip: still the two-body equations at
/// 10 us to 1 um.
#[test]
fn a_stiff_link_is_stepped_as_accurately_with_fewer_sub_steps() {
    let (level, v_s) = (0.3, 1e-4);
    let friction = move |d: f64, v: f64| d - level * (v / v_s).tanh();
    for (wm, zm) in [(400.0, 0.05), (2000.0, 1.0)] {
        let text = BASE.replace(
            "omega_n = 14.0\nzeta = 0.08",
            &format!("omega_n = {wm:.1}\nzeta = {zm}"),
        );
        assert_ne!(text, BASE);
        let spec = ModelSpec::parse(
            &format!("{text}\n[coulomb_friction.x]\nlevel = {level}\nv_s = {v_s}\n"),
            "stiff.toml",
        )
        .unwrap();
        let mut p = Plant::new(&spec, H).unwrap();
        let link = (wm, zm, LINK.2, LINK.3);
        let worst = against_fine_rk4(&mut p, &friction, 0.003, 3.0, link);
        assert!(
            worst < 1e-6,
            "omega_m {wm}: plant and fine RK4 differ by {worst} m"
        );
    }
}

/// Largest CoM difference over 3 s between the plant and the two-body equations with the
/// servo force law `law(demand, joint velocity)`, for a reference `amp sin(w t)` on x.
fn against_fine_rk4(
    p: &mut Plant,
    law: &ForceLaw,
    amp: f64,
    w: f64,
    (wm, zm, share, drive): (f64, f64, f64, f64),
) -> f64 {
    let (wn, z) = (25.0, 0.9);
    let u = share * (1.0 - drive);
    p.reset([0.0, 0.0]);
    let deriv = |s: [f64; 4], r: f64| {
        let force = law(wn * wn * (r - s[0]) - 2.0 * z * wn * s[1], s[1]);
        let spring = wm * wm * (s[0] - s[2]) + 2.0 * zm * wm * (s[1] - s[3]);
        [s[1], (force - u * spring) / (1.0 - u), s[3], spring]
    };
    // 10 us sub-steps, or finer for a stiff link (h omega_m <= 0.02).
    let fine = 100.max((H * wm / 0.02).ceil() as usize);
    let hs = H / fine as f64;
    let r = |t: f64| amp * (w * t).sin();
    let mut s = [0.0; 4];
    let mut worst: f64 = 0.0;
    for k in 1..=3000 {
        for m in 0..fine {
            let t = (k - 1) as f64 * H + m as f64 * hs;
            let k1 = deriv(s, r(t));
            let k2 = deriv(add(s, k1, 0.5 * hs), r(t + 0.5 * hs));
            let k3 = deriv(add(s, k2, 0.5 * hs), r(t + 0.5 * hs));
            let k4 = deriv(add(s, k3, hs), r(t + hs));
            for i in 0..4 {
                s[i] += hs / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            }
        }
        let com = (1.0 - share) * s[0] + share * s[2];
        let got = p.step([r(k as f64 * H), 0.0]).com[0];
        worst = worst.max((got - com).abs());
    }
    worst
}

/// The flexible trunk of `BASE`: `omega_m`, `zeta_m`, share, drive.
const LINK: (f64, f64, f64, f64) = (14.0, 0.08, 0.35, 0.29);

/// A servo force law: `law(demand, joint velocity)`.
type ForceLaw = dyn Fn(f64, f64) -> f64;

fn add(s: [f64; 4], d: [f64; 4], t: f64) -> [f64; 4] {
    [0, 1, 2, 3].map(|i| s[i] + t * d[i])
}
