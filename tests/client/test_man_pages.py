"""Every man page of the project renders cleanly: groff with every warning on and
mandoc's linter at its warning level say nothing, and no option line shows a stray
quote (a .BI with an odd number of arguments prints its quotes verbatim)."""
import glob
import os
import re
import shutil
import subprocess

import pytest
from client_util import SOURCE

PAGES = sorted(p for d in ("client", "daemon", "packaging", "systemd", "docs")
               for p in glob.glob(os.path.join(SOURCE, d, "**", "*.[1-8]"), recursive=True))


def test_the_pages_are_found():
    names = {os.path.basename(p) for p in PAGES}
    assert {"rs-discover.1", "rs-discoveryd.8"} <= names, PAGES


@pytest.mark.parametrize("page", PAGES, ids=os.path.basename)
def test_groff_renders_without_warnings(page):
    r = subprocess.run(["groff", "-man", "-Tutf8", "-ww", page], capture_output=True, text=True,
                       env=dict(os.environ, MANWIDTH="80"))
    assert r.returncode == 0 and r.stderr == "", r.stderr
    text = re.sub(r".\x08", "", r.stdout)  # overstrikes (bold, underline) to plain text
    # An option's tag line (.TP: a dash at the margin, its text indented deeper below):
    # a quote there is a markup slip.
    lines = text.splitlines()
    indent = lambda line: len(line) - len(line.lstrip())
    stray = [line.strip() for line, below in zip(lines, lines[1:] + [""])
             if line.lstrip().startswith("-") and indent(below) > indent(line) and '"' in line]
    assert not stray, stray


@pytest.mark.parametrize("page", PAGES, ids=os.path.basename)
def test_mandoc_lint_is_clean(page):
    assert shutil.which("mandoc"), "mandoc is installed by dev.sh"
    r = subprocess.run(["mandoc", "-Tlint", "-W", "warning", page], capture_output=True, text=True)
    assert r.returncode == 0 and r.stdout + r.stderr == "", r.stdout + r.stderr


def test_the_readme_reads_each_page_from_the_tree():
    # What the README gives a user of a clone: `man -l PATH`, run as written from the clone.
    readme = open(os.path.join(SOURCE, "README.md")).read()
    named = re.findall(r"^man -l (\S+)", readme, re.M)
    assert {"rs-discover.1", "rs-discoveryd.8"} <= {os.path.basename(p) for p in named}, named
    for page in named:
        r = subprocess.run(["man", "-l", page], cwd=SOURCE, capture_output=True, text=True, timeout=60,
                           env=dict(os.environ, MANPAGER="cat", PAGER="cat", MANWIDTH="80"))
        text = re.sub(r".\x08", "", r.stdout)
        title = os.path.basename(page).split(".")[0]
        assert r.returncode == 0 and "NAME" in text and title in text, (page, r.stderr)
