//! The `furnace` command: parse, run the library, print the error chain, exit code.

use clap::Parser;
use std::error::Error as _;

fn main() {
    let cli = furnace::cli::Cli::parse();
    if let Err(e) = furnace::cli::run(cli) {
        eprintln!("error: {e}");
        let mut source = e.source();
        while let Some(s) = source {
            eprintln!("  caused by: {s}");
            source = s.source();
        }
        std::process::exit(1);
    }
}
