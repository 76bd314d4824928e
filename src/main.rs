//! The `nes` command. Everything it does is in [`nes::cli`]; this file
//! only hands over the process's arguments and exit code.

fn main() -> std::process::ExitCode {
    nes::cli::main()
}
