#!/bin/sh
# http_access.sh - access control end to end (docs/OPERATIONS.md "Access
# control", docs/API.md "Access control and IIIF Authorization Flow 2.0").
#
# A store directory with a public image (pub), one of group staff
# (staff-dem, a height store, so that meshes and terrain answer too) and
# one of group board that is hidden (board-minutes).  Checks: without a
# token every image route of a protected image answers 401 with the
# JSON error body and WWW-Authenticate (404 like an absent image, body
# and headers alike, when hidden); with a token of its group 200 (or the
# route's usual answer), with Cache-Control private and Vary; expired,
# forged (a flipped MAC byte; a payload altered under the same MAC),
# malformed and other-group tokens are 401; the image list and the home
# page show what the caller may see; info.json carries the IIIF
# Authorization Flow 2.0 services; the probe answers 200/401/404; the
# login through the trusted header sets the cookie, the token service
# posts an AuthAccessToken2 with the messageId to the origin (and an
# error to an origin not listed), the logout clears the cookie; a
# policy rewritten and SIGHUP'ed takes effect; `gigaview info URL` sends
# GIGAVIEW_TOKEN; a bad policy or a short
# secret stops the daemon from starting.
# Tokens are minted by scripts/gigaview-token (Python's hmac), so the
# C verifier is checked against an independent signer, and one by
# `gigaview token`.
. "$(dirname "$0")/lib.sh"
. "$(dirname "$0")/http_util.sh"

srcroot=$(cd "$(dirname "$0")/.." && pwd)
S=$T/stores
mkdir "$S" || bail "mkdir"
run encode synth:1200x800 -o "$S/pub.gv"
[ "$rc" -eq 0 ] || bail "encode pub: $(cat "$T/err")"
run encode --height --max-error 2 --unit m --offset -11000 \
    "$TESTDATA/etopo5-720x361-u16.png" -o "$S/staff-dem.gv"
[ "$rc" -eq 0 ] || bail "encode staff-dem: $(cat "$T/err")"
run encode synth:900x700 -o "$S/board-minutes.gv"
[ "$rc" -eq 0 ] || bail "encode board-minutes: $(cat "$T/err")"

head -c 48 /dev/urandom | base64 >"$T/secret" || bail "secret"
chmod 600 "$T/secret"
cat >"$T/policy.json" <<'EOF2'
{"groups": ["staff", "board"],
 "images": [
   {"id": "staff-*", "access": "staff"},
   {"id": "board-*", "access": "board", "hide": true},
   {"id": "*", "access": "public"}
 ]}
EOF2
cat >"$T/a.conf" <<EOF2
store_dir = "$S"
threads = 2
gpu = off
access_log = stderr
access_policy = "$T/policy.json"
access_token_secret_file = "$T/secret"
access_trusted_header = "X-Remote-Groups"
access_origins = "https://viewer.example.org http://localhost:9"
EOF2

