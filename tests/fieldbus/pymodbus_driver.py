#!/usr/bin/python3
"""A pymodbus 3.0 server playing the sensor module / current driver of
docs/modbus_registers.md against the firmware's Modbus client (Debian's python3-pymodbus; the
map is encoded here from the document, not from our C++ code). It serves the sensor block
(its seq advances with every read, so the client always has new data), and records every
request and every command block written, each with time.monotonic() (CLOCK_MONOTONIC) when
pymodbus processed it.

  pymodbus_driver.py tcp PORT|rtu LINK [options]
    --seconds S         stop after S seconds (default 20); SIGTERM stops too
    --faults N          inject N faults, one after every 20 driven command blocks (enable 1),
                        rotating: exception (reads get exception 0x04), bad_value (reads
                        carry a reserved fault bit), fault_line (reads carry fault bit 0),
                        drop (reads are not answered; TCP only); a fault lasts until a safe
                        command block (state bit 0) arrives; stop 20 driven blocks after the
                        last
    --reply-unit U      answer every request with unit id U (a wrong one)
    --reply-protocol P  answer every request with MBAP protocol id P (TCP)
  Prints one JSON object on exit: {"requests": [[t, function, address, count, unit,
  transaction, protocol], ...], "blocks": [[t, echo, set_point_raw, enable, heartbeat, state,
  causes, ticks], ...], "faults": [[t, kind], ...]}. RTU: LINK becomes a pty the client opens.
Run with Debian's /usr/bin/python3.
"""
import argparse
import asyncio
import json
import os
import signal
import sys
import time

from pymodbus.datastore import (ModbusSequentialDataBlock, ModbusServerContext,
                                ModbusSlaveContext)
from pymodbus.framer.rtu_framer import ModbusRtuFramer
from pymodbus.pdu import ExceptionResponse
from pymodbus.register_read_message import ReadHoldingRegistersResponse
from pymodbus.server import async_io

sys.dont_write_bytecode = True  # no __pycache__ beside the sources
from pymodbus_common import (COMMAND_BASE, COMMAND_COUNT, MAP_SIZE,  # noqa: E402
                             SENSOR_BASE, SENSOR_COUNT, pty_pair_relay)

FAULTS = 12                   # sensor block: bit 0 fault line, bit 1 driver fault, others 0
RESERVED_FAULT_BIT = 0x8000
SLAVE_DEVICE_FAILURE = 0x04
KINDS = ["exception", "bad_value", "fault_line", "drop"]

requests, blocks, faults = [], [], []
pending = {"kind": None, "served": False}  # the fault reads get until a safe block arrives
reads = {"seq": 0}
driven_since_fault = {"n": 0}


class SensorModule(ModbusSequentialDataBlock):
    """Holding registers 0..47; a read of the sensor block advances its seq (u32, high word
    first) and applies a pending value fault to that one reply."""

    def getValues(self, address, count=1):
        if address == SENSOR_BASE:
            reads["seq"] = (reads["seq"] + 1) & 0xFFFFFFFF
            super().setValues(SENSOR_BASE, [reads["seq"] >> 16, reads["seq"] & 0xFFFF])
            faults_reg = 0
            if pending["kind"] == "bad_value":
                faults_reg = RESERVED_FAULT_BIT
            elif pending["kind"] == "fault_line":
                faults_reg = 1
            if pending["kind"] in ("bad_value", "fault_line"):
                record_fault(pending["kind"])
            super().setValues(FAULTS, [faults_reg])
        return super().getValues(address, count)


def record_fault(kind):
    """A read carried the pending fault (the first one is the injection time)."""
    if not pending["served"]:
        faults.append([time.monotonic(), kind])
        pending["served"] = True


def log_execute(original):
    def execute(self, request, *addr):
        t = time.monotonic()
        fc = request.function_code
        address = getattr(request, "address", None)
        count = getattr(request, "count", None)
        requests.append([t, fc, address, count, request.unit_id,
                         getattr(request, "transaction_id", None),
                         getattr(request, "protocol_id", None)])
        if fc == 0x10 and address == COMMAND_BASE and len(request.values) == COMMAND_COUNT:
            r = request.values
            blocks.append([t, (r[0] << 16) | r[1], r[2], r[3], r[4], r[5], r[6],
                           (r[7] << 16) | r[8]])
            if r[3] == 1:
                driven_since_fault["n"] += 1
            if (r[5] & 1) and pending["served"]:  # the fault was seen: heal
                pending["kind"], pending["served"] = None, False
                driven_since_fault["n"] = 0
        return original(self, request, *addr)
    return execute


def manipulator(options):
    def manipulate(response):
        if isinstance(response, ReadHoldingRegistersResponse) and pending["kind"] in (
                "exception", "drop"):
            kind = pending["kind"]
            record_fault(kind)
            if kind == "exception":
                e = ExceptionResponse(0x03, SLAVE_DEVICE_FAILURE)
                e.transaction_id, e.unit_id = response.transaction_id, response.unit_id
                e.protocol_id = getattr(response, "protocol_id", 0)
                response = e
            else:
                response.should_respond = False
        if options.reply_unit is not None:
            response.unit_id = options.reply_unit
        if options.reply_protocol is not None:
            response.protocol_id = options.reply_protocol
        return response, False
    return manipulate


def finish():
    print(json.dumps({"requests": requests, "blocks": blocks, "faults": faults}), flush=True)
    os._exit(0)


async def campaign(options, tcp):
    kinds = KINDS if tcp else [k for k in KINDS if k != "drop"]
    injected = 0
    deadline = time.monotonic() + options.seconds
    while time.monotonic() < deadline:
        await asyncio.sleep(0.001)
        if options.faults == 0:
            continue
        if pending["kind"] is not None or driven_since_fault["n"] < 20:
            continue
        if injected == options.faults:
            break
        pending["kind"], pending["served"] = kinds[injected % len(kinds)], False
        injected += 1
    finish()


async def serve(options):
    async_io.ModbusBaseRequestHandler.execute = log_execute(
        async_io.ModbusBaseRequestHandler.execute)
    block = SensorModule(0, [0] * MAP_SIZE)
    block.setValues(COMMAND_BASE + 2, [0x8000, 0xFFFF])  # no set-point, enable not driven
    context = ModbusServerContext(slaves=ModbusSlaveContext(hr=block, zero_mode=True),
                                  single=True)
    kwargs = {"context": context, "response_manipulator": manipulator(options)}
    tcp = options.transport == "tcp"
    if tcp:
        asyncio.create_task(async_io.StartAsyncTcpServer(
            address=("127.0.0.1", int(options.where)), **kwargs))
    else:
        device, keep = pty_pair_relay(options.where)
        asyncio.create_task(async_io.StartAsyncSerialServer(
            framer=ModbusRtuFramer, port=device, baudrate=115200, **kwargs))
    asyncio.get_running_loop().add_signal_handler(signal.SIGTERM, finish)
    await campaign(options, tcp)


def main():
    p = argparse.ArgumentParser()
    p.add_argument("transport", choices=["tcp", "rtu"])
    p.add_argument("where")
    p.add_argument("--seconds", type=float, default=20.0)
    p.add_argument("--faults", type=int, default=0)
    p.add_argument("--reply-unit", type=int)
    p.add_argument("--reply-protocol", type=int)
    options = p.parse_args()
    # The RTU relay is a second Python thread: with the default 5 ms GIL switch interval it
    # could wait that long behind the server's thread, a delay of this peer, not the client's.
    sys.setswitchinterval(0.0001)
    asyncio.run(serve(options))
    return 0


if __name__ == "__main__":
    sys.exit(main())
