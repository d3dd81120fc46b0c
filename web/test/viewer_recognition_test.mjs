// Browser test of the viewer on a map with recognition (ctest:
// Viewer.BrowserListsInstancesAndColoursLabels): a real skimapd with a data dir; the sim
// `mini` objects (3) trained through `skimap objects train` and a small classifier built
// (`skimap objects build`), as tests/server/recognition does; the mini test scene posted over
// REST (every --stride-th frame) into map "scene" with recognition on (policy EVERY_FRAME,
// so every frame is recognised before its ack). Then, in Debian's headless chromium
// (playwright-core), the viewer
//   - lists the instances of GET /v1/maps/scene/instances (name and score of each),
//   - draws one oriented box per instance (pixels of the box colour where the boxes are),
//   - with "labels" on, draws the Labels volume (GET /v1/maps/scene/labels, every page)
//     one box per voxel coloured by its heaviest label's object, with a legend naming the
//     objects and their voxel counts, as the REST reply says.
// Screenshots: --out/viewer-instances.png, viewer-labels.png.
//
// The mini dataset is made once by skimap-sim into --cache (kept while the skimap-sim
// binary is unchanged).
//
//   node web/test/viewer_recognition_test.mjs --skimapd=build/release/server/skimapd \
//     --skimap=build/release/client/skimap --sim=build/release/sim/skimap-sim \
//     --web_root=web/dist --cache=build/release/tests/web/testdata --out=build/viewer
import { spawn } from 'node:child_process';
import { existsSync, mkdirSync, mkdtempSync, readFileSync, rmSync, statSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { call, check, failures, launchChromium, parseArgs, sceneFrames, startSkimapd, tearDown } from './harness.mjs';

const args = parseArgs(process.argv.slice(2), ['skimapd', 'skimap', 'sim', 'web_root', 'cache', 'out']);
const stride = Number(args.stride || 5);
mkdirSync(args.out, { recursive: true });
const started = Date.now();
const elapsed = () => `${((Date.now() - started) / 1000).toFixed(1)} s`;

function run(program, argv) {
  return new Promise((resolve, reject) => {
    const child = spawn(program, argv, { stdio: ['ignore', 'ignore', 'pipe'] });
    let err = '';
    child.stderr.on('data', (c) => { err += c; });
    child.on('exit', (code) => (code === 0 ? resolve() : reject(new Error(`${program} ${argv.join(' ')}: exit ${code}: ${err.slice(-2000)}`))));
  });
}

// The mini dataset, made once per skimap-sim binary.
async function miniDataset() {
  const root = join(args.cache, 'mini');
  const done = join(root, '.complete');
  const stamp = String(statSync(args.sim).mtimeMs);
  if (existsSync(done) && readFileSync(done, 'utf8') === stamp) return root;
  rmSync(root, { recursive: true, force: true });
  mkdirSync(args.cache, { recursive: true });
  await run(args.sim, ['--preset', 'mini', '--out', root, '--threads', '2', '--quiet']);
  writeFileSync(done, stamp);
  return root;
}

// Non-background pixels of the 3D view with only the named scene groups shown.
function drawnWith(page, shown) {
  return page.evaluate((names) => {
    const v = window.skimapViewer.view3d;
    const groups = { voxels: v.voxels, labels: v.labels, instances: v.instances, trajectory: v.trajectory, axes: v.axes };
    const before = Object.fromEntries(Object.entries(groups).map(([k, g]) => [k, g ? g.visible : false]));
    for (const [k, g] of Object.entries(groups)) if (g) g.visible = names.includes(k);
    const drawn = v.drawnPixels();
    for (const [k, g] of Object.entries(groups)) if (g) g.visible = before[k];
    v.requestRender();
    return drawn;
  }, shown);
}

const dataset = await miniDataset();
console.log(`mini dataset ready (${elapsed()})`);
const dataDir = mkdtempSync(join(tmpdir(), 'skimap_viewer_rec_'));
const { server, base, grpc } = await startSkimapd(args.skimapd, [`--data_dir=${dataDir}`, `--web_root=${args.web_root}`]);
let browser;
try {
  // ORB, the fastest to train (the viewer is under test here, not recognition).
  await run(args.skimap, [`--server=${grpc}`, 'objects', 'train', dataset, '--frame_stride=3', '--detector=ORB']);
  await run(args.skimap, [`--server=${grpc}`, 'objects', 'build', '--classes_per_object=100', '--trees=10', '--max_depth=18']);
  console.log(`3 objects trained, classifier built (${elapsed()})`);
  await call(base, 'POST', '/v1/maps', {
    mapId: 'scene', options: { resolution: 0.02, recognition: { enabled: true, policy: 'EVERY_FRAME' } },
  });
  const frames = sceneFrames(join(dataset, 'test', '000001'), 'maps/scene').filter((_, i) => i % stride === 0);
  for (const frame of frames) {
    const ack = await call(base, 'POST', '/v1/maps/scene/frames', frame);
    if (ack.code) throw new Error(`frame ${frame.sequence}: ${ack.message}`);
  }
  const instances = (await call(base, 'GET', '/v1/maps/scene/instances?pageSize=1000')).instances || [];
  console.log(`${frames.length} frames recognised (${elapsed()}): ${instances.map((i) => `${i.objectName} ${i.score.toFixed(0)}`).join(', ')}`);
  check(instances.length >= 2, `the server found ${instances.length} instances`);
  const labels = [];
  for (let token = ''; ;) {
    const page = await call(base, 'GET', `/v1/maps/scene/labels?pageSize=5000${token ? `&pageToken=${encodeURIComponent(token)}` : ''}`);
    labels.push(...(page.voxels || []));
    token = page.nextPageToken || '';
    if (!token) break;
  }
  const byObject = {};
  for (const v of labels) byObject[v.objId || 0] = (byObject[v.objId || 0] || 0) + 1;
  console.log(`labels volume: ${labels.length} voxels, by object ${JSON.stringify(byObject)}`);
  check(labels.length > 50, `the labels volume has ${labels.length} voxels`);

  browser = await launchChromium(args.chromium);
  const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
  const errors = [];
  page.on('pageerror', (e) => errors.push(String(e)));
  page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
  // A budget of 30 000 boxes: the map's ~100 000 voxels come at level 1 (JSON pages are the
  // slow part on a loaded machine); the instances and labels are drawn whatever the level.
  await page.goto(`${base}/?budget=30000#map=scene&tab=view3d`);
  await page.waitForSelector('body[data-ready="1"]', { timeout: 30000 });

  // The instances: listed with their names and scores, drawn as boxes.
  await page.waitForFunction(() => /^\d+$/.test(document.body.dataset.instances || ''), null, { timeout: 180000 })
    .catch(async (error) => {
      await page.screenshot({ path: join(args.out, 'viewer-instances-timeout.png') });
      throw new Error(`${error.message}; status "${await page.textContent('#status')}", ` +
        `body ${JSON.stringify(await page.evaluate(() => ({ ...document.body.dataset })))}, errors ${errors.join('; ')}`);
    });
  const listed = await page.$$eval('#instances li', (items) => items.map((li) => ({
    object: li.dataset.object, score: Number(li.dataset.score), text: li.textContent })));
  check(listed.length === instances.length, `the viewer lists ${listed.length} instances (server: ${instances.length})`);
  for (const inst of instances) {
    const item = listed.find((l) => l.object === inst.object && Math.abs(l.score - inst.score) < 1e-6);
    check(item && item.text.includes(inst.objectName) && item.text.includes(inst.score.toFixed(0)),
          `listed: ${item ? item.text : `(missing ${inst.objectName} ${inst.score})`}`);
  }
  check(await page.evaluate(() => window.skimapViewer.view3d.instances.children.length) === instances.length,
        'one box per instance in the scene');
  await page.click('#fit-instances');
  const boxes = await drawnWith(page, ['instances']);
  check(boxes.drawn > 500, `the instance boxes and their labels drew ${boxes.drawn} pixels`);
  await page.waitForTimeout(300);
  await page.screenshot({ path: join(args.out, 'viewer-instances.png') });

  // The Labels volume coloured by object.
  await page.check('#show-labels');
  await page.waitForSelector('body[data-labels-shown]', { timeout: 120000 });
  check(Number(await page.getAttribute('body', 'data-labels-shown')) === labels.length,
        `the viewer draws ${await page.getAttribute('body', 'data-labels-shown')} label voxels (server: ${labels.length})`);
  const legend = await page.$$eval('#labels-legend li', (items) => items.map((li) => ({
    obj: Number(li.dataset.objId), voxels: Number(li.dataset.voxels), colour: li.dataset.colour, text: li.textContent })));
  for (const [obj, n] of Object.entries(byObject)) {
    const item = legend.find((l) => l.obj === Number(obj));
    check(item && item.voxels === n, `legend: ${item ? item.text : `(object ${obj} missing)`}`);
  }
  const colours = await page.evaluate(() => window.skimapViewer.view3d.labelColours());
  check(Object.keys(colours).length === Object.keys(byObject).length &&
        new Set(Object.values(colours)).size === Object.keys(byObject).length,
        `each object has its own colour: ${JSON.stringify(colours)}`);
  const painted = await drawnWith(page, ['labels']);
  check(painted.drawn > 200, `the label voxels drew ${painted.drawn} pixels`);
  await page.waitForTimeout(300);
  await page.screenshot({ path: join(args.out, 'viewer-labels.png') });
  await page.uncheck('#show-labels');
  check(await page.evaluate(() => !window.skimapViewer.view3d.labels.visible), 'unchecked, the labels are hidden');
  check(errors.length === 0, `no page errors${errors.length ? `: ${errors.join('; ')}` : ''}`);
} finally {
  await tearDown(browser, server, dataDir);
}
console.log(`${elapsed()} in all`);
console.log(failures() ? `${failures()} check(s) failed` : 'all checks passed');
process.exit(failures() ? 1 : 0);
