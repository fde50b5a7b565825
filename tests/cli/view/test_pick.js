// test_pick.js PAGE.html MARKERS.csv OUT_DIR: on a --pick page of the two
// meshes the markers were made for, picks every pair again by clicking:
// for each row, the camera is aimed at the source vertex (the test hook
// dtxView.aim, as a user orbits and zooms to a spot), the mouse clicks at its
// projected screen position, the label is typed, then the same for the
// target vertex.  Checks every click lands on exactly that vertex, that
// deleting and undoing work, that "Download CSV" saves OUT_DIR/markers.csv
// and that this file, less its "# index_base: 0" line, is MARKERS.csv byte
// for byte.  Keeps OUT_DIR/pick.png.
'use strict';
const fs = require('fs');
const path = require('path');
const { launch, open } = require('./browser.js');

const [pageFile, markersFile, outDir] = process.argv.slice(2);
let fails = 0;
function check(what, ok, detail) {
  console.log((ok ? 'ok: ' : 'FAILED: ') + what + (ok || !detail ? '' : ': ' + detail));
  if (!ok) fails++;
}

(async () => {
  const shipped = fs.readFileSync(markersFile, 'utf8');
  const rows = shipped.split('\n').slice(1).filter((l) => l.trim() !== '').map((l) => {
    const m = /^(\d+),(\d+),(.*)$/.exec(l);
    return { s: Number(m[1]), t: Number(m[2]), label: m[3] };
  });
  const browser = await launch(outDir);
  try {
    const { page, problems, dialogs, ms } = await open(browser, pageFile);
    console.log('time to first frame: ' + ms.toFixed(0) + ' ms');
    let wrong = [];
    for (const r of rows) {
      const got = [];
      for (const [pane, v] of [[0, r.s], [1, r.t]]) {
        if (pane === 1) {
          await page.click('#dtx-side input[type=text]', { clickCount: 3 });
          await page.keyboard.type(r.label);
        }
        const p = await page.evaluate((i, vv) => { window.dtxView.aim(i, vv); return window.dtxView.project(i, vv); }, pane, v);
        await page.mouse.click(p.x, p.y);
        got.push(await page.evaluate(() => window.dtxView.pending()));
      }
      const pairs = await page.evaluate(() => window.dtxView.pairs());
      const last = pairs[pairs.length - 1];
      if (got[0].s !== r.s || !last || last.s !== r.s || last.t !== r.t || last.label !== r.label)
        wrong.push(JSON.stringify(r) + ' gave ' + JSON.stringify(last) + ' (source click: ' + got[0].s + ')');
    }
    check('each of the ' + rows.length + ' pairs picked by clicking gives its vertices', wrong.length === 0, wrong.slice(0, 5).join('; '));
    const n = (await page.evaluate(() => window.dtxView.pairs())).length;
    check('pairs listed: ' + n, n === rows.length);

    // Select row 3, delete it, undo.
    await page.click('#dtx-side tbody tr:nth-child(3)');
    await page.evaluate(() => { for (const b of document.querySelectorAll('button')) if (b.textContent === 'Delete selected') b.click(); });
    const afterDel = await page.evaluate(() => window.dtxView.pairs());
    check('delete removes the selected pair', afterDel.length === rows.length - 1 && afterDel[2].s === rows[3].s);
    await page.keyboard.down('Control'); await page.keyboard.press('z'); await page.keyboard.up('Control');
    const afterUndo = await page.evaluate(() => window.dtxView.pairs());
    check('undo (ctrl+z) brings it back', afterUndo.length === rows.length && afterUndo[2].s === rows[2].s);

    // Move: select row 3, click another target vertex (row 5's), undo.
    await page.click('#dtx-side tbody tr:nth-child(3)');
    const q = await page.evaluate((v) => { window.dtxView.aim(1, v); return window.dtxView.project(1, v); }, rows[4].t);
    await page.mouse.click(q.x, q.y);
    const moved = await page.evaluate(() => window.dtxView.pairs());
    check('a click with row 3 selected moves its target end', moved[2].t === rows[4].t && moved[2].s === rows[2].s && moved.length === rows.length,
          JSON.stringify(moved[2]));
    await page.keyboard.press('Escape');
    await page.keyboard.down('Control'); await page.keyboard.press('z'); await page.keyboard.up('Control');
    const back = await page.evaluate(() => window.dtxView.pairs());
    check('undo puts it back', back[2].t === rows[2].t);

    // Mirror: pair 1 across each axis of the cat's box; the new ends are
    // the vertices nearest to the reflected ones, the label's left is right.
    const pos = [await page.evaluate(() => window.dtxView.positions(0)), await page.evaluate(() => window.dtxView.positions(1))];
    const nearest = (P, x) => { let b = -1, bd = Infinity; for (let j = 0; j < P.length; j += 3) { const d = (P[j] - x[0]) ** 2 + (P[j + 1] - x[1]) ** 2 + (P[j + 2] - x[2]) ** 2; if (d < bd) { bd = d; b = j / 3; } } return b; };
    const centre = (P, a) => { let lo = Infinity, hi = -Infinity; for (let j = a; j < P.length; j += 3) { lo = Math.min(lo, P[j]); hi = Math.max(hi, P[j]); } return (lo + hi) / 2; };
    const mirrorOf = (P, v, a) => { const x = [P[3 * v], P[3 * v + 1], P[3 * v + 2]]; x[a] = 2 * centre(P, a) - x[a]; return nearest(P, x); };
    await page.click('#dtx-side tbody tr:nth-child(1)');
    await page.select('#dtx-side select', 'x');
    await page.evaluate(() => { for (const b of document.querySelectorAll('button')) if (b.textContent === 'Add mirrored pair') b.click(); });
    const mir = await page.evaluate(() => window.dtxView.pairs());
    const m = mir[mir.length - 1];
    const mwant = { s: mirrorOf(pos[0], rows[0].s, 0), t: mirrorOf(pos[1], rows[0].t, 0), label: rows[0].label.replace(/left/g, 'right') };
    check('mirrored pair ' + JSON.stringify(m), mir.length === rows.length + 1 && JSON.stringify(m) === JSON.stringify(mwant), JSON.stringify(mwant));
    await page.keyboard.down('Control'); await page.keyboard.press('z'); await page.keyboard.up('Control');
    check('undo removes it', (await page.evaluate(() => window.dtxView.pairs())).length === rows.length);

    // The real download.
    const cdp = await page.target().createCDPSession();
    await cdp.send('Page.setDownloadBehavior', { behavior: 'allow', downloadPath: path.resolve(outDir) });
    const csvPath = path.join(outDir, 'markers.csv');
    try { fs.unlinkSync(csvPath); } catch (e) { /* none */ }
    await page.evaluate(() => { for (const b of document.querySelectorAll('button')) if (b.textContent === 'Download CSV') b.click(); });
    for (let i = 0; i < 100 && !fs.existsSync(csvPath); i++) await new Promise((r) => setTimeout(r, 50));
    const csv = fs.existsSync(csvPath) ? fs.readFileSync(csvPath, 'utf8') : '';
    check('Download CSV saved ' + csvPath, csv.length > 0);
    check('it starts with "# index_base: 0"', csv.startsWith('# index_base: 0\n'));
    check('the rest is the shipped marker file byte for byte', csv.replace(/^# index_base: 0\n/, '') === shipped);
    await page.evaluate(() => { for (const b of document.querySelectorAll('button')) if (b.textContent === 'Reset view') b.click(); });
    await page.hover('#dtx-side tbody tr:nth-child(20)');
    await new Promise((r) => setTimeout(r, 100));
    await page.screenshot({ path: path.join(outDir, 'pick.png') });
    check('no console error, failed request or dialog', problems.length === 0 && dialogs.length === 0, problems.concat(dialogs).join('; '));
  } finally {
    await browser.close();
  }
  console.log(fails ? fails + ' failed' : 'all passed');
  process.exit(fails ? 1 : 0);
})().catch((e) => { console.error('FAILED: ' + (e.stack || e)); process.exit(1); });
