//! The recorder's time stamps: `dd/MM/yyyy HH:MM:SS.fff` (day first, as both public readers parse
//! them), as seconds since 1970-01-01 in whatever zone the recorder wrote (one zone per log).

/// Days from 1970-01-01 to the civil date (proleptic Gregorian).
pub fn days_from_civil(year: i64, month: i64, day: i64) -> i64 {
    let y = if month <= 2 { year - 1 } else { year };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let mp = (month + 9) % 12;
    let doy = (153 * mp + 2) / 5 + day - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

/// The civil date of a day count from 1970-01-01.
fn civil_from_days(days: i64) -> (i64, i64, i64) {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    (yoe + era * 400 + i64::from(month <= 2), month, day)
}

fn days_in_month(year: i64, month: i64) -> i64 {
    days_from_civil(year + i64::from(month == 12), month % 12 + 1, 1)
        - days_from_civil(year, month, 1)
}

/// A stamp read: whole seconds since 1970-01-01, the fraction, and the resolution its digits
/// give (s). Kept apart so that times relative to a log's origin keep every digit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Stamp {
    pub whole_s: i64,
    pub fraction_s: f64,
    pub resolution_s: f64,
}

impl Stamp {
    /// Seconds after `origin` (whole seconds since 1970-01-01), the origin set from this stamp
    /// when not yet set.
    pub fn since(&self, origin: &mut Option<i64>) -> f64 {
        let o = *origin.get_or_insert(self.whole_s);
        (self.whole_s - o) as f64 + self.fraction_s
    }

    /// Seconds since 1970-01-01.
    pub fn seconds(&self) -> f64 {
        self.whole_s as f64 + self.fraction_s
    }
}

/// Reads `dd/MM/yyyy HH:MM:SS[.f…]`; the message says what was expected.
pub(crate) fn parse_stamp(text: &str) -> Result<Stamp, String> {
    let expected =
        || format!("`{text}`; expected a time stamp dd/MM/yyyy HH:MM:SS.fff (day first)");
    let (date, clock) = text.trim().split_once(' ').ok_or_else(expected)?;
    let d: Vec<&str> = date.split('/').collect();
    let c: Vec<&str> = clock.trim().split(':').collect();
    if d.len() != 3 || c.len() != 3 {
        return Err(expected());
    }
    let int = |s: &str| -> Result<i64, String> {
        if s.is_empty() || !s.bytes().all(|b| b.is_ascii_digit()) || s.len() > 4 {
            return Err(expected());
        }
        s.parse().map_err(|_| expected())
    };
    let (day, month, year) = (int(d[0])?, int(d[1])?, int(d[2])?);
    let (hour, minute) = (int(c[0])?, int(c[1])?);
    let (whole, frac) = c[2].split_once('.').unwrap_or((c[2], ""));
    let second = int(whole)?;
    if !frac.bytes().all(|b| b.is_ascii_digit()) || frac.len() > 9 {
        return Err(expected());
    }
    if !(1..=12).contains(&month)
        || !(1..=days_in_month(year, month)).contains(&day)
        || hour > 23
        || minute > 59
        || second > 59
    {
        return Err(format!("{}: no such date or time", expected()));
    }
    let fraction = if frac.is_empty() {
        0.0
    } else {
        frac.parse::<f64>().map_err(|_| expected())? / 10f64.powi(frac.len() as i32)
    };
    let days = days_from_civil(year, month, day);
    Ok(Stamp {
        whole_s: days * 86_400 + hour * 3600 + minute * 60 + second,
        fraction_s: fraction,
        resolution_s: 10f64.powi(-(frac.len() as i32)),
    })
}

