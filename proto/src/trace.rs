//! OSI `.osi` trace files: messages of one type, each preceded by a 4-byte little-endian unsigned length
//! (the prefix does not count itself); no header, no index.
//!
//! * [`OsiTraceWriter`] writes frames ([`OsiTraceWriter::write_message`], [`OsiTraceWriter::write_raw`]).
//! * [`OsiTraceReader`] iterates the raw frames as `Result<Vec<u8>, TraceError>`; a truncated length prefix or
//!   body is an error naming the file, the frame index and the byte offset of the frame.
//! * [`read_messages`] decodes a whole file into typed messages.
//! * [`trace_file_name`] builds the standard name
//!   `<timestamp>_<type>_<osi-version>_<protobuf-version>_<frames>_<custom-name>.osi`;
//!   [`NamedOsiTraceWriter`] writes under a temporary name and renames the file to its standard name with
//!   the number of messages it holds; [`mcap_trace_file_name`] is the `multi` name of a `.mcap` trace.
//! * [`mcap`]: OSI multi-channel `.mcap` traces ([`mcap::McapTraceWriter`], [`mcap::McapTraceReader`]).
//!
//! Frames are limited to [`MAX_FRAME_LEN`] (2 GiB − 1, the protobuf message limit): writers refuse longer
//! messages, readers refuse longer length prefixes before allocating (a corrupt prefix must not allocate
//! gigabytes).

use std::fs::File;
use std::io::{self, BufReader, BufWriter, Read, Write};
use std::path::Path;
use std::time::{SystemTime, UNIX_EPOCH};

pub mod mcap;

/// The largest frame readers and writers accept: `i32::MAX` bytes (protobuf messages are < 2 GiB).
pub const MAX_FRAME_LEN: u64 = i32::MAX as u64;

/// Trace type codes of the OSI file naming convention.
pub const TRACE_TYPE_CODES: &[&str] = &[
    "sv", "svc", "gt", "hvd", "sd", "tc", "tcu", "tu", "mr", "su", "multi",
];

/// Errors reading or writing `.osi` traces.
#[derive(Debug, thiserror::Error)]
pub enum TraceError {
    #[error("cannot {action} trace `{file}`: {source}")]
    Io {
        action: &'static str,
        file: String,
        #[source]
        source: io::Error,
    },
    #[error(
        "{file}: frame {frame} at byte offset {offset}: truncated length prefix ({got} of 4 bytes)"
    )]
    TruncatedPrefix {
        file: String,
        frame: u64,
        offset: u64,
        got: usize,
    },
    #[error(
        "{file}: frame {frame} at byte offset {offset}: truncated body ({got} of {expected} bytes)"
    )]
    TruncatedBody {
        file: String,
        frame: u64,
        offset: u64,
        got: u64,
        expected: u64,
    },
    #[error(
        "{file}: frame {frame} at byte offset {offset}: length prefix {len} exceeds the limit of {max} bytes \
         (corrupt file, or not an .osi trace)"
    )]
    FrameTooLarge {
        file: String,
        frame: u64,
        offset: u64,
        len: u64,
        max: u64,
    },
    #[error("{file}: frame {frame} at byte offset {offset}: cannot decode {message}: {source}")]
    Decode {
        file: String,
        frame: u64,
        offset: u64,
        message: &'static str,
        #[source]
        source: prost::DecodeError,
    },
    #[error("{file}: frame {frame} at byte offset {offset}: the {message} has no {field}")]
    MissingField {
        file: String,
        frame: u64,
        offset: u64,
        message: &'static str,
        field: &'static str,
    },
    #[error("{file}: a message of {len} bytes exceeds the .osi frame limit of {max} bytes")]
    MessageTooLarge { file: String, len: u64, max: u64 },
    #[error("invalid trace file name component: {0}")]
    InvalidName(String),
    #[error("{file}: {action}: {source}")]
    Mcap {
        file: String,
        action: &'static str,
        #[source]
        source: ::mcap::McapError,
    },
    #[error("{file}: {reason}")]
    InvalidMcap { file: String, reason: String },
    #[error("{file}: {reason}; channels: {}", list_or_none(.available))]
    Channel {
        file: String,
        reason: String,
        /// `topic (schema)` of every channel in the file.
        available: Vec<String>,
    },
}

