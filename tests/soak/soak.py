#!/usr/bin/env python3
"""tests/soak/soak.py: a bounded soak of gearloop-server (issue 7).

Starts gearloop-server on a free loopback port with a fresh SQLite file, drives it with
gearloop-load at a steady rate (two keep-alive clients, POST /api/v1/corrections), samples the
server's resident memory (VmRSS) every few seconds, and fails when

  - any request fails or an acknowledged job is not read back (gearloop-load's own check),
  - fewer than a quarter of the requested rate is reached, the server dies, or
    `PRAGMA integrity_check` of the history is not "ok" afterwards,
  - memory grows: the largest RSS of the last third exceeds the RSS at the end of the first
    third by more than --max-rss-growth-mb (SQLite's page cache and the allocator's arenas
    settle within the first third),
  - latency drifts: the median of the 10 s window p50s in the last third exceeds three times
    that of the first third plus 5 ms (loose: CI machines are shared),
  - beside the load, hostile clients (issue 17) are not contained: --slow-clients connections
    trickle a body a byte every 0.5 s (each must be cut off, 408 or closed, and reconnects), a
    client sends a 20 MiB chunked body every 2 s (each must be answered 413 before the end of
    it), and /healthz, asked every second, must answer within 1 s.

CI runs 60 s (ctest server_soak); the 10-minute soak of BENCHMARKS.md is

  python3 tests/soak/soak.py --server-bin build/server/gearloop-server \
      --load-bin build/server/gearloop-load --seconds 600 --rate 100
"""
import argparse
import os
import re
import socket
import sqlite3
import statistics
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def rss_mb(pid):
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        return None
    return None


def wait_healthy(port, server, timeout_s=30.0):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if server.poll() is not None:
            return False
        try:
            with urllib.request.urlopen(f"http://127.0.0.1:{port}/healthz", timeout=1) as r:
                if r.status == 200:
                    return True
        except OSError:
            time.sleep(0.1)
    return False


def trickle(port, stop, stats):
    """One slow client: a body a byte every 0.5 s until the server cuts it off; again."""
    while not stop.is_set():
        try:
            s = socket.create_connection(("127.0.0.1", port), timeout=5)
            s.sendall(b"POST /api/v1/corrections HTTP/1.1\r\nHost: x\r\nContent-Length: 100000\r\n\r\n{")
            answer = None
            while answer is None and not stop.is_set():
                s.sendall(b" ")
                stop.wait(0.5)
                s.setblocking(False)
                try:
                    answer = s.recv(4096)
                except BlockingIOError:
                    pass
                s.setblocking(True)
            if answer is not None:
                stats["cut"] += 1
                if answer and not answer.startswith(b"HTTP/1.1 408"):
                    stats["bad"].append(answer[:60])
            s.close()
        except OSError:
            stats["cut"] += 1  # reset by the server: cut off as well
            stop.wait(0.2)


def chunked_flood(port, stop, stats):
    """A 20 MiB chunked body every 2 s; each must be refused (413) before its end."""
    piece = b" " * 65536
    chunk = b"%x\r\n" % len(piece) + piece + b"\r\n"
    while not stop.is_set():
        sent = 0
        try:
            s = socket.create_connection(("127.0.0.1", port), timeout=10)
            s.sendall(b"POST /api/v1/corrections HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: chunked\r\n\r\n")
            answer = []
            reader = threading.Thread(target=lambda: answer.append(s.recv(64)), daemon=True)
            reader.start()
            while sent < 20 << 20:
                s.sendall(chunk)
                sent += len(piece)
            reader.join(10)
            s.close()
        except OSError:
            pass
        head = answer[0] if answer else b""
        if head.startswith(b"HTTP/1.1 413") and sent < 20 << 20:
            stats["refused"] += 1
        else:
            stats["bad"].append((head[:40], sent))
        stop.wait(2.0)