# mint GROUPS [TTL]: a token signed with the secret.
mint() {
    python3 "$srcroot/scripts/gigaview-token" --secret-file "$T/secret" \
        --groups "$1" --ttl="${2:-3600}" --sub tester
}
STAFF=$(mint staff) || bail "mint"
BOARD=$(mint board)
BOTH=$(mint staff,board)
EXPIRED=$(mint staff -10)
# A flipped bit in the MAC's first byte; the payload of BOTH under
# STAFF's MAC.
FLIPPED=$(python3 - "$STAFF" <<'PY'
import base64, sys
p, m = sys.argv[1].split(".")
mac = bytearray(base64.urlsafe_b64decode(m + "=" * (-len(m) % 4)))
mac[0] ^= 1
print(p + "." + base64.urlsafe_b64encode(bytes(mac)).rstrip(b"=").decode())
PY
)
ALTERED="${BOTH%%.*}.${STAFF#*.}"
OTHER_SECRET=$(printf '%s' "${STAFF%%.*}" | python3 -c '
import base64, hashlib, hmac, sys
p = sys.stdin.read()
pl = base64.urlsafe_b64decode(p + "=" * (-len(p) % 4))
mac = hmac.new(b"x" * 40, pl, hashlib.sha256).digest()
print(p + "." + base64.urlsafe_b64encode(mac).rstrip(b"=").decode())')

# ------------------------------------------------------------ start-up
printf '{"groups": ["staff"], "images": [{"id": "a*", "access": "staf"}]}\n' \
    >"$T/bad-policy.json"
sed "s|$T/policy.json|$T/bad-policy.json|" "$T/a.conf" >"$T/bad1.conf"
rc=0
"$GIGAVIEWD" -t -c "$T/bad1.conf" >/dev/null 2>"$T/err" || rc=$?
expect_rc "-t refuses a policy naming an unknown group" 1
expect_err_is "-t names the file and the rule" \
    "gigaviewd: $T/bad-policy.json: images[0]: access: neither \"public\" nor a group listed in \"groups\""
printf '{"groups": ["staff"],\n "images": [}\n' >"$T/bad-policy.json"
rc=0
"$GIGAVIEWD" -t -c "$T/bad1.conf" >/dev/null 2>"$T/err" || rc=$?
expect_rc "-t refuses a policy that is not JSON" 1
expect_err "-t names file:line:column of the syntax error" "$T/bad-policy.json:2:"
printf 'short secret\n' >"$T/short"
sed "s|$T/secret|$T/short|" "$T/a.conf" >"$T/bad2.conf"
rc=0
"$GIGAVIEWD" -t -c "$T/bad2.conf" >/dev/null 2>"$T/err" || rc=$?
expect_rc "-t refuses a secret under 32 bytes" 1
expect_err "-t says how long the secret is" "12 bytes; a secret needs at least 32"
rc=0
(gvd -c "$T/bad2.conf" -p 0) >/dev/null 2>"$T/err" || rc=$?
expect_rc "the daemon does not start with a short secret" 1
check "-t accepts the good configuration" "$GIGAVIEWD" -t -c "$T/a.conf"

start_daemon "$T/a.conf"

# ------------------------------------------------------------ the routes
# Every route that shows an image: "METHOD PATH-AFTER-ID STATUS-WITH-ACCESS"
# (the id is put in front).  filter: gpu = off, so 503 even with access.
cat >"$T/routes" <<'EOF2'
GET /v1/images/ID 200
GET /v1/images/ID/root 200
GET /v1/images/ID/tiles/0/0/0 200
GET /v1/images/ID/batch?t=0,0,0 200
POST /v1/images/ID/batch 200
GET /v1/images/ID/region?level=0&x=0&y=0&w=64&h=64&format=png 200
GET /iiif/3/ID 303
GET /iiif/3/ID/info.json 200
GET /iiif/3/ID/full/64,/0/default.png 200
GET /v1/images/ID/mesh?level=0&region=0,0,64,64&max_error=15&format=obj 200
GET /v1/images/ID/terrain/layer.json 200
GET /v1/images/ID/terrain/0/0/0.terrain 200
POST /v1/images/ID/filter 503
EOF2
printf '{"tiles": [[0, 0, 0]]}' >"$T/batch.json"
printf '{"filter": "blur", "level": 0, "region": [0, 0, 32, 32]}' >"$T/filter.json"

# call METHOD PATH [CURL ARGS...]: one request with the body the route
# takes.
call() {
    cm=$1 cp=$2
    shift 2
    case $cm:$cp in
    POST:*/batch) req -X POST -H 'Content-Type: application/json' \
        --data-binary @"$T/batch.json" "$@" "$(url "$cp")" ;;
    POST:*/filter) req -X POST -H 'Content-Type: application/json' \
        --data-binary @"$T/filter.json" "$@" "$(url "$cp")" ;;
    *) req "$@" "$(url "$cp")" ;;
    esac
}

