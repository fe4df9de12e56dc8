//! The robust-stability check (`zmp_models::robust`) against a hand computation, against the
//! closed loop's eigenvalues, and against time simulations of perturbed loops.

use nalgebra::{DMatrix, Matrix2};
use num_complex::Complex64;
use zmp_models::controller::CascadeParams;
use zmp_models::lti::{canonical, eigenvalues, Poly, TransferFunction};
use zmp_models::robust::perturbed::{growth_rate, step_error, PerturbedPlant};
use zmp_models::robust::{
    analyse, analyse_model, CascadeLoop, Grid, LoopController, Perturbation, Response2, Weight,
    Weights,
};
use zmp_models::{Channel, ModelSpec};

const G22: Channel = Channel::ALL[3];

fn paper() -> ModelSpec {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/params/silo2-paper.toml");
    ModelSpec::parse(&std::fs::read_to_string(path).unwrap(), "silo2-paper.toml").unwrap()
}

/// A pure integrator per axis, `K = diag(kx/s, ky/s)`.
struct Integrators([f64; 2]);

impl LoopController for Integrators {
    fn at(&self, s: Complex64) -> Response2 {
        let z = Complex64::new(0.0, 0.0);
        Matrix2::new(self.0[0] / s, z, z, self.0[1] / s)
    }
    fn describe(&self) -> String {
        format!("integrators {:?}", self.0)
    }
}

/// The case with a known answer. Plant `G = I`, controller `k/s` per axis: a first-order loop,
/// `T = k / (s + k)`. Weight `W = k_w (s + z) / (s + p)` with `k_w = 2`, `z = 1`, `p = 10` on
/// both diagonal channels (none on the others).
///
/// By hand: `|W T|^2 = k_w^2 k^2 (w^2 + z^2) / ((w^2 + p^2)(w^2 + k^2))`. With `x = w^2`, the
/// derivative of `(x + z^2) / ((x + p^2)(x + k^2))` vanishes where
/// `x^2 + 2 z^2 x - (p^2 - z^2)(k^2 - z^2) + z^4 = 0`... that is
/// `x* = -z^2 + sqrt((p^2 - z^2)(k^2 - z^2))`.
///
/// - x axis, `k = 4`: `x* = -1 + sqrt(99 * 15) = -1 + 38.5357 = 37.5357`, `w* = 6.1267 rad/s`,
///   `|W T| = 2 * 4 * sqrt(38.5357 / (137.5357 * 53.5357)) = 8 * 0.072343 = 0.57875`.
/// - y axis, `k = 1 = z`: `|W T|^2 = 4 / (w^2 + 100)`, largest at `w -> 0`: `0.2` (the grid's
///   lowest point, 1e-4 rad/s, gives it to 1e-10).
///
/// The plant is diagonal, so the channels do not interact: the structured margin is the larger
/// of the two, 0.57875 at 6.1267 rad/s. The nominal loop's poles are `-4` and `-1`: stable.
/// Required agreement: 1 % (the issue's), on values and frequencies.
#[test]
fn first_order_loop_agrees_with_the_hand_computation() {
    let w = Weight {
        k: 2.0,
        z: 1.0,
        p: 10.0,
    };
    let weights = Weights([Some(w), None, None, Some(w)]);
    let identity = |_: f64| Matrix2::<Complex64>::identity();
    let a = analyse(
        &identity,
        &Integrators([4.0, 1.0]),
        &weights,
        &Grid::default(),
    );
    assert_eq!(a.unstable_poles, Some(0));
    let x_star = -1.0 + (99.0f64 * 15.0).sqrt();
    let hand_peak = 8.0 * ((x_star + 1.0) / ((x_star + 100.0) * (x_star + 16.0))).sqrt();
    let hand_omega = x_star.sqrt();
    assert!((hand_peak - 0.57875).abs() < 1e-5 && (hand_omega - 6.1267).abs() < 1e-4);
    let gx = a
        .channels
        .iter()
        .find(|c| c.channel == Channel::ALL[0])
        .unwrap();
    assert!((gx.peak / 0.57875 - 1.0).abs() < 0.01, "{gx:?}");
    assert!((gx.omega / 6.1267 - 1.0).abs() < 0.01, "{gx:?}");
    let gy = a.channels.iter().find(|c| c.channel == G22).unwrap();
    assert!((gy.peak / 0.2 - 1.0).abs() < 0.01, "{gy:?}");
    let s = a.structured.unwrap();
    assert!((s.peak / 0.57875 - 1.0).abs() < 0.01, "{s:?}");
    assert!((s.omega / 6.1267 - 1.0).abs() < 0.01, "{s:?}");
    assert!(a.robustly_stable());
    // A loop with positive feedback on x (`-4/s`: a pole at +4) is counted unstable.
    let b = analyse(
        &identity,
        &Integrators([-4.0, 1.0]),
        &weights,
        &Grid::default(),
    );
    assert_eq!(b.unstable_poles, Some(1));
    assert!(!b.robustly_stable());
}

