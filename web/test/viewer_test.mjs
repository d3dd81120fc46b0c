// Browser test of the viewer (ctest: Viewer.BrowserShowsMapGridAndLiveUpdates): starts a
// real skimapd serving web/dist with a fresh data dir, streams nine ycbv-0000 frames into
// map "ycbv" over REST (POST /v1/maps/ycbv/frames), opens the viewer in Debian's headless
// chromium (playwright-core) and checks that
//   - the map list shows the map with its voxel count (as GET /v1/maps/ycbv says),
//   - the 3D canvas drew non-background pixels, and the trajectory has a pose per frame,
//   - the grid tab drew the grid and shows metric coordinates under the mouse,
//   - posting the tenth frame updates the shown stats live, without a reload.
// and that a small voxel budget (?budget=1000) makes it ask for coarser levels.
// Screenshots go to --out (viewer-3d.png, viewer-grid.png, viewer-height.png,
// viewer-live.png, viewer-lod.png).
//
//   node web/test/viewer_test.mjs --skimapd=build/release/server/skimapd \
//     --web_root=web/dist --scene=../shared/data/ycbv-0000/test/000000 --out=build/viewer
import { mkdtempSync, mkdirSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { call, check, failures, launchChromium, parseArgs, sceneFrames, startSkimapd, tearDown } from './harness.mjs';

const args = parseArgs(process.argv.slice(2), ['skimapd', 'web_root', 'scene', 'out']);
mkdirSync(args.out, { recursive: true });

// --- the test ----------------------------------------------------------------------

const dataDir = mkdtempSync(join(tmpdir(), 'skimap_viewer_'));
const { server, base } = await startSkimapd(args.skimapd, [`--data_dir=${dataDir}`, `--web_root=${args.web_root}`]);
let browser;
try {
  await call(base, 'POST', '/v1/maps', { mapId: 'ycbv', options: { resolution: 0.01 } });
  const frames = sceneFrames(args.scene, 'maps/ycbv');
  check(frames.length >= 2, `the scene has ${frames.length} frames`);
  for (const frame of frames.slice(0, -1)) {
    const ack = await call(base, 'POST', '/v1/maps/ycbv/frames', frame);
    if (ack.code) throw new Error(`frame ${frame.sequence}: ${ack.message}`);
  }
  const before = await call(base, 'GET', '/v1/maps/ycbv');
  console.log(`map ycbv: ${before.stats.voxels} voxels, ${before.stats.frames} frames`);

  browser = await launchChromium(args.chromium);
  const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
  const errors = [];
  page.on('pageerror', (e) => errors.push(String(e)));
  page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
  await page.goto(`${base}/`);
  await page.waitForSelector('body[data-ready="1"]', { timeout: 30000 });

  // The map list.
  const row = page.locator('tr[data-map="ycbv"]');
  await row.waitFor({ timeout: 10000 });
  check(await row.getAttribute('data-voxels') === before.stats.voxels,
        `the list shows ${await row.getAttribute('data-voxels')} voxels (server: ${before.stats.voxels})`);
  const shownCount = Number(before.stats.voxels).toLocaleString('en-US');
  check((await row.locator('td').nth(1).textContent()) === shownCount, `the voxel cell reads ${shownCount}`);

  // The 3D tab.
  await page.waitForSelector('body[data-voxels-shown]', { timeout: 60000 });
  const shown = Number(await page.getAttribute('body', 'data-voxels-shown'));
  check(shown > 1000, `the 3D view holds ${shown} voxels (${await page.textContent('#lod')})`);
  await page.waitForSelector('body[data-trajectory]', { timeout: 30000 });
  check(Number(await page.getAttribute('body', 'data-trajectory')) === Number(before.stats.frames),
        `the trajectory has ${await page.getAttribute('body', 'data-trajectory')} poses`);
  await page.waitForTimeout(500);
  const pixels = await page.evaluate(() => window.skimapViewer.drawnPixels());
  check(pixels.drawn > 0.02 * pixels.total && pixels.drawn < 0.9 * pixels.total, `the 3D canvas drew ${pixels.drawn} of ${pixels.total} pixels`);
  await page.screenshot({ path: join(args.out, 'viewer-3d.png') });

  // The grid tab.
  await page.click('#tabs button[data-tab="grid"]');
  await page.waitForSelector('body[data-grid-known]', { timeout: 30000 });
  const known = Number(await page.getAttribute('body', 'data-grid-known'));
  check(known > 100, `the grid has ${known} known cells`);
  const painted = await page.evaluate(() => {
    const c = document.getElementById('grid-canvas');
    const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
    let n = 0;
    for (let i = 3; i < d.length; i += 4) if (d[i] > 0) n++;
    return { n, w: c.width, h: c.height };
  });
  check(painted.n === painted.w * painted.h && painted.w > 10, `the grid canvas is ${painted.w} x ${painted.h}, painted`);
  const box = await page.locator('#grid-canvas').boundingBox();
  await page.mouse.move(box.x + box.width / 2, box.y + box.height / 2);
  const coords = await page.textContent('#coords');
  check(/^x = -?\d+\.\d{3} m, y = -?\d+\.\d{3} m/.test(coords), `coordinates under the mouse: "${coords}"`);
  await page.screenshot({ path: join(args.out, 'viewer-grid.png') });

  // The height map tab.
  await page.click('#tabs button[data-tab="height"]');
  await page.waitForSelector('body[data-height-drawn]', { timeout: 30000 });
  await page.screenshot({ path: join(args.out, 'viewer-height.png') });

  // Live: the last frame, posted now, reaches the page without a reload.
  await page.click('#tabs button[data-tab="view3d"]');
  await page.evaluate(() => { window.notReloaded = true; });
  check(await page.textContent('#live') === 'live', 'the live indicator is on');
  const last = frames[frames.length - 1];
  await call(base, 'POST', '/v1/maps/ycbv/frames', last);
  const after = await call(base, 'GET', '/v1/maps/ycbv');
  await page.waitForSelector(`tr[data-map="ycbv"][data-frames="${after.stats.frames}"]`, { timeout: 15000 });
  check(await row.getAttribute('data-voxels') === after.stats.voxels,
        `after the live frame the list shows ${after.stats.voxels} voxels, ${after.stats.frames} frames`);
  check(await page.evaluate(() => window.notReloaded === true), 'the page was not reloaded');
  await page.waitForFunction((n) => Number(document.body.dataset.voxelsShown) > 0 &&
    document.getElementById('lod').textContent.includes(`of ${Number(n).toLocaleString('en-US')} voxels`),
    after.stats.voxels, { timeout: 30000 });
  check(true, `the 3D view reloaded: ${await page.textContent('#lod')}`);
  await page.waitForTimeout(300);
  await page.screenshot({ path: join(args.out, 'viewer-live.png') });

  // Level of detail: with a budget of 1000 voxels the viewer asks for coarser blocks.
  const coarse = await browser.newPage({ viewport: { width: 1280, height: 800 } });
  coarse.on('pageerror', (e) => errors.push(String(e)));
  await coarse.goto(`${base}/?budget=1000#map=ycbv&tab=view3d`);
  await coarse.waitForSelector('body[data-voxels-shown]', { timeout: 60000 });
  const lod = await coarse.textContent('#lod');
  const level = Number(lod.match(/level (\d+)/)[1]);
  const coarseShown = Number(await coarse.getAttribute('body', 'data-voxels-shown'));
  check(level >= 2 && coarseShown <= 2000 && coarseShown > 50, `with budget 1000: ${lod}`);
  await coarse.waitForTimeout(300);
  const coarsePixels = await coarse.evaluate(() => window.skimapViewer.drawnPixels());
  check(coarsePixels.drawn > 0.02 * coarsePixels.total, `the coarse view drew ${coarsePixels.drawn} pixels`);
  await coarse.screenshot({ path: join(args.out, 'viewer-lod.png') });

  // Moving the camera: with a frame-time target below any real frame, the viewer merges
  // the voxels into coarser blocks and draws those while the camera is dragged, the full
  // level again once the drag ends.
  const moving = await browser.newPage({ viewport: { width: 1280, height: 800 } });
  moving.on('pageerror', (e) => errors.push(String(e)));
  await moving.goto(`${base}/?interactiveMs=0.01#map=ycbv&tab=view3d`);
  await moving.waitForSelector('body[data-voxels-shown]', { timeout: 60000 });
  const full = Number(await moving.getAttribute('body', 'data-voxels-shown'));
  const proxy = Number(await moving.getAttribute('body', 'data-proxy-shown'));
  check(proxy > 0 && proxy < full, `while moving the view draws ${proxy} blocks for ${full} voxels (${await moving.textContent('#lod')})`);
  const canvas = await moving.locator('#canvas3d canvas').boundingBox();
  await moving.mouse.move(canvas.x + canvas.width / 2, canvas.y + canvas.height / 2);
  await moving.mouse.down();
  await moving.mouse.move(canvas.x + canvas.width / 2 + 120, canvas.y + canvas.height / 2 + 30, { steps: 5 });
  await moving.waitForFunction(() => window.skimapViewer.view3d.proxy.visible, null, { timeout: 10000 }).catch(() => {});
  const during = await moving.evaluate(() => ({ proxy: window.skimapViewer.view3d.proxy.visible, voxels: window.skimapViewer.view3d.voxels.visible }));
  check(during.proxy && !during.voxels, `during the drag the proxy shows (${JSON.stringify(during)})`);
  await moving.screenshot({ path: join(args.out, 'viewer-moving.png') });
  await moving.mouse.up();
  await moving.waitForFunction(() => window.skimapViewer.view3d.voxels.visible, null, { timeout: 30000 });
  check(!(await moving.evaluate(() => window.skimapViewer.view3d.proxy.visible)), 'after the drag the full level shows again');
  check(errors.length === 0, `no page errors${errors.length ? `: ${errors.join('; ')}` : ''}`);
} finally {
  await tearDown(browser, server, dataDir);
}
console.log(failures() ? `${failures()} check(s) failed` : 'all checks passed');
process.exit(failures() ? 1 : 0);
