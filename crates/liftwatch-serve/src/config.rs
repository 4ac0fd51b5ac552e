//! The service's settings: `--config FILE` (TOML) over built-in defaults, every bound named.
//!
//! ```toml
//! listen = "127.0.0.1:8080"
//! data = "/var/lib/liftwatch"   # `--data` wins over it
//! reorder_window_s = 30          # how late a row may come and still be sorted in
//! checkpoint_every_s = 2.0       # wall time between two checkpoints of the worker
//! checkpoint_every_batches = 500 # or this many batches, whichever comes first
//! keep_raw_days = 35             # raw batches kept for fitting from history
//! max_body_bytes = 8388608
//! max_rows_per_request = 200000
//! max_elevators = 2000
//! read_token = false             # true: reads need the token too
//! mqtt = "mqtt://liftwatch:PASSWORD@127.0.0.1:1883"  # optional: telemetry in, events out
//! mqtt_client_id = "liftwatch-serve"  # the broker keeps this session's subscription
//! nats = "nats://127.0.0.1:4222,nats://127.0.0.1:4223"  # optional: the fleet mode (README)
//! nats_partitions = 16           # P of the server's `partition(P,1)` mapping, the same number
//! nats_replicas = 3              # replicas of the streams and buckets (1 for one server)
//! nats_lease_s = 6.0             # a partition's lease lives this long without a renewal
//!
//! [[elevators]]
//! id = "B7-east"
//! name = "Lift A"
//! group = "Building 7"
//! rated_load_kg = 1000
//! rated_speed_mps = 1.6
//! floors = 16
//! timezone = "+01:00"
//! ```

use std::net::SocketAddr;
use std::path::Path;
use std::time::Duration;

use serde::{Deserialize, Serialize};

/// Default reorder window of the service (s): short, for latency. A row later than this
/// behind the newest one is counted as late and dropped (a file is sorted instead); loggers
/// that flush every few seconds stay far inside it.
pub const DEFAULT_REORDER_WINDOW_S: f64 = 30.0;

/// Default wall time between two checkpoints (s): the worker's outputs become visible and
/// durable at most this late, and a restart re-applies at most this much.
pub const DEFAULT_CHECKPOINT_EVERY_S: f64 = 2.0;

/// Default number of batches applied between two checkpoints, whichever comes first: bounds
/// the work a restart repeats when a backlog is applied faster than the wall-time rule fires.
pub const DEFAULT_CHECKPOINT_EVERY_BATCHES: u64 = 500;

/// Default retention of raw batches (days): a month of history to fit from, plus a margin.
pub const DEFAULT_KEEP_RAW_DAYS: f64 = 35.0;

/// Default largest request body (bytes): 8 MiB, about 12 hours of one elevator's raw log.
pub const DEFAULT_MAX_BODY_BYTES: usize = 8 << 20;

/// Default most rows in one telemetry request: about 9 hours of one elevator at 6 signals/s.
pub const DEFAULT_MAX_ROWS_PER_REQUEST: usize = 200_000;

/// Default most elevators one instance holds: a few large buildings; each costs a worker state
/// of tens of KiB in memory.
pub const DEFAULT_MAX_ELEVATORS: usize = 2_000;

/// Default MQTT client id of the service: the broker keeps the persistent session (and the
/// messages not yet acknowledged) under it; two services on one broker need two ids.
pub const DEFAULT_MQTT_CLIENT_ID: &str = "liftwatch-serve";

/// Default number of partitions of the fleet mode: the `P` of the server's mapping.
pub const DEFAULT_NATS_PARTITIONS: u32 = 16;

/// Default lease of a partition in the fleet mode (s): renewed every third of it, so a dead
/// worker's partitions are free again this long after its last renewal.
pub const DEFAULT_NATS_LEASE_S: f64 = 6.0;

/// Default listening address: this machine only.
pub const DEFAULT_LISTEN: &str = "127.0.0.1:8080";

/// One elevator as the config file (or `PUT /api/v1/elevators/{id}`) describes it.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ElevatorInfo {
    /// Id, `[A-Za-z0-9_-]{1,64}` (in the config file; the path gives it in the API).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub id: Option<String>,
    /// Name a person reads (`"Lift A"`).
    #[serde(default)]
    pub name: Option<String>,
    /// Bank or building label; peers are compared within it.
    #[serde(default)]
    pub group: Option<String>,
    /// Rated load (kg).
    #[serde(default)]
    pub rated_load_kg: Option<f64>,
    /// Rated speed (m/s).
    #[serde(default)]
    pub rated_speed_mps: Option<f64>,
    /// Floors served.
    #[serde(default)]
    pub floors: Option<u32>,
    /// Fixed UTC offset (`"+01:00"`) or `"UTC"`, as in `elevator.toml`.
    #[serde(default)]
    pub timezone: Option<String>,
}

