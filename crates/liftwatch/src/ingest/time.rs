//! Stage 1, time stamps: numeric seconds or RFC 3339, both turned into f64 seconds
//! (paper, Sec. 4.1, "inconsistencies in ... timestamps and data formats").
//!
//! ```text
//! t = number                      "1709280000.25", "12.5" (seconds since any epoch)
//! t = unix(RFC 3339 instant)      "2026-03-01T08:00:00.250Z", "2026-03-01T09:00:00+01:00"
//! accepted only if |t| <= MAX_ABS_TIME_S
//! ```
//!
//! One file uses one form: the first row with a readable time fixes it ([`TimeForm`]),
//! and a later row of the other form is a bad row.
//!
//! Deviation from the paper: the paper does not say how time stamps are written; the
//! accepted range is ours. ±1e10 s (±317 years) covers Unix seconds of the years 1653
//! to 2286 and any relative clock, keeps f64 resolution finer than 2 µs, and turns
//! logger garbage such as `1e300` or `inf` into bad rows instead of a grid of 1e300 steps.

use crate::sample::DAY_S;
use time::format_description::well_known::Rfc3339;
use time::OffsetDateTime;

/// Largest accepted |time| (s): ±317 years around the epoch.
pub const MAX_ABS_TIME_S: f64 = 1.0e10;

/// How the time column of one file is written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimeForm {
    /// A number of seconds since any epoch, fractional allowed.
    Seconds,
    /// An RFC 3339 instant, converted to seconds since the Unix epoch.
    Rfc3339,
}

impl TimeForm {
    /// Name used in messages.
    pub fn name(self) -> &'static str {
        match self {
            TimeForm::Seconds => "numeric seconds",
            TimeForm::Rfc3339 => "RFC 3339",
        }
    }
}

/// Why a time field was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimeError {
    /// Neither a number nor an RFC 3339 instant.
    Unreadable,
    /// Readable, but of the other form than the file's.
    OtherForm(TimeForm),
    /// Readable, but not finite or outside ±[`MAX_ABS_TIME_S`].
    OutOfRange,
}

/// Parses seconds: a finite number within the accepted range.
pub fn parse_seconds(s: &str) -> Result<f64, TimeError> {
    // `f64::from_str` also reads "inf" and "NaN"; they fall out by the range test.
    let t = crate::text::parse_f64(s.as_bytes()).ok_or(TimeError::Unreadable)?;
    check_range(t)
}

/// Parses an RFC 3339 instant into seconds since the Unix epoch (with the fraction).
pub fn parse_rfc3339(s: &str) -> Result<f64, TimeError> {
    let dt = OffsetDateTime::parse(s, &Rfc3339).map_err(|_| TimeError::Unreadable)?;
    let whole = dt.unix_timestamp() as f64;
    let frac = f64::from(dt.nanosecond()) * 1e-9;
    check_range(whole + frac)
}

fn check_range(t: f64) -> Result<f64, TimeError> {
    if t.is_finite() && t.abs() <= MAX_ABS_TIME_S {
        Ok(t)
    } else {
        Err(TimeError::OutOfRange)
    }
}

/// Reads a time field of a file whose form may not be known yet.
///
/// With `form == None` the field decides the form (a number first, then RFC 3339) and
/// the chosen form is stored in `form`; an unreadable field leaves it undecided.
pub fn parse_time(s: &str, form: &mut Option<TimeForm>) -> Result<f64, TimeError> {
    match *form {
        Some(TimeForm::Seconds) => match parse_seconds(s) {
            Err(TimeError::Unreadable) if parse_rfc3339(s).is_ok() => {
                Err(TimeError::OtherForm(TimeForm::Rfc3339))
            }
            r => r,
        },
        Some(TimeForm::Rfc3339) => match parse_rfc3339(s) {
            Err(TimeError::Unreadable) if s.parse::<f64>().is_ok() => {
                Err(TimeError::OtherForm(TimeForm::Seconds))
            }
            r => r,
        },
        None => {
            if s.parse::<f64>().is_ok() {
                *form = Some(TimeForm::Seconds);
                parse_seconds(s)
            } else if OffsetDateTime::parse(s, &Rfc3339).is_ok() {
                *form = Some(TimeForm::Rfc3339);
                parse_rfc3339(s)
            } else {
                Err(TimeError::Unreadable)
            }
        }
    }
}

