// Browser test of lf-web (issue 10): Debian's headless chromium, driven by
// playwright-core, against lf-web on loopback with the real Chess light field.
// Every check is made from inside the page (WebRTC getStats, pixels read from
// a canvas) or from what the server reports on the data channel.
//
// usage: node tests/web/web-test.mjs LF_WEB RIG [--browsers N]
//   LF_WEB: the lf-web binary; RIG: rig file or dataset folder.
//   --browsers N: also open N browsers at once and report each one's frame
//   rate (the scaling measurement; default 4).
import { spawn } from 'node:child_process';
import { readFileSync } from 'node:fs';
import { cpus } from 'node:os';
import { chromium } from 'playwright-core';
import { wsOpen, wsClose } from './wsraw.mjs';

const [lfWeb, rig, ...rest] = process.argv.slice(2);
const nBrowsers = rest[0] === '--browsers' ? Number(rest[1]) : 4;
const FPS = 10;
const results = [];
let failures = 0;

function check(name, ok, detail) {
  results.push(`${ok ? 'ok  ' : 'FAIL'} ${name}: ${detail}`);
  console.log(`${ok ? 'ok  ' : 'FAIL'} ${name}: ${detail}`);
  if (!ok) failures++;
}

// ---- the server -----------------------------------------------------------
const server = spawn(lfWeb, ['--rig', rig, '--block', '0,0,4,4', '--input-scale', '0.5',
  '--framerate', String(FPS), '--port', '0', '--address', '127.0.0.1', '--latency', '300'],
{ stdio: ['ignore', 'pipe', 'pipe'] });
let serverOut = '';
process.on('exit', () => server.kill('SIGKILL'));  // never leave it running
server.stdout.on('data', (d) => { serverOut += d; process.stdout.write(`  server: ${d}`); });
server.stderr.on('data', (d) => { serverOut += d; process.stdout.write(`  server: ${d}`); });
const port = await new Promise((resolve, reject) => {
  const t = setTimeout(() => reject(new Error('lf-web did not print its port in 60 s')), 60000);
  server.stdout.on('data', () => {
    const m = serverOut.match(/open http:\/\/[^:]+:(\d+)\//);
    if (m) { clearTimeout(t); resolve(Number(m[1])); }
  });
  server.on('exit', (code) => reject(new Error(`lf-web exited with ${code}`)));
});
const url = `http://127.0.0.1:${port}/`;

// ---- the browser ------------------------------------------------------------
const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
  args: ['--no-sandbox', '--disable-gpu', '--no-first-run', '--disable-background-networking',
    '--disable-component-update', '--disable-sync',
    // host candidates as addresses, not mDNS names (webrtcbin cannot resolve those)
    '--disable-features=WebRtcHideLocalIpsWithMdns',
    '--autoplay-policy=no-user-gesture-required'],
});

// Test helpers injected into each page (not part of the page itself):
// canvas grabs of the video, kept in the page, compared there.
function pageHelpers() {
  window.__grabs = {};
  window.__grab = (name) => {
    const v = document.getElementById('video');
    const c = document.createElement('canvas');
    c.width = v.videoWidth; c.height = v.videoHeight;
    const g = c.getContext('2d', { willReadFrequently: true });
    g.drawImage(v, 0, 0);
    window.__grabs[name] = g.getImageData(0, 0, c.width, c.height);
    return [c.width, c.height];
  };
  const luma = (img, i) => 0.299 * img.data[4 * i] + 0.587 * img.data[4 * i + 1] + 0.114 * img.data[4 * i + 2];
  // Mean absolute luma difference of two grabs (or -1 if their sizes differ).
  window.__diff = (a, b) => {
    const A = window.__grabs[a], B = window.__grabs[b];
    if (A.width !== B.width || A.height !== B.height) return -1;
    let s = 0;
    const n = A.width * A.height;
    for (let i = 0; i < n; ++i) s += Math.abs(luma(A, i) - luma(B, i));
    return s / n;
  };
  window.__mean = (a) => {
    const A = window.__grabs[a];
    let s = 0;
    for (let i = 0; i < A.width * A.height; ++i) s += luma(A, i);
    return s / (A.width * A.height);
  };
  // Sharpness: mean squared Laplacian of luma in a (2r+1)^2 window at (x, y).
  window.__sharpness = (a, x, y, r) => {
    const A = window.__grabs[a], w = A.width;
    let s = 0, n = 0;
    for (let j = y - r; j <= y + r; ++j) {
      for (let i = x - r; i <= x + r; ++i) {
        const l = 4 * luma(A, j * w + i) - luma(A, j * w + i - 1) - luma(A, j * w + i + 1) -
          luma(A, (j - 1) * w + i) - luma(A, (j + 1) * w + i);
        s += l * l; n++;
      }
    }
    return s / n;
  };
}

