//! `liftwatch serve` and `liftwatch replay` end to end, on loopback only: the stored trip rows
//! and events of a stream that was killed (`kill -9`) and restarted mid-way equal a batch
//! `liftwatch monitor --rows trip` over the same raw log; bad input is refused with a 4xx and
//! changes nothing. Every server is killed when its case ends (also on a failed assertion).

mod common;

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::serve::*;
use common::{env_num, Dir};
use serde_json::Value;

/// One simulated healthy day (seed 5) into `healthy` and its model (150 epochs), the start of
/// the stream test and of the load test; returns the model's path.
fn healthy_day_and_model(dir: &Dir, healthy: &Path) -> std::path::PathBuf {
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let model = dir.path("model.json");
    run(&[
        "simulate",
        "--out",
        &s(healthy),
        "--days",
        "1",
        "--seed",
        "5",
        "-q",
    ]);
    run(&[
        "fit",
        "--input",
        &s(&healthy.join("raw.csv")),
        "--elevator",
        &s(&healthy.join("elevator.toml")),
        "--out",
        &s(&model),
        "--epochs",
        "150",
        "-q",
    ]);
    model
}

#[test]
fn a_stream_killed_and_restarted_gives_the_rows_of_a_batch_run() {
    let dir = Dir::new("serve-stream");
    let t0 = Instant::now();
    let (healthy, worn) = (dir.path("healthy"), dir.path("worn"));
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let model = healthy_day_and_model(&dir, &healthy);
    // A stuck speed reading from 0.3 days on: a sensor advisory and its end, two events.
    run(&[
        "simulate",
        "--out",
        &s(&worn),
        "--days",
        "1",
        "--seed",
        "5",
        "--start-hour",
        "24",
        "--sensor-fault",
        "stuck-speed",
        "--onset-days",
        "0.3",
        "-q",
    ]);
    let raw = worn.join("raw.csv");
    let (want_rows, want_events) = (dir.path("trips.csv"), dir.path("events.jsonl"));
    run(&[
        "monitor",
        "--model",
        &s(&model),
        "--input",
        &s(&raw),
        "--out",
        &s(&want_rows),
        "--rows",
        "trip",
        "--events",
        &s(&want_events),
        "-q",
    ]);
    eprintln!("prepared in {:.1} s", t0.elapsed().as_secs_f64());

    let data = dir.path("data");
    // The first server checkpoints every 7 batches, the restarted one at its defaults (2 s or
    // 500 batches): the outputs must not depend on it.
    let config = dir.file("serve.toml", b"checkpoint_every_batches = 7\n");
    let mut server = Server::start_with(
        &data,
        "127.0.0.1:0",
        Some(TOKEN),
        &["--config", config.to_str().unwrap()],
    );
    let port = server.port;
    let body = std::fs::read(&model).unwrap();
    server.upload_model("lift-1", &body);

    // The first 20 000 rows by hand: 10-s batches, rows shuffled within each batch (less than
    // the 30-s reorder window), every 5th batch sent twice (at-least-once delivery). Batches
    // of a minute below: each request is one fsynced commit, a few ms here.
    let text = std::fs::read_to_string(&raw).unwrap();
    let rows: Vec<&str> = text.lines().skip(1).take(20_000).collect();
    let mut batches: Vec<Vec<&str>> = Vec::new();
    let mut start = f64::NAN;
    for r in rows {
        let t: f64 = r.split(',').next().unwrap().parse().unwrap();
        if batches.is_empty() || t >= start + 10.0 {
            batches.push(Vec::new());
            start = t;
        }
        batches.last_mut().unwrap().push(r);
    }
    let mut state = 0x9e37_79b9_7f4a_7c15_u64;
    for (i, b) in batches.iter_mut().enumerate() {
        for k in (1..b.len()).rev() {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            b.swap(k, (state % (k as u64 + 1)) as usize);
        }
        let body = format!("time,signal,value\n{}\n", b.join("\n"));
        for _ in 0..(1 + usize::from(i % 5 == 0)) {
            server.post_telemetry("lift-1", &body);
        }
    }

    // Then the whole log again with replay (the first part is dropped as late or duplicate),
    // and the server killed with SIGKILL mid-stream and restarted on the same port.
    let replay = Command::new(BIN)
        .args([
            "replay",
            "--input",
            &s(&raw),
            "--id",
            "lift-1",
            "--to",
            &server.url(),
        ])
        .args(["--speed", "0", "--batch-s", "60", "-q"])
        .env("LIFTWATCH_TOKEN", TOKEN)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let wait = Instant::now();
    loop {
        let seq = server.get_json("/api/v1/elevators/lift-1")["applied_seq"]
            .as_i64()
            .unwrap_or(0);
        if seq > 1000 {
            break;
        }
        assert!(wait.elapsed() < PATIENCE, "the stream did not get going");
        std::thread::sleep(Duration::from_millis(20));
    }
    server.kill9();
    let killed_at = Instant::now();
    let server = Server::start(&data, &format!("127.0.0.1:{port}"), Some(TOKEN));
    eprintln!("restarted after {:.2} s", killed_at.elapsed().as_secs_f64());
    let out = replay.wait_with_output().unwrap();
    let log = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "replay: {log}");
    assert!(
        log.contains("sending it again"),
        "the kill was felt by replay: {log}"
    );
    settle(&server);

    let got = server.get_json("/api/v1/elevators/lift-1/risk?limit=100000");
    let got: Vec<Value> = got["rows"].as_array().unwrap().clone();
    let want = csv_rows(&want_rows);
    // The service holds back the last reorder window and never calls `finish`: the trips still
    // open at the end of the log are the batch run's last ones.
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
    // The same rows in the other direction: nothing the service stored is missing from the
    // batch run either (the comparison above is of the first got.len()).
    for w in want.iter().skip(got.len()) {
        assert!(w["end"].as_f64() > got.last().and_then(|g| g["end"].as_f64()));
    }
    let events = server.get_json("/api/v1/elevators/lift-1/events");
    let events = events["events"].as_array().unwrap();
    let mut want: Vec<Value> = std::fs::read_to_string(&want_events)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    // The file lists events as they are raised, the API by their time: an outage is dated
    // from the car's last motion, before the event raised just ahead of its detection.
    want.sort_by(|a, b| {
        a["time"]
            .as_f64()
            .unwrap()
            .total_cmp(&b["time"].as_f64().unwrap())
    });
    assert!(!want.is_empty(), "the scenario raises events");
    assert_eq!(events.len(), want.len());
    for (g, w) in events.iter().zip(&want) {
        assert_eq!(
            &strip(g.clone(), &["elevator", "id", "seq", "time_text", "label"]),
            w
        );
        assert_eq!(g["elevator"], "lift-1");
    }
    // The verdict is the text `liftwatch status --json` prints, its field order included.
    let (_, raw_summary) = server.req("GET", "/api/v1/elevators/lift-1", None, b"");
    assert!(
        raw_summary.contains("\"verdict\":{\"level\":"),
        "{raw_summary}"
    );
    let summary = server.get_json("/api/v1/elevators");
    let e = &summary["elevators"][0];
    assert_eq!(e["id"], "lift-1");
    assert_eq!(e["model_version"], 1);
    assert!(e["verdict"]["level"].is_string(), "{e}");
    let metrics = server.req("GET", "/metrics", None, b"").1;
    assert!(
        metrics.contains("liftwatch_rows_duplicate_total{elevator=\"lift-1\"}"),
        "{metrics}"
    );
    eprintln!(
        "{} trip rows and {} events identical to the batch run after {:.1} s",
        got.len(),
        events.len(),
        t0.elapsed().as_secs_f64()
    );
    registry_and_shutdown(server, &body);
    eprintln!("{:.1} s in all", t0.elapsed().as_secs_f64());
}

