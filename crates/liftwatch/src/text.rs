//! Numbers as CSV text, both ways: the one fixed-precision writer of every CSV liftwatch
//! writes (monitor rows, the simulator's raw log and truth) and the decimal reader in front of
//! `str::parse::<f64>`.
//!
//! ```text
//! write  v, d decimals   round(|v|·10^d) as an integer, then the digits; NaN -> nothing,
//!                        a value that rounds to zero -> 0.000, never -0.000
//! read   [+-]digits[.digits], at most 19 digits, mantissa m <= 2^53, k <= 22 decimals
//!                        -> m / 10^k, one IEEE division: correctly rounded, so the same
//!                           bits as `str::parse` (Clinger's fast path); anything else
//!                           (exponents, longer mantissas, words) -> `None`, for `str::parse`
//! ```
//!
//! Both exist because the monitor's process spends most of its time here: a 30-day aligned
//! file is 18 M numbers in and 28 M out. Beside them, [`sig3`]: a number in a sentence.

use std::io::Write as _;

/// Largest |v|·10^d written through integers (below 2^53, exact in an f64); larger values,
/// never seen in practice, go through the standard formatter.
const MAX_SCALED: f64 = 9.0e15;

/// Powers of ten exact in an f64 (10^22 is the last one).
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// Appends `v` with `dec` decimals (at most 9); nothing for a non-finite value (a missing
/// field), no `-0.000`.
///
/// Integer arithmetic instead of `format!`, which formats the exact binary value digit by
/// digit: several times faster. Values beyond `MAX_SCALED` fall back to `format!`.
pub fn push_fixed(out: &mut Vec<u8>, v: f64, dec: usize) {
    match Fixed::of(v, dec) {
        Fixed::Missing => {}
        Fixed::Digits(f) => {
            let (buf, i) = f.text();
            out.extend_from_slice(&buf[i..]);
        }
        Fixed::Large => {
            let dec = dec.min(9);
            let _ = write!(out, "{v:.dec$}");
        }
    }
}

/// A value as [`push_fixed`] writes it, before its digits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Fixed {
    /// Not finite: an empty field.
    Missing,
    /// Beyond [`MAX_SCALED`]: the standard formatter's text.
    Large,
    /// round(|v|·10^dec), its sign and `dec`: the text is a function of these alone.
    Digits(Rounded),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Rounded {
    n: u64,
    negative: bool,
    dec: usize,
}

impl Fixed {
    #[inline]
    fn of(v: f64, dec: usize) -> Fixed {
        if !v.is_finite() {
            return Fixed::Missing;
        }
        let dec = dec.min(9);
        let x = v.abs() * POW10[dec];
        if x >= MAX_SCALED {
            return Fixed::Large;
        }
        // `x.round()` (half away from zero) without the libm call that baseline x86-64 makes
        // of it: the truncation and the remainder of a float below 2^53 are exact, and signed
        // integers convert to and from floats in one instruction each.
        let t = x as i64;
        let n = t + i64::from(x - t as f64 >= 0.5);
        if n >= MAX_SCALED as i64 {
            return Fixed::Large;
        }
        Fixed::Digits(Rounded {
            n: n as u64,
            negative: v < 0.0 && n != 0,
            dec,
        })
    }
}

impl Rounded {
    /// The text right to left in one small buffer: exactly `dec` digits of the fraction, the
    /// point, the whole part, the sign; the digits peeled off `n` itself, so no division by
    /// the variable 10^dec. Returns the buffer and where the text starts in it.
    fn text(self) -> ([u8; 32], usize) {
        let mut buf = [0u8; 32];
        let mut i = buf.len();
        let mut m = self.n;
        for _ in 0..self.dec / 2 {
            i -= 2;
            put_pair(&mut buf, i, m % 100);
            m /= 100;
        }
        if self.dec % 2 == 1 {
            i -= 1;
            buf[i] = b'0' + (m % 10) as u8;
            m /= 10;
        }
        if self.dec > 0 {
            i -= 1;
            buf[i] = b'.';
        }
        i = put_whole(&mut buf, i, m);
        if self.negative {
            i -= 1;
            buf[i] = b'-';
        }
        (buf, i)
    }
}

