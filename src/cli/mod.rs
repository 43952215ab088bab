//! The command line: flags ([`args`]) → validated job ([`config`]) → run ([`run`]). Nothing here
//! computes; it only parses, calls the library and maps outcomes to exit codes.

mod args;
mod backend;
mod config;
mod run;
mod screen;
mod simulate;

use clap::Parser;

/// Parses the command line and runs it; returns the exit code.
pub fn main() -> i32 {
    let cli = match args::Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            // --help and --version are not errors.
            let code = if e.use_stderr() {
                run::EXIT_FATAL
            } else {
                run::EXIT_OK
            };
            let _ = e.print();
            return code;
        }
    };
    if let args::Command::Screen(a) = cli.command {
        return screen::main(a);
    }
    if let args::Command::Simulate(a) = &cli.command {
        return match simulate::job(a) {
            Ok(job) => simulate::run(&job),
            Err(e) => {
                eprintln!("imunoise: {e}");
                run::EXIT_FATAL
            }
        };
    }
    match config::job(cli) {
        Ok(job) => run::run(&job),
        Err(e) => {
            eprintln!("imunoise: {e}");
            run::EXIT_FATAL
        }
    }
}
