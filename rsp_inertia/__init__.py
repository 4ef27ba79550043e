"""Command line and experiment pipeline of rsp-inertia (no physics here)."""