fn list_or_none(items: &[String]) -> String {
    if items.is_empty() {
        "none".to_owned()
    } else {
        items.join(", ")
    }
}

/// Checks a frame length against [`MAX_FRAME_LEN`]; returns the 4-byte little-endian prefix.
pub fn frame_prefix(len: usize) -> Option<[u8; 4]> {
    let len = u64::try_from(len).ok().filter(|&l| l <= MAX_FRAME_LEN)?;
    Some((len as u32).to_le_bytes())
}

/// Writes length-prefixed frames.
#[derive(Debug)]
pub struct OsiTraceWriter<W: Write> {
    inner: W,
    name: String,
    frames: u64,
    bytes: u64,
}

impl OsiTraceWriter<BufWriter<File>> {
    /// Creates (truncates) the file at `path`.
    pub fn create(path: impl AsRef<Path>) -> Result<Self, TraceError> {
        let path = path.as_ref();
        let file = File::create(path).map_err(|source| TraceError::Io {
            action: "create",
            file: path.display().to_string(),
            source,
        })?;
        Ok(OsiTraceWriter::with_name(
            BufWriter::new(file),
            path.display().to_string(),
        ))
    }
}

impl<W: Write> OsiTraceWriter<W> {
    /// Wraps a writer (named `<writer>` in errors).
    pub fn new(inner: W) -> Self {
        Self::with_name(inner, "<writer>".to_owned())
    }

    /// Wraps a writer named `name` in errors.
    pub fn with_name(inner: W, name: String) -> Self {
        OsiTraceWriter {
            inner,
            name,
            frames: 0,
            bytes: 0,
        }
    }

    /// Encodes `message` and writes it as one frame.
    pub fn write_message(&mut self, message: &impl prost::Message) -> Result<(), TraceError> {
        self.write_raw(&message.encode_to_vec())
    }

    /// Writes already-encoded message bytes as one frame.
    pub fn write_raw(&mut self, bytes: &[u8]) -> Result<(), TraceError> {
        let prefix = frame_prefix(bytes.len()).ok_or_else(|| TraceError::MessageTooLarge {
            file: self.name.clone(),
            len: bytes.len() as u64,
            max: MAX_FRAME_LEN,
        })?;
        let io_err = |source| TraceError::Io {
            action: "write",
            file: self.name.clone(),
            source,
        };
        self.inner.write_all(&prefix).map_err(io_err)?;
        self.inner.write_all(bytes).map_err(io_err)?;
        self.frames += 1;
        self.bytes += 4 + bytes.len() as u64;
        Ok(())
    }

    /// Frames written so far.
    pub fn frames(&self) -> u64 {
        self.frames
    }

    /// Bytes written so far (prefixes included).
    pub fn bytes_written(&self) -> u64 {
        self.bytes
    }

    /// Flushes the underlying writer.
    pub fn flush(&mut self) -> Result<(), TraceError> {
        self.inner.flush().map_err(|source| TraceError::Io {
            action: "flush",
            file: self.name.clone(),
            source,
        })
    }

    /// Flushes and returns the underlying writer.
    pub fn finish(mut self) -> Result<W, TraceError> {
        self.flush()?;
        Ok(self.inner)
    }
}

/// Iterates the raw frames of a trace. After the first error it yields `None`.
#[derive(Debug)]
pub struct OsiTraceReader<R: Read> {
    inner: R,
    name: String,
    frame: u64,
    offset: u64,
    max_frame_len: u64,
    done: bool,
}

