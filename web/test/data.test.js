// Decoding of the page's data block and the questions the page asks of it.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import zlib from 'node:zlib';
import { base64ToBytes, colourModes, decodeArray, decodeSegment, decodeData, loadMatrix, loadRows, loadAll, rowsLoaded, allLoaded, row, denseRow, denseColumn, entry, topEntries, reciprocity, surfaceRow, surfaceColumn } from '../src/data.js';

const bytesOf = (typed) => Buffer.from(typed.buffer, typed.byteOffset, typed.byteLength);
const b64 = (typed) => bytesOf(typed).toString('base64');
// An array as the writer stores it: deflated (zlib's format), then base64.
const arr = (dtype, typed) => ({ dtype, count: typed.length, compression: 'deflate', base64: zlib.deflateSync(bytesOf(typed)).toString('base64') });
// An array stored as it is.
const raw = (dtype, typed) => ({ dtype, count: typed.length, base64: b64(typed) });
// Deflated by byte planes: every value's first byte, then every second byte, ...
const planes = (dtype, typed) => {
    const bytes = bytesOf(typed), w = typed.BYTES_PER_ELEMENT, n = typed.length, out = Buffer.alloc(bytes.length);
    for (let k = 0; k < n; ++k) for (let b = 0; b < w; ++b) out[b * n + k] = bytes[k * w + b];
    return { dtype, count: n, compression: 'deflate', byte_planes: true, base64: zlib.deflateSync(out).toString('base64') };
};

// Three patches: 0 and 1 on surface 0, 2 on surface 1; F (stored entries only):
//   row 0: F01 = 0.25, F02 = 0.5    row 1: F10 = 0.5    row 2: F20 = 0.125, F21 = 0.375
// Columns row by row: 1 2 | 0 | 0 1, each after the first of its row as the step: 1 1 | 0 | 0 1.
function sample() {
    return {
        format: 'formfactor-page', version: 2, title: 't',
        surfaces: [{ name: 'wall' }, { name: '<img onerror=alert(1)>' }],
        patches: {
            count: 3,
            area: arr('f64', new Float64Array([1, 0.5, 2])),
            surface: arr('u32', new Uint32Array([0, 0, 1])),
            vertex_offset: arr('u32', new Uint32Array([0, 3, 6, 9])),
            vertices: arr('f32', new Float32Array(27)),
            triangles: arr('u32', new Uint32Array([0, 1, 2, 3, 4, 5, 6, 7, 8])),
            triangle_patch: arr('u32', new Uint32Array([0, 1, 2])),
        },
        fields: [{ key: 'row_sum', label: 'row sum', values: arr('f32', new Float32Array([0.75, 0.5, 0.5])) }],
        matrix: {
            threshold: 0.1, stored_entries: 5, nonzeros: 6,
            row_ptr: arr('u32', new Uint32Array([0, 2, 3, 5])),
            col: arr('u16', new Uint16Array([1, 1, 0, 0, 1])),
            col_coding: 'row-delta',
            val: planes('f32', new Float32Array([0.25, 0.5, 0.5, 0.125, 0.375])),
            dropped: arr('f32', new Float32Array([0, 0.01, 0])),
            row_sum: arr('f64', new Float64Array([0.75, 0.51, 0.5])),
        },
    };
}

// The model with its rows of F decoded.
async function decoded(json) {
    const model = await decodeData(json);
    await loadMatrix(model);
    return model;
}

test('base64 decodes to the bytes it encodes, padded or not', () => {
    assert.deepEqual([...base64ToBytes('AAEC/w==')], [0, 1, 2, 255]);
    assert.deepEqual([...base64ToBytes('AAEC/w')], [0, 1, 2, 255]);
    assert.deepEqual([...base64ToBytes('')], []);
});

test('base64 decodes every length and every byte value as node encodes them', () => {
    const bytes = new Uint8Array(300);
    for (let k = 0; k < bytes.length; ++k) bytes[k] = (k * 97 + 13) & 255;
    for (let len = 0; len <= 70; ++len) {
        const part = bytes.subarray(0, len);
        const text = Buffer.from(part).toString('base64');
        assert.deepEqual([...base64ToBytes(text)], [...part], `length ${len}`);
        assert.deepEqual([...base64ToBytes(text.replace(/=+$/, ''))], [...part], `length ${len}, unpadded`);
    }
    assert.deepEqual([...base64ToBytes(Buffer.from(bytes).toString('base64'))], [...bytes]);
});

test('a character outside the base64 alphabet is refused', () => {
    assert.throws(() => base64ToBytes('AA*C'), /not base64/);
    assert.throws(() => base64ToBytes('AAEC/'), /not base64/);
});

