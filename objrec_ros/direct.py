"""Messages of an uncompressed ROS 1 bag read straight from the file, one message at a time.

rosbags reads a ROS 1 chunk whole into memory, keeps it while its generator is suspended, and copies each
message out of it: a 10000 x 10000 image in a 300 MB chunk costs the chunk, the copy and then the decoded
frame, 900 MB before any processing. A chunk that is not compressed needs none of that: its index already says
where each message lies, so each message is read from the file into a buffer of its own size (a ``bytearray``,
which the decoders may then view without copying again). Compressed chunks still go through rosbags, with
their inflation bounded (``objrec_ros.bounded``).
"""

from __future__ import annotations

import heapq
import os
from collections.abc import Collection, Iterator
from typing import Any


def direct_reader(any_reader: Any) -> Any | None:
    """The rosbags ROS 1 reader behind ``any_reader`` when it is one bag whose chunks are all uncompressed."""
    from rosbags.rosbag1 import Reader as Reader1
    from rosbags.rosbag1 import reader as ros1

    readers = getattr(any_reader, "readers", [])
    if len(readers) != 1 or not isinstance(readers[0], Reader1):
        return None
    reader = readers[0]
    identity = ros1.decompressors.get("none")
    chunks = getattr(reader, "chunks", {})
    if not chunks or any(chunk.decompressor is not identity for chunk in chunks.values()):
        return None
    return reader


def messages(reader: Any, connections: Collection[Any], start: int | None, stop: int | None
             ) -> Iterator[tuple[Any, int, bytearray]]:
    """``(connection, log time ns, raw message)`` in log-time order, as rosbags' ``messages`` gives them."""
    from rosbags.rosbag1.reader import Header, ReaderError, RecordType, read_uint32

    bio = reader.bio
    connmap = {c.id: c for c in reader.connections}
    indexes = [reader.indexes[c.id] for c in connections]
    for entry in heapq.merge(*indexes):
        if start is not None and entry.time < start:
            continue
        if stop is not None and entry.time >= stop:
            return
        chunk = reader.chunks[entry.chunk_pos]
        if entry.offset >= chunk.datasize:
            raise ReaderError(f"a message index points past its chunk ({entry.offset} >= {chunk.datasize})")
        bio.seek(chunk.datapos + entry.offset)
        while True:
            header = Header.read(bio)
            op = header.get_uint8("op")
            if op != RecordType.CONNECTION:
                break
            bio.seek(read_uint32(bio), os.SEEK_CUR)
        if op != RecordType.MSGDATA:
            raise ReaderError("Expected to find message data.")
        size = read_uint32(bio)
        if bio.tell() + size > chunk.datapos + chunk.datasize:
            raise ReaderError(f"a message of {size:,} bytes runs past the end of its chunk")
        data = bytearray(size)
        if bio.readinto(data) != size:
            raise ReaderError("the bag ends inside a message (truncated?)")
        connection = connmap[header.get_uint32("conn")]
        if header.get_time("time") != entry.time:
            raise ReaderError("a message's time differs from its index")
        yield connection, entry.time, data
