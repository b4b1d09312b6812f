//! The `haptic6d` command line.
//!
//! One module per subcommand (`tree.rs`, ...): each exports an argument type (clap derive) and a
//! `run` function returning `anyhow::Result<()>`. To add a subcommand, add its module, a variant
//! to [`Command`] and an arm to [`dispatch`]. Errors reach the user as one line (`error: ...`) with a
//! non-zero exit status; progress bars (see `progress.rs`) only show on a terminal.

mod bench;
mod bench_ablation;
mod bench_contact;
mod bench_fit;
mod bench_friction;
mod bench_peer;
mod bench_plot;
mod bench_pqp;
mod bench_report;
mod bench_speed;
mod bench_tuning;
mod bench_zoo;
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
    /// The paper's experiments: every solver on identical recorded input, plus scaling, hand-speed, contact and friction studies, and the rapier3d and MuJoCo peers.
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
            eprintln!("error: {}", error_line(&e));
            if is_usage(&e) {
                ExitCode::from(2)
            } else {
                ExitCode::FAILURE
            }
        }
    }
}

/// A command-line value the command cannot use (a flag out of range, a duration the memory
/// cannot hold): reported like clap's own usage errors, exit status 2.
#[derive(Debug)]
pub(crate) struct UsageError(pub String);

impl std::fmt::Display for UsageError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for UsageError {}

/// Returns early with a [`UsageError`] (exit 2) made by `format!`.
#[macro_export]
macro_rules! usage_bail {
    ($($arg:tt)*) => {
        return Err($crate::UsageError(format!($($arg)*)).into())
    };
}

/// True for an error in how the command was called: a [`UsageError`], or a range check of
/// a flag (`--rate`, ...; a scene file's key out of range is an input error, exit 1).
fn is_usage(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.is::<UsageError>()
            || c.downcast_ref::<engine::config::SettingError>()
                .is_some_and(|s| s.key.starts_with("--"))
    })
}

/// Longest error line printed, characters (a cause may quote a huge input line).
const MAX_ERROR_CHARS: usize = 1000;

/// The error and its causes on one line, `context: cause: ...`. A cause whose text an outer
/// message already quotes (`... (os error 98)`) is not repeated; the line is capped.
fn error_line(e: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in e.chain() {
        let text = one_line(&cause.to_string());
        if text.is_empty() || line.contains(&text) {
            continue;
        }
        if !line.is_empty() {
            line.push_str(": ");
        }
        line.push_str(&text);
    }
    match line.char_indices().nth(MAX_ERROR_CHARS) {
        Some((at, _)) => format!("{} …", &line[..at]),
        None => line,
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

/// `base` with each of `pairs` (`name=value`, names of [`engine::Tuning::NAMES`]) set in turn,
/// checked; a usage error naming `flag` for a pair that is not NAME=NUMBER, a range error for
/// a value out of its range.
fn tuning_with(
    base: engine::Tuning,
    pairs: &[String],
    flag: &str,
) -> anyhow::Result<engine::Tuning> {
    use anyhow::Context as _;
    let mut tuning = base;
    for pair in pairs {
        let parsed = pair
            .split_once('=')
            .and_then(|(name, v)| Some((name, v.trim().parse::<f64>().ok()?)));
        let Some(next) = parsed.and_then(|(name, v)| tuning.with(name.trim(), v)) else {
            usage_bail!(
                "{flag}: `{pair}` is not NAME=NUMBER with NAME one of {}",
                engine::Tuning::NAMES.join(", ")
            );
        };
        next.validate().with_context(|| flag.to_string())?;
        tuning = next;
    }
    Ok(tuning)
}

/// `on`/`off` (also `true`/`false`) for a switch that overrides a scene's setting.
fn parse_on_off(s: &str) -> Result<bool, String> {
    match s {
        "on" | "true" => Ok(true),
        "off" | "false" => Ok(false),
        _ => Err(format!("`{s}`: expected on or off")),
    }
}
