// The page's data: the JSON the C++ writer (src/output/page.cpp) puts in
// <script type="application/json" id="ff-data">, decoded into typed arrays, and the questions the
// page asks of it (a row of F, a column, the largest entries, reciprocity, per-surface sums).
// Pure functions, no DOM: node's test runner checks them (test/data.test.js).

// Six bits per base64 character code (RFC 4648; 255: not in the alphabet).
const kBase64Value = (() => {
    const table = new Uint8Array(256).fill(255);
    const alphabet = 'ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/';
    for (let k = 0; k < alphabet.length; ++k) table[alphabet.charCodeAt(k)] = k;
    return table;
})();

/// Bytes of a base64 string (RFC 4648, with or without padding), straight from the string's
/// character codes into the bytes (no intermediate binary string; the browser's native
/// Uint8Array.fromBase64 when it has one). Throws on a character outside the alphabet.
export function base64ToBytes(text) {
    if (typeof Uint8Array.fromBase64 === 'function') return Uint8Array.fromBase64(text);
    let end = text.length;
    while (end > 0 && text.charCodeAt(end - 1) === 61) --end;  // '=' padding
    const out = new Uint8Array((end * 3) >>> 2);
    const v = kBase64Value;
    let o = 0, k = 0;
    const whole = end - (end % 4);
    for (; k < whole; k += 4) {
        const a = v[text.charCodeAt(k)], b = v[text.charCodeAt(k + 1)];
        const c = v[text.charCodeAt(k + 2)], d = v[text.charCodeAt(k + 3)];
        if ((a | b | c | d) > 63) throw new Error('not base64');
        out[o++] = (a << 2) | (b >> 4);
        out[o++] = ((b & 15) << 4) | (c >> 2);
        out[o++] = ((c & 3) << 6) | d;
    }
    const rest = end - k;
    if (rest === 1) throw new Error('not base64 (length)');
    if (rest >= 2) {
        const a = v[text.charCodeAt(k)], b = v[text.charCodeAt(k + 1)];
        const c = rest === 3 ? v[text.charCodeAt(k + 2)] : 0;
        if ((a | b | c) > 63) throw new Error('not base64');
        out[o++] = (a << 2) | (b >> 4);
        if (rest === 3) out[o++] = ((b & 15) << 4) | (c >> 2);
    }
    return out;
}

const kArrayTypes = { f32: Float32Array, f64: Float64Array, u16: Uint16Array, u32: Uint32Array, i32: Int32Array };

/// The bytes of a zlib stream (RFC 1950), by the browser's (or node's) DecompressionStream: no
/// library, no request. Rejects on a stream that is not zlib's or is cut short.
export async function inflate(bytes) {
    return pipe(bytes, new DecompressionStream('deflate'));
}

// The bytes out of a transform stream fed `bytes` (written straight to it: a Blob's stream
// costs several times as much per call, which tells when a click inflates a few dozen segments).
async function pipe(bytes, transform) {
    const writer = transform.writable.getWriter();
    // A broken stream rejects both sides: the reading side tells.
    writer.write(bytes).then(() => writer.close()).catch(() => {});
    return new Uint8Array(await new Response(transform.readable).arrayBuffer());
}

/// The bytes of a raw deflate stream (RFC 1951) that may end without its final block (a segment
/// cut at a full flush): an empty final block is added.
async function inflateRaw(bytes) {
    const closed = new Uint8Array(bytes.length + 2);
    closed.set(bytes);
    closed.set([3, 0], bytes.length);
    return pipe(closed, new DecompressionStream('deflate-raw'));
}

// The value offsets of an entry's segments: [0, ..., count] ([0, count]: one segment).
function segmentsOf(entry) {
    const s = entry.segments ?? [0, entry.count];
    if (s[0] !== 0 || s[s.length - 1] !== entry.count) throw new Error('array segments do not cover its values');
    return s;
}

// Byte planes (every value's first byte, then every second byte, ... within each segment) back
// to values; `bounds` are the segments' value offsets relative to bytes.
function unplane(bytes, width, bounds) {
    const out = new Uint8Array(bytes.length);
    for (let s = 0; s + 1 < bounds.length; ++s) {
        const a = bounds[s] - bounds[0], n = bounds[s + 1] - bounds[s], base = a * width;
        for (let b = 0; b < width; ++b) {
            const plane = bytes.subarray(base + b * n, base + (b + 1) * n);
            for (let k = 0, o = base + b; k < n; ++k, o += width) out[o] = plane[k];
        }
    }
    return out;
}

