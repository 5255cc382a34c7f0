"""``python -m robostar.cli``: the same as the ``robostar`` command."""

from robostar.cli.app import main

main()
