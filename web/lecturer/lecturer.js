// The lecturer's page: joins whepserversink over WHEP, shows the view, sends
// the pose over a data channel, shows pose-to-photon latency from the server's
// per-frame echo. No build step, nothing from the internet.
'use strict';

// posenav's mapping (plugins/lecturer/gstposenav.cpp, gst/vclassroom/core/pose.h):
// kept in one object the browser test compares with the C++ constants.
const NAV = {
  moveStep: 0.1,        // m per key press or wheel notch (posenav move-step)
  turnSpeed: 0.2,       // degrees per pixel dragged (posenav turn-speed)
  sliderMetres: 0.02,   // kSliderMetres
  sliderDegrees: 1.8,   // kSliderDegrees
  maxPitch: 89,
};

// The view as posenav keeps it: offsets from the reference camera (the rig
// origin looking level along -Z when the page knows no rig).
const view = { right: 0, up: 0, forward: 0, yaw: 0, pitch: 0, roll: 0 };
let seq = 0;
let channel = null;
let xrPose = null;  // set while an XR session drives the pose
// The view Reset returns to: the one the server shows before this lecturer steers (its reference camera,
// inside the navigation bounds, horizon level), adopted from the first echo; the rig origin looking level
// when the server names no pose.
let home = null;
let microphone = null;  // the lecturer's microphone's stream, once allowed
// This page's own poses, seq -> the viewer time it sent (the latest 300): an echo counts for the latency
// readout only when it names one of them (another lecturer's pose on a shared view has another clock).
const sentTimes = new Map();

function quatMul(a, b) {
  return [a[3]*b[0] + a[0]*b[3] + a[1]*b[2] - a[2]*b[1], a[3]*b[1] - a[0]*b[2] + a[1]*b[3] + a[2]*b[0],
          a[3]*b[2] + a[0]*b[1] - a[1]*b[0] + a[2]*b[3], a[3]*b[3] - a[0]*b[0] - a[1]*b[1] - a[2]*b[2]];
}
function axisAngle(axis, deg) {
  const h = deg * Math.PI / 360, s = Math.sin(h);
  return [axis[0]*s, axis[1]*s, axis[2]*s, Math.cos(h)];
}
function rotate(q, v) {
  const p = quatMul(quatMul(q, [v[0], v[1], v[2], 0]), [-q[0], -q[1], -q[2], q[3]]);
  return [p[0], p[1], p[2]];
}

// offset_to_pose with the level reference: camera-to-rig rotation is
// R_ref (diag(1,-1,-1), i.e. 180° about X) then yaw (about camera Y: turn
// right), pitch (about camera X: look up, the camera's Y pointing down),
// roll (about camera Z), as gst/vclassroom/core/view_offset.cpp.
function viewToPose(v) {
  const ref = [1, 0, 0, 0];  // 180° about X
  let q = quatMul(ref, axisAngle([0, 1, 0], v.yaw));
  q = quatMul(q, axisAngle([1, 0, 0], v.pitch));
  q = quatMul(q, axisAngle([0, 0, 1], v.roll));
  // Offsets in the reference camera's axes: right +X, up -Y, forward +Z.
  const p = rotate(ref, [v.right, -v.up, v.forward]);
  return { position: p, orientation: q };
}

// The inverse of viewToPose: a camera pose (rig frame) as the page's offsets. The rotation after the level
// reference is yaw (about Y), then pitch (about X), then roll (about Z): R = Ry Rx Rz, so R[0][2] = sin(yaw)
// cos(pitch), R[2][2] = cos(yaw) cos(pitch), R[1][2] = -sin(pitch), R[1][0] / R[1][1] = tan(roll).
function poseToView(position, orientation) {
  const refInverse = [-1, 0, 0, 0];
  const q = quatMul(refInverse, orientation);
  const col2 = rotate(q, [0, 0, 1]), col0 = rotate(q, [1, 0, 0]), col1 = rotate(q, [0, 1, 0]);
  const deg = 180 / Math.PI;
  const p = rotate(refInverse, position);
  return { right: p[0], up: -p[1], forward: p[2], yaw: Math.atan2(col2[0], col2[2]) * deg,
           pitch: -Math.asin(Math.max(-1, Math.min(1, col2[1]))) * deg, roll: Math.atan2(col0[1], col1[1]) * deg };
}

