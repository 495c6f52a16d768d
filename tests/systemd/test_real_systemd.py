"""The packages under a real systemd: a minimal Debian booted with systemd-nspawn.

One system, in the order a user meets it: the previous release installed, upgraded
to this tree's packages, the service contract checked (user, enablement, socket
activation on both sockets, permissions, STATUS=, reload, journal, watchdog, crash
restart and its rate limit, hardening), a reboot with the packages installed, and
at last remove (the CLI stays, without the daemon) and purge.

The container has its own network namespace: its DDS traffic and port 8035 are
its own. RSD_SUITE picks the Debian release (default: this host's); RSD_DEBS_DIR
gives prebuilt packages of this tree (default: built here with packaging/build-deb).
"""
import json
import subprocess
import os
import re
import shutil
import time

import pytest

import nspawn
from conftest import wait_for

SUITE = os.environ.get("RSD_SUITE") or nspawn.host_suite()
BUILD_IN_CONTAINER = SUITE != nspawn.host_suite()
API_SOCK = "/run/rs-discoveryd/api.sock"
SERVICE = "rs-discoveryd.service"
SOCKET = "rs-discoveryd.socket"
CURRENT, PREVIOUS = nspawn.CURRENT, nspawn.PREVIOUS

pytestmark = pytest.mark.skipif(os.geteuid() != 0, reason="boots a container: needs root")


def timed(what, fn, *args):
    t0 = time.monotonic()
    out = fn(*args)
    nspawn.log(f"{what}: {time.monotonic() - t0:.1f} s")
    return out


@pytest.fixture(scope="module")
def debs(tmp_path_factory):
    given = os.environ.get("RSD_DEBS_DIR")
    if given and "rs-discoveryd" in nspawn.debs_in(given):
        current = nspawn.debs_in(given)
    else:
        out = str(tmp_path_factory.mktemp("debs"))
        current = timed("build-deb (this tree)", nspawn.build_debs, nspawn.SOURCE_DIR, out,
                        SUITE if BUILD_IN_CONTAINER else None)
    previous = timed("build-deb (previous release, or its cache)", nspawn.previous_debs,
                     SUITE if BUILD_IN_CONTAINER else None)
    for p in CURRENT:
        assert p in current, f"{p} not built: {sorted(current)}"
    yield current, previous


@pytest.fixture(scope="module")
def system(debs, tmp_path_factory):
    current, previous = debs
    wanted = {p: current[p] for p in CURRENT}
    old = {p: previous[p] for p in PREVIOUS}
    tar = timed("rootfs", nspawn.system_rootfs, SUITE, current, previous)
    staged = tmp_path_factory.mktemp("staged")
    for name, group in (("current", wanted), ("previous", old)):
        (staged / name).mkdir()
        for path in group.values():
            shutil.copy(path, staged / name)
    c = nspawn.Container(tar, binds=[(str(staged), "/srv/debs")])
    try:
        nspawn.log(f"boot: {c.boot():.1f} s")
        c.current, c.previous = current, previous
        yield c
    finally:
        c.remove()


# ---- helpers: what a user types ---------------------------------------------------

def show(c, unit, *props):
    out = c.run("systemctl", "show", unit, *[f"--property={p}" for p in props]).stdout
    return dict(line.split("=", 1) for line in out.splitlines() if "=" in line)


def main_pid(c):
    return int(show(c, SERVICE, "MainPID")["MainPID"])


def curl(c, path, unix=False, user=None, check=False):
    """(HTTP status or None, body) of GET path, through the Unix socket or HTTP."""
    cmd = ["curl", "-sS", "--max-time", "10", "-o", "-", "-w", "\n%{http_code}"]
    cmd += ["--unix-socket", API_SOCK, f"http://localhost{path}"] if unix else [f"http://127.0.0.1:8035{path}"]
    if user:
        cmd = ["setpriv", *user, *cmd]
    r = c.run(*cmd, check=False)
    body, _, code = r.stdout.rpartition("\n")
    status = int(code) if r.returncode == 0 and code.isdigit() else None
    if check:
        assert status == 200, (path, unix, r.returncode, r.stdout, r.stderr)
    return status, body if status else r.stderr


