"""bench/run's `scale10k` section: 10,000 cameras from 100 participants over 4 domains
(issue 25), and where the daemon's memory per camera goes.

The cameras are raw Cyclone writers (bench/raw_writers.py: one process per domain, its
participants matched locally) with real realdds servers among them (one per domain).
Two daemons watch the same domains at once:
  full   the caps raised for the site (the per-domain caps' defaults are a flood guard:
         --max-devices-per-domain / --max-writers-per-domain, or the config keys);
  floor  every cap at 1: Cyclone still discovers and matches every writer (its proxies,
         its reliable-reader state), but the table holds one camera. Its growth is
         Cyclone's cost per camera; the full daemon's growth beyond it is the daemon's.
Measured: the time from the last announcement to all listed, RSS, GET /v1/devices of all
(10 clients, rsd-load and curl over the Unix socket), a filtered list (one serial), and one change
to 100 SSE watchers (a camera added, then its writer deleted).
"""
import json
import os
import subprocess
import time

from bench_common import BenchError, Lines, device_info, log, med_of, rss_kb, stats, unix_get, wait_until

HERE = os.path.dirname(os.path.abspath(__file__))

# (cameras, participants, domains, realdds cameras per domain, seconds per load run, changes)
SIZES = {"full": (10000, 100, 4, 5, 5, 20), "quick": (2000, 20, 4, 2, 2, 8), "smoke": (40, 4, 2, 1, 1, 2)}


def metric(sock, name):
    status, body = unix_get(sock, "/metrics")
    total = 0.0
    for line in body.decode().splitlines():
        if line.startswith(name + "{") or line.startswith(name + " "):
            total += float(line.rsplit(" ", 1)[1])
    return total


