"""python -m rsdiscovery: a small command line over the package, for machines that have
Python but not the rs-discover tool. The same exit status as rs-discover: 0 ok, 1 not
found or timed out, 2 usage error, 3 daemon unreachable, 4 reply not understood."""
import argparse
import json
import sys
from typing import Any, Dict, List, Optional

from . import (Client, DaemonNotRunning, Device, MalformedReply, NotFound, PermissionDenied, RSDiscoveryError,
               VersionMismatch, __version__)


def _filters(p: argparse.ArgumentParser) -> None:
    p.add_argument("-d", "--domain", type=int, action="append",
                   help="only this DDS domain (0-232); repeat for several")
    p.add_argument("--product-line", help="only this product line, e.g. D400 (any case)")
    p.add_argument("--source", choices=["dds", "usb", "remote-usb"], type=str.lower, help="only cameras seen by this source")
    p.add_argument("--host", metavar="NAME",
                   help="only the USB cameras the daemon on host NAME shares (remote-usb; any case)")


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m rsdiscovery",
                                description="Ask rs-discoveryd which RealSense cameras are there.")
    p.add_argument("--endpoint", help="unix:/path or http://host:port (default: $RS_DISCOVERY_ENDPOINT, "
                                      "else the daemon's default socket)")
    p.add_argument("--json", action="store_true", help="print the daemon's JSON instead of a table")
    p.add_argument("--version", action="version", version=f"rsdiscovery {__version__}")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    _filters(sub.add_parser("list", help="the cameras there now"))
    g = sub.add_parser("get", help="cameras by id, serial or topic-root")
    g.add_argument("ids", nargs="+", metavar="ID")
    w = sub.add_parser("wait", help="wait until cameras are there; print the first")
    w.add_argument("--count", type=int, default=1, help="how many must be there (default 1)")
    w.add_argument("--timeout", type=float, default=10.0, help="seconds (default 10)")
    _filters(w)
    _filters(sub.add_parser("watch", help="one line per camera added, changed or removed, until Ctrl-C"))
    sub.add_parser("domains", help="the DDS domains the daemon joined")
    pa = sub.add_parser("participants", help="who is on the DDS network (cameras, programs, tools)")
    pa.add_argument("-d", "--domain", type=int, action="append", help="only this DDS domain; repeat for several")
    pa.add_argument("-a", "--all", action="store_true", help="also those gone")
    sub.add_parser("health", help="the daemon's health")
    return p


def _table(devices: List[Device]) -> str:
    rows = [("ID", "NAME", "SERIAL", "SOURCE", "STATE")]
    for d in devices:
        rows.append((d.id, d.name, d.serial or "", ",".join(d.sources), d.state))
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    return "\n".join("  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip() for r in rows)


def _print(args: argparse.Namespace, data: Any, devices: Optional[List[Device]] = None) -> None:
    if args.json or devices is None:
        print(json.dumps(data, indent=None if args.json else 2))
    else:
        print(_table(devices))


def run(argv: Optional[List[str]] = None) -> int:
    args = _parser().parse_args(argv)
    try:
        client = Client(args.endpoint)
        filters: Dict[str, Any] = {k: getattr(args, k, None) for k in ("domain", "product_line", "source", "host")}
        if args.command == "list":
            devices = client.list_devices(**filters)
            _print(args, [d.raw for d in devices], devices)
        elif args.command == "get":
            devices = [client.get_device(i) for i in args.ids]
            _print(args, [d.raw for d in devices] if len(devices) > 1 else devices[0].raw, devices)
        elif args.command == "wait":
            device = client.wait_for(timeout=args.timeout, count=args.count, **filters)
            _print(args, device.raw, [device])
        elif args.command == "watch":
            for e in client.watch(**filters):
                if args.json:
                    print(json.dumps({"event": e.type, "id": e.id, "device": e.device.raw}), flush=True)
                else:
                    print(f"{e.type:8} {e.device.id}  {e.device.name}", flush=True)
        elif args.command == "domains":
            print(json.dumps([d.raw for d in client.domains()], indent=None if args.json else 2))
        elif args.command == "participants":
            found = client.participants(args.domain, None if args.all else "alive")
            print(json.dumps([p.raw for p in found], indent=None if args.json else 2))
        elif args.command == "health":
            h = client.health()
            if args.json:
                print(json.dumps(h.raw))
            else:  # the line rs-discover health prints
                print(f"{h.status}: rs-discoveryd {h.version or '(version unknown)'} at {client.endpoint}, "
                      f"{h.devices} device{'' if h.devices == 1 else 's'}"
                      f"{'' if h.complete else ' so far (first discovery still running)'}")
            return 0 if h.status == "ok" else 1
    except KeyboardInterrupt:
        return 0
    except ValueError as e:  # a bad argument the parser let through (a domain of 300)
        print(f"python -m rsdiscovery: {e}", file=sys.stderr)
        return 2
    except (NotFound, TimeoutError) as e:
        print(f"python -m rsdiscovery: {e}", file=sys.stderr)
        return 1
    except (DaemonNotRunning, PermissionDenied) as e:
        # The library's hint names its endpoint= argument; here it is an option.
        print(f"python -m rsdiscovery: {str(e).replace(' with endpoint= ', ' with --endpoint ')}", file=sys.stderr)
        return 3
    except (MalformedReply, VersionMismatch, RSDiscoveryError) as e:
        print(f"python -m rsdiscovery: {e}", file=sys.stderr)
        return 4
    return 0


if __name__ == "__main__":
    sys.exit(run())