/// [`parse_time`] of a field's bytes: a plain decimal in a file of seconds is read without
/// the UTF-8 check and the form tests, with the same result.
pub fn parse_time_field(field: &[u8], form: &mut Option<TimeForm>) -> Result<f64, TimeError> {
    if *form == Some(TimeForm::Seconds) {
        if let Some(t) = crate::text::parse_decimal(field) {
            return check_range(t);
        }
    }
    match std::str::from_utf8(field) {
        Ok(s) => parse_time(s, form),
        Err(_) => Err(TimeError::Unreadable),
    }
}

/// Times at or after this (s) are read as Unix time and shown as UTC dates: 1e8 s is
/// 3 Mar 1973, and a relative clock (seconds since a logger or a simulation started) stays
/// below it for its first three years.
pub const CALENDAR_FROM_S: f64 = 1.0e8;

/// True when `t` reads as Unix time ([`CALENDAR_FROM_S`]), so a date can be shown for it.
pub fn is_calendar(t: f64) -> bool {
    t.is_finite() && (CALENDAR_FROM_S..=MAX_ABS_TIME_S).contains(&t)
}

/// The UTC date and time of Unix time `t`, `None` for a relative clock.
fn utc(t: f64) -> Option<OffsetDateTime> {
    if !is_calendar(t) {
        return None;
    }
    OffsetDateTime::from_unix_timestamp(t.floor() as i64).ok()
}

/// A day for people: `3 Mar 2026` (UTC) for Unix time, `day 12.4` of a relative clock.
pub fn day_text(t: f64) -> String {
    match utc(t) {
        Some(d) => format!("{} {} {}", d.day(), month_abbrev(d.month()), d.year()),
        None => format!("day {:.1}", t / DAY_S),
    }
}

/// An instant for people: `2026-03-03 14:05 UTC` for Unix time, `day 12.41 of the data
/// clock` for a relative clock.
pub fn instant_text(t: f64) -> String {
    match utc(t) {
        Some(d) => format!(
            "{}-{:02}-{:02} {:02}:{:02} UTC",
            d.year(),
            u8::from(d.month()),
            d.day(),
            d.hour(),
            d.minute()
        ),
        None => format!("day {:.2} of the data clock", t / DAY_S),
    }
}

fn month_abbrev(m: time::Month) -> &'static str {
    const NAMES: [&str; 12] = [
        "Jan", "Feb", "Mar", "Apr", "May", "Jun", "Jul", "Aug", "Sep", "Oct", "Nov", "Dec",
    ];
    NAMES[usize::from(u8::from(m)) - 1]
}

