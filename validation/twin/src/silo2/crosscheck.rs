//! Is the corner-sensor ZMP right, and what does the contact softness cost?
//!
//! - [`static_check`]: at rest at an operating point, the ZMP of the 8 load cells against
//!   MuJoCo's centre of pressure (the normal forces of its contacts, `mj_contactForce`) and the
//!   whole robot's CoM projection (seed eq. 10: statically the ZMP is the CoM).
//! - [`dynamic_check`]: during a trunk sine, the same ZMP against the centre of pressure, the
//!   momentum ZMP (Newton-Euler on the whole robot from MuJoCo's subtree CoM, velocity and
//!   angular momentum) and the seed's cart-table ZMP `x - z/g x''`, which leaves out the trunk's
//!   rotation.
//! - [`budget`]: the contact softness (`solref` time constant) against the static errors and the
//!   penetration, and the ZMP's frequency response against the rigid-robot prediction of
//!   [`props`](super::props) from the measured trunk motion (what the soft contacts and the leg
//!   servos add to the ZMP).
//!
//! All without sensor noise: these are checks of the measurement principle.

use super::props::{predict, MassProperties};
use super::{Silo2, STEP};
use crate::mj::TwinError;
use crate::zmp::{cart_table_zmp, contact_cop, derivative3, momentum, momentum_zmp};
use num_complex::Complex64;
use serde::Serialize;
use zmp_models::harmonic::first_harmonic;
use zmp_models::Axis;

/// The static comparison at one operating point.
#[derive(Debug, Clone, Serialize)]
pub struct StaticCheck {
    /// CoM reference (eq. 26), m.
    pub com_ref: [f64; 2],
    /// Trunk angles reached, rad.
    pub theta: [f64; 2],
    /// Whole-robot CoM, m (mean over the window).
    pub com: [f64; 3],
    /// ZMP of the load cells and MuJoCo's centre of pressure, m (means).
    pub zmp_cells: [f64; 2],
    pub cop: [f64; 2],
    /// Largest `|zmp_cells - cop|` and `|zmp_cells - com|` over the window (both axes), m.
    pub max_cells_minus_cop: f64,
    pub max_cells_minus_com: f64,
    /// Deepest contact penetration, m.
    pub penetration: f64,
}

fn norm2(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).abs().max((a[1] - b[1]).abs())
}

/// Brings the trunk to the operating point `com_ref`, waits `settle_s`, then compares over
/// `window_s` (every physics step).
pub fn static_check(
    twin: &Silo2,
    props: &MassProperties,
    com_ref: [f64; 2],
    settle_s: f64,
    window_s: f64,
) -> Result<StaticCheck, TwinError> {
    let kr = props.reference_gain();
    let c0 = props.com_upright;
    let theta_ref = [(com_ref[0] - c0[0]) / kr, (com_ref[1] - c0[1]) / kr];
    let mut d = twin.stand()?;
    twin.settle(&mut d, theta_ref, 0.5, (settle_s - 0.5).max(0.0));
    let n = (window_s / STEP).round().max(1.0) as usize;
    let mut sum_com = [0.0; 3];
    let mut sum_cells = [0.0; 2];
    let mut sum_cop = [0.0; 2];
    let (mut max_cop, mut max_com, mut pen) = (0.0f64, 0.0f64, 0.0f64);
    for _ in 0..n {
        d.step();
        let z = twin.cells(&d).zmp().ok_or_else(|| no_load(twin))?;
        let cop = contact_cop(&d, twin.floor_geom).ok_or_else(|| no_load(twin))?;
        let com = twin.com(&d);
        max_cop = max_cop.max(norm2(z, cop));
        max_com = max_com.max(norm2(z, [com[0], com[1]]));
        pen = pen.max(twin.penetration(&d));
        for i in 0..3 {
            sum_com[i] += com[i] / n as f64;
        }
        for i in 0..2 {
            sum_cells[i] += z[i] / n as f64;
            sum_cop[i] += cop[i] / n as f64;
        }
    }
    Ok(StaticCheck {
        com_ref,
        theta: twin.trunk_angles(&d),
        com: sum_com,
        zmp_cells: sum_cells,
        cop: sum_cop,
        max_cells_minus_cop: max_cop,
        max_cells_minus_com: max_com,
        penetration: pen,
    })
}

fn no_load(twin: &Silo2) -> TwinError {
    TwinError::Model {
        path: twin.path.clone(),
        message: "no load on the feet (the robot left the floor)".into(),
    }
}

