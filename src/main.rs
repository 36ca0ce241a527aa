//! The `isoc` binary: the command line (`cli`) over the library. Argument
//! parsing, progress bars, messages and exit statuses live here and only
//! here; the library never prints, exits or reads the environment.

mod cli;

use clap::Parser;

fn main() {
    keep_heap_small();
    let cli = cli::Cli::parse();
    let status = cli::run(cli, &mut std::io::stdout(), &mut std::io::stderr());
    std::process::exit(status);
}

/// glibc's allocator raises its mmap threshold each time a large block is
/// freed, so the mesher's stage-sized vectors (tens of MB, freed between
/// stages) end up on the heap, which it keeps: a level-7 gyroid peaked at
/// 440–490 MB instead of 330–345 MB. Any explicit trim threshold turns that
/// adjustment off; 16 MiB keeps small churn on the heap. (An allocator
/// policy is the program's choice, not the library's.)
fn keep_heap_small() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: `mallopt` only sets an allocator parameter; it is called
    // before any other thread exists.
    unsafe {
        libc::mallopt(libc::M_TRIM_THRESHOLD, 16 << 20);
    }
}
