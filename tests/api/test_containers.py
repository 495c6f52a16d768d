"""The README's container recipes (issue 23), with Linux namespaces standing in for a
container engine (Docker and Podman make the same ones):

- a client in a container (its own mount and network namespaces, as `nobody`) reads
  the host's daemon through the runtime directory bind-mounted at
  /run/rs-discoveryd, with the socket's group added; it finds the socket there by
  itself, and keeps finding it across a daemon restart, which a bind-mounted socket
  *file* does not (the restart makes a new socket file: the mount still shows the old);
- rootless: the same from a user namespace made by an unprivileged user, who keeps
  the socket's group (Podman's --group-add keep-groups);
- over HTTP from a bridge network: the daemon listening on the bridge's address, the
  container asking by the name host.docker.internal: curl (which sends that name as
  Host) is answered once the name is in allowed-hosts (421 Misdirected Request
  before); rs-discover, which always sends Host: localhost, either way;
- the daemon's own recipe: host network, an engine's minimal /dev and /run, USB
  bus and udev's directory passed in or not.
"""
import grp
import json
import os
import shutil
import subprocess
import sys
import tempfile

import pytest
from conftest import device_info, wait_for

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "interop"))
from netns import _run  # noqa: E402

CLI = os.path.join(os.environ.get("RSD_BUILD_DIR", ""), "client", "rs-discover")
GROUP = "users"  # stands in for rs-discoveryd, the packaged socket's group
CLEAN_ENV = {"PATH": "/usr/sbin:/usr/bin:/sbin:/bin", "HOME": "/"}


class Container:
    """A long-lived process in new mount and network namespaces (`unshare`), set up
    by `setup` (shell, run as root inside); commands go in with nsenter."""

    def __init__(self, setup):
        args = ["unshare", "--mount", "--net", "--propagation", "private", "sh", "-ec",
                setup + "\necho ready\nexec sleep 600\n"]
        self.proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=CLEAN_ENV)
        line = self.proc.stdout.readline()
        assert line.strip() == "ready", self.proc.stderr.read()

    def run(self, *cmd, as_user):
        uid, gid, groups = as_user
        user = ["setpriv", f"--reuid={uid}", f"--regid={gid}", f"--groups={groups}" if groups else "--clear-groups"]
        return subprocess.run(["nsenter", "-t", str(self.proc.pid), "-m", "-n"] + user + list(cmd),
                              capture_output=True, text=True, timeout=60, env=CLEAN_ENV)

    def close(self):
        self.proc.kill()
        self.proc.wait()


@pytest.fixture
def run_dir():
    """The host's runtime directory, as systemd makes /run/rs-discoveryd (0755)."""
    path = tempfile.mkdtemp(prefix="rsd-run-")
    os.chmod(path, 0o755)
    yield path
    shutil.rmtree(path, ignore_errors=True)


def start_daemon(daemon, domain, sock, extra=(), prefix=(), **kw):
    # The daemon's group makes the socket's (root:users 0660), as the socket unit's
    # SocketGroup=rs-discoveryd does.
    gid = grp.getgrnam(GROUP).gr_gid
    return daemon([domain], extra=extra, socket=sock,
                  prefix=list(prefix) + ["setpriv", f"--regid={gid}", "--clear-groups"], **kw)


def listed(result):
    assert result.returncode == 0, (result.returncode, result.stdout, result.stderr)
    return [x["serial"] for x in json.loads(result.stdout)["devices"]]


def test_a_client_in_a_container_reads_the_host_daemon_through_the_runtime_directory(
        free_domain, daemon, realdds_server, run_dir):
    camera = device_info(1)
    realdds_server(free_domain, [camera], name="host-camera-server")
    sock = os.path.join(run_dir, "api.sock")
    d = start_daemon(daemon, free_domain, sock)
    wait_for(lambda: len(d.devices()) == 1, 20, what="the camera")
    assert grp.getgrgid(os.stat(sock).st_gid).gr_name == GROUP
    gid = grp.getgrnam(GROUP).gr_gid
    # docker run -v /run/rs-discoveryd:/run/rs-discoveryd --group-add <gid> ...; beside
    # it, what not to do: -v /run/rs-discoveryd/api.sock:/run/file/api.sock
    c = Container(f"mount -t tmpfs tmpfs /run\n"
                  f"mkdir -p /run/rs-discoveryd /run/file\n"
                  f"mount --bind {run_dir} /run/rs-discoveryd\n"
                  f": > /run/file/api.sock\n"
                  f"mount --bind {sock} /run/file/api.sock\n")
    try:
        member = ("nobody", "nogroup", str(gid))
        # No --endpoint: a client finds /run/rs-discoveryd/api.sock by itself.
        assert listed(c.run(CLI, "list", "--json", as_user=member)) == [camera["serial"]]
        assert listed(c.run(CLI, "--endpoint", "unix:/run/file/api.sock", "list", "--json", as_user=member)) == [
            camera["serial"]]
        # Without the socket's group: refused, and told which group to add.
        r = c.run(CLI, "list", "--json", as_user=("nobody", "nogroup", None))
        assert r.returncode == 3 and "permission denied" in r.stderr and f"join group {GROUP}" in r.stderr, r.stderr

        # A daemon restart (an upgrade, a crash) makes a new socket file.
        d.stop()
        d2 = start_daemon(daemon, free_domain, sock)
        wait_for(lambda: len(d2.devices()) == 1, 20, what="the camera after the restart")
        assert listed(c.run(CLI, "list", "--json", as_user=member)) == [camera["serial"]]
        stale = c.run(CLI, "--endpoint", "unix:/run/file/api.sock", "list", "--json", as_user=member)
        assert stale.returncode == 3, (stale.stdout, stale.stderr)  # the old socket: nothing listens on it
    finally:
        c.close()


