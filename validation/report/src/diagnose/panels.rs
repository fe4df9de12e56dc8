//! The report's figure panels: Bode overlays, error against frequency, the third harmonic,
//! the worst record's time overlay and residual spectrum, and grouped error bars.

use super::Overlay;
use crate::plot::{BodePanel, BodeSeries, Style, TimePanel, TimeSeries, PALETTE};
use num_complex::Complex64;
use rustfft::FftPlanner;
use zmp_campaign::Campaign;
use zmp_diagnose::cells::channel_scores;
use zmp_diagnose::measure::{aggregate, score, Prediction, RecordScore};
use zmp_diagnose::observe::Observation;
use zmp_models::{Axis, Channel};

pub(super) fn bode_panels(obs: &[&Observation], models: &[Overlay]) -> Vec<BodePanel> {
    // Model curves through the records of one operating point and the largest amplitude, by
    // frequency; measured points for every record.
    let op0 = obs.first().map(|o| o.operating_point).unwrap_or([0.0; 2]);
    let amax = obs.iter().map(|o| o.nominal_amplitude).fold(0.0, f64::max);
    let mut out = Vec::new();
    for ch in Channel::ALL {
        let (i, j) = (ch.output.index(), ch.input.index());
        let mine: Vec<usize> = (0..obs.len())
            .filter(|&k| obs[k].excited.index() == j)
            .collect();
        if mine.is_empty() {
            continue;
        }
        let mut panel = BodePanel {
            title: format!("{} ({} from {})", ch.name(), ch.output, ch.input),
            ..Default::default()
        };
        panel.series.push(BodeSeries::points(
            "measured",
            mine.iter().map(|&k| obs[k].omega).collect(),
            mine.iter().map(|&k| obs[k].g(i)).collect(),
            PALETTE[0],
        ));
        let mut line: Vec<usize> = mine
            .iter()
            .copied()
            .filter(|&k| obs[k].operating_point == op0 && obs[k].nominal_amplitude == amax)
            .collect();
        line.sort_by(|a, b| obs[*a].omega.total_cmp(&obs[*b].omega));
        for (m, ov) in models.iter().enumerate() {
            let s = BodeSeries::line(
                ov.label,
                line.iter().map(|&k| obs[k].omega).collect(),
                line.iter().map(|&k| ov.predictions[k].g[i]).collect(),
                PALETTE[(m + 1) % PALETTE.len()],
            );
            panel.series.push(if m == 0 && models.len() > 1 {
                s.dashed()
            } else {
                s
            });
        }
        out.push(panel);
    }
    out
}

/// Error over noise floor per record and channel against frequency (for
/// [`frequency_svg`](crate::plot::frequency_svg)), one series per amplitude.
pub(super) fn error_panels(obs: &[&Observation], preds: &[Prediction]) -> Vec<TimePanel> {
    let mut amps: Vec<f64> = obs.iter().map(|o| o.nominal_amplitude).collect();
    amps.sort_by(f64::total_cmp);
    amps.dedup();
    let mut out = Vec::new();
    for ch in Channel::ALL {
        let (i, j) = (ch.output.index(), ch.input.index());
        let mut series = Vec::new();
        for (m, a) in amps.iter().enumerate() {
            // RMS over operating points at each frequency.
            let mut by_w: Vec<(f64, f64, f64)> = Vec::new();
            for (o, p) in obs.iter().zip(preds) {
                if o.excited.index() != j || o.nominal_amplitude != *a {
                    continue;
                }
                let c = channel_scores(o, p)[i];
                match by_w.iter_mut().find(|x| x.0 == o.omega) {
                    Some(x) => {
                        x.1 += c.error2;
                        x.2 += c.floor2;
                    }
                    None => by_w.push((o.omega, c.error2, c.floor2)),
                }
            }
            by_w.sort_by(|a, b| a.0.total_cmp(&b.0));
            if by_w.is_empty() {
                continue;
            }
            series.push(TimeSeries {
                label: format!("{:.1} mm", a * 1e3),
                t: by_w.iter().map(|x| x.0).collect(),
                y: by_w
                    .iter()
                    .map(|x| (x.1 / x.2.max(1e-300)).sqrt())
                    .collect(),
                color: PALETTE[m % PALETTE.len()],
                style: Style::Line,
            });
        }
        if series.is_empty() {
            continue;
        }
        let w: Vec<f64> = series[0].t.clone();
        series.push(TimeSeries {
            label: "noise floor".into(),
            t: vec![w[0], w[w.len() - 1]],
            y: vec![1.0, 1.0],
            color: PALETTE[5],
            style: Style::Dashed,
        });
        out.push(TimePanel {
            title: format!("{}: error / noise floor against frequency", ch.name()),
            y_label: "error / floor".into(),
            series,
            markers: vec![],
            x_label: None,
        });
    }
    out
}

/// The third harmonic of the measured ZMP against frequency, per channel (for
/// [`frequency_svg`](crate::plot::frequency_svg)).
pub(super) fn harmonic_panel(obs: &[&Observation]) -> TimePanel {
    let mut series = Vec::new();
    for (m, ch) in Channel::ALL.iter().enumerate() {
        let (i, j) = (ch.output.index(), ch.input.index());
        let mut pts: Vec<(f64, f64)> = obs
            .iter()
            .filter(|o| o.excited.index() == j)
            .map(|o| (o.omega, 100.0 * o.y3[i].norm() / o.y1[i].norm().max(1e-300)))
            .collect();
        if pts.is_empty() {
            continue;
        }
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        series.push(TimeSeries {
            label: ch.name().to_string(),
            t: pts.iter().map(|p| p.0).collect(),
            y: pts.iter().map(|p| p.1).collect(),
            color: PALETTE[m % PALETTE.len()],
            style: Style::Points,
        });
    }
    TimePanel {
        title: "Third harmonic of the measured ZMP, % of the fundamental (nonlinearity)".into(),
        y_label: "|Y3| / |Y1| (%)".into(),
        series,
        markers: vec![],
        x_label: None,
    }
}

