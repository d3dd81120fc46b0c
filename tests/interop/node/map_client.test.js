// A third-party Node.js client of skimapd that knows only the .proto files:
// @grpc/grpc-js + @grpc/proto-loader (package-lock.json; scripts/deps.sh runs npm ci),
// loading proto/skimap/v1/map_service.proto at run time. Against a real skimapd process:
// create a map, stream the first frames of the real YCB-Video sample (files sent as they
// are: 16-bit PNG depth, PNG colour), fetch the occupancy grid and check it. ctest runs it
// (tests/interop/CMakeLists.txt) with:
//
//   SKIMAPD=PATH PROTO_DIR=proto SCENE=.../test/000000 node --test map_client.test.js
//
// TODO (when recognition lands): read the instances of the scene's objects.
'use strict';
const test = require('node:test');
const assert = require('node:assert');
const { spawn } = require('node:child_process');
const fs = require('node:fs');
const net = require('node:net');
const os = require('node:os');
const path = require('node:path');
const grpc = require('@grpc/grpc-js');
const protoLoader = require('@grpc/proto-loader');

const FRAMES = 5;
const { SKIMAPD, PROTO_DIR, SCENE } = process.env;
const MIN_FREE = Number(process.env.MIN_FREE || 0);
const MIN_OCCUPIED = Number(process.env.MIN_OCCUPIED || 0);

function freePort() {
  return new Promise((resolve, reject) => {
    const s = net.createServer();
    s.listen(0, '127.0.0.1', () => {
      const { port } = s.address();
      s.close(() => resolve(port));
    });
    s.on('error', reject);
  });
}

const mat3 = (v) => [v.slice(0, 3), v.slice(3, 6), v.slice(6, 9)];
const transpose = (m) => [0, 1, 2].map((i) => [0, 1, 2].map((j) => m[j][i]));
const mul = (m, v) => m.map((row) => row[0] * v[0] + row[1] * v[1] + row[2] * v[2]);

// (w, x, y, z) of a rotation matrix (Shepperd's method).
function quaternion(m) {
  const trace = m[0][0] + m[1][1] + m[2][2];
  if (trace > 0) {
    const s = 2 * Math.sqrt(trace + 1);
    return [s / 4, (m[2][1] - m[1][2]) / s, (m[0][2] - m[2][0]) / s, (m[1][0] - m[0][1]) / s];
  }
  let i = 0;
  if (m[1][1] > m[i][i]) i = 1;
  if (m[2][2] > m[i][i]) i = 2;
  const j = (i + 1) % 3, k = (i + 2) % 3;
  const s = 2 * Math.sqrt(1 + m[i][i] - m[j][j] - m[k][k]);
  const q = [(m[k][j] - m[j][k]) / s, 0, 0, 0];
  q[1 + i] = s / 4;
  q[1 + j] = (m[j][i] + m[i][j]) / s;
  q[1 + k] = (m[k][i] + m[i][k]) / s;
  return q;
}

function frames(map) {
  const cameras = JSON.parse(fs.readFileSync(path.join(SCENE, 'scene_camera.json')));
  const ids = Object.keys(cameras).map(Number).sort((a, b) => a - b).slice(0, FRAMES);
  return ids.map((id) => {
    const cam = cameras[String(id)];
    const rC2w = transpose(mat3(cam.cam_R_w2c));
    const t = mul(rC2w, cam.cam_t_w2c).map((x) => -x / 1000);
    const [w, x, y, z] = quaternion(rC2w);
    const k = cam.cam_K;
    const name = String(id).padStart(6, '0') + '.png';
    return {
      map, sequence: id,
      pose: { rotation: { w, x, y, z }, translation: { x: t[0], y: t[1], z: t[2] } },
      intrinsics: { fx: k[0], fy: k[4], cx: k[2], cy: k[5], width: 640, height: 480 },
      depth_encoding: 'DEPTH_ENCODING_PNG16',
      depth: fs.readFileSync(path.join(SCENE, 'depth', name)),
      depth_scale: cam.depth_scale / 1000,  // BOP: depth units of 0.1 mm
      color_encoding: 'COLOR_ENCODING_PNG',
      color: fs.readFileSync(path.join(SCENE, 'rgb', name)),
    };
  });
}

