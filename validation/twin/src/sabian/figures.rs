//! The calibration and walking report's SVG figures: the error ellipses of each calibration
//! design, the seed's figures 5-8 (planned and measured ZMP of each virtual model, walking with
//! Torso Position Control as the seed did) and the control's torso shift per model.

use super::experiment::{DesignOutcome, ModelOutcome};
use super::report::Outcome;
use anyhow::Result;
use std::path::{Path, PathBuf};
use zmp_report::plot::{time_svg, Style, TimePanel, TimeSeries, PALETTE};

/// The SVG figures (written into `dir`).
pub fn figures(o: &Outcome, dir: &Path, force: bool) -> Result<Vec<PathBuf>> {
    let mut files = vec![error_ellipses(o, dir, force)?, walk_zmp_y(o, dir, force)?];
    files.extend(walk_zmp_xy(o, dir, force)?);
    files.push(walk_zmp_contact(o, dir, force)?);
    files.push(torso_shift(o, dir, force)?);
    Ok(files)
}

/// The walking traces' sample times, s (the controller's 30 ms period).
fn sample_times(n: usize) -> Vec<f64> {
    (0..n).map(|k| k as f64 * 0.03).collect()
}

/// Error ellipses (2 sigma, from the reported covariance averaged over the draws) and the
/// draws, relative to the true CoM, in mm; each design on its own scale.
fn error_ellipses(o: &Outcome, dir: &Path, force: bool) -> Result<PathBuf> {
    let c = &o.calibration;
    let mut panels = Vec::new();
    let names = ["x", "y", "z"];
    for (k, d) in [&c.designed, &c.seed_zeroed].iter().enumerate() {
        let color = PALETTE[2 - k];
        for (a, b) in [(0, 2), (1, 2), (0, 1)] {
            let cov = mean_covariance(d);
            panels.push(TimePanel {
                title: format!("{}: CoM error {}-{} (mm)", d.name, names[a], names[b]),
                y_label: format!("{} error (mm)", names[b]),
                x_label: Some(format!("{} error (mm)", names[a])),
                series: vec![
                    TimeSeries {
                        label: "draws".into(),
                        t: d.draws.iter().map(|r| r.error[a] * 1e3).collect(),
                        y: d.draws.iter().map(|r| r.error[b] * 1e3).collect(),
                        color,
                        style: Style::Points,
                    },
                    ellipse(&cov, a, b, color),
                ],
                markers: vec![],
            });
        }
    }
    let p = dir.join("com-error-ellipses.svg");
    time_svg(&p, &panels, force)?;
    Ok(p)
}

/// Figure 5: ZMP y, ideal and real (mean of the runs), per model.
fn walk_zmp_y(o: &Outcome, dir: &Path, force: bool) -> Result<PathBuf> {
    let mut panels = Vec::new();
    for (k, m) in o.walking.iter().enumerate() {
        let (ideal, real) = mean_traces(m);
        let n = ideal.len();
        panels.push(TimePanel {
            title: format!("model {}: ZMP y (with TPC)", m.name),
            y_label: "ZMP y (m)".into(),
            series: vec![
                TimeSeries {
                    label: "ideal".into(),
                    t: sample_times(n),
                    y: ideal.iter().map(|p| p[1]).collect(),
                    color: PALETTE[5],
                    style: Style::Dashed,
                },
                TimeSeries {
                    label: "real (sensors)".into(),
                    t: sample_times(n),
                    y: real.iter().map(|p| p[1]).collect(),
                    color: PALETTE[k % 5],
                    style: Style::Line,
                },
            ],
            ..Default::default()
        });
    }
    let p = dir.join("walk-zmp-y.svg");
    time_svg(&p, &panels, force)?;
    Ok(p)
}

/// Figures 6-7: the XY path and its error for models r and s.
fn walk_zmp_xy(o: &Outcome, dir: &Path, force: bool) -> Result<[PathBuf; 2]> {
    let pick: Vec<&ModelOutcome> = o
        .walking
        .iter()
        .filter(|m| m.name == "r" || m.name == "s")
        .collect();
    let mut xy = Vec::new();
    let mut err = Vec::new();
    for (k, m) in pick.iter().enumerate() {
        let (ideal, real) = mean_traces(m);
        xy.push(TimePanel {
            title: format!("model {}: ZMP in the XY plane (with TPC)", m.name),
            y_label: "y (m)".into(),
            x_label: Some("x (m)".into()),
            series: vec![
                TimeSeries {
                    label: "ideal".into(),
                    t: ideal.iter().map(|p| p[0]).collect(),
                    y: ideal.iter().map(|p| p[1]).collect(),
                    color: PALETTE[5],
                    style: Style::Dashed,
                },
                TimeSeries {
                    label: "real".into(),
                    t: real.iter().map(|p| p[0]).collect(),
                    y: real.iter().map(|p| p[1]).collect(),
                    color: PALETTE[k],
                    style: Style::Line,
                },
            ],
            markers: vec![],
        });
        err.push(TimeSeries {
            label: format!("model {}", m.name),
            t: sample_times(ideal.len()),
            y: ideal
                .iter()
                .zip(&real)
                .map(|(a, b)| (b[0] - a[0]).hypot(b[1] - a[1]))
                .collect(),
            color: PALETTE[k],
            style: Style::Line,
        });
    }
    let p = dir.join("walk-zmp-xy.svg");
    time_svg(&p, &xy, force)?;
    let e = dir.join("walk-zmp-xy-error.svg");
    time_svg(
        &e,
        &[TimePanel {
            title: "distance between ideal and real ZMP (with TPC)".into(),
            y_label: "|error| (m)".into(),
            series: err,
            ..Default::default()
        }],
        force,
    )?;
    Ok([p, e])
}

