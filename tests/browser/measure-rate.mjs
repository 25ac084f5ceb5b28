// The measurement driver of tools/vclassroom-measure-rate (not a test), run inside tests/browser/slow-link.sh
// whose loopback is limited: one lecturer joins and watches for SECONDS while the page samples its inbound
// video statistics every second.
//   node measure-rate.mjs BASE_URL TOKEN SECONDS
// Prints one "sample {json}" line per second (the page's clock in ms, packets lost and received, frames
// shown and kbit/s received, all since the join), then "done".
import { timeout, fail, waitForServer, launchChromium, openLecturer } from './browser-util.mjs';

const [base, token, seconds] = process.argv.slice(2);
await waitForServer(base);
const chromium = await launchChromium();
try {
  const page = await openLecturer(chromium.browser, base, token, 'lecturer');
  await page.waitForFunction(() => window.vclassroom && window.vclassroom.stats.inbound, { timeout });
  // The page keeps its own samples, one per new statistics report, until the window is over.
  const samples = await page.evaluate(async seconds => {
    const s = window.vclassroom.stats, out = [];
    const t0 = performance.now();
    while (performance.now() - t0 < seconds * 1000) {
      const r = s.inbound;
      if (r && (!out.length || out[out.length - 1].t !== r.timestamp))
        out.push({ t: r.timestamp, lost: r.packetsLost, got: r.packetsReceived, shown: s.framesShown, kbps: s.kbps });
      await new Promise(resolve => setTimeout(resolve, 250));  // polling the page's statistics, not a synchronisation
    }
    return out;
  }, Number(seconds));
  for (const x of samples) console.log('sample ' + JSON.stringify(x));
  console.log('done');
} catch (e) {
  fail(String(e));
} finally {
  await chromium.close();
}
