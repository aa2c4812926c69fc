// rgbdmap live map viewer page: a Foxglove WebSocket client (subprotocol foxglove.websocket.v1, JSON
// encoding) of the viewer that served it. Subscribes to every robot's voxel_delta, trajectory, pose, status,
// loops and map_grid topics and draws them with three.js. The map frame is z-up (REP-103); three.js is
// y-up, so the scene is turned (x, y, z) -> (x, z, -y).
/* global THREE */
'use strict';

const ROBOT_COLOURS = [0xe6194b, 0x3cb44b, 0x4363d8, 0xf58231, 0x911eb4, 0x46f0f0, 0xf032e6, 0x808000];
const state = { robots: {}, voxels: 0, drawn: false, messages: 0, poses: 0, grids: 0 };
window.rgbdmapViewer = state;  // read by the tests (headless Chromium)

const container = document.getElementById('view');
const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(window.devicePixelRatio || 1);
renderer.setSize(window.innerWidth, window.innerHeight);
renderer.setClearColor(0xf4f4f4);
container.appendChild(renderer.domElement);
const scene = new THREE.Scene();
const world = new THREE.Group();
world.rotation.x = -Math.PI / 2;  // map z (up) -> three.js y
scene.add(world);
scene.add(new THREE.AmbientLight(0xffffff, 0.9));
const camera = new THREE.PerspectiveCamera(60, window.innerWidth / window.innerHeight, 0.05, 500);
camera.position.set(4, 5, 6);
const controls = new THREE.OrbitControls(camera, renderer.domElement);
controls.target.set(0, 0, 0);
const grid = new THREE.GridHelper(20, 40, 0xcccccc, 0xe0e0e0);
scene.add(grid);
// The scene is drawn only when something in it changed: new data, the camera, the window. Drawing every
// animation frame would keep a software-rendered page (no GPU) busy for nothing.
let needsRender = true;
const requestRender = () => { needsRender = true; };
controls.addEventListener('change', requestRender);

function robot(name) {
  if (state.robots[name]) return state.robots[name];
  const colour = ROBOT_COLOURS[Object.keys(state.robots).length % ROBOT_COLOURS.length];
  const r = { name, colour, voxels: new Map(), resolution: 0.05, dirty: false, status: null, keyframes: 0 };
  r.points = new THREE.Points(new THREE.BufferGeometry(),
                              new THREE.PointsMaterial({ size: 0.05, vertexColors: THREE.VertexColors }));
  r.line = new THREE.Line(new THREE.BufferGeometry(), new THREE.LineBasicMaterial({ color: colour }));
  r.marker = new THREE.Group();  // the robot: a sphere and a cone along the camera's viewing direction (z)
  const body = new THREE.Mesh(new THREE.SphereBufferGeometry(0.08, 12, 8), new THREE.MeshBasicMaterial({ color: colour }));
  const nose = new THREE.Mesh(new THREE.ConeBufferGeometry(0.05, 0.25, 12), new THREE.MeshBasicMaterial({ color: colour }));
  nose.rotation.x = Math.PI / 2;  // the cone's axis (y) along the camera's z
  nose.position.z = 0.16;
  r.marker.add(body, nose);
  r.marker.visible = false;
  r.grid = new THREE.Mesh(new THREE.PlaneBufferGeometry(1, 1),
    new THREE.MeshBasicMaterial({ transparent: true, opacity: 0.8, side: THREE.DoubleSide, depthWrite: false }));
  r.grid.visible = false;
  r.gridCells = 0;
  r.floor = Infinity;
  r.loops = new THREE.LineSegments(new THREE.BufferGeometry(),
    new THREE.LineBasicMaterial({ vertexColors: THREE.VertexColors, transparent: true, opacity: 0.6 }));
  world.add(r.points, r.line, r.marker, r.loops, r.grid);
  state.robots[name] = r;
  return r;
}

function heightColour(t) {  // blue -> cyan -> green -> yellow -> red, as the viewer's point clouds
  const c = (v) => Math.min(1, Math.max(0, v));
  return [c(Math.min(4 * t - 1.5, -4 * t + 4.5)), c(Math.min(4 * t - 0.5, -4 * t + 3.5)),
          c(Math.min(4 * t + 0.5, -4 * t + 2.5))];
}

function rebuildVoxels(r) {
  const n = r.voxels.size;
  const pos = new Float32Array(3 * n), col = new Float32Array(3 * n);
  let low = Infinity, high = -Infinity;
  for (const v of r.voxels.values()) { low = Math.min(low, v[2]); high = Math.max(high, v[2]); }
  let i = 0;
  for (const v of r.voxels.values()) {
    pos.set(v, 3 * i);
    col.set(heightColour(high > low ? (v[2] - low) / (high - low) : 0.5), 3 * i);
    ++i;
  }
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.BufferAttribute(pos, 3));
  g.setAttribute('color', new THREE.BufferAttribute(col, 3));
  r.points.geometry.dispose();
  r.points.geometry = g;
  r.points.material.size = r.resolution;
  r.floor = low;  // the 2-D map is drawn just under the lowest voxels, not through them
  if (n > 0) r.grid.position.z = low - r.resolution;
  r.dirty = false;
}

