#!/usr/bin/env python3
"""Times a viewer's answers to one well-behaved client while slow and idle clients hold
connections open against it, on the loopback only.

    python3 scripts/viewer-load.py PORT [--slow 25] [--idle 25] [--seconds 30] [--path URL]

PORT is a running `lucid view ... --port PORT` (or `lucid train ... --view PORT`). Half the
extra connections send nothing, half trickle a request head one byte every 0.2 s; every 0.5 s
the script reopens any that the server closed, so the count stays up for the whole run. The
well-behaved client sends GET PATH (default /api/info) every 0.25 s and the script prints the
median, 95th percentile and worst time to a full reply, and how many requests failed.
"""

import argparse
import socket
import statistics
import threading
import time

HEAD = b"GET /api/info HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Slow: " + b"a" * 400


def get(port, path):
    started = time.monotonic()
    with socket.create_connection(("127.0.0.1", port), timeout=10) as s:
        s.sendall(f"GET {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n\r\n".encode())
        data = b""
        while chunk := s.recv(65536):
            data += chunk
    status = int(data.split(b" ", 2)[1]) if data.startswith(b"HTTP/1.1 ") else 0
    return status, time.monotonic() - started


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("port", type=int)
    parser.add_argument("--slow", type=int, default=25)
    parser.add_argument("--idle", type=int, default=25)
    parser.add_argument("--seconds", type=float, default=30.0)
    parser.add_argument("--path", default="/api/info")
    args = parser.parse_args()
    stop = threading.Event()
    held = {"opened": 0}

    def hold(count, trickle):
        conns = []
        offsets = []
        while not stop.is_set():
            while len(conns) < count:
                try:
                    conns.append(socket.create_connection(("127.0.0.1", args.port), timeout=1))
                    offsets.append(0)
                    held["opened"] += 1
                except OSError:
                    break
            for k in range(len(conns) - 1, -1, -1):
                try:
                    if trickle:
                        conns[k].sendall(HEAD[offsets[k] % len(HEAD) : offsets[k] % len(HEAD) + 1])
                        offsets[k] += 1
                except OSError:
                    conns.pop(k).close()
                    offsets.pop(k)
            time.sleep(0.2)
        for c in conns:
            c.close()

    threads = [threading.Thread(target=hold, args=(args.slow, True)), threading.Thread(target=hold, args=(args.idle, False))]
    for t in threads:
        t.start()
    time.sleep(1.0)
    times, failures = [], 0
    end = time.monotonic() + args.seconds
    while time.monotonic() < end:
        try:
            status, seconds = get(args.port, args.path)
            if status == 200:
                times.append(seconds)
            else:
                failures += 1
        except OSError:
            failures += 1
        time.sleep(0.25)
    stop.set()
    for t in threads:
        t.join()
    times.sort()
    if not times:
        print(f"no answer beside {args.slow} slow and {args.idle} idle connections; {failures} requests failed")
        return
    p95 = times[int(0.95 * (len(times) - 1))]
    print(
        f"{len(times)} answers beside {args.slow} slow and {args.idle} idle connections "
        f"({held['opened']} opened in all): median {statistics.median(times) * 1e3:.1f} ms, "
        f"95th percentile {p95 * 1e3:.1f} ms, worst {times[-1] * 1e3:.1f} ms; {failures} failed"
    )


if __name__ == "__main__":
    main()
