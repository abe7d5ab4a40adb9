// window_tables.mjs FILE [MAX] - for each line of FILE (a window text,
// points up to MAX, default 255), the tables client/web/window.js builds,
// joined by ';', or "error" when parseWindow refuses it; past 255 each
// table as the SHA-256 of its bytes: the same output as
// tests/window_ref.py tables, which tests/http_window.sh compares line by
// line.
import { createHash } from 'node:crypto';
import { readFileSync } from 'node:fs';
import { buildTable, parseWindow } from '../../client/web/window.js';

const max = process.argv[3] ? Number(process.argv[3]) : 255;
const text = (t) => (max > 255 ? createHash('sha256').update(t).digest('hex') : Array.from(t).join(' '));

const lines = readFileSync(process.argv[2], 'utf8').split('\n');
if (lines[lines.length - 1] === '')
    lines.pop();
const out = [];
for (const l of lines) {
    const w = parseWindow(l, max);
    out.push(w === null ? 'error' : w.map((c) => text(buildTable(c, max))).join(';'));
}
process.stdout.write(out.join('\n') + '\n');
