//! What the controller saw and sent, recorded as MCAP (Foxglove opens it): `/sensors`, `/command` and `/operator`
//! as JSON, one message each per control period. Messages are encoded in the control loop and written by a thread
//! of their own, so a slow disk never holds the loop (a full queue drops the message and counts it). Written to a
//! temporary file and moved into place when finished: a recording is complete or absent.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{sync_channel, SyncSender, TrySendError};
use std::thread::JoinHandle;

use serde_json::json;
use topa_control::driver::Readings;
use topa_control::MotorCommand;

use crate::error::{Error, Result};

const SCHEMA: &str = r#"{"type":"object","additionalProperties":true}"#;
const TOPICS: [&str; 3] = ["/sensors", "/command", "/operator"];
/// Messages queued for the writer at most (a few seconds at the control rate).
const QUEUE: usize = 1024;

type Message = (u16, u64, Vec<u8>);

pub struct ControlLog {
    tx: Option<SyncSender<Message>>,
    writer: Option<JoinHandle<Result<()>>>,
    channels: [u16; 3],
    tmp: PathBuf,
    path: PathBuf,
    /// Messages dropped because the writer fell behind.
    pub dropped: u64,
}

fn mcap_error(path: &Path) -> impl Fn(mcap::McapError) -> Error + '_ {
    move |e| Error::File { message: format!("recording {}: {e}", path.display()), source: Some(Box::new(e)) }
}

impl ControlLog {
    pub fn create(path: &Path) -> Result<ControlLog> {
        let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        std::fs::create_dir_all(dir).map_err(|source| Error::Io { action: "creating", path: dir.into(), source })?;
        let name =
            path.file_name().ok_or_else(|| Error::Invalid(format!("--record {} names no file", path.display())))?;
        let tmp = dir.join(format!(".{}.tmp-{}", name.to_string_lossy(), std::process::id()));
        let file = File::create(&tmp).map_err(|source| Error::Io { action: "creating", path: tmp.clone(), source })?;
        let mut w = mcap::Writer::new(BufWriter::new(file)).map_err(mcap_error(path))?;
        let mut channels = [0; 3];
        for (c, topic) in channels.iter_mut().zip(TOPICS) {
            let schema = w
                .add_schema(topic.trim_start_matches('/'), "jsonschema", SCHEMA.as_bytes())
                .map_err(mcap_error(path))?;
            *c = w.add_channel(schema, topic, "json", &BTreeMap::new()).map_err(mcap_error(path))?;
        }
        let (tx, rx) = sync_channel::<Message>(QUEUE);
        let owned = path.to_path_buf();
        let writer = std::thread::spawn(move || -> Result<()> {
            for (sequence, (channel_id, ns, data)) in rx.into_iter().enumerate() {
                let header = mcap::records::MessageHeader {
                    channel_id,
                    sequence: sequence as u32,
                    log_time: ns,
                    publish_time: ns,
                };
                w.write_to_known_channel(&header, &data).map_err(mcap_error(&owned))?;
            }
            w.finish().map_err(mcap_error(&owned))?;
            Ok(())
        });
        Ok(ControlLog { tx: Some(tx), writer: Some(writer), channels, tmp, path: path.to_path_buf(), dropped: 0 })
    }

    fn send(&mut self, channel: usize, ns: u64, value: serde_json::Value) {
        let Some(tx) = &self.tx else { return };
        let data = serde_json::to_vec(&value).unwrap_or_default();
        if let Err(TrySendError::Full(_) | TrySendError::Disconnected(_)) =
            tx.try_send((self.channels[channel], ns, data))
        {
            self.dropped += 1;
        }
    }

    /// One control period: the frame the controller read (None: none came), what it sent, the operator's command.
    pub fn record(&mut self, t: f64, frame: Option<&Readings>, sent: &MotorCommand, command: [f64; 3]) {
        let ns = (t.max(0.0) * 1e9).round() as u64;
        if let Some(r) = frame {
            let v = json!({"orientation": r.orientation, "gyro": r.gyro, "base_velocity": r.base_velocity,
                           "motor_pos": r.motor_pos, "motor_vel": r.motor_vel});
            self.send(0, ns, v);
        }
        let mode = format!("{:?}", sent.mode);
        self.send(1, ns, json!({"mode": mode, "target": sent.target, "kp": sent.kp, "kd": sent.kd}));
        self.send(2, ns, json!({"v_x": command[0], "v_y": command[1], "w_z": command[2]}));
    }

    /// Closes the recording and moves it into place.
    pub fn finish(mut self) -> Result<PathBuf> {
        drop(self.tx.take());
        if let Some(w) = self.writer.take() {
            w.join().map_err(|_| Error::Invalid("the recording's writer thread panicked".into()))??;
        }
        std::fs::rename(&self.tmp, &self.path).map_err(|source| Error::Io {
            action: "moving the recording to",
            path: self.path.clone(),
            source,
        })?;
        Ok(self.path.clone())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use topa_control::Mode;

    #[test]
    fn a_recording_holds_every_period_on_its_three_topics() {
        let path = std::env::temp_dir().join(format!("topa-control-log-{}.mcap", std::process::id()));
        let mut log = ControlLog::create(&path).unwrap();
        let r = Readings::new(2);
        let sent = MotorCommand { mode: Mode::Policy, target: vec![0.1, 0.2], kp: vec![30.0; 2], kd: vec![1.0; 2] };
        for k in 0..100 {
            log.record(k as f64 * 0.02, (k % 10 != 0).then_some(&r), &sent, [0.5, 0.0, 0.0]);
        }
        assert_eq!(log.dropped, 0);
        log.finish().unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let mut per_topic = BTreeMap::new();
        for m in mcap::MessageStream::new(&bytes).unwrap() {
            let m = m.unwrap();
            *per_topic.entry(m.channel.topic.clone()).or_insert(0) += 1;
            let v: serde_json::Value = serde_json::from_slice(&m.data).unwrap();
            if m.channel.topic == "/command" {
                assert_eq!(v["mode"], "Policy");
                assert_eq!(v["target"][1], 0.2);
            }
        }
        assert_eq!(per_topic["/sensors"], 90, "a frame in the periods that had one");
        assert_eq!((per_topic["/command"], per_topic["/operator"]), (100, 100));
        std::fs::remove_file(path).ok();
    }
}
