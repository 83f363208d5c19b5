"""`zenav bench`: accuracy, latency, cost and speed of the stack, and the offline studies."""