# Without a token: 401, JSON error, WWW-Authenticate; hidden: 404 as
# an absent image that no protected rule names (same body but for the
# id, same headers but Date).
while read -r m p want; do
    sp=$(printf '%s' "$p" | sed 's/ID/staff-dem/')
    call "$m" "$sp"
    if [ "$code" = 401 ] && error_body_ok 401 &&
        [ "$(header WWW-Authenticate)" = 'Bearer realm="gigaview"' ] &&
        [ "$(header Vary)" = "Authorization, Cookie" ]; then
        ok "no token: $m $sp is 401 with WWW-Authenticate"
    else
        not_ok "no token: $m $sp (got $code)" "$(cat "$T/h")" "$(head -c 300 "$T/b")"
    fi
    bp=$(printf '%s' "$p" | sed 's/ID/board-minutes/')
    call "$m" "$bp"
    hcode=$code
    sed 's/board-minutes/XXXXX/g' "$T/b" >"$T/hidden.b"
    tr -d '\r' <"$T/h" | grep -v '^Date:' >"$T/hidden.h"
    ap=$(printf '%s' "$p" | sed 's/ID/nothing-here1/')
    call "$m" "$ap"
    sed 's/nothing-here1/XXXXX/g' "$T/b" >"$T/absent.b"
    tr -d '\r' <"$T/h" | grep -v '^Date:' >"$T/absent.h"
    # 404, but for filters: with gpu = off their route answers 503 before
    # it looks for the image, for an absent image and a hidden one alike.
    case $bp in */filter) hwant=503 ;; *) hwant=404 ;; esac
    if [ "$hcode" = "$hwant" ] && [ "$code" = "$hwant" ] &&
        cmp -s "$T/hidden.b" "$T/absent.b" && cmp -s "$T/hidden.h" "$T/absent.h"; then
        ok "no token: hidden $m $bp is $hwant like an absent image"
    else
        not_ok "no token: hidden $m $bp (got $hcode, absent $code)" \
            "$(diff "$T/hidden.h" "$T/absent.h")" "$(diff "$T/hidden.b" "$T/absent.b")"
    fi
done <"$T/routes"

