"""Coverage-guided fuzzing (atheris) of the frame decoder and every command's answer decoder.

Run: ``python reliability/atheris_fuzz.py -atheris_runs=1000000`` (libFuzzer flags pass
through; ``-max_total_time=600`` bounds the time instead). The first input byte picks the
target: the frame decoder (bytes and their splits), frame resync, an answer decoder (sample
chosen by the next byte, packets split at 0x00 bytes) or the request decoder. A target's
:class:`~reliability.targets.Violation` is reported by atheris as a crash, with the input saved.
Hits of known (recorded) bugs are counted and printed at exit instead of stopping the run.
``reliability/run.py fuzz --engine atheris`` runs this script and records its figures.
"""

from __future__ import annotations

import atexit
import json
import sys
from collections import Counter
from pathlib import Path

import atheris

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

with atheris.instrument_imports():
    from reliability.samples import SAMPLES
    from reliability.targets import (
        KnownIssue,
        check_answer,
        check_frames,
        check_request,
        check_resync,
    )
    from robostar.protocol.frame import encode_packet

_FRAMES = tuple(sorted({encode_packet(a) for s in SAMPLES for a in s.answer}))


KNOWN: Counter[str] = Counter()


def test_one_input(data: bytes) -> None:
    try:
        _run(data)
    except KnownIssue as exc:
        # A recorded bug: count it and go on, so that the run reaches its inputs and can
        # still find a new one.
        KNOWN[exc.key] += 1


def _report_known() -> None:
    print(f"known issue hits: {json.dumps(dict(KNOWN))}", file=sys.stderr, flush=True)


def _run(data: bytes) -> None:
    fdp = atheris.FuzzedDataProvider(data)
    target = fdp.ConsumeIntInRange(0, 3)
    if target == 0:
        cuts = [fdp.ConsumeIntInRange(0, 300) for _ in range(fdp.ConsumeIntInRange(0, 6))]
        check_frames(fdp.ConsumeBytes(fdp.remaining_bytes()), cuts)
    elif target == 1:
        first = _FRAMES[fdp.ConsumeIntInRange(0, len(_FRAMES) - 1)]
        second = _FRAMES[fdp.ConsumeIntInRange(0, len(_FRAMES) - 1)]
        check_resync(fdp.ConsumeBytes(fdp.remaining_bytes()), first, second)
    elif target == 2:
        sample = SAMPLES[fdp.ConsumeIntInRange(0, len(SAMPLES) - 1)]
        packets = fdp.ConsumeBytes(fdp.remaining_bytes()).split(b"\x00")
        check_answer(sample.command, packets)
    else:
        check_request(fdp.ConsumeBytes(fdp.remaining_bytes()))


def main() -> None:
    atheris.Setup(sys.argv, test_one_input)
    atexit.register(_report_known)
    atheris.Fuzz()


if __name__ == "__main__":
    main()
