#!/bin/sh
# make_corpus_view_script.sh - regenerates tests/fuzz/corpus/view_script,
# the seeds of fuzz_view_script: a selector byte (bit 0: also through
# vs_load from a file; bit 1: the rest repeated 2^k times, k = bits 3-7)
# then a script.  Valid scripts of every command (LF, CRLF, comments, a last
# line without its newline) and one file per hostile case: overlong
# lines, huge, non-finite, negative and fractional numbers, unknown
# commands, keys, axes and buttons, missing and extra arguments, NULs,
# bad views and link hashes, and the command limit (exactly 100000
# commands, and 2^17).  Deterministic; needs python3.
set -eu
here=$(cd "$(dirname "$0")" && pwd)
d=$here/corpus/view_script
mkdir -p "$d"
# Past findings (finding-*) stay: make check replays them forever.
find "$d" -type f ! -name 'finding-*' -delete
# vs NAME SELECTOR TEXT: TEXT through printf (octal escapes allowed).
vs() {
    { printf "\\$2"; printf "$3"; } >"$d/$1"
}
# long NAME SELECTOR PYTHON-EXPRESSION: the text the expression makes.
long() {
    { printf "\\$2"; python3 -c "import sys; sys.stdout.write($3)"; } >"$d/$1"
}

# ----------------------------------------------------------- valid
vs all-commands 001 '# every command\nwait 10\nframes 3\nkey Right\nkey shift+R\nkey ctrl+3\nkey +\n'\
'down 10 20 shift\nmove 30 40\nup 30 40\ndrag 0 0 100 50\ndrag 0 0 100 50 1000\n'\
'wheel 320 180 -2\nview 1632,1224,1.2\nview 100,200,0.5,-30\nimage other\nsettle\nsettle 5000\n'\
'shot /tmp/x.png\nwait-file /tmp/y\nwait-file /tmp/y 0\nprint view is\nmessage\nfilter 10 10 200 100\n'\
'graph negate\ngraph next\nparam +\nparam -\npad-axis leftx -1\npad-axis righttrigger 1\n'\
'pad-button rightshoulder\npinch 320 180 0.1 15\npinch 1 1 -0.2499 0\ntouch 0 0 50 50\ntouch 0 0 50 50 1\nquit\n'
vs crlf 001 'wait 1\r\nkey Home\r\n# comment\r\n\r\nprint done\r\nquit\r\n'
vs no-final-newline 000 'wait 1\nframes 2'
vs comments-tabs 001 '\t# indented comment\n\twait\t5\t# trailing\n   \n\nframes 0 # none\n'
vs view-hash 001 'view #image=big&x=100.5&y=20&z=-1&r=90\nview http://h:1/?a=b#z=2&y=1&x=0 # a comment\n'
vs bench-path 000 'view 1632,1224,1.3502 \nsettle 600000\nwait 1500\nprint step 1\nview 1632,1224,1.2\nsettle 600000\nwait 300\nprint step 2\nquit\n'
vs empty 001 ''
vs only-newlines 001 '\n\n\n'
vs only-cr 001 '\r'
vs lone-crs 000 '\r\r\n\r\n'
vs exponents 000 'wait 1e3\nframes 1e2\nwait 1e-400\nwait -0\nwait +5\nwait .5\n'
vs hex 000 'wait 0x10\n'
vs infinity-word 000 'wait infinity\n'
vs limits-exact 000 'wait 1000000000\nframes 1e9\nwheel -1e9 1e9 0\npad-axis lefty -1\n'
long max-line 001 '"print " + "x" * 4089 + "\n"'
long long-number 000 '"wait " + "0" * 4000 + "1\n"'
long spaces-line 000 '" " * 4095 + "\nquit\n"'
long cmds-100000 052 '"quit\n" * 3125'
long many-comments 072 '"# c\n\n"'

