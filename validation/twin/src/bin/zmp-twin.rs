//! `zmp-twin`: the MuJoCo twins on the command line, one subcommand family per robot.
//! `cargo xtask validate <robot>` runs it with the prerequisites' environment.

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;
use zmp_twin::silo2::{self, campaign::TwinDesign, validate};

#[derive(Parser)]
#[command(
    name = "zmp-twin",
    about = "MuJoCo twins of the seeds' robots: campaigns, identification, closed loop and \
             diagnosis on a physics engine (MuJoCo 3.17.0)"
)]
struct Cli {
    #[command(subcommand)]
    robot: Robot,
}

#[derive(Subcommand)]
enum Robot {
    /// The SILO2 twin of the first seed (models/mjcf/silo2.xml): 14-DOF biped in double
    /// support whose 2-DOF trunk moves the centre of mass.
    Silo2 {
        #[command(subcommand)]
        cmd: Silo2Cmd,
    },
    /// The SABIAN twin of the second seed (models/mjcf/sabian.xml): effective centre of mass
    /// from the two ankle force/torque sensors and the n/r/s/v walking comparison.
    Sabian {
        #[command(subcommand)]
        command: zmp_twin::sabian::cli::SabianCommand,
    },
}

#[derive(Subcommand)]
enum Silo2Cmd {
    /// Everything: mass properties and their predictions, the ZMP cross-checks and the
    /// contact-softness budget, the stepped-sine campaign and its identification, the closed
    /// loop against the identified model, the diagnosis, frames and an HTML report
    /// (OUT/report.html, OUT/summary.json).
    Validate {
        /// Output folder. It is built aside and renamed into place; an existing one is replaced
        /// only with --force and only if an earlier run of this command wrote it.
        #[arg(long, default_value = "out/twin-silo2")]
        out: PathBuf,
        /// The short version (CI and the demo): a 10-record campaign instead of 144, a shorter
        /// softness budget; the closed loop and the checks are the same.
        #[arg(long)]
        short: bool,
        /// The campaign extended to 50 rad/s (240 records: 96 more, 0.1 and 0.2 mm of CoM from
        /// 14 to 50 rad/s), to tell the stance resonance from an in-band surrogate.
        #[arg(long, conflicts_with = "short")]
        extended: bool,
        /// Replace OUT if it holds an earlier validation.
        #[arg(long)]
        force: bool,
        /// Print summary.json on standard output (and no progress).
        #[arg(long)]
        json: bool,
        /// The twin's model file (MJCF).
        #[arg(long, default_value_os_t = silo2::default_mjcf())]
        model: PathBuf,
        /// Worker threads (default: the available cores).
        #[arg(long)]
        threads: Option<usize>,
        /// Do not render frames of the robot.
        #[arg(long)]
        no_frames: bool,
        /// Delay of the ZMP measurement, s (0 to 1; the campaign states it in campaign.toml's
        /// `robot` field; the closed loop's controller sees the same sensor).
        #[arg(long, default_value_t = 0.0)]
        zmp_delay: f64,
        /// Why frames cannot be rendered on this machine (set by `cargo xtask validate` when it
        /// builds without the `renderer` feature); written into the report.
        #[arg(long, hide = true)]
        frames_unavailable: Option<String>,
        /// Also write this run's numbers into the book page at PATH (docs/src/twin-silo2.md),
        /// between its `<!-- twin-silo2:... -->` markers (the full run only: the page quotes it).
        #[arg(long, value_name = "PATH", conflicts_with_all = ["short", "extended"])]
        readme: Option<PathBuf>,
    },
    /// Only the stepped-sine campaign (zmp-campaign/1) into OUT.
    Campaign {
        /// Campaign folder to write.
        #[arg(long)]
        out: PathBuf,
        /// The short campaign (10 records) instead of the full one (144).
        #[arg(long)]
        short: bool,
        /// The full campaign extended to 50 rad/s (240 records).
        #[arg(long, conflicts_with = "short")]
        extended: bool,
        /// Replace an existing campaign folder.
        #[arg(long)]
        force: bool,
        /// Print a machine-readable summary.
        #[arg(long)]
        json: bool,
        /// The twin's model file (MJCF).
        #[arg(long, default_value_os_t = silo2::default_mjcf())]
        model: PathBuf,
        /// Worker threads (default: the available cores).
        #[arg(long)]
        threads: Option<usize>,
        /// Delay of the ZMP measurement, s (0 to 1; stated in campaign.toml's `robot` field).
        #[arg(long, default_value_t = 0.0)]
        zmp_delay: f64,
    },
    /// The twin's mass properties and what they predict for the seed's model at the campaign's
    /// operating points (no dynamics simulated).
    Predict {
        /// Print JSON.
        #[arg(long)]
        json: bool,
        /// The twin's model file (MJCF).
        #[arg(long, default_value_os_t = silo2::default_mjcf())]
        model: PathBuf,
    },
    /// Render frames of the given postures (used by `validate` in a child process).
    #[command(hide = true)]
    RenderFrames {
        #[arg(long)]
        model: PathBuf,
        /// JSON list of {t, qpos, loaded}.
        #[arg(long)]
        states: PathBuf,
        #[arg(long)]
        out: PathBuf,
    },
}

