"""The README's newcomer path, run as written: the shell commands of its first sections
(from "Run it" to the API), in order, from the clone, against a daemon of this test's own
(its domain, socket and port). The only changes made to them: `./dev.sh run` is that
daemon (started here instead, on this test's domain, socket and port), `./dev.sh test` is
what runs this test and is left out, `build/` is the tree under test, `--domain 0` this
test's domain, `~/.local` a prefix under tmp_path, `.venv/bin/python` this interpreter;
the CLI finds the daemon by $RS_DISCOVERY_ENDPOINT."""
import os
import re
import signal
import subprocess
import sys

from client_util import BUILD, DOMAIN_RANGE, SOURCE

README = os.path.join(SOURCE, "README.md")


def newcomer_blocks():
    text = open(README).read()
    start, end = text.index("\n## Run it\n"), text.index("\n## Asking the daemon")
    return re.findall(r"```sh\n(.*?)```", text[start:end], re.S)


def as_here(line, domain, prefix):
    line = re.sub(r"(^|\s)build/", lambda m: m.group(1) + os.path.abspath(BUILD) + "/", line)
    line = line.replace("--domain 0", f"--domain {domain}").replace("~/.local", str(prefix))
    return line.replace(".venv/bin/python", sys.executable)


def run_block(script, env):
    p = subprocess.Popen(["bash", "-euo", "pipefail", "-c", script], cwd=SOURCE, env=env, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        out, err = p.communicate(timeout=240)
    finally:
        try:  # what the block left in the background, if it failed before its `kill`
            os.killpg(p.pid, signal.SIGTERM)
        except ProcessLookupError:
            pass
    assert p.returncode == 0, f"{script}\n--- stdout\n{out[-3000:]}\n--- stderr\n{err[-3000:]}"
    return out


def test_the_newcomer_path_runs_as_written(daemon, domains, tmp_path):
    blocks = newcomer_blocks()
    assert blocks and blocks[0].splitlines()[0].startswith("./dev.sh run"), blocks
    domain, prefix, d = domains.take(*DOMAIN_RANGE), tmp_path / "prefix", None
    env = dict(os.environ, MANPAGER="cat", PAGER="cat", MANWIDTH="80")
    outputs = []
    for block in blocks:
        lines = []
        for line in block.splitlines():
            if line.startswith("./dev.sh run"):
                d = daemon([domain])
                env["RS_DISCOVERY_ENDPOINT"] = "unix:" + d.socket
            elif not line.startswith("./dev.sh test"):
                lines.append(as_here(line, domain, prefix))
        if lines:
            assert d, "a command before the daemon is started"
            outputs.append(run_block("\n".join(lines) + "\n", env))
    text = "\n".join(outputs)
    # What the README says each command shows.
    assert "rs-discover(1)" in text or "RS-DISCOVER(1)" in text, text[-2000:]
    assert "Intel RealSense D555" in text and "555000000001" in text, text[-2000:]
    assert "Depth" in text and "Infrared 1" in text, text[-2000:]
    assert os.access(prefix / "bin" / "rs-discover", os.X_OK) and os.access(prefix / "sbin" / "rs-discoveryd", os.X_OK)
