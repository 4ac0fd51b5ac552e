//! What the service's test binaries share: a `liftwatch serve` child killed on drop, one
//! HTTP request, waiting for the worker, and the trip CSV as the API's objects.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use serde_json::Value;

pub const BIN: &str = env!("CARGO_BIN_EXE_liftwatch");

/// The server binary of the load test: `LIFTWATCH_BIN` (a release build), else this profile's.
/// A relative path is the workspace's, where the command is typed (cargo runs the test in the
/// crate's directory).
pub fn server_bin() -> String {
    let Ok(bin) = std::env::var("LIFTWATCH_BIN") else {
        return BIN.to_string();
    };
    let workspace = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    workspace.join(bin).to_string_lossy().into_owned()
}

/// The write token of the cases.
pub const TOKEN: &str = "test-token-7f3a";

/// Longest wait for a server to start or catch up.
pub const PATIENCE: Duration = Duration::from_secs(60);

/// A healthy simulated day of seed `seed` in `dir/healthy` and a model fitted on its raw log:
/// (`raw.csv`, `model.json`).
pub fn healthy_day(dir: &super::Dir, seed: &str) -> (std::path::PathBuf, std::path::PathBuf) {
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let healthy = dir.path("healthy");
    run(&[
        "simulate",
        "--out",
        &s(&healthy),
        "--days",
        "1",
        "--seed",
        seed,
        "-q",
    ]);
    let model = dir.path("model.json");
    let (raw, elevator) = (healthy.join("raw.csv"), healthy.join("elevator.toml"));
    run(&[
        "fit",
        "--input",
        &s(&raw),
        "--elevator",
        &s(&elevator),
        "--out",
        &s(&model),
    ]);
    (raw, model)
}

