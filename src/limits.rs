//! The resource budget: every size that allocates is checked before the work
//! starts, against a stated limit and against the memory the machine has, with one line
//! naming the input, what it needs and the limit.
//!
//! Memory available is `MemAvailable` of `/proc/meminfo`, lowered to the cgroup's
//! `memory.max` when there is one (a container's limit); `SHVIS_MEMORY_LIMIT` (bytes, or
//! with a `K`/`M`/`G` suffix) lowers it further, for tests and shared machines. Where none
//! of these can be read, only the stated limits apply.

use std::fmt::Display;

/// Environment variable that caps the memory shvis plans to use.
pub const MEMORY_LIMIT_ENV: &str = "SHVIS_MEMORY_LIMIT";

/// Share of the available memory one allocation plan may use (the rest is the OS's,
/// the GPU driver's, and estimates' slack).
const USABLE_SHARE: f64 = 0.8;

/// A plan that does not fit.
#[derive(Debug, thiserror::Error)]
pub enum LimitError {
    /// More memory than the machine has available.
    #[error("{what} needs {} of memory, more than the {} available{}", gib(*.need), gib(*.available), .hint)]
    Memory {
        /// The input and what it sizes.
        what: String,
        /// Bytes the plan needs.
        need: u64,
        /// Bytes usable.
        available: u64,
        /// How to make it fit ("; lower --vis-res or --order").
        hint: String,
    },
    /// Above a stated limit.
    #[error("{what} is {value}, more than the limit {limit}{}", .hint)]
    Above {
        /// The input.
        what: String,
        /// Its value.
        value: u64,
        /// The limit.
        limit: u64,
        /// Why the limit is there, or what to do.
        hint: String,
    },
}

fn gib(bytes: u64) -> String {
    if bytes >= 1 << 30 {
        format!("{:.1} GiB", bytes as f64 / f64::from(1u32 << 30))
    } else {
        format!("{:.0} MiB", (bytes as f64 / f64::from(1u32 << 20)).ceil())
    }
}

/// Bytes shvis may plan to allocate now, `None` when nothing says.
pub fn available_memory() -> Option<u64> {
    let mut limit = meminfo_available();
    if let Some(cg) = cgroup_limit() {
        limit = Some(limit.map_or(cg, |l| l.min(cg)));
    }
    if let Some(user) = std::env::var(MEMORY_LIMIT_ENV)
        .ok()
        .and_then(|v| parse_bytes(&v))
    {
        limit = Some(limit.map_or(user, |l| l.min(user)));
    }
    limit.map(|l| (l as f64 * USABLE_SHARE) as u64)
}

/// "123", "64K", "512M", "2G" → bytes.
pub fn parse_bytes(text: &str) -> Option<u64> {
    let t = text.trim();
    let (digits, shift) = match t.char_indices().last()? {
        (i, 'k' | 'K') => (&t[..i], 10),
        (i, 'm' | 'M') => (&t[..i], 20),
        (i, 'g' | 'G') => (&t[..i], 30),
        _ => (t, 0),
    };
    digits.trim().parse::<u64>().ok()?.checked_mul(1 << shift)
}

fn meminfo_available() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kib.checked_mul(1024)
}

fn cgroup_limit() -> Option<u64> {
    let text = std::fs::read_to_string("/sys/fs/cgroup/memory.max").ok()?;
    text.trim().parse().ok()
}

/// Checks that `bytes` fit in the memory available; `what` names the input ("--vis-res
/// 8192 × --order 30: the visibility bake"), `hint` what to lower.
///
/// # Errors
/// [`LimitError::Memory`].
pub fn check_memory(what: impl Display, bytes: u64, hint: &str) -> Result<(), LimitError> {
    match available_memory() {
        Some(available) if bytes > available => Err(LimitError::Memory {
            what: what.to_string(),
            need: bytes,
            available,
            hint: if hint.is_empty() {
                String::new()
            } else {
                format!("; {hint}")
            },
        }),
        _ => Ok(()),
    }
}

/// Checks `value ≤ limit` for an input that sets a loop count or a size.
///
/// # Errors
/// [`LimitError::Above`].
pub fn check_at_most(
    what: impl Display,
    value: u64,
    limit: u64,
    hint: &str,
) -> Result<(), LimitError> {
    if value > limit {
        return Err(LimitError::Above {
            what: what.to_string(),
            value,
            limit,
            hint: if hint.is_empty() {
                String::new()
            } else {
                format!(" ({hint})")
            },
        });
    }
    Ok(())
}

/// Bytes of a `width × height` image of `bytes_per_texel`, saturating.
pub fn image_bytes(width: u64, height: u64, bytes_per_texel: u64) -> u64 {
    width.saturating_mul(height).saturating_mul(bytes_per_texel)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn byte_counts_parse_with_suffixes() {
        assert_eq!(parse_bytes("123"), Some(123));
        assert_eq!(parse_bytes("64K"), Some(64 << 10));
        assert_eq!(parse_bytes("2g"), Some(2 << 30));
        assert_eq!(parse_bytes(" 5 M "), Some(5 << 20));
        assert_eq!(parse_bytes("x"), None);
        assert_eq!(parse_bytes(""), None);
        assert_eq!(parse_bytes("99999999999999999999G"), None);
    }

    #[test]
    fn messages_name_the_input_and_the_limit() {
        let e = check_at_most("--warmup", 4_000_000_000, 100_000, "").unwrap_err();
        assert_eq!(
            e.to_string(),
            "--warmup is 4000000000, more than the limit 100000"
        );
        assert!(check_at_most("--warmup", 100_000, 100_000, "").is_ok());
        // 2^62 bytes exceeds any machine's memory.
        let e = check_memory("--vis-res 8192 × --order 30", 1 << 62, "lower --vis-res")
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("--vis-res 8192 × --order 30 needs 4294967296.0 GiB"),
            "{e}"
        );
        assert!(e.ends_with("; lower --vis-res"), "{e}");
    }
}
