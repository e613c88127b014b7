//! The `osiris` executable; see [`osiris::cli`].

use clap::Parser;

fn main() -> std::process::ExitCode {
    let cli = osiris::cli::Cli::parse();
    match osiris::cli::main_with(cli) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
