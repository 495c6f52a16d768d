"""Brings the shared fixtures of tests/conftest.py (free_domain, daemon,
realdds_server, wait_for, ...) into this folder.

ctest runs each pytest file with this folder as rootdir, and pytest only looks
for conftest.py files from the rootdir down, so the shared one is not found on
its own. It is loaded under another module name: both files are "conftest" to
pytest's default import mode. If the shared one is later picked up by pytest
itself too (an ini file higher up), both define the same fixtures and nothing
changes.
"""
import importlib.util
import os
import sys

_SHARED = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "conftest.py")
_spec = importlib.util.spec_from_file_location("rsd_shared_conftest", _SHARED)
shared = importlib.util.module_from_spec(_spec)
sys.modules["rsd_shared_conftest"] = shared
_spec.loader.exec_module(shared)

globals().update({k: v for k, v in vars(shared).items() if not k.startswith("_")})
