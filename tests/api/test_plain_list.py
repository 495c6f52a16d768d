"""The plain list answered past httplib (daemon/api/plain_list.*): `GET /v1/devices`
with no query is answered with a head the daemon writes for the table's generation.
`GET /v1/devices?` (an empty query, the same resource) still goes through httplib, so
the two must be the same bytes, for every header a poller sends, on both listeners,
before and after the table changes; the harness's debug log says which path answered."""
import re

import pytest

from api_util import metric, parse_metrics, raw, request
from test_api_harness import dev, harness  # noqa: F401 (the fixture)

# Header sets pollers send ({etag}: the list's current tag), and the status they get.
VARIANTS = [
    (b"", 200),
    (b"Connection: close\r\n", 200),
    (b"Connection: keep-alive\r\n", 200),
    (b"user-agent: curl/7.88.1\r\naccept: */*\r\n", 200),
    (b"If-None-Match: {etag}\r\n", 304),
    (b"if-none-match: W/{etag}, \"0\"\r\nConnection: close\r\n", 304),
    (b"If-None-Match: \"0\"\r\n", 200),
    (b"If-None-Match: *\r\n", 304),
    # What rsdiscovery (C++, rs-discover) and Python's http.client send.
    (b"Accept: application/json\r\nAccept-Encoding: identity\r\nUser-Agent: rsdiscovery/0.9.0\r\n", 200),
    (b"Accept-Encoding: identity\r\nAccept: application/json\r\nIf-None-Match: {etag}\r\n", 304),
]


def plain_answers(h):
    return len(re.findall(r"GET /v1/devices -> \d+ \(plain list\)", h.log()))


def both(target, headers):
    host = b"Host: localhost\r\n"
    fast = raw(target, b"GET /v1/devices HTTP/1.1\r\n" + host + headers + b"\r\n")
    slow = raw(target, b"GET /v1/devices? HTTP/1.1\r\n" + host + headers + b"\r\n")
    return fast, slow


@pytest.mark.parametrize("devices", [1, 60], ids=["copied-body", "memfd-body"])
def test_the_plain_list_is_httplibs_own_bytes(harness, devices):  # noqa: F811
    h = harness()
    for n in range(devices):
        h.upsert(*dev(n))
    for round_ in range(2):
        for target in (h.socket, h.tcp):
            _, headers, _ = request(target, "/v1/devices")
            etag = headers["etag"].encode()
            for variant, status in VARIANTS:
                before = plain_answers(h)
                fast, slow = both(target, variant.replace(b"{etag}", etag))
                assert fast == slow, (variant, fast[:400], slow[:400])
                assert fast.startswith(b"HTTP/1.1 %d " % status), fast[:200]
                assert plain_answers(h) == before + 1, (variant, h.log()[-2000:])
        # A change: the next answers are of the new generation, not the heads made before.
        generation = h.upsert(*dev(devices + round_))
        _, headers, body = request(h.socket, "/v1/devices")
        assert headers["etag"] == f'"{generation}"' and body.count(b'"serial"') == devices + round_ + 1


@pytest.mark.parametrize("request_bytes", [
    b"GET /v1/devices HTTP/1.1\r\nHost: localhost\r\nAccept-Encoding: gzip\r\n\r\n",
    b"GET /v1/devices HTTP/1.1\r\nHost: localhost\r\nAccept-Encoding: gzip, identity\r\n\r\n",
    b"GET /v1/devices HTTP/1.1\r\nHost: localhost\r\nRange: bytes=0-10\r\n\r\n",
    b"GET /v1/devices HTTP/1.1\r\nHost: localhost\r\nHost: localhost\r\n\r\n",
    b"GET /v1/devices HTTP/1.1\r\nHost: localhost\r\nConnection: Close\r\n\r\n",
    b"GET /v1/devices HTTP/1.0\r\nHost: localhost\r\n\r\n",
    b"HEAD /v1/devices HTTP/1.1\r\nHost: localhost\r\n\r\n",
    b"GET /v1/devices HTTP/1.1\nHost: localhost\n\n",
    b"GET /v1/devices HTTP/1.1\r\nHost: localhost\r\nContent-Length: 2\r\n\r\n{}",
    b"GET /v1/devices HTTP/1.1\r\nHost: local\xffhost\r\n\r\n",
], ids=["gzip", "gzip-identity", "range", "two-hosts", "Close", "http10", "head", "bare-lf", "body", "non-ascii"])
def test_what_the_plain_list_cannot_read_exactly_goes_to_httplib(harness, request_bytes):  # noqa: F811
    h = harness()
    h.upsert(*dev(1))
    before = plain_answers(h)
    answer = raw(h.socket, request_bytes)
    assert answer.startswith(b"HTTP/1."), answer[:200]
    assert plain_answers(h) == before


def test_a_foreign_host_is_refused_as_before(harness):  # noqa: F811
    """On TCP the Host check comes first (DNS rebinding): the plain list leaves it to httplib's 421."""
    h = harness()
    h.upsert(*dev(1))
    answer = raw(h.tcp, b"GET /v1/devices HTTP/1.1\r\nHost: evil.example\r\n\r\n")
    assert answer.startswith(b"HTTP/1.1 421 "), answer[:200]
    answer = raw(h.tcp, f"GET /v1/devices HTTP/1.1\r\nHost: 127.0.0.1:{h.port}\r\n\r\n".encode())
    assert answer.startswith(b"HTTP/1.1 200 "), answer[:200]


def test_plain_list_answers_are_counted(harness):  # noqa: F811
    h = harness()
    h.upsert(*dev(1))

    def counts():
        samples = parse_metrics(request(h.socket, "/metrics")[2].decode())
        return (metric(samples, "rsd_api_requests_total", status="200"),
                metric(samples, "rsd_api_requests_total", status="304"))

    ok, not_modified = counts()
    _, headers, _ = request(h.socket, "/v1/devices")
    etag = headers["etag"].encode()
    for _ in range(5):
        raw(h.socket, b"GET /v1/devices HTTP/1.1\r\nHost: localhost\r\n\r\n")
        raw(h.socket, b"GET /v1/devices HTTP/1.1\r\nHost: localhost\r\nIf-None-Match: " + etag + b"\r\n\r\n")
    ok_after, not_modified_after = counts()
    # The 5, the request that read the tag, and the first /metrics (which counts
    # itself just after its answer).
    assert (ok_after - ok, not_modified_after - not_modified) == (7, 5)
