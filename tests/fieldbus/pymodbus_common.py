"""What the pymodbus peers of the tests share (pymodbus_peer.py, pymodbus_driver.py,
pymodbus_conformance.py): the register map's addresses, taken from docs/modbus_registers.md
(not from our C++ code), and an RTU null-modem link on pseudo-terminals.
"""
import os
import select
import threading
import tty

# The map, from docs/modbus_registers.md.
SENSOR_BASE, SENSOR_COUNT = 0, 13
COMMAND_BASE, COMMAND_COUNT = 32, 9
MAP_SIZE = 48  # holding registers 0..47


def pty_pair_relay(link):
    """Two pty pairs whose masters are relayed: LINK -> slave A (the client opens it);
    returns the name of slave B (pymodbus opens it): a null-modem cable."""
    ma, sa = os.openpty()
    mb, sb = os.openpty()
    for fd in (sa, sb):
        tty.setraw(fd)
    if os.path.lexists(link):
        os.unlink(link)
    os.symlink(os.ttyname(sa), link)

    def relay():
        while True:
            ready, _, _ = select.select([ma, mb], [], [], 0.1)
            for fd in ready:
                try:
                    data = os.read(fd, 512)
                except OSError:
                    continue
                os.write(mb if fd == ma else ma, data)

    threading.Thread(target=relay, daemon=True).start()
    return os.ttyname(sb), (sa, sb)  # keep the slaves open: no EIO on the masters
