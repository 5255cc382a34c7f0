"""The simulator with one library change tried out, to show what a proposed fix would buy.

``python -m bench.sim_variant select ARGS...`` runs ``python -m robostar.sim ARGS...`` with
its serving loop waiting in ``select()`` (microsecond timeouts) instead of the default epoll
(whose timeouts are rounded up to whole milliseconds). The library is not changed: the
selector class is swapped in this process only. Results from it are labelled as such and
never stand in for the library's own figures.
"""

from __future__ import annotations

import selectors
import sys

from robostar.sim.__main__ import main

__all__ = ["VARIANTS"]

VARIANTS = ("select",)


def _use_select() -> None:
    # The server module looks the class up in ``selectors`` when each serving loop is made.
    selectors.DefaultSelector = selectors.SelectSelector  # type: ignore[misc,assignment]


if __name__ == "__main__":
    variant, *rest = sys.argv[1:]
    if variant not in VARIANTS:
        raise SystemExit(f"variant: {variant!r} is not one of {', '.join(VARIANTS)}")
    _use_select()
    sys.exit(main(rest))
