// A lecturer with no route to the server but through a TURN server (run inside tests/browser/turn-relay.sh):
//   node turn-relay-test.mjs BASE_URL TOKEN
// The page joins, takes the TURN server from the WHEP endpoint's OPTIONS, and shows frames; its peer
// connection's selected candidate pair has a relayed side. Prints one "ok ..." line; exits non-zero on failure.
import { timeout, fail, waitForServer, launchChromium, openLecturer } from './browser-util.mjs';

const [base, token] = process.argv.slice(2);
await waitForServer(base);
const chromium = await launchChromium();
try {
  const page = await openLecturer(chromium.browser, base, token);
  await page.waitForFunction(() => window.vclassroom && window.vclassroom.stats.framesShown > 10, { timeout });
  const pair = await page.evaluate(async () => {
    const stats = await (await window.vclassroom.joined).pc.getStats();
    let selected = null;
    stats.forEach(s => { if (s.type === 'transport' && s.selectedCandidatePairId) selected = stats.get(s.selectedCandidatePairId); });
    if (!selected) stats.forEach(s => { if (s.type === 'candidate-pair' && s.nominated && s.state === 'succeeded') selected = s; });
    if (!selected) return null;
    const side = id => { const c = stats.get(id); return c ? `${c.candidateType} ${c.address}:${c.port}` : 'unknown'; };
    return { local: side(selected.localCandidateId), remote: side(selected.remoteCandidateId),
             shown: window.vclassroom.stats.framesShown };
  });
  if (!pair) fail('no selected candidate pair');
  if (!pair.local.startsWith('relay') && !pair.remote.startsWith('relay'))
    fail(`the media did not go through the TURN server: local ${pair.local}, remote ${pair.remote}`);
  console.log(`ok relayed: local ${pair.local}, remote ${pair.remote}, ${pair.shown} frames shown`);
} catch (e) {
  fail(String(e));
} finally {
  await chromium.close();
}
