#!/usr/bin/env python3
"""A pymodbus client for linterpd's interop tests: writes, reads back and checks registers.

    pymodbus_client.py (--tcp HOST:PORT | --serial PATH [--baud 19200]) [--unit 1]
                       [--roundtrip START:COUNT]... [--expect START:V,V,...]...
                       [--coil-roundtrip COIL]... [--expect-exception START:COUNT]...

--roundtrip writes COUNT holding registers from START (a fixed pattern, in chunks of at most
123) and reads them back (chunks of at most 125). --expect reads registers and compares them
with the values given (decimal or 0x hex). --coil-roundtrip switches a coil on, reads it, then
off and reads it again. --expect-exception reads COUNT registers from START and expects
Modbus exception 02 (illegal data address). Every read is printed as `read START..=END: v v v` (first few values).
Exit 0 when everything matched, 1 on a mismatch, 2 when a request failed (exception, timeout).
"""

import argparse
import logging
import sys

from pymodbus.client import ModbusSerialClient, ModbusTcpClient
from pymodbus.exceptions import ModbusException

MAX_READ = 125
MAX_WRITE = 123


class Failed(Exception):
    """A request that got no good answer."""


def parse_args():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    where = parser.add_mutually_exclusive_group(required=True)
    where.add_argument("--tcp", metavar="HOST:PORT")
    where.add_argument("--serial", metavar="PATH")
    parser.add_argument("--baud", type=int, default=19200)
    parser.add_argument("--unit", type=int, default=1)
    parser.add_argument("--timeout", type=float, default=2.0, help="seconds per request")
    parser.add_argument("--roundtrip", action="append", default=[], metavar="START:COUNT")
    parser.add_argument("--expect", action="append", default=[], metavar="START:V,V,...")
    parser.add_argument("--coil-roundtrip", action="append", default=[], type=int, metavar="COIL")
    parser.add_argument("--expect-exception", action="append", default=[], metavar="START:COUNT")
    return parser.parse_args()


def pattern(start, count):
    """Distinct, non-zero words that differ in both bytes from one address to the next."""
    return [((start + i) * 0x0101 ^ 0xA55A) & 0xFFFF for i in range(count)]


def checked(response, what):
    if response.isError():
        raise Failed(f"{what}: {response}")
    return response


def read_registers(client, unit, start, count):
    words = []
    for offset in range(0, count, MAX_READ):
        n = min(MAX_READ, count - offset)
        what = f"read {start + offset}..={start + offset + n - 1}"
        response = checked(
            client.read_holding_registers(start + offset, count=n, device_id=unit), what
        )
        words.extend(response.registers)
    shown = " ".join(str(w) for w in words[:8]) + (" ..." if len(words) > 8 else "")
    print(f"read {start}..={start + count - 1}: {shown}", flush=True)
    return words


def write_registers(client, unit, start, words):
    for offset in range(0, len(words), MAX_WRITE):
        chunk = words[offset : offset + MAX_WRITE]
        what = f"write {start + offset}..={start + offset + len(chunk) - 1}"
        checked(client.write_registers(start + offset, chunk, device_id=unit), what)
    print(f"wrote {start}..={start + len(words) - 1}", flush=True)


def compare(start, want, got):
    """Prints every difference; returns whether there was none."""
    if len(got) != len(want):
        print(f"mismatch: asked for {len(want)} registers from {start}, got {len(got)}")
        return False
    bad = [(start + i, w, g) for i, (w, g) in enumerate(zip(want, got)) if w != g]
    for address, w, g in bad[:10]:
        print(f"mismatch at register {address}: wrote/expected {w}, read {g}")
    if len(bad) > 10:
        print(f"... and {len(bad) - 10} more mismatches")
    return not bad


def parse_range(text):
    start, _, count = text.partition(":")
    return int(start, 0), int(count, 0)


def parse_expect(text):
    start, _, values = text.partition(":")
    return int(start, 0), [int(v, 0) for v in values.split(",")]


def run(client, args):
    ok = True
    for text in args.roundtrip:
        start, count = parse_range(text)
        words = pattern(start, count)
        write_registers(client, args.unit, start, words)
        ok &= compare(start, words, read_registers(client, args.unit, start, count))
    for text in args.expect:
        start, want = parse_expect(text)
        ok &= compare(start, want, read_registers(client, args.unit, start, len(want)))
    for coil in args.coil_roundtrip:
        for state in (True, False):
            checked(client.write_coil(coil, state, device_id=args.unit), f"write coil {coil}")
            bits = checked(client.read_coils(coil, count=1, device_id=args.unit), f"read coil {coil}").bits
            print(f"coil {coil}: wrote {int(state)}, read {int(bits[0])}", flush=True)
            if bits[0] != state:
                print(f"mismatch at coil {coil}")
                ok = False
    for text in args.expect_exception:
        start, count = parse_range(text)
        response = client.read_holding_registers(start, count=count, device_id=args.unit)
        code = getattr(response, "exception_code", None) if response.isError() else None
        print(f"read {start}..={start + count - 1}: exception {code}", flush=True)
        if code != 2:
            print(f"mismatch: expected exception 2 (illegal data address), got {response}")
            ok = False
    return ok


def main():
    args = parse_args()
    logging.basicConfig(level=logging.CRITICAL, stream=sys.stderr)
    logging.getLogger("pymodbus").setLevel(logging.CRITICAL)
    if args.tcp:
        host, _, port = args.tcp.rpartition(":")
        client = ModbusTcpClient(host, port=int(port), timeout=args.timeout, retries=0)
    else:
        client = ModbusSerialClient(
            args.serial, baudrate=args.baud, timeout=args.timeout, retries=0
        )
    if not client.connect():
        print(f"could not connect to {args.tcp or args.serial}", flush=True)
        return 2
    try:
        ok = run(client, args)
    except (Failed, ModbusException) as e:
        print(f"request failed: {e}", flush=True)
        return 2
    finally:
        client.close()
    print("all matched" if ok else "MISMATCH", flush=True)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