def test_rootless_a_user_namespace_keeps_the_socket_group(free_domain, daemon, realdds_server, run_dir):
    camera = device_info(2)
    realdds_server(free_domain, [camera], name="rootless-camera-server")
    sock = os.path.join(run_dir, "api.sock")
    d = start_daemon(daemon, free_domain, sock)
    wait_for(lambda: len(d.devices()) == 1, 20, what="the camera")
    gid = grp.getgrnam(GROUP).gr_gid
    # podman run --group-add keep-groups -v /run/rs-discoveryd:/run/rs-discoveryd ...
    # run by `nobody`, a member of the socket's group; root in the container is
    # nobody outside, and the group goes along though it is not mapped.
    r = subprocess.run(["setpriv", "--reuid=nobody", "--regid=nogroup", f"--groups={gid}", "unshare", "--user",
                        "--map-root-user", "--mount", "--net", "sh", "-ec",
                        f"mount -t tmpfs tmpfs /run\nmkdir -p /run/rs-discoveryd\nmount --bind {run_dir} /run/rs-discoveryd\n"
                        f"id -u\nexec {CLI} list --json\n"], capture_output=True, text=True, timeout=60, env=CLEAN_ENV)
    uid, _, out = r.stdout.partition("\n")
    assert uid == "0", (r.stdout, r.stderr)  # root in the container, nobody outside
    assert listed(subprocess.CompletedProcess(r.args, r.returncode, out, r.stderr)) == [camera["serial"]]


@pytest.fixture
def bridge():
    """A host namespace with a bridge (as docker0) and a container on it: the host
    172.30.N.1, the container 172.30.N.2, its default route through the host."""
    n = os.getpid() % 250 + 1
    host, box = f"rsdbr{os.getpid() % 100000}h", f"rsdbr{os.getpid() % 100000}c"
    _run("ip", "netns", "add", host)
    _run("ip", "netns", "add", box)
    try:
        def ex(ns, *a):
            _run("ip", "netns", "exec", ns, *a)
        ex(host, "ip", "link", "set", "lo", "up")
        ex(box, "ip", "link", "set", "lo", "up")
        ex(host, "ip", "link", "add", "rsdbr0", "type", "bridge")
        ex(host, "ip", "addr", "add", f"172.30.{n}.1/24", "dev", "rsdbr0")
        ex(host, "ip", "link", "set", "rsdbr0", "up")
        _run("ip", "link", "add", "veth0", "netns", host, "type", "veth", "peer", "name", "eth0", "netns", box)
        ex(host, "ip", "link", "set", "veth0", "master", "rsdbr0", "up")
        ex(box, "ip", "addr", "add", f"172.30.{n}.2/24", "dev", "eth0")
        ex(box, "ip", "link", "set", "eth0", "up")
        ex(box, "ip", "route", "add", "default", "via", f"172.30.{n}.1")
        yield host, box, f"172.30.{n}.1"
    finally:
        for ns in (host, box):
            subprocess.run(["ip", "netns", "del", ns], capture_output=True)


