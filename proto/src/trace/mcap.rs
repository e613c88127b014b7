//! OSI multi-channel trace files (`.mcap`), as the OSI 3.8.0 trace file specification
//! (`doc/architecture/trace_file_formats.adoc`, "Multi channel trace file format") defines them:
//!
//! * an indexed MCAP file (format `0x30`): every message in a chunk record (zstd-compressed here), chunk
//!   indexes, schemas, channels and statistics in the summary section;
//! * one metadata record `net.asam.osi.trace` with `version` (the trace file format's OSI release,
//!   [`TRACE_FORMAT_VERSION`]), `min_osi_version` / `max_osi_version` (over the OSI channels),
//!   `min_protobuf_version` / `max_protobuf_version` (the protobuf implementation, prost:
//!   [`crate::PROTOBUF_VERSION`]) and the recommended `creation_time` (plus what the caller adds, e.g.
//!   `description`, `data_sources`);
//! * one schema record per message type: `name` = the full protobuf name (`osi3.SensorView`), `encoding`
//!   `protobuf`, `data` = a serialized `FileDescriptorSet` of the file that defines the type and its
//!   imports ([`schema_descriptor_set`], from the descriptors compiled into this crate);
//! * one channel per message stream, `message_encoding` `protobuf`; OSI channels (schema `osi3.*`) carry
//!   `net.asam.osi.trace.channel.osi_version` (the `version` of the channel's first message, else 3.8.0),
//!   `net.asam.osi.trace.channel.protobuf_version` and, when given, `net.asam.osi.trace.channel.description`;
//!   other channels (e.g. `osiris.perception.PerceptionData`) use `osiris.*` keys instead, because keys
//!   starting with `net.asam.osi` are reserved for OSI channels;
//! * messages: `sequence` 0 (OSMP has no message counter), `publish_time` = `log_time` = the message's own
//!   `timestamp` in ns ([`message_timestamp_ns`]), or the time it was handed to the writer when it has none.
//!
//! [`McapTraceWriter`] writes such files, [`McapTraceReader`] lists the channels and metadata of any MCAP
//! file and streams one channel's messages (bounded memory: one chunk at a time).

use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::{BufReader, BufWriter, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::time::SystemTime;

use prost::Message as _;

use super::{TraceError, TraceName, rename_trace};

/// Name of the metadata record that identifies an OSI multi-channel trace file.
pub const OSI_TRACE_METADATA_NAME: &str = "net.asam.osi.trace";
/// Channel metadata key: the OSI version of the channel's data.
pub const CHANNEL_OSI_VERSION_KEY: &str = "net.asam.osi.trace.channel.osi_version";
/// Channel metadata key: the protobuf implementation version of the channel's data.
pub const CHANNEL_PROTOBUF_VERSION_KEY: &str = "net.asam.osi.trace.channel.protobuf_version";
/// Channel metadata key (recommended): a human-readable description.
pub const CHANNEL_DESCRIPTION_KEY: &str = "net.asam.osi.trace.channel.description";
/// Metadata key of non-OSI channels written here: a human-readable description.
pub const OSIRIS_CHANNEL_DESCRIPTION_KEY: &str = "osiris.channel.description";
/// Metadata key of PerceptionData channels: the extension message version.
pub const OSIRIS_EXTENSION_VERSION_KEY: &str = "osiris.perception.extension_version";
/// The OSI release whose trace file format this writer follows (`version` of `net.asam.osi.trace`).
pub const TRACE_FORMAT_VERSION: &str = "3.8.0";
/// Schema and message encoding of every channel written here.
pub const PROTOBUF_ENCODING: &str = "protobuf";
/// Full protobuf name of the perception extension message.
pub const PERCEPTION_DATA_SCHEMA: &str = "osiris.perception.PerceptionData";

/// The MCAP magic, the first 8 bytes of every `.mcap` file.
pub const MCAP_MAGIC: &[u8] = ::mcap::MAGIC;

/// Largest metadata record [`McapTraceReader::open`] reads (a corrupt index must not allocate gigabytes).
const MAX_METADATA_LEN: u64 = 64 << 20;

/// Whether the file at `path` starts with the MCAP magic (`false` for a shorter file).
pub fn is_mcap_file(path: impl AsRef<Path>) -> Result<bool, TraceError> {
    let path = path.as_ref();
    let mut file = File::open(path).map_err(|source| TraceError::Io {
        action: "open",
        file: path.display().to_string(),
        source,
    })?;
    let mut head = [0u8; 8];
    let mut got = 0;
    while got < head.len() {
        match file.read(&mut head[got..]) {
            Ok(0) => break,
            Ok(n) => got += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(source) => {
                return Err(TraceError::Io {
                    action: "read",
                    file: path.display().to_string(),
                    source,
                });
            }
        }
    }
    Ok(got == head.len() && head == MCAP_MAGIC)
}

/// A serialized `google.protobuf.FileDescriptorSet` for the message `full_name` (e.g. `osi3.SensorView`):
/// the file that defines it and every file it imports, dependencies first, without source info — what
/// `protoc --include_imports --descriptor_set_out` writes. `None` if no compiled file defines the type.
pub fn schema_descriptor_set(full_name: &str) -> Option<Vec<u8>> {
    let all = prost_types::FileDescriptorSet::decode(crate::FILE_DESCRIPTOR_SET).ok()?;
    let by_name: HashMap<&str, &prost_types::FileDescriptorProto> =
        all.file.iter().map(|f| (f.name(), f)).collect();
    let (package, message) = full_name.rsplit_once('.').unwrap_or(("", full_name));
    let defining = all
        .file
        .iter()
        .find(|f| f.package() == package && f.message_type.iter().any(|m| m.name() == message))?;
    fn visit<'a>(
        f: &'a prost_types::FileDescriptorProto,
        by_name: &HashMap<&str, &'a prost_types::FileDescriptorProto>,
        out: &mut Vec<&'a prost_types::FileDescriptorProto>,
    ) {
        if out.iter().any(|o| o.name() == f.name()) {
            return;
        }
        for dep in &f.dependency {
            if let Some(d) = by_name.get(dep.as_str()) {
                visit(d, by_name, out);
            }
        }
        out.push(f);
    }
    let mut files = Vec::new();
    visit(defining, &by_name, &mut files);
    let set = prost_types::FileDescriptorSet {
        file: files
            .into_iter()
            .map(|f| prost_types::FileDescriptorProto {
                source_code_info: None,
                ..f.clone()
            })
            .collect(),
    };
    Some(set.encode_to_vec())
}

