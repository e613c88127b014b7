//! [`run`]: steps several [`OsmpSensor`]s in one process over a sequence of [`Frame`]s.
//!
//! The API is deliberately small:
//!
//! * the caller instantiates and [initializes](OsmpSensor::initialize) the sensors (each with its own
//!   parameters and configuration grant);
//! * a frame source is any iterator of `Result<Frame, E>`: the built-in scenario maps its per-step
//!   `osi3::SensorView`s (one per sensor, encoded) into frames, a `.osi` trace maps each SensorView frame
//!   into a frame with a single view fed to every sensor; infallible sources use `.map(Ok::<_, Infallible>)`;
//! * every sensor is stepped once per frame, in sensor order (or in parallel, one thread per sensor, with
//!   [`RunOptions::parallel`]); then the sink receives one [`StepRecord`] per stepped sensor, in sensor
//!   order, so it can write SensorData / PerceptionData into per-sensor trace writers;
//! * with [`RunOptions::multi_rate`], each sensor runs at its own cycle `c` instead (its
//!   `DefaultExperiment/@stepSize`, the sensor's update cycle) on the master's clock: its communication
//!   points are exactly `t0 + n·c` (`t0` the first frame's time), whatever the frame times. The frame
//!   that serves the instant `t0 + n·c` is the first frame whose time is at or after the instant, within a
//!   tolerance of half that frame's step `h`: the frame nearest to the instant (frame `t` serves the
//!   instants in `(t − h_prev/2, t + h/2]`). The sensor is stepped with that frame's SensorView at
//!   `fmi2DoStep(t0 + n·c, h_i)`, `h_i` reaching to the first instant after the frame's window, so its
//!   communication points stay contiguous; `h_i = c` unless frames are farther apart than `c` (then
//!   one frame serves several instants and `h_i` is a multiple of `c`). A 0.05 s sensor over 0.01 s
//!   frames steps every 5th frame at exactly 0.05 s intervals; over frames with jittered times it
//!   takes the frame nearest to each instant, so the frame times it sees stay within the jitter of the
//!   grid and never drift.
//!
//! ```no_run
//! # use osiris::master::*;
//! # use std::convert::Infallible;
//! # fn demo(mut sensors: Vec<OsmpSensor>, views: Vec<(f64, Vec<u8>)>) -> Result<(), MasterError> {
//! let frames = views.into_iter().map(|(time, sv)| Ok::<_, Infallible>(Frame::shared(time, sv)));
//! let summary = run(&mut sensors, frames, &RunOptions::default(), |rec: StepRecord<'_>| {
//!     if let Some(bytes) = &rec.outputs.sensor_data {
//!         println!("sensor {} at t={}: {} bytes", rec.sensor_index, rec.time, bytes.len());
//!     }
//!     Ok::<_, Infallible>(())
//! })?;
//! println!("{} frames", summary.frames);
//! # Ok(()) }
//! ```

use std::io::Read;

use osiris_proto::osi3;

use super::{BoxError, MasterError, OsmpSensor, OsmpSource, Result, StepOutputs};
use crate::trace::{OsiTraceReader, TraceError};

/// The input of one communication point.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// The communication point `t` (s) passed to `fmi2DoStep`.
    pub time: f64,
    /// Encoded `osi3::SensorView`s: one per sensor (in the order of the sensors given to [`run`]), or
    /// exactly one, fed to every sensor. An empty buffer means "no input" for that sensor.
    pub sensor_views: Vec<Vec<u8>>,
}

impl Frame {
    /// A frame with one SensorView per sensor.
    pub fn per_sensor(time: f64, sensor_views: Vec<Vec<u8>>) -> Frame {
        Frame { time, sensor_views }
    }

    /// A frame whose single SensorView is fed to every sensor.
    pub fn shared(time: f64, sensor_view: Vec<u8>) -> Frame {
        Frame {
            time,
            sensor_views: vec![sensor_view],
        }
    }
}

/// Options of [`run`].
#[derive(Debug, Clone, Default)]
pub struct RunOptions {
    /// The communication step size `h`. `None` (default): the time to the next frame; the last frame
    /// repeats the previous step size, or uses the first sensor's `DefaultExperiment/@stepSize`.
    pub step_size: Option<f64>,
    /// Step the sensors of a frame in parallel, one scoped thread per sensor (FMI 2.0 allows parallel
    /// calls to different instances).
    pub parallel: bool,
    /// Step each sensor at its own cycle (see the module documentation) instead of at every frame.
    pub multi_rate: bool,
}

