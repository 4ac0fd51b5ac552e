//! The one way liftwatch writes a file: whole or not at all.
//!
//! ```text
//! regular file (or a new one):  write to a unique temporary file beside the target,
//!                               flush, fsync, rename over the target, fsync the directory
//! device, FIFO:                 written in place (a rename would replace /dev/null by a file)
//! `-`:                          standard output, written in place
//! symbolic link:                followed: its target is what gets replaced
//! NAME.gz, NAME.zst (AtomicFile::create_data only): gzip- or zstd-compressed on the way,
//!                               whichever of the above
//! ```
//!
//! A failed or abandoned write removes its temporary file and leaves the target untouched, so a
//! reader sees the old content or the new, never a torn one; after [`AtomicFile::commit`]
//! returns, the new content survives a power cut.

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use flate2::write::GzEncoder;

use crate::error::{Error, Result};
use crate::input::{is_stdio, Compression};

/// The name standard output has in messages.
pub const STDOUT_NAME: &str = "<stdout>";

/// gzip level of compressed outputs: 6, zlib's own default. Measured on 30 days of the
/// monitor's per-second rows: 214 MB become 15.0 MB (14 times smaller) for 3.9 s more CPU.
const GZIP_LEVEL: u32 = 6;

/// zstd level of compressed outputs: 3, libzstd's own default, which compresses better than
/// gzip's 6 at several times its speed.
const ZSTD_LEVEL: i32 = 3;

/// Distinguishes the temporary files of one process (several outputs, several threads).
static NEXT_TEMP: AtomicU64 = AtomicU64::new(0);

/// A file being written: committed into place by [`AtomicFile::commit`], discarded when
/// dropped without it.
#[derive(Debug)]
pub struct AtomicFile {
    /// Where the content ends up (a symbolic link already resolved).
    target: PathBuf,
    /// The temporary file, `None` when the target is written in place (not a regular file).
    temp: Option<PathBuf>,
    out: Out,
}

/// Where the bytes go: a file (temporary or in place) or standard output.
#[derive(Debug)]
enum Dest {
    File(BufWriter<File>),
    Stdout(BufWriter<io::Stdout>),
}

impl Write for Dest {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        match self {
            Dest::File(f) => f.write(buf),
            Dest::Stdout(o) => o.write(buf),
        }
    }

    fn write_all(&mut self, buf: &[u8]) -> io::Result<()> {
        match self {
            Dest::File(f) => f.write_all(buf),
            Dest::Stdout(o) => o.write_all(buf),
        }
    }

    fn flush(&mut self) -> io::Result<()> {
        match self {
            Dest::File(f) => f.flush(),
            Dest::Stdout(o) => o.flush(),
        }
    }
}

/// The destination, compressed on the way or not.
enum Out {
    Plain(Dest),
    /// Buffered in front of the encoder: the CSV writers write field by field, and the encoder
    /// runs its compressor on every write it gets.
    Gzip(BufWriter<GzEncoder<Dest>>),
    /// Buffered in front of the encoder, as gzip.
    Zstd(BufWriter<zstd::stream::write::Encoder<'static, Dest>>),
    /// Taken apart after an error in the middle of a restart.
    Gone,
}

impl std::fmt::Debug for Out {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // The encoders' states say nothing a reader of a debug print could use.
        let name = match self {
            Out::Plain(d) => return f.debug_tuple("Plain").field(d).finish(),
            Out::Gzip(_) => "Gzip",
            Out::Zstd(_) => "Zstd",
            Out::Gone => "Gone",
        };
        f.write_str(name)
    }
}

impl Out {
    fn new(dest: Dest, compression: Compression) -> io::Result<Out> {
        Ok(match compression {
            Compression::None => Out::Plain(dest),
            Compression::Gzip => Out::Gzip(BufWriter::with_capacity(
                1 << 16,
                GzEncoder::new(dest, flate2::Compression::new(GZIP_LEVEL)),
            )),
            Compression::Zstd => Out::Zstd(BufWriter::with_capacity(
                1 << 16,
                zstd::stream::write::Encoder::new(dest, ZSTD_LEVEL)?,
            )),
        })
    }

