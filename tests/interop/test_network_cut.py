"""Network cuts between the daemon and a realdds server on another host (network
namespaces, nftables drop rules: the link stays up). Cyclone DDS never finds a
server again on the same participant after a cut that outlasted its lease of the
server but not the server's lease of us; the daemon must heal by itself.

For each cut: a cut longer than realdds' 3 s lease removes the remote camera
within lease + 1 s of the cut; after the heal it is listed again within 5 s, without a
restart; the camera of a healthy server beside the daemon sees no event at all.

CI runs the cuts in RSD_CUTS (default "2 5 12"); the full sweep is
    RSD_CUTS="1 2 3 5 8 12 20" ctest --test-dir build -R interop_network_cut -V
and prints its table of times.
"""
import os
import time

from conftest import EventStream, device_info, wait_for
from netns import two_hosts  # noqa: F401 (a fixture)
from test_realdds import LEASE_S, dds_id

CUTS = [float(c) for c in os.environ.get("RSD_CUTS", "2 5 12").split()]
REMOVE_WITHIN_S = LEASE_S + 1.0
BACK_WITHIN_S = 5.0


def test_cuts_heal_by_themselves(free_domain, daemon, realdds_server, two_hosts):
    net = two_hosts
    remote_cam, local_cam = device_info(1), device_info(2)
    realdds_server(free_domain, [remote_cam], name="remote-server", prefix=net.prefix(net.camera))
    realdds_server(free_domain, [local_cam], name="local-server", prefix=net.prefix(net.host))
    d = daemon([free_domain], http=False, prefix=net.prefix(net.host))
    remote, local = dds_id(free_domain, remote_cam), dds_id(free_domain, local_cam)
    wait_for(lambda: d.device_ids() == sorted([remote, local]), timeout=20, what="both cameras")
    remote_server = {x["id"]: x for x in d.devices()}[remote]["server"]
    assert net.camera_ip in remote_server["addresses"], remote_server

    def domain():
        return d.get_json("/v1/domains")["domains"][0]

    assert domain()["refreshes"] == 0, "a domain that lost no server never refreshes"

    def stays_listed(seconds):
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            if remote not in d.device_ids():
                return False
            time.sleep(0.05)
        return True

    events = EventStream(d)
    rows = []
    for cut_s in CUTS:
        refreshes_before = domain()["refreshes"]
        net.cut()
        t_cut = time.monotonic()
        removed_after = None
        while time.monotonic() - t_cut < cut_s:
            if removed_after is None and remote not in d.device_ids():
                removed_after = time.monotonic() - t_cut
            time.sleep(0.02)
        net.heal()
        t_heal = time.monotonic()
        back_after = None
        while time.monotonic() - t_heal < 30:
            ids = d.device_ids()
            if removed_after is None and remote not in ids:
                removed_after = time.monotonic() - t_cut
            if remote in ids and (removed_after is not None or cut_s <= LEASE_S):
                back_after = time.monotonic() - t_heal
                break
            time.sleep(0.02)
        # Wait for the looking to end before the next cut (a server that is back
        # is no longer lost).
        wait_for(lambda: domain()["lost-servers"] == 0 and remote in d.device_ids(), timeout=30,
                 what=f"the remote server found again after the {cut_s} s cut")
        # The next cut starts from a lease renewed after this heal (else its
        # countdown began in this cut): the camera stays listed for a lease.
        wait_for(lambda: stays_listed(LEASE_S + 0.5), timeout=30, what="the remote camera steady")
        refreshes = domain()["refreshes"] - refreshes_before
        rows.append((cut_s, removed_after, back_after, refreshes))
        print(f"cut {cut_s:5.1f} s: removed after {removed_after}, listed again {back_after} s after the heal, "
              f"{refreshes} refresh(es)")
        if cut_s > LEASE_S + 1.0:
            assert removed_after is not None and removed_after <= REMOVE_WITHIN_S, (cut_s, removed_after)
        # The lease runs from the last message heard, up to 1.5 s (realdds'
        # re-announce period) before the cut: only a cut under half the lease
        # never removes anything (a 2 s cut removed the camera after 1.62 s).
        if cut_s <= LEASE_S / 2:
            assert removed_after is None, f"a {cut_s} s cut is shorter than the lease: nothing to remove"
            assert refreshes == 0
        assert back_after is not None and back_after <= BACK_WITHIN_S, (cut_s, back_after, d.log()[-3000:])

    # The healthy server's camera saw no event at all through every cut and refresh.
    seen = []
    while not events.events.empty():
        ev = events.events.get()
        if ev and ev.get("event") in ("added", "changed", "removed"):
            seen.append((ev["event"], ev["json"]["id"]))
    assert not [e for e in seen if e[1] == local], seen
    assert ("removed", remote) in seen or all(c < LEASE_S for c in CUTS)
    events.close()
    print("\n| cut (s) | removed after (s) | listed again after the heal (s) | refreshes |")
    print("| --- | --- | --- | --- |")
    for cut_s, removed, back, refreshes in rows:
        fmt = (lambda v: "not removed" if v is None else f"{v:.2f}")
        print(f"| {cut_s:g} | {fmt(removed)} | {back:.2f} | {refreshes} |")
