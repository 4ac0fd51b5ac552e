//! What the CLI test binaries share: a scratch directory per case.

// Each test binary uses its own subset of these helpers.
#![allow(dead_code)]

pub mod serve;

use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::Child;
use std::time::{Duration, Instant};

/// A fresh directory for one case under the target's tmp dir, removed at the end.
pub struct Dir(pub PathBuf);

impl Dir {
    /// Creates `<target tmp>/<name>-<pid>`, empty.
    pub fn new(name: &str) -> Dir {
        let dir =
            Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("the target's tmp dir is writable");
        Dir(dir)
    }

    /// A path inside the directory.
    pub fn path(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }

    /// Writes `bytes` to `name` inside the directory and returns its path.
    pub fn file(&self, name: &str, bytes: &[u8]) -> PathBuf {
        let path = self.0.join(name);
        std::fs::write(&path, bytes).expect("case dir is writable");
        path
    }

    /// The names of the entries, sorted.
    pub fn names(&self) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(&self.0)
            .expect("dir exists")
            .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }
}

impl Drop for Dir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A child process (a broker, a server) killed on drop.
pub struct Killed(pub Child);

impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// A free loopback port (the listener is closed again at once: see [`on_fresh_ports`]).
pub fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .expect("a free port")
        .port()
}

/// Starts of a server (a broker, a cluster) on fresh ports before a case gives up. A port
/// that [`free_port`] found free is closed again before the server binds it, and in that gap
/// another process's connection can take it as its local port; the server then exits
/// ("address already in use"). A fresh set of ports is the remedy.
pub const PORT_TRIES: usize = 3;

/// `start(attempt)` until it returns a server, at most [`PORT_TRIES`] times, each try on
/// ports it takes afresh; `Err` says why a try failed (a server that exited, and its log).
/// Panics with the last reason when none started.
pub fn on_fresh_ports<T>(what: &str, mut start: impl FnMut(usize) -> Result<T, String>) -> T {
    let mut why = String::new();
    for attempt in 0..PORT_TRIES {
        match start(attempt) {
            Ok(server) => return server,
            Err(e) => {
                eprintln!("{what} again on new ports: {e}");
                why = e;
            }
        }
    }
    panic!("{what} did not start in {PORT_TRIES} tries: {why}");
}

/// A number from the environment, or `default`.
pub fn env_num(name: &str, default: f64) -> f64 {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// The resident memory of process `pid` (KiB), NaN when unknown.
pub fn rss_kb(pid: u32) -> f64 {
    let st = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap_or_default();
    st.lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        .unwrap_or(f64::NAN)
}

/// The rows of a raw log's text in batches of `period_s` of log, each with the header.
pub fn batches(text: &str, period_s: f64) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    let mut start = f64::NAN;
    for r in text.lines().skip(1) {
        let t: f64 = r.split(',').next().unwrap().parse().unwrap();
        if out.is_empty() || t >= start + period_s {
            out.push("time,signal,value\n".into());
            start = t;
        }
        let b = out.last_mut().unwrap();
        b.push_str(r);
        b.push('\n');
    }
    out
}

/// One sender thread's plan: (due time in s, elevator index, batch) for each of its elevators
/// and `batches` batches, elevator i's batch b due at (b + i/n)·`period_s`, in due order.
pub fn plan(
    mine: impl Iterator<Item = usize>,
    n: usize,
    batches: usize,
    period_s: f64,
) -> Vec<(f64, usize, usize)> {
    let mut plan = Vec::new();
    for i in mine {
        for b in 0..batches {
            plan.push(((b as f64 + i as f64 / n as f64) * period_s, i, b));
        }
    }
    plan.sort_by(|a, b| a.0.total_cmp(&b.0));
    plan
}

/// Sleeps until `due` s after `t0`; how late it is then (s).
pub fn wait_until(t0: Instant, due: f64) -> f64 {
    let now = t0.elapsed().as_secs_f64();
    if due > now {
        std::thread::sleep(Duration::from_secs_f64(due - now));
    }
    t0.elapsed().as_secs_f64() - due
}
