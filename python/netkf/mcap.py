"""A small pure-Python MCAP reader (https://mcap.dev/spec, major version 0).

It reads what netkf writes (cli/recording/mcap_writer.hpp: the unchunked, unindexed form,
CRCs 0) and, beyond that, any MCAP file: chunked (uncompressed, or zstd / lz4 compressed when
Debian's python3-zstandard / python3-lz4 is installed), with a summary section, attachments and
metadata. Index, statistics and attachment records are skipped (metadata records are kept in
`metadata` when well formed): the reader streams the file the way @mcap/core's McapStreamReader does.

A file cut short (what `kill -9` leaves) yields every whole record before the cut, with
`complete` False. A file that ends with a Footer and the closing magic was closed by its
writer, so it must parse record by record up to that footer: a record that runs past it, or
anything else malformed, is damage and a McapError, never a shorter result. Non-zero CRCs
(data section, summary section, chunks, attachments) are checked.

Every record is <opcode u8><content length u64 LE><content>; a string or byte array is
<length u32><bytes> (a chunk's records and an attachment's data: <length u64><bytes>); a map
is <byte length u32><entries>.
"""
import json
import struct
import zlib
from dataclasses import dataclass, field

from . import ros2msg

MAGIC = b"\x89MCAP0\r\n"

OP_HEADER = 0x01
OP_FOOTER = 0x02
OP_SCHEMA = 0x03
OP_CHANNEL = 0x04
OP_MESSAGE = 0x05
OP_CHUNK = 0x06
OP_MESSAGE_INDEX = 0x07
OP_CHUNK_INDEX = 0x08
OP_ATTACHMENT = 0x09
OP_ATTACHMENT_INDEX = 0x0A
OP_STATISTICS = 0x0B
OP_METADATA = 0x0C
OP_METADATA_INDEX = 0x0D
OP_SUMMARY_OFFSET = 0x0E
OP_DATA_END = 0x0F

_NAMES = {OP_HEADER: "Header", OP_FOOTER: "Footer", OP_SCHEMA: "Schema", OP_CHANNEL: "Channel",
          OP_MESSAGE: "Message", OP_CHUNK: "Chunk", OP_MESSAGE_INDEX: "Message Index",
          OP_CHUNK_INDEX: "Chunk Index", OP_ATTACHMENT: "Attachment", OP_ATTACHMENT_INDEX: "Attachment Index",
          OP_STATISTICS: "Statistics", OP_METADATA: "Metadata", OP_METADATA_INDEX: "Metadata Index",
          OP_SUMMARY_OFFSET: "Summary Offset", OP_DATA_END: "Data End"}
# Where the spec allows each known record (unknown opcodes are skipped anywhere, as it says).
_IN_DATA = {OP_SCHEMA, OP_CHANNEL, OP_MESSAGE, OP_CHUNK, OP_MESSAGE_INDEX, OP_ATTACHMENT, OP_METADATA}
_IN_SUMMARY = {OP_SCHEMA, OP_CHANNEL, OP_CHUNK_INDEX, OP_ATTACHMENT_INDEX, OP_STATISTICS, OP_METADATA_INDEX,
               OP_SUMMARY_OFFSET}
_IN_CHUNK = {OP_SCHEMA, OP_CHANNEL, OP_MESSAGE}

FOOTER_LENGTH = 20  # summary_start u64, summary_offset_start u64, summary_crc u32; never extended
_TRAILER = 1 + 8 + FOOTER_LENGTH + len(MAGIC)
_DECOMPRESS_STEP = 1 << 20


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


def _name(opcode):
    return _NAMES.get(opcode, "opcode 0x%02x" % opcode)


class _Cursor:
    """Reads the spec's primitive types from one record's content; a read past its end is
    a McapError naming the record's offset."""

    def __init__(self, buf, offset, what):
        self.buf, self.pos, self.offset, self.what = buf, 0, offset, what

    def take(self, n):
        if n > len(self.buf) - self.pos:
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

    def bytes64(self):
        return self.take(self.u64())

    def string(self):
        raw = self.bytes()
        try:
            return raw.decode("utf-8")
        except UnicodeDecodeError:
            raise McapError("MCAP: %s record at byte %d holds a string that is not UTF-8" %
                            (self.what, self.offset)) from None

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


def _bounded(step, limit):
    """Joins the pieces `step(n)` returns (b"" at the end) until `limit` bytes: the most a
    chunk may hold is its declared size, so a damaged one cannot make the reader allocate more."""
    parts, total = [], 0
    while total < limit:
        piece = step(min(_DECOMPRESS_STEP, limit - total))
        if not piece:
            break
        parts.append(piece)
        total += len(piece)
    return b"".join(parts)


