// A bare WebSocket client over node:net (RFC 6455), for tests that act as a
// hostile or careless peer of lf-web: it can stop at any point of the
// handshake, bind a chosen local address, send any Origin, and read the
// HTTP status of a refused upgrade. Not a general client: text frames only,
// no fragmentation, no extensions.
import { connect } from 'node:net';
import { randomBytes } from 'node:crypto';

// Opens ws://host:port/path. Resolves {status, socket, messages, closed}
// once the server answers the upgrade (status 101: open; anything else: the
// refusal, and the socket is closed). messages: text frames received so far
// (pushed as they come); onMessage(text) is called for each.
export function wsOpen({ host = '127.0.0.1', port, path = '/ws', origin, localAddress,
  timeoutMs = 10000, onMessage } = {}) {
  return new Promise((resolve, reject) => {
    const socket = connect({ host, port, localAddress });
    const key = randomBytes(16).toString('base64');
    let buf = Buffer.alloc(0), upgraded = false;
    const conn = { status: 0, socket, messages: [], closed: false, body: '' };
    const timer = setTimeout(() => { socket.destroy(); reject(new Error(`no answer to the upgrade in ${timeoutMs} ms`)); }, timeoutMs);
    socket.on('connect', () => {
      socket.write(`GET ${path} HTTP/1.1\r\nHost: ${host}:${port}\r\nUpgrade: websocket\r\n` +
        'Connection: Upgrade\r\nSec-WebSocket-Version: 13\r\n' +
        `Sec-WebSocket-Key: ${key}\r\n${origin ? `Origin: ${origin}\r\n` : ''}\r\n`);
    });
    socket.on('error', (e) => { if (!upgraded && !conn.status) { clearTimeout(timer); reject(e); } });
    socket.on('close', () => {
      conn.closed = true;
      if (!conn.status) { clearTimeout(timer); reject(new Error('closed before an answer')); }
    });
    socket.on('data', (d) => {
      if (upgraded && conn.status !== 101) return;  // a refusal's text (read below)
      buf = Buffer.concat([buf, d]);
      if (!upgraded) {
        const end = buf.indexOf('\r\n\r\n');
        if (end < 0) return;
        const head = buf.subarray(0, end).toString();
        conn.status = Number(head.split(' ')[1]);
        buf = buf.subarray(end + 4);
        upgraded = true;
        clearTimeout(timer);
        if (conn.status !== 101) {  // the refusal's text, then the server closes
          conn.body = buf.toString();
          socket.on('data', (more) => { conn.body += more.toString(); });
          socket.on('end', () => { socket.destroy(); resolve(conn); });
          socket.on('close', () => resolve(conn));
          return;
        }
        resolve(conn);
      }
      // Frames from the server (never masked).
      for (;;) {
        if (buf.length < 2) return;
        const op = buf[0] & 0x0f;
        let len = buf[1] & 0x7f, at = 2;
        if (len === 126) { if (buf.length < 4) return; len = buf.readUInt16BE(2); at = 4; }
        else if (len === 127) { if (buf.length < 10) return; len = Number(buf.readBigUInt64BE(2)); at = 10; }
        if (buf.length < at + len) return;
        const payload = buf.subarray(at, at + len);
        buf = buf.subarray(at + len);
        if (op === 1) {
          const text = payload.toString();
          conn.messages.push(text);
          if (onMessage) onMessage(text);
        } else if (op === 8) {
          socket.end();
        }
      }
    });
  });
}

// One masked client frame.
function frame(op, payload) {
  const mask = randomBytes(4);
  const n = payload.length;
  const head = n < 126 ? Buffer.from([0x80 | op, 0x80 | n])
    : Buffer.from([0x80 | op, 0x80 | 126, n >> 8, n & 0xff]);
  const body = Buffer.from(payload);
  for (let i = 0; i < n; ++i) body[i] ^= mask[i % 4];
  return Buffer.concat([head, mask, body]);
}

export function wsSend(conn, text) {
  conn.socket.write(frame(1, Buffer.from(text)));
}

// A clean close (a close frame, then FIN), or an abrupt one (the TCP
// connection dropped with no close frame).
export function wsClose(conn, { abrupt = false } = {}) {
  if (abrupt) { conn.socket.destroy(); return; }
  conn.socket.write(frame(8, Buffer.from([0x03, 0xe8])));  // 1000, normal
  conn.socket.end();
}

// Resolves when a text message satisfying pred has arrived (or rejects
// after timeoutMs).
export function wsWaitFor(conn, pred, timeoutMs = 10000) {
  return new Promise((resolve, reject) => {
    const t0 = Date.now();
    const poll = () => {
      const m = conn.messages.find(pred);
      if (m) return resolve(m);
      if (conn.closed) return reject(new Error('closed while waiting'));
      if (Date.now() - t0 > timeoutMs) return reject(new Error(`no such message in ${timeoutMs} ms`));
      setTimeout(poll, 10);
    };
    poll();
  });
}
