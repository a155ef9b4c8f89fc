// Helpers shared by the Node scripts of skidimm's ROS 2 tests: MCAP files
// written by @mcap/core (an implementation nobody here wrote), messages
// serialized by @foxglove/rosmsg2-serialization from definitions parsed by
// @foxglove/rosmsg. The packages are installed by scripts/setup.sh outside
// the source tree; NODE_PATH points at them (tests/CMakeLists.txt).
"use strict";

function need(name) {
  try {
    return require(name);
  } catch (e) {
    console.error(
      `cannot load the npm package ${name} (${e.message.split("\n")[0]}): ` +
        "run scripts/setup.sh, which installs tests/ros/package.json's packages, and give their node_modules in NODE_PATH",
    );
    process.exit(2);
  }
}

const fs = require("fs");
const mcap = need("@mcap/core");
const rosmsg = need("@foxglove/rosmsg");
const serialization = need("@foxglove/rosmsg2-serialization");
const zstd = need("@foxglove/wasm-zstd");
const lz4 = need("lz4js");

// A file opened for McapWriter: {position(), write()}.
class FileWritable {
  constructor(path) {
    this.fd = fs.openSync(path, "w");
    this.offset = 0n;
  }
  position() {
    return this.offset;
  }
  async write(buffer) {
    fs.writeSync(this.fd, buffer);
    this.offset += BigInt(buffer.byteLength);
  }
  close() {
    fs.closeSync(this.fd);
  }
}

// Options: compression "zstd" | "lz4" | "" ; chunked (default true);
// summary (default true: statistics, chunk and message indexes, summary
// offsets); chunkSize (bytes, default 64 KiB, so a run has several chunks).
async function openMcap(path, options = {}) {
  const compression = options.compression === undefined ? "zstd" : options.compression;
  const summary = options.summary !== false;
  if (compression === "zstd") await zstd.isLoaded;
  const writable = new FileWritable(path);
  let compressChunk;
  if (compression === "zstd") {
    compressChunk = (data) => ({ compression: "zstd", compressedData: zstd.compress(data, 3) });
  } else if (compression === "lz4") {
    compressChunk = (data) => ({ compression: "lz4", compressedData: lz4.compress(data) });
  }
  const writer = new mcap.McapWriter({
    writable,
    useChunks: options.chunked !== false,
    chunkSize: options.chunkSize || 64 * 1024,
    compressChunk,
    useStatistics: summary,
    useSummaryOffsets: summary,
    useChunkIndex: summary,
    useMessageIndex: summary,
    useAttachmentIndex: summary,
    useMetadataIndex: summary,
    repeatSchemas: summary,
    repeatChannels: summary,
  });
  await writer.start({ profile: "ros2", library: "@mcap/core (skidimm tests)" });
  const topics = new Map();
  return {
    // `definition`: ros2msg text ("" for a schema without one, as rosbag2
    // writes when it cannot find a type's definition), or null for a channel
    // without a schema.
    async addTopic(topic, type, definition, messageEncoding = "cdr") {
      let schemaId = 0;
      if (definition !== null) {
        schemaId = await writer.registerSchema({
          name: type,
          encoding: options.schemaEncoding || "ros2msg",
          data: new TextEncoder().encode(definition),
        });
      }
      const channelId = await writer.registerChannel({
        topic,
        schemaId,
        messageEncoding,
        metadata: new Map([["offered_qos_profiles", ""]]),
      });
      const writerDefinition = options.serializeWith ? options.serializeWith(type) : definition;
      const messageWriter = !writerDefinition || messageEncoding !== "cdr" ? null
        : new serialization.MessageWriter(rosmsg.parse(writerDefinition, { ros2: true }));
      topics.set(topic, { channelId, sequence: 0, writer: messageWriter });
    },
    // Serializes `message` with the topic's definition; `bytes` instead writes them as they are.
    async add(topic, logTimeNs, message, bytes) {
      const t = topics.get(topic);
      const data = bytes || t.writer.writeMessage(message);
      await writer.addMessage({
        channelId: t.channelId,
        sequence: t.sequence++,
        logTime: BigInt(logTimeNs),
        publishTime: BigInt(logTimeNs),
        data,
      });
    },
    async close() {
      await writer.end();
      writable.close();
    },
  };
}