function sendPose(pose) {
  if (!channel || channel.readyState !== 'open') return false;
  seq += 1;
  const q = pose.orientation, p = pose.position, time = performance.now().toFixed(3);
  sentTimes.set(seq, Number(time));
  if (sentTimes.size > 300) sentTimes.delete(sentTimes.keys().next().value);
  channel.send(`pose ${seq} ${time} ${p[0]} ${p[1]} ${p[2]} ${q[0]} ${q[1]} ${q[2]} ${q[3]}`);
  return true;
}
function viewChanged() { updateSliders(); sendPose(viewToPose(view)); }

// The XR frame loop's pose path, also driven by the test with a scripted pose:
// a WebXR viewer pose (position in metres, orientation a quaternion, WebXR
// axes: +Y up, -Z forward) becomes the camera pose (OpenCV axes: +Y down, +Z forward).
function xrPoseToPose(position, orientation) {
  const q = quatMul([orientation.x, orientation.y, orientation.z, orientation.w], [1, 0, 0, 0]);
  return { position: [position.x, position.y, position.z], orientation: q };
}
function onXRPose(position, orientation) { xrPose = xrPoseToPose(position, orientation); return sendPose(xrPose); }

function walk(forward, right) {
  const y = view.yaw * Math.PI / 180;
  view.forward += forward * Math.cos(y) - right * Math.sin(y);
  view.right += forward * Math.sin(y) + right * Math.cos(y);
}
const LEVEL_ORIGIN = { right: 0, up: 0, forward: 0, yaw: 0, pitch: 0, roll: 0 };
function reset() { Object.assign(view, home || LEVEL_ORIGIN); viewChanged(); }
// The server's first echoed pose becomes home, its roll taken as level (a rig's cameras have level horizons;
// the page turns about the vertical from there).
function adoptHome(pose) {
  home = Object.assign(poseToView(pose.position, pose.orientation), { roll: 0 });
  reset();
}

const KEYS = { ArrowUp: [1, 0], w: [1, 0], ArrowDown: [-1, 0], s: [-1, 0], ArrowLeft: [0, -1], a: [0, -1],
               ArrowRight: [0, 1], d: [0, 1] };
function installControls(video) {
  let drag = null;
  video.addEventListener('pointerdown', e => { drag = [e.clientX, e.clientY]; video.setPointerCapture(e.pointerId); });
  video.addEventListener('pointerup', () => { drag = null; });
  video.addEventListener('pointermove', e => {
    if (!drag) return;
    // Yaw about the vertical, pitch about the horizontal: the roll (0 unless a slider set it) stays, so the
    // horizon stays level.
    view.yaw += (e.clientX - drag[0]) * NAV.turnSpeed;
    view.pitch = Math.max(-NAV.maxPitch, Math.min(NAV.maxPitch, view.pitch - (e.clientY - drag[1]) * NAV.turnSpeed));
    drag = [e.clientX, e.clientY];
    viewChanged();
  });
  video.addEventListener('wheel', e => { e.preventDefault(); walk(-Math.sign(e.deltaY) * NAV.moveStep, 0); viewChanged(); },
                         { passive: false });
  window.addEventListener('keydown', e => {
    const k = KEYS[e.key];
    if (k) walk(k[0] * NAV.moveStep, k[1] * NAV.moveStep);
    else if (e.key === 'PageUp' || e.key === 'q') view.up += NAV.moveStep;
    else if (e.key === 'PageDown' || e.key === 'e') view.up -= NAV.moveStep;
    else if (e.key === 'Home' || e.key === 'r') return reset();
    else return;
    viewChanged();
  });
}

