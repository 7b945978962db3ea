"""ROS 2 messages in a bag: the .msg definitions an MCAP schema holds (encoding ros2msg) and
the CDR the messages are in (message encoding cdr), decoded in pure Python.

A ros2msg schema is the type's .msg text followed by the types it uses, each after a line of
80 '=' and a line "MSG: package/Type" (as rosbag2 stores it). A message is XCDR1, the
encoding of ROS 2's DDS middleware: a 4-byte encapsulation header (0x00 0x00 big endian,
0x00 0x01 little endian, then two option bytes), then the fields in order, each primitive
aligned to its own size (at most 8) counted from the end of the header; a string is a uint32
length that counts its closing NUL, the bytes and the NUL; a sequence (T[], T[<=N]) a uint32
count and its elements; a fixed array (T[N]) its N elements; a nested message its fields.

This decoder follows the definitions in the file and shares no code with netkf's C++ encoder
(Fast CDR), so each checks the other (python/tests/test_ros2_cdr.py).
"""
import re
import struct

PRIMITIVES = {
    # name: (struct format, size)
    "bool": ("?", 1), "byte": ("B", 1), "char": ("B", 1), "int8": ("b", 1), "uint8": ("B", 1),
    "int16": ("h", 2), "uint16": ("H", 2), "int32": ("i", 4), "uint32": ("I", 4),
    "int64": ("q", 8), "uint64": ("Q", 8), "float32": ("f", 4), "float64": ("d", 8),
}
_SEPARATOR = "=" * 80
_FIELD = re.compile(r"^([A-Za-z][A-Za-z0-9_/]*)(<=\d+)?(\[(<=)?(\d*)\])?$")


class Ros2MsgError(ValueError):
    """A schema that is not a ROS 2 .msg definition this decoder reads, or bytes that are not
    the CDR of its type (with the field where it failed)."""


class Field:
    __slots__ = ("name", "type", "array", "length")

    def __init__(self, name, type_, array, length):
        self.name, self.type, self.array, self.length = name, type_, array, length
        # array: None (a single value), "seq" (T[] or T[<=N]: counted) or "fixed" (T[N])

    def __repr__(self):
        return "Field(%s %s %s %s)" % (self.type, self.name, self.array, self.length)


def _full_name(type_, package):
    if type_ in PRIMITIVES or type_ in ("string", "wstring"):
        return type_
    parts = type_.split("/")
    if len(parts) == 1:
        return "%s/%s" % (package, type_)
    if len(parts) == 3 and parts[1] == "msg":
        return "%s/%s" % (parts[0], parts[2])
    if len(parts) == 2:
        return type_
    raise Ros2MsgError("type %r is not a ROS 2 message type" % type_)