    fn compression(&self) -> Compression {
        match self {
            Out::Gzip(_) => Compression::Gzip,
            Out::Zstd(_) => Compression::Zstd,
            Out::Plain(_) | Out::Gone => Compression::None,
        }
    }

    /// Ends the compressed stream (its trailer written) and returns the destination.
    fn finish(self) -> io::Result<Dest> {
        match self {
            Out::Plain(d) => Ok(d),
            Out::Gzip(g) => g.into_inner().map_err(|e| e.into_error())?.finish(),
            Out::Zstd(z) => z.into_inner().map_err(|e| e.into_error())?.finish(),
            Out::Gone => Err(io::Error::other("not written after an earlier error")),
        }
    }

    fn writer(&mut self) -> io::Result<&mut dyn Write> {
        match self {
            Out::Plain(d) => Ok(d),
            Out::Gzip(g) => Ok(g),
            Out::Zstd(z) => Ok(z),
            Out::Gone => Err(io::Error::other("not written after an earlier error")),
        }
    }
}

impl AtomicFile {
    /// Starts writing `path` as it is: a model, a state, a JSON summary. `-` is standard output.
    ///
    /// # Errors
    /// [`Error::Io`] when the temporary file (or a device target) cannot be opened.
    pub fn create(path: &Path) -> Result<AtomicFile> {
        AtomicFile::open(path, Compression::None)
    }

    /// Starts writing the data file `path` (aligned series, monitor rows, events), compressed
    /// as its name says ([`Compression::of`]): `rows.csv.gz` is gzip, `rows.csv.zst` zstd.
    /// `-` is standard output, uncompressed.
    ///
    /// # Errors
    /// As [`AtomicFile::create`].
    pub fn create_data(path: &Path) -> Result<AtomicFile> {
        AtomicFile::open(path, Compression::of(path))
    }

    fn open(path: &Path, compression: Compression) -> Result<AtomicFile> {
        if is_stdio(path) {
            return Ok(AtomicFile {
                target: PathBuf::from(STDOUT_NAME),
                temp: None,
                out: Out::Plain(Dest::Stdout(BufWriter::with_capacity(
                    1 << 16,
                    io::stdout(),
                ))),
            });
        }
        let target = resolve(path);
        let special = std::fs::metadata(&target).is_ok_and(|m| !m.is_file() && !m.is_dir());
        if special {
            let file = std::fs::OpenOptions::new()
                .write(true)
                .open(&target)
                .map_err(|e| Error::io(&target, e))?;
            let out = Out::new(Dest::File(BufWriter::new(file)), compression)
                .map_err(|e| Error::io(&target, e))?;
            return Ok(AtomicFile {
                target,
                temp: None,
                out,
            });
        }
        sweep_stale(&target);
        let temp = temp_path(&target);
        let file = File::create(&temp).map_err(|e| Error::io(&target, e))?;
        let out = match Out::new(
            Dest::File(BufWriter::with_capacity(1 << 16, file)),
            compression,
        ) {
            Ok(out) => out,
            Err(e) => {
                let _ = std::fs::remove_file(&temp);
                return Err(Error::io(&target, e));
            }
        };
        Ok(AtomicFile {
            target,
            temp: Some(temp),
            out,
        })
    }

    /// The path the content will have.
    pub fn path(&self) -> &Path {
        &self.target
    }

