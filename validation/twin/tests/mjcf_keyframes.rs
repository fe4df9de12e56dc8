//! Both MJCF files stand for 2 s from their keyframe `stand` (and from the pose they load in),
//! read and simulated by MuJoCo's own Python bindings (`tests/python/stand.py`), not by the twin
//! code: a file that loads with its soles in the floor (sabian.xml before its keyframe: 5 cm,
//! thrown 0.76 m up) or that tips, slides or keeps moving fails here.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The venv's Python: `ZMP_PYTHON`, else `$HOME/.cache/zmp-toolkit/venv/bin/python`. Fails the
/// test (never skips) when it is missing.
fn python() -> PathBuf {
    let p = std::env::var_os("ZMP_PYTHON")
        .map(PathBuf::from)
        .or_else(|| {
            std::env::var_os("HOME")
                .map(|h| PathBuf::from(h).join(".cache/zmp-toolkit/venv/bin/python"))
        })
        .expect("neither ZMP_PYTHON nor HOME is set");
    assert!(
        p.exists(),
        "Python with MuJoCo not found at {}: run `cargo xtask setup` (or set ZMP_PYTHON)",
        p.display()
    );
    p
}

#[test]
fn sabian_and_silo2_stand_for_2_s_from_their_keyframes_in_mujoco_python() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python/stand.py");
    let starts: Vec<String> = ["sabian.xml", "silo2.xml"]
        .iter()
        .flat_map(|f| {
            let p = root.join("models/mjcf").join(f);
            ["stand", "qpos0"].map(|s| format!("{}:{s}", p.display()))
        })
        .collect();
    let out = Command::new(python())
        .arg(&script)
        .arg("2.0")
        .args(&starts)
        .output()
        .expect("run the Python script");
    assert!(
        out.status.success(),
        "{} failed: {}",
        script.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    let rows: Vec<serde_json::Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(rows.len(), starts.len(), "{text}");
    for r in &rows {
        let f = |k: &str| {
            r[k].as_f64()
                .unwrap_or_else(|| panic!("{k} missing in {r}"))
        };
        let what = format!("{} from {}", r["file"], r["start"]);
        assert!(f("simulated_s") >= 2.0 - 1e-9, "{what}: {r}");
        // The soles start on the floor, not in it.
        assert!(f("initial_penetration_m") < 1e-4, "{what}: {r}");
        // Standing still: a fall or a throw moves the base by decimetres; the servos' sag and
        // the contacts' 5 ms softness by tenths of a millimetre.
        assert!(f("max_base_height_change_m") < 1e-3, "{what}: {r}");
        assert!(f("max_penetration_m") < 1e-3, "{what}: {r}");
        assert!(f("max_tilt_deg") < 0.5, "{what}: {r}");
        assert!(f("max_com_drift_m") < 1e-3, "{what}: {r}");
        // Both feet flat on the floor (a box on a plane: 4 corner contacts each) and at rest.
        assert!(r["final_contacts"].as_u64().unwrap() >= 8, "{what}: {r}");
        assert!(f("final_max_speed") < 1e-3, "{what}: {r}");
    }
}
