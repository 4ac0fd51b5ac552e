//! `liftwatch serve --mqtt` with a real Mosquitto broker on loopback: a gateway (`liftwatch
//! replay --to mqtt://…`) publishes a raw log on `liftwatch/{id}/telemetry`; the service takes
//! it through the broker into the same store and monitor as HTTP, so its trip rows equal a batch
//! `liftwatch monitor`; its events come out on `liftwatch/{id}/events`; a gateway with a wrong
//! password is refused by the broker. Skipped, saying so, where Mosquitto is not installed
//! (`.ci/run` installs it). The broker and the server are killed when the case ends.

mod common;

use std::io::Read;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::serve::{csv_rows, healthy_day, run, strip, Server, BIN, PATIENCE, TOKEN};
use common::{free_port, on_fresh_ports, Dir, Killed};
use serde_json::Value;

/// Debian's Mosquitto broker and its password tool.
const MOSQUITTO: &str = "/usr/sbin/mosquitto";
const MOSQUITTO_PASSWD: &str = "/usr/bin/mosquitto_passwd";
const MOSQUITTO_SUB: &str = "/usr/bin/mosquitto_sub";

/// Starts Mosquitto on a free loopback port, which it returns, with two logins: the service
/// and a gateway.
fn broker(dir: &Dir) -> (Killed, u16) {
    let pw = dir.path("passwords");
    for (i, (user, pass)) in [("svc", "svc-pw"), ("gw", "gw-pw")].iter().enumerate() {
        let create: &[&str] = if i == 0 { &["-c"] } else { &[] };
        let st = Command::new(MOSQUITTO_PASSWD)
            .args(create)
            .args(["-b", pw.to_str().unwrap(), user, pass])
            .status()
            .expect("mosquitto_passwd runs");
        assert!(st.success());
    }
    on_fresh_ports("mosquitto", |attempt| {
        let port = free_port();
        let conf = dir.file(
            &format!("mosquitto-{attempt}.conf"),
            format!(
                "listener {port} 127.0.0.1\nallow_anonymous false\npassword_file {}\npersistence false\n",
                pw.display()
            )
            .as_bytes(),
        );
        // Its log, not a connection, tells it listens: a connection could reach whatever
        // else holds the port.
        let log = dir.path(&format!("mosquitto-{attempt}.log"));
        let mut child = Killed(
            Command::new(MOSQUITTO)
                .args(["-c", conf.to_str().unwrap()])
                .stdout(Stdio::null())
                .stderr(std::fs::File::create(&log).unwrap())
                .spawn()
                .expect("mosquitto starts"),
        );
        let t0 = Instant::now();
        loop {
            let text = std::fs::read_to_string(&log).unwrap_or_default();
            if let Ok(Some(status)) = child.0.try_wait() {
                let error = text.lines().find(|l| l.contains("Error"));
                return Err(format!(
                    "port {port}: exited ({status}): {}",
                    error.unwrap_or("no error logged")
                ));
            }
            // "running" comes once every listener is bound.
            if text.contains(" running") {
                return Ok((child, port));
            }
            assert!(t0.elapsed() < PATIENCE, "mosquitto did not listen");
            std::thread::sleep(Duration::from_millis(50));
        }
    })
}

