//! The `epivox` command: the editor (no arguments, or `edit`), headless rendering and comparison
//! (`epivox --help`).

mod cli;

use clap::Parser;
use cli::{Cli, Command};

fn main() {
    let cli = Cli::parse();
    let result = match cli.command {
        Some(Command::Render(args)) => cli::render(args),
        Some(Command::Compare { a, b, json }) => cli::compare(&a, &b, json),
        Some(Command::Check(args)) => cli::check(args),
        Some(Command::Bench(args)) => cli::bench(args),
        Some(Command::Edit(args)) => cli::edit(args),
        None => cli::edit(cli::EditArgs::default()),
    };
    if let Err(e) = result {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}
