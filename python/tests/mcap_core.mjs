// An independent MCAP implementation for the Python reader's tests (test_mcap_core.py):
// @mcap/core's McapWriter writes files, @mcap/core's McapStreamReader reads them.
//
//   node mcap_core.mjs write DIR   writes DIR/{plain,unchunked,chunked,chunked_zstd,chunked_lz4}.mcap
//                                  (the same messages in each) and DIR/written.json: what was written
//   node mcap_core.mjs read FILE   prints what @mcap/core reads in FILE as one JSON object
//
// The messages are netkf's (docs/recording.md): JSON on netkf/truth, netkf/estimate (with
// fuse_within revisions), netkf/measurement/delivered, netkf/link/status and netkf/events, with
// pseudo-random doubles (a fixed seed) so exact round trips are tested. Compression: zstd by
// @foxglove/wasm-zstd, lz4 (frame format, as the spec's registry says) by lz4js.
import { mkdirSync, readFileSync, writeFileSync } from "node:fs";
import { join } from "node:path";
import { McapStreamReader, McapWriter } from "@mcap/core";
import zstd from "@foxglove/wasm-zstd";
import lz4 from "lz4js";

const [command, target] = process.argv.slice(2);
if (!["write", "read"].includes(command) || !target) {
  console.error("usage: node mcap_core.mjs write DIR | read FILE");
  process.exit(2);
}
await zstd.isLoaded;
const utf8 = new TextEncoder();
const text = new TextDecoder("utf-8", { fatal: true });

// A small seeded generator (mulberry32): the same files on every run.
function generator(seed) {
  let a = seed >>> 0;
  return () => {
    a = (a + 0x6d2b79f5) >>> 0;
    let t = a;
    t = Math.imul(t ^ (t >>> 15), t | 1);
    t ^= t + Math.imul(t ^ (t >>> 7), t | 61);
    return ((t ^ (t >>> 14)) >>> 0) / 4294967296;
  };
}

// The channels of a netkf recording (cli/live/channel_catalogue.cpp), with short schemas.
const CHANNELS = [
  { topic: "netkf/truth", schema: "netkf.wire.Truth", required: ["k", "t", "x"] },
  { topic: "netkf/estimate", schema: "netkf.wire.Estimate", required: ["k", "t", "x_hat", "P", "fused", "state", "trace_P"] },
  { topic: "netkf/measurement/delivered", schema: "netkf.wire.Measurement", required: ["sensor_id", "k", "stamp", "y"] },
  { topic: "netkf/link/status", schema: "netkf.wire.LinkStatus", required: ["sensor_id"], metadata: [["origin", "test"]] },
  { topic: "netkf/events", schema: "foxglove.Log", required: ["level", "message"] },
];

// Every message of a 1.5 s run at 10 ms periods: [topic, log time ns (BigInt), object].
function netkfMessages() {
  const rnd = generator(20240607);
  const normal = () => (rnd() - 0.5) * 4;
  const out = [];
  const ns = (t) => BigInt(Math.round(t * 1e9));
  const periods = 150;
  const pendingRevisions = [];
  for (let k = 0; k < periods; ++k) {
    const t = k * 0.01;
    out.push(["netkf/truth", ns(t), { k, t, x: [normal(), normal() * 1e-3] }]);
    for (const sensor of [1, 2]) {
      if (rnd() < 0.2) continue; // lost
      const y = sensor === 1 ? [normal()] : [normal(), normal()];
      out.push(["netkf/measurement/delivered", ns(t), { sensor_id: sensor, k, stamp: t + rnd() * 0.003, y }]);
    }
    const fused = [1, 2].filter(() => rnd() < 0.8);
    const late = k % 17 === 5 ? [{ k: k - 1, sensor_id: 2 }] : [];
    const P = [rnd(), rnd() * 1e-2, rnd() * 1e-2, rnd()];
    const estimate = {
      k, revision: 0, t, x_hat: [normal(), normal() * 1e-3], P, fused, late: late.length, late_samples: late,
      late_total: Math.floor(k / 17), rejected_total: 0,
      state: k > 120 && k < 126 ? "diverging" : "ok",
      trace_P: k === 123 ? null : P[0] + P[3], // null: how netkf writes a non-finite trace
      trace_P_pred: P[0] + P[3] + 0.01,
    };
    out.push(["netkf/estimate", ns(t), estimate]);
    // late_policy fuse_within: a revision of k, written after the in-time estimate of k + 2.
    if (k % 7 === 3) pendingRevisions.push({ ...estimate, revision: 1, x_hat: [normal(), normal()], fused: [1, 2] });
    while (pendingRevisions.length && pendingRevisions[0].k <= k - 2)
      out.push(["netkf/estimate", ns(t), pendingRevisions.shift()]);
    if (k % 50 === 0)
      for (const sensor of [1, 2])
        out.push(["netkf/link/status", ns(t), { sensor_id: sensor, observed_loss: k ? rnd() : null, delivered: k }]);
    if (k === 60)
      out.push(["netkf/events", ns(t), { timestamp: { sec: 1, nsec: 200000000 }, level: 3, message: "link 2: loss ↑ (ω)", name: "netkf", file: "", line: 0 }]);
  }
  return out;
}

