//! `liftwatch serve --nats`, the fleet mode, against real nats-server processes on loopback:
//! a 3-node JetStream cluster and 3 workers (the real binary) take a bounded load of many
//! simulated elevators; one worker and one server are `kill -9`ed mid-stream, and a worker
//! joins while that server is down; every elevator's risk rows equal a batch `liftwatch
//! monitor --rows trip` over the same data and every reading was applied exactly once. A
//! second case: a gateway publishing over MQTT into the server's MQTT listener reaches a
//! worker. Skipped, saying so, where nats-server is not
//! installed (`.ci/run` installs Debian's). Every process is killed when its case ends.

mod common;

use std::collections::HashMap;
use std::path::Path;
use std::process::{Command, Stdio};
use std::sync::Arc;
use std::time::{Duration, Instant};

use common::serve::{csv_rows, healthy_day, run, Server, BIN, PATIENCE, TOKEN};
use common::{batches, env_num, free_port, on_fresh_ports, rss_kb, Dir, Killed};
use liftwatch_serve::fleet::bus::server_mappings;
use liftwatch_serve::fleet::gateway::Gateway;
use serde_json::Value;

/// Debian's nats-server.
const NATS_SERVER: &str = "/usr/sbin/nats-server";

/// How long a nats-server may take to say it is ready (and, clustered, to elect the JetStream
/// metadata leader): well under a second here, so this only bounds a broken start.
const STARTUP: Duration = Duration::from_secs(20);

/// Running nats-servers: the processes (killed on drop), their client URLs and the MQTT port
/// of the first when one was asked for.
struct Cluster {
    servers: Vec<Killed>,
    urls: Vec<String>,
    mqtt: u16,
}

/// Starts `n` nats-servers with JetStream, clustered when `n > 1`, the partition mapping of
/// `partitions`, and an MQTT listener on the first when `mqtt`; returns once every server
/// has bound its listeners and, clustered, a metadata leader is elected. A start that loses a
/// port is retried on new ports ([`on_fresh_ports`]): one server gone leaves a cluster of 3
/// with 2 JetStream peers, too few for 3 replicas; the last failure's server log ends the case.
fn cluster(dir: &Dir, n: usize, partitions: u32, mqtt: bool) -> Cluster {
    on_fresh_ports("the nats-servers", |attempt| {
        start(dir, attempt, n, partitions, mqtt)
    })
}

