// Reads a ros2-profile MCAP file (netkf ... --mcap-profile ros2) with Foxglove's libraries, the
// readers of Foxglove's ROS 2 panels: @mcap/core's McapStreamReader for the file,
// @foxglove/rosmsg's parse(text, {ros2: true}) for every schema, and
// @foxglove/rosmsg2-serialization's MessageReader (CDR) for every message. Prints one JSON
// object on stdout:
//   { complete, header, channels: [{id, topic, schemaName, schemaEncoding, messageEncoding,
//     metadata, types}], metadata: [{name, metadata}], counts: {topic: n},
//     messages: {topic: [decoded message + log_time]}, trailing: {topic: n}, problems: [...] }
// uint64/int64 values are printed as numbers when exact, else as strings; typed arrays as arrays.
// `trailing` counts messages whose bytes go on past the last field of their schema.
// Used by tests/e2e/test_mcap_ros2.py.  Usage: node mcap_ros2_read.mjs FILE.mcap
import { readFileSync } from "node:fs";
import { McapStreamReader } from "@mcap/core";
import { parse } from "@foxglove/rosmsg";
import { MessageReader } from "@foxglove/rosmsg2-serialization";

const file = process.argv[2];
if (!file) {
  console.error("usage: node mcap_ros2_read.mjs FILE.mcap");
  process.exit(2);
}
const reader = new McapStreamReader({ validateCrcs: true });
reader.append(new Uint8Array(readFileSync(file)));

const decoder = new TextDecoder();
const schemas = new Map();
const channels = new Map();
const out = {
  complete: false,
  header: null,
  channels: [],
  metadata: [],
  counts: {},
  messages: {},
  trailing: {},
  problems: [],
};

function plain(value) {
  if (typeof value === "bigint") return Number.isSafeInteger(Number(value)) ? Number(value) : value.toString();
  if (ArrayBuffer.isView(value)) return Array.from(value, plain);
  if (Array.isArray(value)) return value.map(plain);
  if (value && typeof value === "object") {
    const o = {};
    for (const [k, v] of Object.entries(value)) o[k] = plain(v);
    return o;
  }
  return value;
}

function addChannel(record) {
  const schema = schemas.get(record.schemaId);
  const c = {
    id: record.id,
    topic: record.topic,
    schemaName: schema ? schema.name : null,
    schemaEncoding: schema ? schema.encoding : null,
    messageEncoding: record.messageEncoding,
    metadata: Object.fromEntries(record.metadata),
    types: [],
  };
  if (schema) {
    try {
      const definitions = parse(decoder.decode(schema.data), { ros2: true });
      c.types = definitions.map((d) => d.name ?? "(root)");
      c.reader = new MessageReader(definitions);
    } catch (e) {
      out.problems.push(`schema ${schema.name} of ${record.topic}: ${e}`);
    }
  }
  channels.set(record.id, c);
  out.counts[record.topic] = 0;
  out.messages[record.topic] = [];
  out.trailing[record.topic] = 0;
}

function addMessage(record) {
  const c = channels.get(record.channelId);
  if (!c) {
    out.problems.push(`message on unknown channel ${record.channelId}`);
    return;
  }
  out.counts[c.topic] += 1;
  if (!c.reader) return;
  try {
    const m = plain(c.reader.readMessage(record.data));
    if (c.reader.lastReadHadTrailingBytes()) out.trailing[c.topic] += 1;
    m.log_time = Number(record.logTime);
    out.messages[c.topic].push(m);
  } catch (e) {
    out.problems.push(`message ${record.sequence} on ${c.topic}: ${e}`);
  }
}

try {
  for (let record; (record = reader.nextRecord()); ) {
    switch (record.type) {
      case "Header":
        out.header = { profile: record.profile, library: record.library };
        break;
      case "Schema":
        schemas.set(record.id, record);
        break;
      case "Channel":
        if (!channels.has(record.id)) addChannel(record); // the summary repeats the channels
        break;
      case "Message":
        addMessage(record);
        break;
      case "Metadata":
        out.metadata.push({ name: record.name, metadata: Object.fromEntries(record.metadata) });
        break;
      case "Footer":
        out.complete = true;
        break;
      default:
        break;
    }
  }
  out.complete = out.complete && reader.done();
} catch (e) {
  out.problems.push(String(e));
}
out.channels = [...channels.values()].map(({ reader: _r, ...c }) => c);
console.log(JSON.stringify(out));
