// tile_cache.js - decoded tiles on the GPU: what to fetch, what to decode
// next, and what to forget (thesis section 7.5).
//
// Three stores, each keyed "level/tx/ty":
//   - textures: decoded tiles (the decoder's, tileBytes each: 513^2
//     RGBA8UI for an image store, 513^2 R16UI a channel for codes), an LRU
//     bounded in bytes.  The root tile and the root mips are uploaded at
//     start and never evicted.  Tiles the current view draws and all their
//     ancestors are pinned for the frame: the ancestors are what a missing
//     tile is drawn from, and what the next decode needs.
//   - prepared: fetched, checked tile buffers ready for the GPU (words and
//     decoded rANS indices), an LRU bounded in bytes, so that a texture
//     evicted and needed again costs a decode and no round trip.
//   - inflight / failed: tiles in a batch on the wire, and tiles the
//     server answered with an error or that failed their check (never
//     asked again this session; their area keeps showing an ancestor).
//
// Each frame the viewer calls update(needed, prefetch, budgetMs): for
// every needed tile (nearest the view centre first) the chain of missing
// ancestors is walked up to the first resident one, and what is neither
// prepared nor in flight is fetched in batches, coarsest first (recursive
// parent pulling).  Then tiles are decoded, each right after its parent,
// until the time slice is spent.  Only when every needed tile is resident
// or on its way does the prefetch circle get fetched and decoded, and then
// only into free room or room taken by tiles outside view and circle,
// never by the parent the tile is about to be decoded from (a prefetched
// tile's parent is often outside both; evicting it left a tile decoded
// from no texture, drawn wrong once the view reached it).

import { prepArrays } from './batch.js';
import { TILE } from './tilebuf.js';

export const key = (k, x, y) => `${k}/${x}/${y}`;

const BATCH_MAX = 48;        // tiles per batch request (the server allows 256)
const INFLIGHT_MAX = 4;      // batches on the wire at once
const PREFETCH_INFLIGHT = 2; // of which prefetching may hold (the view gets the rest)
// Decodes per frame at most, whatever the time slice says: submitting is
// cheap, so the slice alone could queue more GPU work than one frame
// should carry (one decode is ~0.1 ms on a GPU, ~40 ms on SwiftShader).
const DECODES_PER_FRAME = 12;

export class TileCache {
    /**
     * decoder: a GpuDecoder or a CodesDecoder (sample stores); info: /v1/images/{id} metadata; imageUrl: its
     * absolute URL; levels: pyramid.levelsOf(info); fetcher: a Fetcher;
     * budget: bytes of decoded tiles to keep (soft for pinned tiles);
     * onChange(): called when fetched data arrives (schedule a frame).
     * onUnauthorized(): called when a batch answers 401 (a login that has
     * expired): fetching then waits for resume().
     */
    constructor({ decoder, info, imageUrl, levels, fetcher, budget, prepBudget, onChange,
        onUnauthorized }) {
        this.dec = decoder;
        this.info = info;
        this.imageUrl = imageUrl;
        this.levels = levels;
        this.R = info.levels_tiled;
        this.form = { channels: info.channels, codes: !!(info.samples || info.elevation) };
        this.channels = info.channels;
        this.tileBytes = decoder.tileBytes;
        this.fetcher = fetcher;
        this.budget = budget;
        this.prepBudget = prepBudget || 64 << 20;
        this.onChange = onChange || (() => {});
        this.onUnauthorized = onUnauthorized || (() => {});
        this.tex = new Map();       // key -> {tex, used, fixed}
        this.prep = new Map();      // key -> {prep, used}
        this.inflight = new Set();
        this.failed = new Map();    // key -> message
        this.batches = 0;           // batches on the wire
        this.clock = 0;
        this.texBytes = 0;
        this.prepBytes = 0;
        this.disposed = false;
        this.stats = {
            batches: 0, bytes: 0, tilesFetched: 0, decoded: 0, entropy: 0, dct: 0, prefetched: 0,
            decodeMs: 0, fetchMs: 0, prepMs: 0, evicted: 0, errors: 0, lastError: '',
        };
    }

    /** Upload the root tile (level R, the root clamp-padded to 513^2) and
     * the root mips (levels R+1 ..) from the root's raw samples (bytes, or
     * 16-bit codes in a Uint16Array: the same box filter serves both). */
    setRoot(px, w, h) {
        const c = this.channels, Px = px.constructor;
        const padded = new Px(TILE * TILE * c);
        for (let v = 0; v < TILE; v++) {
            const sy = Math.min(v, h - 1);
            for (let u = 0; u < TILE; u++) {
                const s = (sy * w + Math.min(u, w - 1)) * c, d = (v * TILE + u) * c;
                for (let k = 0; k < c; k++)
                    padded[d + k] = px[s + k];
            }
        }
        this.tex.set(key(this.R, 0, 0), { tex: this.dec.upload(padded, TILE, TILE), used: 0, fixed: true });
        // Mips: the 2x2 box filter with odd edges replicated (FORMAT.md 1).
        let cur = px, cw = w, ch = h;
        for (let k = this.R + 1; k < this.levels.length; k++) {
            const nw = (cw + 1) >> 1, nh = (ch + 1) >> 1, next = new Px(nw * nh * c);
            for (let y = 0; y < nh; y++) {
                const r0 = 2 * y, r1 = Math.min(2 * y + 1, ch - 1);
                for (let x = 0; x < nw; x++) {
                    const a = 2 * x, b = Math.min(2 * x + 1, cw - 1);
                    for (let q = 0; q < c; q++)
                        next[(y * nw + x) * c + q] = (cur[(r0 * cw + a) * c + q] + cur[(r0 * cw + b) * c + q] +
                            cur[(r1 * cw + a) * c + q] + cur[(r1 * cw + b) * c + q] + 2) >> 2;
                }
            }
            this.tex.set(key(k, 0, 0), { tex: this.dec.upload(next, nw, nh), used: 0, fixed: true });
            cur = next; cw = nw; ch = nh;
        }
    }

