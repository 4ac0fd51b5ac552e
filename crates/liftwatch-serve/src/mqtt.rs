//! MQTT, the field convention for gateways: telemetry in on `liftwatch/{id}/telemetry`, events
//! out on `liftwatch/{id}/events`, through a broker (Mosquitto from Debian's package in the
//! tests).
//!
//! ```text
//! gateway ─ PUBLISH liftwatch/{id}/telemetry (QoS 1) ─ broker ─ subscriber thread
//!     ─ ingest::ingest (the HTTP path: parse, one batch committed, worker woken) ─ PUBACK
//! worker ─ checkpoint committed ─ PUBLISH liftwatch/{id}/events (QoS 1), one event line each
//! ```
//!
//! Delivery is at least once end to end: the service's session is persistent (clean session
//! off) and a message is acknowledged only once its batch is committed, so a service killed in
//! between gets it again from the broker; the worker drops a re-delivered reading as a
//! duplicate. A message whose body is refused (no usable row, an id out of form) is
//! acknowledged and counted as refused: a re-delivery would be refused again. A database
//! error leaves it unacknowledged, for the broker to deliver again after a reconnect.
//!
//! Authentication is the broker's: the service and every gateway log in with a user and
//! password (`mqtt://user:password@host:port`), and the broker's ACL lets gateways publish
//! telemetry and the service read it (README, *Service*). Payloads are the raw
//! `time,signal,value` CSV of DATA.md (header optional) or JSON lines, told apart by their
//! first character.

use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::Duration;

use rumqttc::{Client, Connection, Event, Packet, QoS};

use crate::config::{Broker, MQTT_REQUEST_QUEUE};
use crate::{ingest, log, Shared};

/// The topic filter the service subscribes to.
pub const TELEMETRY_FILTER: &str = "liftwatch/+/telemetry";

/// Pause before reconnecting after a connection error, so that a broker that is away is not
/// hammered.
const RECONNECT_PAUSE: Duration = Duration::from_secs(1);

/// The events topic of elevator `id`.
pub fn events_topic(id: &str) -> String {
    format!("liftwatch/{id}/events")
}

/// The telemetry topic of elevator `id`.
pub fn telemetry_topic(id: &str) -> String {
    format!("liftwatch/{id}/telemetry")
}

/// The elevator id of a telemetry topic, `None` for any other topic.
pub fn id_of_topic(topic: &str) -> Option<&str> {
    topic
        .strip_prefix("liftwatch/")?
        .strip_suffix("/telemetry")
        .filter(|id| !id.contains('/'))
}

/// Connects the service to `broker` as `client_id`: a thread takes telemetry from
/// [`TELEMETRY_FILTER`] into [`ingest::ingest`], and the returned client publishes events.
///
/// # Errors
/// One line when the thread cannot be started.
pub fn start(shared: Arc<Shared>, broker: &Broker, client_id: &str) -> Result<Client, String> {
    let mut opts = broker.options(client_id, true);
    opts.set_manual_acks(true);
    let (client, connection) = Client::new(opts, MQTT_REQUEST_QUEUE);
    let sub = client.clone();
    let name = broker.display();
    std::thread::Builder::new()
        .name("liftwatch-mqtt".into())
        .spawn(move || subscriber(&shared, &sub, connection, &name))
        .map_err(|e| format!("cannot start the MQTT thread: {e}"))?;
    Ok(client)
}

/// The subscriber loop: (re)subscribes at every connection, ingests every telemetry message
/// and acknowledges it once committed. Runs until the process ends.
fn subscriber(shared: &Shared, client: &Client, mut connection: Connection, broker: &str) {
    let mut connected = false;
    for event in connection.iter() {
        match event {
            Ok(Event::Incoming(Packet::ConnAck(_))) => {
                log("info", &format!("mqtt: connected to {broker}"));
                connected = true;
                if let Err(e) = client.try_subscribe(TELEMETRY_FILTER, QoS::AtLeastOnce) {
                    log("error", &format!("mqtt: cannot subscribe: {e}"));
                }
            }
            Ok(Event::Incoming(Packet::Publish(p))) => {
                let ack = take(shared, &p.topic, &p.payload);
                if ack {
                    if let Err(e) = client.ack(&p) {
                        log("error", &format!("mqtt: cannot acknowledge: {e}"));
                    }
                }
            }
            Ok(_) => {}
            Err(e) => {
                if connected {
                    log("warn", &format!("mqtt: {broker}: {e}; reconnecting"));
                }
                connected = false;
                std::thread::sleep(RECONNECT_PAUSE);
            }
        }
    }
}

/// Ingests one message; true when it is to be acknowledged (committed, or refused for good).
fn take(shared: &Shared, topic: &str, payload: &[u8]) -> bool {
    let Some(id) = id_of_topic(topic) else {
        shared.refused.fetch_add(1, Ordering::Relaxed);
        log("warn", &format!("mqtt: ignored a message on `{topic}`"));
        return true;
    };
    let ndjson = payload
        .iter()
        .find(|b| !b.is_ascii_whitespace())
        .is_some_and(|&b| b == b'{');
    match ingest::ingest(shared, id, payload, ndjson) {
        Ok(_) => true,
        Err(e) if e.0.is_client_error() => {
            shared.refused.fetch_add(1, Ordering::Relaxed);
            log("warn", &format!("mqtt: {topic}: refused: {}", e.1));
            true
        }
        Err(e) => {
            log(
                "error",
                &format!(
                    "mqtt: {topic}: {}; left for the broker to deliver again",
                    e.1
                ),
            );
            false
        }
    }
}

/// Publishes event lines of elevator `id` on its events topic; a full queue drops them with a
/// log line (the store keeps every event; the topic is a notification).
pub fn publish_events(client: &Client, id: &str, lines: &[&str]) {
    for line in lines {
        if let Err(e) = client.try_publish(
            events_topic(id),
            QoS::AtLeastOnce,
            false,
            line.as_bytes().to_vec(),
        ) {
            log("warn", &format!("mqtt: event of {id} not published: {e}"));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn urls_and_topics_read_as_documented() {
        let b = Broker::parse("mqtt://gw:s3cret@127.0.0.1:18830").unwrap();
        assert_eq!(b.host, "127.0.0.1");
        assert_eq!(b.port, 18830);
        assert_eq!(b.login, Some(("gw".into(), "s3cret".into())));
        assert_eq!(b.display(), "mqtt://127.0.0.1:18830");
        assert_eq!(Broker::parse("mqtt://broker").unwrap().port, 1883);
        assert!(Broker::parse("http://x").is_err());
        assert!(Broker::parse("mqtt://:1883").is_err());
        assert!(Broker::parse("mqtt://h:port").is_err());
        assert_eq!(id_of_topic("liftwatch/lift-7/telemetry"), Some("lift-7"));
        assert_eq!(id_of_topic("liftwatch/a/b/telemetry"), None);
        assert_eq!(id_of_topic("liftwatch/lift-7/events"), None);
        assert_eq!(telemetry_topic("x"), "liftwatch/x/telemetry");
    }
}
