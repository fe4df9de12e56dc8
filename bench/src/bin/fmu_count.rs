//! One FMI 2.0 co-simulation step of the plant FMU through the Rust importer (the `fmi` crate:
//! `fmi2SetReal` of the 2 inputs, `fmi2DoStep` of 1 ms, `fmi2GetReal` of the 4 outputs), for
//! instruction counts under callgrind (`cargo xtask bench` runs it):
//!
//! ```text
//! valgrind --tool=callgrind --toggle-collect='*count_loop*' \
//!     target/release/fmu_count zmp_plant.fmu models/params/silo2-paper.toml [steps]
//! ```
//!
//! Loading, instantiating and initialising the FMU, and 1000 warm-up steps, happen outside the
//! counted function; the inputs are CoM-reference sines around the FMU's start values from a
//! precomputed table. Without valgrind it prints wall-clock nanoseconds per step.

use fmi::fmi2::import::Fmi2Import;
use fmi::fmi2::instance::{CoSimulation, Common, InstanceCS};
use fmi::traits::FmiInstance;
use std::hint::black_box;
use std::path::Path;
use std::process::ExitCode;
use std::time::Instant;
use zmp_bench::realtime::TABLE;
use zmp_fmu_core::{Kind, VarTable};
use zmp_models::ModelSpec;

/// Communication step, s (the model's internal step: one plant step per `doStep`).
const DT: f64 = 1e-3;

struct Slave {
    inst: InstanceCS,
    inputs: [u32; 2],
    outputs: [u32; 4],
}

#[inline(never)]
fn count_loop_fmu_do_step(s: &mut Slave, table: &[[f64; 2]], start: usize, steps: usize) -> f64 {
    let mut out = [0.0; 4];
    let mut acc = 0.0;
    for k in start..start + steps {
        s.inst
            .set_real(&s.inputs, black_box(&table[k & (TABLE - 1)]))
            .expect("fmi2SetReal");
        s.inst.do_step(k as f64 * DT, DT, true).expect("fmi2DoStep");
        s.inst.get_real(&s.outputs, &mut out).expect("fmi2GetReal");
        acc += black_box(out[0]);
    }
    acc
}

fn run(fmu: &Path, model: &Path, steps: usize) -> Result<f64, String> {
    let text = std::fs::read_to_string(model).map_err(|e| format!("{}: {e}", model.display()))?;
    let spec = ModelSpec::parse(&text, &model.display().to_string()).map_err(|e| e.to_string())?;
    let vars = VarTable::new(Kind::Plant, &spec)?;
    let vr = |name: &str| {
        vars.by_name(name)
            .map(|v| v.vr)
            .ok_or_else(|| format!("plant FMU has no variable {name}"))
    };
    let imp: Fmi2Import =
        fmi::import::from_path(fmu).map_err(|e| format!("{}: {e}", fmu.display()))?;
    let inst = imp
        .instantiate_cs("count", false, false)
        .map_err(|e| format!("fmi2Instantiate: {e}"))?;
    let mut s = Slave {
        inst,
        inputs: [vr("x_cr")?, vr("y_cr")?],
        outputs: [vr("zmp_x")?, vr("zmp_y")?, vr("x_c")?, vr("y_c")?],
    };
    let mut base = [0.0; 2];
    s.inst
        .get_real(&s.inputs, &mut base)
        .map_err(|e| format!("fmi2GetReal: {e}"))?;
    FmiInstance::enter_initialization_mode(&mut s.inst, None, 0.0, None)
        .map_err(|e| format!("fmi2EnterInitializationMode: {e}"))?;
    FmiInstance::exit_initialization_mode(&mut s.inst)
        .map_err(|e| format!("fmi2ExitInitializationMode: {e}"))?;
    let table: Vec<[f64; 2]> = (0..TABLE)
        .map(|k| {
            let t = k as f64 * DT;
            [
                base[0] + 0.01 * (6.0 * t).sin(),
                base[1] + 0.008 * (4.6 * t).sin(),
            ]
        })
        .collect();
    let warm_up = 1000;
    // Warm-up through the same calls, outside the counted function.
    let mut out = [0.0; 4];
    for k in 0..warm_up {
        s.inst
            .set_real(&s.inputs, &table[k & (TABLE - 1)])
            .and_then(|_| s.inst.do_step(k as f64 * DT, DT, true))
            .and_then(|_| s.inst.get_real(&s.outputs, &mut out))
            .map_err(|e| format!("warm-up step {k}: {e}"))?;
    }
    let t = Instant::now();
    black_box(count_loop_fmu_do_step(&mut s, &table, warm_up, steps));
    Ok(t.elapsed().as_secs_f64())
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().collect();
    let (fmu, model, steps) = match args.as_slice() {
        [_, fmu, model] => (fmu, model, 100_000),
        [_, fmu, model, steps] => match steps.parse() {
            Ok(n) => (fmu, model, n),
            Err(_) => {
                eprintln!("steps must be a whole number, got {steps:?}");
                return ExitCode::from(2);
            }
        },
        _ => {
            eprintln!("usage: fmu_count PLANT.fmu MODEL.toml [steps]");
            return ExitCode::from(2);
        }
    };
    match run(Path::new(fmu), Path::new(model), steps) {
        Ok(seconds) => {
            println!(
                "fmu_do_step/plant_fmi2: {steps} steps, {:.1} ns/step (wall clock)",
                seconds * 1e9 / steps as f64
            );
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("fmu_count: {e}");
            ExitCode::FAILURE
        }
    }
}
