"""OpenSCENARIO out: scenarios that play in a real engine, and playing them in esmini."""

from sitcov.sim.xosc._esmini import ENV, esmini_tool, find_esmini, schema_dir

__all__ = ["ENV", "esmini_tool", "find_esmini", "schema_dir"]
