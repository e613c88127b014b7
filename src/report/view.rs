//! `osiris view`: the report and KPI tables of any SensorData trace — an `.osi` trace (one sensor)
//! or every SensorData channel of an `.mcap` trace (one section each) — written by `osiris run` or
//! by another tool.
//!
//! Pairing, message for message (the n-th SensorData with the n-th PerceptionData / SensorView):
//!
//! * PerceptionData: `--perception TRACE`; in an `.mcap`, the PerceptionData channel whose topic has
//!   the SensorData channel's sensor prefix (`<sensor>.` in `<sensor>.OSMPSensorDataOut`);
//! * ground truth: the SensorView embedded in the SensorData (`SensorData.sensor_view`), else
//!   `--sensor-view TRACE`, else (`.mcap`) the SensorView channel with the same sensor prefix, else
//!   none (the objects table then has no rows for that sensor and the report says so).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use osiris_proto::{Message, osi3, perception};

use super::{ReportBuilder, ReportStep};
use crate::trace::OsiTraceReader;
use crate::trace::mcap::{McapTraceReader, PERCEPTION_DATA_SCHEMA};

const SENSOR_DATA_SCHEMA: &str = "osi3.SensorData";
const SENSOR_VIEW_SCHEMA: &str = "osi3.SensorView";

/// Arguments of `osiris view`.
#[derive(Debug, clap::Args)]
pub struct ViewArgs {
    /// SensorData trace: `.osi`, or `.mcap` (every SensorData channel, or the one `--channel` names).
    #[arg(value_name = "TRACE")]
    pub trace: PathBuf,
    /// Output folder (report.html, objects.csv, frames.csv).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// SensorView trace (`.osi`, or `.mcap` with one SensorView channel per sensor prefix) with the
    /// ground truth, when the SensorData embeds none.
    #[arg(long, value_name = "TRACE")]
    pub sensor_view: Option<PathBuf>,
    /// `.mcap` traces: only this SensorData channel (topic).
    #[arg(long, value_name = "TOPIC")]
    pub channel: Option<String>,
    /// PerceptionData trace (`.osi`, e.g. `out/<sensor>.perception.osi`) of an `.osi` SensorData trace.
    #[arg(long, value_name = "TRACE")]
    pub perception: Option<PathBuf>,
    /// Write only the CSV tables.
    #[arg(long)]
    pub no_report: bool,
}

/// Raw messages with their time (s, when the trace has one).
type RawMessages = Box<dyn Iterator<Item = Result<(Vec<u8>, Option<f64>)>>>;

/// Raw messages of one trace stream with what names them in errors.
struct Stream {
    /// `file` or `file, channel `topic``.
    what: String,
    messages: RawMessages,
    index: usize,
}

impl Stream {
    fn osi(path: &Path) -> Result<Stream> {
        let reader = OsiTraceReader::open(path)?;
        Ok(Stream {
            what: path.display().to_string(),
            messages: Box::new(reader.map(|r| r.map(|b| (b, None)).map_err(anyhow::Error::from))),
            index: 0,
        })
    }

    fn mcap(reader: &McapTraceReader, id: u16, topic: &str) -> Result<Stream> {
        let messages = reader.messages(id)?;
        Ok(Stream {
            what: format!("{}, channel `{topic}`", reader.path().display()),
            messages: Box::new(messages.map(|m| {
                m.map(|m| (m.data, Some(m.publish_time as f64 * 1e-9)))
                    .map_err(anyhow::Error::from)
            })),
            index: 0,
        })
    }

    /// The next message decoded as `M` (`None`: end of the stream).
    fn next<M: Message + Default>(&mut self, type_name: &str) -> Result<Option<(M, Option<f64>)>> {
        let i = self.index;
        let Some(item) = self.messages.next() else {
            return Ok(None);
        };
        let (bytes, time) = item.with_context(|| format!("{}: message {i}", self.what))?;
        self.index += 1;
        let m = M::decode(bytes.as_slice()).with_context(|| {
            format!(
                "{}: message {i} is not a valid {type_name} (is this a {type_name} trace?)",
                self.what
            )
        })?;
        Ok(Some((m, time)))
    }
}

/// One sensor of the trace.
struct ViewSensor {
    name: String,
    sd: Stream,
    pd: Option<Stream>,
    sv: Option<Stream>,
}

/// The sensor name of an mcap topic `<sensor>.<variable>` (a topic without a dot: itself).
fn topic_sensor(topic: &str) -> &str {
    topic.rsplit_once('.').map_or(topic, |(s, _)| s)
}

fn is_mcap(path: &Path) -> Result<bool> {
    Ok(osiris_proto::trace::mcap::is_mcap_file(path)?)
}

