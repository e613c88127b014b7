//! The `osiris` executable; see [`osiris::cli`].
//!
//! Exit status ([`osiris::cli::exit_code`]): 0 success (a consistency run that is CONSISTENT or
//! EXPLAINED), 1 the consistency verdict fails (outputs written), 2 a usage, input or I/O error
//! (the message names the file, key or value), 3 an internal error (a bug: please report it).

use clap::Parser;

fn main() -> std::process::ExitCode {
    let cli = osiris::cli::Cli::parse();
    match std::panic::catch_unwind(|| osiris::cli::main_with(cli)) {
        Ok(Ok(())) => std::process::ExitCode::SUCCESS,
        Ok(Err(e)) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::from(osiris::cli::exit_code(&e))
        }
        Err(_) => {
            // The panic hook has printed the message and location.
            eprintln!(
                "error: internal error in osiris (a bug; please report it with the message above)"
            );
            std::process::ExitCode::from(osiris::cli::EXIT_INTERNAL)
        }
    }
}
