"""After `cmake --install`, find_package(rsdiscovery) and pkg-config both build a program
against the library (shared and static), and the CLI, man page and header are there."""
import glob
import os
import re
import shutil
import subprocess

import pytest
from client_util import BUILD, SOURCE

EXAMPLE_SRC = os.path.join(SOURCE, "client", "examples", "list_cameras.cpp")


def run(cmd, **kw):
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=300, **kw)
    assert r.returncode == 0, f"{cmd}:\n{r.stdout[-4000:]}\n{r.stderr[-4000:]}"
    return r


@pytest.fixture(scope="module")
def prefix(tmp_path_factory):
    p = tmp_path_factory.mktemp("prefix")
    run(["cmake", "--install", BUILD, "--prefix", str(p)])
    return p


def libdir(prefix):
    (pc,) = glob.glob(str(prefix / "**" / "pkgconfig" / "rsdiscovery.pc"), recursive=True)
    return os.path.dirname(os.path.dirname(pc))


def check_runs(binary, lib):
    env = dict(os.environ, LD_LIBRARY_PATH=lib)
    r = subprocess.run([binary, "unix:/nonexistent/api.sock"], capture_output=True, text=True, env=env, timeout=30)
    assert r.returncode == 3 and "no socket at /nonexistent/api.sock" in r.stderr, r.stderr


def test_installed_files(prefix):
    assert os.access(prefix / "bin" / "rs-discover", os.X_OK)
    assert (prefix / "include" / "rsdiscovery" / "rsdiscovery.hpp").is_file()
    man = prefix / "share" / "man" / "man1" / "rs-discover.1"
    assert man.is_file()
    r = run(["groff", "-man", "-Tutf8", "-ww", str(man)])  # groff-base: ./dev.sh installs it
    text = re.sub(r".\x08", "", r.stdout)  # overstrike bold
    assert "EXIT STATUS" in text and "RS_DISCOVERY_ENDPOINT" in text and not r.stderr
    lib = libdir(prefix)
    assert glob.glob(os.path.join(lib, "librsdiscovery.so.1*")) and os.path.exists(os.path.join(lib, "librsdiscovery.a"))
    # Only the public API is exported from the shared library.
    syms = run(["nm", "-D", "--defined-only", "-C", os.path.join(lib, "librsdiscovery.so")]).stdout
    assert "rsdiscovery::Client::list_devices" in syms
    assert "rsdiscovery::detail::" not in syms and "httplib::" not in syms


# The sanitizer build's libraries need their consumers built the same way.
SANITIZER_FLAGS = os.environ.get("RSD_SANITIZER_FLAGS", "")


def test_find_package(prefix, tmp_path):
    src = tmp_path / "consumer"
    src.mkdir()
    shutil.copy(EXAMPLE_SRC, src / "list_cameras.cpp")
    (src / "CMakeLists.txt").write_text(
        "cmake_minimum_required(VERSION 3.16)\nproject(consumer CXX)\n"
        "find_package(rsdiscovery 0.1 REQUIRED)\n"
        "add_executable(shared_demo list_cameras.cpp)\n"
        "target_link_libraries(shared_demo PRIVATE rsdiscovery::rsdiscovery)\n"
        "add_executable(static_demo list_cameras.cpp)\n"
        "target_link_libraries(static_demo PRIVATE rsdiscovery::rsdiscovery_static)\n")
    build = tmp_path / "build"
    gen = ["-G", "Ninja"] if shutil.which("ninja") else []
    run(["cmake", "-S", str(src), "-B", str(build), f"-DCMAKE_PREFIX_PATH={prefix}",
         f"-DCMAKE_CXX_FLAGS={SANITIZER_FLAGS}", f"-DCMAKE_EXE_LINKER_FLAGS={SANITIZER_FLAGS}"] + gen)
    run(["cmake", "--build", str(build), "-j2"])
    check_runs(str(build / "shared_demo"), libdir(prefix))
    check_runs(str(build / "static_demo"), "")
    assert "librsdiscovery" not in run(["ldd", str(build / "static_demo")]).stdout


def test_pkg_config(prefix, tmp_path):
    lib = libdir(prefix)
    env = dict(os.environ, PKG_CONFIG_PATH=os.path.join(lib, "pkgconfig"))
    flags = run(["pkg-config", "--cflags", "--libs", "rsdiscovery"], env=env).stdout.split()
    assert "-lrsdiscovery" in flags
    incs = [f[2:] for f in flags if f.startswith("-I")]
    assert [os.path.realpath(i) for i in incs] == [os.path.realpath(prefix / "include")], flags
    out = tmp_path / "demo"
    run(["c++", "-std=c++17", "-Wall", "-Werror", EXAMPLE_SRC, "-o", str(out)] + SANITIZER_FLAGS.split() + flags,
        env=env)
    check_runs(str(out), lib)
