#!/usr/bin/python3
"""An independent Modbus peer (Debian's python3-pymodbus) for the register map of
docs/modbus_registers.md, encoded and decoded here from the document, not from our C++ code.

  pymodbus_peer.py server-tcp PORT   serve a fixed sensor block on 127.0.0.1:PORT
  pymodbus_peer.py server-rtu LINK   the same over RTU: LINK becomes a pty the client opens
      Both print one JSON line with the decoded command block once a client has written a
      set-point with enable on and two different heartbeats, then exit 0 (exit 1 after 20 s).
  pymodbus_peer.py client-tcp HOST:PORT   read mrd-hil's sensor block, write set-points
  pymodbus_peer.py client-rtu LINK        the same over RTU on mrd-hil's pty
      Print one JSON line with what was read and whether a write to the sensor block was
      refused with an exception; exit 0, or 1 on a failed request.
Run with Debian's /usr/bin/python3 (the package is not in other interpreters).
"""
import asyncio
import json
import os
import sys
import time

from pymodbus.datastore import (ModbusSequentialDataBlock, ModbusServerContext,
                                ModbusSlaveContext)
from pymodbus.framer.rtu_framer import ModbusRtuFramer

sys.dont_write_bytecode = True  # no __pycache__ beside the sources
from pymodbus_common import (COMMAND_BASE, COMMAND_COUNT, MAP_SIZE,  # noqa: E402
                             SENSOR_BASE, SENSOR_COUNT, pty_pair_relay)

VELOCITY_LSB, DISPLACEMENT_LSB, FORCE_LSB, SETPOINT_LSB = 1e-4, 1e-5, 1e-2, 1e-3

# The sensor block the servers hold.
SENSORS = {"seq": 7, "velocity": -12.3456, "displacement": 0.98765, "demand": 456.78,
           "body_velocity": 3.5, "force": -321.09}


def u32_regs(value):
    value &= 0xFFFFFFFF
    return [value >> 16, value & 0xFFFF]  # high word first


def i32_regs(value, lsb):
    return u32_regs(round(value / lsb))


def regs_i32(hi, lo, lsb):
    v = (hi << 16) | lo
    if v & 0x80000000:
        v -= 1 << 32
    return v * lsb


def sensor_block(s):
    return (u32_regs(s["seq"]) + i32_regs(s["velocity"], VELOCITY_LSB)
            + i32_regs(s["displacement"], DISPLACEMENT_LSB) + i32_regs(s["demand"], FORCE_LSB)
            + i32_regs(s["body_velocity"], VELOCITY_LSB) + i32_regs(s["force"], FORCE_LSB) + [0])


def decode_sensors(r):
    return {"seq": (r[0] << 16) | r[1], "velocity": regs_i32(r[2], r[3], VELOCITY_LSB),
            "displacement": regs_i32(r[4], r[5], DISPLACEMENT_LSB),
            "demand": regs_i32(r[6], r[7], FORCE_LSB),
            "body_velocity": regs_i32(r[8], r[9], VELOCITY_LSB),
            "force": regs_i32(r[10], r[11], FORCE_LSB), "faults": r[12]}


def decode_command(r):
    sp = r[2] - 0x10000 if r[2] & 0x8000 else r[2]
    return {"echo": (r[0] << 16) | r[1], "set_point": None if r[2] == 0x8000 else sp * SETPOINT_LSB,
            "enable": r[3], "heartbeat": r[4], "state": r[5], "causes": r[6],
            "ticks": (r[7] << 16) | r[8]}


async def serve(mode, where):
    from pymodbus.server import StartAsyncSerialServer, StartAsyncTcpServer
    block = ModbusSequentialDataBlock(0, [0] * MAP_SIZE)
    block.setValues(SENSOR_BASE, sensor_block(SENSORS))
    block.setValues(COMMAND_BASE + 2, [0x8000, 0xFFFF])  # no set-point, enable not driven
    slave = ModbusSlaveContext(hr=block, zero_mode=True)
    context = ModbusServerContext(slaves=slave, single=True)
    if mode == "server-tcp":
        server_task = asyncio.create_task(
            StartAsyncTcpServer(context=context, address=("127.0.0.1", int(where))))
    else:
        device, keep = pty_pair_relay(where)
        server_task = asyncio.create_task(StartAsyncSerialServer(
            context=context, framer=ModbusRtuFramer, port=device, baudrate=115200))
    heartbeats = set()
    deadline = time.monotonic() + 20.0
    while time.monotonic() < deadline:
        await asyncio.sleep(0.005)
        c = decode_command(slave.getValues(3, COMMAND_BASE, COMMAND_COUNT))
        if c["set_point"] is not None and c["enable"] == 1:
            heartbeats.add(c["heartbeat"])
            if len(heartbeats) >= 2:
                print(json.dumps(c), flush=True)
                os._exit(0)
    server_task.cancel()
    print(json.dumps({"error": "no command written"}), flush=True)
    os._exit(1)


def client(mode, where):
    from pymodbus.client import ModbusSerialClient, ModbusTcpClient
    if mode == "client-tcp":
        host, port = where.rsplit(":", 1)
        c = ModbusTcpClient(host, port=int(port), timeout=1)
    else:
        c = ModbusSerialClient(port=where, framer=ModbusRtuFramer, baudrate=115200, timeout=1)
    if not c.connect():
        print(json.dumps({"error": "cannot connect"}), flush=True)
        return 1
    reads = []
    t_end = time.monotonic() + 1.0
    heartbeat = 0
    while time.monotonic() < t_end:
        r = c.read_holding_registers(SENSOR_BASE, SENSOR_COUNT, slave=1)
        if r.isError():
            print(json.dumps({"error": "read: %s" % r}), flush=True)
            return 1
        s = decode_sensors(r.registers)
        reads.append(s)
        heartbeat = (heartbeat + 1) & 0xFFFF
        # set-point 1.5 V, enable on, echo of the seq just read, a fresh heartbeat, status off
        w = c.write_registers(COMMAND_BASE, u32_regs(s["seq"]) + [1500, 1, heartbeat, 0, 0, 0, 0],
                              slave=1)
        if w.isError():
            print(json.dumps({"error": "write: %s" % w}), flush=True)
            return 1
        time.sleep(0.01)
    bad = c.write_registers(SENSOR_BASE, [0, 1], slave=1)  # the sensor block is read-only
    c.close()
    print(json.dumps({
        "reads": len(reads), "first": reads[0], "last": reads[-1],
        "seq_increasing": all(b["seq"] > a["seq"] for a, b in zip(reads, reads[1:])),
        "sensor_write_refused": bad.isError(),
        "sensor_write_exception": getattr(bad, "exception_code", None)}), flush=True)
    return 0


def main():
    if len(sys.argv) != 3:
        print(__doc__, file=sys.stderr)
        return 2
    mode, where = sys.argv[1], sys.argv[2]
    if mode.startswith("server-"):
        asyncio.run(serve(mode, where))
        return 1
    if mode.startswith("client-"):
        return client(mode, where)
    print(__doc__, file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
