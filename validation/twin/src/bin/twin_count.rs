//! Instruction count of one SILO2 twin step, for the gate of `cargo xtask bench` (the
//! `twin_step` row of `bench/README.md`), and by hand:
//!
//! ```text
//! valgrind --tool=callgrind --toggle-collect='*count_loop*' twin_count [steps]
//! ```
//!
//! One step is the campaign's work per millisecond: the trunk servos' references (a 6 rad/s
//! sine of 0.07 rad on the lateral tilt), `mj_step` of `models/mjcf/silo2.xml`, and the ZMP
//! of the 8 load cells. The robot stands and settles for 1000 steps outside the counted
//! function; `steps` (default 10000) run inside it, so the instructions per step are the
//! collected total over `steps`. MuJoCo's own instructions are counted (callgrind follows
//! the calls into `libmujoco.so`), so the gate also sees a change of the engine. Without
//! valgrind it prints wall-clock nanoseconds per step.

use std::hint::black_box;
use std::process::ExitCode;
use std::time::Instant;
use zmp_twin::silo2::{default_mjcf, Data, Silo2, STEP};

#[inline(never)]
fn count_loop_twin_step(twin: &Silo2, d: &mut Data<'_>, k0: usize, steps: usize) -> f64 {
    let mut z = 0.0;
    for k in k0..k0 + steps {
        twin.set_trunk(d, [0.07 * (6.0 * k as f64 * STEP).sin(), 0.0]);
        d.step();
        z += twin.cells(d).zmp().map_or(0.0, |p| p[0]);
    }
    black_box(z)
}

fn main() -> ExitCode {
    let steps: usize = match std::env::args().nth(1).map(|s| s.parse()) {
        None => 10_000,
        Some(Ok(n)) if n > 0 => n,
        Some(_) => {
            eprintln!("usage: twin_count [steps > 0]");
            return ExitCode::from(2);
        }
    };
    let twin = match Silo2::load(&default_mjcf()) {
        Ok(t) => t,
        Err(e) => {
            eprintln!("twin_count: {e}");
            return ExitCode::FAILURE;
        }
    };
    let mut d = match twin.stand() {
        Ok(d) => d,
        Err(e) => {
            eprintln!("twin_count: {e}");
            return ExitCode::FAILURE;
        }
    };
    // Settle, outside the counted function.
    for _ in 0..1000 {
        twin.set_trunk(&mut d, [0.0, 0.0]);
        d.step();
    }
    let t = Instant::now();
    let z = count_loop_twin_step(&twin, &mut d, 1000, steps);
    let ns = t.elapsed().as_secs_f64() * 1e9 / steps as f64;
    if !z.is_finite() {
        eprintln!("twin_count: the load cells' ZMP is not finite");
        return ExitCode::FAILURE;
    }
    println!("twin_step: {steps} steps, {ns:.0} ns/step (wall clock; under callgrind: ignore)");
    ExitCode::SUCCESS
}
