// Reference side of the MCAP source tests: a TUM-layout folder (as `rgbdmap synth` writes it) into a
// rosbag2-style MCAP file written by the reference libraries (npm @mcap/core's McapWriter, ROS 2 CDR by
// @foxglove/rosmsg2-serialization from the standard definitions of @foxglove/rosmsg-msgs-common), with the
// realsense2_camera topics of aligned depth; and a verify mode that reads a file back with @mcap/core's
// readers and the CDR MessageReader built from the file's own schema text.
//
// Usage: node mcap_reference_writer.js TUM_DIR OUT.mcap [--compression zstd|lz4|none] [--frames N]
//          [--cut FRACTION] [--depth 32FC1|16UC1] [--color rgb8|bgr8] [--chunk-size BYTES]
//          [--schema-text plain|rosbag2] [--nan-invalid]
//        node mcap_reference_writer.js --verify FILE.mcap [--against TUM_DIR]
//   --compression  chunk compression by the Debian CLIs `zstd -q -c` / `lz4 -q -c` (default zstd)
//   --frames N     only the first N associated colour/depth pairs
//   --cut F        after writing, keep the first floor(F * size) bytes (0 < F < 1): a recording cut off
//                  mid-write, without summary and footer
//   --depth        32FC1 metres (default; raw / depth_scale as float32) or 16UC1 millimetres
//   --color        bgr8 (default, as realsense2_camera publishes) or rgb8
//   --chunk-size   McapWriter's chunk size (default 1 MiB: one chunk per frame here)
//   --schema-text  plain (default): the .msg field lines, dependencies after `MSG: pkg/msg/Type` lines;
//                  rosbag2: as rosbag2's LocalMessageDefinitionSource concatenates the .msg files - comment
//                  lines and trailing comments, same-package field types without the package
//                  (`RegionOfInterest roi`), dependencies after `MSG: pkg/Type` lines as the fields name them
//   --nan-invalid  32FC1 pixels without depth as NaN (as depth_image_proc writes them) instead of 0
// Verify prints the schemas, channels, per-topic message counts, the first image of each image topic,
// whether the file is complete (footer, summary, statistics, chunk and message indexes, read again
// through McapIndexedReader) or cut off; with --against, compares every image and camera_info with the
// folder (colour bytes exact, depth back in the folder's units exact for 32FC1, millimetre-rounded for
// 16UC1). Exit 0 when all holds (a cut file is fine: it says so), 1 on an error or a mismatch, 2 usage.
// Needs NODE_PATH with @mcap/core, @foxglove/rosmsg2-serialization, @foxglove/rosmsg-msgs-common,
// @foxglove/rosmsg (deploy/install_deps.sh installs them into /usr/local/lib/rgbdmap-node).
'use strict';
const fs = require('fs');
const path = require('path');
const zlib = require('zlib');
const { execFileSync } = require('child_process');

const PROGRAM = 'mcap_reference_writer';
const TOPIC_COLOR = '/camera/camera/color/image_raw';
const TOPIC_DEPTH = '/camera/camera/aligned_depth_to_color/image_raw';
const TOPIC_INFO = '/camera/camera/color/camera_info';
const FRAME_ID = 'camera_color_optical_frame';
const MAX_DT = 0.02;  // colour <-> depth association tolerance (s), the project's default
const SEPARATOR = '='.repeat(80);
// What rosbag2 (humble) stores as a channel's offered QoS (a sensor-data style reliable publisher).
const QOS_YAML = '- history: 3\n  depth: 0\n  reliability: 1\n  durability: 2\n  deadline:\n    sec: 2147483647\n' +
  '    nsec: 4294967295\n  lifespan:\n    sec: 2147483647\n    nsec: 4294967295\n  liveliness: 1\n' +
  '  liveliness_lease_duration:\n    sec: 2147483647\n    nsec: 4294967295\n  avoid_ros_namespace_conventions: false';

class UsageError extends Error {}
class Failure extends Error {}

function need(name) {
  try {
    return require(name);
  } catch (e) {
    throw new Failure(`cannot load npm ${name} (${e.code || e.message}); set NODE_PATH to the node_modules ` +
                      'that has it (deploy/install_deps.sh installs it into /usr/local/lib/rgbdmap-node)');
  }
}

// ---------------------------------------------------------------------------------------------------
// PNG (non-interlaced; filters 0-4; 8- and 16-bit samples, big-endian) with Node's zlib.

const PNG_SIGNATURE = Buffer.from([0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a]);
const PNG_CHANNELS = { 0: 1, 2: 3, 4: 2, 6: 4 };  // colour type -> samples per pixel (no palette)

