// The result page: reads the data block the C++ writer inlined, draws the scene with three.js
// (orbit / zoom / pan from the scene's camera), colours it by a field or by a row / column of F,
// and lists what a clicked patch sees. Every name from an input file reaches the page through
// textContent, never as markup.

import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { decodeData, loadMatrix, loadRows, loadAll, rowsLoaded, allLoaded, storageText, colourModes, denseRow, denseColumn, topEntries, reciprocity, surfaceRow, surfaceColumn, entry } from './data.js';
import { inferno, toneMap, makeScale, ticks, formatNumber, valueRange, categorical } from './colour.js';

const kTopEntries = 12;

/// An element with text (never HTML) and optional class.
function el(tag, text, className) {
    const e = document.createElement(tag);
    if (text !== undefined && text !== null) e.textContent = String(text);
    if (className) e.className = className;
    return e;
}

function surfaceName(model, s) {
    const surf = model.surfaces[s];
    return surf ? surf.name : `surface ${s}`;
}

function buildMesh(model) {
    const tris = model.triangles, count = tris.length / 3, verts = model.vertices;
    // One vertex per triangle corner (flat colours per patch), copied index by index (no views).
    const pos = new Float32Array(count * 9);
    for (let k = 0, o = 0; k < tris.length; ++k, o += 3) {
        const v = 3 * tris[k];
        pos[o] = verts[v];
        pos[o + 1] = verts[v + 1];
        pos[o + 2] = verts[v + 2];
    }
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.BufferAttribute(pos, 3));
    const colour = new THREE.BufferAttribute(new Float32Array(count * 9), 3);
    colour.setUsage(THREE.DynamicDrawUsage);
    geometry.setAttribute('color', colour);
    geometry.computeBoundingSphere();
    const material = new THREE.MeshBasicMaterial({ vertexColors: true, side: THREE.FrontSide });
    return new THREE.Mesh(geometry, material);
}

// The patches' outlines as one line-segment geometry (built when first shown).
function buildEdges(model) {
    const offset = model.vertexOffset, verts = model.vertices;
    const segs = new Float32Array(6 * offset[model.n]);
    let o = 0;
    for (let i = 0; i < model.n; ++i) {
        const a = offset[i], b = offset[i + 1];
        for (let v = a; v < b; ++v) {
            const w = v + 1 < b ? v + 1 : a;
            for (let c = 0; c < 3; ++c) segs[o + c] = verts[3 * v + c];
            for (let c = 0; c < 3; ++c) segs[o + 3 + c] = verts[3 * w + c];
            o += 6;
        }
    }
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.BufferAttribute(segs, 3));
    return new THREE.LineSegments(geometry, new THREE.LineBasicMaterial({ color: 0x202020 }));
}

function patchOutline(model, i) {
    const a = model.vertexOffset[i], b = model.vertexOffset[i + 1];
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.BufferAttribute(model.vertices.slice(3 * a, 3 * b), 3));
    const line = new THREE.LineLoop(geometry, new THREE.LineBasicMaterial({ color: 0x00e5ff, depthTest: false }));
    line.renderOrder = 10;
    return line;
}

function patchCentroid(model, i) {
    const a = model.vertexOffset[i], b = model.vertexOffset[i + 1];
    const c = new THREE.Vector3();
    for (let v = a; v < b; ++v) c.add(new THREE.Vector3().fromArray(model.vertices, 3 * v));
    return c.multiplyScalar(1 / (b - a));
}

class Page {
    constructor(root, model) {
        this.model = model;
        // answered: how many selections have been drawn and listed (a scripted check waits on it).
        this.state = { mode: null, log: false, column: false, perSurface: false, selected: -1, answered: 0 };
        this.drawing = false;  // nothing is drawn before the first colours are set
        this.layout(root);
        this.setupThree();
        this.fillControls();
        this.fillReport();
        this.drawing = true;
        this.setMode(this.defaultMode());
    }

