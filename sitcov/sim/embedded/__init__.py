"""sim/embedded."""
