"""A small pure-Python MCAP reader (https://mcap.dev/spec, major version 0).

It reads what netkf writes (cli/recording/mcap_writer.hpp: the unchunked, unindexed form,
CRCs 0) and, beyond that, any MCAP file whose chunks are uncompressed (or zstd / lz4
compressed when Debian's python3-zstandard / python3-lz4 is installed). Index, statistics,
attachment and metadata records are skipped: the reader streams the data section the way
@mcap/core's McapStreamReader does, so a file cut short (what `kill -9` leaves) still yields
every whole record before the cut, with `complete` False.

Every record is <opcode u8><content length u64 LE><content>; a string or byte array is
<length u32><bytes>; a map is <byte length u32><entries>.
"""
import json
import struct
import zlib
from dataclasses import dataclass, field

MAGIC = b"\x89MCAP0\r\n"

OP_HEADER = 0x01
OP_FOOTER = 0x02
OP_SCHEMA = 0x03
OP_CHANNEL = 0x04
OP_MESSAGE = 0x05
OP_CHUNK = 0x06
OP_DATA_END = 0x0F


class McapError(ValueError):
    """The file is not MCAP, or a record in it is malformed (with its byte offset)."""


@dataclass
class Schema:
    id: int
    name: str
    encoding: str
    data: bytes


@dataclass
class Channel:
    id: int
    schema_id: int
    topic: str
    message_encoding: str
    metadata: dict = field(default_factory=dict)


@dataclass
class Message:
    channel_id: int
    sequence: int
    log_time: int  # ns
    publish_time: int  # ns
    data: bytes


class _Cursor:
    """Reads the spec's primitive types from one record's content; a read past its end is
    a McapError naming the record's offset."""

    def __init__(self, buf, offset, what):
        self.buf, self.pos, self.offset, self.what = buf, 0, offset, what

    def take(self, n):
        if self.pos + n > len(self.buf):
            raise McapError("MCAP: %s record at byte %d is shorter than its fields" % (self.what, self.offset))
        b = self.buf[self.pos:self.pos + n]
        self.pos += n
        return b

    def u16(self):
        return struct.unpack("<H", self.take(2))[0]

    def u32(self):
        return struct.unpack("<I", self.take(4))[0]

    def u64(self):
        return struct.unpack("<Q", self.take(8))[0]

    def bytes(self):
        return bytes(self.take(self.u32()))

    def string(self):
        raw = self.bytes()
        try:
            return raw.decode("utf-8")
        except UnicodeDecodeError:
            raise McapError("MCAP: %s record at byte %d holds a string that is not UTF-8" % (self.what, self.offset))

    def string_map(self):
        length = self.u32()
        end = self.pos + length
        out = {}
        while self.pos < end:
            key = self.string()
            out[key] = self.string()
        if self.pos != end:
            raise McapError("MCAP: %s record at byte %d has a malformed map" % (self.what, self.offset))
        return out

    def rest(self):
        return bytes(self.take(len(self.buf) - self.pos))


def _decompress(compression, data, size, offset):
    if compression == "":
        return data
    if compression == "zstd":
        try:
            import zstandard  # Debian: python3-zstandard
        except ImportError:
            raise McapError("MCAP: chunk at byte %d is zstd-compressed; install python3-zstandard" % offset)
        return zstandard.ZstdDecompressor().decompress(data, max_output_size=size)
    if compression == "lz4":
        try:
            import lz4.frame  # Debian: python3-lz4
        except ImportError:
            raise McapError("MCAP: chunk at byte %d is lz4-compressed; install python3-lz4" % offset)
        return lz4.frame.decompress(data)
    raise McapError("MCAP: chunk at byte %d has an unknown compression %r" % (offset, compression))


