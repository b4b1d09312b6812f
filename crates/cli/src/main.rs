//! The `haptic6d` command line.
use clap::Parser;

/// 6-DoF haptic rendering with sphere-trees and small QPs.
#[derive(Parser)]
#[command(name = "haptic6d", version, about)]
struct Cli {}

fn main() -> anyhow::Result<()> {
    let _cli = Cli::parse();
    Ok(())
}
