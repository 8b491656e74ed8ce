//! The `furnace` command: parse, run the library, print the error chain, exit code.

use std::error::Error as _;

fn main() {
    let cli = furnace::cli::Cli::parse_args();
    if let Err(e) = furnace::cli::run(cli) {
        let top = e.to_string();
        eprintln!("error: {top}");
        // each cause once: a message that already quotes its cause is not followed by it again
        let mut printed = vec![top];
        let mut source = e.source();
        while let Some(s) = source {
            let text = s.to_string();
            if !printed.iter().any(|p| p.contains(&text)) {
                eprintln!("  caused by: {text}");
            }
            printed.push(text);
            source = s.source();
        }
        std::process::exit(1);
    }
}
