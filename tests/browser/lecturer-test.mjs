// Drives the system Chromium against a running whepserversink:
//   node lecturer-test.mjs BASE_URL TOKEN WIDTH HEIGHT
// Prints one "ok ..." line per check, exits non-zero at the first failure.
// Waits on conditions in the page (waitForFunction), never on fixed sleeps.
import { timeout, fail, waitForServer, launchChromium, openLecturer, picture, difference, shownFor as shownForPage }
  from './browser-util.mjs';

const [base, token, width, height] = process.argv.slice(2);
await waitForServer(base);

// 1. A wrong token gets 401 and nothing else.
for (const url of [`${base}/whep?token=wrong`, `${base}/whep`]) {
  const r = await fetch(url, { method: 'POST', headers: { 'Content-Type': 'application/sdp' }, body: 'v=0\r\n' });
  const body = await r.text();
  if (r.status !== 401 || body !== '') fail(`${url}: ${r.status} with ${body.length} bytes, expected 401 and nothing`);
}
const page401 = await fetch(`${base}/?token=wrong`);
if (page401.status !== 401) fail(`page with a wrong token: ${page401.status}`);
console.log('ok wrong token: 401, empty');

// (A microphone the browser allows, which this server, without sound pads, does not take.)
const chromium = await launchChromium(['--use-fake-device-for-media-stream', '--use-fake-ui-for-media-stream']);
try {
  // The page's first join is lost on the way, as when the network changes under it: the page sends it
  // again.
  let lostJoins = 0;
  const page = await openLecturer(chromium.browser, base, token, 'page', async p => {
    await p.setRequestInterception(true);
    p.on('request', r => {
      if (r.method() === 'POST' && new URL(r.url()).pathname === '/whep' && lostJoins === 0) {
        ++lostJoins;
        r.abort('internetdisconnected');
      } else {
        r.continue();
      }
    });
  });
  // 2. Joined, and frames decode at the server's size.
  await page.waitForFunction(() => window.vclassroom && window.vclassroom.stats.framesShown > 10, { timeout });
  const size = await page.evaluate(() => [window.vclassroom.stats.width, window.vclassroom.stats.height]);
  if (size[0] !== Number(width) || size[1] !== Number(height)) fail(`frames of ${size}, expected ${width}x${height}`);
  const retries = await page.evaluate(() => window.vclassroom.stats.joinRetries);
  if (lostJoins !== 1 || retries !== 1) fail(`join lost ${lostJoins} time(s), the page tried again ${retries} time(s)`);
  console.log(`ok joined after a join lost on the way, frames ${size[0]}x${size[1]}`);
  // The answer carries the playout-delay extension the page's offer listed: the browser shows each frame
  // without growing a jitter buffer (docs/lecturer.md).
  const answer = await page.evaluate(async () => (await window.vclassroom.joined).pc.remoteDescription.sdp);
  if (!/a=extmap:\d+ http:\/\/www\.webrtc\.org\/experiments\/rtp-hdrext\/playout-delay/.test(answer))
    fail('the answer has no playout-delay extension');
  console.log('ok playout delay answered');

  const shownFor = seq => shownForPage(page, seq);

  try { await page.waitForFunction(() => window.vclassroom.stats.lastSeqShown >= 1, { timeout }); } catch (e) {
    fail('no echo: ' + JSON.stringify(await page.evaluate(() => ({ seq: window.vclassroom.seq, echoed: window.vclassroom.stats.lastSeqEchoed, shown: window.vclassroom.stats.lastSeqShown, rtp: window.vclassroom.stats.lastRtp }))));
  }
  // The first view is the server's own (its reference camera, 20° down, inside the bounds), level.
  const first = await page.evaluate(() => ({ view: { ...window.vclassroom.view }, clamped: window.vclassroom.stats.lastShownClamped }));
  if (Math.abs(first.view.pitch + 20) > 0.01 || first.view.roll !== 0 || Math.abs(first.view.yaw) > 0.01 || first.clamped)
    fail(`the first view is not the server's reference camera, level and inside the bounds: ${JSON.stringify(first)}`);
  console.log(`ok first view: pitch ${first.view.pitch.toFixed(2)}°, roll 0, inside the bounds`);
  // The panel: collapsed at the start, in the picture's lower half (the banner is at its top left); the
  // button opens and closes the controls.
  const panel = await page.evaluate(() => {
    const rect = document.getElementById('panel').getBoundingClientRect();
    const shown = () => document.getElementById('sliders').offsetParent !== null;
    const at = { top: rect.top, height: rect.height, controls: shown() };
    document.getElementById('toggle').click();
    at.opened = shown();
    document.getElementById('toggle').click();
    at.closed = !shown();
    return at;
  });
  if (panel.controls || !(panel.top > 270) || !(panel.height < 540 / 4) || !panel.opened || !panel.closed)
    fail(`the control panel: ${JSON.stringify(panel)}`);
  console.log(`ok panel: collapsed ${panel.height.toFixed(0)} px high at y ${panel.top.toFixed(0)}, opens and closes`);
  const seqBefore = await page.evaluate(() => window.vclassroom.seq);
  const before = await picture(page);
  // 3. A scripted drag turns the view; the echoed seq advances and the picture changes.
  await page.mouse.move(480, 270);
  await page.mouse.down();
  await page.mouse.move(680, 270, { steps: 5 });
  await page.mouse.up();
  const seqAfter = await page.evaluate(() => window.vclassroom.seq);
  if (seqAfter <= seqBefore) fail('the drag sent no pose');
  await shownFor(seqAfter);
  const after = await picture(page);
  const d = difference(before, after);
  if (!(d > 2)) fail(`picture unchanged by the drag (mean difference ${d})`);
  console.log(`ok drag: seq ${seqBefore} -> ${seqAfter} echoed, picture changed by ${d.toFixed(1)}`);
  // A left/right drag turns about the vertical: the view sent and the one rendered keep a level horizon.
  const level = await page.evaluate(() => {
    const s = window.vclassroom.stats;
    return { page: window.vclassroom.view.roll,
             rendered: window.vclassroom.poseToView(s.lastShownPose.position, s.lastShownPose.orientation).roll };
  });
  if (level.page !== 0 || !(Math.abs(level.rendered) < 0.01)) fail(`the drag tilted the horizon: ${JSON.stringify(level)}`);
  console.log(`ok level: roll ${level.rendered.toFixed(3)}° after the drag`);
  // Holding still: frames keep coming for the same pose; the readout says idle and measures nothing more.
  const still = await page.evaluate(() => ({ shown: window.vclassroom.stats.framesShown,
                                            samples: window.vclassroom.stats.latencyMs.length }));
  await page.waitForFunction(n => window.vclassroom.stats.framesShown > n + 10, { timeout }, still.shown);
  const idle = await page.evaluate(() => ({ text: document.getElementById('readout').textContent,
                                           samples: window.vclassroom.stats.latencyMs.length }));
  if (!idle.text.startsWith('pose→photon: idle') || idle.samples !== still.samples)
    fail(`holding still: readout '${idle.text}', ${idle.samples - still.samples} more samples`);
  console.log(`ok idle: '${idle.text}'`);

  // 4. The soft stop: a drag far past the server's navigation bounds (yaw ±60° from its reference camera)
  // shows the view at the edge, the echo says it was clamped, and the page's view moves to that edge, so
  // dragging back moves at once.
  const yawBefore = await page.evaluate(() => window.vclassroom.view.yaw);
  await page.mouse.move(200, 270);
  await page.mouse.down();
  await page.mouse.move(700, 270, { steps: 5 });  // 500 px at 0.2°/px: 100° more, to about 140°
  await page.mouse.up();
  const dragged = await page.evaluate(() => window.vclassroom.seq);
  await shownFor(dragged);
  try {
    await page.waitForFunction(() => window.vclassroom.stats.adopted > 0, { timeout });
  } catch (e) {
    fail('no clamped echo adopted: ' + JSON.stringify(await page.evaluate(() => window.vclassroom.stats)));
  }
  const stop = await page.evaluate(() => ({ yaw: window.vclassroom.view.yaw, clamped: window.vclassroom.stats.lastShownClamped }));
  if (!stop.clamped) fail('the view past the bounds was not echoed as clamped');
  // The edge is 60° from the reference camera (which looks 20° down; the page's yaw is about the vertical).
  if (!(stop.yaw > 40 && stop.yaw < 80)) fail(`the page's view is not at the edge: yaw ${stop.yaw}`);
  // At the edge the horizon stays level: the page keeps its roll, and the server's clamp (whose yaw turns
  // about its camera's tilted axis) gives the tilt back.
  const edge = await page.evaluate(() => {
    const s = window.vclassroom.stats;
    return { page: window.vclassroom.view.roll,
             rendered: window.vclassroom.poseToView(s.lastShownPose.position, s.lastShownPose.orientation).roll };
  });
  if (edge.page !== 0 || !(Math.abs(edge.rendered) < 0.01)) fail(`the horizon at the edge: ${JSON.stringify(edge)}`);
  console.log(`ok soft stop: dragged to yaw ${(yawBefore + 100).toFixed(0)}°, held at ${stop.yaw.toFixed(1)}°, ` +
              `level (rendered roll ${edge.rendered.toFixed(3)}°)`);

  // 5. The XR frame loop's pose path with a scripted headset pose (0.3 m to the right, turned 20°).
  const xrSeq = await page.evaluate(() => {
    const h = 20 * Math.PI / 360;
    window.vclassroom.onXRPose({ x: 0.3, y: 0, z: 0 }, { x: 0, y: -Math.sin(h), z: 0, w: Math.cos(h) });
    return window.vclassroom.seq;
  });
  await shownFor(xrSeq);
  const xr = await picture(page);
  const dx = difference(after, xr);
  if (!(dx > 2)) fail(`picture unchanged by the XR pose (mean difference ${dx})`);
  // The headset is 0.1 m past the bounds' right edge: the server rendered, and echoed, the edge.
  const shown = await page.evaluate(() => ({ clamped: window.vclassroom.stats.lastShownClamped,
                                              pose: window.vclassroom.stats.lastShownPose }));
  if (!shown.clamped || Math.abs(shown.pose.position[0] - 0.2) > 1e-3)
    fail(`the XR pose 0.3 m right was not echoed clamped to 0.2 m: ${JSON.stringify(shown)}`);
  console.log(`ok XR pose: seq ${xrSeq} echoed, picture changed by ${dx.toFixed(1)}, clamped to x ${shown.pose.position[0].toFixed(3)} m`);
  // The frame in front of the eyes: the XR loop's drawer puts the received frame into each eye's viewport
  // (two side by side here, in a WebGL canvas of the test's: no headset); each half shows the video.
  const eyes = await page.evaluate(() => {
    const canvas = document.createElement('canvas');
    canvas.width = 320; canvas.height = 90;
    const gl = canvas.getContext('webgl', { preserveDrawingBuffer: true });
    if (!gl) return null;
    const draw = window.vclassroom.makeFrameDrawer(gl);
    const video = document.getElementById('view');
    if (!draw || !draw(video, [{ x: 0, y: 0, width: 160, height: 90 }, { x: 160, y: 0, width: 160, height: 90 }]))
      return { drawn: false };
    const pixels = new Uint8Array(320 * 90 * 4);
    gl.readPixels(0, 0, 320, 90, gl.RGBA, gl.UNSIGNED_BYTE, pixels);
    const c2 = document.createElement('canvas');
    c2.width = 160; c2.height = 90;
    const g = c2.getContext('2d');
    g.drawImage(video, 0, 0, 160, 90);
    const ref = g.getImageData(0, 0, 160, 90).data;
    // readPixels rows go bottom-up; the 2D canvas's top-down.
    let left = 0, right = 0;
    for (let y = 0; y < 90; ++y)
      for (let x = 0; x < 160; ++x)
        for (let c = 0; c < 3; ++c) {
          const want = ref[((89 - y) * 160 + x) * 4 + c];
          left += Math.abs(pixels[(y * 320 + x) * 4 + c] - want);
          right += Math.abs(pixels[(y * 320 + 160 + x) * 4 + c] - want);
        }
    return { drawn: true, left: left / (160 * 90 * 3), right: right / (160 * 90 * 3) };
  });
  if (eyes === null) fail('no WebGL in this browser: the XR drawing cannot be checked');
  if (!eyes.drawn || !(eyes.left < 8 && eyes.right < 8))
    fail(`the XR drawer did not put the frame in both eyes: ${JSON.stringify(eyes)}`);
  console.log(`ok XR eyes: the frame drawn in both viewports (mean difference ${eyes.left.toFixed(1)}, ${eyes.right.toFixed(1)})`);
  const latency = await page.evaluate(() => ({ samples: window.vclassroom.stats.latencyMs.length,
                                               negative: window.vclassroom.stats.negativeLatency,
                                               microphone: window.vclassroom.stats.microphone }));
  if (!latency.samples || latency.negative !== 0) fail(`pose-to-photon samples: ${JSON.stringify(latency)}`);
  if (latency.microphone !== 'not taken') fail(`the microphone: ${latency.microphone}`);
  console.log(`ok ${latency.samples} latency samples, none negative; the microphone not taken`);
  // 6. Leaving: DELETE of the session's Location is 200, a second one 404 (the session is gone).
  const left = await page.evaluate(async () => [await window.vclassroom.leave(), await window.vclassroom.leave()]);
  if (left[0] !== 200 || left[1] !== 404) fail(`DELETE gave ${left}, expected 200 then 404`);
  console.log('ok left: DELETE 200, again 404');
} finally {
  await chromium.close();
}
