"""Who holds a USB camera: `rs-discover clients ID` on an emulated bus (umockdev).

The daemon lists the camera's device nodes (its document's usb.device-nodes); the CLI
looks for them among every process's open files, as fuser does. A real process holds
the emulated nodes open here: under umockdev's preload its open() reaches the
testbed's files, which is also where the CLI's stat() of the node paths leads, so the
match is the one a real /dev gives (same file). Runs under umockdev-wrapper, as
test_usb.py does (its fixtures are reused).
"""
import json
import os
import subprocess
import sys

import pytest

from conftest import wait_for
from test_usb import D455_ID, D455_SERIAL, bed, usb_daemon, usb_devices  # noqa: F401 (fixtures)
from usbbed import in_umockdev

TESTS = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(TESTS, "client"))
from client_util import rs_discover  # noqa: E402
from test_cli import table  # noqa: E402

pytestmark = pytest.mark.skipif(not in_umockdev(), reason="run under umockdev-wrapper (ctest does)")

HOLD = ("import os, sys\n"
        "fds = [os.open(p, os.O_RDONLY) for p in sys.argv[1:]]\n"
        "print('held', flush=True)\n"
        "sys.stdin.read()\n")


class Holder:
    """A process with the given nodes open until it is closed."""

    def __init__(self, bed, *nodes, user=None):
        env = dict(os.environ)
        env.update(bed.env())
        cmd = [sys.executable, "-c", HOLD, *nodes]
        if user:
            cmd = ["setpriv", "--reuid", user, "--regid", "nogroup", "--clear-groups", "--"] + cmd
        self.proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                     text=True, env=env)
        line = self.proc.stdout.readline()
        assert line == "held\n", self.proc.stderr.read()

    def close(self):
        self.proc.stdin.close()
        self.proc.wait(5)


def camera_with_nodes(bed, usb_daemon):  # noqa: F811
    bed.plug("root-hubs")
    bed.plug("d455-uvc")
    d, _ = usb_daemon()
    wait_for(lambda: "/dev/video0" in usb_devices(d).get(D455_ID, {}).get("usb", {}).get("device-nodes", []), 5,
             what="the D455 listed with its video node")
    return d


def clients(bed, d, *args, user=None):
    """rs-discover clients over HTTP (reachable by another user too), under the preload."""
    if user:
        return rs_discover("clients", *args, endpoint=f"http://127.0.0.1:{d.port}",
                           env=bed.env(), wrap=["setpriv", "--reuid", user, "--regid", "nogroup", "--clear-groups", "--"])
    return rs_discover("clients", *args, endpoint=f"http://127.0.0.1:{d.port}", env=bed.env())


def test_a_process_holding_the_camera_is_found_and_nothing_when_none(bed, usb_daemon):  # noqa: F811
    d = camera_with_nodes(bed, usb_daemon)

    r = clients(bed, d, D455_SERIAL)
    assert (r.returncode, r.stdout, r.stderr) == (0, "no process holds it open\n", "")
    r = clients(bed, d, "--json", D455_ID)
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout) == {"holders": [], "holders-complete": True}

    holder = Holder(bed, "/dev/video0", "/dev/bus/usb/002/002")
    try:
        r = clients(bed, d, D455_SERIAL)
        assert r.returncode == 0, r.stderr
        _, rows = table(r.stdout)
        assert rows == [{"PID": str(holder.proc.pid), "USER": "root", "COMMAND": rows[0]["COMMAND"],
                         "NODES": "/dev/bus/usb/002/002, /dev/video0"}], r.stdout
        # Its command line on one line: the script's newlines shown as '?', as ps does.
        assert rows[0]["COMMAND"].startswith(sys.executable + " -c import os, sys?fds = "), r.stdout
        doc = json.loads(clients(bed, d, "--json", D455_ID).stdout)
        [h] = doc["holders"]
        assert (h["pid"], h["uid"], h["user"], h["nodes"]) == (
            holder.proc.pid, 0, "root", ["/dev/bus/usb/002/002", "/dev/video0"])
        assert doc["holders-complete"] is True
        # doctor ID says the same.
        r = rs_discover("doctor", "--json", "--listen", "0", D455_SERIAL, endpoint=f"http://127.0.0.1:{d.port}",
                        env=bed.env())
        found = [f for f in json.loads(r.stdout)["findings"] if f["topic"] == "in-use"]
        assert [f["verdict"] for f in found] == ["info"], found
        assert f"is held open by pid {holder.proc.pid} (root: " in found[0]["text"], found
    finally:
        holder.close()

    # Let go: nothing holds it any more.
    r = clients(bed, d, D455_SERIAL)
    assert (r.returncode, r.stdout) == (0, "no process holds it open\n")


def test_without_root_only_own_processes_and_a_note_that_root_sees_all(bed, usb_daemon):  # noqa: F811
    d = camera_with_nodes(bed, usb_daemon)
    # The testbed open to another user (its nodes and umockdev's ioctl sockets), so that
    # an unprivileged process can hold a node, as a member of group video does.
    subprocess.run(["chmod", "-R", "a+rwX", bed.root], check=True)
    root_holder = Holder(bed, "/dev/video0")
    # (umockdev makes a video node a pty of root's, which nobody may open: the USB node)
    own_holder = Holder(bed, "/dev/bus/usb/002/002", user="nobody")
    try:
        r = clients(bed, d, D455_SERIAL, user="nobody")
        assert r.returncode == 0, r.stderr
        _, rows = table(r.stdout)
        assert [(row["PID"], row["USER"], row["NODES"]) for row in rows] == [
            (str(own_holder.proc.pid), "nobody", "/dev/bus/usb/002/002")], r.stdout
        assert "could not be read: only yours are shown; root sees every holder" in r.stderr, r.stderr
        doc = json.loads(clients(bed, d, "--json", D455_ID, user="nobody").stdout)
        assert [h["pid"] for h in doc["holders"]] == [own_holder.proc.pid]
        assert doc["holders-complete"] is False

        # root sees both.
        _, rows = table(clients(bed, d, D455_SERIAL).stdout)
        assert [(int(row["PID"]), row["NODES"]) for row in rows] == sorted(
            [(root_holder.proc.pid, "/dev/video0"), (own_holder.proc.pid, "/dev/bus/usb/002/002")])
    finally:
        own_holder.close()
        root_holder.close()
