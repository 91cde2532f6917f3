//! Wall-clock dates in UTC for what the tool records (a results page's date, when a probe
//! was measured), without a calendar crate: Hinnant's `civil_from_days`.

/// Seconds since 1970-01-01 UTC now.
fn now_secs() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs())
}

/// Today's date in UTC, "YYYY-MM-DD".
pub fn utc_date_today() -> String {
    utc_date(now_secs() / 86_400)
}

/// Now in UTC, "YYYY-MM-DD HH:MM".
pub fn utc_now() -> String {
    let secs = now_secs();
    format!(
        "{} {:02}:{:02}",
        utc_date(secs / 86_400),
        secs % 86_400 / 3600,
        secs % 3600 / 60
    )
}

/// Whether `text` is a time as [`utc_now`] writes it, "YYYY-MM-DD HH:MM", with each field
/// in its range (what a cache file claims is checked before it is shown).
pub fn is_utc_minute(text: &str) -> bool {
    let b = text.as_bytes();
    let digits = |r: std::ops::Range<usize>| -> Option<u32> {
        let s = text.get(r)?;
        s.bytes()
            .all(|c| c.is_ascii_digit())
            .then(|| s.parse().ok())?
    };
    b.len() == 16
        && (b[4], b[7], b[10], b[13]) == (b'-', b'-', b' ', b':')
        && digits(0..4).is_some()
        && digits(5..7).is_some_and(|m| (1..=12).contains(&m))
        && digits(8..10).is_some_and(|d| (1..=31).contains(&d))
        && digits(11..13).is_some_and(|h| h < 24)
        && digits(14..16).is_some_and(|m| m < 60)
}

/// The civil date of day `days` after 1970-01-01.
fn utc_date(days: u64) -> String {
    let z = days as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!("{year:04}-{month:02}-{day:02}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn civil_dates_of_known_days() {
        assert_eq!(utc_date(0), "1970-01-01");
        assert_eq!(utc_date(11_016), "2000-02-29");
        assert_eq!(utc_date(20_791), "2026-12-04");
        assert_eq!(utc_now().len(), "2026-12-04 20:40".len());
        assert!(is_utc_minute(&utc_now()));
        assert!(is_utc_minute("2026-12-04 20:40"));
        for bad in [
            "2026-13-04 20:40",
            "2026-12-04 24:00",
            "2026-12-04T20:40",
            "<b>x</b>",
            "",
        ] {
            assert!(!is_utc_minute(bad), "{bad}");
        }
    }
}
