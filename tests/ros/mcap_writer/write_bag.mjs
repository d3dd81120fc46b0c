#!/usr/bin/env node
// write_bag.mjs: converts a BOP scene folder into a ROS 2 bag (MCAP, CDR messages), written
// by libraries independent of SkiMap's reader (@mcap/core, @foxglove/rosmsg2-serialization),
// for the tests of ros/bag (mcap_reader.h, cdr_messages.h) and the end-to-end tests of
// `skimap stream BAG`.
//
// Usage: node write_bag.mjs SCENE_DIR OUT.mcap [flags]
//   SCENE_DIR: scene_camera.json (cam_K, depth_scale, cam_R_w2c, cam_t_w2c in mm),
//              rgb/NNNNNN.png|jpg, depth/NNNNNN.png (16-bit, raw * depth_scale = mm)
//   --compression none|zstd|lz4   chunk compression (default zstd; lz4 = LZ4 frame format)
//   --unchunked                   no chunks, no indexes: records straight in the data section
//   --chunk-size BYTES            target uncompressed chunk size (default 4194304)
//   --every N                     every N-th frame of scene_camera.json (default 1)
//   --limit N                     at most N frames (after --every; default all)
//   --depth-format 16UC1|32FC1    16UC1: uint16 mm, round(raw * depth_scale), so sub-mm
//                                 depth is rounded unless depth_scale is 1 (default);
//                                 32FC1: float32 metres, raw * depth_scale / 1000
//   --color raw|compressed        raw: rgb8 sensor_msgs/msg/Image on /camera/color/image_raw
//                                 (default); compressed: sensor_msgs/msg/CompressedImage on
//                                 /camera/color/image_raw/compressed carrying the rgb file's
//                                 bytes as stored (format "png" or "jpeg")
//   --jsonl FILE                  also every message as a JSON line {topic, type, ns, cdr}
//                                 (base64 CDR), for tests/ros/write_db3.py
//   --crop WxH                    keep only the top-left W x H pixels of the depth and raw
//                                 colour images (K is unchanged, so the geometry stays
//                                 right): small test bags. Compressed colour stays whole.
//
// Topics, in this order for each frame (the first /tf_static before them all):
//   /tf_static                 tf2_msgs/msg/TFMessage, once: camera_link ->
//                              camera_color_optical_frame, zero translation, the standard
//                              optical rotation (x right, y down, z forward) q = (-0.5, 0.5,
//                              -0.5, 0.5) (x, y, z, w)
//   /tf                        tf2_msgs/msg/TFMessage: world -> camera_link such that
//                              world -> camera_color_optical_frame is the BOP pose
//                              (cam_R_w2c, cam_t_w2c)^-1, t in metres
//   /camera/color/camera_info  sensor_msgs/msg/CameraInfo: k = cam_K, plumb_bob, d = 0
//   /camera/depth/image_raw    sensor_msgs/msg/Image 16UC1 or 32FC1
//   /camera/color/image_raw    sensor_msgs/msg/Image rgb8 (or .../compressed, see --color)
// Every message of a frame has header.stamp = 1000 s + id / 30 s (id: the BOP image id) and
// log_time = publish_time = that stamp; images and camera_info have header.frame_id =
// camera_color_optical_frame. Geometry: the world <- optical rotation is the quaternion of
// cam_R_w2c^T (Eigen's Quaterniond(Matrix3d) method), translation -cam_R_w2c^T * t / 1000;
// world -> camera_link is that pose times the inverse optical rotation, so composing the two
// tf messages gives back the BOP pose up to double rounding (~1e-16).
import fs from "node:fs";
import path from "node:path";
import { McapWriter } from "@mcap/core";
import { parse } from "@foxglove/rosmsg";
import { MessageWriter } from "@foxglove/rosmsg2-serialization";
import * as zstd from "@foxglove/wasm-zstd";
import lz4 from "lz4js";
import pngjs from "pngjs";