def test_a_client_on_a_bridge_network_asks_over_http_with_allowed_hosts(free_domain, daemon, realdds_server, bridge,
                                                                         tmp_path):
    host, box, gateway = bridge
    camera = device_info(3)
    realdds_server(free_domain, [camera], name="bridge-camera-server", prefix=["ip", "netns", "exec", host])
    port = 18035 + os.getpid() % 1000
    # docker run --add-host=host.docker.internal:host-gateway: the name of the host's
    # address on the bridge, in the container's /etc/hosts.
    hosts = tmp_path / "hosts"
    hosts.write_text(f"127.0.0.1 localhost\n{gateway} host.docker.internal\n")
    hosts.chmod(0o644)

    def in_box(*cmd):
        return subprocess.run(["ip", "netns", "exec", box, "unshare", "--mount", "sh", "-ec",
                               f'mount --bind {hosts} /etc/hosts; exec "$@"', "sh",
                               "setpriv", "--reuid=nobody", "--regid=nogroup", "--clear-groups", *cmd],
                              capture_output=True, text=True, timeout=60, env=CLEAN_ENV)

    def curl_status(url):
        return in_box("curl", "-s", "-o", "/dev/null", "-w", "%{http_code}", url).stdout

    # The daemon listens on the bridge's address ("http": "172.17.0.1:8035" for docker0).
    d = daemon([free_domain], extra=["--http", f"{gateway}:{port}"], http=False, prefix=["ip", "netns", "exec", host])
    wait_for(lambda: len(d.devices()) == 1, 20, what="the camera")
    # By address it listens on: answered.
    assert curl_status(f"http://{gateway}:{port}/v1/devices") == "200"
    assert listed(in_box(CLI, "--endpoint", f"http://{gateway}:{port}", "list", "--json")) == [camera["serial"]]
    # By name: a Host header it does not know (curl, browsers send the name).
    assert curl_status(f"http://host.docker.internal:{port}/v1/devices") == "421"
    d.stop()

    d = daemon([free_domain], extra=["--http", f"{gateway}:{port}", "--allowed-host", "host.docker.internal"],
               http=False, prefix=["ip", "netns", "exec", host])
    wait_for(lambda: len(d.devices()) == 1, 20, what="the camera")
    assert curl_status(f"http://host.docker.internal:{port}/v1/devices") == "200"
    assert listed(in_box(CLI, "--endpoint", f"http://host.docker.internal:{port}", "list", "--json")) == [
        camera["serial"]]


def container_prefix(setup):
    """The command prefix that runs a program in a new mount namespace set up by
    `setup` (shell, as root) and on the host's network, as `docker run --network host`."""
    return ["unshare", "--mount", "--propagation", "private", "sh", "-ec", setup + '\nexec "$@"', "sh"]


def test_the_daemons_own_container_recipe(free_domain, daemon, realdds_server, run_dir, tmp_path):
    # The README's `docker run --network host -v /dev/bus/usb:/dev/bus/usb:ro
    # -v /run/udev:/run/udev:ro -v /run/rs-discoveryd:/run/rs-discoveryd ...`: an
    # engine's minimal /dev and its own /run, the host's network. A camera on the
    # host's network is listed, the host's client reads the daemon through the
    # runtime directory, and with the USB bus and udev's directory passed in the
    # daemon watches USB. This machine has no USB bus: a directory stands in for
    # the host's /dev/bus/usb (the real one when there is one).
    camera = device_info(1)
    realdds_server(free_domain, [camera], name="host-network-camera")
    usb_bus = "/dev/bus/usb" if os.path.isdir("/dev/bus/usb") else str(tmp_path / "host-usb")
    udev = "/run/udev" if os.path.isdir("/run/udev") else str(tmp_path / "host-udev")
    os.makedirs(usb_bus, exist_ok=True)
    os.makedirs(udev, exist_ok=True)
    minimal = (f"mkdir -p {tmp_path}/host-dev && mount --rbind /dev {tmp_path}/host-dev\n"
               "mount -t tmpfs -o mode=755 tmpfs /dev\n"
               f"for n in null zero full random urandom; do : > /dev/$n; mount --bind {tmp_path}/host-dev/$n /dev/$n; done\n"
               "mount -t tmpfs -o mode=755 tmpfs /run\n"
               f"mkdir -p /run/rs-discoveryd && mount --bind {run_dir} /run/rs-discoveryd\n")
    with_usb = (f"mkdir -p /dev/bus/usb /run/udev\n"
                f"mount --bind -o ro {usb_bus} /dev/bus/usb\nmount --bind -o ro {udev} /run/udev\n")
    sock = os.path.join(run_dir, "api.sock")  # the host's view of the container's socket
    inside = ["--socket", "/run/rs-discoveryd/api.sock"]
    for passed, state in ((True, "hotplug"), (False, "unavailable")):
        d = start_daemon(daemon, free_domain, sock, extra=inside, usb=True, http=False,
                         prefix=container_prefix(minimal + (with_usb if passed else "")))
        wait_for(lambda: [x["serial"] for x in d.devices()] == [camera["serial"]], 20,
                 what="the host network's camera, from the container")
        usb = d.get_json("/healthz")["usb"]
        assert usb["state"] in ((state, "polling") if passed else (state,)), usb
        if not passed:
            assert "/dev/bus/usb" in usb["error"], usb  # and says what to pass in
        r = subprocess.run([CLI, "--endpoint", "unix:" + sock, "list", "--json"], capture_output=True, text=True,
                           timeout=60)
        assert listed(r) == [camera["serial"]]
        d.stop()
