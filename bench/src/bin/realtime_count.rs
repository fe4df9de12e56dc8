//! Instruction counts of the real-time steps, for a noise-free regression check under
//! callgrind (see `bench/README.md`):
//!
//! ```text
//! valgrind --tool=callgrind --callgrind-out-file=/tmp/cg.out \
//!     --toggle-collect='*count_loop*' target/release/realtime_count <loop> [steps]
//! ```
//!
//! `<loop>` is `plant_all_effects`, `plant_paper_nominal` or `controller`. Only the
//! `count_loop_*` function runs measured, `steps` (default 100000) times, so the instructions
//! per step are the collected total divided by `steps`. Without valgrind it prints wall-clock
//! nanoseconds per step.

use std::hint::black_box;
use std::time::Instant;
use zmp_bench::realtime::{
    all_effects_spec, com_ref_table, controller, paper_spec, settled_plant, zmp_table, TABLE,
};
use zmp_models::controller::CascadeController;
use zmp_models::Plant;

// Two functions with the same body: the linker may fold them into one symbol, which only
// matters for naming in a profile; each run measures one loop.
#[inline(never)]
fn count_loop_plant_all_effects(plant: &mut Plant, input: &[[f64; 2]], steps: usize) -> f64 {
    plant_loop(plant, input, steps)
}

#[inline(never)]
fn count_loop_plant_paper_nominal(plant: &mut Plant, input: &[[f64; 2]], steps: usize) -> f64 {
    plant_loop(plant, input, steps)
}

#[inline(always)]
fn plant_loop(plant: &mut Plant, input: &[[f64; 2]], steps: usize) -> f64 {
    let mut acc = 0.0;
    for k in 0..steps {
        acc += black_box(plant.step(black_box(input[k & (TABLE - 1)]))).zmp[0];
    }
    acc
}

#[inline(never)]
fn count_loop_controller(ctrl: &mut CascadeController, zmp: &[[f64; 2]], steps: usize) -> f64 {
    let mut acc = 0.0;
    for k in 0..steps {
        acc += black_box(ctrl.step(black_box([0.17, 0.0]), black_box(zmp[k & (TABLE - 1)])))[0];
    }
    acc
}

fn main() {
    let mut args = std::env::args().skip(1);
    let which = args.next().unwrap_or_else(|| "all".into());
    let steps: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(100_000);
    let input = com_ref_table();
    let zmp = zmp_table();
    // Setup is outside the measured functions.
    let (name, seconds, result) = match which.as_str() {
        "plant_all_effects" | "all" => {
            let mut plant = settled_plant(&all_effects_spec());
            let t = Instant::now();
            let r = count_loop_plant_all_effects(&mut plant, &input, steps);
            ("plant_step/all_effects", t.elapsed().as_secs_f64(), r)
        }
        "plant_paper_nominal" | "nominal" => {
            let mut plant = settled_plant(&paper_spec());
            let t = Instant::now();
            let r = count_loop_plant_paper_nominal(&mut plant, &input, steps);
            ("plant_step/paper_nominal", t.elapsed().as_secs_f64(), r)
        }
        "controller" => {
            let mut ctrl = controller();
            let t = Instant::now();
            let r = count_loop_controller(&mut ctrl, &zmp, steps);
            ("controller_step", t.elapsed().as_secs_f64(), r)
        }
        other => {
            eprintln!("unknown loop {other:?}: plant_all_effects, plant_paper_nominal, controller");
            std::process::exit(2);
        }
    };
    black_box(result);
    println!(
        "{name}: {steps} steps, {:.1} ns/step (wall clock)",
        seconds * 1e9 / steps as f64
    );
}