class McapFile:
    """One MCAP file read whole: header, schemas, channels (in file order) and messages.

    complete: the file ends with DataEnd, Footer and the closing magic (a stopped recording).
    truncated: the file ended inside a record (the partial record is ignored).
    """

    def __init__(self, path, validate_crcs=True):
        self.path = path
        self.header = None
        self.schemas = {}
        self.channels = {}
        self.messages = []
        self.complete = False
        self.truncated = False
        with open(path, "rb") as f:
            data = f.read()
        if data[:len(MAGIC)] != MAGIC:
            raise McapError("MCAP: %s does not start with the MCAP magic" % path)
        self._read_records(memoryview(data), len(MAGIC), len(data), validate_crcs, top_level=True)

    def _read_records(self, data, pos, end, validate_crcs, top_level):
        while pos < end:
            if end - pos < 9:
                if top_level and bytes(data[pos:end]) == MAGIC[:end - pos] and self.complete:
                    return
                self._cut(top_level, pos)
                return
            opcode = data[pos]
            length = struct.unpack_from("<Q", data, pos + 1)[0]
            start = pos + 9
            if start + length > end:
                self._cut(top_level, pos)
                return
            content = data[start:start + length]
            self._record(opcode, content, pos, validate_crcs)
            pos = start + length
            if opcode == OP_FOOTER and top_level:
                tail = bytes(data[pos:end])
                if tail == MAGIC:
                    self.complete = True
                    return
                if len(tail) < len(MAGIC) and MAGIC.startswith(tail):
                    self.truncated = True
                    return
                raise McapError("MCAP: bytes after the footer of %s are not the closing magic" % self.path)

    def _cut(self, top_level, pos):
        if not top_level:
            raise McapError("MCAP: a record inside the chunk ending near byte %d is cut short" % pos)
        self.truncated = True

    def _record(self, opcode, content, offset, validate_crcs):
        if opcode == OP_HEADER:
            c = _Cursor(content, offset, "Header")
            self.header = {"profile": c.string(), "library": c.string()}
        elif opcode == OP_SCHEMA:
            c = _Cursor(content, offset, "Schema")
            s = Schema(c.u16(), c.string(), c.string(), c.bytes())
            self.schemas[s.id] = s
        elif opcode == OP_CHANNEL:
            c = _Cursor(content, offset, "Channel")
            ch = Channel(c.u16(), c.u16(), c.string(), c.string(), c.string_map())
            if ch.schema_id != 0 and ch.schema_id not in self.schemas:
                raise McapError("MCAP: channel %d (%s) at byte %d names schema %d, which no Schema record before it "
                                "defines" % (ch.id, ch.topic, offset, ch.schema_id))
            self.channels[ch.id] = ch
        elif opcode == OP_MESSAGE:
            c = _Cursor(content, offset, "Message")
            m = Message(c.u16(), c.u32(), c.u64(), c.u64(), c.rest())
            if m.channel_id not in self.channels:
                raise McapError("MCAP: message at byte %d is on channel %d, which no Channel record before it "
                                "defines" % (offset, m.channel_id))
            self.messages.append(m)
        elif opcode == OP_CHUNK:
            c = _Cursor(content, offset, "Chunk")
            c.u64(), c.u64()  # message start / end time
            size, crc, compression = c.u64(), c.u32(), c.string()
            records = _decompress(compression, c.bytes(), size, offset)
            if len(records) != size:
                raise McapError("MCAP: chunk at byte %d holds %d bytes, not the %d it declares"
                                % (offset, len(records), size))
            if validate_crcs and crc != 0 and zlib.crc32(records) != crc:
                raise McapError("MCAP: chunk at byte %d fails its CRC" % offset)
            self._read_records(memoryview(records), 0, len(records), validate_crcs, top_level=False)
        elif opcode == OP_FOOTER:
            pass
        elif opcode == OP_DATA_END:
            pass
        # Every other opcode (indexes, statistics, attachments, metadata, summary offsets)
        # carries nothing a stream reader needs: skipped, as the spec allows.

    def topics(self):
        """The channels' topics in the order the file defines them."""
        return [c.topic for c in self.channels.values()]

    def channel(self, topic):
        for c in self.channels.values():
            if c.topic == topic:
                return c
        raise KeyError("MCAP: %s has no channel %r (it has %s)" % (self.path, topic, ", ".join(self.topics())))

    def schema_of(self, topic):
        ch = self.channel(topic)
        return self.schemas.get(ch.schema_id)

    def decoded(self, topic):
        """(log_time ns, message) of every message on `topic`, in file order; JSON messages
        are decoded into dicts (netkf's channels are all JSON)."""
        ch = self.channel(topic)
        if ch.message_encoding != "json":
            raise McapError("MCAP: channel %s is %r-encoded; only json is decoded" % (topic, ch.message_encoding))
        out = []
        for m in self.messages:
            if m.channel_id == ch.id:
                try:
                    out.append((m.log_time, json.loads(m.data)))
                except ValueError as e:
                    raise McapError("MCAP: message %d on %s is not JSON (%s)" % (m.sequence, topic, e))
        return out

    def counts(self):
        """Messages per topic."""
        by_id = {c.id: 0 for c in self.channels.values()}
        for m in self.messages:
            by_id[m.channel_id] += 1
        return {self.channels[i].topic: n for i, n in by_id.items()}