/// The service's settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Config {
    /// Address to listen on.
    pub listen: String,
    /// Data directory, when `--data` does not give it.
    pub data: Option<std::path::PathBuf>,
    /// Reorder window of the aligner (s).
    pub reorder_window_s: f64,
    /// Wall time between checkpoints (s).
    pub checkpoint_every_s: f64,
    /// Batches between checkpoints.
    pub checkpoint_every_batches: u64,
    /// Days raw batches are kept.
    pub keep_raw_days: f64,
    /// Largest request body (bytes).
    pub max_body_bytes: usize,
    /// Most rows in one telemetry request.
    pub max_rows_per_request: usize,
    /// Most elevators.
    pub max_elevators: usize,
    /// Reads need the token too.
    pub read_token: bool,
    /// MQTT broker (`mqtt://[user:password@]host[:port]`): telemetry taken from
    /// `liftwatch/+/telemetry`, events published on `liftwatch/{id}/events`; none by default.
    pub mqtt: Option<String>,
    /// The service's MQTT client id.
    pub mqtt_client_id: String,
    /// NATS servers (`nats://host:port[,nats://host:port…]`): the fleet mode on JetStream
    /// instead of the embedded store (README, *Fleet*); none by default.
    pub nats: Option<String>,
    /// Partitions of the telemetry subjects: the `P` of the server's mapping.
    pub nats_partitions: u32,
    /// Replicas of the fleet's streams and buckets (at most the cluster's servers).
    pub nats_replicas: usize,
    /// Lifetime of a partition lease without renewal (s).
    pub nats_lease_s: f64,
    /// Elevators known from the start.
    pub elevators: Vec<ElevatorInfo>,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            listen: DEFAULT_LISTEN.into(),
            data: None,
            reorder_window_s: DEFAULT_REORDER_WINDOW_S,
            checkpoint_every_s: DEFAULT_CHECKPOINT_EVERY_S,
            checkpoint_every_batches: DEFAULT_CHECKPOINT_EVERY_BATCHES,
            keep_raw_days: DEFAULT_KEEP_RAW_DAYS,
            max_body_bytes: DEFAULT_MAX_BODY_BYTES,
            max_rows_per_request: DEFAULT_MAX_ROWS_PER_REQUEST,
            max_elevators: DEFAULT_MAX_ELEVATORS,
            read_token: false,
            mqtt: None,
            mqtt_client_id: DEFAULT_MQTT_CLIENT_ID.into(),
            nats: None,
            nats_partitions: DEFAULT_NATS_PARTITIONS,
            nats_replicas: 1,
            nats_lease_s: DEFAULT_NATS_LEASE_S,
            elevators: Vec::new(),
        }
    }
}

/// Largest config file read (bytes).
const MAX_CONFIG_BYTES: u64 = 1 << 20;

impl Config {
    /// Reads a TOML config file; missing keys keep their defaults.
    ///
    /// # Errors
    /// One line naming the file and what is wrong.
    pub fn load(path: &Path) -> Result<Config, String> {
        let meta = std::fs::metadata(path).map_err(|e| format!("{}: {e}", path.display()))?;
        if meta.len() > MAX_CONFIG_BYTES {
            return Err(format!(
                "{}: {} bytes, more than the {MAX_CONFIG_BYTES} a config may have",
                path.display(),
                meta.len()
            ));
        }
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let cfg: Config = toml::from_str(&text).map_err(|e| {
            let line = e.span().map(|s| {
                text.as_bytes()[..s.start.min(text.len())]
                    .iter()
                    .filter(|&&b| b == b'\n')
                    .count()
                    + 1
            });
            let at = line.map_or(String::new(), |l| format!(" line {l}:"));
            format!("{}:{at} {}", path.display(), one_line(e.message()))
        })?;
        cfg.validate()
            .map_err(|e| format!("{}: {e}", path.display()))?;
        Ok(cfg)
    }

