// tile_worker.js - a module worker that fetches batches of compressed
// tiles, checks them and decodes their rANS indices or residuals
// (batch.js, tilebuf.js, heighttile.js) off the main thread, which then only uploads and draws.
//
// Messages in:  {type: 'fetch', id, imageUrl, tiles, form}
//               {type: 'abort', id}
// Messages out: {type: 'done', id, result} (result as fetchPrepared,
//               its prepared arrays transferred, not copied)
//               {type: 'failed', id, error, status, aborted}

import { fetchPrepared, prepArrays } from './batch.js';

const pending = new Map();   // id -> AbortController

self.onmessage = async (ev) => {
    const m = ev.data;
    if (m.type === 'abort') {
        const c = pending.get(m.id);
        if (c)
            c.abort();
        return;
    }
    if (m.type !== 'fetch')
        return;
    const ctl = new AbortController();
    pending.set(m.id, ctl);
    try {
        const result = await fetchPrepared(m.imageUrl, m.tiles, m.form, ctl.signal);
        const transfer = [];
        for (const t of result.tiles)
            if (t.prep)
                transfer.push(...prepArrays(t.prep).map((a) => a.buffer));
        self.postMessage({ type: 'done', id: m.id, result }, transfer);
    } catch (e) {
        self.postMessage({ type: 'failed', id: m.id, error: String(e && e.message || e),
            status: (e && e.status) || 0, aborted: ctl.signal.aborted });
    } finally {
        pending.delete(m.id);
    }
};
