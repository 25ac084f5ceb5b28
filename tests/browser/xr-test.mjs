// The headset path of the lecturer's page on an emulated headset: the test (not the page) installs the
// WebXR emulation runtime `iwer` (a Meta Quest 3, both eyes) into the page before it loads, so the page's
// own code runs as on a headset: it finds immersive-vr, the "Enter VR" button starts the session, each XR
// frame's viewer pose goes to the server, and the received frame is drawn into both eyes' viewports.
//   node xr-test.mjs BASE_URL TOKEN
// Prints one "ok ..." line per check, exits non-zero at the first failure. Waits on page conditions.
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { timeout, fail, waitForServer, launchChromium, openLecturer, shownFor } from './browser-util.mjs';

const [base, token] = process.argv.slice(2);
const here = path.dirname(fileURLToPath(import.meta.url));
const iwer = fs.readFileSync(path.join(here, 'node_modules/iwer/build/iwer.min.js'), 'utf8');
await waitForServer(base);

const chromium = await launchChromium();
try {
  const page = await openLecturer(chromium.browser, base, token, 'page', p => p.evaluateOnNewDocument(`
    ${iwer}
    window.xrDevice = new IWER.XRDevice(IWER.metaQuest3, { stereoEnabled: true });
    window.xrDevice.installRuntime({ forceInstall: true });`));
  const errors = [];
  page.on('pageerror', e => errors.push(String(e)));
  await page.waitForFunction(() => window.vclassroom && window.vclassroom.stats.framesShown > 10, { timeout });
  await page.waitForFunction(() => window.vclassroom.stats.lastSeqShown >= 1, { timeout });

  // 1. The page finds the headset and enters immersive-vr by its own button (behind the panel's toggle).
  const offered = await page.evaluate(() => !document.getElementById('vr').disabled);
  if (!offered) fail(`no immersive-vr offered: ${await page.evaluate(() => document.getElementById('vrstatus').textContent)}`);
  await page.click('#toggle');
  await page.click('#vr');
  await page.waitForFunction(() => window.xrDevice.activeSession !== undefined, { timeout });
  const hidden = await page.evaluate(() => document.getElementById('panel').hidden);
  if (!hidden) fail('the control panel stays over the page in VR');
  console.log('ok entered immersive-vr by the page\'s button, panel hidden');

  // 2. A scripted head trajectory: the head moves 0.1 m right over a second and turns 10° left, as the
  // headset's frame loop samples it. The server receives the headset's poses (their seq comes back with
  // frames) and renders where the head is.
  const seqBefore = await page.evaluate(() => window.vclassroom.seq);
  // (The session's local space starts at the head: positions are set relative to where it was.)
  await page.evaluate(() => {
    const t0 = performance.now(), p0 = window.xrDevice.position, [x0, y0, z0] = [p0.x, p0.y, p0.z];
    window.headPath = setInterval(() => {
      const s = Math.min(1, (performance.now() - t0) / 1000), h = 10 * s * Math.PI / 360;
      window.xrDevice.position.set(x0 + 0.1 * s, y0, z0);
      window.xrDevice.quaternion.set(0, Math.sin(h), 0, Math.cos(h));
    }, 16);
  });
  await page.waitForFunction(() => {
    const p = window.vclassroom.stats.lastShownPose;
    return p && Math.abs(p.position[0] - 0.1) < 1e-3;
  }, { timeout });
  const headSeq = await page.evaluate(() => { clearInterval(window.headPath); return window.vclassroom.seq; });
  await shownFor(page, headSeq);
  const head = await page.evaluate(() => ({ pose: window.vclassroom.stats.lastShownPose,
                                            view: window.vclassroom.poseToView(window.vclassroom.stats.lastShownPose.position,
                                                                               window.vclassroom.stats.lastShownPose.orientation) }));
  if (!(headSeq > seqBefore + 2)) fail(`the headset sent ${headSeq - seqBefore} poses in its second of moving`);
  if (Math.abs(head.view.yaw + 10) > 0.1) fail(`the frame shown is not rendered for the head turned 10° left: ${JSON.stringify(head)}`);
  console.log(`ok head path: ${headSeq - seqBefore} headset poses sent, the last rendered at x ` +
              `${head.pose.position[0].toFixed(3)} m, yaw ${head.view.yaw.toFixed(1)}°`);

  // 3. Both eyes: after the page's XR frame callback drew, each half of the XR layer holds the received
  // frame (compared with the video drawn into a 2D canvas of the same size).
  const eyes = await page.evaluate(() => new Promise(resolve => {
    const session = window.xrDevice.activeSession;
    session.requestAnimationFrame(() => {
      const canvas = window.xrDevice.appCanvas;
      const gl = canvas.getContext('webgl');
      const w = gl.drawingBufferWidth, h = gl.drawingBufferHeight, half = Math.floor(w / 2);
      const pixels = new Uint8Array(w * h * 4);
      gl.bindFramebuffer(gl.FRAMEBUFFER, null);
      gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, pixels);
      const video = document.getElementById('view');
      const ref = document.createElement('canvas');
      ref.width = half; ref.height = h;
      const g = ref.getContext('2d');
      g.drawImage(video, 0, 0, half, h);
      const want = g.getImageData(0, 0, half, h).data;
      // readPixels rows go bottom-up; the 2D canvas's top-down. Every 4th pixel is enough.
      const differ = x0 => {
        let sum = 0, n = 0;
        for (let y = 0; y < h; y += 4)
          for (let x = 0; x < half; x += 4, ++n)
            for (let c = 0; c < 3; ++c)
              sum += Math.abs(pixels[(y * w + x0 + x) * 4 + c] - want[((h - 1 - y) * half + x) * 4 + c]);
        return sum / (n * 3);
      };
      resolve({ width: w, height: h, left: differ(0), right: differ(half) });
    });
  }));
  if (!(eyes.left < 12 && eyes.right < 12)) fail(`the eyes do not show the received frame: ${JSON.stringify(eyes)}`);
  console.log(`ok both eyes show the view (${eyes.width}x${eyes.height} layer; mean difference ` +
              `${eyes.left.toFixed(1)}, ${eyes.right.toFixed(1)})`);

  // 4. Pose to photon on the headset's path: one sample per headset pose shown, none negative.
  const latency = await page.evaluate(() => window.vclassroom.stats.latencyMs.slice());
  const negative = await page.evaluate(() => window.vclassroom.stats.negativeLatency);
  const sorted = latency.slice().sort((a, b) => a - b);
  if (sorted.length < 3 || negative !== 0) fail(`pose-to-photon samples: ${JSON.stringify(latency)}, ${negative} negative`);
  console.log(`ok pose to photon in VR: p50 ${sorted[Math.floor(sorted.length / 2)].toFixed(0)} ms over ${sorted.length} poses`);

  // 5. Leaving VR ends the session cleanly: the panel is back, and the mouse steers again.
  await page.evaluate(() => window.xrDevice.activeSession.end());
  await page.waitForFunction(() => window.xrDevice.activeSession === undefined && !document.getElementById('panel').hidden,
                             { timeout });
  const seqOut = await page.evaluate(() => window.vclassroom.seq);
  await page.mouse.move(480, 270);
  await page.mouse.down();
  await page.mouse.move(520, 270, { steps: 4 });
  await page.mouse.up();
  const seqDrag = await page.evaluate(() => window.vclassroom.seq);
  if (!(seqDrag > seqOut)) fail('after leaving VR the mouse sends no pose');
  await shownFor(page, seqDrag);
  // The headset's frame loop has stopped: no pose is sent while nothing moves.
  const still = await page.evaluate(() => new Promise(resolve => {
    const before = window.vclassroom.seq;
    requestAnimationFrame(() => requestAnimationFrame(() => resolve(window.vclassroom.seq - before)));
  }));
  if (still !== 0) fail(`${still} poses sent after leaving VR with nothing moving`);
  if (errors.length) fail(`page errors: ${errors.join('; ')}`);
  console.log(`ok left VR: panel back, the mouse steers (seq ${seqOut} -> ${seqDrag}), no page error`);
} finally {
  await chromium.close();
}
