"""Other Cyclone DDS versions on the device-info topic: PyPI's cyclonedds 11 (its
own libddsc, XTypes type information on every endpoint) writing and reading
beside the daemon. One such peer used to crash the daemon inside libddsc while it
parsed the peer's type object (issue 8): the daemon must keep running, take the
peer's device-info by type name, and keep serving realdds as before."""
import json

import pytest

from conftest import device_info, wait_for
from test_realdds import dds_id

# uint8 octets give a type id other than idlc's: the peer whose type object the
# old daemon asked for, and crashed on; byte octets give idlc's own type id.
@pytest.mark.parametrize("octet", ["uint8", "byte"])
def test_cyclone11_writer_and_reader_beside_realdds(free_domain, daemon, realdds_server, cyclone_peer, octet):
    camera = device_info(1)
    realdds = realdds_server(free_domain, [camera])
    d = daemon([free_domain])
    wait_for(lambda: d.device_ids() == [dds_id(free_domain, camera)], what="the realdds camera")

    reader = cyclone_peer(free_domain, "reader", octet)
    assert reader.next() == {"reading": True}
    writer = cyclone_peer(free_domain, "writer", octet)
    assert writer.next() == {"matched": True}
    other = device_info(2, name="Cyclone 11 test device")
    # A writer that was just matched may write before the daemon's Cyclone knows
    # it (then the sample is lost for good): write until the daemon lists it.
    def listed():
        if d.proc.poll() is not None:
            pytest.fail(f"the daemon died ({d.proc.returncode}):\n{d.log()[-3000:]}")
        if dds_id(free_domain, other) in d.device_ids():
            return True
        writer.send(json=other)
        return False
    wait_for(listed, timeout=20, interval=0.5, what="the Cyclone 11 writer's device")
    dev = {x["id"]: x for x in d.devices()}[dds_id(free_domain, other)]
    assert dev["name"] == "Cyclone 11 test device" and dev["serial"] == other["serial"]
    # Cyclone 11 announces its multicast locator among its addresses: not the camera's.
    assert dev["server"]["addresses"] and not any(a.startswith("239.") for a in dev["server"]["addresses"])
    # The peer's reader is a working reader on the same topic (whether it catches
    # realdds' one broadcast is the late-reader race of any Cyclone reader).
    writer.send(json=other)
    wait_for(lambda: any(other["topic-root"] in x.get("data", "") for x in reader.drain()), timeout=20,
             what="the Cyclone 11 reader receiving the Cyclone 11 writer's device-info")

    # realdds is served as before, with the peers still there.
    late = device_info(3)
    realdds.command(cmd="add", info=late)
    wait_for(lambda: dds_id(free_domain, late) in d.device_ids(), what="a new realdds device")
    realdds.command(cmd="disconnect", **{"topic-root": camera["topic-root"]})
    wait_for(lambda: dds_id(free_domain, camera) not in d.device_ids(), what="a realdds 'stopping'")

    # The peer going away takes its device with it (its writer is gone).
    writer.close()
    wait_for(lambda: dds_id(free_domain, other) not in d.device_ids(), what="the Cyclone 11 device removed")
    reader.close()
    assert d.proc.poll() is None, d.log()[-3000:]
    assert d.healthy()
    realdds.quit()



def test_a_single_writer_whose_broadcast_was_lost_is_asked_again(free_domain, daemon, cyclone_peer):
    """A one-device server matches one writer (pyrealdds 2.59.1 in most runs): if
    the broadcast to the daemon is lost (the discovery race of realdds-wire.md),
    that single silent writer must make the daemon ask again. The peer here loses
    its first broadcast on purpose; it announces again, as realdds does, whenever a
    reader matches. Before, one silent writer was taken for realdds' idle writer and
    the camera was never listed."""
    d = daemon([free_domain])
    camera = device_info(7, name="Lost-broadcast camera")
    peer = cyclone_peer(free_domain, "announcer", "byte",
                        extra=["--device", json.dumps(camera), "--lose-first", "1"])
    assert peer.next() == {"announcing": True}
    assert peer.next() == {"matched": 1, "sent": False}  # the daemon's reader: broadcast lost
    # The silent grace (2.5 s), then a new reader: the peer matches it and announces.
    assert peer.next(timeout=15) == {"matched": 2, "sent": True}
    wait_for(lambda: d.device_ids() == [dds_id(free_domain, camera)], timeout=5, what="the camera listed")
    assert "1 writer(s) that matched but sent no device-info" in d.log()
    peer.close()
    wait_for(lambda: d.device_ids() == [], what="the camera gone with its writer")
