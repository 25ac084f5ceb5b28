// A lecturer joining the lesson pipelines/lesson.sh started:
//   node lesson-test.mjs BASE_URL TOKEN WIDTH HEIGHT
// Prints one "ok ..." line per check, exits non-zero at the first failure. Waits on conditions in the
// page (waitForFunction), never on fixed sleeps.
import { timeout, fail, waitForServer, launchChromium, openLecturer, picture, difference }
  from './browser-util.mjs';

const [base, token, width, height] = process.argv.slice(2);
await waitForServer(base);
const framesOver = (page, n) =>
  page.waitForFunction(k => window.vclassroom && window.vclassroom.stats.framesShown > k, { timeout: 4 * timeout }, n);

const chromium = await launchChromium();
try {
  const page = await openLecturer(chromium.browser, base, token, 'lecturer');
  await framesOver(page, 10);
  const size = await page.evaluate(() => [window.vclassroom.stats.width, window.vclassroom.stats.height]);
  if (size[0] !== Number(width) || size[1] !== Number(height)) fail(`frames of ${size}, expected ${width}x${height}`);
  console.log(`ok joined, frames ${size[0]}x${size[1]}`);
  // The learners move: without a pose from the lecturer, later frames still show another picture.
  const first = await picture(page);
  const shown = await page.evaluate(() => window.vclassroom.stats.framesShown);
  let d = 0;
  for (let more = 15; more <= 150 && !(d > 1); more += 15) {
    await framesOver(page, shown + more);
    d = difference(first, await picture(page));
  }
  if (!(d > 1)) fail(`the picture stays the same over 150 frames (mean difference ${d})`);
  const seen = difference(first, first.map(() => 0));
  if (!(seen > 20)) fail(`the picture is dark (mean ${seen}): no camera seen`);
  console.log(`ok the classroom moves: mean difference ${d.toFixed(1)} grey levels, mean level ${seen.toFixed(0)}`);
} catch (e) {
  fail(e.stack || String(e));
} finally {
  await chromium.close();
}