/// What the sink receives for each sensor and frame.
#[derive(Debug, Clone, Copy)]
pub struct StepRecord<'a> {
    /// 0-based index of the frame.
    pub frame_index: usize,
    /// Index into the `sensors` slice given to [`run`].
    pub sensor_index: usize,
    /// The sensor's instance name.
    pub sensor_name: &'a str,
    /// The communication point `t` of the step (with [`RunOptions::multi_rate`] the sensor's own
    /// instant `t0 + n·cycle`, else the frame's time).
    pub time: f64,
    /// The step size `h`; the outputs belong to `t + h` in FMI terms.
    pub step_size: f64,
    /// The time of the frame whose SensorView the sensor got.
    pub frame_time: f64,
    /// The encoded SensorView the sensor got (empty: none).
    pub sensor_view: &'a [u8],
    pub outputs: &'a StepOutputs,
    /// Wall time of this sensor's `fmi2DoStep` (input and output transfer included), ms, measured
    /// by the master around the step (with [`RunOptions::parallel`], inside the sensor's thread).
    pub step_wall_ms: Option<f64>,
}

/// Totals of a [`run`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RunSummary {
    /// Frames consumed.
    pub frames: usize,
    /// Per sensor: how many steps published SensorData.
    pub sensor_data_frames: Vec<usize>,
    /// Per sensor: how many steps published PerceptionData.
    pub perception_frames: Vec<usize>,
    /// Per sensor: how many steps returned a status other than `fmi2OK`.
    pub non_ok_steps: Vec<usize>,
    /// The last communication point reached (`t + h` of the last frame).
    pub end_time: Option<f64>,
}

