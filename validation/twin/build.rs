//! mujoco-rs links `libmujoco.so` from `$MUJOCO_DYNAMIC_LINK_DIR` but sets no run path: put that
//! directory in the run path of every binary and test of this crate, so that they run without
//! `LD_LIBRARY_PATH`.

fn main() {
    println!("cargo::rerun-if-env-changed=MUJOCO_DYNAMIC_LINK_DIR");
    match std::env::var("MUJOCO_DYNAMIC_LINK_DIR") {
        Ok(dir) if std::path::Path::new(&dir).is_absolute() => {
            println!("cargo::rustc-link-arg=-Wl,-rpath,{dir}");
        }
        Ok(dir) => panic!(
            "MUJOCO_DYNAMIC_LINK_DIR must be an absolute path holding libmujoco.so ('{dir}' is \
             not absolute); `cargo xtask setup` prints the right one"
        ),
        Err(_) => panic!(
            "MUJOCO_DYNAMIC_LINK_DIR is not set: the MuJoCo twin crate (zmp-twin) needs MuJoCo \
             3.17.0. Run `cargo xtask setup` and build it through `cargo xtask validate` (or \
             export MUJOCO_DYNAMIC_LINK_DIR=<deps>/mujoco-3.17.0/lib)"
        ),
    }
}
