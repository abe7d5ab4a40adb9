// zfield_gl.js - the terrain mode's view-dependent refinement
// (`refine=zfield`, docs/VIEWER.md): the height grid of the view, a
// (2^k+1)-square of samples fetched once, is re-simplified every frame on
// the client's GPU by the z-field sweep (zfield.js) in the screen-space
// error mode of lib/mesh/zfield.h - a vertex stays when its error
// projected at its distance from the eye exceeds TAU pixels - and the
// mesh of the enabled vertices replaces the drawn one (terrain_gl.js).
//
// Frames.  terrain_gl.js draws in a world frame of level-0 pixels around
// the mesh's centre with heights times an exaggeration `exag`; the sweep's
// frame is the grid's (x = column * xyScale, y = row * xyScale, z =
// height).  With xyScale = level-0 pixels per sample / exag the world
// frame is the sweep's frame scaled by exag and shifted, so distances
// scale by exag, as does a vertical error on the screen: the pixel test
// (delta K)^2 > tau^2 d^2 is the same in both, and the eye is mapped
// into the sweep's frame as it is.

import { ZFieldSweep, zfieldK, zfieldMesh } from './zfield.js';

export const TAU = 2;                 // pixels of screen-space error
const FOVY = Math.PI / 4;             // terrain_gl.js draw()

export class ZFieldTerrain {
    /** tgl: the TerrainGl drawing the view; src: loadZfieldSources(). */
    constructor(tgl, src) {
        this.tgl = tgl;
        this.sweep = new ZFieldSweep(tgl.gl, src);
        this.tau = TAU;
        this.grid = null;
        this.active = false;
        this.frames = 0;
    }

    /** The grid: z (Float32Array) of n x n samples of level `level`,
     * its corner at (x0, y0) in that level's samples. */
    setGrid(z, n, x0, y0, level) {
        this.sweep.heights(z, n);
        let zmin = Infinity, zmax = -Infinity;
        for (let i = 0; i < z.length; i++) {
            zmin = Math.min(zmin, z[i]);
            zmax = Math.max(zmax, z[i]);
        }
        this.grid = { z, n, x0, y0, level, zmin, zmax };
        // the corners alone, to set terrain_gl.js's frame (fixed by the grid)
        const en = new Uint8Array(n * n);
        en[0] = en[n - 1] = en[(n - 1) * n] = en[n * n - 1] = 1;
        this.show(zfieldMesh(z, n, en));
        this.active = true;
    }

    show(m) {
        const g = this.grid, nv = m.vx.length, pos = new Float32Array(3 * nv);
        for (let i = 0; i < nv; i++) {
            pos[3 * i] = g.x0 + m.vx[i];
            pos[3 * i + 1] = m.vz[i];
            pos[3 * i + 2] = g.y0 + m.vy[i];
        }
        this.tgl.setMesh({ pos, idx: m.tris, min: [g.x0, g.zmin, g.y0],
            max: [g.x0 + g.n - 1, g.zmax, g.y0 + g.n - 1] }, g.level);
        this.mesh = m;
    }

    /** The sweep's parameters for the camera at (az, el, dist). */
    params(az, el, dist) {
        const g = this.grid, f = this.tgl.mesh, w = this.tgl.eye(az, el, dist), x = f.exag;
        return {
            mode: 'screen', threshold: this.tau, k: zfieldK(this.tgl.canvas.height, FOVY),
            xyScale: f.s / x,
            eye: [(w[0] + f.cx - g.x0 * f.s) / x, (w[2] + f.cy - g.y0 * f.s) / x, w[1] / x + f.zc],
        };
    }

    /** Refine for the camera at (az, el, dist) and hand the mesh to the
     * TerrainGl (which the caller then draws): the triangle count. */
    refine(az, el, dist) {
        const g = this.grid;
        const en = this.sweep.enable(this.params(az, el, dist));
        this.show(zfieldMesh(g.z, g.n, en));
        this.frames++;
        return this.mesh.tris.length / 3;
    }
}
