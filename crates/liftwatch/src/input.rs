//! The one way liftwatch opens telemetry to read, the counterpart of [`crate::output`].
//!
//! ```text
//! -            standard input, copied to an unlinked spool file while it is read
//! pipe, device a path that is no regular file (a FIFO, `<(zcat log.gz)`): spooled the same way
//! NAME.gz      gzip, decompressed while it is read (several members allowed, as `cat a.gz b.gz`)
//! NAME.zst     zstd, decompressed while it is read (several frames allowed, as `cat a.zst b.zst`)
//! anything     read as it is
//! ```
//!
//! Alignment may read its input a second time (a row later than the reorder window, a
//! `current` column appearing late, an aligned file at another step), so every input is
//! [`Seek`]able back to its start: a compressed file is reopened and decompressed again, and
//! standard input (or a pipe) is replayed from its spool. The spool costs one copy of the piped bytes on
//! the temporary directory's disk, never memory; it is unlinked as soon as it is created, so
//! nothing is left behind by a kill.

use std::fs::File;
use std::io::{self, BufReader, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use flate2::read::MultiGzDecoder;

use crate::error::{Error, Result};

/// The file argument that means standard input (for an input) or standard output (for an
/// output).
pub const STDIO: &str = "-";

/// The name standard input has in messages.
pub const STDIN_NAME: &str = "<stdin>";

/// Distinguishes the spool files of one process.
static NEXT_SPOOL: AtomicU64 = AtomicU64::new(0);

/// True when `path` is the command-line `-`.
pub fn is_stdio(path: &Path) -> bool {
    path.as_os_str() == STDIO
}

/// How a data file is compressed, told by its name's extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Compression {
    /// Plain text.
    None,
    /// gzip (`.gz`), RFC 1952.
    Gzip,
    /// Zstandard (`.zst`), RFC 8878.
    Zstd,
}

impl Compression {
    /// The compression the name of `path` asks for; `-` is always plain.
    pub fn of(path: &Path) -> Compression {
        match path.extension().and_then(|e| e.to_str()) {
            Some(e) if e.eq_ignore_ascii_case("gz") => Compression::Gzip,
            Some(e) if e.eq_ignore_ascii_case("zst") => Compression::Zstd,
            _ => Compression::None,
        }
    }
}

/// An opened telemetry input: read it, and seek back to its start to read it again.
pub struct Input {
    /// The name in messages: the path, or [`STDIN_NAME`].
    name: PathBuf,
    inner: Inner,
}

enum Inner {
    File(File),
    /// Boxed: a decoder's state is several times the size of the other variants.
    Gzip(Box<MultiGzDecoder<BufReader<File>>>, PathBuf),
    Zstd(Box<ZstdDecoder>, PathBuf),
    Spooled(Spool),
}

impl Input {
    /// Opens `path`: `-` is standard input, a `.gz` or `.zst` name is decompressed.
    ///
    /// # Errors
    /// [`Error::Io`] naming the file when it cannot be opened, or when standard input's spool
    /// file cannot be created.
    pub fn open(path: &Path) -> Result<Input> {
        if is_stdio(path) {
            let name = PathBuf::from(STDIN_NAME);
            let spool = Spool::new(Box::new(io::stdin())).map_err(|e| Error::io(&name, e))?;
            return Ok(Input {
                name,
                inner: Inner::Spooled(spool),
            });
        }
        let file = File::open(path).map_err(|e| Error::io(path, e))?;
        let regular = file.metadata().map_err(|e| Error::io(path, e))?.is_file();
        if !regular && Compression::of(path) == Compression::None {
            // A pipe (`<(zcat log.gz)`, a FIFO) or a device reads once: spooled like standard
            // input, so that alignment's second pass can read it again.
            let spool = Spool::new(Box::new(file)).map_err(|e| Error::io(path, e))?;
            return Ok(Input {
                name: path.to_path_buf(),
                inner: Inner::Spooled(spool),
            });
        }
        let inner = match Compression::of(path) {
            Compression::None => Inner::File(file),
            Compression::Gzip => Inner::Gzip(Box::new(gunzip(file)), path.to_path_buf()),
            Compression::Zstd => Inner::Zstd(
                Box::new(unzstd(file).map_err(|e| Error::io(path, e))?),
                path.to_path_buf(),
            ),
        };
        Ok(Input {
            name: path.to_path_buf(),
            inner,
        })
    }

