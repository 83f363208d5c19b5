"""The zenav command line."""
