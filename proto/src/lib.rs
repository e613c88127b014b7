//! Protobuf types of osiris.
//!
//! * [`osi3`]: the ASAM OSI 3.8.0 subset osiris reads and writes (proto2, the standard's names and
//!   field numbers; checked against the official `osi-python` descriptors in CI).
//! * [`perception`]: the osiris extension carrying each sensor's raw perception output
//!   (`osiris.perception.PerceptionData`).
//! * [`trace`]: OSI `.osi` trace files (length-prefixed messages) and, in [`trace::mcap`], OSI
//!   multi-channel `.mcap` trace files, read and written.
//!
//! Files: `proto/osi3/*.proto`, `proto/osiris/perception.proto`.

#[allow(clippy::all, clippy::pedantic, missing_docs, rustdoc::all)]
pub mod osi3 {
    include!(concat!(env!("OUT_DIR"), "/osi3.rs"));
}

/// Package `osiris` of the .proto files (module nesting mirrors the protobuf packages).
pub mod osiris {
    #[allow(clippy::all, clippy::pedantic, missing_docs, rustdoc::all)]
    pub mod perception {
        include!(concat!(env!("OUT_DIR"), "/osiris.perception.rs"));
    }
}
pub use osiris::perception;

pub mod trace;

pub use prost::Message;

/// Encoded `google.protobuf.FileDescriptorSet` of all the .proto files above (imports included), as
/// compiled by `protox`: for reflection (`prost-reflect`) and the descriptor diff against `osi-python`.
pub const FILE_DESCRIPTOR_SET: &[u8] =
    include_bytes!(concat!(env!("OUT_DIR"), "/file_descriptor_set.bin"));

/// OSI version every top-level message osiris writes carries.
pub const OSI_VERSION: (u32, u32, u32) = (3, 8, 0);

/// Version of the protobuf implementation that encodes every message osiris writes (prost), for the
/// `protobuf_version` entries of `.mcap` trace metadata. Kept equal to the `prost` of `Cargo.lock` by a test.
pub const PROTOBUF_VERSION: &str = "0.14.4";

/// Version of the `osiris.perception` extension message.
pub const PERCEPTION_EXTENSION_VERSION: &str = "1.0.0";

/// OSMP MIME type of a SensorView buffer.
pub const MIME_SENSOR_VIEW: &str =
    "application/x-open-simulation-interface; type=SensorView; version=3.8.0";
/// OSMP MIME type of a SensorData buffer.
pub const MIME_SENSOR_DATA: &str =
    "application/x-open-simulation-interface; type=SensorData; version=3.8.0";
/// OSMP MIME type of a SensorViewConfiguration buffer.
pub const MIME_SENSOR_VIEW_CONFIGURATION: &str =
    "application/x-open-simulation-interface; type=SensorViewConfiguration; version=3.8.0";
/// Private MIME type of the perception extension buffer.
pub const MIME_PERCEPTION_DATA: &str =
    "application/x-osiris-perception-data; type=PerceptionData; version=1.0.0";

/// `InterfaceVersion{3,8,0}`.
pub fn interface_version() -> osi3::InterfaceVersion {
    osi3::InterfaceVersion {
        version_major: Some(OSI_VERSION.0),
        version_minor: Some(OSI_VERSION.1),
        version_patch: Some(OSI_VERSION.2),
    }
}

/// Seconds as an OSI `Timestamp` (nanos normalised to `[0, 1e9)`, rounded to the nearest ns).
pub fn timestamp_from_seconds(t_s: f64) -> osi3::Timestamp {
    let total_ns = (t_s * 1e9).round() as i128;
    let seconds = total_ns.div_euclid(1_000_000_000) as i64;
    let nanos = total_ns.rem_euclid(1_000_000_000) as u32;
    osi3::Timestamp {
        seconds: Some(seconds),
        nanos: Some(nanos),
    }
}

/// An OSI `Timestamp` in seconds (absent fields count as 0).
pub fn timestamp_to_seconds(ts: &osi3::Timestamp) -> f64 {
    ts.seconds.unwrap_or(0) as f64 + f64::from(ts.nanos.unwrap_or(0)) * 1e-9
}

/// An OSI `Timestamp` in integer nanoseconds (absent fields count as 0; saturates instead of
/// overflowing).
pub fn timestamp_to_nanos(ts: &osi3::Timestamp) -> i64 {
    ts.seconds
        .unwrap_or(0)
        .saturating_mul(1_000_000_000)
        .saturating_add(i64::from(ts.nanos.unwrap_or(0)))
}

/// An OSI `Identifier` with the given value.
pub fn id(value: u64) -> osi3::Identifier {
    osi3::Identifier { value: Some(value) }
}

/// The reserved invalid identifier value, 2^64 - 1.
pub const INVALID_ID: u64 = u64::MAX;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn timestamp_normalises_negative_and_positive() {
        let t = timestamp_from_seconds(1.25);
        assert_eq!((t.seconds, t.nanos), (Some(1), Some(250_000_000)));
        let t = timestamp_from_seconds(-0.5);
        assert_eq!((t.seconds, t.nanos), (Some(-1), Some(500_000_000)));
        assert!((timestamp_to_seconds(&t) + 0.5).abs() < 1e-12);
    }

    #[test]
    fn protobuf_version_is_the_locked_prost() {
        let lock = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../Cargo.lock"))
            .expect("Cargo.lock beside the workspace manifest");
        let locked = lock
            .split("[[package]]")
            .find(|p| p.contains("\nname = \"prost\"\n"))
            .and_then(|p| p.lines().find_map(|l| l.strip_prefix("version = \"")))
            .and_then(|v| v.strip_suffix('"'))
            .expect("prost in Cargo.lock");
        assert_eq!(
            PROTOBUF_VERSION, locked,
            "update osiris_proto::PROTOBUF_VERSION to the prost version of Cargo.lock"
        );
    }

    #[test]
    fn zero_values_keep_presence_on_the_wire() {
        // proto2 `optional`: an explicit 0 is encoded (proto3 would drop it).
        let ident = id(0);
        let bytes = ident.encode_to_vec();
        assert_eq!(bytes, vec![0x08, 0x00]);
        let back = osi3::Identifier::decode(bytes.as_slice()).unwrap();
        assert_eq!(back.value, Some(0));
    }
}
