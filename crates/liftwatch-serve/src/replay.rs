//! `liftwatch replay`: sends a raw `time,signal,value` log to a server in batches of
//! `batch_s` seconds of log, at `speed`× real time (0: as fast as accepted).
//!
//! ```text
//! rows (file order) ─ cut where the time passes batch start + batch_s ─ Sender::send(batch)
//!                     failed send → same batch again after a pause (idempotent at the server:
//!                     a re-sent reading is pending already, or older than its window)
//! ```
//!
//! The sending side is the [`Sender`] trait: [`HttpSender`] speaks HTTP/1.1 over a plain TCP
//! connection (a few dozen lines: no TLS, which a reverse proxy or a tunnel adds; one
//! keep-alive connection, reopened after an error); [`MqttSender`] publishes each batch on
//! `liftwatch/{id}/telemetry` at QoS 1 and waits for the broker's acknowledgement, as a gateway
//! does (the token is then the broker's login, in the URL).

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::Path;
use std::time::{Duration, Instant};

/// Pause before a failed batch is sent again.
const RETRY_PAUSE: Duration = Duration::from_millis(500);

/// How long replay keeps sending a failed batch again, from its first failure: a server
/// being away for a restart is ridden out; one that stays away ends the run within about a
/// minute and [`REQUEST_TIMEOUT`].
const RETRY_WINDOW: Duration = Duration::from_secs(60);

/// How long one request may take before it counts as failed: a batch of ten seconds of log
/// is accepted in milliseconds, so a server silent this long is stuck, not busy.
const REQUEST_TIMEOUT: Duration = Duration::from_secs(15);

/// Largest response read (bytes): the server's answers are small JSON objects.
const MAX_RESPONSE_BYTES: usize = 1 << 20;

/// Where a batch goes: one implementation per transport.
pub trait Sender {
    /// Sends one batch of raw CSV rows (with the header) for elevator `id`.
    ///
    /// # Errors
    /// [`SendError::Retry`] for what another attempt may cure (connection refused or broken,
    /// a 5xx or 429), [`SendError::Fatal`] for what it cannot (a 4xx: bad token, bad data).
    fn send(&mut self, id: &str, csv: &[u8]) -> Result<SendReply, SendError>;
}

/// The server's counts for one batch.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SendReply {
    /// Rows accepted.
    pub accepted: u64,
    /// Rows refused as bad.
    pub bad: u64,
    /// The server's seq of the stored batch (0 when it does not say).
    pub seq: i64,
}

/// Why a send failed.
#[derive(Debug)]
pub enum SendError {
    /// Worth another attempt.
    Retry(String),
    /// Not worth one.
    Fatal(String),
}

/// `--to` as a sender.
///
/// # Errors
/// One line for a URL of a scheme this build does not speak.
pub fn sender_for(url: &str, token: Option<String>) -> Result<Box<dyn Sender>, String> {
    if let Some(rest) = url.strip_prefix("http://") {
        let (host, base) = match rest.find('/') {
            Some(i) => (&rest[..i], rest[i..].trim_end_matches('/')),
            None => (rest, ""),
        };
        if host.is_empty() {
            return Err(format!("--to `{url}`: no host"));
        }
        return Ok(Box::new(HttpSender {
            host: host.to_string(),
            base: base.to_string(),
            token,
            conn: None,
        }));
    }
    if url.starts_with("https://") {
        return Err(format!("--to `{url}`: https is not spoken by replay; send to the server's plain address, or through a local TLS tunnel"));
    }
    if url.starts_with("mqtt://") {
        let broker = crate::config::Broker::parse(url).map_err(|e| format!("--to {e}"))?;
        return Ok(Box::new(MqttSender::new(&broker)));
    }
    Err(format!(
        "--to `{url}`: expected http://HOST:PORT or mqtt://[user:password@]HOST:PORT"
    ))
}

/// HTTP/1.1 `POST {base}/api/v1/elevators/{id}/telemetry` on one keep-alive connection.
pub struct HttpSender {
    host: String,
    base: String,
    token: Option<String>,
    conn: Option<BufReader<TcpStream>>,
}

