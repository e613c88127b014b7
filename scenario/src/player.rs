//! SensorView players: one stream of `osi3::SensorView`s over time, from a scenario or from a
//! recorded trace. This is what `scenario.fmu` plays; the FMU shell (`osiris-fmu`) maps its
//! parameters onto [`Player`] and publishes what [`Player::view_at`] returns. Nothing here knows FMI.
//!
//! # Time
//!
//! `t` is seconds since the start of the recording:
//! * a scenario plays its own time: step `k` at `t = k · step_s` (the view's timestamps are
//!   `start_time_s + t`, see the crate documentation). The scenario is defined on
//!   `[0, duration_s]`; outside, there is no view. Within [`TIME_TOLERANCE_S`] of a step, the view is
//!   exactly [`ScenarioConfig::sensor_view`] of that step; between steps the constant-velocity motion
//!   is evaluated at `t` ([`ScenarioConfig::sensor_view_at`]).
//! * a trace plays its messages at their timestamps relative to the first message's: `t = 0` is the
//!   first message, and the view at `t` is the last message whose timestamp is at most
//!   `first + t` (zero-order hold, within [`TIME_TOLERANCE_S`]). After the last message's timestamp
//!   there is no view. The messages are passed on byte for byte (fields outside the OSI subset
//!   osiris decodes are kept). Traces are read as they play (memory does not grow with their
//!   length), so the times of [`Player::view_at`] must not decrease.
//!
//! # Which sensor
//!
//! A scenario mounts several sensors; a player outputs the SensorView of one: the mount named by
//! [`Player::scenario`]'s `sensor` argument, or the first of `sensors` when none is named. Every view
//! carries the global ground truth and that mount's `mounting_position`, so a sensor of any kind
//! can use it. A trace plays its SensorViews as recorded.

use std::borrow::Cow;
use std::path::{Path, PathBuf};

use osiris_proto::trace::{OsiTraceReader, TraceError};
use osiris_proto::{Message, osi3};

use crate::{ScenarioConfig, SensorMount};

/// A communication point within this of a scenario step or a trace timestamp counts as that step
/// or timestamp, s.
pub const TIME_TOLERANCE_S: f64 = 1e-6;
const TOLERANCE_NS: i64 = 1_000;

/// The trace formats [`Player::trace`] reads, by file extension.
pub const TRACE_EXTENSIONS: &[&str] = &["osi", "mcap"];

/// Errors of opening or playing a source.
#[derive(Debug, thiserror::Error)]
pub enum PlayerError {
    /// The scenario names no sensor mount of that name.
    #[error("the scenario has no sensor named `{name}` (its sensors: {known})")]
    UnknownSensor { name: String, known: String },
    /// The scenario has no sensor mount at all.
    #[error(
        "the scenario has no sensor mounts (`sensors` is empty); a SensorView needs one: add a \
         mount to `sensors`"
    )]
    NoSensor,
    /// The trace's extension is not one [`TRACE_EXTENSIONS`] lists.
    #[error("trace `{}`: unsupported format `{ext}` (supported: {})", path.display(), supported())]
    UnsupportedTrace { path: PathBuf, ext: String },
    /// Reading the trace failed (missing file, truncated frame, ...; the error names the file).
    #[error(transparent)]
    Trace(#[from] TraceError),
    /// The trace holds no usable SensorView.
    #[error("trace `{}` holds no SensorView with a timestamp ({frames} frames read)", path.display())]
    EmptyTrace { path: PathBuf, frames: u64 },
    /// A trace was asked for an earlier time than before.
    #[error(
        "trace `{}` plays forward only: t = {t_s} s is before the previous t = {previous_s} s",
        path.display()
    )]
    Backwards {
        path: PathBuf,
        t_s: f64,
        previous_s: f64,
    },
}

