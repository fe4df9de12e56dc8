//! The real-time steps allocate nothing: `Plant::step` with every effect of the registry on
//! (a random `Delta` realisation included) and `CascadeController::step`, over 10,000 steps.
//!
//! A counting global allocator counts per thread, and only on threads that switched counting
//! on: the test harness and the other tests allocate on their own threads meanwhile.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::f64::consts::PI;
use std::sync::atomic::{AtomicUsize, Ordering};
use zmp_models::controller::{CascadeController, CascadeParams};
use zmp_models::EffectKind;
use zmp_models::{Binding, Channel, ModelSpec, Plant, REGISTRY};

struct Counting;

thread_local! {
    static COUNTING: Cell<bool> = const { Cell::new(false) };
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

/// Allocations on every thread, counting or not: shows the allocator is in use.
static ALL_ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

fn count() {
    ALL_ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
    if COUNTING.try_with(|c| c.get()).unwrap_or(false) {
        let _ = ALLOCATIONS.try_with(|n| n.set(n.get() + 1));
    }
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count();
        System.alloc(layout)
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        count();
        System.alloc_zeroed(layout)
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count();
        System.realloc(ptr, layout, new_size)
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        System.dealloc(ptr, layout)
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Allocations made by `f` on this thread.
fn allocations_in(f: impl FnOnce()) -> usize {
    let before = ALLOCATIONS.with(|n| n.get());
    COUNTING.with(|c| c.set(true));
    f();
    COUNTING.with(|c| c.set(false));
    ALLOCATIONS.with(|n| n.get()) - before
}

const PAPER: &str = include_str!("../params/silo2-paper.toml");
const EXTRA: &str = r#"
[acceleration_saturation]
limit = 1.5
[coulomb_friction]
level = 0.1
[time_delay]
delay = 0.0125
[backlash]
width = 0.002
[operating_point_dependence]
da_dx = 0.5
db_dy = -0.3
[structural_mode]
omega_n = 60.0
zeta = 0.05
[flexible_trunk]
omega_n = 40.0
zeta = 0.05
share = 0.3
[sensor_lowpass]
cutoff = 100.0
[sensor_drift]
offset = 0.001
rate = 1e-5
"#;

fn all_effects_plant() -> Plant {
    let mut spec = ModelSpec::parse(&format!("{PAPER}{EXTRA}"), "all.toml").unwrap();
    for (n, ch) in Channel::ALL.iter().enumerate() {
        assert!(spec.set_value(EffectKind::Uncertainty, Binding::Channel(*ch), "delta", 0.8));
        assert!(spec.set_value(
            EffectKind::Uncertainty,
            Binding::Channel(*ch),
            "delta_seed",
            5.0 + n as f64
        ));
    }
    for info in REGISTRY.iter() {
        assert!(spec.has(info.kind), "the model lacks {}", info.kind);
    }
    Plant::new(&spec, 1e-3).unwrap()
}

#[test]
fn the_counter_counts() {
    let n = allocations_in(|| {
        let v: Vec<f64> = std::hint::black_box(vec![1.0; 16]);
        drop(v);
    });
    assert!(n >= 1, "a Vec allocation went uncounted");
    assert!(ALL_ALLOCATIONS.load(Ordering::Relaxed) >= n);
    // Not counting: not counted.
    COUNTING.with(|c| c.set(false));
    let before = ALLOCATIONS.with(|n| n.get());
    drop(std::hint::black_box(vec![0u8; 64]));
    assert_eq!(ALLOCATIONS.with(|n| n.get()), before);
}

#[test]
fn plant_step_with_every_effect_allocates_nothing() {
    let mut plant = all_effects_plant();
    let op = [0.03, -0.01];
    plant.set_operating_point(op);
    plant.reset(op);
    let (mut saturated, mut still, mut sum) = (0, 0, 0.0);
    let n = allocations_in(|| {
        for k in 1..=10_000 {
            let t = k as f64 * 1e-3;
            // Large and fast enough to saturate, slow parts that stop inside the backlash.
            let r = [
                op[0] + 0.05 * (2.0 * PI * 1.5 * t).sin(),
                op[1] + 0.0008 * (2.0 * PI * 0.5 * t).sin(),
            ];
            let out = plant.step(r);
            if out.com_acceleration[0].abs() >= 1.5 {
                saturated += 1;
            }
            if out.com_acceleration[1].abs() < 1e-9 {
                still += 1;
            }
            sum += out.zmp[0] + out.zmp[1];
        }
        sum += plant.advance([0.0, 0.0], 100).zmp[0];
    });
    assert_eq!(n, 0, "plant.step allocated {n} times");
    assert!(sum.is_finite());
    // The nonlinear paths were taken: saturation, and the backlash holding an axis still.
    assert!(saturated > 100, "saturated in {saturated} steps");
    assert_eq!(still, 10_000, "the y reference stays inside the play");
}

#[test]
fn controller_step_allocates_nothing() {
    let mut ctrl = CascadeController::new(CascadeParams::silo2(), 0.01);
    ctrl.reset_to_com([0.14, 0.0]);
    let mut sum = 0.0;
    let n = allocations_in(|| {
        for k in 0..10_000 {
            let t = k as f64 * 0.01;
            let zmp = [0.15 + 0.01 * (0.3 * t).sin(), 0.002 * (0.7 * t).cos()];
            let com = ctrl.step([0.17, 0.0], zmp);
            sum += com[0] + com[1];
        }
    });
    assert_eq!(n, 0, "controller step allocated {n} times");
    assert!(sum.is_finite());
}