#[test]
fn telemetry_through_a_broker_gives_the_rows_of_a_batch_run_and_events_come_out() {
    if !Path::new(MOSQUITTO).exists() {
        eprintln!("SKIPPED: {MOSQUITTO} is not installed (apt-get install mosquitto)");
        return;
    }
    if !Path::new(MOSQUITTO_SUB).exists() {
        eprintln!("SKIPPED: {MOSQUITTO_SUB} is not installed (apt-get install mosquitto-clients)");
        return;
    }
    let dir = Dir::new("serve-mqtt");
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let worn = dir.path("worn");
    let (_, model) = healthy_day(&dir, "6");
    // A stuck speed reading from 0.3 days on: a sensor advisory and its end.
    let worn_args = ["--days", "0.6", "--seed", "6", "--start-hour", "24"];
    let fault = ["--sensor-fault", "stuck-speed", "--onset-days", "0.3", "-q"];
    run(&[&["simulate", "--out", &s(&worn)][..], &worn_args, &fault].concat());
    let raw = worn.join("raw.csv");
    let (want_rows, want_events) = (dir.path("trips.csv"), dir.path("events.jsonl"));
    let monitor = ["monitor", "--model", &s(&model), "--input", &s(&raw)];
    let outs = [
        "--out",
        &s(&want_rows),
        "--rows",
        "trip",
        "--events",
        &s(&want_events),
    ];
    run(&[&monitor[..], &outs, &["-q"]].concat());
    let want_events: Vec<Value> = std::fs::read_to_string(&want_events)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert!(!want_events.is_empty(), "the scenario raises events");

    let (_broker, port) = broker(&dir);
    let url = |login: &str| format!("mqtt://{login}@127.0.0.1:{port}");
    let server = Server::start_with(
        &dir.path("data"),
        "127.0.0.1:0",
        Some(TOKEN),
        &["--mqtt", &url("svc:svc-pw")],
    );
    server.upload_model("lift-m", &std::fs::read(&model).unwrap());
    // An operator's subscription to the events topic, as a dashboard or a ticket system has.
    let events_file = dir.path("mqtt-events.jsonl");
    let sub = Command::new(MOSQUITTO_SUB)
        .args([
            "-h",
            "127.0.0.1",
            "-p",
            &port.to_string(),
            "-u",
            "gw",
            "-P",
            "gw-pw",
        ])
        .args(["-t", "liftwatch/lift-m/events", "-q", "1"])
        .args(["-C", &want_events.len().to_string(), "-W", "120"])
        .stdout(std::fs::File::create(&events_file).unwrap())
        .spawn()
        .expect("mosquitto_sub runs");
    let sub = Killed(sub);
    std::thread::sleep(Duration::from_millis(300)); // the subscription is in place

    // A gateway with a wrong password is refused by the broker, and replay says so.
    let refused = Command::new(BIN)
        .args([
            "replay",
            "--input",
            &s(&raw),
            "--id",
            "lift-m",
            "--to",
            &url("gw:wrong"),
        ])
        .args(["--speed", "0", "-q"])
        .output()
        .unwrap();
    assert!(!refused.status.success());
    let why = String::from_utf8_lossy(&refused.stderr);
    assert!(why.contains("refused"), "{why}");

    let t0 = Instant::now();
    let sent = Command::new(BIN)
        .args([
            "replay",
            "--input",
            &s(&raw),
            "--id",
            "lift-m",
            "--to",
            &url("gw:gw-pw"),
        ])
        .args(["--speed", "0", "--batch-s", "60", "-q"])
        .output()
        .unwrap();
    assert!(
        sent.status.success(),
        "{}",
        String::from_utf8_lossy(&sent.stderr)
    );
    let want = csv_rows(&want_rows);
    // The broker acknowledged every batch; wait until the service stored what a batch run gives
    // (it holds back the trips of the last reorder window, as over HTTP).
    let got = loop {
        let rows = server.get_json("/api/v1/elevators/lift-m/risk?limit=100000")["rows"]
            .as_array()
            .cloned()
            .unwrap_or_default();
        if rows.len() + 3 >= want.len() || t0.elapsed() > PATIENCE {
            break rows;
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    assert!(
        got.len() + 3 >= want.len() && got.len() <= want.len(),
        "{} of {}",
        got.len(),
        want.len()
    );
    for (i, (g, w)) in got.iter().zip(&want).enumerate() {
        assert_eq!(
            &strip(g.clone(), &["start_text", "end_text"]),
            w,
            "trip row {i}"
        );
    }
    let events = server.get_json("/api/v1/elevators/lift-m/events")["events"]
        .as_array()
        .cloned()
        .unwrap();
    assert_eq!(events.len(), want_events.len());

    // Every event also came out on the events topic, as the events file's lines.
    let mut sub = sub;
    let t1 = Instant::now();
    while sub.0.try_wait().unwrap().is_none() {
        assert!(
            t1.elapsed() < PATIENCE,
            "the events did not all come out on MQTT"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
    let mut text = String::new();
    std::fs::File::open(&events_file)
        .unwrap()
        .read_to_string(&mut text)
        .unwrap();
    let published: Vec<Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(published, want_events);
    let metrics = server.req("GET", "/metrics", None, b"").1;
    assert!(metrics.contains("elevator=\"lift-m\""), "{metrics}");
    eprintln!(
        "{} trip rows and {} events through the broker in {:.1} s",
        got.len(),
        events.len(),
        t0.elapsed().as_secs_f64()
    );
}
