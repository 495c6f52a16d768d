"""No systemd PID 1 runs here, so the unit's SystemCallFilter= and
RestrictAddressFamilies= cannot be tried for real. Instead the daemon runs under
strace through start-up, API use, a device, a reload and a stop, and every system
call it makes must be one the unit's filter allows, every socket family one the
unit lets it have."""
import os
import re
import signal
import subprocess

import pytest

from conftest import DAEMON, UnixHTTPConnection, device_info, free_port, wait_for
from svc_util import SANITIZED, SOURCE_DIR, write_config

pytestmark = pytest.mark.skipif(SANITIZED, reason="the sanitizer runtime makes system calls of its own")


def expand(name, seen=None):
    """A systemd syscall set (@group or name), expanded recursively."""
    seen = seen if seen is not None else set()
    if not name.startswith("@"):
        return {name}
    if name in seen:
        return set()
    seen.add(name)
    out = subprocess.run(["systemd-analyze", "--no-pager", "syscall-filter", name], capture_output=True, text=True,
                         check=True).stdout
    calls = set()
    for line in out.splitlines()[1:]:
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        calls |= expand(line, seen)
    return calls


def unit_filter():
    allow, deny, families = set(), set(), None
    for line in open(os.path.join(SOURCE_DIR, "systemd", "rs-discoveryd.service")):
        line = line.strip()
        if line.startswith("SystemCallFilter="):
            value = line.split("=", 1)[1]
            target = deny if value.startswith("~") else allow
            for item in value.lstrip("~").split():
                target |= expand(item)
        elif line.startswith("RestrictAddressFamilies="):
            families = set(line.split("=", 1)[1].split())
    return allow - deny, families


def test_every_system_call_and_socket_family_is_allowed_by_the_unit(tmp_path, domains, realdds_server):
    allowed, families = unit_filter()
    assert "bind" in allowed and "reboot" not in allowed and "setrlimit" not in allowed
    a, b = domains.take(60, 79), domains.take(60, 79)
    config = tmp_path / "config.json"
    write_config(config, domains=[a], usb=True)
    sock, port = str(tmp_path / "api.sock"), free_port()
    trace = str(tmp_path / "strace.out")
    log = open(tmp_path / "daemon.log", "wb")
    p = subprocess.Popen(["strace", "-f", "-qq", "-o", trace, DAEMON, "--config", str(config), "--socket", sock,
                          "--http", f"127.0.0.1:{port}"], stdout=log, stderr=subprocess.STDOUT)
    def daemon_pid():
        # strace forks short-lived probes of its own at start; the daemon is the
        # child that has exec'd the daemon's binary.
        with open(f"/proc/{p.pid}/task/{p.pid}/children") as f:
            kids = [int(k) for k in f.read().split()]
        for kid in kids:
            try:
                if os.path.realpath(f"/proc/{kid}/exe") == os.path.realpath(DAEMON):
                    return kid
            except OSError:
                pass
        return None

    pid = None
    try:
        pid = wait_for(daemon_pid, what="the traced daemon")  # signals go to it, not to strace

        def ask(path):
            try:
                c = UnixHTTPConnection(sock, timeout=5)
                c.request("GET", path)
                r = c.getresponse()
                return r.status, r.read()
            except OSError:
                return None, b""

        realdds_server(a, [device_info(1)])
        wait_for(lambda: b'"domain"' in ask("/v1/devices")[1], timeout=30, what="device listed under strace")
        for path in ("/v1/domains", "/metrics", "/healthz", "/v1/devices?domain=1", "/nope"):
            assert ask(path)[0] is not None
        write_config(config, domains=[a, b], usb=True)
        os.kill(pid, signal.SIGHUP)
        wait_for(lambda: ask("/v1/domains")[1].count(b'"running"') == 2, timeout=30, what="reload under strace")
        os.kill(pid, signal.SIGUSR1)
        os.kill(pid, signal.SIGTERM)
        assert p.wait(30) == 0  # strace exits with the daemon's status
    finally:
        if p.poll() is None:
            p.kill()  # strace killed leaves its tracee running: end the daemon too
            p.wait()
            if pid:
                try:
                    os.kill(pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
        log.close()

    used, used_families = set(), set()
    for line in open(trace):
        m = re.match(r"\d+\s+(?:<\.\.\. )?(\w+)[( ]", line)
        if m and m.group(1) not in ("exit", "resumed", "killed", "exited"):
            used.add(m.group(1))
        f = re.search(r"\bsocket\((AF_\w+)", line)
        if f:
            used_families.add(f.group(1))
    assert "execve" in used and "socket" in used, sorted(used)[:20]
    # execve is systemd's own, before the filter applies to us.
    denied = sorted(used - allowed - {"execve"})
    assert not denied, f"the unit's SystemCallFilter= would refuse: {denied}"
    assert used_families <= families, f"the unit's RestrictAddressFamilies= would refuse: {used_families - families}"


def test_the_reload_check_needs_no_system_call_the_unit_refuses(tmp_path):
    """ExecReload= runs `rs-discoveryd --check-config` under the same filter."""
    allowed, _ = unit_filter()
    config = tmp_path / "config.json"
    for text in ('{"domains": [0, 5], "usb": false}', '{"domains": [0,'):  # valid, then not
        config.write_text(text)
        trace = str(tmp_path / "strace.out")
        r = subprocess.run(["strace", "-f", "-qq", "-o", trace, DAEMON, "--check-config", str(config)],
                           capture_output=True, text=True, timeout=60)
        assert r.returncode == (0 if text.endswith("}") else 1), r.stderr
        used = set()
        for line in open(trace):
            m = re.match(r"\d+\s+(?:<\.\.\. )?(\w+)[( ]", line)
            if m and m.group(1) not in ("exit", "resumed", "killed", "exited"):
                used.add(m.group(1))
        assert "openat" in used or "open" in used, sorted(used)
        denied = sorted(used - allowed - {"execve"})
        assert not denied, f"the unit's SystemCallFilter= would refuse: {denied}"
