//! Stage 1, the record splitter under [`super::csv`]: a telemetry file's bytes to records of
//! fields, with the line each record ends on.
//!
//! ```text
//! line without '"'   split at its commas by hand, 8 bytes a step  -- nearly every line
//! line with '"'      the line read by csv_core (RFC 4180 quotes, "" inside)
//! quote open at EOL  the line split at its commas, quote characters and all: a bad row
//! empty line         skipped (as csv_core skips it); "\r" alone is a record of one field
//! ```
//!
//! Deviation from RFC 4180: a record never spans lines. No field of telemetry holds a line
//! break (a time, a signal's name, a number), so a quote still open at the end of its line is a
//! broken line, not a field that goes on: read as RFC 4180 reads it, one stray quote took
//! every good row after it into one record, silently, up to the next quote.
//!
//! Written by hand because csv_core's byte-by-byte state machine was the largest single cost
//! of a `monitor` run (22 % of its CPU on 30 aligned days, `perf`): a line without a quote
//! holds no escape, so its fields are exactly the bytes between its commas, found eight bytes
//! at a time with any quote (`comma_ends`; `memchr` finds the line's end). Every record with
//! a quote still goes through csv_core, so the two paths return the same fields; a test
//! compares them with the `csv` crate's reader on random texts of quotes, commas, CR and
//! blank lines, handed over a few bytes at a time.
//!
//! Deviation from the paper: none; the paper does not describe its file format.

use std::io::{self, Read};

use crate::limits::{MAX_LINE_BYTES, MAX_SKIPPED_BYTES};

/// Bytes read from the file at a time.
const CHUNK_BYTES: usize = 1 << 16;

/// The records of a CSV file, one at a time into reused buffers: a good line allocates
/// nothing.
pub struct Records<R> {
    src: R,
    /// Bytes read and not yet consumed: `buf[pos..filled]`.
    buf: Vec<u8>,
    pos: usize,
    filled: usize,
    eof: bool,
    /// Line breaks consumed so far.
    breaks: u64,
    /// Line of the current record's last byte (1-based).
    line: u64,
    /// Where the current record's fields are: a split line's in `buf`, a quoted record's in
    /// `unescaped` (csv_core's output).
    quoted: bool,
    unescaped: Vec<u8>,
    /// Field `i` ends at `ends[i]` and starts where field `i - 1` ends, plus one past its
    /// comma for a split line; field 0 starts at `start0`.
    ends: Vec<usize>,
    start0: usize,
    n_fields: usize,
    core: csv_core::Reader,
    /// The current record is an over-long line, skipped.
    overlong: bool,
}

impl<R: Read> Records<R> {
    /// Records of `input`.
    pub fn new(input: R) -> Self {
        Records {
            src: input,
            buf: vec![0; CHUNK_BYTES],
            pos: 0,
            filled: 0,
            eof: false,
            breaks: 0,
            line: 0,
            quoted: false,
            unescaped: vec![0; 256],
            ends: vec![0; 16],
            start0: 0,
            n_fields: 0,
            core: csv_core::ReaderBuilder::new()
                .terminator(csv_core::Terminator::Any(b'\n'))
                .build(),
            overlong: false,
        }
    }

    /// The input, to read it again from the start.
    pub fn into_inner(self) -> R {
        self.src
    }

    /// True when the current record is a line longer than [`MAX_LINE_BYTES`], skipped to its
    /// end unread (no fields): a bad row, not the end of the file.
    pub fn overlong(&self) -> bool {
        self.overlong
    }

    /// Fields of the current record.
    pub fn len(&self) -> usize {
        self.n_fields
    }

    /// True before the first record and after the last.
    pub fn is_empty(&self) -> bool {
        self.n_fields == 0
    }

    /// Field `i` of the current record.
    ///
    /// # Panics
    /// When `i` is not below [`Self::len`].
    #[inline]
    pub fn field(&self, i: usize) -> &[u8] {
        assert!(
            i < self.n_fields,
            "field {i} of a record of {}",
            self.n_fields
        );
        let (bytes, gap) = if self.quoted {
            (&self.unescaped[..], 0)
        } else {
            (&self.buf[..], 1)
        };
        let start = if i == 0 {
            self.start0
        } else {
            self.ends[i - 1] + gap
        };
        &bytes[start..self.ends[i]]
    }