impl HttpSender {
    fn connect(&mut self) -> Result<&mut BufReader<TcpStream>, SendError> {
        if self.conn.is_none() {
            let s = TcpStream::connect(&self.host)
                .map_err(|e| SendError::Retry(format!("{}: {e}", self.host)))?;
            s.set_read_timeout(Some(REQUEST_TIMEOUT)).ok();
            s.set_write_timeout(Some(REQUEST_TIMEOUT)).ok();
            s.set_nodelay(true).ok();
            self.conn = Some(BufReader::new(s));
        }
        Ok(self.conn.as_mut().expect("set above"))
    }

    fn exchange(&mut self, id: &str, csv: &[u8]) -> Result<(u16, String), SendError> {
        let mut head = format!(
            "POST {}/api/v1/elevators/{id}/telemetry HTTP/1.1\r\nHost: {}\r\nContent-Type: text/csv\r\nContent-Length: {}\r\n",
            self.base,
            self.host,
            csv.len()
        );
        if let Some(t) = &self.token {
            head.push_str(&format!("Authorization: Bearer {t}\r\n"));
        }
        head.push_str("\r\n");
        let io = |e: std::io::Error| {
            SendError::Retry(match e.kind() {
                // A read or write timeout shows as either kind, depending on the platform.
                std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut => {
                    format!("no answer within {} s", REQUEST_TIMEOUT.as_secs())
                }
                _ => format!("connection: {e}"),
            })
        };
        let r = self.connect()?;
        let s = r.get_mut();
        s.write_all(head.as_bytes()).map_err(io)?;
        s.write_all(csv).map_err(io)?;
        let mut status_line = String::new();
        r.read_line(&mut status_line).map_err(io)?;
        let status: u16 = status_line
            .split_whitespace()
            .nth(1)
            .and_then(|c| c.parse().ok())
            .ok_or_else(|| {
                SendError::Retry(format!("not an HTTP answer: `{}`", status_line.trim()))
            })?;
        let (mut len, mut close) = (None, false);
        loop {
            let mut line = String::new();
            if r.read_line(&mut line).map_err(io)? == 0 {
                return Err(SendError::Retry("connection closed in the headers".into()));
            }
            let line = line.trim_end();
            if line.is_empty() {
                break;
            }
            if let Some((k, v)) = line.split_once(':') {
                let k = k.trim().to_ascii_lowercase();
                if k == "content-length" {
                    len = v.trim().parse::<usize>().ok();
                } else if k == "connection" && v.trim().eq_ignore_ascii_case("close") {
                    close = true;
                } else if k == "transfer-encoding" {
                    return Err(SendError::Fatal(
                        "chunked answers are not read by replay".into(),
                    ));
                }
            }
        }
        let len = len.unwrap_or(0).min(MAX_RESPONSE_BYTES);
        let mut body = vec![0u8; len];
        r.read_exact(&mut body).map_err(io)?;
        if close {
            self.conn = None;
        }
        Ok((status, String::from_utf8_lossy(&body).into_owned()))
    }
}

impl Sender for HttpSender {
    fn send(&mut self, id: &str, csv: &[u8]) -> Result<SendReply, SendError> {
        let (status, body) = match self.exchange(id, csv) {
            Ok(x) => x,
            Err(e) => {
                self.conn = None;
                return Err(e);
            }
        };
        let v: serde_json::Value = serde_json::from_str(&body).unwrap_or_default();
        // The server's own words on one line: its JSON `error`, else its body, else a note.
        let words: Vec<&str> = v["error"]
            .as_str()
            .unwrap_or(&body)
            .split_whitespace()
            .collect();
        let said = if words.is_empty() {
            "(no body)".to_string()
        } else {
            words.join(" ")
        };
        match status {
            200..=299 => Ok(SendReply {
                accepted: v["accepted"].as_u64().unwrap_or(0),
                bad: v["bad"].as_u64().unwrap_or(0),
                seq: v["seq"].as_i64().unwrap_or(0),
            }),
            429 | 500..=599 => {
                self.conn = None;
                Err(SendError::Retry(format!("HTTP {status}: {said}")))
            }
            _ => Err(SendError::Fatal(format!("HTTP {status}: {said}"))),
        }
    }
}

/// How to replay.
#[derive(Clone, Debug)]
pub struct ReplayOptions {
    /// Seconds of log per batch.
    pub batch_s: f64,
    /// Multiple of real time; 0: as fast as accepted.
    pub speed: f64,
    /// Progress lines on stderr (a terminal).
    pub progress: bool,
}

