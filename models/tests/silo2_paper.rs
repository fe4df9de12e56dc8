//! The SILO2 model file `params/silo2-paper.toml` is the first seed's section 6, number for
//! number: the nominal `G_ZMP` of section 6.5 and the uncertainty weights of section 6.4.

// Index loops read as the matrix algebra they check.
#![allow(clippy::needless_range_loop)]

use num_complex::Complex64;
use zmp_models::EffectKind;
use zmp_models::{Binding, Channel, ModelSpec, Plant};

const FILE: &str = include_str!("../params/silo2-paper.toml");

/// Section 6.2, written out here rather than read from the file: `A[i][j] = a_ij`.
const A: [[f64; 2]; 2] = [[0.8293, 0.07455], [0.1895, 1.245]];
const B: [[f64; 2]; 2] = [[0.2767, 0.005428], [0.09979, 0.1012]];
/// Section 6.4: `G_iju = k (s + z)/(s + p)`, as `(k, z, p)` per channel `[i][j]`.
const W: [[(f64, f64, f64); 2]; 2] = [
    [(4.0, 1.0, 10.0), (4.0, 5.0, 20.0)],
    [(7.0, 1.0, 10.0), (1.0, 0.1, 0.3)],
];

fn paper_spec() -> ModelSpec {
    ModelSpec::parse(FILE, "silo2-paper.toml").expect("the paper's model parses")
}

/// The seed's nominal formula, section 6.5: `900 (a_ij - b_ij s^2) / (s^2 + 60 s + 900)`.
fn seed_nominal(i: usize, j: usize, omega: f64) -> Complex64 {
    let s = Complex64::new(0.0, omega);
    900.0 * (A[i][j] - B[i][j] * s * s) / (s * s + 60.0 * s + 900.0)
}

fn seed_weight(i: usize, j: usize, omega: f64) -> Complex64 {
    let s = Complex64::new(0.0, omega);
    let (k, z, p) = W[i][j];
    k * (s + z) / (s + p)
}

/// 200 log-spaced frequencies from 0.01 to 100 rad/s.
fn grid() -> impl Iterator<Item = f64> {
    (0..200).map(|k| 10f64.powf(-2.0 + 4.0 * k as f64 / 199.0))
}

fn assert_rel(got: Complex64, want: Complex64, tol: f64, what: &str) {
    let rel = (got - want).norm() / want.norm();
    assert!(
        rel <= tol,
        "{what}: got {got}, want {want}, relative error {rel:e} > {tol:e}"
    );
}

#[test]
fn nominal_frequency_response_is_the_seeds_formula() {
    let plant = Plant::new(&paper_spec(), 1e-3).unwrap();
    for omega in grid() {
        let g = plant.frequency_response(omega);
        for i in 0..2 {
            for j in 0..2 {
                assert_rel(
                    g[i][j],
                    seed_nominal(i, j, omega),
                    1e-12,
                    &format!("G{}{} at {omega} rad/s", i + 1, j + 1),
                );
            }
        }
    }
}

#[test]
fn file_holds_the_seeds_numbers() {
    let spec = paper_spec();
    let pend = |name: &str| {
        spec.value(EffectKind::Pendulum, Binding::Global, name)
            .unwrap()
    };
    for ch in Channel::ALL {
        let (i, j) = (ch.output.index(), ch.input.index());
        assert_eq!(
            pend(&format!("a{}", ch.suffix())),
            A[i][j],
            "a{}",
            ch.suffix()
        );
        assert_eq!(
            pend(&format!("b{}", ch.suffix())),
            B[i][j],
            "b{}",
            ch.suffix()
        );
        let b = Binding::Channel(ch);
        let (k, z, p) = W[i][j];
        assert_eq!(
            spec.value(EffectKind::Uncertainty, b, "k"),
            Some(k),
            "{ch} k"
        );
        assert_eq!(
            spec.value(EffectKind::Uncertainty, b, "z"),
            Some(z),
            "{ch} z"
        );
        assert_eq!(
            spec.value(EffectKind::Uncertainty, b, "p"),
            Some(p),
            "{ch} p"
        );
        // The file is the nominal model.
        assert_eq!(
            spec.value(EffectKind::Uncertainty, b, "delta"),
            Some(0.0),
            "{ch} delta"
        );
    }
    // 900/(s^2 + 60 s + 900): omega_n = 30 rad/s, 2 zeta omega_n = 60.
    for axis in zmp_models::Axis::BOTH {
        let b = Binding::Axis(axis);
        assert_eq!(
            spec.value(EffectKind::TrackingLowpass, b, "omega_n"),
            Some(30.0)
        );
        assert_eq!(
            spec.value(EffectKind::TrackingLowpass, b, "zeta"),
            Some(1.0)
        );
    }
}

/// With the constant `Delta_ij = 1` every channel is `G_ij,nominal (1 + W_ij)`, `W_ij` the
/// seed's weights; with `Delta = -1` it is `G_ij,nominal (1 - W_ij)`.
#[test]
fn constant_delta_applies_the_seeds_weights() {
    for delta in [1.0, -1.0, 0.5] {
        let mut spec = paper_spec();
        for ch in Channel::ALL {
            assert!(spec.set_value(
                EffectKind::Uncertainty,
                Binding::Channel(ch),
                "delta",
                delta
            ));
        }
        let plant = Plant::new(&spec, 1e-3).unwrap();
        for omega in grid() {
            let g = plant.frequency_response(omega);
            for i in 0..2 {
                for j in 0..2 {
                    let want = seed_nominal(i, j, omega) * (1.0 + seed_weight(i, j, omega) * delta);
                    assert_rel(
                        g[i][j],
                        want,
                        1e-12,
                        &format!("G{}{} at {omega} rad/s, delta {delta}", i + 1, j + 1),
                    );
                }
            }
        }
    }
}

/// The brief's explicit case: G11 with Delta = 1 is G11_nominal (1 + 4 (s + 1)/(s + 10)).
#[test]
fn g11_with_unit_delta() {
    let mut spec = paper_spec();
    assert!(spec.set_value(
        EffectKind::Uncertainty,
        Binding::Channel(Channel::ALL[0]),
        "delta",
        1.0
    ));
    let plant = Plant::new(&spec, 1e-3).unwrap();
    for omega in grid() {
        let s = Complex64::new(0.0, omega);
        let want = seed_nominal(0, 0, omega) * (1.0 + 4.0 * (s + 1.0) / (s + 10.0));
        let g = plant.frequency_response(omega);
        assert_rel(g[0][0], want, 1e-12, &format!("G11 at {omega} rad/s"));
        // The other channels stay nominal.
        assert_rel(g[1][1], seed_nominal(1, 1, omega), 1e-12, "G22 nominal");
    }
}