async function openViewer(name) {
  const context = await browser.newContext({ viewport: { width: 1000, height: 900 } });
  const page = await context.newPage();
  await page.addInitScript(pageHelpers);
  page.on('pageerror', (e) => console.log(`  ${name} page error: ${e.message}`));
  await page.goto(url);
  return { name, page, context };
}

const lfState = (v) => v.page.evaluate(() => ({
  viewer: lf.viewer, framesDecoded: lf.framesDecoded, frameWidth: lf.frameWidth,
  frameHeight: lf.frameHeight, fps: lf.fps, stats: lf.stats, rttMs: lf.rttMs,
  warnings: lf.warnings.length, channelOpen: lf.channelOpen,
}));

async function waitFor(v, what, pred, seconds = 60) {
  const end = Date.now() + seconds * 1000;
  let s;
  while (Date.now() < end) {
    s = await lfState(v);
    if (pred(s)) return s;
    await v.page.waitForTimeout(250);
  }
  throw new Error(`${v.name}: timed out after ${seconds} s waiting for ${what}: ${JSON.stringify(s)}`);
}

// A picture made after now: wait for the server to composite and the page to
// decode at least a second's worth of frames more.
async function settle(v) {
  const s0 = await lfState(v);
  await waitFor(v, 'new frames', (s) => s.stats && s.stats.frames >= s0.stats.frames + FPS &&
    s.framesDecoded >= s0.framesDecoded + FPS / 2, 30);
}

const shots = process.env.LF_WEB_SHOTS;  // a folder: page screenshots at each grab
const grab = async (v, name) => {
  if (shots) await v.page.screenshot({ path: `${shots}/${v.name}-${name}.png` });
  return v.page.evaluate((n) => window.__grab(n), name);
};
const diff = (v, a, b) => v.page.evaluate(([x, y]) => window.__diff(x, y), [a, b]);
// Cross-page difference: copy one page's grab into another.
async function crossDiff(a, an, b, bn) {
  const data = await a.page.evaluate((n) => { const g = window.__grabs[n]; return [g.width, g.height, Array.from(g.data)]; }, an);
  await b.page.evaluate(([w, h, d, key]) => { window.__grabs[key] = new ImageData(new Uint8ClampedArray(d), w, h); }, [...data, 'other']);
  return diff(b, bn, 'other');
}