// The paper's six sliders, 0..100, 50 = the reference camera.
const SLIDERS = ['right', 'up', 'forward', 'yaw', 'pitch', 'roll'];
function updateSliders() {
  SLIDERS.forEach((name, i) => {
    const el = document.getElementById('slider-' + name);
    if (el) el.value = 50 + view[name] / (i < 3 ? NAV.sliderMetres : NAV.sliderDegrees);
  });
}
function installSliders() {
  const box = document.getElementById('sliders');
  SLIDERS.forEach((name, i) => {
    const label = document.createElement('label');
    label.textContent = name + ' ';
    const el = document.createElement('input');
    Object.assign(el, { type: 'range', min: 0, max: 100, step: 0.5, value: 50, id: 'slider-' + name });
    el.addEventListener('input', () => { view[name] = (el.value - 50) * (i < 3 ? NAV.sliderMetres : NAV.sliderDegrees); viewChanged(); });
    label.appendChild(el);
    box.appendChild(label);
    box.appendChild(document.createElement('br'));
  });
}

// Echoes from the server: RTP timestamp -> the pose seq and viewer time it was rendered for and, from a
// server with navigation bounds, the pose it really rendered and whether it had to move it inside them.
const echoes = new Map();
// Per pose of this page's, at the first frame shown for it (latencyReadout), the latest 300: latencyMs (pose
// to photon), serverMs (the pose to its frame's echo: the data channel, waiting for the next camera frame,
// rendering, encoding), receiveMs (the pose to the frame's last packet) and displayMs (that packet to the
// display). Per second, the latest 60: jitterMs and decodeMs, the receiver's own averages per frame
// (getStats).
const stats = { framesShown: 0, lastSeqShown: 0, latencyMs: [], serverMs: [], receiveMs: [], displayMs: [],
                jitterMs: [], decodeMs: [], lastSeqEchoed: 0, width: 0, height: 0, clampedShown: 0,
                lastShownClamped: false, lastShownPose: null, adopted: 0, lastLatencyMs: 0,
                negativeLatency: 0 };
