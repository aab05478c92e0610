"""`twin serve --motion-udp PORT`: a UDP listener thread that hands an MRU's datagrams to the
live motion source (`twin.sim.motion_live.LiveMotion`, which parses them).

Trust follows the REST inputs (`twin.web.access`): by default the socket is bound to loopback
and only loopback senders (127.0.0.1, ::1) are read; `--motion-udp-allow ADDRESS` adds a
sender (and binds to all interfaces). A datagram from any other address is counted as
"refused sender" and never parsed, so it never moves the scene.
"""

from __future__ import annotations

import contextlib
import ipaddress
import socket
import threading
import time
from collections.abc import Iterable, Iterator

from twin.errors import TwinError
from twin.sim.motion_live import LiveMotion

#: the senders always read: this machine's own loopback addresses
LOOPBACK_SENDERS = frozenset({"127.0.0.1", "::1"})
#: [bytes] read per datagram: far above a burst of sentences (each ≤ 82 characters)
DATAGRAM = 65_507
#: [s] a blocked receive wakes this often to see whether it was stopped
POLL = 0.2


def allowed_senders(addresses: Iterable[str]) -> frozenset[str]:
    """Loopback plus the given addresses, each normalised (IPv4-mapped IPv6 as IPv4).

    Raises:
        TwinError: an address that is not an IP address (a name could change what it means).
    """
    out = set(LOOPBACK_SENDERS)
    for a in addresses:
        try:
            out.add(str(ipaddress.ip_address(a)))
        except ValueError:
            raise TwinError(f"--motion-udp-allow {a!r}: not an IP address; allowed e.g. "
                            "192.168.1.20 or fd00::20") from None  # fmt: skip
    return frozenset(out)


def _sender(address: str) -> str:
    """The sender's address as `allowed_senders` writes it (::ffff:a.b.c.d as a.b.c.d)."""
    ip = ipaddress.ip_address(address.split("%")[0])
    mapped = getattr(ip, "ipv4_mapped", None)
    return str(mapped or ip)


class MotionListener(threading.Thread):
    """Receives datagrams on `port` and feeds them, from allowed senders only, to `live`."""

    def __init__(self, live: LiveMotion, port: int, allow: Iterable[str] = (),
                 host: str | None = None) -> None:  # fmt: skip
        if not 0 <= int(port) <= 65535:
            raise TwinError(f"--motion-udp {port!r}; allowed 1-65535 (0: any free port)")
        super().__init__(name="motion-udp", daemon=True)
        self.live = live
        self.allowed = allowed_senders(allow)
        bind = host or ("127.0.0.1" if self.allowed == LOOPBACK_SENDERS else "0.0.0.0")
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._sock.bind((bind, int(port)))
        self._sock.settimeout(POLL)
        self.address: tuple[str, int] = self._sock.getsockname()
        self._halt = threading.Event()
        self.cpu_s = 0.0  # [s] CPU time of this thread so far (time.thread_time)

    def run(self) -> None:
        """Receive until stopped; each datagram's samples go to `live` with its arrival."""
        try:
            while not self._halt.is_set():
                try:
                    data, (address, *_rest) = self._sock.recvfrom(DATAGRAM)
                except TimeoutError:
                    continue
                self._take(data, address)
                self.cpu_s = time.thread_time()
        finally:
            self._sock.close()

    def _take(self, data: bytes, address: str) -> None:
        """Hand one datagram from an allowed sender to the live source; count a refused one."""
        if _sender(address) not in self.allowed:
            self.live.count("refused sender")
            return
        self.live.feed(data, time.monotonic())

    def stop(self, timeout: float = 2.0) -> None:
        """Stop receiving and close the socket (returns once the thread ended)."""
        self._halt.set()
        if self.is_alive():
            self.join(timeout)


@contextlib.contextmanager
def listening(
    port: int | None, allow: Iterable[str] = (),
    sensor_position: tuple[float, float, float] = (0.0, 0.0, 0.0),
) -> Iterator[MotionListener | None]:  # fmt: skip
    """`twin serve --motion-udp PORT`: a started listener for the block (None: no port),
    its address printed; stopped on the way out. `sensor_position` [m]: where the sensor
    sits on the hull (`--motion-sensor`), from which the live session moves the motion to
    the mount.

    Raises:
        TwinError: a port out of range or taken, or an allowed sender that is not an address.
    """
    if port is None:
        yield None
        return
    try:
        live = LiveMotion(f"udp :{port}", sensor_position=sensor_position)
        listener = MotionListener(live, port, allow)
    except OSError as exc:
        raise TwinError(f"--motion-udp {port}: cannot bind ({exc.strerror})") from None
    listener.start()
    senders = ", ".join(sorted(listener.allowed))
    print(f"twin: motion sensor on udp {listener.address[0]}:{listener.address[1]} "
          f"(senders {senders})", flush=True)  # fmt: skip
    try:
        yield listener
    finally:
        listener.stop()