const HEADER = `builtin_interfaces/Time stamp
string frame_id`;
const TIME = `int32 sec
uint32 nanosec`;
const SEP = "=".repeat(80);
function Definition(main, deps) {
  return [main, ...deps.map(([name, text]) => `${SEP}\nMSG: ${name}\n${text}`)].join("\n");
}
const HEADER_DEPS = [["std_msgs/Header", HEADER], ["builtin_interfaces/Time", TIME]];
const SCHEMAS = {
  "sensor_msgs/msg/Image": Definition(`std_msgs/Header header
uint32 height
uint32 width
string encoding
uint8 is_bigendian
uint32 step
uint8[] data`, HEADER_DEPS),
  "sensor_msgs/msg/CompressedImage": Definition(`std_msgs/Header header
string format
uint8[] data`, HEADER_DEPS),
  "sensor_msgs/msg/CameraInfo": Definition(`std_msgs/Header header
uint32 height
uint32 width
string distortion_model
float64[] d
float64[9] k
float64[9] r
float64[12] p
uint32 binning_x
uint32 binning_y
sensor_msgs/RegionOfInterest roi`, [...HEADER_DEPS, ["sensor_msgs/RegionOfInterest", `uint32 x_offset
uint32 y_offset
uint32 height
uint32 width
bool do_rectify`]]),
  "tf2_msgs/msg/TFMessage": Definition("geometry_msgs/TransformStamped[] transforms", [
    ["geometry_msgs/TransformStamped", `std_msgs/Header header
string child_frame_id
geometry_msgs/Transform transform`],
    ...HEADER_DEPS,
    ["geometry_msgs/Transform", `geometry_msgs/Vector3 translation
geometry_msgs/Quaternion rotation`],
    ["geometry_msgs/Vector3", "float64 x\nfloat64 y\nfloat64 z"],
    ["geometry_msgs/Quaternion", "float64 x\nfloat64 y\nfloat64 z\nfloat64 w"],
  ]),
};
const OPTICAL = "camera_color_optical_frame";

function Fail(message) {
  process.stderr.write(`write_bag: ${message}\n`);
  process.exit(2);
}

function ParseFlags(argv) {
  const o = {
    compression: "zstd", chunked: true, chunkSize: 4 << 20, every: 1, limit: Infinity,
    depthFormat: "16UC1", color: "raw", crop: null, jsonl: null, positional: [],
  };
  for (let i = 0; i < argv.length; ++i) {
    const a = argv[i];
    const value = () => {
      if (i + 1 >= argv.length) Fail(`${a} needs a value`);
      return argv[++i];
    };
    const count = () => {
      const v = Number(value());
      if (!Number.isInteger(v) || v < 1) Fail(`${a}: want a positive integer`);
      return v;
    };
    if (a === "--compression") o.compression = value();
    else if (a === "--unchunked") o.chunked = false;
    else if (a === "--chunk-size") o.chunkSize = count();
    else if (a === "--every") o.every = count();
    else if (a === "--limit") o.limit = count();
    else if (a === "--depth-format") o.depthFormat = value();
    else if (a === "--color") o.color = value();
    else if (a === "--jsonl") o.jsonl = value();
    else if (a === "--crop") {
      const m = /^(\d+)x(\d+)$/.exec(value());
      if (!m || +m[1] < 1 || +m[2] < 1) Fail("--crop: want WxH, e.g. 8x6");
      o.crop = { width: +m[1], height: +m[2] };
    } else if (a.startsWith("--")) Fail(`unknown flag ${a}`);
    else o.positional.push(a);
  }
  if (o.positional.length !== 2) Fail("usage: write_bag.mjs SCENE_DIR OUT.mcap [flags]");
  if (!["none", "zstd", "lz4"].includes(o.compression)) Fail("--compression: none|zstd|lz4");
  if (!["16UC1", "32FC1"].includes(o.depthFormat)) Fail("--depth-format: 16UC1|32FC1");
  if (!["raw", "compressed"].includes(o.color)) Fail("--color: raw|compressed");
  return o;
}

