"""``python -m robostar.sim``: run the virtual controller on TCP and/or a pseudo-terminal.

A minimal launcher over :func:`robostar.sim.listeners.serve`; the ``robostar sim`` command of the
command line offers the same. Each endpoint is printed on its own line once it is ready.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from robostar.errors import RobostarError
from robostar.sim.listeners import DEFAULT_LISTEN, serve


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m robostar.sim",
        description="Serve a virtual Robostar N1 controller.",
    )
    parser.add_argument(
        "--listen",
        default=DEFAULT_LISTEN,
        metavar="HOST:PORT",
        help=f"TCP address (default {DEFAULT_LISTEN}; port 0 picks a free one; 'none' for no TCP)",
    )
    parser.add_argument("--pty", action="store_true", help="also serve on a pseudo-terminal")
    parser.add_argument(
        "--count", type=int, default=1, metavar="N", help="controllers on consecutive ports"
    )
    parser.add_argument("--state", metavar="DIR", help="keep the controllers' state in DIR")
    parser.add_argument(
        "--fault",
        action="append",
        default=[],
        metavar="SPEC",
        help="inject faults, e.g. corrupt:0.01, drop:to_host:0.005, delay:0.5@3 (repeatable)",
    )
    parser.add_argument("--baud", type=int, metavar="BPS", help="pace bytes as a serial line")
    parser.add_argument(
        "--turnaround",
        type=float,
        default=0.0,
        metavar="SECONDS",
        help="delay before each answer leaves (implies --baud 115200 if --baud is not given)",
    )
    parser.add_argument("--config", metavar="FILE", help="controller configuration (TOML)")
    parser.add_argument(
        "--allow-remote", action="store_true", help="allow listening on a non-loopback address"
    )
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    listen = None if args.listen.strip().lower() in ("", "none") else args.listen
    try:
        from robostar.sim.config import SimConfig

        config = SimConfig.from_file(args.config) if args.config else SimConfig()
        serve(
            config,
            listen=listen,
            pty=args.pty,
            count=args.count,
            state_dir=args.state,
            faults=args.fault,
            baud=args.baud,
            turnaround=args.turnaround,
            allow_remote=args.allow_remote,
        )
    except RobostarError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