/// The dynamic comparison during one trunk sine.
#[derive(Debug, Clone, Serialize)]
pub struct DynamicCheck {
    pub axis: Axis,
    /// rad/s, and the CoM reference amplitude, m.
    pub omega: f64,
    pub amplitude: f64,
    /// RMS of the load-cell ZMP about its mean on the excited axis, m.
    pub rms_zmp: f64,
    /// RMS differences of the load-cell ZMP on the excited axis from MuJoCo's centre of
    /// pressure, the momentum ZMP and the cart-table ZMP, m.
    pub rms_cells_minus_cop: f64,
    pub rms_cells_minus_momentum: f64,
    pub rms_cells_minus_cart_table: f64,
    /// First-harmonic amplitude of the cart-table ZMP over that of the load cells.
    pub cart_table_amplitude_ratio: f64,
}

/// A sine of `amplitude` (CoM reference, m) at `omega` on `axis` around the upright posture;
/// compares over `periods` whole periods after 2 s.
pub fn dynamic_check(
    twin: &Silo2,
    props: &MassProperties,
    axis: Axis,
    omega: f64,
    amplitude: f64,
    periods: usize,
) -> Result<DynamicCheck, TwinError> {
    let kr = props.reference_gain();
    let ax = axis.index();
    let mut d = twin.stand()?;
    twin.settle(&mut d, [0.0; 2], 0.5, 1.0);
    let n_skip = (2.0 / STEP).round() as usize;
    let per = 2.0 * std::f64::consts::PI / omega;
    let n = (periods as f64 * per / STEP).round() as usize;
    let mass = props.total_mass;
    let (mut cells, mut cop, mut com, mut vel, mut ang) = (
        Vec::with_capacity(n + 2),
        Vec::with_capacity(n + 2),
        Vec::with_capacity(n + 2),
        Vec::with_capacity(n + 2),
        Vec::with_capacity(n + 2),
    );
    // One sample either side of the window for the central differences.
    for k in 0..n_skip + n + 1 {
        let t = k as f64 * STEP;
        let mut th = [0.0; 2];
        th[ax] = amplitude / kr * (omega * t).sin();
        twin.set_trunk(&mut d, th);
        d.step();
        if k + 1 >= n_skip {
            let z = twin.cells(&d).zmp().ok_or_else(|| no_load(twin))?;
            let c = contact_cop(&d, twin.floor_geom).ok_or_else(|| no_load(twin))?;
            let m = momentum(&mut d, twin.root_body);
            cells.push(z[ax]);
            cop.push(c[ax]);
            com.push(m.com);
            vel.push(m.com_vel);
            ang.push(m.angmom);
        }
    }
    let acc = derivative3(&vel, STEP);
    let ldot = derivative3(&ang, STEP);
    let window = 1..cells.len() - 1;
    let mean = cells[window.clone()].iter().sum::<f64>() / window.len() as f64;
    let rms = |f: &dyn Fn(usize) -> f64| -> f64 {
        (window.clone().map(|k| f(k).powi(2)).sum::<f64>() / window.len() as f64).sqrt()
    };
    let mom: Vec<f64> = (0..cells.len())
        .map(|k| momentum_zmp(mass, com[k], acc[k], ldot[k])[ax])
        .collect();
    let cart: Vec<f64> = (0..cells.len())
        .map(|k| cart_table_zmp(com[k], acc[k])[ax])
        .collect();
    let t0 = n_skip as f64 * STEP;
    let h_cells = first_harmonic(&cells[window.clone()], omega, STEP, t0);
    let h_cart = first_harmonic(&cart[window.clone()], omega, STEP, t0);
    Ok(DynamicCheck {
        axis,
        omega,
        amplitude,
        rms_zmp: rms(&|k| cells[k] - mean),
        rms_cells_minus_cop: rms(&|k| cells[k] - cop[k]),
        rms_cells_minus_momentum: rms(&|k| cells[k] - mom[k]),
        rms_cells_minus_cart_table: rms(&|k| cells[k] - cart[k]),
        cart_table_amplitude_ratio: h_cart.norm() / h_cells.norm(),
    })
}

/// The ZMP's response at one frequency against the rigid-robot prediction.
#[derive(Debug, Clone, Serialize)]
pub struct ResponseError {
    pub axis: Axis,
    pub omega: f64,
    /// `|Z / Z_rigid| - 1` and `arg(Z / Z_rigid)` (degrees), `Z_rigid` from the measured trunk
    /// motion through the rigid-robot ZMP of `props`.
    pub magnitude_error: f64,
    pub phase_error_deg: f64,
}

/// One row of the contact-softness budget.
#[derive(Debug, Clone, Serialize)]
pub struct BudgetRow {
    /// `solref` time constant, s (damping ratio 1).
    pub timeconst: f64,
    pub penetration: f64,
    pub max_cells_minus_cop: f64,
    pub max_cells_minus_com: f64,
    pub response: Vec<ResponseError>,
}

