"""Which client a request counts under: every per-client limit counts an address by its prefix.

The connection cap of `hcss serve` (hcss.platform.serving.connections), the
Starts of the public study link (`ratelimit`), the console's sign-in lockout
and the live API's commands all count a client the same way.
"""

from __future__ import annotations

import ipaddress

from flask import current_app, request

#: IPv4 addresses are counted by this prefix (HCSS_CLIENT_PREFIX_V4: 32, or 24 where one
#: holder gets a whole /24); IPv6 by its /64, the block one subscriber gets.
IPV4_PREFIX, IPV6_PREFIX = 32, 64


def client_prefix(address: str | None, ipv4_bits: int = IPV4_PREFIX) -> str:
    """The network an address is counted in by every per-client limit.

    One holder of an IPv6 /64 has 2^64 addresses, so a limit per address
    would bound nothing there; an IPv4-mapped IPv6 address is its IPv4 one.
    Anything that is not an address (a test's "?") is its own client.
    """
    if not address:
        return "?"
    try:
        ip = ipaddress.ip_address(address.strip("[]"))
    except ValueError:
        return address
    if ip.version == 6 and ip.ipv4_mapped is not None:
        ip = ip.ipv4_mapped
    bits = ipv4_bits if ip.version == 4 else IPV6_PREFIX
    return str(ipaddress.ip_network(f"{ip}/{bits}", strict=False))


def request_client() -> str:
    """The client every per-client limit counts this request under: its address's prefix."""
    return client_prefix(request.remote_addr, int(current_app.config.get("CLIENT_PREFIX_V4", 32)))