/// Writes `t` (seconds since the Unix epoch) as an RFC 3339 instant at the UTC offset
/// `offset_s` (`Z` for 0): whole seconds as `2026-03-01T09:00:00+01:00`, a fraction to the
/// millisecond as `...T09:00:00.250+01:00`. The inverse of [`parse_rfc3339`] to 1 ms.
/// Times outside the parser's range ([`MAX_ABS_TIME_S`]) or a zone offset beyond ±26 h come
/// out as their plain seconds, which every reader of this crate also takes.
pub fn format_rfc3339(t: f64, offset_s: i32) -> String {
    let ms = (t * 1000.0).round() as i64;
    let (secs, milli) = (ms.div_euclid(1000), ms.rem_euclid(1000));
    let local = time::UtcOffset::from_whole_seconds(offset_s)
        .ok()
        .zip(OffsetDateTime::from_unix_timestamp(secs).ok())
        .and_then(|(off, d)| d.checked_to_offset(off));
    let Some(d) = local.filter(|_| t.abs() <= MAX_ABS_TIME_S) else {
        return format!("{t}");
    };
    let mut s = format!(
        "{:04}-{:02}-{:02}T{:02}:{:02}:{:02}",
        d.year(),
        u8::from(d.month()),
        d.day(),
        d.hour(),
        d.minute(),
        d.second()
    );
    if milli != 0 {
        s.push_str(&format!(".{milli:03}"));
    }
    if offset_s == 0 {
        s.push('Z');
    } else {
        let a = offset_s.unsigned_abs();
        let sign = if offset_s < 0 { '-' } else { '+' };
        s.push_str(&format!("{sign}{:02}:{:02}", a / 3600, a / 60 % 60));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sample::HOUR_S;

    #[test]
    fn unix_times_read_as_utc_dates_and_a_relative_clock_as_days() {
        let t = parse_rfc3339("2026-03-03T14:05:59Z").unwrap();
        assert_eq!(day_text(t), "3 Mar 2026");
        assert_eq!(instant_text(t), "2026-03-03 14:05 UTC");
        assert_eq!(day_text(3.5 * DAY_S), "day 3.5");
        assert_eq!(instant_text(DAY_S), "day 1.00 of the data clock");
        assert!(!is_calendar(f64::NAN));
    }

    #[test]
    fn numeric_seconds_keep_their_fraction() {
        assert_eq!(parse_seconds("12.25"), Ok(12.25));
        assert_eq!(parse_seconds("-3"), Ok(-3.0));
        assert_eq!(parse_seconds("1709280000.5"), Ok(1_709_280_000.5));
        assert_eq!(parse_seconds("1e3"), Ok(1000.0));
    }

    #[test]
    fn absurd_and_non_finite_times_are_out_of_range() {
        for s in ["1e300", "-1e300", "inf", "-inf", "NaN", "1e11"] {
            assert_eq!(parse_seconds(s), Err(TimeError::OutOfRange), "{s}");
        }
        assert_eq!(parse_seconds("12:00"), Err(TimeError::Unreadable));
        assert_eq!(parse_seconds(""), Err(TimeError::Unreadable));
    }

    #[test]
    fn rfc3339_utc_is_unix_seconds() {
        // 2026-03-01T00:00:00Z: 20513 days after 1970-01-01.
        let day = 20_513.0 * DAY_S;
        assert_eq!(parse_rfc3339("2026-03-01T00:00:00Z"), Ok(day));
        assert_eq!(
            parse_rfc3339("2026-03-01T08:00:00.250Z"),
            Ok(day + 8.0 * HOUR_S + 0.25)
        );
        assert_eq!(parse_rfc3339("1970-01-01T00:00:01Z"), Ok(1.0));
    }

    #[test]
    fn rfc3339_offsets_name_the_same_instant() {
        let z = parse_rfc3339("2026-03-01T08:00:00Z").unwrap();
        assert_eq!(parse_rfc3339("2026-03-01T09:00:00+01:00"), Ok(z));
        assert_eq!(parse_rfc3339("2026-03-01T02:30:00-05:30"), Ok(z));
        let frac = parse_rfc3339("2026-03-01T09:00:00.125+01:00").unwrap();
        assert!((frac - z - 0.125).abs() < 1e-6);
    }

    #[test]
    fn first_readable_time_fixes_the_form() {
        let mut form = None;
        assert_eq!(parse_time("garbage", &mut form), Err(TimeError::Unreadable));
        assert_eq!(form, None);
        assert!(parse_time("2026-03-01T00:00:00Z", &mut form).is_ok());
        assert_eq!(form, Some(TimeForm::Rfc3339));
        assert_eq!(
            parse_time("12.5", &mut form),
            Err(TimeError::OtherForm(TimeForm::Seconds))
        );

        let mut form = None;
        assert_eq!(parse_time("12.5", &mut form), Ok(12.5));
        assert_eq!(form, Some(TimeForm::Seconds));
        assert_eq!(
            parse_time("2026-03-01T00:00:00Z", &mut form),
            Err(TimeError::OtherForm(TimeForm::Rfc3339))
        );
        assert_eq!(parse_time("1e300", &mut form), Err(TimeError::OutOfRange));
    }

    #[test]
    fn rfc3339_out_reads_back_as_the_same_instant() {
        assert_eq!(format_rfc3339(0.0, 0), "1970-01-01T00:00:00Z");
        let z = parse_rfc3339("2026-03-01T08:00:00.250Z").unwrap();
        assert_eq!(format_rfc3339(z, 0), "2026-03-01T08:00:00.250Z");
        assert_eq!(format_rfc3339(z, 3600), "2026-03-01T09:00:00.250+01:00");
        assert_eq!(format_rfc3339(z, -19_800), "2026-03-01T02:30:00.250-05:30");
        for t in [-1e9, -0.5, 951_782_400.0, 4_107_542_399.0, 1.7e9 + 0.125] {
            for off in [0, 3600, -36_000] {
                let back = parse_rfc3339(&format_rfc3339(t, off)).unwrap();
                assert!((back - t).abs() < 1e-6, "{t} {off}: {back}");
            }
        }
        assert_eq!(format_rfc3339(951_782_400.0, 0), "2000-02-29T00:00:00Z");
    }
}