    /// Forgets everything written so far, to write the content again from the start (the
    /// aligner replays its input when a row comes later than its reorder window).
    ///
    /// # Errors
    /// [`Error::Io`] when the temporary file cannot be truncated, or when the target is a
    /// device or FIFO, whose bytes are already gone.
    pub fn restart(&mut self) -> Result<()> {
        use std::io::Seek;
        let target = self.target.clone();
        if self.temp.is_none() {
            return Err(Error::io(
                &target,
                io::Error::other("cannot rewrite a stream output (input rows came too late to stream: sort the input or write to a file)"),
            ));
        }
        let result = (|| {
            let compression = self.out.compression();
            let mut dest = std::mem::replace(&mut self.out, Out::Gone).finish()?;
            dest.flush()?;
            if let Dest::File(f) = &mut dest {
                let f = f.get_mut();
                f.set_len(0)?;
                f.rewind()?;
            }
            self.out = Out::new(dest, compression)?;
            Ok(())
        })();
        result.map_err(|e: io::Error| Error::io(&target, e))
    }

    /// Flushes, syncs and moves the content into place.
    ///
    /// # Errors
    /// [`Error::Io`] when any step fails; the target is then unchanged.
    pub fn commit(mut self) -> Result<()> {
        let target = self.target.clone();
        let result = (|| {
            let mut dest = std::mem::replace(&mut self.out, Out::Gone).finish()?;
            dest.flush()?;
            let Some(temp) = self.temp.as_ref() else {
                return Ok(());
            };
            if let Dest::File(f) = &dest {
                f.get_ref().sync_all()?;
            }
            std::fs::rename(temp, &self.target)?;
            self.temp = None;
            sync_dir(&self.target);
            Ok(())
        })();
        result.map_err(|e: io::Error| Error::io(&target, e))
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.out.writer()?.write(buf)
    }

    fn write_all(&mut self, buf: &[u8]) -> io::Result<()> {
        self.out.writer()?.write_all(buf)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.out.writer()?.flush()
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if let Some(temp) = self.temp.take() {
            let _ = std::fs::remove_file(temp);
        }
    }
}

/// Writes `bytes` to `path` as one [`AtomicFile`].
///
/// # Errors
/// [`Error::Io`] when the file cannot be written; the target is then unchanged.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let mut f = AtomicFile::create(path)?;
    f.write_all(bytes).map_err(|e| Error::io(path, e))?;
    f.commit()
}

/// A directory of outputs written as a unit: files go into a temporary directory beside the
/// target, and [`AtomicDir::commit`] moves them in. A new target directory appears whole (one
/// rename); into an existing one each file is renamed over its namesake, so every file is
/// whole, and files of the target that the run does not write are left alone.
#[derive(Debug)]
pub struct AtomicDir {
    target: PathBuf,
    temp: Option<PathBuf>,
}

impl AtomicDir {
    /// Creates the temporary directory for `target`.
    ///
    /// # Errors
    /// [`Error::Io`] when it cannot be created (a missing parent, no permission).
    pub fn create(target: &Path) -> Result<AtomicDir> {
        let target = resolve(target);
        if target.exists() && !target.is_dir() {
            return Err(Error::io(
                &target,
                io::Error::other("exists and is not a directory"),
            ));
        }
        sweep_stale(&target);
        let temp = PathBuf::from(format!("{}dir", temp_path(&target).display()));
        std::fs::create_dir(&temp).map_err(|e| Error::io(&target, e))?;
        Ok(AtomicDir {
            target,
            temp: Some(temp),
        })
    }

    /// Where to write the files now (the temporary directory).
    pub fn path(&self) -> &Path {
        self.temp.as_deref().unwrap_or(&self.target)
    }

    /// The directory the files end up in.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Refuses, with one line naming the flag, when a file written so far would replace one
    /// of `inputs` in the target (an input kept in the output directory under a name the
    /// command writes, such as `risk.svg`).
    ///
    /// # Errors
    /// [`Error::InvalidConfig`] naming the input's flag and path.
    pub fn check_spares(&self, inputs: &[FileArg]) -> Result<()> {
        let Some(temp) = &self.temp else {
            return Ok(());
        };
        let inputs: Vec<(&FileArg, PathBuf)> = inputs
            .iter()
            .filter(|a| !a.output)
            .filter_map(|a| std::fs::canonicalize(a.path).ok().map(|p| (a, p)))
            .collect();
        for e in std::fs::read_dir(temp).map_err(|e| Error::io(temp, e))? {
            let e = e.map_err(|e| Error::io(temp, e))?;
            let Ok(written) = std::fs::canonicalize(self.target.join(e.file_name())) else {
                continue;
            };
            if let Some((a, _)) = inputs.iter().find(|(_, p)| *p == written) {
                return Err(Error::InvalidConfig {
                    field: "--out",
                    why: format!(
                        "{} would be replaced by the output {}: {} lies in the output directory under a name it writes; choose another --out",
                        a.flag,
                        written.display(),
                        a.path.display()
                    ),
                });
            }
        }
        Ok(())
    }