/// Reads the element layout's `START_IRRADIATION` stamp in any of the three forms REGGUI reads:
/// `2021-10-20 23:02:04.144 UTC`, `20170423-20:07:38.788` or `2018-06-11T11:59:54.846+02:00`
/// (a zone suffix is not applied: every stamp of a log is taken in one zone).
pub(crate) fn parse_element_stamp(text: &str) -> Result<Stamp, String> {
    let t = text.trim();
    let expected = || {
        format!("`{t}`; expected a time stamp yyyy-MM-dd HH:MM:SS.fff UTC, yyyyMMdd-HH:MM:SS.fff or yyyy-MM-ddTHH:MM:SS.fff")
    };
    let (date, clock) = if let Some(rest) = t.strip_suffix(" UTC") {
        rest.split_once(' ').ok_or_else(expected)?
    } else if let Some((d, c)) = t.split_once('T') {
        // Drop a zone: `Z`, or `+hh:mm` / `-hh:mm` after the seconds.
        let c = c.trim_end_matches('Z');
        let cut = c
            .char_indices()
            .skip(6)
            .find(|&(_, ch)| ch == '+' || ch == '-')
            .map_or(c.len(), |(i, _)| i);
        (d, &c[..cut])
    } else {
        t.split_once('-').ok_or_else(expected)?
    };
    let digits: String = date.chars().filter(|c| *c != '-').collect();
    if digits.len() != 8 || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return Err(expected());
    }
    let day_first = format!(
        "{}/{}/{} {clock}",
        &digits[6..8],
        &digits[4..6],
        &digits[0..4]
    );
    parse_stamp(&day_first).map_err(|_| expected())
}

/// Writes seconds since 1970-01-01 as `yyyy-MM-ddTHH:MM:SS.fff` (the element layout's
/// `START_IRRADIATION`), truncated to the millisecond.
pub(crate) fn format_element_stamp(seconds: f64) -> String {
    let s = format_stamp(seconds);
    format!("{}-{}-{}T{}", &s[6..10], &s[3..5], &s[0..2], &s[11..])
}

/// Writes seconds since 1970-01-01 as `dd/MM/yyyy HH:MM:SS.fff`, truncated to the millisecond
/// (as a clock reads).
pub(crate) fn format_stamp(seconds: f64) -> String {
    let ms_total = (seconds * 1000.0 + 1e-6).floor() as i64;
    let (days, ms_of_day) = (
        ms_total.div_euclid(86_400_000),
        ms_total.rem_euclid(86_400_000),
    );
    let (y, m, d) = civil_from_days(days);
    let (h, rest) = (ms_of_day / 3_600_000, ms_of_day % 3_600_000);
    let (mi, rest) = (rest / 60_000, rest % 60_000);
    format!(
        "{d:02}/{m:02}/{y:04} {h:02}:{mi:02}:{:02}.{:03}",
        rest / 1000,
        rest % 1000
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn element_stamps_read_in_each_form_reggui_reads() {
        let want = parse_stamp("20/10/2021 23:02:04.144").expect("stamp");
        for form in [
            "2021-10-20 23:02:04.144 UTC",
            "20211020-23:02:04.144",
            "2021-10-20T23:02:04.144+02:00",
            "2021-10-20T23:02:04.144-05:00",
            "2021-10-20T23:02:04.144Z",
            "2021-10-20T23:02:04.144",
        ] {
            assert_eq!(parse_element_stamp(form), Ok(want), "{form}");
        }
        let whole = parse_element_stamp("2018-06-11T11:59:54+02:00").expect("whole seconds");
        assert_eq!(whole.resolution_s, 1.0);
        assert_eq!(
            parse_element_stamp(&format_element_stamp(want.seconds())),
            Ok(want)
        );
        for bad in [
            "2021-10-20",
            "21-10-20 23:02:04.144 UTC",
            "2021-10-20T25:00:00.000",
            "",
        ] {
            assert!(parse_element_stamp(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn stamps_round_trip_across_midnight_and_leap_days() {
        let a = parse_stamp("29/02/2024 23:59:59.999").expect("leap day");
        let b = parse_stamp("01/03/2024 00:00:00.000").expect("next day");
        let mut origin = None;
        assert_eq!(a.since(&mut origin), 0.999);
        assert!((b.since(&mut origin) - 1.0).abs() < 1e-12);
        assert_eq!(a.resolution_s, 1e-3);
        assert_eq!(format_stamp(a.seconds()), "29/02/2024 23:59:59.999");
        // 2024-03-01 is day 19783 from 1970-01-01.
        assert_eq!(b.whole_s, 19_783 * 86_400);
        for bad in [
            "31/04/2024 10:00:00.0",
            "2024-03-01 10:00:00",
            "01/03/2024 24:00:00",
        ] {
            assert!(parse_stamp(bad).is_err(), "{bad}");
        }
    }
}