def answers(c):
    """Both sockets answer /healthz with 200."""
    return all(curl(c, "/healthz", unix=u)[0] == 200 for u in (True, False))


def domains(c):
    status, body = curl(c, "/v1/domains", check=True)
    return sorted(d["domain"] for d in json.loads(body)["domains"])


def status_text(c):
    return show(c, SERVICE, "StatusText")["StatusText"]


def journal(c, *args):
    """The service's journal lines since boot as (priority, message)."""
    out = c.run("journalctl", "-b", "-u", SERVICE, "-o", "json", "--no-pager", *args).stdout
    lines = []
    for line in out.splitlines():
        e = json.loads(line)
        msg = e.get("MESSAGE")
        if isinstance(msg, list):
            msg = bytes(msg).decode(errors="replace")
        lines.append((int(e.get("PRIORITY", 6)), msg or ""))
    return lines


def write_config(c, **settings):
    c.run("sh", "-ec", "cat > /etc/rs-discoveryd/config.json.new && mv /etc/rs-discoveryd/config.json.new "
          "/etc/rs-discoveryd/config.json", input=json.dumps(settings, indent=2) + "\n")


def apt_install(c, directory, names):
    debs = c.current if directory == "current" else c.previous
    files = [f"/srv/debs/{directory}/{os.path.basename(debs[p])}" for p in names]
    return c.run("apt-get", "install", "-y", *files, timeout=300)


def restart_seen(c, old_pid, timeout):
    """Waits until the service runs again under a new PID and answers; the PID."""
    def up():
        s = show(c, SERVICE, "MainPID", "ActiveState", "SubState")
        pid = int(s["MainPID"])
        return pid if pid not in (0, old_pid) and s["ActiveState"] == "active" and s["SubState"] == "running" \
            and answers(c) else None
    return wait_for(up, timeout=timeout, interval=0.2, what="the service running again under a new PID")


def kill_main(c, sig):
    c.run("systemctl", "kill", f"--signal={sig}", "--kill-who=main", SERVICE)


def socket_owner(c):
    return c.run("stat", "-c", "%U:%G %a", API_SOCK, "/run/rs-discoveryd").stdout.split("\n")[:2]


OWNERSHIP = ["rs-discoveryd:rs-discoveryd 660", "rs-discoveryd:rs-discoveryd 755"]


# ---- the scenario ------------------------------------------------------------------

def test_previous_release_installs_and_serves(system):
    c = system
    apt_install(c, "previous", PREVIOUS)
    wait_for(lambda: answers(c), timeout=30, what="the previous release answering on both sockets")
    assert c.run("dpkg-query", "-W", "-f=${Version}", "rs-discoveryd").stdout == nspawn.PREVIOUS_VERSION


