"""The unit files as systemd reads them: `systemd-analyze verify`, the offline
security score (target: exposure <= 1.5), the sysusers entry, the default config,
the exit status that is not restarted, and the reload commands run in order as
systemd runs them."""
import os
import re
import shlex
import subprocess

from conftest import DAEMON, free_port
from svc_util import SOURCE_DIR, notify_socket, write_config  # noqa: F401  (fixture)

UNITS = os.path.join(SOURCE_DIR, "systemd")
MAX_EXPOSURE = 1.5


def analyze(*args, cwd=None):
    return subprocess.run(["systemd-analyze", "--no-pager", *args], capture_output=True, text=True, cwd=cwd,
                          timeout=60)


def copy_units(tmp_path):
    """The units with ExecStart pointing at the built daemon (/usr/sbin has none yet)."""
    for name in ("rs-discoveryd.service", "rs-discoveryd.socket"):
        text = open(os.path.join(UNITS, name)).read().replace("/usr/sbin/rs-discoveryd", DAEMON)
        (tmp_path / name).write_text(text)
    return [str(tmp_path / "rs-discoveryd.service"), str(tmp_path / "rs-discoveryd.socket")]


def test_units_verify(tmp_path):
    r = analyze("verify", "--man=no", *copy_units(tmp_path))
    assert r.returncode == 0, r.stdout + r.stderr
    assert r.stderr.strip() == "", r.stderr  # not even a warning


def test_security_exposure_is_at_most_1_5(tmp_path):
    r = analyze("security", "--offline=true", os.path.join(UNITS, "rs-discoveryd.service"))
    m = re.search(r"Overall exposure level for rs-discoveryd.service: (\d+\.\d+)", r.stdout)
    assert m, r.stdout + r.stderr
    assert float(m.group(1)) <= MAX_EXPOSURE, r.stdout
    # Also as systemd itself gates it.
    r = analyze("security", "--offline=true", f"--threshold={int(MAX_EXPOSURE * 10)}",
                os.path.join(UNITS, "rs-discoveryd.service"))
    assert r.returncode == 0, r.stdout[-2000:]


def test_service_contract_settings():
    text = open(os.path.join(UNITS, "rs-discoveryd.service")).read()
    for line in ("Type=notify", "NotifyAccess=main", "ExecReload=/bin/sh -c 'kill -HUP $$MAINPID'", "User=rs-discoveryd",
                 "RuntimeDirectory=rs-discoveryd", "RuntimeDirectoryPreserve=yes", "Requires=rs-discoveryd.socket",
                 "RestrictAddressFamilies=AF_UNIX AF_INET AF_INET6 AF_NETLINK", "CapabilityBoundingSet=\n"):
        assert line in text, line
    assert re.search(r"^WatchdogSec=\d+", text, re.M)
    sock = open(os.path.join(UNITS, "rs-discoveryd.socket")).read()
    assert "ListenStream=/run/rs-discoveryd/api.sock" in sock
    assert "ListenStream=127.0.0.1:8035" in sock


def unit_commands(key, daemon):
    """The service's KEY= command lines, in order, as systemd runs them: `$$` is a
    `$` to the shell, and /usr/sbin/rs-discoveryd is `daemon` (the built binary and
    the test's flags, as a drop-in would give ExecStart=)."""
    lines = [l.split("=", 1)[1] for l in open(os.path.join(UNITS, "rs-discoveryd.service")).read().splitlines()
             if l.startswith(key + "=")]
    return [shlex.split(l.replace("$$", "$").replace("/usr/sbin/rs-discoveryd", daemon)) for l in lines]


