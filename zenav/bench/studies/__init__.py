"""Offline studies: one algorithm at a time on the world model, without the bus."""