// Eigen's Quaterniond(const Matrix3d&) (Shepperd's method), m row-major; returns [x,y,z,w].
function QuaternionOf(m) {
  const at = (r, c) => m[3 * r + c];
  const trace = at(0, 0) + at(1, 1) + at(2, 2);
  if (trace > 0) {
    let t = Math.sqrt(trace + 1.0);
    const w = 0.5 * t;
    t = 0.5 / t;
    return [(at(2, 1) - at(1, 2)) * t, (at(0, 2) - at(2, 0)) * t, (at(1, 0) - at(0, 1)) * t, w];
  }
  let i = 0;
  if (at(1, 1) > at(0, 0)) i = 1;
  if (at(2, 2) > at(i, i)) i = 2;
  const j = (i + 1) % 3, k = (j + 1) % 3;
  let t = Math.sqrt(at(i, i) - at(j, j) - at(k, k) + 1.0);
  const q = [0, 0, 0, 0];
  q[i] = 0.5 * t;
  t = 0.5 / t;
  q[3] = (at(k, j) - at(j, k)) * t;
  q[j] = (at(j, i) + at(i, j)) * t;
  q[k] = (at(k, i) + at(i, k)) * t;
  return q;
}

// Hamilton product a * b of [x,y,z,w] quaternions.
function Multiply(a, b) {
  const [ax, ay, az, aw] = a, [bx, by, bz, bw] = b;
  return [
    aw * bx + ax * bw + ay * bz - az * by,
    aw * by - ax * bz + ay * bw + az * bx,
    aw * bz + ax * by - ay * bx + az * bw,
    aw * bw - ax * bx - ay * by - az * bz,
  ];
}

const Q_LINK_OPTICAL = [-0.5, 0.5, -0.5, 0.5];

// The BOP pose (x_cam = R x_world + t, t in mm) as world -> camera_link.
function WorldToLink(r, tMm) {
  const rt = [r[0], r[3], r[6], r[1], r[4], r[7], r[2], r[5], r[8]];  // R^T, row-major
  const t = tMm.map((v) => v * 1e-3);
  const translation = [0, 1, 2].map(
    (row) => -(rt[3 * row] * t[0] + rt[3 * row + 1] * t[1] + rt[3 * row + 2] * t[2]));
  const [x, y, z, w] = Q_LINK_OPTICAL;
  const rotation = Multiply(QuaternionOf(rt), [-x, -y, -z, w]);
  return { translation, rotation };
}

function Stamp(id) {
  const sec = 1000 + Math.floor(id / 30);
  const nanosec = Math.round(((id % 30) / 30) * 1e9);
  return { sec, nanosec, ns: BigInt(sec) * 1000000000n + BigInt(nanosec) };
}

function Transform(stamp, parent, child, translation, rotation) {
  return {
    header: { stamp: { sec: stamp.sec, nanosec: stamp.nanosec }, frame_id: parent },
    child_frame_id: child,
    transform: {
      translation: { x: translation[0], y: translation[1], z: translation[2] },
      rotation: { x: rotation[0], y: rotation[1], z: rotation[2], w: rotation[3] },
    },
  };
}

// PNG pixels as { width, height, channels, data } after --crop; 16-bit kept as is.
function ReadPng(file, crop, want16) {
  const png = pngjs.PNG.sync.read(fs.readFileSync(file), { skipRescale: true });
  const is16 = png.depth === 16;
  if (want16 !== is16) Fail(`${file}: want a ${want16 ? 16 : 8}-bit PNG, got ${png.depth}-bit`);
  const width = crop ? Math.min(crop.width, png.width) : png.width;
  const height = crop ? Math.min(crop.height, png.height) : png.height;
  return { width, height, src: png.data, srcWidth: png.width };
}

