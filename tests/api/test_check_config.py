"""rs-discoveryd --check-config [FILE], like nginx -t: the configuration is read and
validated, nothing is started; exit 0 for a valid one, 1 with the error's
FILE:LINE:COLUMN for an invalid one."""
import os
import subprocess

from conftest import DAEMON


def check(*args):
    return subprocess.run([DAEMON, *args], capture_output=True, text=True, timeout=30)


def test_a_valid_file_is_said_valid_and_nothing_starts(tmp_path):
    sock = tmp_path / "never.sock"
    good = tmp_path / "good.json"
    good.write_text(f'{{"domains": [3, 4], "socket": "{sock}", "http": "127.0.0.1:8099", "usb": false}}\n')
    r = check("--check-config", str(good))
    assert r.returncode == 0, r.stderr
    assert r.stdout == f"rs-discoveryd: {good} is valid: domains 3,4, socket {sock}, http 127.0.0.1:8099, usb off\n"
    assert not sock.exists()
    # The file of --config, flags over it, as the daemon would run.
    r = check("--config", str(good), "--check-config", "--domain", "9")
    assert r.returncode == 0 and "domains 9," in r.stdout, r
    r = check(f"--check-config={good}")
    assert r.returncode == 0, r


def test_an_invalid_file_names_its_line_and_column(tmp_path):
    syntax = tmp_path / "syntax.json"
    syntax.write_text('{\n  "domains": [0,\n  "http": "x"\n')
    r = check("--check-config", str(syntax))
    assert r.returncode == 1 and r.stdout == ""
    assert r.stderr.startswith(f"rs-discoveryd: {syntax}:3:9: not valid JSON: "), r.stderr
    value = tmp_path / "value.json"
    value.write_text('{\n  "domains": [0, 5],\n    "http": 8035\n}\n')
    r = check("--check-config", str(value))
    assert r.returncode == 1 and r.stderr == f'rs-discoveryd: {value}:3:5: "http" must be a string\n', r.stderr
    r = check("--check-config", str(tmp_path / "missing.json"))
    assert r.returncode == 1 and "cannot read config file" in r.stderr, r
    # Without --check-config a bad file stays a usage error (exit 2), as before, said
    # as clearly: a start under systemd runs no separate check.
    r = check("--config", str(value))
    assert r.returncode == 2 and r.stderr == f'rs-discoveryd: {value}:3:5: "http" must be a string\n', r.stderr