/// An auxiliary stream (`--perception`, `--sensor-view`) for `sensor`.
fn aux_stream(path: &Path, schema: &str, sensor: &str, several: bool) -> Result<Stream> {
    if !path.is_file() {
        bail!("{}: no such file", path.display());
    }
    if is_mcap(path)? {
        let reader = McapTraceReader::open(path)?;
        let matching: Vec<_> = reader
            .channels()
            .iter()
            .filter(|c| c.schema_name.as_deref() == Some(schema))
            .collect();
        let ch = match matching
            .iter()
            .find(|c| topic_sensor(&c.topic) == sensor)
            .or(if matching.len() == 1 {
                matching.first()
            } else {
                None
            }) {
            Some(c) => (*c).clone(),
            None => bail!(
                "{}: no {schema} channel for sensor `{sensor}` (channels: {})",
                path.display(),
                reader
                    .channels()
                    .iter()
                    .map(|c| c.topic.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        };
        return Stream::mcap(&reader, ch.id, &ch.topic);
    }
    if several {
        bail!(
            "{}: one .osi trace cannot serve several sensors; choose one with --channel",
            path.display()
        );
    }
    Stream::osi(path)
}

/// The sensor name of an `.osi` trace: the custom part of a standard trace name
/// (`<UTC>_sd_380_014_<frames>_<name>.osi`), else the file stem.
fn osi_sensor_name(path: &Path) -> Result<String> {
    let stem = path
        .file_stem()
        .map_or("sensor".to_owned(), |s| s.to_string_lossy().into_owned());
    if let Some((type_code, _, _)) = crate::trace::parse_trace_file_name(path) {
        if type_code != "sd" {
            bail!(
                "{}: the file name says this is a `{type_code}` trace, not SensorData (`sd`)",
                path.display()
            );
        }
        if let Some(custom) = stem.splitn(6, '_').nth(5) {
            return Ok(custom.to_owned());
        }
    }
    Ok(stem)
}

/// `osiris view`: writes the report and the KPI tables; returns their paths.
pub fn view(args: &ViewArgs) -> Result<super::ReportPaths> {
    let path = &args.trace;
    if !path.is_file() {
        bail!("{}: no such file", path.display());
    }
    let mut sensors = Vec::new();
    if is_mcap(path)? {
        let reader = McapTraceReader::open(path)?;
        let channels: Vec<_> = match &args.channel {
            Some(topic) => vec![
                reader
                    .select_channel(SENSOR_DATA_SCHEMA, Some(topic))?
                    .clone(),
            ],
            None => reader
                .channels()
                .iter()
                .filter(|c| c.schema_name.as_deref() == Some(SENSOR_DATA_SCHEMA))
                .cloned()
                .collect(),
        };
        if channels.is_empty() {
            bail!(
                "{}: no SensorData channel (channels: {})",
                path.display(),
                reader
                    .channels()
                    .iter()
                    .map(|c| c.describe())
                    .collect::<Vec<_>>()
                    .join("; ")
            );
        }
        let several = channels.len() > 1;
        for ch in channels {
            let name = topic_sensor(&ch.topic).to_owned();
            let paired = |schema: &str| -> Result<Option<Stream>> {
                reader
                    .channels()
                    .iter()
                    .find(|c| {
                        c.schema_name.as_deref() == Some(schema) && topic_sensor(&c.topic) == name
                    })
                    .map(|c| Stream::mcap(&reader, c.id, &c.topic))
                    .transpose()
            };
            let pd = match &args.perception {
                Some(p) => Some(aux_stream(p, PERCEPTION_DATA_SCHEMA, &name, several)?),
                None => paired(PERCEPTION_DATA_SCHEMA)?,
            };
            let sv = match &args.sensor_view {
                Some(p) => Some(aux_stream(p, SENSOR_VIEW_SCHEMA, &name, several)?),
                None => paired(SENSOR_VIEW_SCHEMA)?,
            };
            sensors.push(ViewSensor {
                sd: Stream::mcap(&reader, ch.id, &ch.topic)?,
                name,
                pd,
                sv,
            });
        }
    } else {
        if let Some(c) = &args.channel {
            bail!(
                "{}: --channel {c} is for .mcap traces; this is an .osi trace (one message stream)",
                path.display()
            );
        }
        let name = osi_sensor_name(path)?;
        let pd = args
            .perception
            .as_deref()
            .map(|p| aux_stream(p, PERCEPTION_DATA_SCHEMA, &name, false))
            .transpose()?;
        let sv = args
            .sensor_view
            .as_deref()
            .map(|p| aux_stream(p, SENSOR_VIEW_SCHEMA, &name, false))
            .transpose()?;
        sensors.push(ViewSensor {
            sd: Stream::osi(path)?,
            name,
            pd,
            sv,
        });
    }

    let mut report = ReportBuilder::new(format!("osiris view {}", path.display()));
    for s in &mut sensors {
        report.add_sensor(&s.name, None);
        let mut index = 0usize;
        while let Some((sd, time)) = s.sd.next::<osi3::SensorData>("SensorData")? {
            let pd = match s.pd.as_mut() {
                Some(p) => p
                    .next::<perception::PerceptionData>("PerceptionData")?
                    .map(|m| m.0),
                None => None,
            };
            let sv_trace = match s.sv.as_mut() {
                Some(v) => v.next::<osi3::SensorView>("SensorView")?.map(|m| m.0),
                None => None,
            };
            let sv = sd.sensor_view.first().or(sv_trace.as_ref());
            report.push(ReportStep {
                sensor: &s.name,
                time_s: time.unwrap_or(index as f64),
                sensor_view: sv,
                sensor_data: &sd,
                perception: pd.as_ref(),
                step_wall_ms: None,
            });
            index += 1;
        }
        if index == 0 {
            bail!("{}: no SensorData messages", s.sd.what);
        }
    }
    report.write(&args.out, !args.no_report)
}
