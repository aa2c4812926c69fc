// N Foxglove clients (the reference client) subscribed to every channel of a viewer until it closes; then
// prints one JSON line: bytes and messages received per client, and the latency of incremental voxel
// updates after the first (receive time minus the server's send time of the map update they came from, same host clock).
// Usage: node bench_clients.js HOST PORT N   (deploy/bench_viewer.sh)
'use strict';
const WebSocket = require('ws');
const { FoxgloveClient } = require('@foxglove/ws-protocol');
const [host, port, nArg] = process.argv.slice(2);
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
    if (i !== 0 || !String(topics.get(subscriptionId)).endsWith('/voxel_delta')) return;
    const m = JSON.parse(new TextDecoder().decode(data));
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
function report() {
  if (finished) return;
  finished = true;
  const seconds = (Date.now() - started) / 1000;
  const bytes = stats.reduce((a, s) => a + s.bytes, 0);
  console.log(JSON.stringify({ clients: n, seconds, bytes_total: bytes, bytes_per_s: bytes / seconds,
    bytes_per_s_per_client: bytes / seconds / n, messages: stats.reduce((a, s) => a + s.messages, 0),
    voxel_updates: latencies_ms.length, latency_ms_median: quantile(latencies_ms, 0.5),
    latency_ms_p90: quantile(latencies_ms, 0.9) }));
  process.exit(0);
}