def test_a_configuration_the_daemon_cannot_use_is_not_restarted(tmp_path):
    """A restart loop cannot fix a bad configuration: the unit's RestartPreventExitStatus=
    is the status the daemon exits with for one (a bad file, a bad flag), and only that
    (a domain or a port it could not take exits 1, and a later start may succeed)."""
    prevented = [s for line in unit_commands("RestartPreventExitStatus", DAEMON) for s in line]
    assert prevented, "the unit has no RestartPreventExitStatus="
    bad = tmp_path / "config.json"
    bad.write_text('{"domains": [0,\n')
    exits = set()
    for args in (["--config", str(bad)], ["--domain", "999"], ["--no-such-flag"]):
        # A socket and HTTP of its own, should it start after all (then the timeout fails the test).
        r = subprocess.run([DAEMON, "--socket", str(tmp_path / "api.sock"), "--http", "off", *args],
                           capture_output=True, text=True, timeout=30)
        assert "rs-discoveryd: " in r.stderr, (args, r.stderr)
        exits.add(r.returncode)
    assert sorted(str(e) for e in exits) == prevented


def systemctl_reload(daemon, pid):
    """What `systemctl reload` does: each ExecReload= in turn, with $MAINPID, until one
    fails; its status is the reload's."""
    for cmd in unit_commands("ExecReload", daemon):
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=30, env=dict(os.environ, MAINPID=str(pid)))
        if r.returncode != 0:
            return r
    return r


def test_reload_refuses_an_invalid_file_with_its_line_and_column(tmp_path, daemon, domains, notify_socket):
    a, b = domains.take(60, 79), domains.take(60, 79)
    config = tmp_path / "config.json"
    write_config(config, domains=[a], usb=False)
    d = daemon([], extra=["--config", str(config)], env=notify_socket.env())
    flags = f"{DAEMON} --config {config}"
    notify_socket.drain()

    config.write_text('{\n  "domains": [1, 999]\n}\n')
    r = systemctl_reload(flags, d.proc.pid)
    assert r.returncode == 1, r
    assert f"{config}:2:3: " in r.stderr and "0 to 232" in r.stderr, r.stderr
    # No SIGHUP was sent: the daemon never began a reload (and kept its domain).
    assert notify_socket.seen_within(lambda m: m.get("RELOADING") == "1", 2) is None
    assert "reload failed" not in d.log()
    assert [x["domain"] for x in d.get_json("/v1/domains")["domains"]] == [a]

    write_config(config, domains=[a, b], usb=False)
    r = systemctl_reload(flags, d.proc.pid)
    assert r.returncode == 0, r
    notify_socket.wait(lambda m: m.get("RELOADING") == "1", what="RELOADING=1")
    notify_socket.wait(lambda m: m.get("READY") == "1", what="READY=1 after the reload")
    assert sorted(x["domain"] for x in d.get_json("/v1/domains")["domains"]) == sorted([a, b])


def test_sysusers_makes_the_system_user(tmp_path):
    root = tmp_path / "root"
    (root / "etc").mkdir(parents=True)
    r = subprocess.run(["systemd-sysusers", f"--root={root}", os.path.join(UNITS, "rs-discoveryd.sysusers")],
                       capture_output=True, text=True, timeout=30)
    assert r.returncode == 0, r.stderr
    passwd = (root / "etc" / "passwd").read_text()
    entry = next(l for l in passwd.splitlines() if l.startswith("rs-discoveryd:"))
    uid, shell = int(entry.split(":")[2]), entry.split(":")[6]
    assert uid < 1000 and shell.endswith("nologin"), entry
    assert "rs-discoveryd:" in (root / "etc" / "group").read_text()


def test_default_config_is_accepted(tmp_path, free_domain):
    # The shipped file, with the listeners and domain moved out of the way.
    p = subprocess.Popen([DAEMON, "--config", os.path.join(UNITS, "config.json"), "--domain", str(free_domain),
                          "--socket", str(tmp_path / "s.sock"), "--http", f"127.0.0.1:{free_port()}", "--no-usb"],
                         stderr=subprocess.PIPE, text=True)
    try:
        line = p.stderr.readline()
        while line and "serving" not in line:
            line = p.stderr.readline()
        assert "serving" in line, line
    finally:
        p.terminate()
        p.communicate(timeout=10)
    assert p.returncode == 0
