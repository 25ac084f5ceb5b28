// A lecturer behind a slow link (run inside tests/browser/slow-link.sh, whose loopback is limited):
//   node slow-link-test.mjs BASE_URL TOKEN
// The server starts at its full bitrate, more than the link carries. Passes once the page has seen five
// seconds in which under 10 % of the video packets were lost and at least 15 frames were shown: the
// server's rate came down to what the link carries. Prints one "ok ..." line; exits non-zero on failure.
// Waits on page conditions, never on fixed sleeps.
import { fail, waitForServer, launchChromium, openLecturer } from './browser-util.mjs';

const [base, token] = process.argv.slice(2);
await waitForServer(base);
const chromium = await launchChromium();
try {
  const page = await openLecturer(chromium.browser, base, token, 'lecturer');
  // The page samples its inbound video statistics every second (stats.inbound); this keeps the samples and
  // looks at the last five seconds.
  const settled = await page.waitForFunction(() => {
    const s = window.vclassroom && window.vclassroom.stats, r = s && s.inbound;
    if (!r) return false;
    const w = window.slowLinkSamples || (window.slowLinkSamples = []);
    if (!w.length || w[w.length - 1].t !== r.timestamp)
      w.push({ t: r.timestamp, lost: r.packetsLost, got: r.packetsReceived, shown: s.framesShown, kbps: s.kbps });
    if (w.length < 6) return false;
    const a = w[w.length - 6], b = w[w.length - 1];
    const lost = b.lost - a.lost, got = b.got - a.got;
    if (got < 50 || lost / (lost + got) >= 0.10 || b.shown - a.shown < 15) return false;
    return { seconds: (b.t - w[0].t) / 1000, lost: lost / (lost + got), shown: b.shown - a.shown,
             kbps: w.slice(-5).reduce((sum, x) => sum + (x.kbps || 0), 0) / 5,
             firstKbps: Math.max(...w.slice(1, 4).map(x => x.kbps || 0)) };
  }, { timeout: 180000, polling: 250 });
  const r = await settled.jsonValue();
  console.log(`ok settled after ${r.seconds.toFixed(0)} s: ${(100 * r.lost).toFixed(1)} % lost, ` +
              `${r.shown} frames shown in 5 s, ${r.kbps.toFixed(0)} kbit/s received (at first ${r.firstKbps.toFixed(0)})`);
} catch (e) {
  fail(`the picture never settled behind the slow link: ${e.message}`);
} finally {
  await chromium.close();
}