function applyVoxels(r, m) {
  const key = (x, y, z) => Math.round(x / m.resolution * 2) + ',' + Math.round(y / m.resolution * 2) + ',' +
                           Math.round(z / m.resolution * 2);
  r.resolution = m.resolution;
  if (m.full) r.voxels.clear();
  for (let i = 0; i + 2 < m.remove.length; i += 3) r.voxels.delete(key(m.remove[i], m.remove[i + 1], m.remove[i + 2]));
  for (let i = 0; i + 2 < m.add.length; i += 3)
    r.voxels.set(key(m.add[i], m.add[i + 1], m.add[i + 2]), [m.add[i], m.add[i + 1], m.add[i + 2]]);
  r.dirty = true;
}

function applyTrajectory(r, m) {
  const pos = new Float32Array(3 * m.poses.length);
  m.poses.forEach((p, i) => pos.set([p.position.x, p.position.y, p.position.z], 3 * i));
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.BufferAttribute(pos, 3));
  r.line.geometry.dispose();
  r.line.geometry = g;
  r.keyframes = m.poses.length;
}

function applyLoops(r, m) {  // foxglove.SceneUpdate: one entity with one line list
  const line = m.entities[0].lines[0];
  const pos = new Float32Array(3 * line.points.length), col = new Float32Array(3 * line.points.length);
  line.points.forEach((p, i) => {
    pos.set([p.x, p.y, p.z], 3 * i);
    const c = line.colors[i] || line.color;
    col.set([c.r, c.g, c.b], 3 * i);
  });
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.BufferAttribute(pos, 3));
  g.setAttribute('color', new THREE.BufferAttribute(col, 3));
  r.loops.geometry.dispose();
  r.loops.geometry = g;
  r.loopEdges = line.points.length / 2;
}

function applyPose(r, m) {
  const q = m.pose.orientation;
  r.marker.position.set(m.pose.position.x, m.pose.position.y, m.pose.position.z);
  r.marker.quaternion.set(q.x, q.y, q.z, q.w);
  r.marker.visible = true;
  ++state.poses;
}

// foxglove.Grid of the robot's map's global 2-D map (int8 cells: -1 unknown, 0 free .. 100 occupied) as a
// translucent texture at the grid's pose: occupied dark, free light, unknown transparent.
function applyGrid(r, m) {
  const cells = Uint8Array.from(atob(m.data), (c) => c.charCodeAt(0));
  const w = m.column_count, h = Math.floor(cells.length / w);
  if (!w || !h) return;
  const canvas = document.createElement('canvas');
  canvas.width = w;
  canvas.height = h;
  const ctx = canvas.getContext('2d'), image = ctx.createImageData(w, h);
  for (let row = 0; row < h; ++row)
    for (let col = 0; col < w; ++col) {
      const v = (cells[row * w + col] << 24) >> 24, o = 4 * ((h - 1 - row) * w + col);  // grid row 0 at the bottom
      const grey = v < 0 ? 0 : 235 - Math.round(1.9 * v);
      image.data.set([grey, grey, grey, v < 0 ? 0 : 255], o);
    }
  ctx.putImageData(image, 0, 0);
  const texture = new THREE.CanvasTexture(canvas);
  texture.magFilter = THREE.NearestFilter;
  if (r.grid.material.map) r.grid.material.map.dispose();
  r.grid.material.map = texture;
  r.grid.material.needsUpdate = true;
  const sx = w * m.cell_size.x, sy = h * m.cell_size.y, p = m.pose.position, q = m.pose.orientation;
  r.grid.geometry.dispose();
  r.grid.geometry = new THREE.PlaneBufferGeometry(sx, sy).translate(sx / 2, sy / 2, 0);
  r.grid.position.set(p.x, p.y, Number.isFinite(r.floor) ? r.floor - r.resolution : p.z);
  r.grid.quaternion.set(q.x, q.y, q.z, q.w);
  r.grid.visible = showGrids;
  r.gridCells = w * h;
  ++state.grids;
}

function legend() {
  const el = document.getElementById('legend');
  el.innerHTML = '';
  let total = 0;
  for (const r of Object.values(state.robots)) {
    total += r.voxels.size;
    const s = r.status || {};
    const hex = '#' + r.colour.toString(16).padStart(6, '0');
    const seen = s.last_seen_s === undefined || s.last_seen_s < 0 ? 'never' : s.last_seen_s.toFixed(1) + ' s ago';
    const div = document.createElement('div');
    div.className = 'robot';
    // A localising robot not placed in the stored map yet, or a mapping robot whose map has not merged.
    const mode = s.map_mode === 'localize' ? (s.placed ? 'localising' : '<span class="unplaced">localising, unplaced</span>')
      : (s.map_mode === 'map' && s.placed === false && s.keyframes > 0 ? '<span class="unplaced">not merged</span>' : '');
    div.innerHTML = `<span class="swatch" style="background:${hex}"></span><b>${r.name}</b> ${s.state || ''} ${mode}` +
      `<div class="detail">${s.keyframes || r.keyframes} keyframes, ${s.loops || 0} loops (${r.loopEdges || 0} drawn), ${r.voxels.size} voxels</div>` +
      `<div class="detail">${(s.down_kbps || 0).toFixed(1)} kbit/s, last seen ${seen}</div>` +
      (r.gridCells ? `<div class="detail">2-D map ${r.gridCells} cells</div>` : '');
    el.appendChild(div);
  }
  state.voxels = total;
}