/// One try of [`cluster`], its files named by `attempt`.
fn start(
    dir: &Dir,
    attempt: usize,
    n: usize,
    partitions: u32,
    mqtt: bool,
) -> Result<Cluster, String> {
    let client: Vec<u16> = (0..n).map(|_| free_port()).collect();
    let route: Vec<u16> = (0..n).map(|_| free_port()).collect();
    let mqtt = if mqtt { free_port() } else { 0 };
    let routes: Vec<String> = route
        .iter()
        .map(|p| format!("nats-route://127.0.0.1:{p}"))
        .collect();
    let mut servers = Vec::new();
    let mut logs = Vec::new();
    for i in 0..n {
        let mut conf = format!(
            "server_name: n{i}\nlisten: 127.0.0.1:{}\njetstream {{ store_dir: \"{}\" }}\n{}",
            client[i],
            dir.path(&format!("js{i}-{attempt}")).display(),
            server_mappings(partitions)
        );
        if n > 1 {
            conf.push_str(&format!(
                "cluster {{ name: lw, listen: 127.0.0.1:{}, routes: [{}] }}\n",
                route[i],
                routes.join(", ")
            ));
        }
        if i == 0 && mqtt != 0 {
            conf.push_str(&format!("mqtt {{ listen: 127.0.0.1:{mqtt} }}\n"));
        }
        let path = dir.file(&format!("n{i}-{attempt}.conf"), conf.as_bytes());
        let log = dir.path(&format!("n{i}-{attempt}.log"));
        let child = Command::new(NATS_SERVER)
            .args(["-c", path.to_str().unwrap()])
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(&log).unwrap())
            .spawn()
            .expect("nats-server starts");
        servers.push(Killed(child));
        logs.push(log);
    }
    let t0 = Instant::now();
    loop {
        let text: Vec<String> = logs
            .iter()
            .map(|l| std::fs::read_to_string(l).unwrap_or_default())
            .collect();
        for (i, s) in servers.iter_mut().enumerate() {
            if let Ok(Some(status)) = s.0.try_wait() {
                let last = text[i]
                    .lines()
                    .rev()
                    .find(|l| l.contains("[FTL]") || l.contains("[ERR]"));
                return Err(format!(
                    "n{i} exited ({status}): {}",
                    last.unwrap_or("no error logged")
                ));
            }
        }
        // Every listener bound (a route port is bound after "Server is ready"), and a leader.
        let ready = text.iter().enumerate().all(|(i, t)| {
            t.contains("Server is ready")
                && (n == 1 || t.contains("Listening for route connections"))
                && (i > 0 || mqtt == 0 || t.contains("Listening for MQTT clients"))
        });
        let led = n == 1 || text.iter().any(|t| t.contains("new metadata leader"));
        if ready && led {
            let urls = client
                .iter()
                .map(|p| format!("nats://127.0.0.1:{p}"))
                .collect();
            return Ok(Cluster {
                servers,
                urls,
                mqtt,
            });
        }
        if t0.elapsed() > STARTUP {
            return Err(format!(
                "not ready after {STARTUP:?} (logs in {})",
                dir.0.display()
            ));
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// A gateway, once the cluster has a JetStream leader and the streams exist.
fn gateway(urls: &str, replicas: usize) -> Gateway {
    let t0 = Instant::now();
    loop {
        match Gateway::connect(urls, replicas) {
            Ok(g) => return g,
            Err(e) => {
                assert!(t0.elapsed() < PATIENCE, "the cluster did not come up: {e}");
                std::thread::sleep(Duration::from_millis(500));
            }
        }
    }
}

/// `f` on a gateway, with a new connection after each failure: this blocking client does not
/// always find its way back by itself after the server it was on is killed (README, *Fleet*).
fn retried<T>(urls: &str, f: impl Fn(&Gateway) -> Result<T, String>) -> T {
    let t0 = Instant::now();
    loop {
        match f(&gateway(urls, 3)) {
            Ok(v) => return v,
            Err(e) => {
                assert!(t0.elapsed() < PATIENCE, "{e}");
                eprintln!("again: {e}");
            }
        }
    }
}

/// The trip CSV lines of a batch `liftwatch monitor --rows trip` over `body`.
fn batch_rows(dir: &Dir, model: &Path, body: &str) -> Vec<Value> {
    let input = dir.file("streamed.csv", body.as_bytes());
    let out = dir.path("want.csv");
    let s = |p: &Path| p.to_str().unwrap().to_string();
    run(&[
        "monitor",
        "--model",
        &s(model),
        "--input",
        &s(&input),
        "--out",
        &s(&out),
        "--rows",
        "trip",
        "-q",
    ]);
    csv_rows(&out)
}

/// The risk rows per elevator read from the outputs stream, as the CSV's objects (read with
/// `header`, the batch run's), each with the telemetry seq it came from and when it was stored.
fn risk_rows(
    dir: &Dir,
    header: &str,
    outputs: &[liftwatch_serve::fleet::bus::Published],
) -> HashMap<String, Vec<(Value, u64, f64)>> {
    let mut per: HashMap<String, Vec<(String, u64, f64)>> = HashMap::new();
    for o in outputs {
        let Some(id) = o.subject.strip_prefix("liftwatch.risk.") else {
            continue;
        };
        let seq = o
            .msg_id
            .split(':')
            .nth(2)
            .and_then(|s| s.parse().ok())
            .unwrap_or(0);
        per.entry(id.to_string())
            .or_default()
            .push((o.line.clone(), seq, o.stored));
    }
    per.into_iter()
        .map(|(id, lines)| {
            let text: String = std::iter::once(format!("{header}\n"))
                .chain(lines.iter().map(|l| format!("{}\n", l.0)))
                .collect();
            let rows = csv_rows(&dir.file("rows.csv", text.as_bytes()));
            let v = rows
                .into_iter()
                .zip(lines)
                .map(|(r, (_, seq, t))| (r, seq, t))
                .collect();
            (id, v)
        })
        .collect()
}

/// The header line of the batch run's trip CSV.
fn header(dir: &Dir) -> String {
    let text = std::fs::read_to_string(dir.path("want.csv")).unwrap();
    text.lines().next().unwrap().to_string()
}

fn health(s: &Server) -> Value {
    s.get_json("/healthz")
}

/// The scale-out run: `LIFTWATCH_NATS_ELEVATORS` (100 in CI) elevators, each sending 10 s of
/// log per message, `LIFTWATCH_NATS_SPEEDUP` (20) times real time, for `LIFTWATCH_NATS_SECONDS`
/// (60) of wall time, through 3 servers and 3 workers; worker 0 is killed at 40 % of the run and
/// server 2 at 60 %, when a fourth worker starts.
fn fleet_run(default_n: f64, default_s: f64, default_speedup: f64) {
    if !Path::new(NATS_SERVER).exists() {
        eprintln!("SKIPPED: {NATS_SERVER} is not installed (apt-get install nats-server)");
        return;
    }
    let n = env_num("LIFTWATCH_NATS_ELEVATORS", default_n) as usize;
    let seconds = env_num("LIFTWATCH_NATS_SECONDS", default_s);
    let speedup = env_num("LIFTWATCH_NATS_SPEEDUP", default_speedup);
    const PERIOD_S: f64 = 10.0;
    const PARTITIONS: u32 = 12;
    const THREADS: usize = 4;
    let dir = Dir::new("nats-fleet");
    let (raw, model) = healthy_day(&dir, "5");
    let all = batches(&std::fs::read_to_string(&raw).unwrap(), PERIOD_S);
    let per_elevator = ((seconds * speedup / PERIOD_S) as usize).min(all.len());
    let sent: Vec<String> = all[..per_elevator].to_vec();
    let streamed: String = std::iter::once("time,signal,value\n".to_string())
        .chain(
            sent.iter()
                .map(|b| b.split_once('\n').unwrap().1.to_string()),
        )
        .collect();
    let want = batch_rows(&dir, &model, &streamed);
    let rows_each: u64 = sent.iter().map(|b| b.lines().count() as u64 - 1).sum();

    let Cluster {
        mut servers, urls, ..
    } = cluster(&dir, 3, PARTITIONS, false);
    let urls = urls.join(",");
    let gw = gateway(&urls, 3);
    let body = std::fs::read(&model).unwrap();
    for i in 0..n {
        gw.put_model(&format!("e{i}"), &body).unwrap();
    }
    let cfg = dir.file(
        "fleet.toml",
        format!("nats_partitions = {PARTITIONS}\nnats_replicas = 3\nnats_lease_s = 3.0\ncheckpoint_every_s = 1.0\n").as_bytes(),
    );
    let args = [
        "--nats",
        &urls,
        "--listen",
        "127.0.0.1:0",
        "--config",
        cfg.to_str().unwrap(),
    ];
    let mut workers: Vec<Server> = (0..3).map(|_| Server::spawn(&args, Some(TOKEN))).collect();
    // Every partition held before the load starts.
    let t0 = Instant::now();
    loop {
        let held: usize = workers
            .iter()
            .map(|w| health(w)["partitions"].as_array().unwrap().len())
            .sum();
        if held == PARTITIONS as usize {
            break;
        }
        assert!(
            t0.elapsed() < PATIENCE,
            "the partitions were not shared out"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
    let rss0: Vec<f64> = workers.iter().map(|w| rss_kb(w.child.id())).collect();
    eprintln!("{n} elevators, {per_elevator} messages of {PERIOD_S} s each ({rows_each} rows), {speedup}× real time, partitions shared in {:.1} s", t0.elapsed().as_secs_f64());

    let sent = Arc::new(sent);
    let t0 = Instant::now();
    let wall = per_elevator as f64 * PERIOD_S / speedup;
    let senders: Vec<_> = (0..THREADS)
        .map(|k| {
            let (sent, urls) = (sent.clone(), urls.clone());
            std::thread::spawn(move || {
                let mut gw = gateway(&urls, 3);
                let plan = common::plan((k..n).step_by(THREADS), n, sent.len(), PERIOD_S / speedup);
                let mut acks: Vec<(String, u64, f64)> = Vec::new();
                let mut late = 0.0f64;
                for (due, i, b) in plan {
                    late = late.max(common::wait_until(t0, due));
                    let id = format!("e{i}");
                    let seq = loop {
                        match gw.publish(&id, sent[b].as_bytes()) {
                            Ok(s) => break s,
                            Err(e) => {
                                // As a gateway does: a new connection, the same message again
                                // (its id makes the stream store it once).
                                eprintln!("retry {id}: {e}");
                                std::thread::sleep(Duration::from_millis(200));
                                gw = gateway(&urls, 3);
                            }
                        }
                    };
                    acks.push((id, seq, unix_now()));
                }
                (acks, late)
            })
        })
        .collect();
    // The faults: worker 0 at 40 %, server 2 at 60 % of the run; the takeover is timed until
    // the survivors hold every partition again.
    std::thread::sleep(Duration::from_secs_f64(wall * 0.4));
    workers[0].kill9();
    let t_kill = Instant::now();
    let survivors = &workers[1..];
    let takeover = loop {
        let held: usize = survivors
            .iter()
            .map(|w| health(w)["partitions"].as_array().unwrap().len())
            .sum();
        if held == PARTITIONS as usize {
            break t_kill.elapsed().as_secs_f64();
        }
        assert!(
            t_kill.elapsed() < PATIENCE,
            "the partitions of the dead worker were not taken over"
        );
        std::thread::sleep(Duration::from_millis(50));
    };
    let left = wall * 0.6 - t0.elapsed().as_secs_f64();
    if left > 0.0 {
        std::thread::sleep(Duration::from_secs_f64(left));
    }
    let killed_server = servers.remove(2);
    drop(killed_server); // SIGKILL

    // A worker that starts while the server is down starts all the same and takes a share.
    let joined = Server::spawn(&args, Some(TOKEN));
    let t_join = Instant::now();
    let mut acks = Vec::new();
    let mut worst_late = 0.0f64;
    for h in senders {
        let (a, late) = h.join().unwrap();
        acks.extend(a);
        worst_late = worst_late.max(late);
    }
    let sent_s = t0.elapsed().as_secs_f64();
    let last_seq: HashMap<String, u64> = acks.iter().fold(HashMap::new(), |mut m, (id, s, _)| {
        let e = m.entry(id.clone()).or_insert(0);
        *e = (*e).max(*s);
        m
    });
    // Caught up: every elevator's checkpoint covers its last message.
    let t1 = Instant::now();
    let progress = loop {
        let p = retried(&urls, |g| g.progress());
        if last_seq
            .iter()
            .all(|(id, s)| p.get(id).is_some_and(|x| x.0 >= *s))
        {
            break p;
        }
        if t1.elapsed() > PATIENCE * 2 {
            let behind: Vec<String> = last_seq
                .iter()
                .filter(|(id, s)| !p.get(*id).is_some_and(|x| x.0 >= **s))
                .map(|(id, s)| format!("{id} {:?}<{s}", p.get(id)))
                .take(10)
                .collect();
            let h: Vec<Value> = survivors.iter().chain([&joined]).map(health).collect();
            panic!("the workers did not catch up: {behind:?}; {h:?}");
        }
        std::thread::sleep(Duration::from_millis(250));
    };
    let caught_up = t1.elapsed().as_secs_f64();
    let joined_share = loop {
        let held = health(&joined)["partitions"].as_array().unwrap().len();
        if held > 0 {
            break (held, t_join.elapsed().as_secs_f64());
        }
        assert!(
            t_join.elapsed() < PATIENCE * 2,
            "the worker started during the outage took no partition"
        );
        std::thread::sleep(Duration::from_millis(100));
    };
    let rss: f64 =
        survivors.iter().map(|w| rss_kb(w.child.id())).sum::<f64>() - rss0[1..].iter().sum::<f64>();
    let outputs = retried(&urls, |g| g.outputs());
    let got = risk_rows(&dir, &header(&dir), &outputs);
    let ack_time: HashMap<u64, f64> = acks.iter().map(|(_, s, t)| (*s, *t)).collect();
    let mut lat = Vec::new();
    let mut complete = 0;
    for i in 0..n {
        let id = format!("e{i}");
        assert_eq!(
            progress[&id].1, rows_each,
            "{id}: readings applied exactly once"
        );
        let rows = got.get(&id).cloned().unwrap_or_default();
        // The aligner holds the last reorder window back: at most a few trips at the end.
        assert!(
            rows.len() <= want.len() && rows.len() + 3 >= want.len(),
            "{id}: {} rows of {}",
            rows.len(),
            want.len()
        );
        for (k, (r, seq, stored)) in rows.iter().enumerate() {
            assert_eq!(r, &want[k], "{id}: trip row {k}");
            if let Some(t) = ack_time.get(seq) {
                lat.push(stored - t);
            }
        }
        complete += usize::from(rows.len() == want.len());
    }
    lat.sort_by(f64::total_cmp);
    let q = |p: f64| {
        lat.get(((lat.len().max(1) - 1) as f64 * p).round() as usize)
            .copied()
            .unwrap_or(f64::NAN)
    };
    eprintln!(
        "fleet: {n} elevators × {per_elevator} messages ({:.0}/s) in {sent_s:.0} s, senders at most {worst_late:.2} s behind, \
         caught up {caught_up:.1} s later; worker killed: its partitions taken over in {takeover:.2} s; server killed at 60 %, \
         a worker started then held {} partitions {:.1} s later; \
         {} risk rows, each equal to the batch run's ({} of {n} elevators with every batch row); \
         ingest-to-row latency median {:.3} s, p99 {:.3} s; worker memory {:.1} KB per elevator; \
         readings applied exactly once ({rows_each} each)",
        acks.len() as f64 / sent_s,
        joined_share.0,
        joined_share.1,
        got.values().map(Vec::len).sum::<usize>(),
        complete,
        q(0.5),
        q(0.99),
        rss / n as f64,
    );
    assert!(!lat.is_empty(), "rows came out");
}

fn unix_now() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs_f64())
        .unwrap_or(0.0)
}

#[test]
fn a_fleet_with_a_worker_and_a_server_killed_gives_the_rows_of_a_batch_run() {
    fleet_run(100.0, 60.0, 20.0);
}

/// The size: 10,000 elevators at 1 Hz (one 10-s message each every 10 s) for 5
/// minutes; knobs as above. Run with a release binary:
/// `LIFTWATCH_BIN=$PWD/target/release/liftwatch cargo test --release -p liftwatch-cli --test nats -- --ignored --nocapture`.
#[test]
#[ignore = "minutes of wall time and most of a machine"]
fn fleet_of_ten_thousand_elevators() {
    fleet_run(10_000.0, 300.0, 1.0);
}

#[test]
fn a_gateway_over_mqtt_reaches_a_worker() {
    if !Path::new(NATS_SERVER).exists() {
        eprintln!("SKIPPED: {NATS_SERVER} is not installed (apt-get install nats-server)");
        return;
    }
    let dir = Dir::new("nats-mqtt");
    let (raw, model) = healthy_day(&dir, "6");
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let Cluster {
        servers: _servers,
        urls,
        mqtt,
    } = cluster(&dir, 1, 4, true);
    let gw = gateway(&urls[0], 1);
    let cfg = dir.file(
        "fleet.toml",
        b"nats_partitions = 4\ncheckpoint_every_s = 0.5\n",
    );
    let worker = Server::spawn(
        &[
            "--nats",
            &urls[0],
            "--listen",
            "127.0.0.1:0",
            "--config",
            cfg.to_str().unwrap(),
        ],
        Some(TOKEN),
    );
    worker.upload_model("lift-m", &std::fs::read(&model).unwrap());
    let (st, _) = worker.req("POST", "/api/v1/elevators/lift-m/models", None, b"{}");
    assert_eq!(st, 401, "a write without the token is refused");
    // Three hours of the healthy day through MQTT, in 60-s batches (QoS 1).
    let text = std::fs::read_to_string(&raw).unwrap();
    let part: String = text
        .lines()
        .take(1 + 3 * 3600 * 6)
        .map(|l| format!("{l}\n"))
        .collect();
    let part_file = dir.file("part.csv", part.as_bytes());
    let want = batch_rows(&dir, &model, &part);
    assert!(want.len() > 5, "the hours have trips");
    let sent = Command::new(BIN)
        .args(["replay", "--input", &s(&part_file), "--id", "lift-m"])
        .args([
            "--to",
            &format!("mqtt://127.0.0.1:{mqtt}"),
            "--speed",
            "0",
            "--batch-s",
            "60",
            "-q",
        ])
        .output()
        .unwrap();
    assert!(
        sent.status.success(),
        "{}",
        String::from_utf8_lossy(&sent.stderr)
    );
    let rows = part.lines().count() as u64 - 1;
    let t0 = Instant::now();
    loop {
        let p = gw.progress().unwrap();
        if p.get("lift-m").is_some_and(|x| x.1 == rows) {
            break;
        }
        assert!(
            t0.elapsed() < PATIENCE,
            "the worker did not apply the MQTT telemetry: {p:?}"
        );
        std::thread::sleep(Duration::from_millis(200));
    }
    let got = risk_rows(&dir, &header(&dir), &gw.outputs().unwrap())
        .remove("lift-m")
        .unwrap_or_default();
    assert!(
        got.len() <= want.len() && got.len() + 3 >= want.len(),
        "{} rows of {}",
        got.len(),
        want.len()
    );
    for (k, (r, _, _)) in got.iter().enumerate() {
        assert_eq!(r, &want[k], "trip row {k}");
    }
    let h = health(&worker);
    assert_eq!(h["partitions"].as_array().unwrap().len(), 4, "{h}");
    eprintln!("mqtt: {} rows through the NATS server's MQTT listener, {} risk rows equal to the batch run's", rows, got.len());
}

#[test]
fn bad_nats_settings_are_refused_with_one_line() {
    for (args, want) in [
        (
            &["--nats", "http://127.0.0.1:4222"][..],
            "is not nats://host:port",
        ),
        (&["--nats", "nats://127.0.0.1"][..], "has no :port"),
        (
            &[
                "--nats",
                "nats://127.0.0.1:4222",
                "--mqtt",
                "mqtt://127.0.0.1:1883",
            ][..],
            "exclude each other",
        ),
        // Nobody listens on port 1 of loopback.
        (
            &["--nats", "nats://127.0.0.1:1", "--listen", "127.0.0.1:0"][..],
            "nats nats://127.0.0.1:1",
        ),
    ] {
        let out = Command::new(BIN).arg("serve").args(args).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?}");
        assert_eq!(err.lines().count(), 1, "{args:?}: {err}");
        assert!(
            err.contains(want) && !err.contains("panicked"),
            "{args:?}: {err}"
        );
    }
}