impl OsiTraceReader<BufReader<File>> {
    /// Opens the file at `path`.
    pub fn open(path: impl AsRef<Path>) -> Result<Self, TraceError> {
        let path = path.as_ref();
        let file = File::open(path).map_err(|source| TraceError::Io {
            action: "open",
            file: path.display().to_string(),
            source,
        })?;
        Ok(OsiTraceReader::with_name(
            BufReader::new(file),
            path.display().to_string(),
        ))
    }
}

impl<R: Read> OsiTraceReader<R> {
    /// Wraps a reader (named `<reader>` in errors).
    pub fn new(inner: R) -> Self {
        Self::with_name(inner, "<reader>".to_owned())
    }

    /// Wraps a reader named `name` in errors.
    pub fn with_name(inner: R, name: String) -> Self {
        OsiTraceReader {
            inner,
            name,
            frame: 0,
            offset: 0,
            max_frame_len: MAX_FRAME_LEN,
            done: false,
        }
    }

    /// Lowers the frame-length limit (default [`MAX_FRAME_LEN`]).
    pub fn with_max_frame_len(mut self, max: u64) -> Self {
        self.max_frame_len = max.min(MAX_FRAME_LEN);
        self
    }

    /// The name used in errors.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Index of the next frame (= frames read so far).
    pub fn frame_index(&self) -> u64 {
        self.frame
    }

    /// Byte offset of the next frame.
    pub fn offset(&self) -> u64 {
        self.offset
    }

    /// Reads into `buf` until it is full or EOF; returns the bytes read.
    fn fill(&mut self, buf: &mut [u8]) -> Result<usize, TraceError> {
        let mut got = 0;
        while got < buf.len() {
            match self.inner.read(&mut buf[got..]) {
                Ok(0) => break,
                Ok(n) => got += n,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(source) => {
                    return Err(TraceError::Io {
                        action: "read",
                        file: self.name.clone(),
                        source,
                    });
                }
            }
        }
        Ok(got)
    }

    fn read_frame(&mut self) -> Result<Option<Vec<u8>>, TraceError> {
        let mut prefix = [0u8; 4];
        let got = self.fill(&mut prefix)?;
        if got == 0 {
            return Ok(None);
        }
        if got < 4 {
            return Err(TraceError::TruncatedPrefix {
                file: self.name.clone(),
                frame: self.frame,
                offset: self.offset,
                got,
            });
        }
        let len = u64::from(u32::from_le_bytes(prefix));
        if len > self.max_frame_len {
            return Err(TraceError::FrameTooLarge {
                file: self.name.clone(),
                frame: self.frame,
                offset: self.offset,
                len,
                max: self.max_frame_len,
            });
        }
        // Grow with the data instead of trusting the prefix for the allocation.
        let mut body = Vec::with_capacity(len.min(1 << 20) as usize);
        let read = (&mut self.inner)
            .take(len)
            .read_to_end(&mut body)
            .map_err(|source| TraceError::Io {
                action: "read",
                file: self.name.clone(),
                source,
            })?;
        if (read as u64) < len {
            return Err(TraceError::TruncatedBody {
                file: self.name.clone(),
                frame: self.frame,
                offset: self.offset,
                got: read as u64,
                expected: len,
            });
        }
        self.frame += 1;
        self.offset += 4 + len;
        Ok(Some(body))
    }

    /// Decodes the remaining frames as `M`, stopping at the first error.
    pub fn messages<M: prost::Message + Default>(
        self,
    ) -> impl Iterator<Item = Result<M, TraceError>> {
        let mut reader = self;
        std::iter::from_fn(move || {
            let (frame, offset) = (reader.frame, reader.offset);
            let item = reader.next()?;
            Some(item.and_then(|bytes| {
                M::decode(bytes.as_slice()).map_err(|source| TraceError::Decode {
                    file: reader.name.clone(),
                    frame,
                    offset,
                    message: short_type_name::<M>(),
                    source,
                })
            }))
        })
    }
}

