// lf-web's viewer page script (plain JS, no build step).
//
// Signalling on the WebSocket /ws (JSON): the server sends
//   {type: "hello", viewer, width, height, fps, cameras, focal_depth_range: [near, far],
//    aperture_range: [tent, widest]},
//   {type: "offer", sdp}, {type: "ice", candidate, sdpMLineIndex}, {type: "error", message};
// the page answers {type: "answer", sdp} and {type: "ice", candidate, sdpMLineIndex}.
// View control on the WebRTC data channel "control" (JSON text, <= 4096 bytes,
// <= 60 messages/s; x, y are pixels of the video picture):
//   {type: "pointer", action: "press"|"move"|"release", button: 1, x, y}  drag the eye
//   {type: "focus", x, y}            focus on the scene under that pixel
//   {type: "wheel", dy}              focal plane: +1 one notch nearer, -1 farther
//   {type: "key", key}               Left, Right, Up, Down, Page_Up, Page_Down, r (reset)
//   {type: "lf-view", "focal-depth": d, "eye-s": s, "aperture": D, ...}  view properties (rig
//      units): the JSON form of the lf-view event (docs/steering.md), applied whole ("set" is
//      the same message's older name)
//   {type: "sampling", filter: "bilinear"|"bicubic"}
//   {type: "surface", on: true|false}  a focal surface (the default) or the focal plane
//   {type: "stereo", on: true|false}  {type: "ping", t}
// and the server sends {type: "stats", ...} twice a second, {type: "pong", t},
// {type: "warning", message} when it refused something.
'use strict';

