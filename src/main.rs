//! The `epivox` command: headless rendering and comparison (`epivox --help`).

mod cli;

use clap::Parser;
use cli::{Cli, Command};

fn main() {
    let cli = Cli::parse();
    let result = match cli.command {
        Some(Command::Render(args)) => cli::render(args),
        Some(Command::Compare { a, b, json }) => cli::compare(&a, &b, json),
        None => {
            eprintln!(
                "the editor is not built yet; render headless instead:\n  epivox render --out shafts.png\n(see `epivox --help`)"
            );
            std::process::exit(2);
        }
    };
    if let Err(e) = result {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}