// The complete ros2msg definitions rosbag2 stores for the types the tests use.
const SEPARATOR = "=".repeat(80);
const DEFINITIONS = {
  "builtin_interfaces/msg/Time": "int32 sec\nuint32 nanosec\n",
  "std_msgs/msg/Header": "# Standard metadata\nbuiltin_interfaces/Time stamp\nstring frame_id\n",
  "geometry_msgs/msg/Vector3": "float64 x\nfloat64 y\nfloat64 z\n",
  "geometry_msgs/msg/Quaternion": "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n",
  "sensor_msgs/msg/Imu":
    "std_msgs/Header header\ngeometry_msgs/Quaternion orientation\nfloat64[9] orientation_covariance # Row major\n" +
    "geometry_msgs/Vector3 angular_velocity\nfloat64[9] angular_velocity_covariance\n" +
    "geometry_msgs/Vector3 linear_acceleration\nfloat64[9] linear_acceleration_covariance\n",
  "sensor_msgs/msg/JointState":
    "std_msgs/Header header\n\nstring[] name\nfloat64[] position\nfloat64[] velocity\nfloat64[] effort\n",
};
const DEPENDENCIES = {
  "std_msgs/msg/Header": ["builtin_interfaces/msg/Time"],
  "sensor_msgs/msg/Imu": ["std_msgs/msg/Header", "builtin_interfaces/msg/Time", "geometry_msgs/msg/Quaternion", "geometry_msgs/msg/Vector3"],
  "sensor_msgs/msg/JointState": ["std_msgs/msg/Header", "builtin_interfaces/msg/Time"],
};
// The dependencies are named "package/Type" after MSG:, as the fields name
// them: @foxglove/rosmsg resolves a field's type by that exact name.
function completeDefinition(type) {
  let text = DEFINITIONS[type];
  for (const dep of DEPENDENCIES[type] || []) text += `${SEPARATOR}\nMSG: ${dep.replace("/msg/", "/")}\n${DEFINITIONS[dep]}`;
  return text;
}

// Seconds (a CSV cell's text) to a ROS time, exactly: the decimal digits
// themselves, not through a double, so "0.15384615384615385" is 153846154 ns.
function stampOf(text) {
  let t = text.trim();
  let negative = false;
  if (t.startsWith("-")) {
    negative = true;
    t = t.slice(1);
  }
  let [whole, frac = ""] = t.split(".");
  if (/e/i.test(t)) {
    const ns = BigInt(Math.round(Number(text) * 1e9));
    return { sec: Number(ns / 1000000000n), nanosec: Number(ns % 1000000000n) };
  }
  frac = (frac + "0000000000").slice(0, 10);
  let ns = BigInt(whole || "0") * 1000000000n + BigInt(frac.slice(0, 9));
  if (Number(frac[9]) >= 5) ns += 1n;  // round half up on the tenth digit
  if (negative) ns = -ns;
  const sec = ns >= 0n ? ns / 1000000000n : -((-ns + 999999999n) / 1000000000n);
  return { sec: Number(sec), nanosec: Number(ns - sec * 1000000000n) };
}
function nanoseconds(stamp) {
  return BigInt(stamp.sec) * 1000000000n + BigInt(stamp.nanosec);
}

// A CSV file as {header, rows (arrays of cell texts)}.
function readCsv(path) {
  const lines = fs.readFileSync(path, "utf8").split(/\r?\n/).filter((l) => l.length > 0);
  const header = lines[0].split(",");
  return { header, rows: lines.slice(1).map((l) => l.split(",")) };
}

module.exports = { need, mcap, rosmsg, serialization, zstd, lz4, openMcap, completeDefinition, stampOf, nanoseconds, readCsv, SEPARATOR };
