"""Shared by every test folder: this folder on ``sys.path`` (as pytest's default import mode does for a
conftest.py outside a package, made explicit), so that its helper modules import by name, e.g.
``from work_time import work_seconds`` (tests/work_time.py).
"""

from __future__ import annotations

import sys
from pathlib import Path

if str(Path(__file__).parent) not in sys.path:
    sys.path.insert(0, str(Path(__file__).parent))
