// Reads an MCAP file with @mcap/core, both ways it can: McapIndexedReader
// (summary, chunk and message indexes, every CRC checked) and
// McapStreamReader (front to back, CRCs checked), and prints what it holds
// as one JSON object: {profile, library, channels: [{topic, messageEncoding,
// schemaName, schemaEncoding, schema}], statistics: {messageCount,
// channelMessageCounts}, messages: [{topic, logTime, publishTime, json |
// base64}]}. Fails (exit 1) if the two readers disagree or either refuses
// the file.
//
//   node read_mcap.cjs FILE.mcap
"use strict";
const fs = require("fs");
const tools = require("./bag_tools.cjs");

async function main() {
  await tools.zstd.isLoaded;
  const file = process.argv[2];
  const bytes = fs.readFileSync(file);
  const decompressHandlers = {
    zstd: (data, size) => tools.zstd.decompress(data, Number(size)),
    lz4: (data) => tools.lz4.decompress(data),
  };
  const readable = {
    size: async () => BigInt(bytes.length),
    read: async (offset, length) => new Uint8Array(bytes.buffer, bytes.byteOffset + Number(offset), Number(length)),
  };
  const indexed = await tools.mcap.McapIndexedReader.Initialize({ readable, decompressHandlers });
  const describe = (m, channels, schemas) => {
    const channel = channels.get(m.channelId);
    const out = { topic: channel.topic, logTime: m.logTime.toString(), publishTime: m.publishTime.toString() };
    if (channel.messageEncoding === "json") out.json = JSON.parse(new TextDecoder().decode(m.data));
    else out.base64 = Buffer.from(m.data).toString("base64");
    return out;
  };
  const messages = [];
  for await (const m of indexed.readMessages()) messages.push(describe(m, indexed.channelsById, indexed.schemasById));

  // The same file front to back.
  const stream = new tools.mcap.McapStreamReader({ decompressHandlers, validateCrcs: true });
  stream.append(bytes);
  const channels = new Map();
  const streamed = [];
  let footer = false;
  for (let r; (r = stream.nextRecord()); ) {
    if (r.type === "Channel") channels.set(r.id, r);
    if (r.type === "Message") streamed.push(describe(r, channels, null));
    if (r.type === "Footer") footer = true;
  }
  if (!stream.done() || !footer) throw new Error("the stream reader did not reach a complete file's end");
  // Sorted by log time, the two must agree message for message.
  const key = (m) => JSON.stringify(m);
  const sorted = (list) => list.slice().sort((a, b) => (BigInt(a.logTime) < BigInt(b.logTime) ? -1 : BigInt(a.logTime) > BigInt(b.logTime) ? 1 : 0));
  const a = sorted(messages).map(key), b = sorted(streamed).map(key);
  if (a.length !== b.length || a.some((x, i) => x !== b[i])) throw new Error("the indexed and stream readers disagree");

  const channelList = [...indexed.channelsById.values()].map((c) => {
    const s = indexed.schemasById.get(c.schemaId);
    return {
      topic: c.topic,
      messageEncoding: c.messageEncoding,
      schemaName: s ? s.name : "",
      schemaEncoding: s ? s.encoding : "",
      schema: s ? new TextDecoder().decode(s.data) : "",
    };
  });
  const stats = indexed.statistics;
  console.log(JSON.stringify({
    profile: indexed.header.profile,
    library: indexed.header.library,
    channels: channelList,
    statistics: stats ? {
      messageCount: stats.messageCount.toString(),
      channelMessageCounts: Object.fromEntries([...stats.channelMessageCounts].map(([id, n]) => [indexed.channelsById.get(id).topic, n.toString()])),
    } : null,
    chunks: indexed.chunkIndexes.length,
    messages,
  }));
}

main().catch((e) => {
  console.error(e.stack || String(e));
  process.exit(1);
});
