//! `cargo xtask <verb>`: the command line for users and CI.

// The argument structs' doc comments are clap's `--help` text, byte for byte: placeholders
// such as `<campaign>` and TOML such as `[[records]]` are meant for the terminal, not for
// rustdoc's Markdown, so rustdoc's HTML and link checks do not apply to them.
#![allow(rustdoc::invalid_html_tags, rustdoc::broken_intra_doc_links)]

mod bench;
mod calibrate;
mod ci;
mod cli;
mod demo;
mod demo_com;
mod design_next;
mod diagnose;
mod env;
mod files_doc;
mod fleet;
mod fmu;
mod identify;
mod links;
mod loop_cmd;
mod robust;
mod scale;
mod setup;
mod simulate;
mod twin;

use std::process::ExitCode;

use anyhow::Result;
use clap::Parser;
use cli::Cli;

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // The error chain only; no backtrace dump even with RUST_BACKTRACE set.
            eprintln!("error: {e}");
            for cause in e.chain().skip(1) {
                eprintln!("  caused by: {cause}");
            }
            ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.threads {
        Some(n) => zmp_campaign::par::with_threads(usize::from(n), || cli.command.run()),
        None => cli.command.run(),
    }
}