def _decompress(compression, data, size, offset):
    """The chunk's records, at most size + 1 bytes of them (one more tells a chunk that holds
    more than it declares)."""
    if compression == "":
        return data
    if len(data) == 0:
        return b""  # an empty chunk needs no decompressor (as in @mcap/core)
    if compression == "zstd":
        try:
            import zstandard  # Debian: python3-zstandard
        except ImportError:
            raise McapError("MCAP: chunk at byte %d is zstd-compressed, which needs python3-zstandard "
                            "(not installed)" % offset) from None
        try:
            with zstandard.ZstdDecompressor().stream_reader(bytes(data), read_across_frames=True) as r:
                return _bounded(r.read, size + 1)
        except zstandard.ZstdError as e:
            raise McapError("MCAP: chunk at byte %d is not valid zstd data (%s)" % (offset, e)) from None
    if compression == "lz4":
        try:
            import lz4.frame  # Debian: python3-lz4
        except ImportError:
            raise McapError("MCAP: chunk at byte %d is lz4-compressed, which needs python3-lz4 "
                            "(not installed)" % offset) from None
        d = lz4.frame.LZ4FrameDecompressor()
        first = [bytes(data)]

        def step(n):
            if d.eof or (d.needs_input and not first):
                return b""
            return d.decompress(first.pop() if first else b"", max_length=n)
        try:
            out = _bounded(step, size + 1)
        except RuntimeError as e:  # lz4.frame's error for a malformed frame
            raise McapError("MCAP: chunk at byte %d is not valid lz4 data (%s)" % (offset, e)) from None
        if len(out) <= size and not d.eof:
            raise McapError("MCAP: chunk at byte %d ends inside its lz4 frame" % offset)
        return out
    raise McapError("MCAP: chunk at byte %d has compression %r, which this reader does not know (it reads "
                    "uncompressed, zstd and lz4 chunks)" % (offset, compression))


def _has_trailer(data):
    """Whether the file ends with a Footer record and the closing magic."""
    n = len(data)
    if n < len(MAGIC) + _TRAILER or bytes(data[n - len(MAGIC):]) != MAGIC:
        return False
    f = n - _TRAILER
    return data[f] == OP_FOOTER and struct.unpack_from("<Q", data, f + 1)[0] == FOOTER_LENGTH


