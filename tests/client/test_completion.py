"""rs-discover's shell completions (client/completions), run in bash with
bash-completion and in zsh's completion system, against the real daemon: commands,
a command's options (from its own --help), and the ids and serials of the cameras
there now for get and describe."""
import os
import shutil
import subprocess

import pytest
from client_util import CLI, DOMAIN_RANGE, SOURCE
from conftest import device_info, wait_for

BASH = os.path.join(SOURCE, "client", "completions", "rs-discover.bash")
ZSH = os.path.join(SOURCE, "client", "completions", "_rs-discover")


def bash_complete(line, env):
    """What bash offers for Tab at the end of `line` (words split on spaces)."""
    script = f"""
        source /usr/share/bash-completion/bash_completion
        source {BASH}
        COMP_LINE={line!r}
        read -ra COMP_WORDS <<< "$COMP_LINE"
        [[ "$COMP_LINE" == *" " ]] && COMP_WORDS+=("")
        COMP_CWORD=$(( ${{#COMP_WORDS[@]}} - 1 ))
        COMP_POINT=${{#COMP_LINE}}
        _rs_discover
        printf '%s\\n' "${{COMPREPLY[@]}}"
    """
    r = subprocess.run(["bash", "-c", script], capture_output=True, text=True, env=env, timeout=30)
    assert r.returncode == 0, r.stderr
    return sorted(x for x in r.stdout.splitlines() if x)


@pytest.fixture
def camera_env(daemon, realdds_server, domains):
    domain = domains.take(*DOMAIN_RANGE)
    info = device_info(21)
    realdds_server(domain, [info])
    d = daemon([domain])
    wait_for(lambda: len(d.devices()) == 1, 20, what="the camera")
    env = dict(os.environ, PATH=os.path.dirname(CLI) + os.pathsep + os.environ["PATH"],
               RS_DISCOVERY_ENDPOINT="unix:" + d.socket)
    return d, info, env


def test_bash_commands_options_and_devices(camera_env):
    d, info, env = camera_env
    assert bash_complete("rs-discover ", env) == sorted(
        ["list", "get", "describe", "clients", "watch", "wait", "domains", "participants", "doctor", "health", "history",
         "help"])
    assert bash_complete("rs-discover pa", env) == ["participants"]
    options = bash_complete("rs-discover list --", env)
    for option in ("--domain", "--serial", "--format", "--no-headers", "--json", "--endpoint"):
        assert option in options
    assert bash_complete("rs-discover list --so", env) == ["--source"]
    assert bash_complete("rs-discover list --source ", env) == ["dds", "remote-usb", "usb"]
    device_id = d.devices()[0]["id"]
    assert bash_complete("rs-discover get ", env) == sorted([device_id, info["serial"]])
    assert bash_complete("rs-discover describe 1236", env) == [info["serial"]]
    assert bash_complete("rs-discover history 1236", env) == [info["serial"]]
    assert bash_complete("rs-discover clients 1236", env) == [info["serial"]]
    assert bash_complete("rs-discover list --serial ", env) == [info["serial"]]