# With a token of the group: the route's usual answer, private.
while read -r m p want; do
    sp=$(printf '%s' "$p" | sed 's/ID/staff-dem/')
    call "$m" "$sp" -H "Authorization: Bearer $STAFF"
    cc=$(header Cache-Control)
    if [ "$code" = "$want" ] && [ "$(header Vary | sed 's/.*\(Authorization, Cookie\)$/\1/')" = "Authorization, Cookie" ] &&
        case $cc in *public*) false ;; *private*|*no-store*) true ;; *) false ;; esac; then
        ok "staff token: $m $sp is $want, Cache-Control $cc, Vary"
    else
        not_ok "staff token: $m $sp (got $code, wanted $want)" "$(cat "$T/h")" "$(head -c 300 "$T/b")"
    fi
    bp=$(printf '%s' "$p" | sed 's/ID/board-minutes/')
    case $bp in */mesh*|*/terrain/*) bwant=400 ;; *) bwant=$want ;; esac
    call "$m" "$bp" -b "gigaview_access=$BOARD"
    if [ "$code" = "$bwant" ]; then
        ok "board cookie: hidden $m $bp is $bwant"
    else
        not_ok "board cookie: hidden $m $bp (got $code, wanted $bwant)" "$(head -c 300 "$T/b")"
    fi
done <"$T/routes"

# Public images keep their caching.
req "$(url /v1/images/pub/tiles/0/0/0)"
check "public tile: Cache-Control stays public" \
    sh -c "tr -d '\r' <'$T/h' | grep -qi '^Cache-Control: public'"
check "public tile: no Vary on credentials" \
    sh -c "! grep -qi '^Vary:.*Authorization' '$T/h'"
req -H "Authorization: Bearer $STAFF" "$(url /v1/images/pub/tiles/0/0/0)"
check "public tile with a token: still public" \
    sh -c "tr -d '\r' <'$T/h' | grep -qi '^Cache-Control: public'"

# ------------------------------------------------------------ refused tokens
for t in expired:$EXPIRED flipped-mac:$FLIPPED altered-payload:$ALTERED \
    other-secret:$OTHER_SECRET malformed:not-a-token two-dots:a.b.c \
    empty-mac:${STAFF%%.*}. other-group:$BOARD; do
    name=${t%%:*} tok=${t#*:}
    for how in bearer cookie; do
        if [ $how = bearer ]; then
            req -H "Authorization: Bearer $tok" "$(url /v1/images/staff-dem/tiles/0/0/0)"
        else
            req -b "gigaview_access=$tok" "$(url /v1/images/staff-dem/tiles/0/0/0)"
        fi
        if [ "$code" = 401 ] && error_body_ok 401; then
            ok "$name token ($how): 401"
        else
            not_ok "$name token ($how): got $code"
        fi
    done
done
req -H "Authorization: Bearer $EXPIRED" "$(url /v1/images/staff-dem)"
check "a refused token: WWW-Authenticate says invalid_token" \
    test "$(header WWW-Authenticate)" = 'Bearer realm="gigaview", error="invalid_token"'
expect_status "a token of both groups" 200 /v1/images/staff-dem -H "Authorization: Bearer $BOTH"
CLI=$(gv token --secret-file "$T/secret" --groups board,staff --ttl 3600 --sub cli) ||
    not_ok "gigaview token mints a token"
expect_status "a token from gigaview token" 200 /v1/images/board-minutes -H "Authorization: Bearer $CLI"
rc=0
gv token --secret-file "$T/short" --groups staff >/dev/null 2>"$T/err" || rc=$?
expect_rc "gigaview token refuses a short secret" 1

# ------------------------------------------------------------ lists
ids() {
    python3 -c 'import json,sys; print(" ".join(sorted((i["id"] + ":" + i.get("access", "public")) for i in json.load(open(sys.argv[1]))["images"])))' "$T/b"
}
req "$(url /v1/images)"
check "list without a token: pub and staff-dem (restricted), not board-minutes" \
    test "$(ids)" = "pub:public staff-dem:restricted"
check "list: private, Vary" test "$(header Vary)" = "Authorization, Cookie"
req -H "Authorization: Bearer $STAFF" "$(url /v1/images)"
check "list with staff: staff-dem granted" test "$(ids)" = "pub:public staff-dem:granted"
req -b "gigaview_access=$BOARD" "$(url /v1/images)"
check "list with board: board-minutes granted" \
    test "$(ids)" = "board-minutes:granted pub:public staff-dem:restricted"
req "$(url /)"
check "home page without a token: no board-minutes" sh -c "! grep -q 'board-minutes' '$T/b'"
check "home page: lists pub" grep -q '#image=pub' "$T/b"
req -b "gigaview_access=$BOARD" "$(url /)"
check "home page with board: board-minutes listed" grep -q '#image=board-minutes' "$T/b"

# The native client sends GIGAVIEW_TOKEN as its Bearer token.
GIGAVIEW_TOKEN= run info "$BASE"
check "gigaview info URL without a token: no board-minutes" \
    sh -c "[ $rc -eq 0 ] && ! grep -q board-minutes '$T/out'"
GIGAVIEW_TOKEN=$BOARD run info "$BASE"
check "gigaview info URL with GIGAVIEW_TOKEN of board: board-minutes listed" \
    sh -c "[ $rc -eq 0 ] && grep -q board-minutes '$T/out'"
GIGAVIEW_TOKEN='not a token' run info "$BASE"
check "gigaview info URL with a malformed GIGAVIEW_TOKEN: refused, said why" \
    sh -c "[ $rc -ne 0 ] && grep -q 'GIGAVIEW_TOKEN is not an access token' '$T/err'"
# A restricted image through the GPU client, its token expired: said so.
GIGAVIEW_TOKEN=$EXPIRED run render "$BASE" --timeout "$GV_TEST_PATIENCE" --image staff-dem --level 3 -o "$T/expired.png"
if grep -q 'needs a build with GPU' "$T/err"; then
    skip "gigaview render with an expired GIGAVIEW_TOKEN" "built without GPU support"
else
    check "gigaview render of a restricted image with an expired GIGAVIEW_TOKEN: refused, said why" \
        sh -c "[ $rc -ne 0 ] && grep -q 'HTTP 401.*GIGAVIEW_TOKEN must hold an access token' '$T/err' && [ ! -e $T/expired.png ]"
    GIGAVIEW_TOKEN=$STAFF run render "$BASE" --timeout "$GV_TEST_PATIENCE" --image staff-dem --level 3 -o "$T/fresh.png"
    check "... and with a good one, rendered" sh -c "[ $rc -eq 0 ] && [ -s $T/fresh.png ]"
fi

# ------------------------------------------------------------ info.json
req -H "Authorization: Bearer $STAFF" "$(url /iiif/3/staff-dem/info.json)"
cat >"$T/services.py" <<'PY'
import json, sys
j, base, img = json.load(open(sys.argv[1])), sys.argv[2], sys.argv[3]
s = j["service"]
assert len(s) == 1, s
p = s[0]
assert p["type"] == "AuthProbeService2" and p["id"] == base + "/iiif/auth/probe/" + img, p
a = p["service"][0]
assert a["type"] == "AuthAccessService2" and a["profile"] == "active", a
assert a["id"] == base + "/iiif/auth/login", a
for k in ("label", "heading", "note", "confirmLabel"):
    assert isinstance(a[k]["en"][0], str) and a[k]["en"][0], k
t, o = a["service"]
assert t == {"id": base + "/iiif/auth/token", "type": "AuthAccessTokenService2"}, t
assert o["id"] == base + "/iiif/auth/logout" and o["type"] == "AuthLogoutService2", o
PY
check "info.json: probe, access, token and logout services" \
    python3 "$T/services.py" "$T/b" "$BASE" staff-dem
check "info.json: the auth context before the image context" \
    test "$(json_get 'j["@context"]')" = "['http://iiif.io/api/auth/2/context.json', 'http://iiif.io/api/image/3/context.json']"
req "$(url /iiif/3/staff-dem/info.json)"
check "info.json 401: the error body also names the services" \
    python3 "$T/services.py" "$T/b" "$BASE" staff-dem
req "$(url /iiif/3/pub/info.json)"
check "a public info.json has no auth service" test "$(json_get '"service" in j')" = False

# ------------------------------------------------------------ probe
probe() { # probe ID [CURL ARGS...]: the probe's status field
    id=$1
    shift
    req "$@" "$(url "/iiif/auth/probe/$id")"
    [ "$code" = 200 ] && [ "$(json_get 'j["type"]')" = AuthProbeResult2 ] &&
        json_get 'j["status"]'
}
check "probe: public image 200" test "$(probe pub)" = 200
check "probe: staff-dem without token 401" test "$(probe staff-dem)" = 401
check "probe: the 401 has a heading and a note" \
    test "$(json_get 'bool(j["heading"]["en"][0] and j["note"]["en"][0])')" = True
check "probe: no-store, Vary" sh -c "grep -qi '^Cache-Control: no-store' '$T/h' && grep -qi '^Vary: Authorization, Cookie' '$T/h'"
check "probe: staff-dem with staff 200" test "$(probe staff-dem -H "Authorization: Bearer $STAFF")" = 200
check "probe: staff-dem with board 401" test "$(probe staff-dem -H "Authorization: Bearer $BOARD")" = 401
check "probe: staff-dem with an expired token 401" test "$(probe staff-dem -H "Authorization: Bearer $EXPIRED")" = 401
check "probe: hidden board-minutes without token 404" test "$(probe board-minutes)" = 404
check "probe: absent image 404" test "$(probe board-nothing)" = 404
check "probe: board-minutes with board 200" test "$(probe board-minutes -H "Authorization: Bearer $BOARD")" = 200
check "probe: CORS for any origin" test "$(header Access-Control-Allow-Origin)" = "*"

# ------------------------------------------------------------ login, token, logout
req "$(url /iiif/auth/login)"
check "login without the proxy's header: 401" test "$code" = 401
req -H "X-Remote-Groups: staff, nonsense!, board" "$(url "/iiif/auth/login?origin=https://viewer.example.org")"
cookie=$(header Set-Cookie)
COOKIE=$(printf '%s' "$cookie" | sed -n 's/^gigaview_access=\([^;]*\);.*/\1/p')
check "login: 200 HTML that closes the window" \
    sh -c "[ $code = 200 ] && grep -q 'window.close()' '$T/b'"