#[test]
fn a_checkpoint_of_another_build_restarts_the_monitor_and_the_stream_goes_on() {
    // A build that takes a model's identity or writes its state otherwise cannot resume the
    // monitor state the one before it checkpointed. The elevator's stream must go on, with a
    // fresh monitor of the active model, as after a re-baseline: it used to stop for good,
    // every later batch stored and none applied.
    let dir = Dir::new("serve-foreign-checkpoint");
    let healthy = dir.path("healthy");
    let model = healthy_day_and_model(&dir, &healthy);
    let text = std::fs::read_to_string(healthy.join("raw.csv")).unwrap();
    let lines: Vec<&str> = text.lines().skip(1).collect();
    let post = |server: &Server, rows: &[&str]| {
        for chunk in rows.chunks(5_000) {
            let body = format!("time,signal,value\n{}\n", chunk.join("\n"));
            server.post_telemetry("lift-1", &body);
        }
    };
    let data = dir.path("data");
    let mut server = Server::start(&data, "127.0.0.1:0", Some(TOKEN));
    server.upload_model("lift-1", &std::fs::read(&model).unwrap());
    let half = lines.len() / 2;
    post(&server, &lines[..half]);
    settle(&server);
    let trips_before = server.get_json("/api/v1/elevators/lift-1/risk?limit=100000")["rows"]
        .as_array()
        .unwrap()
        .len();
    assert!(trips_before > 10, "{trips_before} trips in half a day");
    server.kill9();

    // The checkpoint as another build's: its model identity is not this build's.
    let db = rusqlite::Connection::open(data.join("liftwatch.db")).unwrap();
    let changed = db
        .execute(
            "UPDATE checkpoints SET monitor = json_set(monitor, '$.model_id', '0123456789abcdef') WHERE elevator = 'lift-1' AND monitor IS NOT NULL",
            [],
        )
        .unwrap();
    assert_eq!(
        changed, 1,
        "the elevator's checkpoint holds a monitor state"
    );
    drop(db);

    let server = Server::start(&data, "127.0.0.1:0", Some(TOKEN));
    let seq_before = server.get_json("/api/v1/elevators/lift-1")["applied_seq"]
        .as_i64()
        .unwrap();
    post(&server, &lines[half..]);
    settle(&server);
    let summary = server.get_json("/api/v1/elevators/lift-1");
    assert!(
        summary["applied_seq"].as_i64().unwrap() > seq_before,
        "the batches after the restart were applied: {summary}"
    );
    let trips_after = server.get_json("/api/v1/elevators/lift-1/risk?limit=100000")["rows"]
        .as_array()
        .unwrap()
        .len();
    assert!(
        trips_after > trips_before + 10,
        "trips of the second half watched: {trips_before} then {trips_after}"
    );
}