    /// Checks every setting.
    ///
    /// # Errors
    /// One line naming the first setting out of range.
    pub fn validate(&self) -> Result<(), String> {
        self.listen
            .parse::<SocketAddr>()
            .map_err(|_| format!("listen `{}` is not an address:port", self.listen))?;
        liftwatch::align::AlignConfig::default()
            .with_reorder_window(self.reorder_window_s)
            .map_err(|e| e.to_string())?;
        if !(self.checkpoint_every_s > 0.0 && self.checkpoint_every_s <= 3600.0) {
            return Err(format!(
                "checkpoint_every_s {} is outside (0, 3600]",
                self.checkpoint_every_s
            ));
        }
        if self.checkpoint_every_batches == 0 {
            return Err("checkpoint_every_batches must be at least 1".into());
        }
        if !(self.keep_raw_days >= 0.0 && self.keep_raw_days <= 3650.0) {
            return Err(format!(
                "keep_raw_days {} is outside 0 to 3650",
                self.keep_raw_days
            ));
        }
        if self.max_body_bytes < 1024 || self.max_rows_per_request == 0 || self.max_elevators == 0 {
            return Err("max_body_bytes (≥ 1024), max_rows_per_request and max_elevators (≥ 1) bound the input".into());
        }
        if let Some(url) = &self.mqtt {
            Broker::parse(url).map_err(|e| format!("mqtt {e}"))?;
        }
        if let Some(urls) = &self.nats {
            nats_servers(urls).map_err(|e| format!("nats {e}"))?;
            if self.mqtt.is_some() {
                return Err("mqtt and nats exclude each other: with nats, gateways publish MQTT into the NATS server's MQTT listener".into());
            }
        }
        if !(1..=1024).contains(&self.nats_partitions) {
            return Err(format!(
                "nats_partitions {} is outside 1 to 1024",
                self.nats_partitions
            ));
        }
        if !(1..=5).contains(&self.nats_replicas) {
            return Err(format!(
                "nats_replicas {} is outside 1 to 5",
                self.nats_replicas
            ));
        }
        if !(self.nats_lease_s >= 1.0 && self.nats_lease_s <= 600.0) {
            return Err(format!(
                "nats_lease_s {} is outside 1 to 600",
                self.nats_lease_s
            ));
        }
        if self.mqtt_client_id.is_empty() || self.mqtt_client_id.len() > 64 {
            return Err("mqtt_client_id must be 1 to 64 characters".into());
        }
        for e in &self.elevators {
            let id = e.id.as_deref().unwrap_or("");
            if !valid_id(id) {
                return Err(format!(
                    "elevator id `{}` is not [A-Za-z0-9_-]{{1,64}}",
                    one_line(id)
                ));
            }
            check_info(e).map_err(|why| format!("elevator {id}: {why}"))?;
        }
        Ok(())
    }
}

/// The servers of a `nats` setting: `nats://host:port` addresses separated by commas.
///
/// # Errors
/// One line naming the address out of form.
pub fn nats_servers(urls: &str) -> Result<Vec<String>, String> {
    let mut out = Vec::new();
    for u in urls.split(',').map(str::trim) {
        let rest = u
            .strip_prefix("nats://")
            .ok_or_else(|| format!("`{}` is not nats://host:port", one_line(u)))?;
        let (host, port) = rest
            .rsplit_once(':')
            .ok_or_else(|| format!("`{}` has no :port", one_line(u)))?;
        if host.is_empty() || host.contains(['/', '@']) || port.parse::<u16>().is_err() {
            return Err(format!("`{}` is not nats://host:port", one_line(u)));
        }
        out.push(u.to_string());
    }
    Ok(out)
}

/// Checks the values of an elevator description.
///
/// # Errors
/// One line naming the field.
pub fn check_info(e: &ElevatorInfo) -> Result<(), String> {
    // The rated values in the library's own ranges (`Elevator::validate`, what `fit` and
    // `elevator.toml` demand), the values not given standing in as valid: PUT took a
    // rated load of 999,999 kg that a fit then refused.
    liftwatch::Elevator::new(
        e.rated_load_kg.unwrap_or(1000.0),
        e.rated_speed_mps.unwrap_or(1.0),
        e.floors.unwrap_or(10),
    )
    .validate()?;
    for (name, v) in [("name", &e.name), ("group", &e.group)] {
        if v.as_ref()
            .is_some_and(|s| s.chars().count() > MAX_LABEL_CHARS)
        {
            return Err(format!(
                "{name} is longer than {MAX_LABEL_CHARS} characters"
            ));
        }
    }
    if let Some(tz) = &e.timezone {
        utc_offset(tz)?;
    }
    Ok(())
}

/// Longest name or group label (characters).
pub const MAX_LABEL_CHARS: usize = 200;

/// Seconds east of UTC of a `timezone` value, read as `elevator.toml` reads it.
///
/// # Errors
/// One line for anything but a fixed offset or `UTC`.
pub fn utc_offset(tz: &str) -> Result<i32, String> {
    let mut e = liftwatch::Elevator::new(1000.0, 1.0, 2);
    e.timezone = Some(tz.to_string());
    e.utc_offset_s()
}

/// Longest elevator id (characters).
pub const MAX_ID_CHARS: usize = 64;

