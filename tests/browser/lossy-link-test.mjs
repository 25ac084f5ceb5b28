// A lecturer on a lossy link (the server runs with tools/lossy_udp.cpp preloaded, dropping a share of the
// video packets it sends):
//   node lossy-link-test.mjs BASE_URL TOKEN FRAMES
// Passes once the answer names the RTX stream (payload and SSRC), and the page has shown FRAMES frames after
// joining while packets went missing and the browser got them again: it asked (NACK) and the server sent
// them on the RTX stream. Without the retransmissions a
// lost packet spoils its frame and the frames after it until the next key frame: the picture freezes.
// Prints one "ok ..." line; exits non-zero on failure. Waits on page conditions, never on fixed sleeps.
import { timeout, fail, waitForServer, launchChromium, openLecturer } from './browser-util.mjs';

const [base, token, frames] = process.argv.slice(2);
await waitForServer(base);
const chromium = await launchChromium();
try {
  const page = await openLecturer(chromium.browser, base, token, 'lecturer');
  await page.waitForFunction(() => window.vclassroom && window.vclassroom.stats.framesShown > 0, { timeout });
  // The answer names the RTX stream with its SSRC (RFC 4588's FID group): without it Chromium decodes the
  // frames but shows none.
  const answer = await page.evaluate(async () => (await window.vclassroom.joined).pc.remoteDescription.sdp);
  if (!/^a=rtpmap:\d+ rtx\/90000/m.test(answer) || !/^a=ssrc-group:FID \d+ \d+/m.test(answer))
    fail(`the answer names no RTX stream with its SSRC:\n${answer}`);
  const start = await page.evaluate(() => window.vclassroom.stats.framesShown);
  await page.waitForFunction((start, frames) => window.vclassroom.stats.framesShown - start >= frames,
                             { timeout: 4 * timeout, polling: 250 }, start, Number(frames));
  const r = await page.evaluate(async () => {
    const { pc } = await window.vclassroom.joined;
    let inbound = null;
    (await pc.getStats()).forEach(s => { if (s.type === 'inbound-rtp' && s.kind === 'video') inbound = s; });
    return inbound;
  });
  if (!r) fail('no inbound video statistics');
  const line = `${r.packetsReceived} packets received, ${r.packetsLost} lost, ${r.nackCount} NACKs sent, ` +
               `${r.retransmittedPacketsReceived} retransmissions received, ${r.pliCount} key frames asked for, ` +
               `${r.freezeCount} freezes (${r.totalFreezesDuration.toFixed(2)} s) in ${r.framesDecoded} frames`;
  if (!(r.packetsLost > 0)) fail(`no packet went missing: ${line}`);
  if (!(r.retransmittedPacketsReceived > 0)) fail(`nothing was sent again: ${line}`);
  console.log(`ok repaired: ${line}`);
} catch (e) {
  fail(`the picture did not go on over the lossy link: ${e.message}`);
} finally {
  await chromium.close();
}
