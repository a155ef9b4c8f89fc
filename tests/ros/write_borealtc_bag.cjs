// Writes one BorealTC run (TERRAIN/pro_NN.csv + imu_NN.csv) as a ROS 2 bag
// recorded the way a Husky driver publishes it:
//   /imu/data      sensor_msgs/msg/Imu: angular_velocity = (wx, wy, wz),
//                  linear_acceleration = (ax, ay, az)
//   /joint_states  sensor_msgs/msg/JointState: name [left, right],
//                  velocity [velL, velR], effort [curL, curR]
// header.stamp is the CSV's time (its decimal digits rounded to the
// nanosecond); the log time is the stamp plus a reception delay that
// differs per topic (2 ms for the IMU, 9 ms for the joints), so a reader
// that used log times instead of stamps would step differently.
// The numbers are the CSV cells read by JavaScript (the same doubles as any
// correct reader of the CSV).
//
//   node write_borealtc_bag.cjs PRO IMU OUT.mcap [--compression zstd|lz4|none] [--no-summary] [--no-schemas]
//                               [--stamp-back ROW:MS]
// (--no-schemas: schemas with the type's name and no definition; --stamp-back:
// the header.stamp of the IMU file's data row ROW, from 0, MS milliseconds
// earlier, its log time unchanged, as a driver stamping on another thread
// writes now and then)
//   node write_borealtc_bag.cjs PRO IMU OUT.jsonl   (messages for write_db3.py)
"use strict";
const fs = require("fs");
const tools = require("./bag_tools.cjs");

async function main() {
  const args = process.argv.slice(2);
  const valued = ["--compression", "--stamp-back"];
  const positional = args.filter((a, i) => !a.startsWith("--") && !(i > 0 && valued.includes(args[i - 1])));
  const [proPath, imuPath, out] = positional;
  const option = (name) => args.includes(name);
  const compressionIndex = args.indexOf("--compression");
  let compression = compressionIndex >= 0 ? args[compressionIndex + 1] : "zstd";
  if (compression === "none") compression = "";

  const pro = tools.readCsv(proPath);
  const imu = tools.readCsv(imuPath);
  const column = (csv, name) => {
    const i = csv.header.indexOf(name);
    if (i < 0) throw new Error(`${name} not in ${csv.header}`);
    return i;
  };
  const messages = [];
  const [pt, cl, cr, vl, vr] = ["time", "curL", "curR", "velL", "velR"].map((n) => column(pro, n));
  for (const row of pro.rows) {
    const stamp = tools.stampOf(row[pt]);
    messages.push({
      topic: "/joint_states",
      logTime: tools.nanoseconds(stamp) + 9000000n,
      message: {
        header: { stamp, frame_id: "base_link" },
        name: ["left", "right"],
        position: [],
        velocity: [Number(row[vl]), Number(row[vr])],
        effort: [Number(row[cl]), Number(row[cr])],
      },
    });
  }
  const [it, wx, wy, wz, ax, ay, az] = ["time", "wx", "wy", "wz", "ax", "ay", "az"].map((n) => column(imu, n));
  const zeros = new Array(9).fill(0);
  for (const row of imu.rows) {
    const stamp = tools.stampOf(row[it]);
    messages.push({
      topic: "/imu/data",
      logTime: tools.nanoseconds(stamp) + 2000000n,
      message: {
        header: { stamp, frame_id: "imu_link" },
        orientation: { x: 0, y: 0, z: 0, w: 1 },
        orientation_covariance: [-1, 0, 0, 0, 0, 0, 0, 0, 0],
        angular_velocity: { x: Number(row[wx]), y: Number(row[wy]), z: Number(row[wz]) },
        angular_velocity_covariance: zeros,
        linear_acceleration: { x: Number(row[ax]), y: Number(row[ay]), z: Number(row[az]) },
        linear_acceleration_covariance: zeros,
      },
    });
  }
  const stampBackIndex = args.indexOf("--stamp-back");
  if (stampBackIndex >= 0) {
    const [row, ms] = args[stampBackIndex + 1].split(":").map(Number);
    const imuMessages = messages.filter((m) => m.topic === "/imu/data");
    const header = imuMessages[row].message.header;
    const ns = tools.nanoseconds(header.stamp) - BigInt(Math.round(ms * 1e6));
    header.stamp = { sec: Number(ns / 1000000000n), nanosec: Number(ns % 1000000000n) };
  }
  // A recorder writes in the order messages arrive.
  messages.sort((a, b) => (a.logTime < b.logTime ? -1 : a.logTime > b.logTime ? 1 : 0));
  const types = { "/imu/data": "sensor_msgs/msg/Imu", "/joint_states": "sensor_msgs/msg/JointState" };

  if (out.endsWith(".jsonl")) {
    const writers = {};
    for (const [topic, type] of Object.entries(types)) {
      writers[topic] = new tools.serialization.MessageWriter(tools.rosmsg.parse(tools.completeDefinition(type), { ros2: true }));
    }
    const lines = [JSON.stringify({ topics: Object.entries(types).map(([name, type]) => ({ name, type, definition: tools.completeDefinition(type) })) })];
    for (const m of messages) {
      const data = Buffer.from(writers[m.topic].writeMessage(m.message)).toString("base64");
      lines.push(JSON.stringify({ topic: m.topic, timestamp: m.logTime.toString(), data }));
    }
    fs.writeFileSync(out, lines.join("\n") + "\n");
    return;
  }
  const withSchemas = !option("--no-schemas");
  const bag = await tools.openMcap(out, {
    compression,
    summary: !option("--no-summary"),
    serializeWith: (type) => tools.completeDefinition(type),
  });
  for (const [topic, type] of Object.entries(types)) {
    // Without: schemas naming the type with no definition, as rosbag2 writes
    // a type whose definition it cannot find.
    await bag.addTopic(topic, type, withSchemas ? tools.completeDefinition(type) : "");
  }
  for (const m of messages) await bag.add(m.topic, m.logTime, m.message);
  await bag.close();
}

main().catch((e) => {
  console.error(e.stack || String(e));
  process.exit(1);
});
