"""The `.mcap` trace of `osiris run --format both`, read back with the OSI tools from PyPI:

* asam-osi-utilities (`osi_utilities`, ASAM OSI's trace file utilities): `MultiTraceReader` in both
  decoder modes (the precompiled official `osi3` classes, and the FileDescriptorSet schemas stored in
  the file), its channel specifications and file metadata;
* betterosi: `betterosi.read` of every OSI channel, `read_file_metadata`, `read_channel_metadata`;

compared per channel with the `.osi` traces of the same run: message counts, and message bytes (the
MCAP message records, byte for byte; the tools' decoded messages re-serialized, byte for byte, against
the same `.osi` message decoded and re-serialized by the same tool). The PerceptionData channel (not an
OSI channel) is decoded with its stored schema.

The run uses $OSIRIS_BIN if set (else `cargo run --release --`) and `--fmu-dir $OSIRIS_FMU_DIR` when set.
"""

from __future__ import annotations

import json
import os
import struct
import subprocess
from pathlib import Path

import betterosi
import pytest
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory
from osi3 import osi_sensordata_pb2, osi_sensorview_pb2
from osi_utilities._types import ReadStatus
from osi_utilities.tracefile.readers.multi import MultiTraceReader

REPO = Path(__file__).resolve().parents[2]

REQUIRED_FILE_KEYS = {"version", "min_osi_version", "max_osi_version", "min_protobuf_version", "max_protobuf_version"}
REQUIRED_CHANNEL_KEYS = {"net.asam.osi.trace.channel.osi_version", "net.asam.osi.trace.channel.protobuf_version"}
OSI_CLASSES = {"osi3.SensorView": osi_sensorview_pb2.SensorView, "osi3.SensorData": osi_sensordata_pb2.SensorData}
BETTEROSI_TYPES = {"osi3.SensorView": "SensorView", "osi3.SensorData": "SensorData"}
# 40 frames of 0.01 s: radar (0.05 s) 8 cycles, LiDAR (0.1 s) 4.
CYCLES = {"front_radar": 8, "front_lidar": 4}


def osiris_command() -> list[str]:
    exe = os.environ.get("OSIRIS_BIN")
    return [exe] if exe else ["cargo", "run", "--quiet", "--release", "--"]


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("mcap-run")
    args = [
        "run",
        "--sensors",
        "radar,lidar",
        "--param",
        "mode=physical",
        "--max-frames",
        "40",
        "--format",
        "both",
        "--out",
        str(out),
        "--quiet",
    ]
    if os.environ.get("OSIRIS_FMU_DIR"):
        args += ["--fmu-dir", os.environ["OSIRIS_FMU_DIR"]]
    proc = subprocess.run(osiris_command() + args, cwd=REPO, capture_output=True, timeout=3600, check=False)
    assert proc.returncode == 0, proc.stderr.decode(errors="replace")[-6000:]
    return out


def the_mcap(run_dir: Path) -> Path:
    found = sorted(run_dir.glob("*.mcap"))
    assert len(found) == 1, found
    return found[0]


def osi_frames(path: Path) -> list[bytes]:
    data = path.read_bytes()
    frames, i = [], 0
    while i < len(data):
        (n,) = struct.unpack_from("<I", data, i)
        frames.append(data[i + 4 : i + 4 + n])
        i += 4 + n
    assert i == len(data), path
    return frames


def osi_trace_of(run_dir: Path, topic: str) -> Path:
    """The `.osi` trace holding the same stream as an mcap channel `<sensor>.<variable>`."""
    sensor, variable = topic.split(".", 1)
    if variable == "PerceptionDataOut":
        return run_dir / f"{sensor}.perception.osi"
    code = {"OSMPSensorViewIn": "sv", "OSMPSensorDataOut": "sd"}[variable]
    found = [p for p in run_dir.glob(f"*_{code}_380_*.osi") if p.stem.endswith("_" + sensor.replace("_", "-"))]
    assert len(found) == 1, (topic, found)
    # The name carries the number of messages.
    assert int(found[0].name.split("_")[4]) == len(osi_frames(found[0])), found[0].name
    return found[0]


