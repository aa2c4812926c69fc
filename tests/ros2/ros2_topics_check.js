// The ROS 2 topics of rgbdmap-ros2 decoded by the reference ROS 2 CDR reader (npm
// @foxglove/rosmsg2-serialization, with the standard Jazzy definitions of @foxglove/rosmsg-msgs-common; the
// octomap_msgs/Octomap definition is written out below from its .msg file) and compared with what the run
// wrote (EXPECTED, made by test_ros2_topics.sh): the 2-D map's extent (map_<id>.pgm), the occupied voxels
// (map.bt), each robot's optimised keyframes (keyframes_<robot>.txt), the default camera mount. Writes the
// octree of /octomap_binary as a .bt file (OUT_BT) for `rgbdmap view-map` to read back.
// Usage: node ros2_topics_check.js CAPTURE_DIR EXPECTED.json OUT_BT
'use strict';
const fs = require('fs');
const { MessageReader } = require('@foxglove/rosmsg2-serialization');
const { ros2jazzy } = require('@foxglove/rosmsg-msgs-common');
const { parse } = require('@foxglove/rosmsg');

const [dir, expectedFile, outBt] = process.argv.slice(2);
const expected = JSON.parse(fs.readFileSync(expectedFile, 'utf8'));
const robots = Object.keys(expected.robots);
let failures = 0;
const ok = (m) => console.log('ok: ' + m);
const check = (cond, m) => { if (cond) ok(m); else { console.log('FAIL: ' + m); ++failures; } };

const BUILTIN = { time: 'builtin_interfaces/Time', duration: 'builtin_interfaces/Duration' };
function definitionsFor(root) {
  const seen = new Map();
  const visit = (name) => {
    if (seen.has(name)) return;
    const def = ros2jazzy[name];
    if (!def) throw new Error('@foxglove/rosmsg-msgs-common ros2jazzy has no ' + name);
    seen.set(name, def);
    for (const f of def.definitions) {
      if (f.isConstant) continue;
      if (BUILTIN[f.type]) visit(BUILTIN[f.type]);
      else if (f.isComplex) visit(f.type);
    }
  };
  visit(root);
  return [...seen.values()];
}
// octomap_msgs/msg/Octomap.msg (not in common_interfaces), with std_msgs/Header spelled out.
const OCTOMAP_MSG = `std_msgs/Header header
bool binary
string id
float64 resolution
int8[] data
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec`;

function read(topic, type) {
  const file = `${dir}/${topic.replace(/^\//, '').replace(/\//g, '_')}.cdr`;
  if (!fs.existsSync(file)) { check(false, `${topic}: a sample was captured`); return null; }
  const defs = type === 'octomap_msgs/Octomap' ? parse(OCTOMAP_MSG, { ros2: true }) : definitionsFor(type);
  const bytes = fs.readFileSync(file);
  check(bytes[0] === 0 && bytes[1] === 1, `${topic}: CDR little-endian encapsulation (${bytes.length} bytes)`);
  return new MessageReader(defs).readMessage(bytes);
}

const near = (a, b, tol) => Math.abs(a - b) <= tol;
// Poses as [x y z qx qy qz qw]: composition and the point of a position.
function compose(a, b) {
  const [ax, ay, az, aqx, aqy, aqz, aqw] = a, [bx, by, bz, bqx, bqy, bqz, bqw] = b;
  const rot = (qx, qy, qz, qw, vx, vy, vz) => {  // q v q*
    const tx = 2 * (qy * vz - qz * vy), ty = 2 * (qz * vx - qx * vz), tz = 2 * (qx * vy - qy * vx);
    return [vx + qw * tx + qy * tz - qz * ty, vy + qw * ty + qz * tx - qx * tz, vz + qw * tz + qx * ty - qy * tx];
  };
  const t = rot(aqx, aqy, aqz, aqw, bx, by, bz);
  return [ax + t[0], ay + t[1], az + t[2],
    aqw * bqx + aqx * bqw + aqy * bqz - aqz * bqy,
    aqw * bqy - aqx * bqz + aqy * bqw + aqz * bqx,
    aqw * bqz + aqx * bqy - aqy * bqx + aqz * bqw,
    aqw * bqw - aqx * bqx - aqy * bqy - aqz * bqz];
}
const fromTransform = (t) => [t.translation.x, t.translation.y, t.translation.z,
  t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w];