function DepthImage(file, depthScale, o) {
  const png = ReadPng(file, o.crop, true);
  const n = png.width * png.height;
  const bytesPer = o.depthFormat === "16UC1" ? 2 : 4;
  const data = new Uint8Array(n * bytesPer);
  const view = new DataView(data.buffer);
  for (let y = 0; y < png.height; ++y) {
    for (let x = 0; x < png.width; ++x) {
      const raw = png.src[4 * (y * png.srcWidth + x)];  // pngjs expands grey to RGBA
      const i = y * png.width + x;
      if (bytesPer === 2) view.setUint16(2 * i, Math.min(65535, Math.round(raw * depthScale)), true);
      else view.setFloat32(4 * i, (raw * depthScale) / 1000, true);
    }
  }
  return {
    height: png.height, width: png.width, encoding: o.depthFormat, is_bigendian: 0,
    step: png.width * bytesPer, data,
  };
}

function ColorImage(file, o) {
  const png = ReadPng(file, o.crop, false);
  const data = new Uint8Array(png.width * png.height * 3);
  for (let y = 0; y < png.height; ++y) {
    for (let x = 0; x < png.width; ++x) {
      const s = 4 * (y * png.srcWidth + x), d = 3 * (y * png.width + x);
      data[d] = png.src[s];
      data[d + 1] = png.src[s + 1];
      data[d + 2] = png.src[s + 2];
    }
  }
  return {
    height: png.height, width: png.width, encoding: "rgb8", is_bigendian: 0,
    step: png.width * 3, data,
  };
}

function CameraInfo(k, width, height) {
  return {
    height, width, distortion_model: "plumb_bob", d: [0, 0, 0, 0, 0], k,
    r: [1, 0, 0, 0, 1, 0, 0, 0, 1],
    p: [k[0], k[1], k[2], 0, k[3], k[4], k[5], 0, k[6], k[7], k[8], 0],
    binning_x: 0, binning_y: 0,
    roi: { x_offset: 0, y_offset: 0, height: 0, width: 0, do_rectify: false },
  };
}

function Compressor(name) {
  if (name === "zstd") {
    return (data) => ({ compression: "zstd", compressedData: zstd.compress(data, 3) });
  }
  if (name === "lz4") return (data) => ({ compression: "lz4", compressedData: lz4.compress(data) });
  return undefined;  // @mcap/core writes "" (no compression)
}

class FileWritable {
  constructor(file) {
    this.fd = fs.openSync(file, "w");
    this.pos = 0n;
  }
  async write(buffer) {
    fs.writeSync(this.fd, buffer);
    this.pos += BigInt(buffer.byteLength);
  }
  position() {
    return this.pos;
  }
  close() {
    fs.closeSync(this.fd);
  }
}

