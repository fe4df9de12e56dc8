//! `models/mjcf/silo2.xml` stands for 2 s from its keyframe `stand`, read and stepped by an
//! independent reader: MuJoCo's own Python bindings (`$ZMP_PYTHON`, mujoco 3.17.0, installed by
//! `cargo xtask setup`), which share nothing with this crate's Rust bindings but the library.
//! The same 2 s through `zmp_twin` must end in the same state.

use std::path::PathBuf;
use std::process::Command;
use zmp_twin::silo2::{default_mjcf, Silo2, STEP};

/// Loads the file, resets to the keyframe with every servo holding zero (the keyframe's joint
/// angles), steps 2 s and reports what a standing robot must show.
const SCRIPT: &str = r#"
import json, sys
import numpy as np
import mujoco
m = mujoco.MjModel.from_xml_path(sys.argv[1])
d = mujoco.MjData(m)
mujoco.mj_resetDataKeyframe(m, d, mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, "stand"))
d.ctrl[:] = 0.0
mujoco.mj_forward(m, d)
pelvis = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "pelvis")
p0 = d.xpos[pelvis].copy()
c0 = d.subtree_com[pelvis].copy()
steps = int(round(float(sys.argv[2]) / m.opt.timestep))
max_pen, min_con = 0.0, d.ncon
for _ in range(steps):
    mujoco.mj_step(m, d)
    min_con = min(min_con, d.ncon)
    for i in range(d.ncon):
        max_pen = max(max_pen, -d.contact[i].dist)
f = np.zeros(6)
normal = 0.0
for i in range(d.ncon):
    mujoco.mj_contactForce(m, d, i, f)
    normal += f[0]
q = d.xquat[pelvis]
print(json.dumps({
    "mujoco": mujoco.__version__,
    "timestep": m.opt.timestep,
    "pelvis_start": p0.tolist(), "pelvis_end": d.xpos[pelvis].tolist(),
    "tilt_end": float(2.0 * np.arccos(min(1.0, abs(q[0])))),
    "com_start": c0.tolist(), "com_end": d.subtree_com[pelvis].tolist(),
    "min_contacts": int(min_con), "contacts_end": int(d.ncon),
    "max_penetration": float(max_pen),
    "normal_force": float(normal),
    "weight": float(np.sum(m.body_mass) * -m.opt.gravity[2]),
    "max_speed_end": float(np.max(np.abs(d.qvel))),
}))
"#;

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
        "MuJoCo's Python bindings not found at {}: run `cargo xtask setup` (or set ZMP_PYTHON)",
        p.display()
    );
    p
}

#[test]
fn silo2_stands_for_two_seconds_from_its_keyframe() {
    const SECONDS: f64 = 2.0;
    let mjcf = default_mjcf();
    let out = Command::new(python())
        .args(["-c", SCRIPT])
        .arg(&mjcf)
        .arg(SECONDS.to_string())
        .output()
        .expect("starting Python");
    assert!(
        out.status.success(),
        "the Python reader failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let r: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let f = |k: &str| r[k].as_f64().unwrap_or_else(|| panic!("{k}: {r}"));
    let v = |k: &str| -> Vec<f64> {
        r[k].as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect()
    };
    assert_eq!(r["mujoco"], "3.17.0", "the bindings the project pins");
    // Standing: all 8 sole corners on the floor throughout; the floor carries the weight
    // (0.5 %: the contact solver's residual at rest, far below a foot's lift-off); penetration
    // as the README's static check (0.012 mm at rest; 0.1 mm bound); the pelvis and the CoM do
    // not move by more than 0.1 mm, the pelvis does not tilt by more than 1e-4 rad, and the robot
    // is at rest (joint speeds below 1e-3 rad/s or m/s) at the end.
    assert_eq!(f("min_contacts"), 8.0, "{r}");
    assert!(
        (f("normal_force") / f("weight") - 1.0).abs() < 5e-3,
        "floor {} N, weight {} N",
        f("normal_force"),
        f("weight")
    );
    assert!(f("max_penetration") < 1e-4, "{r}");
    let moved = |a: &[f64], b: &[f64]| {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max)
    };
    assert!(moved(&v("pelvis_start"), &v("pelvis_end")) < 1e-4, "{r}");
    assert!(moved(&v("com_start"), &v("com_end")) < 1e-4, "{r}");
    assert!(f("tilt_end") < 1e-4, "{r}");
    assert!(f("max_speed_end") < 1e-3, "{r}");

    // The project's reader and stepper from the same keyframe end in the same state.
    let twin = Silo2::load(&mjcf).unwrap();
    assert!((f("timestep") - STEP).abs() < 1e-15);
    let mut d = twin.stand().unwrap();
    for _ in 0..(SECONDS / STEP).round() as usize {
        d.step();
    }
    let end = d.xpos()[twin.root_body];
    assert!(
        moved(&end, &v("pelvis_end")) < 1e-9,
        "zmp_twin {end:?} vs Python {:?}",
        v("pelvis_end")
    );
}
