#!/bin/sh
# layers.sh - the include rules of docs/ARCHITECTURE.md, checked on the
# sources: which folder may include which, and no cycles.
#
# The layer table of lib/ is read from docs/ARCHITECTURE.md itself (the
# rows "| `lib/X` | may use | what it is |"), so the document stays the one
# source: a lib/ folder missing from the table, or an include the table
# does not allow, fails.  The rules for the folders above lib/ come from
# the same document's prose: filters/ and server/ may use every lib/
# folder, server/ also filters/; client/ uses every lib/ folder and
# nothing of server/ or filters/; lib/ uses nothing above it.  Inside
# client/, remote/ uses only itself, view/ also remote/, and cmd/ (the
# commands) every client folder.
#
# An include is resolved as the build resolves it: "X/name.h" is
# lib/X/name.h (or filters/name.h for "filters/..."; from a file of
# client/, client/X/name.h first: client/cmd, view, remote), a bare "name.h" is
# the including file's folder, then filters/ (the -I of Makefile.am);
# what resolves to neither (config.h, generated shaders.h) is skipped.
#
# Cycles, two kinds, both reported:
#   - headers that include each other (a.h -> b.h -> a.h);
#   - source files that need each other through headers: a.c needs b.c
#     when a.c includes, directly or through other headers, a header that
#     declares a function b.c defines.  Two files needing each other are
#     one module cut in two, or a declaration in the wrong header.
# Known cycles are let through, named in known_cycles below (one a
# line, its files in the order the check prints them):
# - http.c puts the IIIF auth services (route_auth.c) into a 401 body,
#   and route_auth.c answers through http.c's helpers, as every route
#   does.
# A new cycle, or one of these grown, still fails.
known_cycles="server/http.c server/route_auth.c"
set -eu
top=${top_srcdir:-$(dirname "$0")/..}
cd "$top"
doc=docs/ARCHITECTURE.md
[ -f "$doc" ] || { echo "layers: $doc not found" >&2; exit 99; }

files=$(find lib filters server client \( -name '*.c' -o -name '*.h' -o \
        -name '*.cpp' \) -type f | LC_ALL=C sort)

