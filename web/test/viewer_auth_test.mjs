// Browser test of the viewer against a skimapd with bearer tokens (ctest:
// Viewer.BrowserSignsInWithABearerToken): a real skimapd with --auth_tokens_file, three
// ycbv-0000 frames posted with the robot's token, then Debian's headless chromium:
//   - without a token the viewer lists nothing and shows the token form (the server
//     answered 401),
//   - a token the server does not know is refused and the form stays,
//   - a read token scoped to another map signs in but sees no map (the scope holds),
//   - a read token for the map shows it: the list, the 3D voxels, and a frame posted now
//     arrives live (the event stream carries the token too).
// Screenshots: viewer-signin.png, viewer-signed-in.png under --out.
//
//   node web/test/viewer_auth_test.mjs --skimapd=build/release/server/skimapd \
//     --web_root=web/dist --scene=../shared/data/ycbv-0000/test/000000 --out=build/viewer
import { mkdtempSync, mkdirSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { call, check, failures, launchChromium, parseArgs, sceneFrames, startSkimapd, tearDown } from './harness.mjs';

const args = parseArgs(process.argv.slice(2), ['skimapd', 'web_root', 'scene', 'out']);
mkdirSync(args.out, { recursive: true });

const ROBOT = 'robot-7c1f0b2e9a';  // write, every map
const VIEWER = 'viewer-3d5e8a1c44';  // read, map ycbv only
const OTHER = 'other-9b2c7d6e01';  // read, map kitchen only

const dataDir = mkdtempSync(join(tmpdir(), 'skimap_viewer_auth_'));
const tokens = join(dataDir, 'tokens');
writeFileSync(tokens, `${ROBOT} write\n${VIEWER} read ycbv\n${OTHER} read kitchen\n`);
const { server, base } = await startSkimapd(args.skimapd, [
  `--data_dir=${join(dataDir, 'maps')}`, `--web_root=${args.web_root}`, `--auth_tokens_file=${tokens}`]);
let browser;
try {
  await call(base, 'POST', '/v1/maps', { mapId: 'ycbv', options: { resolution: 0.01 } }, ROBOT);
  const frames = sceneFrames(args.scene, 'maps/ycbv');
  for (const frame of frames.slice(0, 3)) {
    const ack = await call(base, 'POST', '/v1/maps/ycbv/frames', frame, ROBOT);
    if (ack.code) throw new Error(`frame ${frame.sequence}: ${ack.message}`);
  }
  const before = await call(base, 'GET', '/v1/maps/ycbv', undefined, VIEWER);

  browser = await launchChromium(args.chromium);
  const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
  const errors = [];
  page.on('pageerror', (e) => errors.push(String(e)));
  await page.goto(`${base}/`);
  await page.waitForSelector('body[data-auth-needed="1"]', { timeout: 30000 });
  check(await page.isVisible('#token-form'), 'without a token the viewer asks for one');
  check(await page.locator('tr[data-map]').count() === 0, 'and lists no map');
  check((await page.textContent('#status')).includes('missing bearer token'), `status: "${await page.textContent('#status')}"`);
  await page.screenshot({ path: join(args.out, 'viewer-signin.png') });

  const signIn = async (value) => {
    await page.fill('#token', value);
    await Promise.all([page.waitForNavigation(), page.click('#token-form button')]);
  };
  await signIn('not-a-token');
  await page.waitForSelector('body[data-auth-needed="1"]', { timeout: 30000 });
  check((await page.textContent('#status')).includes('unknown bearer token'), `an unknown token: "${await page.textContent('#status')}"`);

  await signIn(OTHER);
  await page.waitForSelector('body[data-ready="1"]', { timeout: 30000 });
  check(!(await page.isVisible('#token-form')), 'a known token signs in');
  check(await page.locator('tr[data-map="ycbv"]').count() === 0, 'a token scoped to another map does not see ycbv');

  await Promise.all([page.waitForNavigation(), page.click('#sign-out')]);
  await page.waitForSelector('body[data-auth-needed="1"]', { timeout: 30000 });
  check(await page.isVisible('#token-form'), 'signing out forgets the token');
  await signIn(VIEWER);
  await page.waitForSelector('tr[data-map="ycbv"]', { timeout: 30000 });
  check(await page.getAttribute('tr[data-map="ycbv"]', 'data-voxels') === before.stats.voxels,
        `the map's token lists ycbv with ${before.stats.voxels} voxels`);
  await page.waitForSelector('body[data-voxels-shown]', { timeout: 60000 });
  check(Number(await page.getAttribute('body', 'data-voxels-shown')) > 1000,
        `the 3D view drew ${await page.getAttribute('body', 'data-voxels-shown')} voxels`);
  await page.waitForFunction(() => document.getElementById('live').textContent === 'live', null, { timeout: 15000 });
  const ack = await call(base, 'POST', '/v1/maps/ycbv/frames', frames[3], ROBOT);
  check(!ack.code, 'the robot posts one more frame');
  await page.waitForSelector('tr[data-map="ycbv"][data-frames="4"]', { timeout: 15000 });
  check(true, 'the frame arrived live through the authorised event stream');
  await page.screenshot({ path: join(args.out, 'viewer-signed-in.png') });
  check(errors.length === 0, `no page errors${errors.length ? `: ${errors.join('; ')}` : ''}`);
} finally {
  await tearDown(browser, server, dataDir);
}
console.log(failures() ? `${failures()} check(s) failed` : 'all checks passed');
process.exit(failures() ? 1 : 0);
