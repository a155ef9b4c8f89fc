// A Foxglove WebSocket client made of @foxglove/ws-protocol's FoxgloveClient
// (over the `ws` package): connects to URL, subscribes to every channel the
// server advertises, and prints, as one JSON object, the server's info, the
// channels and every message received (payloads of JSON channels parsed)
// once COUNT messages have arrived or the server closed the connection.
// Fails after TIMEOUT seconds (default 60).
//
//   node ws_client.cjs URL COUNT [TIMEOUT]
"use strict";
const tools = require("./bag_tools.cjs");
const { FoxgloveClient } = tools.need("@foxglove/ws-protocol");
const WebSocket = tools.need("ws");

const [url, countText, timeoutText] = process.argv.slice(2);
const count = Number(countText);
const result = { serverInfo: null, channels: [], messages: [], closed: false };
let done = false;

function finish(code) {
  if (done) return;
  done = true;
  console.log(JSON.stringify(result));
  process.exit(code);
}

const ws = new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]);
const client = new FoxgloveClient({ ws });
const channels = new Map();
const subscriptions = new Map();
client.on("serverInfo", (info) => {
  result.serverInfo = info;
});
client.on("advertise", (advertised) => {
  for (const channel of advertised) {
    channels.set(channel.id, channel);
    result.channels.push(channel);
    subscriptions.set(client.subscribe(channel.id), channel);
  }
});
client.on("message", ({ subscriptionId, timestamp, data }) => {
  const channel = subscriptions.get(subscriptionId);
  const message = { topic: channel.topic, timestamp: timestamp.toString() };
  const bytes = new Uint8Array(data.buffer, data.byteOffset, data.byteLength);
  if (channel.encoding === "json") message.json = JSON.parse(new TextDecoder().decode(bytes));
  result.messages.push(message);
  if (result.messages.length >= count) finish(0);
});
client.on("error", (e) => {
  result.error = String(e && e.message ? e.message : e);
});
client.on("close", () => {
  result.closed = true;
  finish(0);
});
setTimeout(() => {
  result.error = "timed out";
  finish(1);
}, 1000 * Number(timeoutText || 60));