async function Main() {
  const o = ParseFlags(process.argv.slice(2));
  const [sceneDir, out] = o.positional;
  await zstd.isLoaded;
  const cameraFile = path.join(sceneDir, "scene_camera.json");
  if (!fs.existsSync(cameraFile)) Fail(`${cameraFile}: not found`);
  const cams = JSON.parse(fs.readFileSync(cameraFile, "utf8"));
  let ids = Object.keys(cams).map(Number).sort((a, b) => a - b);
  ids = ids.filter((_, i) => i % o.every === 0).slice(0, o.limit);
  if (ids.length === 0) Fail(`${cameraFile}: no frames`);

  const writable = new FileWritable(out);
  const writer = new McapWriter({
    writable, useChunks: o.chunked, chunkSize: o.chunkSize,
    useChunkIndex: o.chunked, useMessageIndex: o.chunked,
    compressChunk: o.chunked ? Compressor(o.compression) : undefined,
  });
  await writer.start({ profile: "ros2", library: "skimap tests/ros/mcap_writer" });
  const serializers = {};
  const channels = {};
  async function Channel(topic, type) {
    if (!serializers[type]) {
      const id = await writer.registerSchema({
        name: type, encoding: "ros2msg", data: new TextEncoder().encode(SCHEMAS[type]),
      });
      serializers[type] = { id, writer: new MessageWriter(parse(SCHEMAS[type], { ros2: true })) };
    }
    channels[topic] = {
      type,
      id: await writer.registerChannel({
        topic, messageEncoding: "cdr", schemaId: serializers[type].id, metadata: new Map(),
      }),
    };
  }
  const colorTopic =
    o.color === "raw" ? "/camera/color/image_raw" : "/camera/color/image_raw/compressed";
  await Channel("/tf_static", "tf2_msgs/msg/TFMessage");
  await Channel("/tf", "tf2_msgs/msg/TFMessage");
  await Channel("/camera/color/camera_info", "sensor_msgs/msg/CameraInfo");
  await Channel("/camera/depth/image_raw", "sensor_msgs/msg/Image");
  await Channel(colorTopic, o.color === "raw" ? "sensor_msgs/msg/Image" : "sensor_msgs/msg/CompressedImage");
  const sequence = {};
  // --jsonl FILE: every message also as one JSON line {topic, type, ns, cdr (base64)}, for
  // tests/ros/write_db3.py to store in rosbag2's sqlite3 layout.
  const jsonl = o.jsonl ? fs.openSync(o.jsonl, "w") : null;
  async function Publish(topic, stamp, message) {
    const c = channels[topic];
    sequence[topic] = (sequence[topic] ?? 0) + 1;
    const data = serializers[c.type].writer.writeMessage(message);
    await writer.addMessage({
      channelId: c.id, sequence: sequence[topic], logTime: stamp.ns, publishTime: stamp.ns, data,
    });
    if (jsonl !== null) {
      fs.writeSync(jsonl, JSON.stringify({
        topic, type: c.type, ns: stamp.ns.toString(), cdr: Buffer.from(data).toString("base64"),
      }) + "\n");
    }
  }

  const first = Stamp(ids[0]);
  await Publish("/tf_static", first, {
    transforms: [Transform(first, "camera_link", OPTICAL, [0, 0, 0], Q_LINK_OPTICAL)],
  });
  for (const id of ids) {
    const cam = cams[String(id)];
    const stamp = Stamp(id);
    const header = { stamp: { sec: stamp.sec, nanosec: stamp.nanosec }, frame_id: OPTICAL };
    const name = String(id).padStart(6, "0");
    if (!cam.cam_R_w2c || !cam.cam_t_w2c) Fail(`${cameraFile}: frame ${id} has no pose`);
    const pose = WorldToLink(cam.cam_R_w2c, cam.cam_t_w2c);
    await Publish("/tf", stamp, {
      transforms: [Transform(stamp, "world", "camera_link", pose.translation, pose.rotation)],
    });
    const depth = DepthImage(path.join(sceneDir, "depth", `${name}.png`), cam.depth_scale ?? 1, o);
    await Publish("/camera/color/camera_info", stamp,
      { header, ...CameraInfo(cam.cam_K, depth.width, depth.height) });
    await Publish("/camera/depth/image_raw", stamp, { header, ...depth });
    const png = path.join(sceneDir, "rgb", `${name}.png`);
    if (o.color === "raw") {
      await Publish(colorTopic, stamp, { header, ...ColorImage(png, o) });
    } else {
      const file = fs.existsSync(png) ? png : path.join(sceneDir, "rgb", `${name}.jpg`);
      await Publish(colorTopic, stamp, {
        header, format: file.endsWith(".png") ? "png" : "jpeg", data: fs.readFileSync(file),
      });
    }
  }
  await writer.end();
  writable.close();
  if (jsonl !== null) fs.closeSync(jsonl);
}

Main().catch((e) => Fail(e.stack ?? String(e)));
