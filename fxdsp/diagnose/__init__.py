"""`fxdsp diagnose`: explain where a measured log disagrees with the baseline model.

See shared/spec/measured-data.md for the contract (log format, causes, report). The entry points
are imported on first use, so that loading a command module through this package (e.g. for
`fxdsp diagnose --help`) does not pay for scipy and numba.
"""

from __future__ import annotations

import importlib

_EXPORTS = {"diagnose_file": "api", "diagnose_log": "api", "series_from_log": "api",
            "Log": "logio", "parse_mapping": "logio", "read_log": "logio"}

__all__ = list(_EXPORTS)


def __getattr__(name: str):
    if name in _EXPORTS:
        return getattr(importlib.import_module(f"fxdsp.diagnose.{_EXPORTS[name]}"), name)
    raise AttributeError(f"module 'fxdsp.diagnose' has no attribute {name!r}")
