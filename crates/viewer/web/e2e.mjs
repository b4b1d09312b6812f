// End-to-end test of `haptic6d serve` in headless Chromium (Debian's /usr/bin/chromium driven by
// playwright-core). Starts the server on free loopback ports, opens the page, drives the tool
// into the object with the keyboard, and checks: the force shown is non-zero, the graphic tool
// stayed out of the object (penetration within tolerance while the device went deep), the
// contact spheres arrive on demand, a recording started from the page (allowed with
// --allow-page-recording) is a valid trajectory CSV, and a second page only watches. Saves a
// screenshot. Prints "e2e: N passed, M failed".
//
// Usage: node e2e.mjs [--bin PATH] [--out DIR] [--scene NAME]
//   --bin   the haptic6d binary (default: $HAPTIC6D_BIN or ../../../target/release/haptic6d)
//   --out   where the screenshot and recordings go (default: ./e2e-out)
import { spawn } from 'node:child_process';
import { mkdtempSync, mkdirSync, readdirSync, readFileSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { dirname, join, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';
import { chromium } from 'playwright-core';

const here = dirname(fileURLToPath(import.meta.url));
const arg = (name, dflt) => {
  const i = process.argv.indexOf(name);
  return i > 0 ? process.argv[i + 1] : dflt;
};
const bin = resolve(arg('--bin', process.env.HAPTIC6D_BIN || join(here, '../../../target/release/haptic6d')));
const outDir = resolve(arg('--out', join(here, 'e2e-out')));
const sceneName = arg('--scene', 'bunny');
const chromiumPath = process.env.CHROMIUM || '/usr/bin/chromium';
mkdirSync(outDir, { recursive: true });
const recordDir = mkdtempSync(join(tmpdir(), 'haptic6d-e2e-rec-'));
const userDataDir = mkdtempSync(join(tmpdir(), 'haptic6d-e2e-profile-'));

let passed = 0;
let failed = 0;
function check(name, ok, detail) {
  if (ok) { passed += 1; console.log(`ok   ${name}${detail ? ` (${detail})` : ''}`); }
  else { failed += 1; console.log(`FAIL ${name}${detail ? ` (${detail})` : ''}`); }
}
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

// --- server -----------------------------------------------------------------------------------
function startServer() {
  return new Promise((resolveUrl, reject) => {
    const p = spawn(bin, ['serve', sceneName, '--port', '0', '--udp-port', '0', '--bind', '127.0.0.1',
      '--record-dir', recordDir, '--allow-page-recording', '--duration', '300'], { stdio: ['ignore', 'pipe', 'pipe'] });
    let out = '';
    const timer = setTimeout(() => reject(new Error(`server did not start in 180 s:\n${out}`)), 180_000);
    const onData = (d) => {
      out += d.toString();
      const m = out.match(/open (http:\/\/127\.0\.0\.1:\d+\/)/);
      if (m) { clearTimeout(timer); resolveUrl({ proc: p, url: m[1], log: () => out }); }
    };
    p.stdout.on('data', onData);
    p.stderr.on('data', onData);
    p.on('exit', (code) => { clearTimeout(timer); reject(new Error(`server exited (${code}):\n${out}`)); });
  });
}

async function main() {
  const { proc, url, log } = await startServer();
  proc.removeAllListeners('exit');
  console.log(`server: ${url}`);
  // A fresh profile (--user-data-dir) per run, through Playwright's persistent context.
  const browser = await chromium.launchPersistentContext(userDataDir, {
    executablePath: chromiumPath,
    headless: true,
    viewport: { width: 1280, height: 800 },
    args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
      '--disable-background-networking', '--disable-component-update', '--disable-sync',
      '--enable-unsafe-swiftshader', '--use-angle=swiftshader'],
  });
  try {
    const page = browser.pages()[0] || await browser.newPage();
    const consoleErrors = [];
    page.on('pageerror', (e) => consoleErrors.push(String(e)));
    page.on('console', (m) => { if (m.type() === 'error') consoleErrors.push(m.text()); });
    await page.goto(url);
    await page.waitForFunction(() => window.haptic6d && window.haptic6d.ready, null, { timeout: 60_000 });
    // The scene arrived (named, with triangles), the state stream is live (frames advance over
    // half a second), and this first page owns the device.
    const s0 = await page.evaluate(() => ({ frame: window.haptic6d.state.frame, n: window.haptic6d.frames }));
    await sleep(500);
    const loaded = await page.evaluate(() => {
      const a = window.haptic6d;
      return { name: a.scene.name, tris: a.scene.objects.reduce((k, o) => k + o.indices.length / 3, 0),
        frame: a.state.frame, n: a.frames, role: a.role };
    });
    check('page loads the scene and streams state', loaded.name && loaded.tris > 0
      && loaded.frame > s0.frame + 100 && loaded.n - s0.n >= 10 && loaded.role === 'owner',
    `scene ${loaded.name}, ${loaded.tris} triangles, ${loaded.n - s0.n} states and `
      + `${loaded.frame - s0.frame} haptic frames in 0.5 s, role ${loaded.role}`);

    // Direction from the tool's start toward the object's centre, as the key to hold.
    const plan = await page.evaluate(() => {
      const s = window.haptic6d.scene;
      const o = s.objects[0];
      let lo = [Infinity, Infinity, Infinity];
      let hi = [-Infinity, -Infinity, -Infinity];
      for (let i = 0; i < o.positions.length; i += 3) {
        for (let k = 0; k < 3; k++) {
          lo[k] = Math.min(lo[k], o.positions[i + k]);
          hi[k] = Math.max(hi[k], o.positions[i + k]);
        }
      }
      const c = [0, 1, 2].map((k) => (lo[k] + hi[k]) / 2 + o.pose[k]);
      const d = [0, 1, 2].map((k) => c[k] - s.start[k]);
      const axis = [0, 1, 2].reduce((a, k) => (Math.abs(d[k]) > Math.abs(d[a]) ? k : a), 0);
      return { axis, sign: Math.sign(d[axis]) };
    });
    const KEYS = [['KeyA', 'KeyD'], ['KeyS', 'KeyW'], ['KeyQ', 'KeyE']];
    const key = KEYS[plan.axis][plan.sign > 0 ? 1 : 0];
    console.log(`driving along axis ${'xyz'[plan.axis]} (${plan.sign > 0 ? '+' : '-'}) with ${key}`);

    // Hold the key until the device is well inside (force above 10 N) or 20 s pass.
    await page.locator('#view canvas').click({ position: { x: 5, y: 5 }, button: 'middle' });
    await page.keyboard.down(key);
    const t0 = Date.now();
    let forceShown = 0;
    while (Date.now() - t0 < 20_000) {
      await sleep(100);
      forceShown = parseFloat(await page.locator('#force-norm').textContent());
      if (forceShown > 10) break;
    }
    await page.keyboard.up(key);
    await sleep(600);
    const st = await page.evaluate(() => window.haptic6d.state);
    forceShown = parseFloat(await page.locator('#force-norm').textContent());
    const dev = st.device;
    const gra = st.graphic;
    const sep = Math.hypot(dev[0] - gra[0], dev[1] - gra[1], dev[2] - gra[2]);
    check('force shown is non-zero after pushing into the object', forceShown > 1, `${forceShown} N on the page`);
    check('the page drives the device', st.source === 1, `source ${st.source}`);
    check('the device (ghost) went into the object, the graphic tool stopped at the surface', sep > 5,
      `device–graphic separation ${sep.toFixed(2)} mm`);
    check('graphic tool did not enter the object', st.penetration_mm <= 0.5 && st.pairs > 0,
      `penetration ${st.penetration_mm.toFixed(4)} mm at ${st.pairs} pairs`);
    const fDir = st.force[plan.axis] * plan.sign;
    check('force pushes the hand back out', fDir < 0, `F along the push axis ${(-fDir).toFixed(2)} N outward`);

    // Contact spheres on demand.
    await page.click('#btn-contacts');
    await page.waitForFunction(() => (window.haptic6d.state.contacts || []).length > 0, null, { timeout: 10_000 })
      .then(() => {}, () => {});
    const nContacts = await page.evaluate(() => (window.haptic6d.state.contacts || []).length);
    check('contact spheres arrive when asked', nContacts > 0, `${nContacts} pairs listed`);
    await sleep(300);
    await page.screenshot({ path: join(outDir, 'viewer.png') });
    console.log(`screenshot: ${join(outDir, 'viewer.png')}`);

    // Recording from the page: record while moving back out, stop, check the CSV.
    await page.click('#btn-record');
    await page.waitForFunction(() => window.haptic6d.state.recording, null, { timeout: 10_000 });
    const back = KEYS[plan.axis][plan.sign > 0 ? 0 : 1];
    await page.keyboard.down(back);
    await sleep(700);
    await page.keyboard.up(back);
    await page.click('#btn-record');
    await page.waitForFunction(() => /recorded \d+ frames/.test(document.getElementById('notice').textContent),
      null, { timeout: 10_000 });
    const notice = await page.locator('#notice').textContent();
    const files = readdirSync(recordDir).filter((f) => f.endsWith('.csv'));
    let rows = [];
    if (files.length === 1) rows = readFileSync(join(recordDir, files[0]), 'utf8').trim().split('\n');
    const header = rows[0];
    const data = rows.slice(1).map((r) => r.split(',').map(Number));
    const okRows = data.length > 50 && data.every((r) => r.length === 7 && r.every(Number.isFinite));
    const moved = data.length > 1 ? Math.abs(data[data.length - 1][plan.axis + 1] - data[0][plan.axis + 1]) : 0;
    const dt = data.length > 1 ? data[1][0] - data[0][0] : 0;
    check('recording from the page writes a trajectory CSV', files.length === 1
      && header === 't,x,y,z,gamma,beta,alpha' && okRows && moved > 5 && Math.abs(dt - 0.001) < 1e-9,
    `${notice}; ${data.length} rows, moved ${moved.toFixed(1)} mm, dt ${dt}`);

    // A second page watches: told so, and its keys do not move the device.
    const page2 = await browser.newPage();
    page2.on('pageerror', (e) => consoleErrors.push(String(e)));
    await page2.goto(url);
    await page2.waitForFunction(() => window.haptic6d && window.haptic6d.ready && window.haptic6d.role,
      null, { timeout: 60_000 });
    const devBefore = await page.evaluate(() => window.haptic6d.state.device.slice());
    await page2.locator('#view canvas').click({ position: { x: 5, y: 5 }, button: 'middle' });
    await page2.keyboard.down(key);
    await sleep(700);
    await page2.keyboard.up(key);
    await sleep(300);
    const watch = await page2.evaluate(() => ({ role: window.haptic6d.role, conn: document.getElementById('conn').textContent,
      dev: window.haptic6d.state.device }));
    const moved2 = Math.hypot(...[0, 1, 2].map((k) => watch.dev[k] - devBefore[k]));
    check('a second page only watches', watch.role === 'watcher' && /watching/.test(watch.conn) && moved2 < 1e-9,
      `role ${watch.role}, "${watch.conn}", device moved ${moved2.toFixed(3)} mm`);
    await page2.close();

    check('no errors in the page console', consoleErrors.length === 0, consoleErrors.slice(0, 3).join(' | '));
  } finally {
    await browser.close();
    proc.kill('SIGINT');
    await Promise.race([new Promise((r) => proc.on('exit', r)), sleep(5000)]);
    if (failed > 0) console.log(`server log:\n${log()}`);
    rmSync(userDataDir, { recursive: true, force: true });
    rmSync(recordDir, { recursive: true, force: true });
  }
}

main()
  .catch((e) => { failed += 1; console.log(`FAIL e2e aborted: ${e.stack || e}`); })
  .finally(() => {
    console.log(`e2e: ${passed} passed, ${failed} failed`);
    process.exit(failed === 0 && passed > 0 ? 0 : 1);
  });
