// window_tables.mjs FILE - for each line of FILE (a window text), the
// tables client/web/window.js builds, joined by ';', or "error" when
// parseWindow refuses it: the same output as tests/window_ref.py tables,
// which tests/http_window.sh compares line by line.
import { readFileSync } from 'node:fs';
import { buildTable, parseWindow } from '../../client/web/window.js';

const lines = readFileSync(process.argv[2], 'utf8').split('\n');
if (lines[lines.length - 1] === '')
    lines.pop();
const out = [];
for (const l of lines) {
    const w = parseWindow(l);
    out.push(w === null ? 'error' : w.map((c) => Array.from(buildTable(c)).join(' ')).join(';'));
}
process.stdout.write(out.join('\n') + '\n');