function typeOf(entry) {
    const Type = kArrayTypes[entry.dtype];
    if (!Type) throw new Error(`unknown dtype '${entry.dtype}'`);
    return Type;
}

// A typed array on bytes (a copy when they do not start on an aligned offset).
function view(Type, bytes, count) {
    if (bytes.byteOffset % Type.BYTES_PER_ELEMENT !== 0) bytes = bytes.slice();
    return new Type(bytes.buffer, bytes.byteOffset, count);
}

/// A typed array from {dtype, count, base64} (little-endian, as the writer stores it), the bytes
/// deflated when the entry says compression: 'deflate', and stored by byte planes (every value's
/// first byte, then every second byte, ...; within each of its segments when it has them) when
/// it says byte_planes. Rejects on an unknown dtype or compression, or a length that does not
/// match count.
export async function decodeArray(entry) {
    const Type = typeOf(entry);
    let bytes = base64ToBytes(entry.base64);
    if (entry.compression === 'deflate') bytes = await inflate(bytes);
    else if (entry.compression !== undefined) throw new Error(`unknown compression '${entry.compression}'`);
    if (bytes.length !== entry.count * Type.BYTES_PER_ELEMENT)
        throw new Error(`array of ${entry.count} ${entry.dtype} has ${bytes.length} bytes`);
    if (entry.byte_planes) bytes = unplane(bytes, Type.BYTES_PER_ELEMENT, segmentsOf(entry));
    return view(Type, bytes, entry.count);
}

/// Segment k of an array stored in segments ({segments, segment_bytes}: a full flush of the
/// deflate stream after each), inflated alone: {start, values} (start: the offset of its first
/// value in the whole array).
export async function decodeSegment(entry, k) {
    const Type = typeOf(entry), bounds = segmentsOf(entry), at = entry.segment_bytes;
    if (entry.compression !== 'deflate' || !at || at.length !== bounds.length)
        throw new Error('array is not stored in segments');
    const a = at[k], b = at[k + 1];
    // The base64 characters that hold bytes [a, b): whole groups of 4 characters for 3 bytes.
    const text = entry.base64.slice(Math.floor(a / 3) * 4, Math.ceil(b / 3) * 4);
    const skip = a % 3;
    let bytes = await inflateRaw(base64ToBytes(text).subarray(skip, skip + (b - a)));
    const count = bounds[k + 1] - bounds[k];
    if (bytes.length !== count * Type.BYTES_PER_ELEMENT)
        throw new Error(`segment ${k} of ${count} ${entry.dtype} has ${bytes.length} bytes`);
    if (entry.byte_planes) bytes = unplane(bytes, Type.BYTES_PER_ELEMENT, [bounds[k], bounds[k + 1]]);
    return { start: bounds[k], values: view(Type, bytes, count) };
}

/// The decoded model, what drawing the scene needs: patches (areas, surfaces, polygon
/// vertices, triangles), surfaces and colour fields. The rows of F are decoded apart, when first
/// asked for (loadMatrix): until then model.matrix is null and model.hasMatrix says whether the
/// page has them.
export async function decodeData(json) {
    if (json.format !== 'formfactor-page' || json.version !== 2)
        throw new Error('not a formfactor page data block (format/version)');
    const n = json.patches.count;
    const p = json.patches;
    const [area, surface, vertexOffset, vertices, triangles, trianglePatch, ...fieldValues] = await Promise.all([
        p.area, p.surface, p.vertex_offset, p.vertices, p.triangles, p.triangle_patch,
        ...(json.fields ?? []).map((f) => f.values),
    ].map(decodeArray));
    const model = {
        n,
        title: json.title ?? '',
        scene: json.scene ?? {},
        camera: json.camera ?? null,
        report: json.report ?? null,
        surfaces: json.surfaces ?? [],
        area, surface, vertexOffset, vertices, triangles, trianglePatch,
        fields: (json.fields ?? []).map((f, k) => ({ ...f, values: fieldValues[k] })),
        hasMatrix: Boolean(json.matrix),
        matrix: null,
        matrixBlock: json.matrix ?? null,
        matrixLoading: null,
    };
    if (model.area.length !== n || model.surface.length !== n || model.vertexOffset.length !== n + 1)
        throw new Error('patch arrays do not match the patch count');
    return model;
}

