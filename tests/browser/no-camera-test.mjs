// A server with no camera sending (started before its cameras, or their ports wrong): the page joins and,
// rather than a black view that only says "joined", says no camera is sending.
//   node no-camera-test.mjs BASE_URL TOKEN
import { timeout, fail, waitForServer, launchChromium, openLecturer } from './browser-util.mjs';

const [base, token] = process.argv.slice(2);
await waitForServer(base);
const chromium = await launchChromium();
try {
  const page = await openLecturer(chromium.browser, base, token, 'page');
  try {
    await page.waitForFunction(() => document.getElementById('status').textContent.includes('no camera is sending'),
                               { timeout });
  } catch (e) {
    fail(`the page says '${await page.evaluate(() => document.getElementById('status').textContent)}'`);
  }
  const shown = await page.evaluate(() => window.vclassroom.stats.framesShown);
  if (shown !== 0) fail(`${shown} frames shown without a camera`);
  console.log(`ok no camera: '${await page.evaluate(() => document.getElementById('status').textContent)}'`);
} finally {
  await chromium.close();
}
