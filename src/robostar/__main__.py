"""``python -m robostar``: the same as the ``robostar`` command."""

from robostar.cli.app import main

main()