/// One column of rows written by [`push_fixed`] that keeps its last text: a value that rounds
/// to the digits of the row before is copied instead of formatted again, and the very value
/// of the row before is not even rounded again. Between trips most of a monitor's columns
/// (risks, drifts) hold still from one second to the next.
///
/// The text goes into the line as one copy. Pushed byte by byte (against the store-forwarding
/// stall of copying bytes just stored one at a time) the row writer took 171 ns a row against
/// 148 (`cargo bench --bench monitor`): each push stores the vector's length again, and most
/// of a row's texts are a column's kept text, stored rows before. A fixed 16-byte copy of
/// left-aligned texts and a truncation was slower still (180 ns).
#[derive(Clone, Debug)]
pub struct FixedColumn {
    dec: usize,
    last: Option<Rounded>,
    /// The bits of the last value written from digits, whose text `text` holds.
    last_bits: Option<u64>,
    text: [u8; 32],
    start: usize,
}

impl FixedColumn {
    /// A column of `dec` decimals (at most 9).
    pub fn new(dec: usize) -> Self {
        FixedColumn {
            dec,
            last: None,
            last_bits: None,
            text: [0; 32],
            start: 32,
        }
    }

    /// Appends `v` as [`push_fixed`] does, to the byte.
    pub fn push(&mut self, out: &mut Vec<u8>, v: f64) {
        if self.last_bits != Some(v.to_bits()) {
            let Fixed::Digits(r) = Fixed::of(v, self.dec) else {
                push_fixed(out, v, self.dec);
                return;
            };
            if self.last != Some(r) {
                (self.text, self.start) = r.text();
                self.last = Some(r);
            }
            self.last_bits = Some(v.to_bits());
        }
        out.extend_from_slice(&self.text[self.start..]);
    }
}

/// Writes the digits of `m` into `buf` right to left, ending before `end`; returns where
/// they start.
fn put_whole(buf: &mut [u8; 32], mut end: usize, mut m: u64) -> usize {
    while m >= 100 {
        end -= 2;
        put_pair(buf, end, m % 100);
        m /= 100;
    }
    if m >= 10 {
        end -= 2;
        put_pair(buf, end, m);
    } else {
        end -= 1;
        buf[end] = b'0' + m as u8;
    }
    end
}

/// The two digits of `r` (below 100) at `buf[at..at + 2]`, from [`DIGIT_PAIRS`]: half the
/// dependent divisions of peeling one digit at a time.
#[inline]
fn put_pair(buf: &mut [u8; 32], at: usize, r: u64) {
    let k = 2 * r as usize;
    buf[at] = DIGIT_PAIRS[k];
    buf[at + 1] = DIGIT_PAIRS[k + 1];
}

/// "00", "01", … "99" in one string.
const DIGIT_PAIRS: &[u8; 200] = b"\
0001020304050607080910111213141516171819\
2021222324252627282930313233343536373839\
4041424344454647484950515253545556575859\
6061626364656667686970717273747576777879\
8081828384858687888990919293949596979899";

/// Appends the decimal digits of `n`.
pub fn push_u64(out: &mut Vec<u8>, n: u64) {
    let mut buf = [0u8; 32];
    let i = put_whole(&mut buf, 32, n);
    out.extend_from_slice(&buf[i..]);
}

/// Appends `t` exactly as `format!("{t}")` writes it (the shortest text that reads back
/// the same); whole numbers, the grid times of a 1 s step, through [`push_u64`].
pub fn push_shortest(out: &mut Vec<u8>, t: f64) {
    // `-0.0` is written `-0` by the standard formatter: left to it, as every other case.
    // Whole when its truncation is itself (exact below MAX_SCALED; `fract` is a libm call on
    // the baseline x86-64 target).
    if t.abs() < MAX_SCALED && (t as i64) as f64 == t && !(t == 0.0 && t.is_sign_negative()) {
        if t < 0.0 {
            out.push(b'-');
        }
        push_u64(out, t.abs() as u64);
    } else {
        let _ = write!(out, "{t}");
    }
}

