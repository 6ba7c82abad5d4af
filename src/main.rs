//! The `campath` command: parses the arguments, runs the command, prints the error chain, and
//! exits 2 on bad input, 3 when an outside program is missing or failed, 130 when Ctrl-C stops
//! `video`'s encode, 1 on other failures.

mod cli;

use std::io::Write;
use std::process::ExitCode;

use clap::error::ErrorKind;
use clap::Parser;

fn main() -> ExitCode {
    cli::started();
    let parsed = match cli::Cli::try_parse() {
        Ok(parsed) => parsed,
        Err(e) => return option_error(e),
    };
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    match cli::run(parsed, &mut out) {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::from(1),
        // The reader of standard output went away (`campath path … | head`): end quietly.
        Err(e) if e.is_broken_pipe() => ExitCode::SUCCESS,
        Err(e) => {
            let _ = out.flush();
            eprintln!("campath: error: {e}");
            let mut source = std::error::Error::source(&e);
            while let Some(s) = source {
                eprintln!("  caused by: {s}");
                source = s.source();
            }
            ExitCode::from(e.exit_status())
        }
    }
}

/// Help and version go to standard output (exit 0), and the help for a missing command to
/// standard error (exit 2); a bad option is printed in campath's own style, `campath: error: …`,
/// with clap's hint, and exits 2, like any other bad input.
fn option_error(e: clap::Error) -> ExitCode {
    match e.kind() {
        ErrorKind::DisplayHelp | ErrorKind::DisplayVersion => {
            let _ = e.print();
            return ExitCode::SUCCESS;
        }
        // `campath` alone: the help, on standard error, as a usage error.
        ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => {
            let _ = e.print();
            return ExitCode::from(2);
        }
        _ => {}
    }
    let text = e.render().to_string();
    let text = text.strip_prefix("error: ").unwrap_or(&text);
    eprintln!("campath: error: {}", text.trim_end());
    ExitCode::from(2)
}