/// The observation with the largest excess error.
pub(super) fn worst(obs: &[&Observation], preds: &[Prediction]) -> Option<usize> {
    obs.iter()
        .zip(preds)
        .enumerate()
        .map(|(k, (o, p))| {
            let s = score(o, p);
            (k, s.error2 - s.floor2)
        })
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map(|x| x.0)
}

/// Time overlay of observation `k`'s steady state (measured against the model's first
/// harmonic and trend on the measured mean) and the residual's spectrum.
pub(super) fn record_panels(
    campaign: &Campaign,
    obs: &[&Observation],
    preds: &[Prediction],
    k: usize,
) -> Option<(usize, Vec<TimePanel>, TimePanel)> {
    let o = obs[k];
    let rec = campaign.records.get(o.index)?;
    let i0 = rec.t.iter().position(|&t| t >= o.t0)?;
    let i1 = rec.t.iter().rposition(|&t| t <= o.t1)? + 1;
    let t = &rec.t[i0..i1];
    let tmid = 0.5 * (o.t0 + o.t1);
    let mut panels = Vec::new();
    let mut residual_spec = None;
    for axis in Axis::BOTH {
        let i = axis.index();
        let y = &rec.output(axis)[i0..i1];
        let mean = y.iter().sum::<f64>() / y.len() as f64;
        let g = preds[k].g[i] * o.u1;
        let model: Vec<f64> = t
            .iter()
            .map(|&tk| {
                mean + preds[k].slope[i] * (tk - tmid)
                    + (g * Complex64::from_polar(1.0, o.omega * tk)).im
            })
            .collect();
        let resid: Vec<f64> = y.iter().zip(&model).map(|(a, b)| a - b).collect();
        let step = (y.len() / 2000).max(1);
        let pick = |v: &[f64]| v.iter().step_by(step).map(|x| x * 1e3).collect::<Vec<_>>();
        let tt: Vec<f64> = t.iter().step_by(step).copied().collect();
        panels.push(TimePanel {
            title: format!(
                "record {} ({} excited, {:.2} rad/s, {:.1} mm, op ({:.3}, {:.3}) m): zmp_{}",
                o.index,
                o.excited,
                o.omega,
                o.nominal_amplitude * 1e3,
                o.operating_point[0],
                o.operating_point[1],
                axis
            ),
            y_label: "mm".into(),
            series: vec![
                TimeSeries {
                    label: "measured".into(),
                    t: tt.clone(),
                    y: pick(y),
                    color: PALETTE[0],
                    style: Style::Line,
                },
                TimeSeries {
                    label: "model (steady state)".into(),
                    t: tt.clone(),
                    y: pick(&model),
                    color: PALETTE[1],
                    style: Style::Line,
                },
                TimeSeries {
                    label: "residual".into(),
                    t: tt,
                    y: pick(&resid),
                    color: PALETTE[3],
                    style: Style::Line,
                },
            ],
            markers: vec![],
            x_label: None,
        });
        if axis == o.excited {
            // Amplitude spectrum of the residual, Hann window.
            let n = resid.len();
            let mut buf: Vec<Complex64> = resid
                .iter()
                .enumerate()
                .map(|(m, v)| {
                    let w = 0.5 - 0.5 * (2.0 * std::f64::consts::PI * m as f64 / n as f64).cos();
                    Complex64::new(v * w, 0.0)
                })
                .collect();
            FftPlanner::new().plan_fft_forward(n).process(&mut buf);
            let dt = rec.dt();
            let wmax = (8.0 * o.omega).min(std::f64::consts::PI / dt);
            let (mut f, mut a) = (Vec::new(), Vec::new());
            for (m, c) in buf.iter().enumerate().take(n / 2) {
                let w = 2.0 * std::f64::consts::PI * m as f64 / (n as f64 * dt);
                if w > wmax {
                    break;
                }
                f.push(w);
                a.push(4.0 * c.norm() / n as f64 * 1e3);
            }
            residual_spec = Some(TimePanel {
                title: format!(
                    "Residual spectrum of zmp_{axis}, record {} (markers: omega, 2 omega, 3 omega)",
                    o.index
                ),
                y_label: "amplitude (mm)".into(),
                series: vec![TimeSeries {
                    label: "residual".into(),
                    t: f,
                    y: a,
                    color: PALETTE[3],
                    style: Style::Line,
                }],
                markers: (1..=3)
                    .map(|h| (h as f64 * o.omega, format!("{h}w")))
                    .collect(),
                x_label: Some("omega (rad/s)".into()),
            });
        }
    }
    Some((o.index, panels, residual_spec?))
}

pub(super) fn group_bars(
    obs: &[&Observation],
    preds: &[Prediction],
    key: &dyn Fn(&Observation) -> String,
) -> Vec<(String, f64)> {
    let mut groups: Vec<(String, Vec<RecordScore>)> = Vec::new();
    for (o, p) in obs.iter().zip(preds) {
        let k = key(o);
        let s = score(o, p);
        match groups.iter_mut().find(|g| g.0 == k) {
            Some(g) => g.1.push(s),
            None => groups.push((k, vec![s])),
        }
    }
    groups
        .into_iter()
        .map(|(k, s)| {
            let (e, f) = aggregate(&s);
            (k, e / f)
        })
        .collect()
}
