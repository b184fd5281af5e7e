// lf-web under connect/close cycles and hostile connections, with no browser
// (tests/web/wsraw.mjs plays the peer): every viewer a connection builds is
// freed when it closes, fails or misses the handshake deadline, so threads,
// fds and memory come back to the idle level and the CPU goes quiet; a peer
// closing at once, as fast as it can, finds no more than the viewers of the
// moment held (their threads and fds while it runs); peers
// that never answer cannot hold the slots; a foreign Origin and a missing
// token are refused before any viewer is built.
//
// usage: node tests/web/lifetime-test.mjs LF_WEB RIG [--cycles N]
//   --cycles N: connect/close cycles after the warm-up (default 1000; the
//   figure in docs/reliability.md was taken with 10000).
import { spawn } from 'node:child_process';
import { readFileSync, readdirSync } from 'node:fs';
import { wsOpen, wsSend, wsClose, wsWaitFor } from './wsraw.mjs';

const [lfWeb, rig, ...rest] = process.argv.slice(2);
const arg = (name, dflt) => { const i = rest.indexOf(name); return i >= 0 ? Number(rest[i + 1]) : dflt; };
const cycles = arg('--cycles', 1000);
const HANDSHAKE_S = 3;
const results = [];
let failures = 0;
function check(name, ok, detail) {
  const line = `${ok ? 'ok  ' : 'FAIL'} ${name}: ${detail}`;
  results.push(line); console.log(line);
  if (!ok) failures++;
}
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

function startServer(extra = []) {
  const server = spawn(lfWeb, ['--rig', rig, '--block', '0,0,4,4', '--input-scale', '0.5',
    '--framerate', '10', '--port', '0', '--address', '127.0.0.1', '--max-viewers', '8',
    '--max-per-address', '4', '--handshake-timeout', String(HANDSHAKE_S), ...extra],
  { stdio: ['ignore', 'pipe', 'pipe'] });
  server.out = '';
  server.stdout.on('data', (d) => { server.out += d; });
  server.stderr.on('data', (d) => { server.out += d; });
  process.on('exit', () => server.kill('SIGKILL'));
  return server;
}

// SIGINT, then SIGKILL if it has not exited within 10 s.
function stopServer(server) {
  server.kill('SIGINT');
  return new Promise((r) => {
    const t = setTimeout(() => { server.kill('SIGKILL'); r(); }, 10000);
    server.on('exit', () => { clearTimeout(t); r(); });
  });
}

