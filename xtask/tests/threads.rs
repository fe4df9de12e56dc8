//! `--threads N` (a global option): identify and diagnose give the same results on one thread
//! as on the default pool, and a zero is refused with a message naming the option.

mod support;

use std::path::Path;
use support::{ok, xtask};

#[test]
fn one_thread_gives_the_same_results_and_zero_is_refused() {
    let tmp = std::env::temp_dir().join(format!("zmp-threads-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&tmp);
    std::fs::create_dir_all(&tmp).unwrap();
    let design = tmp.join("design.toml");
    std::fs::write(
        &design,
        "operating_points = [[0.0, 0.0]]\namplitudes = [0.003, 0.008]\n\
         omegas = [0.5, 1.5, 4.0, 9.0, 14.0]\nexcited = [\"x\", \"y\"]\n\
         sample_rate_hz = 200.0\ntransient_s = 3.0\nperiods = 4\nmin_steady_s = 8.0\n\
         zmp_noise_std = 0.0005\nquantisation = 0.0001\nseed = 7\n",
    )
    .unwrap();
    let model = Path::new(env!("CARGO_MANIFEST_DIR")).join("../models/params/silo2-paper.toml");
    let m = model.to_str().unwrap();
    ok(
        xtask(
            &[
                "simulate",
                "--model",
                m,
                "--design",
                "design.toml",
                "--out",
                "camp",
            ],
            &tmp,
        ),
        "simulate",
    );
    let identify = |threads: &[&str], out: &str| {
        let mut args = threads.to_vec();
        args.extend(["identify", "camp", "--out", out, "--json"]);
        ok(xtask(&args, &tmp), "identify")
    };
    let pool = identify(&[], "pool.toml");
    let one = identify(&["--threads", "1"], "one.toml");
    assert!(pool.contains("\"parameters\""), "no parameters in {pool}");
    assert_eq!(one, pool.replace("pool.toml", "one.toml"));
    let diagnose = |threads: &[&str]| {
        let mut args = threads.to_vec();
        args.extend(["diagnose", "camp", "--model", "pool.toml", "--json"]);
        ok(xtask(&args, &tmp), "diagnose")
    };
    assert_eq!(diagnose(&["--threads", "1"]), diagnose(&[]));
    let zero = xtask(&["--threads", "0", "identify", "camp"], &tmp);
    assert!(!zero.status.success());
    let msg = String::from_utf8_lossy(&zero.stderr);
    assert!(msg.contains("--threads"), "{msg}");
    let _ = std::fs::remove_dir_all(&tmp);
}
