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
        ["list", "get", "describe", "watch", "domains", "participants", "doctor", "health", "help"])
    assert bash_complete("rs-discover pa", env) == ["participants"]
    options = bash_complete("rs-discover list --", env)
    for option in ("--domain", "--serial", "--format", "--no-headers", "--json", "--endpoint"):
        assert option in options
    assert bash_complete("rs-discover list --so", env) == ["--source"]
    assert bash_complete("rs-discover list --source ", env) == ["dds", "usb"]
    device_id = d.devices()[0]["id"]
    assert bash_complete("rs-discover get ", env) == sorted([device_id, info["serial"]])
    assert bash_complete("rs-discover describe 1236", env) == [info["serial"]]
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
        ["list", "get", "describe", "watch", "domains", "participants", "doctor", "health"]), commands.stderr