    layout(root) {
        root.textContent = '';
        this.view = el('div', null, 'ff-view');
        this.side = el('div', null, 'ff-side');
        root.append(this.view, this.side);
        const m = this.model;
        const h = el('h1', m.title || 'formfactor result');
        const sub = el('p', `${m.scene.name ?? ''} — ${m.n} patches, ${m.surfaces.length} surfaces`, 'ff-sub');
        const storage = m.hasMatrix ? storageText(m.matrixBlock) : null;
        this.controls = el('div', null, 'ff-controls');
        this.bar = el('div', null, 'ff-bar');
        this.selection = el('div', null, 'ff-selection');
        this.selection.append(el('p', 'Click a patch to see its row of F.', 'ff-hint'));
        this.reportBox = el('details', null, 'ff-report');
        this.side.append(h, sub, ...(storage ? [el('p', storage, 'ff-storage')] : []), this.controls, this.bar, this.selection, this.reportBox);
    }

    setupThree() {
        THREE.ColorManagement.enabled = false;
        const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
        renderer.outputColorSpace = THREE.LinearSRGBColorSpace;
        renderer.setPixelRatio(window.devicePixelRatio || 1);
        renderer.setClearColor(0x2a2a2a);
        this.view.append(renderer.domElement);
        this.renderer = renderer;
        this.scene3 = new THREE.Scene();
        this.mesh = buildMesh(this.model);
        this.edges = null;  // built when first shown
        this.scene3.add(this.mesh);
        const cam = this.model.camera;
        const radius = this.mesh.geometry.boundingSphere.radius || 1;
        this.camera = new THREE.PerspectiveCamera(cam ? cam.fov : 40, 1, radius * 1e-3, radius * 100);
        if (cam) {
            this.camera.position.fromArray(cam.eye);
            this.camera.up.fromArray(cam.up);
        }
        const target = cam ? new THREE.Vector3().fromArray(cam.target) : this.mesh.geometry.boundingSphere.center;
        this.camera.lookAt(target);
        this.orbit = new OrbitControls(this.camera, renderer.domElement);
        this.orbit.target.copy(target);
        this.orbit.update();
        this.orbit.addEventListener('change', () => this.render());
        this.raycaster = new THREE.Raycaster();
        let down = null;
        renderer.domElement.addEventListener('pointerdown', (e) => (down = [e.clientX, e.clientY]));
        renderer.domElement.addEventListener('pointerup', (e) => {
            if (down && Math.hypot(e.clientX - down[0], e.clientY - down[1]) < 4) this.pick(e.clientX, e.clientY);
            down = null;
        });
        new ResizeObserver(() => this.resize()).observe(this.view);
        this.resize();
    }

    resize() {
        const w = Math.max(1, this.view.clientWidth), h = Math.max(1, this.view.clientHeight);
        this.renderer.setSize(w, h);
        this.camera.aspect = w / h;
        this.camera.updateProjectionMatrix();
        this.render();
    }

    render() {
        if (this.drawing) this.renderer.render(this.scene3, this.camera);
    }

    /// The patch under client coordinates (x, y), or −1.
    patchAt(x, y) {
        const r = this.renderer.domElement.getBoundingClientRect();
        const ndc = new THREE.Vector2(((x - r.left) / r.width) * 2 - 1, -((y - r.top) / r.height) * 2 + 1);
        this.raycaster.setFromCamera(ndc, this.camera);
        const hit = this.raycaster.intersectObject(this.mesh, false)[0];
        return hit ? this.model.trianglePatch[hit.faceIndex] : -1;
    }

    pick(x, y) {
        const i = this.patchAt(x, y);
        if (i >= 0) this.select(i);
    }

    /// Client coordinates of patch i's centroid in the current view.
    project(i) {
        const p = patchCentroid(this.model, i).project(this.camera);
        const r = this.renderer.domElement.getBoundingClientRect();
        return { x: r.left + ((p.x + 1) / 2) * r.width, y: r.top + ((1 - p.y) / 2) * r.height };
    }

    defaultMode() {
        const keys = this.model.fields.map((f) => f.key);
        return keys.includes('radiosity') ? 'radiosity' : keys[0] ?? 'surface';
    }

