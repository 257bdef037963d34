#!/usr/bin/env python3
"""Answer time of POST /api/v1/shaving/cutter-target (issue 18, BENCHMARKS.md): posts
clients/examples/shaving.json N times on one keep-alive connection to a running gearloop-server
and prints the client's wall time per answer and the server's elapsed_ms (the engine call).

    build/server/gearloop-server --port 18779 --db /tmp/bench_shv.sqlite --quiet &
    python3 bench/shaving_http.py 18779 [N=200] [WARMUP=20]
"""
import http.client
import json
import pathlib
import sys
import time

REQUEST = pathlib.Path(__file__).resolve().parent.parent / "clients" / "examples" / "shaving.json"


def quantile(values, p):
    ordered = sorted(values)
    return ordered[int(p * (len(ordered) - 1))]


def main() -> None:
    port = int(sys.argv[1])
    count = int(sys.argv[2]) if len(sys.argv) > 2 else 200
    warmup = int(sys.argv[3]) if len(sys.argv) > 3 else 20
    body = REQUEST.read_text()
    conn = http.client.HTTPConnection("127.0.0.1", port)
    walls, engine = [], []
    for i in range(warmup + count):
        start = time.perf_counter()
        conn.request("POST", "/api/v1/shaving/cutter-target", body, {"Content-Type": "application/json"})
        answer = conn.getresponse()
        data = answer.read()
        wall_ms = (time.perf_counter() - start) * 1e3
        if answer.status != 200:
            sys.exit(f"HTTP {answer.status}: {data[:200]!r}")
        if i >= warmup:
            walls.append(wall_ms)
            engine.append(json.loads(data)["elapsed_ms"])
    print(f"n {len(walls)} wall p50 {quantile(walls, .5):.2f} p90 {quantile(walls, .9):.2f} "
          f"p99 {quantile(walls, .99):.2f} max {max(walls):.2f} ms")
    print(f"server elapsed_ms p50 {quantile(engine, .5):.2f} p90 {quantile(engine, .9):.2f}")


if __name__ == "__main__":
    main()
