//! The `isoc` binary: a thin layer over the library's [`isoc::cli`].

use clap::Parser;

fn main() {
    let cli = isoc::cli::Cli::parse();
    let status = isoc::cli::run(cli, &mut std::io::stdout(), &mut std::io::stderr());
    std::process::exit(status);
}
