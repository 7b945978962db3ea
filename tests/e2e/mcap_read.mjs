// Reads an MCAP file with an independent reader (@mcap/core's McapStreamReader, the
// library Foxglove uses) and prints one JSON object on stdout:
//   { complete, header, channels: [{id, topic, schemaName, schemaEncoding, messageEncoding,
//     schemaIsJson}], counts: {topic: n}, estimates: [{k, t, x_hat, trace_P, log_time}],
//     truths: [{k, u, input_arrived}] (u and input_arrived as the message has them, else null),
//     link_status: [first few messages], link_change: [...], events: [{level, message,
//     timestamp, log_time}], problems: [...] }
// `complete` is true when the file ends with a valid Footer and magic (a stopped recording);
// without it (a killed one) the reader still returns every whole record before the end.
// Used by tests/e2e/test_mcap.py.  Usage: node mcap_read.mjs FILE.mcap
import { readFileSync } from "node:fs";
import { McapStreamReader } from "@mcap/core";

const file = process.argv[2];
if (!file) {
  console.error("usage: node mcap_read.mjs FILE.mcap");
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
  counts: {},
  estimates: [],
  truths: [],
  link_status: [],
  link_change: [],
  events: [],
  delivered_first: [],
  records: 0,
  problems: [],
};
try {
  for (let record; (record = reader.nextRecord()); ) {
    out.records += 1;
    switch (record.type) {
      case "Header":
        out.header = { profile: record.profile, library: record.library };
        break;
      case "Schema":
        schemas.set(record.id, record);
        break;
      case "Channel": {
        const schema = schemas.get(record.schemaId);
        let schemaIsJson = false;
        if (schema) {
          try {
            schemaIsJson = typeof JSON.parse(decoder.decode(schema.data)) === "object";
          } catch {
            schemaIsJson = false;
          }
        }
        const c = {
          id: record.id,
          topic: record.topic,
          schemaName: schema ? schema.name : null,
          schemaEncoding: schema ? schema.encoding : null,
          messageEncoding: record.messageEncoding,
          schemaIsJson,
        };
        channels.set(record.id, c);
        out.channels.push(c);
        out.counts[record.topic] = 0;
        break;
      }
      case "Message": {
        const c = channels.get(record.channelId);
        if (!c) {
          out.problems.push(`message on unknown channel ${record.channelId}`);
          break;
        }
        out.counts[c.topic] += 1;
        let m;
        try {
          m = JSON.parse(decoder.decode(record.data));
        } catch (e) {
          out.problems.push(`${c.topic}: message is not JSON: ${e.message}`);
          break;
        }
        if (record.logTime !== record.publishTime) out.problems.push(`${c.topic}: log_time != publish_time`);
        if (c.topic === "netkf/estimate")
          out.estimates.push({ k: m.k, t: m.t, x_hat: m.x_hat, trace_P: m.trace_P, log_time: record.logTime.toString() });
        else if (c.topic === "netkf/truth")
          out.truths.push({ k: m.k, u: m.u ?? null, input_arrived: m.input_arrived ?? null });
        else if (c.topic === "netkf/link/status" && out.link_status.length < 20) out.link_status.push(m);
        else if (c.topic === "netkf/link/change") out.link_change.push(m);
        else if (c.topic === "netkf/events") out.events.push({ ...m, log_time: record.logTime.toString() });
        else if (c.topic === "netkf/measurement/delivered" && out.delivered_first.length < 5) out.delivered_first.push(m);
        break;
      }
      default:
        break;
    }
  }
  out.complete = reader.done();
  out.bytes_left = reader.bytesRemaining();
} catch (e) {
  out.problems.push(`reader error: ${e.message}`);
}
process.stdout.write(JSON.stringify(out) + "\n");
