//! `zmp-fmi3-controller --model-description`: the FMU's modelDescription.xml (used by `cargo xtask fmu`).

fn main() -> std::process::ExitCode {
    zmp_fmu_core::fmi3::main::<zmp_fmi3_controller::Model>()
}
