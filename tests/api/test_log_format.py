"""The daemon's log reads well wherever it goes: on a terminal, in a file or through a
pipe (`docker logs`) each line starts with the local date and time and the level's
word; written to the journal (JOURNAL_STREAM names stderr) the "<N>" priority prefix
journald reads, and nothing else."""
import os
import pty
import re
import select
import signal
import subprocess
import time

from conftest import DAEMON, wait_for


def start(tmp_path, domain, stderr, env=None):
    config = tmp_path / "empty.json"
    config.write_text("{}")
    return subprocess.Popen([DAEMON, "--config", str(config), "--domain", str(domain), "--socket",
                             str(tmp_path / "api.sock"), "--http", "off", "--no-usb"],
                            stdin=subprocess.DEVNULL, stdout=stderr, stderr=stderr, env=dict(os.environ, **(env or {})))


def stop(proc):
    proc.send_signal(signal.SIGTERM)
    assert proc.wait(10) == 0


def test_on_a_terminal_time_and_level_words(tmp_path, free_domain):
    master, slave = pty.openpty()
    # A JOURNAL_STREAM inherited from a service that ran this shell names another file.
    proc = start(tmp_path, free_domain, slave, env={"JOURNAL_STREAM": "8:12345"})
    os.close(slave)
    out = ""
    deadline = time.monotonic() + 15
    while "serving" not in out and time.monotonic() < deadline:
        if select.select([master], [], [], 0.5)[0]:
            out += os.read(master, 65536).decode("utf-8", "replace")
    stop(proc)
    os.close(master)
    line = next((x for x in out.splitlines() if "serving" in x), None)
    assert line, out
    assert re.match(r"\d{4}-\d\d-\d\d \d\d:\d\d:\d\d\.\d{3} notice: rs-discoveryd \S+ serving on unix:", line), line
    assert not re.search(r"^<\d>", out, re.M), out


def test_to_the_journal_the_priority_prefix(tmp_path, free_domain):
    log = tmp_path / "journal-stand-in.log"
    with open(log, "wb") as f:
        st = os.fstat(f.fileno())
        proc = start(tmp_path, free_domain, f, env={"JOURNAL_STREAM": f"{st.st_dev}:{st.st_ino}"})
        wait_for(lambda: "serving" in log.read_text(), 15, what="the daemon serving")
        stop(proc)
    lines = log.read_text().splitlines()
    assert any(x.startswith("<5>rs-discoveryd ") and "serving" in x for x in lines), lines
    assert all(re.match(r"<[3-7]>", x) for x in lines), lines


def test_through_a_pipe_time_and_level_words(tmp_path, free_domain):
    # A container engine's log driver, a `| tee`: a person reads these lines too.
    r, w = os.pipe()
    proc = start(tmp_path, free_domain, w)
    os.close(w)
    out = b""
    while b"serving" not in out:
        chunk = os.read(r, 65536)
        assert chunk, out
        out += chunk
    stop(proc)
    os.close(r)
    line = next(x for x in out.decode().splitlines() if "serving" in x)
    assert re.match(r"\d{4}-\d\d-\d\d \d\d:\d\d:\d\d\.\d{3} notice: rs-discoveryd \S+ serving on unix:", line), line
    assert not re.search(r"^<\d>", out.decode(), re.M), out