/// The stored rows of F (CSR, columns ascending in each row), with the threshold below which
/// entries were left out and each row's dropped mass, from the data block's matrix and its
/// entries ({col, val, standard_error}, or {col, entry_index} with the matrix's palette of
/// (value, standard error) pairs). Entries stored in segments of rows are inflated when their
/// rows are first asked for (loadRows, loadAll); until then they read as 0. Others are decoded
/// at once.
export async function decodeMatrix(m, n, entries = m) {
    const [rowPtr, dropped, rowSum] = await Promise.all([m.row_ptr, m.dropped, m.row_sum].map(decodeArray));
    if (m.col_coding !== undefined && m.col_coding !== 'row-delta') throw new Error(`unknown column coding '${m.col_coding}'`);
    const palette = m.palette ? {
        val: await decodeArray(m.palette.val),
        se: m.palette.standard_error ? await decodeArray(m.palette.standard_error) : null,
    } : null;
    const stored = palette ? { col: entries.col, index: entries.entry_index, palette }
        : { col: entries.col, val: entries.val, se: entries.standard_error ?? null };
    const valueCount = (palette ? stored.index : stored.val)?.count;
    if (rowPtr.length !== n + 1 || rowPtr[n] !== stored.col.count || valueCount !== stored.col.count)
        throw new Error('matrix row pointers do not match its entries');
    const perSegment = m.rows_per_segment;
    const lazy = perSegment > 0 && [stored.col, stored.val, stored.se, stored.index].every((e) => !e || e.segment_bytes);
    const matrix = {
        threshold: m.threshold,
        storedEntries: m.stored_entries,
        nonzeros: m.nonzeros,
        rowPtr, dropped, rowSum,
        col: null, val: null, se: null,
        columns: null,
        stored, rowDelta: m.col_coding === 'row-delta',
        rowsPerSegment: lazy ? perSegment : n,
        segments: [],  // a promise per segment once asked for
        asked: 0,  // calls of loadRows under way
        complete: null,  // the promise of every segment
    };
    if (lazy) {
        const count = stored.col.count;
        matrix.col = new (typeOf(stored.col))(count);
        matrix.val = new Float32Array(count);
        matrix.se = (palette ? palette.se : stored.se) ? new Float32Array(count) : null;
        matrix.loaded = new Uint8Array(Math.ceil(n / perSegment));
        return matrix;
    }
    if (palette) {
        const [col, index] = await Promise.all([stored.col, stored.index].map(decodeArray));
        matrix.col = col;
        matrix.val = new Float32Array(col.length);
        matrix.se = palette.se ? new Float32Array(col.length) : null;
        fromPalette(matrix, palette, index, 0);
    } else {
        [matrix.col, matrix.val, matrix.se] = await Promise.all([stored.col, stored.val, stored.se].map((a) => (a ? decodeArray(a) : null)));
    }
    if (matrix.rowDelta) undoRowDelta(matrix.col, rowPtr, 0, n);
    matrix.loaded = new Uint8Array(1).fill(1);
    matrix.complete = Promise.resolve(matrix);
    return matrix;
}

// Entries [start, start + index.length) from their pairs' indices into the palette.
function fromPalette(matrix, palette, index, start) {
    const val = matrix.val, se = matrix.se, pv = palette.val, ps = palette.se;
    for (let k = 0; k < index.length; ++k) {
        const p = index[k];
        if (p >= pv.length) throw new Error('an entry of F names a pair the palette does not have');
        val[start + k] = pv[p];
        if (ps) se[start + k] = ps[p];
    }
}

// Each column after the first of its row is the step from the one before: rows [a, b) summed back.
function undoRowDelta(col, rowPtr, a, b) {
    for (let i = a; i < b; ++i)
        for (let k = rowPtr[i] + 1; k < rowPtr[i + 1]; ++k) col[k] += col[k - 1];
}

// Inflates segment s of F's entries (rows [s R, (s + 1) R)) into the matrix, once.
function loadSegment(matrix, s) {
    if (matrix.loaded[s]) return Promise.resolve();
    matrix.segments[s] ??= (async () => {
        const { col, val, se, index, palette } = matrix.stored;
        const parts = await Promise.all([col, val, se, index].map((e) => (e ? decodeSegment(e, s) : null)));
        const start = parts[0].start;
        matrix.col.set(parts[0].values, start);
        if (palette) fromPalette(matrix, palette, parts[3].values, start);
        else {
            matrix.val.set(parts[1].values, start);
            if (parts[2]) matrix.se.set(parts[2].values, start);
        }
        const n = matrix.rowPtr.length - 1, R = matrix.rowsPerSegment;
        if (matrix.rowDelta) undoRowDelta(matrix.col, matrix.rowPtr, s * R, Math.min(n, (s + 1) * R));
        matrix.loaded[s] = 1;
    })();
    return matrix.segments[s];
}

