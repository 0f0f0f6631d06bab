// Independent check of imukit's MCAP files: reads them with the MCAP project's own TypeScript
// reader (@mcap/core, both the streaming reader and the indexed reader that trusts imukit's
// summary, chunk indexes and message indexes) and decodes sensor_msgs/msg/Imu with Foxglove's
// ROS 2 CDR decoder, driven by the schema text stored in the file.
//   node check_mcap.mjs FILE.mcap EXPECTED.json
// EXPECTED: {"channels": {topic: count}, "first": {topic, log_time_ns, angular_velocity: [...],
//            linear_acceleration: [...]}}. Prints "N passed, M failed"; exits 1 on any failure.
import { readFileSync } from "node:fs";
import { crc32 } from "node:zlib";
import { McapIndexedReader, McapStreamReader } from "@mcap/core";
import { parse } from "@foxglove/rosmsg";
import { MessageReader } from "@foxglove/rosmsg2-serialization";
import { decompress } from "fzstd";

const [file, expectedPath] = process.argv.slice(2);
const bytes = new Uint8Array(readFileSync(file));
const expected = JSON.parse(readFileSync(expectedPath, "utf8"));
const decompressHandlers = { zstd: (data, size) => decompress(data, new Uint8Array(Number(size))) };
let passed = 0;
let failed = 0;
const check = (ok, what) => {
  console.log(`${ok ? "ok:  " : "FAIL:"} ${what}`);
  ok ? passed++ : failed++;
};

// 1. Streaming reader with CRC validation: every record of the file, in order.
const stream = new McapStreamReader({ decompressHandlers, validateCrcs: true });
stream.append(bytes);
const schemas = new Map();
const channels = new Map();
const counts = new Map();
let firstImu;
let footer = false;
for (let r; (r = stream.nextRecord()); ) {
  if (r.type === "Schema") schemas.set(r.id, r);
  if (r.type === "Channel") channels.set(r.id, r);
  if (r.type === "Footer") footer = true;
  if (r.type === "Message") {
    const topic = channels.get(r.channelId).topic;
    counts.set(topic, (counts.get(topic) ?? 0) + 1);
    if (topic === expected.first.topic && !firstImu) firstImu = r;
  }
}
check(stream.done() && footer, "stream reader reaches the footer with every CRC valid");
for (const [topic, n] of Object.entries(expected.channels)) {
  check(counts.get(topic) === n, `${topic}: ${counts.get(topic)} messages (expected ${n})`);
}

// 2. Decode the first IMU message with the schema text from the file.
const channel = channels.get(firstImu.channelId);
const schema = schemas.get(channel.schemaId);
check(schema.name === "sensor_msgs/msg/Imu" && schema.encoding === "ros2msg" &&
      channel.messageEncoding === "cdr", "IMU channel is sensor_msgs/msg/Imu, ros2msg + cdr");
const reader = new MessageReader(parse(new TextDecoder().decode(schema.data), { ros2: true }));
const msg = reader.readMessage(firstImu.data);
check(firstImu.logTime === BigInt(expected.first.log_time_ns),
      `first log_time ${firstImu.logTime} ns`);
const stampNs = BigInt(msg.header.stamp.sec) * 1000000000n + BigInt(msg.header.stamp.nanosec);
check(stampNs === BigInt(expected.first.log_time_ns), `header.stamp ${stampNs} ns equals log_time`);
const v = msg.angular_velocity;
const a = msg.linear_acceleration;
check([v.x, v.y, v.z].every((x, i) => x === expected.first.angular_velocity[i]),
      `angular_velocity ${[v.x, v.y, v.z]} decoded exactly`);
check([a.x, a.y, a.z].every((x, i) => x === expected.first.linear_acceleration[i]),
      `linear_acceleration ${[a.x, a.y, a.z]} decoded exactly`);
check(msg.orientation_covariance[0] === -1, "orientation marked as not provided (covariance[0] = -1)");

// 3. Indexed reader: uses imukit's summary, chunk indexes and message indexes.
const readable = {
  size: async () => BigInt(bytes.length),
  read: async (offset, size) => bytes.subarray(Number(offset), Number(offset + size)),
};
const indexed = await McapIndexedReader.Initialize({ readable, decompressHandlers });
let indexedCount = 0;
for await (const m of indexed.readMessages({ validateCrcs: true })) indexedCount++;
const total = Object.values(expected.channels).reduce((s, n) => s + n, 0);
check(indexedCount === total, `indexed reader finds ${indexedCount} messages through the indexes`);
check(indexed.statistics && indexed.statistics.messageCount === BigInt(total),
      "statistics record counts every message");
const dataEnd = Number(indexed.footer.summaryStart) - 13;  // Data End: opcode, length, crc
check(indexed.dataSectionCrc === crc32(bytes.subarray(0, dataEnd)),
      "data section CRC covers every byte before Data End");

console.log(`${passed} passed, ${failed} failed`);
process.exit(failed ? 1 : 0);
