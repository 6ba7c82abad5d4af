//! The `campath` command; the command line is the library's `cli` module (feature `cli`).

fn main() -> std::process::ExitCode {
    campath::run_cli()
}
