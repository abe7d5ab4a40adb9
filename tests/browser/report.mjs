// report.mjs - what the headless-Chromium test scripts share: their
// PASS/FAIL/# lines (tests/browser_*.sh turn them into TAP) and their
// `--name value` arguments.

// How many checks failed so far (a live binding for the importers).
export let failed = 0;
export const pass = (t) => console.log(`PASS ${t}`);
export const fail = (t, ...detail) => {
    failed++;
    console.log(`FAIL ${t}`);
    for (const d of detail) console.log(`# ${d}`);
};
export const note = (t) => console.log(`# ${t}`);
export const check = (ok, t, ...detail) => (ok ? pass(t) : fail(t, ...detail));

// Fill opt (its keys are the options, its values the defaults) from the
// command line's `--name value` pairs; an unknown name or a missing value
// prints usage and exits 2, as does a missing one of `required`, which
// `script` names in that message.
export function parseArgs(opt, usage, script, required) {
    const argv = process.argv.slice(2);
    for (let i = 0; i < argv.length; i += 2) {
        const k = argv[i].replace(/^--/, ''), v = argv[i + 1];
        if (v === undefined || !(k in opt)) {
            console.error(usage);
            process.exit(2);
        }
        opt[k] = v;
    }
    if (required.some((k) => !opt[k])) {
        const names = required.map((k) => `--${k}`);
        const list = names.length > 2 ? `${names.slice(0, -1).join(', ')} and ${names.at(-1)}`
            : names.join(' and ');
        console.error(`${script}: ${list} are required`);
        process.exit(2);
    }
    return opt;
}
