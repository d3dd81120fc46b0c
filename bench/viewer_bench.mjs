// viewer_bench: the browser viewer's time to first render and frame rate on maps of about
// 1 M and 10 M voxels (issue 12; docs/benchmarks.md, "Viewer"). A plain program, not a
// test; a markdown table on stdout, progress on stderr:
//
//   node bench/viewer_bench.mjs --skimapd=build/release/server/skimapd --web_root=web/dist \
//     [--sizes=1000000,10000000] [--seconds=5] [--budget=200000] [--timeout_s=1800] [--out=DIR]
//
// (bench/viewer_bench.sh builds skimapd and the viewer, then runs this.)
//
// One real skimapd (loopback, a temporary data dir). Each map is made by posting synthetic frames over
// REST (POST /v1/maps/{map}/frames, RAW_U16 depth + RAW_RGB8 colour, 640 x 480): a camera
// 6 m above a rolling, coloured terrain looking straight down, one frame per tile of a
// grid of non-overlapping footprints, at 1 cm voxels (a pixel covers 1.1 cm there, so
// nearly every pixel makes its own voxel), until the map holds the size asked for.
//
// Then, per map, a fresh page of Debian's headless chromium (playwright-core) opens
// /#map=<id>&tab=view3d, 1280 x 800:
//   first render   from navigation start to the first frame drawn with voxels
//                  (performance.now() of that frame: the first page of
//                  GET /v1/maps/{map}/voxels?level=L, protobuf binary, drawn as it came)
//   all pages      from navigation start until every page of the level was fetched
//   full frame     one frame of every voxel of the level, drawn and finished
//   frame rate     the camera orbiting the map as while a user drags it (the view's
//                  moving path: the coarse proxy when a full frame is slower than the view's
//                  INTERACTIVE_MS), a frame rendered per requestAnimationFrame and finished
//                  (a 1-pixel readPixels), for --seconds
// Headless chromium renders WebGL with SwiftShader (software GL on the CPU), not a GPU:
// the frame rates are a floor, far below a desktop browser's.
import { mkdirSync, mkdtempSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { call, launchChromium, parseArgs, startSkimapd, tearDown } from '../web/test/harness.mjs';

const args = parseArgs(process.argv.slice(2), ['skimapd', 'web_root']);
const sizes = (args.sizes || '1000000,10000000').split(',').map(Number);
const seconds = Number(args.seconds || 5);
const log = (...a) => console.error(...a);

// --- synthetic frames --------------------------------------------------------------

const W = 640, H = 480, F = 525, CX = 319.5, CY = 239.5, HEIGHT = 6;
const terrain = (x, y) => 0.35 * Math.sin(0.9 * x) * Math.cos(0.7 * y) + 0.15 * Math.sin(2.3 * x + 1.7 * y);
const FOOT_X = (W / F) * (HEIGHT - 0.6);  // footprint of a frame at the terrain's top, m
const FOOT_Y = (H / F) * (HEIGHT - 0.6);

// Frame `k` (tiles in rows of 12) as v1.Frame JSON for map `map`.
function frame(map, k) {
  const cx = (k % 12) * FOOT_X, cy = Math.floor(k / 12) * FOOT_Y;
  const depth = Buffer.alloc(W * H * 2);
  const color = Buffer.alloc(W * H * 3);
  for (let v = 0; v < H; v++) {
    for (let u = 0; u < W; u++) {
      const xn = (u - CX) / F, yn = (v - CY) / F;
      // Camera looking down (x right = world +x, y down = world -y): the ray hits the
      // terrain where HEIGHT - t = terrain(cx + t xn, cy - t yn); a few fixed-point steps.
      let t = HEIGHT;
      for (let i = 0; i < 6; i++) t = HEIGHT - terrain(cx + t * xn, cy - t * yn);
      const i = v * W + u;
      depth.writeUInt16LE(Math.round(t * 1000), 2 * i);
      const x = cx + t * xn, y = cy - t * yn, z = HEIGHT - t;
      color[3 * i] = 128 + 100 * Math.sin(0.5 * x);
      color[3 * i + 1] = 140 + 90 * z;
      color[3 * i + 2] = 128 + 100 * Math.cos(0.4 * y);
    }
  }
  return {
    map: `maps/${map}`, sequence: String(k + 1),
    // 180 degrees about x: camera z (optical axis) = world -z.
    pose: { rotation: { w: 0, x: 1, y: 0, z: 0 }, translation: { x: cx, y: cy, z: HEIGHT } },
    intrinsics: { fx: F, fy: F, cx: CX, cy: CY, width: W, height: H },
    depthEncoding: 'DEPTH_ENCODING_RAW_U16', depth: depth.toString('base64'), depthScale: 0.001,
    colorEncoding: 'COLOR_ENCODING_RAW_RGB8', color: color.toString('base64'),
  };
}

async function makeMap(base, id, voxels) {
  await call(base, 'POST', '/v1/maps', { mapId: id, options: { resolution: 0.01, maxDepth: 8 } });
  const started = Date.now();
  let map;
  for (let k = 0; ; k++) {
    const ack = await call(base, 'POST', `/v1/maps/${id}/frames`, frame(id, k));
    if (ack.code) throw new Error(`frame ${k}: ${ack.message}`);
    map = await call(base, 'GET', `/v1/maps/${id}`);
    if (Number(map.stats.voxels) >= voxels) break;
  }
  log(`map ${id}: ${map.stats.voxels} voxels from ${map.stats.frames} frames in ${((Date.now() - started) / 1000).toFixed(1)} s`);
  return map;
}

// --- the viewer --------------------------------------------------------------------

async function measure(browser, base, map) {
  const id = map.name.replace(/^maps\//, '');
  const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
  const errors = [];
  page.on('pageerror', (e) => errors.push(String(e)));
  const budget = args.budget ? `?budget=${args.budget}` : '';
  await page.goto(`${base}/${budget}#map=${id}&tab=view3d`);
  await page.waitForFunction(() => window.skimapViewer?.view3d.firstVoxelRender !== undefined, null, { timeout: Number(args.timeout_s || 1800) * 1000 });
  await page.waitForFunction(() => document.body.dataset.voxelsShown !== undefined, null, { timeout: Number(args.timeout_s || 1800) * 1000 });
  const first = await page.evaluate(() => ({
    firstRender: window.skimapViewer.view3d.firstVoxelRender,
    lod: document.getElementById('lod').textContent,
    shown: Number(document.body.dataset.voxelsShown),
  }));
  const lodDetail = await page.evaluate(() => window.skimapViewer.view3d.lastLod);
  lodDetail.loaded = lodDetail.loadedAt;
  if (args.out) await page.screenshot({ path: join(args.out, `viewer-bench-${id}.png`) });
  const fps = await page.evaluate((ms) => new Promise((resolve) => {
    const v = window.skimapViewer.view3d;
    const gl = v.renderer.getContext();
    const target = v.controls.target.clone();
    const offset = v.camera.position.clone().sub(target);
    const pixel = new Uint8Array(4);
    let frames = 0;
    const start = performance.now();
    const step = () => {
      const now = performance.now();
      if (now - start >= ms) {
        resolve({ frames, fps: frames / ((now - start) / 1000) });
        return;
      }
      offset.applyAxisAngle({ x: 0, y: 0, z: 1, isVector3: true }, 0.02);
      v.camera.position.copy(target).add(offset);
      v.camera.lookAt(target);
      v.renderFrame(true);
      gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, pixel);  // the frame is finished
      frames++;
      requestAnimationFrame(step);
    };
    requestAnimationFrame(step);
  }), seconds * 1000);
  await page.close();
  if (errors.length) throw new Error(`page errors: ${errors.join('; ')}`);
  return { ...first, ...lodDetail, ...fps };
}

// --- main ----------------------------------------------------------------------------

if (args.out) mkdirSync(args.out, { recursive: true });
const dataDir = mkdtempSync(join(tmpdir(), 'skimap_viewer_bench_'));
const { server, base } = await startSkimapd(args.skimapd, [`--data_dir=${dataDir}`, `--web_root=${args.web_root}`, '--http_max_body_mb=64']);
let browser;
const rows = [];
try {
  browser = await launchChromium(args.chromium);
  const version = browser.version();
  for (const size of sizes) {
    const id = `v${Math.round(size / 1e6)}m`;
    const map = await makeMap(base, id, size);
    const m = await measure(browser, base, map);
    log(`${id}: first render ${m.firstRender.toFixed(0)} ms, ${m.fps.toFixed(1)} frames/s; ${m.lod}`);
    rows.push({ voxels: Number(map.stats.voxels), ...m });
  }
  console.log(`chromium ${version}, headless, WebGL by SwiftShader (software GL); viewport 1280 x 800; ` +
    `budget ${args.budget || 200000} boxes; ${seconds} s orbit per map\n`);
  console.log('| map voxels | level | boxes drawn | first render (ms) | all pages (ms) | full frame (ms) | boxes while moving | frames/s moving |');
  console.log('|---|---|---|---|---|---|---|---|');
  for (const r of rows) {
    const proxy = r.proxyShown ? `${r.proxyShown.toLocaleString('en-US')} (${(r.proxyResolution * 100).toFixed(0)} cm)` : 'all';
    console.log(`| ${r.voxels.toLocaleString('en-US')} | ${r.level} | ${r.shown.toLocaleString('en-US')} | ` +
      `${r.firstRender.toFixed(0)} | ${r.loaded.toFixed(0)} | ${r.frameMs.toFixed(0)} | ${proxy} | ${r.fps.toFixed(1)} |`);
  }
} finally {
  await tearDown(browser, server, dataDir);
}
