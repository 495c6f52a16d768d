"""The Debian package end to end: build it with the documented command, lintian
(no errors), install it with dpkg, run the installed daemon from its installed
paths with the installed config (as its unit would: its user, RUNTIME_DIRECTORY,
a notify socket; there is no systemd PID 1 here), ask it with the installed CLI,
then remove and purge and check nothing is left behind."""
import json
import os
import pwd
import shutil
import subprocess
import tempfile

import pytest

from conftest import device_info, free_port, wait_for

SOURCE_DIR = os.environ.get("RSD_SOURCE_DIR", os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..")))
PACKAGES = ["rs-discoveryd", "rs-discover", "librsdiscovery1", "librsdiscovery-dev", "python3-rsdiscovery"]

pytestmark = pytest.mark.skipif(os.geteuid() != 0, reason="installs packages: needs root")


def sh(*cmd, check=True, timeout=600, **kw):
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, **kw)
    if check:
        assert r.returncode == 0, f"{' '.join(cmd)}: {r.returncode}\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}"
    return r


def installed(pkg):
    r = sh("dpkg-query", "-W", "-f=${db:Status-Status}", pkg, check=False)
    return r.returncode == 0 and r.stdout not in ("", "not-installed")


@pytest.fixture(scope="module")
def debs(tmp_path_factory):
    for p in PACKAGES:
        assert not installed(p), f"{p} is already installed here; the test would disturb it"
    # Built once for the suite by the packaging_build test (RSD_DEBS_DIR), or here.
    given = os.environ.get("RSD_DEBS_DIR")
    if given and any(f.endswith(".deb") for f in os.listdir(given) if os.path.isdir(given)):
        import pathlib
        out = pathlib.Path(given)
    else:
        out = tmp_path_factory.mktemp("debs")
        sh(os.path.join(SOURCE_DIR, "packaging", "build-deb"), str(out), timeout=2000)
    files = {f.split("_")[0]: str(out / f) for f in os.listdir(out) if f.endswith(".deb")}
    for p in PACKAGES:
        assert p in files, (p, sorted(files))
    yield out, files
    for p in PACKAGES:  # whatever happened, leave the machine as it was
        if installed(p):
            sh("dpkg", "--purge", p, check=False)


def test_lintian_has_no_errors(debs):
    out, _ = debs
    changes = next(str(out / f) for f in os.listdir(out) if f.endswith(".changes"))
    r = sh("lintian", "--fail-on", "error", changes, check=False)
    assert r.returncode == 0, r.stdout + r.stderr
    assert not [l for l in r.stdout.splitlines() if l.startswith("E:")], r.stdout


def test_install_run_query_remove_purge(debs, domains, realdds_server, tmp_path):
    _, files = debs
    sh("dpkg", "-i", *(files[p] for p in PACKAGES))
    owned = {p: sh("dpkg", "-L", p).stdout.split() for p in PACKAGES}
    try:
        # What the package put where.
        for path in ("/usr/sbin/rs-discoveryd", "/usr/bin/rs-discover", "/lib/systemd/system/rs-discoveryd.service",
                     "/lib/systemd/system/rs-discoveryd.socket", "/usr/lib/sysusers.d/rs-discoveryd.conf",
                     "/usr/share/man/man8/rs-discoveryd.8.gz", "/usr/share/man/man1/rs-discover.1.gz",
                     "/usr/share/doc/rs-discoveryd/copyright", "/usr/include/rsdiscovery/rsdiscovery.hpp",
                     "/usr/lib/tmpfiles.d/rs-discoveryd.conf", "/usr/share/doc/librsdiscovery-dev/examples/list_cameras.cpp",
                     "/usr/share/doc/python3-rsdiscovery/examples/open_camera.py"):
            assert os.path.exists(path), path
        conffiles = sh("dpkg-query", "-W", "-f=${Conffiles}", "rs-discoveryd").stdout
        assert "/etc/rs-discoveryd/config.json" in conffiles
        assert any(p.endswith("librsdiscovery.so.1") for p in owned["librsdiscovery1"])
        # postinst: the system user exists, the units are enabled (no PID 1 to start them).
        user = pwd.getpwnam("rs-discoveryd")
        assert user.pw_uid < 1000 and user.pw_shell.endswith("nologin")
        assert os.path.islink("/etc/systemd/system/multi-user.target.wants/rs-discoveryd.service")
        assert os.path.islink("/etc/systemd/system/sockets.target.wants/rs-discoveryd.socket")
        sh("systemd-analyze", "verify", "--man=no", "/lib/systemd/system/rs-discoveryd.service",
           "/lib/systemd/system/rs-discoveryd.socket")
        check_installed_daemon(user, domains, realdds_server, tmp_path)

        sh("dpkg", "--remove", *PACKAGES)
        assert not os.path.exists("/usr/sbin/rs-discoveryd")
        assert os.path.exists("/etc/rs-discoveryd/config.json")  # a conffile stays until purge
        sh("dpkg", "--purge", *PACKAGES)
    finally:
        for p in PACKAGES:
            if installed(p):
                sh("dpkg", "--purge", p, check=False)

    for p in PACKAGES:
        assert not installed(p), p
    left = [f for files_ in owned.values() for f in files_
            if os.path.lexists(f) and not os.path.isdir(f)]
    assert not left, left
    assert not os.path.exists("/etc/rs-discoveryd")
    assert not [f for d in ("/etc/systemd/system", "/etc/systemd/system/multi-user.target.wants",
                            "/etc/systemd/system/sockets.target.wants") if os.path.isdir(d)
                for f in os.listdir(d) if "rs-discoveryd" in f]
    assert not [f for f in os.listdir("/var/lib/systemd/deb-systemd-helper-enabled") if "rs-discoveryd" in f] \
        if os.path.isdir("/var/lib/systemd/deb-systemd-helper-enabled") else True
    # The system user stays, as Debian policy has it (files may still carry its uid).


