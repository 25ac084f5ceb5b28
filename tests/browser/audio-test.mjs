// The classroom's sound in the lecturer's page: the server (whepviewsink with its audio pad fed by a test
// tone) sends Opus on the session; the page plays it. Chromium runs with autoplay allowed (as after the
// lecturer's first click).
//   node audio-test.mjs BASE_URL TOKEN
// Prints one "ok ..." line per check, exits non-zero at the first failure. Waits on page conditions.
import { timeout, fail, waitForServer, launchChromium, openLecturer } from './browser-util.mjs';

const [base, token] = process.argv.slice(2);
await waitForServer(base);
const chromium = await launchChromium(['--autoplay-policy=no-user-gesture-required']);
try {
  const page = await openLecturer(chromium.browser, base, token, 'page');
  await page.waitForFunction(() => window.vclassroom && window.vclassroom.stats.framesShown > 10, { timeout });
  const answer = await page.evaluate(async () => (await window.vclassroom.joined).pc.remoteDescription.sdp);
  if (!/m=audio [^\r\n]*\r\n(?:[^m][^\r\n]*\r\n)*a=rtpmap:\d+ OPUS\/48000\/2/i.test(answer) || !/a=sendonly/.test(answer))
    fail(`the answer sends no Opus: ${answer}`);
  console.log('ok the answer sends Opus');
  // Sound arrives, is decoded and has energy (the tone), and the page plays it.
  await page.waitForFunction(() => {
    const a = window.vclassroom.stats.soundIn;
    return a && a.packetsReceived > 100 && a.totalAudioEnergy > 0 && window.vclassroom.stats.soundPlaying;
  }, { timeout });
  const sound = await page.evaluate(() => {
    const a = window.vclassroom.stats.soundIn;
    return { packets: a.packetsReceived, lost: a.packetsLost, energy: a.totalAudioEnergy, level: a.audioLevel };
  });
  console.log(`ok sound played: ${sound.packets} packets, ${sound.lost} lost, energy ${sound.energy.toFixed(3)}, ` +
              `level ${sound.level}`);
} finally {
  await chromium.close();
}
