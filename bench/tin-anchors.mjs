// tin-anchors.mjs GRID.bin SIZE OFFSET E1 [E2 ...] - the npm anchors of
// bench/tin-speed.sh: delatin (Garland & Heckbert greedy insertion in JS)
// and @mapbox/martini (RTIN) on one SIZE x SIZE grid of little-endian
// float32 heights (value + OFFSET), at each maximum error.  Prints one line
// per tool and error: "tool E triangles ms maxerr cpu_ms" (cpu_ms: the
// process's user + system time, which under node includes its GC threads).  Times are the meshing
// alone (best of REPS, default 3), after one warm-up run on the same grid,
// single-threaded under node.
import { readFileSync } from 'node:fs';
import Delatin from 'delatin';
import Martini from '@mapbox/martini';

const [file, sizeArg, offArg, ...errs] = process.argv.slice(2);
const n = Number(sizeArg), off = Number(offArg);
const buf = readFileSync(file);
const h = new Float32Array(n * n);
for (let i = 0; i < n * n; i++) h[i] = buf.readFloatLE(4 * i) + off;

function cpuMs(c) { return (c.user + c.system) / 1000; }

function delatin(e) {
  const c0 = process.cpuUsage(), t0 = performance.now();
  const tin = new Delatin(h, n, n);
  tin.run(e);
  const ms = performance.now() - t0, cpu = cpuMs(process.cpuUsage(c0));
  return { tris: tin.triangles.length / 3, ms, cpu, maxerr: tin.getMaxError() };
}

function martini(e) {
  const c0 = process.cpuUsage(), t0 = performance.now();
  const m = new Martini(n);
  const tile = m.createTile(h);
  const mesh = tile.getMesh(e);
  const ms = performance.now() - t0, cpu = cpuMs(process.cpuUsage(c0));
  return { tris: mesh.triangles.length / 3, ms, cpu, maxerr: NaN };
}

delatin(Number(errs[errs.length - 1]));   // warm-up: JIT
martini(Number(errs[errs.length - 1]));
const reps = Number(process.env.REPS || 3);
for (const es of errs) {
  const e = Number(es);
  for (const [name, fn] of [['delatin', delatin], ['martini', martini]]) {
    let best = null;
    for (let i = 0; i < reps; i++) {
      const r = fn(e);
      if (!best || r.ms < best.ms) best = r;
    }
    console.log(`${name} ${e} ${best.tris} ${best.ms.toFixed(3)} ${best.maxerr} ${best.cpu.toFixed(3)}`);
  }
}