/// Figure 8: all models around a foot-ground contact (the third step's landing).
fn walk_zmp_contact(o: &Outcome, dir: &Path, force: bool) -> Result<PathBuf> {
    let mut series = Vec::new();
    let mut ideal_done = false;
    for (k, m) in o.walking.iter().enumerate() {
        let (ideal, real) = mean_traces(m);
        let range = 128 + 2 * 32 + 20..(128 + 3 * 32 + 10).min(real.len());
        if !ideal_done {
            series.push(TimeSeries {
                label: "ideal".into(),
                t: ideal[range.clone()].iter().map(|p| p[0]).collect(),
                y: ideal[range.clone()].iter().map(|p| p[1]).collect(),
                color: PALETTE[5],
                style: Style::Dashed,
            });
            ideal_done = true;
        }
        series.push(TimeSeries {
            label: format!("real, model {}", m.name),
            t: real[range.clone()].iter().map(|p| p[0]).collect(),
            y: real[range].iter().map(|p| p[1]).collect(),
            color: PALETTE[k % 5],
            style: Style::Line,
        });
    }
    let p = dir.join("walk-zmp-contact.svg");
    time_svg(
        &p,
        &[TimePanel {
            title: "ZMP around a foot-ground contact (third step, with TPC)".into(),
            y_label: "y (m)".into(),
            x_label: Some("x (m)".into()),
            series,
            markers: vec![],
        }],
        force,
    )?;
    Ok(p)
}

/// The Torso Position Control's shift per model (mean of the runs), x and y.
fn torso_shift(o: &Outcome, dir: &Path, force: bool) -> Result<PathBuf> {
    let mut panels = Vec::new();
    for m in &o.walking {
        let runs: Vec<_> = m.with_tpc.traces.iter().filter(|r| !r.fell).collect();
        let n = runs.iter().map(|r| r.torso_shift.len()).min().unwrap_or(0);
        let avg = |c: usize| -> Vec<f64> {
            (0..n)
                .map(|k| {
                    runs.iter().map(|r| r.torso_shift[k][c]).sum::<f64>() * 1e3 / runs.len() as f64
                })
                .collect()
        };
        let t: Vec<f64> = (1..=n).map(|k| k as f64 * 0.03).collect();
        panels.push(TimePanel {
            title: format!("model {}: torso shift of the TPC", m.name),
            y_label: "shift (mm)".into(),
            series: vec![
                TimeSeries {
                    label: "x".into(),
                    t: t.clone(),
                    y: avg(0),
                    color: PALETTE[0],
                    style: Style::Line,
                },
                TimeSeries {
                    label: "y".into(),
                    t,
                    y: avg(1),
                    color: PALETTE[1],
                    style: Style::Line,
                },
            ],
            ..Default::default()
        });
    }
    let p = dir.join("walk-torso-shift.svg");
    time_svg(&p, &panels, force)?;
    Ok(p)
}

fn mean_covariance(d: &DesignOutcome) -> [[f64; 3]; 3] {
    let n = d.draws.len().max(1) as f64;
    std::array::from_fn(|r| {
        std::array::from_fn(|c| d.draws.iter().map(|x| x.covariance[r][c]).sum::<f64>() / n)
    })
}

/// The 2-sigma ellipse of the (a, b) marginal of `cov` (m^2), in mm.
fn ellipse(
    cov: &[[f64; 3]; 3],
    a: usize,
    b: usize,
    color: plotters::style::RGBColor,
) -> TimeSeries {
    let m = nalgebra::Matrix2::new(cov[a][a], cov[a][b], cov[b][a], cov[b][b]);
    let eig = m.symmetric_eigen();
    let (t, y): (Vec<f64>, Vec<f64>) = (0..=96)
        .map(|i| {
            let th = std::f64::consts::TAU * i as f64 / 96.0;
            let u = nalgebra::Vector2::new(
                2.0 * eig.eigenvalues[0].max(0.0).sqrt() * th.cos(),
                2.0 * eig.eigenvalues[1].max(0.0).sqrt() * th.sin(),
            );
            let p = eig.eigenvectors * u;
            (p[0] * 1e3, p[1] * 1e3)
        })
        .unzip();
    TimeSeries {
        label: "2 sigma (reported covariance)".into(),
        t,
        y,
        color,
        style: Style::Line,
    }
}

/// The mean over runs (that did not fall) of the ideal and real ZMP traces.
fn mean_traces(m: &ModelOutcome) -> (Vec<[f64; 2]>, Vec<[f64; 2]>) {
    let ok: Vec<_> = m.with_tpc.traces.iter().filter(|r| !r.fell).collect();
    let runs = if ok.is_empty() {
        m.with_tpc.traces.iter().collect()
    } else {
        ok
    };
    let n = runs.iter().map(|r| r.zmp.len()).min().unwrap_or(0);
    let avg = |f: &dyn Fn(&super::walk::Run) -> &Vec<[f64; 2]>| -> Vec<[f64; 2]> {
        (0..n)
            .map(|k| {
                let s = runs.iter().fold([0.0, 0.0], |acc, r| {
                    [acc[0] + f(r)[k][0], acc[1] + f(r)[k][1]]
                });
                [s[0] / runs.len() as f64, s[1] / runs.len() as f64]
            })
            .collect()
    };
    (avg(&|r| &r.zmp_plan), avg(&|r| &r.zmp))
}
