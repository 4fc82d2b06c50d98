"""Campaign tests: put this folder first on the path so ``campaign_fakes:FakeBackend`` resolves.

Helpers shared by the test modules live in ``campaign_helpers.py``.
"""

from __future__ import annotations

import sys
from pathlib import Path

HERE = str(Path(__file__).resolve().parent)
if HERE in sys.path:
    sys.path.remove(HERE)
sys.path.insert(0, HERE)