/// The model registry and maintenance on the streamed elevator, then a graceful shutdown.
fn registry_and_shutdown(mut server: Server, model: &[u8]) {
    let id = "/api/v1/elevators/lift-1";
    // The same model again: version 2, not active, every parameter unchanged.
    let (st, reply) = server.req(
        "POST",
        &format!("{id}/models?note=again"),
        Some(TOKEN),
        model,
    );
    assert_eq!(st, 201, "{reply}");
    let models = server.get_json(&format!("{id}/models"));
    let v2 = &models["models"][1];
    assert_eq!(
        (v2["version"].as_i64(), v2["active"].as_bool()),
        (Some(2), Some(false))
    );
    assert_eq!(v2["changes"]["kd"].as_f64(), Some(0.0), "{v2}");
    // Activation, then rollback: the monitor restarts from a fresh state each time.
    for v in [2, 1] {
        let (st, reply) = server.req(
            "POST",
            &format!("{id}/models/{v}/activate"),
            Some(TOKEN),
            b"",
        );
        assert_eq!(st, 200, "{reply}");
    }
    let (st, reply) = server.req("POST", &format!("{id}/models/9/activate"), Some(TOKEN), b"");
    assert_eq!(st, 404, "{reply}");
    // A description of another car than the active model's is refused: the monitor would
    // go on with the model of a car the elevator no longer is.
    let other = br#"{"rated_load_kg": 630, "rated_speed_mps": 1.0, "floors": 8}"#;
    let (st, reply) = server.req("PUT", id, Some(TOKEN), other);
    assert_eq!(st, 409, "{reply}");
    assert!(reply.contains("630 kg"), "{reply}");
    // A visit labels the open advisory (the `normal` event that closed it is not open).
    let visit = br#"{"time": 1e9, "work": "speed encoder replaced", "finding": "confirmed", "rebaseline": true}"#;
    let (st, reply) = server.req("POST", &format!("{id}/maintenance"), Some(TOKEN), visit);
    assert_eq!(st, 201, "{reply}");
    assert!(reply.contains("\"labelled_events\":1"), "{reply}");
    let events = server.get_json(&format!("{id}/events"));
    let events = events["events"].as_array().unwrap();
    let advisory = events
        .iter()
        .find(|e| e["level"] == "advisory")
        .expect("the advisory");
    assert_eq!(advisory["label"], "confirmed");
    // An outage is not a finding to confirm: it stays unlabelled.
    assert!(events
        .iter()
        .filter(|e| e["kind"] == "outage")
        .all(|e| e["label"].is_null()));
    // After the rollback and the repair the monitor runs afresh (no trip counted yet) on the
    // model rolled back to; the labelled event is no longer open.
    let t0 = Instant::now();
    loop {
        let e = server.get_json(id);
        if e["trips"] == 0 && e["verdict"]["level"] == "normal" {
            assert_eq!(e["model_version"], 1);
            assert_eq!(e["open_events"], 0);
            break;
        }
        assert!(t0.elapsed() < PATIENCE, "no re-baseline: {e}");
        std::thread::sleep(Duration::from_millis(100));
    }
    assert_eq!(
        server.get_json(&format!("{id}/maintenance"))["visits"][0]["finding"],
        "confirmed"
    );
    // A fit from the stored raw telemetry of the healthy first 6 hours (few iterations: the
    // path is under test, not the fit): a `proposed` version with its changes.
    let req = br#"{"from": 86400, "to": 108000, "epochs": 30, "note": "re-identification"}"#;
    let (st, reply) = server.req("POST", &format!("{id}/fit"), Some(TOKEN), req);
    assert_eq!(st, 202, "{reply}");
    let t0 = Instant::now();
    let v3 = loop {
        let m = server.get_json(&format!("{id}/models"));
        let v3 = m["models"][2].clone();
        if v3["status"] != "fitting" {
            break v3;
        }
        assert!(t0.elapsed() < PATIENCE, "the fit did not end");
        std::thread::sleep(Duration::from_millis(200));
    };
    assert_eq!(v3["status"], "proposed", "{v3}");
    assert!(v3["changes"]["kd"].is_number(), "{v3}");
    eprintln!(
        "fit from history in {:.1} s: Kd {:+.2} %",
        t0.elapsed().as_secs_f64(),
        v3["changes"]["kd"].as_f64().unwrap_or(f64::NAN)
    );
    // SIGTERM: a final checkpoint and a clean exit, not held by a client that sent half a
    // request header (hyper waits out its header timeout, 30 s or more, for such a one; the
    // service gives requests under way 5 s).
    let mut half = std::net::TcpStream::connect(("127.0.0.1", server.port)).unwrap();
    std::io::Write::write_all(
        &mut half,
        b"GET /api/v1/health HTTP/1.1\r\nHost: 127.0.0.1\r\n",
    )
    .unwrap();
    std::thread::sleep(Duration::from_millis(200));
    let pid = server.child.id().to_string();
    let st = Command::new("kill").args(["-TERM", &pid]).status().unwrap();
    assert!(st.success());
    let t0 = Instant::now();
    loop {
        if let Some(code) = server.child.try_wait().unwrap() {
            assert!(code.success(), "{code:?}");
            break;
        }
        assert!(
            t0.elapsed() < Duration::from_secs(20),
            "no exit within 20 s of SIGTERM with half a request header open"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

#[test]
fn bad_input_is_refused_with_a_4xx_and_changes_nothing() {
    let dir = Dir::new("serve-bad");
    let server = Server::start(&dir.path("data"), "127.0.0.1:0", Some(TOKEN));
    let good = b"time,signal,value\n1,speed,0\n2,speed,0\n";
    let post = |path: &str, token: Option<&str>, body: &[u8]| server.req("POST", path, token, body);
    let cases: Vec<(&str, (u16, String))> = vec![
        (
            "no token",
            post("/api/v1/elevators/a/telemetry", None, good),
        ),
        (
            "wrong token",
            post("/api/v1/elevators/a/telemetry", Some("nope"), good),
        ),
        (
            "garbage",
            post(
                "/api/v1/elevators/a/telemetry",
                Some(TOKEN),
                b"\x00\xffgarbage,,\nmore\n",
            ),
        ),
        (
            "bad rows only",
            post(
                "/api/v1/elevators/a/telemetry",
                Some(TOKEN),
                b"time,signal,value\nx,speed,1\n",
            ),
        ),
        (
            "aligned layout",
            post(
                "/api/v1/elevators/a/telemetry",
                Some(TOKEN),
                b"time,speed,direction,voltage,load,door,floor\n1,0,0,0,0,0,1\n",
            ),
        ),
        (
            "huge body",
            post(
                "/api/v1/elevators/a/telemetry",
                Some(TOKEN),
                &vec![b'1'; 9 << 20],
            ),
        ),
        (
            "bad id",
            post("/api/v1/elevators/a.b/telemetry", Some(TOKEN), good),
        ),
        (
            "model of another version",
            post(
                "/api/v1/elevators/a/models",
                Some(TOKEN),
                br#"{"format_version": 99}"#,
            ),
        ),
        (
            "garbage model",
            post("/api/v1/elevators/a/models", Some(TOKEN), b"{not json"),
        ),
        (
            "unknown model version",
            post("/api/v1/elevators/a/models/3/activate", Some(TOKEN), b""),
        ),
        (
            "bad visit",
            post(
                "/api/v1/elevators/a/maintenance",
                Some(TOKEN),
                br#"{"time": 1}"#,
            ),
        ),
        (
            "unknown elevator",
            server.req("GET", "/api/v1/elevators/nobody", None, b""),
        ),
        (
            "unknown elevator's rows",
            server.req("GET", "/api/v1/elevators/nobody/risk", None, b""),
        ),
        (
            "bad query",
            server.req("GET", "/api/v1/events?level=panic", None, b""),
        ),
        (
            "a time that is no time",
            server.req("GET", "/api/v1/events?from=NaN", None, b""),
        ),
        (
            "a description that is not an object",
            server.req("PUT", "/api/v1/elevators/a", Some(TOKEN), b"[]"),
        ),
    ];
    for (what, (status, body)) in &cases {
        assert!((400..500).contains(status), "{what}: {status} {body}");
        let v: Value =
            serde_json::from_str(body).unwrap_or_else(|_| panic!("{what}: not JSON: {body}"));
        let msg = v["error"]
            .as_str()
            .unwrap_or_else(|| panic!("{what}: {body}"));
        assert!(!msg.contains('\n') && !msg.is_empty(), "{what}: {msg}");
        eprintln!("{what}: {status} {msg}");
    }
    // Nothing changed: no elevator, no batch.
    assert_eq!(
        server.get_json("/api/v1/elevators")["elevators"],
        serde_json::json!([])
    );
    assert_eq!(server.get_json("/healthz")["queue_depth"], 0);
    // A request with some bad rows keeps the good ones and says which line was bad.
    let (st, body) = post(
        "/api/v1/elevators/a/telemetry",
        Some(TOKEN),
        b"time,signal,value\n1,speed,0\nbad,speed,1\n2,speed,0\n",
    );
    assert_eq!(st, 200, "{body}");
    let v: Value = serde_json::from_str(&body).unwrap();
    assert_eq!(
        (
            v["accepted"].as_u64(),
            v["bad"].as_u64(),
            v["first_bad_line"].as_u64()
        ),
        (Some(2), Some(1), Some(3))
    );
    // JSON lines are the same rows.
    let (st, body) = request(
        server.port,
        "POST",
        "/api/v1/elevators/a/telemetry",
        Some(TOKEN),
        b"{\"time\":3,\"signal\":\"speed\",\"value\":0}\n{\"oops\":1}\n",
        "application/x-ndjson",
    );
    assert_eq!(st, 200, "{body}");
    assert!(body.contains("\"accepted\":1"), "{body}");
    let openapi = server.get_json("/api/v1/openapi.json");
    assert!(openapi["paths"]["/api/v1/elevators/{id}/telemetry"].is_object());

    // Without a token the service is read-only, and says so.
    let ro = Server::start(&dir.path("data-ro"), "127.0.0.1:0", None);
    let (st, body) = ro.req("POST", "/api/v1/elevators/a/telemetry", Some("x"), good);
    assert_eq!(st, 403, "{body}");
    assert!(body.contains("without a token"), "{body}");
}

/// `liftwatch_NAME{elevator="ID"} VALUE` lines of a metrics text, per elevator.
fn metric(text: &str, name: &str) -> std::collections::HashMap<String, f64> {
    let prefix = format!("{name}{{elevator=\"");
    text.lines()
        .filter_map(|l| {
            let rest = l.strip_prefix(&prefix)?;
            let (id, v) = rest.split_once("\"} ")?;
            Some((id.to_string(), v.parse().ok()?))
        })
        .collect()
}

/// The load test of issue 10: N elevators (`LIFTWATCH_LOAD_ELEVATORS`, 1000) at 1 Hz for
/// `LIFTWATCH_LOAD_SECONDS` (600) of wall time, each sending 10 s of a simulated raw log every
/// 10 s, on loopback, with a model each. Reports the ingest-to-visible latency (from a batch's
/// 200 to the checkpoint that stores its outputs, polled every 250 ms), the server's memory per
/// elevator, and checks that every elevator's rows were all applied. Run with a release server:
/// `LIFTWATCH_BIN=$PWD/target/release/liftwatch cargo test -p liftwatch-cli --test serve -- --ignored --nocapture load`.
#[test]
#[ignore = "10 minutes of wall time"]
fn load_many_elevators_at_one_hertz() {
    use liftwatch_serve::replay::{sender_for, SendError};
    let n = env_num("LIFTWATCH_LOAD_ELEVATORS", 1000.0) as usize;
    let seconds = env_num("LIFTWATCH_LOAD_SECONDS", 600.0);
    /// Seconds of log per batch, and of wall time between two batches of one elevator.
    const PERIOD_S: f64 = 10.0;
    /// Sender threads, each with its own keep-alive connection.
    const THREADS: usize = 16;
    let dir = Dir::new("serve-load");
    let healthy = dir.path("healthy");
    let model = healthy_day_and_model(&dir, &healthy);
    let text = std::fs::read_to_string(healthy.join("raw.csv")).unwrap();
    let batches = common::batches(&text, PERIOD_S);
    let per_elevator = ((seconds / PERIOD_S) as usize).min(batches.len());
    let batches = std::sync::Arc::new(batches[..per_elevator].to_vec());
    let rows_each: usize = batches.iter().map(|b| b.lines().count() - 1).sum();

    let server = Server::start_with(
        &dir.path("data"),
        "127.0.0.1:0",
        Some(TOKEN),
        &[
            "--config",
            dir.file("load.toml", b"max_elevators = 5000\n")
                .to_str()
                .unwrap(),
        ],
    );
    let rss = common::rss_kb;
    let rss_before = rss(server.child.id());
    let body = std::fs::read(&model).unwrap();
    for i in 0..n {
        let (st, reply) = server.req(
            "POST",
            &format!("/api/v1/elevators/e{i}/models"),
            Some(TOKEN),
            &body,
        );
        assert_eq!(st, 201, "{reply}");
    }
    eprintln!("{n} elevators, {per_elevator} batches of {PERIOD_S} s each, {rows_each} rows each");

    let url = server.url();
    let t0 = Instant::now();
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    // The probe: applied seq per elevator, every 250 ms, with the time it was seen.
    let probe = {
        let (stop, port) = (stop.clone(), server.port);
        std::thread::spawn(move || {
            let mut seen: Vec<(f64, std::collections::HashMap<String, f64>)> = Vec::new();
            while !stop.load(std::sync::atomic::Ordering::Relaxed) {
                let (_, text) = request(port, "GET", "/metrics", None, b"", "text/plain");
                seen.push((
                    t0.elapsed().as_secs_f64(),
                    metric(&text, "liftwatch_applied_seq"),
                ));
                std::thread::sleep(Duration::from_millis(250));
            }
            seen
        })
    };
    let senders: Vec<_> = (0..THREADS)
        .map(|k| {
            let (batches, url) = (batches.clone(), url.clone());
            std::thread::spawn(move || {
                let mut sender = sender_for(&url, Some(TOKEN.to_string())).unwrap();
                // (elevator, seq, time of the 200)
                let mut done: Vec<(usize, i64, f64)> = Vec::new();
                let mine: Vec<usize> = (k..n).step_by(THREADS).collect();
                let plan = common::plan(mine.iter().copied(), n, batches.len(), PERIOD_S);
                let mut late = 0.0f64;
                for (due, i, b) in plan {
                    late = late.max(common::wait_until(t0, due));
                    let id = format!("e{i}");
                    let reply = loop {
                        match sender.send(&id, batches[b].as_bytes()) {
                            Ok(r) => break r,
                            Err(SendError::Retry(e)) => {
                                eprintln!("retry {id}: {e}");
                                std::thread::sleep(Duration::from_millis(100));
                            }
                            Err(SendError::Fatal(e)) => panic!("{id}: {e}"),
                        }
                    };
                    assert_eq!(reply.bad, 0);
                    done.push((i, reply.seq, t0.elapsed().as_secs_f64()));
                }
                (done, late)
            })
        })
        .collect();
    let mut done = Vec::new();
    let mut worst_late = 0.0f64;
    for h in senders {
        let (d, late) = h.join().unwrap();
        done.extend(d);
        worst_late = worst_late.max(late);
    }
    let sent_s = t0.elapsed().as_secs_f64();
    settle(&server);
    std::thread::sleep(Duration::from_millis(500));
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    let seen = probe.join().unwrap();
    let rss_after = rss(server.child.id());

    // Latency: from a batch's 200 to the first probe that saw its seq applied.
    let mut lat: Vec<f64> = done
        .iter()
        .filter_map(|(i, seq, t_ok)| {
            let id = format!("e{i}");
            seen.iter()
                .find(|(t, m)| *t >= *t_ok && m.get(&id).is_some_and(|&a| a >= *seq as f64))
                .map(|(t, _)| t - t_ok)
        })
        .collect();
    assert_eq!(lat.len(), done.len(), "every batch was seen applied");
    lat.sort_by(f64::total_cmp);
    let q = |p: f64| lat[((lat.len() - 1) as f64 * p).round() as usize];
    let metrics = server.req("GET", "/metrics", None, b"").1;
    let ingested = metric(&metrics, "liftwatch_rows_ingested_total");
    let samples = metric(&metrics, "liftwatch_samples_total");
    let late = metric(&metrics, "liftwatch_rows_late_total");
    for i in 0..n {
        let id = format!("e{i}");
        assert_eq!(
            ingested.get(&id).copied(),
            Some(rows_each as f64),
            "{id}: rows stored"
        );
        assert_eq!(
            samples.get(&id),
            samples.get("e0"),
            "{id}: the same samples as e0"
        );
        assert_eq!(late.get(&id).copied(), Some(0.0), "{id}: late rows");
    }
    eprintln!(
        "{} batches ({:.0}/s) in {sent_s:.0} s, senders at most {worst_late:.2} s behind; \
         ingest-to-visible latency median {:.2} s, p99 {:.2} s, max {:.2} s; \
         server memory {:.0} MB ({:.1} KB per elevator); {} samples per elevator, none lost",
        done.len(),
        done.len() as f64 / sent_s,
        q(0.5),
        q(0.99),
        lat[lat.len() - 1],
        rss_after / 1024.0,
        (rss_after - rss_before) / n as f64,
        samples.get("e0").copied().unwrap_or(0.0),
    );
}
