//! Stage 1, the record splitter under [`super::csv`]: a telemetry file's bytes to records of
//! fields, with the line each record ends on.
//!
//! ```text
//! line without '"'   split at its commas by hand, 8 bytes a step  -- nearly every line
//! line with '"'      the record read by csv_core (RFC 4180 quotes, "" inside, line breaks
//!                    inside quotes), from the line's start to the record's end
//! empty line         skipped (as csv_core skips it); "\r" alone is a record of one field
//! record > 1 MiB     an error (a quote never closed would make the rest of the file one record)
//! ```
//!
//! Written by hand because csv_core's byte-by-byte state machine was the largest single cost
//! of a `monitor` run (22 % of its CPU on 30 aligned days, `perf`): a line without a quote
//! holds no escape, so its fields are exactly the bytes between its commas, found eight bytes
//! at a time (`comma_ends`; `memchr` finds the line's end and any quote). Every record with
//! a quote still goes through csv_core, so the two paths return the same fields; a test
//! compares them with the `csv` crate's reader on random texts of quotes, commas, CR and
//! blank lines, handed over a few bytes at a time.
//!
//! Deviation from the paper: none; the paper does not describe its file format.

use std::io::{self, Read};

use crate::limits::{LineBounded, MAX_LINE_BYTES};

/// Bytes read from the file at a time.
const CHUNK_BYTES: usize = 1 << 16;

/// The records of a CSV file, one at a time into reused buffers: a good line allocates
/// nothing.
pub struct Records<R> {
    src: LineBounded<R>,
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
}

impl<R: Read> Records<R> {
    /// Records of `input`; a line longer than [`MAX_LINE_BYTES`] fails the read.
    pub fn new(input: R) -> Self {
        Records {
            src: LineBounded::new(input),
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
        }
    }

    /// The input, to read it again from the start.
    pub fn into_inner(self) -> R {
        self.src.into_inner()
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
    /// A read error, a line longer than [`MAX_LINE_BYTES`], or a quoted record longer than
    /// it.
    pub fn read(&mut self) -> io::Result<bool> {
        self.n_fields = 0;
        loop {
            let start = self.pos;
            let avail = &self.buf[start..self.filled];
            let (len, terminated) = match memchr::memchr(b'\n', avail) {
                Some(k) => (k, true),
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
            if memchr::memchr(b'"', line).is_some() {
                self.pos = start;
                self.breaks -= u64::from(terminated);
                return self.read_quoted();
            }
            let n = comma_ends(line, start, &mut self.ends);
            self.n_fields = n;
            self.start0 = start;
            self.quoted = false;
            self.line = self.breaks + u64::from(!terminated);
            return Ok(true);
        }
    }

    /// Reads the record at `pos` through csv_core, refilling the buffer as it asks.
    fn read_quoted(&mut self) -> io::Result<bool> {
        use csv_core::ReadRecordResult as R;
        let (mut out, mut n) = (0, 0);
        // Whether the record's last byte so far is a line break: its line is the one that
        // break ends (the terminator's, or a quoted field's last at the end of the file).
        let mut ends_on_break = false;
        loop {
            let input = &self.buf[self.pos..self.filled];
            let (res, nin, nout, nend) =
                self.core
                    .read_record(input, &mut self.unescaped[out..], &mut self.ends[n..]);
            let consumed = &input[..nin];
            if let Some(&last) = consumed.last() {
                ends_on_break = last == b'\n';
            }
            self.breaks += memchr::memchr_iter(b'\n', consumed).count() as u64;
            self.pos += nin;
            out += nout;
            n += nend;
            if out as u64 > MAX_LINE_BYTES {
                return Err(io::Error::new(
                    io::ErrorKind::InvalidData,
                    format!(
                        "a quoted record longer than {} KiB (a quote never closed?)",
                        MAX_LINE_BYTES >> 10
                    ),
                ));
            }
            match res {
                R::InputEmpty if self.eof && nin == 0 => return Ok(false),
                R::InputEmpty => self.fill()?,
                R::OutputFull => self.unescaped.resize(2 * self.unescaped.len(), 0),
                R::OutputEndsFull => self.ends.resize(2 * self.ends.len(), 0),
                R::Record => {
                    self.n_fields = n;
                    self.start0 = 0;
                    self.quoted = true;
                    self.line = self.breaks + u64::from(!ends_on_break);
                    return Ok(true);
                }
                R::End => return Ok(false),
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
/// fields.
///
/// Eight bytes at a time: a word's bytes that equal `,` are found with the exact zero-byte
/// test (no borrow between bytes), and its commas taken lowest first from the mask.
fn comma_ends(line: &[u8], offset: usize, ends: &mut Vec<usize>) -> usize {
    const COMMAS: u64 = u64::from_le_bytes([b','; 8]);
    const LOW7: u64 = 0x7f7f_7f7f_7f7f_7f7f;
    let mut n = 0;
    let mut push = |at: usize, n: &mut usize| {
        if *n == ends.len() {
            ends.push(0);
        }
        ends[*n] = offset + at;
        *n += 1;
    };
    let mut words = line.chunks_exact(8);
    let mut base = 0;
    for w in &mut words {
        let x = u64::from_le_bytes(w.try_into().expect("a chunk of 8 bytes")) ^ COMMAS;
        // The high bit of each byte that is zero in x, that is a comma in the line.
        let mut m = !(((x & LOW7) + LOW7) | x | LOW7);
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
    }
    push(line.len(), &mut n);
    n
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
    /// any number of fields, no header), the line that of the last byte it consumed.
    fn theirs(text: &[u8]) -> Vec<(Vec<Vec<u8>>, u64)> {
        let mut r = csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(true)
            .terminator(csv::Terminator::Any(b'\n'))
            .from_reader(text);
        let mut rec = csv::ByteRecord::new();
        let mut out = Vec::new();
        while r.read_byte_record(&mut rec).unwrap() {
            let after = r.position().byte() as usize;
            let consumed = &text[..after];
            let line = memchr::memchr_iter(b'\n', consumed).count() as u64
                + u64::from(consumed.last() != Some(&b'\n'));
            out.push((rec.iter().map(<[u8]>::to_vec).collect(), line));
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
                vec!["3", "a\nb"],
                vec!["4", "x"],
            ]
        );
        assert_eq!(
            got.iter().map(|r| r.1).collect::<Vec<_>>(),
            vec![1, 3, 5, 7, 8]
        );
    }

    #[test]
    fn a_quote_never_closed_is_an_error_not_the_rest_of_the_file() {
        let mut text = b"time,signal,value\n1,\"speed,2\n".to_vec();
        text.extend(b"2,speed,1\n".repeat(200_000));
        let mut r = Records::new(&text[..]);
        assert!(r.read().unwrap());
        let err = r.read().unwrap_err();
        assert!(err.to_string().contains("quote never closed"), "{err}");
    }
}