fn threads(n: Option<usize>) -> usize {
    n.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |w| w.get()))
        .max(1)
}

fn frames(no_frames: bool, unavailable: Option<String>) -> validate::Frames {
    if no_frames {
        return validate::Frames::Skip("frames not rendered: --no-frames".into());
    }
    if let Some(why) = unavailable {
        return validate::Frames::Skip(format!("frames not rendered: {why}"));
    }
    if !cfg!(feature = "renderer") {
        return validate::Frames::Skip(
            "frames not rendered: this build of zmp-twin has no `renderer` feature".into(),
        );
    }
    match std::env::current_exe() {
        Ok(exe) => validate::Frames::Render { exe },
        Err(e) => validate::Frames::Skip(format!("frames not rendered: {e}")),
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.robot {
        Robot::Sabian { command } => zmp_twin::sabian::cli::run(command),
        Robot::Silo2 { cmd } => match cmd {
            Silo2Cmd::Validate {
                out,
                short,
                extended,
                force,
                json,
                model,
                threads: n,
                no_frames,
                zmp_delay,
                frames_unavailable,
                readme,
            } => {
                // Checked before the run: a README without the markers fails in seconds.
                if let Some(p) = &readme {
                    let text = std::fs::read_to_string(p)
                        .with_context(|| format!("reading {}", p.display()))?;
                    for (tag, _) in silo2::readme::TAGS.iter().map(|t| (t, ())) {
                        if !text.contains(&format!("<!-- {tag} -->\n")) {
                            anyhow::bail!("{}: no marker `<!-- {tag} -->`", p.display());
                        }
                    }
                }
                let summary = validate::validate(&validate::ValidateOptions {
                    model,
                    out,
                    short,
                    extended,
                    force,
                    threads: threads(n),
                    quiet: json,
                    frames: frames(no_frames, frames_unavailable),
                    zmp_delay,
                })?;
                if let Some(p) = &readme {
                    silo2::readme::write(p, &silo2::readme::sections(&summary))
                        .map_err(anyhow::Error::msg)?;
                    if !json {
                        println!("README sections -> {}", p.display());
                    }
                }
                if json {
                    println!("{}", serde_json::to_string_pretty(&summary)?);
                }
                Ok(())
            }
            Silo2Cmd::Campaign {
                out,
                short,
                extended,
                force,
                json,
                model,
                threads: n,
                zmp_delay,
            } => {
                let twin = silo2::Silo2::load(&model)?;
                let props = silo2::props::mass_properties(&twin)?;
                let mut design = if short {
                    TwinDesign::short()
                } else if extended {
                    TwinDesign::extended()
                } else {
                    TwinDesign::full()
                };
                design.sensor.delay = zmp_delay;
                let pb = if json {
                    indicatif::ProgressBar::hidden()
                } else {
                    indicatif::ProgressBar::new(design.records().len() as u64)
                };
                let camp =
                    silo2::campaign::run_campaign(&twin, &props, &design, threads(n), &|d| {
                        pb.set_position(d as u64)
                    })?;
                pb.finish_and_clear();
                zmp_campaign::write_campaign(&out, &camp, force)
                    .with_context(|| format!("writing {}", out.display()))?;
                let rows: usize = camp.records.iter().map(|r| r.len()).sum();
                if json {
                    println!(
                        "{}",
                        serde_json::json!({"campaign": out, "records": camp.records.len(), "rows": rows})
                    );
                } else {
                    println!(
                        "wrote {} records ({rows} rows) to {}",
                        camp.records.len(),
                        out.display()
                    );
                }
                Ok(())
            }
            Silo2Cmd::Predict { json, model } => {
                let twin = silo2::Silo2::load(&model)?;
                let props = silo2::props::mass_properties(&twin)?;
                let preds = TwinDesign::full()
                    .operating_points
                    .iter()
                    .map(|&op| silo2::props::predict(&twin, &props, op))
                    .collect::<Result<Vec<_>, _>>()?;
                if json {
                    println!(
                        "{}",
                        serde_json::to_string_pretty(
                            &serde_json::json!({"mass": props, "predictions": preds})
                        )?
                    );
                } else {
                    println!(
                        "mass {:.3} kg, trunk {:.3} kg (m_t/m_r {:.4}), l_t {:.4} m, CoM height {:.4} m",
                        props.total_mass,
                        props.trunk_mass,
                        props.trunk_mass_ratio,
                        props.trunk_lever,
                        props.com_upright[2]
                    );
                    for p in &preds {
                        println!(
                            "op ({:+.3}, {:+.3}) m: seed a = 1, b = {:.5}; multibody a11 {:.4} b11 {:.5} \
                             a22 {:.4} b22 {:.5}; with the servos a11 {:.4} b11 {:.5} a22 {:.4} b22 {:.5}; \
                             omega_n {:.3}, zeta {:.4}",
                            p.com_ref[0],
                            p.com_ref[1],
                            p.seed.b[0][0],
                            p.multibody.a[0][0],
                            p.multibody.b[0][0],
                            p.multibody.a[1][1],
                            p.multibody.b[1][1],
                            p.servo.a[0][0],
                            p.servo.b[0][0],
                            p.servo.a[1][1],
                            p.servo.b[1][1],
                            p.omega_n[0],
                            p.zeta[0]
                        );
                    }
                }
                Ok(())
            }
            Silo2Cmd::RenderFrames { model, states, out } => render_frames(&model, &states, &out),
        },
    }
}

#[cfg(feature = "renderer")]
fn render_frames(
    model: &std::path::Path,
    states: &std::path::Path,
    out: &std::path::Path,
) -> Result<()> {
    let twin = silo2::Silo2::load(model)?;
    let text =
        std::fs::read_to_string(states).with_context(|| format!("reading {}", states.display()))?;
    let states: Vec<validate::FrameState> =
        serde_json::from_str(&text).with_context(|| format!("parsing {}", states.display()))?;
    let files = zmp_twin::render::render_frames(&twin, "front", &states, out)?;
    println!("{}", serde_json::to_string(&files)?);
    Ok(())
}

#[cfg(not(feature = "renderer"))]
fn render_frames(_: &std::path::Path, _: &std::path::Path, _: &std::path::Path) -> Result<()> {
    anyhow::bail!("this build of zmp-twin has no `renderer` feature")
}

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            for cause in e.chain().skip(1) {
                eprintln!("  caused by: {cause}");
            }
            ExitCode::FAILURE
        }
    }
}
