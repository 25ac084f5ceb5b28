// Two lecturers speak at once, each through their own browser's microphone (Chromium's fake capture device
// playing a file of one tone each: FIRST_WAV and SECOND_WAV); the first then leaves while the second goes on.
// The server's voice pad (read back by the C++ test) must carry both tones mixed, then the second alone.
//   node two-voices-test.mjs BASE_URL TOKEN FIRST_WAV SECOND_WAV
// Prints "ok ..." lines and "left at MS" (ms since the epoch) when the first lecturer has left.
import { timeout, fail, waitForServer, launchChromium, openLecturer } from './browser-util.mjs';

const [base, token, firstWav, secondWav] = process.argv.slice(2);
await waitForServer(base);
const browsers = [];
const speaker = async (wav, label) => {
  const chromium = await launchChromium(['--use-fake-device-for-media-stream', '--use-fake-ui-for-media-stream',
                                         `--use-file-for-fake-audio-capture=${wav}`]);
  browsers.push(chromium);
  return openLecturer(chromium.browser, base, token, label);
};
const speaking = page => page.waitForFunction(() => {
  const v = window.vclassroom && window.vclassroom.stats.voiceOut;
  return window.vclassroom && window.vclassroom.stats.microphone === 'on' && v && v.packetsSent > 150;
}, { timeout });
try {
  const first = await speaker(firstWav, 'first');
  const second = await speaker(secondWav, 'second');
  await Promise.all([speaking(first), speaking(second)]);
  console.log('ok both speak');
  // Both speak together a while longer (five more seconds of packets), then the first leaves.
  const sent = await first.evaluate(() => window.vclassroom.stats.voiceOut.packetsSent);
  await first.waitForFunction(n => window.vclassroom.stats.voiceOut.packetsSent > n + 250, { timeout }, sent);
  const left = await first.evaluate(() => window.vclassroom.leave());
  if (left !== 200) fail(`the first lecturer's DELETE gave ${left}`);
  console.log(`left at ${Date.now()}`);
  await browsers[0].close();
  // The second goes on speaking: five more seconds of its packets.
  const more = await second.evaluate(() => window.vclassroom.stats.voiceOut.packetsSent);
  await second.waitForFunction(n => window.vclassroom.stats.voiceOut.packetsSent > n + 250, { timeout }, more);
  console.log('ok the second speaks on after the first left');
} finally {
  for (const b of browsers) await b.close().catch(() => {});
}
