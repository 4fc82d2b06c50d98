"""Calibration of the perception error model against the camera path.

It sits above ``sitcov.perception`` and ``sitcov.av``: fitting the PEM on rendered frames
uses perception only, but choosing its noise and intercept on run verdicts drives the
reference stack through the embedded world in both modes, so this orchestration cannot
live inside perception without perception importing the stacks that import it.
"""