case $cookie in
*"; HttpOnly; SameSite=Lax") ok "login over http: the cookie is HttpOnly, SameSite=Lax" ;;
*) not_ok "login: cookie flags" "$cookie" ;;
esac
case $cookie in *Secure*) not_ok "login over http: no Secure flag" "$cookie" ;;
*) ok "login over http: no Secure flag" ;; esac
req -H "X-Remote-Groups: staff" -H "X-Forwarded-Proto: https" "$(url /iiif/auth/login)"
case $(header Set-Cookie) in *"; SameSite=None; Secure") ok "login behind https: SameSite=None; Secure" ;;
*) not_ok "login behind https: Secure" "$(header Set-Cookie)" ;; esac
expect_status "the login cookie opens staff-dem" 200 /v1/images/staff-dem -b "gigaview_access=$COOKIE"
expect_status "the login cookie opens board-minutes" 200 /v1/images/board-minutes -b "gigaview_access=$COOKIE"
expect_status "the groups header elsewhere is ignored" 401 /v1/images/staff-dem -H "X-Remote-Groups: staff"
req "$(url "/iiif/auth/login?token=$STAFF")"
check "login with ?token=: the cookie holds it" \
    test "$(header Set-Cookie | sed -n 's/^gigaview_access=\([^;]*\);.*/\1/p')" = "$STAFF"
