//! What commands print on standard output, line by line. A line that cannot be written — a
//! full device, or a closed pipe where SIGPIPE is ignored — is an error for the caller, and
//! the first such failure is remembered ([`failure`]) so that the command's exit status
//! says so even where the line came from a progress callback that cannot return it.

use std::io::{self, Write};
use std::sync::OnceLock;

static FAILURE: OnceLock<String> = OnceLock::new();

/// Writes `line` and a newline to standard output and flushes it.
///
/// # Errors
/// The write's error; the first one is also kept for [`failure`].
pub fn print_line(line: std::fmt::Arguments<'_>) -> io::Result<()> {
    let mut out = io::stdout().lock();
    let result = out
        .write_fmt(line)
        .and_then(|()| out.write_all(b"\n"))
        .and_then(|()| out.flush());
    if let Err(e) = &result {
        let _ = FAILURE.set(e.to_string());
    }
    result
}

/// Why a line could not be written to standard output, if one could not.
pub fn failure() -> Option<&'static str> {
    FAILURE.get().map(String::as_str)
}

#[cfg(test)]
mod tests {
    #[test]
    fn no_failure_is_reported_before_one_happens() {
        // The test harness captures stdout, so a line is written without error.
        super::print_line(format_args!("a line")).unwrap();
        assert_eq!(super::failure(), None);
    }
}
