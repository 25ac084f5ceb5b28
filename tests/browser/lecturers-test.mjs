// Several lecturers against a running whepviewsink (max-sessions=2):
//   node lecturers-test.mjs BASE_URL TOKEN WIDTH HEIGHT
// Prints one "ok ..." line per check, exits non-zero at the first failure.
// Waits on conditions in the pages (waitForFunction), never on fixed sleeps.
import { timeout, fail, waitForServer, launchChromium, openLecturer, picture, difference, shownFor }
  from './browser-util.mjs';

const [base, token, width, height] = process.argv.slice(2);
await waitForServer(base);

const framesOver = (page, n) =>
  page.waitForFunction(k => window.vclassroom && window.vclassroom.stats.framesShown > k, { timeout }, n);
// A headset-style pose through the page's own pose path: `x` metres right of the rig origin, level.
const poseAt = (page, x) => page.evaluate(x => {
  window.vclassroom.onXRPose({ x, y: 0, z: 0 }, { x: 0, y: 0, z: 0, w: 1 });
  return window.vclassroom.seq;
}, x);
const echoedX = page => page.evaluate(() => window.vclassroom.stats.lastShownPose.position[0]);

// Each lecturer in a browser of their own, as on their own machines (a page behind another in one browser
// is not drawn, so its frames would never count as shown).
const browsers = [];
const lecturer = async label => {
  const chromium = await launchChromium();
  browsers.push(chromium);
  return openLecturer(chromium.browser, base, token, label);
};
try {
  // 1. Two lecturers join; each decodes its own stream at the view's size.
  const a = await lecturer('A');
  const b = await lecturer('B');
  await Promise.all([framesOver(a, 10), framesOver(b, 10)]);
  const size = await a.evaluate(() => [window.vclassroom.stats.width, window.vclassroom.stats.height]);
  if (size[0] !== Number(width) || size[1] !== Number(height)) fail(`frames of ${size}, expected ${width}x${height}`);
  console.log(`ok two joined, frames ${size[0]}x${size[1]}`);

  // 2. Different poses, different views: A 0.15 m left, B 0.15 m right. Each page's frames are rendered
  // for its own pose (the echo names it) and the pictures differ.
  const [seqA, seqB] = [await poseAt(a, -0.15), await poseAt(b, 0.15)];
  await Promise.all([shownFor(a, seqA), shownFor(b, seqB)]);
  const [xa, xb] = [await echoedX(a), await echoedX(b)];
  if (Math.abs(xa + 0.15) > 1e-3 || Math.abs(xb - 0.15) > 1e-3) fail(`echoed x: A ${xa}, B ${xb}; expected -0.15 and 0.15`);
  const d = difference(await picture(a), await picture(b));
  if (!(d > 2)) fail(`A and B show the same picture (mean difference ${d})`);
  console.log(`ok own views: A rendered at x ${xa.toFixed(3)} m, B at ${xb.toFixed(3)} m, pictures differ by ${d.toFixed(1)}`);

  // 3. The cap: a third lecturer is refused while two watch.
  const third = await fetch(`${base}/whep?token=${encodeURIComponent(token)}`,
                            { method: 'POST', headers: { 'Content-Type': 'application/sdp' }, body: 'v=0\r\n' });
  if (third.status !== 503) fail(`a third lecturer got ${third.status}, expected 503`);
  console.log('ok third refused: 503');

  // 4. A leaves: B's view goes on (and still follows B), and a new page joins in A's place.
  const left = await a.evaluate(() => window.vclassroom.leave());
  if (left !== 200) fail(`A's DELETE gave ${left}`);
  await a.close();
  const shown = await b.evaluate(() => window.vclassroom.stats.framesShown);
  const seqB2 = await poseAt(b, 0.05);
  await framesOver(b, shown + 10);
  await shownFor(b, seqB2);
  if (Math.abs(await echoedX(b) - 0.05) > 1e-3) fail('B no longer follows its own pose after A left');
  console.log('ok one left, the other goes on');
  const c = await lecturer('C');
  await framesOver(c, 10);
  console.log('ok a new page joined in the freed place');
} finally {
  for (const chromium of browsers) await chromium.close();
}