test('the colour modes list every field with its unit, the error bound among them', async () => {
    const json = sample();
    json.fields.push({
        key: 'error_bound', label: 'error bound of the row sum', unit: 'dimensionless, as F',
        values: arr('f32', new Float32Array([1e-9, 2e-9, 3e-9])),
    });
    const modes = colourModes(await decodeData(json));
    assert.deepEqual(modes.map((m) => m.key), ['row_sum', 'error_bound', 'surface', 'row']);
    assert.equal(modes[1].label, 'error bound of the row sum (dimensionless, as F)');
    const noMatrix = sample();
    delete noMatrix.matrix;
    assert.deepEqual(colourModes(await decodeData(noMatrix)).map((m) => m.key), ['row_sum', 'surface']);
});

test('typed arrays decode little-endian values exactly, deflated (by byte planes or not) or stored as they are', async () => {
    for (const pack of [arr, raw, planes]) {
        const f = new Float64Array([Math.PI, -1e-300, 0.1]);
        assert.deepEqual([...(await decodeArray(pack('f64', f)))], [...f]);
        const u = new Uint32Array([0, 1, 4294967295]);
        assert.deepEqual([...(await decodeArray(pack('u32', u)))], [...u]);
        const h = new Uint16Array([0, 7, 65535]);
        assert.deepEqual([...(await decodeArray(pack('u16', h)))], [...h]);
        assert.equal((await decodeArray(pack('f32', new Float32Array([0.1]))))[0], Math.fround(0.1));
    }
    // Long enough to span several of the stream's chunks.
    const big = new Float32Array(200000).map((_, k) => Math.sin(k) / (1 + k));
    assert.deepEqual(await decodeArray(arr('f32', big)), big);
    assert.deepEqual(await decodeArray(planes('f32', big)), big);
});

test('a length that does not match its count, an unknown dtype or compression, or a broken stream is refused', async () => {
    await assert.rejects(decodeArray({ ...arr('f32', new Float32Array([1])), count: 2 }), /has 4 bytes/);
    await assert.rejects(decodeArray({ ...raw('f32', new Float32Array([1])), count: 2 }), /has 4 bytes/);
    await assert.rejects(decodeArray({ dtype: 'x8', count: 0, base64: '' }), /unknown dtype/);
    await assert.rejects(decodeArray({ ...raw('f32', new Float32Array([1])), compression: 'gzip' }), /unknown compression/);
    // A stream cut short, and bytes that are no zlib stream.
    const whole = zlib.deflateSync(bytesOf(new Float32Array(1000).fill(0.5)));
    await assert.rejects(decodeArray({ dtype: 'f32', count: 1000, compression: 'deflate', base64: whole.subarray(0, whole.length - 6).toString('base64') }));
    await assert.rejects(decodeArray({ ...raw('f32', new Float32Array([1, 2, 3])), compression: 'deflate' }));
});

test('a block of another format or version is refused', async () => {
    await assert.rejects(decodeData({ format: 'other', version: 2 }), /not a formfactor page/);
    await assert.rejects(decodeData({ ...sample(), version: 1 }), /not a formfactor page/);
    const bad = sample();
    bad.matrix.row_ptr = arr('u32', new Uint32Array([0, 2, 3, 4]));
    await assert.rejects(decoded(bad), /row pointers/);
    const coding = sample();
    coding.matrix.col_coding = 'zigzag';
    await assert.rejects(decoded(coding), /unknown column coding/);
});

test('the rows of F are decoded when first asked for, once', async () => {
    const m = await decodeData(sample());
    assert.equal(m.hasMatrix, true);
    assert.equal(m.matrix, null);
    const [a, b] = await Promise.all([loadMatrix(m), loadMatrix(m)]);
    assert.equal(a, b);
    assert.equal(m.matrix, a);
    const noMatrix = sample();
    delete noMatrix.matrix;
    const n = await decodeData(noMatrix);
    assert.equal(n.hasMatrix, false);
    assert.equal(await loadMatrix(n), null);
});

