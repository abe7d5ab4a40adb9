// browser_lib.mjs - what the headless-Chromium benchmarks share: their
// command line (--name value pairs), playwright-core from
// tests/browser/node_modules (never a downloaded browser: Debian's
// chromium is the executable), and Chromium's flags, WebGL2 on
// SwiftShader unless --gpu host.

import { dirname, join } from 'node:path';
import { fileURLToPath, pathToFileURL } from 'node:url';

const here = dirname(fileURLToPath(import.meta.url));

/** tests/browser/node_modules: playwright-core, OpenSeadragon (`npm ci`
 * there installs them). */
export const nodeModules = join(here, '..', 'tests', 'browser', 'node_modules');

/** playwright-core's chromium launcher. */
export const { chromium } = await import(pathToFileURL(join(nodeModules, 'playwright-core',
    'index.mjs')).href);

/** The options of the command line as `--name value` pairs over
 * `defaults` (every name must be one of its keys); on anything else
 * prints `usage` and exits 2. */
export function parseOptions(defaults, usage) {
    const opt = { ...defaults };
    const argv = process.argv.slice(2);
    for (let i = 0; i < argv.length; i += 2) {
        const k = argv[i].replace(/^--/, '');
        if (!(k in opt) || argv[i + 1] === undefined) {
            console.error(`usage: ${usage}`);
            process.exit(2);
        }
        opt[k] = argv[i + 1];
    }
    return opt;
}

/** Chromium's command line: headless, quiet, sRGB; WebGL2 on SwiftShader
 * (gpu 'swiftshader') or on the machine's GPU ('host'). */
export function chromiumArgs(gpu) {
    const args = ['--headless=new', '--no-sandbox', '--disable-background-networking',
        '--disable-component-update', '--disable-sync', '--no-first-run', '--force-color-profile=srgb'];
    if (gpu === 'swiftshader')
        args.push('--use-angle=swiftshader', '--enable-unsafe-swiftshader');
    else
        args.push('--enable-gpu', '--ignore-gpu-blocklist', '--use-angle=default');
    return args;
}
