//! The `imunoise` command; see the library for everything it does.

mod cli;

fn main() {
    std::process::exit(cli::main());
}