class McapFile:
    """One MCAP file read whole: header, schemas, channels (in file order) and messages.

    complete: the file ends with its Footer and the closing magic (a stopped recording).
    truncated: the file ended inside a record (the partial record is ignored).
    """

    def __init__(self, path, validate_crcs=True):
        self.path = path
        self.header = None
        self.schemas = {}
        self.channels = {}
        self.messages = []
        self.metadata = []  # (name, {key: value}) of each Metadata record, in file order
        self.complete = False
        self.truncated = False
        self._validate = validate_crcs
        with open(path, "rb") as f:
            data = memoryview(f.read())
        if bytes(data[:len(MAGIC)]) != MAGIC:
            raise McapError("MCAP: %s does not start with the MCAP magic" % path)
        # A file with a footer and the closing magic was closed by its writer: nothing in it
        # may be taken for a cut (a record running past its end is damage, not kill -9).
        self._closed = _has_trailer(data)
        self._read(data)

    def _error(self, what, offset):
        return McapError("MCAP: %s: %s (byte %d)" % (self.path, what, offset))

    def _read(self, data):
        pos, end = len(MAGIC), len(data)
        data_end = None  # the offset just past the Data End record
        summary = []  # (offset, opcode) of each record after Data End
        while pos < end:
            if end - pos < 9:
                return self._cut(pos)
            opcode = data[pos]
            length = struct.unpack_from("<Q", data, pos + 1)[0]
            if opcode == 0:
                raise self._error("opcode 0x00 is not a record", pos)
            if pos == len(MAGIC) and opcode != OP_HEADER:
                raise self._error("the first record is a %s, not a Header" % _name(opcode), pos)
            start = pos + 9
            if length > end - start:
                return self._cut(pos, length)
            content = data[start:start + length]
            if opcode == OP_FOOTER:
                return self._footer(data, pos, content, data_end, summary)
            if data_end is not None:
                if opcode in _NAMES and opcode not in _IN_SUMMARY:
                    raise self._error("a %s record after Data End" % _name(opcode), pos)
                summary.append((pos, opcode))
            elif opcode == OP_DATA_END:
                self._data_end(data, pos, content)
                data_end = start + length
            elif opcode == OP_HEADER and pos != len(MAGIC):
                raise self._error("a second Header record", pos)
            elif opcode in _NAMES and opcode not in _IN_DATA and opcode != OP_HEADER:
                raise self._error("a %s record in the data section" % _name(opcode), pos)
            self._record(opcode, content, pos)
            pos = start + length
        if self._closed:
            raise self._error("the records end at the end of the file without reaching its footer (at byte %d)"
                              % (end - _TRAILER), pos)

    def _cut(self, pos, length=None):
        if self._closed:
            claim = "" if length is None else ", claiming %d bytes," % length
            raise self._error("the record here%s runs past the footer of a closed file: the file is damaged"
                              % claim, pos)
        self.truncated = True

    def _data_end(self, data, pos, content):
        crc = _Cursor(content, pos, "Data End").u32()
        if self._validate and crc != 0:
            got = zlib.crc32(data[:pos])
            if got != crc:
                raise self._error("the data section fails its CRC (Data End says 0x%08x, the bytes before it "
                                  "give 0x%08x)" % (crc, got), pos)

    def _footer(self, data, pos, content, data_end, summary):
        if len(content) != FOOTER_LENGTH:
            raise self._error("the Footer holds %d bytes, not %d" % (len(content), FOOTER_LENGTH), pos)
        summary_start, offsets_start, crc = struct.unpack("<QQI", content)
        if summary_start != 0 and (data_end is None or summary_start != data_end):
            raise self._error("the Footer's summary_start %d is not the record after Data End (%s)"
                              % (summary_start, "no Data End" if data_end is None else "at byte %d" % data_end), pos)
        starts = [o for o, _ in summary]
        if offsets_start not in (0, pos):  # the footer's own offset: an empty section
            if offsets_start not in starts:
                raise self._error("the Footer's summary_offset_start %d is not a record of the summary"
                                  % offsets_start, pos)
            tail = [op for o, op in summary if o >= offsets_start]
            if any(op != OP_SUMMARY_OFFSET for op in tail):
                raise self._error("the summary offset section (from byte %d) holds other records"
                                  % offsets_start, pos)
        if self._validate and crc != 0:
            begin = summary_start or (data_end if data_end is not None else pos)
            got = zlib.crc32(data[begin:pos + 1 + 8 + 16])
            if got != crc:
                raise self._error("the summary section fails its CRC (the Footer says 0x%08x, the bytes give "
                                  "0x%08x)" % (crc, got), pos)
        tail = bytes(data[pos + 9 + FOOTER_LENGTH:])
        if tail == MAGIC:
            self.complete = True
        elif len(tail) < len(MAGIC) and MAGIC.startswith(tail):
            self.truncated = True
        else:
            raise McapError("MCAP: bytes after the footer of %s are not the closing magic" % self.path)

    def _record(self, opcode, content, offset, chunk=None):
        where = "%s" % _name(opcode) if chunk is None else "%s (in the chunk at byte %d)" % (_name(opcode), chunk)
        c = _Cursor(content, offset, where)
        if opcode == OP_HEADER:
            self.header = {"profile": c.string(), "library": c.string()}
        elif opcode == OP_SCHEMA:
            s = Schema(c.u16(), c.string(), c.string(), c.bytes())
            if s.id == 0:
                return  # the spec: a Schema with id 0 is invalid and ignored
            old = self.schemas.get(s.id)
            if old is not None and old != s:
                raise McapError("MCAP: %s: schema %d at byte %d differs from its earlier record"
                                % (self.path, s.id, offset))
            self.schemas[s.id] = s
        elif opcode == OP_CHANNEL:
            ch = Channel(c.u16(), c.u16(), c.string(), c.string(), c.string_map())
            if ch.schema_id != 0 and ch.schema_id not in self.schemas:
                raise McapError("MCAP: channel %d (%s) at byte %d names schema %d, which no Schema record before it "
                                "defines" % (ch.id, ch.topic, offset, ch.schema_id))
            old = self.channels.get(ch.id)
            if old is not None and old != ch:
                raise McapError("MCAP: %s: channel %d at byte %d differs from its earlier record (%s)"
                                % (self.path, ch.id, offset, old.topic))
            self.channels[ch.id] = ch
        elif opcode == OP_MESSAGE:
            m = Message(c.u16(), c.u32(), c.u64(), c.u64(), c.rest())
            if m.channel_id not in self.channels:
                raise McapError("MCAP: message at byte %d is on channel %d, which no Channel record before it "
                                "defines" % (offset, m.channel_id))
            self.messages.append(m)
        elif opcode == OP_CHUNK:
            self._chunk(c, offset)
        elif opcode == OP_METADATA:
            # Kept for the caller (a ros2 bag's `rosbag2` record); the messages do not depend on
            # it, so a malformed one is skipped like the other records a stream reader ignores.
            try:
                self.metadata.append((c.string(), c.string_map()))
            except McapError:
                pass
        elif opcode == OP_ATTACHMENT:
            c.u64(), c.u64(), c.string(), c.string(), c.bytes64()
            covered = c.pos
            crc = c.u32()
            if self._validate and crc != 0 and zlib.crc32(content[:covered]) != crc:
                raise McapError("MCAP: %s: the attachment at byte %d fails its CRC" % (self.path, offset))
        # Every other record (indexes, statistics, metadata, summary offsets, Data End, unknown
        # opcodes) carries nothing a stream reader needs: skipped, as the spec allows.

    def _chunk(self, c, offset):
        c.u64(), c.u64()  # message start / end time
        size, crc, compression = c.u64(), c.u32(), c.string()
        records = _decompress(compression, c.bytes64(), size, offset)
        if len(records) != size:
            raise McapError("MCAP: chunk at byte %d holds %s bytes, not the %d it declares"
                            % (offset, "more" if len(records) > size else len(records), size))
        if self._validate and crc != 0 and zlib.crc32(records) != crc:
            raise McapError("MCAP: chunk at byte %d fails its CRC" % offset)
        records = memoryview(records)
        pos, end = 0, len(records)
        while pos < end:
            if end - pos < 9:
                raise McapError("MCAP: the chunk at byte %d ends inside a record (at byte %d of its records)"
                                % (offset, pos))
            opcode = records[pos]
            length = struct.unpack_from("<Q", records, pos + 1)[0]
            if opcode == 0 or (opcode in _NAMES and opcode not in _IN_CHUNK):
                raise McapError("MCAP: the chunk at byte %d holds a %s record (at byte %d of its records)"
                                % (offset, _name(opcode), pos))
            if length > end - pos - 9:
                raise McapError("MCAP: a record inside the chunk at byte %d runs past its end (at byte %d of its "
                                "records)" % (offset, pos))
            self._record(opcode, records[pos + 9:pos + 9 + length], pos, chunk=offset)
            pos += 9 + length

    def topics(self):
        """The channels' topics in the order the file defines them."""
        return [c.topic for c in self.channels.values()]

    def channel(self, topic):
        """The channel of `topic`; a McapError when the file has none."""
        for c in self.channels.values():
            if c.topic == topic:
                return c
        raise McapError("MCAP: %s has no channel %r (it has %s)" % (self.path, topic, ", ".join(self.topics())))

    def schema_of(self, topic):
        ch = self.channel(topic)
        return self.schemas.get(ch.schema_id)

    def decoded(self, topic):
        """(log_time ns, message) of every message on `topic`, in file order, decoded into
        dicts: JSON messages (the json profile), and CDR messages with a ros2msg schema (the
        ros2 profile, netkf.ros2msg: the .msg field names)."""
        ch = self.channel(topic)
        if ch.message_encoding == "json":
            decode = json.loads
        elif ch.message_encoding == "cdr":
            decode = self._cdr_decoder(ch)
        else:
            raise McapError("MCAP: channel %s is %r-encoded; json and cdr are decoded" % (topic, ch.message_encoding))
        out = []
        for m in self.messages:
            if m.channel_id == ch.id:
                try:
                    out.append((m.log_time, decode(m.data)))
                except (ValueError, RecursionError) as e:  # ValueError: not UTF-8, not JSON, not the CDR
                    raise McapError("MCAP: message %d on %s is not %s (%s)"
                                    % (m.sequence, topic, "JSON" if ch.message_encoding == "json" else
                                       "the CDR of its schema", e)) from None
        return out

    def _cdr_decoder(self, ch):
        schema = self.schemas.get(ch.schema_id)
        if schema is None or schema.encoding != "ros2msg":
            raise McapError("MCAP: channel %s is CDR without a ros2msg schema (%s)"
                            % (ch.topic, "none" if schema is None else schema.encoding))
        try:
            text = schema.data.decode("utf-8")
            types = ros2msg.parse_definition(schema.name, text)
        except (UnicodeDecodeError, ros2msg.Ros2MsgError) as e:
            raise McapError("MCAP: %s: the schema %s of %s: %s" % (self.path, schema.name, ch.topic, e)) from None
        root = ros2msg.schema_name(schema.name)
        return lambda data: ros2msg.decode(types, root, data, ch.topic)

    def counts(self):
        """Messages per topic."""
        by_id = {c.id: 0 for c in self.channels.values()}
        for m in self.messages:
            by_id[m.channel_id] += 1
        return {self.channels[i].topic: n for i, n in by_id.items()}