check "the access log does not show a ?token=" sh -c "grep -q 'GET /iiif/auth/login?token=-\"' '$T/daemon.log' && ! grep -q '$STAFF' '$T/daemon.log'"
req "$(url "/iiif/auth/login?token=$FLIPPED")"
check "login with a forged ?token=: 401, no cookie" \
    sh -c "[ $code = 401 ] && ! grep -qi '^Set-Cookie' '$T/h'"

# post_of: the message and the origin the token page posts (JSON lines).
post_of() {
    python3 - "$T/b" <<'PY'
import json, re, sys
page = open(sys.argv[1]).read()
m = re.search(r"<script>window\.parent\.postMessage\((.*), (\"[^\"]*\")\);</script>", page, re.S)
msg, origin = json.loads(m.group(1)), json.loads(m.group(2))
print(json.dumps([msg.get("type"), msg.get("messageId"), msg.get("profile"),
                  msg.get("accessToken"), origin, msg.get("@context")]))
PY
}
t0=$(date +%s)
req -b "gigaview_access=$COOKIE" \
    "$(url "/iiif/auth/token?messageId=m-1&origin=https://viewer.example.org")"
t1=$(date +%s)
want=$(printf '["AuthAccessToken2", "m-1", null, "%s", "https://viewer.example.org", "http://iiif.io/api/auth/2/context.json"]' "$COOKIE")
check "token service: posts AuthAccessToken2 with the messageId to the origin" \
    test "$(post_of)" = "$want"
