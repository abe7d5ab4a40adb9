#!/usr/bin/env python3
"""make_corpus_store_meta.py - regenerates tests/fuzz/corpus/store_meta,
the seeds of fuzz_store_meta: metadata sections (docs/FORMAT.md section 6)
as the encoder writes them for a slide and a raster, and hostile ones -
bad magic, version 0, a newer version, lengths that disagree, JSON that is
not an object, nested values, bad keys, NUL in a string, duplicate keys,
non-finite numbers, too many keys, an array too long, a string too long,
JSON one byte over the size limit, deep nesting; default display windows
(display.window) as encode writes them and hostile ones: not a string,
black not below white, past 255, a bad gamma, too many channels, the wrong
channel count, text past the window's limit, a NUL.  Deterministic; past
findings (finding-*) stay."""
import json
import os
import struct

here = os.path.dirname(os.path.abspath(__file__))
out = os.path.join(here, "corpus", "store_meta")
os.makedirs(out, exist_ok=True)
for f in os.listdir(out):
    if not f.startswith("finding-"):
        os.remove(os.path.join(out, f))

MAX_JSON = 65536


def section(body, version=1, length=None, magic=b"GVMD"):
    if isinstance(body, str):
        body = body.encode()
    n = len(body) if length is None else length
    return magic + struct.pack("<II", version, n) + body


def put(name, data):
    with open(os.path.join(out, name), "wb") as f:
        f.write(data)


slide = {"slide.levels": 2, "slide.mpp_x": 0.499, "slide.mpp_y": 0.499,
         "slide.objective_power": 20.0, "slide.vendor": "aperio"}
wkt = 'PROJCS["WGS 84 / UTM zone 33N",GEOGCS["WGS 84"],AUTHORITY["EPSG","32633"]]'
geo = {"geo.bands": 1, "geo.crs_wkt": wkt, "geo.driver": "GTiff",
       "geo.epsg": 32633, "geo.transform": [500000.0, 10.0, 0.0, 4600000.0, 0.0, -10.0]}
compact = dict(separators=(",", ":"), sort_keys=True)
put("slide", section(json.dumps(slide, **compact)))
put("geo", section(json.dumps(geo, **compact)))
put("empty-object", section("{}"))
put("bad-magic", section("{}", magic=b"GVMX"))
put("version-0", section("{}", version=0))
put("version-newer", section('{"any":"thing"}', version=2))
put("length-short", section('{"a":1}', length=3))
put("length-long", section('{"a":1}', length=400))
put("length-huge", section('{"a":1}', length=0xFFFFFFFF))
put("truncated-head", b"GVMD\x01\x00")
put("not-object", section("[1,2,3]"))
put("scalar", section("42"))
put("nested", section('{"a":{"b":1}}'))
put("array-of-strings", section('{"a":["x"]}'))
put("bool", section('{"a":true}'))
put("null", section('{"a":null}'))
put("key-upper", section('{"Slide":1}'))
put("key-space", section('{"a b":1}'))
put("key-empty", section('{"":1}'))
put("key-long", section(json.dumps({"k" * 65: 1})))
put("nul-string", section('{"a":"x\\u0000y"}'))
put("duplicate", section('{"a":1,"a":2}'))
put("nan", section('{"a":NaN}'))
put("huge-number", section('{"a":1e999}'))
put("array-nan", section('{"a":[1,1e999]}'))
put("trailing", section('{"a":1} x'))
put("utf8-bad", section(b'{"a":"\xff\xfe"}'))
put("many-keys", section(json.dumps({"k%d" % i: i for i in range(65)}, **compact)))
put("long-array", section(json.dumps({"a": list(range(17))}, **compact)))
put("long-string", section(json.dumps({"a": "x" * 16385}, **compact)))
pad = MAX_JSON - len('{"a":""}') + 1
put("over-limit", section('{"a":"' + "x" * pad + '"}'))
put("deep", section("[" * 3000 + "]" * 3000))

# The default display window (display.window, render/window.h).
def win(v):
    return section(json.dumps({"display.window": v, "slide.mpp_x": 0.5}, **compact))


put("window", win("30,200,1.500"))
put("window-per-channel", win("10,250,1.000;50,150,0.500;0,100,3.333"))
put("window-number", win(30))
put("window-array", section('{"display.window":[30,200,1]}'))
put("window-equal", win("5,5,1"))
put("window-inverted", win("200,30,1"))
put("window-past-255", win("0,256,1"))
put("window-negative", win("-1,255,1"))
put("window-gamma-low", win("0,255,0.099"))
put("window-gamma-high", win("0,255,10.001"))
put("window-gamma-digits", win("0,255,1.2345"))
put("window-gamma-nan", win("0,255,nan"))
put("window-two", win("0,255,1;0,255,1"))
put("window-nine", win(";".join(["0,255,1"] * 9)))
put("window-trailing", win("0,255,1;"))
put("window-huge", win("99999999999999999999,255,1"))
put("window-long", win("0,255,1" + " " * 600))
put("window-nul", section('{"display.window":"0,255,1\\u00000,1"}'))
put("window-empty", win(""))
put("window-duplicate", section('{"display.window":"0,255,1","display.window":"1,2,1"}'))
