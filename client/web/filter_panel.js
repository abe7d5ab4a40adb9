// filter_panel.js - the filter panel: choose a stock or stored graph
// (GET /v1/filters), one slider per declared parameter (named and ranged
// from the graph), the graph's modules in execution order with their
// inputs (GET /v1/filters/{fid}: the server's plan), a GLSL editor for a
// module's body that shows compile errors at their line, and saving the
// edited graph (POST /v1/filters, with the server's bearer token).
//
// Compile errors come from the server (the graph is compiled there, in
// a worker): "module 'ID' line N: MESSAGE", N counting lines of that
// module's own body from 1, which is exactly the editor's numbering.
// Running an edited graph sends it inline; saving stores it and selects
// the stored id, so a link can name it.

const $ = (id) => document.getElementById(id);

function el(tag, props = {}, ...kids) {
    const e = document.createElement(tag);
    for (const [k, v] of Object.entries(props)) {
        if (k === 'class') e.className = v;
        else if (k in e) e[k] = v;
        else e.setAttribute(k, v);
    }
    for (const k of kids)
        e.append(k);
    return e;
}

export class FilterPanel {
    constructor(viewer, runner) {
        this.viewer = viewer;
        this.runner = runner;
        this.list = [];
        this.doc = null;          // the selected graph document (edited in place)
        this.plan = null;
        this.id = null;
        this.module = null;       // id of the module in the editor
        this.edited = false;
        $('f-graph').addEventListener('change', (e) => {
            this.note = '';
            this.select(e.target.value || null, {});
        });
        $('f-roi').addEventListener('click', () => this.runner.roiTool.arm());
        $('f-clear').addEventListener('click', () => this.runner.setRoi(null));
        $('f-run').addEventListener('click', () => this.runEdited());
        $('f-save').addEventListener('click', () => this.save());
        $('f-reset').addEventListener('click', () => this.select(this.id, {}));
        const ta = $('f-glsl');
        ta.addEventListener('input', () => {
            this.edited = true;
            this.note = '';
            this.gutter();
            this.status('edited: "run" to try it, "save" to store it');
        });
        ta.addEventListener('scroll', () => { $('f-gutter').scrollTop = ta.scrollTop; });
        ta.addEventListener('keydown', (e) => {
            if (e.key === 'Enter' && (e.ctrlKey || e.metaKey)) {
                e.preventDefault();
                this.runEdited();
            }
        });
        $('f-token').value = sessionStorage.getItem('gigaview-token') || '';
        runner.on(() => this.showState());
    }

    status(t) {
        $('f-status').textContent = t;
    }

    /** Load the list of graphs. */
    async load() {
        try {
            const r = await fetch(new URL('v1/filters', document.baseURI));
            if (!r.ok)
                throw new Error(`HTTP ${r.status}`);
            this.list = (await r.json()).filters || [];
        } catch (e) {
            this.list = [];
            this.status(`no filters on this server (${e.message})`);
        }
        const sel = $('f-graph');
        sel.replaceChildren(new Option('none', ''));
        for (const [label, stock] of [['stock', true], ['stored', false]]) {
            const g = el('optgroup', { label });
            for (const f of this.list.filter((x) => !!x.stock === stock))
                g.append(new Option(f.name === f.id ? f.id : `${f.id} (${f.name})`, f.id));
            if (g.children.length)
                sel.append(g);
        }
        sel.value = this.id || '';
    }

    /** Select graph `id` with parameter values `params` ("module.param" ->
     * value; missing ones take their defaults). */
    async select(id, params) {
        this.id = id;
        this.doc = this.plan = null;
        this.edited = false;
        this.note = this.note || '';
        $('f-graph').value = id || '';
        if (!id) {
            this.render(params);
            this.runner.setFilter(null);
            return;
        }
        try {
            const r = await fetch(new URL(`v1/filters/${encodeURIComponent(id)}`, document.baseURI));
            if (!r.ok)
                throw new Error(r.status === 404 ? `no filter '${id}'` : `HTTP ${r.status}`);
            const j = await r.json();
            if (this.id !== id)
                return;          // another selection came first
            this.doc = j.graph;
            this.plan = j.plan;
        } catch (e) {
            this.status(e.message);
        }
        const values = this.render(params);
        // One request for the graph with its parameters.
        this.runner.filter = id;
        this.runner.graph = null;
        this.viewer.extra.filter = id;
        this.runner.setParams(values, 0);
    }

