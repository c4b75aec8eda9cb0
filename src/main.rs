//! The `epivox` command: the editor (no arguments, or `edit`), headless rendering and comparison
//! (`epivox --help`).

mod cli;

use clap::Parser;
use cli::{Cli, Command};

fn main() {
    // Before anything can warn: every command's warnings reach stderr.
    cli::init_logging();
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            if e.use_stderr() {
                // Values the user typed are echoed: escape control characters in them.
                eprint!("{}", cli::escape_controls(&e.render().to_string()));
                std::process::exit(e.exit_code());
            }
            e.exit(); // --help, --version
        }
    };
    let result = match cli.command {
        Some(Command::Render(args)) => cli::render(args),
        Some(Command::Compare { a, b, json, diff, gain }) => cli::compare(&a, &b, json, diff.as_deref(), gain),
        Some(Command::Check(args)) => cli::check(args),
        Some(Command::Bench(args)) => cli::bench(args),
        Some(Command::Edit(args)) => cli::edit(args),
        None => cli::edit(cli::EditArgs::default()),
    };
    if let Err(e) = result {
        eprintln!("error: {}", cli::error_message(&e));
        std::process::exit(1);
    }
}
