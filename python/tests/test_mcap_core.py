"""The MCAP reader against files another implementation wrote, and against damaged copies.

The writer and the second reader are @mcap/core's (python/tests/mcap_core.mjs, run at test
time with Node.js): netkf's messages in netkf's own layout (`plain`), unchunked with a summary,
chunked, and chunked with zstd and lz4 compression. The expectations are what the script wrote
(its written.json) and what @mcap/core's McapStreamReader reads from the same file.
"""
import json
import math
import os
import random
import shutil
import struct
import subprocess
import sys

import pytest

import netkf
from netkf import mcap
from conftest import REPO, TESTS

SCRIPT = os.path.join(TESTS, "mcap_core.mjs")
FILES = ["plain", "unchunked", "chunked", "chunked_zstd", "chunked_lz4"]
DECOMPRESSOR = {"chunked_zstd": "zstandard", "chunked_lz4": "lz4.frame"}


def need(what, why):
    """A missing tool fails under ctest (NETKF_BIN_DIR is set: scripts/deps.sh installs it all)
    and skips by hand."""
    if os.environ.get("NETKF_BIN_DIR"):
        pytest.fail("%s is needed (scripts/deps.sh installs it): %s" % (what, why))
    pytest.skip("%s missing: %s" % (what, why))


def node():
    exe = shutil.which("node")
    for package in ("@mcap/core", "@foxglove/wasm-zstd", "lz4js"):
        if not exe or not os.path.isdir(os.path.join(REPO, "node_modules", package)):
            need("node and node_modules/" + package, "the independent MCAP writer")
    return exe


