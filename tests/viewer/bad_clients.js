// Bad WebSocket clients against a live viewer (test_viewer_bad_clients.sh): malformed text and binary
// frames, unknown ops, a subscribe storm, a connection storm, raw garbage and forged frame lengths on
// plain TCP, and slow readers that subscribe to everything and never read. Meanwhile a well-behaved
// client (the Foxglove reference client) must keep receiving. Prints what each part saw; exit 1 when the
// good client got too little or a bad client crashed the viewer (connection refused afterwards).
// Usage: node bad_clients.js HOST PORT SECONDS
'use strict';
const net = require('net');
const WebSocket = require('ws');
const { FoxgloveClient } = require('@foxglove/ws-protocol');

const [host, port, secondsArg] = process.argv.slice(2);
const url = `ws://${host}:${port}`;
const seconds = Number(secondsArg || 20);
const proto = [FoxgloveClient.SUPPORTED_SUBPROTOCOL];
const counts = { statuses: 0, good_messages: 0, good_voxel_msgs: 0, storm_connections: 0, slow_readers: 0 };
const failures = [];

function open(onOpen) {
  const ws = new WebSocket(url, proto);
  ws.on('error', () => {});
  ws.on('open', () => onOpen(ws));
  return ws;
}

function attack() {
// 1. Malformed text, unknown ops, wrong types, binary frames: every one answered with a status, never a crash.
open((ws) => {
  const bad = ['not json', '{}', '[]', '{"op":5}', '{"op":"subscribe"}', '{"op":"subscribe","subscriptions":"x"}',
    '{"op":"subscribe","subscriptions":[{"id":-1,"channelId":1}]}', '{"op":"subscribe","subscriptions":[{"id":1,"channelId":99999}]}',
    '{"op":"unsubscribe","subscriptionIds":[12345]}', '{"op":"advertise","channels":[]}', '{"op":"getParameters"}',
    '{"op":"x".repeat(1000)}', '['.repeat(100000), '{"op":"' + 'y'.repeat(200000) + '"}'];
  ws.on('message', (data, binary) => { if (!binary && JSON.parse(data).op === 'status') ++counts.statuses; });
  for (const b of bad) ws.send(b);
  ws.send(Buffer.from([1, 2, 3, 4, 5, 6, 7, 8, 9]));
  ws.send(Buffer.alloc(1 << 20, 7));
});

// 2. Subscribe storm: 20000 subscriptions (most of them to unknown channels or duplicate ids) in a burst.
open((ws) => {
  const subscriptions = [];
  for (let i = 0; i < 20000; ++i) subscriptions.push({ id: i % 5000, channelId: 1 + (i % 40) });
  for (let k = 0; k < 20; ++k) ws.send(JSON.stringify({ op: 'subscribe', subscriptions }));
  ws.on('message', () => {});
});

}

// Then, once those two hold their connections, the clients that take or waste connection slots.
function attack2() {
// 3. Connection storm: 200 connections opened and dropped at once (more than --max-clients).
for (let i = 0; i < 200; ++i) {
  const ws = new WebSocket(url, proto);
  ws.on('error', () => {});
  ws.on('open', () => { ++counts.storm_connections; setTimeout(() => ws.terminate(), 50); });
}

// 4. Raw TCP: garbage instead of HTTP, a handshake followed by unmasked, bad-opcode and forged-length frames.
for (const payload of [Buffer.from('garbage\r\n\r\n'), Buffer.alloc(100000, 65)]) {
  const s = net.connect(Number(port), host, () => s.end(payload));
  s.on('error', () => {});
}
function handshake(then) {
  const s = net.connect(Number(port), host, () => {
    s.write(`GET / HTTP/1.1\r\nHost: ${host}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n` +
            'Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n' +
            'Sec-WebSocket-Protocol: foxglove.websocket.v1\r\n\r\n');
    setTimeout(() => then(s), 200);
  });
  s.on('error', () => {});
  return s;
}
handshake((s) => s.write(Buffer.from([0x81, 0x05, 0x68, 0x65, 0x6c, 0x6c, 0x6f])));  // unmasked text
handshake((s) => s.write(Buffer.from([0x83, 0x80, 1, 2, 3, 4])));  // reserved opcode 3
// Claims a 2^40-byte text frame, then sends a few bytes and stays silent.
handshake((s) => s.write(Buffer.from([0x81, 0xff, 0, 0, 1, 0, 0, 0, 0, 0, 1, 2, 3, 4, 9, 9, 9])));

}
setTimeout(attack, 1000);  // after the good client and the slow readers are in
setTimeout(attack2, 3000);

// 5. Slow readers: subscribe to every channel, then stop reading (the socket's receive side is paused).
for (let i = 0; i < 3; ++i) {
  const ws = new WebSocket(url, proto);
  ws.on('error', () => {});
  ws.on('message', (data, binary) => {
    if (binary) return;
    const m = JSON.parse(data);
    if (m.op !== 'advertise') return;
    ws.send(JSON.stringify({ op: 'subscribe', subscriptions: m.channels.map((c) => ({ id: c.id, channelId: c.id })) }));
    ++counts.slow_readers;
    setTimeout(() => ws._socket.pause(), 100);
  });
}

// The good client: Foxglove reference client, subscribed to everything for the whole time.
const good = new FoxgloveClient({ ws: new WebSocket(url, proto) });
const topics = new Map();
good.on('advertise', (list) => { for (const c of list) topics.set(good.subscribe(c.id), c.topic); });
good.on('message', ({ subscriptionId }) => {
  ++counts.good_messages;
  if (String(topics.get(subscriptionId)).endsWith('/voxel_delta')) ++counts.good_voxel_msgs;
});
good.on('error', (e) => failures.push('good client error: ' + e));

setTimeout(() => {
  // The viewer must still accept a new client after all that.
  const late = new WebSocket(url, proto);
  late.on('error', (e) => { failures.push('viewer refused a late client: ' + e.message); done(); });
  late.on('message', (data, binary) => { if (!binary && JSON.parse(data).op === 'advertise') { late.close(); done(); } });
}, seconds * 1000);

function done() {
  if (counts.statuses < 10) failures.push(`only ${counts.statuses} status replies to malformed messages`);
  if (counts.good_messages < 10 || counts.good_voxel_msgs < 2)
    failures.push(`good client received only ${counts.good_messages} messages (${counts.good_voxel_msgs} voxel updates)`);
  console.log('bad clients: ' + JSON.stringify(counts));
  if (failures.length) { for (const f of failures) console.log('FAIL: ' + f); process.exit(1); }
  console.log('ok: the viewer served the good client through the bad ones');
  process.exit(0);
}