/// The budget: for each time constant, the static check at `com_ref` and the response error at
/// each `(axis, omega)` (CoM amplitude `amplitude`, around the upright posture).
pub fn budget(
    twin: &Silo2,
    props: &MassProperties,
    timeconsts: &[f64],
    com_ref: [f64; 2],
    probes: &[(Axis, f64)],
    amplitude: f64,
    threads: usize,
) -> Result<Vec<BudgetRow>, TwinError> {
    let upright = predict(twin, props, [props.com_upright[0], props.com_upright[1]])?;
    zmp_campaign::par::try_parallel_map(timeconsts.len(), threads, |i| {
        let tc = timeconsts[i];
        let soft = twin.with_solref(tc, 1.0)?;
        let st = static_check(&soft, props, com_ref, 2.0, 0.5)?;
        let mut response = Vec::new();
        for &(axis, omega) in probes {
            let r = stance_factor_at(&soft, props, &upright, axis, omega, amplitude)?;
            response.push(ResponseError {
                axis,
                omega,
                magnitude_error: r.norm() - 1.0,
                phase_error_deg: r.arg().to_degrees(),
            });
        }
        Ok(BudgetRow {
            timeconst: tc,
            penetration: st.penetration,
            max_cells_minus_cop: st.max_cells_minus_cop,
            max_cells_minus_com: st.max_cells_minus_com,
            response,
        })
    })
}

/// What the stance adds to the ZMP: the load-cell ZMP's first harmonic over the rigid-robot
/// prediction from the measured trunk motion, `Z / ((J_static - w^2 J_acc) Theta)`, during a
/// trunk sine of CoM amplitude `amplitude` (m) on `axis` at `omega` around the upright posture,
/// without sensor noise. 1 on a rigid stance; the leg servos and the soft contacts let the
/// whole robot sway, a resonance of the stance that this isolates from the trunk's servo.
pub fn stance_factor(
    twin: &Silo2,
    props: &MassProperties,
    axis: Axis,
    omega: f64,
    amplitude: f64,
) -> Result<Complex64, TwinError> {
    let upright = predict(twin, props, [props.com_upright[0], props.com_upright[1]])?;
    stance_factor_at(twin, props, &upright, axis, omega, amplitude)
}

fn stance_factor_at(
    twin: &Silo2,
    props: &MassProperties,
    upright: &super::props::OperatingPoint,
    axis: Axis,
    omega: f64,
    amplitude: f64,
) -> Result<Complex64, TwinError> {
    let (z, theta) = response_phasors(twin, props, axis, omega, amplitude)?;
    let ax = axis.index();
    // Rigid robot: Z = (J_static - w^2 J_acc) Theta.
    let mut zr = Complex64::new(0.0, 0.0);
    for j in 0..2 {
        zr += (upright.zmp_per_angle[ax][j]
            - omega * omega * upright.zmp_per_angular_acceleration[ax][j])
            * theta[j];
    }
    Ok(z / zr)
}

/// Noise-free first harmonics of the load-cell ZMP (excited axis) and of both trunk angles
/// during a sine on `axis` around the upright posture.
fn response_phasors(
    twin: &Silo2,
    props: &MassProperties,
    axis: Axis,
    omega: f64,
    amplitude: f64,
) -> Result<(Complex64, [Complex64; 2]), TwinError> {
    let kr = props.reference_gain();
    let ax = axis.index();
    let mut d = twin.stand()?;
    twin.settle(&mut d, [0.0; 2], 0.5, 1.0);
    let per = 2.0 * std::f64::consts::PI / omega;
    let n_skip = (3.0 / STEP).round() as usize;
    let n = ((4.0 * per).max(3.0) / per).ceil() as usize * (per / STEP).round() as usize;
    let mut z = Vec::with_capacity(n);
    let mut th = [Vec::with_capacity(n), Vec::with_capacity(n)];
    for k in 0..n_skip + n {
        let t = k as f64 * STEP;
        let mut r = [0.0; 2];
        r[ax] = amplitude / kr * (omega * t).sin();
        twin.set_trunk(&mut d, r);
        // The state the step evaluates (sensors at t) is the one before integration.
        let before = twin.trunk_angles(&d);
        d.step();
        if k >= n_skip {
            z.push(twin.cells(&d).zmp().ok_or_else(|| no_load(twin))?[ax]);
            th[0].push(before[0]);
            th[1].push(before[1]);
        }
    }
    let t0 = n_skip as f64 * STEP;
    Ok((
        first_harmonic(&z, omega, STEP, t0),
        [
            first_harmonic(&th[0], omega, STEP, t0),
            first_harmonic(&th[1], omega, STEP, t0),
        ],
    ))
}