# shellcheck disable=SC2086
awk -v doc="$doc" -v known_cycles="$known_cycles" '
function folder(path,   p) {        # lib/X/... -> X; filters/... -> filters
    n = split(path, p, "/")
    return p[1] == "lib" ? p[2] : p[1]
}
function label(path,   p) {          # lib/X, client/X, filters, server
    split(path, p, "/")
    return p[1] == "lib" || p[1] == "client" ? p[1] "/" p[2] : p[1]
}
function dirof(path) { sub(/\/[^\/]*$/, "", path); return path }
function exists(path,   r, line) {
    if (path in known) return 1
    return 0
}
function resolve(from, name,   f, d) {
    if (name ~ /\//) {
        # client/ includes its own folders by name, as -I client does
        if (from ~ /^client\// && exists("client/" name)) return "client/" name
        f = name; sub(/\/.*/, "", f)
        if (f == "filters") { d = "filters/" substr(name, 9) }
        else d = "lib/" name
        return exists(d) ? d : ""
    }
    d = dirof(from) "/" name
    if (exists(d)) return d
    if (exists("filters/" name)) return "filters/" name
    return ""
}
# inside client/: remote/ uses only itself, view/ also remote/, cmd/ all
function client_allowed(from, to,   p, q) {
    split(from, p, "/"); split(to, q, "/")
    if (p[2] == q[2] || p[2] == "cmd") return 1
    return p[2] == "view" && q[2] == "remote"
}
function allowed(from, to,   a, b) {
    a = folder(from); b = folder(to)
    if (a == "client" && b == "client") return client_allowed(from, to)
    if (a == b) return 1
    if (from ~ /^lib\//) return (to ~ /^lib\//) && ((a SUBSEP b) in may)
    if (to ~ /^lib\//) return 1                 # filters, server, client
    if (a == "server" && b == "filters") return 1
    return 0
}
# Tarjan over the graph edge[u, v]; SCCs of more than one node are cycles.
function strong(v,   w, i, n, members) {
    idx[v] = lowl[v] = ++counter
    stack[++sp] = v; onst[v] = 1
    for (i = 1; i <= nout[v]; i++) {
        w = out[v, i]
        if (!(w in idx)) {
            strong(w)
            if (lowl[w] < lowl[v]) lowl[v] = lowl[w]
        } else if (onst[w] && idx[w] < lowl[v])
            lowl[v] = idx[w]
    }
    if (lowl[v] == idx[v]) {
        n = 0; members = ""
        do {
            w = stack[sp--]; onst[w] = 0; n++
            members = w (members == "" ? "" : " ") members
        } while (w != v)
        if (n > 1 && !(members in known_cycle)) {
            printf "layers: include cycle: %s\n", members
            bad++
        }
    }
}
function add_edge(u, v) {
    if ((u SUBSEP v) in has) return
    has[u, v] = 1
    out[u, ++nout[u]] = v
}
# the headers file f reaches through includes, into reach[]
function reach_from(f,   i, h) {
    for (i = 1; i <= ninc[f]; i++) {
        h = inc[f, i]
        if (!(h in reach)) { reach[h] = 1; reach_from(h) }
    }
}
BEGIN {
    nk = split(known_cycles, kc, "\n")
    for (i = 1; i <= nk; i++) known_cycle[kc[i]] = 1
    # the layer table
    while ((getline line < doc) > 0) {
        if (line !~ /^\| `lib\/[a-z_]+` \|/) continue
        split(line, col, "|")
        f = col[2]; gsub(/[ `]/, "", f); sub(/^lib\//, "", f)
        intable[f] = 1
        nu = split(col[3], uses, /[^a-z_]+/)
        for (i = 1; i <= nu; i++) if (uses[i] != "") may[f, uses[i]] = 1
    }
    close(doc)
    if (length(intable) == 0) { print "layers: no layer table in " doc; exit 99 }
    for (i = 1; i < ARGC; i++) known[ARGV[i]] = 1
    for (k in known) {
        if (k ~ /^lib\// && !(folder(k) in intable) && !(("lib/" folder(k)) in warned)) {
            warned["lib/" folder(k)] = 1
            printf "layers: lib/%s is not in the layer table of %s\n", folder(k), doc
            bad++
        }
    }
}
FNR == 1 { header = FILENAME ~ /\.h$/ }
/^[ \t]*#[ \t]*include[ \t]*"/ {
    name = $0; sub(/^[^"]*"/, "", name); sub(/".*/, "", name)
    to = resolve(FILENAME, name)
    if (to == "") next
    if (!allowed(FILENAME, to)) {
        printf "layers: %s:%d: includes %s (%s may not use %s)\n", FILENAME,
               FNR, name, label(FILENAME), label(to)
        bad++
    }
    if (to != FILENAME) inc[FILENAME, ++ninc[FILENAME]] = to
    next
}
# a declaration in a header, a definition in a source file: a line at
# column 0 that is neither static, nor a directive, nor a type
/^[A-Za-z_]/ && /\(/ && !/^(static|typedef|extern "C"|#|struct [a-z_0-9]+ \{|enum|union)/ {
    s = $0; sub(/\(.*/, "", s)
    if (s !~ /[A-Za-z_0-9]$/ || s ~ /=/) next
    fn = s; sub(/.*[^A-Za-z_0-9]/, "", fn)
    if (fn == "" || fn ~ /^(if|for|while|return|sizeof)$/) next
    if (header) declared[FILENAME, fn] = 1
    else if ($0 !~ /;[ \t]*$/ && !(fn in defined)) defined[fn] = FILENAME
}
# the functions a source file calls (or names: a function pointer)
!header {
    s = $0
    while (match(s, /[A-Za-z_][A-Za-z_0-9]*/)) {
        calls[FILENAME, substr(s, RSTART, RLENGTH)] = 1
        s = substr(s, RSTART + RLENGTH)
    }
}
END {
    if (bad && length(intable) == 0) exit 99
    # headers that include each other
    for (k in known)
        if (k ~ /\.h$/)
            for (i = 1; i <= ninc[k]; i++) add_edge(k, inc[k, i])
    # sources that need each other: k calls fn, declared in a header k
    # reaches and defined in another source
    for (k in known) {
        if (k ~ /\.h$/) continue
        delete reach
        reach_from(k)
        for (d in declared) {
            split(d, kv, SUBSEP)
            if ((kv[1] in reach) && (kv[2] in defined) &&
                defined[kv[2]] != k && ((k SUBSEP kv[2]) in calls))
                add_edge(k, defined[kv[2]])
        }
    }
    for (k in known) if (!(k in idx)) strong(k)
    if (bad) { printf "layers: %d problem(s)\n", bad; exit 1 }
    print "layers: every include follows " doc "; no include cycles"
}
' $files > "${TMPDIR:-/tmp}/layers.$$" && rc=0 || rc=$?
out="${TMPDIR:-/tmp}/layers.$$"
echo 1..1
sed 's/^/# /' "$out"
rm -f "$out"
[ "$rc" -eq 0 ] && echo "ok 1 - includes follow $doc, no cycles" || echo "not ok 1 - includes follow $doc, no cycles"
[ "$rc" -eq 0 ] || [ "$rc" -eq 1 ] || exit 99