fn supported() -> String {
    TRACE_EXTENSIONS
        .iter()
        .map(|e| format!(".{e}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// One played view: the decoded message and its encoding (what an OSMP output publishes).
#[derive(Debug, Clone, Copy)]
pub struct PlayedView<'a> {
    pub view: &'a osi3::SensorView,
    pub bytes: &'a [u8],
}

/// A stream of SensorViews over time (see the module documentation).
pub enum Player {
    Scenario(Box<ScenarioPlayer>),
    Trace(Box<TracePlayer>),
}

impl Player {
    /// Play `config` for its sensor `sensor` (`None`: the first of `config.sensors`).
    pub fn scenario(config: ScenarioConfig, sensor: Option<&str>) -> Result<Player, PlayerError> {
        ScenarioPlayer::new(config, sensor).map(|p| Player::Scenario(Box::new(p)))
    }

    /// Play the SensorView trace at `path` (format by extension, [`TRACE_EXTENSIONS`]). Frames that
    /// are skipped while looking for the first usable one are described in `notes`.
    ///
    /// `channel` picks the SensorView channel of an `.mcap` file: its topic, or the sensor name
    /// whose input `osiris run` recorded (`<sensor>.OSMPSensorViewIn`); `None`: the file's only
    /// SensorView channel. `.osi` files have one stream and ignore it.
    pub fn trace(
        path: &Path,
        channel: Option<&str>,
        notes: &mut Vec<String>,
    ) -> Result<Player, PlayerError> {
        TracePlayer::open(path, channel, notes).map(|p| Player::Trace(Box::new(p)))
    }

    /// The view at `t` s (see the module documentation); `Ok(None)` outside the recording. Skipped
    /// trace frames are described in `notes`.
    pub fn view_at(
        &mut self,
        t_s: f64,
        notes: &mut Vec<String>,
    ) -> Result<Option<PlayedView<'_>>, PlayerError> {
        match self {
            Player::Scenario(p) => Ok(p.view_at(t_s)),
            Player::Trace(p) => p.view_at(t_s, notes),
        }
    }

    /// One line saying what is played, for logs.
    pub fn describe(&self) -> String {
        match self {
            Player::Scenario(p) => format!(
                "scenario `{}` ({} s at {} s steps), sensor `{}` ({}, id {})",
                p.config.name,
                p.config.duration_s,
                p.config.step_s,
                p.sensor.name,
                p.sensor.kind.name(),
                p.sensor.sensor_id
            ),
            Player::Trace(p) => format!("trace `{}`", p.path.display()),
        }
    }
}

/// Plays one sensor's view of a [`ScenarioConfig`].
pub struct ScenarioPlayer {
    config: ScenarioConfig,
    sensor: SensorMount,
    /// The last view and its encoding.
    last: Option<(osi3::SensorView, Vec<u8>)>,
}

impl ScenarioPlayer {
    /// Play `config` for its sensor `sensor` (`None`: the first of `config.sensors`).
    pub fn new(
        config: ScenarioConfig,
        sensor: Option<&str>,
    ) -> Result<ScenarioPlayer, PlayerError> {
        let mount = match sensor {
            Some(name) => config
                .sensor(name)
                .ok_or_else(|| PlayerError::UnknownSensor {
                    name: name.to_owned(),
                    known: if config.sensors.is_empty() {
                        "none".to_owned()
                    } else {
                        config
                            .sensors
                            .iter()
                            .map(|s| format!("`{}`", s.name))
                            .collect::<Vec<_>>()
                            .join(", ")
                    },
                })?,
            None => config.sensors.first().ok_or(PlayerError::NoSensor)?,
        }
        .clone();
        Ok(ScenarioPlayer {
            config,
            sensor: mount,
            last: None,
        })
    }

    /// The scenario played.
    pub fn config(&self) -> &ScenarioConfig {
        &self.config
    }

    /// The sensor mount whose view is played.
    pub fn sensor(&self) -> &SensorMount {
        &self.sensor
    }

    /// The view at scenario time `t_s`, `None` outside `[0, duration_s]`.
    pub fn view_at(&mut self, t_s: f64) -> Option<PlayedView<'_>> {
        let c = &self.config;
        if !t_s.is_finite() || t_s < -TIME_TOLERANCE_S || t_s > c.duration_s + TIME_TOLERANCE_S {
            return None;
        }
        let k = (t_s / c.step_s).round();
        let view = if (t_s - c.time_s(k.max(0.0) as usize)).abs() <= TIME_TOLERANCE_S {
            c.sensor_view(k.max(0.0) as usize, &self.sensor)
        } else {
            c.sensor_view_at(t_s, &self.sensor)
        };
        let bytes = view.encode_to_vec();
        let (view, bytes) = self.last.insert((view, bytes));
        Some(PlayedView { view, bytes })
    }
}