// Stored in segments as the writer does: each segment's bytes (by byte planes within it, or as
// they are) deflated with a full flush after it, in one zlib stream; the offset of each segment
// in the stream.
function segmented(dtype, typed, bounds, bytePlanes) {
    const w = typed.BYTES_PER_ELEMENT, all = bytesOf(typed), parts = [], at = [2];
    let length = 2;
    const laidOut = Buffer.alloc(all.length);
    for (let s = 0; s + 1 < bounds.length; ++s) {
        const a = bounds[s], n = bounds[s + 1] - a, seg = all.subarray(a * w, (a + n) * w);
        for (let k = 0; k < n; ++k)
            for (let b = 0; b < w; ++b) laidOut[a * w + (bytePlanes ? b * n + k : k * w + b)] = seg[k * w + b];
        const part = zlib.deflateRawSync(laidOut.subarray(a * w, (a + n) * w), { finishFlush: zlib.constants.Z_FULL_FLUSH });
        parts.push(part);
        at.push((length += part.length));
    }
    let s1 = 1, s2 = 0;  // Adler-32 of the laid-out bytes
    for (const byte of laidOut) {
        s1 = (s1 + byte) % 65521;
        s2 = (s2 + s1) % 65521;
    }
    const tail = Buffer.alloc(6);
    tail.set([3, 0]);
    tail.writeUInt32BE(((s2 << 16) | s1) >>> 0, 2);
    const stream = Buffer.concat([Buffer.from([0x78, 0x9c]), ...parts, tail]);
    assert.deepEqual(zlib.inflateSync(stream), laidOut);  // one zlib stream, as a whole
    return { dtype, count: typed.length, compression: 'deflate', ...(bytePlanes ? { byte_planes: true } : {}),
        segments: bounds, segment_bytes: at, base64: stream.toString('base64') };
}

test('an array stored in segments decodes whole and a segment at a time', async () => {
    const values = new Float32Array(50).map((_, k) => k / 7);
    for (const planes of [true, false]) {
        const e = segmented('f32', values, [0, 11, 11, 30, 50], planes);
        assert.deepEqual([...(await decodeArray(e))], [...values]);
        for (const [k, a, b] of [[0, 0, 11], [1, 11, 11], [2, 11, 30], [3, 30, 50]]) {
            const s = await decodeSegment(e, k);
            assert.equal(s.start, a);
            assert.deepEqual([...s.values], [...values.subarray(a, b)], `segment ${k}`);
        }
    }
});

test('rows stored in segments are decoded when asked for, the rest as they come', async () => {
    // Segments of two rows: rows 0-1 (entries 0-2), row 2 (entries 3-4).
    const json = sample();
    const bounds = [0, 3, 5];
    json.matrix.rows_per_segment = 2;
    json.matrix.col = segmented('u16', new Uint16Array([1, 1, 0, 0, 1]), bounds, true);
    json.matrix.val = segmented('f32', new Float32Array([0.25, 0.5, 0.5, 0.125, 0.375]), bounds, true);
    json.matrix.standard_error = segmented('f32', new Float32Array([0.01, 0.02, 0.03, 0.04, 0.05]), bounds, false);
    const model = await decodeData(json);
    const m = await loadMatrix(model);
    assert.equal(rowsLoaded(m, [0]), false);
    await loadRows(m, [2]);
    assert.equal(rowsLoaded(m, [2]), true);
    assert.equal(rowsLoaded(m, [1, 2]), false);
    assert.deepEqual([...denseRow(m, 3, 2)], [0.125, 0.375, 0]);
    assert.deepEqual([...row(m, 2).se].map((x) => Math.round(x * 100)), [4, 5]);
    assert.deepEqual([...denseRow(m, 3, 0)], [0, 0, 0]);  // not yet decoded
    assert.equal(allLoaded(m), false);
    await loadAll(m);
    assert.equal(allLoaded(m), true);
    const whole = await decoded(sample());
    for (let i = 0; i < 3; ++i) assert.deepEqual([...denseRow(m, 3, i)], [...denseRow(whole.matrix, 3, i)], `row ${i}`);
    assert.deepEqual([...denseColumn(m, 3, 0)], [0, 0.5, 0.125]);
});

test('entries stored as indices into a palette of (value, standard error) pairs read the same', async () => {
    // Pairs: 0 (0.5, 0.05), 1 (0.25, 0.025), 2 (0.125, 0.0125), 3 (0.375, 0.0375).
    const palette = { val: arr('f32', new Float32Array([0.5, 0.25, 0.125, 0.375])), standard_error: arr('f32', new Float32Array([0.05, 0.025, 0.0125, 0.0375])) };
    const index = new Uint16Array([1, 0, 0, 2, 3]);
    for (const lazy of [false, true]) {
        const json = sample();
        delete json.matrix.val;
        json.matrix.palette = palette;
        if (lazy) {
            json.matrix.rows_per_segment = 2;
            json.matrix.col = segmented('u16', new Uint16Array([1, 1, 0, 0, 1]), [0, 3, 5], true);
            json.matrix.entry_index = segmented('u16', index, [0, 3, 5], true);
        } else json.matrix.entry_index = planes('u16', index);
        const model = await decodeData(json);
        const m = await loadMatrix(model);
        await loadAll(m);
        const whole = await decoded(sample());
        for (let i = 0; i < 3; ++i) assert.deepEqual([...denseRow(m, 3, i)], [...denseRow(whole.matrix, 3, i)], `row ${i}${lazy ? ', lazy' : ''}`);
        assert.deepEqual([...m.se].map((x) => Math.round(x * 1e4)), [250, 500, 500, 125, 375]);
        const bad = sample();
        delete bad.matrix.val;
        bad.matrix.palette = palette;
        bad.matrix.entry_index = planes('u16', new Uint16Array([1, 0, 0, 2, 4]));
        await assert.rejects(decoded(bad), /palette/);
    }
});