    fillControls() {
        const c = this.controls;
        const modeLabel = el('label', 'Colour ');
        this.modeSelect = el('select');
        this.modeSelect.id = 'ff-mode';
        const add = (key, label) => {
            const o = el('option', label);
            o.value = key;
            this.modeSelect.append(o);
        };
        for (const mode of colourModes(this.model)) add(mode.key, mode.label);
        this.modeSelect.addEventListener('change', () => this.setMode(this.modeSelect.value));
        modeLabel.append(this.modeSelect);
        c.append(modeLabel);
        const check = (id, label, onChange, checked = false) => {
            const l = el('label');
            const box = el('input');
            box.type = 'checkbox';
            box.id = id;
            box.checked = checked;
            box.addEventListener('change', () => onChange(box.checked));
            l.append(box, document.createTextNode(' ' + label));
            c.append(l);
            return box;
        };
        check('ff-log', 'log scale', (v) => ((this.state.log = v), this.recolour()));
        check('ff-edges', 'patch edges', (v) => this.showEdges(v));
        check('ff-back', 'back faces', (v) => {
            this.mesh.material.side = v ? THREE.DoubleSide : THREE.FrontSide;
            this.mesh.material.needsUpdate = true;
            this.render();
        });
        if (this.model.hasMatrix) {
            check('ff-column', 'column: who sees it', (v) => ((this.state.column = v), this.reselect()));
            check('ff-surface', 'per surface', (v) => ((this.state.perSurface = v), this.reselect()));
        }
    }

    showEdges(visible) {
        if (visible && !this.edges) {
            this.edges = buildEdges(this.model);
            this.scene3.add(this.edges);
        }
        if (this.edges) this.edges.visible = visible;
        this.render();
    }

    fillReport() {
        const r = this.model.report;
        this.reportBox.append(el('summary', 'Run report'));
        if (!r) {
            this.reportBox.append(el('p', 'No report.'));
            return;
        }
        const tree = (value, parent) => {
            if (value === null || typeof value !== 'object') {
                parent.append(el('span', typeof value === 'number' ? formatNumber(value, 6) : String(value), 'ff-val'));
                return;
            }
            const dl = el('dl');
            for (const [k, v] of Object.entries(value)) {
                dl.append(el('dt', k));
                const dd = el('dd');
                if (Array.isArray(v) && v.every((x) => x === null || typeof x !== 'object'))
                    dd.append(el('span', v.map((x) => (typeof x === 'number' ? formatNumber(x, 6) : String(x))).join(', '), 'ff-val'));
                else tree(v, dd);
                dl.append(dd);
            }
            parent.append(dl);
        };
        tree(r, this.reportBox);
    }

    setMode(mode) {
        this.state.mode = mode;
        this.modeSelect.value = mode;
        this.recolour();
    }

    /// Values per patch for the current mode: {values, rgb, label, unit} (rgb: true colour).
    currentValues() {
        const m = this.model, s = this.state;
        if (s.mode === 'row') {
            if (s.selected < 0 || !this.answerable(s.selected)) return { values: new Float32Array(m.n).fill(NaN), label: 'row of F (click a patch)', unit: '' };
            if (s.perSurface) {
                const sel = m.surface[s.selected];
                const perSurf = s.column ? surfaceColumn(m, sel) : surfaceRow(m, sel);
                const values = new Float32Array(m.n);
                for (let i = 0; i < m.n; ++i) values[i] = m.surface[i] === sel ? NaN : perSurf[m.surface[i]];
                const name = surfaceName(m, sel);
                return { values, label: s.column ? `F to surface ${name}` : `F from surface ${name}`, unit: '' };
            }
            const values = s.column ? denseColumn(m.matrix, m.n, s.selected) : denseRow(m.matrix, m.n, s.selected);
            values[s.selected] = NaN;
            return { values, label: s.column ? `F_ij to patch ${s.selected}` : `F_ij from patch ${s.selected}`, unit: '' };
        }
        if (s.mode === 'surface') return { values: null, label: 'surface', unit: '' };
        const f = m.fields.find((x) => x.key === s.mode);
        return { values: f.values, rgb: f.kind === 'rgb', exposure: f.exposure, label: f.label, unit: f.unit ?? '' };
    }