/// A decoded trace message and its place in the file.
struct TraceMessage {
    view: osi3::SensorView,
    bytes: Vec<u8>,
    /// Timestamp, ns.
    ns: i64,
}

/// The raw frames of a trace file, by extension (an `.mcap` file: the SensorView channel `channel`
/// names, see [`Player::trace`]).
fn open_frames(path: &Path, channel: Option<&str>) -> Result<Box<dyn FrameSource>, PlayerError> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    match ext.as_str() {
        "osi" => Ok(Box::new(OsiTraceReader::open(path)?)),
        "mcap" => {
            let reader = osiris_proto::trace::mcap::McapTraceReader::open(path)?;
            const SV: &str = "osi3.SensorView";
            let topic = match channel {
                Some(c) if reader.channel(c).is_none() => Some(format!("{c}.OSMPSensorViewIn")),
                other => other.map(str::to_owned),
            };
            let id = reader.select_channel(SV, topic.as_deref())?.id;
            Ok(Box::new(reader.messages(id)?.map(|m| m.map(|m| m.data))))
        }
        _ => Err(PlayerError::UnsupportedTrace {
            path: path.to_path_buf(),
            ext: if ext.is_empty() {
                "(no extension)".to_owned()
            } else {
                format!(".{ext}")
            },
        }),
    }
}

/// The frames of a trace: each a serialized `osi3::SensorView`.
trait FrameSource: Iterator<Item = Result<Vec<u8>, TraceError>> + Send {}
impl<T: Iterator<Item = Result<Vec<u8>, TraceError>> + Send> FrameSource for T {}

/// Plays a SensorView trace (see the module documentation).
pub struct TracePlayer {
    path: PathBuf,
    frames: Box<dyn FrameSource>,
    /// Frames read so far.
    frames_read: u64,
    /// Timestamp of the first message, ns (the player's `t = 0`).
    first_ns: i64,
    current: TraceMessage,
    /// The message after `current`; `None` at the end of the file.
    next: Option<TraceMessage>,
    /// The last requested time, s.
    last_t_s: f64,
}

impl TracePlayer {
    /// Open `path` and read up to its first usable message (skipped frames are described in
    /// `notes`).
    pub fn open(
        path: &Path,
        channel: Option<&str>,
        notes: &mut Vec<String>,
    ) -> Result<TracePlayer, PlayerError> {
        let mut frames = open_frames(path, channel)?;
        let mut frames_read = 0;
        let first =
            read_message(path, &mut frames, &mut frames_read, None, notes)?.ok_or_else(|| {
                PlayerError::EmptyTrace {
                    path: path.to_path_buf(),
                    frames: frames_read,
                }
            })?;
        let next = read_message(path, &mut frames, &mut frames_read, Some(first.ns), notes)?;
        Ok(TracePlayer {
            path: path.to_path_buf(),
            frames,
            frames_read,
            first_ns: first.ns,
            current: first,
            next,
            last_t_s: f64::NEG_INFINITY,
        })
    }

