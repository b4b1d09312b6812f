//! The `haptic6d` command line.
//!
//! One module per subcommand (`tree.rs`, ...): each exports an argument type (clap derive) and a
//! `run` function returning `anyhow::Result<()>`. To add a subcommand, add its module, a variant
//! to [`Command`] and an arm to [`dispatch`]. Errors reach the user as one line (`error: ...`) with a
//! non-zero exit status; progress bars (see `progress.rs`) only show on a terminal.

mod bench;
mod bench_contact;
mod bench_friction;
mod bench_peer;
mod bench_plot;
mod bench_report;
mod bench_speed;
mod plot;
mod progress;
mod run;
mod serve;
mod stability;
mod tree;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// 6-DoF haptic rendering with sphere-trees and small QPs.
#[derive(Parser)]
#[command(name = "haptic6d", version, about, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Sphere-trees: build one from a mesh, or measure how well one fits a mesh.
    #[command(subcommand)]
    Tree(tree::TreeCommand),
    /// Run the haptic pipeline on a scene and write frames.csv, summary.json and plots.
    Run(run::RunArgs),
    /// The paper's experiments: every solver on identical recorded input, plus scaling, hand-speed, contact and friction studies, and the rapier3d peer.
    Bench(bench::BenchArgs),
    /// Interactive viewer: the haptic loop at 1 kHz, a web page and a UDP device bridge.
    Serve(serve::ServeArgs),
    /// Closed-loop stability with the emulated hand: the largest stable coupling stiffness per scene and rate.
    Stability(stability::StabilityArgs),
}

fn dispatch(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Tree(cmd) => tree::run(cmd),
        Command::Run(args) => run::run(args),
        Command::Bench(args) => bench::run(args),
        Command::Serve(args) => serve::run(args),
        Command::Stability(args) => stability::run(args),
    }
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => return usage_error(e),
    };
    match dispatch(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // `{:#}` prints the whole context chain on one line: "context: cause: ...".
            eprintln!("error: {}", one_line(&format!("{e:#}")));
            ExitCode::FAILURE
        }
    }
}

/// Help and version go to stdout as usual; a usage error becomes one line on stderr (exit 2).
fn usage_error(e: clap::Error) -> ExitCode {
    use clap::error::ErrorKind;
    match e.kind() {
        ErrorKind::DisplayHelp
        | ErrorKind::DisplayVersion
        | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => {
            let _ = e.print();
            if e.kind() == ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand {
                ExitCode::from(2)
            } else {
                ExitCode::SUCCESS
            }
        }
        _ => {
            let text = e.render().to_string();
            // Keep the message, drop the usage block clap appends.
            let message = text.split("\n\nUsage:").next().unwrap_or(&text);
            let message = one_line(message);
            let message = message.strip_prefix("error: ").unwrap_or(&message);
            eprintln!("error: {message} (see --help)");
            ExitCode::from(2)
        }
    }
}

/// Collapses whitespace runs (including newlines) to single spaces.
fn one_line(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// `on`/`off` (also `true`/`false`) for a switch that overrides a scene's setting.
fn parse_on_off(s: &str) -> Result<bool, String> {
    match s {
        "on" | "true" => Ok(true),
        "off" | "false" => Ok(false),
        _ => Err(format!("`{s}`: expected on or off")),
    }
}