# expiresIn is the cookie's exp less the time of the answer (between t0
# and t1, however long the test has run since the login).
check "token service: expiresIn within the ttl" \
    python3 -c "import base64,json,re,sys; p=sys.argv[2].split('.')[0]; x=json.loads(base64.urlsafe_b64decode(p + '=' * (-len(p) % 4)))['exp']; e=int(re.search(r'\"expiresIn\":(\d+)', open(sys.argv[1]).read()).group(1)); assert x - int(sys.argv[4]) <= e <= min(x - int(sys.argv[3]), 3600)" "$T/b" "$COOKIE" "$t0" "$t1"
check "token service: no-store, text/html" \
    sh -c "grep -qi '^Cache-Control: no-store' '$T/h' && grep -qi '^Content-Type: text/html' '$T/h'"
check "token service: only the origin may frame it" \
    sh -c "grep -qi '^Content-Security-Policy:.*frame-ancestors https://viewer.example.org' '$T/h'"
req "$(url "/iiif/auth/token?messageId=m-2&origin=https://viewer.example.org")"
check "token service without the cookie: missingAspect" \
    test "$(post_of)" = '["AuthAccessTokenError2", "m-2", "missingAspect", null, "https://viewer.example.org", "http://iiif.io/api/auth/2/context.json"]'
req -b "gigaview_access=$EXPIRED" "$(url "/iiif/auth/token?messageId=m-3&origin=https://viewer.example.org")"
check "token service with an expired cookie: expiredAspect" \
    test "$(post_of | python3 -c 'import json,sys; print(json.load(sys.stdin)[2])')" = expiredAspect
req -b "gigaview_access=$FLIPPED" "$(url "/iiif/auth/token?messageId=m-4&origin=https://viewer.example.org")"
check "token service with a forged cookie: invalidAspect" \
    test "$(post_of | python3 -c 'import json,sys; print(json.load(sys.stdin)[2])')" = invalidAspect
req -b "gigaview_access=$COOKIE" "$(url "/iiif/auth/token?messageId=m-5&origin=https://evil.example.com")"
check "token service to an origin not listed: invalidOrigin, no token" \
    sh -c "grep -q invalidOrigin '$T/b' && ! grep -q '$COOKIE' '$T/b'"
req -b "gigaview_access=$COOKIE" \
    "$(url "/iiif/auth/token?origin=https://viewer.example.org&messageId=%3C%2Fscript%3E%3Cscript%3Ealert(1)%3C%2Fscript%3E")"
check "token service: a hostile messageId cannot close the script" \
    test "$(grep -o '</script>' "$T/b" | wc -l)" = 1
expect_status "token service without messageId" 400 "/iiif/auth/token?origin=https://viewer.example.org"
expect_status "token service with a bad origin" 400 "/iiif/auth/token?messageId=1&origin=javascript:alert(1)"
req -b "gigaview_access=$COOKIE" "$(url /iiif/auth/logout)"
check "logout: clears the cookie" \
    sh -c "[ $code = 200 ] && tr -d '\r' <'$T/h' | grep -q '^Set-Cookie: gigaview_access=; Path=/; Max-Age=0'"

