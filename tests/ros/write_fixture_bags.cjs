// Writes the MCAP files skidimm's reader tests (tests/ros/*_test.cc) read,
// with @mcap/core and @foxglove/rosmsg2-serialization, and beside each a
// ".expected" file of what every message holds: one line per message and
// field, "message<TAB>path<TAB>value", the value as JavaScript prints it
// (the shortest text that reads back to the same double; "nan" where the
// message lacks the field, "text:..." for strings).
//
//   node write_fixture_bags.cjs OUTPUT_DIRECTORY
"use strict";
const fs = require("fs");
const path = require("path");
const tools = require("./bag_tools.cjs");
const cdr = tools.need("@foxglove/cdr");

const out = process.argv[2];
fs.mkdirSync(out, { recursive: true });

// A small deterministic generator (mulberry32), so the files are the same on every machine.
function random(seed) {
  let a = seed >>> 0;
  return () => {
    a = (a + 0x6d2b79f5) >>> 0;
    let t = a;
    t = Math.imul(t ^ (t >>> 15), t | 1);
    t ^= t + Math.imul(t ^ (t >>> 7), t | 61);
    return ((t ^ (t >>> 14)) >>> 0) / 4294967296;
  };
}

// A type with every primitive, arrays of each kind, nested and bounded types.
// Stored as rosbag2 writes it: "MSG: package/msg/Type" after the separator.
const ALL_TYPES_BODY = `# Every kind of field the reader must step over or read
bool b
byte y
char c
int8 i8
uint8 u8
int16 i16
uint16 u16
int32 i32
uint32 u32
int64 i64
uint64 u64
float32 f32
float64 f64
string s
string<=8 bounded
builtin_interfaces/Time stamp
float64[3] fixed
int16[] seq
uint8 after_seq
string[] name
float32[] velocity
geometry_msgs/Vector3[] vectors
Inner[2] inner
Inner[<=3] bounded_inner
int32 CONSTANT=7
string GREETING="a # is kept in a constant"
float64 with_default 1.5
`;
const INNER = "string label\nuint8 flag\nfloat64 x\n";
function allTypesDefinition(msgForm) {
  const sep = tools.SEPARATOR;
  const n = (t) => (msgForm ? t : t.replace("/msg/", "/"));
  return (
    ALL_TYPES_BODY +
    `${sep}\nMSG: ${n("skidimm_test/msg/Inner")}\n${INNER}` +
    `${sep}\nMSG: ${n("builtin_interfaces/msg/Time")}\nint32 sec\nuint32 nanosec\n` +
    `${sep}\nMSG: ${n("geometry_msgs/msg/Vector3")}\nfloat64 x\nfloat64 y\nfloat64 z\n`
  );
}
// @foxglove/rosmsg resolves "Inner" in the package of the type it appears in.
const SERIALIZE_AS = allTypesDefinition(false).replace(/^Inner\[/gm, "skidimm_test/Inner[");

function text(v) {
  if (typeof v === "bigint") return v.toString();
  if (typeof v === "string") return "text:" + v;
  if (v === undefined || Number.isNaN(v)) return "nan";
  if (Object.is(v, -0)) return "-0";
  return String(v);
}

function allTypesMessages(count, seed) {
  const r = random(seed);
  const int = (lo, hi) => lo + Math.floor(r() * (hi - lo + 1));
  // ASCII only: @foxglove/cdr writes a string's UTF-16 length, which cuts
  // multi-byte UTF-8 (skidimm reads the bytes the length says).
  const word = () => ["", "a", "left", "right", "wheel", "ete", "x y"][int(0, 6)] + (r() < 0.3 ? String(int(0, 99)) : "");
  const messages = [];
  for (let k = 0; k < count; ++k) {
    const special = [0, -0, 5e-324, -1.7976931348623157e308, 1 / 3, 123456.789][k % 6];
    const names = [];
    for (let i = int(0, 4); i > 0; --i) names.push(["left", "right", "front", "back"][int(0, 3)]);
    const m = {
      b: r() < 0.5,
      y: int(-128, 127),
      c: int(0, 255),
      i8: int(-128, 127),
      u8: int(0, 255),
      i16: int(-32768, 32767),
      u16: int(0, 65535),
      i32: int(-2147483648, 2147483647),
      u32: int(0, 4294967295),
      i64: k === 0 ? -9223372036854775808n : k === 1 ? 9223372036854775807n : BigInt(int(-1e9, 1e9)) * 1000003n,
      u64: k === 0 ? 18446744073709551615n : BigInt(int(0, 2e9)) * 7919n,
      f32: Math.fround((r() - 0.5) * 1000),
      f64: k < 6 ? special : (r() - 0.5) * Math.pow(10, int(-20, 20)),
      s: word(),
      bounded: word().slice(0, 8),
      stamp: { sec: int(0, 100000), nanosec: int(0, 999999999) },
      fixed: [r(), -r(), r() * 1e6],
      seq: Array.from({ length: int(0, 7) }, () => int(-32768, 32767)),
      after_seq: int(0, 255),
      name: names,
      velocity: names.map(() => Math.fround(r() * 10 - 5)),
      vectors: Array.from({ length: int(0, 3) }, () => ({ x: r(), y: -r(), z: r() * 100 })),
      inner: [0, 1].map(() => ({ label: word(), flag: int(0, 255), x: r() - 0.5 })),
      bounded_inner: Array.from({ length: int(0, 3) }, () => ({ label: word(), flag: int(0, 255), x: r() })),
      with_default: r() * 3,
    };
    messages.push(m);
  }
  return messages;
}

// What a reader must find at each path of an AllTypes message.
function allTypesExpected(m) {
  const e = {};
  for (const f of ["b", "y", "c", "i8", "u8", "i16", "u16", "i32", "u32", "i64", "u64", "f32", "f64", "after_seq", "with_default"]) {
    e[f] = typeof m[f] === "boolean" ? (m[f] ? 1 : 0) : m[f];
  }
  // A byte is written as an int8 by @foxglove/rosmsg (normalizeType), read back by skidimm as an unsigned byte.
  e.y = m.y < 0 ? m.y + 256 : m.y;
  e.s = m.s;
  e.bounded = m.bounded;
  e["stamp"] = (m.stamp.sec * 1e9 + m.stamp.nanosec) / 1e9;
  e["fixed[0]"] = m.fixed[0];
  e["fixed[2]"] = m.fixed[2];
  e["seq[0]"] = m.seq[0];
  e["seq[5]"] = m.seq[5];
  e["name[0]"] = m.name[0];
  e["velocity[1]"] = m.velocity[1];
  e["velocity[left]"] = m.velocity[m.name.indexOf("left")];
  e["velocity[back]"] = m.velocity[m.name.indexOf("back")];
  e["vectors[1].y"] = m.vectors[1] ? m.vectors[1].y : undefined;
  e["vectors[0].z"] = m.vectors[0] ? m.vectors[0].z : undefined;
  e["inner[1].label"] = m.inner[1].label;
  e["inner[0].x"] = m.inner[0].x;
  e["inner[1].flag"] = m.inner[1].flag;
  e["bounded_inner[2].flag"] = m.bounded_inner[2] ? m.bounded_inner[2].flag : undefined;
  return e;
}

function writeExpected(file, rows) {
  const lines = [];
  rows.forEach((e, k) => {
    for (const [p, v] of Object.entries(e)) lines.push(`${k + 1}\t${p}\t${typeof v === "string" ? "text:" + v : text(v)}`);
  });
  fs.writeFileSync(file, lines.join("\n") + "\n");
}

async function writeAllTypes(name, options, count = 120) {
  const messages = allTypesMessages(count, 20261126);
  const bag = await tools.openMcap(path.join(out, name + ".mcap"), {
    ...options,
    chunkSize: 2048,
    serializeWith: () => SERIALIZE_AS,
  });
  await bag.addTopic("/all_types", "skidimm_test/msg/AllTypes", allTypesDefinition(true));
  let t = 1700000000n * 1000000000n;
  for (const m of messages) {
    t += 10000000n;
    await bag.add("/all_types", t, m);
  }
  await bag.close();
  writeExpected(path.join(out, name + ".expected"), messages.map(allTypesExpected));
}

// A bag of standard ROS 2 types (zstd chunks, complete definitions) with these [topic, type] pairs.
async function rosBag(name, topics) {
  const bag = await tools.openMcap(path.join(out, name + ".mcap"), {
    compression: "zstd",
    serializeWith: (type) => tools.completeDefinition(type),
  });
  for (const [topic, type] of topics) await bag.addTopic(topic, type, tools.completeDefinition(type));
  return bag;
}

async function main() {
  await writeAllTypes("all_types", { compression: "zstd" });
  await writeAllTypes("all_types_lz4", { compression: "lz4" });
  await writeAllTypes("all_types_uncompressed", { compression: "" });
  await writeAllTypes("all_types_unchunked", { compression: "", chunked: false });
  await writeAllTypes("all_types_no_summary", { compression: "zstd", summary: false });

  // Big-endian CDR, written field by field with @foxglove/cdr.
  {
    const bag = await tools.openMcap(path.join(out, "big_endian.mcap"), { compression: "" });
    const def = "std_msgs/Header header\ngeometry_msgs/Vector3 vector\n" +
      `${tools.SEPARATOR}\nMSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n` +
      `${tools.SEPARATOR}\nMSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n` +
      `${tools.SEPARATOR}\nMSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n`;
    await bag.addTopic("/vector", "geometry_msgs/msg/Vector3Stamped", def);
    const rows = [];
    for (let k = 0; k < 5; ++k) {
      const w = new cdr.CdrWriter({ kind: cdr.EncapsulationKind.CDR_BE });
      w.int32(k);
      w.uint32(250000000 * k);
      w.string("frame" + k);
      w.float64(k + 0.5);
      w.float64(-k / 3);
      w.float64(1e300 * k);
      await bag.add("/vector", 1000000000 * (k + 1), null, w.data);
      rows.push({ "header.stamp": k + 0.25 * k, "header.frame_id": "frame" + k, "vector.x": k + 0.5, "vector.y": -k / 3, "vector.z": 1e300 * k });
    }
    await bag.close();
    writeExpected(path.join(out, "big_endian.expected"), rows);
  }

  // Imu with an empty schema, as rosbag2 writes a type it has no definition of (bundled definitions), a type stored only as IDL,
  // a topic in JSON, and a chunk holding a marker text for the CRC tests.
  {
    const bag = await tools.openMcap(path.join(out, "mixed.mcap"), {
      compression: "",
      serializeWith: (type) => (type === "sensor_msgs/msg/Imu" ? tools.completeDefinition(type) : "string data\n"),
    });
    await bag.addTopic("/imu/data", "sensor_msgs/msg/Imu", "");
    await bag.addTopic("/marker", "std_msgs/msg/String", "string data\n");
    await bag.addTopic("/json", "std_msgs/msg/String", "string data\n", "json");
    const rows = [];
    for (let k = 0; k < 4; ++k) {
      const stamp = { sec: 10 + k, nanosec: 5000000 * k };
      await bag.add("/imu/data", 2000000000n + BigInt(k) * 10000000n, {
        header: { stamp, frame_id: "imu" },
        orientation: { x: 0, y: 0, z: 0, w: 1 },
        orientation_covariance: new Array(9).fill(0),
        angular_velocity: { x: k, y: -k, z: 0.125 * k },
        angular_velocity_covariance: new Array(9).fill(0),
        linear_acceleration: { x: 0, y: 0, z: 9.81 },
        linear_acceleration_covariance: new Array(9).fill(0),
      });
      rows.push({ "header.stamp": stamp.sec + stamp.nanosec / 1e9, "angular_velocity.z": 0.125 * k, "linear_acceleration.z": 9.81 });
      await bag.add("/marker", 2000000000n + BigInt(k) * 10000000n + 1n, { data: "SKIDIMM_MARKER_" + k });
      await bag.add("/json", 2000000000n + BigInt(k) * 10000000n + 2n, null, new TextEncoder().encode(JSON.stringify({ data: "x" })));
    }
    await bag.close();
    writeExpected(path.join(out, "mixed_imu.expected"), rows);
  }
  // /joint_states shared by two publishers, each stamping on its own clock: the wheels (left, right) and an arm
  // whose stamps run 30 ms ahead, recorded in arrival order, so the topic's stamps go back and forth.
  {
    const bag = await rosBag("two_publishers", [["/joint_states", "sensor_msgs/msg/JointState"]]);
    const rows = [];
    for (let k = 0; k < 20; ++k) {
      const ns = BigInt(k) * 100000000n;
      const stamp = (t) => ({ sec: Number(t / 1000000000n), nanosec: Number(t % 1000000000n) });
      await bag.add("/joint_states", 1000000000n + ns, {
        header: { stamp: stamp(ns + 30000000n), frame_id: "arm" }, name: ["arm_joint"], position: [0.5], velocity: [0.25], effort: [1],
      });
      await bag.add("/joint_states", 1000000000n + ns + 1000n, {
        header: { stamp: stamp(ns), frame_id: "base" }, name: ["left", "right"], position: [], velocity: [k / 8, -k / 8], effort: [2 * k, 3],
      });
      rows.push({ "header.stamp": k / 10, "velocity[left]": k / 8, "effort[left]": 2 * k });
    }
    await bag.close();
    writeExpected(path.join(out, "two_publishers.expected"), rows);
  }
  // A topic with no message beside one with messages (a driver that never published).
  {
    const bag = await rosBag("silent_topic", [["/imu/data", "sensor_msgs/msg/Imu"], ["/joint_states", "sensor_msgs/msg/JointState"]]);
    for (let k = 0; k < 5; ++k) {
      await bag.add("/joint_states", 1000000000n + BigInt(k) * 100000000n, {
        header: { stamp: { sec: 1, nanosec: k * 100000000 }, frame_id: "base" },
        name: ["left", "right"], position: [], velocity: [k / 8, -k / 8], effort: [2 * k, 3],
      });
    }
    await bag.close();
  }
  // A recording closed before any message arrived: its topics and a summary, no chunk.
  {
    const bag = await rosBag("empty", [["/imu/data", "sensor_msgs/msg/Imu"]]);
    await bag.close();
  }
  // Two topics stamped by different clocks: the IMU's from its driver's start, the joints' in Unix time.
  {
    const bag = await rosBag("two_clocks", [["/imu/data", "sensor_msgs/msg/Imu"], ["/joint_states", "sensor_msgs/msg/JointState"]]);
    const zeros = new Array(9).fill(0);
    for (let k = 0; k < 20; ++k) {
      const log = 1700000000000000000n + BigInt(k) * 100000000n;
      await bag.add("/imu/data", log, {
        header: { stamp: { sec: Math.floor(k / 10), nanosec: (k % 10) * 100000000 }, frame_id: "imu" },
        orientation: { x: 0, y: 0, z: 0, w: 1 }, orientation_covariance: zeros,
        angular_velocity: { x: 0, y: 0, z: k / 16 }, angular_velocity_covariance: zeros,
        linear_acceleration: { x: 0, y: 0, z: 9.81 }, linear_acceleration_covariance: zeros,
      });
      await bag.add("/joint_states", log + 1000n, {
        header: { stamp: { sec: 1700000000 + Math.floor(k / 10), nanosec: (k % 10) * 100000000 }, frame_id: "base" },
        name: ["left", "right"], position: [], velocity: [k / 8, -k / 8], effort: [2 * k, 3],
      });
    }
    await bag.close();
  }
  {
    const bag = await tools.openMcap(path.join(out, "idl.mcap"), {
      compression: "zstd",
      schemaEncoding: "ros2idl",
      serializeWith: (type) => (type === "sensor_msgs/msg/Imu" ? tools.completeDefinition(type) : "float64 data\n"),
    });
    await bag.addTopic("/imu/data", "sensor_msgs/msg/Imu", "module sensor_msgs { module msg { struct Imu { }; }; };");
    await bag.addTopic("/custom", "my_msgs/msg/Custom", "module my_msgs { module msg { struct Custom { double data; }; }; };");
    await bag.add("/custom", 5n, { data: 1.5 });
    await bag.close();
  }
}

main().catch((e) => {
  console.error(e.stack || String(e));
  process.exit(1);
});