// World positions of the scene's objects (scene_gt.json of the first frame).
function objectCentres() {
  const cam = JSON.parse(fs.readFileSync(path.join(SCENE, 'scene_camera.json')))['0'];
  const gt = JSON.parse(fs.readFileSync(path.join(SCENE, 'scene_gt.json')))['0'];
  const rC2w = transpose(mat3(cam.cam_R_w2c));
  return gt.map((o) => mul(rC2w, o.cam_t_m2c.map((v, i) => v - cam.cam_t_w2c[i]))
    .map((v) => v / 1000));
}

let server, client, dataDir;

test.before(async () => {
  const port = await freePort();
  dataDir = fs.mkdtempSync(path.join(os.tmpdir(), 'skimap_node_client_'));
  server = spawn(SKIMAPD, [`--address=127.0.0.1:${port}`, `--data_dir=${dataDir}/data`,
    `--http_address=`],
    { stdio: 'ignore' });
  const definition = protoLoader.loadSync('skimap/v1/map_service.proto', {
    includeDirs: [PROTO_DIR], keepCase: true, longs: Number, enums: String, defaults: true,
  });
  const { MapService } = grpc.loadPackageDefinition(definition).skimap.v1;
  client = new MapService(`127.0.0.1:${port}`, grpc.credentials.createInsecure(),
    { 'grpc.max_receive_message_length': 64 << 20 });
  await new Promise((resolve, reject) =>
    client.waitForReady(Date.now() + 30000, (e) => (e ? reject(e) : resolve())));
});

test.after(async () => {
  client.close();
  const exited = new Promise((resolve) => server.on('exit', resolve));
  server.kill('SIGTERM');
  await exited;
  fs.rmSync(dataDir, { recursive: true, force: true });
});

const call = (method, request) => new Promise((resolve, reject) =>
  client[method](request, { deadline: Date.now() + 60000 }, (e, r) => (e ? reject(e) : resolve(r))));

test('creates a map, streams frames and reads the occupancy grid', async () => {
  const created = await call('CreateMap', { map_id: 'nodeclient', options: { resolution: 0.01 } });
  assert.strictEqual(created.name, 'maps/nodeclient');

  const acks = await new Promise((resolve, reject) => {
    const got = [];
    const stream = client.StreamFrames({ deadline: Date.now() + 120000 });
    stream.on('data', (ack) => got.push(ack));
    stream.on('error', reject);
    stream.on('end', () => resolve(got));
    for (const f of frames('maps/nodeclient')) stream.write(f);
    stream.end();
  });
  assert.deepStrictEqual(acks.map((a) => a.sequence).sort((a, b) => a - b),
    [...Array(FRAMES).keys()]);
  for (const a of acks) assert.strictEqual(a.code, 0, a.message);

  const info = await call('GetMap', { name: 'maps/nodeclient' });
  assert.strictEqual(info.stats.frames, FRAMES);
  assert.ok(info.stats.voxels > 3200, `${info.stats.voxels} voxels`);  // measured 4814: two thirds

  const grid = await call('GetOccupancyGrid', { map: 'maps/nodeclient' });
  assert.strictEqual(grid.frames, FRAMES);
  assert.strictEqual(grid.data.length, grid.width * grid.height);
  const cells = Int8Array.from(grid.data, (b) => (b < 128 ? b : b - 256));
  let free = 0;
  const occupied = [];
  cells.forEach((c, i) => {
    assert.ok(c === -1 || c === 0 || c === 100, `cell ${i} is ${c}`);
    if (c === 0) free++;
    if (c === 100) occupied.push(i);
  });
  assert.ok(free > MIN_FREE, `${free} free cells`);
  assert.ok(occupied.length > MIN_OCCUPIED, `${occupied.length} occupied cells`);
  const centres = objectCentres();
  const near = occupied.filter((i) => {
    const x = grid.origin_x + ((i % grid.width) + 0.5) * grid.resolution;
    const y = grid.origin_y + (Math.floor(i / grid.width) + 0.5) * grid.resolution;
    return Math.min(...centres.map((c) => Math.hypot(x - c[0], y - c[1]))) < 0.12;
  }).length;
  console.log(`grid ${grid.width}x${grid.height}: ${free} free, ${occupied.length} occupied ` +
    `(${near} within 12 cm of an object)`);
  assert.ok(near / occupied.length >= Number(process.env.MIN_NEAR_FRACTION || 0));
});

test('errors come back as gRPC status codes', async () => {
  await assert.rejects(call('GetMap', { name: 'maps/absent' }),
    (e) => e.code === grpc.status.NOT_FOUND);
  await assert.rejects(call('CreateMap', { map_id: 'Bad Id' }),
    (e) => e.code === grpc.status.INVALID_ARGUMENT && /map_id/.test(e.details));
});