let showGrids = true;
document.getElementById('grids').onclick = () => {
  showGrids = !showGrids;
  for (const r of Object.values(state.robots)) r.grid.visible = showGrids && r.gridCells > 0;
  document.getElementById('grids').textContent = showGrids ? 'hide 2-D map' : 'show 2-D map';
  requestRender();
};

let topDown = false;
document.getElementById('topdown').onclick = () => {
  topDown = !topDown;
  const t = controls.target, d = camera.position.distanceTo(t);
  if (topDown) camera.position.set(t.x, t.y + d, t.z + 0.001);
  else camera.position.set(t.x + d * 0.5, t.y + d * 0.6, t.z + d * 0.6);
  document.getElementById('topdown').textContent = topDown ? 'perspective view' : 'top-down view';
  controls.update();
  requestRender();
};

function frameMap() {  // point the camera at the map once, when the first voxels arrive
  world.updateMatrixWorld(true);
  const box = new THREE.Box3();
  for (const r of Object.values(state.robots))  // voxels only: an empty geometry's bounds are NaN
    if (r.voxels.size > 0) box.union(new THREE.Box3().setFromObject(r.points));
  if (box.isEmpty()) return false;
  const c = box.getCenter(new THREE.Vector3()), size = box.getSize(new THREE.Vector3()).length();
  controls.target.copy(c);
  camera.position.set(c.x + size * 0.5, c.y + size * 0.7, c.z + size * 0.6);
  grid.position.y = box.min.y;
  controls.update();
  return true;
}

function connect() {
  const ws = new WebSocket(`ws://${location.host}/`, ['foxglove.websocket.v1']);
  ws.binaryType = 'arraybuffer';
  const subs = {};  // subscription id -> { robot, kind }
  ws.onopen = () => { document.getElementById('conn').textContent = 'connected'; };
  ws.onclose = () => { document.getElementById('conn').textContent = 'disconnected, retrying...'; setTimeout(connect, 2000); };
  ws.onmessage = (event) => {
    if (typeof event.data === 'string') {
      const m = JSON.parse(event.data);
      if (m.op !== 'advertise') return;
      const subscriptions = [];
      for (const c of m.channels) {
        const parts = c.topic.split('/');  // "", robot, kind
        if (parts.length !== 3 || !['voxel_delta', 'trajectory', 'pose', 'status', 'loops', 'map_grid'].includes(parts[2])) continue;
        robot(parts[1]);
        subs[c.id] = { robot: parts[1], kind: parts[2] };
        subscriptions.push({ id: c.id, channelId: c.id });
      }
      ws.send(JSON.stringify({ op: 'subscribe', subscriptions }));
      return;
    }
    const view = new DataView(event.data);
    if (view.getUint8(0) !== 1) return;
    const sub = subs[view.getUint32(1, true)];
    if (!sub) return;
    const m = JSON.parse(new TextDecoder().decode(new Uint8Array(event.data, 13)));
    const r = robot(sub.robot);
    ++state.messages;
    if (sub.kind !== 'status') requestRender();
    if (sub.kind === 'voxel_delta') applyVoxels(r, m);
    else if (sub.kind === 'trajectory') applyTrajectory(r, m);
    else if (sub.kind === 'pose') applyPose(r, m);
    else if (sub.kind === 'status') r.status = m;
    else if (sub.kind === 'loops') applyLoops(r, m);
    else if (sub.kind === 'map_grid') applyGrid(r, m);
  };
}

let framed = false;
function animate() {
  requestAnimationFrame(animate);
  let changed = false;
  for (const r of Object.values(state.robots)) if (r.dirty) { rebuildVoxels(r); changed = true; }
  if (changed && !framed) framed = frameMap();
  controls.update();
  if (needsRender || changed) {
    renderer.render(scene, camera);
    needsRender = false;
  }
  if (changed) legend();
  document.body.dataset.state = `${renderer.domElement.width}x${renderer.domElement.height} cam ${camera.position.toArray().map((v) => v.toFixed(2))} target ${controls.target.toArray().map((v) => v.toFixed(2))} framed ${framed} voxels ${state.voxels} msgs ${state.messages} grids ${state.grids} poses ${state.poses}`;
  if (state.voxels > 0 && framed) {
    state.drawn = true;
    document.title = `rgbdmap viewer: ${state.voxels} voxels`;
  }
}
window.addEventListener('resize', () => {
  camera.aspect = window.innerWidth / window.innerHeight;
  camera.updateProjectionMatrix();
  renderer.setSize(window.innerWidth, window.innerHeight);
  requestRender();
});
setInterval(legend, 500);
connect();
animate();