    /// Syncs every file and moves them into the target.
    ///
    /// # Errors
    /// [`Error::Io`] when a file cannot be synced or moved.
    pub fn commit(mut self) -> Result<()> {
        let Some(temp) = self.temp.clone() else {
            return Ok(());
        };
        let target = self.target.clone();
        let result = (|| -> io::Result<()> {
            let mut names = Vec::new();
            for e in std::fs::read_dir(&temp)? {
                let e = e?;
                if e.file_type()?.is_file() {
                    File::open(e.path())?.sync_all()?;
                }
                names.push(e.file_name());
            }
            if !target.exists() {
                std::fs::rename(&temp, &target)?;
                self.temp = None;
            } else {
                for n in names {
                    std::fs::rename(temp.join(&n), target.join(&n))?;
                }
                sync_dir(&target.join("x"));
            }
            sync_dir(&target);
            Ok(())
        })();
        result.map_err(|e| Error::io(&target, e))
    }
}

impl Drop for AtomicDir {
    fn drop(&mut self) {
        if let Some(temp) = self.temp.take() {
            let _ = std::fs::remove_dir_all(temp);
        }
    }
}

/// One file argument of a command: its flag, its path and whether the command writes it.
#[derive(Clone, Copy, Debug)]
pub struct FileArg<'a> {
    /// The flag that names it, e.g. `--out`.
    pub flag: &'a str,
    /// The path given.
    pub path: &'a Path,
    /// True for an output.
    pub output: bool,
}

impl<'a> FileArg<'a> {
    /// A file the command reads.
    pub fn input(flag: &'a str, path: &'a Path) -> Self {
        FileArg {
            flag,
            path,
            output: false,
        }
    }

    /// A file the command writes (a state it reads and writes counts as an output).
    pub fn output(flag: &'a str, path: &'a Path) -> Self {
        FileArg {
            flag,
            path,
            output: true,
        }
    }
}

/// Refuses a command, before it reads or writes anything, whose outputs could not be written
/// where they are named or name one of its inputs or each other (after following symbolic
/// links and `..`): an output in a directory that does not exist would fail only at the end,
/// after the others were written (`--state` is written last); `--input X --out X` would
/// replace the input, `--state` equal to `--out` would lose the state. Devices and FIFOs may
/// repeat (`/dev/null` twice is fine).
///
/// `-` is standard input for an input and standard output for an output; one of each at
/// most.
///
/// # Errors
/// A one-line message naming the flag (both flags for a clash).
pub fn check_file_args(args: &[FileArg]) -> std::result::Result<(), String> {
    for a in args.iter().filter(|a| a.output && !is_stdio(a.path)) {
        let dir = parent(&resolve(a.path)).to_path_buf();
        if !dir.is_dir() {
            return Err(format!(
                "{} {}: the directory {} does not exist",
                a.flag,
                a.path.display(),
                dir.display()
            ));
        }
    }
    for output in [false, true] {
        let mut dashes = args
            .iter()
            .filter(|a| a.output == output && is_stdio(a.path));
        if let (Some(a), Some(b)) = (dashes.next(), dashes.next()) {
            return Err(format!(
                "{} and {} are both `-`: only one {} of a command can be standard {}",
                a.flag,
                b.flag,
                if output { "output" } else { "input" },
                if output { "output" } else { "input" },
            ));
        }
    }
    let key = |p: &Path| -> Option<PathBuf> {
        if is_stdio(p) {
            return None;
        }
        let target = resolve(p);
        if std::fs::metadata(&target).is_ok_and(|m| !m.is_file()) {
            return None;
        }
        let name = target.file_name()?;
        let dir = std::fs::canonicalize(parent(&target)).ok()?;
        Some(dir.join(name))
    };
    let keys: Vec<Option<PathBuf>> = args.iter().map(|a| key(a.path)).collect();
    for (i, a) in args.iter().enumerate() {
        for (j, b) in args.iter().enumerate().skip(i + 1) {
            if !(a.output || b.output) {
                continue;
            }
            if let (Some(ka), Some(kb)) = (&keys[i], &keys[j]) {
                if ka == kb {
                    return Err(format!(
                        "{} and {} name the same file {}: an output would replace {}",
                        a.flag,
                        b.flag,
                        b.path.display(),
                        if a.output && b.output {
                            "another output"
                        } else {
                            "an input"
                        }
                    ));
                }
            }
        }
    }
    Ok(())
}

