//! The `raylab` command: flags -> library calls -> printing and exit codes
//! (0 ok, 1 "differs", 2 error).

use std::process::ExitCode;

fn main() -> ExitCode {
    raylab::cli::main()
}