const record = (list, value, keep) => { list.push(value); if (list.length > keep) list.shift(); };
function onEcho(text) {
  const f = text.split(' ');
  if ((f.length !== 4 && f.length !== 12) || f[0] !== 'frame') return;
  const e = { seq: Number(f[2]), time: Number(f[3]), arrived: performance.now(), pose: null, clamped: false };
  e.own = sentTimes.has(e.seq) && Math.abs(sentTimes.get(e.seq) - e.time) < 0.01;
  if (f.length === 12) {
    const v = f.slice(4, 11).map(Number);
    if (v.some(x => !Number.isFinite(x))) return;
    e.pose = { position: v.slice(0, 3), orientation: v.slice(3, 7) };
    e.clamped = f[11] === '1';
  }
  echoes.set(Number(f[1]), e);
  stats.lastSeqEchoed = Math.max(stats.lastSeqEchoed, e.seq);
  if (echoes.size > 300) echoes.delete(echoes.keys().next().value);
  // A soft stop for the mouse, keys and sliders: the server moved the latest pose to the edge of what the
  // cameras see, so the page's view moves there too (a drag back moves at once instead of first unwinding
  // what went past the edge). A headset's pose is the head's own and is not adopted. The page keeps its own
  // roll: the bounds are the reference camera's, and a clamp about its tilted axes must not tilt the horizon.
  if (e.clamped && e.own && e.seq === seq && !xrPose) {
    Object.assign(view, poseToView(e.pose.position, e.pose.orientation), { roll: view.roll });
    updateSliders();
    stats.adopted += 1;
  }
  // The view before this page steers: the server's own (seq 0, its reference camera) becomes home; on a
  // view another lecturer already steers (whepserversink) the page starts where that view is, without
  // taking it for home (Reset then asks for the level origin, which the server moves into its bounds).
  if (seq === 0 && !xrPose && e.pose && !home) {
    if (e.seq === 0) adoptHome(e.pose);
    else if (!e.own) {
      Object.assign(view, poseToView(e.pose.position, e.pose.orientation), { roll: 0 });
      viewChanged();
    }
  }
}
// Pose to photon, once per pose of this page's: from the time the page sent it to the expected display of
// the first frame rendered for it. Later frames of the same pose (the lecturer holds still) and frames of
// another lecturer's pose measure nothing. The parts: to the frame's last packet (the data channel, the
// server, the network) and in this browser (decode, display), both on this page's clock. Returns the
// readout's text, or null to leave it as it is.
function latencyReadout(e, meta) {
  if (!e) return null;
  if (!e.own) return e.seq > 0 ? 'pose→photon: another lecturer steers this view' : null;
  if (e.seq === stats.lastSeqShown) return `pose→photon: idle (last ${stats.lastLatencyMs.toFixed(0)} ms)`;
  const latency = meta.expectedDisplayTime - e.time;
  if (!(e.seq > stats.lastSeqShown)) return null;  // an older pose's frame
  if (!(latency >= 0)) {  // never expected: the page's own clock on both ends
    stats.negativeLatency += 1;
    return null;
  }
  stats.lastSeqShown = e.seq;
  stats.lastLatencyMs = latency;
  record(stats.latencyMs, latency, 300);
  record(stats.serverMs, Math.max(0, e.arrived - e.time), 300);
  let parts = '';
  if (meta.receiveTime !== undefined && meta.receiveTime >= e.time && meta.expectedDisplayTime >= meta.receiveTime) {
    record(stats.receiveMs, meta.receiveTime - e.time, 300);
    record(stats.displayMs, meta.expectedDisplayTime - meta.receiveTime, 300);
    parts = ` (to its arrival ${(meta.receiveTime - e.time).toFixed(0)}, ` +
            `in this browser ${(meta.expectedDisplayTime - meta.receiveTime).toFixed(0)})`;
  }
  return `pose→photon ${latency.toFixed(0)} ms${parts}` + (e.clamped ? ' · at the edge of what the cameras see' : '');
}

function watchFrames(video) {
  const readout = document.getElementById('readout');
  const onFrame = (now, meta) => {
    stats.framesShown += 1;
    if (stats.framesShown === 1) startHomeWait();
    const status = document.getElementById('status');
    if (status.textContent === kNoPicture) status.textContent = 'joined';
    stats.width = meta.width; stats.height = meta.height; stats.lastRtp = meta.rtpTimestamp;
    const e = meta.rtpTimestamp !== undefined ? echoes.get(meta.rtpTimestamp) : undefined;
    const readoutText = latencyReadout(e, meta);
    if (readoutText !== null) readout.textContent = readoutText;
    if (e && e.pose) {
      stats.lastShownClamped = e.clamped;
      stats.lastShownPose = e.pose;
      if (e.clamped) stats.clampedShown += 1;
    }
    video.requestVideoFrameCallback(onFrame);
  };
  video.requestVideoFrameCallback(onFrame);
}

