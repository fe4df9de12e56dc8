//! Development aid: measured first harmonic of the saturated records of a campaign over the
//! linear model identified from the others, against the project's describing function of the
//! acceleration limit at several limits. `cargo run --release -p zmp-suites --example
//! satcheck -- CAMPAIGN`.
use num_complex::Complex64;
use zmp_campaign::read_campaign;
use zmp_identify::{identify, IdentifyOptions};
use zmp_models::{Axis, ModelSpec, Plant};

fn main() -> anyhow::Result<()> {
    let dir = std::env::args().nth(1).unwrap_or("/tmp/d9".into());
    let camp = read_campaign(std::path::Path::new(&dir))?;
    let id = identify(&camp, &IdentifyOptions::default())?;
    let (wn, z) = (id.bandwidth.omega_n, id.bandwidth.zeta);
    for &c in &id.saturation.records {
        let r = &id.records[c];
        let j = r.excited.index();
        let lin = id.model_response(j, j, r.omega_fit);
        let q = r.g[j] / lin;
        print!(
            "record {c} w {:.2} A {:.4} meas/lin {:.4} {:+.2}deg ",
            r.omega,
            r.amplitude,
            q.norm(),
            q.arg().to_degrees()
        );
        for limit in [0.5, 1.0, 1.4, 1.5, 1.566, 1.6] {
            let toml = format!(
                "format = \"zmp-model/1\"\nname = \"s\"\n[pendulum]\na11 = 1.0\na12 = 0.0\na21 = 0.0\na22 = 1.0\nb11 = -1.0\nb12 = 0.0\nb21 = 0.0\nb22 = -1.0\n\
                 [tracking_lowpass]\nomega_n = {wn}\nzeta = {z}\n\
                 [acceleration_saturation]\nlimit = {limit}\n"
            );
            let spec = ModelSpec::parse(&toml, "s.toml")?;
            let mut p = Plant::new(
                &spec,
                std::env::var("H").map_or(1e-3, |s| s.parse().unwrap()),
            )?;
            let g =
                p.simulated_response(if j == 0 { Axis::X } else { Axis::Y }, r.omega, r.amplitude)
                    [j];
            let s = Complex64::new(0.0, r.omega);
            let h = wn * wn / (s * s + 2.0 * z * wn * s + wn * wn);
            let g_lin = (1.0 + r.omega * r.omega) * h;
            let n = g / g_lin;
            print!(
                "| {limit}: {:.4} {:+.2}deg ",
                n.norm(),
                n.arg().to_degrees()
            );
        }
        println!();
    }
    Ok(())
}
