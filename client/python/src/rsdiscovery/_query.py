"""The filters as the daemon takes them, argument checks, and when an answer is complete."""
from __future__ import annotations

import urllib.parse
from typing import Any, Dict, Iterable, List, Mapping, Optional, Tuple, Union

#: A ``domain`` argument: one DDS domain id, several (a list, tuple, set, range ...), or
#: None for every domain the daemon joined.
Domains = Union[int, Iterable[int], None]


def _domains(domain: Domains) -> Tuple[int, ...]:
    """The domains a ``domain`` argument names: none (None), one, or several (any iterable of
    them; the daemon takes the query parameter repeated). A bad one is the caller's mistake:
    a ValueError at once, never a request the daemon would answer with 400."""
    if domain is None:
        return ()
    several = isinstance(domain, Iterable) and not isinstance(domain, (str, bytes, Mapping))
    values: List[Any] = list(domain) if several else [domain]  # type: ignore[arg-type]
    if not values:
        raise ValueError("domain must be a DDS domain id or several, not an empty collection (None: every domain)")
    for d in values:
        if isinstance(d, bool) or not isinstance(d, int) or not 0 <= d <= 232:
            raise ValueError(f"domain must be a DDS domain id, a whole number from 0 to 232, or several of them, "
                             f"not {domain!r}")
    return tuple(sorted(set(values)))


def _check_filters(domain: Domains, product_line: Optional[str], source: Optional[str],
                   serial: Optional[str] = None, name: Optional[str] = None, address: Optional[str] = None,
                   host: Optional[str] = None, in_use: Optional[bool] = None) -> None:
    """Bad filter arguments are the caller's mistake: a ValueError at once, never a
    request the daemon would answer with 400 (or, worse, one that filters nothing)."""
    _domains(domain)
    if product_line is not None and (not isinstance(product_line, str) or not product_line.strip()):
        raise ValueError(f"product_line must be a non-empty string such as 'D400', not {product_line!r}")
    if source is not None and (not isinstance(source, str) or source.lower() not in ("dds", "usb", "remote-usb")):
        raise ValueError(f"source must be 'dds', 'usb' or 'remote-usb', not {source!r}")
    for key, value in (("serial", serial), ("name", name), ("address", address), ("host", host)):
        if value is not None and (not isinstance(value, str) or not value.strip()):
            raise ValueError(f"{key} must be a non-empty string, not {value!r}")
    # The daemon's ?host= selects remote-usb cameras only: with another source it would
    # answer an empty list, which reads as "no such camera" rather than as the mistake.
    if host is not None and source is not None and source.lower() != "remote-usb":
        raise ValueError(f"host selects another host's cameras (source 'remote-usb'), not source {source!r}")
    if in_use is not None and not isinstance(in_use, bool):
        raise ValueError(f"in_use must be True, False or None, not {in_use!r}")


def _check_seconds(name: str, value: Any, allow_zero: bool = True) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or value < 0 or (value == 0 and not allow_zero):
        raise ValueError(f"{name} must be a number of seconds {'>= 0' if allow_zero else '> 0'}, not {value!r}")


def _query(domain: Domains, product_line: Optional[str], source: Optional[str],
           serial: Optional[str] = None, name: Optional[str] = None, address: Optional[str] = None,
           host: Optional[str] = None, in_use: Optional[bool] = None) -> str:
    """The filters as the daemon takes them (it filters; the package never filters again)."""
    domains = _domains(domain)  # once: an iterator is empty the second time
    _check_filters(domains or None, product_line, source, serial, name, address, host, in_use)
    q: List[Tuple[str, str]] = [("domain", str(d)) for d in domains]
    for key, value in (("product-line", product_line), ("source", source), ("serial", serial), ("name", name),
                       ("address", address), ("host", host)):
        if value:
            q.append((key, value))
    if in_use is not None:
        q.append(("in-use", "true" if in_use else "false"))
    return ("?" + urllib.parse.urlencode(q)) if q else ""


_NOT_NEWS = ("last-seen", "first-seen", "reason", "arrival", "away-since")


def _same(a: Mapping[str, Any], b: Mapping[str, Any]) -> bool:
    """Equal apart from last-seen, which moves without being news, first-seen, which a
    restarted daemon sets anew for a camera that never went away, and what an event
    says of its change (a removal's reason, an addition's arrival), which no list has."""
    return {k: v for k, v in a.items() if k not in _NOT_NEWS} == {k: v for k, v in b.items() if k not in _NOT_NEWS}


def _complete(doc: Dict[str, Any]) -> bool:
    """Whether an answer says the daemon's first discovery is over. One without the field
    (a daemon older than it) has nothing to wait for."""
    return doc.get("complete") is not False


# How often an answer from an incomplete table is asked again, in seconds. The first
# discovery ends a few seconds after the daemon starts, at no moment a client can know.
_COMPLETE_POLL = 0.05
