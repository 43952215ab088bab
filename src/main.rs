//! The `imunoise` command; see the library for everything it does.

mod cli;

fn main() {
    imunoise::memory::tune_allocator();
    std::process::exit(cli::main());
}
