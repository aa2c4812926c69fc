// The viewer through the Foxglove WebSocket protocol's reference client (npm @foxglove/ws-protocol): connects,
// checks the advertised channels and their JSON schemas, subscribes to every channel, decodes the messages
// and compares them with what the run wrote (EXPECTED, a JSON file made by test_viewer_foxglove.sh):
// per robot the occupied voxel count of map.bt and the optimised keyframe positions of keyframes_<robot>.txt,
// the extent of the server's global 2-D map (map_<id>.pgm; waited for, as the voxels are), and that the
// robots' live poses arrived.
// Then unsubscribes from everything and checks that nothing more arrives. Exit 0 on success, 1 on failure.
// Usage: node foxglove_check.js ws://127.0.0.1:PORT EXPECTED.json [TIMEOUT_S]
'use strict';
const { FoxgloveClient } = require('@foxglove/ws-protocol');
const WebSocket = require('ws');
const fs = require('fs');

const [url, expectedFile, timeoutArg] = process.argv.slice(2);
const expected = JSON.parse(fs.readFileSync(expectedFile, 'utf8'));
const robots = Object.keys(expected.robots);
const failures = [];
const fail = (m) => failures.push(m);
const channels = new Map();  // subscription id -> channel
const latest = new Map();    // topic -> last decoded message
let messages = 0, afterUnsubscribe = 0, unsubscribed = false;

const client = new FoxgloveClient({ ws: new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]) });
client.on('error', (e) => { fail('client error: ' + e); finish(); });
client.on('status', (s) => fail('server status: ' + JSON.stringify(s)));
client.on('advertise', (list) => {
  for (const c of list) {
    if (c.encoding !== 'json' || c.schemaEncoding !== 'jsonschema') fail(`${c.topic}: encoding ${c.encoding}/${c.schemaEncoding}`);
    let schema = null;
    try { schema = JSON.parse(c.schema); } catch (e) { fail(`${c.topic}: schema is not JSON`); }
    if (schema && schema.title !== c.schemaName) fail(`${c.topic}: schema title ${schema.title} != ${c.schemaName}`);
    channels.set(client.subscribe(c.id), c);
  }
  console.log(`advertised ${list.length} channels: ${list.map((c) => c.topic).join(' ')}`);
});
client.on('message', ({ subscriptionId, data }) => {
  if (unsubscribed) { ++afterUnsubscribe; return; }
  if (checked) return;
  const c = channels.get(subscriptionId);
  if (!c) return fail('message for unknown subscription ' + subscriptionId);
  ++messages;
  latest.set(c.topic, JSON.parse(new TextDecoder().decode(data)));
  if (complete()) check();
});

function pointCount(cloud) { return Buffer.from(cloud.data, 'base64').length / cloud.point_stride; }

function complete() {
  for (const c of channels.values()) if (!latest.has(c.topic)) return false;
  for (const r of robots) {
    const cloud = latest.get(`/${r}/voxels`), traj = latest.get(`/${r}/trajectory`);
    if (pointCount(cloud) !== expected.robots[r].voxels) return false;
    if (traj.poses.length !== expected.robots[r].keyframes.length) return false;
    // After the run the robots' live poses stop: /R/pose falls back to the newest optimised keyframe.
    const pose = latest.get(`/${r}/pose`).pose.position, kfs = expected.robots[r].keyframes;
    const last = kfs[kfs.length - 1];
    if (Math.hypot(pose.x - last[0], pose.y - last[1], pose.z - last[2]) > 1e-6) return false;
    // The 2-D map is cut at most once per cloud period: the one cut from the final voxels may come later.
    const map = latest.get(`/${r}/map_grid`);
    if (map.column_count !== expected.grid.width ||
        Buffer.from(map.data, 'base64').length !== expected.grid.width * expected.grid.height) return false;
  }
  return true;
}

