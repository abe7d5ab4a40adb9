#!/bin/sh
# glsl_include.sh FILE - FILE on stdout with each line that is exactly
#   #include "NAME"
# replaced by the file NAME next to FILE (one level: an included file may
# not include another).  GLSL has no #include of its own (only the
# GL_ARB_shading_language_include and GL_GOOGLE_include_directive
# extensions), so the embedders run this on every shader: shaders/embed.sh
# for the programs, client/web/embed.sh for gigaviewd's copy that the
# browser fetches, and the two get the same text.  Exits 1, naming the
# file, when an included file is missing or includes another.
set -eu
dir=$(dirname "$1")
awk -v dir="$dir" -v top="$1" '
function fail(msg) { print "glsl_include.sh: " msg > "/dev/stderr"; bad = 1; exit 1 }
/^#include "[^"]+"[ \t\r]*$/ {
    split($0, part, "\"")
    f = dir "/" part[2]
    n = 0
    while ((r = (getline line < f)) > 0) {
        if (line ~ /^#include /)
            fail(f ": nested #include (included from " top ")")
        print line
        n++
    }
    if (r < 0 || n == 0)
        fail(top ": cannot read " f)
    close(f)
    next
}
{ print }
END { if (bad) exit 1 }
' "$1"
