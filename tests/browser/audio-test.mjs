// Sound both ways between the classroom and the lecturer's page: the server (whepviewsink with its audio pad
// fed by a test tone) sends Opus on the session and the page plays it; the page sends its microphone
// (Chromium's fake capture device, a beep) to the server's voice pad (the C++ test checks what came out).
// Chromium runs with autoplay allowed (as after the lecturer's first click). A second lecturer refuses the
// microphone (the browser's permission set to denied): the lesson goes on and the page says so.
//   node audio-test.mjs BASE_URL TOKEN
// Prints one "ok ..." line per check, exits non-zero at the first failure. Waits on page conditions.
import { timeout, fail, waitForServer, launchChromium, openLecturer } from './browser-util.mjs';

const [base, token] = process.argv.slice(2);
await waitForServer(base);
const chromium = await launchChromium(['--autoplay-policy=no-user-gesture-required', '--use-fake-device-for-media-stream',
                                       '--use-fake-ui-for-media-stream']);
let refusing = null;
try {
  const page = await openLecturer(chromium.browser, base, token, 'page');
  await page.waitForFunction(() => window.vclassroom && window.vclassroom.stats.framesShown > 10, { timeout });
  const answer = await page.evaluate(async () => (await window.vclassroom.joined).pc.remoteDescription.sdp);
  // The answer's audio section: Opus, both ways (the server has the classroom's sound and a loudspeaker).
  const audioSection = (answer.split(/\r\nm=/).find(m => m.startsWith('audio ')) || '');
  if (!/a=rtpmap:\d+ OPUS\/48000\/2/i.test(audioSection) || !/a=sendrecv/.test(audioSection))
    fail(`the answer's audio section is not Opus both ways: ${audioSection}`);
  console.log('ok the answer sends Opus and takes the microphone');
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
  // The lecturer's voice: the microphone opened after joining and its sound leaves for the classroom.
  await page.waitForFunction(() => {
    const v = window.vclassroom.stats.voiceOut;
    return window.vclassroom.stats.microphone === 'on' && v && v.packetsSent > 150;
  }, { timeout });
  console.log(`ok voice sent: ${await page.evaluate(() => window.vclassroom.stats.voiceOut.packetsSent)} packets`);

  // A lecturer who refuses the microphone still gets the view and the sound, and is told the class does
  // not hear them.
  // (A browser of their own, whose microphone permission is set to denied: no fake prompt that accepts.)
  refusing = await launchChromium(['--autoplay-policy=no-user-gesture-required', '--use-fake-device-for-media-stream']);
  const cdp = await refusing.browser.target().createCDPSession();
  await cdp.send('Browser.setPermission', { permission: { name: 'microphone' }, setting: 'denied',
                                            origin: new URL(base).origin });
  const other = await refusing.browser.newPage();
  await other.goto(`${base}/?token=${encodeURIComponent(token)}`);
  await other.waitForFunction(() => window.vclassroom && window.vclassroom.stats.microphone !== undefined &&
                                    window.vclassroom.stats.framesShown > 10, { timeout });
  const refused = await other.evaluate(() => ({ mic: window.vclassroom.stats.microphone,
                                                said: document.getElementById('micstatus').textContent }));
  if (refused.mic !== 'NotAllowedError' || !refused.said.includes('does not hear you'))
    fail(`a refused microphone: ${JSON.stringify(refused)}`);
  await other.waitForFunction(() => window.vclassroom.stats.soundIn && window.vclassroom.stats.soundIn.packetsReceived > 50,
                              { timeout });
  console.log(`ok microphone refused: the view and the sound go on, the page says '${refused.said}'`);
} finally {
  await chromium.close();
  if (refusing) await refusing.close();
}
