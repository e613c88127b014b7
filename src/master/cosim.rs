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
//! * with [`RunOptions::multi_rate`], each sensor runs at its own cycle instead (its
//!   `DefaultExperiment/@stepSize`, the sensor's update cycle): at a frame with time `t` and frame step
//!   `h` a sensor is due when `t` reached its next communication point; it is stepped with
//!   `h_i = k·h`, `k = max(1, round(cycle / h))`, so its communication points stay contiguous
//!   (`t_next = t + h_i`) and fall on frames when the frames are evenly spaced. Its effective cycle is
//!   the multiple of the frame step nearest to its own (e.g. a 0.033 s camera on 0.02 s frames runs
//!   every 0.04 s).
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

use super::{BoxError, MasterError, OsmpSensor, Result, StepOutputs};
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
    /// The communication point `t` of the step.
    pub time: f64,
    /// The step size `h`; the outputs belong to `t + h` in FMI terms.
    pub step_size: f64,
    pub outputs: &'a StepOutputs,
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
    // Next communication point of each sensor (multi-rate); `None`: due at the next frame.
    let mut next_due: Vec<Option<f64>> = vec![None; n];
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
        // Which sensors step at this frame, and with which step size.
        let steps: Vec<Option<f64>> = (0..n)
            .map(|i| match cycles[i] {
                None => Some(h),
                Some(cycle) => match next_due[i] {
                    Some(due) if frame.time < due - 0.5 * h => None,
                    _ => Some(h * (cycle / h).round().max(1.0)),
                },
            })
            .collect();
        for (i, hi) in steps.iter().enumerate() {
            if let (Some(hi), Some(_)) = (hi, cycles[i]) {
                next_due[i] = Some(frame.time + hi);
            }
        }
        let results: Vec<Option<Result<StepOutputs>>> = if options.parallel && n > 1 {
            std::thread::scope(|scope| {
                let handles: Vec<_> = sensors
                    .iter_mut()
                    .enumerate()
                    .map(|(i, s)| {
                        let sv = view(i);
                        let hi = steps[i];
                        scope.spawn(move || hi.map(|hi| s.step(sv, frame.time, hi)))
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
                .map(|(i, s)| steps[i].map(|hi| s.step(view(i), frame.time, hi)))
                .collect()
        };

        for (sensor_index, result) in results.into_iter().enumerate() {
            let Some(result) = result else { continue };
            let hi = steps[sensor_index].unwrap_or(h);
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
                time: frame.time,
                step_size: hi,
                outputs: &outputs,
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
