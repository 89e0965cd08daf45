// Writes tests/data/third_party_bag/loop.mcap with Foxglove's MCAP writer and ROS 2 CDR
// serializer (npm: @mcap/core, @mcap/nodejs, @foxglove/rosmsg, @foxglove/rosmsg2-serialization,
// @foxglove/wasm-zstd): a single robot, ROS 2 names (/scan, /odom, /tf_static; frames odom,
// base_link, base_scan), driving a loop around the corridor ring of one 16 m x 10 m floor.
// Run once by hand (npm install those packages, then node make_bag.mjs OUT.mcap); the
// file is committed, CI never runs this.
import { McapWriter } from "@mcap/core";
import { FileHandleWritable } from "@mcap/nodejs";
import { parse } from "@foxglove/rosmsg";
import { MessageWriter } from "@foxglove/rosmsg2-serialization";
import zstd from "@foxglove/wasm-zstd";
import { open } from "node:fs/promises";

// The floor's walls, metres.
const box = (x0, y0, x1, y1) => [[x0, y0, x1, y0], [x1, y0, x1, y1], [x1, y1, x0, y1], [x0, y1, x0, y0]];
export const walls = [
  ...box(0, 0, 16, 10),        // outer walls
  ...box(3.5, 3.5, 12.5, 6.5), // the block the corridor runs around
  ...box(7.75, 0.75, 8.25, 1.25), // a pillar
  [5, 9, 5, 10], [11, 9, 11, 10], // stubs on the north wall
  [15, 3, 16, 4],              // a slanted corner in the east
];

function cast(x, y, a, max) {
  const dx = Math.cos(a), dy = Math.sin(a);
  let best = Infinity;
  for (const [x0, y0, x1, y1] of walls) {
    const ex = x1 - x0, ey = y1 - y0;
    const den = dx * ey - dy * ex;
    if (Math.abs(den) < 1e-12) continue;
    const t = ((x0 - x) * ey - (y0 - y) * ex) / den;
    const u = ((x0 - x) * dy - (y0 - y) * dx) / den;
    if (t > 0 && u >= 0 && u <= 1) best = Math.min(best, t);
  }
  return best <= max ? best : Infinity;
}

// A seeded normal generator (xorshift32 + Box-Muller), so the file is the same every run.
let state = 12345;
function uniform() {
  state ^= state << 13; state >>>= 0; state ^= state >>> 17; state ^= state << 5; state >>>= 0;
  return (state + 0.5) / 4294967296;
}
const normal = () => Math.sqrt(-2 * Math.log(uniform())) * Math.cos(2 * Math.PI * uniform());

// The path: straight at 0.4 m/s, turning on the spot at 0.5 rad/s, scans at 2.5 Hz.
const corners = [[1.75, 1.75], [14.25, 1.75], [14.25, 8.25], [1.75, 8.25], [1.75, 1.75], [8, 1.75]];
const poses = [];
let x = corners[0][0], y = corners[0][1], th = 0;
const dt = 0.4;
for (let k = 1; k < corners.length; ++k) {
  const [gx, gy] = corners[k];
  const heading = Math.atan2(gy - y, gx - x);
  let turn = Math.atan2(Math.sin(heading - th), Math.cos(heading - th));
  while (Math.abs(turn) > 1e-9) {
    const step = Math.sign(turn) * Math.min(Math.abs(turn), 0.5 * dt);
    th += step; turn -= step;
    poses.push([x, y, th]);
  }
  let left = Math.hypot(gx - x, gy - y);
  while (left > 1e-9) {
    const step = Math.min(left, 0.4 * dt);
    x += step * Math.cos(th); y += step * Math.sin(th); left -= step;
    poses.push([x, y, th]);
  }
}

const definitions = (text) => parse(text, { ros2: true });
const timeMsg = "int32 sec\nuint32 nanosec";
const headerMsg = `builtin_interfaces/Time stamp\nstring frame_id\n===\nMSG: builtin_interfaces/Time\n${timeMsg}`;
const scanDef = `std_msgs/Header header\nfloat32 angle_min\nfloat32 angle_max\nfloat32 angle_increment\nfloat32 time_increment\nfloat32 scan_time\nfloat32 range_min\nfloat32 range_max\nfloat32[] ranges\nfloat32[] intensities\n================================================================================\nMSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n================================================================================\nMSG: builtin_interfaces/Time\n${timeMsg}`;
const vec = "float64 x\nfloat64 y\nfloat64 z";
const quat = "float64 x\nfloat64 y\nfloat64 z\nfloat64 w";
const sep = "\n================================================================================\n";
const odomDef = `std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/PoseWithCovariance pose\ngeometry_msgs/TwistWithCovariance twist${sep}MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id${sep}MSG: builtin_interfaces/Time\n${timeMsg}${sep}MSG: geometry_msgs/PoseWithCovariance\ngeometry_msgs/Pose pose\nfloat64[36] covariance${sep}MSG: geometry_msgs/Pose\ngeometry_msgs/Point position\ngeometry_msgs/Quaternion orientation${sep}MSG: geometry_msgs/Point\n${vec}${sep}MSG: geometry_msgs/Quaternion\n${quat}${sep}MSG: geometry_msgs/TwistWithCovariance\ngeometry_msgs/Twist twist\nfloat64[36] covariance${sep}MSG: geometry_msgs/Twist\ngeometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular${sep}MSG: geometry_msgs/Vector3\n${vec}`;
const tfDef = `geometry_msgs/TransformStamped[] transforms${sep}MSG: geometry_msgs/TransformStamped\nstd_msgs/Header header\nstring child_frame_id\ngeometry_msgs/Transform transform${sep}MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id${sep}MSG: builtin_interfaces/Time\n${timeMsg}${sep}MSG: geometry_msgs/Transform\ngeometry_msgs/Vector3 translation\ngeometry_msgs/Quaternion rotation${sep}MSG: geometry_msgs/Vector3\n${vec}${sep}MSG: geometry_msgs/Quaternion\n${quat}`;