const viewers = [];
try {
  // 1. The video plays: frames decoded, 640x480.
  const A = await openViewer('A');
  viewers.push(A);
  let s = await waitFor(A, 'video', (x) => x.framesDecoded > 3 * FPS && x.channelOpen && x.stats, 90);
  s = await waitFor(A, 'the rate report', (x) => x.stats.rate && x.stats.rate.type === 'lf-rate', 20);
  check('stats carry the compositor\'s lf-rate in JSON form', s.stats.rate.fps > 0 && s.stats.rate['requested-fps'] > 0,
    `rate: ${JSON.stringify(s.stats.rate)}`);
  check('video plays', s.frameWidth === 640 && s.frameHeight === 480,
    `${s.framesDecoded} frames decoded, ${s.frameWidth}x${s.frameHeight}, ${s.fps.toFixed(1)} fps, ` +
    `${s.stats.cameras_answered}/${s.stats.cameras} cameras in the last frame, control round trip ${s.rttMs?.toFixed(1)} ms`);

  // 1b. 64 connections from another address that never answer the offer
  //     (a peer holding the slots) do not keep a real browser from a
  //     picture: they get at most --max-per-address (4) slots, and lose them
  //     at the handshake deadline.
  const silent = await Promise.all(Array.from({ length: 64 }, () =>
    wsOpen({ port, localAddress: '127.0.0.2' }).catch((e) => ({ status: -1, body: e.message }))));
  const tSilent = Date.now();
  const H = await openViewer('H');
  viewers.push(H);
  s = await waitFor(H, 'video beside 64 silent connections', (x) => x.framesDecoded > 0 && x.stats, 15);
  const held = silent.filter((c) => c.status === 101).length;
  check('64 silent connections do not keep a browser out', held <= 4,
    `${held} of 64 silent connections got a slot; a browser decoded its first frame ` +
    `${((Date.now() - tSilent) / 1000).toFixed(1)} s after they opened (bound 15 s)`);
  await H.context.close();
  viewers.splice(viewers.indexOf(H), 1);
  for (const c of silent) if (c.status === 101) wsClose(c);

  // 2. A drag changes the picture, and the server saw the requests move.
  await settle(A);
  await grab(A, 'before-drag');
  const box = await A.page.locator('#stage').boundingBox();
  const cx = box.x + box.width / 2, cy = box.y + box.height / 2;
  await A.page.mouse.move(cx, cy);
  await A.page.mouse.down();
  for (let k = 1; k <= 10; ++k) { await A.page.mouse.move(cx + 6 * k, cy, { steps: 2 }); await A.page.waitForTimeout(40); }
  await A.page.mouse.up();
  s = await waitFor(A, 'the eye to move', (x) => x.stats.eye[0] < 0, 20);
  await settle(A);
  await grab(A, 'after-drag');
  const dDrag = await diff(A, 'before-drag', 'after-drag');
  check('drag moves the eye (server)', s.stats.eye[0] < 0, `eye (s, t) = (${s.stats.eye[0].toFixed(4)}, ${s.stats.eye[1].toFixed(4)}) after a drag to the right`);
  check('drag changes the picture', dDrag > 2, `mean |luma difference| ${dDrag.toFixed(2)} (> 2)`);
  // A long drag stops at the border of the array: the picture stays.
  await A.page.mouse.move(cx, cy);
  await A.page.mouse.down();
  for (let k = 1; k <= 10; ++k) { await A.page.mouse.move(cx + 40 * k, cy + 10 * k, { steps: 2 }); await A.page.waitForTimeout(40); }
  await A.page.mouse.up();
  await settle(A);
  await grab(A, 'long-drag');
  const meanBefore = await A.page.evaluate(() => window.__mean('before-drag'));
  const meanLong = await A.page.evaluate(() => window.__mean('long-drag'));
  s = await lfState(A);
  check('a long drag keeps the picture', meanLong > 0.7 * meanBefore,
    `mean luma ${meanBefore.toFixed(1)} -> ${meanLong.toFixed(1)} with the eye at the array's border (${s.stats.eye[0].toFixed(2)}, ${s.stats.eye[1].toFixed(2)})`);
  await A.page.evaluate(() => lf.send({ type: 'key', key: 'r' }));
  await waitFor(A, 'reset', (x) => x.stats.eye[0] === 0 && x.stats.eye[1] === 0, 20);

  // Stereo: the checkbox gives left | right side by side (the video is
  // renegotiated at twice the width), and back.
  await A.page.locator('#stereo').check();
  const on = await waitFor(A, 'stereo video', (x) => x.frameWidth === 1280 && x.stats.stereo, 30);
  await A.page.locator('#stereo').uncheck();
  s = await waitFor(A, 'mono video', (x) => x.frameWidth === 640 && !x.stats.stereo, 30);
  check('stereo toggle', on.frameWidth === 1280 && on.frameHeight === 480 && s.frameWidth === 640 && s.frameHeight === 480,
    `on: ${on.frameWidth}x${on.frameHeight}, ${on.stats.cameras_answered}/${on.stats.cameras} cameras per eye; ` +
    `off: ${s.frameWidth}x${s.frameHeight}`);

  // Aperture: the slider's wide end reaches the requests (the server's
  // state) and changes the picture; back to the tent. Bicubic: the box
  // reaches the requests, and back.
  await settle(A);
  await grab(A, 'tent');
  const [, widest] = await A.page.evaluate(() => lf.apertureRange);
  const setAperture = (v) => A.page.evaluate((x) => {
    const el = document.getElementById('aperture');
    el.value = x;
    el.dispatchEvent(new Event('input'));
  }, v);
  await setAperture(1000);
  const wide = await waitFor(A, 'the widest aperture', (x) => Math.abs(x.stats.aperture - widest) < 1e-6 * widest, 20);
  await settle(A);
  await grab(A, 'wide');
  const dWide = await A.page.evaluate(() => window.__diff('tent', 'wide'));
  await setAperture(0);
  await waitFor(A, 'the tent again', (x) => x.stats.aperture === 0, 20);
  check('aperture slider', dWide > 1, `aperture ${wide.stats.aperture.toFixed(3)} (4 tents): mean |luma difference| from the tent ${dWide.toFixed(2)} (> 1)`);
  await A.page.locator('#bicubic').check();
  const cubic = await waitFor(A, 'bicubic sampling', (x) => x.stats.sampling === 'bicubic', 20);
  await A.page.locator('#bicubic').uncheck();
  const linear = await waitFor(A, 'bilinear sampling', (x) => x.stats.sampling === 'bilinear', 20);
  check('bicubic box', cubic.stats.sampling === 'bicubic' && linear.stats.sampling === 'bilinear',
    `server: ${cubic.stats.sampling}, then ${linear.stats.sampling}`);

  // 3. Focal plane: out of focus at the near end of the slider's range, then
  //    click to focus on the board under the view centre: sharper there.
  const [near] = await A.page.evaluate(() => lf.focalRange);
  await A.page.evaluate((d) => lf.send({ type: 'lf-view', 'focal-depth': d }), near);
  await waitFor(A, 'the near focal plane', (x) => Math.abs(x.stats.focal_depth - near) < 1e-6 * near, 20);
  await settle(A);
  await grab(A, 'near');
  const fx = 320, fy = 300;
  await A.page.mouse.click(box.x + fx * box.width / 640, box.y + fy * box.height / 480, { button: 'right' });
  s = await waitFor(A, 'click to focus', (x) => Math.abs(x.stats.focal_depth - near) > 0.05 * near, 20);
  await settle(A);
  await grab(A, 'focused');
  const sharpNear = await A.page.evaluate(([x, y]) => window.__sharpness('near', x, y, 24), [fx, fy]);
  const sharpFocused = await A.page.evaluate(([x, y]) => window.__sharpness('focused', x, y, 24), [fx, fy]);
  check('click to focus sharpens the clicked region', sharpFocused > 1.5 * sharpNear,
    `mean squared Laplacian ${sharpNear.toFixed(1)} at focal depth ${near.toFixed(1)} -> ` +
    `${sharpFocused.toFixed(1)} at ${s.stats.focal_depth.toFixed(1)} (> 1.5x)`);

  if (process.env.LF_WEB_QUICK) throw new Error("quick run: stopped after the focus check");
  // 4. Independent viewers: B and C steer differently at the same time; A's
  //    picture stays as it was.
  const B = await openViewer('B'), C = await openViewer('C');
  viewers.push(B, C);
  for (const v of [B, C]) await waitFor(v, 'video', (x) => x.framesDecoded > 2 * FPS && x.channelOpen && x.stats, 90);
  await settle(A);
  const stateA0 = (await lfState(A)).stats;
  await grab(A, 'A-before');
  await B.page.locator('#stage').focus();
  for (let k = 0; k < 8; ++k) await B.page.keyboard.press('ArrowLeft');
  await C.page.evaluate(() => lf.send({ type: 'set', 'focal-depth': lf.focalRange[0] }));
  await waitFor(B, 'B to move', (x) => x.stats.eye[0] < 0, 20);
  await waitFor(C, 'C to refocus', (x) => x.stats.focal_depth > 0, 20);
  for (const v of [A, B, C]) await settle(v);
  await Promise.all([grab(A, 'A-after'), grab(B, 'B'), grab(C, 'C')]);
  const ids = await Promise.all([A, B, C].map((v) => v.page.evaluate(() => lf.viewer)));
  const dAA = await diff(A, 'A-before', 'A-after');
  const dAB = await crossDiff(B, 'B', A, 'A-after');
  const dAC = await crossDiff(C, 'C', A, 'A-after');
  const dBC = await crossDiff(C, 'C', B, 'B');
  check('viewers have their own ids', new Set(ids).size === 3, `viewer ids ${ids.join(', ')}`);
  check('three browsers, three pictures', dAB > 2 && dAC > 2 && dBC > 2,
    `mean |luma difference| A-B ${dAB.toFixed(2)}, A-C ${dAC.toFixed(2)}, B-C ${dBC.toFixed(2)} (> 2)`);
  // A's view is A's alone: the server's state of it is unchanged, and its
  // picture changed far less than the others differ from it (what changes
  // is codec noise and, on a loaded machine, frames composited at the
  // deadline without a late camera).
  const stateA1 = (await lfState(A)).stats;
  check('other viewers do not move A',
    JSON.stringify([stateA0.eye, stateA0.focal_depth]) === JSON.stringify([stateA1.eye, stateA1.focal_depth]) &&
    dAA < 0.5 * Math.min(dAB, dAC),
    `A's eye and focal depth unchanged; A's picture before/after: ${dAA.toFixed(2)} (< half of ${Math.min(dAB, dAC).toFixed(2)})`);

  // 5. Hostile control messages from A: refused with warnings, no effect on
  //    A's view or on the other viewers.
  const stA = (await lfState(A)).stats;
  const eyeBefore = stA.eye, focusedDepth = stA.focal_depth;
  const sB0 = await lfState(B), framesB0 = sB0.framesDecoded, floodAt = Date.now();
  await A.page.evaluate(() => {
    const ch = (m) => lf.send(m);
    ch({ type: 'set', 'focal-depth': 1e308 });
    ch({ type: 'lf-view', 'eye-s': 'left' });
    ch({ type: 'set', 'eye-s': 0.01, colour: 'red' });
    ch({ type: 'pointer', action: 'press', button: 1, x: -5, y: 1e9 });
    ch({ type: 'focus', x: 10 });
    ch({ type: 'launch-missiles' });
    ch([1, 2, 3]);
    lf.sendText('{"type": "set", "focal-depth": NaN}');  // not JSON
    lf.sendText('x'.repeat(5000));                         // too long
    for (let i = 0; i < 300; ++i) ch({ type: 'key', key: 'Left' });  // a flood
  });
  s = await waitFor(A, 'the refusals', (x) => x.stats.refused >= 9 + 200 && x.warnings > 0, 20);
  const refused = s.stats.refused;
  // B's decoded frame rate over a fixed window from the flood on (settle
  // would stop at whatever count it waits for, which proves nothing).
  await B.page.waitForTimeout(Math.max(0, floodAt + 3000 - Date.now()));
  const sB = await lfState(B);
  const secsB = (Date.now() - floodAt) / 1000, fpsB = (sB.framesDecoded - framesB0) / secsB;
  const eyeAfter = s.stats.eye;
  check('hostile control messages refused', refused >= 9 && s.warnings > 0 && s.stats.focal_depth === focusedDepth,
    `${refused} refused, ${s.warnings} warnings shown in the page; focal depth unchanged; eye s ` +
    `${eyeBefore[0].toFixed(2)} -> ${eyeAfter[0].toFixed(2)} by the flood's accepted steps`);
  check('a flood is rate limited', refused >= 9 + 200,
    `${refused} refused of 9 malformed + 300 in a burst (at most 60 pass at once): >= 209`);
  check('other viewers unaffected by the hostile one', fpsB > 3 &&
    JSON.stringify([sB.stats.eye, sB.stats.focal_depth]) === JSON.stringify([sB0.stats.eye, sB0.stats.focal_depth]),
    `B decoded ${sB.framesDecoded - framesB0} frames in the ${secsB.toFixed(1)} s ` +
    `from the flood on (${fpsB.toFixed(1)} fps of ${FPS}, > 3), its view unchanged`);

  // 6. A browser that leaves frees its branch; the others keep playing.
  await C.context.close();
  viewers.splice(viewers.indexOf(C), 1);
  s = await waitFor(A, 'the server to count 2 viewers', (x) => x.stats.viewers === 2, 20);
  const fB = (await lfState(B)).framesDecoded;
  await settle(B);
  const fB2 = (await lfState(B)).framesDecoded;
  check('a browser leaving frees its viewer', s.stats.viewers === 2 && /viewer \d+ left/.test(serverOut) && fB2 > fB,
    `server: ${s.stats.viewers} viewers; B decoded ${fB2 - fB} frames after C left`);

  // 6b. The WHEP player page (/whep.html): a standard WHEP client in the
  // browser (POST an offer, 201 with answer and Location, DELETE) plays a
  // view; its data channel steers it with the same control protocol.
  {
    const context = await browser.newContext({ viewport: { width: 900, height: 700 } });
    const page = await context.newPage();
    page.on('pageerror', (e) => console.log(`  WHEP page error: ${e.message}`));
    await page.goto(url + 'whep.html');
    const t0 = Date.now();
    await page.click('#play');
    const state = () => page.evaluate(() => JSON.parse(JSON.stringify(whep)));
    const until = async (what, pred, seconds) => {
      const end = Date.now() + seconds * 1000;
      let x;
      while (Date.now() < end) { x = await state(); if (pred(x)) return x; await page.waitForTimeout(250); }
      throw new Error(`WHEP page: timed out after ${seconds} s waiting for ${what}: ${JSON.stringify(x)}`);
    };
    let w = await until('frames', (x) => x.framesDecoded > 2 * FPS || x.error, 30);
    const firstS = (Date.now() - t0) / 1000;
    check('the WHEP page plays a view', w.status === 201 && /^\/whep\/resource\/\d+$/.test(w.location) &&
      w.frameWidth === 640 && w.frameHeight === 480,
    `POST ${w.status}, Location ${w.location}, ${w.framesDecoded} frames of ${w.frameWidth}x${w.frameHeight} decoded ${firstS.toFixed(1)} s after Play`);
    await page.click('#right');
    w = await until('the eye to move', (x) => x.stats && Math.abs(x.stats.eye[0] - 0.25) < 1e-9, 15);
    check('the WHEP page steers over its data channel', true, `stats: eye ${w.stats.eye.join(', ')}`);
    await page.click('#stop');
    w = await until('the DELETE', (x) => x.deleted !== null, 15);
    await page.waitForTimeout(500);
    check('the WHEP page ends its session with DELETE', w.deleted === 200 && /ended the session \(DELETE\)/.test(serverOut),
      `DELETE ${w.deleted}`);
    await context.close();
  }

  // 7. N browsers at once (the scaling figure): every one plays 640x480.
  while (viewers.length < nBrowsers) {
    const v = await openViewer(String.fromCharCode(65 + viewers.length + 1));
    viewers.push(v);
  }
  for (const v of viewers) await waitFor(v, 'video', (x) => x.framesDecoded > 2 * FPS && x.stats, 90);
  const cpu = () => { const f = readFileSync(`/proc/${server.pid}/stat`, 'utf8').split(') ')[1].split(' '); return (Number(f[11]) + Number(f[12])) / 100; };
  const f0 = await Promise.all(viewers.map(lfState));
  const cpu0 = cpu();
  const t0 = Date.now();
  await A.page.waitForTimeout(10000);
  const f1 = await Promise.all(viewers.map(lfState));
  const secs = (Date.now() - t0) / 1000;
  const serverCpu = (cpu() - cpu0) / secs;
  const rates = f1.map((x, i) => (x.framesDecoded - f0[i].framesDecoded) / secs);
  const sizes = f1.map((x) => `${x.frameWidth}x${x.frameHeight}`);
  const rtts = f1.map((x) => (x.rttMs ?? NaN).toFixed(0));
  const cams = f1.map((x) => `${x.stats.cameras_answered}/${x.stats.cameras}`);
  check(`${viewers.length} browsers at once`, sizes.every((z) => z === '640x480') && rates.every((r) => r > 0.3 * FPS),
    `decoded fps ${rates.map((r) => r.toFixed(1)).join(', ')} of ${FPS} (each > ${0.3 * FPS}); ` +
    `sizes ${sizes.join(', ')}; control round trips ${rtts.join(', ')} ms; cameras in the last frame ${cams.join(', ')}; ` +
    `lf-web used ${(100 * serverCpu).toFixed(0)} % CPU (of ${cpus().length * 100} %)`);
} catch (e) {
  check('test ran to the end', false, e.message);
} finally {
  for (const v of viewers) await v.context.close().catch(() => {});
  await browser.close();
  // A clean shutdown on SIGINT: lf-web exits 0 and says so.
  server.kill('SIGINT');
  const code = await new Promise((r) => { const t = setTimeout(() => { server.kill('SIGKILL'); r('killed'); }, 10000); server.on('exit', (c) => { clearTimeout(t); r(c); }); });
  check('SIGINT stops the server cleanly', code === 0 && /interrupted: stopping/.test(serverOut), `exit ${code}`);
}
console.log(`\nweb: ${results.length - failures} passed, ${failures} failed`);
process.exit(failures ? 1 : 0);
