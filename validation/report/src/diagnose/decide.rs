//! The diagnosis report's section on what the data cannot decide (the set of structures the
//! records do not separate, each with its parameters, held-out error and what distinguishes
//! it), on the structures the records part from one of the set yet fit no better, and on
//! what the final model leaves (the residual in words).

use super::esc;
use std::fmt::Write as _;
use zmp_diagnose::run::Diagnosis;
use zmp_diagnose::words::sig;

/// The section's HTML (empty when the data decide and the final model explains them).
pub fn section(d: &Diagnosis) -> String {
    let mut h = String::new();
    let f = d.noise_floor;
    if d.alternatives.len() > 1 {
        h.push_str(
            "<h2>What the data cannot decide</h2>\n<p>These structures each explain the records \
             better than anything simpler, and no one of them predicts the held-out records \
             significantly better than the others. The experiment that separates them is where \
             they part.</p>\n<table><tr><th>#</th><th>structure</th><th>parameters</th>\
             <th>held-out error / floor</th><th>z from the best</th>\
             <th class=\"l\">what distinguishes it</th></tr>\n",
        );
        for (k, a) in d.alternatives.iter().enumerate() {
            let params: Vec<String> = a
                .parameters
                .iter()
                .map(|(n, v)| esc(&format!("{n} = {}", sig(*v))))
                .collect();
            let words = a
                .distinguished
                .as_ref()
                .map_or(String::new(), |s| esc(&s.words));
            let _ = writeln!(
                h,
                "<tr><td>{}</td><td class=\"l\">{}</td><td class=\"l\">{}</td><td>{:.2}</td>\
                 <td>{:.1}</td><td class=\"l\">{words}</td></tr>",
                k + 1,
                esc(&a.structure),
                params.join("<br>"),
                a.held_out_error / f,
                a.z_from_best
            );
        }
        h.push_str("</table>\n");
    }
    if !d.parted.is_empty() {
        h.push_str(
            "<h2>What the records part yet fit no better</h2>\n<p>Each of these structures \
             predicts the held-out records about as well as one of the set, though the records \
             part the two: were either the whole truth, the other would fit them far worse. \
             Cox's test rejects both, so neither is the whole truth, and no new record is \
             needed to tell them apart.</p>\n<ul>\n",
        );
        for p in &d.parted {
            let _ = writeln!(h, "<li>{}</li>", esc(&p.words));
        }
        h.push_str("</ul>\n");
    }
    if !d.residual.is_empty() {
        h.push_str("<h2>What the final model leaves</h2>\n<ul>\n");
        for r in &d.residual {
            let _ = writeln!(
                h,
                "<li>{} <span class=\"bad\">({:.1} standard deviations)</span></li>",
                esc(&r.words),
                r.z
            );
        }
        h.push_str("</ul>\n");
    }
    h
}
