// The page of `formfactor run`'s Cornell box in headless Chromium: what it shows from the
// scene's camera, what a click on the floor lists against the matrix file, and that it asks
// for nothing over the network and logs no error.

import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import path from 'node:path';
import { scratch, runCli, openPage, pageData, readNpy, decodePng, meanColour, dataArray, clickAndWait } from './support.mjs';

let tmp, view, F, data;

before(async () => {
    tmp = scratch();
    runCli(['run', '--subdivide', '6', '--image-size', '64', '--out-dir', 'out', '--threads', '2'], tmp.dir);
    const file = path.join(tmp.dir, 'out', 'cornell.html');
    F = readNpy(path.join(tmp.dir, 'out', 'formfactors.npy'));
    data = pageData(file);
    view = await openPage(file, path.join(tmp.dir, 'profile'));
});

after(async () => {
    if (view) await view.close();
    if (tmp) tmp.remove();
});

// The 3D view's box in the screenshot (left of the side panel).
async function viewBox() {
    return view.page.evaluate(() => {
        const r = document.querySelector('.ff-view canvas').getBoundingClientRect();
        return { x: r.left, y: r.top, w: r.width, h: r.height };
    });
}

test('the Cornell box shows the red wall left, the green wall right, the light on the ceiling', async () => {
    const png = decodePng(await view.page.screenshot());
    const b = await viewBox();
    const red = meanColour(png, b.x + 0.04 * b.w, b.y + 0.4 * b.h, b.x + 0.14 * b.w, b.y + 0.6 * b.h);
    const green = meanColour(png, b.x + 0.86 * b.w, b.y + 0.4 * b.h, b.x + 0.96 * b.w, b.y + 0.6 * b.h);
    assert.ok(red[0] > 1.5 * red[1] && red[0] > 1.5 * red[2] && red[0] > 60, `left: ${red}`);
    assert.ok(green[1] > green[0] + 30 && green[1] > 2 * green[2] && green[1] > 60, `right: ${green}`);
    // The light: the brightest pixels of the upper fifth, near the middle, white.
    let best = { lum: -1 };
    for (let y = Math.round(b.y); y < b.y + 0.2 * b.h; ++y)
        for (let x = Math.round(b.x); x < b.x + b.w; ++x) {
            const c = png.rgb(x, y);
            const lum = c[0] + c[1] + c[2];
            if (lum > best.lum) best = { lum, x, y, c };
        }
    assert.ok(best.c.every((v) => v > 240), `brightest of the top: ${best.c}`);
    assert.ok(Math.abs(best.x - (b.x + b.w / 2)) < 0.2 * b.w, `light at x = ${best.x}`);
    const floor = meanColour(png, b.x + 0.4 * b.w, b.y + 0.9 * b.h, b.x + 0.6 * b.w, b.y + 0.97 * b.h);
    assert.ok(best.lum > floor.reduce((a, v) => a + v) + 100, 'the light is brighter than the floor');
});

test('a click on a floor patch lists the entries of its row of the matrix', async () => {
    const p = view.page;
    const floor = data.surfaces.findIndex((s) => s.name === 'floor');
    assert.ok(floor >= 0, 'the Cornell box has a surface named floor');
    const surfaces = dataArray(data.patches.surface);
    // A visible floor patch near the front middle: the first whose centroid the camera sees.
    const candidates = [...surfaces.keys()].filter((i) => surfaces[i] === floor);
    let target = -1, at = null;
    for (const i of candidates) {
        const q = await p.evaluate((k) => window.formfactorPage.project(k), i);
        if ((await p.evaluate(([x, y]) => window.formfactorPage.patchAt(x, y), [q.x, q.y])) === i) {
            target = i;
            at = q;
            break;
        }
    }
    assert.ok(target >= 0, 'some floor patch is visible');
    await clickAndWait(p, at.x, at.y);
    const state = await p.evaluate(() => window.formfactorPage.state());
    assert.equal(state.selected, target);
    assert.equal(state.mode, 'row');
    const n = F.rows;
    const rowOf = (i) => F.data.subarray(i * n, (i + 1) * n);
    const row = rowOf(target);
    const listed = await p.$$eval('#ff-top tr[data-patch]', (trs) =>
        trs.map((tr) => [Number(tr.dataset.patch), Number(tr.querySelector('[data-value]').dataset.value)]));
    assert.ok(listed.length >= 5, `${listed.length} entries listed`);
    for (const [j, v] of listed) assert.ok(Math.abs(v - row[j]) <= 1e-6 * Math.max(row[j], 1e-3), `F[${target}][${j}] = ${row[j]}, listed ${v}`);
    // The list is the row's largest entries, in order.
    const sorted = [...row].sort((a, b) => b - a);
    listed.forEach(([, v], k) => assert.ok(Math.abs(v - sorted[k]) <= 1e-6, `entry ${k}: ${v} vs ${sorted[k]}`));
    const rowSum = row.reduce((a, v) => a + v, 0);
    const shown = Number((await p.textContent('#ff-rowsum')).trim());
    assert.ok(Math.abs(shown - rowSum) < 1e-5, `row sum ${shown} vs ${rowSum}`);

    // The heat map: each visible listed partner is drawn in the colour of its value on the bar,
    // and the brightest of them is near the top of the colour map.
    const png = decodePng(await p.screenshot());
    const maxF = sorted[0];
    let checked = 0;
    for (const [j, v] of listed) {
        const q = await p.evaluate((k) => window.formfactorPage.project(k), j);
        if ((await p.evaluate(([x, y]) => window.formfactorPage.patchAt(x, y), [q.x, q.y])) !== j) continue;
        const c = meanColour(png, q.x - 1, q.y - 1, q.x + 2, q.y + 2);
        const expected = await p.evaluate((t) => window.formfactorPage.colourOf(t), v);
        assert.ok(c.every((x, k) => Math.abs(x - 255 * expected[k]) < 40), `patch ${j} (F ${v}, max ${maxF}): ${c} vs ${expected.map((x) => 255 * x)}`);
        ++checked;
    }
    assert.ok(checked >= 1, 'a listed partner is visible');
    // The largest entries are near the patch: the ceiling (the far side of the box) holds none
    // of the row's ten largest.
    const ceiling = new Set(data.surfaces.flatMap((s, k) => (s.name.startsWith('ceiling') ? [k] : [])));
    assert.equal(ceiling.size, 4);
    assert.ok(listed.slice(0, 10).every(([j]) => !ceiling.has(surfaces[j])), 'no ceiling patch in the top ten');

    // Reciprocity with each listed partner: A_i F_ij against A_j F_ji from the matrix file.
    const areas = dataArray(data.patches.area);
    const pairs = await p.$$eval('#ff-top tr[data-patch]', (trs) => trs.map((tr) => [Number(tr.dataset.patch), tr.children[3].textContent]));
    for (const [j, text] of pairs.slice(0, 3)) {
        const [a, b] = text.split('/').map((s) => Number(s.trim()));
        assert.ok(Math.abs(a - areas[target] * row[j]) <= 1e-3 * a, `A_i F_ij ${a}`);
        assert.ok(Math.abs(b - areas[j] * rowOf(j)[target]) <= 1e-3 * Math.max(b, 1e-12), `A_j F_ji ${b}`);
    }
});