(() => {
  const video = document.getElementById('video');
  const stage = document.getElementById('stage');
  const focal = document.getElementById('focal');
  const aperture = document.getElementById('aperture');
  const bicubic = document.getElementById('bicubic');
  const surface = document.getElementById('surface');
  const stereo = document.getElementById('stereo');
  let stereoWanted = null, stereoSince = 0; // a toggle not yet confirmed by the server
  const statusLine = document.getElementById('status');
  const messageLine = document.getElementById('message');

  // The page's state, readable from the console (and by the browser test).
  const lf = window.lf = {
    viewer: null, width: 640, height: 480, cameras: 0, focalRange: [1, 100], apertureRange: [1, 4],
    stats: null, rttMs: null, fps: 0, framesDecoded: 0, frameWidth: 0, frameHeight: 0,
    warnings: [], connected: false, channelOpen: false,
    send(msg) { this.sendText(JSON.stringify(msg)); },
    sendText(text) {
      if (channel && channel.readyState === 'open') channel.send(text);
    },
  };
  let ws = null, pc = null, channel = null;

  function show(text) { messageLine.textContent = text; }

  // The focal slider is logarithmic in depth between the server's bounds
  // (24 px and 0.1 px of parallax between neighbouring cameras).
  function sliderToDepth(v) {
    const [a, b] = lf.focalRange;
    return a * Math.pow(b / a, v / 1000);
  }
  function depthToSlider(d) {
    const [a, b] = lf.focalRange;
    return Math.round(1000 * Math.log(d / a) / Math.log(b / a));
  }

  function connect() {
    const scheme = location.protocol === 'https:' ? 'wss' : 'ws';
    // The page's own query (?token=SECRET when lf-web runs with --token) goes
    // along to the signalling socket.
    const token = new URLSearchParams(location.search).get('token');
    ws = new WebSocket(`${scheme}://${location.host}/ws` + (token ? `?token=${encodeURIComponent(token)}` : ''));
    // A refused upgrade (a wrong token, no free slot) closes before it opens.
    let opened = false;
    ws.onopen = () => { opened = true; };
    ws.onclose = () => {
      statusLine.textContent = opened ? 'disconnected (reload to reconnect)'
        : 'the server refused this page (a wrong ?token=, or no free viewer slot): reload to try again';
      lf.connected = false;
    };
    ws.onmessage = async (ev) => {
      const m = JSON.parse(ev.data);
      if (m.type === 'hello') {
        lf.viewer = m.viewer; lf.width = m.width; lf.height = m.height; lf.cameras = m.cameras;
        lf.focalRange = m.focal_depth_range;
        if (m.aperture_range) lf.apertureRange = m.aperture_range;
        stage.style.aspectRatio = `${m.width} / ${m.height}`;
        startPeer();
      } else if (m.type === 'offer') {
        await pc.setRemoteDescription({ type: 'offer', sdp: m.sdp });
        const answer = await pc.createAnswer();
        await pc.setLocalDescription(answer);
        ws.send(JSON.stringify({ type: 'answer', sdp: answer.sdp }));
      } else if (m.type === 'ice') {
        await pc.addIceCandidate({ candidate: m.candidate, sdpMLineIndex: m.sdpMLineIndex });
      } else if (m.type === 'error' || m.type === 'warning') {
        show(m.message);
      }
    };
  }

  function startPeer() {
    pc = new RTCPeerConnection({ iceServers: [] });
    pc.ontrack = (e) => {
      video.srcObject = e.streams[0] || new MediaStream([e.track]);
      lf.connected = true;
    };
    pc.onicecandidate = (e) => {
      if (e.candidate && e.candidate.candidate)
        ws.send(JSON.stringify({ type: 'ice', candidate: e.candidate.candidate, sdpMLineIndex: e.candidate.sdpMLineIndex || 0 }));
    };
    pc.ondatachannel = (e) => {
      channel = e.channel;
      channel.onopen = () => { lf.channelOpen = true; };
      channel.onclose = () => { lf.channelOpen = false; };
      channel.onmessage = (ev) => onControl(JSON.parse(ev.data));
    };
  }

  function onControl(m) {
    if (m.type === 'stats') {
      lf.stats = m;
      // The server's state wins, except while a toggle of ours is on its way:
      // stats sent before the server applied it would undo the click.
      if (stereoWanted !== null && (m.stereo === stereoWanted || performance.now() - stereoSince > 3000)) stereoWanted = null;
      if (stereoWanted === null && stereo.checked !== m.stereo) stereo.checked = m.stereo;
      if (document.activeElement !== focal && m.focal_depth > 0) focal.value = depthToSlider(m.focal_depth);
      if (document.activeElement !== aperture && m.aperture !== undefined) aperture.value = apertureToSlider(m.aperture);
      if (document.activeElement !== surface && m.focal_surface !== undefined) surface.checked = m.focal_surface;
      if (document.activeElement !== bicubic && m.sampling) bicubic.checked = m.sampling === 'bicubic';
    } else if (m.type === 'pong') {
      lf.rttMs = performance.now() - m.t;
    } else if (m.type === 'warning') {
      lf.warnings.push(m.message);
      show(`server: ${m.message}`);
    }
  }

  // Pointer position in pixels of the picture (object-fit: contain).
  function toPicture(e) {
    const r = stage.getBoundingClientRect();
    const vw = video.videoWidth || lf.width, vh = video.videoHeight || lf.height;
    const s = Math.min(r.width / vw, r.height / vh);
    const x = (e.clientX - r.left - (r.width - vw * s) / 2) / s;
    const y = (e.clientY - r.top - (r.height - vh * s) / 2) / s;
    return { x: Math.min(vw - 1, Math.max(0, x)), y: Math.min(vh - 1, Math.max(0, y)) };
  }

  let dragging = false, lastMove = 0, pendingMove = null;
  // The stage follows the picture's shape (stereo doubles its width).
  video.addEventListener('resize', () => {
    if (video.videoWidth && video.videoHeight) stage.style.aspectRatio = `${video.videoWidth} / ${video.videoHeight}`;
  });
  stage.addEventListener('contextmenu', (e) => e.preventDefault());
  stage.addEventListener('pointerdown', (e) => {
    stage.focus();
    const p = toPicture(e);
    if (e.button === 2 || (e.button === 0 && e.ctrlKey)) {
      lf.send({ type: 'focus', x: p.x, y: p.y });
      show(`focusing at (${p.x.toFixed(0)}, ${p.y.toFixed(0)})`);
      return;
    }
    if (e.button !== 0) return;
    dragging = true;
    stage.classList.add('dragging');
    stage.setPointerCapture(e.pointerId);
    lf.send({ type: 'pointer', action: 'press', button: 1, x: p.x, y: p.y });
  });
  // Moves at most 30 per second (the last one is never lost).
  function flushMove() {
    if (!pendingMove) return;
    lf.send({ type: 'pointer', action: 'move', x: pendingMove.x, y: pendingMove.y });
    pendingMove = null;
    lastMove = performance.now();
  }
  stage.addEventListener('pointermove', (e) => {
    if (!dragging) return;
    pendingMove = toPicture(e);
    const wait = 33 - (performance.now() - lastMove);
    if (wait <= 0) flushMove(); else setTimeout(flushMove, wait);
  });
  function endDrag(e) {
    if (!dragging) return;
    flushMove();
    dragging = false;
    stage.classList.remove('dragging');
    const p = toPicture(e);
    lf.send({ type: 'pointer', action: 'release', button: 1, x: p.x, y: p.y });
  }
  stage.addEventListener('pointerup', endDrag);
  stage.addEventListener('pointercancel', endDrag);
  stage.addEventListener('wheel', (e) => {
    e.preventDefault();
    if (e.deltaY !== 0) lf.send({ type: 'wheel', dy: e.deltaY < 0 ? 1 : -1 });
  }, { passive: false });
  const keys = { ArrowLeft: 'Left', ArrowRight: 'Right', ArrowUp: 'Up', ArrowDown: 'Down', PageUp: 'Page_Up', PageDown: 'Page_Down', r: 'r' };
  stage.addEventListener('keydown', (e) => {
    if (keys[e.key]) { e.preventDefault(); lf.send({ type: 'key', key: keys[e.key] }); }
  });
  focal.addEventListener('input', () => lf.send({ type: 'lf-view', 'focal-depth': sliderToDepth(Number(focal.value)) }));
  // The aperture slider is linear in diameter from the tent (0: the paper's)
  // to the server's widest.
  function sliderToAperture(v) {
    const [a, b] = lf.apertureRange;
    return v === 0 ? 0 : a + (b - a) * v / 1000;
  }
  function apertureToSlider(d) {
    const [a, b] = lf.apertureRange;
    return d <= a ? 0 : Math.round(1000 * (d - a) / (b - a));
  }
  aperture.addEventListener('input', () => lf.send({ type: 'lf-view', aperture: sliderToAperture(Number(aperture.value)) }));
  surface.addEventListener('change', () => lf.send({ type: 'surface', on: surface.checked }));
  bicubic.addEventListener('change', () => lf.send({ type: 'sampling', filter: bicubic.checked ? 'bicubic' : 'bilinear' }));
  function setStereo(on) {
    stereo.checked = on;
    stereoWanted = on;
    stereoSince = performance.now();
    lf.send({ type: 'stereo', on });
  }
  stereo.addEventListener('change', () => setStereo(stereo.checked));
  document.getElementById('reset').addEventListener('click', () => {
    lf.send({ type: 'key', key: 'r' });
    if (stereo.checked) setStereo(false);
  });

  // Once a second: decoded frame rate and size (getStats), the control
  // round trip (ping), and what the server says.
  let lastFrames = 0, lastTime = performance.now();
  setInterval(async () => {
    lf.send({ type: 'ping', t: performance.now() });
    if (!pc) return;
    const report = await pc.getStats();
    report.forEach((r) => {
      if (r.type === 'inbound-rtp' && r.kind === 'video') {
        const now = performance.now();
        lf.fps = (r.framesDecoded - lastFrames) * 1000 / (now - lastTime);
        lastFrames = r.framesDecoded; lastTime = now;
        lf.framesDecoded = r.framesDecoded; lf.frameWidth = r.frameWidth || 0; lf.frameHeight = r.frameHeight || 0;
      }
    });
    const s = lf.stats;
    statusLine.textContent = [
      `viewer ${lf.viewer}`,
      `${lf.fps.toFixed(1)} fps`,
      `${lf.frameWidth}x${lf.frameHeight}`,
      lf.rttMs === null ? 'round trip -' : `round trip ${lf.rttMs.toFixed(0)} ms`,
      s ? `cameras ${s.cameras_answered}/${s.cameras}` : 'cameras -',
      s ? `${s.viewers} viewer${s.viewers === 1 ? '' : 's'}` : '',
    ].filter(Boolean).join(' · ');
  }, 1000);

  connect();
})();
