#!/usr/bin/python3
"""The virtual board's result (mrd-hil run --json in the guest) against the scenario's
criteria and against the same scenario's lockstep run on the build machine.

Board: passed; lockstep on CAN; 0 invariant violations, command timeouts, missed grants;
firmware exit 0; the plant drove the encoder on the gpio-sim chip (port "gpio-sim") and the
firmware counted every edge (rx_ok == edges written, none rejected); the fault line put it into
the safe state within 2 periods of detection and it recovered.

Agreement (side by side on stdout): equal step, command and fault-period counts within
kPeriods; tracking errors within kTracking (absolute). Why not zero: the two runs execute the
same code on the same inputs in lockstep, but on two architectures (aarch64 vs x86-64
glibc libm: exp/tanh/sin may differ in the last ulp, and the plant integrates 20 RK4
substeps per period over 2000 periods) and through two GPIO paths (the kernel stamps gpio-sim
edges in its interrupt handler; the simulated chip stamps them itself): an edge applied one
period later shifts the differentiated velocity for a period.

Usage: check_result.py BOARD.json NATIVE.json   (exit 0 ok, 1 a check failed, 2 bad input)
"""
import json
import sys

kTracking = 0.01  # |error_reachable|, |error_all| difference, fractions of ||d||
kPeriods = 1      # fault detection / safe / recovery periods


def load(path):
    try:
        with open(path, encoding="utf-8") as f:
            return json.load(f)
    except (OSError, ValueError) as e:
        print(f"error: {path}:1: cannot read a JSON summary ({e})", file=sys.stderr)
        sys.exit(2)


def main():
    if len(sys.argv) != 3:
        print("usage: check_result.py BOARD.json NATIVE.json", file=sys.stderr)
        sys.exit(2)
    board, native = load(sys.argv[1]), load(sys.argv[2])
    failures = []

    def check(cond, what):
        if not cond:
            failures.append(what)

    for name, r in (("board", board), ("native", native)):
        check(r.get("pass") is True, f"{name}: scenario failed: {r.get('failures')}")
        check(r.get("clock") == "lockstep" and r.get("transport") == "can", f"{name}: not lockstep CAN")
        check(r.get("invariant_violations") == 0, f"{name}: invariant violations")
        check(r.get("command_timeouts") == 0, f"{name}: command timeouts")
        fw = r.get("firmware", {})
        check(fw.get("exit") == 0, f"{name}: firmware exit {fw.get('exit')}")
        check(fw.get("summary", {}).get("clock", {}).get("missed_grants") == 0, f"{name}: missed grants")
        faults = r.get("faults", [])
        check(len(faults) == 1 and faults[0].get("kind") == "fault_line" and faults[0].get("ok"),
              f"{name}: fault_line not handled: {faults}")
    ports = board.get("ports", {})
    edges = ports.get("gpio-sim", {}).get("published", 0)
    check(edges > 3000, f"board: {edges} encoder edges written on gpio-sim (expected > 3000)")
    fw_gpio = board.get("firmware", {}).get("summary", {}).get("devices", {}).get("gpio", {})
    check(fw_gpio.get("rx_ok") == edges and fw_gpio.get("rx_rejected") == 0,
          f"board: firmware counted {fw_gpio.get('rx_ok')} edges of {edges}, "
          f"rejected {fw_gpio.get('rx_rejected')}")
    check(ports.get("can", {}).get("rejected", 1) == 0, "board: harness rejected CAN frames")

    rows = []

    def row(label, b, n, tol):
        ok = b is not None and n is not None and abs(b - n) <= tol
        rows.append((label, b, n, tol, ok))
        check(ok, f"{label}: board {b} vs build machine {n} (tolerance {tol})")

    row("steps", board.get("steps"), native.get("steps"), 0)
    row("commands", board.get("commands"), native.get("commands"), 0)
    row("safe commands", board.get("safe_commands"), native.get("safe_commands"), 2 * kPeriods)
    row("driven steps", board.get("driven_steps"), native.get("driven_steps"), 2 * kPeriods)
    bt, nt = board.get("tracking", {}), native.get("tracking", {})
    row("tracking error (reachable)", bt.get("error_reachable"), nt.get("error_reachable"), kTracking)
    row("tracking error (all)", bt.get("error_all"), nt.get("error_all"), kTracking)
    row("passive-off error (reachable)", bt.get("passive_off", {}).get("error_reachable"),
        nt.get("passive_off", {}).get("error_reachable"), kTracking)
    bf = (board.get("faults") or [{}])[0]
    nf = (native.get("faults") or [{}])[0]
    for key in ("periods_to_detection", "periods_to_safe_state", "periods_to_recovery"):
        row(f"fault_line {key}", bf.get(key), nf.get(key), kPeriods)
    print(f"{'':32} {'board':>14} {'build machine':>14} {'tolerance':>10}")
    for label, b, n, tol, ok in rows:
        fmt = (lambda v: f"{v:14.5f}") if isinstance(b, float) else (lambda v: f"{v!s:>14}")
        print(f"{label:32} {fmt(b)} {fmt(n)} {tol!s:>10} {'' if ok else '  <-- differs'}")
    for f in failures:
        print(f"check_result: {f}", file=sys.stderr)
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
