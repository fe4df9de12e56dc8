//! FMU benchmarks.
//!
//! - `fmu_step_rust_importer/*`: one 1 ms communication step through the Rust `fmi` crate
//!   (fmi2SetReal of the 2 inputs, fmi2DoStep, fmi2GetReal of the 4 outputs): the plant FMU
//!   (FMI 2.0 and 3.0, one internal sub-step per communication step), the trivial pass-through
//!   FMU, and the in-process `Plant::advance` for reference. Target: at least 5 million plant
//!   steps per second (<= 200 ns per step).
//! - FMPy: the per-step cost of the plant FMU against the pass-through FMU in the same run
//!   (`fmu/tests/python/overhead.py`, printed after the criterion groups). Target: < 10 %.
//!
//! The FMUs of `models/params/silo2-paper.toml` are built first (release) into
//! `<target>/fmu-bench`. Python: `ZMP_PYTHON`, else the venv of `cargo xtask setup`.

use criterion::{black_box, criterion_group, Criterion, Throughput};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use zmp_fmu_core::package::{build_fmus, BuildOptions};
use zmp_fmu_core::{FmiVersion, Kind, VarTable};
use zmp_models::{ModelSpec, Plant};

const DT: f64 = 1e-3;

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn model() -> PathBuf {
    workspace().join("models/params/silo2-paper.toml")
}

fn target_dir() -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            let exe = std::env::current_exe().unwrap();
            exe.ancestors().nth(3).unwrap().to_path_buf()
        })
}

fn fmu_dir() -> &'static Path {
    static D: OnceLock<PathBuf> = OnceLock::new();
    D.get_or_init(|| {
        let dir = target_dir().join("fmu-bench");
        let opts = BuildOptions {
            release: true,
            fmi3: true,
            passthrough: true,
            force: true,
            target_dir: Some(target_dir()),
        };
        build_fmus(&model(), &dir, &opts).expect("building the FMUs");
        dir
    })
}

fn fmu(kind: Kind, fmi: FmiVersion) -> PathBuf {
    fmu_dir().join(format!("{}.fmu", kind.model_identifier(fmi)))
}

fn spec() -> ModelSpec {
    ModelSpec::parse(
        &std::fs::read_to_string(model()).unwrap(),
        "silo2-paper.toml",
    )
    .unwrap()
}

fn vrs(kind: Kind, names: &[&str]) -> Vec<u32> {
    let t = VarTable::new(kind, &spec()).unwrap();
    names.iter().map(|n| t.by_name(n).unwrap().vr).collect()
}

/// Input table: CoM-reference sines around the FMU's start values.
fn inputs(base: [f64; 2]) -> Vec<[f64; 2]> {
    (0..4096)
        .map(|k| {
            let t = k as f64 * DT;
            [
                base[0] + 0.01 * (6.0 * t).sin(),
                base[1] + 0.008 * (4.6 * t).sin(),
            ]
        })
        .collect()
}

fn rust_importer(c: &mut Criterion) {
    use fmi::traits::FmiInstance;
    let mut g = c.benchmark_group("fmu_step_rust_importer");
    g.throughput(Throughput::Elements(1));

    for (label, kind, ins, outs) in [
        (
            "plant_fmi2",
            Kind::Plant,
            ["x_cr", "y_cr"],
            ["zmp_x", "zmp_y", "x_c", "y_c"],
        ),
        (
            "passthrough_fmi2",
            Kind::Passthrough,
            ["u1", "u2"],
            ["y1", "y2", "y3", "y4"],
        ),
    ] {
        use fmi::fmi2::instance::{CoSimulation, Common};
        let imp: fmi::fmi2::import::Fmi2Import =
            fmi::import::from_path(fmu(kind, FmiVersion::V2)).unwrap();
        let mut inst = imp.instantiate_cs("bench", false, false).unwrap();
        let (vin, vout) = (vrs(kind, &ins), vrs(kind, &outs));
        let mut base = [0.0; 2];
        inst.get_real(&vin, &mut base).unwrap();
        FmiInstance::enter_initialization_mode(&mut inst, None, 0.0, None).unwrap();
        FmiInstance::exit_initialization_mode(&mut inst).unwrap();
        let table = inputs(base);
        let mut out = [0.0; 4];
        let mut k = 0usize;
        g.bench_function(label, |b| {
            b.iter(|| {
                let u = &table[k % table.len()];
                inst.set_real(&vin, black_box(u)).unwrap();
                inst.do_step(k as f64 * DT, DT, true).unwrap();
                inst.get_real(&vout, &mut out).unwrap();
                k += 1;
                black_box(&out);
            })
        });
    }

    {
        use fmi::fmi3::{CoSimulation, Fmi3Model, GetSet};
        let imp: fmi::fmi3::import::Fmi3Import =
            fmi::import::from_path(fmu(Kind::Plant, FmiVersion::V3)).unwrap();
        let mut inst = imp
            .instantiate_cs("bench", false, false, false, false, &[])
            .unwrap();
        let plus1 = |v: Vec<u32>| v.into_iter().map(|x| x + 1).collect::<Vec<_>>();
        let vin = plus1(vrs(Kind::Plant, &["x_cr", "y_cr"]));
        let vout = plus1(vrs(Kind::Plant, &["zmp_x", "zmp_y", "x_c", "y_c"]));
        let mut base = [0.0; 2];
        inst.get_float64(&vin, &mut base).unwrap();
        inst.enter_initialization_mode(None, 0.0, None).unwrap();
        inst.exit_initialization_mode().unwrap();
        let table = inputs(base);
        let mut out = [0.0; 4];
        let mut k = 0usize;
        let (mut ev, mut term, mut early, mut last) = (false, false, false, 0.0);
        g.bench_function("plant_fmi3", |b| {
            b.iter(|| {
                let u = &table[k % table.len()];
                inst.set_float64(&vin, black_box(u)).unwrap();
                inst.do_step(
                    k as f64 * DT,
                    DT,
                    true,
                    &mut ev,
                    &mut term,
                    &mut early,
                    &mut last,
                )
                .unwrap();
                inst.get_float64(&vout, &mut out).unwrap();
                k += 1;
                black_box(&out);
            })
        });
    }

    {
        let mut plant = Plant::new(&spec(), DT).unwrap();
        let base = zmp_fmu_core::vars::initial_operating_point(&spec())
            .unwrap()
            .0;
        plant.reset(base);
        let table = inputs(base);
        let mut k = 0usize;
        g.bench_function("plant_in_process", |b| {
            b.iter(|| {
                let o = plant.advance(black_box(table[k % table.len()]), 1);
                k += 1;
                black_box(o);
            })
        });
    }
    g.finish();
}