const FILES = {
  // netkf's own layout (cli/recording/mcap_writer.hpp): records in the data section only.
  plain: {
    useChunks: false, useStatistics: false, useSummaryOffsets: false, repeatSchemas: false, repeatChannels: false,
    useAttachmentIndex: false, useMetadataIndex: false, useChunkIndex: false, useMessageIndex: false,
  },
  unchunked: { useChunks: false },
  chunked: { useChunks: true, chunkSize: 4096 },
  chunked_zstd: {
    useChunks: true, chunkSize: 8192,
    compressChunk: (data) => ({ compression: "zstd", compressedData: zstd.compress(data, 3) }),
  },
  chunked_lz4: {
    useChunks: true, chunkSize: 8192,
    compressChunk: (data) => ({ compression: "lz4", compressedData: lz4.compress(data) }),
  },
};

async function writeFiles(dir) {
  mkdirSync(dir, { recursive: true });
  const messages = netkfMessages();
  const written = { header: { profile: "", library: "@mcap/core test writer" }, schemas: [], channels: [], messages: [], files: {} };
  for (const [name, options] of Object.entries(FILES)) {
    const chunks = [];
    let position = 0n;
    const writable = {
      position: () => position,
      write: async (buffer) => {
        chunks.push(Buffer.from(buffer));
        position += BigInt(buffer.byteLength);
      },
    };
    const writer = new McapWriter({ writable, ...options });
    await writer.start(written.header);
    const ids = new Map();
    const describe = name === "plain";
    for (const c of CHANNELS) {
      const schemaJson = JSON.stringify({ type: "object", required: c.required });
      const schemaId = await writer.registerSchema({ name: c.schema, encoding: "jsonschema", data: utf8.encode(schemaJson) });
      const metadata = new Map(c.metadata ?? []);
      const channelId = await writer.registerChannel({ topic: c.topic, schemaId, messageEncoding: "json", metadata });
      ids.set(c.topic, channelId);
      if (describe) {
        written.schemas.push({ id: schemaId, name: c.schema, encoding: "jsonschema", data: schemaJson });
        written.channels.push({ id: channelId, schemaId, topic: c.topic, messageEncoding: "json", metadata: Object.fromEntries(metadata) });
      }
    }
    const sequence = new Map();
    let i = 0;
    for (const [topic, logTime, object] of messages) {
      const channelId = ids.get(topic);
      const seq = sequence.get(channelId) ?? 0;
      sequence.set(channelId, seq + 1);
      const data = JSON.stringify(object);
      await writer.addMessage({ channelId, sequence: seq, logTime, publishTime: logTime, data: utf8.encode(data) });
      if (describe) written.messages.push({ channelId, sequence: seq, logTime: logTime.toString(), publishTime: logTime.toString(), data });
      // An attachment and a metadata record between the messages: records a stream reader skips.
      if (++i === 200) {
        await writer.addAttachment({ name: "note.txt", mediaType: "text/plain", logTime, createTime: logTime, data: utf8.encode("netkf test attachment") });
        await writer.addMetadata({ name: "run", metadata: new Map([["scenario", "test"]]) });
      }
    }
    await writer.end();
    const file = join(dir, `${name}.mcap`);
    writeFileSync(file, Buffer.concat(chunks));
    written.files[name] = { path: file, chunks: writer.statistics?.chunkCount ?? 0 };
  }
  writeFileSync(join(dir, "written.json"), JSON.stringify(written));
}

function readFile(file) {
  const reader = new McapStreamReader({
    validateCrcs: true,
    decompressHandlers: {
      zstd: (buffer, size) => zstd.decompress(buffer, Number(size)),
      lz4: (buffer, size) => lz4.decompress(buffer, Number(size)),
    },
  });
  reader.append(new Uint8Array(readFileSync(file)));
  const out = { header: null, schemas: [], channels: [], messages: [], chunks: 0, complete: false, error: null };
  const seen = { schemas: new Set(), channels: new Set() };
  try {
    for (let record; (record = reader.nextRecord()); ) {
      switch (record.type) {
        case "Header":
          out.header = { profile: record.profile, library: record.library };
          break;
        case "Schema": // repeated in the summary section: listed once
          if (!seen.schemas.has(record.id))
            out.schemas.push({ id: record.id, name: record.name, encoding: record.encoding, data: text.decode(record.data) });
          seen.schemas.add(record.id);
          break;
        case "Channel":
          if (!seen.channels.has(record.id))
            out.channels.push({ id: record.id, schemaId: record.schemaId, topic: record.topic, messageEncoding: record.messageEncoding, metadata: Object.fromEntries(record.metadata) });
          seen.channels.add(record.id);
          break;
        case "Message":
          out.messages.push({ channelId: record.channelId, sequence: record.sequence, logTime: record.logTime.toString(), publishTime: record.publishTime.toString(), data: text.decode(record.data) });
          break;
        case "ChunkIndex":
          out.chunks += 1;
          break;
        default:
          break;
      }
    }
    out.complete = reader.done();
  } catch (e) {
    out.error = e.message;
  }
  process.stdout.write(JSON.stringify(out) + "\n");
}

if (command === "write") await writeFiles(target);
else readFile(target);