/// Reads a plain decimal (`-12.26`, `0.000`, `+3`, `.5`) with the same result as
/// `str::parse::<f64>`; `None` for anything else, which the caller hands to `str::parse`.
pub fn parse_decimal(s: &[u8]) -> Option<f64> {
    let (negative, digits) = match s.first()? {
        b'-' => (true, &s[1..]),
        b'+' => (false, &s[1..]),
        _ => (false, s),
    };
    // The whole part's digits, then the fraction's: one test a byte (a digit less '0' wraps
    // above 9 for anything else). m wraps past 19 digits, but such a text is refused below.
    let mut m: u64 = 0;
    let mut i = 0;
    let mut run = |i: &mut usize| {
        while let Some(d) = digits
            .get(*i)
            .map(|b| b.wrapping_sub(b'0'))
            .filter(|d| *d < 10)
        {
            m = m.wrapping_mul(10).wrapping_add(u64::from(d));
            *i += 1;
        }
    };
    run(&mut i);
    let whole = i;
    let mut decimals = 0;
    if digits.get(i) == Some(&b'.') {
        i += 1;
        run(&mut i);
        decimals = i - whole - 1;
    }
    let n_digits = whole + decimals;
    if i != digits.len() || n_digits == 0 || n_digits > 19 {
        return None;
    }
    if m > 1 << 53 || decimals >= POW10.len() {
        return None;
    }
    // m and 10^k are exact, so the one division rounds correctly, as `str::parse` does. A
    // whole number (a time, a door, a floor, a speed of 0) needs none: half the reader's
    // time in this function was the division's latency.
    let v = if decimals == 0 {
        m as f64
    } else {
        m as f64 / POW10[decimals]
    };
    Some(if negative { -v } else { v })
}

/// Reads a float as `str::parse::<f64>` does, plain decimals through [`parse_decimal`].
pub fn parse_f64(s: &[u8]) -> Option<f64> {
    parse_decimal(s).or_else(|| std::str::from_utf8(s).ok()?.parse().ok())
}