function decodePng(file) {
  let buf;
  try {
    buf = fs.readFileSync(file);
  } catch (e) {
    throw new Failure(`${file}: cannot read (${e.code || e.message})`);
  }
  const bad = (why) => new Failure(`${file}: not a PNG this tool reads: ${why}`);
  if (buf.length < 8 || !buf.subarray(0, 8).equals(PNG_SIGNATURE)) throw bad('no PNG signature');
  let ihdr = null, ended = false;
  const idat = [];
  for (let pos = 8; pos < buf.length;) {
    if (pos + 12 > buf.length) throw bad(`chunk header past the end at byte ${pos}`);
    const len = buf.readUInt32BE(pos), type = buf.toString('latin1', pos + 4, pos + 8);
    if (pos + 12 + len > buf.length) throw bad(`chunk ${type} runs past the end`);
    const data = buf.subarray(pos + 8, pos + 8 + len);
    if (typeof zlib.crc32 === 'function' &&
        (zlib.crc32(data, zlib.crc32(buf.subarray(pos + 4, pos + 8))) >>> 0) !== buf.readUInt32BE(pos + 8 + len))
      throw bad(`chunk ${type}: CRC mismatch`);
    if (type === 'IHDR') {
      ihdr = { width: data.readUInt32BE(0), height: data.readUInt32BE(4), bitDepth: data[8], colorType: data[9],
               compression: data[10], filter: data[11], interlace: data[12] };
    } else if (type === 'IDAT') {
      idat.push(data);
    } else if (type === 'IEND') {
      ended = true;
      break;
    }
    pos += 12 + len;
  }
  if (!ihdr) throw bad('no IHDR');
  if (!ended) throw bad('no IEND');
  const { width, height, bitDepth, colorType } = ihdr;
  const channels = PNG_CHANNELS[colorType];
  if (!channels) throw bad(`colour type ${colorType} (only grey, grey+alpha, RGB, RGBA)`);
  if (bitDepth !== 8 && bitDepth !== 16) throw bad(`bit depth ${bitDepth} (only 8 and 16)`);
  if (ihdr.compression !== 0 || ihdr.filter !== 0) throw bad('unknown compression or filter method');
  if (ihdr.interlace !== 0) throw bad('interlaced');
  if (!width || !height) throw bad('empty image');
  let raw;
  try {
    raw = zlib.inflateSync(Buffer.concat(idat));
  } catch (e) {
    throw bad(`image data does not inflate (${e.message})`);
  }
  const bpp = channels * (bitDepth / 8), stride = width * bpp;
  if (raw.length < height * (stride + 1)) throw bad(`${raw.length} bytes of image data, expected ${height * (stride + 1)}`);
  const out = Buffer.alloc(height * stride);
  for (let y = 0; y < height; ++y) {
    const filter = raw[y * (stride + 1)], src = y * (stride + 1) + 1, dst = y * stride, up = dst - stride;
    switch (filter) {
      case 0:
        raw.copy(out, dst, src, src + stride);
        break;
      case 1:
        for (let i = 0; i < stride; ++i) out[dst + i] = (raw[src + i] + (i >= bpp ? out[dst + i - bpp] : 0)) & 255;
        break;
      case 2:
        for (let i = 0; i < stride; ++i) out[dst + i] = (raw[src + i] + (y > 0 ? out[up + i] : 0)) & 255;
        break;
      case 3:
        for (let i = 0; i < stride; ++i) {
          const a = i >= bpp ? out[dst + i - bpp] : 0, b = y > 0 ? out[up + i] : 0;
          out[dst + i] = (raw[src + i] + ((a + b) >> 1)) & 255;
        }
        break;
      case 4:
        for (let i = 0; i < stride; ++i) {
          const a = i >= bpp ? out[dst + i - bpp] : 0, b = y > 0 ? out[up + i] : 0;
          const c = i >= bpp && y > 0 ? out[up + i - bpp] : 0;
          const p = a + b - c, pa = Math.abs(p - a), pb = Math.abs(p - b), pc = Math.abs(p - c);
          out[dst + i] = (raw[src + i] + (pa <= pb && pa <= pc ? a : pb <= pc ? b : c)) & 255;
        }
        break;
      default:
        throw bad(`row ${y}: filter type ${filter}`);
    }
  }
  return { width, height, bitDepth, channels, data: out };
}

// ---------------------------------------------------------------------------------------------------
// The TUM folder: camera.yaml, rgb.txt / depth.txt and their association.

function readText(file) {
  try {
    return fs.readFileSync(file, 'utf8');
  } catch (e) {
    throw new Failure(`${file}: cannot read (${e.code || e.message})`);
  }
}

