#!/usr/bin/env python3
# make_corpus_access.py - writes the seed corpora of fuzz_access_token and
# fuzz_access_policy (tests/fuzz/corpus/access_token, access_policy):
# valid inputs and hostile ones (empty, huge, not base64, JSON bombs,
# deep nesting, wrong types, exp overflow, forged MACs).  Deterministic:
# rerunning gives the same files.  Past findings (finding-*) stay.
#
#   tests/fuzz/make_corpus_access.py
import base64, hashlib, hmac, json, os, sys

here = os.path.dirname(os.path.abspath(__file__))
SECRET = b"fuzz-secret-fuzz-secret-fuzz-secret!"  # fuzz_access_token.c
TOKEN, PAYLOAD, B64 = b"\x00", b"\x01", b"\x02"   # its selector byte


def b64(b):
    return base64.urlsafe_b64encode(b).rstrip(b"=")


def token(payload, secret=SECRET):
    return b64(payload) + b"." + b64(hmac.new(secret, payload, hashlib.sha256).digest())


def clean(kind):
    d = os.path.join(here, "corpus", kind)
    os.makedirs(d, exist_ok=True)
    for f in os.listdir(d):
        if not f.startswith("finding-"):
            os.remove(os.path.join(d, f))
    return d


def write(d, name, data):
    with open(os.path.join(d, name), "wb") as f:
        f.write(data)


d = clean("access_token")
good = b'{"sub":"ann","groups":["staff","board"],"exp":4000000000}'
t = token(good)
write(d, "tok-valid", TOKEN + t)
write(d, "tok-expired", TOKEN + token(b'{"sub":"ann","groups":["staff"],"exp":1700000000}'))
flipped = bytearray(t)
flipped[-5] = ord("A") if flipped[-5] != ord("A") else ord("B")
write(d, "tok-flipped-mac", TOKEN + bytes(flipped))
other = token(b'{"sub":"ann","groups":["staff","board","admin"],"exp":4000000000}')
write(d, "tok-altered-payload", TOKEN + other.split(b".")[0] + b"." + t.split(b".")[1])
write(d, "tok-other-secret", TOKEN + token(good, b"x" * 40))
write(d, "tok-empty", TOKEN)
write(d, "tok-dot", TOKEN + b".")
write(d, "tok-two-dots", TOKEN + t + b".x")
write(d, "tok-huge", TOKEN + b"A" * 5000 + b"." + b"A" * 43)
write(d, "tok-not-base64", TOKEN + b"eyJ*!.@@@@")
write(d, "tok-padding", TOKEN + b64(good) + b"==." + t.split(b".")[1])
write(d, "tok-nul-inside", TOKEN + t[:10] + b"\x00" + t[10:])
write(d, "tok-short-mac", TOKEN + t[:-2])
write(d, "tok-not-json", TOKEN + token(b"not json at all"))
write(d, "tok-deep", TOKEN + token(b"[" * 1500 + b"]" * 1500))
write(d, "tok-exp-overflow", TOKEN + token(b'{"groups":[],"exp":99999999999999999999999999}'))
write(d, "tok-exp-real", TOKEN + token(b'{"groups":[],"exp":4e9}'))
write(d, "tok-exp-2p53", TOKEN + token(b'{"groups":[],"exp":9007199254740992}'))
write(d, "tok-groups-string", TOKEN + token(b'{"groups":"staff","exp":4000000000}'))
write(d, "tok-17-groups", TOKEN + token(json.dumps(
    {"groups": ["g%d" % i for i in range(17)], "exp": 4000000000}).encode()))
write(d, "tok-dup-exp", TOKEN + token(b'{"groups":[],"exp":4000000000,"exp":1}'))
write(d, "pl-valid", PAYLOAD + good)
write(d, "pl-minimal", PAYLOAD + b'{"groups":[],"exp":1}')
write(d, "pl-empty", PAYLOAD)
write(d, "pl-bomb-deep", PAYLOAD + b'{"groups":' + b"[" * 1000 + b"]" * 1000 + b',"exp":1}')
write(d, "pl-wrong-types", PAYLOAD + b'{"sub":[],"groups":{},"exp":"1"}')
write(d, "pl-exp-zero", PAYLOAD + b'{"groups":[],"exp":0}')
write(d, "pl-exp-negative", PAYLOAD + b'{"groups":[],"exp":-1}')
write(d, "pl-iat", PAYLOAD + b'{"sub":"ann","groups":["staff"],"exp":4000000000,"iat":1764720000}')
write(d, "pl-iat-zero", PAYLOAD + b'{"groups":[],"exp":1,"iat":0}')
write(d, "pl-iat-string", PAYLOAD + b'{"groups":[],"exp":1,"iat":"1"}')
write(d, "tok-iat", TOKEN + token(b'{"sub":"ann","groups":["staff"],"exp":4000000000,"iat":1764720000}'))
write(d, "pl-exp-overflow", PAYLOAD + b'{"groups":[],"exp":18446744073709551616}')
write(d, "pl-sub-control", PAYLOAD + b'{"sub":"a\\u0001b","groups":[],"exp":1}')
write(d, "pl-sub-utf8", PAYLOAD + '{"sub":"Zoë","groups":[],"exp":1}'.encode())
write(d, "pl-bad-utf8", PAYLOAD + b'{"sub":"\xff\xfe","groups":[],"exp":1}')
write(d, "pl-group-nul", PAYLOAD + b'{"groups":["a\\u0000b"],"exp":1}')
write(d, "pl-too-long", PAYLOAD + b'{"groups":[],"exp":1,"pad":"' + b"x" * 2100 + b'"}')
write(d, "b64-canonical", B64 + b"Zm9vYmFy")
write(d, "b64-stray-bits", B64 + b"Zh")
write(d, "b64-len-1", B64 + b"Z")
write(d, "b64-std-alphabet", B64 + b"ab+/")
write(d, "b64-empty", B64)