/// A number for a sentence: three significant digits, plainly (an exponent only outside
/// 10⁻³ to 10⁶), `0` for zero and `n/a` for a value that is not a number.
pub fn sig3(v: f64) -> String {
    if !v.is_finite() {
        return "n/a".into();
    }
    let a = v.abs();
    if a == 0.0 {
        "0".into()
    } else if !(1e-3..1e6).contains(&a) {
        format!("{v:.2e}")
    } else {
        let d = (2 - a.log10().floor() as i32).max(0) as usize;
        format!("{v:.d$}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    fn fixed(v: f64, d: usize) -> String {
        let mut o = Vec::new();
        push_fixed(&mut o, v, d);
        String::from_utf8(o).unwrap()
    }

    #[test]
    fn fixed_point_text_is_within_half_a_unit_of_the_value() {
        let mut rng = Rng::new(7);
        for k in 0..20_000 {
            let v = match k % 4 {
                0 => rng.uniform(-1.0, 1.0),
                1 => rng.uniform(-500.0, 500.0),
                2 => rng.uniform(0.0, 3e6),
                _ => (rng.uniform(-50.0, 50.0) * 4.0).round() / 4.0,
            };
            for dec in [0, 1, 2, 3, 4, 7] {
                // The same digits as rounding with `f64::round` and `format!` of the integer.
                let scale = 10u64.pow(dec as u32);
                let n = (v.abs() * scale as f64).round() as u64;
                let sign = if v < 0.0 && n != 0 { "-" } else { "" };
                let (w, f) = (n / scale, n % scale);
                let want = match dec {
                    0 => format!("{sign}{w}"),
                    _ => format!("{sign}{w}.{f:0dec$}"),
                };
                assert_eq!(fixed(v, dec), want);
                let got: f64 = fixed(v, dec).parse().unwrap();
                // Within half a unit of the last digit, as `format!` would be.
                let half = 0.5 * 10f64.powi(-(dec as i32));
                assert!(
                    (got - v).abs() <= half * (1.0 + 1e-6) + 1e-9 * v.abs(),
                    "{v} {dec} -> {got}"
                );
            }
        }
    }

    #[test]
    fn fixed_point_rounds_and_never_writes_minus_zero() {
        assert_eq!(fixed(-0.0004, 3), "0.000");
        assert_eq!(fixed(-1.25, 2), "-1.25");
        assert_eq!(fixed(0.05, 3), "0.050");
        assert_eq!(fixed(12.0, 0), "12");
        assert_eq!(fixed(2.5, 0), "3");
        assert_eq!(fixed(-12.26, 1), "-12.3");
        assert_eq!(fixed(f64::NAN, 2), "");
        assert_eq!(fixed(1e12, 1), "1000000000000.0");
        assert_eq!(fixed(1e17, 1), "100000000000000000.0");
    }

    #[test]
    fn a_column_that_keeps_its_last_text_writes_the_same_bytes() {
        // Runs of repeated values (a monitor's columns between trips), values that round to
        // the same digits from different bits, sign changes through zero, gaps, the large.
        let mut rng = Rng::new(5);
        for dec in [0, 1, 2, 3, 9] {
            let mut column = FixedColumn::new(dec);
            let (mut got, mut want) = (Vec::new(), Vec::new());
            let mut v = 0.0;
            for k in 0..20_000 {
                v = match k % 7 {
                    0..=2 => v,
                    3 => v + rng.uniform(-1e-5, 1e-5),
                    4 => rng.uniform(-2.0, 2.0) * 10f64.powi(-(dec as i32)),
                    5 => [f64::NAN, f64::INFINITY, 1e17, -0.0][rng.below(4) as usize],
                    // Half the time the special value of the row before once more.
                    _ if k % 2 == 0 => v,
                    _ => rng.uniform(-500.0, 500.0),
                };
                column.push(&mut got, v);
                push_fixed(&mut want, v, dec);
                got.push(b',');
                want.push(b',');
            }
            assert_eq!(
                String::from_utf8(got).unwrap(),
                String::from_utf8(want).unwrap()
            );
        }
    }

    #[test]
    fn shortest_text_is_the_standard_formatters() {
        let mut rng = Rng::new(3);
        let mut cases = vec![
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.5,
            -0.5,
            1e15,
            8.99e15,
            9.1e15,
            1e300,
            -7.25,
            1e-7,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ];
        cases.extend((0..2000).map(|_| rng.uniform(-1e7, 1e7).round()));
        cases.extend((0..2000).map(|_| (rng.uniform(0.0, 1e6) * 10.0).round() / 10.0));
        for t in cases {
            let mut o = Vec::new();
            push_shortest(&mut o, t);
            assert_eq!(String::from_utf8(o).unwrap(), format!("{t}"));
        }
    }

    #[test]
    fn decimals_read_to_the_same_bits_as_str_parse() {
        let mut rng = Rng::new(11);
        let mut texts: Vec<String> = [
            "0",
            "-0",
            "-0.000",
            "+3",
            ".5",
            "5.",
            "1.5",
            "9007199254740993",
            "0.1",
            "123.456",
            "-12.26",
            "1e3",
            "nan",
            "inf",
            "",
            "-",
            ".",
            "1.2.3",
            "12a",
            "00012.5000",
            "0.30000000000000004",
            "1234567890123456789",
            "12345678901234567890",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        for _ in 0..20_000 {
            let v = rng.uniform(-5e4, 5e4);
            let d = (rng.uniform(0.0, 10.0) as usize).min(9);
            texts.push(format!("{v:.d$}"));
            texts.push(format!("{v}"));
        }
        for s in texts {
            let want = s.parse::<f64>().ok();
            let got = parse_f64(s.as_bytes());
            assert_eq!(got.map(f64::to_bits), want.map(f64::to_bits), "`{s}`");
        }
    }
}