# ------------------------------------------------------------ revocation
# answers STATUS PATH [CURL ARGS]: PATH answers STATUS now.
# shellcheck disable=SC2317 # run by wait_until
answers() {
    a_want=$1 a_path=$2
    shift 2
    req "$@" "$(url "$a_path")"
    [ "$code" = "$a_want" ]
}
# hup_until DESC STATUS PATH [CURL ARGS]: SIGHUP, then wait until PATH
# answers STATUS.
hup_until() {
    d=$1 want=$2
    shift 2
    kill -HUP "$DPID"
    wait_until answers "$want" "$@"
    check "$d ($code)" test "$code" = "$want"
}
# logged_more N PATTERN: the daemon's log has more than N lines that match
# PATTERN (a reload that fails says so only in the log).
# shellcheck disable=SC2317 # run by wait_until
logged_more() {
    [ "$(grep -c -- "$2" "$T/daemon.log")" -gt "$1" ]
}
ANN=$(python3 "$srcroot/scripts/gigaview-token" --secret-file "$T/secret" --groups staff --sub ann)
NOIAT=$(python3 "$srcroot/scripts/gigaview-token" --secret-file "$T/secret" --groups staff --no-iat)
iat=$(python3 -c "import base64,json,sys; p=sys.argv[1].split('.')[0]; print(json.loads(base64.urlsafe_b64decode(p + '=' * (-len(p) % 4)))['iat'])" "$STAFF")
expect_status "ann's token, before revocation" 200 /v1/images/staff-dem -H "Authorization: Bearer $ANN"
expect_status "a token without iat, before revocation" 200 /v1/images/staff-dem -H "Authorization: Bearer $NOIAT"
POLICY=$(cat "$T/policy.json")
printf '%s' "$POLICY" | python3 -c "import json,sys; p=json.load(sys.stdin); p['revoked']={'subjects':['zed','ann']}; print(json.dumps(p))" >"$T/policy.json"
hup_until "revoked subject: ann's token is refused after SIGHUP" 401 /v1/images/staff-dem -H "Authorization: Bearer $ANN"
check "... as an invalid token" test "$(header WWW-Authenticate)" = 'Bearer realm="gigaview", error="invalid_token"'
req -b "gigaview_access=$ANN" "$(url /iiif/3/staff-dem/info.json)"
check "... in a cookie too" test "$code" = 401
expect_status "another subject's token still serves" 200 /v1/images/staff-dem -H "Authorization: Bearer $STAFF"
LATER=$(python3 "$srcroot/scripts/gigaview-token" --secret-file "$T/secret" --groups staff --iat $((iat + 1)))
printf '%s' "$POLICY" | python3 -c "import json,sys; p=json.load(sys.stdin); p['revoked']={'issued_before':$((iat + 1))}; print(json.dumps(p))" >"$T/policy.json"
hup_until "issued_before: a token issued a second before is refused" 401 /v1/images/staff-dem -H "Authorization: Bearer $STAFF"
expect_status "... a token without iat too" 401 /v1/images/staff-dem -H "Authorization: Bearer $NOIAT"
expect_status "... one issued at that second serves" 200 /v1/images/staff-dem -H "Authorization: Bearer $LATER"
expect_status "... and ann's is no longer revoked by name" 200 /v1/images/staff-dem -H "Authorization: Bearer $ANN"
printf '%s' "$POLICY" | python3 -c "import json,sys; p=json.load(sys.stdin); p['revoked']={'subjects':['']}; print(json.dumps(p))" >"$T/policy.json"
kill -HUP "$DPID"
wait_until logged_more 0 "revoked: subjects\[0\]: not a subject"
expect_status "a revocation of an empty subject is refused: the previous policy stays" 401 \
    /v1/images/staff-dem -H "Authorization: Bearer $STAFF"
check "... and the error is logged" grep -q "revoked: subjects\[0\]: not a subject" "$T/daemon.log"
printf '%s' "$POLICY" >"$T/policy.json"
hup_until "the policy without revocations: STAFF serves again" 200 /v1/images/staff-dem -H "Authorization: Bearer $STAFF"

# ------------------------------------------------------------ SIGHUP
cat >"$T/policy.json" <<'EOF2'
{"groups": ["staff"], "hide": true,
 "images": [{"id": "pub", "access": "staff"}]}
EOF2
kill -HUP "$DPID"
wait_until answers 404 /v1/images/pub
check "SIGHUP: the new policy hides pub" test "$code" = 404
expect_status "SIGHUP: staff-dem is public now" 200 /v1/images/staff-dem
printf '{"groups": [' >"$T/policy.json"
stays=$(grep -c "previous policy stays" "$T/daemon.log")
kill -HUP "$DPID"
wait_until logged_more "$stays" "previous policy stays"
expect_status "SIGHUP with a broken policy: the previous one stays" 404 /v1/images/pub
check "SIGHUP with a broken policy: logged" logged_more "$stays" "previous policy stays"

stop_daemon
check "daemon exits 0" test "$drc" -eq 0
no_sanitizer_report
done_testing
