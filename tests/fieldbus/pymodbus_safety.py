#!/usr/bin/python3
"""A pymodbus 3.0 server playing the current driver of the modbus-float32 map (docs/devices.md,
"Modbus register maps"; encoded here from the document, not from our C++ code) to check the
driver's safety features against the firmware's Modbus client:

  unit 1, input registers: 0-1 sensor_seq (uint32, +1 per read), 2-11 five float32 sensor
          values, 12 fault_line (uint16, 0), 14-15 grant (0); words swapped (low word first)
  unit 2, input register 0: driver_faults (uint16)
  unit 2, holding registers 0-1 set-point (float32), 2-3 echo, 4 heartbeat, 5 causes, 6 safe
  unit 2, coil 0: enable

  pymodbus_safety.py tcp PORT|rtu LINK MODE [--seconds S]
    MODE enable-refused  after 20 driven blocks (enable on, set-point > 0) every write of the
                         enable coil (0x0F / 0x05) gets exception 0x04 (server device failure)
    MODE driver-fault    after 20 driven blocks driver_faults reads 1
    MODE latched-fault   after 20 driven blocks driver_faults reads 1 and stays (latched): a
                         rising edge of coil 1 (fault_reset) is a reset; the first is ignored
                         (the fault persists), the second clears it
    MODE record          serves and records only
Prints one JSON object when the firmware answered the fault (enable-refused: two command
blocks with the safe flag, set-point 0 and different heartbeats after the first refusal;
driver-fault: a block with the safe flag and cause bit 4, fault_line;
latched-fault: 1.5 s after the fault cleared) or after S seconds:
{"fault_at": index of the first block after the fault began (null: never began),
 "blocks": [[set_point, enable, heartbeat, causes, safe], ...] (every command block written),
 "refused": enable writes refused, "writes": the first 4000 write requests [unit, function,
 address], "resets": seconds of each reset edge after the first}; unit 2 holds 16 registers: a write beyond them gets exception 0x02.
Run with Debian's /usr/bin/python3.
"""
import argparse
import asyncio
import json
import logging
import os
import signal
import struct
import sys
import time

from pymodbus.datastore import (ModbusSequentialDataBlock, ModbusServerContext,
                                ModbusSlaveContext)
from pymodbus.framer.rtu_framer import ModbusRtuFramer
from pymodbus.server import async_io

sys.dont_write_bytecode = True  # no __pycache__ beside the sources
from pymodbus_common import pty_pair_relay  # noqa: E402

FAULT_LINE_BIT = 1 << 4
state = {"seq": 0, "driven": 0, "fault_at": None, "refused": 0, "reset_coil": 0,
         "cleared_at": None}
resets = []
blocks, writes = [], []
options = None


def f32_swapped(x):
    hi, lo = struct.unpack(">HH", struct.pack(">f", x))
    return [lo, hi]


def from_f32_swapped(lo, hi):
    return struct.unpack(">f", struct.pack(">HH", hi, lo))[0]


class Sensors(ModbusSequentialDataBlock):
    def getValues(self, address, count=1):
        if address == 0:
            state["seq"] = (state["seq"] + 1) & 0xFFFFFFFF
            super().setValues(0, [state["seq"] & 0xFFFF, state["seq"] >> 16])
        return super().getValues(address, count)


class Coils(ModbusSequentialDataBlock):
    """Unit 2's coils: once the fault began (enable-refused) a write raises, which pymodbus
    answers with exception 0x04 (server device failure); the coil keeps its value."""

    def setValues(self, address, values):
        if options.mode == "enable-refused" and state["fault_at"] is not None:
            state["refused"] += 1
            raise RuntimeError("enable write refused (the test's fault)")
        super().setValues(address, values)
        if options.mode == "latched-fault" and address <= 1 < address + len(values):
            reset = int(values[1 - address])
            if reset and not state["reset_coil"] and state["fault_at"] is not None:
                resets.append(time.monotonic())
                if len(resets) == 2:  # the second reset clears the latched fault
                    driver_inputs.setValues(0, [0])
                    state["cleared_at"] = time.monotonic()
            state["reset_coil"] = reset


coils = Coils(0, [0] * 16)  # 0 enable, 1 fault_reset (latched-fault)
driver_inputs = ModbusSequentialDataBlock(0, [0] * 16)


def fault_began():
    if state["fault_at"] is None:
        state["fault_at"] = len(blocks)
        if options.mode in ("driver-fault", "latched-fault"):
            driver_inputs.setValues(0, [1])


class Driver(ModbusSequentialDataBlock):
    """Unit 2's holding registers: a command block written whole is decoded."""

    def setValues(self, address, values):
        super().setValues(address, values)
        if address != 0 or len(values) != 7:
            return
        r = super().getValues(0, 7)
        enable = int(coils.getValues(0, 1)[0])
        set_point = from_f32_swapped(r[0], r[1])
        blocks.append([set_point, enable, r[4], r[5], r[6]])
        if enable and set_point > 0.0 and r[6] == 0:
            state["driven"] += 1
        if state["driven"] >= 20 and options.mode != "record":
            fault_began()
        check_answered()


def check_answered():
    at = state["fault_at"]
    if at is None:
        return
    after = blocks[at:]
    if options.mode == "enable-refused":
        safe = [b for b in after if b[4] == 1 and b[0] == 0.0]
        if len({b[2] for b in safe}) >= 2:
            finish()
    elif options.mode == "latched-fault":
        if state["cleared_at"] is not None and time.monotonic() - state["cleared_at"] > 1.5:
            finish()
    elif options.mode == "driver-fault":
        if any(b[4] == 1 and (b[3] & FAULT_LINE_BIT) for b in after):
            finish()


def log_execute(original):
    def execute(self, request, *addr):
        fc = request.function_code
        if fc in (0x05, 0x06, 0x0F, 0x10):
            writes.append([request.unit_id, fc, getattr(request, "address", None)])
        return original(self, request, *addr)
    return execute


def finish():
    print(json.dumps({"fault_at": state["fault_at"], "blocks": blocks,
                      "refused": state["refused"], "writes": writes[:4000],
                      "resets": [t - resets[0] for t in resets]}), flush=True)
    os._exit(0)


async def serve():
    async_io.ModbusBaseRequestHandler.execute = log_execute(
        async_io.ModbusBaseRequestHandler.execute)
    sensors = Sensors(0, [0] * 32)
    regs = []
    for v in (-12.5, 0.5, 450.0, 3.5, -320.0):
        regs += f32_swapped(v)
    sensors.setValues(2, regs + [0])
    unit1 = ModbusSlaveContext(ir=sensors, zero_mode=True)
    unit2 = ModbusSlaveContext(ir=driver_inputs, hr=Driver(0, [0] * 16), co=coils,
                               zero_mode=True)
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
    global options
    p = argparse.ArgumentParser()
    p.add_argument("transport", choices=["tcp", "rtu"])
    p.add_argument("where")
    p.add_argument("mode", choices=["enable-refused", "driver-fault", "latched-fault", "record"])
    p.add_argument("--seconds", type=float, default=20.0)
    options = p.parse_args()
    sys.setswitchinterval(0.0001)
    logging.getLogger("pymodbus").setLevel(logging.CRITICAL)  # the refusals are the test's
    asyncio.run(serve())
    return 0


if __name__ == "__main__":
    sys.exit(main())