d = clean("access_policy")
write(d, "valid", json.dumps({
    "groups": ["staff", "board"], "hide": False,
    "images": [{"id": "staff-open", "access": "public"},
               {"id": "staff-*", "access": "staff"},
               {"id": "board-*", "access": "board", "hide": True},
               {"id": "*", "access": "public"}],
    "messages": {"label": "Log in", "heading": "Restricted",
                 "note": "Staff only", "confirm_label": "Go",
                 "denied_heading": "No", "denied_note": "Not yours"}},
    indent=1).encode())
write(d, "empty", b"")
write(d, "empty-object", b"{}")
write(d, "not-json", b"groups = staff\n")
write(d, "array", b"[]")
write(d, "deep-nesting", b"[" * 50000)
write(d, "deep-in-images", b'{"images":' + b"[" * 3000 + b"]" * 3000 + b"}")
write(d, "bomb-wide", b'{"groups":["a"],"images":[' +
      b",".join([b'{"id":"*a*a*a*a*a*a*a*a*a*a*a*a*a*a*a*b","access":"a"}'] * 400) + b"]}")
write(d, "glob-stars", json.dumps({"groups": ["g"], "images": [
    {"id": "*" * 128, "access": "g"}, {"id": "a" + "*a" * 63, "access": "g"}]}).encode())
write(d, "wrong-types", b'{"groups":{"a":1},"images":"all","hide":"yes"}')
write(d, "rule-wrong-types", b'{"images":[{"id":7,"access":null,"hide":0}]}')
write(d, "unknown-group", b'{"groups":["staff"],"images":[{"id":"x","access":"staf"}]}')
write(d, "unknown-member", b'{"hidden":true}')
write(d, "dup-keys", b'{"hide":true,"hide":false}')
write(d, "public-group", b'{"groups":["public"]}')
write(d, "65-groups", json.dumps({"groups": ["g%d" % i for i in range(65)]}).encode())
write(d, "20-groups", json.dumps({"groups": ["g%d" % i for i in range(20)], "images": [
    {"id": "x%d" % i, "access": "g%d" % i} for i in range(20)]}).encode())
write(d, "pattern-too-long", json.dumps({"images": [{"id": "a" * 129, "access": "public"}]}).encode())
write(d, "pattern-traversal", b'{"images":[{"id":"../etc","access":"public"}]}')
write(d, "pattern-nul", b'{"images":[{"id":"a\\u0000b","access":"public"}]}')
write(d, "message-long", json.dumps({"messages": {"note": "n" * 1025}}).encode())
write(d, "message-nul", b'{"messages":{"note":"a\\u0000b"}}')
write(d, "bad-utf8", b'{"groups":["\xc3\x28"]}')
write(d, "trailing-garbage", b'{"groups":[]} {}')
write(d, "numbers-huge", b'{"hide":1e999999}')
write(d, "revoked", json.dumps({"groups": ["staff"], "images": [{"id": "*", "access": "staff"}],
                                "revoked": {"subjects": ["zed", "ann", "ann", "Zoë"],
                                            "issued_before": 1764720000}}).encode())
write(d, "revoked-bad", b'{"groups":["staff"],"images":[],"revoked":{"subjects":[""],"issued_before":-1}}')
write(d, "revoked-wrong-types", b'{"groups":[],"images":[],"revoked":{"subjects":"ann","extra":1}}')
write(d, "revoked-many", json.dumps({"revoked": {"subjects": ["s%d" % i for i in range(10001)]}}).encode())
write(d, "revoked-nul", b'{"revoked":{"subjects":["a\\u0000b"]}}')