    /// The fields of the current record in order.
    pub fn iter(&self) -> impl Iterator<Item = &[u8]> {
        (0..self.n_fields).map(|i| self.field(i))
    }

    /// Line of the current record's last byte (1-based; a quoted field may span lines).
    pub fn line(&self) -> u64 {
        self.line
    }

    /// Reads the next record; `false` at the end of the file.
    ///
    /// # Errors
    /// A read error, or [`MAX_SKIPPED_BYTES`] without a line break.
    pub fn read(&mut self) -> io::Result<bool> {
        self.n_fields = 0;
        self.overlong = false;
        loop {
            let start = self.pos;
            let avail = &self.buf[start..self.filled];
            let (len, terminated) = match memchr::memchr(b'\n', avail) {
                Some(k) if k as u64 <= MAX_LINE_BYTES => (k, true),
                Some(_) => return self.skip_overlong(),
                None if avail.len() as u64 > MAX_LINE_BYTES => return self.skip_overlong(),
                // A line cut by the end of the buffer: read on and look again.
                None if !self.eof => {
                    self.fill()?;
                    continue;
                }
                None if avail.is_empty() => return Ok(false),
                None => (avail.len(), false),
            };
            self.pos += len + usize::from(terminated);
            self.breaks += u64::from(terminated);
            let line = &avail[..len];
            if line.is_empty() {
                // A blank line is no record (csv_core skips it too).
                continue;
            }
            self.line = self.breaks + u64::from(!terminated);
            let (mut n, quoted) = comma_ends(line, start, &mut self.ends);
            if quoted {
                if self.read_quoted(start, len) {
                    return Ok(true);
                }
                // A quote still open at the line's end, and csv_core wrote over the ends:
                // the line split at every comma again.
                n = comma_ends(&self.buf[start..start + len], start, &mut self.ends).0;
            }
            self.n_fields = n;
            self.start0 = start;
            self.quoted = false;
            return Ok(true);
        }
    }

    /// Skips the over-long line at `pos` through its break (or the end of the file), a record
    /// of no fields flagged [`Self::overlong`]. Memory stays bounded: what is skipped is
    /// dropped as it is read.
    fn skip_overlong(&mut self) -> io::Result<bool> {
        let mut skipped: u64 = 0;
        loop {
            let avail = &self.buf[self.pos..self.filled];
            if let Some(k) = memchr::memchr(b'\n', avail) {
                self.pos += k + 1;
                self.breaks += 1;
                self.line = self.breaks;
                break;
            }
            skipped += avail.len() as u64;
            self.pos = self.filled;
            if skipped > MAX_SKIPPED_BYTES {
                return Err(io::Error::new(
                    io::ErrorKind::InvalidData,
                    format!(
                        "no line break in {} MiB: not a text log",
                        MAX_SKIPPED_BYTES >> 20
                    ),
                ));
            }
            if self.eof {
                self.line = self.breaks + 1;
                break;
            }
            self.fill()?;
        }
        self.overlong = true;
        Ok(true)
    }

    /// Reads the line of `len` bytes at `start` (its break left out) through csv_core;
    /// `false`, with csv_core reset, when a quote is still open at the line's end.
    fn read_quoted(&mut self, start: usize, len: usize) -> bool {
        use csv_core::ReadRecordResult as R;
        let (mut out, mut n) = (0, 0);
        // The line, then a line break of its own (the last line of a file may have none):
        // a record by then is the line's; none means a quote is still open.
        let (mut at, mut fed_break) = (start, false);
        loop {
            let in_line = at < start + len;
            let input: &[u8] = if in_line {
                &self.buf[at..start + len]
            } else if !fed_break {
                b"\n"
            } else {
                self.core.reset();
                return false;
            };
            let (res, nin, nout, nend) =
                self.core
                    .read_record(input, &mut self.unescaped[out..], &mut self.ends[n..]);
            if in_line {
                at += nin;
            } else {
                fed_break = nin > 0;
            }
            out += nout;
            n += nend;
            match res {
                R::InputEmpty | R::End => {}
                R::OutputFull => self.unescaped.resize(2 * self.unescaped.len(), 0),
                R::OutputEndsFull => self.ends.resize(2 * self.ends.len(), 0),
                R::Record => {
                    self.n_fields = n;
                    self.start0 = 0;
                    self.quoted = true;
                    return true;
                }
            }
        }
    }

