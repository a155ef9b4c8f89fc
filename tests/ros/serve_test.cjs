// `skidimm run --serve` seen by @foxglove/ws-protocol's client: skidimm runs
// at the end of a pipe (--input -); the client connects, subscribes to what
// skidimm advertises, then the log is written into the pipe; every step the
// client receives must be the row skidimm wrote to its --output CSV (time,
// probabilities, most likely mode, decision, status), in order, with the
// step's time as the message timestamp.
//
//   node serve_test.cjs SKIDIMM BANK LOG.csv WORK_DIR
"use strict";
const fs = require("fs");
const path = require("path");
const { spawn } = require("child_process");
const tools = require("./bag_tools.cjs");
const { FoxgloveClient } = tools.need("@foxglove/ws-protocol");
const WebSocket = tools.need("ws");

const [skidimm, bank, log, work] = process.argv.slice(2);
fs.mkdirSync(work, { recursive: true });
const output = path.join(work, "served.csv");

function fail(message) {
  console.error("FAIL: " + message);
  process.exit(1);
}
setTimeout(() => fail("timed out after 120 s"), 120000);

const child = spawn(skidimm, ["run", "-q", "--bank", bank, "--input", "-", "--output", output, "--serve", "0"], {
  stdio: ["pipe", "inherit", "pipe"],
});
let stderr = "";
const received = [];
let advertised = null;
let serverName = null;
let connected = false;

child.stderr.on("data", (chunk) => {
  stderr += chunk.toString();
  const m = /serving Foxglove WebSocket on (ws:\/\/[0-9.]+:\d+)/.exec(stderr);
  if (m && !connected) {
    connected = true;
    connect(m[1]);
  }
});

function connect(url) {
  const client = new FoxgloveClient({ ws: new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]) });
  const subscriptions = new Map();
  const text = fs.readFileSync(log, "utf8");
  const firstLine = text.indexOf("\n") + 1;
  client.on("serverInfo", (info) => {
    serverName = info.name;
    // skidimm listens before the log is open; it advertises its channel once
    // the log's header (the first line) has come through the pipe.
    child.stdin.write(text.slice(0, firstLine));
  });
  client.on("advertise", (channels) => {
    advertised = channels;
    for (const c of channels) subscriptions.set(client.subscribe(c.id), c);
    // Subscribed: now the robot's log arrives through the pipe, 50 rows every
    // 20 ms (a client falling more than 1024 messages behind would lose the
    // oldest: skidimm never waits for a viewer).
    const rows = text.slice(firstLine).split(/(?<=\n)/);
    let next = 0;
    const feed = () => {
      child.stdin.write(rows.slice(next, next + 50).join(""));
      next += 50;
      if (next < rows.length) setTimeout(feed, 20);
      else child.stdin.end();
    };
    setTimeout(feed, 200);
  });
  client.on("message", ({ subscriptionId, timestamp, data }) => {
    const channel = subscriptions.get(subscriptionId);
    const bytes = new Uint8Array(data.buffer, data.byteOffset, data.byteLength);
    received.push({ topic: channel.topic, timestamp, json: JSON.parse(new TextDecoder().decode(bytes)) });
  });
  client.on("close", () => check());
}

child.on("exit", (code) => {
  if (code !== 0) fail(`skidimm exited with ${code}: ${stderr}`);
});

function check() {
  if (!advertised || advertised.length !== 1 || advertised[0].topic !== "/skidimm/estimate") {
    fail("expected one channel /skidimm/estimate, got " + JSON.stringify(advertised));
  }
  if (advertised[0].encoding !== "json" || advertised[0].schemaEncoding !== "jsonschema") fail("not a JSON channel");
  const lines = fs.readFileSync(output, "utf8").trim().split("\n");
  const header = lines[0].split(",");
  const rows = lines.slice(1).map((l) => l.split(","));
  if (received.length !== rows.length) fail(`received ${received.length} steps, the output has ${rows.length}`);
  const col = (name) => header.indexOf(name);
  rows.forEach((row, i) => {
    const m = received[i].json;
    const same = (text, value) => Number(text) === value || (text === "nan" && value === null);
    if (!same(row[col("t")], m.t)) fail(`step ${i + 1}: t ${row[col("t")]} != ${m.t}`);
    const ns = BigInt(Math.round(m.t * 1e9));
    if (received[i].timestamp !== ns) fail(`step ${i + 1}: timestamp ${received[i].timestamp} != ${ns}`);
    for (const [mode, p] of Object.entries(m.probability)) {
      if (!same(row[col("mu_" + mode)], p)) fail(`step ${i + 1}: mu_${mode} ${row[col("mu_" + mode)]} != ${p}`);
    }
    for (const name of ["mode", "decision", "status"]) {
      if (row[col(name)] !== m[name]) fail(`step ${i + 1}: ${name} ${row[col(name)]} != ${m[name]}`);
    }
  });
  console.log(`${received.length} steps received live by @foxglove/ws-protocol's client from '${serverName}', ` +
              "each equal to the row written to --output");
  process.exit(0);
}