/// `(a - b s^2) wn^2 / (s^2 + 2 zeta wn s + wn^2)`: one channel of the paper model.
fn channel_tf(spec: &ModelSpec, ch: Channel) -> TransferFunction {
    let pend = spec
        .get(
            zmp_models::EffectKind::Pendulum,
            zmp_models::Binding::Global,
        )
        .unwrap();
    let coef = |p: &str| pend.value(&format!("{p}{}", ch.suffix())).unwrap();
    let lp = spec
        .get(
            zmp_models::EffectKind::TrackingLowpass,
            zmp_models::Binding::Axis(ch.input),
        )
        .unwrap();
    let (wn, zeta) = (lp.values[0], lp.values[1]);
    TransferFunction::new(
        Poly::new(&[coef("a") * wn * wn, 0.0, -coef("b") * wn * wn]),
        Poly::new(&[wn * wn, 2.0 * zeta * wn, 1.0]),
    )
}

/// The continuous closed loop of the paper model and the cascade controller as a state matrix:
/// each channel and each axis's controller in canonical form, `u = K e`, `e = -y`.
fn closed_loop_matrix(spec: &ModelSpec, p: &CascadeParams) -> DMatrix<f64> {
    let c = p.error_scale * p.trunk_gain() * p.k1 * p.k2;
    let ctrl = TransferFunction::new(Poly::new(&[c]), Poly::new(&[0.0, p.k2, 1.0]));
    let (ac, bc, cc, _) = canonical(&ctrl);
    let chans: Vec<_> = Channel::ALL
        .iter()
        .map(|&ch| (ch, canonical(&channel_tf(spec, ch))))
        .collect();
    let np: usize = chans.iter().map(|(_, r)| r.0.nrows()).sum();
    let nc = ac.nrows();
    let n = np + 2 * nc;
    let mut a = DMatrix::zeros(n, n);
    // Offsets: plant channels first, then the x and y controllers.
    let ctrl_off = |axis: usize| np + axis * nc;
    let mut off = 0;
    for (ch, (ap, bp, _, _)) in &chans {
        let k = ap.nrows();
        a.view_mut((off, off), (k, k)).copy_from(ap);
        // x_p' += b_p u_j, u_j = c_c x_c(j).
        let j = ch.input.index();
        let coupling = bp * cc.transpose();
        a.view_mut((off, ctrl_off(j)), (k, nc)).copy_from(&coupling);
        off += k;
    }
    for axis in 0..2 {
        let o = ctrl_off(axis);
        a.view_mut((o, o), (nc, nc)).copy_from(&ac);
        // x_c' += b_c e_i, e_i = -y_i = -sum_j (c_ij x_ij + d_ij u_j).
        let mut off = 0;
        for (ch, (ap, _, cp, dp)) in &chans {
            let k = ap.nrows();
            if ch.output.index() == axis {
                let m = -(&bc * cp.transpose());
                let cur = a.view((o, off), (nc, k)).clone_owned();
                a.view_mut((o, off), (nc, k)).copy_from(&(cur + m));
                let j = ch.input.index();
                let m = -(*dp) * (&bc * cc.transpose());
                let cur = a.view((o, ctrl_off(j)), (nc, nc)).clone_owned();
                a.view_mut((o, ctrl_off(j)), (nc, nc)).copy_from(&(cur + m));
            }
            off += k;
        }
    }
    a
}

/// The argument-principle count against the eigenvalues of the closed loop's state matrix
/// (continuous controller, so that both describe the same loop exactly): integral gains from
/// the seed's up to well past the loop's stability limit.
#[test]
fn nominal_stability_count_is_the_closed_loop_eigenvalues() {
    let spec = paper();
    let mut seen = [false; 2];
    for k1 in [0.014, 0.05, 0.14, 0.3, 0.6, 0.8, 1.0, 2.0] {
        let mut c = CascadeLoop::with_gains(k1, 0.2);
        c.period = 0.0;
        let a = analyse_model(&spec, &c, &Grid::default()).unwrap();
        let eig = eigenvalues(&closed_loop_matrix(&spec, &c.params)).unwrap();
        let rhp = eig.iter().filter(|l| l.re > 0.0).count();
        // No eigenvalue near the axis, where the two counts could disagree by rounding.
        assert!(eig.iter().all(|l| l.re.abs() > 1e-6), "{k1}: {eig:?}");
        assert_eq!(a.unstable_poles, Some(rhp), "K1 = {k1}: {eig:?}");
        seen[usize::from(rhp > 0)] = true;
    }
    assert_eq!(
        seen,
        [true, true],
        "both stable and unstable loops were checked"
    );
}

