//! `lucid`: one command line for datasets, training, evaluation, rendering and reports.
//!
//! A thin binary over the library crates: it parses arguments, sets up logging, runs one
//! subcommand and turns any error into a single line on stderr and a non-zero exit code.

mod cli;
mod commands;
mod loaded_model;
mod progress;
mod report;
mod training;

use std::io::IsTerminal;
use std::process::ExitCode;

// glibc malloc returns large freed buffers to the OS on every free, which halved burn's CPU
// throughput in our measurements; mimalloc keeps them (built without transparent huge pages:
// see the workspace Cargo.toml).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() -> ExitCode {
    let matches = negative_values(<cli::Cli as clap::CommandFactory>::command()).get_matches();
    let args = match <cli::Cli as clap::FromArgMatches>::from_arg_matches(&matches) {
        Ok(args) => args,
        Err(e) => e.exit(),
    };
    init_logging(args.verbose, args.quiet);
    if let Some(layer) = &args.exr_layer
        && let Err(e) = lucid_image::io::exr_layers::set_layer(layer)
    {
        eprintln!("error: --exr-layer: {e}");
        return ExitCode::FAILURE;
    }
    match commands::run(args.command, &matches) {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("error: {}", one_line(&error));
            ExitCode::FAILURE
        }
    }
}

/// Lets every option that takes a value take one that starts with a minus sign (`--focus -1`,
/// `--elevation -10`): no option is spelled as a number, so nothing becomes ambiguous, and the
/// option's own range check then says what it allows (clap would call `-1` an unknown
/// argument and suggest `-- -1`, which passes nothing to the option).
fn negative_values(command: clap::Command) -> clap::Command {
    command
        .mut_args(|arg| if arg.get_action().takes_values() { arg.allow_negative_numbers(true) } else { arg })
        .mut_subcommands(negative_values)
}

/// The error's context chain on one line ("reading x.json: x.json: frames[2]…"), leaving out
/// causes whose text an outer message already shows (library errors often print their
/// source and also expose it as the next link of the chain).
fn one_line(error: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in error.chain() {
        let text = cause.to_string();
        if line.contains(&text) {
            continue;
        }
        if !line.is_empty() {
            line.push_str(": ");
        }
        line.push_str(&text);
    }
    line
}

fn init_logging(verbose: u8, quiet: bool) {
    let default = match (quiet, verbose) {
        (true, _) => "error",
        (false, 0) => "info",
        (false, 1) => "debug",
        (false, _) => "trace",
    };
    let filter = tracing_subscriber::EnvFilter::try_from_env("LUCID_LOG")
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(default));
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_ansi(std::io::stderr().is_terminal())
        .with_target(false)
        .init();
}
