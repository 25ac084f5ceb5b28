// The measurement driver of tools/vclassroom-measure-lecturers (not a test): N lecturers, each in a Chromium
// of their own, join a running whepviewsink and move their head like a headset (a new pose every 33 ms
// through the page's XR pose path) for SECONDS; then each reports frames shown, bitrate and pose-to-photon
// latency (the frame's expected display time minus the time its pose was taken, from the server's echo).
//   node measure-lecturers.mjs BASE_URL TOKEN N SECONDS
// Prints "window start" and "window end" around the measured window (the tool reads the server's CPU time
// there), then one "lecturer {json}" line each, with the video's packet, loss, retransmission, key-frame-request and
// freeze counters over the window.
import { timeout, fail, waitForServer, launchChromium, openLecturer } from './browser-util.mjs';

const [base, token, count, seconds] = process.argv.slice(2);
await waitForServer(base);
const browsers = [];
try {
  const pages = [];
  for (let i = 0; i < Number(count); ++i) {
    const chromium = await launchChromium();
    browsers.push(chromium);
    pages.push(await openLecturer(chromium.browser, base, token, `lecturer ${i}`));
  }
  for (const p of pages)
    await p.waitForFunction(() => window.vclassroom && window.vclassroom.stats.framesShown > 30, { timeout });
  // Each sways 0.1 m left and right and turns ±10° at its own pace, a pose every 33 ms.
  const start = async (p, i) => p.evaluate(i => {
    const t0 = performance.now();
    window.swaying = setInterval(() => {
      const t = (performance.now() - t0) / 1000, h = 10 * Math.sin(t * (0.7 + 0.1 * i)) * Math.PI / 360;
      window.vclassroom.onXRPose({ x: 0.1 * Math.sin(t * (1 + 0.2 * i)), y: 0, z: 0 },
                                 { x: 0, y: Math.sin(h), z: 0, w: Math.cos(h) });
    }, 33);
  }, i);
  await Promise.all(pages.map(start));
  // The first second of swaying fills the pipeline; then the window.
  await new Promise(resolve => setTimeout(resolve, 1000));  // a measurement window, not a synchronisation
  // The video's counters (the page samples them every second), read at both ends of the window.
  await Promise.all(pages.map(p => p.evaluate(() => {
    window.videoCounters = () => {
      const r = window.vclassroom.stats.inbound || {};
      return Object.fromEntries(['packetsReceived', 'packetsLost', 'retransmittedPacketsReceived', 'pliCount',
                                 'freezeCount', 'totalFreezesDuration'].map(k => [k, r[k] || 0]));
    };
  })));
  const before = await Promise.all(pages.map(p => p.evaluate(() => {
    for (const key of ['latencyMs', 'serverMs', 'jitterMs', 'decodeMs', 'receiveMs', 'displayMs'])
      window.vclassroom.stats[key].length = 0;
    return { shown: window.vclassroom.stats.framesShown, t: performance.now(), counters: window.videoCounters() };
  })));
  console.log('window start');
  await new Promise(resolve => setTimeout(resolve, Number(seconds) * 1000));  // the measured window
  console.log('window end');
  for (let i = 0; i < pages.length; ++i) {
    const r = await pages[i].evaluate(() => {
      clearInterval(window.swaying);
      const s = window.vclassroom.stats;
      return { shown: s.framesShown, t: performance.now(), latency: s.latencyMs.slice(), server: s.serverMs.slice(),
               jitter: s.jitterMs.slice(), decode: s.decodeMs.slice(), kbps: s.kbps,
               receive: s.receiveMs.slice(), display: s.displayMs.slice(), counters: window.videoCounters() };
    });
    const counted = k => r.counters[k] - before[i].counters[k];
    const quantile = (values, q) => {
      const sorted = values.slice().sort((a, b) => a - b);
      return sorted.length ? sorted[Math.min(sorted.length - 1, Math.floor(q * sorted.length))] : NaN;
    };
    console.log('lecturer ' + JSON.stringify({
      lecturer: i, fps: (r.shown - before[i].shown) / ((r.t - before[i].t) / 1000), frames: r.shown - before[i].shown,
      kbps: r.kbps, samples: r.latency.length, p50: quantile(r.latency, 0.5), p99: quantile(r.latency, 0.99),
      server_p50: quantile(r.server, 0.5), jitter_p50: quantile(r.jitter, 0.5), decode_p50: quantile(r.decode, 0.5),
      receive_p50: quantile(r.receive, 0.5), display_p50: quantile(r.display, 0.5),
      packets: counted('packetsReceived'), lost: counted('packetsLost'), resent: counted('retransmittedPacketsReceived'),
      key_frames_asked: counted('pliCount'), freezes: counted('freezeCount'),
      frozen_s: counted('totalFreezesDuration') }));
  }
} catch (e) {
  fail(String(e));
} finally {
  for (const chromium of browsers) await chromium.close();
}
