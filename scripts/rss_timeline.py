#!/usr/bin/env python3
"""Runs a command on a pseudo-terminal (so tritrace draws its phase lines) and samples its resident
memory (VmRSS in /proc/PID/status, with its child processes') every 50 ms: prints the timeline, each output line with the
time it was finished (tritrace's `loading ...  2.1 s` ends when the phase ends), and the peak.

    /usr/bin/python3 scripts/rss_timeline.py [--every 0.05] -- build/tritrace render scene.json -o x.png
"""
import argparse
import os
import pty
import select
import subprocess
import sys
import time


def rss_kib(pid):
    """VmRSS of pid plus that of its descendants (so that `/usr/bin/time -v CMD` can be sampled
    too), or None when pid has none (it has exited)."""
    total, found, todo = 0, False, [pid]
    while todo:
        p = todo.pop()
        try:
            with open(f"/proc/{p}/status") as f:
                for line in f:
                    if line.startswith("VmRSS:"):
                        total += int(line.split()[1])
                        found = True
            with open(f"/proc/{p}/task/{p}/children") as f:
                todo += [int(c) for c in f.read().split()]
        except (OSError, ValueError):
            pass
    return total if found else None


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--every", type=float, default=0.05, help="seconds between samples")
    parser.add_argument("command", nargs=argparse.REMAINDER)
    args = parser.parse_args()
    command = args.command[1:] if args.command[:1] == ["--"] else args.command
    if not command:
        parser.error("give a command after --")

    master, slave = pty.openpty()
    start = time.monotonic()
    child = subprocess.Popen(command, stdin=subprocess.DEVNULL, stdout=slave, stderr=slave)
    os.close(slave)
    samples, lines, pending = [], [], b""
    peak = (0, 0.0)
    open_terminal = True
    while True:
        ready, _, _ = select.select([master] if open_terminal else [], [], [], args.every)
        now = time.monotonic() - start
        if ready:
            try:
                chunk = os.read(master, 65536)
            except OSError:  # EIO: every holder of the terminal has closed it
                chunk = b""
            if not chunk:
                open_terminal = False
            pending += chunk
            while b"\n" in pending:
                line, pending = pending.split(b"\n", 1)
                # A redrawn line keeps only what follows its last carriage return.
                text = line.rstrip(b"\r").split(b"\r")[-1].decode(errors="replace").rstrip()
                if text:
                    lines.append((now, text))
        kib = rss_kib(child.pid)
        if kib is not None:
            samples.append((now, kib))
            if kib > peak[0]:
                peak = (kib, now)
        if child.poll() is not None and not open_terminal:
            break
    os.close(master)

    events = iter(lines)
    event = next(events, None)
    for t, kib in samples:
        while event is not None and event[0] <= t:
            print(f"{event[0]:7.2f} s  ---- {event[1]}")
            event = next(events, None)
        print(f"{t:7.2f} s  {kib / 1024:8.1f} MiB")
    for t, text in ([event] if event else []) + list(events):
        print(f"{t:7.2f} s  ---- {text}")
    print(f"peak {peak[0]} KiB ({peak[0] / 1048576:.3f} GiB) at {peak[1]:.2f} s; "
          f"exit status {child.returncode}")
    return child.returncode


if __name__ == "__main__":
    sys.exit(main())