/// Field 1 (`version`) of an OSI top-level message.
#[derive(Clone, PartialEq, prost::Message)]
struct VersionField {
    #[prost(message, optional, tag = "1")]
    version: Option<crate::osi3::InterfaceVersion>,
}

/// A message's `timestamp` at field 2 (OSI top-level messages).
#[derive(Clone, PartialEq, prost::Message)]
struct TimestampAt2 {
    #[prost(message, optional, tag = "2")]
    timestamp: Option<crate::osi3::Timestamp>,
}

/// A message's `timestamp` at field 3 (`osiris.perception.PerceptionData`).
#[derive(Clone, PartialEq, prost::Message)]
struct TimestampAt3 {
    #[prost(message, optional, tag = "3")]
    timestamp: Option<crate::osi3::Timestamp>,
}

/// The `timestamp` of an encoded message of type `schema_name` in ns since the OSI epoch, for the types
/// whose timestamp field is known here (`osi3.SensorView`, `osi3.SensorData`, `osi3.GroundTruth`: field 2;
/// `osiris.perception.PerceptionData`: field 3). `Ok(None)`: another type, or no timestamp; an error for
/// bytes that do not decode or a negative time (OSI timestamps are >= 0).
pub fn message_timestamp_ns(schema_name: &str, bytes: &[u8]) -> Result<Option<u64>, String> {
    let ts = match schema_name {
        "osi3.SensorView" | "osi3.SensorData" | "osi3.GroundTruth" => {
            TimestampAt2::decode(bytes)
                .map_err(|e| format!("cannot decode the {schema_name}: {e}"))?
                .timestamp
        }
        PERCEPTION_DATA_SCHEMA => {
            TimestampAt3::decode(bytes)
                .map_err(|e| format!("cannot decode the {schema_name}: {e}"))?
                .timestamp
        }
        _ => None,
    };
    let Some(ts) = ts else { return Ok(None) };
    let ns = crate::timestamp_to_nanos(&ts);
    u64::try_from(ns).map(Some).map_err(|_| {
        format!(
            "timestamp {} s {} ns is negative (OSI timestamps are >= 0)",
            ts.seconds.unwrap_or(0),
            ts.nanos.unwrap_or(0)
        )
    })
}

/// `major.minor.patch` of an OSI top-level message's `version` field, if it has a non-zero one.
fn message_osi_version(bytes: &[u8]) -> Option<String> {
    let v = VersionField::decode(bytes).ok()?.version?;
    let (a, b, c) = (
        v.version_major.unwrap_or(0),
        v.version_minor.unwrap_or(0),
        v.version_patch.unwrap_or(0),
    );
    ((a, b, c) != (0, 0, 0)).then(|| format!("{a}.{b}.{c}"))
}

/// `major.minor.patch` as numbers for ordering (unparsable parts count as 0).
fn version_key(v: &str) -> (u64, u64, u64) {
    let mut it = v.split('.').map(|p| p.parse::<u64>().unwrap_or(0));
    (
        it.next().unwrap_or(0),
        it.next().unwrap_or(0),
        it.next().unwrap_or(0),
    )
}

/// ISO 8601 UTC date-time with seconds (`2021-08-18T15:05:42Z`), as the `dateTimeStamp` of the spec.
pub fn format_date_time_utc(t: SystemTime) -> Option<String> {
    let basic = super::format_timestamp_utc(t)?; // 20210818T150542Z
    let b = basic.as_bytes();
    let s = |r: std::ops::Range<usize>| std::str::from_utf8(&b[r]).unwrap_or("00");
    Some(format!(
        "{}-{}-{}T{}:{}:{}Z",
        s(0..4),
        s(4..6),
        s(6..8),
        s(9..11),
        s(11..13),
        s(13..15)
    ))
}

/// A channel of a [`McapTraceWriter`] (returned by [`McapTraceWriter::add_channel`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ChannelHandle(usize);

#[derive(Debug)]
struct WriterChannel {
    topic: String,
    schema_name: String,
    description: Option<String>,
    /// The MCAP channel id, once registered (at the first message, or at `finish`).
    id: Option<u16>,
    messages: u64,
    osi_version: Option<String>,
}