const fromPose = (p) => [p.position.x, p.position.y, p.position.z,
  p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w];
function samePose(a, b, tol) {
  const dot = a[3] * b[3] + a[4] * b[4] + a[5] * b[5] + a[6] * b[6];
  return near(a[0], b[0], tol) && near(a[1], b[1], tol) && near(a[2], b[2], tol) && near(Math.abs(dot), 1, 1e-6);
}

// /map: the global 2-D map, as map_<id>.pgm.
const map = read('/map', 'nav_msgs/OccupancyGrid');
if (map) {
  const { width, height, resolution } = map.info;
  check(map.header.frame_id === 'map', `/map: frame ${map.header.frame_id}`);
  check(width === expected.grid.width && height === expected.grid.height,
    `/map: ${width} x ${height} cells, map_<id>.pgm ${expected.grid.width} x ${expected.grid.height}`);
  check(map.data.length === width * height, `/map: ${map.data.length} cells`);
  const counts = { unknown: 0, free: 0, occupied: 0, other: 0 };
  for (const v of map.data) {
    if (v === -1) ++counts.unknown; else if (v === 0) ++counts.free; else if (v === 100) ++counts.occupied;
    else if (v > 0 && v < 100) ++counts.free; else ++counts.other;
  }
  check(counts.other === 0 && counts.free > 0 && counts.occupied > 0,
    `/map: cells -1 / 0..100 only (${counts.unknown} unknown, ${counts.free} free, ${counts.occupied} occupied)`);
  check(near(resolution, expected.resolution, 1e-6), `/map: resolution ${resolution.toFixed(3)} m`);
}

// /octomap_binary: as octomap_server publishes it; written back as a .bt file.
const octomap = read('/octomap_binary', 'octomap_msgs/Octomap');
if (octomap) {
  check(octomap.binary === true && octomap.id === 'OcTree' && octomap.header.frame_id === 'map',
    `/octomap_binary: binary ${octomap.binary}, id ${octomap.id}, frame ${octomap.header.frame_id}`);
  check(near(octomap.resolution, expected.resolution, 1e-9), `/octomap_binary: resolution ${octomap.resolution}`);
  const data = Buffer.from(octomap.data.buffer, octomap.data.byteOffset, octomap.data.length);
  // The node count the .bt header needs: OcTree::readBinaryNode's layout, 2 bits per child (01 free leaf,
  // 10 occupied leaf, 11 inner node, whose children follow depth first).
  let pos = 0;
  const nodes = () => {
    const bits = data[pos] | (data[pos + 1] << 8);
    pos += 2;
    let n = 1;
    const inner = [];
    for (let i = 0; i < 8; ++i) {
      const b = (bits >> (2 * i)) & 3;
      if (b === 3) inner.push(i); else if (b !== 0) ++n;
    }
    for (const _ of inner) n += nodes();
    return n;
  };
  const count = data.length >= 2 ? nodes() : 0;
  check(pos === data.length, `/octomap_binary: ${count} nodes in ${data.length} bytes, read to the end`);
  fs.writeFileSync(outBt, Buffer.concat([
    Buffer.from(`# Octomap OcTree binary file\nid OcTree\nsize ${count}\nres ${octomap.resolution}\ndata\n`), data]));
}