    render(params) {
        const doc = this.doc, plan = this.plan;
        $('f-desc').textContent = doc ? doc.description || '' : '';
        // Sliders: every parameter of every module, in execution order.
        const box = $('f-params');
        box.replaceChildren();
        const values = {};
        if (doc && plan) {
            for (const pm of plan.modules) {
                const m = doc.modules.find((x) => x.id === pm.id);
                for (const p of (m && m.params) || []) {
                    const key = `${m.id}.${p.name}`;
                    const val = params && key in params ? Math.min(p.max, Math.max(p.min, params[key])) : p.default;
                    values[key] = val;
                    const out = el('output', { textContent: fmt(val) });
                    const input = el('input', {
                        // step before value: with the default step of 1 the
                        // value would snap to the grid first.
                        type: 'range', min: String(p.min), max: String(p.max), step: 'any',
                        value: String(val), 'aria-label': key,
                    });
                    input.dataset.key = key;
                    input.addEventListener('input', () => {
                        out.textContent = fmt(+input.value);
                        this.runner.setParams({ ...this.runner.params, [key]: +input.value });
                    });
                    box.append(el('label', { class: 'param' }, el('span', { textContent: `${m.id} · ${p.name}` }), input, out));
                }
            }
        }
        box.hidden = !box.children.length;
        // The graph: modules in execution order, each with its inputs.
        const ol = $('f-modules');
        ol.replaceChildren();
        if (plan) {
            for (const pm of plan.modules) {
                const li = el('li', {},
                    el('button', { type: 'button', class: 'link', textContent: pm.id }),
                    el('span', { class: 'dim', textContent: ` ${pm.template}${pm.format ? `, ${pm.format}` : ''} ← ${pm.inputs.join(', ')}` +
                        (pm.id === plan.output ? ' → output' : '') }));
                li.dataset.module = pm.id;
                li.querySelector('button').addEventListener('click', () => this.edit(pm.id));
                ol.append(li);
            }
            const pad = plan.padding || [0, 0, 0, 0];
            $('f-plan').textContent = `${plan.modules.length} module${plan.modules.length === 1 ? '' : 's'}, ` +
                `${plan.textures} texture${plan.textures === 1 ? '' : 's'}, padding ${pad.join('/')}`;
        } else {
            $('f-plan').textContent = '';
        }
        $('f-graph-box').hidden = !plan;
        // The editor: the output module's body, or the first with GLSL.
        const first = doc && (doc.modules.find((m) => m.id === plan.output && m.glsl) || doc.modules.find((m) => m.glsl));
        this.edit(first ? first.id : null);
        this.showState();
        return values;
    }

    /** Show module `id`'s body in the editor. */
    edit(id) {
        this.commit();
        this.module = id;
        const m = this.doc && id ? this.doc.modules.find((x) => x.id === id) : null;
        $('f-mod-id').textContent = m ? m.id : '';
        $('f-editor-box').hidden = !m;
        const ta = $('f-glsl');
        ta.value = m ? (m.glsl !== undefined ? m.glsl : JSON.stringify(m.kernel)) : '';
        ta.readOnly = !m || m.glsl === undefined;
        for (const li of $('f-modules').children)
            li.classList.toggle('current', li.dataset.module === id);
        this.gutter();
    }

    // Put the editor's text back into the document.
    commit() {
        if (!this.doc || !this.module)
            return;
        const m = this.doc.modules.find((x) => x.id === this.module);
        if (m && m.glsl !== undefined)
            m.glsl = $('f-glsl').value;
    }

