#!/bin/sh
# browser_auth.sh - the browser viewer logs in to a restricted image
# (client/web/auth.js, IIIF Authorization Flow 2.0; docs/API.md "What a
# client does"), in headless Chromium (Debian's /usr/bin/chromium driven
# by playwright-core; tests/browser/auth.mjs lists the checks).
#
# gigaviewd serves three stores under an access policy: "pub" (public),
# "staff-pic" and "staff-large" (group staff), with its own texts for the dialog, a token
# secret and the trusted header X-Remote-Groups, which auth.mjs adds to
# the login page's request alone, as a single sign-on proxy in front of
# the login would.  access_origins names another site only: the viewer
# gigaviewd serves is allowed its own origin.
#
# Skipped when /usr/bin/chromium, node or tests/browser/node_modules is
# missing (scripts/install-deps.sh installs chromium and nodejs;
# scripts/check.sh runs `npm ci` in tests/browser), and under valgrind
# (tests/http_access.sh covers the services there).
. "$(dirname "$0")/lib.sh"

browser_preflight "" "http_access.sh covers the auth services"
. "$(dirname "$0")/http_util.sh"

S=$T/stores
mkdir "$S" || bail "mkdir"
run encode synth:900x600 -o "$S/pub.gv"
[ "$rc" -eq 0 ] || bail "encode pub: $(cat "$T/err")"
run encode "$TESTDATA/picos-1100x700.jpg" -o "$S/staff-pic.gv"
[ "$rc" -eq 0 ] || bail "encode staff-pic: $(cat "$T/err")"
run encode synth:6000x4000 -o "$S/staff-large.gv"
[ "$rc" -eq 0 ] || bail "encode staff-large: $(cat "$T/err")"

head -c 48 /dev/urandom | base64 >"$T/secret" || bail "secret"
chmod 600 "$T/secret"
cat >"$T/policy.json" <<'EOF2'
{"groups": ["staff", "visitors"],
 "images": [
   {"id": "staff-*", "access": "staff"},
   {"id": "*", "access": "public"}
 ],
 "messages": {
   "label": "Staff login",
   "heading": "Staff only: log in",
   "note": "Log in with your staff account to see this picture.",
   "confirm_label": "Log in now",
   "denied_heading": "Not for your account",
   "denied_note": "Your account is not in the staff group."
 }}
EOF2
cat >"$T/a.conf" <<EOF2
listen = 127.0.0.1
port = 0
store_dir = "$S"
threads = 4
access_log = off
access_policy = "$T/policy.json"
access_token_secret_file = "$T/secret"
access_trusted_header = "X-Remote-Groups"
access_origins = "https://viewer.example.org"
EOF2
start_daemon "$T/a.conf"

mkdir -p "$T/shots"
brc=0
EXPIRED=$(python3 "$(dirname "$0")/../scripts/gigaview-token" --secret-file "$T/secret" \
    --groups staff --ttl=-10 --sub expired) || bail "mint an expired token"
timeout "$BROWSER_HANG" node "$BROWSER_DIR/auth.mjs" --base "$BASE" --public pub \
    --restricted staff-pic --large staff-large --group staff --other-group visitors \
    --expired-token "$EXPIRED" \
    --header X-Remote-Groups --heading "Staff only: log in" \
    --chromium "$CHROMIUM" --out "$T/shots" >"$T/auth.out" 2>&1 || brc=$?
browser_relay "$T/auth.out" "$brc" auth.mjs

stop_daemon
if [ "$drc" -eq 0 ]; then ok "gigaviewd exits 0 on SIGTERM"; else
    not_ok "gigaviewd exits 0 on SIGTERM (exit $drc)" "$(tail -n 20 "$T/daemon.log")"
fi
done_testing