/// The path a write to `path` replaces: a symbolic link's target (relative links resolved
/// against the link's directory, chains followed), else `path` itself.
fn resolve(path: &Path) -> PathBuf {
    let mut p = path.to_path_buf();
    // A bounded walk: a loop of links is left to the open call to report.
    for _ in 0..40 {
        match std::fs::read_link(&p) {
            Ok(next) => {
                p = match p.parent() {
                    Some(dir) if next.is_relative() => dir.join(next),
                    _ => next,
                }
            }
            Err(_) => break,
        }
    }
    p
}

/// `.name.<pid>.<n>.tmp` beside `target`, so the final rename stays on one file system.
fn temp_path(target: &Path) -> PathBuf {
    let name = target
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    let n = NEXT_TEMP.fetch_add(1, Ordering::Relaxed);
    parent(target).join(format!(".{name}.{}.{n}.tmp", std::process::id()))
}

/// Removes temporary files of `target` left by processes that no longer run (a `kill -9` or a
/// power cut gives a process no chance to clean up): `.name.<pid>.<n>.tmp` whose pid has no
/// `/proc/<pid>`. Files of live processes, and anything else, are left alone.
fn sweep_stale(target: &Path) {
    let Some(name) = target.file_name().map(|n| n.to_string_lossy().into_owned()) else {
        return;
    };
    let prefix = format!(".{name}.");
    let Ok(entries) = std::fs::read_dir(parent(target)) else {
        return;
    };
    for e in entries.flatten() {
        let file = e.file_name().to_string_lossy().into_owned();
        let Some(rest) = file.strip_prefix(&prefix) else {
            continue;
        };
        let Some(rest) = rest
            .strip_suffix(".tmp")
            .or_else(|| rest.strip_suffix(".tmpdir"))
        else {
            continue;
        };
        let Some((pid, n)) = rest.split_once('.') else {
            continue;
        };
        let (Ok(pid), Ok(_)) = (pid.parse::<u32>(), n.parse::<u64>()) else {
            continue;
        };
        let alive = pid == std::process::id() || Path::new(&format!("/proc/{pid}")).exists();
        if !alive {
            let p = e.path();
            let _ = if p.is_dir() {
                std::fs::remove_dir_all(p)
            } else {
                std::fs::remove_file(p)
            };
        }
    }
}

fn parent(path: &Path) -> &Path {
    path.parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."))
}