impl<R: Read> Iterator for OsiTraceReader<R> {
    type Item = Result<Vec<u8>, TraceError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        match self.read_frame() {
            Ok(Some(frame)) => Some(Ok(frame)),
            Ok(None) => {
                self.done = true;
                None
            }
            Err(e) => {
                self.done = true;
                Some(Err(e))
            }
        }
    }
}

fn short_type_name<M>() -> &'static str {
    let full = std::any::type_name::<M>();
    full.rsplit("::").next().unwrap_or(full)
}

/// Reads and decodes every frame of the `.osi` file at `path` as `M`.
pub fn read_messages<M: prost::Message + Default>(
    path: impl AsRef<Path>,
) -> Result<Vec<M>, TraceError> {
    OsiTraceReader::open(path)?.messages::<M>().collect()
}

/// Formats `t` as ISO 8601 basic UTC, e.g. `20210818T150542Z` (`None` before 1970).
pub fn format_timestamp_utc(t: SystemTime) -> Option<String> {
    let secs = t.duration_since(UNIX_EPOCH).ok()?.as_secs();
    let (days, rem) = (secs / 86_400, secs % 86_400);
    // Civil date from days since 1970-01-01 (H. Hinnant's algorithm).
    let z = days as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    Some(format!(
        "{year:04}{month:02}{day:02}T{:02}{:02}{:02}Z",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    ))
}

fn version_digits(what: &str, v: &str) -> Result<String, TraceError> {
    let digits: String = v.chars().filter(|&c| c != '.').collect();
    if digits.is_empty() || !digits.chars().all(|c| c.is_ascii_digit()) {
        return Err(TraceError::InvalidName(format!(
            "{what} `{v}`, expected digits such as `3.8.0` or `380`"
        )));
    }
    Ok(digits)
}

/// The standard `.osi` trace file name
/// `<timestamp>_<type>_<osi-version>_<protobuf-version>_<frames>_<custom-name>.osi`, e.g.
/// `20210818T150542Z_sv_380_2112_1523_highway.osi`.
///
/// * `type_code`: one of [`TRACE_TYPE_CODES`] except `multi` (multi-channel traces are `.mcap`);
/// * versions: `3.8.0` or `380` (dots are dropped);
/// * `frames`: the number of messages in the file;
/// * `custom`: characters other than ASCII letters, digits, `-` and `.` become `-`; empty: the part (and its
///   `_`) is omitted.
pub fn trace_file_name(
    timestamp_utc: SystemTime,
    type_code: &str,
    osi_version: &str,
    protobuf_version: &str,
    frames: u64,
    custom: &str,
) -> Result<String, TraceError> {
    trace_file_name_with_extension(
        timestamp_utc,
        type_code,
        osi_version,
        protobuf_version,
        &frames.to_string(),
        custom,
        "osi",
    )
}

/// The standard name of a multi-channel `.mcap` trace,
/// `<timestamp>_multi_<osi-version>_<protobuf-version>_<frames>_<custom-name>.mcap`: by the naming
/// convention `frames` is the largest number of messages of any channel, the OSI version the `version` of
/// the file's `net.asam.osi.trace` metadata and the protobuf version its `min_protobuf_version`.
pub fn mcap_trace_file_name(
    timestamp_utc: SystemTime,
    osi_version: &str,
    protobuf_version: &str,
    frames: u64,
    custom: &str,
) -> Result<String, TraceError> {
    trace_file_name_with_extension(
        timestamp_utc,
        "multi",
        osi_version,
        protobuf_version,
        &frames.to_string(),
        custom,
        "mcap",
    )
}

/// The parts of a standard trace file name other than the number of frames, which is known only once the
/// trace is complete ([`NamedOsiTraceWriter`], [`mcap::McapTraceWriter::create_in`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TraceName {
    /// When the recording started (the name's ISO 8601 UTC timestamp).
    pub timestamp_utc: SystemTime,
    /// One of [`TRACE_TYPE_CODES`] (`multi` for `.mcap` only).
    pub type_code: String,
    /// `3.8.0` or `380`.
    pub osi_version: String,
    /// e.g. `0.14`.
    pub protobuf_version: String,
    /// The custom trace name (sanitised as in [`trace_file_name`]).
    pub custom: String,
}