/// What a replay did.
#[derive(Clone, Copy, Debug, Default)]
pub struct ReplaySummary {
    /// Batches sent.
    pub batches: u64,
    /// Rows read from the log (header excluded).
    pub rows: u64,
    /// Rows the server accepted.
    pub accepted: u64,
    /// Rows it refused as bad.
    pub bad: u64,
    /// Attempts that failed and were retried.
    pub retries: u64,
    /// Wall time (s).
    pub seconds: f64,
}

/// Reads `input` (`.gz` and `-` as everywhere) and sends it batch by batch.
///
/// # Errors
/// One line: the input, a batch the server refused, a server away for too long.
pub fn replay(
    input: &Path,
    id: &str,
    sender: &mut dyn Sender,
    opts: &ReplayOptions,
) -> Result<ReplaySummary, String> {
    if !crate::config::valid_id(id) {
        return Err(format!(
            "--id `{}` is not [A-Za-z0-9_-]{{1,64}}",
            crate::config::one_line(id)
        ));
    }
    let batch_ok = opts.batch_s.is_finite() && opts.batch_s > 0.0;
    let speed_ok = opts.speed.is_finite() && opts.speed >= 0.0;
    if !(batch_ok && speed_ok) {
        return Err("--batch-s must be positive and --speed at least 0".into());
    }
    let file = liftwatch::input::Input::open(input).map_err(|e| e.to_string())?;
    let mut lines = BufReader::new(file).lines();
    let header = lines
        .next()
        .ok_or_else(|| format!("{}: empty", input.display()))?
        .map_err(|e| format!("{}: {e}", input.display()))?;
    if !header
        .trim()
        .to_ascii_lowercase()
        .starts_with("time,signal,value")
    {
        return Err(format!(
            "{}: not a raw `time,signal,value` log",
            input.display()
        ));
    }
    let started = Instant::now();
    let mut sum = ReplaySummary::default();
    let mut batch = Vec::new();
    let (mut batch_start, mut first_t) = (f64::NAN, f64::NAN);
    let mut send = |batch: &mut Vec<u8>,
                    first_t: f64,
                    t_end: f64,
                    sum: &mut ReplaySummary|
     -> Result<(), String> {
        if batch.is_empty() {
            return Ok(());
        }
        if opts.speed > 0.0 && first_t.is_finite() {
            let due = Duration::from_secs_f64(((t_end - first_t) / opts.speed).max(0.0));
            if let Some(wait) = due.checked_sub(started.elapsed()) {
                std::thread::sleep(wait);
            }
        }
        let mut body = b"time,signal,value\n".to_vec();
        body.extend_from_slice(batch);
        let mut attempt = 0;
        let mut failing_since = None;
        loop {
            attempt += 1;
            match sender.send(id, &body) {
                Ok(r) => {
                    sum.accepted += r.accepted;
                    sum.bad += r.bad;
                    break;
                }
                Err(SendError::Fatal(e)) => return Err(format!("batch {}: {e}", sum.batches + 1)),
                Err(SendError::Retry(e))
                    if failing_since.get_or_insert_with(Instant::now).elapsed() < RETRY_WINDOW =>
                {
                    sum.retries += 1;
                    if opts.progress || attempt == 1 {
                        eprintln!(
                            "replay: batch {} failed ({e}); sending it again",
                            sum.batches + 1
                        );
                    }
                    std::thread::sleep(RETRY_PAUSE);
                }
                Err(SendError::Retry(e)) => {
                    return Err(format!(
                        "batch {}: {e} ({attempt} attempts over {} s)",
                        sum.batches + 1,
                        RETRY_WINDOW.as_secs()
                    ))
                }
            }
        }
        sum.batches += 1;
        batch.clear();
        if opts.progress && sum.batches % 100 == 0 {
            eprint!("\rreplay: {} batches, {} rows", sum.batches, sum.rows);
        }
        Ok(())
    };
    let mut last_t = f64::NAN;
    for line in lines {
        let line = line.map_err(|e| format!("{}: {e}", input.display()))?;
        if line.trim().is_empty() {
            continue;
        }
        sum.rows += 1;
        // Cut on the log's own time; a row whose time does not parse rides along (the server
        // counts it bad).
        let t = line
            .split(',')
            .next()
            .and_then(|f| f.trim().parse::<f64>().ok())
            .or_else(|| {
                line.split(',')
                    .next()
                    .and_then(|f| liftwatch::ingest::time::parse_time(f.trim(), &mut None).ok())
            });
        if let Some(t) = t {
            if first_t.is_nan() {
                first_t = t;
                batch_start = t;
            }
            if t >= batch_start + opts.batch_s {
                send(&mut batch, first_t, last_t, &mut sum)?;
                batch_start = t;
            }
            last_t = t;
        }
        batch.extend_from_slice(line.as_bytes());
        batch.push(b'\n');
    }
    send(&mut batch, first_t, last_t, &mut sum)?;
    if opts.progress {
        eprintln!();
    }
    sum.seconds = started.elapsed().as_secs_f64();
    Ok(sum)
}

