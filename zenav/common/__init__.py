"""Shared pieces of every zenav service: messages, codec, keys, clock, config, runtime."""
