"""Helpers of the client suites (tests/conftest.py has the shared fixtures)."""
import json
import os
import signal
import subprocess
import threading

BUILD = os.environ.get("RSD_BUILD_DIR", os.path.join(os.path.dirname(__file__), "..", "..", "build"))
SOURCE = os.environ.get("RSD_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
CLI = os.path.join(BUILD, "client", "rs-discover")
EXAMPLE = os.path.join(BUILD, "client", "rsdiscovery-list-cameras")
DRIVER = os.path.join(BUILD, "tests", "client", "rsdiscovery_test_driver")

# This suite's DDS domains: 80-100, so it never meets another suite's servers.
DOMAIN_RANGE = (80, 100)


class WatchProcess:
    """`rs-discover --endpoint ENDPOINT watch ARGS...` running, its stdout and stderr read
    line by line on threads into `lines` and `errors` as they come."""

    def __init__(self, endpoint, *args):
        self.proc = subprocess.Popen([CLI, "--endpoint", endpoint, "watch", *args], stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE, text=True)
        self.lines, self.errors = [], []
        self.readers = [threading.Thread(target=lambda: self.lines.extend(iter(self.proc.stdout.readline, "")),
                                         daemon=True),
                        threading.Thread(target=lambda: self.errors.extend(iter(self.proc.stderr.readline, "")),
                                         daemon=True)]
        for t in self.readers:
            t.start()

    def interrupt(self):
        """A user's Ctrl-C; returns the exit status, with the output read to its end."""
        self.proc.send_signal(signal.SIGINT)
        code = self.proc.wait(30)
        for t in self.readers:
            t.join(10)
        return code


def rs_discover(*args, endpoint=None, env=None, timeout=30, wrap=()):
    """Runs the CLI (after the command `wrap`, e.g. setpriv, when given); returns
    CompletedProcess with text stdout/stderr."""
    full_env = dict(os.environ)
    full_env.pop("RS_DISCOVERY_ENDPOINT", None)
    full_env.update(env or {})
    cmd = list(wrap) + [CLI] + (["--endpoint", endpoint] if endpoint else []) + list(args)
    return subprocess.run(cmd, capture_output=True, text=True, env=full_env, timeout=timeout)


def fold(view, event):
    """Applies one watch event (a dict from --json output) to a view {id: device}."""
    dev = event["device"]
    if event["event"] == "removed":
        view.pop(dev["id"], None)
    else:
        view[dev["id"]] = dev
    return view


def json_lines(text):
    return [json.loads(line) for line in text.splitlines() if line.strip()]
