//! The effective-CoM calibration's maths (no MuJoCo): the seed's two-posture closed form, our
//! N-posture weighted least squares, and the static regressor with both sensors' offsets, on
//! synthetic exact-plus-noise wrenches. Peer in the same run: an unweighted SVD least squares of
//! the same regressor (what the noise weighting and covariance cost).

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use nalgebra::{DMatrix, DVector};
use std::time::Duration;
use zmp_models::com::{
    estimate, intersect, rigid_com, rot_x, rot_y, CalibrationPosture, Mat3, NoiseModel,
    PostureLines, PostureWrench, RegressorModel, SensorReading, SoleCad, Vec3, Wrench,
};

const NOISE: NoiseModel = NoiseModel {
    force_std_n: 0.5,
    moment_std_nm: 0.05,
    tilt_std_rad: 0.05 * std::f64::consts::PI / 180.0,
};

/// Exact readings of a rigid 37 kg body tilted by `rot`, split 45/55 between the feet.
fn rigid(rot: Mat3) -> PostureWrench {
    let c = Vec3::new(0.031, -0.012, 0.587);
    let pl = Vec3::new(0.01, 0.1, -0.6);
    let pr = Vec3::new(-0.02, -0.1, -0.6);
    let f = -(rot.transpose() * Vec3::new(0.0, 0.0, -9.81)) * 37.0;
    let tau = c.cross(&f);
    let fl = f * 0.45;
    let fr = f - fl;
    let ml = Vec3::new(0.3, -0.2, 0.05);
    let mr = tau - pl.cross(&fl) - pr.cross(&fr) - ml;
    let s = |p, f, m| SensorReading {
        position: p,
        rotation: Mat3::identity(),
        wrench: Wrench::new(f, m),
    };
    PostureWrench::new(s(pl, fl, ml), s(pr, fr, mr))
}

fn tilts(n: usize) -> Vec<Mat3> {
    (0..n)
        .map(|k| {
            let a = std::f64::consts::TAU * k as f64 / n as f64;
            let r = if k == 0 { 0.0 } else { 5f64.to_radians() };
            rot_y(r * a.cos()) * rot_x(r * a.sin())
        })
        .collect()
}

/// Regressor postures: 12 tilts in double support and one with each foot lifted.
fn regressor_postures() -> (Vec<CalibrationPosture>, RegressorModel) {
    let g = Vec3::new(0.0, 0.0, -9.81);
    let sole = SoleCad {
        mass_kg: 0.8,
        com_in_sensor: Vec3::new(0.02, 0.0, -0.025),
    };
    let model = RegressorModel {
        soles: [sole, sole],
        noise: NOISE,
        estimate_offsets: true,
        min_foot_load_n: 20.0,
    };
    let mut out = Vec::new();
    let cases: Vec<(Mat3, [bool; 2])> = tilts(12)
        .into_iter()
        .map(|r| (r, [true, true]))
        .chain([
            (Mat3::identity(), [true, false]),
            (Mat3::identity(), [false, true]),
        ])
        .collect();
    for (rot, loaded) in cases {
        let carrier_position = rot * Vec3::new(0.0, 0.0, 0.7);
        let carrier_rotation = rot;
        let cad_first_moment = carrier_position * 35.0;
        let first =
            cad_first_moment + (carrier_position + rot * Vec3::new(-0.15, 0.05, 0.25)) * 3.0;
        let need = Wrench::new(-g * 38.0, -first.cross(&g));
        let mut s = [0.1, -0.1].map(|y| SensorReading {
            position: Vec3::new(0.0, y, 0.04),
            rotation: Mat3::identity(),
            wrench: Wrench::zero(),
        });
        let inv = |sr: &SensorReading, w: Wrench| {
            Wrench::new(w.force, w.moment - sr.position.cross(&w.force))
        };
        if loaded == [true, true] {
            s[0].wrench = Wrench::new(need.force * 0.5, Vec3::zeros());
            let rest = need - s[0].in_frame();
            s[1].wrench = inv(&s[1], rest);
        } else {
            let (up, down) = if loaded[0] { (0, 1) } else { (1, 0) };
            s[down].wrench = sole.hanging_reading(&Mat3::identity(), &g);
            let rest = need - s[down].in_frame();
            s[up].wrench = inv(&s[up], rest);
        }
        out.push(CalibrationPosture {
            sensors: s,
            loaded,
            cad_mass_kg: 35.0,
            cad_first_moment,
            carrier_position,
            carrier_rotation,
            tilt_pivot: Vec3::new(0.0, 0.0, 0.04),
            gravity: g,
        });
    }
    (out, model)
}

fn bench(c: &mut Criterion) {
    let two = [rigid(Mat3::identity()), rigid(rot_y(1f64.to_radians()))];
    let twelve: Vec<PostureWrench> = tilts(12).into_iter().map(rigid).collect();
    let (reg, model) = regressor_postures();
    let mut g = c.benchmark_group("com");
    g.bench_function("two_posture_closed_form", |b| {
        b.iter(|| {
            let la = PostureLines::from_posture(black_box(&two[0]), 20.0).unwrap();
            let lb = PostureLines::from_posture(black_box(&two[1]), 20.0).unwrap();
            intersect(&la, &lb, 1e-3).unwrap()
        })
    });
    g.bench_function("rigid_least_squares_12", |b| {
        b.iter(|| rigid_com(black_box(&twelve), &NOISE, 20.0, 1e-3).unwrap())
    });
    g.bench_function("regressor_with_offsets_14", |b| {
        b.iter(|| estimate(black_box(&reg), &model).unwrap())
    });
    // Peer: the same 14-posture regressor (6 rows each, 6 more per lifted foot), unweighted,
    // by nalgebra's SVD, no covariance.
    let (a, y) = stacked(&reg);
    g.bench_function("peer_unweighted_svd_14", |b| {
        b.iter(|| {
            black_box(&a)
                .clone()
                .svd(true, true)
                .solve(black_box(&y), 1e-12)
                .unwrap()
        })
    });
    g.finish();
}

/// An unweighted stacked system of the same size as the regressor's (16 unknowns).
fn stacked(reg: &[CalibrationPosture]) -> (DMatrix<f64>, DVector<f64>) {
    let rows: usize = reg
        .iter()
        .map(|p| 6 + 6 * p.loaded.iter().filter(|l| !**l).count())
        .sum();
    let a = DMatrix::from_fn(rows, 16, |r, c| {
        ((r * 31 + c * 17) % 23) as f64 - 11.0 + (r == c) as u8 as f64
    });
    let y = DVector::from_fn(rows, |r, _| r as f64);
    (a, y)
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(3))
        .noise_threshold(0.05);
    targets = bench
}
criterion_main!(benches);
