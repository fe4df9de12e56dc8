//! The twin's HTML report and its closed-loop figure (the seed's figures 18-20, twin and model
//! overlaid).

use super::closed_loop::TwinRun;
use super::props::OperatingPoint;
use super::validate::Summary;
use anyhow::Result;
use std::fmt::Write as _;
use std::path::Path;
use zmp_identify::Identification;
use zmp_models::closed_loop::{ClosedLoopTrace, StepExperiment};
use zmp_report::html::{esc, STYLE};
use zmp_report::plot::{time_svg, Style, TimePanel, TimeSeries, PALETTE};

/// Seed figures 18-20 for the twin (measured ZMP, true ZMP) and the identified model.
pub fn closed_loop_svg(
    path: &Path,
    twin: &TwinRun,
    model: &ClosedLoopTrace,
    exp: &StepExperiment,
) -> Result<()> {
    let tr = &twin.trace;
    // Every 5th controller sample (20 Hz) is plenty for a 160 s run.
    let idx: Vec<usize> = (0..tr.t.len().min(model.t.len())).step_by(5).collect();
    let col = |f: &dyn Fn(usize) -> f64| -> Vec<f64> { idx.iter().map(|&k| f(k)).collect() };
    let t = col(&|k| tr.t[k]);
    let line = |label: &str, y: Vec<f64>, c: usize, style: Style| TimeSeries {
        label: label.into(),
        t: t.clone(),
        y,
        color: PALETTE[c],
        style,
    };
    let panels = [
        TimePanel {
            title: format!(
                "ZMP regulation (seed fig. 18): reference {:.4} -> {:.4} m, {} kg load at t = {} s",
                exp.zmp_ref_before[0], exp.zmp_ref_after[0], exp.load_mass, exp.load_time
            ),
            y_label: "zmp_x (m)".into(),
            series: vec![
                line("reference", col(&|k| tr.zmp_ref[k][0]), 5, Style::Dashed),
                line(
                    "twin, measured (load cells)",
                    col(&|k| tr.zmp[k][0]),
                    0,
                    Style::Line,
                ),
                line(
                    "identified model's prediction",
                    col(&|k| model.zmp[k][0]),
                    1,
                    Style::Dashed,
                ),
            ],
            markers: vec![(exp.load_time, format!("{} kg load", exp.load_mass))],
            x_label: None,
        },
        TimePanel {
            title: "ZMP error (seed fig. 19)".into(),
            y_label: "zmp_ref - zmp (m)".into(),
            series: vec![
                line(
                    "twin (true ZMP)",
                    col(&|k| tr.zmp_ref[k][0] - twin.zmp_true[k][0]),
                    0,
                    Style::Line,
                ),
                line(
                    "model",
                    col(&|k| model.zmp_ref[k][0] - model.zmp[k][0]),
                    1,
                    Style::Dashed,
                ),
            ],
            markers: vec![],
            x_label: None,
        },
        TimePanel {
            title: "Trunk motion (seed fig. 20)".into(),
            y_label: "theta lateral (rad)".into(),
            series: vec![
                line(
                    "twin, controller output",
                    col(&|k| tr.theta[k][0]),
                    2,
                    Style::Line,
                ),
                line(
                    "twin, measured",
                    col(&|k| twin.theta_measured[k][0]),
                    0,
                    Style::Dashed,
                ),
                line(
                    "model, controller output",
                    col(&|k| model.theta[k][0]),
                    1,
                    Style::Dashed,
                ),
            ],
            markers: vec![],
            x_label: None,
        },
    ];
    time_svg(path, &panels, false)
}

fn td(v: f64, digits: usize) -> String {
    if v.is_finite() {
        format!("<td>{v:.digits$}</td>")
    } else {
        "<td>-</td>".into()
    }
}

fn pct(a: f64, b: f64) -> String {
    if b != 0.0 && a.is_finite() && b.is_finite() {
        format!("<td>{:+.1} %</td>", 100.0 * (a / b - 1.0))
    } else {
        "<td>-</td>".into()
    }
}