pub fn run(args: &[&str]) {
    let out = Command::new(BIN)
        .args(args)
        .output()
        .expect("the binary runs");
    assert!(
        out.status.success(),
        "liftwatch {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// A running `liftwatch serve`, killed on drop.
pub struct Server {
    pub child: Child,
    pub port: u16,
}

impl Server {
    pub fn start(data: &Path, listen: &str, token: Option<&str>) -> Server {
        Server::start_with(data, listen, token, &[])
    }

    pub fn start_with(data: &Path, listen: &str, token: Option<&str>, extra: &[&str]) -> Server {
        let data = data.to_str().expect("a UTF-8 path");
        Server::spawn(
            &[&["--data", data, "--listen", listen][..], extra].concat(),
            token,
        )
    }

    /// `liftwatch serve ARGS…`, once it printed its listening line.
    pub fn spawn(args: &[&str], token: Option<&str>) -> Server {
        let mut cmd = Command::new(server_bin());
        cmd.arg("serve")
            .args(args)
            .env_remove("LIFTWATCH_TOKEN")
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped());
        if let Some(t) = token {
            cmd.env("LIFTWATCH_TOKEN", t);
        }
        let mut child = cmd.spawn().expect("serve starts");
        let mut err = BufReader::new(child.stderr.take().expect("piped"));
        // Log lines (an MQTT connection, say) may come before the listening line.
        let mut seen = String::new();
        let port = loop {
            let mut line = String::new();
            if err.read_line(&mut line).unwrap_or(0) == 0 {
                let _ = child.kill();
                panic!("serve ended without a listening line: {seen}");
            }
            seen.push_str(&line);
            let port = line
                .strip_prefix("liftwatch serve: listening on http://127.0.0.1:")
                .and_then(|r| r.split_whitespace().next())
                .and_then(|p| p.parse().ok());
            if let Some(p) = port {
                break p;
            }
        };
        // Drain the logs so the server never blocks on a full pipe.
        // LIFTWATCH_TEST_LOGS=1 passes them on.
        let show = std::env::var_os("LIFTWATCH_TEST_LOGS").is_some();
        std::thread::spawn(move || {
            let mut line = String::new();
            while err.read_line(&mut line).unwrap_or(0) > 0 {
                if show {
                    eprint!("{line}");
                }
                line.clear();
            }
        });
        Server { child, port }
    }

    pub fn url(&self) -> String {
        format!("http://127.0.0.1:{}", self.port)
    }

    pub fn kill9(&mut self) {
        let _ = self.child.kill(); // SIGKILL on unix
        let _ = self.child.wait();
    }

    /// A request; (status, body).
    pub fn req(&self, method: &str, path: &str, token: Option<&str>, body: &[u8]) -> (u16, String) {
        request(self.port, method, path, token, body, "text/csv")
    }

    /// Activates the model file `model` (its bytes) for elevator `id` with the test token.
    pub fn upload_model(&self, id: &str, model: &[u8]) {
        let path = format!("/api/v1/elevators/{id}/models");
        let (st, reply) = self.req("POST", &path, Some(TOKEN), model);
        assert_eq!(st, 201, "POST {path}: {reply}");
    }

    /// Posts `body`, raw telemetry as CSV, for elevator `id` with the test token; it is taken.
    pub fn post_telemetry(&self, id: &str, body: &str) {
        let path = format!("/api/v1/elevators/{id}/telemetry");
        let (st, reply) = self.req("POST", &path, Some(TOKEN), body.as_bytes());
        assert_eq!(st, 200, "POST {path}: {reply}");
    }

    pub fn get_json(&self, path: &str) -> Value {
        let (status, body) = self.req("GET", path, None, b"");
        assert_eq!(status, 200, "GET {path}: {body}");
        serde_json::from_str(&body).expect("JSON")
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        self.kill9();
    }
}

/// One HTTP/1.1 request on its own connection (`Connection: close`).
pub fn request(
    port: u16,
    method: &str,
    path: &str,
    token: Option<&str>,
    body: &[u8],
    ctype: &str,
) -> (u16, String) {
    let mut s = TcpStream::connect(("127.0.0.1", port)).expect("connects");
    s.set_read_timeout(Some(PATIENCE)).unwrap();
    let auth = token.map_or(String::new(), |t| format!("Authorization: Bearer {t}\r\n"));
    let head = format!(
        "{method} {path} HTTP/1.1\r\nHost: x\r\nConnection: close\r\nContent-Type: {ctype}\r\nContent-Length: {}\r\n{auth}\r\n",
        body.len()
    );
    s.write_all(head.as_bytes()).unwrap();
    // A server may answer (413) and close before it read a large body: that is fine.
    let _ = s.write_all(body);
    let mut out = Vec::new();
    let _ = s.read_to_end(&mut out);
    let text = String::from_utf8_lossy(&out).into_owned();
    let status = text
        .split_whitespace()
        .nth(1)
        .and_then(|c| c.parse().ok())
        .unwrap_or(0);
    let body = text.split_once("\r\n\r\n").map_or("", |x| x.1).to_string();
    (status, body)
}

/// Waits until the server has applied and checkpointed every stored batch.
pub fn settle(s: &Server) {
    let t0 = Instant::now();
    loop {
        let h = s.get_json("/healthz");
        if h["queue_depth"] == 0 {
            return;
        }
        assert!(t0.elapsed() < PATIENCE, "the queue did not drain: {h}");
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// The trip CSV rows as the API's objects (same conversion: numbers, empty → null).
pub fn csv_rows(path: &Path) -> Vec<Value> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    lines
        .map(|l| {
            let mut m = serde_json::Map::new();
            for (k, f) in header.iter().zip(l.split(',')) {
                let v = if f.is_empty() {
                    Value::Null
                } else if matches!(*k, "level" | "mode") {
                    Value::String(f.into())
                } else {
                    serde_json::Number::from_f64(f.parse().unwrap())
                        .map_or(Value::Null, Value::Number)
                };
                m.insert((*k).to_string(), v);
            }
            Value::Object(m)
        })
        .collect()
}

/// The API's trip row with only the CSV's columns.
pub fn strip(mut row: Value, keys: &[&str]) -> Value {
    let m = row.as_object_mut().unwrap();
    m.retain(|k, _| !keys.contains(&k.as_str()));
    row
}