def _parse_fields(text, package, where):
    fields = []
    for number, raw in enumerate(text.splitlines(), 1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        words = line.split(None, 2)
        if len(words) < 2:
            raise Ros2MsgError("%s, line %d: %r is not 'TYPE NAME'" % (where, number, raw))
        type_text, name = words[0], words[1]
        if "=" in name or (len(words) > 2 and words[2].startswith("=")):
            continue  # a constant: not in the message's bytes
        m = _FIELD.match(type_text)
        if not m:
            raise Ros2MsgError("%s, line %d: %r is not a field type" % (where, number, type_text))
        base, _bound, brackets, upper, count = m.groups()
        if brackets is None:
            array, length = None, None
        elif upper or count == "":
            array, length = "seq", None
        else:
            array, length = "fixed", int(count)
        fields.append(Field(name, _full_name(base, package), array, length))
    return fields


def schema_name(name):
    """netkf_msgs/msg/Estimate -> netkf_msgs/Estimate (the form the MSG: lines use)."""
    parts = name.split("/")
    if len(parts) == 3 and parts[1] == "msg":
        return parts[0] + "/" + parts[2]
    if len(parts) == 2:
        return name
    raise Ros2MsgError("schema name %r is not package/msg/Type" % name)


def parse_definition(name, text):
    """{full type name: [Field]} of a ros2msg schema `name` (netkf_msgs/msg/Estimate) with the
    definitions appended to it; the root type is schema_name(name)."""
    root = schema_name(name)
    types = {}
    current, lines = root, []

    def close(type_name, body):
        if type_name in types:
            raise Ros2MsgError("schema %s defines %s twice" % (name, type_name))
        types[type_name] = _parse_fields("\n".join(body), type_name.split("/")[0], "%s (%s)" % (name, type_name))

    all_lines = text.splitlines()
    i = 0
    while i < len(all_lines):
        line = all_lines[i]
        if line.strip() == _SEPARATOR:
            if i + 1 >= len(all_lines) or not all_lines[i + 1].startswith("MSG: "):
                raise Ros2MsgError("schema %s: a separator line not followed by 'MSG: package/Type'" % name)
            close(current, lines)
            current, lines = _full_name(all_lines[i + 1][5:].strip(), root.split("/")[0]), []
            i += 2
            continue
        lines.append(line)
        i += 1
    close(current, lines)
    for type_name, fields in types.items():
        for f in fields:
            if f.type not in PRIMITIVES and f.type not in ("string", "wstring") and f.type not in types:
                raise Ros2MsgError("schema %s: %s uses %s, which the schema does not define" % (name, type_name, f.type))
    return types


class _Reader:
    def __init__(self, data, where):
        if len(data) < 4:
            raise Ros2MsgError("%s: %d bytes, shorter than the CDR encapsulation header" % (where, len(data)))
        kind = bytes(data[:2])
        if kind == b"\x00\x01":
            self.order = "<"
        elif kind == b"\x00\x00":
            self.order = ">"
        else:
            raise Ros2MsgError("%s: encapsulation 0x%s is not plain CDR (XCDR1, 0x0000 or 0x0001)" % (where, kind.hex()))
        self.data, self.pos, self.where = memoryview(data)[4:], 0, where

    def take(self, n, what):
        if n > len(self.data) - self.pos:
            raise Ros2MsgError("%s: the bytes end inside %s (offset %d of %d after the header)"
                               % (self.where, what, self.pos, len(self.data)))
        b = self.data[self.pos:self.pos + n]
        self.pos += n
        return b

    def primitive(self, type_, what):
        fmt, size = PRIMITIVES[type_]
        self.pos += (-self.pos) % size  # aligned to its size, from the end of the header
        value = struct.unpack(self.order + fmt, self.take(size, what))[0]
        if type_ == "bool" and bytes(self.data[self.pos - 1:self.pos]) not in (b"\x00", b"\x01"):
            raise Ros2MsgError("%s: %s is not a boolean (0 or 1)" % (self.where, what))
        return value

    def string(self, what):
        n = self.primitive("uint32", what)
        if n == 0:
            return ""  # some writers send an empty string as length 0, without the NUL
        raw = bytes(self.take(n, what))
        if raw[-1:] != b"\x00":
            raise Ros2MsgError("%s: %s does not end with NUL" % (self.where, what))
        try:
            return raw[:-1].decode("utf-8")
        except UnicodeDecodeError:
            raise Ros2MsgError("%s: %s is not UTF-8" % (self.where, what)) from None


def _value(r, types, type_, what):
    if type_ in PRIMITIVES:
        return r.primitive(type_, what)
    if type_ == "string":
        return r.string(what)
    if type_ == "wstring":
        raise Ros2MsgError("%s: %s is a wstring, which this decoder does not read" % (r.where, what))
    return _struct(r, types, type_, what)


def _struct(r, types, type_, where):
    out = {}
    for f in types[type_]:
        what = "%s.%s" % (where, f.name)
        if f.array is None:
            out[f.name] = _value(r, types, f.type, what)
            continue
        n = r.primitive("uint32", what + " (its length)") if f.array == "seq" else f.length
        if f.type in PRIMITIVES and n > len(r.data):
            raise Ros2MsgError("%s: %s claims %d elements, more than the message holds" % (r.where, what, n))
        out[f.name] = [_value(r, types, f.type, "%s[%d]" % (what, i)) for i in range(n)]
    return out


def decode(types, root, data, where="message"):
    """The message `data` (CDR with its encapsulation header) of type `root` as a dict of its
    fields (arrays as lists, nested messages as dicts). Bytes after the last field (the
    writer's padding) are allowed."""
    r = _Reader(data, where)
    return _struct(r, types, root, root.split("/")[-1])