// The server's STUN/TURN servers, from the Link headers of its WHEP OPTIONS answer (the WHEP draft's ICE
// server configuration): <stun:host:port>; rel="ice-server", and for TURN also username, credential.
function iceServersFromLinks(header) {
  const servers = [];
  const link = /<([^>]*)>((?:\s*;\s*[a-z-]+="[^"]*")*)/g;
  for (let m; (m = link.exec(header || '')) !== null;) {
    const params = {};
    for (const p of m[2].matchAll(/([a-z-]+)="([^"]*)"/g)) params[p[1]] = p[2];
    if (params.rel !== 'ice-server') continue;
    const server = { urls: m[1] };
    if (params.username !== undefined)
      Object.assign(server, { username: params.username, credential: params.credential });
    servers.push(server);
  }
  return servers;
}

// The classroom's sound. A browser may refuse to play sound before the lecturer touched the page: the first
// click or key press then starts it.
function playSound(track) {
  const sound = document.getElementById('sound');
  sound.srcObject = new MediaStream([track]);
  sound.play().then(() => { stats.soundPlaying = true; }).catch(() => {
    const label = document.getElementById('soundstatus');
    label.textContent = 'click for the classroom\'s sound';
    const start = () => sound.play().then(() => { stats.soundPlaying = true; label.textContent = ''; }).catch(() => {});
    window.addEventListener('pointerdown', start, { once: true });
    window.addEventListener('keydown', start, { once: true });
  });
}

// The lecturer's microphone, with the browser's own echo cancelling (the classroom's sound from the
// lecturer's loudspeaker stays out of it). Refused or missing, the lesson goes on and the page says the class
// does not hear the lecturer.
async function openMicrophone(transceiver) {
  const label = document.getElementById('micstatus');
  if (transceiver.currentDirection !== 'sendrecv' && transceiver.currentDirection !== 'sendonly') {
    stats.microphone = 'not taken';
    label.textContent = 'the classroom has no loudspeaker for you: the class does not hear you';
    return;
  }
  if (!navigator.mediaDevices || !navigator.mediaDevices.getUserMedia) {
    stats.microphone = 'unavailable';
    label.textContent = 'no microphone here (the page needs https): the class does not hear you';
    return;
  }
  try {
    const mic = await navigator.mediaDevices.getUserMedia({ audio: { echoCancellation: true, noiseSuppression: true } });
    await transceiver.sender.replaceTrack(mic.getAudioTracks()[0]);
    microphone = mic;
    stats.microphone = 'on';
  } catch (e) {
    stats.microphone = e.name;
    label.textContent = e.name === 'NotAllowedError' ? 'microphone refused: the class does not hear you'
                                                     : 'no microphone: the class does not hear you';
  }
}

const kJoinAttempts = 5;
const kNoPictureMs = 3000;
const kNoPicture = 'joined, no picture yet: no camera is sending to the server';
const kHomeWaitMs = 2000;

// The first pose goes out once the server's first echo names its view (adoptHome); a server that names none
// gets the page's view a while after the first frame is shown with the pose channel open. The wait counts
// from the picture, not from the channel: a loaded server's first frame (and the echo with it) can come
// later than the wait, and the page would then steer away from the server's view before it knew it.
let homeWaitStarted = false;
function startHomeWait() {
  if (homeWaitStarted || stats.framesShown === 0 || !channel || channel.readyState !== 'open') return;
  homeWaitStarted = true;
  setTimeout(() => { if (seq === 0 && !xrPose) viewChanged(); }, kHomeWaitMs);
}

async function join() {
  const params = new URLSearchParams(location.search);
  const token = params.get('token') || '';
  const video = document.getElementById('view');
  const options = await fetch('whep?token=' + encodeURIComponent(token), { method: 'OPTIONS' }).catch(() => null);
  const iceServers = iceServersFromLinks(options && options.status === 204 ? options.headers.get('Link') : '');
  const pc = new RTCPeerConnection({ iceServers });
  pc.addTransceiver('video', { direction: 'recvonly' });
  // The classroom's sound, where the server has it, and the lecturer's voice, once the microphone is allowed
  // (after joining: the view does not wait for the lecturer to answer the browser's question).
  const audio = pc.addTransceiver('audio', { direction: 'sendrecv' });
  channel = pc.createDataChannel('pose');
  channel.onmessage = e => onEcho(e.data);
  channel.onopen = startHomeWait;
  pc.ontrack = e => {
    if (e.track.kind === 'audio') return playSound(e.track);
    if ('jitterBufferTarget' in e.receiver) e.receiver.jitterBufferTarget = 0;
    if ('playoutDelayHint' in e.receiver) e.receiver.playoutDelayHint = 0;
    video.srcObject = new MediaStream([e.track]);
  };
  const offer = await pc.createOffer();
  await pc.setLocalDescription(offer);
  // WHEP without trickle: the offer carries the candidates gathered, all of them once gathering completes,
  // else those of the first 3 s (a STUN or TURN server that does not answer must not keep the lecturer out).
  await new Promise(resolve => {
    if (pc.iceGatheringState === 'complete') return resolve();
    pc.addEventListener('icegatheringstatechange', () => pc.iceGatheringState === 'complete' && resolve());
    setTimeout(resolve, 3000);
  });
  const status = document.getElementById('status');
  // A join lost on the way (the network changed: Wi-Fi roaming, a VPN coming up; fetch rejects) is sent
  // again with the same offer, a few times, further apart each time. The server's answer, even a refusal,
  // is final.
  let response;
  for (let attempt = 1; !response; ++attempt) {
    try {
      response = await fetch('whep?token=' + encodeURIComponent(token),
                             { method: 'POST', headers: { 'Content-Type': 'application/sdp' }, body: pc.localDescription.sdp });
    } catch (e) {
      if (attempt === kJoinAttempts) { status.textContent = `cannot reach the server (${e.message})`; throw e; }
      status.textContent = `network error, joining again (${attempt} of ${kJoinAttempts - 1})`;
      stats.joinRetries = attempt;
      await new Promise(resolve => setTimeout(resolve, 500 * attempt));
    }
  }
  if (response.status !== 201) { status.textContent = `refused (${response.status})`; return { status: response.status }; }
  await pc.setRemoteDescription({ type: 'answer', sdp: await response.text() });
  status.textContent = 'joined';
  const location_ = response.headers.get('Location');
  const stopMicrophone = () => { if (microphone) microphone.getTracks().forEach(t => t.stop()); };
  window.vclassroom.leave = () => {
    stopMicrophone();
    return fetch(location_ + '?token=' + encodeURIComponent(token), { method: 'DELETE' }).then(r => r.status);
  };
  window.addEventListener('pagehide', () => {
    stopMicrophone();
    fetch(location_ + '?token=' + encodeURIComponent(token), { method: 'DELETE', keepalive: true });
  });
  watchFrames(video);
  openMicrophone(audio);
  // A server whose cameras have not sent yet has no picture to give: say so rather than a black page (and
  // a connection that never came up is not that).
  setTimeout(() => {
    if (stats.framesShown > 0) return;
    status.textContent = pc.connectionState === 'connected' ? kNoPicture
                                                            : `no picture: the connection is ${pc.connectionState}`;
  }, kNoPictureMs);
  setInterval(async () => {
    const report = await pc.getStats();
    report.forEach(r => {
      if (r.type === 'inbound-rtp' && r.kind === 'audio') stats.soundIn = r;
      if (r.type === 'outbound-rtp' && r.kind === 'audio') stats.voiceOut = r;
      if (r.type === 'inbound-rtp' && r.kind === 'video') {
        const prev = stats.inbound;
        stats.inbound = r;
        if (prev === undefined) return;
        stats.kbps = (r.bytesReceived - prev.bytesReceived) * 8 / 1000;
        const perFrame = (key, count) => 1000 * (r[key] - prev[key]) / Math.max(1, r[count] - prev[count]);
        record(stats.jitterMs, perFrame('jitterBufferDelay', 'jitterBufferEmittedCount'), 60);
        record(stats.decodeMs, perFrame('totalDecodeTime', 'framesDecoded'), 60);
      }
    });
  }, 1000);
  return { status: 201, pc };
}

// The received frame in front of the eyes: every XR view gets the whole frame (the server rendered it for
// the head pose it last had), drawn over the view's viewport of the XR WebGL layer. The same drawer serves
// any WebGL context (the browser test draws into a canvas of its own: no headset there).
function makeFrameDrawer(gl) {
  const shader = (type, text) => {
    const sh = gl.createShader(type);
    gl.shaderSource(sh, text);
    gl.compileShader(sh);
    return sh;
  };
  const program = gl.createProgram();
  gl.attachShader(program, shader(gl.VERTEX_SHADER,
    'attribute vec2 p; varying vec2 uv; void main() { uv = vec2(p.x + 1.0, 1.0 - p.y) * 0.5; gl_Position = vec4(p, 0.0, 1.0); }'));
  gl.attachShader(program, shader(gl.FRAGMENT_SHADER,
    'precision mediump float; varying vec2 uv; uniform sampler2D frame; void main() { gl_FragColor = texture2D(frame, uv); }'));
  gl.linkProgram(program);
  if (!gl.getProgramParameter(program, gl.LINK_STATUS)) return null;
  const quad = gl.createBuffer();
  gl.bindBuffer(gl.ARRAY_BUFFER, quad);
  gl.bufferData(gl.ARRAY_BUFFER, new Float32Array([-1, -1, 1, -1, -1, 1, -1, 1, 1, -1, 1, 1]), gl.STATIC_DRAW);
  const texture = gl.createTexture();
  gl.bindTexture(gl.TEXTURE_2D, texture);
  for (const [k, v] of [[gl.TEXTURE_MIN_FILTER, gl.LINEAR], [gl.TEXTURE_MAG_FILTER, gl.LINEAR],
                        [gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE], [gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE]])
    gl.texParameteri(gl.TEXTURE_2D, k, v);
  const where = gl.getAttribLocation(program, 'p');
  // Draws `video`'s current frame into each viewport ({x, y, width, height}); false before the first frame.
  return (video, viewports) => {
    if (video.readyState < 2) return false;
    gl.useProgram(program);
    gl.bindTexture(gl.TEXTURE_2D, texture);
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA, gl.RGBA, gl.UNSIGNED_BYTE, video);
    gl.bindBuffer(gl.ARRAY_BUFFER, quad);
    gl.enableVertexAttribArray(where);
    gl.vertexAttribPointer(where, 2, gl.FLOAT, false, 0, 0);
    for (const v of viewports) {
      gl.viewport(v.x, v.y, v.width, v.height);
      gl.drawArrays(gl.TRIANGLES, 0, 6);
    }
    return true;
  };
}

