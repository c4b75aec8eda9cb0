//! The `epivox` command: the editor (no arguments, or `edit`), headless rendering and comparison
//! (`epivox --help`).

mod cli;

use clap::Parser;
use cli::{Cli, Command};

fn main() {
    // Before any thread starts (the environment is the process's) and before any Vulkan instance.
    quiet_headless_vulkan();
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
        Some(Command::Ab(args)) => cli::ab(args),
        Some(Command::Edit(args)) => cli::edit(args),
        None => cli::edit(cli::EditArgs::default()),
    };
    if let Err(e) = result {
        eprintln!("error: {}", cli::error_message(&e));
        std::process::exit(1);
    }
}

/// Mesa's device-select Vulkan layer looks for a Wayland compositor whenever an instance is made,
/// and without `XDG_RUNTIME_DIR` libwayland prints "error: XDG_RUNTIME_DIR is invalid or not set in
/// the environment." twice on every headless run (CI, ssh), although nothing failed. With no
/// `XDG_RUNTIME_DIR` there is no Wayland session whose device the layer could put first, so it is
/// turned off (`NODEVICE_SELECT=1`) unless the user set `NODEVICE_SELECT` themselves; the layer only
/// reorders the devices, and wgpu chooses the adapter by its power preference either way.
fn quiet_headless_vulkan() {
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() && std::env::var_os("NODEVICE_SELECT").is_none() {
        std::env::set_var("NODEVICE_SELECT", "1");
    }
}
