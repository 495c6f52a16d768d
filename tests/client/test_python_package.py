"""The Python package: pip-installed from the tree into a fresh venv, its tests run there
with pytest against the real daemon and real realdds servers."""
import os
import subprocess
import sys
import venv

import pytest
from client_util import DOMAIN_RANGE, SOURCE

PACKAGE = os.path.join(SOURCE, "client", "python")


def run(cmd, **kw):
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=300, **kw)
    assert r.returncode == 0, f"{cmd}:\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}"
    return r


def test_package_in_a_fresh_venv(tmp_path, domains):
    env_dir = tmp_path / "venv"
    venv.EnvBuilder(with_pip=True).create(env_dir)
    py = str(env_dir / "bin" / "python")
    # From the tree, as a user would (pip builds it in isolation with setuptools from PyPI).
    run([py, "-m", "pip", "install", "-q", PACKAGE])
    r = subprocess.run([py, "-m", "pip", "install", "-q", "pytest"], capture_output=True, text=True, timeout=300)
    if r.returncode != 0:  # no registry: borrow this interpreter's pytest, read-only
        import _pytest
        import pluggy
        import iniconfig

        site = run([py, "-c", "import site; print(site.getsitepackages()[0])"]).stdout.strip()
        with open(os.path.join(site, "borrowed-pytest.pth"), "w") as f:
            for mod in (_pytest, pluggy, iniconfig):
                f.write(os.path.dirname(os.path.dirname(mod.__file__)) + "\n")
    # The package must not need anything beyond the standard library.
    deps = run([py, "-m", "pip", "show", "rsdiscovery"]).stdout
    requires = [ln.split(":", 1)[1].strip() for ln in deps.splitlines() if ln.startswith("Requires:")]
    assert requires == [""], deps
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    env.update(RSD_SERVER_PYTHON=sys.executable, RSD_TEST_DOMAIN=str(domains.take(*DOMAIN_RANGE)),
               RSD_SOURCE_DIR=SOURCE)
    r = subprocess.run([py, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-rfE", os.path.join(PACKAGE, "tests")],
                       capture_output=True, text=True, timeout=300, env=env, cwd=str(tmp_path))
    assert r.returncode == 0, r.stdout[-6000:] + r.stderr[-3000:]
    assert " passed" in r.stdout