impl WriterChannel {
    fn is_osi(&self) -> bool {
        self.schema_name.starts_with("osi3.")
    }
}

/// Writes an OSI multi-channel trace (see the module documentation).
///
/// Channels are declared with [`McapTraceWriter::add_channel`] and registered in the file at their first
/// message (an OSI channel's `osi_version` is that message's `version`), or at
/// [`McapTraceWriter::finish`] if they stay empty. The `net.asam.osi.trace` record is written by `finish`,
/// when the OSI versions of all channels are known.
pub struct McapTraceWriter<W: Write + Seek> {
    inner: ::mcap::Writer<W>,
    name: String,
    schemas: HashMap<String, u16>,
    channels: Vec<WriterChannel>,
    file_metadata: BTreeMap<String, String>,
    /// Where [`McapTraceWriter::create_in`] writes, and the name it renames to.
    rename: Option<(PathBuf, PathBuf, TraceName)>,
}

impl<W: Write + Seek> std::fmt::Debug for McapTraceWriter<W> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("McapTraceWriter")
            .field("name", &self.name)
            .field("channels", &self.channels)
            .finish_non_exhaustive()
    }
}

impl McapTraceWriter<BufWriter<File>> {
    /// Creates (truncates) the file at `path`.
    pub fn create(path: impl AsRef<Path>) -> Result<Self, TraceError> {
        let path = path.as_ref();
        let file = File::create(path).map_err(|source| TraceError::Io {
            action: "create",
            file: path.display().to_string(),
            source,
        })?;
        McapTraceWriter::new(BufWriter::new(file), path.display().to_string())
    }

    /// Creates `<dir>/<partial name>` ([`TraceName::partial_file_name`]); [`McapTraceWriter::finish_named`]
    /// renames it to the standard `multi` name with the largest channel's message count.
    pub fn create_in(dir: impl AsRef<Path>, name: TraceName) -> Result<Self, TraceError> {
        let dir = dir.as_ref().to_owned();
        let partial = dir.join(name.partial_file_name("mcap")?);
        let mut w = Self::create(&partial)?;
        w.rename = Some((dir, partial, name));
        Ok(w)
    }

    /// Finishes the file and, if it was made by [`McapTraceWriter::create_in`], renames it to its standard
    /// name; returns the final path.
    pub fn finish_named(mut self) -> Result<PathBuf, TraceError> {
        let frames = self.max_messages();
        let rename = self.rename.take();
        let name = self.name.clone();
        self.finish()?;
        match rename {
            Some((dir, partial, trace_name)) => {
                let path = dir.join(trace_name.file_name(frames, "mcap")?);
                rename_trace(&partial, &path)?;
                Ok(path)
            }
            None => Ok(PathBuf::from(name)),
        }
    }
}

impl<W: Write + Seek> McapTraceWriter<W> {
    /// Wraps a writer, named `name` in errors.
    pub fn new(inner: W, name: String) -> Result<Self, TraceError> {
        let options = ::mcap::WriteOptions::new()
            .compression(Some(::mcap::Compression::Zstd))
            .compression_threads(0)
            .profile("")
            .library(format!(
                "osiris {} (mcap-rust {})",
                env!("CARGO_PKG_VERSION"),
                ::mcap::VERSION
            ));
        let inner = options.create(inner).map_err(|source| TraceError::Mcap {
            file: name.clone(),
            action: "writing the header",
            source,
        })?;
        let mut file_metadata = BTreeMap::new();
        if let Some(t) = format_date_time_utc(SystemTime::now()) {
            file_metadata.insert("creation_time".to_owned(), t);
        }
        Ok(McapTraceWriter {
            inner,
            name,
            schemas: HashMap::new(),
            channels: Vec::new(),
            file_metadata,
            rename: None,
        })
    }

    /// Sets an entry of the `net.asam.osi.trace` record, e.g. `description`, `data_sources`, `zero_time`
    /// (the mandatory version entries are computed by [`McapTraceWriter::finish`] and cannot be set).
    pub fn set_file_metadata(&mut self, key: &str, value: &str) -> Result<(), TraceError> {
        if [
            "version",
            "min_osi_version",
            "max_osi_version",
            "min_protobuf_version",
            "max_protobuf_version",
        ]
        .contains(&key)
        {
            return Err(TraceError::InvalidMcap {
                file: self.name.clone(),
                reason: format!("`{key}` of {OSI_TRACE_METADATA_NAME} is computed by the writer"),
            });
        }
        self.file_metadata.insert(key.to_owned(), value.to_owned());
        Ok(())
    }

    /// Declares a channel `topic` of protobuf messages of type `schema_name` (e.g. `osi3.SensorData`, or
    /// [`PERCEPTION_DATA_SCHEMA`]); the type must be one compiled into this crate. Topics are unique.
    pub fn add_channel(
        &mut self,
        topic: &str,
        schema_name: &str,
        description: Option<&str>,
    ) -> Result<ChannelHandle, TraceError> {
        if self.channels.iter().any(|c| c.topic == topic) {
            return Err(TraceError::InvalidMcap {
                file: self.name.clone(),
                reason: format!("channel topic `{topic}` is used twice (topics are unique)"),
            });
        }
        if schema_descriptor_set(schema_name).is_none() {
            return Err(TraceError::InvalidMcap {
                file: self.name.clone(),
                reason: format!(
                    "channel `{topic}`: no compiled protobuf type `{schema_name}` (expected e.g. \
                     osi3.SensorView, osi3.SensorData, {PERCEPTION_DATA_SCHEMA})"
                ),
            });
        }
        self.channels.push(WriterChannel {
            topic: topic.to_owned(),
            schema_name: schema_name.to_owned(),
            description: description.map(str::to_owned),
            id: None,
            messages: 0,
            osi_version: None,
        });
        Ok(ChannelHandle(self.channels.len() - 1))
    }

