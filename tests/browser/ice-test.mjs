// The lecturer link's STUN and TURN servers, with stand-ins answering on loopback
// (browser-util.mjs: startFakeIceServers):
//   node ice-test.mjs BASE_URL TOKEN HOST STUN_PORT TURN_PORT
// whepserversink must run with stun-server=stun://HOST:STUN_PORT and
// turn-server=turn://alice:s3cret@HOST:TURN_PORT; HOST is this machine's own (not loopback) address:
// libnice asks no STUN or TURN server on loopback. Prints one "ok ..." line per check.
import { timeout, fail, waitForServer, launchChromium, openLecturer, startFakeIceServers } from './browser-util.mjs';

const [base, token, host, stunPort, turnPort] = process.argv.slice(2);
const fake = await startFakeIceServers(host, stunPort, turnPort);
const chromium = await launchChromium();
try {
  await waitForServer(base);
  // 1. OPTIONS names both servers as WHEP Link headers, TURN with its credentials; only with the token.
  const refused = await fetch(`${base}/whep?token=wrong`, { method: 'OPTIONS' });
  if (refused.status !== 401 || refused.headers.get('Link')) fail(`OPTIONS without the token: ${refused.status}`);
  const options = await fetch(`${base}/whep?token=${encodeURIComponent(token)}`, { method: 'OPTIONS' });
  const links = options.headers.get('Link') || '';
  if (options.status !== 204 || !links.includes(`<stun:${host}:${stunPort}>; rel="ice-server"`) ||
      !links.includes(`<turn:${host}:${turnPort}?transport=udp>; rel="ice-server"; username="alice"; ` +
                      'credential="s3cret"; credential-type="password"'))
    fail(`OPTIONS: ${options.status} with Link: ${links}`);
  console.log('ok OPTIONS: 204 with the STUN and TURN servers');

  // 2. The page takes them for its own peer connection, and joins.
  const page = await openLecturer(chromium.browser, base, token);
  await page.waitForFunction(() => window.vclassroom && window.vclassroom.stats.framesShown > 5, { timeout });
  const config = await page.evaluate(async () => (await window.vclassroom.joined).pc.getConfiguration().iceServers);
  const urls = config.map(s => [].concat(s.urls).join(' ') + (s.username ? ` ${s.username}/${s.credential}` : ''));
  if (urls.join(', ') !== `stun:${host}:${stunPort}, turn:${host}:${turnPort}?transport=udp alice/s3cret`)
    fail(`the page's ICE servers: ${urls.join(', ')}`);
  console.log(`ok the page uses ${urls.join(', ')}`);

  // 3. The server's ICE agent asked the TURN server for a relay (libnice names itself in SOFTWARE), again
  // with the credentials after the challenge, and the STUN server for its address, from the same socket
  // (libnice's Binding requests carry no SOFTWARE).
  const server = fake.allocations.filter(a => /libnice/i.test(a.software));
  if (!server.some(a => a.user === 'alice'))
    fail('the server never asked the TURN server as alice: ' + JSON.stringify(fake.allocations));
  const serverBindings = fake.bindings.filter(b => server.some(a => a.port === b.port));
  if (serverBindings.length === 0)
    fail('the server never asked the STUN server: ' + JSON.stringify({ bindings: fake.bindings, server }));
  console.log(`ok the server asked the TURN server as alice (${server.length} requests) and the STUN server ` +
              `(${serverBindings.length})`);
} catch (e) {
  fail(String(e));
} finally {
  await chromium.close();
  fake.close();
}