/// Makes the rename durable. Best effort: some file systems refuse to sync a directory, and
/// the content itself is already on disk.
fn sync_dir(target: &Path) {
    if let Ok(dir) = File::open(parent(target)) {
        let _ = dir.sync_all();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::tests::scratch;

    #[test]
    fn a_directory_of_outputs_spares_an_input_kept_in_it() {
        let dir = scratch("output-spares");
        let out = dir.join("report");
        std::fs::create_dir(&out).unwrap();
        let input = out.join("risk.svg");
        std::fs::write(&input, "time,signal,value\n").unwrap();
        let elsewhere = dir.join("model.json");
        std::fs::write(&elsewhere, "{}").unwrap();
        let d = AtomicDir::create(&out).unwrap();
        std::fs::write(d.path().join("risk.svg"), "<svg/>").unwrap();
        std::fs::write(d.path().join("index.html"), "<html/>").unwrap();
        let err = d
            .check_spares(&[
                FileArg::input("--model", &elsewhere),
                FileArg::input("--input", &input),
            ])
            .unwrap_err()
            .to_string();
        assert!(err.contains("--input") && err.contains("risk.svg"), "{err}");
        assert!(d
            .check_spares(&[FileArg::input("--model", &elsewhere)])
            .is_ok());
        drop(d);
        assert_eq!(
            std::fs::read_to_string(&input).unwrap(),
            "time,signal,value\n"
        );
    }

    fn entries(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn an_abandoned_write_leaves_the_old_content_and_no_temp_file() {
        let dir = scratch("output-abandon");
        let path = dir.join("out.csv");
        std::fs::write(&path, "old").unwrap();
        {
            let mut f = AtomicFile::create(&path).unwrap();
            f.write_all(b"new, half").unwrap();
        }
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "old");
        assert_eq!(entries(&dir), ["out.csv"]);
        write_atomic(&path, b"new").unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "new");
        assert_eq!(entries(&dir), ["out.csv"]);
    }

    #[test]
    fn a_restart_forgets_what_was_written() {
        let dir = scratch("output-restart");
        let path = dir.join("rows.csv");
        let mut f = AtomicFile::create(&path).unwrap();
        f.write_all(b"first attempt, longer\n").unwrap();
        f.restart().unwrap();
        f.write_all(b"again\n").unwrap();
        f.commit().unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "again\n");
        let mut dev = AtomicFile::create(Path::new("/dev/null")).unwrap();
        assert!(dev.restart().is_err(), "a device cannot be rewound");
    }

    #[test]
    fn temp_files_of_dead_processes_are_swept_and_live_ones_kept() {
        let dir = scratch("output-sweep");
        let path = dir.join("risk.csv");
        // pid 0 is never a user process; this process is alive.
        std::fs::write(dir.join(".risk.csv.0.3.tmp"), "left by a kill").unwrap();
        std::fs::create_dir(dir.join(".risk.csv.0.4.tmpdir")).unwrap();
        let mine = format!(".risk.csv.{}.99.tmp", std::process::id());
        std::fs::write(dir.join(&mine), "in use").unwrap();
        std::fs::write(dir.join(".other.csv.0.1.tmp"), "another target's").unwrap();
        write_atomic(&path, b"rows").unwrap();
        assert_eq!(
            entries(&dir),
            [".other.csv.0.1.tmp".to_string(), mine, "risk.csv".into()]
        );
    }

    #[test]
    fn a_symlink_is_followed_not_replaced() {
        let dir = scratch("output-link");
        let real = dir.join("real.json");
        std::fs::write(&real, "old").unwrap();
        let link = dir.join("link.json");
        std::os::unix::fs::symlink("real.json", &link).unwrap();
        write_atomic(&link, b"new").unwrap();
        assert!(std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink());
        assert_eq!(std::fs::read_to_string(&real).unwrap(), "new");
    }

    #[test]
    fn an_output_naming_an_input_or_another_output_or_a_missing_directory_is_refused() {
        let dir = scratch("output-distinct");
        let input = dir.join("in.csv");
        std::fs::write(&input, "x").unwrap();
        let arg = |flag, path, output| FileArg { flag, path, output };
        let same = dir.join("sub/../in.csv");
        std::fs::create_dir_all(dir.join("sub")).unwrap();
        let err = check_file_args(&[arg("--input", &input, false), arg("--out", &same, true)])
            .unwrap_err();
        assert!(err.contains("--input and --out"), "{err}");
        let out = dir.join("out.csv");
        assert!(check_file_args(&[arg("--out", &out, true), arg("--state", &out, true)]).is_err());
        assert!(
            check_file_args(&[arg("--input", &input, false), arg("--out", &out, true)]).is_ok()
        );
        let null = Path::new("/dev/null");
        assert!(check_file_args(&[arg("--out", null, true), arg("--events", null, true)]).is_ok());
        // Two inputs may be the same file.
        assert!(check_file_args(&[arg("--a", &input, false), arg("--b", &input, false)]).is_ok());
        let dash = Path::new("-");
        assert!(check_file_args(&[arg("--input", dash, false), arg("--out", dash, true)]).is_ok());
        let err =
            check_file_args(&[arg("--out", dash, true), arg("--events", dash, true)]).unwrap_err();
        assert!(err.contains("--out and --events are both `-`"), "{err}");
        assert!(check_file_args(&[arg("--a", dash, false), arg("--b", dash, false)]).is_err());
        // An output whose directory is missing is refused by its flag, the inputs not looked at.
        let lost = dir.join("nodir/state.json");
        let err =
            check_file_args(&[arg("--out", &out, true), arg("--state", &lost, true)]).unwrap_err();
        assert!(
            err.starts_with("--state ") && err.ends_with("nodir does not exist"),
            "{err}"
        );
    }

    #[test]
    fn a_directory_appears_whole_or_keeps_its_old_files() {
        let dir = scratch("output-dir");
        let target = dir.join("report");
        {
            let d = AtomicDir::create(&target).unwrap();
            std::fs::write(d.path().join("a.svg"), "half").unwrap();
        }
        assert!(!target.exists(), "an abandoned directory leaves nothing");
        assert_eq!(entries(&dir), Vec::<String>::new());
        let d = AtomicDir::create(&target).unwrap();
        std::fs::write(d.path().join("a.svg"), "new").unwrap();
        d.commit().unwrap();
        assert_eq!(
            std::fs::read_to_string(target.join("a.svg")).unwrap(),
            "new"
        );
        std::fs::write(target.join("mine.txt"), "keep").unwrap();
        let d = AtomicDir::create(&target).unwrap();
        std::fs::write(d.path().join("a.svg"), "newer").unwrap();
        d.commit().unwrap();
        assert_eq!(
            std::fs::read_to_string(target.join("a.svg")).unwrap(),
            "newer"
        );
        assert_eq!(
            std::fs::read_to_string(target.join("mine.txt")).unwrap(),
            "keep"
        );
        assert_eq!(entries(&dir), ["report"]);
    }

    #[test]
    fn a_gz_data_file_is_compressed_even_after_a_restart() {
        use std::io::Read;
        let dir = scratch("output-gz");
        let path = dir.join("rows.csv.gz");
        let mut f = AtomicFile::create_data(&path).unwrap();
        f.write_all(b"first attempt\n").unwrap();
        f.restart().unwrap();
        f.write_all(b"time,risk\n1,0.5\n").unwrap();
        f.commit().unwrap();
        let mut text = String::new();
        flate2::read::GzDecoder::new(File::open(&path).unwrap())
            .read_to_string(&mut text)
            .unwrap();
        assert_eq!(text, "time,risk\n1,0.5\n");
        assert_eq!(entries(&dir), ["rows.csv.gz"]);
        write_atomic(&dir.join("model.json.gz"), b"{}").unwrap();
        assert_eq!(std::fs::read(dir.join("model.json.gz")).unwrap(), b"{}");
    }

    #[test]
    fn a_device_is_written_in_place() {
        write_atomic(Path::new("/dev/null"), b"nothing").unwrap();
        let meta = std::fs::metadata("/dev/null").unwrap();
        assert!(!meta.is_file(), "/dev/null must stay a device");
    }

    #[test]
    fn a_missing_directory_is_an_error_naming_the_target() {
        let err = write_atomic(Path::new("/nonexistent-dir/x.json"), b"x").unwrap_err();
        assert!(err.to_string().contains("/nonexistent-dir/x.json"), "{err}");
    }
}