    /// Messages written to `channel` so far.
    pub fn message_count(&self, channel: ChannelHandle) -> u64 {
        self.channels.get(channel.0).map_or(0, |c| c.messages)
    }

    /// The largest message count of any channel (the frames field of the `multi` file name).
    pub fn max_messages(&self) -> u64 {
        self.channels.iter().map(|c| c.messages).max().unwrap_or(0)
    }

    fn mcap_err(&self, action: &'static str) -> impl FnOnce(::mcap::McapError) -> TraceError {
        let file = self.name.clone();
        move |source| TraceError::Mcap {
            file,
            action,
            source,
        }
    }

    /// Registers schema and channel `index` in the file (once).
    fn register(&mut self, index: usize, first_message: Option<&[u8]>) -> Result<u16, TraceError> {
        if let Some(id) = self.channels[index].id {
            return Ok(id);
        }
        let schema_name = self.channels[index].schema_name.clone();
        let schema_id = match self.schemas.get(&schema_name) {
            Some(id) => *id,
            None => {
                let data = schema_descriptor_set(&schema_name).unwrap_or_default();
                let id = self
                    .inner
                    .add_schema(&schema_name, PROTOBUF_ENCODING, &data)
                    .map_err(self.mcap_err("writing a schema record"))?;
                self.schemas.insert(schema_name.clone(), id);
                id
            }
        };
        let ch = &self.channels[index];
        let mut metadata = BTreeMap::new();
        if ch.is_osi() {
            let osi_version = first_message
                .and_then(message_osi_version)
                .unwrap_or_else(|| {
                    let (a, b, c) = crate::OSI_VERSION;
                    format!("{a}.{b}.{c}")
                });
            metadata.insert(CHANNEL_OSI_VERSION_KEY.to_owned(), osi_version.clone());
            metadata.insert(
                CHANNEL_PROTOBUF_VERSION_KEY.to_owned(),
                crate::PROTOBUF_VERSION.to_owned(),
            );
            if let Some(d) = &ch.description {
                metadata.insert(CHANNEL_DESCRIPTION_KEY.to_owned(), d.clone());
            }
            self.channels[index].osi_version = Some(osi_version);
        } else {
            if let Some(d) = &ch.description {
                metadata.insert(OSIRIS_CHANNEL_DESCRIPTION_KEY.to_owned(), d.clone());
            }
            if ch.schema_name == PERCEPTION_DATA_SCHEMA {
                metadata.insert(
                    OSIRIS_EXTENSION_VERSION_KEY.to_owned(),
                    crate::PERCEPTION_EXTENSION_VERSION.to_owned(),
                );
            }
        }
        let topic = self.channels[index].topic.clone();
        let id = self
            .inner
            .add_channel(schema_id, &topic, PROTOBUF_ENCODING, &metadata)
            .map_err(self.mcap_err("writing a channel record"))?;
        self.channels[index].id = Some(id);
        Ok(id)
    }

    /// Writes one encoded message to `channel`. `enqueue_time_ns` is used for `publish_time` and `log_time`
    /// only when the message has no timestamp of its own ([`message_timestamp_ns`]).
    pub fn write(
        &mut self,
        channel: ChannelHandle,
        bytes: &[u8],
        enqueue_time_ns: u64,
    ) -> Result<(), TraceError> {
        let Some(ch) = self.channels.get(channel.0) else {
            return Err(TraceError::InvalidMcap {
                file: self.name.clone(),
                reason: format!("no channel {}", channel.0),
            });
        };
        let time = message_timestamp_ns(&ch.schema_name, bytes)
            .map_err(|reason| TraceError::InvalidMcap {
                file: self.name.clone(),
                reason: format!("channel `{}`, message {}: {reason}", ch.topic, ch.messages),
            })?
            .unwrap_or(enqueue_time_ns);
        let id = self.register(channel.0, Some(bytes))?;
        let header = ::mcap::records::MessageHeader {
            channel_id: id,
            sequence: 0,
            log_time: time,
            publish_time: time,
        };
        self.inner
            .write_to_known_channel(&header, bytes)
            .map_err(self.mcap_err("writing a message"))?;
        self.channels[channel.0].messages += 1;
        Ok(())
    }