/// True for an elevator id of the contract: `[A-Za-z0-9_-]{1,64}`. Ids never reach the file
/// system; the check keeps URLs, logs and metric labels plain.
pub fn valid_id(id: &str) -> bool {
    !id.is_empty()
        && id.len() <= MAX_ID_CHARS
        && id
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'-')
}

/// Most characters of outside text quoted in a message.
const QUOTED_CHARS: usize = 120;

/// `s` on one line and clipped, for messages.
pub fn one_line(s: &str) -> String {
    let flat: String = s
        .chars()
        .map(|c| if c.is_control() { ' ' } else { c })
        .take(QUOTED_CHARS)
        .collect();
    if s.chars().count() > QUOTED_CHARS {
        format!("{flat}…")
    } else {
        flat
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_are_plain_names_never_paths() {
        assert!(valid_id("B7-east_2"));
        for bad in ["", "../etc", "a/b", "a.b", "é", &"x".repeat(65)] {
            assert!(!valid_id(bad), "{bad}");
        }
    }

    #[test]
    fn a_config_file_reads_with_defaults_and_refuses_nonsense() {
        let cfg: Config = toml::from_str(
            "reorder_window_s = 10\n[[elevators]]\nid = \"a\"\nfloors = 8\ntimezone = \"+01:00\"\n",
        )
        .unwrap();
        assert!(cfg.validate().is_ok());
        assert_eq!(cfg.max_body_bytes, DEFAULT_MAX_BODY_BYTES);
        let bad: Config = toml::from_str("[[elevators]]\nid = \"a/b\"\n").unwrap();
        assert!(bad.validate().is_err());
        assert!(toml::from_str::<Config>("lisen = \"x\"").is_err());
    }
}

/// A broker's address and login, from `mqtt://[user[:password]@]host[:port]`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Broker {
    /// Host name or address.
    pub host: String,
    /// Port (1883 when the URL gives none).
    pub port: u16,
    /// User and password, when the URL gives them.
    pub login: Option<(String, String)>,
}

/// Keep-alive of the connections: a dead broker is noticed within one and a half of it.
pub const MQTT_KEEP_ALIVE: Duration = Duration::from_secs(15);

/// Requests the client may queue before a publish waits: a few seconds of a busy building's
/// events and acknowledgements.
pub const MQTT_REQUEST_QUEUE: usize = 1024;

/// Largest MQTT packet accepted or sent (bytes): the HTTP body limit's order, a few minutes of
/// a gateway's batch.
pub const MQTT_MAX_PACKET_BYTES: usize = 8 << 20;

/// MQTT's registered port.
const DEFAULT_PORT: u16 = 1883;

impl Broker {
    /// Reads an `mqtt://` URL.
    ///
    /// # Errors
    /// One line saying what is wrong with it.
    pub fn parse(url: &str) -> Result<Broker, String> {
        let rest = url
            .strip_prefix("mqtt://")
            .ok_or_else(|| format!("`{url}`: expected mqtt://[user:password@]host[:port]"))?;
        let rest = rest.trim_end_matches('/');
        let (login, hostport) = match rest.rsplit_once('@') {
            Some((l, h)) => {
                let (u, p) = l.split_once(':').unwrap_or((l, ""));
                (Some((u.to_string(), p.to_string())), h)
            }
            None => (None, rest),
        };
        let (host, port) = match hostport.rsplit_once(':') {
            Some((h, p)) => (
                h,
                p.parse::<u16>()
                    .map_err(|_| format!("`{url}`: the port `{p}` is not a number"))?,
            ),
            None => (hostport, DEFAULT_PORT),
        };
        if host.is_empty() || host.contains('/') {
            return Err(format!("`{url}`: no host"));
        }
        Ok(Broker {
            host: host.to_string(),
            port,
            login,
        })
    }

    /// Connection options for a client named `client_id`.
    pub fn options(&self, client_id: &str, persistent: bool) -> rumqttc::MqttOptions {
        let mut o = rumqttc::MqttOptions::new(client_id, self.host.clone(), self.port);
        o.set_keep_alive(MQTT_KEEP_ALIVE)
            .set_clean_session(!persistent)
            .set_max_packet_size(MQTT_MAX_PACKET_BYTES, MQTT_MAX_PACKET_BYTES)
            .set_request_channel_capacity(MQTT_REQUEST_QUEUE);
        if let Some((u, p)) = &self.login {
            o.set_credentials(u.clone(), p.clone());
        }
        o
    }

    /// `host:port`, without the login, for messages.
    pub fn display(&self) -> String {
        format!("mqtt://{}:{}", self.host, self.port)
    }
}
