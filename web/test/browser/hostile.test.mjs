// A scene whose surface names are HTML and script: the page shows them as text and runs none
// of it.

import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { writeFileSync } from 'node:fs';
import path from 'node:path';
import { scratch, runCli, openPage } from './support.mjs';

const kNames = [
    '</script><script>window.__pwned=1</script>',
    '<img/src=x/onerror=window.__pwned=2>',
    '<!--<script>window.__pwned=3</script>',
    '&lt;b&gt;not-bold&amp;',
];

let tmp, view, file;

before(async () => {
    tmp = scratch();
    // Four faces of a box, inward, each a group named by one of the names.
    const v = ['v 0 0 0', 'v 1 0 0', 'v 1 1 0', 'v 0 1 0', 'v 0 0 1', 'v 1 0 1', 'v 1 1 1', 'v 0 1 1'];
    const faces = ['f 1 2 3 4', 'f 5 8 7 6', 'f 1 5 6 2', 'f 4 3 7 8'];
    const obj = [...v, ...kNames.flatMap((name, k) => [`g ${name}`, faces[k]])].join('\n') + '\n';
    writeFileSync(path.join(tmp.dir, 'hostile.obj'), obj);
    file = path.join(tmp.dir, 'hostile.html');
    runCli(['view', 'hostile.obj', '--subdivide', '2', '--method', 'analytic', '--title', kNames[0], '-o', file], tmp.dir);
    view = await openPage(file, path.join(tmp.dir, 'profile'));
});

after(async () => {
    if (view) await view.close();
    if (tmp) tmp.remove();
});

test('hostile surface names render as text and run nothing', async () => {
    const p = view.page;
    await p.selectOption('#ff-mode', 'surface');
    const legend = await p.$$eval('.ff-legend li', (lis) => lis.map((li) => li.textContent.trim()));
    for (const name of kNames) assert.ok(legend.includes(name), `legend shows ${name}: ${legend}`);
    assert.equal(await p.textContent('h1'), kNames[0]);
    assert.equal(await p.evaluate(() => window.__pwned), undefined);
    assert.equal(await p.$$eval('img', (x) => x.length), 0);
    assert.deepEqual(await p.$$eval('script', (x) => x.map((e) => e.id || 'bundle')), ['ff-data', 'bundle', 'ff-matrix'],
        "the data block, the bundle and F's entries");
    // A click shows the surface name of a patch as text too.
    await p.evaluate(() => window.formfactorPage.select(0));
    const shown = await p.textContent('.ff-surface-name');
    assert.ok(shown.endsWith(kNames[0]), shown);
    assert.equal(await p.evaluate(() => window.__pwned), undefined);
    assert.deepEqual(view.log.requests, []);
    assert.deepEqual(view.log.consoleErrors, []);
    assert.deepEqual(view.log.pageErrors, []);
});
