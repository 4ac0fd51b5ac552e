//! The dashboard of `liftwatch serve` in a real browser: the server started on loopback with
//! a fresh data directory, loaded with one small simulated elevator whose drive degrades (fit
//! on its healthy day, the model uploaded, its degraded days replayed as fast as accepted, on
//! a calendar clock in a zone of UTC+01:00), a healthy peer of the same group (its training
//! day replayed with the same model), a third without a model and a fourth whose motor
//! voltage sensor reads 25 V high from noon of its day (a `sensor` verdict and event naming the
//! `voltage` channel); then Debian's headless Chromium loads the fleet page and the elevator
//! pages, their DOM is checked (the order, the levels in words, the drift in physical units,
//! the date and zone; the verdict, the charts, the peers; the broken sensor named in words in
//! the fleet row, the headline and the events table) and screenshots at a laptop's (1366×768)
//! and a phone's (390×844) size are
//! written under `target/dashboard-screenshots/`, their paths printed. Skipped, saying why,
//! on a machine without `chromium`.

mod common;

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use common::Dir;

const TOKEN: &str = "dashboard-test-token";
/// The elevator that degrades, a healthy peer of its group and a peer without a model.
const CAR: &str = "car-1";
const PEER: &str = "car-2";
const SPARE: &str = "car-3";
/// An elevator of the same group whose voltage sensor fails (the machine stays healthy).
const SENSOR: &str = "car-4";
/// 2026-03-02 00:00 UTC: the degraded days are replayed on a calendar clock (the simulator's
/// starts at 0), so that the pages show dates; whole days keep the hours of the traffic.
const START_S: f64 = 1_772_409_600.0;

fn chromium() -> Option<PathBuf> {
    ["chromium", "chromium-browser", "google-chrome"]
        .iter()
        .find_map(|name| {
            let ok = Command::new(name)
                .arg("--version")
                .output()
                .is_ok_and(|o| o.status.success());
            ok.then(|| PathBuf::from(name))
        })
}

