"""Tools around a running stack: recording, replay, live view, plots, benchmarks."""
