"""A bag rewritten as rosbag2 writes a split recording (``ros2 bag record --max-bag-size``).

rosbag2's SequentialWriter names each file ``<bag directory name>_<n>.mcap`` (rosbag2_cpp
``format_storage_uri``), writes each with the schemas and channels its messages use, and lists the files
in metadata.yaml's ``relative_file_paths`` and ``files`` (path, starting_time, duration, message_count).
Written here with the ``mcap`` library, not with this package's writer, so the reader meets files it did
not write. Each file registers its channels in its own order (reversed in every other file), so a
topic's channel id differs between files, as it may in a real recording.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import yaml
from mcap.reader import make_reader
from mcap.writer import Writer


def split_recording(
    source: Path,
    out_dir: Path,
    parts: int,
    *,
    chunk_size: int = 16384,
    drop: tuple[str, ...] = (),
    custom_data: bool = True,
) -> list[Path]:
    """Bag directory ``source`` (one MCAP file) rewritten in ``out_dir`` as ``parts`` files, split by
    message count in log-time order, with rosbag2's metadata.yaml; the files in order. Topics in ``drop``
    are left out, as a recording of the other topics only would have them (a real sensor's bag has no
    truth); without ``custom_data``, metadata.yaml's custom_data (the stored scene) is left out too."""
    mcap_file = next(source.glob("*.mcap"))
    with mcap_file.open("rb") as stream:
        messages = [
            m for m in make_reader(stream).iter_messages(log_time_order=True) if m[1].topic not in drop
        ]
    meta: dict[str, Any] = yaml.safe_load((source / "metadata.yaml").read_text(encoding="utf8"))
    info = meta["rosbag2_bagfile_information"]
    info["topics_with_message_count"] = [
        t for t in info["topics_with_message_count"] if t["topic_metadata"]["name"] not in drop
    ]
    info["message_count"] = len(messages)
    if not custom_data:
        info.pop("custom_data", None)
    out_dir.mkdir()
    files: list[Path] = []
    entries = []
    for part, picks in enumerate(np.array_split(np.arange(len(messages)), parts)):
        path = out_dir / f"{out_dir.name}_{part}.mcap"
        ours = [messages[i] for i in picks.tolist()]
        order = sorted({(s.id, c.id) for s, c, _ in ours}, reverse=part % 2 == 1)
        with path.open("wb") as out:
            writer = Writer(out, chunk_size=chunk_size)
            writer.start(profile="ros2", library="test split_recording")
            schemas: dict[int, int] = {}
            channels: dict[int, int] = {}
            known = {c.id: (s, c) for s, c, _ in ours}
            for schema_id, channel_id in order:
                schema, channel = known[channel_id]
                if schema_id not in schemas:
                    schemas[schema_id] = writer.register_schema(schema.name, schema.encoding, schema.data)
                channels[channel_id] = writer.register_channel(
                    channel.topic, channel.message_encoding, schemas[schema_id], channel.metadata
                )
            for _, channel, message in ours:
                writer.add_message(channels[channel.id], message.log_time, message.data, message.publish_time)
            writer.finish()
        files.append(path)
        times = [m.log_time for _, _, m in ours]
        entries.append(
            {
                "path": path.name,
                "starting_time": {"nanoseconds_since_epoch": min(times)},
                "duration": {"nanoseconds": max(times) - min(times)},
                "message_count": len(ours),
            }
        )
    info["relative_file_paths"] = [p.name for p in files]
    info["files"] = entries
    (out_dir / "metadata.yaml").write_text(yaml.safe_dump(meta, sort_keys=False), encoding="utf8")
    return files