    /// The trace file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The view at `t_s` (s since the first message); `None` before the first message and after the
    /// last one.
    pub fn view_at(
        &mut self,
        t_s: f64,
        notes: &mut Vec<String>,
    ) -> Result<Option<PlayedView<'_>>, PlayerError> {
        if !t_s.is_finite() {
            return Ok(None);
        }
        if t_s < self.last_t_s - TIME_TOLERANCE_S {
            return Err(PlayerError::Backwards {
                path: self.path.clone(),
                t_s,
                previous_s: self.last_t_s,
            });
        }
        self.last_t_s = self.last_t_s.max(t_s);
        let target = self.first_ns.saturating_add((t_s * 1e9).round() as i64);
        if target < self.first_ns - TOLERANCE_NS {
            return Ok(None);
        }
        while let Some(next) = self.next.take() {
            if next.ns > target.saturating_add(TOLERANCE_NS) {
                self.next = Some(next);
                break;
            }
            self.current = next;
            self.next = read_message(
                &self.path,
                &mut self.frames,
                &mut self.frames_read,
                Some(self.current.ns),
                notes,
            )?;
        }
        if self.next.is_none() && target > self.current.ns.saturating_add(TOLERANCE_NS) {
            return Ok(None);
        }
        Ok(Some(PlayedView {
            view: &self.current.view,
            bytes: &self.current.bytes,
        }))
    }
}

/// The next usable message: a SensorView with a timestamp (its own, else its ground truth's) not
/// before `after_ns`. Frames that are not are described in `notes` and skipped; `Ok(None)` at the end.
fn read_message(
    path: &Path,
    frames: &mut Box<dyn FrameSource>,
    frames_read: &mut u64,
    after_ns: Option<i64>,
    notes: &mut Vec<String>,
) -> Result<Option<TraceMessage>, PlayerError> {
    for bytes in frames.by_ref() {
        let bytes = bytes?;
        let frame = *frames_read;
        *frames_read += 1;
        let skip = |why: Cow<'_, str>| {
            format!(
                "trace `{}`: frame {frame}: {why}; frame skipped",
                path.display()
            )
        };
        let view = match osi3::SensorView::decode(bytes.as_slice()) {
            Ok(v) => v,
            Err(e) => {
                notes.push(skip(format!("not a SensorView ({e})").into()));
                continue;
            }
        };
        let Some(ts) = view.timestamp.or_else(|| {
            view.global_ground_truth
                .as_ref()
                .and_then(|gt| gt.timestamp)
        }) else {
            notes.push(skip(
                "the SensorView has no timestamp (nor its global_ground_truth)".into(),
            ));
            continue;
        };
        let ns = osiris_proto::timestamp_to_nanos(&ts);
        if let Some(after) = after_ns
            && ns < after
        {
            notes.push(skip(
                format!(
                    "timestamp {} s is before the previous frame's {} s",
                    ns as f64 * 1e-9,
                    after as f64 * 1e-9
                )
                .into(),
            ));
            continue;
        }
        return Ok(Some(TraceMessage { view, bytes, ns }));
    }
    Ok(None)
}

#[cfg(test)]
mod tests {
    use super::*;
    use osiris_proto::trace::OsiTraceWriter;

    fn view_at_time(t_s: f64, sensor_id: u64) -> osi3::SensorView {
        osi3::SensorView {
            timestamp: Some(osiris_proto::timestamp_from_seconds(t_s)),
            sensor_id: Some(osiris_proto::id(sensor_id)),
            ..Default::default()
        }
    }

    fn write_trace(dir: &Path, frames: &[Vec<u8>]) -> PathBuf {
        let path = dir.join("views.osi");
        let mut w = OsiTraceWriter::create(&path).unwrap();
        for f in frames {
            w.write_raw(f).unwrap();
        }
        w.finish().unwrap();
        path
    }

    #[test]
    fn scenario_player_plays_the_steps_of_the_named_sensor() {
        let c = ScenarioConfig::default();
        let radar = c.sensor("front_radar").unwrap().clone();
        let mut p = ScenarioPlayer::new(c.clone(), Some("front_radar")).unwrap();
        for k in [0usize, 1, 7, 199, 200] {
            // A communication point accumulated by repeated addition still hits the step.
            let t = (0..k).fold(0.0, |t, _| t + c.step_s);
            let v = p.view_at(t).unwrap();
            assert_eq!(*v.view, c.sensor_view(k, &radar), "step {k}");
            assert_eq!(v.bytes, c.sensor_view(k, &radar).encode_to_vec());
        }
        // Between steps: the motion at that time.
        let v = p.view_at(0.015).unwrap();
        assert_eq!(*v.view, c.sensor_view_at(0.015, &radar));
        // Outside [0, duration_s]: nothing.
        assert!(p.view_at(-0.01).is_none());
        assert!(p.view_at(c.duration_s + 0.01).is_none());
        assert!(p.view_at(f64::NAN).is_none());
    }