def test_zsh_offers_the_same(camera_env):
    d, info, env = camera_env
    assert shutil.which("zsh"), "zsh is installed by the set-up step"
    r = subprocess.run(["zsh", "-n", ZSH], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    # Outside a terminal zsh's completion widgets cannot run: compadd, _describe and
    # _arguments are stand-ins that print what they would offer, and the script's
    # own functions run as they would under Tab.
    script = f"""
        compadd() {{ local a; for a in "$@"; do [[ $a == -* ]] || print -r -- "$a"; done }}
        _describe() {{ local -a list; list=("${{(@P)${{@[-1]}}}}"); print -rl -- "${{list[@]%%:*}}"; }}
        _arguments() {{ return 1 }}
        source {ZSH}
        complete_line() {{
          words=("$@"); CURRENT=${{#words}}
          line=("${{words[2]}}"); state=argument
          _rs_discover_devices
        }}
        complete_line rs-discover get ''
    """
    r = subprocess.run(["zsh", "-f", "-c", script], capture_output=True, text=True, env=env, timeout=30)
    offered = sorted(x for x in r.stdout.splitlines() if x)
    assert offered == sorted([d.devices()[0]["id"], info["serial"]]), (r.stdout, r.stderr)
    commands = subprocess.run(["zsh", "-f", "-c", f"""
        compadd() {{ :; }}
        _describe() {{ local -a list; list=("${{(@P)${{@[-1]}}}}"); print -rl -- "${{list[@]%%:*}}"; }}
        _arguments() {{ state=command; return 1 }}
        source {ZSH}
    """], capture_output=True, text=True, env=env, timeout=30)
    assert sorted(commands.stdout.split()) == sorted(
        ["list", "get", "describe", "clients", "watch", "wait", "domains", "participants", "doctor", "health",
         "history"]), commands.stderr


class Terminal:
    """An interactive shell on a pseudo-terminal, as a user at a prompt: Tab goes to the
    shell's own completion (bash's readline, with COMP_WORDBREAKS as it is, and zsh's
    compinit), not a stand-in."""

    def __init__(self, argv, env, setup):
        import pty
        import fcntl
        import struct
        import termios
        self.master, slave = pty.openpty()
        fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 50, 400, 0, 0))  # no wrapped lines
        self.proc = subprocess.Popen(argv, stdin=slave, stdout=slave, stderr=slave, env=env, start_new_session=True)
        os.close(slave)
        self.buffer = ""
        for command in setup:
            self.run(command)

    def read_until(self, marker, timeout=20):
        import select
        import time
        deadline = time.monotonic() + timeout
        while marker not in self.buffer:
            left = deadline - time.monotonic()
            assert left > 0, f"no {marker!r} from the shell; it printed:\n{self.buffer[-3000:]}"
            if select.select([self.master], [], [], left)[0]:
                try:
                    self.buffer += os.read(self.master, 65536).decode("utf-8", "replace")
                except OSError:  # the shell ended
                    break
        found = self.buffer.index(marker)
        out, self.buffer = self.buffer[:found], self.buffer[found + len(marker):]
        return out

    def run(self, command):
        """Runs `command` at the prompt and waits for it to end."""
        os.write(self.master, f"{command}; echo DONE''$?\r".encode())
        self.read_until("DONE0")

    def complete(self, line):
        """Types `line`, presses Tab once, and returns the line as the shell has it then
        (read back by putting `echo LINE:` in front of it and pressing Enter)."""
        os.write(self.master, line.encode() + b"\t")
        os.write(self.master, b"\x01echo LINE:\r")  # Ctrl-A: to the start of the line
        self.read_until("\nLINE:")
        return self.read_until("\n").strip()

    def close(self):
        self.proc.kill()
        self.proc.wait()
        os.close(self.master)


@pytest.fixture
def endpoint_env(camera_env, tmp_path):
    """No endpoint in the environment, and no daemon at the default socket: only the
    line's --endpoint reaches the camera's daemon."""
    d, info, env = camera_env
    env = {k: v for k, v in env.items() if k != "RS_DISCOVERY_ENDPOINT"}
    env.update(RUNTIME_DIRECTORY=str(tmp_path / "nothing-here"), TERM="dumb", HOME=str(tmp_path))
    return d, info, env


def endpoints(d):
    return [f"--endpoint unix:{d.socket}", f"--endpoint http://127.0.0.1:{d.port}", f"--endpoint=unix:{d.socket}",
            f"--endpoint=http://127.0.0.1:{d.port}"]


def assert_ids_complete_after_every_endpoint(shell, d, info):
    """In `shell`, an id and a serial complete after each form of --endpoint, before the
    command and after it; the shell is closed after."""
    device_id = d.devices()[0]["id"]
    try:
        for endpoint in endpoints(d):
            assert shell.complete(f"rs-discover {endpoint} get dds-") == \
                f"rs-discover {endpoint} get {device_id}", endpoint
            assert shell.complete(f"rs-discover {endpoint} describe 1236") == \
                f"rs-discover {endpoint} describe {info['serial']}", endpoint
            assert shell.complete(f"rs-discover get {endpoint} dds-") == \
                f"rs-discover get {endpoint} {device_id}", endpoint
    finally:
        shell.close()


def test_bash_completes_ids_after_every_form_of_endpoint(endpoint_env):
    d, info, env = endpoint_env
    shell = Terminal(["bash", "--norc", "--noprofile", "-i"], env, [
        "PS1='$ '", "bind 'set enable-bracketed-paste off'", "bind 'set bell-style none'",
        "source /usr/share/bash-completion/bash_completion", f"source {BASH}",
        "[[ $COMP_WORDBREAKS == *:* && $COMP_WORDBREAKS == *=* ]]"])  # the default, splitting at ':' and '='
    assert_ids_complete_after_every_endpoint(shell, d, info)


def test_zsh_completes_ids_after_every_form_of_endpoint(endpoint_env):
    d, info, env = endpoint_env
    shell = Terminal(["zsh", "-f", "-i"], dict(env, PS1="$ "), [
        "bindkey -e", "unsetopt beep", f"fpath=({os.path.dirname(ZSH)} $fpath)", "autoload -Uz compinit",
        "compinit -u -D"])
    assert_ids_complete_after_every_endpoint(shell, d, info)