test('columns stored as they are (no row-delta coding) read the same', async () => {
    const json = sample();
    json.matrix.col = arr('u16', new Uint16Array([1, 2, 0, 0, 1]));
    delete json.matrix.col_coding;
    assert.deepEqual([...(await decoded(json)).matrix.col], [1, 2, 0, 0, 1]);
    // u32 columns (N > 65,536) decode the same way.
    json.matrix.col = arr('u32', new Uint32Array([1, 1, 0, 0, 1]));
    json.matrix.col_coding = 'row-delta';
    assert.deepEqual([...(await decoded(json)).matrix.col], [1, 2, 0, 0, 1]);
});

test('rows, columns and entries read the CSR arrays', async () => {
    const m = await decoded(sample());
    assert.equal(m.n, 3);
    assert.deepEqual([...row(m.matrix, 2).cols], [0, 1]);
    assert.deepEqual([...denseRow(m.matrix, 3, 0)], [0, 0.25, 0.5]);
    assert.deepEqual([...denseColumn(m.matrix, 3, 0)], [0, 0.5, 0.125]);
    assert.deepEqual([...denseColumn(m.matrix, 3, 1)], [0.25, 0, 0.375]);
    assert.equal(entry(m.matrix, 0, 2), 0.5);
    assert.equal(entry(m.matrix, 1, 2), 0);
    assert.equal(entry(m.matrix, 2, 2), 0);
    assert.equal(m.surfaces[1].name, '<img onerror=alert(1)>');
});

test('top entries come largest first, ties by the lower patch', async () => {
    const m = await decoded(sample());
    assert.deepEqual(topEntries(m.matrix, 0, 5).map((t) => [t.j, t.value]), [[2, 0.5], [1, 0.25]]);
    assert.deepEqual(topEntries(m.matrix, 2, 1).map((t) => t.j), [1]);
});

test('reciprocity compares A_i F_ij with A_j F_ji', async () => {
    const m = await decoded(sample());
    const r = reciprocity(m, 0, 1); // 1 × 0.25 against 0.5 × 0.5
    assert.equal(r.forward, 0.25);
    assert.equal(r.backward, 0.25);
    assert.equal(r.defect, 0);
    const s = reciprocity(m, 0, 2); // 1 × 0.5 against 2 × 0.125
    assert.equal(s.defect, 0.5);
    assert.equal(reciprocity(m, 1, 2).defect, 1); // F12 was not stored, F21 was
});

test('per-surface form factors are area-weighted sums of the rows', async () => {
    const m = await decoded(sample());
    // surface 0 = patches 0 (A 1) and 1 (A 0.5): to surface 1: (1 × 0.5) / 1.5; to itself (1 × 0.25 + 0.5 × 0.5) / 1.5
    const r = surfaceRow(m, 0);
    assert.ok(Math.abs(r[1] - 0.5 / 1.5) < 1e-7);
    assert.ok(Math.abs(r[0] - 0.5 / 1.5) < 1e-7);
    assert.deepEqual([...surfaceRow(m, 1)], [0.5, 0]);
    // The column into surface t is each surface's row, read at t.
    for (const t of [0, 1]) assert.deepEqual([...surfaceColumn(m, t)], [surfaceRow(m, 0)[t], surfaceRow(m, 1)[t]]);
});

test('the storage statement says how much of F is kept and the share of a row dropped', async () => {
    const { storageText } = await import('../src/data.js');
    assert.equal(storageText({ stored_entries: 2430, nonzeros: 2430, threshold: 0 }),
        'F: 2,430 of 2,430 nonzero entries stored (all)');
    assert.equal(storageText({ stored_entries: 914755, nonzeros: 2191681, threshold: 5.0e-4,
        dropped_share_mean: 0.1104, dropped_share_max: 0.5 }),
        'F: 914,755 of 2,191,681 nonzero entries stored (F > 0.00050); a row drops 11.0 % of its mass on average, 50.0 % at most');
});