    recolour() {
        const m = this.model;
        const cur = this.currentValues();
        const patchColour = new Float32Array(m.n * 3);
        let scale = null;
        if (cur.values === null) {
            for (let i = 0; i < m.n; ++i) patchColour.set(categorical(m.surface[i]), 3 * i);
        } else if (cur.rgb) {
            const exposure = cur.exposure ?? 1;
            for (let i = 0; i < m.n; ++i)
                patchColour.set(toneMap([cur.values[3 * i], cur.values[3 * i + 1], cur.values[3 * i + 2]], exposure), 3 * i);
        } else {
            const [lo, hi] = valueRange(cur.values, this.state.log);
            scale = makeScale(lo, hi, this.state.log);
            for (let i = 0; i < m.n; ++i) {
                const v = cur.values[i];
                patchColour.set(Number.isNaN(v) ? [0.85, 0.95, 1.0] : inferno(scale.map(v)), 3 * i);
            }
        }
        const colour = this.mesh.geometry.getAttribute('color');
        const tp = m.trianglePatch, out = colour.array;
        for (let t = 0, o = 0; t < tp.length; ++t) {
            const p = 3 * tp[t];
            const r = patchColour[p], g = patchColour[p + 1], b = patchColour[p + 2];
            for (let c = 0; c < 3; ++c, o += 3) {
                out[o] = r;
                out[o + 1] = g;
                out[o + 2] = b;
            }
        }
        colour.needsUpdate = true;
        this.scale = scale;
        this.drawBar(cur, scale);
        this.render();
    }

    drawBar(cur, scale) {
        const b = this.bar;
        b.textContent = '';
        b.append(el('div', cur.unit ? `${cur.label} [${cur.unit}]` : cur.label, 'ff-bar-title'));
        if (cur.values === null) {
            const list = el('ul', null, 'ff-legend');
            this.model.surfaces.slice(0, 40).forEach((s, k) => {
                const li = el('li');
                const sw = el('span', null, 'ff-swatch');
                const [r, g, bl] = categorical(k).map((x) => Math.round(x * 255));
                sw.style.background = `rgb(${r},${g},${bl})`;
                li.append(sw, document.createTextNode(' ' + s.name));
                list.append(li);
            });
            if (this.model.surfaces.length > 40) list.append(el('li', `… ${this.model.surfaces.length - 40} more`));
            b.append(list);
            return;
        }
        if (cur.rgb) {
            b.append(el('div', `true colour, linear radiosity × exposure ${formatNumber(cur.exposure ?? 1)} then sRGB (as the PNG)`, 'ff-bar-note'));
            return;
        }
        const canvas = el('canvas', null, 'ff-bar-canvas');
        canvas.width = 256;
        canvas.height = 14;
        const g = canvas.getContext('2d');
        for (let x = 0; x < 256; ++x) {
            const [r, gg, bl] = inferno(x / 255).map((v) => Math.round(v * 255));
            g.fillStyle = `rgb(${r},${gg},${bl})`;
            g.fillRect(x, 0, 1, 14);
        }
        b.append(canvas);
        const tickRow = el('div', null, 'ff-ticks');
        for (const t of ticks(scale, 5)) {
            const span = el('span', formatNumber(t));
            span.style.left = `${(scale.map(t) * 100).toFixed(2)}%`;
            tickRow.append(span);
        }
        b.append(tickRow);
        b.append(el('div', `${scale.log ? 'log' : 'linear'} scale, ${formatNumber(scale.min)} … ${formatNumber(scale.max)}`, 'ff-bar-note'));
    }

    /// Whether the rows of F that selecting patch i shows are decoded: its row and those of its
    /// listed partners (reciprocity), or every row for a column or per-surface factors.
    answerable(i) {
        const mx = this.model.matrix, s = this.state;
        if (!mx) return false;
        if (s.column || s.perSurface) return allLoaded(mx);
        return rowsLoaded(mx, [i]) && rowsLoaded(mx, topEntries(mx, i, kTopEntries).map((t) => t.j));
    }