/// `report.html`.
pub fn write_html(
    path: &Path,
    s: &Summary,
    ident: &Identification,
    upright: &OperatingPoint,
) -> Result<()> {
    let mut h = String::new();
    let title = "MuJoCo twin of SILO2: identification, closed loop, diagnosis";
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>{title}</title>{STYLE}\
         </head><body>\n<h1>{title}</h1>\n<p class=\"note\">Model <code>{}</code>; {} run; \
         {:.0} s wall time. Everything here is computed by <code>cargo xtask validate \
         silo2{}</code>; the numbers are in <code>summary.json</code>.</p>\n",
        esc(&s.model_file),
        if s.short {
            "short"
        } else if s.extended {
            "extended"
        } else {
            "full"
        },
        s.wall_s,
        if s.short {
            " --short"
        } else if s.extended {
            " --extended"
        } else {
            ""
        }
    );

    // The twin.
    let m = &s.mass;
    let _ = write!(
        h,
        "<h2>The twin</h2>\n<table><tr><th class=l>quantity</th><th>value</th></tr>\
         <tr><td class=l>total mass m_r</td><td>{:.3} kg</td></tr>\
         <tr><td class=l>trunk mass m_t (m_t/m_r)</td><td>{:.3} kg ({:.1} %)</td></tr>\
         <tr><td class=l>trunk lever l_t (tilt axes to trunk CoM)</td><td>{:.3} m</td></tr>\
         <tr><td class=l>tilt axes height</td><td>{:.3} m</td></tr>\
         <tr><td class=l>CoM height z_c, upright</td><td>{:.4} m</td></tr>\
         <tr><td class=l>trunk joint inertia M_ii (lateral, sagittal)</td><td>{:.4}, {:.4} kg m&sup2;</td></tr>\
         <tr><td class=l>trunk servo kp/M_ii, kv/M_ii</td><td>{:.1}, {:.2} (seed: 900, 60)</td></tr>\
         <tr><td class=l>servo with gravity: omega_n, zeta (upright, lateral)</td><td>{:.3} rad/s, {:.4}</td></tr>\
         <tr><td class=l>support polygon x, y</td><td>[{:.3}, {:.3}], [{:.3}, {:.3}] m</td></tr>\
         <tr><td class=l>eq. 26 gain (m_t/m_r) l_t</td><td>{:.4} m/rad</td></tr></table>\n",
        m.total_mass,
        m.trunk_mass,
        100.0 * m.trunk_mass_ratio,
        m.trunk_lever,
        m.axis_height,
        m.com_upright[2],
        m.joint_inertia[0],
        m.joint_inertia[1],
        m.servo_omega_n2[0],
        m.servo_2zeta_omega_n[0],
        upright.omega_n[0],
        upright.zeta[0],
        m.support[0],
        m.support[1],
        m.support[2],
        m.support[3],
        m.reference_gain()
    );

    // ZMP measurement.
    h.push_str(
        "<h2>ZMP measurement</h2>\n<p>Static (seed eq. 10): at rest at each operating point, the \
         load-cell ZMP against MuJoCo's contact centre of pressure and the CoM's projection.</p>\n\
         <table><tr><th>CoM reference (mm)</th><th>trunk angles (rad)</th><th>CoM x, y (mm)</th>\
         <th>load-cell ZMP x, y (mm)</th><th>max |cells - CoP| (mm)</th><th>max |cells - CoM| (mm)</th>\
         <th>penetration (mm)</th></tr>\n",
    );
    for c in &s.eq10 {
        let _ = writeln!(
            h,
            "<tr><td>{:+.1}, {:+.1}</td><td>{:+.4}, {:+.4}</td><td>{:+.3}, {:+.3}</td>\
             <td>{:+.3}, {:+.3}</td><td>{:.2e}</td><td>{:.2e}</td><td>{:.4}</td></tr>",
            c.com_ref[0] * 1e3,
            c.com_ref[1] * 1e3,
            c.theta[0],
            c.theta[1],
            c.com[0] * 1e3,
            c.com[1] * 1e3,
            c.zmp_cells[0] * 1e3,
            c.zmp_cells[1] * 1e3,
            c.max_cells_minus_cop * 1e3,
            c.max_cells_minus_com * 1e3,
            c.penetration * 1e3
        );
    }
    h.push_str(
        "</table>\n<p>Dynamic: a trunk sine (CoM reference 3.5 mm at 6 rad/s), RMS differences of \
         the load-cell ZMP over 3 periods. The momentum ZMP is Newton-Euler on the whole robot \
         (MuJoCo's subtree CoM, velocity and angular momentum, differentiated); the cart-table ZMP \
         <code>x - z/g x''</code> leaves out the trunk's rotation and underestimates the swing.</p>\n\
         <table><tr><th class=l>axis</th><th>RMS ZMP swing (mm)</th><th>cells - CoP (mm)</th>\
         <th>cells - momentum ZMP (mm)</th><th>cells - cart-table (mm)</th><th>cart-table / cells amplitude</th></tr>\n",
    );
    for c in &s.dynamic {
        let _ = writeln!(
            h,
            "<tr><td class=l>{}</td><td>{:.3}</td><td>{:.2e}</td><td>{:.3}</td><td>{:.3}</td><td>{:.3}</td></tr>",
            c.axis,
            c.rms_zmp * 1e3,
            c.rms_cells_minus_cop * 1e3,
            c.rms_cells_minus_momentum * 1e3,
            c.rms_cells_minus_cart_table * 1e3,
            c.cart_table_amplitude_ratio
        );
    }
    h.push_str(
        "</table>\n<h3>Contact-softness budget</h3>\n<p>Per contact time constant (solref, damping \
         ratio 1): penetration and static ZMP errors at rest, and the ZMP's response to a trunk \
         sine against the rigid-robot prediction from the measured trunk motion (what soft \
         contacts and leg servos add).</p>\n<table><tr><th>time constant (ms)</th>\
         <th>penetration (mm)</th><th>max |cells - CoP| (mm)</th><th>max |cells - CoM| (mm)</th>",
    );
    if let Some(r) = s.budget.first() {
        for e in &r.response {
            let _ = write!(
                h,
                "<th>|Z/Z_rigid| - 1, {} at {} rad/s</th>",
                e.axis, e.omega
            );
        }
    }
    h.push_str("</tr>\n");
    for r in &s.budget {
        let _ = write!(
            h,
            "<tr><td>{:.0}</td><td>{:.4}</td><td>{:.2e}</td><td>{:.2e}</td>",
            r.timeconst * 1e3,
            r.penetration * 1e3,
            r.max_cells_minus_cop * 1e3,
            r.max_cells_minus_com * 1e3
        );
        for e in &r.response {
            let _ = write!(
                h,
                "<td>{:+.2} % ({:+.2}&deg;)</td>",
                100.0 * e.magnitude_error,
                e.phase_error_deg
            );
        }
        h.push_str("</tr>\n");
    }
    h.push_str("</table>\n");

    // Identification.
    let c = &s.campaign;
    let _ = write!(
        h,
        "<h2>Campaign and identification</h2>\n<p>{} records ({} rows, {:.0} s simulated in \
         {:.1} s): the trunk servos follow seed eq. 26 sines; {}. \
         <a href=\"campaign/campaign.toml\">campaign</a>, \
         <a href=\"identify/report.html\">identification report</a>, \
         <a href=\"identified.toml\">identified model</a>. Reduced chi-square {:.2}.</p>\n",
        c.records,
        c.rows,
        c.simulated_s,
        c.wall_s,
        esc(&c.sensor),
        s.reduced_chi2
    );
    h.push_str(
        "<table><tr><th class=l>parameter</th><th>seed eqs. 6-15 (point mass)</th><th>multibody (rigid)</th>\
         <th>multibody + servo gravity</th><th>identified &plusmn; s.e.</th><th>identified vs servo</th>\
         <th>after the diagnosis loop</th></tr>\n",
    );
    for p in &s.parameters {
        let _ = write!(
            h,
            "<tr><td class=l>{}</td>{}{}{}<td class=nw>{:.5} &plusmn; {:.5}</td>{}",
            p.name,
            td(p.seed, 5),
            td(p.multibody, 5),
            td(p.servo, 5),
            p.identified,
            p.identified_stderr,
            if p.name.len() == 3 && p.name.as_bytes()[1] != p.name.as_bytes()[2] {
                "<td>(coupling)</td>".to_string()
            } else {
                pct(p.identified, p.servo)
            }
        );
        match p.after_loop {
            Some(v) => {
                let _ = writeln!(h, "{}</tr>", td(v, 5));
            }
            None => h.push_str("<td>-</td></tr>\n"),
        }
    }
    h.push_str("</table>\n");
    if !s.excluded_records.is_empty() {
        let _ = writeln!(
            h,
            "<p>Excluded from the linear fit: {}.</p>",
            s.excluded_records
                .iter()
                .map(|(k, w)| format!("r{k:03} ({})", esc(w)))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    for w in &ident.warnings {
        let _ = writeln!(h, "<p class=note>identify: {}</p>", esc(w));
    }

    // Closed loop.
    let cl = &s.closed_loop;
    let e = &cl.experiment;
    let (tw, mo) = (&cl.comparison.twin, &cl.comparison.model);
    let _ = write!(
        h,
        "<h2>Closed loop (seed section 6.6)</h2>\n<p>The cascade controller (K1 = 0.014, K2 = 0.2, \
         the controller FMU's code) on the twin: ZMP reference {:.4} -> {:.4} m at t = 0 (the seed's \
         0.12 -> 0.17 m mapped to the same trunk tilt), {} kg on the right hip at ({:.3}, {:.3}) m at \
         t = {} s. Dashed: the identified model in the same loop. Twin against model: NRMSE {:.4} \
         (noise floor {:.4}), RMS difference {:.3} mm (x), {:.3} mm (y).</p>\n\
         <img src=\"closed_loop.svg\" alt=\"closed loop\">\n\
         <table><tr><th></th><th>reaches the reference (s)</th><th>settles 2 % (s)</th><th>overshoot</th>\
         <th>load: peak error (mm)</th><th>load: recovery (s)</th><th>final error (mm)</th>\
         <th>final trunk angle (rad)</th></tr>\n\
         <tr><td class=l>twin</td>{}{}<td>{:.1} %</td>{}{}{}{}</tr>\n\
         <tr><td class=l>model</td>{}{}<td>{:.1} %</td>{}{}{}{}</tr></table>\n",
        e.zmp_ref_before[0],
        e.zmp_ref_after[0],
        e.load_mass,
        e.load_position[0],
        e.load_position[1],
        e.load_time,
        cl.comparison.nrmse_x,
        cl.comparison.noise_floor_x,
        cl.comparison.rms_difference[0] * 1e3,
        cl.comparison.rms_difference[1] * 1e3,
        td(tw.reach_time_s, 1),
        td(tw.settling_time_2pct_s, 1),
        tw.overshoot_pct,
        td(tw.load_peak_error_m * 1e3, 2),
        td(tw.load_recovery_time_s, 1),
        td(tw.final_error_m * 1e3, 3),
        td(cl.comparison.final_theta_twin, 3),
        td(mo.reach_time_s, 1),
        td(mo.settling_time_2pct_s, 1),
        mo.overshoot_pct,
        td(mo.load_peak_error_m * 1e3, 2),
        td(mo.load_recovery_time_s, 1),
        td(mo.final_error_m * 1e3, 3),
        td(cl.comparison.final_theta_model, 3),
    );

    // Diagnosis.
    let d = &s.diagnosis;
    let _ = write!(
        h,
        "<h2>Diagnosis on the twin</h2>\n<p>Verdict: <b>{}</b>. The identified model scores {:.2}x \
         the noise floor ({:.4}); with the effects added by the loop, {:.2}x. \
         <a href=\"diagnosis/diagnosis.html\">diagnosis report</a>{}.</p>\n<ul>\n",
        esc(&d.verdict),
        d.baseline_error / d.noise_floor,
        d.noise_floor,
        d.final_error / d.noise_floor,
        match &d.final_model {
            Some(f) => format!(
                ", <a href=\"{0}\">{0}</a>",
                esc(&f.display().to_string())
            ),
            None => String::new(),
        }
    );
    for (effect, sig, ev) in &d.findings {
        let _ = writeln!(
            h,
            "<li><b>{}</b>{}: {}</li>",
            esc(effect),
            if *sig { "" } else { " (not significant)" },
            esc(ev)
        );
    }
    h.push_str("</ul>\n");
    stance_section(&mut h, s);

    // Frames.
    h.push_str("<h2>The robot during the disturbance experiment</h2>\n");
    if let Some(n) = &s.frames_note {
        let _ = writeln!(h, "<p class=note>{}</p>", esc(n));
    }
    for f in &s.frames {
        let name = f.display().to_string();
        let _ = writeln!(
            h,
            "<figure style=\"display:inline-block;margin:4px\"><img src=\"{0}\" width=\"320\" \
             alt=\"{0}\"><figcaption>{0}</figcaption></figure>",
            esc(&name)
        );
    }
    h.push_str("</body></html>\n");
    zmp_files::atomic_write(path, h.as_bytes(), false)
}

/// The stance resonance swept on the model file and the verdict on the named mode.
fn stance_section(h: &mut String, s: &Summary) {
    let band = s
        .stance
        .first()
        .and_then(|a| Some((a.swept.first()?.omega, a.swept.last()?.omega)));
    let _ =
        write!(
        h,
        "<h2>Stance resonance: the named mode against the model file</h2>\n<p>The load-cell ZMP \
         over the rigid robot's prediction from the measured trunk motion (the trunk servo \
         divided out), swept noise-free on the model file{}, and the <code>structural_mode</code> \
         law fitted to it. A mode the diagnosis names is the physical resonance only if it sits \
         within 15 % of the swept one and the model with it predicts the twin's response at that \
         frequency within 30 %; otherwise it is an in-band surrogate (below a mode its factor is \
         1 + (share/wm<sup>2</sup>) w<sup>2</sup>: a campaign ending below the resonance fixes \
         that curvature and little else).</p>\n<table><tr><th>axis</th><th>swept resonance \
         (wm, zeta, share)</th><th>peak |factor|</th><th>named mode (wm, zeta, share)</th>\
         <th>|G| at its wm: twin, model</th><th>verdict</th></tr>\n",
        band.map_or(String::new(), |(a, b)| format!(" from {a:.0} to {b:.0} rad/s"))
    );
    for a in &s.stance {
        let f = a.fitted;
        let _ = writeln!(
            h,
            "<tr><td class=l>{}</td><td>{:.1} rad/s, {:.3}, {:.2}</td><td>{:.2} at {:.1} rad/s</td>\
             <td>{}</td><td>{}</td><td class=l><b>{}</b></td></tr>",
            a.axis,
            f.omega_n,
            f.zeta,
            f.share,
            a.peak_magnitude,
            a.peak_omega,
            a.named.map_or("none".into(), |m| format!(
                "{}: {:.1} rad/s, {:.3}, {:.3}",
                a.named_effect.as_deref().unwrap_or(""),
                m.omega_n,
                m.zeta,
                m.share
            )),
            a.at_named
                .map_or("".into(), |(t, n)| format!("{t:.1}, {n:.1}")),
            esc(&a.verdict)
        );
    }
    h.push_str("</table>\n");
}
