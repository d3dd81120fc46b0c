// What the browser tests (viewer_test.mjs, viewer_recognition_test.mjs) and the viewer
// benchmark (bench/viewer_bench.mjs) share: command-line flags, a real skimapd child
// process, REST calls, a BOP scene's frames as v1.Frame JSON, and Debian's headless
// chromium through playwright-core.
import { spawn } from 'node:child_process';
import { readFileSync, rmSync } from 'node:fs';
import { join } from 'node:path';
import { chromium } from 'playwright-core';

// --name=value flags as an object; throws naming the first missing required one.
export function parseArgs(argv, required = []) {
  const args = Object.fromEntries(argv.map((a) => a.replace(/^--/, '').split(/=(.*)/s).slice(0, 2)));
  for (const name of required) {
    if (!args[name]) throw new Error(`--${name}= is required`);
  }
  return args;
}

// check(condition, what) prints ok / FAIL and counts failures; failures() says how many.
let failed = 0;
export function check(condition, what) {
  console.log(`${condition ? 'ok  ' : 'FAIL'} ${what}`);
  if (!condition) failed++;
}
export const failures = () => failed;

function quaternion(m) {  // row-major 3x3 -> {w, x, y, z}
  const [a, b, c, d, e, f, g, h, i] = m;
  const trace = a + e + i;
  let w, x, y, z;
  if (trace > 0) {
    const s = 0.5 / Math.sqrt(trace + 1);
    w = 0.25 / s; x = (h - f) * s; y = (c - g) * s; z = (d - b) * s;
  } else if (a > e && a > i) {
    const s = 2 * Math.sqrt(1 + a - e - i);
    w = (h - f) / s; x = 0.25 * s; y = (b + d) / s; z = (c + g) / s;
  } else if (e > i) {
    const s = 2 * Math.sqrt(1 + e - a - i);
    w = (c - g) / s; x = (b + d) / s; y = 0.25 * s; z = (f + h) / s;
  } else {
    const s = 2 * Math.sqrt(1 + i - a - e);
    w = (d - b) / s; x = (c + g) / s; y = (f + h) / s; z = 0.25 * s;
  }
  const n = Math.hypot(w, x, y, z);
  return { w: w / n, x: x / n, y: y / n, z: z / n };
}

// The frames of a BOP scene folder (scene_camera.json, rgb/, depth/; 640 x 480) as
// v1.Frame JSON for map `map` ("maps/ycbv"), in frame order, sequence = the frame id.
export function sceneFrames(scene, map) {
  const cameras = JSON.parse(readFileSync(join(scene, 'scene_camera.json'), 'utf8'));
  return Object.keys(cameras).map(Number).sort((p, q) => p - q).map((id) => {
    const cam = cameras[id];
    const R = cam.cam_R_w2c;
    const t = cam.cam_t_w2c.map((v) => v / 1000);  // mm -> m
    const Rt = [R[0], R[3], R[6], R[1], R[4], R[7], R[2], R[5], R[8]];  // world <- camera
    const T = [0, 1, 2].map((r) => -(Rt[3 * r] * t[0] + Rt[3 * r + 1] * t[1] + Rt[3 * r + 2] * t[2]));
    const name = String(id).padStart(6, '0');
    const K = cam.cam_K;
    return {
      map,
      sequence: String(id),
      pose: { rotation: quaternion(Rt), translation: { x: T[0], y: T[1], z: T[2] } },
      intrinsics: { fx: K[0], fy: K[4], cx: K[2], cy: K[5], width: 640, height: 480 },
      depthEncoding: 'DEPTH_ENCODING_PNG16',
      depth: readFileSync(join(scene, 'depth', `${name}.png`)).toString('base64'),
      depthScale: cam.depth_scale / 1000,
      colorEncoding: 'COLOR_ENCODING_PNG',
      color: readFileSync(join(scene, 'rgb', `${name}.png`)).toString('base64'),
    };
  });
}

// Starts `skimapd` on free loopback ports (gRPC and REST) with `flags`; resolves to
// { server, base: "http://127.0.0.1:PORT", grpc: "127.0.0.1:PORT" } once both listen.
export function startSkimapd(skimapd, flags) {
  const server = spawn(skimapd, ['--address=127.0.0.1:0', '--http_address=127.0.0.1:0', ...flags],
    { stdio: ['ignore', 'pipe', 'inherit'] });
  return new Promise((resolve, reject) => {
    let out = '';
    const timer = setTimeout(() => reject(new Error(`skimapd did not start: ${out}`)), 60000);
    server.stdout.on('data', (chunk) => {
      out += chunk;
      const http = out.match(/REST on http port (\d+)/);
      const grpc = out.match(/listening on port (\d+)/);
      if (http && grpc) {
        clearTimeout(timer);
        resolve({ server, base: `http://127.0.0.1:${http[1]}`, grpc: `127.0.0.1:${grpc[1]}` });
      }
    });
    server.on('exit', (code) => reject(new Error(`skimapd exited with ${code}: ${out}`)));
  });
}

// Stops a skimapd of startSkimapd (SIGTERM) and waits for it to exit.
export async function stopSkimapd(server) {
  if (server.exitCode !== null) return;
  server.kill('SIGTERM');
  await new Promise((resolve) => server.once('exit', resolve));
}

// One REST call (with a bearer token if given); the parsed JSON reply, or throws with the
// status and error body.
export async function call(base, method, path, body, token) {
  const headers = { 'Content-Type': 'application/json' };
  if (token) headers.Authorization = `Bearer ${token}`;
  const response = await fetch(base + path, { method, headers, body: body && JSON.stringify(body) });
  const json = await response.json();
  if (!response.ok) throw new Error(`${method} ${path}: ${response.status} ${JSON.stringify(json)}`);
  return json;
}

// Ends a run: closes `browser` (if it started), stops `server` and removes `dataDir`.
export async function tearDown(browser, server, dataDir) {
  if (browser) await browser.close();
  await stopSkimapd(server);
  rmSync(dataDir, { recursive: true, force: true });
}

// Debian's chromium, headless, WebGL through SwiftShader (software GL).
export function launchChromium(executablePath = process.env.CHROMIUM || '/usr/bin/chromium') {
  return chromium.launch({
    executablePath, headless: true,
    args: ['--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist'],
  });
}
