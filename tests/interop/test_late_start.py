"""Cyclone can be matched and written to by a realdds server before it knows the
server's writer, and a volatile reader never gets that broadcast back (seen in 6
of 15 late starts). The daemon must end up with every device anyway."""
from conftest import device_info, wait_for

RUNS = 20


def test_daemon_started_after_servers_lists_every_device_every_time(free_domain, daemon, realdds_server):
    realdds_server(free_domain, [device_info(n) for n in range(1, 4)], name="server-a")
    realdds_server(free_domain, [device_info(n) for n in range(4, 7)], name="server-b")
    realdds_server(free_domain, [device_info(n) for n in range(7, 9)], name="server-c")
    for run in range(RUNS):
        d = daemon([free_domain])
        wait_for(lambda: len(d.devices()) == 8, timeout=20, what=f"all 8 devices on run {run + 1}")
        assert d.stop() == 0
