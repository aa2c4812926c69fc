// The viewer's map recording (rgbdmap run --viewer --record FILE.mcap) through the MCAP reference reader
// (npm @mcap/core, McapStreamReader with CRC checks; zstd chunks decompressed by the zstd command): every
// record parses, each schema is a JSON Schema titled with its Foxglove name, each channel is JSON, messages
// come in time order, and the last message of each topic matches what the run wrote (EXPECTED, the file
// test_viewer_foxglove.sh makes): per robot the occupied voxels of map.bt, the keyframes of
// keyframes_<robot>.txt, the pose at the newest keyframe. Then the indexed reader (McapIndexedReader: the
// summary's chunk indexes and the message indexes) reads the same messages by seeking. Exit 0 on success,
// 1 on failure.
// Usage: node mcap_check.js FILE.mcap EXPECTED.json
'use strict';
const { McapIndexedReader, McapStreamReader } = require('@mcap/core');
const { execFileSync } = require('child_process');
const fs = require('fs');

const [file, expectedFile] = process.argv.slice(2);
const expected = JSON.parse(fs.readFileSync(expectedFile, 'utf8'));
const failures = [];
const fail = (m) => failures.push(m);

const decompressHandlers = {
  zstd: (buffer, size) => {
    const out = execFileSync('zstd', ['-d', '-c', '-q'], { input: buffer, maxBuffer: 1 << 30 });
    if (BigInt(out.length) !== size) throw new Error(`zstd chunk: ${out.length} bytes, declared ${size}`);
    return out;
  },
};
const bytes = fs.readFileSync(file);
const reader = new McapStreamReader({ validateCrcs: true, decompressHandlers });
reader.append(bytes);
const schemas = new Map(), channels = new Map(), latest = new Map(), counts = new Map();
let header = null, footer = false, lastTime = -1n, records = 0;
for (let r; (r = reader.nextRecord()) !== undefined; ++records) {
  if (r.type === 'Header') header = r;
  else if (r.type === 'Schema') schemas.set(r.id, r);
  else if (r.type === 'Channel') channels.set(r.id, r);
  else if (r.type === 'Footer') footer = true;
  else if (r.type === 'Message') {
    const c = channels.get(r.channelId);
    if (r.logTime < lastTime) fail(`${c.topic}: message at ${r.logTime} after one at ${lastTime}`);
    lastTime = r.logTime;
    latest.set(c.topic, JSON.parse(new TextDecoder().decode(r.data)));
    counts.set(c.topic, (counts.get(c.topic) || 0) + 1);
  }
}
if (!reader.done()) fail(`${reader.bytesRemaining()} bytes left unread`);
if (!header || !footer) fail('no Header or Footer record');
for (const c of channels.values()) {
  const s = schemas.get(c.schemaId);
  if (c.messageEncoding !== 'json' || !s || s.encoding !== 'jsonschema') fail(`${c.topic}: not JSON with a JSON Schema`);
  else if (JSON.parse(new TextDecoder().decode(s.data)).title !== s.name) fail(`${c.topic}: schema title is not ${s.name}`);
  if (c.topic.endsWith('/voxel_delta')) fail(`${c.topic}: the incremental channel is recorded`);
  if (!counts.get(c.topic)) fail(`${c.topic}: no message`);
}
const near = (p, k) => Math.hypot(p.x - k[0], p.y - k[1], p.z - k[2]) < 1e-6;
for (const [r, e] of Object.entries(expected.robots)) {
  const cloud = latest.get(`/${r}/voxels`), traj = latest.get(`/${r}/trajectory`), pose = latest.get(`/${r}/pose`);
  if (!cloud || !traj || !pose) { fail(`${r}: voxels, trajectory or pose missing`); continue; }
  const points = Buffer.from(cloud.data, 'base64').length / cloud.point_stride;
  if (points !== e.voxels) fail(`${r}: last point cloud has ${points} voxels, map.bt ${e.voxels}`);
  if (traj.poses.length !== e.keyframes.length || !traj.poses.every((p, i) => near(p.position, e.keyframes[i])))
    fail(`${r}: last trajectory (${traj.poses.length} poses) is not keyframes_${r}.txt (${e.keyframes.length})`);
  if (!near(pose.pose.position, e.keyframes[e.keyframes.length - 1])) fail(`${r}: last pose is not the newest keyframe`);
  console.log(`${r}: ${counts.get(`/${r}/voxels`)} point clouds (last ${points} voxels), ` +
              `${counts.get(`/${r}/trajectory`)} trajectories (last ${traj.poses.length} poses)`);
}
async function indexed() {
  const readable = {
    size: async () => BigInt(bytes.length),
    read: async (offset, length) => bytes.subarray(Number(offset), Number(offset + length)),
  };
  const r = await McapIndexedReader.Initialize({ readable, decompressHandlers });
  let n = 0, last = -1n;
  for await (const m of r.readMessages()) {
    if (m.logTime < last) fail(`indexed reader: message at ${m.logTime} after ${last}`);
    last = m.logTime;
    ++n;
  }
  const total = [...counts.values()].reduce((a, b) => a + b, 0);
  if (n !== total) fail(`indexed reader: ${n} messages, the stream ${total}`);
  console.log(`indexed reader: ${r.chunkIndexes.length} chunk indexes, ${n} messages`);
  if (r.chunkIndexes.length === 0) fail('no chunk index');
}

console.log(`${file}: ${records} records, ${channels.size} channels, ${[...counts.values()].reduce((a, b) => a + b, 0)} messages`);
indexed().catch((e) => fail('indexed reader: ' + e)).finally(() => {
  for (const f of failures) console.log('FAIL: ' + f);
  process.exit(failures.length ? 1 : 0);
});
