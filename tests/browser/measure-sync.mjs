// The measurement driver of tools/vclassroom-measure-sync (not a test): one lecturer's page in headless
// Chromium (sound allowed to play at once, as after the lecturer's first click) joins the server, and for
// SECONDS notes when each clap shows and sounds: the picture's flash (the shown frame turns white, timed at
// its expected display) and the sound's tick (the received audio rising from silence, timed where the page's
// audio graph plays it). Prints "flash MS" and "click MS" lines (ms since the epoch: the page's time origin
// plus its clock, which the tool compares with the server's), then "frames N sound-packets N" over the
// window.
//   node measure-sync.mjs BASE_URL TOKEN SECONDS
import { timeout, fail, waitForServer, launchChromium, openLecturer } from './browser-util.mjs';

const [base, token, seconds] = process.argv.slice(2);
await waitForServer(base);
const chromium = await launchChromium(['--autoplay-policy=no-user-gesture-required']);
try {
  const page = await openLecturer(chromium.browser, base, token, 'page');
  await page.waitForFunction(() => window.vclassroom && window.vclassroom.stats.framesShown > 10 &&
                                   window.vclassroom.stats.soundPlaying, { timeout });
  // The first seconds settle the receivers (the sound's jitter buffer stretches and squeezes it meanwhile).
  await new Promise(resolve => setTimeout(resolve, 10000));  // a warm-up, not a synchronisation
  await page.evaluate(() => {
    window.claps = { flashes: [], clicks: [] };
    // The picture: the first frame of a flash (its mean near white) after one that is not.
    const video = document.getElementById('view');
    const canvas = document.createElement('canvas');
    canvas.width = 16; canvas.height = 9;
    const g = canvas.getContext('2d', { willReadFrequently: true });
    let white = false;
    const onFrame = (now, meta) => {
      g.drawImage(video, 0, 0, 16, 9);
      const px = g.getImageData(0, 0, 16, 9).data;
      let sum = 0;
      for (let i = 0; i < px.length; i += 4) sum += px[i] + px[i + 1] + px[i + 2];
      const isWhite = sum / (16 * 9 * 3) > 200;
      if (isWhite && !white) window.claps.flashes.push(meta.expectedDisplayTime);
      white = isWhite;
      video.requestVideoFrameCallback(onFrame);
    };
    video.requestVideoFrameCallback(onFrame);
    // The sound: the first sample above a tenth of full scale after a second of quiet, at the time the audio
    // graph plays it (its context time mapped to the page's clock).
    const context = new AudioContext();
    const source = context.createMediaStreamSource(document.getElementById('sound').srcObject);
    const processor = context.createScriptProcessor(256, 1, 1);
    const mute = context.createGain();
    mute.gain.value = 0;
    let quietSince = 0;
    processor.onaudioprocess = e => {
      const x = e.inputBuffer.getChannelData(0), rate = e.inputBuffer.sampleRate;
      for (let i = 0; i < x.length; ++i) {
        const t = e.playbackTime + i / rate;
        if (Math.abs(x[i]) < 0.1) continue;
        if (t - quietSince > 1) {
          const stamp = context.getOutputTimestamp();
          window.claps.clicks.push(stamp.performanceTime + (t - stamp.contextTime) * 1000);
        }
        quietSince = t;
      }
    };
    source.connect(processor);
    processor.connect(mute);
    mute.connect(context.destination);
    window.clapWindow = { frames: window.vclassroom.stats.framesShown };
  });
  await new Promise(resolve => setTimeout(resolve, Number(seconds) * 1000));  // the measured window
  const claps = await page.evaluate(() => ({ ...window.claps, frames: window.vclassroom.stats.framesShown - window.clapWindow.frames,
                                             sound: window.vclassroom.stats.soundIn ? window.vclassroom.stats.soundIn.packetsReceived : 0 }));
  const origin = await page.evaluate(() => performance.timeOrigin);
  for (const t of claps.flashes) console.log(`flash ${(origin + t).toFixed(2)}`);
  for (const t of claps.clicks) console.log(`click ${(origin + t).toFixed(2)}`);
  console.log(`frames ${claps.frames} sound-packets ${claps.sound}`);
} catch (e) {
  fail(String(e));
} finally {
  await chromium.close();
}