test('the column toggle shows who sees the patch', async () => {
    const p = view.page;
    const i = (await p.evaluate(() => window.formfactorPage.state())).selected;
    await p.click('#ff-column');
    const listed = await p.$$eval('#ff-top tr[data-patch]', (trs) =>
        trs.map((tr) => [Number(tr.dataset.patch), Number(tr.querySelector('[data-value]').dataset.value)]));
    const n = F.rows;
    for (const [k, v] of listed) assert.ok(Math.abs(v - F.data[k * n + i]) <= 1e-6, `F[${k}][${i}]`);
    await p.click('#ff-column');
});

test('per surface, the row is the area-weighted surface factors of the matrix', async () => {
    const p = view.page;
    const i = (await p.evaluate(() => window.formfactorPage.state())).selected;
    const surfaces = dataArray(data.patches.surface);
    const areas = dataArray(data.patches.area);
    await p.check('#ff-surface');
    const s = surfaces[i], n = F.rows;
    const fst = new Float64Array(data.surfaces.length);
    let as = 0;
    for (let a = 0; a < n; ++a) {
        if (surfaces[a] !== s) continue;
        as += areas[a];
        for (let b = 0; b < n; ++b) fst[surfaces[b]] += areas[a] * F.data[a * n + b];
    }
    const rows = await p.$$eval('.ff-top tr', (trs) => trs.slice(1).map((tr) => [Number(tr.children[0].textContent), Number(tr.children[2].textContent)]));
    assert.ok(rows.length >= 3);
    for (const [t, v] of rows) assert.ok(Math.abs(v - fst[t] / as) <= 1e-4 * Math.max(v, 1e-3), `F from surface ${s} to ${t}: ${v} vs ${fst[t] / as} (${JSON.stringify(rows)})`);
    // Its column: F from every surface t into s.
    await p.check('#ff-column');
    const into = new Float64Array(data.surfaces.length), at = new Float64Array(data.surfaces.length);
    for (let a = 0; a < n; ++a) {
        at[surfaces[a]] += areas[a];
        for (let b = 0; b < n; ++b) if (surfaces[b] === s) into[surfaces[a]] += areas[a] * F.data[a * n + b];
    }
    const cols = await p.$$eval('.ff-top tr', (trs) => trs.slice(1).map((tr) => [Number(tr.children[0].textContent), Number(tr.children[2].textContent)]));
    assert.ok(cols.length >= 3);
    for (const [t, v] of cols) assert.ok(Math.abs(v - into[t] / at[t]) <= 1e-4 * Math.max(v, 1e-3), `F from surface ${t} into ${s}: ${v} vs ${into[t] / at[t]}`);
    await p.uncheck('#ff-column');
    await p.uncheck('#ff-surface');
});

test('every colour mode draws with a colour bar, and the report panel shows the run', async () => {
    const p = view.page;
    const modes = await p.$$eval('#ff-mode option', (os) => os.map((o) => o.value));
    for (const m of ['radiosity', 'row_sum', 'sky_factor', 'standard_error', 'error_bound', 'surface', 'material'])
        assert.ok(modes.includes(m), `mode ${m} offered`);
    for (const m of modes) {
        await p.selectOption('#ff-mode', m);
        const title = await p.textContent('.ff-bar-title');
        assert.ok(title.length > 0, `bar title of ${m}`);
    }
    await p.selectOption('#ff-mode', 'error_bound');
    assert.match(await p.textContent('.ff-bar-title'), /error bound of the row sum.*\[dimensionless, as F\]/);
    assert.ok((await p.$$('.ff-ticks span')).length > 0, 'the error bound has a scale');
    await p.check('#ff-log');
    await p.selectOption('#ff-mode', 'row_sum');
    assert.match(await p.textContent('.ff-bar-note'), /log scale/);
    const report = await p.textContent('.ff-report');
    assert.match(report, /mc-hemisphere/);
    assert.match(report, /row_sum/);
});

test('the page asks for nothing over the network and logs no error', () => {
    assert.deepEqual(view.log.requests, []);
    assert.deepEqual(view.log.consoleErrors, []);
    assert.deepEqual(view.log.pageErrors, []);
});
