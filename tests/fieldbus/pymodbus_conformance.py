#!/usr/bin/python3
"""Conformance of a Modbus server of the register map (docs/modbus_registers.md, "Server
conventions") against the Modbus Application Protocol V1.1b3, checked with Debian's pymodbus
3.0 client and, for what pymodbus cannot send, raw frames built here from the specifications
(MBAP header for TCP, CRC-16/MODBUS for RTU).

  pymodbus_conformance.py tcp HOST:PORT | rtu LINK
Prints one JSON list of checks [{"check": NAME, "want": ..., "got": ..., "ok": bool}] and
exits 0 (1 when the server cannot be reached). Run with Debian's /usr/bin/python3.
"""
import json
import socket
import struct
import sys
import time

import serial
from pymodbus.client import ModbusSerialClient, ModbusTcpClient
from pymodbus.framer.rtu_framer import ModbusRtuFramer

sys.dont_write_bytecode = True  # no __pycache__ beside the sources
from pymodbus_common import (COMMAND_BASE, COMMAND_COUNT, MAP_SIZE,  # noqa: E402
                             SENSOR_COUNT)

UNIT = 1
LOCKSTEP_COUNT = 16
SET_POINT, ENABLE, STATE = COMMAND_BASE + 2, COMMAND_BASE + 3, COMMAND_BASE + 5
ILLEGAL_FUNCTION, ILLEGAL_ADDRESS, ILLEGAL_VALUE, GATEWAY_NO_RESPONSE = 1, 2, 3, 0x0B
NO_REPLY = "no reply"

checks = []


def check(name, want, got):
    checks.append({"check": name, "want": want, "got": got, "ok": want == got})


def outcome(r):
    """A pymodbus result as 'ok', an exception code, or NO_REPLY."""
    if r is None or r.__class__.__name__ == "ModbusIOException":
        return NO_REPLY
    if r.isError():
        return getattr(r, "exception_code", "error")
    return "ok"


def crc16(data):
    crc = 0xFFFF
    for b in data:
        crc ^= b
        for _ in range(8):
            crc = (crc >> 1) ^ 0xA001 if crc & 1 else crc >> 1
    return struct.pack("<H", crc)


class Raw:
    """Raw request PDUs: MBAP over a TCP socket, or address + PDU + CRC on the serial line."""

    def __init__(self, mode, where):
        self.mode, self.tid = mode, 0
        if mode == "tcp":
            host, port = where.rsplit(":", 1)
            self.s = socket.create_connection((host, int(port)), timeout=2)
        else:
            self.s = serial.Serial(where, 115200, timeout=0.3)

    def ask(self, pdu, unit=UNIT, protocol=0, wait=0.5):
        """Sends a PDU; the reply PDU (bytes), or NO_REPLY."""
        self.tid = (self.tid + 1) & 0xFFFF
        if self.mode == "tcp":
            self.s.settimeout(wait)
            self.s.sendall(struct.pack(">HHHB", self.tid, protocol, len(pdu) + 1, unit) + pdu)
            try:
                while True:  # a late reply to an earlier request is skipped
                    tid, _, length, _ = struct.unpack(">HHHB", self._recv(7))
                    body = self._recv(length - 1)
                    if tid == self.tid:
                        return body
            except socket.timeout:
                return NO_REPLY
        frame = bytes([unit]) + pdu
        self.s.reset_input_buffer()
        self.s.write(frame + crc16(frame))
        deadline, data = time.monotonic() + wait, b""
        while time.monotonic() < deadline:
            data += self.s.read(256)
            if len(data) >= 5 and crc16(data[:-2]) == data[-2:]:
                return data[1:-2]
        return NO_REPLY if not data else b"garbled:" + data

    def _recv(self, n):
        data = b""
        while len(data) < n:
            chunk = self.s.recv(n - len(data))
            if not chunk:
                raise socket.timeout()
            data += chunk
        return data


def exception_of(reply, function):
    """The exception code of a raw reply to `function`, 'ok', or NO_REPLY."""
    if reply == NO_REPLY or isinstance(reply, str):
        return NO_REPLY
    if reply[0] == function | 0x80 and len(reply) == 2:
        return reply[1]
    return "ok" if reply[0] == function else "malformed"


