//! The `isoc` binary: the command line (`cli`) over the library. Argument
//! parsing, progress bars, messages and exit statuses live here and only
//! here; the library never prints, exits or reads the environment.

mod cli;

use clap::Parser;

fn main() {
    let cli = cli::Cli::parse();
    let status = cli::run(cli, &mut std::io::stdout(), &mut std::io::stderr());
    std::process::exit(status);
}