    /// The input's name in messages: its path, or [`STDIN_NAME`].
    pub fn name(&self) -> &Path {
        &self.name
    }
}

fn gunzip(file: File) -> MultiGzDecoder<BufReader<File>> {
    MultiGzDecoder::new(BufReader::with_capacity(1 << 16, file))
}

/// A zstd stream over a buffered file; it reads frame after frame to the end of the file.
type ZstdDecoder = zstd::stream::read::Decoder<'static, BufReader<File>>;

fn unzstd(file: File) -> io::Result<ZstdDecoder> {
    ZstdDecoder::with_buffer(BufReader::with_capacity(1 << 16, file))
}

impl Read for Input {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        match &mut self.inner {
            Inner::File(f) => f.read(buf),
            Inner::Gzip(d, _) => d.read(buf),
            Inner::Zstd(d, _) => d.read(buf),
            Inner::Spooled(s) => s.read(buf),
        }
    }
}

impl Seek for Input {
    /// A plain file seeks anywhere; gzip and standard input only back to the start, which is
    /// all alignment asks.
    fn seek(&mut self, pos: SeekFrom) -> io::Result<u64> {
        match (&mut self.inner, pos) {
            (Inner::File(f), pos) => f.seek(pos),
            (Inner::Gzip(d, path), SeekFrom::Start(0)) => {
                **d = gunzip(File::open(&*path)?);
                Ok(0)
            }
            (Inner::Zstd(d, path), SeekFrom::Start(0)) => {
                **d = unzstd(File::open(&*path)?)?;
                Ok(0)
            }
            (Inner::Spooled(s), SeekFrom::Start(0)) => {
                s.pos = 0;
                Ok(0)
            }
            _ => Err(io::Error::new(
                io::ErrorKind::Unsupported,
                "a compressed or piped input can only be read again from its start",
            )),
        }
    }
}

/// Standard input, or a pipe or device given by its path, copied to a spool file as it is
/// read, so that it can be read again.
struct Spool {
    source: Box<dyn Read + Send>,
    file: File,
    /// Bytes copied to the spool so far.
    len: u64,
    /// Where the reader is: below `len` it reads the spool, at `len` standard input.
    pos: u64,
    /// The spool file's own cursor, to skip needless seeks.
    cursor: u64,
}

impl Spool {
    fn new(source: Box<dyn Read + Send>) -> io::Result<Spool> {
        let n = NEXT_SPOOL.fetch_add(1, Ordering::Relaxed);
        let path =
            std::env::temp_dir().join(format!(".liftwatch-stdin.{}.{n}.spool", std::process::id()));
        let file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .create_new(true)
            .open(&path)?;
        // Unlinked at once: the open handle keeps the bytes, and no exit path leaves the file.
        std::fs::remove_file(&path)?;
        Ok(Spool {
            source,
            file,
            len: 0,
            pos: 0,
            cursor: 0,
        })
    }

    fn seek_file(&mut self, to: u64) -> io::Result<()> {
        if self.cursor != to {
            self.file.seek(SeekFrom::Start(to))?;
            self.cursor = to;
        }
        Ok(())
    }
}

impl Read for Spool {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        if self.pos < self.len {
            self.seek_file(self.pos)?;
            let want = usize::try_from(self.len - self.pos).map_or(buf.len(), |r| r.min(buf.len()));
            let n = self.file.read(&mut buf[..want])?;
            self.pos += n as u64;
            self.cursor += n as u64;
            return Ok(n);
        }
        let n = self.source.read(buf)?;
        if n > 0 {
            self.seek_file(self.len)?;
            self.file.write_all(&buf[..n])?;
            self.len += n as u64;
            self.pos = self.len;
            self.cursor = self.len;
        }
        Ok(n)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A fresh directory for one test, `lw-test-<pid>-<name>` under the system's temporary
    /// directory, removed with everything in it when the test ends (pass or fail). Names are
    /// unique across the crate's tests, which share one process.
    pub(crate) struct Scratch(PathBuf);

