//! The clock of a treatment record: TreatmentControlPointDate (DA, `YYYYMMDD`) and
//! TreatmentControlPointTime (TM, `HH[MM[SS[.F{1,6}]]]`) as seconds on one continuous scale, and
//! the resolution the system wrote them at.
//!
//! Every date and time of a record is in one time zone (the data set's TimezoneOffsetFromUTC,
//! (0008,0201), when given), so differences between them need no zone: the scale counts seconds
//! from 1970-01-01 in that zone, and a delivery across midnight stays continuous because the date
//! changes with it.

/// A time of day read from a TM value: seconds since midnight, and the resolution it was
/// written at (1 s for `HHMMSS`, 1 µs for six fraction digits, 60 s for `HHMM`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct TimeOfDay {
    pub seconds: f64,
    pub resolution_s: f64,
}

/// The days since 1970-01-01 of a DA value (`YYYYMMDD`; the old `YYYY.MM.DD` is accepted), or
/// what is wrong with it.
pub(crate) fn parse_date(text: &str) -> Result<i64, String> {
    let digits: String = text.chars().filter(|c| *c != '.').collect();
    let bad = || format!("\"{text}\" is not a date; expected YYYYMMDD");
    if digits.len() != 8 || !digits.chars().all(|c| c.is_ascii_digit()) {
        return Err(bad());
    }
    let num = |r: std::ops::Range<usize>| digits[r].parse::<i64>().map_err(|_| bad());
    let (y, m, d) = (num(0..4)?, num(4..6)?, num(6..8)?);
    let month_days = match m {
        1 | 3 | 5 | 7 | 8 | 10 | 12 => 31,
        4 | 6 | 9 | 11 => 30,
        2 if (y % 4 == 0 && y % 100 != 0) || y % 400 == 0 => 29,
        2 => 28,
        _ => return Err(format!("\"{text}\": month {m} does not exist")),
    };
    if !(1..=month_days).contains(&d) {
        return Err(format!("\"{text}\": day {d} does not exist in month {m}"));
    }
    Ok(arcsim_log::iba::days_from_civil(y, m, d))
}

/// A TM value (`HH`, `HHMM`, `HHMMSS` or `HHMMSS.F` with 1 to 6 fraction digits; the old
/// `HH:MM:SS` is accepted), or what is wrong with it.
pub(crate) fn parse_time(text: &str) -> Result<TimeOfDay, String> {
    let bad = |why: &str| format!("\"{text}\" is not a time of day: {why}; expected HHMMSS.FFFFFF");
    let t: String = text.chars().filter(|c| *c != ':').collect();
    let (whole, frac) = match t.split_once('.') {
        Some((w, f)) => (w, Some(f)),
        None => (t.as_str(), None),
    };
    if !whole.chars().all(|c| c.is_ascii_digit()) || ![2, 4, 6].contains(&whole.len()) {
        return Err(bad("hours, minutes and seconds are two digits each"));
    }
    let two = |i: usize| whole.get(i..i + 2).map_or(Ok(0.0), |s| s.parse::<f64>());
    let (h, m, s) = (
        two(0).map_err(|_| bad("hours"))?,
        two(2).map_err(|_| bad("minutes"))?,
        two(4).map_err(|_| bad("seconds"))?,
    );
    // A leap second (60) is allowed, as DICOM allows it.
    if h > 23.0 || m > 59.0 || s > 60.0 {
        return Err(bad("out of range"));
    }
    let mut seconds = 3600.0 * h + 60.0 * m + s;
    let mut resolution_s = match whole.len() {
        2 => 3600.0,
        4 => 60.0,
        _ => 1.0,
    };
    if let Some(f) = frac {
        if whole.len() != 6 || f.is_empty() || f.len() > 6 || !f.chars().all(|c| c.is_ascii_digit())
        {
            return Err(bad("a fraction takes 1 to 6 digits after whole seconds"));
        }
        let scale = 10f64.powi(f.len() as i32);
        seconds += f.parse::<f64>().map_err(|_| bad("fraction"))? / scale;
        resolution_s = 1.0 / scale;
    }
    Ok(TimeOfDay {
        seconds,
        resolution_s,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dates_count_days_across_months_years_and_leap_days() {
        assert_eq!(parse_date("19700101"), Ok(0));
        assert_eq!(parse_date("19700102"), Ok(1));
        assert_eq!(
            parse_date("20000301").unwrap() - parse_date("20000228").unwrap(),
            2
        );
        assert_eq!(
            parse_date("19000301").unwrap() - parse_date("19000228").unwrap(),
            1
        );
        assert_eq!(
            parse_date("20270101").unwrap() - parse_date("20261231").unwrap(),
            1
        );
        assert_eq!(parse_date("2026.12.06"), parse_date("20261206"));
        assert!(parse_date("20260230").is_err());
        assert!(parse_date("2026126").is_err());
    }

    #[test]
    fn times_keep_their_written_resolution() {
        let t = parse_time("235959.5").unwrap();
        assert_eq!((t.seconds, t.resolution_s), (86_399.5, 0.1));
        let t = parse_time("101500").unwrap();
        assert_eq!((t.seconds, t.resolution_s), (36_900.0, 1.0));
        let t = parse_time("1015").unwrap();
        assert_eq!((t.seconds, t.resolution_s), (36_900.0, 60.0));
        let t = parse_time("10:15:00.000001").unwrap();
        assert!((t.seconds - 36_900.000_001).abs() < 1e-9 && t.resolution_s == 1e-6);
        for bad in ["25", "1261", "10150", "101500.1234567", "ab", "101500."] {
            assert!(parse_time(bad).is_err(), "{bad}");
        }
    }
}
