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

// Headless system Chromium with a throw-away profile, and `extraArgs`; close() removes the profile.
export async function launchChromium(extraArgs = []) {
  const profile = fs.mkdtempSync(path.join(os.tmpdir(), 'vclassroom-chromium-'));
  const browser = await puppeteer.launch({
    executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
    headless: true,
    args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-background-networking',
           '--disable-component-update', '--disable-sync', '--no-first-run', `--user-data-dir=${profile}`, ...extraArgs],
  });
  return { browser, close: async () => { await browser.close(); fs.rmSync(profile, { recursive: true, force: true }); } };
}

// A page of the lecturer's site, joined with `token`, its console echoed with `label`.
// `beforeLoad(page)`, if given, runs before the page loads (e.g. to intercept its requests).
export async function openLecturer(browser, base, token, label = 'page', beforeLoad = null) {
  const page = await browser.newPage();
  await page.setViewport({ width: 960, height: 540 });
  page.on('console', m => console.log(`${label}: ${m.text()}`));
  if (beforeLoad) await beforeLoad(page);
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

// Stand-ins for a STUN and a TURN server at `host`, answering the real STUN messages (RFC 8489) the
// server's ICE agent (libnice) and Chromium send, each counted with its sender's SOFTWARE attribute
// (`bindings`, `allocations`): a Binding request gets a success response whose XOR-MAPPED-ADDRESS is
// `mapped` (an address a NAT might show) at the sender's port; a TURN Allocate request is challenged (401
// with a realm and nonce, as a real TURN server does) and, once it comes with the long-term credential
// (user alice, password s3cret), refused with an authenticated 403 (Chromium ignored an unauthenticated
// one), so no relay is made. close() stops both.
export async function startFakeIceServers(host, stunPort, turnPort, mapped = '203.0.113.7') {
  const dgram = await import('node:dgram');
  const zlib = await import('node:zlib');
  if (typeof zlib.crc32 !== 'function')
    fail(`the STUN stand-ins need zlib.crc32 (Node.js 20.15 or later; this is ${process.version})`);
  const crypto = await import('node:crypto');
  const realm = 'vclassroom-test', nonce = 'f1xed-n0nce';
  const key = crypto.createHash('md5').update(`alice:${realm}:s3cret`).digest();
  const cookie = 0x2112a442;
  const attribute = (type, value) => {
    const padded = Buffer.alloc(4 + Math.ceil(value.length / 4) * 4);
    padded.writeUInt16BE(type, 0);
    padded.writeUInt16BE(value.length, 2);
    value.copy(padded, 4);
    return padded;
  };
  // With `integrityKey`, a MESSAGE-INTEGRITY (HMAC-SHA1 over what precedes it) before the FINGERPRINT.
  const message = (type, transaction, attributes, integrityKey) => {
    let body = Buffer.concat(attributes);
    const header = Buffer.alloc(20);
    header.writeUInt16BE(type, 0);
    header.writeUInt32BE(cookie, 4);
    transaction.copy(header, 8);
    if (integrityKey) {
      header.writeUInt16BE(body.length + 24, 2);
      const hmac = crypto.createHmac('sha1', integrityKey).update(Buffer.concat([header, body])).digest();
      body = Buffer.concat([body, attribute(0x0008, hmac)]);
    }
    header.writeUInt16BE(body.length + 8, 2);  // with the fingerprint
    const unsigned = Buffer.concat([header, body]);
    const crc = Buffer.alloc(4);
    crc.writeUInt32BE((zlib.crc32(unsigned) ^ 0x5354554e) >>> 0, 0);
    return Buffer.concat([unsigned, attribute(0x8028, crc)]);
  };
  const parse = packet => {
    if (packet.length < 20 || packet.readUInt32BE(4) !== cookie) return null;
    const attributes = new Map();
    for (let at = 20; at + 4 <= packet.length;) {
      const type = packet.readUInt16BE(at), length = packet.readUInt16BE(at + 2);
      attributes.set(type, packet.subarray(at + 4, Math.min(packet.length, at + 4 + length)));
      at += 4 + Math.ceil(length / 4) * 4;
    }
    return { type: packet.readUInt16BE(0), transaction: packet.subarray(8, 20), attributes };
  };
  const allocations = [], bindings = [];
  const stun = dgram.createSocket('udp4'), turn = dgram.createSocket('udp4');
  stun.on('message', (packet, from) => {
    const m = parse(packet);
    if (!m || m.type !== 0x0001) return;
    const software = m.attributes.get(0x8022);
    bindings.push({ port: from.port, software: software ? software.toString() : '' });
    const value = Buffer.alloc(8);
    value.writeUInt16BE(0x0001, 0);
    value.writeUInt16BE(from.port ^ (cookie >>> 16), 2);
    const address = mapped.split('.').reduce((a, b) => a * 256 + Number(b), 0);
    value.writeUInt32BE((address ^ cookie) >>> 0, 4);
    stun.send(message(0x0101, m.transaction, [attribute(0x0020, value)]), from.port, from.address);
  });
  turn.on('message', (packet, from) => {
    const m = parse(packet);
    if (!m || m.type !== 0x0003) return;
    const software = m.attributes.get(0x8022), user = m.attributes.get(0x0006);
    allocations.push({ port: from.port, software: software ? software.toString() : '', user: user ? user.toString() : '' });
    const error = (code, reason) => attribute(0x0009, Buffer.concat([Buffer.from([0, 0, Math.floor(code / 100), code % 100]),
                                                                     Buffer.from(reason)]));
    const reply = user
      ? message(0x0113, m.transaction, [error(403, 'Forbidden')], key)
      : message(0x0113, m.transaction, [error(401, 'Unauthorized'), attribute(0x0014, Buffer.from(realm)),
                                        attribute(0x0015, Buffer.from(nonce))]);
    turn.send(reply, from.port, from.address);
  });
  await Promise.all([[stun, stunPort], [turn, turnPort]].map(([socket, port]) =>
    new Promise(resolve => socket.bind(Number(port), host, resolve))));
  return { allocations, bindings, close: () => { stun.close(); turn.close(); } };
}
