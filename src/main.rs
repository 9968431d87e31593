//! The `cubeforge` command: parses arguments, calls the library, reports.

mod cli;

fn main() {
    std::process::exit(cli::run());
}