    #[test]
    fn scenario_player_defaults_to_the_first_sensor_and_names_unknown_ones() {
        let c = ScenarioConfig::default();
        let p = ScenarioPlayer::new(c.clone(), None).unwrap();
        assert_eq!(p.sensor(), &c.sensors[0]);
        let e = ScenarioPlayer::new(c.clone(), Some("rear_radar"))
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("`rear_radar`"), "{e}");
        assert!(
            e.contains("`front_camera`, `front_radar`, `front_lidar`"),
            "{e}"
        );
        let none = ScenarioConfig {
            sensors: Vec::new(),
            ..c
        };
        let e = ScenarioPlayer::new(none, None).err().unwrap();
        assert!(matches!(e, PlayerError::NoSensor), "{e}");
    }

    #[test]
    fn sensor_view_at_a_step_time_is_the_step_view() {
        let c = ScenarioConfig::default();
        let lidar = c.sensor("front_lidar").unwrap();
        for k in [0, 3, 150] {
            assert_eq!(
                c.sensor_view_at(c.time_s(k), lidar),
                c.sensor_view(k, lidar)
            );
        }
    }

    #[test]
    fn trace_player_holds_each_message_until_the_next_and_ends_after_the_last() {
        let dir = tempfile::tempdir().unwrap();
        // Timestamps 10.0, 10.1, 10.2 s: t = 0 is the first message.
        let frames: Vec<Vec<u8>> = (0..3)
            .map(|i| view_at_time(10.0 + 0.1 * i as f64, i).encode_to_vec())
            .collect();
        let path = write_trace(dir.path(), &frames);
        let mut notes = Vec::new();
        let mut p = Player::trace(&path, None, &mut notes).unwrap();
        assert!(notes.is_empty(), "{notes:?}");
        let mut id_at = |t: f64| -> Option<u64> {
            p.view_at(t, &mut notes)
                .unwrap()
                .map(|v| v.view.sensor_id.unwrap().value.unwrap())
        };
        assert_eq!(id_at(0.0), Some(0));
        assert_eq!(id_at(0.05), Some(0));
        assert_eq!(id_at(0.1), Some(1));
        assert_eq!(id_at(0.1999999999), Some(2));
        assert_eq!(id_at(0.2), Some(2));
        assert_eq!(id_at(0.25), None, "past the last message");
        assert!(notes.is_empty(), "{notes:?}");
    }

    #[test]
    fn trace_player_passes_frames_through_byte_for_byte() {
        let dir = tempfile::tempdir().unwrap();
        // A field osiris does not decode (an unknown tag 999, varint 5) must survive the replay.
        let mut bytes = view_at_time(0.0, 4).encode_to_vec();
        bytes.extend_from_slice(&[0xb8, 0x3e, 0x05]);
        let path = write_trace(dir.path(), std::slice::from_ref(&bytes));
        let mut notes = Vec::new();
        let mut p = Player::trace(&path, None, &mut notes).unwrap();
        assert_eq!(p.view_at(0.0, &mut notes).unwrap().unwrap().bytes, bytes);
    }

    /// An `.mcap` with two sensors' recorded inputs: the channel is chosen by topic or by sensor
    /// name, and without a choice the error lists both.
    #[test]
    fn trace_player_plays_the_chosen_mcap_channel() {
        use osiris_proto::trace::mcap::McapTraceWriter;
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("run.mcap");
        let mut w = McapTraceWriter::create(&path).unwrap();
        let a = w
            .add_channel("front_radar.OSMPSensorViewIn", "osi3.SensorView", None)
            .unwrap();
        let b = w
            .add_channel("front_lidar.OSMPSensorViewIn", "osi3.SensorView", None)
            .unwrap();
        for i in 0..3u64 {
            let t = 5.0 + 0.1 * i as f64;
            w.write(a, &view_at_time(t, 10 + i).encode_to_vec(), 0)
                .unwrap();
            w.write(b, &view_at_time(t, 20 + i).encode_to_vec(), 0)
                .unwrap();
        }
        w.finish().unwrap();
        let mut notes = Vec::new();
        for (channel, first) in [("front_lidar", 20), ("front_radar.OSMPSensorViewIn", 10)] {
            let mut p = Player::trace(&path, Some(channel), &mut notes).unwrap();
            let ids: Vec<u64> = [0.0, 0.1, 0.2]
                .iter()
                .map(|t| {
                    p.view_at(*t, &mut notes)
                        .unwrap()
                        .unwrap()
                        .view
                        .sensor_id
                        .unwrap()
                        .value
                        .unwrap()
                })
                .collect();
            assert_eq!(ids, vec![first, first + 1, first + 2], "{channel}");
        }
        let e = Player::trace(&path, None, &mut notes)
            .err()
            .unwrap()
            .to_string();
        assert!(
            e.contains("front_radar.OSMPSensorViewIn")
                && e.contains("front_lidar.OSMPSensorViewIn"),
            "{e}"
        );
        assert!(notes.is_empty(), "{notes:?}");
    }

    #[test]
    fn trace_player_skips_bad_frames_with_notes_and_names_bad_files() {
        let dir = tempfile::tempdir().unwrap();
        let frames = vec![
            vec![0xff; 7],                               // frame 0: not a SensorView
            osi3::SensorView::default().encode_to_vec(), // frame 1: no timestamp
            view_at_time(1.0, 1).encode_to_vec(),        // frame 2: first usable
            view_at_time(0.5, 2).encode_to_vec(),        // frame 3: goes back in time
            view_at_time(1.5, 3).encode_to_vec(),        // frame 4
        ];
        let path = write_trace(dir.path(), &frames);
        let mut notes = Vec::new();
        let mut p = Player::trace(&path, None, &mut notes).unwrap();
        assert_eq!(notes.len(), 3, "{notes:?}");
        assert!(notes[0].contains("frame 0: not a SensorView"), "{notes:?}");
        assert!(
            notes[1].contains("frame 1: the SensorView has no timestamp"),
            "{notes:?}"
        );
        assert!(
            notes[2].contains("frame 3: timestamp 0.5 s is before"),
            "{notes:?}"
        );
        let v = p.view_at(0.5, &mut notes).unwrap().unwrap();
        assert_eq!(v.view.sensor_id, Some(osiris_proto::id(3)));
        let e = p.view_at(0.1, &mut notes).err().unwrap().to_string();
        assert!(e.contains("plays forward only"), "{e}");

        let missing = dir.path().join("missing.osi");
        let e = Player::trace(&missing, None, &mut notes)
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("missing.osi"), "{e}");
        let other = dir.path().join("views.bag");
        let e = Player::trace(&other, None, &mut notes)
            .err()
            .unwrap()
            .to_string();
        assert!(
            e.contains("unsupported format `.bag`") && e.contains(".osi") && e.contains(".mcap"),
            "{e}"
        );
        std::fs::write(dir.path().join("empty.osi"), b"").unwrap();
        let e = Player::trace(&dir.path().join("empty.osi"), None, &mut notes)
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("holds no SensorView"), "{e}");
        // A truncated frame is an error naming the file and the frame.
        let good = view_at_time(0.0, 1).encode_to_vec();
        let mut file = std::fs::read(write_trace(dir.path(), &[good.clone(), good])).unwrap();
        file.truncate(file.len() - 3);
        let cut = dir.path().join("cut.osi");
        std::fs::write(&cut, file).unwrap();
        let e = Player::trace(&cut, None, &mut notes)
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("cut.osi") && e.contains("frame 1"), "{e}");
    }
}
