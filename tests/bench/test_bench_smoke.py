"""bench/run --smoke: the harness of bench/ runs end to end against the real daemon, real
realdds servers, nginx and wrk, and writes latest.json (valid, every section,
none failed) and latest.md. No number is checked against a target: the machine is shared."""
import json
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SECTIONS = ["http", "cli_cold", "client_library", "librealsense", "discovery", "removal", "scale", "fanout", "idle",
            "open", "scale10k", "share", "clients"]


def test_bench_run_smoke(tmp_path):
    env = dict(os.environ, RSD_BENCH_PYTHON=sys.executable)
    r = subprocess.run([os.path.join(ROOT, "bench", "run"), "--smoke", "--out", str(tmp_path)], env=env,
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, timeout=200)
    assert r.returncode == 0, f"bench/run --smoke exited {r.returncode}:\n{r.stderr[-6000:]}"
    data = json.loads((tmp_path / "latest.json").read_text())
    assert data["meta"]["mode"] == "smoke"
    for name in SECTIONS:
        section = data["sections"].get(name)
        assert isinstance(section, dict), f"section {name} missing"
        assert "error" not in section, f"section {name} failed: {section['error']}\n{section.get('trace', '')}"
    s = data["sections"]
    # each comparison carries its anchor, measured in the same run
    assert {row["connections"] for row in s["http"]["rows"]} == {64, 1}
    assert {row["transport"] for row in s["http"]["rows"]} == {"tcp", "unix"}
    for row in s["http"]["rows"]:
        assert row["nginx"]["rps"]["n"] >= 1 and row["ratio"]["rps"]["n"] >= 1
    assert "/bin/true" in s["cli_cold"]["commands"]
    for name in ("unix", "http"):  # the library's list and a kept view's, each beside its floor
        e = s["client_library"]["endpoints"][name]
        assert e["request_304_median_us"]["n"] >= 1 and e["view_median_us"]["n"] >= 1
    assert s["discovery"]["dds_floor"]["n"] >= 1
    assert s["removal"]["sigkill_to_removed"]["n"] >= 1
    assert s["librealsense"]["query_ms"]["n"] >= 1
    assert s["scale"]["devices"] > 0 and s["scale"]["rss_kb"] > 0
    assert s["fanout"]["connected"] > 0
    assert set(s["idle"]["wakeups_per_min"]) == {"main", "cyclone", "other"}
    for leg in ("plug_to_a", "a_to_b", "unplug_to_a", "a_to_b_removed"):  # host A's own events beside B's
        assert s["share"][leg]["n"] == s["share"]["rounds"]
    for path in ("query-devices", "devices-changed", "librealsense", "realdds"):  # each beside its anchor
        assert s["open"]["paths"][path]["ready_ms"]["n"] >= 1 and s["open"]["paths"][path]["first_frame_ms"]["n"] >= 1
    for leg in ("device_to_daemon_dds", "daemon_dds_to_listed", "device_to_listed", "quit_to_unlisted"):
        assert s["clients"][leg]["n"] == s["clients"]["rounds"]
    big = s["scale10k"]  # the 10,000-camera row, small: every camera listed, memory split, reads, fan-out
    # The floor holds at most a camera a domain (none when a silent writer took the one slot).
    assert big["devices"] > 0 and big["floor_devices"] <= big["domains"], big
    assert big["memory_per_device_bytes"]["cyclone"] > 0 and big["list_all"]["requests"] > 0
    assert big["fanout"]["connected"] == big["fanout"]["watchers"]
    assert data["table"]
    md = (tmp_path / "latest.md").read_text()
    assert md.startswith("# bench/run") and "| comparison |" in md