    /// Decodes what selecting patch i shows (answerable).
    async loadFor(i) {
        const mx = await loadMatrix(this.model);
        if (this.state.column || this.state.perSurface) return loadAll(mx);
        await loadRows(mx, [i]);
        return loadRows(mx, topEntries(mx, i, kTopEntries).map((t) => t.j));
    }

    /// Selects patch i: outlined at once, its row drawn and listed when the rows of F it needs
    /// are decoded (a click may wait for them).
    async select(i) {
        const m = this.model;
        if (i < 0 || i >= m.n) return;
        this.state.selected = i;
        if (this.outline) this.scene3.remove(this.outline);
        this.outline = patchOutline(m, i);
        this.scene3.add(this.outline);
        if (m.hasMatrix) this.state.mode = 'row';
        this.modeSelect.value = this.state.mode;
        if (m.hasMatrix && !this.answerable(i)) {
            this.refreshSelection();
            await this.loadFor(i);
            if (this.state.selected !== i) return;  // a later click answers for itself
        }
        this.refreshSelection();
        ++this.state.answered;
    }

    /// The selection again, after a toggle (column, per surface) that may need more rows.
    reselect() {
        if (this.state.selected >= 0) this.select(this.state.selected);
        else this.refreshSelection();
    }

    refreshSelection() {
        const m = this.model, s = this.state, i = s.selected;
        this.recolour();
        const box = this.selection;
        box.textContent = '';
        if (i < 0) {
            box.append(el('p', 'Click a patch to see its row of F.', 'ff-hint'));
            return;
        }
        const surf = m.surface[i];
        box.append(el('h2', `patch ${i}`));
        box.append(el('p', `surface ${surf}: ${surfaceName(m, surf)}`, 'ff-surface-name'));
        box.append(el('p', `area ${formatNumber(m.area[i], 6)}`));
        if (!m.hasMatrix) return;
        if (!this.answerable(i)) return box.append(el('p', 'reading the rows of F…', 'ff-hint'));
        const mx = m.matrix;
        if (s.perSurface) return this.surfaceSelection(surf);
        const info = el('dl', null, 'ff-rowinfo');
        const add = (k, v, id) => {
            info.append(el('dt', k));
            const dd = el('dd', v);
            if (id) dd.id = id;
            info.append(dd);
        };
        add('row sum Σ_j F_ij', formatNumber(mx.rowSum[i], 6), 'ff-rowsum');
        add('entries stored', String(mx.rowPtr[i + 1] - mx.rowPtr[i]));
        add('dropped below threshold', `${formatNumber(mx.dropped[i], 4)} (threshold ${formatNumber(mx.threshold, 4)})`, 'ff-dropped');
        box.append(info);
        const top = s.column ? this.topColumn(i) : topEntries(mx, i, kTopEntries);
        const table = el('table', null, 'ff-top');
        table.id = 'ff-top';
        const head = el('tr');
        for (const h of [s.column ? 'from i' : 'to j', 'surface', s.column ? 'F_ij' : 'F_ij', 'A_i F_ij / A_j F_ji', 'defect'])
            head.append(el('th', h));
        table.append(head);
        for (const t of top) {
            const tr = el('tr');
            tr.dataset.patch = String(t.j);
            const rec = s.column ? reciprocity(m, t.j, i) : reciprocity(m, i, t.j);
            const v = el('td', t.se ? `${formatNumber(t.value, 6)} ± ${formatNumber(t.se, 2)}` : formatNumber(t.value, 6));
            v.dataset.value = String(t.value);
            tr.append(el('td', String(t.j)), el('td', surfaceName(m, m.surface[t.j])), v,
                el('td', `${formatNumber(rec.forward, 4)} / ${formatNumber(rec.backward, 4)}`), el('td', formatNumber(rec.defect, 3)));
            tr.addEventListener('click', () => this.select(t.j));
            table.append(tr);
        }
        box.append(el('p', s.column ? `largest F_ij into patch ${i} (who sees it)` : `largest entries of row ${i}`), table);
    }