    /// Registers the channels that got no message, writes the `net.asam.osi.trace` metadata record and the
    /// summary section, and flushes; returns the underlying writer.
    pub fn finish(mut self) -> Result<W, TraceError> {
        for i in 0..self.channels.len() {
            self.register(i, None)?;
        }
        let mut versions: Vec<&str> = self
            .channels
            .iter()
            .filter_map(|c| c.osi_version.as_deref())
            .collect();
        versions.sort_by_key(|v| version_key(v));
        let (a, b, c) = crate::OSI_VERSION;
        let default = format!("{a}.{b}.{c}");
        let mut metadata = self.file_metadata.clone();
        for (key, value) in [
            ("version", TRACE_FORMAT_VERSION),
            (
                "min_osi_version",
                versions.first().copied().unwrap_or(&default),
            ),
            (
                "max_osi_version",
                versions.last().copied().unwrap_or(&default),
            ),
            ("min_protobuf_version", crate::PROTOBUF_VERSION),
            ("max_protobuf_version", crate::PROTOBUF_VERSION),
        ] {
            metadata.insert(key.to_owned(), value.to_owned());
        }
        self.inner
            .write_metadata(&::mcap::records::Metadata {
                name: OSI_TRACE_METADATA_NAME.to_owned(),
                metadata,
            })
            .map_err(self.mcap_err("writing the net.asam.osi.trace metadata"))?;
        self.inner
            .finish()
            .map_err(self.mcap_err("writing the summary"))?;
        let mut w = self.inner.into_inner();
        w.flush().map_err(|source| TraceError::Io {
            action: "flush",
            file: self.name.clone(),
            source,
        })?;
        Ok(w)
    }
}

/// A channel of an MCAP file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct McapChannel {
    pub id: u16,
    pub topic: String,
    /// The schema's name (`osi3.SensorView`), `None` for a schemaless channel.
    pub schema_name: Option<String>,
    /// The schema's encoding (`protobuf`).
    pub schema_encoding: Option<String>,
    pub message_encoding: String,
    pub metadata: BTreeMap<String, String>,
    /// From the statistics record, if the file has one.
    pub message_count: Option<u64>,
}

impl McapChannel {
    /// `topic (schema)` for messages.
    pub fn describe(&self) -> String {
        format!(
            "{} ({})",
            self.topic,
            self.schema_name.as_deref().unwrap_or("no schema")
        )
    }
}

/// One message of a channel.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct McapMessage {
    pub sequence: u32,
    pub log_time: u64,
    pub publish_time: u64,
    pub data: Vec<u8>,
}

/// Reads an MCAP file: its channels and metadata records at [`McapTraceReader::open`] (from the summary
/// section, or by reading the file once when it has none), one channel's messages on demand
/// ([`McapTraceReader::messages`], in file order).
#[derive(Debug, Clone)]
pub struct McapTraceReader {
    path: PathBuf,
    channels: Vec<McapChannel>,
    metadata: Vec<(String, BTreeMap<String, String>)>,
}

impl McapTraceReader {
    /// Opens the MCAP file at `path` and reads its channels and metadata.
    pub fn open(path: impl AsRef<Path>) -> Result<Self, TraceError> {
        let path = path.as_ref().to_owned();
        let name = path.display().to_string();
        if !is_mcap_file(&path)? {
            return Err(TraceError::InvalidMcap {
                file: name,
                reason: "not an MCAP file (no MCAP magic at the start)".to_owned(),
            });
        }
        let io = |action| {
            let file = name.clone();
            move |source| TraceError::Io {
                action,
                file,
                source,
            }
        };
        let mcap_err = |action| {
            let file = name.clone();
            move |source| TraceError::Mcap {
                file,
                action,
                source,
            }
        };
        let mut file = File::open(&path).map_err(io("open"))?;
        let size = file.metadata().map_err(io("stat"))?.len();
        let mut reader = ::mcap::sans_io::SummaryReader::new_with_options(
            ::mcap::sans_io::summary_reader::SummaryReaderOptions::default()
                .with_file_size(size)
                .with_record_length_limit(MAX_METADATA_LEN as usize),
        );
        while let Some(event) = reader.next_event() {
            match event.map_err(mcap_err("reading the summary section"))? {
                ::mcap::sans_io::SummaryReadEvent::ReadRequest(n) => {
                    let got = file.read(reader.insert(n)).map_err(io("read"))?;
                    reader.notify_read(got);
                }
                ::mcap::sans_io::SummaryReadEvent::SeekRequest(to) => {
                    let pos = file.seek(to).map_err(io("seek"))?;
                    reader.notify_seeked(pos);
                }
            }
        }
        let (channels, metadata) = match reader.finish() {
            Some(summary) => {
                let counts = summary.stats.as_ref().map(|s| &s.channel_message_counts);
                let mut channels: Vec<McapChannel> = summary
                    .channels
                    .values()
                    .map(|c| McapChannel {
                        id: c.id,
                        topic: c.topic.clone(),
                        schema_name: c.schema.as_ref().map(|s| s.name.clone()),
                        schema_encoding: c.schema.as_ref().map(|s| s.encoding.clone()),
                        message_encoding: c.message_encoding.clone(),
                        metadata: c.metadata.clone(),
                        message_count: counts.map(|m| m.get(&c.id).copied().unwrap_or(0)),
                    })
                    .collect();
                channels.sort_by_key(|c| c.id);
                let mut metadata = Vec::new();
                for index in &summary.metadata_indexes {
                    if index.length > MAX_METADATA_LEN
                        || index.offset.saturating_add(index.length) > size
                    {
                        return Err(TraceError::InvalidMcap {
                            file: name.clone(),
                            reason: format!(
                                "metadata index `{}` points outside the file or to a record over {MAX_METADATA_LEN} bytes",
                                index.name
                            ),
                        });
                    }
                    file.seek(SeekFrom::Start(index.offset))
                        .map_err(io("seek"))?;
                    let mut buf = vec![0u8; index.length as usize];
                    file.read_exact(&mut buf).map_err(io("read"))?;
                    let local = ::mcap::records::MetadataIndex {
                        offset: 0,
                        length: index.length,
                        name: index.name.clone(),
                    };
                    let m = ::mcap::read::metadata(&buf, &local)
                        .map_err(mcap_err("reading a metadata record"))?;
                    metadata.push((m.name, m.metadata));
                }
                (channels, metadata)
            }
            None => Self::scan(&path, &name)?,
        };
        Ok(McapTraceReader {
            path,
            channels,
            metadata,
        })
    }