/// Waits for `child` at most `limit`, killing it after; returns its exit status and stderr.
fn bounded(mut child: Child, limit: Duration, what: &str) -> (bool, String, String) {
    let out = child.stdout.take();
    let err = child.stderr.take();
    let read = |r: Option<Box<dyn Read + Send>>| {
        std::thread::spawn(move || {
            let mut s = Vec::new();
            if let Some(mut r) = r {
                let _ = r.read_to_end(&mut s);
            }
            String::from_utf8_lossy(&s).into_owned()
        })
    };
    let out = read(out.map(|o| Box::new(o) as Box<dyn Read + Send>));
    let err = read(err.map(|e| Box::new(e) as Box<dyn Read + Send>));
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().expect("wait works") {
            break s;
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{what} took more than {} s", limit.as_secs());
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    (
        status.success(),
        out.join().unwrap_or_default(),
        err.join().unwrap_or_default(),
    )
}

/// Runs `liftwatch ARGS` (token in the environment), at most `limit`; panics on failure.
fn liftwatch(args: &[&str], limit: Duration) {
    let child = Command::new(env!("CARGO_BIN_EXE_liftwatch"))
        .args(args)
        .env("LIFTWATCH_TOKEN", TOKEN)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the binary runs");
    let (ok, _, err) = bounded(child, limit, &format!("liftwatch {args:?}"));
    assert!(ok, "liftwatch {args:?} failed: {err}");
}

fn s(p: &Path) -> &str {
    p.to_str().expect("temp paths are UTF-8")
}

/// The server, killed when dropped (also when an assertion fails).
struct Server {
    child: Child,
    /// `http://127.0.0.1:PORT`.
    url: String,
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Server {
    /// Starts `liftwatch serve` on a free loopback port and waits for its listening line.
    fn start(data: &Path) -> Server {
        let mut child = Command::new(env!("CARGO_BIN_EXE_liftwatch"))
            .args(["serve", "--data", s(data), "--listen", "127.0.0.1:0"])
            .env("LIFTWATCH_TOKEN", TOKEN)
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("the binary runs");
        let stderr = child.stderr.take().expect("stderr is piped");
        let (tx, rx) = mpsc::channel();
        // Reads the listening line, then keeps draining stderr so that the server never blocks.
        std::thread::spawn(move || {
            let mut tx = Some(tx);
            for line in BufReader::new(stderr).lines() {
                let Ok(line) = line else { break };
                if let Some(rest) = line.strip_prefix("liftwatch serve: listening on ") {
                    let url = rest
                        .split_whitespace()
                        .next()
                        .unwrap_or_default()
                        .to_string();
                    if let Some(tx) = tx.take() {
                        let _ = tx.send(url);
                    }
                }
            }
        });
        let mut server = Server {
            child,
            url: String::new(),
        };
        server.url = rx
            .recv_timeout(Duration::from_secs(60))
            .expect("the server prints its listening line within 60 s");
        assert!(
            server.url.starts_with("http://127.0.0.1:"),
            "{}",
            server.url
        );
        server
    }

    /// One HTTP/1.1 request over a plain socket; returns the status and the body.
    fn request(&self, method: &str, path: &str, ctype: &str, body: &[u8]) -> (u16, String) {
        let host = self.url.trim_start_matches("http://");
        let mut sock = TcpStream::connect(host).expect("the server accepts");
        sock.set_read_timeout(Some(Duration::from_secs(60))).ok();
        let head = format!(
            "{method} {path} HTTP/1.1\r\nHost: {host}\r\nAuthorization: Bearer {TOKEN}\r\n\
             Content-Type: {ctype}\r\nContent-Length: {}\r\nConnection: close\r\n\r\n",
            body.len()
        );
        sock.write_all(head.as_bytes()).expect("request is sent");
        sock.write_all(body).expect("body is sent");
        let mut raw = Vec::new();
        sock.read_to_end(&mut raw).expect("response is read");
        let text = String::from_utf8_lossy(&raw).into_owned();
        let (head, body) = text.split_once("\r\n\r\n").unwrap_or((&text, ""));
        let status = head
            .split_whitespace()
            .nth(1)
            .and_then(|c| c.parse().ok())
            .unwrap_or(0);
        let chunked = head.lines().any(|l| {
            l.to_ascii_lowercase()
                .starts_with("transfer-encoding: chunked")
        });
        let body = if chunked {
            dechunk(body)
        } else {
            body.to_string()
        };
        (status, body)
    }

    fn get_json(&self, path: &str) -> serde_json::Value {
        let (status, body) = self.request("GET", path, "application/json", b"");
        assert_eq!(status, 200, "GET {path}: {body}");
        serde_json::from_str(&body).unwrap_or_else(|e| panic!("GET {path} is JSON ({e}): {body}"))
    }
}

fn dechunk(mut s: &str) -> String {
    let mut out = String::new();
    while let Some((size, rest)) = s.split_once("\r\n") {
        let n = usize::from_str_radix(size.trim(), 16).unwrap_or(0);
        if n == 0 || rest.len() < n {
            break;
        }
        out.push_str(&rest[..n]);
        s = rest[n..].trim_start_matches("\r\n");
    }
    out
}

/// Headless Chromium on `url` with `args` (a fresh profile each run, at most 90 s); returns
/// stdout.
fn headless(bin: &Path, profile: &Path, args: &[String], url: &str) -> String {
    let _ = std::fs::remove_dir_all(profile);
    let child = Command::new(bin)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--hide-scrollbars",
            "--virtual-time-budget=5000",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .args(args)
        .arg(url)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("chromium runs");
    let (ok, out, err) = bounded(child, Duration::from_secs(90), "chromium");
    assert!(ok, "chromium failed: {err}");
    out
}

/// Width and height of a PNG from its IHDR chunk.
fn png_size(path: &Path) -> (u32, u32) {
    let b = std::fs::read(path).expect("the screenshot exists");
    assert_eq!(&b[..8], b"\x89PNG\r\n\x1a\n", "{} is a PNG", path.display());
    let be = |i: usize| u32::from_be_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
    (be(16), be(20))
}

/// Copies a raw `time,signal,value` log with its times moved by `shift` seconds; returns the
/// last time written.
fn shift_times(from: &Path, to: &Path, shift: f64) -> f64 {
    let text = std::fs::read_to_string(from).expect("the simulated log is readable");
    let mut out = String::with_capacity(text.len() + text.len() / 4);
    let mut last = f64::NEG_INFINITY;
    for (i, line) in text.lines().enumerate() {
        match line.split_once(',') {
            Some((t, rest)) if i > 0 => {
                let t: f64 = t.parse().expect("a time in seconds");
                last = last.max(t + shift);
                out.push_str(&format!("{:.3},{rest}\n", t + shift));
            }
            _ => {
                out.push_str(line);
                out.push('\n');
            }
        }
    }
    std::fs::write(to, out).expect("the case dir is writable");
    last
}

/// The summary of elevator `id` in the fleet list, if listed.
fn summary(fleet: &serde_json::Value, id: &str) -> Option<serde_json::Value> {
    fleet["elevators"]
        .as_array()?
        .iter()
        .find(|e| e["id"] == id)
        .cloned()
}

#[test]
fn the_dashboard_shows_which_elevator_needs_a_visit_in_chromium() {
    let Some(bin) = chromium() else {
        eprintln!("skipped: no chromium on this machine (apt-get install -y chromium)");
        return;
    };
    let dir = Dir::new("dashboard");
    let min = |m: u64| Duration::from_secs(60 * m);

    // One elevator: a healthy day to learn from, then two days with its drive degraded from
    // noon of the first (Kd +20 %, a step), the same elevator (same seed).
    let healthy = dir.path("healthy");
    let worn = dir.path("worn");
    let model = dir.path("model.json");
    #[rustfmt::skip]
    liftwatch(&["simulate", "--out", s(&healthy), "--days", "1", "--seed", "7"], min(2));
    #[rustfmt::skip]
    liftwatch(&["fit", "--input", s(&healthy.join("raw.csv")), "--elevator",
        s(&healthy.join("elevator.toml")), "--out", s(&model), "--epochs", "60"], min(5));
    #[rustfmt::skip]
    liftwatch(&["simulate", "--out", s(&worn), "--days", "2", "--seed", "7", "--scenario", "motor",
        "--onset-days", "0.5", "--ramp", "step", "--severity", "2"], min(2));

    let raw = dir.path("worn-calendar.csv");
    let end = shift_times(&worn.join("raw.csv"), &raw, START_S);
    // The healthy peer: the training day itself, on the same calendar.
    let peer_raw = dir.path("healthy-calendar.csv");
    let peer_end = shift_times(&healthy.join("raw.csv"), &peer_raw, START_S);
    // The sensor fault: the same elevator's day, its voltage sensor 25 V high from noon on.
    let faulty = dir.path("faulty");
    #[rustfmt::skip]
    liftwatch(&["simulate", "--out", s(&faulty), "--days", "1", "--seed", "7",
        "--sensor-fault", "voltage-offset", "--onset-days", "0.5"], min(2));
    let sensor_raw = dir.path("faulty-calendar.csv");
    let sensor_end = shift_times(&faulty.join("raw.csv"), &sensor_raw, START_S);

    let server = Server::start(&dir.path("data"));
    #[rustfmt::skip]
    let cars = [(CAR, "Test bank, car 1"), (PEER, "Test bank, car 2"), (SPARE, "Test bank, car 3"),
        (SENSOR, "Test bank, car 4")];
    for (id, name) in cars {
        let body = serde_json::json!({
            "name": name, "group": "Test bank", "timezone": "+01:00",
            "rated_load_kg": 1000.0, "rated_speed_mps": 1.6, "floors": 16,
        });
        let (status, text) = server.request(
            "PUT",
            &format!("/api/v1/elevators/{id}"),
            "application/json",
            body.to_string().as_bytes(),
        );
        assert!((200..300).contains(&status), "PUT {id}: {status} {text}");
    }
    for (id, log) in [(CAR, &raw), (PEER, &peer_raw), (SENSOR, &sensor_raw)] {
        let (status, text) = server.request(
            "POST",
            &format!("/api/v1/elevators/{id}/models"),
            "application/json",
            &std::fs::read(&model).expect("the model was written"),
        );
        assert!(
            (200..300).contains(&status),
            "model upload for {id}: {status} {text}"
        );
        #[rustfmt::skip]
        liftwatch(&["replay", "--input", s(log), "--id", id, "--to", &server.url,
            "--speed", "0"], min(10));
    }

    // The server analyses what it accepted in the background: wait until it has watched the
    // log to its last minute (the aligner holds the newest samples back) and stated its level.
    let start = Instant::now();
    let watched =
        |e: &serde_json::Value| e["verdict"]["time"].as_f64().unwrap_or(f64::NEG_INFINITY);
    let car = loop {
        let fleet = server.get_json("/api/v1/elevators");
        let car = summary(&fleet, CAR).expect("the elevator is listed");
        let peer = summary(&fleet, PEER).expect("the peer is listed");
        let faulty = summary(&fleet, SENSOR).expect("the car with the sensor fault is listed");
        let level = car["verdict"]["level"].as_str().unwrap_or("").to_string();
        if (level == "advisory" || level == "alarm")
            && watched(&car) >= end - 60.0
            && watched(&peer) >= peer_end - 60.0
            && watched(&faulty) >= sensor_end - 60.0
        {
            assert_eq!(
                peer["verdict"]["level"], "normal",
                "the healthy peer: {peer}"
            );
            assert_eq!(faulty["verdict"]["mode"], "sensor", "{faulty}");
            assert_eq!(faulty["verdict"]["channel"], "voltage", "{faulty}");
            break car;
        }
        assert!(
            start.elapsed() < min(5),
            "the log not watched to its end with an advisory within 5 min after the replay \
             (it ends at {end}): {car}"
        );
        std::thread::sleep(Duration::from_millis(500));
    };
    let level = car["verdict"]["level"]
        .as_str()
        .expect("a level")
        .to_string();
    assert_eq!(car["verdict"]["mode"], "motor", "{car}");

    let shots = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .parent()
        .expect("the tmp dir lies in target/")
        .join("dashboard-screenshots");
    std::fs::create_dir_all(&shots).expect("target/ is writable");
    let profile = dir.path("chromium-profile");
    let fleet_url = format!("{}/#/", server.url);
    let car_url = format!("{}/#/elevator/{CAR}", server.url);
    let sensor_url = format!("{}/#/elevator/{SENSOR}", server.url);

    // The fleet: the degraded car first, with its level in words and its drift in percent.
    let dom = headless(
        &bin,
        &profile,
        &["--window-size=1366,768".into(), "--dump-dom".into()],
        &fleet_url,
    );
    let row = dom
        .find(&format!("data-id=\"{CAR}\""))
        .unwrap_or_else(|| panic!("a fleet row for {CAR}: {dom}"));
    let peer_row = dom
        .find(&format!("data-id=\"{PEER}\""))
        .expect("a fleet row for the peer");
    let spare_row = dom
        .find(&format!("data-id=\"{SPARE}\""))
        .expect("a fleet row for the car without a model");
    assert!(row < peer_row, "the car at risk comes first");
    assert!(peer_row < spare_row, "the car without a model comes last");
    // The row ends where the next begins (the sensor car, at advisory, may come between).
    let row_end = |at: usize| {
        dom[at + 1..]
            .find("data-id=\"")
            .map_or(dom.len(), |i| at + 1 + i)
    };
    let car_row = &dom[row..row_end(row)];
    assert!(
        car_row.contains(&format!("badge lv-{level}\">{level}<")),
        "its level, in words: {car_row}"
    );
    assert!(car_row.contains("Test bank, car 1"), "its name: {car_row}");
    assert!(
        car_row.contains("2026-03-04 00:59"),
        "the last data's date: {car_row}"
    );
    assert!(
        car_row.contains("UTC+01:00"),
        "in the elevator's zone: {car_row}"
    );
    assert!(car_row.contains("drive"), "the subsystem: {car_row}");
    assert!(car_row.contains("Kd +"), "the drift, in Kd %: {car_row}");
    assert!(
        car_row.contains(" ± "),
        "with its standard error: {car_row}"
    );
    assert!(
        car_row.contains("inspect the drive"),
        "what to inspect: {car_row}"
    );
    assert!(
        dom[peer_row..spare_row].contains("badge lv-normal\">normal<"),
        "the healthy peer is normal"
    );
    assert!(
        dom[spare_row..row_end(spare_row)].contains("no model"),
        "the car without a model says so"
    );
    let sensor_row = dom
        .find(&format!("data-id=\"{SENSOR}\""))
        .expect("a fleet row for the car with the sensor fault");
    assert!(
        sensor_row < peer_row,
        "the sensor advisory comes before the normal peer"
    );
    let sensor_row = &dom[sensor_row..row_end(sensor_row)];
    assert!(
        sensor_row.contains("<b>sensors</b>: <span class=\"channel\">motor voltage sensor</span>"),
        "the broken sensor, in words: {sensor_row}"
    );
    assert!(
        sensor_row.contains("check the motor voltage sensor and its wiring"),
        "what to inspect, that sensor: {sensor_row}"
    );
    assert!(
        !dom.contains("class=\"error\" role=\"alert\">"),
        "no API error shown"
    );

    // The elevator: the verdict in sentences, then the charts, the peers, the events.
    let dom = headless(
        &bin,
        &profile,
        &["--window-size=1366,768".into(), "--dump-dom".into()],
        &car_url,
    );
    let verdict = dom.find("id=\"verdict\"").expect("a verdict section");
    let chart = dom.find("<polyline").expect("the charts have lines");
    assert!(verdict < chart, "the verdict comes before the charts");
    assert!(
        dom.contains(&format!("{} (as of 2026-03-0", level.to_uppercase())),
        "the verdict's headline, dated"
    );
    assert!(dom.contains("since 2 Mar 2026"), "since when");
    assert!(dom.contains("advisory level"), "the risk chart's levels");
    assert!(dom.contains("Test bank, car 2"), "the peer is compared");
    assert!(
        dom.contains("aria-label=\"Kd (drive) of this car and its peers\""),
        "the peers' drifts drawn"
    );
    assert!(dom.contains("Model versions"), "the model registry");
    assert!(
        !dom.contains("class=\"error\" role=\"alert\">"),
        "no API error shown"
    );

    // The elevator whose voltage sensor fails: the headline and the events name that sensor.
    let dom = headless(
        &bin,
        &profile,
        &["--window-size=1366,768".into(), "--dump-dom".into()],
        &sensor_url,
    );
    let section = |start: &str| {
        let at = dom
            .find(start)
            .unwrap_or_else(|| panic!("{start} on the page: {dom}"));
        let end = dom[at..].find("</section>").map_or(dom.len(), |i| at + i);
        dom[at..end].to_string()
    };
    let verdict = section("id=\"verdict\"");
    assert!(
        verdict.contains(
            "ADVISORY (as of 2026-03-03 00:59 UTC+01:00), sensors: the motor voltage sensor \
             (voltage channel); check the motor voltage sensor and its wiring: its data look wrong."
        ),
        "the headline names the broken sensor: {verdict}"
    );
    assert!(
        verdict.contains("sensor (sensors), the voltage channel"),
        "the mode names the channel: {verdict}"
    );
    let events = section("<h2>Events</h2>");
    assert!(
        events.contains(">sensors: motor voltage sensor</td>"),
        "the event names the broken sensor: {events}"
    );
    for text in [&verdict, &events] {
        assert!(
            !text.contains("undefined") && !text.contains("null"),
            "no undefined or null shown: {text}"
        );
    }

    let mut written = Vec::new();
    for (name, url, w, h) in [
        ("fleet-laptop.png", &fleet_url, 1366, 768),
        ("fleet-phone.png", &fleet_url, 390, 844),
        ("elevator-laptop.png", &car_url, 1366, 768),
        ("elevator-phone.png", &car_url, 390, 844),
        ("elevator-laptop-full.png", &car_url, 1366, 2600),
        ("elevator-phone-full.png", &car_url, 390, 6400),
        ("sensor-laptop.png", &sensor_url, 1366, 768),
        ("sensor-phone-full.png", &sensor_url, 390, 6400),
    ] {
        let png = shots.join(name);
        let _ = std::fs::remove_file(&png);
        headless(
            &bin,
            &profile,
            &[
                format!("--window-size={w},{h}"),
                format!("--screenshot={}", png.display()),
            ],
            url,
        );
        assert_eq!(png_size(&png), (w, h), "{}", png.display());
        let bytes = std::fs::metadata(&png).map(|m| m.len()).unwrap_or(0);
        assert!(
            bytes > 20_000,
            "{} holds {bytes} bytes: a blank page?",
            png.display()
        );
        written.push(png);
    }
    for png in &written {
        eprintln!("screenshot: {}", png.display());
    }
    drop(server);
}