/// Whether rows i of F are decoded (every one of `rows`).
export function rowsLoaded(matrix, rows) {
    return rows.every((i) => matrix.loaded[Math.floor(i / matrix.rowsPerSegment)] === 1);
}

/// Decodes the rows `rows` of F (their segments) when they are not yet.
export async function loadRows(matrix, rows) {
    const segments = new Set(rows.map((i) => Math.floor(i / matrix.rowsPerSegment)));
    ++matrix.asked;
    try {
        await Promise.all([...segments].map((s) => loadSegment(matrix, s)));
    } finally {
        --matrix.asked;
    }
    return matrix;
}

/// Decodes every row of F, one segment after the other, pausing while rows asked for by
/// loadRows (a click) are being decoded so that they come first; later calls share it.
export function loadAll(matrix) {
    const pause = (ms) => new Promise((resolve) => setTimeout(resolve, ms));
    matrix.complete ??= (async () => {
        for (let s = 0; s < matrix.loaded.length; ++s) {
            while (matrix.asked > 0) await pause(10);
            if (matrix.loaded[s]) continue;
            await loadSegment(matrix, s);
            await pause(0);
        }
        return matrix;
    })();
    return matrix.complete;
}

/// Whether every row of F is decoded.
export function allLoaded(matrix) {
    return matrix.loaded.every((x) => x === 1);
}

/// What the page says of the F it stores (the data block's matrix, before it is decoded): how
/// many of F's nonzero entries, the threshold, and the share of its mass a row drops.
export function storageText(m) {
    const count = (x) => Number(x).toLocaleString('en-US');
    const percent = (x) => `${(100 * (x ?? 0)).toFixed(1)} %`;
    const stored = `F: ${count(m.stored_entries)} of ${count(m.nonzeros)} nonzero entries stored`;
    if (m.stored_entries >= m.nonzeros) return `${stored} (all)`;
    return `${stored} (F > ${Number(m.threshold).toPrecision(2)}); a row drops ` +
        `${percent(m.dropped_share_mean)} of its mass on average, ${percent(m.dropped_share_max)} at most`;
}

/// The model's F (its row sums, dropped mass and row pointers decoded; its entries as they are
/// asked for, decodeMatrix), on the first call (later calls share it); null when the page has
/// none. The entries are in the matrix block itself or in the page's block named by its
/// entries_block (read once the document is parsed).
export function loadMatrix(model) {
    if (!model.hasMatrix) return Promise.resolve(null);
    model.matrixLoading ??= (async () => {
        const m = model.matrixBlock;
        let entries = m;
        if (m.entries_block) {
            if (document.readyState === 'loading')
                await new Promise((resolve) => document.addEventListener('DOMContentLoaded', resolve, { once: true }));
            const block = document.getElementById(m.entries_block);
            if (!block) throw new Error(`no block '${m.entries_block}' with the entries of F`);
            entries = JSON.parse(block.textContent);
        }
        return (model.matrix = await decodeMatrix(m, model.n, entries));
    })();
    return model.matrixLoading;
}

/// Row i of F as stored: {cols, vals, se} (views into the CSR arrays, columns ascending).
export function row(matrix, i) {
    const a = matrix.rowPtr[i], b = matrix.rowPtr[i + 1];
    return {
        cols: matrix.col.subarray(a, b),
        vals: matrix.val.subarray(a, b),
        se: matrix.se ? matrix.se.subarray(a, b) : null,
    };
}

/// Row i as one value per patch (0 where nothing is stored).
export function denseRow(matrix, n, i) {
    const out = new Float32Array(n);
    const r = row(matrix, i);
    for (let k = 0; k < r.cols.length; ++k) out[r.cols[k]] = r.vals[k];
    return out;
}

