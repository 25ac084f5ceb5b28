// What the browser test scripts share: failing, waiting for the server, the system Chromium, and a page's
// picture. Waits are on conditions (a server that answers, page state), never fixed sleeps.
import puppeteer from 'puppeteer-core';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';

export const timeout = 60000;
export const fail = message => { console.error('FAIL ' + message); process.exit(1); };

// The server may still be starting: wait until it answers (bounded).
export async function waitForServer(base) {
  for (let tries = 0; ; ++tries) {
    try { await fetch(`${base}/`); return; } catch (e) {
      if (tries > 600) fail(`no server at ${base}`);
      await new Promise(resolve => setTimeout(resolve, 100));  // retry interval of a connection poll, not a sync point
    }
  }
}

// Headless system Chromium with a throw-away profile; close() removes it.
export async function launchChromium() {
  const profile = fs.mkdtempSync(path.join(os.tmpdir(), 'vclassroom-chromium-'));
  const browser = await puppeteer.launch({
    executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
    headless: true,
    args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-background-networking',
           '--disable-component-update', '--disable-sync', '--no-first-run', `--user-data-dir=${profile}`],
  });
  return { browser, close: async () => { await browser.close(); fs.rmSync(profile, { recursive: true, force: true }); } };
}

// A page of the lecturer's site, joined with `token`, its console echoed with `label`.
export async function openLecturer(browser, base, token, label = 'page') {
  const page = await browser.newPage();
  await page.setViewport({ width: 960, height: 540 });
  page.on('console', m => console.log(`${label}: ${m.text()}`));
  await page.goto(`${base}/?token=${encodeURIComponent(token)}`);
  return page;
}

// The shown frame's pixels, drawn into a 160x90 canvas.
export const picture = page => page.evaluate(() => {
  const v = document.getElementById('view');
  const c = document.createElement('canvas');
  c.width = 160; c.height = 90;
  const g = c.getContext('2d');
  g.drawImage(v, 0, 0, 160, 90);
  return Array.from(g.getImageData(0, 0, 160, 90).data);
});
export const difference = (a, b) => a.reduce((s, x, i) => s + Math.abs(x - b[i]), 0) / a.length;

// Waits until the page's frames shown are rendered for seq >= `seq`.
export const shownFor = (page, seq) =>
  page.waitForFunction(s => window.vclassroom.stats.lastSeqShown >= s, { timeout }, seq);
