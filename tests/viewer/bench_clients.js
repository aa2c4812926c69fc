// N Foxglove clients (the reference client) subscribed to every channel of a viewer until it closes; then
// prints one JSON line: bytes and messages received per client, the latency of incremental voxel updates
// after the first (receive time minus the server's send time of the map update they came from), and, with
// ROBOTS_DIR (run_multiprocess.sh's out/robots, read once the run is over), the latency from each keyframe's
// acknowledgement at its robot (client_<R>.json keyframe_ack_utime) to the first voxel update holding it
// (VoxelDelta robot_keyframe) at client 0. Same host, same clock.
// Usage: node bench_clients.js HOST PORT N [ROBOTS_DIR]   (deploy/bench_viewer.sh)
'use strict';
const WebSocket = require('ws');
const { FoxgloveClient } = require('@foxglove/ws-protocol');
const fs = require('fs');
const [host, port, nArg, robotsDir] = process.argv.slice(2);
const holding = {};  // robot -> [[robot_keyframe, receive ms], ...] of client 0's voxel updates
const topicBytes = {};  // client 0: bytes per topic kind (voxels, voxel_delta, map_grid, ...)
const bytesDown = {};   // robot -> the server -> viewer bytes its last status reports
const n = Number(nArg || 1);
const stats = [];
const latencies_ms = [];
let open = n, started = 0, finished = false;
for (let i = 0; i < n; ++i) {
  const s = { bytes: 0, messages: 0, seen_voxels: 0 };
  stats.push(s);
  const client = new FoxgloveClient({ ws: new WebSocket(`ws://${host}:${port}`, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]) });
  const topics = new Map();
  client.on('open', () => { if (!started) started = Date.now(); });
  client.on('advertise', (list) => { for (const c of list) topics.set(client.subscribe(c.id), c.topic); });
  client.on('message', ({ subscriptionId, data }) => {
    s.bytes += data.byteLength;
    ++s.messages;
    const topic = String(topics.get(subscriptionId));
    if (i === 0) topicBytes[topic.split('/').pop()] = (topicBytes[topic.split('/').pop()] || 0) + data.byteLength;
    if (i === 0 && topic.endsWith('/status'))
      bytesDown[topic.split('/')[1]] = JSON.parse(new TextDecoder().decode(data)).bytes_down;
    if (i !== 0 || !String(topics.get(subscriptionId)).endsWith('/voxel_delta')) return;
    const m = JSON.parse(new TextDecoder().decode(data));
    const robot = String(topics.get(subscriptionId)).split('/')[1];
    (holding[robot] = holding[robot] || []).push([m.robot_keyframe, Date.now()]);
    // Every update but the first (the snapshot a new subscriber gets, possibly of an older map update).
    if (s.seen_voxels++ > 0 && m.map_utime > 0) latencies_ms.push(Date.now() - m.map_utime / 1000);
  });
  const closed = () => { if (--open === 0) report(); };
  client.on('close', closed);
  client.on('error', () => {});
}
function quantile(a, q) {
  if (!a.length) return null;
  const s = [...a].sort((x, y) => x - y);
  return s[Math.min(s.length - 1, Math.floor(q * s.length))];
}
/// Per accepted keyframe acknowledged after the clients connected: ack -> first update holding it (ms).
function ackToClient() {
  const out = { latencies: [], missing: 0, missing_ids: [] };
  if (!robotsDir) return out;
  for (const robot of Object.keys(holding)) {
    let acks = [];
    try {
      acks = JSON.parse(fs.readFileSync(`${robotsDir}/${robot}/client_${robot}.json`, 'utf8')).keyframe_ack_utime;
    } catch (e) { continue; }
    for (const [id, utime] of acks) {
      const ack = utime / 1000;
      if (ack < started) continue;
      const first = holding[robot].filter(([k]) => k >= id).map(([, t]) => t);
      if (!first.length) {
        ++out.missing;
        out.missing_ids.push(`${robot}:${id} (newest seen ${Math.max(-1, ...holding[robot].map(([k]) => k))}, ` +
                             `last acked ${acks[acks.length - 1][0]})`);
        continue;
      }
      out.latencies.push(Math.min(...first) - ack);
    }
  }
  return out;
}

function report() {
  if (finished) return;
  finished = true;
  const ack = ackToClient();
  const seconds = (Date.now() - started) / 1000;
  const bytes = stats.reduce((a, s) => a + s.bytes, 0);
  console.log(JSON.stringify({ clients: n, seconds, bytes_total: bytes, bytes_per_s: bytes / seconds,
    bytes_per_s_per_client: bytes / seconds / n, messages: stats.reduce((a, s) => a + s.messages, 0),
    voxel_updates: latencies_ms.length, latency_ms_median: quantile(latencies_ms, 0.5),
    latency_ms_p90: quantile(latencies_ms, 0.9), ack_keyframes: ack.latencies.length,
    ack_keyframes_missing: ack.missing, ack_missing: ack.missing_ids, ack_latency_ms_median: quantile(ack.latencies, 0.5),
    ack_latency_ms_p90: quantile(ack.latencies, 0.9), ack_latency_ms_max: quantile(ack.latencies, 1),
    kb_per_topic_client0: Object.fromEntries(Object.entries(topicBytes).map(([k, v]) => [k, Math.round(v / 1000)])),
    server_to_viewer_kb: Math.round(Object.values(bytesDown).reduce((a, b) => a + b, 0) / 1000) }));
  process.exit(0);
}