def run(b):
    """b: the harness's Bench (its domains, daemons, tools, cleanup)."""
    total, participants, ndomains, realdds_per_domain, secs, changes = SIZES[b.mode]
    domains = b.d_scale[:ndomains]
    per_domain = total // ndomains
    caps = ["--max-devices-per-domain", str(per_domain * 2), "--max-writers-per-domain", str(per_domain * 2)]
    floor_caps = []
    for key in ("devices-per-domain", "writers-per-domain", "devices-per-participant", "writers-per-participant"):
        floor_caps += [f"--max-{key}", "1"]
    full = b.start_daemon(domains, "scale-full", caps)
    floor = b.start_daemon(domains, "scale-floor", floor_caps)
    rss0 = {"full": rss_kb(full.proc.pid), "floor": rss_kb(floor.proc.pid)}

    # The realdds servers first (a process each), then the raw writers for the rest.
    realdds = b.start_servers(domains, [[device_info(d * 1000 + k, prefix="4") for k in range(realdds_per_domain)]
                                        for d in range(ndomains)], "scale-realdds")
    raw_per_domain = per_domain - realdds_per_domain
    parts_per_domain = max(1, participants // ndomains)
    writers = []
    t_launch = time.monotonic()
    for i, d in enumerate(domains):
        per_part = -(-raw_per_domain // parts_per_domain)
        # The last participant takes what is left: per_domain cameras exactly.
        w = Lines([b.python, os.path.join(HERE, "raw_writers.py"), "--domain", str(d), "--participants",
                   str(parts_per_domain), "--devices", str(per_part), "--prefix", "3", "--first",
                   str(i * 100000), "--readers", "2", "--match-timeout", "300"])
        b.cleanup.append(w.close)
        writers.append((w, parts_per_domain * per_part))
    hellos = [w.wait(lambda x: "writers" in x or "error" in x, 320, f"raw writers on domain {d}")
              for (w, _), d in zip(writers, domains)]
    for h in hellos:
        if "error" in h:
            raise BenchError(h["error"])
    expected = sum(n for _, n in writers) + realdds_per_domain * ndomains
    t_announced = max([h["t"] for h in hellos] + [s.hello["t"] for s in realdds])
    t_listed = wait_until(lambda: b.count(full) >= expected and time.monotonic(), 120,
                          f"{expected} cameras listed", interval=0.01)
    rss1 = {"full": rss_kb(full.proc.pid), "floor": rss_kb(floor.proc.pid)}
    status, body = unix_get(full.socket, "/v1/devices", timeout=30)
    doc = json.loads(body)
    one = doc["devices"][len(doc["devices"]) // 2]["serial"]
    res = {"devices": expected, "participants": parts_per_domain * ndomains + len(realdds), "domains": ndomains,
           "realdds_devices": realdds_per_domain * ndomains,
           "listed_after_last_announced_s": t_listed - t_announced,
           "listed_after_launch_s": t_listed - t_launch,
           "rss_kb_empty": rss0["full"], "rss_kb": rss1["full"],
           "floor_rss_kb_empty": rss0["floor"], "floor_rss_kb": rss1["floor"],
           "floor_devices": b.count(floor),
           "floor_writers_refused": metric(floor.socket, "rsd_writers_refused_total"),
           "list_bytes": len(body), "list_bytes_per_device": len(body) / max(1, len(doc["devices"]))}
    per = 1024 / expected
    res["memory_per_device_bytes"] = {
        "total": (rss1["full"] - rss0["full"]) * per,
        "cyclone": (rss1["floor"] - rss0["floor"]) * per,
        "daemon": ((rss1["full"] - rss0["full"]) - (rss1["floor"] - rss0["floor"])) * per,
        "json_document": len(body) / expected,
    }

    # Reading it: all of it, and a filtered list, 10 clients each.
    def load(path, sock=full.socket):
        r = subprocess.run([b.load, "http", "--unix", sock, "--path", path, "-c", "10", "-t", "2",
                            "-d", str(secs)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                           timeout=secs + 60)
        if r.returncode != 0:
            raise BenchError(f"rsd-load {path}: {r.stderr[-500:]}")
        return json.loads(r.stdout)
    res["list_all"] = load("/v1/devices")

    # The same with curl, a C client outside this project: 10 loops of curl at once,
    # each request's own time (curl's time_total: connect to last byte, not its start).
    def curl_load(path, sock=full.socket):
        loop = (f'end=$(( $(date +%s) + {secs} )); while [ $(date +%s) -lt $end ]; do '
                f'curl -s -o /dev/null -w "%{{time_total}}\\n" --unix-socket {sock} http://localhost{path}; done')
        procs = [subprocess.Popen(["sh", "-c", loop], stdout=subprocess.PIPE, text=True) for _ in range(10)]
        times = [float(x) * 1000 for p in procs for x in p.communicate(timeout=secs + 60)[0].split()]
        if not times:
            raise BenchError(f"curl {path}: no request completed")
        times.sort()
        return {"requests": len(times), "p50_ms": times[len(times) // 2], "p99_ms": times[int(len(times) * 0.99)]}
    # curl again, each of the 10 clients one process for 20 requests on its kept
    # connection: the server's time without the cost of starting curl. Started anew
    # for each request, 10 curls at once on 2 cores wait for each other's start (a
    # cold curl is some 7 ms of CPU), and that wait is most of the tail above, nginx's
    # as much as the daemon's.
    def curl_kept(path, sock=full.socket):
        urls = " ".join([f"-o /dev/null http://localhost{path}"] * 20)
        loop = (f'end=$(( $(date +%s) + {secs} )); while [ $(date +%s) -lt $end ]; do '
                f'curl -s -w "%{{time_total}}\n" --unix-socket {sock} {urls}; done')
        procs = [subprocess.Popen(["sh", "-c", loop], stdout=subprocess.PIPE, text=True) for _ in range(10)]
        times = sorted(float(x) * 1000 for p in procs for x in p.communicate(timeout=secs + 120)[0].split())
        if not times:
            raise BenchError(f"curl {path}: no request completed")
        return {"requests": len(times), "p50_ms": times[len(times) // 2], "p99_ms": times[int(len(times) * 0.99)]}
    res["list_all_curl"] = curl_load("/v1/devices")
    res["list_all_curl_kept"] = curl_kept("/v1/devices")
    # The anchor: nginx serving the same bytes from a file, read the same three ways.
    _, nginx_sock, _ = b.start_nginx(body, "nginx-scale10k")
    res["list_all_nginx"] = load("/v1/devices", nginx_sock)
    res["list_all_curl_nginx"] = curl_load("/v1/devices", nginx_sock)
    res["list_all_curl_kept_nginx"] = curl_kept("/v1/devices", nginx_sock)
    res["list_filtered"] = load(f"/v1/devices?serial={one}")
    res["rss_kb_after_reads"] = rss_kb(full.proc.pid)

    # One change to 100 watchers.
    watchers = 100 if b.mode != "smoke" else 10
    sse = Lines([b.load, "sse", "--unix", full.socket, "-c", str(watchers), "--timeout", "10"])
    b.cleanup.append(sse.close)
    connected = sse.wait(lambda x: "connected" in x, 30, "watchers connected")["connected"]
    sse.drain()
    w = writers[0][0]
    spread, last, by_kind, linger = [], [], {"added": [], "removed": []}, []
    for k in range(changes):
        info = device_info(k, prefix="2")
        kind = "added" if k % 2 == 0 else "removed"
        w.proc.stdin.write(json.dumps({"cmd": "add", "info": info} if kind == "added" else
                                      {"cmd": "remove", "topic-root": device_info(k - 1, prefix="2")["topic-root"]})
                           + "\n")
        w.proc.stdin.flush()
        reply = w.wait(lambda x: "ok" in x, 30, f"change {k}")
        got = {}
        event_id = None
        while len(got) < connected:
            ev = sse.wait(lambda x: x.get("event") == kind, 30, f"change {k} at {connected} watchers")
            event_id = event_id or ev["id"]
            if ev["id"] == event_id:
                got[ev["c"]] = ev["t"]
        ts = sorted(got.values())
        last.append((ts[-1] - reply["t"]) * 1000)
        by_kind[kind].append(last[-1])
        if "t_asked" in reply:
            linger.append((reply["t"] - reply["t_asked"]) * 1000)
        spread.append((ts[-1] - ts[0]) * 1000)
    sse.close()
    res["fanout"] = {"watchers": watchers, "connected": connected, "changes": changes,
                     "change_to_last_watcher_ms": stats(last), "first_to_last_watcher_ms": stats(spread),
                     "change_to_last_watcher_ms_by_kind": {k: stats(v) for k, v in by_kind.items()},
                     "writer_deletion_ms": stats(linger),
                     "note": "change: as the raw writer's write() began (added), or once its deletion returned "
                             "(removed: Cyclone's writer lingers for its readers' acks first, writer_deletion_ms), "
                             "CLOCK_MONOTONIC; so DDS delivery is in it"}
    for s in realdds:
        s.kill()
    for w, _ in writers:
        w.close()
    full.stop()
    floor.stop()
    log(f"scale10k: {expected} cameras listed {res['listed_after_last_announced_s']:.2f} s after the last "
        f"announcement; RSS {rss1['full'] / 1024:.1f} MB")
    return res


def rows(r, f):
    """The table's rows for the section's result r (f: the harness's number formatter)."""
    if "listed_after_last_announced_s" not in r:
        return []
    n = r["devices"]
    mem = r["memory_per_device_bytes"]
    rss_mb = r["rss_kb"] / 1024
    la, lc, lf, fo = r["list_all"], r["list_all_curl"], r["list_filtered"], r["fanout"]
    na, nc = r["list_all_nginx"], r["list_all_curl_nginx"]
    lk, nk = r["list_all_curl_kept"], r["list_all_curl_kept_nginx"]
    fo_p99 = fo["change_to_last_watcher_ms"].get("p99", fo["change_to_last_watcher_ms"].get("max"))
    spread = fo["first_to_last_watcher_ms"]
    kinds = fo.get("change_to_last_watcher_ms_by_kind", {})
    big = n >= 10000

    def verdict(ok):
        return ("met" if ok else "**missed**") if big else f"(at {n:,}: a smaller run, not judged)"
    return [
        {"comparison": f"{n:,} cameras ({r['realdds_devices']} realdds) from {r['participants']} participants over "
                       f"{r['domains']} domains: listed after the last announcement",
         "rs_discoveryd": f"{f(r['listed_after_last_announced_s'], 2)} s; RSS {f(rss_mb, 1)} MB "
                          f"({f(r['rss_kb_empty'] / 1024, 1)} MB empty)",
         "anchor": "", "ratio": "",
         "target": "≤ 10 s, RSS ≤ 160 MB: " + verdict(r["listed_after_last_announced_s"] <= 10 and rss_mb <= 160)},
        {"comparison": f"memory per camera at {n:,}",
         "rs_discoveryd": f"{f(mem['total'], 0)} B RSS: Cyclone {f(mem['cyclone'], 0)} B (a daemon with every cap "
                          f"at 1 beside it), the daemon's own {f(mem['daemon'], 0)} B",
         "anchor": f"its JSON document {f(mem['json_document'], 0)} B", "ratio": "", "target": ""},
        {"comparison": f"`GET /v1/devices` of all {n:,} ({f(r['list_bytes'] / 1e6, 2)} MB), 10 clients, unix",
         "rs_discoveryd": f"rsd-load: p99 {f(la['p99_ms'], 2)} ms, p50 {f(la['p50_ms'], 2)} ms, {f(la['rps'], 0)} req/s; "
                          f"curl, a connection kept: p99 {f(lk['p99_ms'], 2)} ms, p50 {f(lk['p50_ms'], 2)} ms "
                          f"({lk['requests']} requests); curl, a process a request: p99 {f(lc['p99_ms'], 2)} ms, "
                          f"p50 {f(lc['p50_ms'], 2)} ms ({lc['requests']} requests)",
         "anchor": f"nginx, the same bytes: rsd-load p99 {f(na['p99_ms'], 2)} ms, {f(na['rps'], 0)} req/s; "
                   f"curl, kept: p99 {f(nk['p99_ms'], 2)} ms, p50 {f(nk['p50_ms'], 2)} ms ({nk['requests']} requests); "
                   f"curl, a process a request: p99 {f(nc['p99_ms'], 2)} ms, p50 {f(nc['p50_ms'], 2)} ms "
                   f"({nc['requests']} requests)",
         "ratio": f"{f(la['p99_ms'] / na['p99_ms'], 2)}× p99 (rsd-load), {f(lk['p99_ms'] / nk['p99_ms'], 2)}× "
                  f"(curl, kept), {f(lc['p99_ms'] / nc['p99_ms'], 2)}× (curl, a process a request)",
         # Judged on the two clients that measure the server; curl started anew for
         # each request measures curl's start on a loaded machine (nginx's p99 too is
         # far above 25 ms that way), so it is shown beside nginx's, not judged.
         "target": "p99 ≤ 25 ms (rsd-load, curl kept): " + verdict(la["p99_ms"] <= 25 and lk["p99_ms"] <= 25)},
        {"comparison": f"a filtered list (one serial of {n:,}), 10 clients, unix",
         "rs_discoveryd": f"p99 {f(lf['p99_ms'], 3)} ms, p50 {f(lf['p50_ms'], 3)} ms, {f(lf['rps'], 0)} req/s",
         "anchor": "", "ratio": "", "target": "p99 ≤ 2 ms: " + verdict(lf["p99_ms"] <= 2)},
        {"comparison": f"one change to {fo['connected']} of {fo['watchers']} SSE watchers at {n:,} cameras",
         "rs_discoveryd": f"change → last watcher p99 {f(fo_p99, 2)} ms (n={fo['changes']}), median "
                          f"{f(fo['change_to_last_watcher_ms'].get('median'), 2)} ms; "
                          + ", ".join(f"{k} max {f(v.get('max'), 1)} ms" for k, v in kinds.items() if v.get("n")),
         "anchor": f"first → last watcher (the fan-out alone) max {f(spread.get('max'), 2)} ms; the peer's "
                   f"writer deletion itself took {f(med_of(fo.get('writer_deletion_ms')), 0)} ms (not counted)",
         "ratio": "",
         "target": "p99 ≤ 20 ms: " + verdict(fo_p99 is not None and fo_p99 <= 20)},
    ]
