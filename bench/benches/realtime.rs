//! Real-time cost of the hot loop: one plant step (every effect on, and the paper's nominal
//! model) and one cascade-controller step. See `bench/README.md` for the targets and for
//! tracking regressions.

use criterion::measurement::WallTime;
use criterion::{black_box, criterion_group, criterion_main, BenchmarkGroup, Criterion};
use std::time::Duration;
use zmp_bench::realtime::{
    all_effects_spec, com_ref_table, controller, paper_spec, settled_plant, zmp_table, TABLE,
};
use zmp_models::ModelSpec;

fn bench_plant(g: &mut BenchmarkGroup<'_, WallTime>, name: &str, spec: &ModelSpec) {
    let mut plant = settled_plant(spec);
    let input = com_ref_table();
    let mut k = 0usize;
    g.bench_function(name, |b| {
        b.iter(|| {
            k = (k + 1) & (TABLE - 1);
            black_box(plant.step(black_box(input[k])))
        })
    });
}

/// `plant_step/all_effects` and `plant_step/paper_nominal`.
fn plant_step(c: &mut Criterion) {
    let mut g = c.benchmark_group("plant_step");
    bench_plant(&mut g, "all_effects", &all_effects_spec());
    bench_plant(&mut g, "paper_nominal", &paper_spec());
    g.finish();
}

fn controller_step(c: &mut Criterion) {
    let mut ctrl = controller();
    let zmp = zmp_table();
    let zmp_ref = [0.17, 0.0];
    let mut k = 0usize;
    c.bench_function("controller_step", |b| {
        b.iter(|| {
            k = (k + 1) & (TABLE - 1);
            black_box(ctrl.step(black_box(zmp_ref), black_box(zmp[k])))
        })
    });
}

/// Settings for a noisy 2-core machine: 100 samples over 3 s, and a change counts only when it
/// is both over 5 % and significant at the 1 % level.
fn config() -> Criterion {
    Criterion::default()
        .sample_size(100)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(3))
        .noise_threshold(0.05)
        .significance_level(0.01)
        .confidence_level(0.99)
}

criterion_group! {
    name = realtime;
    config = config();
    targets = plant_step, controller_step
}
criterion_main!(realtime);