/// camera.yaml as `rgbdmap synth` writes it: a `camera:` map of scalars and `distortion: [k1, k2, p1, p2, k3]`.
function readCamera(dir) {
  const file = path.join(dir, 'camera.yaml');
  const cam = {};
  let inCamera = false;
  readText(file).split(/\r?\n/).forEach((line, i) => {
    const text = line.replace(/#.*$/, '').trimEnd();
    if (!text.trim()) return;
    if (/^\S/.test(text)) {
      inCamera = /^camera:\s*$/.test(text);
      return;
    }
    if (!inCamera) return;
    const m = /^\s+([A-Za-z_]+):\s*(.*)$/.exec(text);
    if (!m) throw new Failure(`${file}:${i + 1}: cannot read '${line.trim()}'`);
    const [, key, value] = m;
    const number = (s) => {
      const v = Number(s.trim());
      if (s.trim() === '' || !Number.isFinite(v)) throw new Failure(`${file}:${i + 1}: camera.${key}: '${s.trim()}' is not a number`);
      return v;
    };
    if (key === 'distortion') {
      const list = /^\[(.*)\]$/.exec(value.trim());
      if (!list) throw new Failure(`${file}:${i + 1}: camera.distortion must be a list [k1, k2, p1, p2, k3]`);
      cam.distortion = list[1].trim() === '' ? [] : list[1].split(',').map(number);
      if (cam.distortion.length !== 5) throw new Failure(`${file}:${i + 1}: camera.distortion must have 5 numbers`);
    } else {
      cam[key] = number(value);
    }
  });
  for (const key of ['fx', 'fy', 'cx', 'cy', 'width', 'height'])
    if (cam[key] === undefined) throw new Failure(`${file}: camera.${key} is missing`);
  if (!cam.distortion) cam.distortion = [0, 0, 0, 0, 0];
  if (cam.depth_scale === undefined) cam.depth_scale = 5000;
  if (!(cam.depth_scale > 0)) throw new Failure(`${file}: camera.depth_scale must be > 0`);
  return cam;
}

/// A TUM timestamp's text as integer nanoseconds: exact decimal digits (rounded at the 9th decimal), so that
/// sec + nanosec * 1e-9 gives back the text; other number forms through a double, to the microsecond.
function stampNs(text, where) {
  const m = /^\+?(\d+)(?:\.(\d*))?$/.exec(text);
  let ns;
  if (m) {
    const frac = m[2] || '';
    ns = BigInt(m[1]) * 1000000000n + BigInt(frac.slice(0, 9).padEnd(9, '0'));
    if (frac.length > 9 && frac[9] >= '5') ns += 1n;
  } else {
    const t = Number(text);
    if (!Number.isFinite(t) || t < 0) throw new Failure(`${where}: timestamp '${text}' is not a time >= 0`);
    ns = BigInt(Math.round(t * 1e6)) * 1000n;
  }
  if (ns / 1000000000n > 2147483647n) throw new Failure(`${where}: timestamp '${text}' does not fit a ROS 2 time`);
  return ns;
}

function readList(dir, name) {
  const file = path.join(dir, name);
  const out = [];
  readText(file).split(/\r?\n/).forEach((line, i) => {
    const text = line.trim();
    if (!text || text.startsWith('#')) return;
    const fields = text.split(/\s+/);
    const where = `${file}:${i + 1}`;
    if (fields.length !== 2) throw new Failure(`${where}: expected 2 fields (timestamp filename), got ${fields.length}`);
    const t = Number(fields[0]);
    if (!Number.isFinite(t)) throw new Failure(`${where}: timestamp '${fields[0]}' is not a number`);
    out.push({ t, ns: stampNs(fields[0], where), text: fields[0], file: path.join(dir, fields[1]) });
  });
  return out;
}

/// The project's association (common/dataset/src/association.cpp): every (colour, depth) pair less than
/// MAX_DT apart, taken greedily by the smallest difference, each image at most once; sorted by colour time.
function associate(rgb, depth) {
  const order = depth.map((_, i) => i).sort((x, y) => depth[x].t - depth[y].t || x - y);
  const cand = [];
  for (let a = 0; a < rgb.length; ++a) {
    let lo = 0, hi = order.length;
    while (lo < hi) {
      const mid = (lo + hi) >> 1;
      if (depth[order[mid]].t < rgb[a].t - MAX_DT) lo = mid + 1; else hi = mid;
    }
    for (let k = lo; k < order.length && depth[order[k]].t <= rgb[a].t + MAX_DT; ++k) {
      const diff = Math.abs(rgb[a].t - depth[order[k]].t);
      if (diff < MAX_DT) cand.push({ diff, a, b: order[k] });
    }
  }
  cand.sort((x, y) => x.diff - y.diff || rgb[x.a].t - rgb[y.a].t || depth[x.b].t - depth[y.b].t || x.a - y.a || x.b - y.b);
  const aUsed = new Uint8Array(rgb.length), bUsed = new Uint8Array(depth.length), pairs = [];
  for (const c of cand) {
    if (aUsed[c.a] || bUsed[c.b]) continue;
    aUsed[c.a] = bUsed[c.b] = 1;
    pairs.push(c);
  }
  pairs.sort((x, y) => rgb[x.a].t - rgb[y.a].t || depth[x.b].t - depth[y.b].t || x.a - y.a);
  return pairs.map((c) => ({ rgb: rgb[c.a], depth: depth[c.b] }));
}

function openFolder(dir, maxFrames) {
  if (!fs.existsSync(dir) || !fs.statSync(dir).isDirectory()) throw new Failure(`${dir}: not a folder`);
  const camera = readCamera(dir);
  const rgb = readList(dir, 'rgb.txt'), depth = readList(dir, 'depth.txt');
  let frames = associate(rgb, depth);
  if (!frames.length)
    throw new Failure(`${dir}: no colour frame has a depth image within ${MAX_DT} s (${rgb.length} colour, ${depth.length} depth entries)`);
  if (maxFrames) frames = frames.slice(0, maxFrames);
  return { camera, frames, rgbCount: rgb.length, depthCount: depth.length };
}

function loadColor(file, camera) {
  const png = decodePng(file);
  if (png.bitDepth !== 8 || png.channels !== 3) throw new Failure(`${file}: colour must be 8-bit RGB, is ${png.bitDepth}-bit with ${png.channels} channels`);
  if (png.width !== camera.width || png.height !== camera.height)
    throw new Failure(`${file}: image is ${png.width}x${png.height}, camera.yaml says ${camera.width}x${camera.height}`);
  return png;
}

function loadDepth(file, camera) {
  const png = decodePng(file);
  if (png.bitDepth !== 16 || png.channels !== 1) throw new Failure(`${file}: depth must be 16-bit grey, is ${png.bitDepth}-bit with ${png.channels} channels`);
  if (png.width !== camera.width || png.height !== camera.height)
    throw new Failure(`${file}: image is ${png.width}x${png.height}, camera.yaml says ${camera.width}x${camera.height}`);
  return png;
}

// ---------------------------------------------------------------------------------------------------
// Messages: the standard ROS 2 definitions and their ros2msg schema text.

const PRIMITIVES = new Set(['bool', 'byte', 'char', 'float32', 'float64', 'int8', 'uint8', 'int16', 'uint16',
                            'int32', 'uint32', 'int64', 'uint64', 'string', 'wstring']);
const BUILTIN = { time: 'builtin_interfaces/Time', duration: 'builtin_interfaces/Duration' };

function definitionsFor(rootName) {
  const { ros2humble } = need('@foxglove/rosmsg-msgs-common');
  const seen = new Map();
  const visit = (name) => {
    if (seen.has(name)) return;
    const def = ros2humble[name];
    if (!def) throw new Failure(`@foxglove/rosmsg-msgs-common ros2humble has no ${name}`);
    seen.set(name, def);
    for (const f of def.definitions) {
      if (f.isConstant) continue;
      if (BUILTIN[f.type]) visit(BUILTIN[f.type]);
      else if (f.isComplex) visit(f.type);
    }
  };
  visit(rootName);
  return [...seen.values()];  // the root first, as MessageWriter wants
}

// Comments of the rosbag2-style text (our own words; the real .msg files carry longer ones).
const COMMENTS = {
  'sensor_msgs/Image': { top: '# An uncompressed image.\n# (0, 0) is the top-left corner of the image.\n',
                         header: 'acquisition time; frame of the camera optical centre', height: 'rows',
                         width: 'columns', encoding: 'pixel encoding: channel meaning, order, size',
                         step: 'full row length in bytes', data: 'step * rows bytes' },
  'sensor_msgs/CameraInfo': { top: '# Calibration of a pinhole camera.\n\n#######################################\n#   Image acquisition info\n#######################################\n',
                              distortion_model: 'e.g. plumb_bob', d: 'distortion parameters',
                              k: 'intrinsic matrix, row-major 3x3', r: 'rectification matrix, row-major 3x3',
                              p: 'projection matrix, row-major 3x4', roi: 'region of interest' },
  'std_msgs/Header': { top: '# Standard metadata for higher-level stamped data types.\n\n', stamp: 'two-integer timestamp',
                       frame_id: 'the frame this data is associated with' },
  'builtin_interfaces/Time': { top: '# Time: seconds and nanoseconds since an epoch.\n\n', sec: 'seconds',
                               nanosec: 'nanoseconds, [0, 1e9)' },
  'sensor_msgs/RegionOfInterest': { top: '# A sub-window of an image.\n\n', do_rectify: 'true: rectify this ROI' },
};

const pkgOf = (name) => name.split('/')[0];
const longName = (name) => name.replace('/', '/msg/');

/// One type's .msg text; `rosbag2` style: comments, and same-package types without the package.
function msgText(def, style) {
  const comments = style === 'rosbag2' ? COMMENTS[def.name] || {} : {};
  let text = comments.top || '';
  for (const f of def.definitions) {
    let type = BUILTIN[f.type] || f.type;
    if (!PRIMITIVES.has(type)) {
      if (style !== 'rosbag2') type = longName(type);
      else if (pkgOf(type) === pkgOf(def.name)) type = type.split('/')[1];
    }
    if (f.isArray) type += `[${f.arrayLength !== undefined ? f.arrayLength : ''}]`;
    let line = `${type} ${f.name}`;
    if (f.isConstant) line = `${type} ${f.name}=${f.valueText !== undefined ? f.valueText : f.value}`;
    if (comments[f.name]) line = `${line.padEnd(32)} # ${comments[f.name]}`;
    text += line + '\n';
  }
  return text;
}

/// The complete ros2msg definition: the root's text, then each dependency (depth first, each once) after
/// "\n" + 80 '=' + "\nMSG: NAME\n". plain: NAME = pkg/msg/Type, dependencies in field order; rosbag2:
/// NAME = pkg/Type as the field names it (package added for same-package types), dependencies of each
/// type in sorted order (rosbag2_cpp's LocalMessageDefinitionSource::get_full_text).
function schemaText(defs, style) {
  const byName = new Map(defs.map((d) => [d.name, d]));
  const seen = new Set();
  const deps = (def) => {
    const names = [];
    for (const f of def.definitions) {
      const t = BUILTIN[f.type] || (f.isComplex ? f.type : null);
      if (t && !names.includes(t)) names.push(t);
    }
    return style === 'rosbag2' ? names.sort() : names;
  };
  const append = (def) => {
    let result = msgText(def, style);
    for (const name of deps(def)) {
      if (seen.has(name)) continue;
      seen.add(name);
      result += `\n${SEPARATOR}\nMSG: ${style === 'rosbag2' ? name : longName(name)}\n` + append(byName.get(name));
    }
    return result;
  };
  return append(defs[0]);
}

// ---------------------------------------------------------------------------------------------------
// Writing.

class FileWritable {  // @mcap/core IWritable over a file descriptor
  constructor(fd) { this.fd = fd; this.pos = 0n; }
  async write(buffer) {
    for (let off = 0; off < buffer.byteLength;) off += fs.writeSync(this.fd, buffer, off, buffer.byteLength - off);
    this.pos += BigInt(buffer.byteLength);
  }
  position() { return this.pos; }
}

function cliCompressor(kind) {
  return (chunk) => {
    let out;
    try {
      out = execFileSync(kind, ['-q', '-c'], { input: chunk, maxBuffer: 1 << 30, stdio: ['pipe', 'pipe', 'pipe'] });
    } catch (e) {
      const why = e.code === 'ENOENT' ? 'not installed' : (e.stderr && e.stderr.toString().trim()) || e.message;
      throw new Failure(`${kind} -q -c: ${why}`);
    }
    return { compression: kind, compressedData: new Uint8Array(out.buffer, out.byteOffset, out.byteLength) };
  };
}

function cliDecompressor(kind) {
  return (data, size) => {
    let out;
    try {
      out = execFileSync(kind, ['-q', '-d', '-c'], { input: data, maxBuffer: Number(size) + (1 << 20), stdio: ['pipe', 'pipe', 'pipe'] });
    } catch (e) {
      const why = e.code === 'ENOENT' ? 'not installed' : (e.stderr && e.stderr.toString().trim()) || e.message;
      throw new Failure(`${kind} -d: ${why}`);
    }
    if (BigInt(out.byteLength) !== size) throw new Failure(`${kind} -d: ${out.byteLength} bytes, the chunk says ${size}`);
    return new Uint8Array(out.buffer, out.byteOffset, out.byteLength);
  };
}

function header(ns) {
  return { stamp: { sec: Number(ns / 1000000000n), nanosec: Number(ns % 1000000000n) }, frame_id: FRAME_ID };
}

function colorMessage(frame, camera, encoding) {
  const png = loadColor(frame.rgb.file, camera);
  const data = encoding === 'rgb8' ? png.data : Buffer.alloc(png.data.length);
  if (encoding === 'bgr8')
    for (let i = 0; i < data.length; i += 3) {
      data[i] = png.data[i + 2];
      data[i + 1] = png.data[i + 1];
      data[i + 2] = png.data[i];
    }
  return { header: header(frame.rgb.ns), height: png.height, width: png.width, encoding, is_bigendian: 0,
           step: png.width * 3, data: new Uint8Array(data.buffer, data.byteOffset, data.byteLength) };
}

function depthMessage(frame, camera, encoding, nanInvalid) {
  const png = loadDepth(frame.depth.file, camera);
  const n = png.width * png.height, bytes = encoding === '16UC1' ? 2 : 4;
  const data = new Uint8Array(n * bytes), view = new DataView(data.buffer), src = png.data;
  for (let i = 0; i < n; ++i) {
    const raw = (src[2 * i] << 8) | src[2 * i + 1];  // PNG samples are big-endian; the message's little-endian
    if (encoding === '16UC1') view.setUint16(2 * i, Math.min(65535, Math.round(raw * 1000 / camera.depth_scale)), true);
    else view.setFloat32(4 * i, raw === 0 && nanInvalid ? NaN : raw / camera.depth_scale, true);
  }
  return { header: header(frame.depth.ns), height: png.height, width: png.width, encoding, is_bigendian: 0,
           step: png.width * bytes, data };
}

function infoMessage(frame, camera) {
  const { fx, fy, cx, cy } = camera;
  return { header: header(frame.rgb.ns), height: camera.height, width: camera.width, distortion_model: 'plumb_bob',
           d: Float64Array.from(camera.distortion), k: Float64Array.from([fx, 0, cx, 0, fy, cy, 0, 0, 1]),
           r: Float64Array.from([1, 0, 0, 0, 1, 0, 0, 0, 1]), p: Float64Array.from([fx, 0, cx, 0, 0, fy, cy, 0, 0, 0, 1, 0]),
           binning_x: 0, binning_y: 0, roi: { x_offset: 0, y_offset: 0, height: 0, width: 0, do_rectify: false } };
}

async function write(opts) {
  const { McapWriter, LIBRARY_IDENTIFIER } = need('@mcap/core');
  const { MessageWriter } = need('@foxglove/rosmsg2-serialization');
  const started = Date.now();
  const folder = openFolder(opts.dir, opts.frames);
  const { camera, frames } = folder;
  const imageDefs = definitionsFor('sensor_msgs/Image'), infoDefs = definitionsFor('sensor_msgs/CameraInfo');
  const imageWriter = new MessageWriter(imageDefs), infoWriter = new MessageWriter(infoDefs);

  // Every message's time first, then the messages in time order (colour, camera_info, depth on ties).
  const events = [];
  frames.forEach((f, i) => {
    events.push({ ns: f.rgb.ns, i, kind: 0 }, { ns: f.rgb.ns, i, kind: 1 }, { ns: f.depth.ns, i, kind: 2 });
  });
  events.sort((x, y) => (x.ns < y.ns ? -1 : x.ns > y.ns ? 1 : x.i - y.i || x.kind - y.kind));

  const out = path.resolve(opts.out);
  const tmp = path.join(path.dirname(out), `.${path.basename(out)}.tmp-${process.pid}`);
  let fd = -1;
  try {
    fd = fs.openSync(tmp, 'w');
    const writable = new FileWritable(fd);
    const writer = new McapWriter({
      writable,
      useChunks: true,
      chunkSize: opts.chunkSize,
      compressChunk: opts.compression === 'none' ? undefined : cliCompressor(opts.compression),
    });
    await writer.start({ profile: 'ros2', library: `${PROGRAM} (rgbdmap tests; ${LIBRARY_IDENTIFIER})` });
    const enc = (text) => new TextEncoder().encode(text);
    const imageSchema = await writer.registerSchema({ name: 'sensor_msgs/msg/Image', encoding: 'ros2msg', data: enc(schemaText(imageDefs, opts.schemaText)) });
    const infoSchema = await writer.registerSchema({ name: 'sensor_msgs/msg/CameraInfo', encoding: 'ros2msg', data: enc(schemaText(infoDefs, opts.schemaText)) });
    const metadata = () => new Map([['offered_qos_profiles', QOS_YAML]]);
    const channel = {};
    channel[0] = await writer.registerChannel({ schemaId: imageSchema, topic: TOPIC_COLOR, messageEncoding: 'cdr', metadata: metadata() });
    channel[1] = await writer.registerChannel({ schemaId: infoSchema, topic: TOPIC_INFO, messageEncoding: 'cdr', metadata: metadata() });
    channel[2] = await writer.registerChannel({ schemaId: imageSchema, topic: TOPIC_DEPTH, messageEncoding: 'cdr', metadata: metadata() });
    const sequence = [0, 0, 0];
    for (const e of events) {
      const f = frames[e.i];
      let data;
      if (e.kind === 0) data = imageWriter.writeMessage(colorMessage(f, camera, opts.color));
      else if (e.kind === 1) data = infoWriter.writeMessage(infoMessage(f, camera));
      else data = imageWriter.writeMessage(depthMessage(f, camera, opts.depth, opts.nanInvalid));
      await writer.addMessage({ channelId: channel[e.kind], sequence: sequence[e.kind]++, logTime: e.ns, publishTime: e.ns, data });
    }
    // rosbag2's storage plugin adds a "rosbag2" metadata record when it closes the file.
    await writer.addMetadata({ name: 'rosbag2', metadata: new Map([['ROS_DISTRO', 'humble'], ['writer', PROGRAM]]) });
    await writer.end();
    fs.closeSync(fd);
    fd = -1;
    let size = Number(writable.position());
    const full = size;
    if (opts.cut !== undefined) {
      size = Math.floor(opts.cut * full);
      fs.truncateSync(tmp, size);
    }
    fs.renameSync(tmp, out);
    const st = writer.statistics;
    console.error(`${PROGRAM}: wrote ${opts.out}: ${frames.length} frames (${folder.rgbCount} colour, ${folder.depthCount} depth entries), ` +
                  `${st.messageCount} messages in ${st.chunkCount} chunks (${opts.compression}), colour ${opts.color}, depth ${opts.depth}, ` +
                  `schema text ${opts.schemaText}, ${full} bytes` + (opts.cut !== undefined ? `, cut to ${size} bytes` : '') +
                  `, ${((Date.now() - started) / 1000).toFixed(2)} s`);
  } catch (e) {
    if (fd >= 0) fs.closeSync(fd);
    fs.rmSync(tmp, { force: true });
    throw e;
  }
}

// ---------------------------------------------------------------------------------------------------
// Verify: read a file back.

class FileReadable {  // @mcap/core IReadable over a file
  constructor(fd, size) { this.fd = fd; this.bytes = size; }
  async size() { return BigInt(this.bytes); }
  async read(offset, size) {
    const buf = Buffer.alloc(Number(size));
    for (let got = 0; got < buf.length;) {
      const n = fs.readSync(this.fd, buf, got, buf.length - got, Number(offset) + got);
      if (n === 0) throw new Failure(`read past the end of the file at ${Number(offset) + got}`);
      got += n;
    }
    return new Uint8Array(buf.buffer, buf.byteOffset, buf.byteLength);
  }
}

const chunkKey = (data, size) =>
  `${data.byteLength}:${size}:${typeof zlib.crc32 === 'function' ? zlib.crc32(data) : Buffer.from(data).toString('base64')}`;

/// Every complete compressed chunk of the file decompressed by one CLI run per compression (zstd and lz4
/// decode concatenated frames), into `cache`: a process start costs more than the decompression here.
/// Only a speed-up: on any surprise the readers decompress chunk by chunk.
function predecompress(file, cache, key) {
  let buf;
  try {
    buf = fs.readFileSync(file);
  } catch (e) {
    return;
  }
  const groups = new Map();
  for (let pos = 8; pos + 9 <= buf.length;) {  // after the magic: opcode, uint64 length, body
    const op = buf[pos], len = Number(buf.readBigUInt64LE(pos + 1)), body = pos + 9;
    if (body + len > buf.length || op === 0x02) break;  // cut off, or the footer
    if (op === 0x06 && len >= 36) {  // Chunk: start, end, uncompressed size, crc, compression, records
      const size = buf.readBigUInt64LE(body + 16), clen = buf.readUInt32LE(body + 28);
      const compression = buf.toString('utf8', body + 32, body + 32 + clen);
      const rlen = Number(buf.readBigUInt64LE(body + 32 + clen)), records = buf.subarray(body + 40 + clen, body + 40 + clen + rlen);
      if (compression === 'zstd' || compression === 'lz4') {
        if (!groups.has(compression)) groups.set(compression, []);
        groups.get(compression).push({ records, size });
      }
    }
    pos = body + len;
  }
  for (const [kind, chunks] of groups) {
    const total = chunks.reduce((n, c) => n + Number(c.size), 0);
    let out;
    try {
      out = execFileSync(kind, ['-q', '-d', '-c'], { input: Buffer.concat(chunks.map((c) => c.records)), maxBuffer: total + (1 << 20), stdio: ['pipe', 'pipe', 'pipe'] });
    } catch (e) {
      continue;
    }
    if (out.length !== total) continue;
    let off = 0;
    for (const c of chunks) {
      const n = Number(c.size);
      cache.set(key(c.records, c.size), new Uint8Array(out.buffer, out.byteOffset + off, n));
      off += n;
    }
  }
}

const fmtStamp = (s) => `${s.sec}.${String(s.nanosec).padStart(9, '0')}`;

async function verify(opts) {
  const { McapStreamReader, McapIndexedReader } = need('@mcap/core');
  const { MessageReader } = need('@foxglove/rosmsg2-serialization');
  const { parse } = need('@foxglove/rosmsg');
  const file = opts.verify;
  let size;
  try {
    size = fs.statSync(file).size;
  } catch (e) {
    throw new Failure(`${file}: cannot read (${e.code || e.message})`);
  }
  const problems = [];
  const problem = (m) => { if (problems.length < 20) problems.push(m); };
  // Each chunk is decompressed once (the indexed reader's pass gets the stream pass's result).
  const cache = new Map();
  const cached = (decompress) => (data, size) => {
    const key = chunkKey(data, size);
    if (!cache.has(key)) cache.set(key, decompress(data, size));
    return cache.get(key);
  };
  const decompressHandlers = { zstd: cached(cliDecompressor('zstd')), lz4: cached(cliDecompressor('lz4')) };
  predecompress(file, cache, chunkKey);
  const folder = opts.against ? openFolder(opts.against, 0) : null;

  const schemas = new Map(), channels = new Map(), readers = new Map(), perTopic = new Map();
  let header = null, footer = null, chunks = 0, lastLog = -1n, metadata = 0;
  const compressions = new Set(), firstImage = new Map();
  const onMessage = (rec) => {
    const ch = channels.get(rec.channelId);
    if (!ch) return problem(`message on unknown channel ${rec.channelId}`);
    const topic = perTopic.get(ch.topic);
    const k = topic.count++;
    if (rec.logTime < lastLog) problem(`${ch.topic}: message ${k} at log time ${rec.logTime} before the previous one`);
    lastLog = rec.logTime;
    const msg = readers.get(rec.channelId).readMessage(rec.data);
    const stampNsOf = BigInt(msg.header.stamp.sec) * 1000000000n + BigInt(msg.header.stamp.nanosec);
    if (stampNsOf !== rec.logTime || rec.publishTime !== rec.logTime)
      problem(`${ch.topic}: message ${k}: stamp ${fmtStamp(msg.header.stamp)}, log time ${rec.logTime}, publish time ${rec.publishTime}`);
    if (msg.header.frame_id !== FRAME_ID) problem(`${ch.topic}: message ${k}: frame_id '${msg.header.frame_id}'`);
    const isImage = schemas.get(ch.schemaId).name === 'sensor_msgs/msg/Image';
    if (isImage && msg.data.length !== msg.step * msg.height) problem(`${ch.topic}: message ${k}: ${msg.data.length} bytes, step * height = ${msg.step * msg.height}`);
    if (isImage && !firstImage.has(ch.topic))
      firstImage.set(ch.topic, `${msg.width}x${msg.height} ${msg.encoding}, step ${msg.step}, stamp ${fmtStamp(msg.header.stamp)}, frame_id ${msg.header.frame_id}`);
    if (folder) compare(folder, ch.topic, k, msg, problem);
  };

  // Every record through the streaming reader (chunk CRCs checked), as a reader of a file being written would.
  const stream = new McapStreamReader({ includeChunks: true, decompressHandlers, validateCrcs: true });
  const fd = fs.openSync(file, 'r');
  try {
    const piece = Buffer.alloc(8 << 20);
    for (let pos = 0; pos < size;) {
      const n = fs.readSync(fd, piece, 0, piece.length, pos);
      pos += n;
      stream.append(new Uint8Array(piece.buffer, 0, n).slice());
      for (let rec; (rec = stream.nextRecord());) {
        switch (rec.type) {
          case 'Header': header = rec; break;
          case 'Footer': footer = rec; break;
          case 'Metadata': ++metadata; break;
          case 'Chunk': ++chunks; compressions.add(rec.compression || 'none'); break;
          case 'Schema': {
            schemas.set(rec.id, rec);
            break;
          }
          case 'Channel': {
            const schema = schemas.get(rec.schemaId);
            if (!schema) { problem(`channel ${rec.topic}: schema ${rec.schemaId} not seen before it`); break; }
            if (schema.encoding !== 'ros2msg' || rec.messageEncoding !== 'cdr')
              problem(`channel ${rec.topic}: schema encoding ${schema.encoding}, message encoding ${rec.messageEncoding}`);
            if (!channels.has(rec.id)) {
              const text = new TextDecoder().decode(schema.data);
              readers.set(rec.id, new MessageReader(parse(text, { ros2: true })));
              perTopic.set(rec.topic, { count: 0, schema: schema.name });
            }
            channels.set(rec.id, rec);
            break;
          }
          case 'Message': onMessage(rec); break;
          default: break;
        }
      }
    }
  } catch (e) {
    fs.closeSync(fd);
    if (e instanceof Failure) throw e;
    throw new Failure(`${file}: not a readable MCAP file: ${e.message}`);
  }

  if (!header) {
    fs.closeSync(fd);
    throw new Failure(`${file}: not a readable MCAP file: ${size} bytes and no header record`);
  }
  console.log(`file ${file}: ${size} bytes, profile ${header.profile}, library ${header.library}`);
  for (const s of schemas.values()) {
    const text = new TextDecoder().decode(s.data);
    console.log(`schema ${s.id} ${s.name} (${s.encoding}, ${s.data.length} bytes, ${text.split('\n').filter((l) => l.startsWith('MSG: ')).map((l) => l.slice(5)).join(', ') || 'no dependencies'})`);
  }
  for (const c of channels.values()) console.log(`channel ${c.id} ${c.topic}: ${schemas.get(c.schemaId).name}, ${c.messageEncoding}`);
  for (const [topic, t] of perTopic) console.log(`topic ${topic}: ${t.count} messages`);
  for (const [topic, line] of firstImage) console.log(`first image on ${topic}: ${line}`);
  console.log(`chunks: ${chunks} (${[...compressions].join(', ') || 'none'}), metadata records: ${metadata}`);

  if (footer && stream.done()) {
    // Complete: the summary through the indexed reader must agree with what the stream held.
    const indexed = await McapIndexedReader.Initialize({ readable: new FileReadable(fd, size), decompressHandlers });
    const st = indexed.statistics;
    const withIndexes = indexed.chunkIndexes.filter((c) => c.messageIndexOffsets.size > 0).length;
    console.log(`complete: yes: footer, summary (${indexed.chunkIndexes.length} chunk indexes, ${withIndexes} with message indexes, ` +
                `${indexed.metadataIndexes.length} metadata indexes, summary offsets ${indexed.summaryOffsetsByOpcode.size}), ` +
                `statistics ${st ? `${st.messageCount} messages` : 'none'}`);
    if (indexed.chunkIndexes.length !== chunks) problem(`${indexed.chunkIndexes.length} chunk indexes, ${chunks} chunks`);
    const viaIndex = new Map();
    let previous = -1n;
    for await (const m of indexed.readMessages()) {
      viaIndex.set(m.channelId, (viaIndex.get(m.channelId) || 0) + 1);
      if (m.logTime < previous) problem(`through the index: log time ${m.logTime} after ${previous}`);
      previous = m.logTime;
    }
    for (const [id, c] of indexed.channelsById) {
      const n = viaIndex.get(id) || 0;
      const streamed = perTopic.get(c.topic) ? perTopic.get(c.topic).count : 0;
      const counted = st ? Number(st.channelMessageCounts.get(id) || 0n) : n;
      if (n !== streamed || counted !== streamed) problem(`${c.topic}: ${streamed} messages streamed, ${n} through the index, ${counted} in the statistics`);
    }
  } else {
    console.log(`complete: no: cut off after the last whole record (${stream.bytesRemaining()} bytes of an unfinished record at the end; no footer, no summary)`);
  }
  fs.closeSync(fd);
  if (folder) {
    const color = perTopic.get(TOPIC_COLOR), depth = perTopic.get(TOPIC_DEPTH), info = perTopic.get(TOPIC_INFO);
    const n = (t) => (t ? t.count : 0);
    if (footer && (n(color) !== folder.frames.length || n(depth) !== folder.frames.length || n(info) !== folder.frames.length))
      problem(`${folder.frames.length} frames in ${opts.against}; the file has ${n(color)} colour, ${n(depth)} depth, ${n(info)} camera_info messages`);
    console.log(`against ${opts.against}: ${n(color)} colour, ${n(depth)} depth and ${n(info)} camera_info messages compared`);
  }
  if (problems.length) {
    for (const p of problems) console.log(`MISMATCH: ${p}`);
    return 1;
  }
  console.log('verify: ok');
  return 0;
}

/// Message k of a topic against frame k of the folder.
function compare(folder, topic, k, msg, problem) {
  const frame = folder.frames[k], camera = folder.camera;
  if (!frame) return problem(`${topic}: message ${k}: the folder has only ${folder.frames.length} frames`);
  const want = topic === TOPIC_DEPTH ? frame.depth.ns : frame.rgb.ns;
  const got = BigInt(msg.header.stamp.sec) * 1000000000n + BigInt(msg.header.stamp.nanosec);
  if (got !== want) problem(`${topic}: message ${k}: stamp ${fmtStamp(msg.header.stamp)}, expected ${want} ns`);
  if (Math.abs(Number(got) / 1e9 - (topic === TOPIC_DEPTH ? frame.depth.t : frame.rgb.t)) > 0.5e-6)
    problem(`${topic}: message ${k}: sec + nanosec * 1e-9 is not the text timestamp to the microsecond`);
  if (topic === TOPIC_INFO) {
    const k9 = [camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1];
    if (msg.distortion_model !== 'plumb_bob' || msg.width !== camera.width || msg.height !== camera.height ||
        k9.some((v, i) => msg.k[i] !== v) || camera.distortion.some((v, i) => msg.d[i] !== v) || msg.d.length !== 5)
      problem(`${topic}: message ${k}: camera differs from camera.yaml`);
    return;
  }
  const bytes = Buffer.from(msg.data.buffer, msg.data.byteOffset, msg.data.byteLength);
  if (topic === TOPIC_COLOR) {
    const png = loadColor(frame.rgb.file, camera);
    if (msg.encoding !== 'rgb8' && msg.encoding !== 'bgr8') return problem(`${topic}: message ${k}: encoding ${msg.encoding}`);
    const swap = msg.encoding === 'bgr8';
    for (let i = 0; i < png.data.length; i += 3)
      if (bytes[i] !== png.data[swap ? i + 2 : i] || bytes[i + 1] !== png.data[i + 1] || bytes[i + 2] !== png.data[swap ? i : i + 2])
        return problem(`${topic}: message ${k}: pixel ${i / 3} differs from ${frame.rgb.file}`);
  } else if (topic === TOPIC_DEPTH) {
    const png = loadDepth(frame.depth.file, camera);
    for (let i = 0; i < png.width * png.height; ++i) {
      const raw = png.data.readUInt16BE(2 * i);
      let back, want16 = raw;
      if (msg.encoding === '32FC1') {
        const m = bytes.readFloatLE(4 * i);
        back = Number.isNaN(m) ? 0 : Math.round(m * camera.depth_scale);
      } else if (msg.encoding === '16UC1') {
        back = bytes.readUInt16LE(2 * i);
        want16 = Math.min(65535, Math.round(raw * 1000 / camera.depth_scale));
      } else {
        return problem(`${topic}: message ${k}: encoding ${msg.encoding}`);
      }
      if (back !== want16) return problem(`${topic}: message ${k}: pixel ${i} is ${back}, expected ${want16} (${frame.depth.file})`);
    }
  }
}

// ---------------------------------------------------------------------------------------------------

function parseArgs(argv) {
  const opts = { compression: 'zstd', depth: '32FC1', color: 'bgr8', schemaText: 'plain', chunkSize: 1024 * 1024,
                 frames: 0, nanInvalid: false };
  const positional = [];
  const value = (i, name) => {
    if (i + 1 >= argv.length) throw new UsageError(`${name} needs a value`);
    return argv[i + 1];
  };
  const choice = (v, name, allowed) => {
    if (!allowed.includes(v)) throw new UsageError(`${name} '${v}': expected ${allowed.join(', ')}`);
    return v;
  };
  for (let i = 0; i < argv.length; ++i) {
    const a = argv[i];
    if (a === '--compression') opts.compression = choice(value(i++, a), a, ['zstd', 'lz4', 'none']);
    else if (a === '--depth') opts.depth = choice(value(i++, a), a, ['32FC1', '16UC1']);
    else if (a === '--color') opts.color = choice(value(i++, a), a, ['rgb8', 'bgr8']);
    else if (a === '--schema-text') opts.schemaText = choice(value(i++, a), a, ['plain', 'rosbag2']);
    else if (a === '--nan-invalid') opts.nanInvalid = true;
    else if (a === '--frames' || a === '--chunk-size') {
      const v = value(i++, a);
      if (!/^[1-9]\d*$/.test(v)) throw new UsageError(`${a} '${v}': expected a positive integer`);
      opts[a === '--frames' ? 'frames' : 'chunkSize'] = Number(v);
    } else if (a === '--cut') {
      const v = value(i++, a), f = Number(v);
      if (!(f > 0 && f < 1)) throw new UsageError(`--cut '${v}': expected a fraction between 0 and 1`);
      opts.cut = f;
    } else if (a === '--verify') opts.verify = value(i++, a);
    else if (a === '--against') opts.against = value(i++, a);
    else if (a.startsWith('--')) throw new UsageError(`unknown option ${a}`);
    else positional.push(a);
  }
  if (opts.verify !== undefined) {
    if (positional.length) throw new UsageError('--verify takes one file and no other arguments');
    return opts;
  }
  if (opts.against !== undefined) throw new UsageError('--against goes with --verify');
  if (positional.length !== 2) throw new UsageError('expected TUM_DIR OUT.mcap');
  [opts.dir, opts.out] = positional;
  return opts;
}

async function main() {
  let opts;
  try {
    opts = parseArgs(process.argv.slice(2));
  } catch (e) {
    if (!(e instanceof UsageError)) throw e;
    console.error(`${PROGRAM}: ${e.message}\nusage: node mcap_reference_writer.js TUM_DIR OUT.mcap [--compression zstd|lz4|none] ` +
                  '[--frames N] [--cut F] [--depth 32FC1|16UC1] [--color rgb8|bgr8] [--chunk-size BYTES] ' +
                  '[--schema-text plain|rosbag2] [--nan-invalid]\n       node mcap_reference_writer.js --verify FILE.mcap [--against TUM_DIR]');
    return 2;
  }
  try {
    if (opts.verify !== undefined) return await verify(opts);
    await write(opts);
    return 0;
  } catch (e) {
    console.error(`${PROGRAM}: error: ${e instanceof Failure ? e.message : e.stack || e}`);
    return 1;
  }
}

main().then((code) => { process.exitCode = code; });
