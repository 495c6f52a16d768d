"""The route table (daemon/api/routes.cpp) held against proto/openapi.yaml: every path
and method of the spec is routed, every route is in the spec, and the running server
(the real ApiServer in api_harness) answers every path of the spec as one it knows."""
import subprocess

from api_util import request, spec
from test_api_harness import HARNESS, Harness

METHODS = {"get", "put", "post", "delete", "options", "head", "patch", "trace"}


def routes():
    """{(method, pattern)} as the daemon's table has them (api_harness --routes)."""
    out = subprocess.run([HARNESS, "--routes"], check=True, capture_output=True, text=True, timeout=10).stdout
    table = {(line.split()[0].lower(), line.split()[1]) for line in out.splitlines()}
    assert table, "api_harness --routes printed no route"
    return table


def spec_operations():
    return {(method, path) for path, item in spec()["paths"].items() for method in item if method in METHODS}


def test_every_spec_path_is_routed():
    assert spec_operations() - routes() == set()


def test_every_route_is_in_the_spec():
    assert routes() - spec_operations() == set()


def test_the_server_knows_every_spec_path(tmp_path):
    # A method the API does not take: 405 and Allow on a path it knows, 404 elsewhere.
    h = Harness(tmp_path, http=False)
    try:
        for path in spec()["paths"]:
            concrete = path.replace("{id}", "realsense/D455_1")
            status, headers, body = request(h.socket, concrete, method="DELETE")
            assert status == 405, (path, body)
            assert headers["allow"] == "GET, HEAD", path
        status, _, _ = request(h.socket, "/v1/device", method="DELETE")
        assert status == 404
    finally:
        h.stop()