    /** The texture of tile (k, tx, ty) if resident (marks it used), else null. */
    get(k, tx, ty) {
        const e = this.tex.get(key(k, tx, ty));
        if (!e)
            return null;
        e.used = this.clock;
        return e.tex;
    }

    has(k, tx, ty) {
        return this.tex.has(key(k, tx, ty));
    }

    /** The nearest resident ancestor-or-self of (k, tx, ty): [k, tx, ty, tex]. */
    nearest(k, tx, ty) {
        for (;;) {
            const t = this.get(k, tx, ty);
            if (t)
                return [k, tx, ty, t];
            k++; tx >>= 1; ty >>= 1;
        }
    }

    failedTile(k, tx, ty) {
        return this.failed.has(key(k, tx, ty));
    }

    /** Missing tiles from the first resident ancestor of t down to t
     * (coarsest first); [] if t is resident. */
    chain(t) {
        const out = [];
        let [k, x, y] = t;
        while (k < this.R && !this.tex.has(key(k, x, y))) {
            out.push([k, x, y]);
            k++; x >>= 1; y >>= 1;
        }
        return out.reverse();
    }

    /** Is tile t (and so everything it needs) resident or failed? */
    settled(t) {
        return this.tex.has(key(...t)) || this.chain(t).some((c) => this.failed.has(key(...c)));
    }

    /**
     * One frame's work.  needed: tiles the view draws, in priority order;
     * prefetch: the prefetch circle.  Decodes for at most budgetMs (and at
     * least one tile when one is ready).  Returns {pending, decoded,
     * visible}: needed tiles not yet resident and not failed, tiles
     * decoded, and how many of those were needed ones.
     */
    update(needed, prefetch, budgetMs) {
        this.clock++;
        this.frameDecodes = 0;
        const t0 = performance.now();
        // Pin what the view draws and every ancestor.
        const pinned = new Set();
        for (const t of needed) {
            let [k, x, y] = t;
            for (; k <= this.R; k++, x >>= 1, y >>= 1) {
                const kk = key(k, x, y);
                if (pinned.has(kk))
                    break;
                pinned.add(kk);
                const e = this.tex.get(kk);
                if (e)
                    e.used = this.clock;
            }
        }
        const wantNeeded = this.wanted(needed);
        this.request(wantNeeded);
        const visible = this.decodeSome(needed, t0, budgetMs, pinned, null);
        let decoded = visible;
        const pending = needed.filter((t) => !this.settled(t)).length;
        // Prefetch only once every tile of the view is resident.
        if (pending === 0 && this.batches < PREFETCH_INFLIGHT) {
            const room = Math.max(0, Math.floor((this.budget - pinned.size * this.tileBytes) / this.tileBytes));
            const circle = prefetch.filter((t) => !pinned.has(key(...t))).slice(0, room);
            this.request(this.wanted(circle).filter(() => this.prepBytes < this.prepBudget), PREFETCH_INFLIGHT);
            if (performance.now() - t0 < budgetMs) {
                const keep = new Set(pinned);
                for (const t of circle)
                    keep.add(key(...t));
                decoded += this.decodeSome(circle, t0, budgetMs, keep, circle.length);
            }
        }
        this.evict(pinned);
        return { pending, decoded, visible };
    }

    // Tiles of these chains that must still be fetched, coarsest first.
    wanted(tiles) {
        const out = [], seen = new Set();
        for (const t of tiles)
            for (const c of this.chain(t)) {
                const kk = key(...c);
                if (seen.has(kk) || this.prep.has(kk) || this.inflight.has(kk) || this.failed.has(kk))
                    continue;
                seen.add(kk);
                out.push(c);
            }
        out.sort((a, b) => b[0] - a[0]);
        return out;
    }

