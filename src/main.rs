//! `vkrad`: the command line. Everything but the exit is in `vkrad::cli`.

fn main() -> std::process::ExitCode {
    vkrad::cli::main()
}
