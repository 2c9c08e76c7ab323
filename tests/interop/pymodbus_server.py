#!/usr/bin/env python3
"""A memory-backed pymodbus server for linterpd's interop tests.

    pymodbus_server.py --tcp 127.0.0.1:0 [--unit 1] [--registers N] [--coils N]
    pymodbus_server.py --serial /path/to/pty [--baud 19200] [--unit 1] ...
                       [--preset START:V,V,...]...

Holding registers 0..N-1 and coils 0..M-1 start at 0 / off (--preset sets registers first); any address past them answers
Modbus exception 02 (illegal data address). Once it is ready it prints exactly one line,
`listening on ADDR` (the bound host:port, or the serial path), and serves until SIGTERM or
SIGINT, then exits 0.
"""

import argparse
import asyncio
import logging
import signal
import sys

from pymodbus.server import ModbusSerialServer, ModbusTcpServer
from pymodbus.simulator import DataType, SimData, SimDevice


def parse_args():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    where = parser.add_mutually_exclusive_group(required=True)
    where.add_argument("--tcp", metavar="HOST:PORT", help="listen for Modbus TCP")
    where.add_argument("--serial", metavar="PATH", help="serve Modbus RTU on a serial device")
    parser.add_argument("--baud", type=int, default=19200)
    parser.add_argument("--unit", type=int, default=1, help="unit id (slave address)")
    parser.add_argument("--registers", type=int, default=10000, help="holding registers")
    parser.add_argument("--coils", type=int, default=4096, help="coils")
    parser.add_argument(
        "--preset", action="append", default=[], metavar="START:V,V,...",
        help="initial register values (decimal or 0x hex)",
    )
    return parser.parse_args()


def device(unit, registers, coils, presets):
    """One device with separate coil and register blocks, zero but for the presets."""
    memory = [0] * registers
    for text in presets:
        start, _, values = text.partition(":")
        for i, value in enumerate(values.split(",")):
            memory[int(start, 0) + i] = int(value, 0)
    blocks = (
        [SimData(0, count=coils, values=False, datatype=DataType.BITS)],
        [SimData(0, count=16, values=False, datatype=DataType.BITS)],
        [SimData(0, values=memory, datatype=DataType.REGISTERS)],
        [SimData(0, count=16, values=0, datatype=DataType.REGISTERS)],
    )
    return SimDevice(id=unit, simdata=blocks)


async def serve(args):
    dev = device(args.unit, args.registers, args.coils, args.preset)
    if args.tcp:
        host, _, port = args.tcp.rpartition(":")
        server = ModbusTcpServer(dev, address=(host, int(port)))
    else:
        server = ModbusSerialServer(dev, port=args.serial, baudrate=args.baud)
    await server.serve_forever(background=True)
    if args.tcp:
        bound = server.transport.sockets[0].getsockname()
        print(f"listening on {bound[0]}:{bound[1]}", flush=True)
    else:
        print(f"listening on {args.serial}", flush=True)

    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGTERM, signal.SIGINT):
        loop.add_signal_handler(sig, stop.set)
    await stop.wait()
    await server.shutdown()


def main():
    args = parse_args()
    # pymodbus warns on stderr about its own deprecations; only errors matter here.
    logging.basicConfig(level=logging.ERROR, stream=sys.stderr)
    logging.getLogger("pymodbus").setLevel(logging.ERROR)
    asyncio.run(serve(args))
    return 0


if __name__ == "__main__":
    sys.exit(main())
