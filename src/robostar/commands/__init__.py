"""Every command of the N1 host protocol as a typed request/answer pair, found by its two letters.

``COMMANDS["AA"]`` gives the class(es) for a code; ``decode_request`` decodes a request packet on
the controller side. Groups follow the manual: status (A), motion (B), job and control (C, D, E),
files (F), I/O (GA-GD), global variables (GR, GW), system (K).
"""

from robostar.commands.base import AnswerPacket, Command, Shape, make_answer, split_answer
from robostar.commands.registry import COMMANDS, all_commands, command_classes, decode_request

__all__ = [
    "COMMANDS",
    "AnswerPacket",
    "Command",
    "Shape",
    "all_commands",
    "command_classes",
    "decode_request",
    "make_answer",
    "split_answer",
]