    impl std::ops::Deref for Scratch {
        type Target = Path;
        fn deref(&self) -> &Path {
            &self.0
        }
    }

    impl Drop for Scratch {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }

    pub(crate) fn scratch(name: &str) -> Scratch {
        let dir = std::env::temp_dir().join(format!("lw-test-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        Scratch(dir)
    }

    #[test]
    fn a_gzip_file_reads_and_rewinds_to_its_text() {
        let dir = scratch("input-gz");
        let path = dir.join("raw.csv.gz");
        let text = b"time,signal,value\n0,speed,0\n1,speed,1\n";
        let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
        enc.write_all(text).unwrap();
        std::fs::write(&path, enc.finish().unwrap()).unwrap();
        let mut input = Input::open(&path).unwrap();
        let mut got = Vec::new();
        input.read_to_end(&mut got).unwrap();
        assert_eq!(got, text);
        input.seek(SeekFrom::Start(0)).unwrap();
        got.clear();
        input.read_to_end(&mut got).unwrap();
        assert_eq!(got, text, "read again from the start");
        assert!(input.seek(SeekFrom::Start(3)).is_err());
    }

    #[test]
    fn a_zstd_file_of_two_frames_reads_and_rewinds_to_its_text() {
        let dir = scratch("input-zst");
        let path = dir.join("raw.csv.zst");
        let (a, b) = (&b"time,signal,value\n0,speed,0\n"[..], &b"1,speed,1\n"[..]);
        let mut bytes = zstd::encode_all(a, 3).unwrap();
        bytes.extend(zstd::encode_all(b, 3).unwrap());
        std::fs::write(&path, bytes).unwrap();
        let mut input = Input::open(&path).unwrap();
        let mut got = Vec::new();
        input.read_to_end(&mut got).unwrap();
        assert_eq!(got, [a, b].concat(), "both frames, as `cat a.zst b.zst`");
        input.seek(SeekFrom::Start(0)).unwrap();
        got.clear();
        input.read_to_end(&mut got).unwrap();
        assert_eq!(got, [a, b].concat(), "read again from the start");
    }

    #[cfg(unix)]
    #[test]
    fn a_fifo_reads_and_rewinds_to_its_text() {
        let dir = scratch("input-fifo");
        let path = dir.join("raw.csv");
        let made = std::process::Command::new("mkfifo").arg(&path).status();
        if !made.is_ok_and(|s| s.success()) {
            eprintln!("skipped: mkfifo is not available");
            return;
        }
        let text = b"time,signal,value\n0,speed,0\n1,speed,1\n";
        let writer = {
            let path = path.clone();
            std::thread::spawn(move || std::fs::write(path, text).unwrap())
        };
        let mut input = Input::open(&path).unwrap();
        let mut got = Vec::new();
        input.read_to_end(&mut got).unwrap();
        writer.join().unwrap();
        assert_eq!(got, text);
        input.seek(SeekFrom::Start(0)).unwrap();
        got.clear();
        input.read_to_end(&mut got).unwrap();
        assert_eq!(got, text, "read again from its spool, as a pipe reads once");
    }

    #[test]
    fn the_compression_is_told_by_the_extension_in_any_case() {
        assert_eq!(Compression::of(Path::new("a.CSV.GZ")), Compression::Gzip);
        assert_eq!(Compression::of(Path::new("a.csv.Zst")), Compression::Zstd);
        assert_eq!(Compression::of(Path::new("a.csv")), Compression::None);
        assert_eq!(Compression::of(Path::new("-")), Compression::None);
    }
}
