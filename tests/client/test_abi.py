"""librsdiscovery.so.1's ABI is what client/librsdiscovery.symbols says: the library's
soname, every exported symbol under the version node RSDISCOVERY_1 (the linker version
script client/rsdiscovery.map), and the list of them, demangled, equal to the file in
the tree. So a change to the ABI is a diff a reviewer sees, not an accident: after a
deliberate change, write the file anew with

    python3 tests/client/test_abi.py build/client/librsdiscovery.so.1 > client/librsdiscovery.symbols

(an added symbol is compatible; a removed or changed one needs a new soname)."""
import os
import re
import subprocess
import sys

SOURCE = os.environ.get("RSD_SOURCE_DIR", os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..")))
BUILD = os.environ.get("RSD_BUILD_DIR", os.path.join(SOURCE, "build"))
LIBRARY = os.path.join(BUILD, "client", "librsdiscovery.so.1")
SYMBOLS_FILE = os.path.join(SOURCE, "client", "librsdiscovery.symbols")
HEADER = ("# librsdiscovery.so.1: every symbol it exports, demangled (version RSDISCOVERY_1).\n"
          "# Held by tests/client/test_abi.py; written by: python3 tests/client/test_abi.py LIBRARY\n")


def exported(library):
    """{demangled name: version} of the library's defined dynamic symbols."""
    r = subprocess.run(["nm", "-D", "-C", "--defined-only", "--with-symbol-versions", library],
                       capture_output=True, text=True, check=True)
    out = {}
    for line in r.stdout.splitlines():
        parts = line.split(" ", 2)
        if len(parts) < 3 or parts[1] == "A":  # the version node itself
            continue
        name, _, version = parts[2].rpartition("@@") if "@@" in parts[2] else (parts[2], "", "")
        out[name] = version
    return out


def soname(library):
    r = subprocess.run(["readelf", "-d", library], capture_output=True, text=True, check=True)
    m = re.search(r"\(SONAME\)\s+Library soname: \[([^\]]+)\]", r.stdout)
    return m.group(1) if m else None


def test_soname_is_1():
    assert soname(LIBRARY) == "librsdiscovery.so.1"


def test_every_symbol_is_versioned_and_in_namespace_rsdiscovery():
    symbols = exported(LIBRARY)
    assert symbols
    assert {v for v in symbols.values()} == {"RSDISCOVERY_1"}, {n: v for n, v in symbols.items() if v != "RSDISCOVERY_1"}
    outside = [n for n in symbols if not re.match(r"^(typeinfo (name )?for |vtable for )?rsdiscovery::", n)]
    assert outside == [], outside  # nothing of the model, the JSON library or std leaks


def test_exported_symbols_are_the_list_in_the_tree():
    with open(SYMBOLS_FILE) as f:
        listed = [line.rstrip("\n") for line in f if line.strip() and not line.startswith("#")]
    now = sorted(exported(LIBRARY))
    added = sorted(set(now) - set(listed))
    removed = sorted(set(listed) - set(now))
    assert (added, removed) == ([], []), (
        f"the ABI changed: added {added}, removed {removed}; if meant, write {SYMBOLS_FILE} anew (see this file's "
        "docstring), and give a removed or changed symbol a new soname")
    assert listed == sorted(listed), "keep the file sorted (as the command writes it)"


def json_libraries(binary):
    """Which JSON libraries' code is in a binary: every symbol, local ones too (the
    build keeps its symbol table), demangled."""
    r = subprocess.run(["nm", "-C", binary], capture_output=True, text=True, check=True)
    return {lib for lib, mark in (("nlohmann", "nlohmann::"), ("rapidjson", "rapidjson::")) if mark in r.stdout}


def test_each_client_binary_has_one_json_library():
    # The client's one JSON library is RapidJSON (client/src/json.hpp); nlohmann is the daemon's.
    for binary in (LIBRARY, os.path.join(BUILD, "client", "rs-discover")):
        assert json_libraries(binary) == {"rapidjson"}, binary


if __name__ == "__main__":
    sys.stdout.write(HEADER + "".join(n + "\n" for n in sorted(exported(sys.argv[1]))))