/// The seed's controller and one with other gains, as run at `period` s, the trunk-angle
/// limits opened so that a linear loop's growth is not capped by the anti-windup.
fn cascade(k1: f64, period: f64) -> CascadeLoop {
    let mut c = CascadeLoop::with_gains(k1, 0.2);
    c.period = period;
    c.params.theta_min = -1e6;
    c.params.theta_max = 1e6;
    c
}

const T_END: f64 = 1500.0;

/// A 1 mm step of the sagittal ZMP reference on the paper model with `p` on its channel, in
/// closed loop with `c`: the error's growth rate (1/s) and the error.
fn run(spec: &ModelSpec, p: &Perturbation, c: &CascadeLoop) -> (f64, Vec<f64>) {
    let mut plant = PerturbedPlant::new(spec, p, 0.001).unwrap();
    let e = step_error(&mut plant, c.params, c.period, 1, 0.001, T_END);
    // After the step's transient (300 s), 50 s windows, above the rounding of a 1 mm signal.
    (growth_rate(&e, c.period, 300.0, 50.0, 1e-13), e)
}

/// Oscillation frequency of the last 400 s from the zero crossings, rad/s.
fn oscillation(err: &[f64], dt: f64) -> f64 {
    let tail = &err[err.len() - (400.0 / dt) as usize..];
    let crossings: Vec<usize> = (1..tail.len())
        .filter(|&k| (tail[k - 1] < 0.0) != (tail[k] < 0.0))
        .collect();
    let span = (crossings[crossings.len() - 1] - crossings[0]) as f64 * dt;
    std::f64::consts::PI * (crossings.len() - 1) as f64 / span
}

/// The check predicts what a perturbation inside the weights does. A controller tuned past the
/// weights (the seed's K2 with 3.6 times its K1: it reaches the set point about three times
/// sooner) fails on G22 (`||W22 T22|| = 1.55`); the check names the perturbation that places a
/// closed-loop pole on the imaginary axis at the tightest frequency (`|Delta| = 1 / 1.55`,
/// inside the weight). Stepped in time on the paper model (the project's plant stepper with the
/// perturbation's path, the project's digital controller): 10 % more than it (`|Delta| = 0.71`,
/// still inside) makes the loop grow, oscillating at that frequency; 10 % less lets it settle.
/// The seed's controller passes (`||W T|| = 0.63`): the same perturbation, and its own worst one
/// at the weight's full size (`|Delta| = 1`), leave it stable, as the small-gain theorem says.
///
/// At the controller's 1 ms the continuous analysis is the loop; at the project's 10 ms the
/// staircase output's steps reach the ZMP through the pendulum's `-b s^2` (the plant has direct
/// feedthrough), an aliasing the hold factor does not describe: the prediction still holds to
/// 10 % there (the docs page gives the measured critical size at both rates).
#[test]
fn a_perturbation_inside_the_weight_destabilises_the_loop_that_fails_the_check() {
    let spec = paper();
    let grid = Grid::default();
    for period in [0.001, 0.01] {
        let fast = cascade(0.05, period);
        let seed = cascade(0.014, period);
        let fa = analyse_model(&spec, &fast, &grid).unwrap();
        let sa = analyse_model(&spec, &seed, &grid).unwrap();
        assert!(fa.nominally_stable() && sa.nominally_stable());
        assert!(!fa.robustly_stable() && sa.robustly_stable());
        let tight = *fa.tightest_channel().unwrap();
        assert_eq!(tight.channel, G22);
        assert!(tight.peak > 1.4, "{tight:?}");
        let crit = fa.critical_perturbation(G22).unwrap();
        assert!((crit.delta.abs() - 1.0 / tight.peak).abs() < 1e-9);
        // Without perturbation both loops settle (to rounding within the run).
        for c in [&fast, &seed] {
            let (r, _) = run(&spec, &crit.scaled(0.0), c);
            assert!(r < -0.02, "{}: {r}", c.describe());
        }
        // 10 % past the critical perturbation, inside the weight: grows, at the frequency.
        let over = crit.scaled(1.1);
        assert!(over.delta.abs() <= 1.0, "inside the weight: {over:?}");
        let (r, e) = run(&spec, &over, &fast);
        assert!(
            r > 1e-3,
            "{period}: the fast loop with {over:?} grows at {r}/s"
        );
        let w = oscillation(&e, period);
        assert!(
            (w / tight.omega - 1.0).abs() < 0.02,
            "{w} vs {}",
            tight.omega
        );
        // 10 % short of it: settles.
        let (r, _) = run(&spec, &crit.scaled(0.9), &fast);
        assert!(r < -1e-3, "{period}: {r}");
        // The seed's controller: the same perturbation, and its own worst one at |Delta| = 1.
        let (r, _) = run(&spec, &over, &seed);
        assert!(r < -0.01, "{period}: {r}");
        let own = sa.critical_perturbation(G22).unwrap();
        let (r, _) = run(&spec, &own.scaled(1.0 / own.delta.abs()), &seed);
        assert!(r < -0.01, "{period}: {r}");
    }
}