// /map_cloud: occupied voxels x y z rgb.
const cloud = read('/map_cloud', 'sensor_msgs/PointCloud2');
if (cloud) {
  const layout = cloud.fields.map((f) => `${f.name}@${f.offset}:${f.datatype}x${f.count}`).join(' ');
  check(layout === 'x@0:7x1 y@4:7x1 z@8:7x1 rgb@12:7x1', `/map_cloud: fields ${layout}`);
  check(cloud.point_step === 16 && cloud.height === 1 && cloud.data.length === 16 * cloud.width &&
        cloud.row_step === cloud.data.length && !cloud.is_bigendian && cloud.header.frame_id === 'map',
    `/map_cloud: ${cloud.width} points of 16 bytes, frame ${cloud.header.frame_id}`);
  check(cloud.width === expected.voxels, `/map_cloud: ${cloud.width} points, map.bt ${expected.voxels} voxels`);
}

// /tf_static: the camera mounts (default: optical frame at the base's origin, x right y down z forward).
const tfStatic = read('/tf_static', 'tf2_msgs/TFMessage');
if (tfStatic) {
  for (const r of robots) {
    const t = tfStatic.transforms.find((x) => x.header.frame_id === `${r}/base_link`);
    const pose = t ? fromTransform(t.transform) : null;
    check(t && t.child_frame_id === `${r}/camera_optical_frame` && samePose(pose, [0, 0, 0, -0.5, 0.5, -0.5, 0.5], 1e-9),
      `/tf_static: ${r}/base_link -> ${r}/camera_optical_frame, the default mount`);
  }
}

// Per robot: /R/path = the optimised keyframes; /R/pose = the newest one (the live poses have stopped);
// /tf map -> R/odom -> R/base_link = /R/pose.
const tf = read('/tf', 'tf2_msgs/TFMessage');
for (const r of robots) {
  const kfs = expected.robots[r].keyframes;
  const path = read(`/${r}/path`, 'nav_msgs/Path');
  if (path) {
    let worst = 0;
    path.poses.forEach((p, i) => {
      const k = kfs[i] || [NaN, NaN, NaN];
      worst = Math.max(worst, Math.hypot(p.pose.position.x - k[0], p.pose.position.y - k[1], p.pose.position.z - k[2]));
    });
    check(path.header.frame_id === 'map' && path.poses.length === kfs.length && worst < 1e-4,
      `/${r}/path: ${path.poses.length} poses in ${path.header.frame_id}, keyframes_${r}.txt ${kfs.length}, ` +
      `largest difference ${worst.toExponential(1)} m`);
  }
  const pose = read(`/${r}/pose`, 'geometry_msgs/PoseStamped');
  const last = kfs[kfs.length - 1];
  if (pose) {
    const p = pose.pose.position;
    check(pose.header.frame_id === 'map' && Math.hypot(p.x - last[0], p.y - last[1], p.z - last[2]) < 1e-4,
      `/${r}/pose: the newest keyframe, in ${pose.header.frame_id}`);
  }
  if (tf && pose) {
    const odom = tf.transforms.find((x) => x.header.frame_id === 'map' && x.child_frame_id === `${r}/odom`);
    const base = tf.transforms.find((x) => x.header.frame_id === `${r}/odom` && x.child_frame_id === `${r}/base_link`);
    check(odom && base && samePose(compose(fromTransform(odom.transform), fromTransform(base.transform)), fromPose(pose.pose), 1e-6),
      `/tf: map -> ${r}/odom -> ${r}/base_link = /${r}/pose`);
    const stamp = odom ? odom.header.stamp.sec + 1e-9 * odom.header.stamp.nanosec : 0;
    check(Math.abs(stamp - Date.now() / 1000) < 10, `/tf: stamped with the current time (${stamp.toFixed(2)})`);
  }
  const local = read(`/${r}/local_map`, 'nav_msgs/OccupancyGrid');
  if (local)
    check(local.header.frame_id === 'map' && local.data.length === local.info.width * local.info.height &&
          local.info.width > 0, `/${r}/local_map: ${local.info.width} x ${local.info.height} cells in ${local.header.frame_id}`);
}
console.log(failures ? `${failures} check(s) failed` : 'all ROS 2 topic checks passed');
process.exit(failures ? 1 : 0);
