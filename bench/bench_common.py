"""What bench/harness.py and its sections share: waits, child processes that speak JSON
lines, /proc readings, statistics and the device-info of a made-up camera."""
import json
import os
import queue
import random
import statistics
import subprocess
import sys
import threading
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(ROOT, "tests"))

import conftest  # noqa: E402  (the suite's daemon, realdds server and domain-lock helpers)


class BenchError(Exception):
    pass


def log(msg):
    print(f"[bench {time.strftime('%H:%M:%S')}] {msg}", file=sys.stderr, flush=True)


def wait_until(pred, timeout, what, interval=0.02):
    """pred()'s first truthy value; BenchError at the deadline (a wait, never a fixed sleep):
    the suite's one wait helper, failing as the bench fails instead of as a test."""
    last = conftest.wait_for(pred, timeout, interval, what, fail=False)
    if last:
        return last
    raise BenchError(f"timed out after {timeout}s waiting for {what} (last: {last!r})")


def stats(values):
    """median and spread of repetitions."""
    v = sorted(x for x in values if x is not None)
    if not v:
        return {"n": 0}

    def q(p):
        return v[min(len(v) - 1, int(round(p * (len(v) - 1))))]
    out = {"median": statistics.median(v), "min": v[0], "max": v[-1], "p10": q(0.10), "p90": q(0.90),
           "n": len(v)}
    if len(v) > 1:
        out["stdev"] = statistics.stdev(v)
    if len(v) >= 20:
        out["p99"] = q(0.99)
    return out


def spawn_paired(cmds, turns, warmup=5):
    """Whole processes timed as hyperfine times them (spawn to reaped, in ms), every
    command once per turn in a random order, so that load from elsewhere on a shared
    machine falls on all of them alike: hyperfine runs each command's runs one after
    another, and a ratio of two of them then also measures the machine's drift.
    cmds: {label: argv}; returns {label: [ms, turn after turn]}."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    actions = [(os.POSIX_SPAWN_DUP2, devnull, 1), (os.POSIX_SPAWN_DUP2, devnull, 2)]

    def once(argv):
        t0 = time.perf_counter_ns()
        pid = os.posix_spawnp(argv[0], argv, os.environ, file_actions=actions)
        _, status = os.waitpid(pid, 0)
        took = (time.perf_counter_ns() - t0) / 1e6
        if status != 0:
            raise BenchError(f"{' '.join(argv)} failed (wait status {status})")
        return took
    try:
        for _ in range(warmup):
            for argv in cmds.values():
                once(argv)
        samples = {label: [] for label in cmds}
        for _ in range(turns):
            order = list(cmds.items())
            random.shuffle(order)
            for label, argv in order:
                samples[label].append(once(argv))
    finally:
        os.close(devnull)
    return samples


def block_ratios(of, to, block=20):
    """Paired samples (spawn_paired's, the same turns): per block of `block` turns, the
    median of `of` over the median of `to`."""
    return [statistics.median(of[i:i + block]) / statistics.median(to[i:i + block])
            for i in range(0, max(1, len(of) - block + 1), block)]


def ratio(a, b):
    return a / b if a is not None and b not in (None, 0) else None


def med_of(s):
    return (s or {}).get("median")


class Lines:
    """A child process whose stdout is JSON lines, read on a thread, with timed waits."""

    def __init__(self, args, **popen):
        self.proc = subprocess.Popen(args, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, **popen)
        self.q = queue.Queue()
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self):
        for line in self.proc.stdout:
            if line.startswith("{"):
                try:
                    self.q.put(json.loads(line))
                except ValueError:
                    pass
        self.q.put(None)

    def wait(self, pred, timeout, what):
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                raise BenchError(f"timed out after {timeout}s waiting for {what}")
            try:
                item = self.q.get(timeout=left)
            except queue.Empty:
                raise BenchError(f"timed out after {timeout}s waiting for {what}") from None
            if item is None:
                raise BenchError(f"{self.proc.args[0]} ended while waiting for {what}")
            if pred(item):
                return item

    def drain(self):
        out = []
        while True:
            try:
                item = self.q.get_nowait()
            except queue.Empty:
                return out
            if item is not None:
                out.append(item)

    def close(self):
        try:
            self.proc.stdin.close()
        except OSError:
            pass
        try:
            self.proc.wait(5)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()


def unix_get(sock_path, path, timeout=5.0):
    status, _, body = conftest.request_once(conftest.UnixHTTPConnection(sock_path, timeout=timeout), path)
    return status, body


def rss_kb(pid):
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return None


def cpu_seconds(pid):
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    tck = os.sysconf("SC_CLK_TCK")
    return (int(fields[11]) + int(fields[12])) / tck  # utime + stime (fields 14, 15)


# Cyclone DDS's own threads, by the names it gives them (its receive, timed-event,
# delivery-queue, garbage-collector, lease and transmit threads).
CYCLONE_THREADS = ("recv", "recvUC", "recvMC", "tev", "dq.", "gc", "lease", "xmit")


def thread_switches(pid):
    """Voluntary context switches (a thread's wake-ups from a wait) per group of the
    daemon's threads: main (the event loop), cyclone (CYCLONE_THREADS) and other (the
    API's loops, the USB event thread)."""
    out = {"main": 0, "cyclone": 0, "other": 0}
    for tid in os.listdir(f"/proc/{pid}/task"):
        try:
            with open(f"/proc/{pid}/task/{tid}/comm") as f:
                comm = f.read().strip()
            with open(f"/proc/{pid}/task/{tid}/status") as f:
                n = next(int(line.split()[1]) for line in f if line.startswith("voluntary_ctxt_switches"))
        except (OSError, StopIteration):
            continue  # a thread that ended meanwhile
        group = "main" if int(tid) == pid else "cyclone" if comm.startswith(CYCLONE_THREADS) else "other"
        out[group] += n
    return out


def device_info(n, prefix="9"):
    serial = f"{prefix}{n:011d}"
    return {"name": "Intel RealSense D455", "serial": serial, "product-line": "D400", "product-id": "0B5C",
            "fw-version": "5.16.0.1", "topic-root": f"realsense/D455_{serial}"}