/// How long the broker may take to acknowledge one batch before it is sent again.
const MQTT_ACK_TIMEOUT: Duration = Duration::from_secs(30);

/// A gateway's side of MQTT: one batch a QoS 1 PUBLISH, sent again until the broker
/// acknowledges it (the service drops what arrives twice).
pub struct MqttSender {
    client: rumqttc::Client,
    connection: rumqttc::Connection,
}

impl MqttSender {
    fn new(broker: &crate::config::Broker) -> MqttSender {
        let id = format!("liftwatch-replay-{}", std::process::id());
        let (client, connection) = rumqttc::Client::new(broker.options(&id, false), 16);
        MqttSender { client, connection }
    }
}

impl Sender for MqttSender {
    fn send(&mut self, id: &str, csv: &[u8]) -> Result<SendReply, SendError> {
        use rumqttc::{Event, Packet, QoS};
        self.client
            .publish(
                crate::mqtt::telemetry_topic(id),
                QoS::AtLeastOnce,
                false,
                csv.to_vec(),
            )
            .map_err(|e| SendError::Retry(format!("mqtt: {e}")))?;
        let deadline = Instant::now() + MQTT_ACK_TIMEOUT;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.connection.recv_timeout(left) {
                Ok(Ok(Event::Incoming(Packet::PubAck(_)))) => break,
                Ok(Err(rumqttc::ConnectionError::ConnectionRefused(code))) => {
                    return Err(SendError::Fatal(format!(
                        "mqtt: the broker refused the connection: {code:?}"
                    )));
                }
                Ok(Ok(_)) => {}
                Ok(Err(e)) => return Err(SendError::Retry(format!("mqtt: {e}"))),
                Err(_) => return Err(SendError::Retry("mqtt: no acknowledgement in time".into())),
            }
        }
        let rows = csv.split(|&b| b == b'\n').filter(|l| !l.is_empty()).count() as u64;
        let header = u64::from(csv.starts_with(b"time,"));
        // The broker's acknowledgement says it has the batch, not what the service made of
        // it: every row counts as sent, and there is no batch seq to report.
        Ok(SendReply {
            accepted: rows - header,
            bad: 0,
            seq: 0,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Read;
    use std::net::TcpListener;

    /// A loopback server that answers one request with `answer` and stops.
    fn answer_once(answer: &'static str) -> String {
        let listener = TcpListener::bind("127.0.0.1:0").expect("a loopback port");
        let addr = listener.local_addr().expect("bound").to_string();
        std::thread::spawn(move || {
            if let Ok((mut s, _)) = listener.accept() {
                let mut buf = [0u8; 4096];
                let _ = s.read(&mut buf);
                let _ = s.write_all(answer.as_bytes());
            }
        });
        addr
    }

    #[test]
    fn a_refusal_is_one_line_with_the_servers_words_or_a_note_that_it_said_none() {
        let cases = [
            (
                "HTTP/1.1 400 Bad Request\r\nContent-Length: 10\r\n\r\nbad\nthing\n",
                "HTTP 400: bad thing",
            ),
            (
                "HTTP/1.1 401 Unauthorized\r\nContent-Length: 0\r\n\r\n",
                "HTTP 401: (no body)",
            ),
        ];
        for (answer, said) in cases {
            let addr = answer_once(answer);
            let mut sender = sender_for(&format!("http://{addr}"), None).expect("an http sender");
            match sender.send("e1", b"time,signal,value\n") {
                Err(SendError::Fatal(e)) => assert_eq!(e, said),
                other => panic!("{other:?}"),
            }
        }
    }
}
