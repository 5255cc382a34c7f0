"""The MQTT topic tree: ``<prefix>/<line>/<model key>`` and the face's own topics.

The model's keys already form a tree (``ch1/status``, ``ch1/position``, ``io/in/0``, ``alarms``,
``info``, ``online``), so a value's topic is its key under the line. Commands come in under
``<prefix>/<line>/cmd/<name>`` and their results go to the request's response topic, or to
``<prefix>/<line>/cmd/<name>/result``.
"""

from __future__ import annotations

from dataclasses import dataclass

from robostar.errors import UsageError

__all__ = ["SERVER", "Topics", "check_prefix", "response_topic_problem"]

SERVER = "_server"
"""The tree of the server itself (its online state, the buffer's figures)."""


def check_prefix(prefix: str) -> str:
    text = prefix.strip().strip("/")
    if not text or any(c in text for c in "+#\x00"):
        raise UsageError(f"mqtt.prefix: {prefix!r} is not a topic prefix (no +, # or NUL)")
    return text


MAX_TOPIC_BYTES = 65_535
"""MQTT's limit on a topic name (UTF-8)."""


def response_topic_problem(topic: str, prefix: str | None = None) -> str | None:
    """Why ``topic`` (a request's MQTT 5 response topic) cannot take the reply, or None. The
    broker would drop a reply to a ``$`` topic, and a publish cannot go to a filter. With
    ``prefix``, the face's own tree is refused too: the face would publish the reply there
    itself, over a value, or on a command topic it takes (its answer run as a command, under
    its own name, on any line)."""
    if not topic:
        return "empty"
    if prefix is not None and (topic == prefix or topic.startswith(f"{prefix}/")):
        return f"is in the face's own tree ({prefix}/)"
    if "+" in topic or "#" in topic:
        return "has a wildcard (+ or #)"
    if "\x00" in topic:
        return "has a NUL"
    if topic.startswith("$"):
        return "starts with $ (the broker's own topics)"
    try:
        size = len(topic.encode("utf-8"))
    except UnicodeEncodeError:
        return "is not UTF-8"
    if size > MAX_TOPIC_BYTES:
        return f"is longer than {MAX_TOPIC_BYTES:,} bytes"
    return None


@dataclass(frozen=True)
class Topics:
    prefix: str

    def value(self, line: str, key: str) -> str:
        return f"{self.prefix}/{line}/{key}"

    def online(self, line: str) -> str:
        return f"{self.prefix}/{line}/online"

    def server(self, key: str) -> str:
        return f"{self.prefix}/{SERVER}/{key}"

    def commands(self, line: str) -> str:
        """The subscription filter for a line's commands."""
        return f"{self.prefix}/{line}/cmd/+"

    def command(self, line: str, name: str) -> str:
        """One command's topic (the stops' own subscriptions)."""
        return f"{self.prefix}/{line}/cmd/{name}"

    def command_name(self, topic: str, line: str) -> str | None:
        head = f"{self.prefix}/{line}/cmd/"
        if not topic.startswith(head):
            return None
        name = topic[len(head) :]
        return name if name and "/" not in name else None

    def result(self, line: str, name: str) -> str:
        return f"{self.prefix}/{line}/cmd/{name}/result"