/// Steps `sensors` (initialized [`OsmpSensor`]s) once per frame and hands every output to `sink`.
///
/// Stops at the first error: a frame-source error ([`MasterError::Source`]), an inconsistent frame
/// ([`MasterError::InvalidFrame`]: wrong number of views, non-increasing times), a sensor error
/// ([`MasterError::Sensor`]) or a sink error ([`MasterError::Sink`]). The sensors are left as they are
/// (initialized, or in the error state); dropping them terminates and frees them.
pub fn run<I, E, S, SE>(
    sensors: &mut [OsmpSensor],
    frames: I,
    options: &RunOptions,
    mut sink: S,
) -> Result<RunSummary>
where
    I: IntoIterator<Item = Result<Frame, E>>,
    E: Into<BoxError>,
    S: FnMut(StepRecord<'_>) -> Result<(), SE>,
    SE: Into<BoxError>,
{
    let n = sensors.len();
    let mut summary = RunSummary {
        sensor_data_frames: vec![0; n],
        perception_frames: vec![0; n],
        non_ok_steps: vec![0; n],
        ..RunSummary::default()
    };
    let default_step = sensors.first().and_then(OsmpSensor::default_step_size);
    let cycles: Vec<Option<f64>> = sensors
        .iter()
        .map(|s| {
            options
                .multi_rate
                .then(|| s.default_step_size())
                .flatten()
                .filter(|c| *c > 0.0 && c.is_finite())
        })
        .collect();
    // Multi-rate: index `n` of each sensor's next instant `t0 + n·cycle`.
    let mut next_instant: Vec<u64> = vec![0; n];
    let mut t0: Option<f64> = None;
    let mut frames = frames.into_iter().peekable();
    let mut previous_h: Option<f64> = None;
    let mut frame_index = 0;
    while let Some(item) = frames.next() {
        let frame = item.map_err(|e| MasterError::Source {
            frames_done: frame_index,
            source: e.into(),
        })?;
        let invalid = |reason: String| MasterError::InvalidFrame {
            frame_index,
            time: frame.time,
            reason,
        };
        if n > 0 && frame.sensor_views.len() != n && frame.sensor_views.len() != 1 {
            return Err(invalid(format!(
                "{} SensorViews for {n} sensors, expected {n} (one per sensor) or 1 (shared)",
                frame.sensor_views.len()
            )));
        }
        let h = match (options.step_size, frames.peek()) {
            (Some(h), _) => h,
            (None, Some(Ok(next))) => next.time - frame.time,
            (None, _) => previous_h.or(default_step).ok_or_else(|| {
                invalid(
                    "cannot infer the step size of the last frame; set RunOptions::step_size"
                        .to_owned(),
                )
            })?,
        };
        if !(h > 0.0 && h.is_finite()) {
            return Err(invalid(format!(
                "step size {h} s; expected frame times to increase strictly"
            )));
        }

        let view = |i: usize| -> &[u8] {
            &frame.sensor_views[if frame.sensor_views.len() == 1 { 0 } else { i }]
        };
        let t0 = *t0.get_or_insert(frame.time);
        // Which sensors step at this frame: (communication point, step size).
        let steps: Vec<Option<(f64, f64)>> = (0..n)
            .map(|i| match cycles[i] {
                None => Some((frame.time, h)),
                Some(cycle) => {
                    let instant = |k: u64| t0 + k as f64 * cycle;
                    let window_end = frame.time + 0.5 * h;
                    let first = next_instant[i];
                    if instant(first) > window_end {
                        return None;
                    }
                    // The first instant after this frame's window.
                    let mut next = first + 1;
                    if instant(next) <= window_end {
                        next = ((window_end - t0) / cycle).floor().max(0.0) as u64 + 1;
                        while instant(next) <= window_end {
                            next += 1;
                        }
                    }
                    next_instant[i] = next;
                    Some((instant(first), instant(next) - instant(first)))
                }
            })
            .collect();
        let timed = |s: &mut OsmpSensor, sv: &[u8], ti: f64, hi: f64| {
            let started = std::time::Instant::now();
            let r = s.step(sv, ti, hi);
            (r, 1e3 * started.elapsed().as_secs_f64())
        };
        let results: Vec<Option<(Result<StepOutputs>, f64)>> = if options.parallel && n > 1 {
            std::thread::scope(|scope| {
                let handles: Vec<_> = sensors
                    .iter_mut()
                    .enumerate()
                    .map(|(i, s)| {
                        let sv = view(i);
                        let step = steps[i];
                        scope.spawn(move || step.map(|(ti, hi)| timed(s, sv, ti, hi)))
                    })
                    .collect();
                handles
                    .into_iter()
                    .map(|h| h.join().unwrap_or_else(|p| std::panic::resume_unwind(p)))
                    .collect()
            })
        } else {
            sensors
                .iter_mut()
                .enumerate()
                .map(|(i, s)| steps[i].map(|(ti, hi)| timed(s, view(i), ti, hi)))
                .collect()
        };

        for (sensor_index, result) in results.into_iter().enumerate() {
            let Some((result, wall_ms)) = result else {
                continue;
            };
            let (ti, hi) = steps[sensor_index].unwrap_or((frame.time, h));
            let outputs = result.map_err(|e| MasterError::Sensor {
                frame_index,
                sensor_index,
                source: Box::new(e),
            })?;
            summary.sensor_data_frames[sensor_index] += usize::from(outputs.sensor_data.is_some());
            summary.perception_frames[sensor_index] += usize::from(outputs.perception.is_some());
            summary.non_ok_steps[sensor_index] +=
                usize::from(outputs.status != super::Fmi2Status::Ok);
            let record = StepRecord {
                frame_index,
                sensor_index,
                sensor_name: sensors[sensor_index].name(),
                time: ti,
                step_size: hi,
                frame_time: frame.time,
                sensor_view: view(sensor_index),
                outputs: &outputs,
                step_wall_ms: Some(wall_ms),
            };
            sink(record).map_err(|e| MasterError::Sink {
                frame_index,
                sensor_index,
                source: e.into(),
            })?;
        }
        previous_h = Some(h);
        summary.end_time = Some(frame.time + h);
        frame_index += 1;
        summary.frames = frame_index;
    }
    Ok(summary)
}

/// Only the timestamps of a SensorView (field 2, and field 2 of its `global_ground_truth` = 7):
/// decoding it skips everything else cheaply.
#[derive(Clone, PartialEq, prost::Message)]
struct SensorViewTimestamp {
    #[prost(message, optional, tag = "2")]
    timestamp: Option<osi3::Timestamp>,
    #[prost(message, optional, tag = "7")]
    global_ground_truth: Option<GroundTruthTimestamp>,
}

/// Only field 2 (`timestamp`) of a GroundTruth.
#[derive(Clone, PartialEq, prost::Message)]
struct GroundTruthTimestamp {
    #[prost(message, optional, tag = "2")]
    timestamp: Option<osi3::Timestamp>,
}

/// Frames from a SensorView `.osi` trace: one [`Frame::shared`] per message (fed to every sensor) at the
/// SensorView's `timestamp` (or, when that is absent, its ground truth's). A frame with neither is a
/// [`TraceError::MissingField`].
pub fn sensor_view_trace_frames<R: Read>(
    mut reader: OsiTraceReader<R>,
) -> impl Iterator<Item = Result<Frame, TraceError>> {
    std::iter::from_fn(move || {
        let (frame, offset) = (reader.frame_index(), reader.offset());
        let bytes = match reader.next()? {
            Ok(bytes) => bytes,
            Err(e) => return Some(Err(e)),
        };
        let file = || reader.name().to_owned();
        let ts = match <SensorViewTimestamp as prost::Message>::decode(bytes.as_slice()) {
            Ok(SensorViewTimestamp {
                timestamp: Some(ts),
                ..
            }) => ts,
            Ok(SensorViewTimestamp {
                global_ground_truth:
                    Some(GroundTruthTimestamp {
                        timestamp: Some(ts),
                    }),
                ..
            }) => ts,
            Ok(_) => {
                return Some(Err(TraceError::MissingField {
                    file: file(),
                    frame,
                    offset,
                    message: "SensorView",
                    field: "timestamp",
                }));
            }
            Err(source) => {
                return Some(Err(TraceError::Decode {
                    file: file(),
                    frame,
                    offset,
                    message: "SensorView",
                    source,
                }));
            }
        };
        Some(Ok(Frame::shared(
            osiris_proto::timestamp_to_seconds(&ts),
            bytes,
        )))
    })
}

/// The time of an encoded SensorView: its `timestamp`, else its ground truth's (`None`: neither).
fn sensor_view_time(bytes: &[u8]) -> std::result::Result<Option<f64>, prost::DecodeError> {
    let v = <SensorViewTimestamp as prost::Message>::decode(bytes)?;
    Ok(v.timestamp
        .or(v.global_ground_truth.and_then(|g| g.timestamp))
        .map(|ts| osiris_proto::timestamp_to_seconds(&ts)))
}

/// Frames from channel `channel_id` (SensorView messages) of a `.mcap` trace: one [`Frame::shared`] per
/// message at the SensorView's `timestamp` (or its ground truth's; without either, the message's
/// `publish_time`).
pub fn mcap_sensor_view_frames(
    reader: &crate::trace::mcap::McapTraceReader,
    channel_id: u16,
) -> std::result::Result<
    impl Iterator<Item = std::result::Result<Frame, TraceError>> + use<>,
    TraceError,
> {
    let file = reader.path().display().to_string();
    let topic = reader
        .channels()
        .iter()
        .find(|c| c.id == channel_id)
        .map_or_else(|| channel_id.to_string(), |c| c.topic.clone());
    let mut index = 0u64;
    Ok(reader.messages(channel_id)?.map(move |m| {
        let m = m?;
        let i = index;
        index += 1;
        let time = sensor_view_time(&m.data).map_err(|e| TraceError::InvalidMcap {
            file: file.clone(),
            reason: format!("channel `{topic}`, message {i}: cannot decode the SensorView: {e}"),
        })?;
        Ok(Frame::shared(
            time.unwrap_or(m.publish_time as f64 * 1e-9),
            m.data,
        ))
    }))
}

/// Frames from an initialized OSMP source: frame `k` is the SensorView the source publishes after
/// `fmi2DoStep(start + k·step, step)`, at time `start + (k + 1)·step`, fed to every sensor (an empty
/// buffer when the source published none); `frames` frames in all.
pub fn source_frames(
    source: &mut OsmpSource,
    start: f64,
    step: f64,
    frames: usize,
) -> impl Iterator<Item = Result<Frame>> + '_ {
    (0..frames).map(move |k| {
        let t = start + k as f64 * step;
        let view = source.step(t, step)?.unwrap_or_default();
        Ok(Frame::shared(start + (k + 1) as f64 * step, view))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trace::OsiTraceWriter;

    #[test]
    fn trace_frames_carry_the_sensor_view_timestamps() {
        let mut w = OsiTraceWriter::new(Vec::new());
        let sv = |t: f64| osi3::SensorView {
            timestamp: Some(osiris_proto::timestamp_from_seconds(t)),
            sensor_id: Some(osiris_proto::id(7)),
            ..Default::default()
        };
        w.write_message(&sv(0.5)).unwrap();
        w.write_message(&sv(0.55)).unwrap();
        w.write_message(&osi3::SensorView::default()).unwrap();
        let bytes = w.finish().unwrap();
        let frames: Vec<_> =
            sensor_view_trace_frames(OsiTraceReader::with_name(bytes.as_slice(), "sv.osi".into()))
                .collect();
        assert_eq!(frames.len(), 3);
        let f1 = frames[1].as_ref().unwrap();
        assert!((f1.time - 0.55).abs() < 1e-12);
        assert_eq!(
            f1.sensor_views,
            vec![prost::Message::encode_to_vec(&sv(0.55))]
        );
        let err = frames[2].as_ref().unwrap_err().to_string();
        assert!(err.starts_with("sv.osi: frame 2 at byte offset "), "{err}");
        assert!(err.ends_with(": the SensorView has no timestamp"), "{err}");
    }
}
