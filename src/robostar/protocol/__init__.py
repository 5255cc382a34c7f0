"""The sans-IO core: framing, field codecs and the link state machine. No I/O, no clock."""
