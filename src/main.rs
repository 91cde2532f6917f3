//! `shvis`: parse the command line, run it, print one error line on failure.

mod cli;

use std::io::{IsTerminal, Write as _};
use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    // `shvis sh eval | head`: a closed pipe ends the process quietly, as for other tools,
    // instead of a failed print.
    #[cfg(target_os = "linux")]
    // SAFETY: restoring the default disposition of SIGPIPE before any thread starts.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    // A panic is a bug, but even then the user sees one line, not a backtrace dump.
    std::panic::set_hook(Box::new(|info| {
        let msg = info.to_string().replace('\n', " ");
        error_line(format_args!("error: internal error (please report): {msg}"));
    }));
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("shvis=info,warn"))
        .format_timestamp(None)
        .format_target(false)
        .write_style(if std::io::stderr().is_terminal() {
            env_logger::WriteStyle::Auto
        } else {
            env_logger::WriteStyle::Never
        })
        .init();
    shvis::files::remove_temporaries_on_interrupt();
    let cli = match cli::Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            use clap::error::ErrorKind;
            if matches!(
                e.kind(),
                ErrorKind::DisplayHelp
                    | ErrorKind::DisplayVersion
                    | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
            ) {
                // Help or the version into a full device is not a success.
                return match e.print().and_then(|()| std::io::stdout().flush()) {
                    Ok(()) => ExitCode::SUCCESS,
                    Err(cause) => {
                        error_line(format_args!(
                            "error: cannot write to standard output: {cause}"
                        ));
                        ExitCode::FAILURE
                    }
                };
            }
            if let Some(line) = negative_value_line(&e) {
                error_line(format_args!("{line}"));
                return ExitCode::from(2);
            }
            // clap says what is wrong in its first paragraph (a missing argument's name on the
            // lines after "…were not provided:") and adds usage hints after a blank line.
            let text = e.to_string();
            let what: Vec<&str> = text
                .lines()
                .skip_while(|l| l.trim().is_empty())
                .take_while(|l| !l.trim().is_empty())
                .map(str::trim)
                .collect();
            if what.is_empty() {
                error_line(format_args!("error: invalid arguments"));
            } else {
                error_line(format_args!("{}", what.join(" ")));
            }
            return ExitCode::from(2);
        }
    };
    match cli::run(cli) {
        // A line a progress callback could not write fails the command too.
        Ok(()) => match shvis::files::stdout::failure() {
            None => ExitCode::SUCCESS,
            Some(cause) => {
                error_line(format_args!(
                    "error: cannot write to standard output: {cause}"
                ));
                ExitCode::FAILURE
            }
        },
        Err(e) => {
            error_line(format_args!("error: {}", one_line(&e)));
            ExitCode::FAILURE
        }
    }
}

/// One line on standard error; where standard error cannot be written either (a full
/// device), the exit status is all that is left to say it.
fn error_line(line: std::fmt::Arguments<'_>) {
    let _ = writeln!(std::io::stderr(), "{line}");
}

/// The error and its causes on one line, each cause once: a cause whose text its error's
/// message already quotes (`"…: {source}"`) is not repeated.
fn one_line(e: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in e.chain() {
        let cause = cause.to_string();
        if !text.contains(&cause) {
            if !text.is_empty() {
                text.push_str(": ");
            }
            text.push_str(&cause);
        }
    }
    text.replace('\n', " ")
}

/// clap reads `--rays -5` or `--exposure -inf` (on options that take no negative values)
/// as an unknown flag `-5` / `-i`, a message that does not name the option; this names it.
fn negative_value_line(e: &clap::Error) -> Option<String> {
    use clap::error::{ContextKind, ContextValue, ErrorKind};
    if e.kind() != ErrorKind::UnknownArgument {
        return None;
    }
    let Some(ContextValue::String(token)) = e.get(ContextKind::InvalidArg) else {
        return None;
    };
    let args: Vec<String> = std::env::args().collect();
    let i = args
        .iter()
        .position(|a| a.starts_with(token.as_str()) && a.starts_with('-'))?;
    let value = &args[i];
    let looks_numeric = value[1..].starts_with(|c: char| c.is_ascii_digit() || c == '.')
        || ["inf", "nan", "infinity"].contains(&value[1..].to_ascii_lowercase().as_str());
    let flag = args.get(i.checked_sub(1)?)?;
    (looks_numeric && flag.starts_with("--")).then(|| {
        format!("error: invalid value '{value}' for '{flag}': it must not be negative or infinite")
    })
}