    // Line numbers; the line of the current error marked.
    gutter() {
        const n = $('f-glsl').value.split('\n').length, e = this.runner.error;
        const bad = e && e.module === this.module ? e.line : 0;
        const g = $('f-gutter');
        g.replaceChildren();
        for (let i = 1; i <= n; i++)
            g.append(el('div', { class: i === bad ? 'bad' : '', textContent: String(i) }));
        g.scrollTop = $('f-glsl').scrollTop;
    }

    runEdited() {
        if (!this.doc)
            return;
        this.commit();
        this.runner.setGraph(JSON.parse(JSON.stringify(this.doc)));
    }

    async save() {
        if (!this.doc)
            return;
        this.commit();
        const token = $('f-token').value.trim();
        sessionStorage.setItem('gigaview-token', token);
        const doc = JSON.parse(JSON.stringify(this.doc));
        try {
            const r = await fetch(new URL('v1/filters', document.baseURI), {
                method: 'POST', body: JSON.stringify(doc),
                headers: { 'Content-Type': 'application/json', ...(token ? { Authorization: `Bearer ${token}` } : {}) },
            });
            const j = await r.json().catch(() => ({}));
            if (!r.ok) {
                const msg = (j.error && j.error.message) || `HTTP ${r.status}`;
                const m = /module '([^']+)' line (\d+): (.*)$/s.exec(msg);
                this.runner.error = { message: msg, status: r.status, module: m ? m[1] : null, line: m ? +m[2] : 0, text: m ? m[3] : msg };
                this.showState();
                return;
            }
            await this.load();
            await this.select(j.id, this.runner.params);
            this.note = `saved as ${j.id}${j.created ? '' : ' (already stored)'}`;
            this.status(this.note);
            this.savedId = j.id;
        } catch (e) {
            this.status(`save failed: ${e.message}`);
        }
    }

    // Errors, timing, the line of a compile error.
    showState() {
        const e = this.runner.error, r = this.runner.result;
        const box = $('f-error');
        if (e) {
            box.hidden = false;
            box.textContent = e.module ? `module '${e.module}', line ${e.line}: ${e.text}` : e.message;
            if (e.module && e.module !== this.module && this.doc && this.doc.modules.some((m) => m.id === e.module))
                this.edit(e.module);
            this.gutter();
            if (e.module === this.module && e.line > 0)
                this.selectLine(e.line);
        } else {
            box.hidden = true;
            this.gutter();
        }
        if (this.runner.inflight)
            this.status('running…');
        else if (r && !e)
            this.status(`${this.note ? `${this.note} · ` : ''}level ${r.level}, ${r.w} × ${r.h} px: ` +
                `${r.ms.toFixed(0)} ms (GPU ${r.gpuMs.toFixed(1)} ms, ${r.passes} passes, ${r.textures} textures)`);
        else if (!this.viewer.extra.roi && this.id)
            this.status('select a region: "select region", or drag with Shift');
    }

    // Put the caret on line n of the editor.
    selectLine(n) {
        const ta = $('f-glsl'), lines = ta.value.split('\n');
        let at = 0;
        for (let i = 0; i < n - 1 && i < lines.length; i++)
            at += lines[i].length + 1;
        const end = at + (lines[n - 1] || '').length;
        if (ta.selectionStart !== at || ta.selectionEnd !== end)
            ta.setSelectionRange(at, end);
        const lh = ta.scrollHeight / Math.max(1, lines.length);
        if ((n - 1) * lh < ta.scrollTop || n * lh > ta.scrollTop + ta.clientHeight)
            ta.scrollTop = Math.max(0, (n - 3) * lh);
    }
}

function fmt(v) {
    return Math.abs(v) >= 100 ? v.toFixed(0) : Math.abs(v) >= 10 ? v.toFixed(1) : v.toFixed(3);
}
