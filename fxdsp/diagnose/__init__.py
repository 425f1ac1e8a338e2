"""`fxdsp diagnose`: explain where a measured log disagrees with the baseline model.

See shared/spec/measured-data.md for the contract (log format, causes, report). The entry points
are imported on first use, so that loading a command module through this package (e.g. for
`fxdsp diagnose --help`) does not pay for scipy and numba.
"""

from __future__ import annotations

import importlib

_EXPORTS = {"diagnose_file": "fxdsp.diagnose.api", "diagnose_log": "fxdsp.diagnose.api",
            "series_from_log": "fxdsp.diagnose.api",
            # the contract's log reader lives below the simulator and the diagnosis, which both read logs
            "Log": "fxdsp.logfile", "parse_mapping": "fxdsp.logfile", "read_log": "fxdsp.logfile"}

__all__ = list(_EXPORTS)


def __getattr__(name: str):
    if name in _EXPORTS:
        return getattr(importlib.import_module(_EXPORTS[name]), name)
    raise AttributeError(f"module 'fxdsp.diagnose' has no attribute {name!r}")