@pytest.fixture(scope="module")
def channels(run_dir) -> dict[str, tuple[str, list[bytes]]]:
    """topic -> (schema name, raw message bytes) via the `mcap` library both tools build on."""
    out: dict[str, tuple[str, list[bytes]]] = {}
    with the_mcap(run_dir).open("rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None and summary.chunk_indexes, "an indexed, chunked file"
        for ch in summary.channels.values():
            out[ch.topic] = (summary.schemas[ch.schema_id].name, [])
        for _schema, channel, message in reader.iter_messages(log_time_order=False):
            out[channel.topic][1].append(message.data)
            assert message.log_time == message.publish_time
    return out


def test_file_name_and_metadata(run_dir, channels):
    path = the_mcap(run_dir)
    parts = path.stem.split("_")
    assert parts[1:4] == ["multi", "380", "014"], path.name
    assert int(parts[4]) == max(len(m) for _, m in channels.values()), path.name
    meta = betterosi.read_file_metadata(path)
    osi = [m["data"] for m in meta if m["name"] == "net.asam.osi.trace"]
    assert len(osi) == 1, meta
    assert REQUIRED_FILE_KEYS <= osi[0].keys(), osi[0]
    assert osi[0]["version"] == "3.8.0" and osi[0]["min_osi_version"] == osi[0]["max_osi_version"] == "3.8.0"
    reader = MultiTraceReader()
    assert reader.open(path)
    try:
        assert reader.get_file_metadata() == meta
        specs = {s.topic: s for s in reader.list_channel_specifications()}
    finally:
        reader.close()
    chmeta = betterosi.read_channel_metadata(path)
    expected_osi = {t for t, (schema, _) in channels.items() if schema.startswith("osi3.")}
    assert set(specs) == expected_osi
    for topic in expected_osi:
        assert REQUIRED_CHANNEL_KEYS <= chmeta[topic].keys(), (topic, chmeta[topic])
        assert chmeta[topic]["net.asam.osi.trace.channel.osi_version"] == "3.8.0"
    for sensor in CYCLES:
        assert f"{sensor}.PerceptionDataOut" in chmeta
        assert not any(k.startswith("net.asam.osi") for k in chmeta[f"{sensor}.PerceptionDataOut"])


def test_raw_message_bytes_equal_the_osi_traces(run_dir, channels):
    assert len(channels) == 3 * len(CYCLES)
    for topic, (_schema, messages) in channels.items():
        sensor = topic.split(".")[0]
        assert len(messages) == CYCLES[sensor], topic
        assert messages == osi_frames(osi_trace_of(run_dir, topic)), topic


@pytest.mark.parametrize("mode", ["precompiled", "mcap-contained"])
def test_asam_osi_utilities_reads_every_osi_channel(run_dir, channels, mode):
    for topic, (schema, _) in channels.items():
        if not schema.startswith("osi3."):
            continue
        reader = MultiTraceReader(decoder_mode=mode)
        assert reader.open(the_mcap(run_dir))
        reader.set_topics([topic])
        got = []
        while (result := reader.read_message()) is not None:
            assert result.status == ReadStatus.OK, result.error_message
            assert result.channel_name == topic
            got.append(result.message.SerializeToString(deterministic=True))
        reader.close()
        cls = OSI_CLASSES[schema]
        expected = [cls.FromString(b).SerializeToString(deterministic=True) for b in osi_frames(osi_trace_of(run_dir, topic))]
        assert len(got) == len(expected) == CYCLES[topic.split(".")[0]], topic
        assert got == expected, topic


def test_asam_osi_utilities_skips_the_non_osi_channel(run_dir):
    reader = MultiTraceReader(skip_incompatible_messages=False, log_incompatible_messages=False)
    assert reader.open(the_mcap(run_dir))
    reader.set_topics(["front_radar.PerceptionDataOut"])
    result = reader.read_message()
    reader.close()
    assert result is not None and result.status == ReadStatus.INCOMPATIBLE, result
    assert "osiris.perception.PerceptionData" in result.error_message


def test_betterosi_reads_every_osi_channel(run_dir, channels):
    for topic, (schema, _) in channels.items():
        if not schema.startswith("osi3."):
            continue
        from_mcap = list(betterosi.read(str(the_mcap(run_dir)), mcap_topics=[topic]))
        from_osi = list(betterosi.read(str(osi_trace_of(run_dir, topic)), osi_message_type=BETTEROSI_TYPES[schema]))
        assert len(from_mcap) == len(from_osi) == CYCLES[topic.split(".")[0]], topic
        assert type(from_mcap[0]).__name__ == BETTEROSI_TYPES[schema]
        assert [m.to_binary() for m in from_mcap] == [m.to_binary() for m in from_osi], topic


def test_perception_channel_decodes_with_its_stored_schema(run_dir, channels):
    factory = DecoderFactory()
    with the_mcap(run_dir).open("rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        for ch in summary.channels.values():
            schema = summary.schemas[ch.schema_id]
            if schema.name != "osiris.perception.PerceptionData":
                continue
            decode = factory.decoder_for(ch.message_encoding, schema)
            assert decode is not None, ch.topic
            frames = osi_frames(osi_trace_of(run_dir, ch.topic))
            decoded = [decode(m) for m in channels[ch.topic][1]]
            assert len(decoded) == len(frames) == CYCLES[ch.topic.split(".")[0]]
            for msg, raw in zip(decoded, frames):
                assert msg.DESCRIPTOR.full_name == "osiris.perception.PerceptionData"
                assert msg.extension_version == "1.0.0"
                again = type(msg).FromString(raw)
                assert msg.SerializeToString(deterministic=True) == again.SerializeToString(deterministic=True)


def test_summary_names_the_mcap(run_dir):
    summary = json.loads((run_dir / "summary.json").read_text())
    assert Path(summary["mcap_trace"]) == the_mcap(run_dir)