    topColumn(j) {
        const m = this.model;
        const col = denseColumn(m.matrix, m.n, j);
        const order = [];
        for (let i = 0; i < m.n; ++i) if (col[i] > 0) order.push(i);
        order.sort((a, b) => col[b] - col[a] || a - b);
        return order.slice(0, kTopEntries).map((i) => ({ j: i, value: col[i], se: null }));
    }

    surfaceSelection(sel) {
        const m = this.model, box = this.selection;
        const r = this.state.column ? surfaceColumn(m, sel) : surfaceRow(m, sel);
        const areaOf = (s) => {
            let a = 0;
            for (let i = 0; i < m.n; ++i) if (m.surface[i] === s) a += m.area[i];
            return a;
        };
        const sum = r.reduce((a, b) => a + b, 0);
        box.append(el('p', `surface ${sel} sum ${formatNumber(sum, 6)}`, 'ff-surface-sum'));
        const order = Array.from(r.keys()).filter((t) => r[t] > 0).sort((a, b) => r[b] - r[a]).slice(0, kTopEntries);
        const table = el('table', null, 'ff-top');
        const head = el('tr');
        for (const h of ['surface', 'name', this.state.column ? 'F_st into it' : 'F_st', 'A_s F_st / A_t F_ts']) head.append(el('th', h));
        table.append(head);
        const aSel = areaOf(sel);
        for (const t of order) {
            const back = surfaceRow(m, t)[sel];
            const aT = areaOf(t);
            const fwd = this.state.column ? aT * r[t] : aSel * r[t];
            const bwd = this.state.column ? aSel * surfaceRow(m, sel)[t] : aT * back;
            const tr = el('tr');
            tr.append(el('td', String(t)), el('td', surfaceName(m, t)), el('td', formatNumber(r[t], 6)), el('td', `${formatNumber(fwd, 4)} / ${formatNumber(bwd, 4)}`));
            table.append(tr);
        }
        box.append(table);
    }
}

async function start() {
    const root = document.getElementById('ff-app');
    try {
        const t0 = performance.now();
        const block = document.getElementById('ff-data');
        const json = JSON.parse(block.textContent);
        const t1 = performance.now();
        const model = await decodeData(json);
        const t2 = performance.now();
        document.title = model.title ? `${model.title} — formfactor` : 'formfactor result';
        const page = new Page(root, model);
        const t3 = performance.now();
        // A small read-only hook for scripted checks (tests, notebooks): no code is taken in.
        window.formfactorPage = {
            patchCount: model.n,
            select: (i) => page.select(i),
            project: (i) => page.project(i),
            patchAt: (x, y) => page.patchAt(x, y),
            setMode: (mode) => page.setMode(mode),
            entry: (i, j) => (model.matrix ? entry(model.matrix, i, j) : 0),
            state: () => ({ ...page.state }),
            colourOf: (v) => (page.scale ? inferno(page.scale.map(v)) : null),
            // Milliseconds: script start (since navigation), JSON parse, decoding the scene, first
            // draw; firstFrame: the first frame (since navigation); after it: matrix, reading F's
            // row pointers and sums (and the block of its entries), allRows, decoding every row.
            timings: { start: t0, parse: t1 - t0, decode: t2 - t1, draw: t3 - t2, firstFrame: null, matrix: null, allRows: null },
        };
        document.body.dataset.ready = '1';
        // F's rows (most of the data) are decoded once the scene is on screen (after the next
        // frame), a segment of rows at a time so that a click is answered in between (it
        // decodes the rows it shows first).
        const timings = window.formfactorPage.timings;
        requestAnimationFrame(() => (timings.firstFrame = performance.now()));
        if (model.hasMatrix)
            requestAnimationFrame(() => setTimeout(() => {
                const t4 = performance.now();
                loadMatrix(model).then((mx) => {
                    timings.matrix = performance.now() - t4;
                    return loadAll(mx);
                }).then(() => (timings.allRows = performance.now() - t4), (e) => showError(root, e));
            }, 0));
    } catch (e) {
        showError(root, e);
        document.body.dataset.ready = 'error';
        throw e;
    }
}

function showError(root, e) {
    root.textContent = '';
    root.append(el('p', `This page could not be shown: ${e.message}`, 'ff-error'));
}

start();
