"""`./dev.sh run`, a new user's first command, installs only what building and running
need (not the test toolchain: Chromium, clang, nginx, mmdebstrap ...), and builds
rs-discover beside the daemon so the README's next line works, and the client library so
that `cmake --install` works after it; `./dev.sh test` still installs everything. The
files CMake finds for a tree without tests come from the run list's packages (or what
they depend on)."""
import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest
from client_util import SOURCE

DEV = os.path.join(SOURCE, "dev.sh")


def packages(command):
    r = subprocess.run([DEV, "packages", command], capture_output=True, text=True, timeout=30)
    assert r.returncode == 0, r.stderr
    return r.stdout.split()


def test_run_installs_a_part_of_what_test_installs():
    run, test = packages("run"), packages("test")
    assert run and set(run) < set(test)
    heavy = {"chromium", "chromium-driver", "clang", "libclang-rt-dev", "nginx-light", "mmdebstrap", "wrk",
             "umockdev", "lintian", "devscripts", "googletest", "libgtest-dev", "strace",
             "python3-pip", "zsh", "mandoc"}
    assert not heavy & set(run), heavy & set(run)
    assert heavy < set(test)
    assert len(run) <= 15, run


def test_run_builds_the_daemon_and_rs_discover():
    text = open(DEV).read()
    run = text[text.index("\n  run | build)"):text.index("\n    ;;", text.index("\n  run | build)"))]
    assert 'install_packages "${RUN_PACKAGES[@]}"' in run
    assert re.search(r'cmake --build "\$dir" .*--target "\$\{RUN_TARGETS\[@\]\}"', run), run
    targets = re.search(r"^RUN_TARGETS=\(([^)]*)\)", text, re.M)
    assert targets and {"rs-discoveryd", "rs-discover"} <= set(targets.group(1).split()), text


def test_install_works_after_the_run_build(tmp_path):
    # The build step of `./dev.sh run`, alone, in a fresh tree; then what the README's
    # install line does. dev.sh compiles through ccache where it is installed; ccache
    # makes paths relative to the build directory, so a tree at the top of the source
    # (where `build` is) hits the plain tree's objects, one in /tmp would not.
    tree, prefix = Path(SOURCE) / f"build-first-run-{os.getpid()}", tmp_path / "prefix"
    shutil.rmtree(tree, ignore_errors=True)
    try:
        _build_and_install(tree, prefix)
    finally:
        shutil.rmtree(tree, ignore_errors=True)


def _build_and_install(tree, prefix):
    r = subprocess.run([DEV, "build", str(tree)], capture_output=True, text=True, timeout=1500)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    assert os.access(tree / "daemon" / "rs-discoveryd", os.X_OK) and os.access(tree / "client" / "rs-discover", os.X_OK)
    r = subprocess.run(["cmake", "--install", str(tree), "--prefix", str(prefix)], capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    for path in ("bin/rs-discover", "sbin/rs-discoveryd"):
        r = subprocess.run([str(prefix / path), "--version"], capture_output=True, text=True, timeout=30)
        assert r.returncode == 0 and "0.1.0" in r.stdout + r.stderr, (path, r.stdout, r.stderr)
    assert (prefix / "share" / "man" / "man1" / "rs-discover.1").is_file()
    assert list(prefix.glob("lib*/**/librsdiscovery.so.1*")) and list(prefix.glob("lib*/**/librsdiscovery.a"))


@pytest.mark.skipif(not shutil.which("dpkg-query"), reason="Debian only")
def test_what_cmake_finds_comes_from_the_run_packages(tmp_path):
    r = subprocess.run(["cmake", "-S", SOURCE, "-B", str(tmp_path), "-G", "Ninja", "-DRSD_BUILD_TESTS=OFF"],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr
    cache = dict(re.findall(r"^([A-Za-z_]+):[A-Z]+=(.*)$", open(tmp_path / "CMakeCache.txt").read(), re.M))
    files = [os.path.join(cache["CycloneDDS_DIR"], "CycloneDDSConfig.cmake"),
             os.path.join(cache["nlohmann_json_DIR"], "nlohmann_jsonConfig.cmake"),
             os.path.join(cache["RAPIDJSON_INCLUDE_DIR"], "rapidjson", "rapidjson.h"),
             shutil.which("idlc"), shutil.which("ninja"), shutil.which("c++"), cache["PKG_CONFIG_EXECUTABLE"]]
    files += [v for k, v in cache.items() if k.startswith("OPENSSL_") and k.endswith("_LIBRARY")]
    for module in ("cpp-httplib", "libsystemd", "libusb-1.0"):
        files.append(subprocess.run(["pkg-config", "--path", module], capture_output=True, text=True).stdout.strip())
    # Every package the run list brings in, with what it depends on.
    closure = subprocess.run(["apt-cache", "depends", "--recurse", "--installed", "--no-recommends", "--no-suggests",
                              "--no-conflicts", "--no-breaks", "--no-replaces", "--no-enhances"] + packages("run"),
                             capture_output=True, text=True, timeout=60).stdout
    provided = {line.split(":")[0] for line in closure.splitlines() if line and not line.startswith(" ")}
    for f in files:
        real = os.path.realpath(f)
        owners = subprocess.run(["dpkg-query", "-S", real], capture_output=True, text=True)
        if owners.returncode != 0:  # the unresolved path may be the one dpkg knows
            owners = subprocess.run(["dpkg-query", "-S", f], capture_output=True, text=True)
        assert owners.returncode == 0, f"{f}: no package owns it"
        names = {n.strip().split(":")[0] for n in owners.stdout.split(":")[0].split(",")}
        assert names & provided, f"{f} comes from {names}, which the run list does not bring in"