def check_installed_daemon(user, domains, realdds_server, tmp_path):
    """/usr/sbin/rs-discoveryd as the unit starts it: as rs-discoveryd, with
    RUNTIME_DIRECTORY, a NOTIFY_SOCKET, and the installed /etc/rs-discoveryd/config.json
    (read from its default path). Two settings are moved out of the way of other
    tests and daemons on this machine with flags, which win over the file: the DDS
    domain and the HTTP port."""
    domain = domains.take(60, 79)
    port = free_port()
    runtime = tempfile.mkdtemp(prefix="rsd-pkg-run-")  # /run/rs-discoveryd may be someone else's
    os.chmod(runtime, 0o755)
    os.chown(runtime, user.pw_uid, user.pw_gid)
    notify_path = os.path.join(runtime, "notify.sock")
    import socket as socket_mod
    notify = socket_mod.socket(socket_mod.AF_UNIX, socket_mod.SOCK_DGRAM)
    notify.bind(notify_path)
    os.chmod(notify_path, 0o666)
    notify.settimeout(20)
    env = {"PATH": "/usr/sbin:/usr/bin:/sbin:/bin", "RUNTIME_DIRECTORY": runtime, "NOTIFY_SOCKET": notify_path}
    log = open(tmp_path / "installed-daemon.log", "wb")
    daemon = subprocess.Popen(["setpriv", f"--reuid={user.pw_uid}", f"--regid={user.pw_gid}", "--init-groups",
                               "/usr/sbin/rs-discoveryd", "--domain", str(domain), "--http", f"127.0.0.1:{port}"],
                              env=env, stdout=log, stderr=subprocess.STDOUT)
    try:
        while True:
            msg = notify.recv(4096).decode()  # times out (fails) after 20 s
            if "READY=1" in msg:
                break
        # usb: true, from the installed config; STATUS= names USB when it is watched here.
        assert f"on DDS domain {domain}" in msg, msg
        if not os.path.isdir("/dev/bus/usb"):
            assert "USB" not in msg, msg
        api_sock = os.path.join(runtime, "api.sock")
        assert oct(os.stat(api_sock).st_mode & 0o777) == "0o660"
        assert os.stat(api_sock).st_uid == user.pw_uid
        realdds_server(domain, [device_info(7)])
        cli_env = dict(env, RUNTIME_DIRECTORY=runtime)  # the CLI finds the socket the same way
        wait_for(lambda: "123622270707" in sh("/usr/bin/rs-discover", "list", env=cli_env, check=False).stdout,
                 timeout=20, what="the installed CLI listing the device")
        r = sh("/usr/bin/rs-discover", "--endpoint", f"http://127.0.0.1:{port}", "domains", env=cli_env)
        assert str(domain) in r.stdout
        sh("/usr/bin/rs-discover", "health", env=cli_env)
        daemon.terminate()
        assert daemon.wait(10) == 0
    finally:
        if daemon.poll() is None:
            daemon.kill()
            daemon.wait()
        log.close()
        notify.close()
        shutil.rmtree(runtime, ignore_errors=True)
