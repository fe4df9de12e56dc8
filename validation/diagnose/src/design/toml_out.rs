//! The designed experiment as a design file in the list form (`[[records]]`), which both
//! `cargo xtask simulate --design` and `zmp-indep-sim --design` read (see
//! `docs/src/spec/design-format.md`).

use super::Designed;
use std::fmt::Write as _;
use zmp_models::model_file::fmt_float;

/// The design file: a comment naming the rivals, the predicted separations, the total
/// recording time and the limits; the shared timing and noise fields; one `[[records]]`
/// table per record, in the order chosen.
pub fn to_toml(d: &Designed) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# Records designed by `cargo xtask design-next` to separate the rival models:"
    );
    for (k, l) in d.labels.iter().enumerate() {
        let _ = writeln!(s, "#   M{}: {l}", k + 1);
    }
    let _ = writeln!(
        s,
        "# Predicted separation, noise standard deviations (Mi taken as true, Mj refitted to it \
         with every parameter), campaign alone -> with these records:"
    );
    for p in &d.separations {
        let _ = writeln!(
            s,
            "#   M{} true, M{} refitted: {:.2} -> {:.2}",
            p.truth + 1,
            p.rival + 1,
            p.campaign_sigma,
            p.total_sigma
        );
    }
    let l = &d.limits;
    let _ = writeln!(
        s,
        "# {} records, {:.0} s of recording; frequencies {:.3}-{:.3} rad/s; operating points \
         of the campaign; ZMP within x [{:.4}, {:.4}] m, y [{:.4}, {:.4}] m; trunk acceleration \
         within x {:.3}, y {:.3} m/s2.",
        d.records.len(),
        d.total_time_s(),
        l.omega_min,
        l.omega_max,
        l.zmp_range[0][0],
        l.zmp_range[0][1],
        l.zmp_range[1][0],
        l.zmp_range[1][1],
        l.acceleration_cap[0].0,
        l.acceleration_cap[1].0,
    );
    let _ = writeln!(s, "name = \"design-next\"");
    let t = &d.timing;
    let _ = writeln!(s, "sample_rate_hz = {}", fmt_float(t.sample_rate_hz));
    let _ = writeln!(s, "transient_s = {}", fmt_float(t.transient_s));
    let _ = writeln!(s, "periods = {}", t.periods);
    let _ = writeln!(s, "min_steady_s = {}", fmt_float(t.min_steady_s));
    let _ = writeln!(
        s,
        "zmp_noise_std = {}  # m, the campaign's white noise (for the simulators)",
        fmt_float(d.zmp_noise_std)
    );
    let _ = writeln!(
        s,
        "quantisation = {}  # m, the campaign's sensor resolution",
        fmt_float(d.limits.resolution)
    );
    let _ = writeln!(s, "seed = {}", d.seed);
    for r in &d.records {
        let _ = writeln!(s);
        let _ = writeln!(s, "[[records]]");
        let _ = writeln!(s, "excited = \"{}\"", r.excited.name());
        let _ = writeln!(s, "omega = {}", fmt_float(round_sig(r.omega)));
        let _ = writeln!(s, "amplitude = {}", fmt_float(round_sig(r.amplitude)));
        let _ = writeln!(
            s,
            "operating_point = [{}, {}]",
            fmt_float(r.operating_point[0]),
            fmt_float(r.operating_point[1])
        );
    }
    s
}

/// `v` to 6 significant digits: a frequency and an amplitude no robot commands more finely,
/// and a file a person reads.
fn round_sig(v: f64) -> f64 {
    if v == 0.0 || !v.is_finite() {
        return v;
    }
    let e = 10f64.powi(5 - v.abs().log10().floor() as i32);
    (v * e).round() / e
}