function check() {
  if (checked) return;
  checked = true;
  for (const r of robots) {
    const e = expected.robots[r];
    const cloud = latest.get(`/${r}/voxels`), delta = latest.get(`/${r}/voxel_delta`);
    const fields = cloud.fields.map((f) => `${f.name}:${f.offset}:${f.type}`).join(',');
    if (fields !== 'x:0:7,y:4:7,z:8:7,red:12:1,green:13:1,blue:14:1,alpha:15:1') fail(`${r}: point fields ${fields}`);
    if (cloud.frame_id !== 'map') fail(`${r}: point cloud frame ${cloud.frame_id}`);
    if (!delta.full || delta.add.length / 3 !== e.voxels) fail(`${r}: voxel snapshot ${delta.add.length / 3} != ${e.voxels}`);
    const poses = latest.get(`/${r}/trajectory`).poses;
    let worst = 0;
    poses.forEach((p, i) => {
      const k = e.keyframes[i];
      worst = Math.max(worst, Math.hypot(p.position.x - k[0], p.position.y - k[1], p.position.z - k[2]));
    });
    if (!(worst < 1e-6)) fail(`${r}: trajectory differs from keyframes_${r}.txt by ${worst} m`);
    const pose = latest.get(`/${r}/pose`).pose.position, last = e.keyframes[e.keyframes.length - 1];
    if (Math.hypot(pose.x - last[0], pose.y - last[1], pose.z - last[2]) > 1e-6) fail(`${r}: pose is not the newest keyframe`);
    const grid = latest.get(`/${r}/slice`);
    const cells = Buffer.from(grid.data, 'base64').length;
    if (!(grid.column_count > 0 && cells % grid.column_count === 0 && cells > 0)) fail(`${r}: slice grid of ${cells} cells`);
    const map = latest.get(`/${r}/map_grid`), q = map.pose.orientation;
    const mapCells = Buffer.from(map.data, 'base64');
    const occupied = mapCells.filter((v) => v === 100).length, free = mapCells.filter((v) => v === 0).length;
    if (map.column_count !== expected.grid.width || mapCells.length !== expected.grid.width * expected.grid.height)
      fail(`${r}: 2-D map ${map.column_count} x ${mapCells.length / map.column_count}, server's ` +
           `${expected.grid.width} x ${expected.grid.height}`);
    if (Math.abs(q.w) < 1 - 1e-9) fail(`${r}: 2-D map has a yaw (${JSON.stringify(q)})`);
    if (!(occupied > 100 && free > 1000)) fail(`${r}: 2-D map with ${occupied} occupied and ${free} free cells`);
    const status = latest.get(`/${r}/status`);
    if (status.robot !== r || status.keyframes !== e.keyframes.length || status.voxels !== e.voxels)
      fail(`${r}: status ${JSON.stringify(status)}`);
    if (!(status.live_poses > 0)) fail(`${r}: no live pose (RobotPose) reached the viewer`);
    if (status.map_mode !== 'map' || typeof status.placed !== 'boolean')
      fail(`${r}: map mode ${JSON.stringify(status.map_mode)}, placed ${JSON.stringify(status.placed)}`);
    const loops = latest.get(`/${r}/loops`).entities[0].lines[0];
    const inter = loops.colors.filter((c) => c.r > 0.8 && c.b > 0.8).length / 2;
    if (!(loops.type === 2 && loops.points.length >= 2 && loops.points.length % 2 === 0 && inter >= 1))
      fail(`${r}: loop edges: ${loops.points.length / 2} edges, ${inter} inter-robot`);
    const tf = latest.get('/tf').transforms.map((t) => `${t.parent_frame_id}>${t.child_frame_id}`);
    if (!tf.includes(`map>${r}`)) fail(`${r}: no map -> ${r} transform in /tf (${tf})`);
    console.log(`${r}: ${pointCount(cloud)} voxels (map.bt: ${e.voxels}), ${poses.length} keyframes ` +
                `(worst position difference ${worst.toExponential(1)} m), slice ${grid.column_count} x ` +
                `${cells / grid.column_count}, 2-D map ${map.column_count} x ${mapCells.length / map.column_count} ` +
                `(${occupied} occupied, ${free} free), ${status.live_poses} live poses, ` +
                `status keyframes ${status.keyframes} loops ${status.loops}, ` +
                `${loops.points.length / 2} loop edges drawn (${inter} inter-robot)`);
  }
  for (const id of channels.keys()) client.unsubscribe(id);
  // Frames already on their way may still arrive for a moment; after that the viewer (which publishes a
  // status every second) must send nothing more.
  setTimeout(() => { unsubscribed = true; setTimeout(finish, 2000); }, 300);
}
let checked = false;

function finish() {
  if (unsubscribed && afterUnsubscribe > 0) fail(`${afterUnsubscribe} messages after unsubscribing from everything`);
  if (!checked) {
    fail('incomplete before the timeout: ' + [...channels.values()].map((c) => {
      const m = latest.get(c.topic);
      const grid = (g) => `${g.column_count} x ${Buffer.from(g.data, 'base64').length / g.column_count} cells`;
      return `${c.topic}=${m ? (m.data && m.point_stride ? pointCount(m) + ' points' : m.poses ? m.poses.length + ' poses' : m.column_count ? grid(m) : 'ok') : 'nothing'}`;
    }).join(' '));
  }
  client.close();
  console.log(`${messages} messages decoded`);
  if (failures.length) { for (const f of failures) console.log('FAIL: ' + f); process.exit(1); }
  console.log('ok: foxglove reference client checks passed');
  process.exit(0);
}
setTimeout(finish, 1000 * Number(timeoutArg || 30));