impl TraceName {
    /// The file name for a trace of `frames` messages with extension `ext` (`osi` or `mcap`).
    pub fn file_name(&self, frames: u64, ext: &str) -> Result<String, TraceError> {
        trace_file_name_with_extension(
            self.timestamp_utc,
            &self.type_code,
            &self.osi_version,
            &self.protobuf_version,
            &frames.to_string(),
            &self.custom,
            ext,
        )
    }

    /// The name a trace is written under until its frame count is known: the standard name with
    /// `partial` in place of the frame count and `.part` appended (a run that fails leaves these).
    pub fn partial_file_name(&self, ext: &str) -> Result<String, TraceError> {
        Ok(trace_file_name_with_extension(
            self.timestamp_utc,
            &self.type_code,
            &self.osi_version,
            &self.protobuf_version,
            "partial",
            &self.custom,
            ext,
        )? + ".part")
    }
}

/// Renames the trace at `from` to `to` (the final step of writing under a temporary name).
pub fn rename_trace(from: &Path, to: &Path) -> Result<(), TraceError> {
    std::fs::rename(from, to).map_err(|source| TraceError::Io {
        action: "rename",
        file: format!("{} to {}", from.display(), to.display()),
        source,
    })
}

/// An `.osi` trace written under a temporary name ([`TraceName::partial_file_name`]) in a folder and renamed
/// to its standard name, which carries the number of messages written, by [`NamedOsiTraceWriter::finish`].
#[derive(Debug)]
pub struct NamedOsiTraceWriter {
    writer: OsiTraceWriter<BufWriter<File>>,
    dir: std::path::PathBuf,
    partial: std::path::PathBuf,
    name: TraceName,
}

impl NamedOsiTraceWriter {
    /// Creates `<dir>/<partial name>`.
    pub fn create_in(dir: impl AsRef<Path>, name: TraceName) -> Result<Self, TraceError> {
        let dir = dir.as_ref().to_owned();
        let partial = dir.join(name.partial_file_name("osi")?);
        Ok(NamedOsiTraceWriter {
            writer: OsiTraceWriter::create(&partial)?,
            dir,
            partial,
            name,
        })
    }

    /// The underlying writer.
    pub fn writer(&mut self) -> &mut OsiTraceWriter<BufWriter<File>> {
        &mut self.writer
    }

    /// Writes already-encoded message bytes as one frame.
    pub fn write_raw(&mut self, bytes: &[u8]) -> Result<(), TraceError> {
        self.writer.write_raw(bytes)
    }

    /// Frames written so far.
    pub fn frames(&self) -> u64 {
        self.writer.frames()
    }

    /// Flushes, closes and renames the file to its standard name; returns the final path.
    pub fn finish(self) -> Result<std::path::PathBuf, TraceError> {
        let frames = self.writer.frames();
        let file = self.writer.finish()?;
        drop(file);
        let path = self.dir.join(self.name.file_name(frames, "osi")?);
        rename_trace(&self.partial, &path)?;
        Ok(path)
    }
}

