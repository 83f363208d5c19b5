"""Running a stack: the service launcher (processes), the in-process stack and the router."""
