"""Why cameras left, over the real ApiServer fed through stdin (api_harness): the
reason on `removed` events and in /metrics, `arrival` on `added`, a gone camera's
410, and the history routes."""
from api_util import SSEStream, get_json, metric, parse_metrics, request, validate_response
from test_api_harness import dev, harness  # noqa: F401 - the fixture

REASONS = ["stopping", "writer-gone", "lease-expired", "unplugged", "interface-gone", "domain-left", "refused"]


def metrics(target):
    status, _, body = request(target, "/metrics")
    assert status == 200
    return parse_metrics(body.decode())


def test_removed_event_says_why_and_added_says_new_or_back(harness):
    h = harness()
    did, doc = dev(1)
    s = SSEStream(h.tcp)
    assert s.next_event()["event"] == "hello"
    h.upsert(did, doc)
    h.command(f"remove {did} lease-expired")
    h.upsert(did, doc)
    added, removed, back = (s.next_event() for _ in range(3))
    assert added["event"] == "added" and added["json"]["arrival"] == "new"
    assert "away-since" not in added["json"]
    assert removed["event"] == "removed" and removed["json"]["reason"] == "lease-expired"
    assert back["event"] == "added" and back["json"]["arrival"] == "back"
    assert back["json"]["away-since"] >= removed["json"]["last-seen"]
    for e in (added, removed, back):
        validate_response("/v1/devices/{id}", 200, e["json"])
    # The listed document itself carries neither: they belong to the events.
    listed = get_json(h.tcp, f"/v1/devices/{did}")
    assert "arrival" not in listed and "reason" not in listed
    s.close()


def test_metrics_count_removals_by_every_reason_from_zero(harness):
    h = harness()
    m = metrics(h.tcp)
    for reason in REASONS:
        assert metric(m, "rsd_device_removals_total", reason=reason) == 0, reason
    assert metric(m, "rsd_device_returns_total") == 0
    assert metric(m, "rsd_device_flaps_total") == 0
    did, doc = dev(1)
    h.upsert(did, doc)
    h.command(f"remove {did} unplugged")
    h.upsert(did, doc)
    h.command(f"remove {did} writer-gone")
    m = metrics(h.tcp)
    assert metric(m, "rsd_device_removals_total", reason="unplugged") == 1
    assert metric(m, "rsd_device_removals_total", reason="writer-gone") == 1
    assert metric(m, "rsd_device_removals_total", reason="stopping") == 0
    assert metric(m, "rsd_device_returns_total") == 1
    assert metric(m, "rsd_gone_devices") == 1


def test_a_gone_camera_answers_410_by_id_serial_and_topic_root_never_seen_404(harness):
    h = harness()
    did, doc = dev(1)
    h.upsert(did, doc)
    h.command(f"remove {did} stopping")
    for key in (did, doc["serial"], doc["topic-root"].replace("/", "%2F")):
        status, _, body = request(h.tcp, f"/v1/devices/{key}")
        assert status == 410, (key, status, body)
        import json
        answer = json.loads(body)
        validate_response("/v1/devices/{id}", 410, answer)
        gone = answer["gone"]
        assert gone["id"] == did and gone["state"] == "gone" and gone["reason"] == "stopping"
        assert gone["last-seen"] == gone["device"]["last-seen"] and gone["removed-at"] >= gone["last-seen"]
        assert gone["device"]["serial"] == doc["serial"]
    status, _, _ = request(h.tcp, "/v1/devices/never-seen")
    assert status == 404
    h.upsert(did, doc)  # back: listed again, no longer gone
    assert get_json(h.tcp, f"/v1/devices/{did}")["id"] == did


def test_device_history_and_table_history(harness):
    h = harness()
    a, adoc = dev(1)
    b, bdoc = dev(2)
    h.upsert(a, adoc)
    h.upsert(b, bdoc)
    h.command(f"remove {a} lease-expired")
    h.upsert(a, adoc)
    h.command(f"remove {b} writer-gone")
    ha = get_json(h.tcp, f"/v1/devices/{a}/history")
    validate_response("/v1/devices/{id}/history", 200, ha)
    assert ha["id"] == a and ha["state"] == "present"
    assert [(c["event"], c.get("reason"), c.get("arrival")) for c in ha["changes"]] == [
        ("added", None, "new"), ("removed", "lease-expired", None), ("added", None, "back")]
    assert ha["removals"] == {r: (1 if r == "lease-expired" else 0) for r in REASONS}
    assert ha["flaps"] == 1 and ha["changes"][2]["flap"] is True  # lost by lease, back at once
    hb = get_json(h.tcp, f"/v1/devices/{bdoc['serial']}/history")  # gone, found by serial
    assert hb["id"] == b and hb["state"] == "gone" and hb["gone"]["reason"] == "writer-gone"
    status, _, _ = request(h.tcp, "/v1/devices/never-seen/history")
    assert status == 404

    whole = get_json(h.tcp, "/v1/history")
    validate_response("/v1/history", 200, whole)
    assert [(c["id"], c["event"]) for c in whole["changes"]] == [
        (a, "added"), (b, "added"), (a, "removed"), (a, "added"), (b, "removed")]
    gens = [c["generation"] for c in whole["changes"]]
    assert gens == sorted(gens) and whole["next"] == whole["generation"]
    page = get_json(h.tcp, "/v1/history?limit=2")
    assert [c["generation"] for c in page["changes"]] == gens[:2] and page["next"] == gens[1]
    rest = get_json(h.tcp, f"/v1/history?since={page['next']}")
    assert [c["generation"] for c in rest["changes"]] == gens[2:]
    for bad in ("since=x", "limit=0", "limit=10001", "nope=1"):
        status, _, _ = request(h.tcp, f"/v1/history?{bad}")
        assert status == 400, bad
