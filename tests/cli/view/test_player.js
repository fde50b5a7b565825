// test_player.js PAGE.html SHOT.png SPEC...: the player page loads with no
// console error, failed request or dialog; moving the frame slider (with the
// keyboard) to frame k shows, in every pane, the positions of frame k of the
// HDF5 file within the page's quantisation (half a step per axis).  Each
// SPEC is PANE=FILE.h5:GROUP, the object pane PANE shows.
'use strict';
const { execFileSync } = require('child_process');
const path = require('path');
const { launch, open } = require('./browser.js');

const [pageFile, shot, ...specs] = process.argv.slice(2);
let fails = 0;
function check(what, ok, detail) {
  console.log((ok ? 'ok: ' : 'FAILED: ') + what + (ok || !detail ? '' : ': ' + detail));
  if (!ok) fails++;
}
function h5frame(file, group, k) {
  return JSON.parse(execFileSync(process.env.DTX_PY || '/usr/bin/python3', [path.join(__dirname, 'h5frame.py'), file, group, String(k)], { maxBuffer: 1 << 28 }));
}

(async () => {
  const browser = await launch(path.dirname(path.resolve(shot)));
  try {
    const { page, problems, dialogs, ms } = await open(browser, pageFile);
    console.log('time to first frame: ' + ms.toFixed(0) + ' ms');
    const data = await page.evaluate(() => JSON.parse(document.getElementById('dtx-data').textContent));
    const n = await page.evaluate(() => window.dtxView.nframes);
    check('frames in the page (' + n + ')', n >= 2);
    // Frames: the second one, then the last one, reached with the keyboard.
    await page.focus('input[type=range]');
    const targets = [[1, 'ArrowRight'], [n - 1, 'End']];
    for (const [k, key] of targets) {
      await page.keyboard.press(key);
      const shown = await page.evaluate(() => window.dtxView.frame());
      check('slider moved to frame ' + k, shown === k, 'shows ' + shown);
      for (const spec of specs) {
        const [pane, rest] = spec.split(/=(.*)/s);
        const colon = rest.lastIndexOf(':/');
        const file = rest.slice(0, colon), group = rest.slice(colon + 1);
        const p = data.panes[Number(pane)];
        const fileFrame = p.frame[Math.min(k, p.nframes - 1)];
        const want = h5frame(file, group, fileFrame);
        const got = await page.evaluate((i) => window.dtxView.positions(i), Number(pane));
        let worst = 0, bad = -1;
        for (let j = 0; j < want.length; j++) {
          const tol = p.step[j % 3] / 2 * (1 + 1e-6) + 1e-6 * Math.abs(want[j]);
          const d = Math.abs(got[j] - want[j]);
          if (!(d <= tol) && bad < 0) bad = j;
          worst = Math.max(worst, d / (p.step[j % 3] / 2 || 1));
        }
        check('pane ' + pane + ' at slider ' + k + ' shows ' + group + ' frame ' + fileFrame + ' (' + got.length / 3 + ' vertices, worst ' + worst.toFixed(3) + ' of half a step)',
              got.length === want.length && bad < 0, 'first bad coordinate ' + bad + ': ' + got[bad] + ' vs ' + want[bad]);
      }
    }
    await page.screenshot({ path: shot });
    check('no console error, failed request or dialog', problems.length === 0 && dialogs.length === 0, problems.concat(dialogs).join('; '));
  } finally {
    await browser.close();
  }
  console.log(fails ? fails + ' failed' : 'all passed');
  process.exit(fails ? 1 : 0);
})().catch((e) => { console.error('FAILED: ' + (e.stack || e)); process.exit(1); });