/// Column j as one value per patch: F_ij for every i (who sees j). The transpose is built on
/// first use and kept (O(stored entries)).
export function denseColumn(matrix, n, j) {
    if (!matrix.columns) {
        const count = new Uint32Array(n + 1);
        for (let k = 0; k < matrix.col.length; ++k) ++count[matrix.col[k] + 1];
        for (let c = 0; c < n; ++c) count[c + 1] += count[c];
        const rows = new Uint32Array(matrix.col.length);
        const vals = new Float32Array(matrix.col.length);
        const fill = count.slice(0, n);
        for (let i = 0; i < n; ++i)
            for (let k = matrix.rowPtr[i]; k < matrix.rowPtr[i + 1]; ++k) {
                const at = fill[matrix.col[k]]++;
                rows[at] = i;
                vals[at] = matrix.val[k];
            }
        matrix.columns = { ptr: count, rows, vals };
    }
    const t = matrix.columns;
    const out = new Float32Array(n);
    for (let k = t.ptr[j]; k < t.ptr[j + 1]; ++k) out[t.rows[k]] = t.vals[k];
    return out;
}

/// The value of F_ij as stored (0 when not stored), by binary search in row i.
export function entry(matrix, i, j) {
    let lo = matrix.rowPtr[i], hi = matrix.rowPtr[i + 1];
    while (lo < hi) {
        const mid = (lo + hi) >>> 1;
        if (matrix.col[mid] < j) lo = mid + 1;
        else hi = mid;
    }
    return lo < matrix.rowPtr[i + 1] && matrix.col[lo] === j ? matrix.val[lo] : 0;
}

/// The k largest entries of row i, largest first: [{j, value, se}] (ties by lower j).
export function topEntries(matrix, i, k) {
    const r = row(matrix, i);
    const order = Array.from(r.cols.keys());
    order.sort((a, b) => r.vals[b] - r.vals[a] || r.cols[a] - r.cols[b]);
    return order.slice(0, k).map((at) => ({
        j: r.cols[at],
        value: r.vals[at],
        se: r.se ? r.se[at] : null,
    }));
}

/// Reciprocity of the pair (i, j): A_i F_ij, A_j F_ji and |A_i F_ij − A_j F_ji| / max of the two
/// (0 when both are 0), from the stored entries.
export function reciprocity(model, i, j) {
    const a = model.area[i] * entry(model.matrix, i, j);
    const b = model.area[j] * entry(model.matrix, j, i);
    const m = Math.max(a, b);
    return { forward: a, backward: b, defect: m > 0 ? Math.abs(a - b) / m : 0 };
}

/// Per-surface form factors from surface s: F_{s→t} = Σ_{i∈s} A_i Σ_{j∈t} F_ij / A_s for every
/// surface t (from the stored entries), as one value per surface.
export function surfaceRow(model, s) {
    const out = new Float64Array(model.surfaces.length);
    let areaS = 0;
    for (let i = 0; i < model.n; ++i) {
        if (model.surface[i] !== s) continue;
        areaS += model.area[i];
        const r = row(model.matrix, i);
        for (let k = 0; k < r.cols.length; ++k) out[model.surface[r.cols[k]]] += model.area[i] * r.vals[k];
    }
    if (areaS > 0) for (let t = 0; t < out.length; ++t) out[t] /= areaS;
    return out;
}

/// Per-surface form factors into surface t: F_{s→t} for every surface s, as one value per
/// surface (one pass over the stored entries).
export function surfaceColumn(model, t) {
    const out = new Float64Array(model.surfaces.length);
    const areaOf = new Float64Array(model.surfaces.length);
    for (let i = 0; i < model.n; ++i) {
        const s = model.surface[i];
        areaOf[s] += model.area[i];
        const r = row(model.matrix, i);
        for (let k = 0; k < r.cols.length; ++k)
            if (model.surface[r.cols[k]] === t) out[s] += model.area[i] * r.vals[k];
    }
    for (let s = 0; s < out.length; ++s) if (areaOf[s] > 0) out[s] /= areaOf[s];
    return out;
}

/// The patches of surface s (their indices, ascending).
export function patchesOfSurface(model, s) {
    const out = [];
    for (let i = 0; i < model.n; ++i) if (model.surface[i] === s) out.push(i);
    return out;
}

/// The page's colour modes, in the order of its menu: every field of the data block (its label,
/// with the unit in parentheses when it has one), then 'surface', then 'row' when the page has a
/// matrix. [{key, label}].
export function colourModes(model) {
    const modes = model.fields.map((f) => ({ key: f.key, label: f.unit ? `${f.label} (${f.unit})` : f.label }));
    modes.push({ key: 'surface', label: 'surface' });
    if (model.hasMatrix) modes.push({ key: 'row', label: 'row of F of the clicked patch' });
    return modes;
}