async function installVR() {
  const button = document.getElementById('vr'), label = document.getElementById('vrstatus');
  const supported = navigator.xr && await navigator.xr.isSessionSupported('immersive-vr').catch(() => false);
  if (!supported) { button.disabled = true; label.textContent = 'no VR headset found'; return; }
  button.onclick = async () => {
    const session = await navigator.xr.requestSession('immersive-vr');
    // In the headset the panel is not seen; back on the page it is.
    const panel = document.getElementById('panel');
    panel.hidden = true;
    session.addEventListener('end', () => { panel.hidden = false; xrPose = null; viewChanged(); });
    const space = await session.requestReferenceSpace('local');
    const gl = document.createElement('canvas').getContext('webgl', { xrCompatible: true });
    const layer = new XRWebGLLayer(session, gl);
    session.updateRenderState({ baseLayer: layer });
    const draw = makeFrameDrawer(gl);
    const video = document.getElementById('view');
    const onXRFrame = (t, frame) => {
      const pose = frame.getViewerPose(space);
      if (pose) {
        onXRPose(pose.transform.position, pose.transform.orientation);
        gl.bindFramebuffer(gl.FRAMEBUFFER, layer.framebuffer);
        if (draw) draw(video, pose.views.map(v => layer.getViewport(v)));
      }
      session.requestAnimationFrame(onXRFrame);
    };
    session.requestAnimationFrame(onXRFrame);
  };
}

window.vclassroom = { NAV, view, stats, join, onXRPose, viewToPose, poseToView, xrPoseToPose, makeFrameDrawer,
                      iceServersFromLinks,
                      get seq() { return seq; } };
// Loaded after the page's body (index.html adds this script with the token).
installSliders();
installControls(document.getElementById('view'));
document.getElementById('reset').onclick = reset;
document.getElementById('toggle').onclick = () => {
  const panel = document.getElementById('panel');
  const collapsed = panel.classList.toggle('collapsed');
  document.getElementById('toggle').setAttribute('aria-expanded', String(!collapsed));
};
installVR();
window.vclassroom.joined = join();