await zstd.isLoaded;
const handle = await open(process.argv[2], "w");
const writer = new McapWriter({
  writable: new FileHandleWritable(handle),
  chunkSize: 256 * 1024,
  compressChunk: (data) => ({ compression: "zstd", compressedData: zstd.compress(data, 3) }),
});
await writer.start({ profile: "ros2", library: "mcap-js make_bag.mjs" });
const sensorQos = "- history: 1\n  depth: 5\n  reliability: 2\n  durability: 2\n  deadline:\n    sec: 2147483647\n    nsec: 4294967295\n  lifespan:\n    sec: 2147483647\n    nsec: 4294967295\n  liveliness: 1\n  liveliness_lease_duration:\n    sec: 2147483647\n    nsec: 4294967295\n  avoid_ros_namespace_conventions: false";
const staticQos = sensorQos.replace("reliability: 2\n  durability: 2", "reliability: 1\n  durability: 1");
async function channel(topic, type, text, qos) {
  const schemaId = await writer.registerSchema({ name: type, encoding: "ros2msg", data: new TextEncoder().encode(text) });
  const id = await writer.registerChannel({ topic, schemaId, messageEncoding: "cdr", metadata: new Map([["offered_qos_profiles", qos]]) });
  return { id, serializer: new MessageWriter(definitions(text)) };
}
const scanCh = await channel("/scan", "sensor_msgs/msg/LaserScan", scanDef, sensorQos);
const odomCh = await channel("/odom", "nav_msgs/msg/Odometry", odomDef, sensorQos);
const tfCh = await channel("/tf_static", "tf2_msgs/msg/TFMessage", tfDef, staticQos);
let sequence = 0;
async function put(ch, t, message) {
  const ns = BigInt(Math.round(t * 1e9));
  await writer.addMessage({ channelId: ch.id, sequence: sequence++, logTime: ns, publishTime: ns, data: ch.serializer.writeMessage(message) });
}
const stampOf = (t) => ({ sec: Math.floor(t), nanosec: Math.round((t - Math.floor(t)) * 1e9) });
const quaternion = (yaw) => ({ x: 0, y: 0, z: Math.sin(yaw / 2), w: Math.cos(yaw / 2) });
const t0 = 1700000000;
const laser = [0.1, 0.0];  // base_link -> base_scan
await put(tfCh, t0, { transforms: [{ header: { stamp: stampOf(t0), frame_id: "base_link" }, child_frame_id: "base_scan",
  transform: { translation: { x: laser[0], y: laser[1], z: 0.2 }, rotation: quaternion(0) } }] });
// Odometry drifts: 2 % of each step's length and 1 deg per metre, with noise.
let ox = poses[0][0], oy = poses[0][1], oth = poses[0][2];
const beams = 360;
for (let k = 0; k < poses.length; ++k) {
  const t = t0 + 0.1 + k * dt;
  if (k > 0) {
    const [px, py, pth] = poses[k - 1], [qx, qy, qth] = poses[k];
    const c = Math.cos(pth), s = Math.sin(pth);
    const fx = c * (qx - px) + s * (qy - py), fy = -s * (qx - px) + c * (qy - py);
    const dth = Math.atan2(Math.sin(qth - pth), Math.cos(qth - pth));
    const d = Math.hypot(fx, fy);
    const gx = fx * (1.02 + 0.005 * normal()), gy = fy, gth = dth + d * (Math.PI / 180) + 0.002 * normal();
    ox += Math.cos(oth) * gx - Math.sin(oth) * gy;
    oy += Math.sin(oth) * gx + Math.cos(oth) * gy;
    oth += gth;
  }
  await put(odomCh, t, { header: { stamp: stampOf(t), frame_id: "odom" }, child_frame_id: "base_link",
    pose: { pose: { position: { x: ox, y: oy, z: 0 }, orientation: quaternion(oth) }, covariance: new Float64Array(36) },
    twist: { twist: { linear: { x: 0, y: 0, z: 0 }, angular: { x: 0, y: 0, z: 0 } }, covariance: new Float64Array(36) } });
  const [px, py, pth] = poses[k];
  const lx = px + Math.cos(pth) * laser[0], ly = py + Math.sin(pth) * laser[0];
  const ranges = new Float32Array(beams);
  for (let b = 0; b < beams; ++b) {
    const r = cast(lx, ly, pth - Math.PI + (b * 2 * Math.PI) / beams, 8.0);
    ranges[b] = Number.isFinite(r) ? Math.round((r + 0.01 * normal()) * 1000) / 1000 : Infinity;
  }
  await put(scanCh, t, { header: { stamp: stampOf(t), frame_id: "base_scan" }, angle_min: -Math.PI,
    angle_max: Math.PI - (2 * Math.PI) / beams, angle_increment: (2 * Math.PI) / beams, time_increment: 0, scan_time: 0.1,
    range_min: 0.12, range_max: 8.0, ranges, intensities: new Float32Array(0) });
}
await writer.end();
await handle.close();
console.log(`${poses.length} scans`);
