//! One in-sample blind draw, diagnosed, with the candidates' held-out scores: a development
//! aid for the diagnosis (`cargo run --release -p zmp-suites --example blind_draw -- SEED
//! EFFECT [EFFECT]`).

use zmp_diagnose::{diagnose, DiagnoseOptions};
use zmp_identify::{identify, IdentifyOptions};
use zmp_models::EffectKind;
use zmp_suites::blind::{draw_with, paper};

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let seed: u64 = args.first().map_or(Ok(1000), |s| s.parse())?;
    let effects: Vec<&str> = args[1..].iter().map(|s| s.as_str()).collect();
    let draw = draw_with(seed, &effects);
    println!("{}", draw.description);
    let camp = zmp_virtual_robot::simulate_campaign(&draw.truth, &draw.design)?;
    let mut opts = IdentifyOptions::default();
    if draw.diagonal_model {
        let mut m = paper();
        for p in ["a12", "a21", "b12", "b21"] {
            m.set_value(EffectKind::Pendulum, zmp_models::Binding::Global, p, 0.0);
        }
        opts.start_model = Some(m);
    }
    let t = std::time::Instant::now();
    let ident = identify(&camp, &opts)?;
    for w in &ident.warnings {
        println!("identify: {w}");
    }
    let d = diagnose(&camp, &ident.model, &DiagnoseOptions::default(), &|w| {
        if std::env::var("ZMP_VERBOSE").is_ok() {
            eprintln!("  {w}")
        }
    })?;
    print!("{}", d.to_text());
    println!("tried: {:?}", d.tried);
    println!("{:.1} s", t.elapsed().as_secs_f64());
    Ok(())
}