# ----------------------------------------------------------- hostile
long line-too-long 001 '"print " + "x" * 4090 + "\n"'
long line-too-long-cr 001 '"wait 1" + " " * 4089 + "\r\n"'
long line-too-long-last 000 '"#" * 5000'
printf '\222quit\n' >"$d/finding-cmd-limit"
vs nan 000 'wait nan\n'
vs inf 000 'wait inf\n'
vs minus-inf 000 'settle -inf\n'
vs overflow 000 'wait 1e999\n'
vs above-1e9 000 'frames 1000000001\n'
vs hex-float-huge 000 'wait 0x1p40\n'
vs negative-wait 000 'wait -1\n'
vs negative-settle 000 'settle -5\n'
vs negative-frames 000 'frames -1\n'
vs fractional-frames 000 'frames 2.5\n'
vs fractional-moves 000 'drag 0 0 10 10 1.5\n'
vs zero-moves 000 'drag 0 0 10 10 0\n'
vs too-many-moves 000 'touch 0 0 10 10 1001\n'
vs wait-file-negative 000 'wait-file /tmp/x -1\n'
vs wait-file-extra 000 'wait-file /tmp/x 5 6\n'
vs pinch-collapse 000 'pinch 1 1 -0.25 0\n'
vs pad-axis-range 000 'pad-axis leftx 1.0001\n'
vs pad-axis-nan 000 'pad-axis leftx nan\n'
vs pad-axis-unknown 000 'pad-axis sideways 0\n'
vs pad-axis-missing 000 'pad-axis leftx\n'
vs pad-button-unknown 000 'pad-button z\n'
vs pad-button-none 000 'pad-button\n'
vs key-unknown 000 'key NoSuchKey\n'
vs key-empty 000 'key\n'
vs key-mods-only 000 'key shift+ctrl+\n'
vs key-two 000 'key a b\n'
vs key-utf8 000 'key \303\251\n'
vs key-utf8-bad 000 'key \360\200\200\n'
vs key-utf8-4 000 'key \364\217\277\277\n'
vs key-high-byte 000 'key \377\n'
vs key-hash 000 'key #\n'
vs unknown-command 000 'jump 1 2\n'
vs upper-case 000 'WAIT 1\n'
vs missing-number 000 'down 1\n'
vs missing-all 000 'wheel\n'
vs extra-number 000 'move 1 2 3\n'
vs not-a-number 000 'move 1 two\n'
vs number-suffix 000 'wait 10ms\n'
vs down-shift-twice 000 'down 1 2 shift shift\n'
vs down-shift-early 000 'down 1 shift 2\n'
vs shot-missing 000 'shot\n'
vs shot-two 000 'shot a b\n'
vs image-missing 000 'image # none\n'
vs print-empty 000 'print\n'
vs param-bad 000 'param ++\n'
vs param-missing 000 'param\n'
vs quit-args 000 'quit now\n'
vs view-missing 000 'view\n'
vs view-two-numbers 000 'view 1,2\n'
vs view-five-numbers 000 'view 1,2,3,4,5\n'
vs view-zoom-65 000 'view 1,2,65\n'
vs view-nan 000 'view nan,1,2\n'
vs view-extra 000 'view 1,2,3 4\n'
vs view-hash-no-z 000 'view #image=a&x=1&y=2\n'
vs view-hash-inf 000 'view #x=inf&y=1&z=0\n'
long view-hash-long-id 000 '"view #image=" + "i" * 300 + "&x=1&y=2&z=0\n"'
vs view-hash-empty 000 'view #\n'
vs nul-in-line 001 'wait 1\000junk\nquit\n'
vs nul-first 001 '\000wait 1\n'
vs nul-late 001 'wait 1\nwait 2\n\000\n'
vs error-after-ok 001 'wait 1\nframes 1\nbogus\n'
vs error-on-last-line 001 'wait 1\nframes'
vs tab-separated 000 'wheel\t1\t2\t3\n'
vs vertical-tab 000 'wait\v1\n'
vs form-feed-number 000 'wait \f1\n'
long repeated-error 062 '"wait 1\nwait x\n"'
du -sh "$d"
