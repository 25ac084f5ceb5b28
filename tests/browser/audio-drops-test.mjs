// The classroom's sound keeps flowing while the view drops frames (the server's camera loses 90 % of its
// frames before the view): over five seconds of sound the page shows few frames.
//   node audio-drops-test.mjs BASE_URL TOKEN
import { timeout, fail, waitForServer, launchChromium, openLecturer } from './browser-util.mjs';

const [base, token] = process.argv.slice(2);
await waitForServer(base);
const chromium = await launchChromium(['--autoplay-policy=no-user-gesture-required']);
try {
  const page = await openLecturer(chromium.browser, base, token, 'page');
  await page.waitForFunction(() => window.vclassroom && window.vclassroom.stats.framesShown > 2 &&
                                   window.vclassroom.stats.soundIn, { timeout });
  const before = await page.evaluate(() => ({ frames: window.vclassroom.stats.framesShown,
                                              packets: window.vclassroom.stats.soundIn.packetsReceived }));
  // Five seconds of sound (Opus sends 50 packets a second).
  await page.waitForFunction(p => window.vclassroom.stats.soundIn.packetsReceived >= p + 250, { timeout },
                             before.packets);
  const after = await page.evaluate(() => ({ frames: window.vclassroom.stats.framesShown,
                                             packets: window.vclassroom.stats.soundIn.packetsReceived,
                                             lost: window.vclassroom.stats.soundIn.packetsLost }));
  const frames = after.frames - before.frames;
  if (frames > 60) fail(`${frames} frames shown: the view did not drop frames`);
  console.log(`ok sound flows while the view drops frames: ${after.packets - before.packets} sound packets ` +
              `(${after.lost} lost) while ${frames} frames were shown`);
} finally {
  await chromium.close();
}
