//! The `octavar` command: a thin layer over the `octavar` library. One file per subcommand in `cli/`.

use std::process::ExitCode;

use clap::Parser;

mod cli;

fn main() -> ExitCode {
    let cli = cli::Cli::parse();
    match cli.command.run() {
        Ok(code) => code,
        Err(err) => {
            if cli::is_broken_pipe(&err) {
                return ExitCode::SUCCESS;
            }
            eprintln!("octavar: {}", cli::error_line(&err));
            ExitCode::from(2)
        }
    }
}
