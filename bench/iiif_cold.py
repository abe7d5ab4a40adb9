#!/usr/bin/python3
"""iiif_cold.py - one pass over a URL list, each URL requested exactly once.

    iiif_cold.py BASE-URL URL-FILE CONNECTIONS

bench/http-iiif.sh runs it against a freshly started server to measure the
cold cache: CONNECTIONS keep-alive connections (one thread each) take the
next URL of the list in turn until every URL has been asked once.  Prints
one line on stdout:

    requests ok errors seconds req_per_s p50_ms p99_ms max_ms

"ok" is a 200 with a body; the latency of a request is from sending it to
the end of its body, on an already open connection.  The Python client
costs some 0.2 ms a request, small beside a cold render.
"""
import http.client
import sys
import threading
import time
import urllib.parse


def main():
    base, path, nconn = sys.argv[1], sys.argv[2], int(sys.argv[3])
    urls = [u.strip() for u in open(path) if u.strip()]
    host = urllib.parse.urlsplit(base)
    lock = threading.Lock()
    state = {"next": 0, "ok": 0, "errors": 0, "lat": []}

    def worker():
        conn = http.client.HTTPConnection(host.hostname, host.port, timeout=60)
        while True:
            with lock:
                i = state["next"]
                state["next"] += 1
            if i >= len(urls):
                break
            t0 = time.monotonic()
            try:
                conn.request("GET", urls[i])
                r = conn.getresponse()
                body = r.read()
                good = r.status == 200 and len(body) > 0
            except (OSError, http.client.HTTPException):
                good = False
                conn.close()
                conn = http.client.HTTPConnection(host.hostname, host.port, timeout=60)
            dt = time.monotonic() - t0
            with lock:
                state["ok" if good else "errors"] += 1
                state["lat"].append(dt)
        conn.close()

    t0 = time.monotonic()
    threads = [threading.Thread(target=worker) for _ in range(nconn)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    wall = time.monotonic() - t0
    lat = sorted(state["lat"])
    n = len(lat)

    def pct(p):
        return 1000 * lat[min(n - 1, int(p * n))] if n else 0

    print("%d %d %d %.3f %.1f %.1f %.1f %.1f" % (
        n, state["ok"], state["errors"], wall, n / wall if wall else 0,
        pct(0.50), pct(0.99), 1000 * lat[-1] if n else 0))


if __name__ == "__main__":
    main()