/// [`trace_file_name`] with any extension of the convention (`osi`, `txth`, `mcap`) and the frames field
/// given as text.
fn trace_file_name_with_extension(
    timestamp_utc: SystemTime,
    type_code: &str,
    osi_version: &str,
    protobuf_version: &str,
    frames: &str,
    custom: &str,
    ext: &str,
) -> Result<String, TraceError> {
    if !["osi", "txth", "mcap"].contains(&ext) {
        return Err(TraceError::InvalidName(format!(
            "extension `{ext}`, expected osi, txth or mcap"
        )));
    }
    if !TRACE_TYPE_CODES.contains(&type_code) || (type_code == "multi") != (ext == "mcap") {
        return Err(TraceError::InvalidName(format!(
            "type `{type_code}` for a .{ext} trace, expected one of sv, svc, gt, hvd, sd, tc, tcu, tu, mr, su \
             (`multi`, and only `multi`, for .mcap)"
        )));
    }
    let ts = format_timestamp_utc(timestamp_utc)
        .ok_or_else(|| TraceError::InvalidName("timestamp before 1970".to_owned()))?;
    let osi = version_digits("OSI version", osi_version)?;
    let pb = version_digits("protobuf version", protobuf_version)?;
    let custom: String = custom
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '.' {
                c
            } else {
                '-'
            }
        })
        .collect();
    Ok(if custom.is_empty() {
        format!("{ts}_{type_code}_{osi}_{pb}_{frames}.{ext}")
    } else {
        format!("{ts}_{type_code}_{osi}_{pb}_{frames}_{custom}.{ext}")
    })
}

/// A path's file name parsed by the naming convention: (type code, osi version digits, frames), if it follows
/// it.
pub fn parse_trace_file_name(path: &Path) -> Option<(String, String, u64)> {
    let stem = path.file_stem()?.to_str()?;
    let mut parts = stem.splitn(6, '_');
    let _ts = parts
        .next()
        .filter(|t| t.ends_with('Z') && t.contains('T'))?;
    let ty = parts.next().filter(|t| TRACE_TYPE_CODES.contains(t))?;
    let osi = parts
        .next()
        .filter(|v| v.chars().all(|c| c.is_ascii_digit()))?;
    let _pb = parts.next()?;
    let frames = parts.next()?.parse().ok()?;
    Some((ty.to_owned(), osi.to_owned(), frames))
}