def test_upgrade_restarts_keeps_the_conffile_and_refuses_no_request(system):
    c = system
    # The administrator's change to the conffile, not applied yet (the previous
    # release's ExecReload needed /bin/kill, which a minimal system lacks): the
    # restart on upgrade applies it.
    write_config(c, domains=[0, 3], http="127.0.0.1:8035", usb=True, **{"log-level": "info"})
    mine = c.run("cat", "/etc/rs-discoveryd/config.json").stdout
    assert domains(c) == [0]
    old_pid = main_pid(c)

    # A client asking all along, on both sockets, one request at a time.
    c.run("mkdir", "-p", "/run/rsd-load")
    load = c.popen(
        "n=0; while [ ! -e /run/rsd-load/stop ]; do n=$((n+1)); "
        "if [ $((n % 2)) = 0 ]; then a='--unix-socket /run/rs-discoveryd/api.sock http://localhost/healthz'; "
        "else a=http://127.0.0.1:8035/healthz; fi; "
        "code=$(curl -s -o /dev/null -w '%{http_code}' --max-time 30 $a); rc=$?; "
        "echo \"$code $rc\" >> /run/rsd-load/codes; done")
    count = lambda: len(c.run("cat", "/run/rsd-load/codes", check=False).stdout.splitlines())
    try:
        wait_for(lambda: count() >= 10, timeout=30, what="the client's first requests")
        r = apt_install(c, "current", CURRENT)
        assert "Configuration file '/etc/rs-discoveryd/config.json'" not in r.stdout, r.stdout  # no prompt
        new_pid = restart_seen(c, old_pid, timeout=60)
        before = count()
        wait_for(lambda: count() >= before + 10, timeout=30, what="the client's requests after the upgrade")
    finally:
        c.run("touch", "/run/rsd-load/stop")
        load.wait(60)
    results = [line.split() for line in c.run("cat", "/run/rsd-load/codes").stdout.splitlines()]
    # curl's exit status: 7 is a refused connection (no socket listening), 28 a
    # request left without an answer for 30 s. Neither may happen: the sockets stay
    # systemd's and queue what comes while the daemon restarts.
    refused = [r for r in results if r[1] in ("7", "28")]
    assert not refused, f"{len(refused)} of {len(results)} requests refused or unanswered: {refused[:10]}"
    # The daemon stopped here is the previous release's (PREVIOUS_COMMIT), which
    # predates d9f2183: it still cuts about 1 in 500 of the requests it accepted
    # as it stops (curl 52/56, or 18 when the head was out and the body not; seen
    # once in CI). That is the old binary, not this tree: counted and shown here.
    # This tree's stop must cut none: test_restarts_fail_no_request restarts it.
    cut = [r for r in results if r[1] in ("18", "52", "56")]
    wrong = [r for r in results if r not in cut and r != ["200", "0"]]
    assert not wrong, f"{len(wrong)} of {len(results)} requests failed during the upgrade: {wrong[:10]}"
    assert len(cut) <= max(2, len(results) // 50), f"the previous release cut {len(cut)} of {len(results)}: {cut}"
    if cut:
        nspawn.log(f"upgrade: {len(cut)} of {len(results)} requests cut by the previous release's stop: {cut}")

    assert new_pid != old_pid
    version = c.run("dpkg-query", "-W", "-f=${Version}", "rs-discoveryd").stdout
    assert version == nspawn.changelog_version(nspawn.SOURCE_DIR) and version != nspawn.PREVIOUS_VERSION
    assert c.run("cat", "/etc/rs-discoveryd/config.json").stdout == mine  # the conffile is the admin's
    assert domains(c) == [0, 3]  # and the restarted daemon runs it
    # The CLI moved to its own package, taking over the file without a conflict.
    assert c.run("dpkg-query", "-S", "/usr/bin/rs-discover").stdout.startswith("rs-discover:")


def test_restarts_fail_no_request(system):
    # Four clients asking as fast as curl goes, two on each socket, through three
    # `systemctl restart`s: every request is answered, by the old daemon or the
    # new one (issue 24: 1 of 120 failed under a 50 ms poll before).
    c = system
    c.run("mkdir", "-p", "/run/rsd-hard")
    c.run("rm", "-f", "/run/rsd-hard/stop", "/run/rsd-hard/codes")
    loops = []
    for i in range(4):
        target = ("--unix-socket /run/rs-discoveryd/api.sock http://localhost/v1/devices" if i % 2
                  else "http://127.0.0.1:8035/v1/devices")
        loops.append(c.popen(
            f"while [ ! -e /run/rsd-hard/stop ]; do "
            f"code=$(curl -s -o /dev/null -w '%{{http_code}}' --max-time 30 {target}); "
            f"echo \"$code $?\" >> /run/rsd-hard/codes; done"))
    count = lambda: len(c.run("cat", "/run/rsd-hard/codes", check=False).stdout.splitlines())
    try:
        for _ in range(3):
            before = count()
            wait_for(lambda: count() >= before + 100, timeout=60, what="requests answered between restarts")
            old_pid = main_pid(c)
            c.run("systemctl", "restart", SERVICE, timeout=60)
            restart_seen(c, old_pid, timeout=60)
        before = count()
        wait_for(lambda: count() >= before + 100, timeout=60, what="requests after the last restart")
    finally:
        c.run("touch", "/run/rsd-hard/stop")
        for p in loops:
            p.wait(60)
        # Restarts count against StartLimitBurst= (5 a minute) like crashes: the
        # next tests start the service again and must not find the budget spent.
        c.run("systemctl", "reset-failed", SERVICE)
    results = [line.split() for line in c.run("cat", "/run/rsd-hard/codes").stdout.splitlines()]
    wrong = [r for r in results if r != ["200", "0"]]
    nspawn.log(f"restarts: {len(results)} requests through 3 restarts, {len(wrong)} failed")
    assert not wrong, f"{len(wrong)} of {len(results)} requests failed: {wrong[:10]}"


def test_system_user_and_enabled_units(system):
    c = system
    user = c.run("getent", "passwd", "rs-discoveryd").stdout.strip().split(":")
    assert int(user[2]) < 1000 and user[6].endswith("nologin"), user
    for unit in (SERVICE, SOCKET):
        assert c.run("systemctl", "is-enabled", unit).stdout.strip() == "enabled"
        assert c.run("systemctl", "is-active", unit).stdout.strip() == "active"


def test_socket_activation_through_either_socket(system):
    c = system
    for unix in (True, False):
        c.run("systemctl", "stop", SERVICE)
        assert c.run("systemctl", "is-active", SERVICE, check=False).stdout.strip() == "inactive"
        assert c.run("systemctl", "is-active", SOCKET).stdout.strip() == "active"
        assert socket_owner(c) == OWNERSHIP  # the same before the service runs...
        status, body = curl(c, "/v1/devices", unix=unix)  # waits in the socket's queue meanwhile
        assert status == 200, body
        assert json.loads(body)["devices"] == []
        # It answered as soon as it listened; READY=1 follows once its domains are joined.
        wait_for(lambda: c.run("systemctl", "is-active", SERVICE, check=False).stdout.strip() == "active",
                 timeout=30, interval=0.1, what="the activated service ready")
        assert socket_owner(c) == OWNERSHIP  # ...and after


def test_socket_permissions_follow_the_group(system):
    c = system
    gid = c.run("getent", "group", "rs-discoveryd").stdout.split(":")[2]
    nobody = ["--reuid=nobody", "--regid=nogroup", "--clear-groups"]
    member = ["--reuid=nobody", "--regid=nogroup", f"--groups={gid}"]
    assert curl(c, "/healthz", unix=True, user=nobody)[0] is None  # permission denied
    assert curl(c, "/healthz", unix=True, user=member)[0] == 200
    assert curl(c, "/healthz", unix=False, user=nobody)[0] == 200  # loopback HTTP is for everyone
    r = c.run("setpriv", *nobody, "rs-discover", "health", check=False)
    assert r.returncode == 3 and API_SOCK in r.stderr, (r.returncode, r.stdout, r.stderr)  # says why


def test_python_client_from_its_package(system):
    c = system
    r = c.run("python3", "-c", "import rsdiscovery, json; print(json.dumps(rsdiscovery.health().raw))")
    assert json.loads(r.stdout)["status"] == "ok", r.stdout


# On trixie this caught cpp-httplib 0.18's client asking for compressed replies
# the CLI could not read; the client now asks for identity.
def test_cli_from_its_package(system):
    c = system
    gid = c.run("getent", "group", "rs-discoveryd").stdout.split(":")[2]
    member = ["--reuid=nobody", "--regid=nogroup", f"--groups={gid}"]
    r = c.run("setpriv", *member, "rs-discover", "list")  # a member of the group, over the socket
    assert r.stdout.split("\n")[0].split()[:4] == ["NAME", "SERIAL", "SOURCE", "DOMAIN/PORT"], r.stdout
    r = c.run("rs-discover", "--endpoint", "http://127.0.0.1:8035", "domains")  # anyone, over HTTP
    assert "0" in r.stdout and "3" in r.stdout, r.stdout


def test_status_names_what_is_watched(system):
    c = system
    usb = json.loads(curl(c, "/healthz", check=True)[1])["usb"]["state"]
    text = status_text(c)
    # No USB in a container: STATUS= names USB only when it is watched.
    expected = "0 devices on DDS domains 0,3" + (" and USB" if usb in ("hotplug", "polling") else "")
    assert text == expected, (text, usb)


def test_follows_the_network_it_runs_on(system):
    # Issue 21 on this suite's own Cyclone DDS (bookworm 0.10.2, trixie 0.10.5), under
    # the unit's sandbox: an interface appears with an address (a lease), then the
    # address goes (renumbered, unplugged): each domain is joined anew on it and
    # again without it. Deleting a domain whose address had gone once hung for ever
    # in Cyclone's receive threads. The container's network namespace is entered
    # from here: the minimal system has no iproute2.
    c = system
    ip = ["nsenter", "-t", str(c.pid1), "-n", "ip"]

    def joined():
        entries = json.loads(curl(c, "/v1/domains", check=True)[1])["domains"]
        if any(e["state"] != "running" for e in entries):
            return None
        return [sorted(i["name"] for i in e["interfaces"]) for e in entries]

    before = wait_for(joined, timeout=30, what="every domain running")
    # A veth pair, both ends up (carrier): this kernel has no dummy interfaces.
    subprocess.run(ip + ["link", "add", "rsdn0", "type", "veth", "peer", "name", "rsdn1"], check=True)
    try:
        subprocess.run(ip + ["link", "set", "rsdn1", "up"], check=True)
        subprocess.run(ip + ["link", "set", "rsdn0", "multicast", "on", "up"], check=True)
        subprocess.run(ip + ["addr", "add", "10.99.0.1/24", "dev", "rsdn0"], check=True)
        wait_for(lambda: (j := joined()) and all("rsdn0" in names for names in j), timeout=30,
                 what="every domain joined on the new interface")
        subprocess.run(ip + ["addr", "del", "10.99.0.1/24", "dev", "rsdn0"], check=True)
        wait_for(lambda: joined() == before, timeout=30, what="every domain joined anew without it")
    finally:
        subprocess.run(ip + ["link", "del", "rsdn0"], check=False)
    entries = json.loads(curl(c, "/v1/domains", check=True)[1])["domains"]
    assert all(e["network-changes"] >= 2 for e in entries), entries
    assert c.run("systemctl", "is-active", SERVICE).stdout.strip() == "active"


def test_reload_adds_a_domain_survives_an_invalid_file_and_goes_back(system):
    c = system
    pid = main_pid(c)
    write_config(c, domains=[0, 3, 9])
    c.run("systemctl", "reload", SERVICE)
    wait_for(lambda: domains(c) == [0, 3, 9], timeout=30, what="domain 9 joined")
    wait_for(lambda: status_text(c).startswith("0 devices on DDS domains 0,3,9"), timeout=10, what="STATUS=")

    c.run("sh", "-c", "echo '{\"domains\": [0,' > /etc/rs-discoveryd/config.json")
    # ExecReload checks the file first: `systemctl reload` fails, the error at its
    # line and column in the journal, and the daemon is never signalled.
    r = c.run("systemctl", "reload", SERVICE, check=False)
    assert r.returncode != 0, (r.stdout, r.stderr)
    wait_for(lambda: any("/etc/rs-discoveryd/config.json:2:1" in m for _, m in journal(c)), timeout=10,
             what="the reload's error, with its line and column, in the journal")
    assert domains(c) == [0, 3, 9]  # still the running configuration
    # A SIGHUP that bypasses the check (kill -HUP, an older unit) is refused by the
    # daemon itself, which keeps running what it had and says so in STATUS=.
    c.run("systemctl", "kill", "--kill-who=main", "--signal=HUP", SERVICE)
    wait_for(lambda: "reload failed" in status_text(c), timeout=10, what="STATUS= saying the reload failed")
    assert domains(c) == [0, 3, 9]
    assert c.run("systemctl", "is-active", SERVICE).stdout.strip() == "active"

    write_config(c, domains=[0])
    c.run("systemctl", "reload", SERVICE)
    wait_for(lambda: domains(c) == [0], timeout=30, what="back to domain 0 alone")
    wait_for(lambda: status_text(c).startswith("0 devices on DDS domain 0")
             and "reload" not in status_text(c), timeout=10, what="STATUS= without the failure")
    assert main_pid(c) == pid  # reloads, never restarts


ROBOT_UNIT = """[Unit]
Wants=rs-discoveryd.service
After=rs-discoveryd.service
[Service]
Type=oneshot
RemainAfterExit=yes
ExecStartPre=/usr/bin/rs-discover wait --expected --timeout 3
ExecStart=/bin/true
"""


def test_a_robot_program_starts_only_with_its_expected_cameras(system):
    # docs/robots.md's ExecStartPre=: with a camera expected that is not there the
    # program's unit fails to start, its journal naming the camera; once the list is
    # empty (nothing left to wait for) it starts. STATUS= counts the expected ones.
    c = system
    c.run("sh", "-ec", "cat > /etc/systemd/system/rsd-robot-test.service", input=ROBOT_UNIT)
    c.run("systemctl", "daemon-reload")
    write_config(c, domains=[0], expect=["arm=5550000099"])
    c.run("systemctl", "reload", SERVICE)
    wait_for(lambda: "0 of 1 expected camera (missing: arm (5550000099))" in status_text(c), timeout=10,
             what="STATUS= with the missing camera")
    r = c.run("systemctl", "start", "rsd-robot-test.service", check=False, timeout=60)
    assert r.returncode != 0, (r.stdout, r.stderr)
    log = c.run("journalctl", "-b", "-u", "rsd-robot-test.service", "--no-pager", "-o", "cat").stdout
    assert "arm (5550000099): never listed since the daemon started" in log, log
    write_config(c, domains=[0])
    c.run("systemctl", "reload", SERVICE)
    wait_for(lambda: "expected" not in status_text(c), timeout=10, what="STATUS= without expected cameras")
    c.run("systemctl", "start", "rsd-robot-test.service", timeout=60)
    assert c.run("systemctl", "is-active", "rsd-robot-test.service").stdout.strip() == "active"
    c.run("systemctl", "stop", "rsd-robot-test.service")
    c.run("rm", "/etc/systemd/system/rsd-robot-test.service")
    c.run("systemctl", "daemon-reload")


def test_journal_keeps_the_priorities(system):
    c = system
    lines = journal(c)
    assert not [m for _, m in lines if re.match(r"<\d>", m)], "priority prefixes left in the messages"
    failed = [p for p, m in lines if m.startswith("reload failed")]
    assert failed and all(p == 3 for p in failed), failed  # error
    ready = [p for p, m in lines if m.startswith("ready:") or m.startswith("reloaded:")]
    assert ready and all(p == 5 for p in ready), ready
    warnings = [m for _, m in journal(c, "-p", "warning")]
    assert any(m.startswith("reload failed") for m in warnings) and not any(m.startswith("ready:") for m in warnings)


def test_hardening_as_systemd_sees_it_live(system):
    c = system
    r = c.run("systemd-analyze", "security", "--no-pager", SERVICE, check=False)
    m = re.search(r"Overall exposure level for rs-discoveryd.service: (\d+\.\d+)", r.stdout)
    assert m and float(m.group(1)) <= 1.5, r.stdout[-3000:]
    # Whatever it did so far, no system call was refused with a signal.
    assert not [m for _, m in journal(c) if "SYS" in m and "status=" in m]


def test_watchdog_restarts_a_hung_daemon(system):
    c = system
    pid = main_pid(c)
    restarts = int(show(c, SERVICE, "NRestarts")["NRestarts"])
    kill_main(c, "SIGSTOP")
    restart_seen(c, pid, timeout=80)  # WatchdogSec=20s, RestartSec=2s, then the start
    assert any("Watchdog timeout" in m for _, m in journal(c))
    assert int(show(c, SERVICE, "NRestarts")["NRestarts"]) == restarts + 1


def test_a_crash_is_restarted(system):
    c = system
    pid = main_pid(c)
    restarts = int(show(c, SERVICE, "NRestarts")["NRestarts"])
    kill_main(c, "SIGSEGV")
    restart_seen(c, pid, timeout=30)
    assert int(show(c, SERVICE, "NRestarts")["NRestarts"]) == restarts + 1


def test_a_crash_loop_is_stopped_by_the_start_limit(system):
    c = system
    c.run("systemctl", "reset-failed", SERVICE)  # the start counter from the tests before
    limit = show(c, SERVICE, "StartLimitBurst", "StartLimitIntervalUSec")
    assert int(limit["StartLimitBurst"]) > 1
    pid = main_pid(c)
    for _ in range(int(limit["StartLimitBurst"]) + 2):
        kill_main(c, "SIGSEGV")

        def next_state():
            s = show(c, SERVICE, "MainPID", "ActiveState", "SubState", "Result")
            if s["ActiveState"] == "failed":
                return s
            p = int(s["MainPID"])
            return s if p not in (0, pid) and s["SubState"] == "running" else None
        s = wait_for(next_state, timeout=30, interval=0.1, what="a restart or the start limit")
        if s["ActiveState"] == "failed":
            break
        pid = int(s["MainPID"])
    assert s["ActiveState"] == "failed", s
    assert any("Start request repeated too quickly" in m for _, m in journal(c))
    # Its sockets give up with it: clients are refused, not left waiting.
    wait_for(lambda: show(c, SOCKET, "Result")["Result"] == "service-start-limit-hit", timeout=10,
             what="the socket failed with the service's start limit")
    assert curl(c, "/healthz")[0] is None
    # The administrator's way back.
    c.run("systemctl", "reset-failed", SERVICE, SOCKET)
    c.run("systemctl", "start", SOCKET, SERVICE)
    wait_for(lambda: answers(c), timeout=30, what="the service back after reset-failed")


def test_boot_with_the_packages_installed(system):
    c = system
    c.poweroff()
    nspawn.log(f"reboot: {c.boot():.1f} s")
    for unit in (SERVICE, SOCKET):
        assert c.run("systemctl", "is-enabled", unit).stdout.strip() == "enabled"
    wait_for(lambda: answers(c), timeout=30, what="the API after boot")
    sock = int(show(c, SOCKET, "ActiveEnterTimestampMonotonic")["ActiveEnterTimestampMonotonic"])
    svc = int(show(c, SERVICE, "ExecMainStartTimestampMonotonic")["ExecMainStartTimestampMonotonic"])
    assert 0 < sock <= svc, (sock, svc)  # the socket listens before the daemon starts
    assert socket_owner(c) == OWNERSHIP
    assert status_text(c) == "0 devices on DDS domain 0"


def test_remove_keeps_the_cli_then_purge_leaves_nothing(system):
    c = system
    c.run("apt-get", "remove", "-y", "rs-discoveryd", timeout=300)
    for p in ("rs-discover", "librsdiscovery1", "python3-rsdiscovery"):  # installable without the daemon
        assert c.run("dpkg-query", "-W", "-f=${db:Status-Status}", p).stdout == "installed", p
    assert c.run("systemctl", "is-active", SERVICE, SOCKET, check=False).stdout.split() == ["inactive", "inactive"]
    r = c.run("rs-discover", "--endpoint", "http://127.0.0.1:8035", "list", check=False)
    assert r.returncode == 3, (r.returncode, r.stdout, r.stderr)  # daemon unreachable, said so
    r = c.run("python3", "-c", "import rsdiscovery\ntry:\n rsdiscovery.health()\nexcept rsdiscovery.DaemonNotRunning:"
              "\n print('not running')", check=False)
    assert r.stdout.strip() == "not running", (r.stdout, r.stderr)
    assert c.run("test", "-e", "/etc/rs-discoveryd/config.json", check=False).returncode == 0  # conffile until purge

    c.run("apt-get", "purge", "-y", "rs-discoveryd", timeout=300)
    assert c.run("test", "-e", "/etc/rs-discoveryd", check=False).returncode != 0
    left = c.run("sh", "-c", "find /etc/systemd /lib/systemd/system /usr/lib/systemd/system "
                 "/var/lib/systemd/deb-systemd-helper-enabled -name '*rs-discoveryd*' 2>/dev/null; true").stdout
    assert left.strip() == "", left
    assert c.run("systemctl", "list-unit-files", "rs-discoveryd*", "--no-legend", check=False).stdout.strip() == ""
