"""Times N sequential POST /v1/scenes/demo/transforms on one keep-alive connection
and prints one JSON line: the server's --state, and latency percentiles in ms.
   python3 transforms_latency.py URL STATE N"""
import http.client
import json
import sys
import time
import urllib.parse

url, state, n = sys.argv[1], sys.argv[2], int(sys.argv[3])
u = urllib.parse.urlparse(url)
conn = http.client.HTTPConnection(u.hostname, u.port)
times = []
for k in range(n):
    body = json.dumps({"objects": [{"id": 40 + k % 8, "translation": [0.0, 0.01 * (k % 50), 0.0]}]})
    t = time.perf_counter()
    conn.request("POST", "/v1/scenes/demo/transforms", body, {"content-type": "application/json"})
    r = conn.getresponse()
    r.read()
    times.append((time.perf_counter() - t) * 1e3)
    if r.status != 200:
        sys.exit(f"update {k}: {r.status}")
times.sort()
at = lambda q: round(times[int(q * (len(times) - 1))], 3)
print(json.dumps({"state": state, "updates": n, "p50_ms": at(0.5), "p99_ms": at(0.99), "max_ms": round(times[-1], 3)}))