fn python() -> PathBuf {
    let p = std::env::var_os("ZMP_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            PathBuf::from(std::env::var_os("HOME").expect("HOME"))
                .join(".cache/zmp-toolkit/venv/bin/python")
        });
    assert!(
        p.exists(),
        "Python with FMPy not found at {}: run `cargo xtask setup` (or set ZMP_PYTHON)",
        p.display()
    );
    p
}

/// The FMPy comparison (not a criterion measurement: the loop is Python's).
fn fmpy_overhead() {
    let script = workspace().join("fmu/tests/python/overhead.py");
    let out = std::process::Command::new(python())
        .arg(script)
        .arg(fmu(Kind::Plant, FmiVersion::V2))
        .arg(fmu(Kind::Passthrough, FmiVersion::V2))
        .args(["20000", "7"])
        .output()
        .expect("running python");
    assert!(
        out.status.success(),
        "overhead.py failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    println!("\nFMPy, per 1 ms communication step (min of 7 interleaved rounds of 20,000 steps):");
    for loop_ in ["simulate_fmu", "slave"] {
        let r = &v[loop_];
        println!(
            "  {loop_:<13} plant {:6.2} us   trivial {:6.2} us   plant adds {:+5.1} %  (target < 10 %)",
            r["plant_us_per_step"].as_f64().unwrap(),
            r["trivial_us_per_step"].as_f64().unwrap(),
            100.0 * r["overhead"].as_f64().unwrap()
        );
    }
    // Into the history of `cargo xtask bench`: the plant FMU against the trivial pass-through
    // FMU, both in FMPy's slave loop (ratio = trivial / plant: 1 means the physics costs nothing
    // next to FMPy's own per-step cost), and FMPy's step against ours through the Rust importer.
    let slave = &v["slave"];
    let (plant_s, trivial_s) = (
        slave["plant_us_per_step"].as_f64().unwrap() * 1e-6,
        slave["trivial_us_per_step"].as_f64().unwrap() * 1e-6,
    );
    zmp_bench::report_peer(
        "fmu_step/fmpy_plant_vs_trivial",
        plant_s,
        trivial_s,
        "step",
        "plant FMU against the trivial FMU, both in FMPy's FMU2Slave loop (min of 7 rounds of \
         20,000 steps); ratio = trivial / plant",
    );
    let estimates =
        target_dir().join("criterion/fmu_step_rust_importer/plant_fmi2/new/estimates.json");
    if let Some(ours_ns) = std::fs::read_to_string(&estimates)
        .ok()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
        .and_then(|v| v["median"]["point_estimate"].as_f64())
    {
        zmp_bench::report_peer(
            "fmu_step/rust_importer_vs_fmpy",
            ours_ns * 1e-9,
            plant_s,
            "step",
            "plant FMU step through the Rust `fmi` importer (criterion median) against the same \
             FMU in FMPy's FMU2Slave loop",
        );
    }
}

criterion_group!(benches, rust_importer);

fn main() {
    benches();
    Criterion::default().configure_from_args().final_summary();
    // `cargo test --benches` runs benches in test mode: skip the slow Python comparison there.
    if !std::env::args().any(|a| a == "--test" || a == "--list") {
        fmpy_overhead();
    }
}
