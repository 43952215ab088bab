#!/usr/bin/env python3
"""Where a command's wall time goes, on a machine without perf or strace: runs the command and
samples /proc every 2 ms (each thread's state and current system call, the process's resident
memory), then prints a timeline in 20 ms steps (threads running, what the main thread waits in,
resident MiB) and when the files under an output folder were last written.

Usage: python3 scripts/proc_timeline.py [--out DIR] -- COMMAND ARGS...
"""
import collections
import os
import subprocess
import sys
import time

SYSCALLS = {0: "read", 1: "write", 3: "close", 7: "poll", 9: "mmap", 10: "mprotect", 11: "munmap",
            16: "ioctl", 17: "pread", 28: "madvise", 35: "nanosleep", 202: "futex", 228: "clock",
            230: "nanosleep", 231: "exit_group", 60: "exit", 61: "wait4", 232: "epoll_wait",
            257: "openat", 262: "fstat", 281: "epoll_pwait", 25: "mremap", 26: "msync", 74: "fsync",
            75: "fdatasync", 82: "rename", 293: "pipe2", 56: "clone", 435: "clone3"}


def sample(pid, main_tid):
    running, main = 0, "?"
    try:
        tids = os.listdir(f"/proc/{pid}/task")
    except OSError:
        return None
    for tid in tids:
        try:
            with open(f"/proc/{pid}/task/{tid}/stat") as f:
                stat = f.read()
            state = stat[stat.rindex(")") + 2]
        except (OSError, ValueError):
            continue
        if state == "R":
            running += 1
        if int(tid) == main_tid:
            if state == "R":
                main = "run"
            else:
                try:
                    with open(f"/proc/{pid}/task/{tid}/syscall") as f:
                        nr = f.read().split()[0]
                    main = SYSCALLS.get(int(nr), f"sys{nr}") if nr.lstrip("-").isdigit() else nr
                except (OSError, IndexError):
                    main = state
    try:
        with open(f"/proc/{pid}/statm") as f:
            rss = int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20
    except OSError:
        rss = 0.0
    return running, main, rss


def main():
    args = sys.argv[1:]
    out = None
    if args[:1] == ["--out"]:
        out, args = args[1], args[2:]
    if args[:1] == ["--"]:
        args = args[1:]
    t0 = time.time()
    p = subprocess.Popen(args)
    rows = []
    while p.poll() is None:
        s = sample(p.pid, p.pid)
        if s:
            rows.append((time.time() - t0, *s))
        time.sleep(0.002)
    wall = time.time() - t0
    steps = collections.defaultdict(list)
    for t, running, main_state, rss in rows:
        steps[int(t / 0.02)].append((running, main_state, rss))
    print(f"{' '.join(args[:2])}: {wall:.3f} s wall, exit {p.returncode}, {len(rows)} samples")
    print("   ms  threads running  main thread                 RSS MiB")
    for k in sorted(steps):
        v = steps[k]
        mean_running = sum(r for r, _, _ in v) / len(v)
        states = collections.Counter(m for _, m, _ in v).most_common(2)
        text = ", ".join(f"{m} {n}/{len(v)}" for m, n in states)
        print(f"{k * 20:5d}  {mean_running:15.1f}  {text:26}  {max(r for _, _, r in v):7.0f}")
    if out:
        times = []
        for root, _, files in os.walk(out):
            for name in files:
                times.append((os.stat(os.path.join(root, name)).st_mtime - t0, name))
        for t, name in sorted(times)[-3:]:
            print(f"written {name} at {t * 1e3:.0f} ms")


if __name__ == "__main__":
    main()
