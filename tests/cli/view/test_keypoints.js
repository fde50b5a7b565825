// test_keypoints.js PAGE.html S,T S,T ...: on a --pick page of a file with
// key points (whose vertices are the S of the pairs given, in order), the
// first key point is offered as the source of the first pair, and clicking
// only the target vertices T (at their projected screen positions) makes the
// pairs (S, T) with the key points' labels.
'use strict';
const path = require('path');
const { launch, open } = require('./browser.js');

const [pageFile, ...pairsArg] = process.argv.slice(2);
const want = pairsArg.map((p) => p.split(',').map(Number));
let fails = 0;
function check(what, ok, detail) {
  console.log((ok ? 'ok: ' : 'FAILED: ') + what + (ok || !detail ? '' : ': ' + detail));
  if (!ok) fails++;
}

(async () => {
  const browser = await launch(path.dirname(path.resolve(pageFile)));
  try {
    const { page, problems, dialogs } = await open(browser, pageFile);
    const data = await page.evaluate(() => JSON.parse(document.getElementById('dtx-data').textContent));
    check('the page has the key points', data.keypoints && data.keypoints.vertex.length === want.length);
    for (const [s, t] of want) {
      const pend = await page.evaluate(() => window.dtxView.pending());
      check('key point ' + s + ' offered as the next source', pend.s === s, JSON.stringify(pend));
      const p = await page.evaluate((v) => { window.dtxView.aim(1, v); return window.dtxView.project(1, v); }, t);
      await page.mouse.click(p.x, p.y);
    }
    const pairs = await page.evaluate(() => window.dtxView.pairs());
    const got = pairs.map((p) => [p.s, p.t, p.label]);
    const exp = want.map(([s, t], k) => [s, t, data.keypoints.label[k]]);
    check('one click per pair made ' + JSON.stringify(exp), JSON.stringify(got) === JSON.stringify(exp), JSON.stringify(got));
    check('no console error, failed request or dialog', problems.length === 0 && dialogs.length === 0, problems.concat(dialogs).join('; '));
  } finally {
    await browser.close();
  }
  console.log(fails ? fails + ' failed' : 'all passed');
  process.exit(fails ? 1 : 0);
})().catch((e) => { console.error('FAILED: ' + (e.stack || e)); process.exit(1); });
