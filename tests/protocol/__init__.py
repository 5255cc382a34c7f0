"""Tests of robostar.protocol: framing, field codecs and the link machine."""