    /// Moves the unconsumed bytes to the front and reads more after them, doubling the
    /// buffer when a line fills it; sets `eof` at the end of the input.
    fn fill(&mut self) -> io::Result<()> {
        self.buf.copy_within(self.pos..self.filled, 0);
        self.filled -= self.pos;
        self.pos = 0;
        if self.filled == self.buf.len() {
            self.buf.resize(2 * self.buf.len(), 0);
        }
        loop {
            match self.src.read(&mut self.buf[self.filled..]) {
                Ok(0) => {
                    self.eof = true;
                    return Ok(());
                }
                Ok(k) => {
                    self.filled += k;
                    return Ok(());
                }
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
        }
    }
}

/// Writes the end of each comma-separated field of `line` into `ends` (as offsets from
/// `offset`, the line's place in its buffer), growing it as needed; returns the number of
/// fields and whether the line holds a quote (then csv_core reads it).
///
/// Eight bytes at a time: a word's bytes that equal `,` (or `"`) are found with the exact
/// zero-byte test (no borrow between bytes), and its commas taken lowest first from the
/// mask. The line is read once for both: the quote had a `memchr` pass of its own.
/// (Tried and not kept: `memchr2_iter` for both, whose per-match start-up on 15 fields a line
/// took twice the time; sixteen-byte masks built byte by byte, which the compiler did not
/// turn into one vector comparison.)
fn comma_ends(line: &[u8], offset: usize, ends: &mut Vec<usize>) -> (usize, bool) {
    const COMMAS: u64 = u64::from_le_bytes([b','; 8]);
    const QUOTES: u64 = u64::from_le_bytes([b'"'; 8]);
    const LOW7: u64 = 0x7f7f_7f7f_7f7f_7f7f;
    // The high bit of each byte that is zero in x.
    let zero_bytes = |x: u64| !(((x & LOW7) + LOW7) | x | LOW7);
    let mut n = 0;
    let mut push = |at: usize, n: &mut usize| {
        if *n == ends.len() {
            ends.push(0);
        }
        ends[*n] = offset + at;
        *n += 1;
    };
    let mut quotes = 0;
    let mut words = line.chunks_exact(8);
    let mut base = 0;
    for w in &mut words {
        let x = u64::from_le_bytes(w.try_into().expect("a chunk of 8 bytes"));
        quotes |= zero_bytes(x ^ QUOTES);
        let mut m = zero_bytes(x ^ COMMAS);
        while m != 0 {
            push(base + (m.trailing_zeros() / 8) as usize, &mut n);
            m &= m - 1;
        }
        base += 8;
    }
    for (i, &b) in words.remainder().iter().enumerate() {
        if b == b',' {
            push(base + i, &mut n);
        }
        quotes |= u64::from(b == b'"');
    }
    push(line.len(), &mut n);
    (n, quotes != 0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    /// A reader that hands out a few bytes per call, so that records straddle refills.
    struct Trickle<'a> {
        rest: &'a [u8],
        rng: Rng,
    }

    impl Read for Trickle<'_> {
        fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
            let k = (1 + self.rng.below(7) as usize)
                .min(self.rest.len())
                .min(buf.len());
            buf[..k].copy_from_slice(&self.rest[..k]);
            self.rest = &self.rest[k..];
            Ok(k)
        }
    }

    /// Every record with the line it ends on, from [`Records`].
    fn ours(input: impl Read) -> Vec<(Vec<Vec<u8>>, u64)> {
        let mut r = Records::new(input);
        let mut out = Vec::new();
        while r.read().unwrap() {
            out.push((r.iter().map(<[u8]>::to_vec).collect(), r.line()));
        }
        out
    }

    /// The same from the `csv` crate set up as the reader was before it (`\n` ends a line,
    /// any number of fields, no header), one line at a time: the record it reads from the
    /// line, or, where a quote is still open at the line's end (its record would run on past
    /// the line's break), the line's bytes split at every comma.
    fn theirs(text: &[u8]) -> Vec<(Vec<Vec<u8>>, u64)> {
        let mut out = Vec::new();
        for (i, line) in text.split(|&b| b == b'\n').enumerate() {
            if line.is_empty() {
                continue;
            }
            // The line with a break and one more byte: a record that ends past the break
            // had a quote open.
            let probe = [line, b"\nx"].concat();
            let mut r = csv::ReaderBuilder::new()
                .has_headers(false)
                .flexible(true)
                .terminator(csv::Terminator::Any(b'\n'))
                .from_reader(&probe[..]);
            let mut rec = csv::ByteRecord::new();
            assert!(r.read_byte_record(&mut rec).unwrap());
            let fields: Vec<Vec<u8>> = if r.position().byte() as usize <= line.len() + 1 {
                rec.iter().map(<[u8]>::to_vec).collect()
            } else {
                line.split(|&b| b == b',').map(<[u8]>::to_vec).collect()
            };
            out.push((fields, i as u64 + 1));
        }
        out
    }

    #[test]
    fn splits_as_csv_core_does_on_random_texts() {
        const ALPHABET: &[u8] = b"a1.,,,,\"\"\n\n\r ";
        let mut rng = Rng::new(7);
        for case in 0..3_000 {
            let len = rng.below(if case % 10 == 0 { 3_000 } else { 60 }) as usize;
            let text: Vec<u8> = (0..len)
                .map(|_| ALPHABET[rng.below(ALPHABET.len() as u64) as usize])
                .collect();
            let want = theirs(&text);
            assert_eq!(
                ours(&text[..]),
                want,
                "case {case}: {:?}",
                String::from_utf8_lossy(&text)
            );
            let trickle = Trickle {
                rest: &text,
                rng: Rng::new(case),
            };
            assert_eq!(ours(trickle), want, "case {case}, trickled");
        }
    }

    #[test]
    fn telemetry_lines_split_at_their_commas_with_their_lines() {
        let text = b"time,speed\r\n\n1,0.5\n\n2,\"1,5\"\n3,\"a\nb\"\n4,x";
        let got = ours(&text[..]);
        let fields: Vec<Vec<&str>> = got
            .iter()
            .map(|(f, _)| f.iter().map(|x| std::str::from_utf8(x).unwrap()).collect())
            .collect();
        assert_eq!(
            fields,
            vec![
                vec!["time", "speed\r"],
                vec!["1", "0.5"],
                vec!["2", "1,5"],
                // A quote open at a line's end breaks that line alone (a bad row), and the
                // next line is read as the line it is.
                vec!["3", "\"a"],
                vec!["b\""],
                vec!["4", "x"],
            ]
        );
        assert_eq!(
            got.iter().map(|r| r.1).collect::<Vec<_>>(),
            vec![1, 3, 5, 6, 7, 8]
        );
    }

    #[test]
    fn an_overlong_line_is_skipped_as_one_record_and_the_file_read_on() {
        // Ten good lines, 1.1 MiB of NUL bytes as a crash leaves them, a good line, and an
        // over-long last line without a break.
        let mut text = b"1,speed,0\n".repeat(10);
        text.extend(vec![0u8; 1_100_000]);
        text.extend(b"\n2,speed,1\n");
        text.extend(vec![b'x'; 1_200_000]);
        let trickle = Trickle {
            rest: &text,
            rng: Rng::new(3),
        };
        let mut r = Records::new(trickle);
        let mut got = Vec::new();
        while r.read().unwrap() {
            got.push((r.len(), r.overlong(), r.line()));
        }
        let mut want = vec![(3, false, 0); 10];
        for (i, w) in want.iter_mut().enumerate() {
            w.2 = i as u64 + 1;
        }
        want.extend([(0, true, 11), (3, false, 12), (0, true, 13)]);
        assert_eq!(got, want);
        // Without a line break for long, the input is no text log.
        let mut r = Records::new(std::io::repeat(0).take(MAX_SKIPPED_BYTES + (4 << 20)));
        let err = r.read().unwrap_err();
        assert!(err.to_string().contains("no line break"), "{err}");
    }

    #[test]
    fn a_quote_never_closed_breaks_its_line_alone_not_the_rest_of_the_file() {
        let mut text = b"time,signal,value\n1,\"speed,2\n".to_vec();
        text.extend(b"2,speed,1\n".repeat(200_000));
        let got = ours(&text[..]);
        assert_eq!(got.len(), 200_002, "every line a record");
        assert_eq!(
            got[1],
            (vec![b"1".to_vec(), b"\"speed".to_vec(), b"2".to_vec()], 2)
        );
        assert!(got[2..]
            .iter()
            .enumerate()
            .all(|(i, (f, line))| f.len() == 3 && *line == i as u64 + 3));
    }
}