/// A small SensorView per index (t = 0.05 s · i, sensor id i): the sample message of the trace
/// tests of both formats.
#[cfg(test)]
pub(crate) fn sample_view(i: u64) -> crate::osi3::SensorView {
    crate::osi3::SensorView {
        version: Some(crate::interface_version()),
        timestamp: Some(crate::timestamp_from_seconds(i as f64 * 0.05)),
        sensor_id: Some(crate::id(i)),
        ..Default::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::osi3;
    use std::time::Duration;

    use super::sample_view as sv;

    #[test]
    fn round_trip_through_a_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.osi");
        let mut w = OsiTraceWriter::create(&path).unwrap();
        for i in 0..5 {
            w.write_message(&sv(i)).unwrap();
        }
        w.write_raw(&[]).unwrap(); // an empty message is a legal frame
        assert_eq!(w.frames(), 6);
        w.finish().unwrap();

        let frames: Vec<Vec<u8>> = OsiTraceReader::open(&path)
            .unwrap()
            .collect::<Result<_, _>>()
            .unwrap();
        assert_eq!(frames.len(), 6);
        assert_eq!(frames[2], sv(2).encode_to_vec());
        assert!(frames[5].is_empty());
        let msgs: Vec<osi3::SensorView> = read_messages(&path).unwrap();
        assert_eq!(msgs[..5], (0..5).map(sv).collect::<Vec<_>>()[..]);
        assert_eq!(msgs[5], osi3::SensorView::default());
    }

    use prost::Message;

    #[test]
    fn byte_layout_is_little_endian_length_then_body() {
        let mut w = OsiTraceWriter::new(Vec::new());
        w.write_raw(&[1, 2, 3]).unwrap();
        w.write_raw(&[0xAA; 0x0102]).unwrap();
        let bytes = w.finish().unwrap();
        assert_eq!(&bytes[..7], &[3, 0, 0, 0, 1, 2, 3]);
        assert_eq!(&bytes[7..11], &[0x02, 0x01, 0, 0]);
        assert_eq!(bytes.len(), 7 + 4 + 0x0102);
    }

    #[test]
    fn empty_file_has_zero_frames() {
        let mut r = OsiTraceReader::new(io::empty());
        assert!(r.next().is_none());
        assert!(r.next().is_none());
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("empty.osi");
        File::create(&path).unwrap();
        assert!(read_messages::<osi3::SensorData>(&path).unwrap().is_empty());
    }

    #[test]
    fn truncated_body_names_file_frame_and_offset() {
        let mut w = OsiTraceWriter::new(Vec::new());
        w.write_message(&sv(1)).unwrap();
        w.write_message(&sv(2)).unwrap();
        let mut bytes = w.finish().unwrap();
        let first_len = 4 + sv(1).encoded_len() as u64;
        bytes.truncate(bytes.len() - 3);
        let mut r = OsiTraceReader::with_name(bytes.as_slice(), "cut.osi".to_owned());
        assert!(r.next().unwrap().is_ok());
        let err = r.next().unwrap().unwrap_err();
        let expected = sv(2).encoded_len() as u64;
        match &err {
            TraceError::TruncatedBody {
                file,
                frame,
                offset,
                got,
                expected: e,
            } => {
                assert_eq!(
                    (file.as_str(), *frame, *offset, *got, *e),
                    ("cut.osi", 1, first_len, expected - 3, expected)
                );
            }
            other => panic!("unexpected {other:?}"),
        }
        assert_eq!(
            err.to_string(),
            format!(
                "cut.osi: frame 1 at byte offset {first_len}: truncated body ({} of {expected} bytes)",
                expected - 3
            )
        );
        assert!(r.next().is_none(), "the reader stops after an error");
    }

    #[test]
    fn truncated_prefix_is_an_error() {
        let bytes = [2u8, 0, 0, 0, 7, 7, 1, 0];
        let mut r = OsiTraceReader::with_name(&bytes[..], "p.osi".to_owned());
        assert_eq!(r.next().unwrap().unwrap(), vec![7, 7]);
        let err = r.next().unwrap().unwrap_err();
        assert!(
            matches!(
                err,
                TraceError::TruncatedPrefix {
                    frame: 1,
                    offset: 6,
                    got: 2,
                    ..
                }
            ),
            "{err:?}"
        );
        assert_eq!(
            err.to_string(),
            "p.osi: frame 1 at byte offset 6: truncated length prefix (2 of 4 bytes)"
        );
    }

    #[test]
    fn frame_over_2_gib_is_refused_without_allocating() {
        // A prefix of 0xFFFF_FFFF (4 GiB - 1) with no body: refused before any allocation.
        let bytes = [0xFFu8, 0xFF, 0xFF, 0xFF, 0];
        let err = OsiTraceReader::with_name(&bytes[..], "big.osi".to_owned())
            .next()
            .unwrap()
            .unwrap_err();
        assert!(
            matches!(
                err,
                TraceError::FrameTooLarge {
                    len: 0xFFFF_FFFF,
                    max: MAX_FRAME_LEN,
                    frame: 0,
                    offset: 0,
                    ..
                }
            ),
            "{err:?}"
        );
        // 2 GiB exactly is one over the limit.
        let bytes = 0x8000_0000u32.to_le_bytes();
        let err = OsiTraceReader::new(&bytes[..]).next().unwrap().unwrap_err();
        assert!(
            matches!(
                err,
                TraceError::FrameTooLarge {
                    len: 0x8000_0000,
                    ..
                }
            ),
            "{err:?}"
        );
        // The writer-side check.
        assert_eq!(
            frame_prefix(i32::MAX as usize),
            Some([0xFF, 0xFF, 0xFF, 0x7F])
        );
        assert_eq!(frame_prefix(1 << 31), None);
        assert_eq!(frame_prefix(usize::MAX), None);
        // A lowered limit applies to ordinary frames too.
        let mut w = OsiTraceWriter::new(Vec::new());
        w.write_raw(&[0; 100]).unwrap();
        let bytes = w.finish().unwrap();
        let err = OsiTraceReader::new(bytes.as_slice())
            .with_max_frame_len(99)
            .next()
            .unwrap()
            .unwrap_err();
        assert!(
            matches!(
                err,
                TraceError::FrameTooLarge {
                    len: 100,
                    max: 99,
                    ..
                }
            ),
            "{err:?}"
        );
    }

    #[test]
    fn decode_error_names_the_frame() {
        let mut w = OsiTraceWriter::new(Vec::new());
        w.write_message(&sv(0)).unwrap();
        w.write_raw(&[0xFF, 0xFF, 0xFF]).unwrap();
        let bytes = w.finish().unwrap();
        let results: Vec<_> = OsiTraceReader::with_name(bytes.as_slice(), "d.osi".to_owned())
            .messages::<osi3::SensorView>()
            .collect();
        assert_eq!(results.len(), 2);
        let err = results[1].as_ref().unwrap_err();
        let off = 4 + sv(0).encoded_len() as u64;
        assert!(
            err.to_string().starts_with(&format!(
                "d.osi: frame 1 at byte offset {off}: cannot decode SensorView:"
            )),
            "{err}"
        );
    }

    #[test]
    fn standard_file_names() {
        let t = UNIX_EPOCH + Duration::from_secs(1_629_299_142); // 2021-08-18T15:05:42Z
        assert_eq!(format_timestamp_utc(t).unwrap(), "20210818T150542Z");
        assert_eq!(
            trace_file_name(t, "sv", "3.1.2", "3.0.0", 1523, "highway").unwrap(),
            "20210818T150542Z_sv_312_300_1523_highway.osi"
        );
        assert_eq!(
            trace_file_name(t, "sd", "380", "2112", 7, "").unwrap(),
            "20210818T150542Z_sd_380_2112_7.osi"
        );
        assert_eq!(
            trace_file_name(t, "sd", "380", "2112", 7, "radar front/1").unwrap(),
            "20210818T150542Z_sd_380_2112_7_radar-front-1.osi"
        );
        assert!(trace_file_name(t, "xx", "380", "2112", 7, "a").is_err());
        assert!(trace_file_name(t, "multi", "380", "2112", 7, "a").is_err());
        assert!(trace_file_name(t, "sv", "3.8.x", "2112", 7, "a").is_err());
        assert_eq!(
            mcap_trace_file_name(t, "3.8.0", "0.14", 67, "run").unwrap(),
            "20210818T150542Z_multi_380_014_67_run.mcap"
        );
        let name = TraceName {
            timestamp_utc: t,
            type_code: "sd".to_owned(),
            osi_version: "3.8.0".to_owned(),
            protobuf_version: "0.14".to_owned(),
            custom: "front_radar".to_owned(),
        };
        assert_eq!(
            name.partial_file_name("osi").unwrap(),
            "20210818T150542Z_sd_380_014_partial_front-radar.osi.part"
        );
        assert!(name.file_name(3, "mcap").is_err(), "sd is not a .mcap type");
        let dir = tempfile::tempdir().unwrap();
        let mut w = NamedOsiTraceWriter::create_in(dir.path(), name).unwrap();
        for i in 0..3 {
            w.write_raw(&sv(i).encode_to_vec()).unwrap();
        }
        let path = w.finish().unwrap();
        assert_eq!(
            path.file_name().unwrap(),
            "20210818T150542Z_sd_380_014_3_front-radar.osi"
        );
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
        assert_eq!(read_messages::<osi3::SensorView>(&path).unwrap().len(), 3);
        assert_eq!(
            format_timestamp_utc(UNIX_EPOCH).unwrap(),
            "19700101T000000Z"
        );
        assert_eq!(
            format_timestamp_utc(UNIX_EPOCH + Duration::from_secs(951_782_400)).unwrap(), // leap day 2000
            "20000229T000000Z"
        );
        let parsed =
            parse_trace_file_name(Path::new("/x/20210818T150542Z_sv_312_300_1523_highway.osi"));
        assert_eq!(parsed, Some(("sv".to_owned(), "312".to_owned(), 1523)));
        assert_eq!(parse_trace_file_name(Path::new("trace.osi")), None);
    }
}
