// The classroom's sound keeps flowing while the view drops frames (the server's camera loses 90 % of its
// frames before the view) and packets are lost on the way (the server drops 5 % of its RTP): over five
// seconds of sound the page shows few frames, and the sound plays on (what was lost rebuilt from Opus in-band
// FEC or concealed). The page's microphone is allowed, and the server, which has no loudspeaker pad, does
// not take it: the page says so and nothing stops (an unlinked stream from the browser once stopped the
// whole server).
//   node audio-drops-test.mjs BASE_URL TOKEN
import { timeout, fail, waitForServer, launchChromium, openLecturer } from './browser-util.mjs';

const [base, token] = process.argv.slice(2);
await waitForServer(base);
const chromium = await launchChromium(['--autoplay-policy=no-user-gesture-required', '--use-fake-device-for-media-stream',
                                       '--use-fake-ui-for-media-stream']);
try {
  const page = await openLecturer(chromium.browser, base, token, 'page');
  await page.waitForFunction(() => window.vclassroom && window.vclassroom.stats.framesShown > 2 &&
                                   window.vclassroom.stats.soundIn, { timeout });
  const before = await page.evaluate(() => ({ frames: window.vclassroom.stats.framesShown,
                                              packets: window.vclassroom.stats.soundIn.packetsReceived }));
  // Five seconds of sound (Opus sends 50 packets a second).
  await page.waitForFunction(p => window.vclassroom.stats.soundIn.packetsReceived >= p + 250, { timeout },
                             before.packets);
  // (The page samples the receiver's statistics every second: wait for a sample after the window.)
  await page.waitForFunction(p => window.vclassroom.stats.soundIn.packetsReceived >= p + 300, { timeout },
                             before.packets);
  const after = await page.evaluate(() => {
    const a = window.vclassroom.stats.soundIn;
    return { frames: window.vclassroom.stats.framesShown, packets: a.packetsReceived, lost: a.packetsLost,
             concealed: a.concealedSamples, samples: a.totalSamplesReceived, energy: a.totalAudioEnergy };
  });
  const frames = after.frames - before.frames;
  if (frames > 70) fail(`${frames} frames shown: the view did not drop frames`);
  if (!(after.lost > 0) || !(after.energy > 0)) fail(`sound on a lossy link: ${JSON.stringify(after)}`);
  const mic = await page.evaluate(() => ({ state: window.vclassroom.stats.microphone,
                                          said: document.getElementById('micstatus').textContent }));
  if (mic.state !== 'not taken' || !mic.said.includes('does not hear you'))
    fail(`a microphone the server does not take: ${JSON.stringify(mic)}`);
  console.log(`ok sound flows while the view drops frames: ${after.packets - before.packets} sound packets ` +
              `(${after.lost} lost, ${after.concealed} of ${after.samples} samples concealed) while ${frames} ` +
              `frames were shown; the microphone not taken: '${mic.said}'`);
} finally {
  await chromium.close();
}
