//! A blocking client of the fleet's log, for gateways, tools and tests: publishes telemetry,
//! puts models, reads the outputs and the checkpoints. Its own single-thread runtime.

use std::collections::HashMap;

use bytes::Bytes;

use super::bus::{Bus, Published};

/// A connection to the fleet's servers.
pub struct Gateway {
    rt: tokio::runtime::Runtime,
    bus: Bus,
}

impl Gateway {
    /// Connects to `urls` (comma-separated `nats://host:port`); makes the streams and buckets
    /// with `replicas` if missing.
    ///
    /// # Errors
    /// One line: the address, the connection, the server.
    pub fn connect(urls: &str, replicas: usize) -> Result<Gateway, String> {
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .map_err(|e| format!("cannot start the runtime: {e}"))?;
        let cfg = crate::config::Config::default();
        let bus = rt.block_on(Bus::connect(
            urls,
            "liftwatch-gateway",
            replicas,
            cfg.nats_lease_s,
            cfg.keep_raw_days,
        ))?;
        Ok(Gateway { rt, bus })
    }

    /// Publishes one telemetry body of `id`: its stream sequence once stored.
    ///
    /// # Errors
    /// One line from the server.
    pub fn publish(&self, id: &str, body: &[u8]) -> Result<u64, String> {
        self.rt
            .block_on(self.bus.publish_telemetry(id, Bytes::copy_from_slice(body)))
    }

    /// Stores a model and activates it for `id`: its version.
    ///
    /// # Errors
    /// One line from the server.
    pub fn put_model(&self, id: &str, body: &[u8]) -> Result<u64, String> {
        self.rt.block_on(self.bus.put_model(id, body))
    }

    /// Every output stored so far.
    ///
    /// # Errors
    /// One line from the server.
    pub fn outputs(&self) -> Result<Vec<Published>, String> {
        self.rt.block_on(self.bus.outputs())
    }

    /// Every checkpoint: id → (stream seq covered, readings applied).
    ///
    /// # Errors
    /// One line from the server or a checkpoint that does not read.
    pub fn progress(&self) -> Result<HashMap<String, (u64, u64)>, String> {
        let states = self.rt.block_on(self.bus.states())?;
        states
            .into_iter()
            .map(|(id, v)| {
                let c: serde_json::Value =
                    serde_json::from_slice(&v).map_err(|e| format!("{id}: {e}"))?;
                let seq = c["seq"].as_u64().unwrap_or(0);
                let readings = c["counters"]["readings"].as_u64().unwrap_or(0);
                Ok((id, (seq, readings)))
            })
            .collect()
    }
}
