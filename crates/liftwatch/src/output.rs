//! The one way liftwatch writes a file: whole or not at all.
//!
//! ```text
//! regular file (or a new one):  write to a unique temporary file beside the target,
//!                               flush, fsync, rename over the target, fsync the directory
//! device, FIFO:                 written in place (a rename would replace /dev/null by a file)
//! symbolic link:                followed: its target is what gets replaced
//! ```
//!
//! A failed or abandoned write removes its temporary file and leaves the target untouched, so a
//! reader sees the old content or the new, never a torn one; after [`AtomicFile::commit`]
//! returns, the new content survives a power cut. A process killed mid-write cannot clean up:
//! the next write of the same target removes the temporary files of writers no longer running.

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::error::{Error, Result};

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
    out: BufWriter<File>,
}

impl AtomicFile {
    /// Starts writing `path`.
    ///
    /// # Errors
    /// [`Error::Io`] when the temporary file (or a device target) cannot be opened.
    pub fn create(path: &Path) -> Result<AtomicFile> {
        let target = resolve(path);
        let special = std::fs::metadata(&target).is_ok_and(|m| !m.is_file() && !m.is_dir());
        if special {
            let file = std::fs::OpenOptions::new()
                .write(true)
                .open(&target)
                .map_err(|e| Error::io(&target, e))?;
            return Ok(AtomicFile {
                target,
                temp: None,
                out: BufWriter::new(file),
            });
        }
        remove_stale_temps(&target);
        let temp = temp_path(&target);
        let file = File::create(&temp).map_err(|e| Error::io(&target, e))?;
        Ok(AtomicFile {
            target,
            temp: Some(temp),
            out: BufWriter::with_capacity(1 << 16, file),
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
            self.out.flush()?;
            let f = self.out.get_mut();
            f.set_len(0)?;
            f.rewind()?;
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
            self.out.flush()?;
            let Some(temp) = self.temp.as_ref() else {
                return Ok(());
            };
            self.out.get_ref().sync_all()?;
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
        self.out.write(buf)
    }

    fn write_all(&mut self, buf: &[u8]) -> io::Result<()> {
        self.out.write_all(buf)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.out.flush()
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
        remove_stale_temps(&target);
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

/// Refuses a command whose outputs name one of its inputs or each other (after following
/// symbolic links and `..`): `--input X --out X` would replace the input, `--state` equal to
/// `--out` would lose the state. Devices and FIFOs may repeat (`/dev/null` twice is fine).
///
/// # Errors
/// A one-line message naming both flags.
pub fn check_distinct(args: &[FileArg]) -> std::result::Result<(), String> {
    let key = |p: &Path| -> Option<PathBuf> {
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

/// Removes what killed writers of `target` left beside it: `.name.<pid>.<n>.tmp` files and
/// `.tmpdir` directories whose process no longer runs. Only where `/proc` tells which processes
/// run (Linux); elsewhere they stay. Best effort: a leftover costs space, not correctness.
fn remove_stale_temps(target: &Path) {
    let Some(name) = target.file_name().map(|n| n.to_string_lossy().into_owned()) else {
        return;
    };
    if !Path::new("/proc/self").exists() {
        return;
    }
    let Ok(entries) = std::fs::read_dir(parent(target)) else {
        return;
    };
    let prefix = format!(".{name}.");
    for entry in entries.flatten() {
        let file = entry.file_name().to_string_lossy().into_owned();
        let Some(rest) = file.strip_prefix(&prefix) else {
            continue;
        };
        let parts: Vec<&str> = rest.split('.').collect();
        let [pid, n, kind] = parts[..] else {
            continue;
        };
        let Ok(pid) = pid.parse::<u32>() else {
            continue;
        };
        if n.parse::<u64>().is_err()
            || pid == std::process::id()
            || Path::new(&format!("/proc/{pid}")).exists()
        {
            continue;
        }
        let _ = match kind {
            "tmp" => std::fs::remove_file(entry.path()),
            "tmpdir" => std::fs::remove_dir_all(entry.path()),
            _ => continue,
        };
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

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("lw-output-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
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
        let dir = scratch("abandon");
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
        let dir = scratch("restart");
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
    fn a_symlink_is_followed_not_replaced() {
        let dir = scratch("link");
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
    fn an_output_naming_an_input_or_another_output_is_refused() {
        let dir = scratch("distinct");
        let input = dir.join("in.csv");
        std::fs::write(&input, "x").unwrap();
        let arg = |flag, path, output| FileArg { flag, path, output };
        let same = dir.join("sub/../in.csv");
        std::fs::create_dir_all(dir.join("sub")).unwrap();
        let err = check_distinct(&[arg("--input", &input, false), arg("--out", &same, true)])
            .unwrap_err();
        assert!(err.contains("--input and --out"), "{err}");
        let out = dir.join("out.csv");
        assert!(check_distinct(&[arg("--out", &out, true), arg("--state", &out, true)]).is_err());
        assert!(check_distinct(&[arg("--input", &input, false), arg("--out", &out, true)]).is_ok());
        let null = Path::new("/dev/null");
        assert!(check_distinct(&[arg("--out", null, true), arg("--events", null, true)]).is_ok());
        // Two inputs may be the same file.
        assert!(check_distinct(&[arg("--a", &input, false), arg("--b", &input, false)]).is_ok());
    }

    #[test]
    fn a_directory_appears_whole_or_keeps_its_old_files() {
        let dir = scratch("dir");
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
    fn temporary_files_of_dead_writers_are_removed_by_the_next_write() {
        let dir = scratch("stale");
        let path = dir.join("out.csv");
        // No process has the largest pid; this one is alive; `.other` belongs to another target.
        let dead = format!(".out.csv.{}.0.tmp", u32::MAX);
        let alive = format!(".out.csv.{}.7.tmp", std::process::id());
        for name in [&dead, &alive, &".other.csv.1.0.tmp".to_string()] {
            std::fs::write(dir.join(name), "half").unwrap();
        }
        std::fs::create_dir(dir.join(format!(".out.csv.{}.1.tmpdir", u32::MAX))).unwrap();
        write_atomic(&path, b"new").unwrap();
        let mut want = vec![
            alive,
            ".other.csv.1.0.tmp".to_string(),
            "out.csv".to_string(),
        ];
        want.sort();
        assert_eq!(entries(&dir), want);
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
