// fetcher.js - where batches of tiles are fetched and prepared: a small
// pool of module workers (tile_worker.js) so that checking tiles and
// decoding rANS indices never stalls drawing, or the main thread itself
// where workers cannot start.  Both give the same results (batch.js).

import { fetchPrepared } from './batch.js';

export class Fetcher {
    /** n: number of workers (0: fetch on the main thread). */
    constructor(n) {
        this.workers = [];
        this.jobs = new Map();    // id -> {resolve, reject, worker, ctl}
        this.next = 1;
        this.rr = 0;
        for (let i = 0; i < n; i++) {
            let w;
            try {
                w = new Worker(new URL('tile_worker.js', import.meta.url), { type: 'module' });
            } catch (e) {
                break;
            }
            w.onmessage = (ev) => this.onMessage(ev.data);
            w.onerror = (ev) => {
                // A worker that cannot load (old browser): drop the pool and
                // carry on in the main thread.
                ev.preventDefault();
                this.fallBack();
            };
            this.workers.push(w);
        }
    }

    get mode() {
        return this.workers.length ? `${this.workers.length} workers` : 'main thread';
    }

    fallBack() {
        for (const w of this.workers)
            w.terminate();
        this.workers = [];
        for (const [id, j] of this.jobs)
            if (j.worker) {
                this.jobs.delete(id);
                this.fetch(j.args.imageUrl, j.args.tiles, j.args.form).then(j.resolve, j.reject);
            }
    }

    onMessage(m) {
        const j = this.jobs.get(m.id);
        if (!j)
            return;
        this.jobs.delete(m.id);
        if (m.type === 'done')
            j.resolve(m.result);
        else {
            const e = new Error(m.error);
            e.status = m.status;
            if (m.aborted)
                e.name = 'AbortError';
            j.reject(e);
        }
    }

    /** Fetch and prepare tiles [[level, tx, ty], ...]: a promise of
     * fetchPrepared's result, with an id for abort().  form: as
     * fetchPrepared's, {channels, codes}. */
    fetch(imageUrl, tiles, form) {
        const id = this.next++;
        const p = new Promise((resolve, reject) => {
            const args = { imageUrl, tiles, form };
            if (this.workers.length) {
                const w = this.workers[this.rr++ % this.workers.length];
                this.jobs.set(id, { resolve, reject, worker: w, args });
                w.postMessage({ type: 'fetch', id, ...args });
            } else {
                const ctl = new AbortController();
                this.jobs.set(id, { resolve, reject, ctl, args });
                fetchPrepared(imageUrl, tiles, form, ctl.signal).then(
                    (r) => { this.jobs.delete(id); resolve(r); },
                    (e) => { this.jobs.delete(id); reject(e); });
            }
        });
        p.id = id;
        return p;
    }

    /** Abort every job in flight (their promises reject with AbortError). */
    abortAll() {
        for (const [id, j] of this.jobs) {
            if (j.worker)
                j.worker.postMessage({ type: 'abort', id });
            else
                j.ctl.abort();
        }
    }

    dispose() {
        this.abortAll();
        for (const w of this.workers)
            w.terminate();
        this.workers = [];
    }
}
