"""Code the test suites share: plain modules, no tests (rig, procs, rawclient, goals, fuzz, docker)."""
