// batch.js - many compressed tiles in one round trip: GET
// /v1/images/{id}/batch?t=L,X,Y;... and its "GVB1" framing (docs/API.md,
// "Batches").  GET rather than POST so that the browser's HTTP cache and
// proxies keep whole batches (a batch of 200s is immutable).
//
// fetchPrepared() also checks every tile and decodes entropy-coded
// indices (tilebuf.js), or the residuals of codes (heighttile.js): it
// is what tile_worker.js runs off the main thread, and what the viewer
// runs itself where workers are unavailable.

import { prepareSampleTile } from './heighttile.js';
import { prepareTile } from './tilebuf.js';

/** The batch URL for tiles [[level, tx, ty], ...] of image base `imageUrl`. */
export function batchUrl(imageUrl, tiles) {
    return `${imageUrl}/batch?t=${tiles.map((t) => t.join(',')).join(';')}`;
}

/**
 * Parse a GVB1 or GVB2 response (an ArrayBuffer; GVB2 frames also carry
 * the tile's ETag, docs/API.md).  Returns [{level, tx, ty, status, tile,
 * etag}], tile a Uint8Array view of the buffer (empty unless status is
 * 200), etag '' in GVB1.  Throws on a malformed body.
 */
export function parseBatch(buf) {
    const dv = new DataView(buf);
    const magic = buf.byteLength < 8 ? 0 : dv.getUint32(0, false);
    if (magic !== 0x47564231 && magic !== 0x47564232)   // "GVB1", "GVB2"
        throw new Error('batch: not a GVB1 or GVB2 body');
    const n = dv.getUint32(4, true), out = [];
    let off = 8;
    for (let i = 0; i < n; i++) {
        if (off + 20 > buf.byteLength)
            throw new Error(`batch: frame ${i} of ${n} is cut short`);
        const e = dv.getUint8(off + 1), len = dv.getUint32(off + 16, true);
        const at = off + 20 + ((e + 3) & ~3);
        if (at + len > buf.byteLength)
            throw new Error(`batch: tile ${i} of ${n} is cut short`);
        out.push({
            level: dv.getUint8(off), tx: dv.getUint32(off + 4, true),
            ty: dv.getUint32(off + 8, true), status: dv.getUint32(off + 12, true),
            tile: new Uint8Array(buf, at, len),
            etag: new TextDecoder().decode(new Uint8Array(buf, off + 20, e)),
        });
        off = at + ((len + 3) & ~3);
    }
    return out;
}

/** The typed arrays a prepared tile holds (what a worker transfers and
 * the tile cache counts). */
export function prepArrays(prep) {
    return [prep.words, prep.indices, prep.coefs, prep.q, prep.e, prep.coded].filter((a) => a);
}

/**
 * Fetch tiles [[level, tx, ty], ...] and prepare each for the GPU.
 * form: {channels, codes}: the image's channels, and whether its tiles
 * are 16-bit codes (a sample or height store, docs/FORMAT.md sections 12
 * and 13: a height tile buffer a channel).  Resolves to {bytes, ms,
 * tiles: [{level, tx, ty, status, error?, prep?}]}: prep from prepareTile
 * (prepareSampleTile for codes) for a well-formed 200 tile, error
 * (a message) for a damaged or missing one.  Rejects on a network error,
 * an HTTP error status (the error's `status`) or an abort (signal).
 */
export async function fetchPrepared(imageUrl, tiles, form, signal) {
    const t0 = performance.now();
    const resp = await fetch(batchUrl(imageUrl, tiles), { signal });
    if (!resp.ok) {
        const e = new Error(`batch: HTTP ${resp.status}`);
        e.status = resp.status;   // 401: the login has expired (tile_cache.js)
        throw e;
    }
    const buf = await resp.arrayBuffer();
    const frames = parseBatch(buf);
    const t1 = performance.now();
    const out = [];
    for (const f of frames) {
        const r = { level: f.level, tx: f.tx, ty: f.ty, status: f.status };
        if (f.status === 200) {
            try {
                r.prep = form.codes ? prepareSampleTile(f.tile, form.channels)
                    : prepareTile(f.tile, form.channels);
            } catch (e) {
                r.status = 500;
                r.error = e.message;
            }
        } else {
            r.error = `HTTP ${f.status}`;
        }
        out.push(r);
    }
    return { bytes: buf.byteLength, fetchMs: t1 - t0, prepMs: performance.now() - t1, tiles: out };
}