def watch_health(port, stop, stats):
    while not stop.is_set():
        begin = time.monotonic()
        try:
            with urllib.request.urlopen(f"http://127.0.0.1:{port}/healthz", timeout=5) as r:
                if r.status != 200:
                    stats["failures"] += 1
        except OSError:
            stats["failures"] += 1
        stats["worst_s"] = max(stats["worst_s"], time.monotonic() - begin)
        stop.wait(1.0)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--server-bin", required=True)
    parser.add_argument("--load-bin", required=True)
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--rate", type=float, default=100.0, help="requests per second, all clients together")
    parser.add_argument("--clients", type=int, default=2,
                        help="keep-alive connections sharing the rate (2: a 20 ms answer on a busy machine"
                             " does not yet slow the schedule)")
    parser.add_argument("--sample-seconds", type=float, default=5.0)
    parser.add_argument("--max-rss-growth-mb", type=float, default=8.0)
    parser.add_argument("--slow-clients", type=int, default=16, help="trickling connections beside the load")
    parser.add_argument("--no-chunked", action="store_true", help="without the 20 MiB chunked bodies")
    args = parser.parse_args()

    failures = []
    with tempfile.TemporaryDirectory(prefix="gearloop-soak-") as tmp:
        db = os.path.join(tmp, "soak.sqlite")
        port = free_port()
        server = subprocess.Popen([args.server_bin, "--host", "127.0.0.1", "--port", str(port), "--db", db,
                                   "--quiet"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        try:
            if not wait_healthy(port, server):
                print("soak: the server did not come up", file=sys.stderr)
                return 1
            start = time.monotonic()
            load = subprocess.Popen([args.load_bin, "--port", str(port), "--clients", str(args.clients),
                                     "--seconds", str(args.seconds), "--rate", str(args.rate / args.clients)],
                                    stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
            samples = []  # (t_s, rss_mb)
            stop = threading.Event()

            def sample():
                while not stop.is_set():
                    value = rss_mb(server.pid)
                    if value is not None:
                        samples.append((time.monotonic() - start, value))
                    stop.wait(args.sample_seconds)

            sampler = threading.Thread(target=sample, daemon=True)
            sampler.start()
            slow_stats = {"cut": 0, "bad": []}
            chunked_stats = {"refused": 0, "bad": []}
            health_stats = {"failures": 0, "worst_s": 0.0}
            hostile = [threading.Thread(target=trickle, args=(port, stop, slow_stats), daemon=True)
                       for _ in range(args.slow_clients)]
            if not args.no_chunked:
                hostile.append(threading.Thread(target=chunked_flood, args=(port, stop, chunked_stats), daemon=True))
            hostile.append(threading.Thread(target=watch_health, args=(port, stop, health_stats), daemon=True))
            for thread in hostile:
                thread.start()
            output = []
            for line in load.stdout:
                output.append(line)
                sys.stdout.write(line)
                sys.stdout.flush()
            load_rc = load.wait()
            stop.set()
            sampler.join()
            for thread in hostile:
                thread.join(15)
            print(f"soak: {args.slow_clients} slow clients cut off {slow_stats['cut']} times; "
                  f"{chunked_stats['refused']} chunked 20 MiB bodies refused 413; "
                  f"/healthz slowest {health_stats['worst_s']:.3f} s, {health_stats['failures']} failures")
            if slow_stats["bad"]:
                failures.append(f"slow clients answered other than 408: {slow_stats['bad'][:3]}")
            if chunked_stats["bad"]:
                failures.append(f"chunked bodies not refused 413 early: {chunked_stats['bad'][:3]}")
            if not args.no_chunked and chunked_stats["refused"] == 0:
                failures.append("no chunked body was refused")
            if health_stats["failures"] or health_stats["worst_s"] > 1.0:
                failures.append(f"/healthz: {health_stats['failures']} failures, slowest {health_stats['worst_s']:.3f} s")
            achieved = re.search(r"corrections \(([\d.]+)/s\)", "".join(output))
            if achieved and float(achieved.group(1)) < 0.25 * args.rate:
                failures.append(f"only {achieved.group(1)} requests/s of {args.rate}")
            if load_rc != 0:
                failures.append(f"gearloop-load exited {load_rc} (errors or acknowledged jobs missing)")
            if server.poll() is not None:
                failures.append(f"the server died (exit {server.returncode})")

            # Memory: compare within the load phase only (the read-back at the end fills the cache).
            in_load = [(t, m) for t, m in samples if t <= args.seconds]
            third = args.seconds / 3.0
            first = [m for t, m in in_load if t <= third]
            last = [m for t, m in in_load if t >= 2.0 * third]
            print("soak: RSS MB " + ", ".join(f"{t:.0f}s {m:.1f}" for t, m in samples))
            if first and last:
                growth = max(last) - first[-1]
                print(f"soak: RSS at {third:.0f} s {first[-1]:.1f} MB, largest in the last third {max(last):.1f} MB,"
                      f" growth {growth:+.1f} MB (limit {args.max_rss_growth_mb} MB)")
                if growth > args.max_rss_growth_mb:
                    failures.append(f"RSS grew by {growth:.1f} MB")
            else:
                failures.append("too few RSS samples")

            windows = [(float(m.group(1)), float(m.group(2)), float(m.group(3)))
                       for m in re.finditer(r"t =\s*([\d.]+) s: last 10 s p50 ([\d.]+) ms, p99 ([\d.]+) ms",
                                            "".join(output))]
            early = [p50 for t, p50, _ in windows if t <= third + 10]
            late = [p50 for t, p50, _ in windows if t >= 2.0 * third]
            if early and late:
                e, l = statistics.median(early), statistics.median(late)
                print(f"soak: median window p50 first third {e:.2f} ms, last third {l:.2f} ms")
                if l > 3.0 * e + 5.0:
                    failures.append(f"latency drifted: p50 {e:.2f} -> {l:.2f} ms")
            else:
                failures.append("too few latency windows (is the rate reached?)")
        finally:
            if server.poll() is None:
                server.terminate()
                try:
                    server.wait(timeout=30)
                except subprocess.TimeoutExpired:
                    server.kill()
                    server.wait()
        if server.returncode not in (0, -15):
            failures.append(f"the server exited {server.returncode} on SIGTERM: {server.stderr.read()[-2000:]}")
        connection = sqlite3.connect(db)
        integrity = connection.execute("PRAGMA integrity_check").fetchone()[0]
        jobs = connection.execute("SELECT COUNT(*) FROM jobs").fetchone()[0] if connection.execute(
            "SELECT name FROM sqlite_master WHERE name = 'jobs'").fetchone() else -1
        connection.close()
        print(f"soak: integrity_check {integrity}, jobs table rows {jobs}")
        if integrity != "ok":
            failures.append(f"integrity_check: {integrity}")
    for failure in failures:
        print("soak: FAIL: " + failure, file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
