"""Machine instructions per read of the frame decoder and the frame tracker, by kind of read.

``python -m bench.frame_cost`` prints, for each kind of read (the usual ones first: a request
arriving whole, an ACK, an ACK and a frame; then a frame split in three reads, a frame byte by
byte, noise, an overlong frame), the instructions ``FrameDecoder.feed`` and ``FrameTracker.feed``
take per read, counted by valgrind's callgrind as ``bench.profiles instructions`` counts them
(two runs of different lengths, the difference divided by the extra reads, so start-up cancels
out). A count, not a time: an A/B of a change to the framing needs no quiet machine. Skipped
where valgrind is missing.
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

if __package__ in (None, ""):
    _root = Path(__file__).resolve().parent.parent
    sys.path[:0] = [str(_root), str(_root / "src")]

from bench.profiles import callgrind_count

__all__ = ["main"]

KINDS = (
    "request whole",
    "ACK",
    "ACK + answer",
    "answer in 3 reads",
    "answer byte by byte",
    "noise",
    "overlong frame",
)

_LOOP = """
import itertools
import sys
from robostar.protocol.frame import ACK, STX, ETX, FrameDecoder, FrameTracker, encode_packet
kind, who, reads = sys.argv[1], sys.argv[2], int(sys.argv[3])
request = encode_packet(b"\\xffAC01")
answer = encode_packet(b"0" + b"  -123.450" * 6)
pieces = {
    "request whole": [request],
    "ACK": [bytes((ACK,))],
    "ACK + answer": [bytes((ACK,)) + answer],
    "answer in 3 reads": [answer[:20], answer[20:45], answer[45:]],
    "answer byte by byte": [answer[i : i + 1] for i in range(len(answer))],
    "noise": [b"\\x00\\x11\\x22\\x33\\x44\\x55\\x66\\x77"],
    "overlong frame": [bytes((STX,)) + b"A" * 300 + bytes((ETX, 0x41))],
}[kind]
taker = FrameDecoder() if who == "decoder" else FrameTracker()
feed = taker.feed
for piece in itertools.islice(itertools.cycle(pieces), reads):
    feed(piece)
"""


def _count(kind: str, who: str, reads: int) -> int:
    return callgrind_count(_LOOP, kind, who, str(reads))


def per_read(kind: str, who: str) -> float:
    """Instructions ``who`` (decoder or tracker) takes per read of ``kind``."""
    short, long = 1_000, 6_000
    return (_count(kind, who, long) - _count(kind, who, short)) / (long - short)


def main(argv: list[str] | None = None) -> int:
    kinds = (argv if argv is not None else sys.argv[1:]) or list(KINDS)
    for kind in kinds:
        if kind not in KINDS:
            raise SystemExit(f"frame_cost: {kind!r} is not one of {', '.join(KINDS)}")
    if shutil.which("valgrind") is None:
        print("valgrind not found: skipped")
        return 0
    print(f"{'read':22} {'decoder':>9} {'tracker':>9}  (instructions per read, callgrind)")
    for kind in kinds:
        decoder = per_read(kind, "decoder")
        tracker = per_read(kind, "tracker")
        print(f"{kind:22} {decoder:9,.0f} {tracker:9,.0f}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