    // Fetch `list` in batches while fewer than `limit` are on the wire.
    request(list, limit = INFLIGHT_MAX) {
        if (this.retryAt && performance.now() < this.retryAt)
            return;
        while (list.length && this.batches < limit) {
            const part = list.splice(0, BATCH_MAX);
            for (const t of part)
                this.inflight.add(key(...t));
            this.batches++;
            this.stats.batches++;
            this.fetcher.fetch(this.imageUrl, part, this.form).then((r) => {
                if (this.disposed)
                    return;
                this.stats.bytes += r.bytes;
                this.stats.fetchMs += r.fetchMs;
                this.stats.prepMs += r.prepMs;
                for (const f of r.tiles) {
                    const kk = key(f.level, f.tx, f.ty);
                    this.inflight.delete(kk);
                    if (f.prep) {
                        this.stats.tilesFetched++;
                        this.putPrep(kk, f.prep);
                    } else {
                        this.failed.set(kk, f.error);
                        this.stats.errors++;
                        this.stats.lastError = `tile ${kk}: ${f.error}`;
                        console.warn(`gigaview: tile ${kk}: ${f.error}`);
                    }
                }
            }, (e) => {
                for (const t of part)
                    this.inflight.delete(key(...t));
                if (this.disposed || e.name === 'AbortError')
                    return;
                this.stats.errors++;
                this.stats.lastError = `batch: ${e.message}`;
                if (e.status === 401) {
                    // The login has expired: no more requests until the
                    // viewer has logged in again (resume).
                    if (this.retryAt !== Infinity) {
                        this.retryAt = Infinity;
                        this.onUnauthorized();
                    }
                    return;
                }
                console.warn(`gigaview: batch of ${part.length} tiles: ${e.message}`);
                // Network trouble: try again a little later.
                this.retryAt = performance.now() + 2000;
            }).finally(() => {
                this.batches--;
                if (!this.disposed)
                    this.onChange();
            });
        }
    }

    /** Fetch again after a 401 (the viewer has logged in again). */
    resume() {
        this.retryAt = 0;
        this.onChange();
    }

    putPrep(kk, prep) {
        const bytes = prepArrays(prep).reduce((n, a) => n + a.byteLength, 0);
        this.prep.set(kk, { prep, used: this.clock, bytes });
        this.prepBytes += bytes;
        if (this.prepBytes > this.prepBudget) {
            const old = [...this.prep.entries()].sort((a, b) => a[1].used - b[1].used);
            for (const [k2, e] of old) {
                if (this.prepBytes <= this.prepBudget * 0.9)
                    break;
                this.prep.delete(k2);
                this.prepBytes -= e.bytes;
            }
        }
    }

    // Decode along the chains of `tiles` until the time slice is spent.
    // max: stop after this many (null: no limit).  keep: keys eviction
    // must spare while making room.
    decodeSome(tiles, t0, budgetMs, keep, max) {
        let n = 0;
        for (const t of tiles) {
            for (const c of this.chain(t)) {
                const kk = key(...c);
                const p = this.prep.get(kk);
                if (!p)
                    break;                      // waits for its data
                if (n > 0 && (performance.now() - t0 >= budgetMs || this.frameDecodes >= DECODES_PER_FRAME))
                    return n;
                // The parent is what this decode reads: making room must
                // not evict it (it need not be in `keep`: a prefetched
                // tile's parent is often outside the view's chains).
                const [k, x, y] = c;
                if (max !== null && !this.makeRoom(keep, key(k + 1, x >> 1, y >> 1)))
                    return n;
                const parent = this.get(k + 1, x >> 1, y >> 1);
                const d0 = performance.now();
                const tex = this.dec.decode(p.prep, parent, x & 1, y & 1);
                this.stats.decodeMs += performance.now() - d0;
                this.stats.decoded++;
                this.frameDecodes++;
                if (p.prep.entropy)
                    this.stats.entropy++;
                if (p.prep.dct)
                    this.stats.dct++;
                if (max !== null)
                    this.stats.prefetched++;
                p.used = this.clock;
                this.tex.set(kk, { tex, used: this.clock, fixed: false, entropy: p.prep.entropy, dct: p.prep.dct });
                this.texBytes += this.tileBytes;
                n++;
                if (max !== null && n >= max)
                    return n;
            }
        }
        return n;
    }

    // For prefetching: is there room for one more tile, evicting only
    // tiles outside `keep` and other than `spare`?
    makeRoom(keep, spare) {
        if (this.texBytes + this.tileBytes <= this.budget)
            return true;
        return this.evictOne(keep, spare);
    }

    // Evict the least recently used tile that is neither fixed, in `keep`
    // nor `spare`; false when there is none.
    evictOne(keep, spare = null) {
        let old = null;
        for (const [kk, e] of this.tex)
            if (!e.fixed && !keep.has(kk) && kk !== spare && (!old || e.used < old[1].used))
                old = [kk, e];
        if (!old)
            return false;
        this.dec.release(old[1].tex);
        this.tex.delete(old[0]);
        this.texBytes -= this.tileBytes;
        this.stats.evicted++;
        return true;
    }

    evict(pinned) {
        while (this.texBytes > this.budget && this.evictOne(pinned))
            ;
    }

    /** Tiles on the wire, for the loading indicator. */
    get inflightCount() {
        return this.inflight.size;
    }

    dispose() {
        this.disposed = true;
        this.fetcher.abortAll();
        for (const e of this.tex.values())
            this.dec.release(e.tex);
        this.tex.clear();
        this.prep.clear();
    }
}
