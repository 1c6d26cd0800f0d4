#!/usr/bin/python3
"""A pymodbus 3.0 server implementing the modbus-float32 device profile's map on its own, from
docs/devices.md (not from our C++ code): a sensor module at unit 1 and a current driver at
unit 2, IEEE-754 float32 values with swapped words (low word at the lower address), encoded
and decoded here with Python's struct.

  unit 1, input registers: 0-1 sensor_seq (uint32, +1 per read of the block), 2-3 velocity,
          4-5 displacement, 6-7 demand, 8-9 body_velocity, 10-11 force (float32),
          12 fault_line (uint16), 14-15 grant (uint32, 0: no lockstep)
  unit 2, input register 0 driver_faults (uint16, 0)
  unit 2, holding registers: 0-1 set-point [V] (float32), 2-3 echo (uint32), 4 heartbeat,
          5 status causes, 6 status safe (uint16), 8-9 model force [N], 10-11 force demand
          [N], 12-13 command [V] (float32: live telemetry)
  unit 2, coil 0: enable

  pymodbus_float32.py tcp PORT|rtu LINK [--seconds S] [--nan]
    --nan   velocity is a float32 NaN (the firmware must refuse it: bad_value)
Prints one JSON object when it has seen two command blocks with different heartbeats, the
enable coil on and a non-zero set-point (or after S seconds): {"set_point": ..., "enable":
..., "echo": ..., "heartbeat": ..., "safe": ..., "causes": ..., "seq": ..., "requests": [[unit,
function, address, count], ...]} (the first 50 requests). Run with Debian's /usr/bin/python3.
"""
import argparse
import asyncio
import json
import math
import os
import signal
import struct
import sys

from pymodbus.datastore import (ModbusSequentialDataBlock, ModbusServerContext,
                                ModbusSlaveContext)
from pymodbus.framer.rtu_framer import ModbusRtuFramer
from pymodbus.server import async_io

sys.dont_write_bytecode = True  # no __pycache__ beside the sources
from pymodbus_common import pty_pair_relay  # noqa: E402

VALUES = {"velocity": -12.3456, "displacement": 0.98765, "demand": 456.78,
          "body_velocity": 3.5, "force": -321.09}
state = {"seq": 0, "heartbeats": set(), "last": None}
writes = []


def f32_swapped(x):
    """float32 -> two registers, low word first."""
    hi, lo = struct.unpack(">HH", struct.pack(">f", x))
    return [lo, hi]


def u32_swapped(n):
    return [n & 0xFFFF, (n >> 16) & 0xFFFF]


def from_f32_swapped(lo, hi):
    return struct.unpack(">f", struct.pack(">HH", hi, lo))[0]


class Sensors(ModbusSequentialDataBlock):
    """Unit 1's input registers; a read of the block at 0 advances the seq."""

    def getValues(self, address, count=1):
        if address == 0:
            state["seq"] = (state["seq"] + 1) & 0xFFFFFFFF
            super().setValues(0, u32_swapped(state["seq"]))
        return super().getValues(address, count)


def log_execute(original):
    """Records every request as pymodbus decoded it: [unit, function, address, count]."""
    def execute(self, request, *addr):
        count = getattr(request, "count", None)
        if count is None and isinstance(getattr(request, "values", None), list):
            count = len(request.values)  # 0x0F carries its coils, not a count attribute
        writes.append([request.unit_id, request.function_code,
                       getattr(request, "address", None), count])
        return original(self, request, *addr)
    return execute


class Driver(ModbusSequentialDataBlock):
    """Unit 2's holding registers: the command block, decoded when it is written whole."""

    def setValues(self, address, values):
        super().setValues(address, values)
        if address == 8 and len(values) == 6:  # the live telemetry block, written whole
            r = super().getValues(8, 6)
            state["telemetry"] = {"model_force": from_f32_swapped(r[0], r[1]),
                                  "demand": from_f32_swapped(r[2], r[3]),
                                  "command": from_f32_swapped(r[4], r[5])}
            return
        if address != 0 or len(values) != 7:
            return
        r = super().getValues(0, 7)
        enable = bool(coils.getValues(0, 1)[0])
        state["last"] = {"set_point": from_f32_swapped(r[0], r[1]),
                         "echo": r[2] | (r[3] << 16), "heartbeat": r[4], "causes": r[5],
                         "safe": r[6], "enable": int(enable), "seq": state["seq"]}
        if enable and state["last"]["set_point"] != 0.0:
            state["heartbeats"].add(r[4])
            if len(state["heartbeats"]) >= 2:
                finish()


def finish():
    out = dict(state["last"] or {})
    out["telemetry"] = state.get("telemetry")
    out["requests"] = writes[:50]
    print(json.dumps(out), flush=True)
    os._exit(0)


coils = ModbusSequentialDataBlock(0, [0] * 16)


async def serve(options):
    async_io.ModbusBaseRequestHandler.execute = log_execute(
        async_io.ModbusBaseRequestHandler.execute)
    sensors = Sensors(0, [0] * 32)
    regs = []
    for name in ["velocity", "displacement", "demand", "body_velocity", "force"]:
        v = math.nan if options.nan and name == "velocity" else VALUES[name]
        regs += f32_swapped(v)
    sensors.setValues(2, regs + [0])  # 2..11 values, 12 fault_line = 0
    unit1 = ModbusSlaveContext(ir=sensors, zero_mode=True)
    unit2 = ModbusSlaveContext(ir=ModbusSequentialDataBlock(0, [0] * 16),
                               hr=Driver(0, [0] * 16), co=coils, zero_mode=True)
    context = ModbusServerContext(slaves={1: unit1, 2: unit2}, single=False)
    if options.transport == "tcp":
        asyncio.create_task(async_io.StartAsyncTcpServer(
            context=context, address=("127.0.0.1", int(options.where))))
    else:
        device, keep = pty_pair_relay(options.where)
        asyncio.create_task(async_io.StartAsyncSerialServer(
            context=context, framer=ModbusRtuFramer, port=device, baudrate=115200))
    asyncio.get_running_loop().add_signal_handler(signal.SIGTERM, finish)
    await asyncio.sleep(options.seconds)
    finish()


def main():
    p = argparse.ArgumentParser()
    p.add_argument("transport", choices=["tcp", "rtu"])
    p.add_argument("where")
    p.add_argument("--seconds", type=float, default=20.0)
    p.add_argument("--nan", action="store_true")
    options = p.parse_args()
    sys.setswitchinterval(0.0001)
    asyncio.run(serve(options))
    return 0


if __name__ == "__main__":
    sys.exit(main())