def main():
    mode, where = sys.argv[1], sys.argv[2]
    if mode == "tcp":
        host, port = where.rsplit(":", 1)
        # timeout in whole seconds: pymodbus 3.0 truncates it to an int
        c = ModbusTcpClient(host, port=int(port), timeout=1, retries=0)
    else:
        c = ModbusSerialClient(port=where, framer=ModbusRtuFramer, baudrate=115200, timeout=1,
                               retries=0)
    if not c.connect():
        print(json.dumps([{"check": "connect", "ok": False}]), flush=True)
        return 1
    read = lambda a, n, unit=UNIT: c.read_holding_registers(a, n, slave=unit)

    # Every documented register is readable: the sensor block with the grant in one request,
    # each of the 48 registers alone; the sensor block's layout.
    first, second = read(0, LOCKSTEP_COUNT), read(0, SENSOR_COUNT)
    check("read 0..15 (sensor block and grant)", "ok", outcome(first))
    check("read 0..12 (sensor block)", "ok", outcome(second))
    if outcome(first) == "ok" and outcome(second) == "ok":
        check("faults register 12 (no fault asserted)", 0, first.registers[12])
        check("grant 13..15 without lockstep", [0, 0, 0], first.registers[13:16])
    check("read every register 0..47 alone", ["ok"] * MAP_SIZE,
          [outcome(read(a, 1)) for a in range(MAP_SIZE)])
    block = read(COMMAND_BASE, COMMAND_COUNT)
    check("read the command block 32..40", "ok", outcome(block))

    # The command block is written with 0x10, whole or in part.
    valid = [0, 7, 1500, 1, 42, 2, 0, 0, 9]  # echo 7, 1.5 V, enable, heartbeat 42, status
    check("write 32..40 with 0x10", "ok",
          outcome(c.write_registers(COMMAND_BASE, valid, slave=UNIT)))
    back = read(COMMAND_BASE, COMMAND_COUNT)
    check("read back 32..40", valid, back.registers if outcome(back) == "ok" else outcome(back))
    check("write the set-point 34 alone with 0x10", "ok",
          outcome(c.write_registers(SET_POINT, [1250], slave=UNIT)))
    back = read(SET_POINT, 1)
    check("read back 34", [1250], back.registers if outcome(back) == "ok" else outcome(back))

    # Functions the server does not implement: 0x01 ILLEGAL FUNCTION, nothing changed (the
    # grant registers 13..15 are read-only and stay 0 outside lockstep; the plant rewrites
    # 0..12 every step).
    check("0x01 read coils", ILLEGAL_FUNCTION, outcome(c.read_coils(0, 1, slave=UNIT)))
    check("0x02 read discrete inputs", ILLEGAL_FUNCTION,
          outcome(c.read_discrete_inputs(0, 1, slave=UNIT)))
    check("0x04 read input registers", ILLEGAL_FUNCTION,
          outcome(c.read_input_registers(0, 1, slave=UNIT)))
    check("0x05 write single coil", ILLEGAL_FUNCTION, outcome(c.write_coil(0, True, slave=UNIT)))
    check("0x0F write multiple coils", ILLEGAL_FUNCTION,
          outcome(c.write_coils(0, [True], slave=UNIT)))
    check("0x06 write single register on the command block", ILLEGAL_FUNCTION,
          outcome(c.write_register(ENABLE, 0, slave=UNIT)))
    check("0x06 write single register on the sensor block", ILLEGAL_FUNCTION,
          outcome(c.write_register(14, 0xFFFF, slave=UNIT)))
    raw = Raw(mode, where)
    # 0x16 and 0x17: pymodbus 3.0's RTU client reads no exception reply to them ("no response
    # received"), so over RTU these go as raw frames.
    if mode == "tcp":
        mask = lambda a, and_mask, or_mask: outcome(c.mask_write_register(a, and_mask, or_mask,
                                                                          slave=UNIT))
        readwrite = lambda: outcome(c.readwrite_registers(
            read_address=0, read_count=1, write_address=ENABLE, write_registers=[0], slave=UNIT))
    else:
        mask = lambda a, and_mask, or_mask: exception_of(
            raw.ask(struct.pack(">BHHH", 0x16, a, and_mask, or_mask)), 0x16)
        readwrite = lambda: exception_of(
            raw.ask(struct.pack(">BHHHHBH", 0x17, 0, 1, ENABLE, 1, 2, 0)), 0x17)
    check("0x16 mask write on the sensor block", ILLEGAL_FUNCTION, mask(13, 0x0000, 0x00FF))
    check("0x16 mask write on the command block", ILLEGAL_FUNCTION, mask(ENABLE, 0x0000, 0x0001))
    check("0x17 read/write multiple registers", ILLEGAL_FUNCTION, readwrite())
    check("0x41 (no such function)", ILLEGAL_FUNCTION, exception_of(raw.ask(b"\x41\x00\x00"), 0x41))
    check("0x2B (device identification, not implemented)", ILLEGAL_FUNCTION,
          exception_of(raw.ask(b"\x2b\x0e\x01\x00"), 0x2B))
    after = read(13, 3)
    check("read-only grant registers 13..15 unchanged by the refused writes", [0, 0, 0],
          after.registers if outcome(after) == "ok" else outcome(after))
    back = read(COMMAND_BASE, COMMAND_COUNT)
    check("command block unchanged by the refused writes", valid[:2] + [1250] + valid[3:],
          back.registers if outcome(back) == "ok" else outcome(back))

    # Addresses: beyond 47, or a write touching the read-only sensor block (0..31).
    check("read 48", ILLEGAL_ADDRESS, outcome(read(MAP_SIZE, 1)))
    check("read 40..48", ILLEGAL_ADDRESS, outcome(read(40, 9)))
    check("0x10 write to the sensor block 0..1", ILLEGAL_ADDRESS,
          outcome(c.write_registers(0, [0, 1], slave=UNIT)))
    check("0x10 write 30..33 (across into the sensor block)", ILLEGAL_ADDRESS,
          outcome(c.write_registers(30, [0, 0, 0, 0], slave=UNIT)))
    check("0x10 write 47..48", ILLEGAL_ADDRESS, outcome(c.write_registers(47, [0, 0], slave=UNIT)))

    # Values: a quantity outside the function's range, a byte count that does not match, a
    # command block with undefined codes (unchanged).
    check("read quantity 0", ILLEGAL_VALUE,
          exception_of(raw.ask(struct.pack(">BHH", 0x03, 0, 0)), 0x03))
    check("read quantity 126", ILLEGAL_VALUE,
          exception_of(raw.ask(struct.pack(">BHH", 0x03, 0, 126)), 0x03))
    check("0x10 quantity 0", ILLEGAL_VALUE,
          exception_of(raw.ask(struct.pack(">BHHB", 0x10, ENABLE, 0, 0)), 0x10))
    check("0x10 byte count not 2 x quantity", ILLEGAL_VALUE,
          exception_of(raw.ask(struct.pack(">BHHBH", 0x10, ENABLE, 1, 4, 0)), 0x10))
    check("enable = 5 (undefined code)", ILLEGAL_VALUE,
          outcome(c.write_registers(ENABLE, [5], slave=UNIT)))
    check("state with bit 2 (undefined)", ILLEGAL_VALUE,
          outcome(c.write_registers(STATE, [4], slave=UNIT)))
    back = read(COMMAND_BASE, COMMAND_COUNT)
    check("command block unchanged by the undefined codes", valid[:2] + [1250] + valid[3:],
          back.registers if outcome(back) == "ok" else outcome(back))

    # Unit ids: TCP answers its unit (1) and the Modbus TCP "direct" ids 0 and 0xFF; another
    # unit gets 0x0B; a frame with an MBAP protocol id other than 0 is not Modbus (dropped).
    # RTU answers only unit 1; unit 0 is a broadcast: a write is carried out, never answered.
    if mode == "tcp":
        check("unit 2 (another unit)", GATEWAY_NO_RESPONSE, outcome(read(0, 1, unit=2)))
        check("unit 247", GATEWAY_NO_RESPONSE, outcome(read(0, 1, unit=247)))
        check("unit 255 (Modbus TCP: the device addressed by IP)", "ok",
              outcome(read(0, 1, unit=255)))
        check("unit 0 (Modbus TCP: the device addressed by IP)", "ok", outcome(read(0, 1, unit=0)))
        check("MBAP protocol id 7", NO_REPLY,
              exception_of(raw.ask(struct.pack(">BHH", 0x03, 0, 1), protocol=7), 0x03))
    else:
        check("unit 2 (another unit)", NO_REPLY, outcome(read(0, 1, unit=2)))
        check("unit 247", NO_REPLY, outcome(read(0, 1, unit=247)))
        check("unit 0 read (broadcast)", NO_REPLY,
              exception_of(raw.ask(struct.pack(">BHH", 0x03, 0, 1), unit=0), 0x03))
        check("unit 0 write (broadcast: carried out, no reply)", NO_REPLY,
              exception_of(raw.ask(struct.pack(">BHHBH", 0x10, SET_POINT, 1, 2, 999), unit=0),
                           0x10))
        back = read(SET_POINT, 1)
        check("the broadcast write was carried out", [999],
              back.registers if outcome(back) == "ok" else outcome(back))
    check("still answering unit 1", "ok", outcome(read(0, SENSOR_COUNT)))
    c.close()
    print(json.dumps(checks), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
