"""Helpers of the client suites (tests/conftest.py has the shared fixtures)."""
import json
import os
import subprocess

BUILD = os.environ.get("RSD_BUILD_DIR", os.path.join(os.path.dirname(__file__), "..", "..", "build"))
SOURCE = os.environ.get("RSD_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
CLI = os.path.join(BUILD, "client", "rs-discover")
EXAMPLE = os.path.join(BUILD, "client", "rsdiscovery-list-cameras")
DRIVER = os.path.join(BUILD, "tests", "client", "rsdiscovery_test_driver")

# This suite's DDS domains: 80-100, so it never meets another suite's servers.
DOMAIN_RANGE = (80, 100)


def rs_discover(*args, endpoint=None, env=None, timeout=30):
    """Runs the CLI; returns CompletedProcess with text stdout/stderr."""
    full_env = dict(os.environ)
    full_env.pop("RS_DISCOVERY_ENDPOINT", None)
    full_env.update(env or {})
    cmd = [CLI] + (["--endpoint", endpoint] if endpoint else []) + list(args)
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