def run_script(*args):
    r = subprocess.run([node(), SCRIPT] + list(args), cwd=REPO, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    return r.stdout


@pytest.fixture(scope="session")
def written(tmp_path_factory):
    out = str(tmp_path_factory.mktemp("mcap_core"))
    run_script("write", out)
    with open(os.path.join(out, "written.json")) as f:
        return json.load(f)


def path_of(written, name):
    if name in DECOMPRESSOR:
        try:
            __import__(DECOMPRESSOR[name])
        except ImportError:
            need("python3-" + DECOMPRESSOR[name].split(".")[0], "reading %s" % name)
    return written["files"][name]["path"]


def core_read(path):
    return json.loads(run_script("read", path))


def as_core(m):
    """A McapFile in mcap_core.mjs's `read` layout."""
    return {
        "header": m.header,
        "schemas": [{"id": s.id, "name": s.name, "encoding": s.encoding, "data": s.data.decode()}
                    for s in m.schemas.values()],
        "channels": [{"id": c.id, "schemaId": c.schema_id, "topic": c.topic, "messageEncoding": c.message_encoding,
                      "metadata": c.metadata} for c in m.channels.values()],
        "messages": messages(m),
    }


def messages(m):
    return [{"channelId": x.channel_id, "sequence": x.sequence, "logTime": str(x.log_time),
             "publishTime": str(x.publish_time), "data": x.data.decode()} for x in m.messages]


def records(data):
    """(offset, opcode, content length) of each top-level record of a whole file."""
    out, pos = [], len(mcap.MAGIC)
    while pos < len(data) - len(mcap.MAGIC):
        length = struct.unpack_from("<Q", data, pos + 1)[0]
        out.append((pos, data[pos], length))
        pos += 9 + length
    assert pos == len(data) - len(mcap.MAGIC)
    return out


def netkf_layout(written, tmp_path):
    """The `plain` file with its CRCs zeroed: byte for byte what netkf's writer makes
    (cli/recording/mcap_writer.cpp: data section and summary CRCs 0)."""
    data = bytearray(open(path_of(written, "plain"), "rb").read())
    (data_end, op, _), (footer, op2, _) = records(data)[-2:]
    assert (op, op2) == (mcap.OP_DATA_END, mcap.OP_FOOTER)
    data[data_end + 9:data_end + 13] = b"\0\0\0\0"
    data[footer + 9 + 16:footer + 9 + 20] = b"\0\0\0\0"
    p = tmp_path / "netkf_layout.mcap"
    p.write_bytes(bytes(data))
    return str(p), bytes(data)


# ---- files as @mcap/core writes them -----------------------------------------------------

@pytest.mark.parametrize("name", FILES)
def test_reads_what_mcap_core_wrote(written, name):
    path = path_of(written, name)
    theirs = core_read(path)
    assert theirs["error"] is None and theirs["complete"]
    if name.startswith("chunked"):
        assert theirs["chunks"] == written["files"][name]["chunks"] > 10  # really chunked, in many chunks
    mine = netkf.read_mcap(path)
    assert mine.complete and not mine.truncated
    ours = as_core(mine)
    assert ours == {k: theirs[k] for k in ours}
    assert ours["messages"] == written["messages"] and ours["header"] == written["header"]
    by_id = lambda records: sorted(records, key=lambda r: r["id"])  # the file has them in first use's order
    assert by_id(ours["channels"]) == written["channels"] and by_id(ours["schemas"]) == written["schemas"]


def test_period_frames_of_every_layout_are_the_written_messages(written):
    by_topic = {c["id"]: c["topic"] for c in written["channels"]}
    sent = [(by_topic[m["channelId"]], json.loads(m["data"])) for m in written["messages"]]
    truths = {m["k"]: m for t, m in sent if t == "netkf/truth"}
    in_time = {m["k"]: m for t, m in sent if t == "netkf/estimate" and m["revision"] == 0}
    revised = {m["k"]: m for t, m in sent if t == "netkf/estimate" and m["revision"] > 0}
    delivered = [m for t, m in sent if t == "netkf/measurement/delivered"]
    for name in FILES:
        df = netkf.read_mcap_periods(path_of(written, name))
        assert df.attrs["fuse_within"] and df.attrs["state_dim"] == 2, name
        assert df["k"].tolist() == sorted(truths) == sorted(in_time), name
        for i in range(2):
            assert df["x%d" % i].tolist() == [truths[k]["x"][i] for k in df["k"]], name
            assert df["xhat%d" % i].tolist() == [in_time[k]["x_hat"][i] for k in df["k"]], name
            assert df["xhat_final%d" % i].tolist() == [(revised.get(k) or in_time[k])["x_hat"][i] for k in df["k"]]
        nulls = [k for k in df["k"] if in_time[k]["trace_P"] is None]
        assert nulls == [123] and math.isnan(df.set_index("k").loc[123, "trace_P"])  # null: non-finite
        assert all(df.set_index("k").loc[k, "trace_P"] == in_time[k]["trace_P"] for k in df["k"] if k not in nulls)
        assert df["fused"].tolist() == [tuple(in_time[k]["fused"]) for k in df["k"]]
        assert df["late_samples"].tolist() == [tuple((s["k"], s["sensor_id"]) for s in in_time[k]["late_samples"])
                                               for k in df["k"]]
        s = netkf.read_mcap_samples(path_of(written, name))
        assert s["y0"].tolist() == [d["y"][0] for d in delivered] and len(s) == len(delivered)


# ---- compression this machine cannot read ---------------------------------------------------

@pytest.mark.parametrize("name,module,package", [("chunked_zstd", "zstandard", "python3-zstandard"),
                                                 ("chunked_lz4", "lz4", "python3-lz4")])
def test_missing_decompressor_is_named(written, monkeypatch, name, module, package):
    path = written["files"][name]["path"]
    for mod in list(sys.modules):
        if mod == module or mod.startswith(module + "."):
            monkeypatch.delitem(sys.modules, mod)
    monkeypatch.setitem(sys.modules, module, None)  # `import module` now raises ImportError
    with pytest.raises(netkf.McapError, match="%s-compressed.*%s" % (name.split("_")[1], package)):
        netkf.read_mcap(path)


# ---- damage --------------------------------------------------------------------------------

@pytest.mark.parametrize("layout", ["netkf", "chunked"])
def test_record_length_damaged_inside_a_closed_file(written, tmp_path, layout):
    """A closed file (Footer and closing magic at its end) whose record in the middle claims
    2^40 bytes is damaged: an error, not the records before it. The same file cut at that
    record (what kill -9 leaves) reads as its records before the cut."""
    if layout == "netkf":
        path, data = netkf_layout(written, tmp_path)
    else:
        path = path_of(written, layout)
        data = open(path, "rb").read()
    whole = netkf.read_mcap(path)
    kind = mcap.OP_MESSAGE if layout == "netkf" else mcap.OP_CHUNK
    middle = [r for r in records(data) if r[1] == kind]
    offset = middle[len(middle) // 2][0]
    damaged = bytearray(data)
    damaged[offset + 1:offset + 9] = struct.pack("<Q", 1 << 40)
    p = tmp_path / "damaged.mcap"
    p.write_bytes(bytes(damaged))
    with pytest.raises(netkf.McapError, match="runs past the footer"):
        netkf.read_mcap(str(p))
    with pytest.raises(netkf.McapError):
        netkf.read_mcap_periods(str(p))
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(bytes(damaged[:offset + 20]))
    m = netkf.read_mcap(str(cut))
    assert m.truncated and not m.complete
    assert 0 < len(m.messages) < len(whole.messages) and messages(m) == messages(whole)[:len(m.messages)]


def test_data_section_crc(written, tmp_path):
    """@mcap/core writes the data section's CRC in Data End: a wrong one, or a byte changed in
    the data section, is an error; validate_crcs=False reads on; CRC 0 means not computed."""
    path = path_of(written, "unchunked")
    data = open(path, "rb").read()
    data_end = [o for o, op, _ in records(data) if op == mcap.OP_DATA_END][0]
    assert struct.unpack_from("<I", data, data_end + 9)[0] != 0
    wrong = bytearray(data)
    wrong[data_end + 9] ^= 0x01
    p = tmp_path / "crc.mcap"
    p.write_bytes(bytes(wrong))
    with pytest.raises(netkf.McapError, match="data section fails its CRC"):
        netkf.read_mcap(str(p))
    assert core_read(str(p))["error"] is None  # @mcap/core's stream reader does not check this CRC
    assert netkf.mcap.McapFile(str(p), validate_crcs=False).complete
    # A changed byte of a message's JSON (a digit for another: still valid JSON)
    msg = [o for o, op, _ in records(data) if op == mcap.OP_MESSAGE][100]
    digit = data.index(b"1", msg + 9 + 22)
    changed = bytearray(data)
    changed[digit] = ord("7")
    p.write_bytes(bytes(changed))
    with pytest.raises(netkf.McapError, match="data section fails its CRC"):
        netkf.read_mcap(str(p))
    zero = bytearray(data)
    zero[data_end + 9:data_end + 13] = b"\0\0\0\0"
    zero[digit] = ord("7")
    p.write_bytes(bytes(zero))
    assert netkf.read_mcap(str(p)).complete  # no CRC to check: read as written


def test_summary_crc(written, tmp_path):
    path = path_of(written, "chunked")
    data = open(path, "rb").read()
    stats = [o for o, op, _ in records(data) if op == mcap.OP_STATISTICS][0]
    damaged = bytearray(data)
    damaged[stats + 9] ^= 0x40  # the message count
    p = tmp_path / "summary.mcap"
    p.write_bytes(bytes(damaged))
    with pytest.raises(netkf.McapError, match="summary section fails its CRC"):
        netkf.read_mcap(str(p))


def test_random_bytes_after_the_magic(tmp_path):
    rng = random.Random(7)
    for i in range(20):
        body = bytes(rng.randrange(256) for _ in range(rng.randrange(20, 2000)))
        if body[0] == mcap.OP_HEADER:
            continue
        p = tmp_path / ("r%d.mcap" % i)
        p.write_bytes(mcap.MAGIC + body)
        with pytest.raises(netkf.McapError, match="not a Header|0x00"):
            netkf.read_mcap(str(p))


def read_everything(path_or_file, topics=True):
    """The readings of a file a user may do (each topic's frame too when `topics`)."""
    m = path_or_file if isinstance(path_or_file, mcap.McapFile) else netkf.read_mcap(path_or_file)
    netkf.read_mcap_periods(m)
    netkf.read_mcap_samples(m)
    for topic in m.topics() if topics else ():
        netkf.read_mcap_topic(m, topic)
    return m


@pytest.mark.parametrize("name", FILES + ["netkf"])
def test_fuzzed_copies_raise_only_the_readers_errors(written, tmp_path, name):
    """Random cuts read as the records before the cut; random byte changes raise McapError or
    FormatError (never KeyError, struct.error, UnicodeDecodeError, ...), and where they do not,
    a file with CRCs reads as its original's messages (a prefix of them when not complete)."""
    if name == "netkf":
        path, data = netkf_layout(written, tmp_path)
    else:
        path = path_of(written, name)
        data = open(path, "rb").read()
    original = messages(netkf.read_mcap(path))
    has_crcs = name != "netkf"
    rng = random.Random(name)
    p = str(tmp_path / "fuzz.mcap")
    for i in range(40):
        cut = rng.randrange(len(mcap.MAGIC), len(data))
        with open(p, "wb") as f:
            f.write(data[:cut])
        m = netkf.read_mcap(p)
        assert not m.complete and messages(m) == original[:len(m.messages)], cut
        try:
            read_everything(m, topics=i % 8 == 0)
        except netkf.McapError as e:  # cut before the channel's first record
            assert "has no channel" in str(e)
    errors = 0
    for i in range(150):
        damaged = bytearray(data)
        # Half the changes in the last 2 KiB: the summary, Data End, Footer and magic.
        at = rng.randrange(len(data)) if i % 2 else rng.randrange(max(0, len(data) - 2048), len(data))
        damaged[at] ^= rng.randrange(1, 256)
        with open(p, "wb") as f:
            f.write(bytes(damaged))
        try:
            m = read_everything(p, topics=i % 8 == 0)
        except (netkf.McapError, netkf.FormatError):
            errors += 1
            continue
        if has_crcs:
            got = messages(m)
            assert got == original[:len(got)] and (not m.complete or len(got) == len(original)), at
    assert errors > 0