    /// Channels and metadata of a file without a summary section: read through once.
    #[allow(clippy::type_complexity)]
    fn scan(
        path: &Path,
        name: &str,
    ) -> Result<(Vec<McapChannel>, Vec<(String, BTreeMap<String, String>)>), TraceError> {
        let file = File::open(path).map_err(|source| TraceError::Io {
            action: "open",
            file: name.to_owned(),
            source,
        })?;
        let mut source = BufReader::new(file);
        let mut reader = ::mcap::sans_io::LinearReader::new();
        let mut schemas: HashMap<u16, (String, String)> = HashMap::new();
        let mut channels: BTreeMap<u16, McapChannel> = BTreeMap::new();
        let mut counts: HashMap<u16, u64> = HashMap::new();
        let mut metadata = Vec::new();
        let err = |action| {
            let file = name.to_owned();
            move |source| TraceError::Mcap {
                file,
                action,
                source,
            }
        };
        while let Some(event) = reader.next_event() {
            match event.map_err(err("reading records"))? {
                ::mcap::sans_io::LinearReadEvent::ReadRequest(n) => {
                    let got = source
                        .read(reader.insert(n))
                        .map_err(|source| TraceError::Io {
                            action: "read",
                            file: name.to_owned(),
                            source,
                        })?;
                    reader.notify_read(got);
                }
                ::mcap::sans_io::LinearReadEvent::Record { opcode, data } => {
                    match ::mcap::parse_record(opcode, data).map_err(err("parsing a record"))? {
                        ::mcap::records::Record::Schema { header, .. } => {
                            schemas.insert(header.id, (header.name, header.encoding));
                        }
                        ::mcap::records::Record::Channel(c) => {
                            let schema = schemas.get(&c.schema_id);
                            channels.insert(
                                c.id,
                                McapChannel {
                                    id: c.id,
                                    topic: c.topic,
                                    schema_name: schema.map(|s| s.0.clone()),
                                    schema_encoding: schema.map(|s| s.1.clone()),
                                    message_encoding: c.message_encoding,
                                    metadata: c.metadata,
                                    message_count: None,
                                },
                            );
                        }
                        ::mcap::records::Record::Message { header, .. } => {
                            *counts.entry(header.channel_id).or_default() += 1;
                        }
                        ::mcap::records::Record::Metadata(m) => metadata.push((m.name, m.metadata)),
                        _ => {}
                    }
                }
            }
        }
        let channels = channels
            .into_values()
            .map(|mut c| {
                c.message_count = Some(counts.get(&c.id).copied().unwrap_or(0));
                c
            })
            .collect();
        Ok((channels, metadata))
    }

    /// The file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The channels, by id.
    pub fn channels(&self) -> &[McapChannel] {
        &self.channels
    }

    /// The metadata records (name, entries) in file order.
    pub fn metadata(&self) -> &[(String, BTreeMap<String, String>)] {
        &self.metadata
    }

    /// The entries of the `net.asam.osi.trace` record, if the file has one.
    pub fn osi_trace_metadata(&self) -> Option<&BTreeMap<String, String>> {
        self.metadata
            .iter()
            .find(|(n, _)| n == OSI_TRACE_METADATA_NAME)
            .map(|(_, m)| m)
    }

    /// The channel with this topic.
    pub fn channel(&self, topic: &str) -> Option<&McapChannel> {
        self.channels.iter().find(|c| c.topic == topic)
    }

    fn channel_error(&self, reason: String) -> TraceError {
        TraceError::Channel {
            file: self.path.display().to_string(),
            reason,
            available: self.channels.iter().map(McapChannel::describe).collect(),
        }
    }