async function portOf(server) {
  for (let k = 0; k < 600; ++k) {
    const m = server.out.match(/open http:\/\/[^:]+:(\d+)\//);
    if (m) return Number(m[1]);
    if (server.exitCode !== null) throw new Error(`lf-web exited with ${server.exitCode}: ${server.out}`);
    await sleep(100);
  }
  throw new Error('lf-web did not print its port within 60 s');
}

function usage(pid) {
  const status = readFileSync(`/proc/${pid}/status`, 'utf8');
  const f = readFileSync(`/proc/${pid}/stat`, 'utf8').split(') ')[1].split(' ');
  return {
    threads: Number(status.match(/Threads:\s+(\d+)/)[1]),
    fds: readdirSync(`/proc/${pid}/fd`).length,
    rssMiB: Number(status.match(/VmRSS:\s+(\d+)/)[1]) / 1024,
    cpuS: (Number(f[11]) + Number(f[12])) / 100,
  };
}

// CPU used over `ms`, in cores.
async function cpuOver(pid, ms) {
  const a = usage(pid).cpuS, t = Date.now();
  await sleep(ms);
  return (usage(pid).cpuS - a) / ((Date.now() - t) / 1000);
}

// One cycle: upgrade, then close at one of four points: before the offer
// (cleanly or by dropping the connection), after it, or after a bogus answer.
// A 429 means the server has not yet freed this address's last viewer
// (the close is still on its way): try again shortly, as a browser would.
let retries = 0;
let waitedForOffer = 0;  // cycles that waited for the offer (kinds 2 and 3)
// `kind`: 0-3 as above (default: k % 4).
async function cycle(port, k, kind = k % 4) {
  let conn = await wsOpen({ port });
  for (let r = 0; conn.status === 429 && r < 100; ++r) {
    retries++;
    await sleep(20);
    conn = await wsOpen({ port });
  }
  if (conn.status !== 101) throw new Error(`cycle ${k}: upgrade answered ${conn.status}: ${conn.body}`);
  if (kind >= 2) {
    waitedForOffer++;
    await wsWaitFor(conn, (m) => m.includes('"offer"'), 20000);
  }
  if (kind === 3) wsSend(conn, JSON.stringify({ type: 'answer', sdp: 'v=0\r\no=- 0 0 IN IP4 127.0.0.1\r\ns=-\r\nt=0 0\r\nm=video 9 UDP/TLS/RTP/SAVPF 96\r\nc=IN IP4 0.0.0.0\r\na=mid:video0\r\na=recvonly\r\n' }));
  wsClose(conn, { abrupt: kind === 1 });
  await new Promise((r) => (conn.closed ? r() : conn.socket.on('close', r)));
}

// Cycles, four at a time (the per-address cap).
async function cycles4(port, n) {
  let next = 0;
  const worker = async () => { while (next < n) await cycle(port, next++); };
  await Promise.all([worker(), worker(), worker(), worker()]);
}

// Waits until the server has no viewer left (its usage stops falling).
async function settled(pid) {
  let last = usage(pid);
  for (let k = 0; k < 40; ++k) {
    await sleep(250);
    const u = usage(pid);
    if (u.threads === last.threads && u.fds === last.fds) return u;
    last = u;
  }
  return last;
}

const server = startServer();
try {
  const port = await portOf(server);
  // Warm-up: the first viewers load the plugins and fill the allocator's
  // pools; the idle level is taken after them, twice (after 250 and 500
  // cycles: RSS at rest varies by a few MiB with what the last viewers
  // left in the allocator), and the higher of the two kept.
  await cycles4(port, 250);
  await sleep(1500);
  const idle1 = await settled(server.pid);
  await cycles4(port, 250);
  await sleep(1500);
  const idle2 = await settled(server.pid);
  const idle = { threads: Math.max(idle1.threads, idle2.threads), fds: Math.max(idle1.fds, idle2.fds),
    rssMiB: Math.max(idle1.rssMiB, idle2.rssMiB) };
  console.log(`idle after 250 and 500 warm-up cycles: ${JSON.stringify(idle1)}, ${JSON.stringify(idle2)}`);
  const idleCpu = await cpuOver(server.pid, 2000);
  console.log(`idle CPU ${(100 * idleCpu).toFixed(1)} %`);

  const t0 = Date.now();
  for (let done = 0; done < cycles; done += 500) {
    await cycles4(port, Math.min(500, cycles - done));
    const u = usage(server.pid);
    console.log(`  ${Math.min(done + 500, cycles)} cycles, ${((Date.now() - t0) / 1000).toFixed(0)} s: ${u.threads} threads, ${u.fds} fds, ${u.rssMiB.toFixed(0)} MiB`);
  }
  const secs = (Date.now() - t0) / 1000;
  await sleep(2000);  // "2 s after the last viewer leaves"
  const after = await settled(server.pid);
  // The CPU over 2 s from 2 s after; on a loaded machine (CI runs tests side
  // by side: the idle level itself read 3 % there once) the next two 2-s
  // windows too, and the lowest is kept: the server must fall quiet, and a
  // neighbour's load must not fail it.
  const windows = [await cpuOver(server.pid, 2000)];
  while (windows[windows.length - 1] >= 0.05 && windows.length < 3)
    windows.push(await cpuOver(server.pid, 2000));
  const cpuAfter = Math.min(...windows);
  // Back to the idle level (below is fine: the allocator may hand back more
  // than it held at rest). Threads exactly; fds with room for one stray ICE
  // agent (6 sockets and 3 eventfds that about one viewer in 1,000-3,000
  // leaves once, not yet found: docs/reliability.md); RSS within 10 % (it
  // creeps by about 0.2 MiB per 1,000 viewers). The leak this test was
  // written for left 19 fds and 2 threads per connection.
  check(`${cycles} connect/close cycles`, after.threads <= idle.threads &&
    after.fds <= idle.fds + 9 && after.rssMiB <= 1.10 * idle.rssMiB,
  `${secs.toFixed(0)} s (${(1000 * secs / cycles).toFixed(1)} ms a cycle, 4 at a time, ${retries} upgrades retried after a 429); threads ` +
    `${idle.threads} -> ${after.threads}, fds ${idle.fds} -> ${after.fds}, RSS ` +
    `${idle.rssMiB.toFixed(1)} -> ${after.rssMiB.toFixed(1)} MiB (threads no more, fds at most 9 more, RSS at most 10 % more)`);
  // The shared cameras' stream still flows: webrtcbin asks for negotiation
  // once the first frame's caps reach it, so a viewer whose offer waited
  // for the server's 2-s retry ("did not ask for negotiation") had no frame
  // by then. When a viewer's arrival or departure stopped the stream for
  // good (lffragmentdemux passed one viewer's FLUSHING upstream), every
  // later viewer waited for it: half of the cycles (those that wait for the
  // offer) and 2 s each. A loaded machine may delay a few first frames.
  const retried = (server.out.match(/did not ask for negotiation/g) || []).length;
  check('viewers get frames without the offer retry', retried <= 0.02 * waitedForOffer,
    `${retried} of ${waitedForOffer} viewers that waited for the offer had no frame 2 s after connecting (at most 2 %)`);
  check('quiet after the last viewer left', cpuAfter < 0.05,
    `${(100 * cpuAfter).toFixed(1)} % of a core over 2 s, 2 s after (windows: ` +
    `${windows.map((w) => (100 * w).toFixed(1)).join(', ')} %; idle before: ${(100 * idleCpu).toFixed(1)} %; < 5 %)`);

  // A peer closing at once, as fast as it can (half of them without a close
  // frame): a viewer is built and removed each time, and while that goes on
  // the server holds no more than the viewers of the moment (at most 4 from
  // this address). The threads and fds, read every 20 ms, stay within 120
  // of the idle level: the bus once held every removed viewer's state
  // messages, and each viewer with them (its ICE thread and sockets), so
  // 1,000 such cycles left 1,000 threads and fds standing until the peer
  // stopped. 4 live viewers hold about 35 threads and 15 fds.
  {
    let peak = { threads: 0, fds: 0 };
    let running = true;
    const sampler = (async () => {
      while (running) {
        const u = usage(server.pid);
        peak = { threads: Math.max(peak.threads, u.threads), fds: Math.max(peak.fds, u.fds) };
        await sleep(20);
      }
    })();
    const t1 = Date.now();
    let next = 0;
    const quick = async () => {
      while (next < 1000) {
        const k = next++;
        await cycle(port, k, k % 2);  // closed before the offer, cleanly or dropped
      }
    };
    await Promise.all([quick(), quick(), quick(), quick()]);
    running = false;
    await sampler;
    check('1000 cycles closed at once hold no more than the viewers of the moment',
      peak.threads <= idle.threads + 120 && peak.fds <= idle.fds + 120,
      `${((Date.now() - t1) / 1000).toFixed(1)} s; peak ${peak.threads} threads, ${peak.fds} fds ` +
      `(idle ${idle.threads}, ${idle.fds}; at most 120 more of each)`);
  }

  // Peers that never answer: 64 connections from another address hold at
  // most --max-per-address slots, and lose them at the handshake deadline.
  const hostile = await Promise.all(Array.from({ length: 64 }, () =>
    wsOpen({ port, localAddress: '127.0.0.2' }).catch((e) => ({ status: -1, body: e.message }))));
  const admitted = hostile.filter((c) => c.status === 101);
  const refusedStatus = [...new Set(hostile.filter((c) => c.status !== 101).map((c) => c.status))];
  const mine = await wsOpen({ port });  // this address still has its slots
  const tHostile = Date.now();
  await Promise.all(admitted.map((c) => new Promise((r) => (c.closed ? r() : c.socket.on('close', r)))));
  const freedAfter = (Date.now() - tHostile) / 1000;
  check('64 silent connections hold at most 4 slots', admitted.length === 4 &&
    refusedStatus.length === 1 && refusedStatus[0] === 429 && mine.status === 101,
  `${admitted.length} admitted from 127.0.0.2, ${64 - admitted.length} refused with HTTP ` +
    `${refusedStatus.join(',')}; a connection from 127.0.0.1 meanwhile: ${mine.status}`);
  check('the handshake deadline frees them', freedAfter < HANDSHAKE_S + 3 &&
    /no SDP answer within 3 s/.test(server.out),
  `closed by the server ${freedAfter.toFixed(1)} s after (--handshake-timeout ${HANDSHAKE_S})`);
  wsClose(mine);

  // Cross-site pages: a foreign Origin is refused before any viewer is built;
  // the page's own origin and a program without an Origin are let in.
  const foreign = await wsOpen({ port, origin: 'http://evil.example' });
  const own = await wsOpen({ port, origin: `http://127.0.0.1:${port}` });
  check('a foreign Origin is refused', foreign.status === 403 && own.status === 101,
    `Origin http://evil.example: HTTP ${foreign.status} (${foreign.body.trim()}); the page's own: ${own.status}`);
  if (own.status === 101) wsClose(own);
} catch (e) {
  check('test ran to the end', false, e.stack);
} finally {
  await stopServer(server);
}
if (failures) console.log(`lf-web's output, its last 40 lines:\n${server.out.split('\n').slice(-40).join('\n')}`);

// --token: without it, or with a wrong one, 401; with it, 101.
const guarded = startServer(['--token', 's3cret']);
try {
  const port = await portOf(guarded);
  const none = await wsOpen({ port });
  const wrong = await wsOpen({ port, path: '/ws?token=s3cres' });
  const right = await wsOpen({ port, path: '/ws?token=s3cret' });
  check('--token is required', none.status === 401 && wrong.status === 401 && right.status === 101,
    `no token: ${none.status}, a wrong one: ${wrong.status}, the right one: ${right.status}`);
  if (right.status === 101) wsClose(right);
} catch (e) {
  check('token test ran to the end', false, e.stack);
} finally {
  await stopServer(guarded);
}
console.log(`\nweb-lifetime: ${results.length - failures} passed, ${failures} failed`);
process.exit(failures ? 1 : 0);
