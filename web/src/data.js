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
    const stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream('deflate'));
    return new Uint8Array(await new Response(stream).arrayBuffer());
}

/// A typed array from {dtype, count, base64} (little-endian, as the writer stores it), the bytes
/// deflated when the entry says compression: 'deflate', and stored by byte planes (every value's
/// first byte, then every second byte, ...) when it says byte_planes. Rejects on an unknown dtype or
/// compression, or a length that does not match count.
export async function decodeArray(entry) {
    const Type = kArrayTypes[entry.dtype];
    if (!Type) throw new Error(`unknown dtype '${entry.dtype}'`);
    let bytes = base64ToBytes(entry.base64);
    if (entry.compression === 'deflate') bytes = await inflate(bytes);
    else if (entry.compression !== undefined) throw new Error(`unknown compression '${entry.compression}'`);
    if (bytes.length !== entry.count * Type.BYTES_PER_ELEMENT)
        throw new Error(`array of ${entry.count} ${entry.dtype} has ${bytes.length} bytes`);
    if (entry.byte_planes) {
        // Every value's first byte, then every second byte, ...: back to values.
        const w = Type.BYTES_PER_ELEMENT, n = entry.count, out = new Uint8Array(bytes.length);
        for (let b = 0; b < w; ++b) {
            const plane = bytes.subarray(b * n, (b + 1) * n);
            for (let k = 0, o = b; k < n; ++k, o += w) out[o] = plane[k];
        }
        bytes = out;
    }
    // A view needs an aligned offset; a copy when the bytes do not start on one.
    if (bytes.byteOffset % Type.BYTES_PER_ELEMENT !== 0) bytes = bytes.slice();
    return new Type(bytes.buffer, bytes.byteOffset, entry.count);
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
/// entries were left out and each row's dropped mass, from the data block's matrix.
export async function decodeMatrix(m, n) {
    const [rowPtr, col, val, se, dropped, rowSum] = await Promise.all(
        [m.row_ptr, m.col, m.val, m.standard_error, m.dropped, m.row_sum].map((a) => (a ? decodeArray(a) : null)));
    if (rowPtr.length !== n + 1 || rowPtr[n] !== col.length || val.length !== col.length)
        throw new Error('matrix row pointers do not match its entries');
    if (m.col_coding === 'row-delta') {
        // Each column after the first of its row is the step from the one before.
        for (let i = 0; i < n; ++i)
            for (let k = rowPtr[i] + 1; k < rowPtr[i + 1]; ++k) col[k] += col[k - 1];
    } else if (m.col_coding !== undefined) throw new Error(`unknown column coding '${m.col_coding}'`);
    return {
        threshold: m.threshold,
        storedEntries: m.stored_entries,
        nonzeros: m.nonzeros,
        rowPtr, col, val, se, dropped, rowSum,
        columns: null,
    };
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

/// The model's rows of F, decoded on the first call (later calls share it); null when the page
/// has none.
export function loadMatrix(model) {
    if (!model.hasMatrix) return Promise.resolve(null);
    model.matrixLoading ??= decodeMatrix(model.matrixBlock, model.n).then((m) => (model.matrix = m));
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