    /// The channel of protobuf messages of type `schema_name` to read: the one named `topic` (which must
    /// have that type), or without a topic the only channel of that type. Errors list the channels.
    pub fn select_channel(
        &self,
        schema_name: &str,
        topic: Option<&str>,
    ) -> Result<&McapChannel, TraceError> {
        if let Some(topic) = topic {
            let ch = self
                .channel(topic)
                .ok_or_else(|| self.channel_error(format!("no channel `{topic}`")))?;
            if ch.schema_name.as_deref() != Some(schema_name)
                || ch.message_encoding != PROTOBUF_ENCODING
            {
                return Err(self.channel_error(format!(
                    "channel `{topic}` holds {} messages ({} encoding), expected {schema_name} (protobuf)",
                    ch.schema_name.as_deref().unwrap_or("schemaless"),
                    ch.message_encoding
                )));
            }
            return Ok(ch);
        }
        let matching: Vec<&McapChannel> = self
            .channels
            .iter()
            .filter(|c| {
                c.schema_name.as_deref() == Some(schema_name)
                    && c.message_encoding == PROTOBUF_ENCODING
            })
            .collect();
        match matching.as_slice() {
            [one] => Ok(one),
            [] => Err(self.channel_error(format!("no channel of {schema_name} messages"))),
            several => Err(self.channel_error(format!(
                "{} channels of {schema_name} messages ({}); choose one with --channel",
                several.len(),
                several
                    .iter()
                    .map(|c| c.topic.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ))),
        }
    }

    /// The messages of channel `channel_id`, in file order, read chunk by chunk.
    pub fn messages(
        &self,
        channel_id: u16,
    ) -> Result<impl Iterator<Item = Result<McapMessage, TraceError>> + use<>, TraceError> {
        let name = self.path.display().to_string();
        let file = File::open(&self.path).map_err(|source| TraceError::Io {
            action: "open",
            file: name.clone(),
            source,
        })?;
        let mut inner = ::mcap::io::MessageReader::new(BufReader::new(file));
        let mut done = false;
        Ok(std::iter::from_fn(move || {
            if done {
                return None;
            }
            loop {
                match inner.next()? {
                    Ok(m) if m.channel.id == channel_id => {
                        return Some(Ok(McapMessage {
                            sequence: m.sequence,
                            log_time: m.log_time,
                            publish_time: m.publish_time,
                            data: m.data.into_owned(),
                        }));
                    }
                    Ok(_) => {}
                    Err(source) => {
                        done = true;
                        return Some(Err(TraceError::Mcap {
                            file: name.clone(),
                            action: "reading messages",
                            source,
                        }));
                    }
                }
            }
        }))
    }

    /// The messages of the channel with this topic (see [`McapTraceReader::messages`]).
    pub fn topic_messages(
        &self,
        topic: &str,
    ) -> Result<impl Iterator<Item = Result<McapMessage, TraceError>> + use<>, TraceError> {
        let id = self
            .channel(topic)
            .ok_or_else(|| self.channel_error(format!("no channel `{topic}`")))?
            .id;
        self.messages(id)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::osi3;
    use std::io::Cursor;

    use crate::trace::sample_view as sv;

    #[test]
    fn schema_sets_hold_the_type_and_its_imports_only() {
        for (name, file, not) in [
            (
                "osi3.SensorView",
                "osi3/osi_sensorview.proto",
                "osiris/perception.proto",
            ),
            (
                "osi3.SensorData",
                "osi3/osi_sensordata.proto",
                "osiris/perception.proto",
            ),
            (
                PERCEPTION_DATA_SCHEMA,
                "osiris/perception.proto",
                "osi3/osi_sensordata.proto",
            ),
        ] {
            let set = prost_types::FileDescriptorSet::decode(
                schema_descriptor_set(name).unwrap().as_slice(),
            )
            .unwrap();
            let names: Vec<&str> = set.file.iter().map(|f| f.name()).collect();
            assert_eq!(names.last(), Some(&file), "{name}: {names:?}");
            assert!(!names.contains(&not), "{name}: {names:?}");
            assert!(
                names.contains(&"osi3/osi_common.proto"),
                "{name}: {names:?}"
            );
            // Dependencies come before their users.
            for (i, f) in set.file.iter().enumerate() {
                for d in &f.dependency {
                    let j = names.iter().position(|n| n == d).unwrap();
                    assert!(j < i, "{d} after {}", f.name());
                }
                assert!(f.source_code_info.is_none());
            }
        }
        assert!(schema_descriptor_set("osi3.NoSuchMessage").is_none());
    }

    #[test]
    fn timestamps_and_dates() {
        let bytes = sv(3).encode_to_vec();
        assert_eq!(
            message_timestamp_ns("osi3.SensorView", &bytes),
            Ok(Some(150_000_000))
        );
        assert_eq!(message_timestamp_ns("osi3.Other", &bytes), Ok(None));
        let neg = osi3::SensorData {
            timestamp: Some(crate::timestamp_from_seconds(-1.0)),
            ..Default::default()
        };
        assert!(
            message_timestamp_ns("osi3.SensorData", &neg.encode_to_vec())
                .unwrap_err()
                .contains("negative")
        );
        let t = std::time::UNIX_EPOCH + std::time::Duration::from_secs(1_629_299_142);
        assert_eq!(format_date_time_utc(t).unwrap(), "2021-08-18T15:05:42Z");
        assert!(version_key("3.10.0") > version_key("3.8.0"));
    }

    #[test]
    fn write_then_read_back() {
        let dir = tempfile::tempdir().unwrap();
        let name = TraceName {
            timestamp_utc: std::time::UNIX_EPOCH + std::time::Duration::from_secs(1_629_299_142),
            type_code: "multi".to_owned(),
            osi_version: "3.8.0".to_owned(),
            protobuf_version: "0.14".to_owned(),
            custom: "unit".to_owned(),
        };
        let mut w = McapTraceWriter::create_in(dir.path(), name).unwrap();
        w.set_file_metadata("description", "unit test").unwrap();
        assert!(w.set_file_metadata("version", "1").is_err());
        let a = w
            .add_channel("s.OSMPSensorViewIn", "osi3.SensorView", Some("input"))
            .unwrap();
        let b = w
            .add_channel("s.PerceptionDataOut", PERCEPTION_DATA_SCHEMA, None)
            .unwrap();
        let empty = w
            .add_channel("s.OSMPSensorDataOut", "osi3.SensorData", None)
            .unwrap();
        assert!(
            w.add_channel("s.OSMPSensorViewIn", "osi3.SensorView", None)
                .is_err()
        );
        assert!(w.add_channel("x", "osi3.Nope", None).is_err());
        for i in 0..5 {
            w.write(a, &sv(i).encode_to_vec(), 7).unwrap();
        }
        w.write(b, &[], 42).unwrap(); // no timestamp: the enqueue time
        assert_eq!((w.message_count(a), w.message_count(empty)), (5, 0));
        let path = w.finish_named().unwrap();
        assert_eq!(
            path.file_name().unwrap(),
            "20210818T150542Z_multi_380_014_5_unit.mcap"
        );
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);

        let r = McapTraceReader::open(&path).unwrap();
        let meta = r.osi_trace_metadata().unwrap();
        assert_eq!(meta["version"], "3.8.0");
        assert_eq!(meta["min_osi_version"], "3.8.0");
        assert_eq!(meta["max_osi_version"], "3.8.0");
        assert_eq!(meta["min_protobuf_version"], crate::PROTOBUF_VERSION);
        assert_eq!(meta["description"], "unit test");
        assert!(meta["creation_time"].ends_with('Z'));
        let ch = r.channel("s.OSMPSensorViewIn").unwrap();
        assert_eq!(ch.schema_name.as_deref(), Some("osi3.SensorView"));
        assert_eq!(ch.schema_encoding.as_deref(), Some("protobuf"));
        assert_eq!(ch.message_encoding, "protobuf");
        assert_eq!(ch.message_count, Some(5));
        assert_eq!(ch.metadata[CHANNEL_OSI_VERSION_KEY], "3.8.0");
        assert_eq!(ch.metadata[CHANNEL_DESCRIPTION_KEY], "input");
        let pd = r.channel("s.PerceptionDataOut").unwrap();
        assert!(pd.metadata.keys().all(|k| !k.starts_with("net.asam.osi")));
        assert_eq!(pd.metadata[OSIRIS_EXTENSION_VERSION_KEY], "1.0.0");
        assert_eq!(
            r.channel("s.OSMPSensorDataOut").unwrap().message_count,
            Some(0)
        );

        let msgs: Vec<McapMessage> = r
            .topic_messages("s.OSMPSensorViewIn")
            .unwrap()
            .collect::<Result<_, _>>()
            .unwrap();
        assert_eq!(msgs.len(), 5);
        for (i, m) in msgs.iter().enumerate() {
            assert_eq!(m.data, sv(i as u64).encode_to_vec());
            assert_eq!(m.log_time, i as u64 * 50_000_000);
            assert_eq!(m.publish_time, m.log_time);
        }
        let pd: Vec<_> = r
            .topic_messages("s.PerceptionDataOut")
            .unwrap()
            .collect::<Result<_, _>>()
            .unwrap();
        assert_eq!(pd[0].log_time, 42);

        // Channel selection.
        assert_eq!(
            r.select_channel("osi3.SensorView", None).unwrap().topic,
            "s.OSMPSensorViewIn"
        );
        let e = r
            .select_channel("osi3.SensorView", Some("s.PerceptionDataOut"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("expected osi3.SensorView"), "{e}");
        let e = r
            .select_channel("osi3.GroundTruth", None)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("no channel of osi3.GroundTruth")
                && e.contains("s.OSMPSensorViewIn (osi3.SensorView)"),
            "{e}"
        );
    }

    #[test]
    fn several_channels_of_a_type_need_a_topic() {
        let mut w = McapTraceWriter::new(Cursor::new(Vec::new()), "mem".to_owned()).unwrap();
        for t in ["a", "b"] {
            let c = w.add_channel(t, "osi3.SensorView", None).unwrap();
            w.write(c, &sv(1).encode_to_vec(), 0).unwrap();
        }
        let bytes = w.finish().unwrap().into_inner();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("two.mcap");
        std::fs::write(&path, &bytes).unwrap();
        let r = McapTraceReader::open(&path).unwrap();
        let e = r
            .select_channel("osi3.SensorView", None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("2 channels") && e.contains("--channel"), "{e}");
        assert_eq!(
            r.select_channel("osi3.SensorView", Some("b"))
                .unwrap()
                .topic,
            "b"
        );
    }

    #[test]
    fn not_an_mcap_file_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.mcap");
        std::fs::write(&path, [4u8, 0, 0, 0, 1, 2, 3, 4]).unwrap();
        assert!(!is_mcap_file(&path).unwrap());
        let e = McapTraceReader::open(&path).unwrap_err().to_string();
        assert!(
            e.contains("x.mcap") && e.contains("not an MCAP file"),
            "{e}"
        );
        // A truncated MCAP file names the file.
        let mut w = McapTraceWriter::new(Cursor::new(Vec::new()), "mem".to_owned()).unwrap();
        let c = w.add_channel("a", "osi3.SensorView", None).unwrap();
        w.write(c, &sv(1).encode_to_vec(), 0).unwrap();
        let bytes = w.finish().unwrap().into_inner();
        std::fs::write(&path, &bytes[..bytes.len() - 20]).unwrap();
        let e = match McapTraceReader::open(&path) {
            Err(e) => e.to_string(),
            Ok(r) => r
                .topic_messages("a")
                .unwrap()
                .find_map(Result::err)
                .expect("an error")
                .to_string(),
        };
        assert!(e.contains("x.mcap"), "{e}");
    }
}
