"""The daemon as a process: command line, configuration errors, logs, signals."""
import grp
import json
import os
import re
import shutil
import signal
import subprocess
import tempfile
import time

import pytest

from conftest import DAEMON, EventStream, device_info, free_port, wait_for


def run(*args, timeout=20):
    return subprocess.run([DAEMON, *args], capture_output=True, text=True, timeout=timeout)


def test_help_and_version():
    r = run("--help")
    assert r.returncode == 0
    for flag in ("--config", "--domain", "--socket", "--http", "--no-usb", "--participant-name",
                 "--log-level", "--cyclonedds-config", "--version"):
        assert flag in r.stdout
    r = run("--version")
    assert r.returncode == 0 and re.match(r"rs-discoveryd \d+\.\d+\.\d+", r.stdout)


@pytest.mark.parametrize("args, message", [
    (["--domain", "233"], "0 to 232"),
    (["--domain", "five"], "0 to 232"),
    (["--http", "nowhere"], "HOST:PORT"),
    (["--log-level", "chatty"], "log level"),
    (["--bogus"], "unknown argument '--bogus'"),
    (["--config", "/nonexistent/rs-discoveryd.json"], "cannot read config file /nonexistent/rs-discoveryd.json"),
    (["--socket", "off", "--http", "off"], "both the Unix socket and HTTP are off"),
    (["--socket-group", "rsd-no-such-group"], "no group 'rsd-no-such-group' on this host"),
])
def test_bad_usage_is_exit_2_with_a_clear_message(args, message):
    r = run(*args)
    assert r.returncode == 2
    assert message in r.stderr and r.stderr.startswith("rs-discoveryd: ")


@pytest.mark.parametrize("text, message", [
    ("{not json", "not valid JSON"),
    ('{"domains": [1, 500]}', "0 to 232"),
    ('{"domian": [1]}', ':1:2: unknown key "domian"; did you mean "domains"?'),
    ('{\n  "usb": true,\n  "sockte": "off"\n}', ':3:3: unknown key "sockte"; did you mean "socket"?'),
    ('{"usb": "yes"}', '"usb" must be true or false'),
])
def test_bad_config_file_is_exit_2_naming_the_file(tmp_path, text, message):
    path = tmp_path / "config.json"
    path.write_text(text)
    r = run("--config", str(path))
    assert r.returncode == 2
    assert str(path) in r.stderr and message in r.stderr


def test_config_file_settings_apply_and_flags_win(free_domain, domains, daemon, tmp_path):
    other = domains.take()
    path = tmp_path / "config.json"
    path.write_text(json.dumps({"domains": [other], "participant-name": "from-file", "usb": False}))
    d = daemon([free_domain], extra=["--config", str(path)])  # --domain wins over the file's
    assert [s["domain"] for s in d.get_json("/v1/domains")["domains"]] == [free_domain]


def test_logs_to_a_file_read_with_time_and_level_words(free_domain, daemon):
    # What `docker logs` or a redirect shows: readable lines, no "<N>" (journal only).
    d = daemon([free_domain])
    d.stop()
    lines = [l for l in d.log().splitlines() if l]
    stamp = r"\d{4}-\d\d-\d\d \d\d:\d\d:\d\d\.\d{3} (error|warning|notice|info|debug): "
    assert lines and all(re.match(stamp, l) for l in lines), lines[:5]
    assert any(re.match(stamp + "rs-discoveryd .* serving", l) for l in lines), lines[:5]


def test_the_ready_line_counts_the_cameras_already_serving(free_domain, daemon, realdds_server):
    # A camera serving before the daemon starts arrives after the daemon reads its domain:
    # the log gives a count only once the first discovery is over, and then the right one.
    realdds_server(free_domain, [device_info(1)])
    d = daemon([free_domain])
    wait_for(lambda: "notice: ready: " in d.log(), 20, what="the ready line")
    lines = d.log().splitlines()
    assert any(f"notice: listening; discovery in progress on DDS domain {free_domain}" in l for l in lines), lines
    ready = [l for l in lines if "notice: ready: " in l]
    assert len(ready) == 1 and re.search(rf"ready: 1 device on DDS domain {free_domain}( and USB)?$", ready[0]), lines
    assert d.get_json("/healthz")["complete"] is True


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_signal_stops_within_a_second_closing_streams_and_socket(free_domain, daemon, realdds_server, sig):
    realdds_server(free_domain, [device_info(1)])
    d = daemon([free_domain])
    wait_for(lambda: len(d.devices()) == 1, what="device listed")
    stream = EventStream(d)
    assert os.path.exists(d.socket)
    t = time.monotonic()
    d.signal(sig)
    assert d.proc.wait(timeout=5) == 0
    elapsed = time.monotonic() - t
    assert elapsed < 1.0, f"took {elapsed:.2f}s to stop"
    stream.thread.join(timeout=2)
    assert not stream.thread.is_alive(), "event stream left open"
    assert not os.path.exists(d.socket)


def test_second_daemon_on_a_live_socket_is_refused(free_domain, daemon):
    first = daemon([free_domain])
    r = run("--domain", str(free_domain), "--socket", first.socket, "--http", f"127.0.0.1:{free_port()}",
            "--no-usb")
    assert r.returncode == 1
    assert first.socket in r.stderr
    assert first.healthy(), "the first daemon must keep its socket"


def test_stale_socket_from_a_crash_is_replaced(free_domain, daemon):
    first = daemon([free_domain])
    first.signal(signal.SIGKILL)
    first.proc.wait()
    assert os.path.exists(first.socket)  # left behind, as after a crash
    second = daemon([free_domain], socket=first.socket)
    assert second.healthy()
    assert oct(os.stat(first.socket).st_mode & 0o777) == "0o660"


def test_socket_group_grants_its_members_the_socket(free_domain, daemon):
    # The group a user joins for the socket, instead of the daemon's own (root's, when
    # it runs by hand): Debian's nogroup, which grants nothing else. In a directory
    # anybody may pass through, as /run/rs-discoveryd is.
    run_dir = tempfile.mkdtemp(prefix="rsd-group-")
    os.chmod(run_dir, 0o755)
    try:
        d = daemon([free_domain], socket=os.path.join(run_dir, "api.sock"), extra=["--socket-group", "nogroup"])
        st = os.stat(d.socket)
        assert st.st_gid == grp.getgrnam("nogroup").gr_gid and oct(st.st_mode & 0o777) == "0o660"

        def healthz_as_nobody(groups):  # uid nobody, primary group daemon, and `groups`
            return subprocess.run(["setpriv", "--reuid=nobody", "--regid=daemon", f"--groups={groups}", "curl", "-s",
                                   "-o", "/dev/null", "-w", "%{http_code}", "--unix-socket", d.socket,
                                   "http://localhost/healthz"], capture_output=True, text=True, timeout=30)

        assert healthz_as_nobody("nogroup").stdout == "200"
        r = healthz_as_nobody("daemon")
        assert r.stdout != "200" and r.returncode != 0, "a user outside the group must not reach the socket"
    finally:
        shutil.rmtree(run_dir, ignore_errors=True)


def test_default_socket_directory_is_made(free_domain, daemon, tmp_path):
    runtime = tmp_path / "runtime"
    runtime.mkdir()
    d = daemon([free_domain], socket=str(runtime / "rs-discoveryd" / "api.sock"))
    assert d.healthy()
